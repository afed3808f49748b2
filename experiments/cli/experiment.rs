//! `smokelab experiment ID|all|--list`: one numbered experiment, or every
//! one in turn ([`crate::cli::experiment_all`]), at the size asked, into a
//! new folder of its own under `runs/` (as `smokelab run`), into `--out DIR`,
//! or with `--publish` into the committed `results/<id>/` the paper and
//! the gallery are made from.

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;

use crate::cli::process::{default_run_dir, init_threads};
use crate::experiment::{kit, registry};
use crate::run::output_dir;
use smokelab::error::InputError;
use smokelab::io;

/// `smokelab experiment`.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// Experiment id, e.g. `06-1` (see `--list`), or `all` to run every one in turn.
    pub id: Option<String>,
    /// List the experiments and what they reproduce.
    #[arg(long, conflicts_with_all = ["id", "out", "full", "smoke", "overwrite", "publish"])]
    pub list: bool,
    /// Output folder (default: a new `runs/<id>-<time>/`, or
    /// `runs/<id>-smoke-<time>/`, `runs/<id>-full-<time>/`; with `all`, the
    /// parent of one folder per experiment, default a new `runs/all-<time>/`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write into the committed `results/<id>/` (with `all`, `results/`),
    /// which the paper and the gallery are made from: default size only,
    /// from a build of a clean commit. `experiment all --publish
    /// --overwrite` regenerates `results/`.
    #[arg(long, conflicts_with_all = ["out", "full", "smoke"])]
    pub publish: bool,
    /// Replace the outputs of an earlier run of the experiment in its folder
    /// (figures, tables, arrays, manifests, and its run folders; other files
    /// stay); without it such a folder is refused.
    #[arg(long)]
    pub overwrite: bool,
    /// Run at the notes' full sizes instead of the cheap default.
    #[arg(long)]
    pub full: bool,
    /// Tiny sizes that finish in seconds (used by the test suite).
    #[arg(long, conflicts_with = "full")]
    pub smoke: bool,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Hide progress bars.
    #[arg(long)]
    pub quiet: bool,
    /// Experiment P-1, alone or in `all`: also run the peer scripts (Taichi, pyFFTW) with this Python.
    #[arg(long, value_name = "PYTHON")]
    pub peers: Option<PathBuf>,
    /// With --publish (or an --out under `results/`): write even from a
    /// build of a dirty tree (committed results must come from a clean
    /// commit, recorded in their manifests).
    #[arg(long)]
    pub allow_dirty: bool,
}

/// Refuse to write the committed `results/` folder from a build of
/// uncommitted code, unless `allow_dirty`: a manifest must name the code
/// that made its result.
fn check_clean_build(out: &std::path::Path, allow_dirty: bool) -> Result<(), InputError> {
    let into_results =
        out.components().next() == Some(std::path::Component::Normal("results".as_ref()));
    if into_results && !allow_dirty && io::manifest::BUILD_COMMIT.ends_with("-dirty") {
        return Err(InputError::new(format!(
            "this smokelab was built from a dirty tree ({}); commit first, leave out --publish to write a new folder under runs/, or pass --allow-dirty",
            io::manifest::BUILD_COMMIT
        )));
    }
    Ok(())
}

/// Run `smokelab experiment`.
pub(super) fn run(args: &ExperimentArgs) -> Result<()> {
    init_threads(args.threads)?;
    if args.list {
        println!("{}", registry::listing());
        return Ok(());
    }
    let Some(id) = &args.id else {
        return Err(InputError::new(format!(
            "give an experiment id, `all` or --list; known ids: {}",
            registry::ids().join(", ")
        ))
        .into());
    };
    let size = if args.full {
        kit::Size::Full
    } else if args.smoke {
        kit::Size::Smoke
    } else {
        kit::Size::Default
    };
    if args.peers.is_some() && !registry::WITH_PEERS.contains(&id.as_str()) && id != "all" {
        return Err(InputError::new(format!(
            "--peers is for experiment {} (or `all`, which runs it) only",
            registry::WITH_PEERS.join(", ")
        ))
        .into());
    }
    // Only `--publish` (or an `--out` there) writes into the committed
    // `results/`, at the default size (clap refuses `--publish` with
    // another): a rerun on a fresh clone goes into a new folder of its own.
    let fresh = |folder: &str| match size {
        kit::Size::Default => default_run_dir(folder),
        kit::Size::Smoke => default_run_dir(&format!("{folder}-smoke")),
        kit::Size::Full => default_run_dir(&format!("{folder}-full")),
    };
    let published = args.publish.then(|| PathBuf::from("results"));
    if id == "all" {
        let parent = match args.out.clone().or(published) {
            Some(parent) => parent,
            None => output_dir::create_fresh(&fresh("all"))?,
        };
        check_clean_build(&parent, args.allow_dirty)?;
        let options = crate::cli::experiment_all::AllOptions {
            size,
            progress: !args.quiet,
            overwrite: args.overwrite,
            peers: args.peers.as_deref(),
        };
        return crate::cli::experiment_all::run(&parent, &options);
    }
    let exp = registry::find(id)?;
    let given = args.out.clone().or(published.map(|r| r.join(exp.folder)));
    let (out, existed) = match given {
        Some(out) => {
            output_dir::check(&out, &output_dir::EXPERIMENT, args.overwrite)?;
            check_clean_build(&out, args.allow_dirty)?;
            let existed = out.exists();
            (out, existed)
        }
        None => (output_dir::create_fresh(&fresh(exp.folder))?, false),
    };
    let folder = output_dir::open(&out, &output_dir::EXPERIMENT, args.overwrite)?;
    let ctx = kit::Context {
        out: out.clone(),
        size,
        progress: !args.quiet,
        peers: args.peers.clone(),
    };
    let start = std::time::Instant::now();
    let outcome = {
        let _bar = crate::run::progress::experiment(exp.id, !args.quiet);
        (exp.run)(&ctx)
    };
    if outcome.is_err() && !existed {
        // Input the experiment checks itself (P-1's `--peers`) leaves no
        // folder behind when it is refused before anything is written.
        drop(folder);
        output_dir::remove_if_unwritten(&out);
    }
    outcome?;
    println!(
        "experiment {} ({}) finished in {:.1} s; wrote {}",
        exp.id,
        exp.reproduces,
        start.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}
