//! The `smokelab` command line (clap).
//!
//! `smokelab` with no arguments runs the hot/cold default into a new folder
//! under `runs/`. Bad input is reported as one line naming the value and what
//! is valid, with exit code 2, before anything is written.

use std::path::{Path, PathBuf};

use anyhow::Result;
use clap::{Args, Parser, Subcommand};

use crate::frames::FrameRender;
use crate::registry;
use crate::run::{self, RunOptions, SaveFrames};
use smokelab::advection::{Backtrace, Limiter, Scheme};
use smokelab::boundary::BoundaryRule;
use smokelab::density::DensityMode;
use smokelab::error::InputError;
use smokelab::io;
use smokelab::render::camera::parse_image_size;
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::slab_box::SlabBoxConfig;
use smokelab::scenario::ScenarioKind;

/// Navier–Stokes smoke with gridded, gridless and SELMA density.
#[derive(Debug, Parser)]
#[command(name = "smokelab", version, about)]
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
    Render(crate::render_command::RenderArgs),
    /// Sample a divergence-free noise onto an N³ grid (`noise.npy` + slice PNG).
    Noise(crate::noise_command::NoiseArgs),
    /// Refresh `paper/paper.md` from `results/` and build it to HTML (pandoc).
    Paper,
}

/// `smokelab run`.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Scenario to run.
    #[arg(value_enum, default_value = "hot-cold")]
    pub scenario: ScenarioKind,
    /// TOML file with scenario parameters; flags override it.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Cells per axis.
    #[arg(long, allow_negative_numbers = true)]
    pub res: Option<usize>,
    /// Number of time steps (frames).
    #[arg(long, allow_negative_numbers = true)]
    pub frames: Option<usize>,
    /// Time step Δt.
    #[arg(long, allow_negative_numbers = true)]
    pub dt: Option<f32>,
    /// Kinematic viscosity ν.
    #[arg(long, allow_negative_numbers = true)]
    pub nu: Option<f32>,
    /// Magnitude of gravity.
    #[arg(long, allow_negative_numbers = true)]
    pub gravity: Option<f32>,
    /// Radius of the injection spheres.
    #[arg(long, allow_negative_numbers = true)]
    pub radius: Option<f32>,
    /// Semi-Lagrangian backtrace.
    #[arg(long, value_enum)]
    pub backtrace: Option<Backtrace>,
    /// Advection scheme for velocity and densities.
    #[arg(long, value_enum)]
    pub advection: Option<Scheme>,
    /// QUICK density limiter.
    #[arg(long, value_enum)]
    pub limiter: Option<Limiter>,
    /// QUICK: refuse steps beyond the CFL bound instead of splitting them.
    #[arg(long)]
    pub no_substeps: bool,
    /// Obstacle rule (slab-box): reflecting (eq 6.6) or sticky (eq 6.7).
    #[arg(long, value_enum)]
    pub boundary: Option<BoundaryRule>,
    /// Fraction α of normal velocity a sticky boundary sends back (slab-box).
    #[arg(long, allow_negative_numbers = true)]
    pub alpha: Option<f32>,
    /// Boundary-rule/projection pairs per step (slab-box).
    #[arg(long, allow_negative_numbers = true)]
    pub boundary_passes: Option<usize>,
    /// Write volumes every K frames (0: metrics only).
    #[arg(long, allow_negative_numbers = true)]
    pub save_every: Option<usize>,
    /// Width of a smooth edge of the injection spheres (0: solid, as the notes).
    #[arg(long, allow_negative_numbers = true)]
    pub source_edge: Option<f32>,
    /// How the densities are held: gridded (eq 6.4), gridless (eq 7.4) or selma (eq 8.8).
    #[arg(long, value_enum)]
    pub density: Option<DensityMode>,
    /// SELMA map grid cells along the longest axis (default: --res; finer is SELMA^fine).
    #[arg(long, allow_negative_numbers = true)]
    pub map_res: Option<usize>,
    /// SELMA: re-anchor the map when its lattice has deformed by more than this many map cells (0: never).
    #[arg(long, allow_negative_numbers = true)]
    pub selma_remap: Option<f32>,
    /// Also write the densities sampled at this resolution (`<gas>_fine_NNNN.npy`).
    #[arg(long, allow_negative_numbers = true)]
    pub sample_res: Option<usize>,
    /// Fine-sampled density metrics every K steps (costly for gridless; default 1).
    #[arg(long, allow_negative_numbers = true)]
    pub metrics_every: Option<usize>,
    /// Run even if the memory estimate exceeds the available memory.
    #[arg(long)]
    pub force: bool,
    /// Random seed.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Output folder (default: a new folder under `runs/`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Worker threads (default: all cores).
    #[arg(long)]
    pub threads: Option<usize>,
    /// Hide the progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Volume-render frames to render_NNNN.exr/.png.
    #[arg(long)]
    pub render: bool,
    /// Render every K frames and the last (default: --save-every).
    #[arg(long, requires = "render", allow_negative_numbers = true)]
    pub render_every: Option<usize>,
    /// Render image size WxH (default 256x256).
    #[arg(long, requires = "render")]
    pub image: Option<String>,
    /// Render march step Δs (default: the cell size).
    #[arg(long, requires = "render", allow_negative_numbers = true)]
    pub march_step: Option<f32>,
}

