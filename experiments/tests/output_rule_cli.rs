//! The one output rule: a folder holding an earlier run's outputs is
//! refused (exit 2, naming it) unless `--overwrite`, which removes only
//! what the command writes; a non-default size never writes into
//! `results/` unless asked; `gallery` and `paper` never fall back into the
//! checkout the binary was built from.

mod common;

use common::Sandbox;

/// `experiment ID --smoke` without `--out` used to rewrite the committed
/// `results/ID/`; now it writes a new folder under `runs/`, and `results/`
/// is untouched. A rerun into a used folder is refused unless
/// `--overwrite`, which keeps a file the experiment does not write.
#[test]
fn smoke_experiments_stay_out_of_results_and_reruns_need_overwrite() {
    let sb = Sandbox::new();
    let d = sb.path();
    std::fs::create_dir_all(d.join("results/A-1")).unwrap();
    std::fs::write(d.join("results/A-1/data.csv"), "committed").unwrap();
    let out = sb.ok(&["experiment", "A-1", "--smoke", "--quiet"]).stdout;
    let out = String::from_utf8_lossy(&out);
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
    sb.refused(
        &["experiment", "A-1", "--quiet", "--allow-dirty"],
        &["output folder results/A-1 holds 1 files", "--overwrite"],
    );
    let args = ["experiment", "A-1", "--smoke", "--quiet", "--out", "mine"];
    sb.ok(&args);
    std::fs::write(d.join("mine/notes.txt"), "mine").unwrap();
    let figures = std::fs::read_dir(d.join("mine")).unwrap().count();
    sb.refused(&args, &["output folder mine holds", "--overwrite"]);
    sb.ok(&[&args[..], &["--overwrite"]].concat());
    assert_eq!(std::fs::read_dir(d.join("mine")).unwrap().count(), figures);
    assert!(d.join("mine/notes.txt").is_file());
}

/// `experiment all` checks every experiment's folder before running any.
#[test]
fn experiment_all_refuses_used_folders_before_running() {
    let sb = Sandbox::new();
    let d = sb.path();
    std::fs::create_dir_all(d.join("all/08-3")).unwrap();
    std::fs::write(d.join("all/08-3/manifest.json"), "{}").unwrap();
    sb.refused(
        &["experiment", "all", "--smoke", "--quiet", "--out", "all"],
        &["all/08-3 holds 1 files of an earlier run", "--overwrite"],
    );
    // Nothing ran: the first experiment's folder was not made.
    assert_eq!(std::fs::read_dir(d.join("all")).unwrap().count(), 1);
}

/// `script`, `noise` and `export` follow the same rule.
#[test]
fn script_noise_and_export_refuse_used_folders_unless_overwrite() {
    let sb = Sandbox::new();
    let d = sb.path();
    let script = d.join("tiny.rhai");
    std::fs::write(&script, "let res = param(\"res\", 8);\n").unwrap();
    let s = script.to_str().unwrap();
    sb.ok(&["script", s, "--out", "s"]);
    sb.refused(
        &["script", s, "--out", "s"],
        &["output folder s holds", "--overwrite"],
    );
    sb.ok(&["script", s, "--out", "s", "--overwrite"]);

    let noise = ["noise", "value", "--res", "8", "--quiet", "--out", "n"];
    sb.ok(&noise);
    sb.refused(&noise, &["output folder n holds 3 files", "--overwrite"]);
    sb.ok(&[&noise[..], &["--overwrite"]].concat());

    sb.small_hot_cold_run("run", &["--save-every", "2", "--vdb"]);
    sb.refused(
        &["export", "vdb", "run"],
        &[
            "output folder run holds 2 files",
            "frame_0001.vdb",
            "--overwrite",
        ],
    );
    sb.ok(&["export", "vdb", "run", "--overwrite"]);
    // Into another folder, rotated for Blender; the run's own frames stay.
    sb.ok(&["export", "vdb", "run", "--up", "z", "--out", "blender"]);
    assert!(d.join("blender/frame_0002.vdb").is_file());
    assert!(d.join("run/frame_0002.vdb").is_file() && d.join("run/hot_0004.npy").is_file());
    sb.refused(
        &["export", "paraview", "run", "--up", "z"],
        &["--density-grid and --up shape VDB files"],
    );
    sb.refused(
        &[
            "run", "--res", "10", "--frames", "1", "--up", "z", "--out", "x",
        ],
        &["add --vdb"],
    );
    sb.refused(
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
        &["--density-grid smoke", "hot, cold"],
    );
    assert!(!d.join("x").exists());
}

/// Outside a repository `paper` and `gallery` used to write into the
/// checkout the binary was built from; now they need a path.
#[test]
fn paper_and_gallery_outside_a_repository_need_a_path() {
    let sb = Sandbox::new();
    sb.refused(&["paper"], &["no paper/paper.md", "--root DIR"]);
    sb.refused(&["gallery"], &["no paper/paper.md", "--results DIR"]);
    sb.refused(
        &["paper", "--root", "."],
        &["--root .: it holds no paper/paper.md"],
    );
}
