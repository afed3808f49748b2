//! `smokelab sweep`: parameter sweeps, on this machine or as a Slurm job
//! array.
//!
//! `sweep FILE.toml [--out DIR]` expands the file into points
//! ([`plan`]), writes `DIR/sweep.json` and runs every point with
//! `smokelab sweep run-point DIR INDEX` ([`point`]), the one entry point of
//! every executor: child processes here ([`local`]) or the tasks of a
//! Slurm array ([`slurm`]; a Kubernetes Indexed Job runs the same command).
//! `sweep status`, `sweep resubmit` and `sweep gather` ([`gather`], with
//! its figure across the sweep, [`figure`]) read the points' folders, so
//! they work whichever executor ran them.

pub mod figure;
pub mod gather;
pub mod layout;
pub mod local;
pub mod plan;
pub mod point;
pub mod slurm;

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, Subcommand};
use smokelab::error::InputError;
use smokelab::io;

use layout::LOGS;
use plan::{Plan, State};
use slurm::SlurmOptions;

/// `smokelab sweep`.
#[derive(Debug, Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    /// Track, resubmit or gather a sweep, or run one of its points.
    #[command(subcommand)]
    pub action: Option<SweepAction>,
    /// The sweep file: `scenario` (or `experiment`), `[keys]`, `[axes]`
    /// (see the book's Clusters page).
    #[arg(value_name = "FILE.toml", required = true)]
    pub file: Option<PathBuf>,
    /// The sweep's folder, new or empty (default: a new folder under `runs/`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Where the points run.
    #[command(flatten)]
    pub executor: Executor,
}

/// `smokelab sweep ACTION`.
#[derive(Debug, Subcommand)]
pub enum SweepAction {
    /// Each point's state (pending, running, complete, failed) from its folder.
    Status {
        /// The sweep's folder.
        dir: PathBuf,
    },
    /// Run the points that are not complete again (they resume from their checkpoints).
    Resubmit {
        /// The sweep's folder.
        dir: PathBuf,
        /// Where the points run (default: as the sweep was started).
        #[command(flatten)]
        executor: Executor,
    },
    /// Write DIR/sweep.csv: a row per point, its axis values, then its run's summary; and DIR/sweep.png: each point's last preview (an experiment's main figure) in a grid, a column per value of the last axis.
    Gather {
        /// The sweep's folder.
        dir: PathBuf,
    },
    /// Run point INDEX of the sweep in DIR, or continue it from its checkpoint (what each Slurm array task or Kubernetes Indexed Job pod runs).
    RunPoint {
        /// The sweep's folder.
        dir: PathBuf,
        /// The point, 0 to points − 1 (`$SLURM_ARRAY_TASK_ID`, `$JOB_COMPLETION_INDEX`).
        index: usize,
    },
}

/// Where the points run.
#[derive(Debug, Default, Args)]
pub struct Executor {
    /// Run the points on this machine as child processes (the default).
    #[arg(long, conflicts_with = "slurm")]
    pub local: bool,
    /// Points run at once on this machine (default 1; each uses all cores
    /// unless `threads` is set, and shares them with the others).
    #[arg(long, value_name = "N", conflicts_with = "slurm")]
    pub jobs: Option<usize>,
    /// Write DIR/sweep.sbatch, one array task per point, and submit it with `sbatch`.
    #[arg(long)]
    pub slurm: bool,
    /// With --slurm: write the script and print it and the `sbatch` command, without submitting.
    #[arg(long, requires = "slurm")]
    pub dry_run: bool,
    /// The Slurm job's resources (with --slurm; override the file's `[slurm]`).
    #[command(flatten)]
    pub slurm_options: SlurmOptions,
}

impl Executor {
    /// Refuse Slurm options without `--slurm`, and `--jobs 0`.
    fn check(&self) -> Result<(), InputError> {
        if !self.slurm && self.slurm_options != SlurmOptions::default() {
            return Err(InputError::new(
                "--partition, --time, --cpus-per-task, --mem and --sbatch shape the Slurm job; add --slurm",
            ));
        }
        if self.jobs == Some(0) {
            return Err(InputError::new("--jobs is 0; it must be at least 1"));
        }
        Ok(())
    }
}

/// Run `smokelab sweep …`; `run_cli` runs a point's own command line
/// (`smokelab run …` or `smokelab experiment …`) in this process.
pub fn run(args: SweepArgs, run_cli: point::RunCli) -> Result<()> {
    match args.action {
        Some(SweepAction::Status { dir }) => gather::status(&dir),
        Some(SweepAction::Gather { dir }) => gather::gather(&dir),
        Some(SweepAction::RunPoint { dir, index }) => point::run_point(&dir, index, run_cli),
        Some(SweepAction::Resubmit { dir, executor }) => resubmit(&dir, &executor),
        None => {
            let file = args
                .file
                .expect("clap requires the file without a subcommand");
            start(&file, args.out, &args.executor)
        }
    }
}