impl Default for RunArgs {
    fn default() -> Self {
        Self {
            scenario: ScenarioKind::HotCold,
            config: None,
            res: None,
            frames: None,
            dt: None,
            nu: None,
            gravity: None,
            radius: None,
            backtrace: None,
            advection: None,
            limiter: None,
            no_substeps: false,
            boundary: None,
            alpha: None,
            boundary_passes: None,
            save_every: None,
            source_edge: None,
            density: None,
            map_res: None,
            selma_remap: None,
            sample_res: None,
            metrics_every: None,
            force: false,
            seed: None,
            out: None,
            threads: None,
            quiet: false,
            render: false,
            render_every: None,
            image: None,
            march_step: None,
        }
    }
}

impl RunArgs {
    /// The hot/cold configuration: defaults, then the TOML file, then flags.
    pub fn hot_cold_config(&self) -> Result<HotColdConfig, InputError> {
        let mut c = match &self.config {
            Some(path) => HotColdConfig::from_toml_file(path)?,
            None => HotColdConfig::default(),
        };
        macro_rules! take {
            ($($f:ident),*) => { $( if let Some(v) = self.$f { c.$f = v; } )* };
        }
        take!(
            res,
            frames,
            dt,
            nu,
            gravity,
            radius,
            backtrace,
            save_every,
            source_edge,
            density,
            selma_remap,
            metrics_every,
            seed
        );
        take!(advection, limiter);
        if self.no_substeps {
            c.substeps = false;
        }
        if self.map_res.is_some() {
            c.map_res = self.map_res;
        }
        if self.sample_res.is_some() {
            c.sample_res = self.sample_res;
        }
        c.force |= self.force;
        for (flag, given) in [
            ("--boundary", self.boundary.is_some()),
            ("--alpha", self.alpha.is_some()),
            ("--boundary-passes", self.boundary_passes.is_some()),
        ] {
            if given {
                return Err(InputError::new(format!(
                    "{flag} applies to slab-box only; hot-cold has no obstacles"
                )));
            }
        }
        c.validate()?;
        Ok(c)
    }

    /// The slab-box configuration: defaults, then the TOML file, then flags.
    pub fn slab_box_config(&self) -> Result<SlabBoxConfig, InputError> {
        let mut c = match &self.config {
            Some(path) => SlabBoxConfig::from_toml_file(path)?,
            None => SlabBoxConfig::default(),
        };
        macro_rules! take {
            ($($f:ident),*) => { $( if let Some(v) = self.$f { c.$f = v; } )* };
        }
        take!(res, frames, dt, nu, gravity, radius, backtrace, save_every, seed);
        take!(advection, limiter, boundary, alpha, boundary_passes);
        if self.no_substeps {
            c.substeps = false;
        }
        for (flag, given) in [
            (
                "--density",
                self.density.is_some_and(|d| d != DensityMode::Gridded),
            ),
            ("--map-res", self.map_res.is_some()),
            ("--selma-remap", self.selma_remap.is_some()),
            ("--sample-res", self.sample_res.is_some()),
            ("--source-edge", self.source_edge.is_some()),
        ] {
            if given {
                return Err(InputError::new(format!(
                    "{flag} applies to hot-cold only; slab-box holds its gas on the grid (--density gridded)"
                )));
            }
        }
        if self.metrics_every == Some(0) {
            return Err(InputError::new(
                "--metrics-every 0: give a step count ≥ 1".to_string(),
            ));
        }
        c.validate()?;
        Ok(c)
    }
}

