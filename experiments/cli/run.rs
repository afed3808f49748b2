//! `smokelab run`: a scenario's configuration resolved from its defaults,
//! `--config`, the flags and `--set`, then run by the run driver into a
//! new folder under `runs/` (or `--out`), continued by `--resume` ([`crate::cli::resume`]).

use std::path::PathBuf;

use anyhow::Result;
use clap::Args;
use serde::Serialize;

use crate::cli::process::{default_run_dir, init_threads, set_running};
use crate::run::checkpoint::{RenderFlags, RunRecord};
use crate::run::frames::{FrameRender, SaveFrames};
use crate::run::output_dir;
use crate::run::{self, Checkpointing, RunOptions};
use smokelab::boundary::{BoundaryRule, ObstacleMethod};
use smokelab::density::DensityMode;
use smokelab::error::InputError;
use smokelab::io;
use smokelab::render::camera::parse_image_size;
use smokelab::scenario::{config, Scenario, ScenarioKind, SolverConfig, SolverFlags};
use smokelab::simulation::Simulation;

/// `smokelab run`.
#[derive(Debug, Default, Args)]
pub struct RunArgs {
    /// Scenario to run.
    #[arg(value_enum, default_value = "hot-cold")]
    pub scenario: ScenarioKind,
    /// TOML file with configuration keys (any of `--print-config`'s); flags override it.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// The solver's parameters, shared by every scenario.
    #[command(flatten)]
    pub solver: SolverFlags,
    /// Parameters of the sources and obstacles that have flags of their own.
    #[command(flatten)]
    pub scene: SceneFlags,
    /// Set any configuration key to a TOML value, e.g. `--set wall=1.2`
    /// or `--set 'slab_min=[2, 5, 1.5]'` (repeatable; after --config and the flags).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    pub set: Vec<String>,
    /// Print the resolved configuration as TOML and exit.
    #[arg(long)]
    pub print_config: bool,
    /// Output folder (default: a new folder under `runs/`).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Hide the progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Run into a folder that holds an earlier run, replacing its outputs
    /// (files named as a run names them); without it such a folder is refused.
    #[arg(long)]
    pub overwrite: bool,
    /// Write the whole state to `checkpoint.bin` after every K steps and
    /// after the last (atomically, the latest kept), so that `--resume` can
    /// continue the run, killed or complete.
    #[arg(long, value_name = "K")]
    pub checkpoint_every: Option<usize>,
    /// Continue the run in RUN_DIR (killed, or complete to extend it with
    /// `--frames`) from its `checkpoint.bin`, with the
    /// configuration and flags recorded there (only `--frames`, `--threads`
    /// and `--quiet` may be given; `--frames N` changes the total).
    #[arg(long, value_name = "RUN_DIR")]
    pub resume: Option<PathBuf>,
    /// Also write each saved frame as OpenVDB, `frame_NNNN.vdb` (Houdini,
    /// Blender), numbered 1, 2, 3… in the order saved.
    #[arg(long)]
    pub vdb: bool,
    /// The VDB frames' `density` grid and up axis (with --vdb).
    #[command(flatten)]
    pub vdb_flags: crate::run::export::VdbFlags,
    /// Also write each saved frame as VTK image data, `frame_NNNN.vti`, listed in `run.pvd` (ParaView).
    #[arg(long)]
    pub paraview: bool,
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

/// Flags for scenario keys that have their own (others: `--set KEY=VALUE`).
/// A flag the chosen scenario does not have is refused, naming the scenario
/// that has it.
#[derive(Debug, Default, Args, Serialize)]
pub struct SceneFlags {
    /// Radius of the injection spheres.
    #[arg(long, allow_negative_numbers = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radius: Option<f32>,
    /// Width of a smooth edge of the injection spheres (hot-cold; 0: solid, as the notes).
    #[arg(long, allow_negative_numbers = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub source_edge: Option<f32>,
    /// Horizontal offset of the sources (hot-cold, world units): hot moves
    /// by +d and cold by −d along x, so the gases collide and pass each other
    /// (default 0.5; 0: head-on, mirror-symmetric, the gases spread into a disc).
    #[arg(long, allow_negative_numbers = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offset: Option<f32>,
    /// How the pressure solve treats obstacles (slab-box): `exact` (solved
    /// over the fluid cells, no flux through closed faces) or `notes` (eqs
    /// 6.6–6.7 after a periodic projection, `--boundary-passes` times).
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub obstacles: Option<ObstacleMethod>,
    /// Obstacle rule (slab-box): reflecting (eq 6.6; exact: free slip) or
    /// sticky (eq 6.7; exact: tangential velocity in the wall scaled by α).
    #[arg(long, value_enum)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub boundary: Option<BoundaryRule>,
    /// Sticky boundary's α (slab-box): the share of normal velocity sent
    /// back (notes) or of tangential velocity carried into the wall (exact).
    #[arg(long, allow_negative_numbers = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub alpha: Option<f32>,
    /// Boundary-rule/projection pairs per step (slab-box, `--obstacles notes`).
    #[arg(long, allow_negative_numbers = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub boundary_passes: Option<usize>,
    /// Period of the prescribed flow (deformation: returns at T; zalesak: one turn).
    #[arg(long, allow_negative_numbers = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub period: Option<f32>,
    /// Initial density (deformation, zalesak): a cell-centred f32 or f64
    /// `.npy` of shape (res, res, res) instead of the scenario's sphere.
    #[arg(long, value_name = "FILE.npy")]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub initial: Option<PathBuf>,
    /// Amplitude A of the Taylor–Green vortex at t = 0 (taylor-green; its
    /// exact decay `A e^{−2νk²t}` is measured in `exact.csv`).
    #[arg(long, allow_negative_numbers = true)]
    #[serde(skip_serializing_if = "Option::is_none")]
    pub amplitude: Option<f32>,
}

/// One row of `exact.csv` (without frame and time) for a state.
type Measure = Box<dyn Fn(&Simulation) -> String>;

/// `exact.csv`: at every saved frame the run against its scenario's exact
/// solution. A prescribed-flow run measures its density
/// ([`smokelab::scenario::prescribed::Exact`]: L1 and L∞ return errors at
/// full periods, mass, volume of ρ > ½, peak); a Taylor–Green run its
/// velocity ([`smokelab::scenario::taylor_green::TaylorGreen`]: relative L2
/// and L∞ errors, kinetic energy and the exact energy). A turbulence
/// benchmark's run (`taylor-green-3d`) writes `energy.csv` instead: the
/// kinetic energy and enstrophy per unit volume and the viscous
/// dissipation `2νΩ` ([`smokelab::metrics::enstrophy`]).
struct ExactLog {
    measure: Measure,
    path: PathBuf,
    rows: String,
}

impl ExactLog {
    /// The log of scenario `config` run as `sim` (just built), if it knows
    /// an exact solution or logs its integrals.
    fn of<C: Scenario>(config: &C, sim: &Simulation, out: &std::path::Path) -> Option<Self> {
        let (file, header, measure): (_, _, Measure) = if let Some(exact) = config.exact(sim) {
            let measure = move |sim: &Simulation| {
                let m = exact.measure(sim.gases[0].density(), sim.time(), sim.params.dt);
                format!("{},{},{},{},{}", m.l1, m.linf, m.mass, m.volume, m.peak)
            };
            (
                "exact.csv",
                "l1,linf,mass,volume_half,peak",
                Box::new(measure),
            )
        } else if config.logs_integrals() {
            let measure = |sim: &Simulation| {
                let m = smokelab::metrics::enstrophy::integrals(&sim.velocity);
                let viscous = 2.0 * sim.params.viscosity as f64 * m.enstrophy;
                format!("{},{},{}", m.energy, m.enstrophy, viscous)
            };
            (
                "energy.csv",
                "energy,enstrophy,viscous_dissipation",
                Box::new(measure),
            )
        } else {
            let flow = config.exact_velocity()?;
            let measure = move |sim: &Simulation| {
                let m = flow.measure(&sim.velocity, sim.time());
                format!("{},{},{},{}", m.l2, m.linf, m.energy, m.energy_exact)
            };
            (
                "exact.csv",
                "l2,linf,energy,energy_exact",
                Box::new(measure),
            )
        };
        Some(Self {
            measure,
            path: out.join(file),
            rows: format!("frame,t,{header}\n"),
        })
    }

