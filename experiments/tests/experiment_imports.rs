//! Experiments share their pieces through the helper modules
//! (`cloud_figures`, `sphere_wall_series`, …), never through each other:
//! no experiment file names another experiment's module, so each can be
//! read, changed or removed alone.

use std::path::Path;

/// Whether the file stem names a numbered experiment: `e06_1_…`, `ep_1_…`,
/// `ev_1_…`, `s1_…`.
fn is_experiment(stem: &str) -> bool {
    let mut parts = stem.splitn(3, '_');
    let (Some(a), Some(b)) = (parts.next(), parts.next()) else {
        return false;
    };
    let numbered = |s: &str| !s.is_empty() && s.chars().all(|c| c.is_ascii_digit());
    (a.starts_with('e')
        && a.len() > 1
        && a[1..].chars().all(|c| c.is_ascii_alphanumeric())
        && numbered(b))
        || (a.starts_with('s') && numbered(&a[1..]))
}

#[test]
fn no_experiment_imports_another() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut stems: Vec<String> = std::fs::read_dir(dir)
        .expect("experiments folder")
        .filter_map(|e| {
            let path = e.expect("entry").path();
            let stem = path.file_stem()?.to_str()?.to_string();
            (path.extension()? == "rs" && is_experiment(&stem)).then_some(stem)
        })
        .collect();
    stems.sort();
    assert!(
        stems.iter().any(|s| s == "e06_1_hot_cold_gridded")
            && stems.iter().any(|s| s == "s1_symmetry"),
        "the scan found the experiments: {stems:?}"
    );
    let mut found = vec![];
    for stem in &stems {
        let text = std::fs::read_to_string(dir.join(format!("{stem}.rs"))).expect("read");
        for other in stems.iter().filter(|o| *o != stem) {
            for path in [format!("crate::{other}"), format!("super::{other}")] {
                if text.contains(&path) {
                    found.push(format!("{stem}.rs names {path}"));
                }
            }
        }
    }
    assert!(
        found.is_empty(),
        "experiments import each other:\n{}",
        found.join("\n")
    );
}
