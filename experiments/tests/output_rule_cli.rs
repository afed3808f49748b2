//! The one output rule: a folder holding files an earlier smokelab wrote
//! is refused (exit 2, naming them) unless `--overwrite`, which removes
//! exactly those (smokelab records them) and never a user's file; one
//! writer per folder; no writes through symbolic links or into system
//! folders; a non-default size never writes into `results/` unless asked;
//! `gallery` and `paper` never fall back into the checkout the binary was
//! built from.

mod common;

use common::Sandbox;

/// An experiment without `--out` writes a new folder of its own under
/// `runs/` at every size, as `run` does: the committed `results/` is left
/// alone and a rerun on a fresh clone is not refused. `--publish` writes
/// into `results/<id>/` (default size only), where a file smokelab did not
/// write is refused, not replaced. A rerun into a used `--out` folder is
/// refused unless `--overwrite`, which keeps a file the experiment does
/// not write.
#[test]
fn experiments_write_new_folders_and_results_only_when_published() {
    let sb = Sandbox::new();
    let d = sb.path();
    std::fs::create_dir_all(d.join("results/A-1")).unwrap();
    std::fs::write(d.join("results/A-1/data.csv"), "committed").unwrap();
    let mut printed = String::new();
    for args in [
        &["experiment", "A-1", "--quiet"][..],
        &["experiment", "A-1", "--quiet"],
        &["experiment", "A-1", "--smoke", "--quiet"],
    ] {
        printed += &String::from_utf8_lossy(&sb.ok(args).stdout);
    }
    assert_eq!(
        std::fs::read_to_string(d.join("results/A-1/data.csv")).unwrap(),
        "committed"
    );
    let mut runs: Vec<String> = std::fs::read_dir(d.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    runs.sort();
    assert_eq!(runs.len(), 3, "{runs:?}");
    assert!(
        runs[..2]
            .iter()
            .all(|r| r.starts_with("A-1-") && !r.contains("smoke"))
            && runs[2].starts_with("A-1-smoke-"),
        "{runs:?}"
    );
    for r in &runs {
        assert!(d.join("runs").join(r).join("data.csv").is_file(), "{r}");
        assert!(
            printed.contains(&format!("wrote runs/{r}\n")),
            "{r}: {printed}"
        );
    }
    // --publish writes into results/: its data.csv there is not one
    // smokelab recorded writing, so it is refused, not replaced.
    sb.refused(
        &[
            "experiment",
            "A-1",
            "--quiet",
            "--publish",
            "--allow-dirty",
            "--overwrite",
        ],
        &["results/A-1/data.csv", "smokelab did not write"],
    );
    assert_eq!(
        std::fs::read_to_string(d.join("results/A-1/data.csv")).unwrap(),
        "committed"
    );
    // The committed results are the default size's, and --out names
    // another folder: neither goes with --publish.
    sb.refused(
        &["experiment", "A-1", "--publish", "--smoke"],
        &["--publish", "--smoke"],
    );
    sb.refused(
        &["experiment", "all", "--publish", "--out", "o"],
        &["--publish", "--out"],
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
        &[
            "all/08-3 holds a manifest.json but no record",
            "even with --overwrite",
        ],
    );
    // Nothing ran: the first experiment's folder was not made.
    assert_eq!(std::fs::read_dir(d.join("all")).unwrap().count(), 1);
    // Nor with --overwrite: nothing is removed by name.
    sb.refused(
        &[
            "experiment",
            "all",
            "--smoke",
            "--quiet",
            "--out",
            "all",
            "--overwrite",
        ],
        &["all/08-3 holds a manifest.json but no record"],
    );
    assert_eq!(
        std::fs::read_to_string(d.join("all/08-3/manifest.json")).unwrap(),
        "{}"
    );
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

/// Every file of `dir` (recursively, relative paths) and its bytes, but
/// smokelab's record and lock.
fn files(dir: &std::path::Path) -> std::collections::BTreeMap<String, Vec<u8>> {
    fn walk(
        root: &std::path::Path,
        d: &std::path::Path,
        out: &mut std::collections::BTreeMap<String, Vec<u8>>,
    ) {
        for e in std::fs::read_dir(d).unwrap() {
            let p = e.unwrap().path();
            let rel = p.strip_prefix(root).unwrap().to_string_lossy().into_owned();
            if p.is_dir() {
                walk(root, &p, out);
            } else if !rel.starts_with(".smokelab") {
                out.insert(rel, std::fs::read(&p).unwrap());
            }
        }
    }
    let mut out = std::collections::BTreeMap::new();
    walk(dir, dir, &mut out);
    out
}

/// `run --overwrite` into a folder holding a user's files named as frames
/// are (`IMG_1234.png`, `scan_00012.npy`) used to delete them: only files
/// smokelab recorded writing are replaced now, and the folder stays usable.
#[test]
fn overwrite_replaces_only_what_smokelab_wrote_whatever_the_names() {
    let sb = Sandbox::new();
    let d = sb.join("D");
    std::fs::create_dir(&d).unwrap();
    let mine = [
        ("notes.txt", "notes"),
        ("IMG_1234.png", "photo"),
        ("scan_00012.npy", "scan"),
    ];
    for (f, text) in mine {
        std::fs::write(d.join(f), text).unwrap();
    }
    let args = [
        "run", "hot-cold", "--res", "10", "--frames", "4", "--quiet", "--out", "D",
    ];
    sb.ok(&[&args[..], &["--overwrite"]].concat());
    let first = files(&d);
    sb.refused(
        &args,
        &[
            "output folder D holds",
            "files an earlier smokelab wrote",
            "manifest.json",
            "--overwrite",
        ],
    );
    sb.ok(&[&args[..], &["--save-every", "2", "--overwrite"]].concat());
    for (f, text) in mine {
        assert_eq!(std::fs::read_to_string(d.join(f)).unwrap(), text, "{f}");
    }
    // The second run replaced the first's files: frame 2 is new, and no
    // file of the first run is left but those the second wrote again.
    let second = files(&d);
    assert!(second.contains_key("hot_0002.npy"), "{:?}", second.keys());
    assert!(
        first.keys().all(|k| second.contains_key(k)),
        "{:?}",
        first.keys()
    );
}

/// `experiment --overwrite` used to delete a `README.md` and a
/// `sub/data.csv` of the user's in its folder; they stay now.
#[test]
fn experiment_overwrite_keeps_the_users_files_in_subfolders() {
    let sb = Sandbox::new();
    let d = sb.join("D");
    std::fs::create_dir_all(d.join("sub")).unwrap();
    std::fs::write(d.join("README.md"), "read me").unwrap();
    std::fs::write(d.join("sub/data.csv"), "a,b\n1,2\n").unwrap();
    let args = [
        "experiment",
        "A-1",
        "--smoke",
        "--quiet",
        "--out",
        "D",
        "--overwrite",
    ];
    sb.ok(&args);
    sb.ok(&args);
    assert_eq!(
        std::fs::read_to_string(d.join("README.md")).unwrap(),
        "read me"
    );
    assert_eq!(
        std::fs::read_to_string(d.join("sub/data.csv")).unwrap(),
        "a,b\n1,2\n"
    );
}

/// A folder a smokelab without records wrote (a manifest, no record) is
/// refused even with `--overwrite`, and nothing in it is removed.
#[test]
fn a_folder_without_a_record_is_refused_and_kept() {
    let sb = Sandbox::new();
    let d = sb.join("old");
    std::fs::create_dir(&d).unwrap();
    for f in ["manifest.json", "hot_0010.npy", "metrics.csv"] {
        std::fs::write(d.join(f), "old").unwrap();
    }
    let before = files(&d);
    let args = [
        "run",
        "--res",
        "8",
        "--frames",
        "1",
        "--quiet",
        "--out",
        "old",
        "--overwrite",
    ];
    sb.refused(
        &args,
        &["output folder old", "no record", "nothing is removed"],
    );
    assert_eq!(files(&d), before);
}

/// `metrics.csv` a symbolic link to a file outside the folder: the outside
/// file used to be overwritten; now the run is refused (the link is not
/// smokelab's), and a link put in place of a recorded output is replaced,
/// never written through.
#[test]
fn outputs_are_never_written_through_a_symbolic_link() {
    let sb = Sandbox::new();
    let outside = sb.join("outside.csv");
    std::fs::write(&outside, "precious").unwrap();
    std::fs::create_dir(sb.join("D")).unwrap();
    std::os::unix::fs::symlink(&outside, sb.join("D/metrics.csv")).unwrap();
    let args = [
        "run", "--res", "8", "--frames", "2", "--quiet", "--out", "D",
    ];
    sb.refused(&args, &["metrics.csv", "smokelab did not write"]);
    sb.refused(&[&args[..], &["--overwrite"]].concat(), &["metrics.csv"]);
    assert_eq!(std::fs::read_to_string(&outside).unwrap(), "precious");

    sb.ok(&[
        "run", "--res", "8", "--frames", "2", "--quiet", "--out", "E",
    ]);
    for f in ["metrics.csv", "manifest.json"] {
        std::fs::remove_file(sb.join("E").join(f)).unwrap();
        std::os::unix::fs::symlink(&outside, sb.join("E").join(f)).unwrap();
    }
    sb.ok(&[
        "run",
        "--res",
        "8",
        "--frames",
        "2",
        "--quiet",
        "--out",
        "E",
        "--overwrite",
    ]);
    assert_eq!(std::fs::read_to_string(&outside).unwrap(), "precious");
    assert!(!std::fs::symlink_metadata(sb.join("E/metrics.csv"))
        .unwrap()
        .is_symlink());
}

/// The file system's root and the system's folders are refused as output
/// folders before anything is written.
#[test]
fn system_folders_are_refused() {
    let sb = Sandbox::new();
    for out in ["/", "/usr", "/etc", "/tmp"] {
        sb.refused(
            &[
                "run", "--res", "8", "--frames", "1", "--quiet", "--out", out,
            ],
            &[out, "system folder"],
        );
    }
}

/// Two writers of one folder: the second exits 2 naming the first (its
/// process id), which goes on undisturbed; and two runs started at once
/// without `--out` get folders of their own.
#[test]
fn one_writer_per_folder() {
    use std::process::{Command, Stdio};
    let sb = Sandbox::new();
    let d = sb.join("D");
    let mut first = Command::new(env!("CARGO_BIN_EXE_smokelab"))
        .args([
            "run", "--res", "16", "--frames", "100000", "--quiet", "--out",
        ])
        .arg(&d)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while !d.join("metrics.csv").exists() {
        assert!(
            start.elapsed().as_secs() < 120,
            "the first run did not start"
        );
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let pid = format!("pid {}", first.id());
    let args = [
        "run",
        "--res",
        "8",
        "--frames",
        "1",
        "--quiet",
        "--out",
        "D",
        "--overwrite",
    ];
    sb.refused(
        &args,
        &["output folder D is being written by another smokelab", &pid],
    );
    // So is an export into it, and a partial render reads but may not write there.
    sb.refused(
        &["export", "paraview", "D", "--partial"],
        &["being written", &pid],
    );
    assert!(first.try_wait().unwrap().is_none(), "the first run stopped");
    first.kill().unwrap();
    first.wait().unwrap();
    // Killed, it holds the folder no more.
    sb.ok(&args);

    let run = || {
        Command::new(env!("CARGO_BIN_EXE_smokelab"))
            .args(["run", "--res", "8", "--frames", "2", "--quiet"])
            .current_dir(sb.path())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap()
    };
    let (a, b) = (run(), run());
    for c in [a, b] {
        let o = c.wait_with_output().unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let runs: Vec<_> = std::fs::read_dir(sb.join("runs")).unwrap().collect();
    assert_eq!(runs.len(), 2, "two runs shared a folder");
    for r in runs {
        let m = common::manifest(&r.unwrap().path());
        assert_eq!(m["status"], "complete");
    }
}
