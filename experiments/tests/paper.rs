//! `paper/paper.md`: every link resolves to a file under `results/`, and its
//! figures table names every registered experiment.

use std::path::{Path, PathBuf};

fn paper() -> (PathBuf, String) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../paper");
    let text = std::fs::read_to_string(dir.join("paper.md")).expect("paper/paper.md");
    (dir, text)
}

/// Targets of Markdown links and images, `](target)`.
fn links(text: &str) -> Vec<&str> {
    text.match_indices("](")
        .filter_map(|(i, _)| {
            let rest = &text[i + 2..];
            rest.find(')').map(|end| &rest[..end])
        })
        .collect()
}

#[test]
fn every_link_resolves_under_results() {
    let (dir, text) = paper();
    let root = dir
        .parent()
        .unwrap()
        .join("results")
        .canonicalize()
        .unwrap();
    let targets = links(&text);
    assert!(targets.len() >= 10, "too few links: {targets:?}");
    for t in targets {
        if t.starts_with('#') {
            continue;
        }
        let path = dir.join(t);
        let resolved = path
            .canonicalize()
            .unwrap_or_else(|e| panic!("paper links {t}, which does not exist ({e})"));
        assert!(
            resolved.starts_with(&root),
            "paper links {t}, outside results/"
        );
    }
}

#[test]
fn figures_table_names_every_experiment() {
    let (_, text) = paper();
    let table = &text[text.find("## Figures table").expect("a figures table")..];
    for id in smokelab_app::registry::ids() {
        assert!(
            table.contains(&format!("`smokelab experiment {id}`")),
            "the figures table has no row for experiment {id}"
        );
    }
}