/// `smokelab experiment`.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// Experiment id, e.g. `06-1` (see `--list`), or `all` to run every one in turn.
    pub id: Option<String>,
    /// List the experiments and what they reproduce.
    #[arg(long)]
    pub list: bool,
    /// Output folder (default: `results/<id>/`; with `all`, the parent of
    /// one folder per experiment, default `results/`).
    #[arg(long)]
    pub out: Option<PathBuf>,
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
}

/// Set the number of rayon worker threads (once per process).
fn init_threads(threads: Option<usize>) -> Result<(), InputError> {
    if let Some(n) = threads {
        if n == 0 {
            return Err(InputError::new("--threads is 0; it must be at least 1"));
        }
        // A second call (e.g. in tests) keeps the first pool; that is fine.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global();
    }
    Ok(())
}

/// Run the parsed command line.
pub fn execute(cli: Cli) -> Result<()> {
    match cli.command {
        None => run_scenario(&RunArgs::default()),
        Some(Command::Run(args)) => run_scenario(&args),
        Some(Command::Experiment(args)) => run_experiment(&args),
        Some(Command::Render(args)) => {
            init_threads(args.threads)?;
            crate::render_command::run(&args)
        }
        Some(Command::Noise(args)) => crate::noise_command::run(&args),
        Some(Command::Paper) => crate::paper::build(Path::new(".")),
    }
}

fn run_scenario(args: &RunArgs) -> Result<()> {
    init_threads(args.threads)?;
    match args.scenario {
        ScenarioKind::HotCold => {
            let config = args.hot_cold_config()?;
            let out = args
                .out
                .clone()
                .unwrap_or_else(|| default_run_dir("hot-cold"));
            io::check_output_dir(&out)?;
            let render = frame_render(args, &config)?;
            let mut sim = config.build()?;
            io::create_output_dir(&out)?;
            let opts = RunOptions {
                out: out.clone(),
                frames: config.frames,
                save: SaveFrames::Every(config.save_every),
                progress: !args.quiet,
                metrics_every: config.metrics_every,
                sample_res: config.sample_res,
                render,
            };
            let summary = run::run(&mut sim, &opts, &config, config.seed)?;
            println!(
                "hot-cold ({} density): {} steps at {}³ in {:.1} s; wrote {}",
                config.density,
                config.frames,
                config.res,
                summary.wall_seconds,
                out.display()
            );
        }
        ScenarioKind::SlabBox => {
            let config = args.slab_box_config()?;
            if args.render {
                return Err(InputError::new(
                    "--render is not available for slab-box yet; use the slices (preview_NNNN.png) or `smokelab render` on the volumes",
                )
                .into());
            }
            let out = args
                .out
                .clone()
                .unwrap_or_else(|| default_run_dir("slab-box"));
            io::check_output_dir(&out)?;
            let mut sim = config.build()?;
            io::create_output_dir(&out)?;
            let opts = RunOptions {
                out: out.clone(),
                frames: config.frames,
                save: SaveFrames::Every(config.save_every),
                progress: !args.quiet,
                metrics_every: args.metrics_every.unwrap_or(1),
                sample_res: None,
                render: None,
            };
            let summary = run::run(&mut sim, &opts, &config, config.seed)?;
            println!(
                "slab-box: {} steps at {}³ in {:.1} s; wrote {}",
                config.frames,
                config.res,
                summary.wall_seconds,
                out.display()
            );
        }
    }
    Ok(())
}

fn default_run_dir(name: &str) -> PathBuf {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    PathBuf::from("runs").join(format!("{name}-{secs}"))
}

