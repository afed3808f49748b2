//! Checkpoint and resume (issue 18 item 5): a run killed with SIGKILL after
//! a checkpoint, resumed with `run --resume`, ends with the same frames
//! (bitwise) and metrics rows (but the wall-clock columns) as a run that
//! was never interrupted — in every density mode; and a bad `--resume`
//! exits 2 with one line naming the problem, writing nothing.

mod common;

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use common::{manifest, reseal, Sandbox};
use smokelab::density::DensityMode;

/// Every file of `dir` and its bytes.
fn snapshot(dir: &Path) -> BTreeMap<String, Vec<u8>> {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .map(|p| {
            let name = p.file_name().unwrap().to_string_lossy().into_owned();
            (name, std::fs::read(&p).unwrap())
        })
        .collect()
}

/// `metrics.csv` rows without the wall-clock columns (`t_*`).
fn metric_rows(dir: &Path) -> Vec<Vec<String>> {
    let text = std::fs::read_to_string(dir.join("metrics.csv")).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            l.split(',')
                .zip(&header)
                .filter(|(_, c)| !c.starts_with("t_"))
                .map(|(v, _)| v.to_string())
                .collect()
        })
        .collect()
}

/// The run's flags at 16³ with `extra` (density mode, scheme).
fn run_args<'a>(frames: &'a str, extra: &[&'a str]) -> Vec<&'a str> {
    let mut a = vec!["run", "hot-cold", "--res", "16", "--frames", frames];
    a.extend(["--save-every", "4", "--metrics-every", "3", "--quiet"]);
    a.extend_from_slice(extra);
    a
}

/// The frames and metrics rows of `resumed` are those of `full`, bitwise.
fn assert_same_run(full: &Path, resumed: &Path, frames: usize) {
    let (a, b) = (snapshot(full), snapshot(resumed));
    let npy = |s: &BTreeMap<String, Vec<u8>>| -> Vec<String> {
        s.keys().filter(|n| n.ends_with(".npy")).cloned().collect()
    };
    assert_eq!(npy(&a), npy(&b), "the saved frames differ");
    assert!(npy(&a)
        .iter()
        .any(|n| n.ends_with(&format!("_{frames:04}.npy"))));
    for name in npy(&a) {
        assert!(
            a[&name] == b[&name],
            "{name} differs from the uninterrupted run's"
        );
    }
    let (ra, rb) = (metric_rows(full), metric_rows(resumed));
    assert_eq!(ra.len(), frames);
    assert_eq!(ra, rb, "metrics rows differ");
    assert_eq!(manifest(full)["config"], manifest(resumed)["config"]);
    assert!(
        !b.keys()
            .any(|n| n.ends_with(".tmp") || n.ends_with(".smokelab-tmp")),
        "{:?}",
        b.keys()
    );
}

/// Start a run of (nearly) endless frames checkpointing every 4 steps, kill
/// it with SIGKILL once it has written 6 metrics rows (so after the
/// checkpoint of step 4), resume it to 16 frames, and compare with 16
/// uninterrupted frames.
fn killed_and_resumed(extra: &[&str], check_killed: impl Fn(&Path)) {
    let sb = Sandbox::new();
    sb.ok(&[run_args("16", extra), vec!["--out", "full"]].concat());
    let part = sb.join("part");
    let mut args = run_args("100000", extra);
    args.extend(["--checkpoint-every", "4", "--out"]);
    let mut child = Command::new(env!("CARGO_BIN_EXE_smokelab"))
        .args(&args)
        .arg(&part)
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    // Whole data rows so far; a file whose header is not yet written has
    // none (a plain `- 1` wrapped to usize::MAX there and killed the run
    // before its manifest existed).
    let rows = || {
        std::fs::read_to_string(part.join("metrics.csv"))
            .map_or(0, |t| t.lines().count().saturating_sub(1))
    };
    while rows() < 6 {
        assert!(
            start.elapsed() < Duration::from_secs(120),
            "no 6th step after two minutes"
        );
        std::thread::sleep(Duration::from_millis(1));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let killed_rows = rows();
    assert_eq!(manifest(&part)["status"], "running");
    check_killed(&part);
    sb.ok(&["run", "--resume", "part", "--frames", "16", "--quiet"]);
    let m = manifest(&part);
    assert_eq!(m["status"], "complete");
    let from = m["extra"]["resumed_from"].as_u64().unwrap() as usize;
    assert!(
        from.is_multiple_of(4) && (4..16).contains(&from) && from <= killed_rows,
        "{from}"
    );
    eprintln!("{extra:?}: killed after {killed_rows} rows, resumed from step {from}");
    assert_same_run(&sb.join("full"), &part, 16);
}

/// A finished 10-frame run continued to 16 frames resumes from its last
/// frame, step 10 (it used to restart from the checkpoint of step 8): the
/// checkpoint is written after the last step too. Its steps 11–16 are those
/// of an uninterrupted 16-frame run, bitwise; what it had written stays,
/// frame 10 (saved as its last) and row 10 (measured finely as its last).
fn extended(extra: &[&str]) {
    let sb = Sandbox::new();
    sb.ok(&[run_args("16", extra), vec!["--out", "full"]].concat());
    let args = [
        run_args("10", extra),
        vec!["--checkpoint-every", "4", "--out", "part"],
    ];
    sb.ok(&args.concat());
    let part = sb.join("part");
    let before = snapshot(&part);
    let rows_before = metric_rows(&part);
    sb.ok(&["run", "--resume", "part", "--frames", "16", "--quiet"]);
    assert_eq!(manifest(&part)["extra"]["resumed_from"], 10);
    let (full, after) = (snapshot(&sb.join("full")), snapshot(&part));
    for name in full.keys().filter(|n| n.ends_with(".npy")) {
        assert!(
            full[name] == after[name],
            "{name} differs from the uninterrupted run's"
        );
    }
    for name in ["hot_0010.npy", "vel_0010.npy"] {
        assert!(
            !full.contains_key(name) && after[name] == before[name],
            "{name}"
        );
    }
    let (rf, ra) = (metric_rows(&sb.join("full")), metric_rows(&part));
    assert_eq!(ra.len(), 16);
    assert_eq!(
        ra[..10],
        rows_before[..],
        "rows up to the last frame changed"
    );
    assert_eq!(
        ra[10..],
        rf[10..],
        "rows 11–16 differ from the uninterrupted run's"
    );
    assert_eq!(ra[..9], rf[..9]);
}

/// In every density mode; SELMA with a re-anchoring threshold low enough
/// (τ = 0.0005 map cells, default 2) that the checkpoint holds a
/// re-anchored map, checked in its header: measured 1 re-anchoring by step
/// 4 (none with τ = 0.001: the flow starts at rest; 4 by step 8).
#[test]
fn a_killed_run_resumes_bitwise_in_every_mode() {
    for mode in DensityMode::ALL {
        let density = ["--density", mode.name()];
        if mode != DensityMode::Selma {
            killed_and_resumed(&density, |_| ());
            continue;
        }
        let remap = [&density[..], &["--selma-remap", "0.0005"]].concat();
        killed_and_resumed(&remap, |part| {
            let bytes = std::fs::read(part.join("checkpoint.bin")).unwrap();
            let len = u64::from_le_bytes(bytes[12..20].try_into().unwrap()) as usize;
            let header: serde_json::Value = serde_json::from_slice(&bytes[20..20 + len]).unwrap();
            for gas in header["gases"].as_array().unwrap() {
                assert!(gas["restarts"].as_u64().unwrap() > 0, "{gas}");
            }
        });
    }
}

#[test]
fn a_killed_quick_run_resumes_bitwise() {
    killed_and_resumed(&["--advection", "quick"], |_| ());
}

#[test]
fn a_finished_run_extends_bitwise_in_every_mode() {
    for mode in DensityMode::ALL {
        extended(&["--density", mode.name()]);
    }
}

/// Slab-box runs of 8 frames (saves, fine metrics, diagnostics and
/// checkpoints every 4 steps, so the last frame is one the 12-frame run
/// measures and writes too) continued
/// to 12 are the 12-frame runs, bitwise, with every obstacle method: the notes' rule
/// (semi-Lagrangian), and the exact projection with semi-Lagrangian and
/// with QUICK (the default), whose solves warm-start from the checkpoint's
/// pressure and face potential.
#[test]
fn slab_box_runs_extend_bitwise_with_every_obstacle_method() {
    for method in [["notes", "sl"], ["exact", "sl"], ["exact", "quick"]] {
        let sb = Sandbox::new();
        let args = |frames: &'static str| {
            let mut a = vec!["run", "slab-box", "--res", "32", "--frames", frames];
            a.extend(["--save-every", "4", "--metrics-every", "4"]);
            a.extend(["--diagnostics-every", "4", "--obstacles", method[0]]);
            a.extend(["--advection", method[1], "--quiet", "--out"]);
            a
        };
        sb.ok(&[args("12"), vec!["full"]].concat());
        let part = [args("8"), vec!["part", "--checkpoint-every", "4"]];
        sb.ok(&part.concat());
        sb.ok(&["run", "--resume", "part", "--frames", "12", "--quiet"]);
        let part = sb.join("part");
        assert_eq!(manifest(&part)["extra"]["resumed_from"], 8, "{method:?}");
        assert_same_run(&sb.join("full"), &part, 12);
    }
}

/// `--resume` of `dir` fails with exit 2 and one line containing `what`,
/// changing nothing in the folder.
fn refused(sb: &Sandbox, args: &[&str], dir: &Path, what: &str) {
    let before = snapshot(dir);
    let err = sb.refused(args, &[what]);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(
        snapshot(dir) == before,
        "{args:?} changed {}",
        dir.display()
    );
}

#[test]
fn bad_resumes_exit_2_and_write_nothing() {
    let sb = Sandbox::new();
    let cwd = sb.path();
    sb.ok(&[
        run_args("10", &[]),
        vec!["--checkpoint-every", "4", "--out", "good"],
    ]
    .concat());
    let copy = |name: &str| {
        let to = cwd.join(name);
        std::fs::create_dir(&to).unwrap();
        for (n, bytes) in snapshot(&cwd.join("good")) {
            std::fs::write(to.join(n), bytes).unwrap();
        }
        to
    };
    let resume = |name: &'static str| ["run", "--resume", name, "--frames", "16"];

    sb.ok(&[run_args("4", &[]), vec!["--out", "plain"]].concat());
    refused(
        &sb,
        &resume("plain"),
        &cwd.join("plain"),
        "has no checkpoint.bin",
    );

    let d = copy("truncated");
    let ckpt = d.join("checkpoint.bin");
    let len = std::fs::metadata(&ckpt).unwrap().len();
    std::fs::OpenOptions::new()
        .write(true)
        .open(&ckpt)
        .unwrap()
        .set_len(len / 2)
        .unwrap();
    refused(&sb, &resume("truncated"), &d, "truncated or corrupt");

    let d = copy("corrupt");
    let mut bytes = std::fs::read(d.join("checkpoint.bin")).unwrap();
    let mid = bytes.len() / 2;
    bytes[mid] ^= 0x10;
    std::fs::write(d.join("checkpoint.bin"), bytes).unwrap();
    refused(&sb, &resume("corrupt"), &d, "truncated or corrupt");

    let d = copy("format");
    reseal(&d.join("checkpoint.bin"), |b| b[8] = 99);
    refused(&sb, &resume("format"), &d, "checkpoint format 99");

    let d = copy("version");
    reseal(&d.join("checkpoint.bin"), |b| {
        let at = b.windows(11).position(|w| w == b"\"version\":\"").unwrap() + 11;
        b[at] = b'7';
    });
    refused(&sb, &resume("version"), &d, "was written by smokelab 7");

    let d = copy("config");
    let mut m = manifest(&d);
    m["config"]["dt"] = serde_json::json!(0.07);
    std::fs::write(d.join("manifest.json"), m.to_string()).unwrap();
    refused(&sb, &resume("config"), &d, "another configuration");

    let good = cwd.join("good");
    refused(&sb, &["run", "--resume", "good"], &good, "is complete");
    refused(
        &sb,
        &["run", "--resume", "good", "--frames", "8"],
        &good,
        "--frames N > 10",
    );
    let args = ["run", "--resume", "good", "--frames", "16", "--res", "8"];
    refused(&sb, &args, &good, "drop --res");
}

/// A resume killed before its first checkpoint used to leave a folder that
/// could never be resumed again ("keys differing: frames": the manifest
/// held the new `--frames`, the checkpoint the old). Now it resumes, and
/// the result is the uninterrupted run's, bitwise.
#[test]
fn an_interrupted_resume_can_be_resumed_again() {
    let sb = Sandbox::new();
    // Metrics and diagnostics every 4th step: the first leg's last step
    // (4, diagnosed as a run's last step is) is then on the cadence of the
    // uninterrupted run.
    let cadence = ["--metrics-every", "4", "--diagnostics-every", "4"];
    let leg = |frames| {
        let mut a = vec!["run", "hot-cold", "--res", "16", "--frames", frames];
        a.extend(["--save-every", "4", "--quiet"]);
        a.extend(cadence);
        a
    };
    sb.ok(&[leg("16"), vec!["--out", "full"]].concat());
    // Checkpoints only at the last step: the resume below writes none
    // before it is killed.
    sb.ok(&[
        leg("4"),
        vec!["--checkpoint-every", "100000", "--out", "part"],
    ]
    .concat());
    let part = sb.join("part");
    let mut child = Command::new(env!("CARGO_BIN_EXE_smokelab"))
        .args(["run", "--resume", "part", "--frames", "100000", "--quiet"])
        .current_dir(sb.path())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let rows = || {
        std::fs::read_to_string(part.join("metrics.csv"))
            .map_or(0, |t| t.lines().count().saturating_sub(1))
    };
    let start = Instant::now();
    while rows() < 7 {
        assert!(start.elapsed() < Duration::from_secs(120), "no 7th step");
        std::thread::sleep(Duration::from_millis(1));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let m = manifest(&part);
    assert_eq!(
        (m["status"].as_str(), m["config"]["frames"].as_u64()),
        (Some("running"), Some(100000))
    );
    sb.ok(&["run", "--resume", "part", "--frames", "16", "--quiet"]);
    let m = manifest(&part);
    assert_eq!(m["status"], "complete");
    assert_eq!(m["extra"]["resumed_from"], 4);
    assert_same_run(&sb.join("full"), &part, 16);
}
