//! `paper/paper.md`: every link resolves to a file under `results/`, its
//! figures table names every registered experiment, and it is the paper
//! `smokelab paper` makes from the committed results.

mod common;

use std::path::{Path, PathBuf};

use common::{assert_ok, smokelab};

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
    for id in smokelab_app::experiment::registry::ids() {
        assert!(
            table.contains(&format!("`smokelab experiment {id}`")),
            "the figures table has no row for experiment {id}"
        );
    }
}

/// `smokelab paper` finds the repository from any folder inside it (it used
/// to work only from the repository root, and to fail whenever pandoc was
/// installed because pandoc was given a path relative to the wrong folder).
#[test]
fn paper_builds_from_a_subfolder() {
    let dir = tempfile::tempdir().unwrap();
    let root = dir.path();
    std::fs::create_dir_all(root.join("paper/sub")).unwrap();
    std::fs::create_dir_all(root.join("results/convergence")).unwrap();
    std::fs::write(
        root.join("paper/paper.md"),
        "# t\n<!-- orders:begin -->\nold\n<!-- orders:end -->\n",
    )
    .unwrap();
    std::fs::write(root.join("results/convergence/orders.md"), "| new |\n").unwrap();
    assert_ok(&smokelab(&["paper"], &root.join("paper/sub")), &["paper"]);
    let md = std::fs::read_to_string(root.join("paper/paper.md")).unwrap();
    assert!(md.contains("| new |") && !md.contains("old"), "{md}");
}

/// The committed paper is the one `smokelab paper` makes from the committed
/// results: its claims, orders and performance blocks and its figure
/// captions. Regenerating results without `smokelab paper` fails here.
#[test]
fn committed_paper_matches_the_committed_results() {
    let (dir, text) = paper();
    let root = dir.parent().unwrap();
    let regenerated = smokelab_app::publish::paper::refreshed(root).unwrap();
    if let Some(line) = text
        .lines()
        .zip(regenerated.lines())
        .position(|(a, b)| a != b)
    {
        panic!(
            "paper/paper.md is stale at line {}: run `smokelab paper --overwrite` and commit it\n\
             committed:   {}\nregenerated: {}",
            line + 1,
            text.lines().nth(line).unwrap(),
            regenerated.lines().nth(line).unwrap()
        );
    }
    assert_eq!(
        text, regenerated,
        "paper/paper.md is stale at its end: run `smokelab paper --overwrite`"
    );
}
