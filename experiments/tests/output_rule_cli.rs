//! The one output rule: a folder holding an earlier run's outputs is
//! refused (exit 2, naming it) unless `--overwrite`, which removes only
//! what the command writes; a non-default size never writes into
//! `results/` unless asked; `gallery` and `paper` never fall back into the
//! checkout the binary was built from.

mod common;

use std::path::Path;

use common::{small_hot_cold_run, smokelab};

/// Exit code and stderr of `smokelab args` in `cwd`.
fn refused(args: &[&str], cwd: &Path, needles: &[&str]) {
    let o = smokelab(args, cwd);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{args:?}: {err}");
    for n in needles {
        assert!(err.contains(n), "{args:?}: {err:?} does not mention {n:?}");
    }
}

fn ok(args: &[&str], cwd: &Path) -> String {
    let o = smokelab(args, cwd);
    assert!(
        o.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    String::from_utf8_lossy(&o.stdout).into_owned()
}

/// `experiment ID --smoke` without `--out` used to rewrite the committed
/// `results/ID/`; now it writes a new folder under `runs/`, and `results/`
/// is untouched. A rerun into a used folder is refused unless
/// `--overwrite`, which keeps a file the experiment does not write.
#[test]
fn smoke_experiments_stay_out_of_results_and_reruns_need_overwrite() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("results/A-1")).unwrap();
    std::fs::write(d.join("results/A-1/data.csv"), "committed").unwrap();
    let out = ok(&["experiment", "A-1", "--smoke", "--quiet"], d);
    assert_eq!(
        std::fs::read_to_string(d.join("results/A-1/data.csv")).unwrap(),
        "committed"
    );
    let runs: Vec<String> = std::fs::read_dir(d.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    assert!(
        runs.len() == 1 && runs[0].starts_with("A-1-smoke-") && out.contains(&runs[0]),
        "{runs:?} {out}"
    );
    // The default size writes into results/: refused there, as it holds outputs.
    refused(
        &["experiment", "A-1", "--quiet", "--allow-dirty"],
        d,
        &["output folder results/A-1 holds 1 files", "--overwrite"],
    );
    let args = ["experiment", "A-1", "--smoke", "--quiet", "--out", "mine"];
    ok(&args, d);
    std::fs::write(d.join("mine/notes.txt"), "mine").unwrap();
    let figures = std::fs::read_dir(d.join("mine")).unwrap().count();
    refused(&args, d, &["output folder mine holds", "--overwrite"]);
    ok(&[&args[..], &["--overwrite"]].concat(), d);
    assert_eq!(std::fs::read_dir(d.join("mine")).unwrap().count(), figures);
    assert!(d.join("mine/notes.txt").is_file());
}

/// `experiment all` checks every experiment's folder before running any.
#[test]
fn experiment_all_refuses_used_folders_before_running() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::create_dir_all(d.join("all/08-3")).unwrap();
    std::fs::write(d.join("all/08-3/manifest.json"), "{}").unwrap();
    refused(
        &["experiment", "all", "--smoke", "--quiet", "--out", "all"],
        d,
        &["all/08-3 holds 1 files of an earlier run", "--overwrite"],
    );
    // Nothing ran: the first experiment's folder was not made.
    assert_eq!(std::fs::read_dir(d.join("all")).unwrap().count(), 1);
}

/// `script`, `noise` and `export` follow the same rule.
#[test]
fn script_noise_and_export_refuse_used_folders_unless_overwrite() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let script = d.join("tiny.rhai");
    std::fs::write(&script, "let res = param(\"res\", 8);\n").unwrap();
    let s = script.to_str().unwrap();
    ok(&["script", s, "--out", "s"], d);
    refused(
        &["script", s, "--out", "s"],
        d,
        &["output folder s holds", "--overwrite"],
    );
    ok(&["script", s, "--out", "s", "--overwrite"], d);

    let noise = ["noise", "value", "--res", "8", "--quiet", "--out", "n"];
    ok(&noise, d);
    refused(&noise, d, &["output folder n holds 3 files", "--overwrite"]);
    ok(&[&noise[..], &["--overwrite"]].concat(), d);

    small_hot_cold_run(d, "run", &["--save-every", "2", "--vdb"]);
    refused(
        &["export", "vdb", "run"],
        d,
        &[
            "output folder run holds 2 files",
            "frame_0001.vdb",
            "--overwrite",
        ],
    );
    ok(&["export", "vdb", "run", "--overwrite"], d);
    // Into another folder, rotated for Blender; the run's own frames stay.
    ok(
        &["export", "vdb", "run", "--up", "z", "--out", "blender"],
        d,
    );
    assert!(d.join("blender/frame_0002.vdb").is_file());
    assert!(d.join("run/frame_0002.vdb").is_file() && d.join("run/hot_0004.npy").is_file());
    refused(
        &["export", "paraview", "run", "--up", "z"],
        d,
        &["--density-grid and --up shape VDB files"],
    );
    refused(
        &[
            "run", "--res", "10", "--frames", "1", "--up", "z", "--out", "x",
        ],
        d,
        &["add --vdb"],
    );
    refused(
        &[
            "run",
            "--res",
            "10",
            "--frames",
            "1",
            "--vdb",
            "--density-grid",
            "smoke",
            "--out",
            "x",
        ],
        d,
        &["--density-grid smoke", "hot, cold"],
    );
    assert!(!d.join("x").exists());
}

/// Outside a repository `paper` and `gallery` used to write into the
/// checkout the binary was built from; now they need a path.
#[test]
fn paper_and_gallery_outside_a_repository_need_a_path() {
    let dir = tempfile::tempdir().unwrap();
    refused(&["paper"], dir.path(), &["no paper/paper.md", "--root DIR"]);
    refused(
        &["gallery"],
        dir.path(),
        &["no paper/paper.md", "--results DIR"],
    );
    refused(
        &["paper", "--root", "."],
        dir.path(),
        &["--root .: it holds no paper/paper.md"],
    );
}
