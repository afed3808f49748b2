//! A run's manifest says whether it finished, and an interrupted run leaves
//! only whole files (issue 18: killed runs used to leave `.tmp` files, and
//! the manifest appeared only at the end).

mod common;

use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{assert_exit, manifest, Sandbox};

#[test]
fn a_finished_run_says_complete() {
    let sb = Sandbox::new();
    sb.small_hot_cold_run("r", &["--save-every", "2"]);
    let m = sb.manifest("r");
    assert_eq!(m["status"], "complete");
    assert_eq!(m["extra"]["gases"], serde_json::json!(["hot", "cold"]));
}

/// Ctrl-C in the middle of a run that writes every frame in every format:
/// exit 130, the manifest written at the start still says `running` (with
/// the grid), no temporary file is left and every volume reads whole.
#[test]
fn an_interrupted_run_says_running_and_leaves_only_whole_files() {
    let sb = Sandbox::new();
    let out = sb.join("r");
    let child = Command::new(env!("CARGO_BIN_EXE_smokelab"))
        .args([
            "run",
            "hot-cold",
            "--res",
            "24",
            "--frames",
            "100000",
            "--save-every",
            "1",
            "--vdb",
            "--paraview",
            "--quiet",
            "--out",
        ])
        .arg(&out)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while !out.join("hot_0003.npy").exists() {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no third frame after two minutes"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    let m = manifest(&out);
    assert_eq!(m["status"], "running");
    assert_eq!(m["extra"]["grid"]["dims"], serde_json::json!([24, 24, 24]));
    // SAFETY: sending a signal to our own child process has no preconditions.
    assert_eq!(unsafe { libc::kill(child.id() as i32, libc::SIGINT) }, 0);
    let err = assert_exit(
        &child.wait_with_output().unwrap(),
        &["run", "(SIGINT)"],
        130,
    );
    assert!(err.contains("interrupted"), "{err}");
    // How to go on: this run wrote no checkpoint, so how to make one that does.
    assert!(
        err.contains("wrote no checkpoint")
            && err.contains("--checkpoint-every K")
            && err.contains("smokelab run --resume"),
        "{err}"
    );
    assert_eq!(manifest(&out)["status"], "running");
    let mut volumes = 0;
    for entry in std::fs::read_dir(&out).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            !smokelab::io::is_temporary_file(&name),
            "{name} was left behind"
        );
        if name.starts_with("vel_") {
            ndarray_npy::read_npy::<_, ndarray::Array4<f32>>(&path)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            volumes += 1;
        } else if name.ends_with(".npy") {
            ndarray_npy::read_npy::<_, ndarray::Array3<f32>>(&path)
                .unwrap_or_else(|e| panic!("{name}: {e}"));
            volumes += 1;
        }
    }
    // Frames 1 and 2 whole (hot, cold, u, v, w, vel), and frame 3's hot.
    assert!(volumes > 2 * 6, "only {volumes} volumes");
}

/// A run that stops on an error (here the velocity overflows at step 2)
/// exits 1 and rewrites its manifest as `failed`, naming the error.
#[test]
fn a_failed_run_says_failed_with_its_error() {
    let sb = Sandbox::new();
    let args = ["run", "hot-cold", "--res", "16", "--frames", "5"];
    sb.fails(
        &[&args[..], &["--gravity", "1e38", "--quiet", "--out", "r"]].concat(),
        1,
    );
    let m = sb.manifest("r");
    assert_eq!(m["status"], "failed");
    let error = m["extra"]["error"].as_str().unwrap();
    assert!(error.contains("non-finite at step 2"), "{error}");
}
