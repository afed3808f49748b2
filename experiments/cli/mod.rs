//! The `smokelab` command line (clap): the subcommands and where each
//! goes, one file per subcommand that has code of its own (`run`,
//! `experiment`, `render`, `noise`, `export`; `paper`, `gallery` and
//! `script` live with their rooms).
//!
//! `smokelab` with no arguments runs the hot/cold default into a new folder
//! under `runs/`. Bad input is reported as one line naming the value and what
//! is valid, with exit code 2, before anything is written.

mod experiment;
mod experiment_all;
pub mod export;
pub mod noise;
pub mod process;
pub mod render;
mod resume;
pub mod run;
pub mod sweep;

use anyhow::Result;
use clap::{CommandFactory, Parser, Subcommand};

use crate::cli::experiment::ExperimentArgs;
use crate::cli::process::init_threads;
use crate::cli::run::RunArgs;

/// `--version`: the package version and the git commit the library was
/// built from (`-dirty` when the tree had changes).
fn version() -> &'static str {
    static VERSION: std::sync::LazyLock<String> = std::sync::LazyLock::new(|| {
        format!(
            "{} ({})",
            env!("CARGO_PKG_VERSION"),
            smokelab::io::manifest::BUILD_COMMIT
        )
    });
    &VERSION
}

/// Navier–Stokes smoke with gridded, gridless and SELMA density.
#[derive(Debug, Parser)]
#[command(
    name = "smokelab",
    version = version(),
    about,
    after_help = "Without a command, `smokelab` runs hot/cold smoke at 50³ into a new folder \
                  runs/hot-cold-<time>/, as `smokelab run` does, and prints where it wrote."
)]
pub struct Cli {
    /// What to do (default: `run hot-cold`).
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// Subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Run a scenario and write volumes, previews, metrics and a manifest.
    Run(RunArgs),
    /// Run a numbered experiment that reproduces a figure of the notes.
    Experiment(ExperimentArgs),
    /// Render saved density volumes (.npy) to EXR and PNG.
    Render(crate::cli::render::RenderArgs),
    /// Convert a run's saved frames to OpenVDB (`vdb`) or ParaView (`paraview`) files.
    Export(crate::cli::export::ExportArgs),
    /// Sample a noise velocity field onto an N³ grid (`noise.npy` + slice PNG): the divergence-free kinds (simulation, curl, bitangent, Stam–Fiume) and, for comparison, value and Perlin noise, which are not.
    Noise(crate::cli::noise::NoiseArgs),
    /// Refresh `paper/paper.md` from `results/` and build it to HTML (pandoc).
    Paper(crate::publish::paper::PaperArgs),
    /// Run a field script (`experiments/scripts/*.rhai`), the notes' FELT almost as printed.
    Script(crate::script::ScriptArgs),
    /// Write `results/index.html`: every experiment's figures with captions and commands.
    Gallery(crate::publish::gallery::GalleryArgs),
    /// Run a parameter sweep (a scenario over axes of keys, or experiments) locally or as a Slurm job array; track, resubmit and gather it.
    Sweep(crate::cli::sweep::SweepArgs),
}

/// A command-line error clap reports (unknown or misspelt option, missing
/// or conflicting argument, a value clap itself refuses) as one line: the
/// error with what clap lists under it (the missing arguments, the possible
/// values), its tips, and which command's `--help` lists the options — not
/// clap's block of error, tips, usage and a pointer to `--help`. `args` is
/// the command line, for the subcommand.
pub fn one_line_error(e: &clap::Error, args: &[String]) -> String {
    let text = e.render().to_string();
    let mut error = String::new();
    let mut tips = Vec::new();
    for line in text.lines().map(str::trim).filter(|l| !l.is_empty()) {
        if line.starts_with("Usage:") || line.starts_with("For more information") {
            continue;
        }
        match line.strip_prefix("tip:") {
            Some(tip) => tips.push(tip.trim().trim_end_matches('.').to_owned()),
            None if error.is_empty() => error = line.to_owned(),
            None => {
                error.push(' ');
                error.push_str(line);
            }
        }
    }
    let mut command = Cli::command();
    let mut words = vec!["smokelab".to_owned()];
    for arg in args.iter().skip(1) {
        if let Some(sub) = command.find_subcommand(arg) {
            let sub = sub.clone();
            words.push(arg.clone());
            command = sub;
        }
    }
    let mut parts = vec![error.trim_end_matches('.').to_owned()];
    parts.extend(tips);
    format!(
        "{} (`{} --help` lists the options)",
        parts.join("; "),
        words.join(" ")
    )
}

/// Run the parsed command line.
pub fn execute(cli: Cli) -> Result<()> {
    match cli.command {
        None => crate::cli::run::run_scenario(&RunArgs::default()),
        Some(Command::Run(args)) => match &args.resume {
            Some(dir) => crate::cli::resume::resume_run(&args, dir),
            None => crate::cli::run::run_scenario(&args),
        },
        Some(Command::Experiment(args)) => crate::cli::experiment::run(&args),
        Some(Command::Render(args)) => {
            init_threads(args.threads)?;
            crate::cli::render::run(&args)
        }
        Some(Command::Export(args)) => crate::cli::export::run(&args),
        Some(Command::Noise(args)) => crate::cli::noise::run(&args),
        Some(Command::Paper(args)) => crate::publish::paper::run(&args),
        Some(Command::Script(args)) => crate::script::run(&args),
        Some(Command::Gallery(args)) => crate::publish::gallery::run(&args),
        Some(Command::Sweep(args)) => sweep::run(args, |argv| execute(Cli::try_parse_from(argv)?)),
    }
}