    /// One row for the state `sim` reached, and the file rewritten whole.
    fn record(&mut self, sim: &Simulation) -> Result<()> {
        use std::io::Write as _;
        self.rows += &format!(
            "{},{},{}\n",
            sim.step_index,
            sim.time(),
            (self.measure)(sim)
        );
        io::write_atomic(&self.path, |w| Ok(w.write_all(self.rows.as_bytes())?))
    }
}

impl RunArgs {
    /// The configuration layers this command line gives, in order: the
    /// `--config` file, the flags, the `--set` pairs.
    fn layers(&self) -> Result<Vec<(String, toml::Table)>, InputError> {
        let mut layers = Vec::new();
        if let Some(path) = &self.config {
            layers.push((
                format!("config {}", path.display()),
                config::read_toml(path)?,
            ));
        }
        let mut flags = self.solver.overrides();
        flags.extend(toml::Table::try_from(&self.scene).expect("flags serialize to a table"));
        layers.push(("flags".into(), flags));
        let mut set = toml::Table::new();
        for pair in &self.set {
            let Some((key, value)) = pair.split_once('=') else {
                return Err(InputError::new(format!(
                    "--set {pair}: give KEY=VALUE, e.g. --set wall=1.2"
                )));
            };
            // A TOML value, or else the text itself (`--set boundary=sticky`).
            let value = toml::from_str::<toml::Table>(&format!("v = {value}"))
                .ok()
                .and_then(|mut t| t.remove("v"))
                .unwrap_or_else(|| toml::Value::String(value.to_string()));
            set.insert(key.trim().to_string(), value);
        }
        layers.push(("--set".into(), set));
        Ok(layers)
    }

