//! `smokelab sweep run-point DIR INDEX`: run one point of a sweep, the
//! entry point of every executor (a local child process, a Slurm array
//! task, a Kubernetes Indexed Job pod).
//!
//! A complete point is left alone. A scenario point with a checkpoint
//! continues from it (`run --resume`, bitwise the uninterrupted run on the
//! same build), so a task that was preempted or timed out finishes when
//! submitted again; any other point starts afresh in its folder. The run is
//! the ordinary `smokelab run` (or `experiment`) command line of the point,
//! parsed and executed in this process.

use std::path::Path;

use anyhow::Result;

use super::gather::{failure_file, state};
use super::plan::{Plan, State, Target};

/// Parses and runs a `smokelab …` command line in this process (the command
/// line's own `execute`, handed down so that this room does not import it).
pub type RunCli = fn(Vec<std::ffi::OsString>) -> Result<()>;

/// Run point `index` of the sweep in `dir`.
pub fn run_point(dir: &Path, index: usize, run_cli: RunCli) -> Result<()> {
    let plan = Plan::read(dir)?;
    let point = plan.point(index)?.clone();
    let folder = dir.join(&point.folder);
    if state(dir, &point) == State::Complete {
        println!("point {index} is complete; nothing to do");
        return Ok(());
    }
    let failure = failure_file(dir, &point);
    if failure.exists() {
        std::fs::remove_file(&failure)?;
    }
    let resume = matches!(plan.target, Target::Scenario(_))
        && folder.join(crate::run::checkpoint::FILE).exists();
    let mut argv: Vec<std::ffi::OsString> = vec!["smokelab".into()];
    if resume {
        argv.extend(["run".into(), "--resume".into(), folder.clone().into()]);
        argv.push("--quiet".into());
    } else {
        argv.extend(point.args.iter().map(Into::into));
        argv.extend(["--out".into(), folder.clone().into(), "--overwrite".into()]);
    }
    println!(
        "point {index} ({}): {}{}",
        plan.describe(&point),
        if resume { "resuming " } else { "" },
        argv.iter()
            .map(|a| a.to_string_lossy())
            .collect::<Vec<_>>()
            .join(" ")
    );
    run_cli(argv).inspect_err(|e| {
        // The error in the log and, for `status`, beside the logs; a run
        // that got as far as its manifest also records it there.
        let _ = std::fs::write(&failure, format!("{e:#}\n"));
    })
}
