//! `smokelab export vdb|paraview RUN_DIR`: a finished run's saved frames as
//! the files `run --vdb/--paraview` writes.

mod common;

use std::path::Path;

use common::{small_hot_cold_run, smokelab};

/// Exporting a plain run gives the files a `--vdb --paraview` run of the
/// same configuration wrote: the `.vti` frames and `run.pvd` byte for byte,
/// the `.vdb` frames but for the 36 characters of each file's random UUID.
#[test]
fn export_writes_what_run_vdb_and_paraview_write() {
    let dir = tempfile::tempdir().unwrap();
    small_hot_cold_run(
        dir.path(),
        "direct",
        &["--save-every", "2", "--vdb", "--paraview"],
    );
    small_hot_cold_run(dir.path(), "later", &["--save-every", "2"]);
    for format in ["vdb", "paraview"] {
        let o = smokelab(&["export", format, "later"], dir.path());
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let (direct, later) = (dir.path().join("direct"), dir.path().join("later"));
    let read = |d: &Path, f: &str| std::fs::read(d.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    for f in ["frame_0002.vti", "frame_0004.vti", "run.pvd"] {
        assert!(read(&direct, f) == read(&later, f), "{f} differs");
    }
    for f in ["frame_0002.vdb", "frame_0004.vdb"] {
        let (a, b) = (read(&direct, f), read(&later, f));
        assert_eq!(a.len(), b.len(), "{f}: lengths differ");
        let differing: Vec<usize> = (0..a.len()).filter(|&i| a[i] != b[i]).collect();
        if let (Some(first), Some(last)) = (differing.first(), differing.last()) {
            assert!(
                last - first < 36,
                "{f}: bytes {first}..={last} differ, more than a UUID"
            );
        }
    }
}

/// A folder that is not a run's is refused with exit 2 and one line naming
/// it, and nothing is written into it.
#[test]
fn export_refuses_what_is_not_a_run_folder() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("file.txt"), "text").unwrap();
    std::fs::create_dir(d.join("empty")).unwrap();
    std::fs::create_dir(d.join("other")).unwrap();
    std::fs::write(d.join("other/manifest.json"), "{\"config\": {}}").unwrap();
    small_hot_cold_run(d, "unsaved", &["--save-every", "0"]);
    for (folder, needle) in [
        ("missing", "run folder missing cannot be read"),
        ("file.txt", "run folder file.txt is not a folder"),
        ("empty", "run folder empty has no manifest.json"),
        (
            "other",
            "run folder other has a manifest.json that is not a run's",
        ),
        ("unsaved", "run folder unsaved holds no saved frames"),
    ] {
        for format in ["vdb", "paraview"] {
            let o = smokelab(&["export", format, folder], d);
            let err = String::from_utf8_lossy(&o.stderr);
            assert_eq!(o.status.code(), Some(2), "{folder}: {err}");
            assert_eq!(err.trim().lines().count(), 1, "{folder}: {err}");
            assert!(err.contains(needle), "{folder}: {err}");
            assert!(err.contains("give a folder `smokelab run` wrote"), "{err}");
        }
    }
    for folder in ["empty", "other", "unsaved"] {
        let written: Vec<_> = std::fs::read_dir(d.join(folder))
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .filter(|n| n.ends_with(".vdb") || n.ends_with(".vti") || n.ends_with(".pvd"))
            .collect();
        assert!(written.is_empty(), "{folder}: wrote {written:?}");
    }
}
