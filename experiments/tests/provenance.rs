//! The committed results name the code that made them: every
//! `results/**/manifest.json` records one commit, and a clean one
//! (`experiment all` refuses to write `results/` from a dirty build); and
//! what only the default-size runs can show is checked on them.

mod common;
use common::{num, table};

use std::path::{Path, PathBuf};

fn manifests(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            manifests(&path, out);
        } else if path.file_name().is_some_and(|n| n == "manifest.json") {
            out.push(path);
        }
    }
}

#[test]
fn committed_results_come_from_one_clean_commit() {
    let results = Path::new(env!("CARGO_MANIFEST_DIR")).join("../results");
    let mut found = vec![];
    manifests(&results, &mut found);
    assert!(found.len() >= 20, "only {} manifests", found.len());
    let mut commits: Vec<(String, PathBuf)> = found
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).unwrap();
            let json: serde_json::Value = serde_json::from_str(&text).unwrap();
            let commit = json["commit"].as_str().unwrap_or("none").to_string();
            (commit, p)
        })
        .collect();
    for (c, p) in &commits {
        assert!(
            c.len() == 40 && c.chars().all(|ch| ch.is_ascii_hexdigit()),
            "{} was written by {c}: not a clean commit",
            p.display()
        );
    }
    commits.sort();
    let (first, last) = (&commits[0], &commits[commits.len() - 1]);
    assert_eq!(
        first.0,
        last.0,
        "results come from several commits, e.g. {} ({}) and {} ({}): regenerate with `smokelab experiment all`",
        first.1.display(),
        first.0,
        last.1.display(),
        last.0
    );
}

/// The committed 07-10 (32³, `experiment all`): resident memory and the
/// heap's high-water mark grow by one staggered 32³ velocity (0.375 MiB)
/// per gridless frame, linearly, with either march (measured 0.375–0.376
/// MiB, r² ≥ 0.9997 for the RSS and ≥ 0.99998 for the heap).
#[test]
fn committed_07_10_rss_grows_one_velocity_grid_per_frame() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../results/07-10/summary.csv");
    let rows = table(&path);
    for name in ["march=cell", "march=cell/10"] {
        for quantity in ["rss_mib", "heap_mib"] {
            let row = rows
                .iter()
                .find(|r| r["series"] == name && r["quantity"] == quantity)
                .unwrap_or_else(|| panic!("{}: no {name} {quantity} row", path.display()));
            let (slope, r2) = (num(row, "slope"), num(row, "r2"));
            assert!(
                (slope / 0.375 - 1.0).abs() < 0.05 && r2 > 0.999 && row["trend"] == "linear",
                "{name}: {quantity} {slope} MiB per frame, r² {r2}, {}",
                row["trend"]
            );
        }
    }
}