    /// The configuration of scenario `C`: its defaults, then `--config`, the
    /// flags and `--set`, checked.
    pub fn resolve<C: Scenario>(&self) -> Result<C, InputError> {
        config::resolve::<C>(&self.layers()?, &scenario_keys())
    }

    /// Refuse SELMA's key given on the command line to another mode than
    /// `s`'s, even at its default (the configuration refuses any other
    /// value itself).
    pub fn check_selma_remap(&self, s: &SolverConfig) -> Result<(), InputError> {
        let given = self.solver.selma_remap.is_some()
            || self
                .set
                .iter()
                .any(|p| p.split('=').next().map(str::trim) == Some("selma_remap"));
        if given && s.density != DensityMode::Selma {
            return Err(InputError::new(format!(
                "selma_remap {} is only used by --density selma (density is {})",
                s.selma_remap, s.density
            )));
        }
        Ok(())
    }
}

/// Every scenario's name and keys, in [`ScenarioKind::ALL`]'s order, for
/// naming the owner of a key another scenario does not have.
pub fn scenario_keys() -> Vec<(&'static str, Vec<String>)> {
    ScenarioKind::ALL
        .into_iter()
        .map(|kind| smokelab::with_scenario!(kind, C => (C::NAME, config::keys::<C>())))
        .collect()
}

/// `smokelab run` (without `--resume`): the scenario's configuration
/// resolved and run (the dispatch is [`smokelab::with_scenario!`]).
pub(super) fn run_scenario(args: &RunArgs) -> Result<()> {
    smokelab::with_scenario!(args.scenario, C => run_config(args, &args.resolve::<C>()?))
}

/// `--print-config`: every key with its value as TOML, then the keys that
/// are unset (TOML has no empty value: `threads`, `map_res`…, whose
/// default follows from the others) as comments, so that every key shows.
fn printed_config<C: Scenario>(config: &C) -> String {
    let mut text = toml::to_string(config).expect("a configuration serializes to TOML");
    if let Ok(serde_json::Value::Object(keys)) = serde_json::to_value(config) {
        let unset: Vec<&String> = keys
            .iter()
            .filter(|(_, v)| v.is_null())
            .map(|(k, _)| k)
            .collect();
        if !unset.is_empty() {
            text.push_str(
                "\n# Unset: each follows from the keys above unless given \
                 (`smokelab run --help` says how).\n",
            );
            for key in unset {
                text.push_str(&format!("# {key} =\n"));
            }
        }
    }
    text
}

/// Run the resolved configuration of any scenario (or print it).
fn run_config<C: Scenario>(args: &RunArgs, config: &C) -> Result<()> {
    if args.print_config {
        print!("{}", printed_config(config));
        return Ok(());
    }
    let s = config.solver();
    args.check_selma_remap(s)?;
    init_threads(s.threads)?;
    if let Some(out) = &args.out {
        output_dir::check(out, &output_dir::RUN, args.overwrite)?;
    }
    let render = frame_render(args, s)?;
    let mut sim = config.build()?;
    let vdb = vdb_frames(args, &sim)?;
    let checkpoints = match args.checkpoint_every {
        Some(0) => {
            return Err(InputError::new("--checkpoint-every is 0; it must be at least 1").into())
        }
        Some(every) => Some(Checkpointing {
            every,
            record: RunRecord {
                scenario: args.scenario,
                config: toml::to_string(config).expect("a configuration serializes to TOML"),
                checkpoint_every: every,
                vdb: args.vdb,
                vdb_frames: vdb.clone().unwrap_or_default(),
                paraview: args.paraview,
                render: args.render.then(|| RenderFlags {
                    every: args.render_every,
                    image: args.image.clone(),
                    march_step: args.march_step,
                }),
            },
            resumed_from: None,
        }),
        None => None,
    };
    let out = match &args.out {
        Some(out) => out.clone(),
        None => output_dir::create_fresh(&default_run_dir(C::NAME))?,
    };
    let _folder = output_dir::open(&out, &output_dir::RUN, args.overwrite)?;
    set_running(&out, checkpoints.is_some());
    let opts = run_options(out.clone(), s, args.quiet, render, (vdb, args.paraview));
    let mut exact = ExactLog::of(config, &sim, &out);
    let summary = match (&checkpoints, exact.as_mut()) {
        (Some(c), _) => run::run_checkpointed(&mut sim, &opts, config, s.seed, c)?,
        (None, Some(log)) => {
            run::run_with(&mut sim, &opts, config, s.seed, |sim, _| log.record(sim))?
        }
        (None, None) => run::run(&mut sim, &opts, config, s.seed)?,
    };
    println!(
        "{} ({} density): {} steps at {}³ in {:.1} s; wrote {}",
        C::NAME,
        s.density,
        s.frames,
        s.res,
        summary.wall_seconds,
        out.display()
    );
    Ok(())
}

/// What `run` (fresh or resumed) writes into `out`: the solver's frames,
/// saves and metrics cadence, the frame renders, and `(vdb, paraview)`.
pub(crate) fn run_options(
    out: PathBuf,
    s: &SolverConfig,
    quiet: bool,
    render: Option<FrameRender>,
    (vdb, paraview): (Option<crate::run::export::VdbFrames>, bool),
) -> RunOptions {
    RunOptions {
        out,
        frames: s.frames,
        save: SaveFrames::Every(s.save_every),
        progress: !quiet,
        metrics_every: s.metrics_every,
        diagnostics_every: s.diagnostics_every,
        sample_res: s.sample_res,
        render,
        vdb,
        paraview,
    }
}

/// The VDB frames `run --vdb [--density-grid sum|GAS] [--up y|z]` asks
/// for (`None` without `--vdb`; the flags without it are refused).
fn vdb_frames(
    args: &RunArgs,
    sim: &smokelab::simulation::Simulation,
) -> Result<Option<crate::run::export::VdbFrames>, InputError> {
    if !args.vdb {
        if args.vdb_flags.given() {
            return Err(InputError::new(
                "--density-grid and --up shape the VDB frames; add --vdb",
            ));
        }
        return Ok(None);
    }
    let gases: Vec<String> = sim.gases.iter().map(|g| g.name.clone()).collect();
    args.vdb_flags.resolve(&gases).map(Some)
}

/// The renders `smokelab run hot-cold --render [--render-every K]
/// [--image WxH] [--march-step S]` asks for (`None` without `--render`).
/// K defaults to the run's `save_every`; the default image is 256×256.
pub(crate) fn frame_render(
    args: &RunArgs,
    config: &SolverConfig,
) -> Result<Option<FrameRender>, InputError> {
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