fn run_experiment(args: &ExperimentArgs) -> Result<()> {
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
        registry::Size::Full
    } else if args.smoke {
        registry::Size::Smoke
    } else {
        registry::Size::Default
    };
    if id == "all" {
        let parent = args.out.clone().unwrap_or_else(|| PathBuf::from("results"));
        io::check_output_dir(&parent)?;
        return run_all_experiments(&parent, size, !args.quiet);
    }
    let exp = registry::find(id)?;
    let out = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("results").join(exp.folder));
    io::check_output_dir(&out)?;
    let ctx = registry::Context {
        out: out.clone(),
        size,
        progress: !args.quiet,
    };
    let start = std::time::Instant::now();
    (exp.run)(&ctx)?;
    println!(
        "experiment {} ({}) finished in {:.1} s; wrote {}",
        exp.id,
        exp.reproduces,
        start.elapsed().as_secs_f64(),
        out.display()
    );
    Ok(())
}

/// `smokelab experiment all`: every experiment in the notes' order into
/// `parent/<folder>/`, going on past failures, then a table of what ran, how
/// long and where it wrote — printed and saved as `parent/experiments.csv`.
fn run_all_experiments(
    parent: &std::path::Path,
    size: registry::Size,
    progress: bool,
) -> Result<()> {
    let mut rows = Vec::new();
    for exp in registry::ALL {
        let out = parent.join(exp.folder);
        println!("== experiment {} ({})", exp.id, exp.reproduces);
        let ctx = registry::Context {
            out: out.clone(),
            size,
            progress,
        };
        let start = std::time::Instant::now();
        let status = match (exp.run)(&ctx) {
            Ok(()) => "ok".to_string(),
            Err(e) => {
                eprintln!("experiment {} failed: {e:#}", exp.id);
                format!("failed: {e}")
            }
        };
        rows.push((exp, start.elapsed().as_secs_f64(), out, status));
    }
    let mut table = format!(
        "{:<7} {:<22} {:>9}  {:<28} {}\n",
        "id", "reproduces", "seconds", "output", "status"
    );
    let mut csv = String::from("id,reproduces,seconds,output,status\n");
    for (exp, secs, out, status) in &rows {
        table.push_str(&format!(
            "{:<7} {:<22} {:>9.1}  {:<28} {}\n",
            exp.id,
            exp.reproduces,
            secs,
            out.display(),
            status
        ));
        csv.push_str(&format!(
            "{},\"{}\",{:.1},{},\"{}\"\n",
            exp.id,
            exp.reproduces,
            secs,
            out.display(),
            status.replace('"', "'")
        ));
    }
    print!("{table}");
    io::create_output_dir(parent)?;
    io::write_atomic(&parent.join("experiments.csv"), |w| {
        use std::io::Write;
        Ok(w.write_all(csv.as_bytes())?)
    })?;
    let failed: Vec<_> = rows
        .iter()
        .filter(|r| r.3 != "ok")
        .map(|r| r.0.id)
        .collect();
    if !failed.is_empty() {
        anyhow::bail!("experiments failed: {}", failed.join(", "));
    }
    Ok(())
}

/// The renders `smokelab run hot-cold --render [--render-every K]
/// [--image WxH] [--march-step S]` asks for (`None` without `--render`).
/// K defaults to the run's `save_every`; the default image is 256×256.
fn frame_render(args: &RunArgs, config: &HotColdConfig) -> Result<Option<FrameRender>, InputError> {
    if !args.render {
        return Ok(None);
    }
    let every = args.render_every.unwrap_or(config.save_every);
    if every == 0 {
        return Err(InputError::new(match args.render_every {
            Some(_) => "--render-every is 0; it must be at least 1",
            None => {
                "--render renders every --save-every frames, which is 0; give --render-every K ≥ 1"
            }
        }));
    }
    let image = match &args.image {
        Some(s) => parse_image_size(s)?,
        None => (256, 256),
    };
    FrameRender::new(
        SaveFrames::Every(every),
        image,
        args.march_step,
        &config.domain()?,
    )
    .map(Some)
}