/// `smokelab sweep FILE.toml`: plan, check everything, then run or submit.
fn start(file: &Path, out: Option<PathBuf>, executor: &Executor) -> Result<()> {
    executor.check()?;
    let mut plan = Plan::from_file(file)?;
    plan.slurm = plan.slurm.with(&executor.slurm_options)?;
    let dir = out.unwrap_or_else(|| {
        let stem = file
            .file_stem()
            .map_or_else(|| "sweep".into(), |s| s.to_string_lossy());
        crate::cli::process::default_run_dir(&format!("sweep-{stem}"))
    });
    io::check_output_dir(&dir)?;
    if std::fs::read_dir(&dir).is_ok_and(|mut d| d.next().is_some()) {
        let hint = match dir.join(layout::INDEX).exists() {
            true => format!(
                "; `smokelab sweep resubmit {}` finishes the sweep it holds",
                dir.display()
            ),
            false => String::new(),
        };
        return Err(InputError::new(format!(
            "sweep folder {} is not empty; give a new folder{hint}",
            dir.display()
        ))
        .into());
    }
    if executor.slurm && !executor.dry_run {
        slurm::check_sbatch()?;
    }
    io::create_output_dir(&dir.join(LOGS))?;
    plan.write(&dir)?;
    println!(
        "sweep of {} points into {}",
        plan.points.len(),
        dir.display()
    );
    let all: Vec<usize> = (0..plan.points.len()).collect();
    if executor.slurm {
        submit(&dir, &mut plan, None, executor.dry_run)
    } else {
        local::run(&dir, &mut plan, &all, executor.jobs.unwrap_or(1))
    }
}

/// `smokelab sweep resubmit DIR`: the points not complete, again, with
/// the executor asked for or else the one that started the sweep.
fn resubmit(dir: &Path, executor: &Executor) -> Result<()> {
    executor.check()?;
    let mut plan = Plan::read(dir)?;
    gather::refresh(dir, &mut plan)?;
    let todo: Vec<usize> = plan
        .points
        .iter()
        .filter(|p| p.state != State::Complete)
        .map(|p| p.index)
        .collect();
    if todo.is_empty() {
        println!(
            "all {} points are complete; nothing to resubmit",
            plan.points.len()
        );
        return Ok(());
    }
    let on_slurm = executor.slurm || (!executor.local && !plan.slurm_jobs.is_empty());
    println!(
        "resubmitting {} of {} points: {}",
        todo.len(),
        plan.points.len(),
        slurm::array_list(&todo)
    );
    if on_slurm {
        plan.slurm = plan.slurm.with(&executor.slurm_options)?;
        if !executor.dry_run {
            slurm::check_sbatch()?;
        }
        submit(dir, &mut plan, Some(&todo), executor.dry_run)
    } else {
        local::run(dir, &mut plan, &todo, executor.jobs.unwrap_or(1))
    }
}

/// Write `DIR/sweep.sbatch` and submit it (the points `only`, else all),
/// recording the job in `sweep.json`; with `dry_run` print it and the
/// command instead.
fn submit(dir: &Path, plan: &mut Plan, only: Option<&[usize]>, dry_run: bool) -> Result<()> {
    let dir = std::path::absolute(dir)?;
    let exe = std::env::current_exe()?;
    let script = dir.join(slurm::SCRIPT);
    let text = slurm::script(&dir, &exe, plan.points.len(), &plan.slurm);
    io::write_atomic(&script, |w| {
        use std::io::Write as _;
        Ok(w.write_all(text.as_bytes())?)
    })?;
    let array = only.map(|o| format!(" --array={}", slurm::array_list(o)));
    if dry_run {
        print!("{text}");
        println!(
            "# not submitted (--dry-run); submit with: sbatch{} {}",
            array.unwrap_or_default(),
            script.display()
        );
        return plan.write(&dir);
    }
    let job = slurm::submit(&script, only)?;
    let tasks = only.map_or(plan.points.len(), <[usize]>::len);
    println!(
        "submitted Slurm job {job}, an array of {tasks} task{}; `smokelab sweep status {}` follows it",
        if tasks == 1 { "" } else { "s" },
        dir.display()
    );
    plan.slurm_jobs.push(job);
    plan.write(&dir)
}
