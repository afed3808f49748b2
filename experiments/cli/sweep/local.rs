//! The local executor: the points as child processes of this machine,
//! `smokelab sweep run-point DIR INDEX` each, at most N at once, each one's
//! output in `DIR/logs/<folder>.log`.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use anyhow::{bail, Context as _, Result};

use super::gather::{counts, refresh, state};
use super::plan::{Plan, State};

/// Run the points `indices` of the sweep in `dir`, `jobs` at a time, and
/// record their states; an error if any did not complete.
pub fn run(dir: &Path, plan: &mut Plan, indices: &[usize], jobs: usize) -> Result<()> {
    let exe = std::env::current_exe().context("cannot find the smokelab binary")?;
    // Share the cores: without a `threads` key each run takes them all.
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let per_child = (threads / jobs).max(1);
    let mut queue = indices.iter().copied();
    let mut running: Vec<(usize, Child, Instant)> = Vec::new();
    let mut done = 0;
    loop {
        while running.len() < jobs {
            let Some(index) = queue.next() else { break };
            let point = &plan.points[index];
            let name = point
                .folder
                .file_name()
                .unwrap_or_default()
                .to_string_lossy();
            let log_path = dir.join(super::layout::LOGS).join(format!("{name}.log"));
            let log = std::fs::OpenOptions::new()
                .create(true)
                .append(true)
                .open(&log_path)
                .with_context(|| format!("cannot open {}", log_path.display()))?;
            let mut cmd = Command::new(&exe);
            cmd.args(["sweep", "run-point"])
                .arg(dir)
                .arg(index.to_string())
                .stdin(Stdio::null())
                .stdout(log.try_clone()?)
                .stderr(log);
            if jobs > 1 && std::env::var_os("RAYON_NUM_THREADS").is_none() {
                cmd.env("RAYON_NUM_THREADS", per_child.to_string());
            }
            let child = cmd
                .spawn()
                .with_context(|| format!("cannot start {}", exe.display()))?;
            running.push((index, child, Instant::now()));
        }
        if running.is_empty() {
            break;
        }
        std::thread::sleep(Duration::from_millis(50));
        let mut i = 0;
        while i < running.len() {
            if running[i].1.try_wait()?.is_none() {
                i += 1;
                continue;
            }
            let (index, _, started) = running.swap_remove(i);
            done += 1;
            let point = &plan.points[index];
            println!(
                "[{done}/{}] point {index} ({}): {} in {:.1} s",
                indices.len(),
                plan.describe(point),
                state(dir, point),
                started.elapsed().as_secs_f64()
            );
        }
    }
    refresh(dir, plan)?;
    println!("{}", counts(plan));
    let unfinished: Vec<String> = indices
        .iter()
        .filter(|&&i| plan.points[i].state != State::Complete)
        .map(|i| i.to_string())
        .collect();
    if !unfinished.is_empty() {
        bail!(
            "{} of {} points did not complete (points {}); their logs are in {}",
            unfinished.len(),
            indices.len(),
            unfinished.join(", "),
            dir.join(super::layout::LOGS).display()
        );
    }
    Ok(())
}
