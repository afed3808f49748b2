//! Driving a [`Simulation`] through its frames and writing what it produced.
//!
//! Output folder layout (see the README):
//! - `<gas>_NNNN.npy` — f32 `(nz, ny, nx)` density at the velocity grid's cell
//!   centres, whatever the density mode, so runs compare file by file;
//! - `<gas>_fine_NNNN.npy` — the density sampled at `sample_res` (if asked);
//! - `vel_NNNN.npy` — f32 `(nz, ny, nx, 3)` velocity, as the projection left it;
//! - `preview_NNNN.png` — mid-plane slice of the gases (obstacles grey);
//! - `render_NNNN.exr`, `render_NNNN.png` — volume renders (with `--render`);
//! - `frame_NNNN.vdb` — with `--vdb`: OpenVDB, a fog volume per gas, the
//!   fog volume `density` (the gases' sum, or `--density-grid GAS`), the
//!   vec3s grid `vel` and, with obstacles, the level set `obstacle`
//!   (negative inside); voxel `(0,0,0)` at the first cell centre (`--up z`
//!   rotates it all for z-up hosts). `NNNN` is the *sequence number*
//!   `⌈N/K⌉` of the frame saved after step `N` with `--save-every K`, so
//!   the files count 1, 2, 3… as Blender's and Houdini's sequence
//!   detection needs ([`crate::run::export`]);
//! - `frame_NNNN.vti`, `run.pvd` — with `--paraview`: VTK image data (cell
//!   data: the gases, `obstacle` and `vel`), numbered as the VDB files, and
//!   the time series ParaView opens;
//! - `obstacle.npy` — f32 `(nz, ny, nx)` obstacle level set at the cell
//!   centres, positive inside, world units (runs with obstacles);
//! - `metrics.csv` — one row per step ([`MetricsRow`]), appended and flushed
//!   as each step ends; the fine measures ([`FineMeasures`]) are computed
//!   every `metrics_every` steps and at the last, `NaN` in between, and the
//!   step diagnostics ([`StepMeasures`]) every `diagnostics_every` steps
//!   and at the last, `NaN` in between;
//! - `checkpoint.bin` — with `--checkpoint-every K`: the whole state after
//!   the latest K-th step and after the last ([`crate::run::checkpoint`]), for
//!   `run --resume` (a complete run resumes from its last frame);
//! - `manifest.json` — configuration, machine, commit, wall time, peak memory;
//!   written at the start with `"status": "running"`, rewritten at the end
//!   with `"status": "complete"`, or `"failed"` and the error if a step fails.
//!
//! Frame `N` is the state after `N` steps.

pub mod checkpoint;
pub mod export;
pub mod frames;
pub mod output_dir;
pub mod progress;

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Result};
use glam::Vec3;
use serde::Serialize;

use crate::figures::table::{field_names, Log};
use crate::run::checkpoint::RunRecord;
use crate::run::export::{write_frame_formats, Exchange, FrameVolumes, VdbFrames};
use crate::run::frames::{FrameRecord, FrameRender, SaveFrames};
use smokelab::boundary::Boundary;
use smokelab::density::probe::{DensityMeasures, DensityProbe};
use smokelab::density::{DensityMode, DensityModel};
use smokelab::domain::Domain;
use smokelab::grid::{BoxKind, ScalarGrid};
use smokelab::io::vdb::VolumeGeometry;
use smokelab::io::vtk::PvdCollection;
use smokelab::io::{self, manifest::Manifest, preview};
use smokelab::metrics::{self, SpectralShare};
use smokelab::simulation::{Gas, Simulation};
use smokelab::timing::{timed, StageTimes};

/// Which frames to write and how to report progress.
#[derive(Clone, Debug)]
pub struct RunOptions {
    /// Output folder (created by the caller after validation).
    pub out: PathBuf,
    /// Steps to take.
    pub frames: usize,
    /// Frames to write volumes and previews for.
    pub save: SaveFrames,
    /// Show a progress bar on stderr.
    pub progress: bool,
    /// Compute the fine measures ([`FineMeasures`]) every this many steps
    /// (and at the last); they are the expensive part of a gridless run.
    pub metrics_every: usize,
    /// Compute the step diagnostics ([`StepMeasures`]) every this many
    /// steps (and at the last).
    pub diagnostics_every: usize,
    /// Also write each gas sampled with this many cells along the longest axis.
    pub sample_res: Option<usize>,
    /// Frames to volume-render, and how (`None`: no renders).
    pub render: Option<FrameRender>,
    /// Also write each saved frame as OpenVDB (`frame_NNNN.vdb`), shaped so.
    pub vdb: Option<VdbFrames>,
    /// Also write each saved frame as VTK image data (`frame_NNNN.vti`,
    /// listed with its time in `run.pvd`) for ParaView.
    pub paraview: bool,
}

/// Where the run's arrays live in the world, for tools that read them back
/// (`smokelab render`, ParaView, Houdini).
#[derive(Clone, Debug, Serialize)]
pub struct GridRecord {
    /// Lower corner of the box.
    pub origin: [f32; 3],
    /// Edge Δx of a cubic cell.
    pub cell: f32,
    /// Cells `[nx, ny, nz]`; `.npy` arrays are `(nz, ny, nx)`.
    pub dims: [usize; 3],
    /// Where the samples sit: velocity on the faces, densities at the cell centres.
    pub layout: &'static str,
    /// The boundary of the box: `periodic` or `closed`.
    pub boundary: &'static str,
}

/// What a run wrote and what it cost.
#[derive(Clone, Debug, Serialize)]
pub struct RunSummary {
    /// The grid the arrays are sampled on.
    pub grid: GridRecord,
    /// The gases, in the run's order: each saved frame has `<gas>_NNNN.npy`.
    pub gases: Vec<String>,
    /// Wall time of the whole run, seconds.
    pub wall_seconds: f64,
    /// Frames whose volumes were written.
    pub saved_frames: Vec<usize>,
    /// Preview images written, in frame order.
    pub previews: Vec<PathBuf>,
    /// Seconds per stage summed over the run.
    pub stage_seconds: smokelab::timing::StageTimes,
    /// Mirror-symmetry error at the last step (two-gas scenarios).
    pub final_mirror_error: Option<f32>,
    /// How the densities were held.
    pub density_mode: DensityMode,
    /// Bytes held by the density representations at the last step.
    pub final_density_bytes: usize,
    /// Per gas, `∫S dV`, the injection per unit time of every density mode
    /// ([`smokelab::simulation::Gas::injected_per_step`]; the `<g>_injected`
    /// column is this times the simulated time).
    pub source_rates: Vec<f64>,
    /// Per gas, the fine-sampled measures at the last step.
    pub final_measures: Vec<DensityMeasures>,
    /// Volume renders written, in frame order, with their statistics
    /// (of a resumed run: those after the checkpoint).
    pub renders: Vec<FrameRecord>,
    /// The checkpoint step a resumed run continued from (`wall_seconds`,
    /// `stage_seconds` and `renders` then cover the steps after it).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub resumed_from: Option<usize>,
}

/// Checkpoints of a run, and the step it resumes from ([`run_checkpointed`]).
#[derive(Clone, Debug)]
pub struct Checkpointing {
    /// Write `checkpoint.bin` after every this many steps (not after the last).
    pub every: usize,
    /// What the checkpoint records to continue the run.
    pub record: RunRecord,
    /// The step of the checkpoint the simulation was restored from
    /// (`None`: a fresh run); `metrics.csv` must hold exactly its rows.
    pub resumed_from: Option<usize>,
}

/// Fixed random points at which the interpolant's divergence is measured.
pub const PROBE_POINTS: usize = 4096;

/// The step diagnostics, taken every `diagnostics_every` steps: one pass
/// over the faces and one over the two gases' cells.
pub struct StepMeasures {
    /// The compact divergence after projection, the velocity's mirror
    /// error and `max |u_a|`.
    pub velocity: metrics::VelocityStats,
    /// The two gases' mirror error (two gases only).
    pub mirror: Option<f32>,
}

impl StepMeasures {
    /// Measure `sim`'s current state.
    pub fn take(sim: &Simulation) -> Self {
        Self {
            velocity: metrics::velocity_stats(&sim.velocity),
            mirror: (sim.gases.len() == 2)
                .then(|| metrics::mirror_error(sim.gases[0].density(), sim.gases[1].density())),
        }
    }
}

/// The measures taken every `metrics_every` steps (and at the last): the
/// ones that sample finely, take spectra or differentiate.
pub struct FineMeasures {
    /// Each gas sampled at 2× and measured by [`DensityProbe`].
    pub densities: Vec<DensityMeasures>,
    /// The top-octave share of the kinetic energy (`NaN` in a closed box,
    /// where the periodic spectrum is not defined).
    pub ke_top_octave: f64,
    /// The divergence tracers feel, relative to `|∇u|`, at [`PROBE_POINTS`]
    /// fixed random points.
    pub div_interp: metrics::RmsMax,
    /// The divergence of the velocity's interpolant differentiated exactly
    /// at the same points, relative to `max|u|/Δx`
    /// ([`metrics::face_pointwise_divergence`]).
    pub div_point: metrics::RmsMax,
}

/// The state of the fine measures on one grid, made once per run: the
/// probe points, the 2× density probe and the spectrum's plans.
pub struct FineProbes {
    points: Vec<Vec3>,
    density: DensityProbe,
    spectrum: SpectralShare,
}

impl FineProbes {
    /// Probes for a run on `domain`.
    pub fn new(domain: Domain) -> Self {
        Self {
            points: metrics::probe_points(&domain, PROBE_POINTS, 1),
            density: DensityProbe::new(domain),
            spectrum: SpectralShare::new(domain.dims),
        }
    }

    /// The [`FineMeasures`] of `sim`'s current state (gridless gases
    /// sampled with one walk for all).
    pub fn measure(&mut self, sim: &Simulation) -> FineMeasures {
        let models: Vec<&DensityModel> = sim.gases.iter().map(|g| &g.model).collect();
        FineMeasures {
            densities: self.density.measure_all(&models),
            ke_top_octave: if sim.velocity.kind() == BoxKind::Periodic {
                metrics::top_octave_share(&mut self.spectrum, &sim.velocity)
            } else {
                f64::NAN
            },
            div_interp: metrics::face_interpolant_divergence(&sim.velocity, &self.points),
            div_point: metrics::face_pointwise_divergence(&sim.velocity, &self.points),
        }
    }
}

/// A CFL number `max|u| Δt/Δx` beyond which a run warns (once): the
/// semi-Lagrangian step stays stable at any CFL number, but a departure
/// point this many cells away leaves the flow unresolved.
pub const CFL_WARNING: f32 = 10.0;

/// One row of `metrics.csv`: its fields, in order, are the columns (nested
/// parts flattened; [`metric_columns`] names them):
/// - `step, time`, then the diagnostics `max_u, cfl, div_rms, div_max` (the
///   discrete divergence the projection zeroes) on their cadence
///   (`diagnostics_every`, `NaN` between), `div_interp_rms, div_interp_max` (the divergence of
///   the velocity's point query at [`PROBE_POINTS`] fixed random points,
///   relative to the rms of `|∇u|` there —
///   [`metrics::interpolant_divergence`]), `div_point_rms, div_point_max`
///   (the interpolant's divergence differentiated exactly at the same
///   points, relative to `max|u|/Δx` —
///   [`metrics::face_pointwise_divergence`]), `ke_top_octave` (share of the
///   kinetic energy with a wavenumber index beyond `N/4` on some axis: the top
///   octave, grid-scale flow); these two on the fine-measure cadence, `NaN`
///   between;
/// - per gas `<g>_mass` (∫ρ at 2× the velocity grid), `<g>_injected`
///   (`∫S dV · t`, the same in every mode: gridless and SELMA evaluate `S`
///   anywhere, a gridded density adds the cell averages of `S` whose total
///   is that integral — [`smokelab::simulation::SOURCE_REFINE`]), `<g>_lost`
///   (`injected − mass`), `<g>_advection` and `<g>_cleared` (gridded:
///   cumulative change of `Σ ρ Δx³` by advection and by clearing the dry
///   cells, every step, so `mass = injected + advection + cleared` to
///   rounding — [`smokelab::simulation::MassBudget`]; `NaN` for gridless and
///   SELMA), `<g>_max` (peak ρ at 2×), `<g>_grad` (mean |∇ρ| at 2×),
///   `<g>_subgrid` (share of spectral energy beyond the velocity grid's
///   Nyquist index) — see [`smokelab::density::probe`]; the fine measures
///   are `NaN` on steps without them;
/// - `mirror_error` (two gases; densities at the cell centres),
///   `vel_mirror_error` ([`metrics::velocity_stats`]) — diagnostics, on
///   their cadence — `density_bytes`
///   (all gases' representations, shared buffers once), `substeps` (QUICK);
/// - with obstacles, [`ObstacleColumns`];
/// - wall seconds per stage, [`StageColumns`].
#[derive(Serialize)]
struct MetricsRow {
    step: StepColumns,
    gases: Vec<GasColumns>,
    /// One value with two gases, none otherwise.
    mirror_error: Vec<f32>,
    flow: FlowColumns,
    /// One entry with obstacles, none otherwise.
    obstacles: Vec<ObstacleColumns>,
    times: StageColumns,
}

/// The step and the velocity's measures.
#[derive(Default, Serialize)]
struct StepColumns {
    step: usize,
    time: f32,
    max_u: f32,
    cfl: f32,
    div_rms: f32,
    div_max: f32,
    div_interp_rms: f32,
    div_interp_max: f32,
    div_point_rms: f32,
    div_point_max: f32,
    ke_top_octave: f64,
}

/// One gas's measures; the columns are prefixed with the gas's name.
#[derive(Default, Serialize)]
struct GasColumns {
    mass: f64,
    injected: f64,
    lost: f64,
    advection: f64,
    cleared: f64,
    max: f64,
    grad: f64,
    subgrid: f64,
}

/// Symmetry, memory and QUICK sub-steps.
#[derive(Default, Serialize)]
struct FlowColumns {
    vel_mirror_error: f32,
    density_bytes: usize,
    substeps: usize,
}

/// How well obstacles hold ([`Leak`]), the obstacle-aware solve and QUICK's
/// open-face projection.
#[derive(Default, Serialize)]
pub struct ObstacleColumns {
    /// Flux divergence `D_A u` over the wet cells, rms and max.
    div_fluid_rms: f32,
    div_fluid_max: f32,
    /// Largest speed through a closed face beside the fluid.
    closed_flux_max: f32,
    /// Density in the dry cells (inside obstacles, any depth), and its share.
    obstacle_mass: f64,
    obstacle_fraction: f64,
    /// Gas in the fluid (`Σ ρ Δx³` over the wet cells, all gases) over the
    /// gas injected (`Σ <g>_injected`).
    retained: f64,
    /// The obstacle-aware solve (exact obstacles; 0 and NaN with the notes'
    /// method): conjugate-gradient iterations and relative residual.
    cg_iterations: usize,
    cg_residual: f64,
    /// QUICK's face projection: CG iterations and relative residual.
    face_cg_iterations: usize,
    face_div_rel: f32,
}

/// Wall seconds per stage of the step (see [`smokelab::timing::StageTimes`]).
#[derive(Default, Serialize)]
struct StageColumns {
    t_advect: f64,
    t_inject: f64,
    t_density: f64,
    t_force: f64,
    t_project: f64,
    t_boundary: f64,
    t_output: f64,
    t_metrics: f64,
}

impl From<StageTimes> for StageColumns {
    fn from(t: StageTimes) -> Self {
        Self {
            t_advect: t.advect,
            t_inject: t.inject,
            t_density: t.density,
            t_force: t.force,
            t_project: t.project,
            t_boundary: t.boundary,
            t_output: t.output,
            t_metrics: t.metrics,
        }
    }
}

/// Column names of `metrics.csv` for a simulation: the field names of
/// [`MetricsRow`]'s parts, in order.
pub fn metric_columns(sim: &Simulation) -> Vec<String> {
    let mut cols = field_names(&StepColumns::default());
    let gas = field_names(&GasColumns::default());
    for g in &sim.gases {
        cols.extend(gas.iter().map(|m| format!("{}_{m}", g.name)));
    }
    if sim.gases.len() == 2 {
        cols.push("mirror_error".into());
    }
    cols.extend(field_names(&FlowColumns::default()));
    if sim.boundary.is_some() {
        cols.extend(field_names(&ObstacleColumns::default()));
    }
    cols.extend(field_names(&StageColumns::default()));
    cols
}

impl MetricsRow {
    /// The row of `sim` after step `frame`: the diagnostics `measures` and
    /// the `fine` measures on their cadences (`NaN` without), the gases' budgets
    /// against their injection `t · rate` (`source_rates`, per gas), the
    /// obstacles' leaks and solves, and the stage times.
    fn measure(
        sim: &Simulation,
        frame: usize,
        measures: Option<&StepMeasures>,
        fine: Option<&FineMeasures>,
        source_rates: &[f64],
        times: StageTimes,
    ) -> Self {
        let nan = f32::NAN;
        let (div, vel_mirror) = measures.map_or(
            (
                metrics::RmsMax { rms: nan, max: nan },
                metrics::VelocityMirror {
                    error: nan,
                    max_norm: nan,
                },
            ),
            |m| (m.velocity.divergence, m.velocity.mirror),
        );
        let max_u = vel_mirror.max_norm;
        let t = frame as f64 * sim.params.dt as f64;
        let gases = (sim.gases.iter().zip(source_rates).enumerate())
            .map(|(n, (g, rate))| GasColumns::measure(g, fine.map(|f| f.densities[n]), t * rate))
            .collect();
        let injected_total = t * source_rates.iter().sum::<f64>();
        let obstacles =
            (sim.boundary.as_ref()).map(|b| ObstacleColumns::measure(sim, b, injected_total));
        Self {
            step: StepColumns {
                step: frame,
                time: sim.time(),
                max_u,
                cfl: max_u * sim.params.dt / sim.domain().cell,
                div_rms: div.rms,
                div_max: div.max,
                div_interp_rms: fine.map_or(f32::NAN, |f| f.div_interp.rms),
                div_interp_max: fine.map_or(f32::NAN, |f| f.div_interp.max),
                div_point_rms: fine.map_or(f32::NAN, |f| f.div_point.rms),
                div_point_max: fine.map_or(f32::NAN, |f| f.div_point.max),
                ke_top_octave: fine.map_or(f64::NAN, |f| f.ke_top_octave),
            },
            gases,
            mirror_error: match measures {
                Some(m) => m.mirror.into_iter().collect(),
                None => (sim.gases.len() == 2)
                    .then_some(f32::NAN)
                    .into_iter()
                    .collect(),
            },
            flow: FlowColumns {
                vel_mirror_error: vel_mirror.error,
                density_bytes: sim.density_bytes(),
                substeps: sim.advector().substeps(),
            },
            obstacles: obstacles.into_iter().collect(),
            times: times.into(),
        }
    }
}

impl GasColumns {
    /// Gas `g`'s columns: its fine measures `m` (`NaN` without) against the
    /// mass `injected` so far; the budget terms of a gridded gas (`NaN`
    /// for the others).
    fn measure(g: &Gas, m: Option<DensityMeasures>, injected: f64) -> Self {
        let on_grid = |v: f64| {
            if g.model.mode() == DensityMode::Gridded {
                v
            } else {
                f64::NAN
            }
        };
        let mass = m.map_or(f64::NAN, |m| m.mass);
        Self {
            mass,
            injected,
            lost: injected - mass,
            advection: on_grid(g.budget.advection),
            cleared: on_grid(g.budget.cleared),
            max: m.map_or(f64::NAN, |m| m.max),
            grad: m.map_or(f64::NAN, |m| m.mean_gradient),
            subgrid: m.map_or(f64::NAN, |m| m.subgrid_fraction),
        }
    }
}

impl ObstacleColumns {
    /// The obstacles' columns of `sim` with boundary `b`, the gas retained
    /// against `injected` (all gases).
    fn measure(sim: &Simulation, b: &Boundary, injected: f64) -> Self {
        let densities: Vec<_> = sim.gases.iter().map(|g| g.density()).collect();
        let leak = b.leak(&sim.velocity, &densities);
        let (iterations, residual) = sim.advector().face_projection_stats().unwrap_or((0, 0.0));
        let cg = sim.cg_report();
        Self {
            div_fluid_rms: leak.div_fluid.rms,
            div_fluid_max: leak.div_fluid.max,
            closed_flux_max: leak.closed_flux_max,
            obstacle_mass: leak.mass_inside,
            obstacle_fraction: leak.mass_fraction,
            retained: leak.mass_fluid / injected,
            cg_iterations: cg.map_or(0, |c| c.iterations),
            cg_residual: cg.map_or(f64::NAN, |c| c.residual),
            face_cg_iterations: iterations,
            face_div_rel: residual,
        }
    }
}

/// Take step `frame` of `sim`, or fail naming it (a refused step, or a
/// velocity that became non-finite) and where the frames so far are.
fn step(sim: &mut Simulation, frame: usize, out: &Path) -> Result<()> {
    if let Err(e) = sim.try_step() {
        bail!(
            "step {frame}: {e}; frames written so far are in {}",
            out.display()
        );
    }
    if !sim.velocity.is_finite() {
        bail!(
            "velocity became non-finite at step {frame}; frames written so far are in {}",
            out.display()
        );
    }
    Ok(())
}

/// Step `sim` through `opts.frames` frames, writing into `opts.out`.
///
/// Stops with an error naming the step if the velocity becomes non-finite;
/// frames written before that stay.
pub fn run<C: Serialize>(
    sim: &mut Simulation,
    opts: &RunOptions,
    config: &C,
    seed: u64,
) -> Result<RunSummary> {
    run_with(sim, opts, config, seed, |_, _| Ok(()))
}

/// [`run`] writing checkpoints, or continuing from one: a resumed run
/// appends to `metrics.csv` after the checkpoint's row and reaches the
/// frames and metrics rows of an uninterrupted run bitwise.
pub fn run_checkpointed<C: Serialize>(
    sim: &mut Simulation,
    opts: &RunOptions,
    config: &C,
    seed: u64,
    checkpoints: &Checkpointing,
) -> Result<RunSummary> {
    drive(sim, opts, config, seed, Some(checkpoints), |_, _| Ok(()))
}

/// [`run`], calling `at_saved(sim, frame)` after each saved frame is written
/// (experiments capture their images there); its time counts as output.
pub fn run_with<C: Serialize>(
    sim: &mut Simulation,
    opts: &RunOptions,
    config: &C,
    seed: u64,
    at_saved: impl FnMut(&Simulation, usize) -> Result<()>,
) -> Result<RunSummary> {
    drive(sim, opts, config, seed, None, at_saved)
}

/// The progress bar of a run's steps, at step `first`: its cost grows with
/// the step if a gas is gridless (a gridless step walks back through every
/// velocity grid so far).
fn progress_bar(sim: &Simulation, opts: &RunOptions, first: usize) -> crate::run::progress::Stage {
    let growth = sim
        .gases
        .iter()
        .map(|g| crate::run::progress::growth_of(g.model.mode()))
        .max_by_key(|g| *g == crate::run::progress::Growth::Linear)
        .unwrap_or(crate::run::progress::Growth::Constant);
    let name = crate::run::progress::stage_name(&opts.out);
    let mut bar = crate::run::progress::stage(&name, opts.frames as u64, growth, opts.progress);
    bar.set_position(first as u64);
    bar
}

/// `run.pvd` with the frames saved before step one of this process (those
/// of a resumed run before its checkpoint), if ParaView files are asked for.
fn paraview_collection(
    opts: &RunOptions,
    dt: f32,
    saved_frames: &[usize],
) -> Result<Option<PvdCollection>> {
    if !opts.paraview {
        return Ok(None);
    }
    let mut pvd = PvdCollection::new(opts.out.join("run.pvd"));
    for &f in saved_frames {
        // As `write_frame_formats` lists it: the f32 time's shortest decimal.
        let time: f64 = (f as f32 * dt).to_string().parse()?;
        let n = opts.save.sequence(f);
        pvd.push(time, &crate::run::export::sequence_file(n, "vti"))?;
    }
    Ok(Some(pvd))
}

impl RunSummary {
    /// The summary of a run of `sim` before its first step: its grid and
    /// gases, and the frames a run resumed at `resumed_from` saved before.
    fn start(sim: &Simulation, opts: &RunOptions, resumed_from: Option<usize>) -> Self {
        let domain = *sim.domain();
        let mut summary = RunSummary {
            grid: GridRecord {
                origin: domain.origin.to_array(),
                cell: domain.cell,
                dims: domain.dims,
                layout: "MAC: u, v, w on the x-, y-, z-faces; densities at cell centres",
                boundary: sim.velocity.kind().name(),
            },
            gases: sim.gases.iter().map(|g| g.name.clone()).collect(),
            wall_seconds: 0.0,
            saved_frames: vec![],
            previews: vec![],
            stage_seconds: Default::default(),
            final_mirror_error: None,
            density_mode: sim
                .gases
                .first()
                .map_or_else(Default::default, |g| g.model.mode()),
            final_density_bytes: 0,
            source_rates: sim.gases.iter().map(|g| g.injected_per_step(1.0)).collect(),
            final_measures: vec![],
            renders: vec![],
            resumed_from,
        };
        // The frames a resumed run wrote before its checkpoint.
        let earlier =
            (1..=resumed_from.unwrap_or(0)).filter(|&f| opts.save.contains(f, opts.frames));
        for f in earlier {
            summary.saved_frames.push(f);
            summary.previews.push(preview_path(&opts.out, f));
        }
        summary
    }
}

/// The steps of a run ([`drive`]), each taken and followed by what the
/// run writes after it: the measures, the saved frame (`at_saved` after
/// it), the render, the metrics row and the checkpoint, as `opts` and
/// `checkpoints` ask; the progress bar and the run's summary follow along.
struct StepLoop<'a, F> {
    opts: &'a RunOptions,
    checkpoints: Option<&'a Checkpointing>,
    at_saved: F,
    csv: &'a mut Log,
    bar: &'a mut crate::run::progress::Stage,
    summary: &'a mut RunSummary,
    /// `run.pvd`, with `--paraview`.
    pvd: Option<PvdCollection>,
    probes: FineProbes,
    /// Whether the CFL warning was given (it is given once).
    warned_cfl: bool,
}

impl<F: FnMut(&Simulation, usize) -> Result<()>> StepLoop<'_, F> {
    /// Take step `frame` of `sim` and write what follows it.
    fn advance(&mut self, sim: &mut Simulation, frame: usize) -> Result<()> {
        let opts = self.opts;
        step(sim, frame, &opts.out)?;
        let mut times = sim.times;
        let on = |every: usize| frame.is_multiple_of(every.max(1)) || frame == opts.frames;
        let (measuring, diagnosing) = (on(opts.metrics_every), on(opts.diagnostics_every));
        let saving = opts.save.contains(frame, opts.frames);
        let render = opts.render.as_ref().filter(|r| r.wants(frame, opts.frames));
        let checkpoint = (self.checkpoints).filter(|c| c.every > 0 && on(c.every));
        // A prescribed step leaves gridless and SELMA densities at the
        // cell centres to be evaluated where they are read (a forced
        // step has evaluated them: then this is free); the diagnostics
        // read them with two gases, the obstacles' columns every step.
        let read = (diagnosing && sim.gases.len() == 2) || sim.boundary.is_some();
        if read || measuring || saving || render.is_some() || checkpoint.is_some() {
            timed(&mut times.density, || sim.evaluate_densities());
        }
        let measures = diagnosing.then(|| timed(&mut times.metrics, || StepMeasures::take(sim)));
        let probes = &mut self.probes;
        let fine = measuring.then(|| timed(&mut times.metrics, || probes.measure(sim)));
        if saving {
            self.save_frame(sim, frame, &mut times.output)?;
        }
        if let Some(r) = render {
            let record = timed(&mut times.output, || r.render_frame(sim, &opts.out, frame))?;
            self.summary.renders.push(record);
        }
        let summary = &mut *self.summary;
        let row = MetricsRow::measure(
            sim,
            frame,
            measures.as_ref(),
            fine.as_ref(),
            &summary.source_rates,
            times,
        );
        self.csv.push(&row)?;
        // After the row, so that a checkpoint's metrics rows are all on
        // disk; after the last step too, so that a complete run resumes
        // from its last frame (`--resume --frames N`).
        if let Some(c) = checkpoint {
            timed(&mut times.output, || {
                self.csv.sync()?;
                checkpoint::write(&opts.out, sim, &c.record)
            })?;
        }
        summary.stage_seconds += times;
        if let Some(m) = &measures {
            summary.final_mirror_error = m.mirror;
        }
        summary.final_density_bytes = row.flow.density_bytes;
        if let Some(f) = fine {
            summary.final_measures = f.densities;
        }
        self.show_progress(frame, &row.step);
        Ok(())
    }

    /// Write saved frame `frame` in every format asked for, then call
    /// `at_saved`; the time counts to `output`.
    fn save_frame(&mut self, sim: &Simulation, frame: usize, output: &mut f64) -> Result<()> {
        let opts = self.opts;
        timed(output, || {
            write_frame(sim, &opts.out, frame, opts.sample_res)?;
            let exchange = Exchange {
                vdb: opts.vdb.as_ref(),
                pvd: self.pvd.as_mut(),
            };
            write_exchange(sim, &opts.out, (frame, opts.save.sequence(frame)), exchange)?;
            (self.at_saved)(sim, frame)
        })?;
        self.summary.saved_frames.push(frame);
        self.summary.previews.push(preview_path(&opts.out, frame));
        Ok(())
    }

    /// Advance the progress bar past `frame`, showing the last `max|u|`
    /// measured; warn once if the CFL number passes [`CFL_WARNING`] (both
    /// on the diagnostics' steps: `NaN` between passes no test).
    fn show_progress(&mut self, frame: usize, row: &StepColumns) {
        let (cfl, max_u) = (row.cfl, row.max_u);
        if cfl > CFL_WARNING && !self.warned_cfl {
            self.warned_cfl = true;
            self.bar.suspend(|| {
                eprintln!(
                    "warning: CFL number {cfl:.3e} at step {frame} (max|u| {max_u:.3e} × dt / cell); \
                     the flow is not resolved above {CFL_WARNING}: lower --dt or --gravity"
                )
            });
        }
        if !max_u.is_nan() {
            self.bar.set_message(format!("max|u| {max_u:.3}"));
        }
        self.bar.inc(1);
    }
}

/// Run `sim` from its current step (`checkpoints`' `resumed_from`, else 0)
/// to `opts.frames`: set up (`metrics.csv`, the progress bar, the manifest
/// marked running), the steps ([`StepLoop`]), and at the end the manifest
/// of the complete run, or of the failed one naming its error.
fn drive<C: Serialize>(
    sim: &mut Simulation,
    opts: &RunOptions,
    config: &C,
    seed: u64,
    checkpoints: Option<&Checkpointing>,
    at_saved: impl FnMut(&Simulation, usize) -> Result<()>,
) -> Result<RunSummary> {
    let start = Instant::now();
    let resumed_from = checkpoints.and_then(|c| c.resumed_from);
    let first = resumed_from.unwrap_or(0);
    let metrics_path = opts.out.join("metrics.csv");
    let mut csv = match resumed_from {
        Some(_) => Log::append(metrics_path)?,
        None => Log::create(metrics_path, &metric_columns(sim))?,
    };
    let mut bar = progress_bar(sim, opts, first);
    let mut summary = RunSummary::start(sim, opts, resumed_from);
    // At the start: what runs, where its grid sits and that it has not finished.
    io::write_json(
        &opts.out.join("manifest.json"),
        &Manifest::running(config, seed, serde_json::to_value(&summary)?),
    )?;
    if let Some(b) = &sim.boundary {
        io::write_npy3(&opts.out.join("obstacle.npy"), b.level().data())?;
    }
    // The steps; an error ends the run with a `failed` manifest naming it.
    let steps = paraview_collection(opts, sim.params.dt, &summary.saved_frames).and_then(|pvd| {
        let mut steps = StepLoop {
            opts,
            checkpoints,
            at_saved,
            csv: &mut csv,
            bar: &mut bar,
            summary: &mut summary,
            pvd,
            probes: FineProbes::new(*sim.domain()),
            warned_cfl: false,
        };
        (first + 1..=opts.frames).try_for_each(|frame| steps.advance(sim, frame))
    });
    if let Err(e) = steps {
        bar.abandon();
        io::write_json(
            &opts.out.join("manifest.json"),
            &Manifest::failed(
                config,
                seed,
                start.elapsed().as_secs_f64(),
                format!("{e:#}"),
            ),
        )?;
        return Err(e);
    }
    bar.finish_and_clear();
    summary.wall_seconds = start.elapsed().as_secs_f64();
    let extra = serde_json::to_value(&summary)?;
    io::write_json(
        &opts.out.join("manifest.json"),
        &Manifest::new(config, seed, summary.wall_seconds, extra),
    )?;
    Ok(summary)
}

fn preview_path(out: &Path, frame: usize) -> PathBuf {
    out.join(format!("preview_{frame:04}.png"))
}

/// Write the volumes and the preview of one frame: each gas at the velocity
/// grid's cell centres, and, with `sample_res`, sampled at that resolution.
pub fn write_frame(
    sim: &Simulation,
    out: &Path,
    frame: usize,
    sample_res: Option<usize>,
) -> Result<()> {
    for g in &sim.gases {
        io::write_npy3(
            &out.join(format!("{}_{frame:04}.npy", g.name)),
            g.density().data(),
        )?;
    }
    if let Some(res) = sample_res {
        let fine = sim.domain().with_resolution(res)?;
        let mut grid = ScalarGrid::zeros(fine);
        for g in &sim.gases {
            g.model.sample(&mut grid);
            io::write_npy3(
                &out.join(format!("{}_fine_{frame:04}.npy", g.name)),
                grid.data(),
            )?;
        }
    }
    for (a, name) in ["u", "v", "w"].iter().enumerate() {
        io::write_npy3(
            &out.join(format!("{name}_{frame:04}.npy")),
            sim.velocity.component(a),
        )?;
    }
    io::write_npy4(
        &out.join(format!("vel_{frame:04}.npy")),
        sim.velocity.to_cell_centres().data(),
    )?;
    // A run without gases (taylor-green) has nothing to preview.
    if sim.gases.is_empty() {
        return Ok(());
    }
    io::write_png(&preview_path(out, frame), &preview_image(sim))
}

/// The formats other tools open, for one saved frame `(step, sequence
/// number)` (see [`write_frame_formats`]).
fn write_exchange(
    sim: &Simulation,
    out: &Path,
    (frame, sequence): (usize, usize),
    to: Exchange,
) -> Result<()> {
    if to.vdb.is_none() && to.pvd.is_none() {
        return Ok(());
    }
    let geometry = VolumeGeometry::from(sim.domain());
    let scalars: Vec<(&str, _)> = sim
        .gases
        .iter()
        .map(|g| (g.name.as_str(), g.density().data().view()))
        .collect();
    let centred = sim.velocity.to_cell_centres();
    let volumes = FrameVolumes {
        frame,
        sequence,
        time: sim.time(),
        geometry: &geometry,
        scalars: &scalars,
        vectors: &[("vel", centred.data().view())],
        obstacle: sim.boundary.as_ref().map(|b| b.level().data().view()),
    };
    write_frame_formats(out, &volumes, to)
}

/// Mid-plane slice of every gas in its display colour, obstacles in grey.
pub fn preview_image(sim: &Simulation) -> image::RgbImage {
    let solid = sim.boundary.as_ref().map(|b| {
        let mut m = b.level().clone();
        m.as_slice_mut()
            .iter_mut()
            .for_each(|o| *o = if *o >= 0.0 { 2.0 } else { 0.0 });
        m
    });
    let mut layers: Vec<preview::Layer> = sim
        .gases
        .iter()
        .map(|g| preview::Layer {
            grid: g.density(),
            color: if g.lift >= 0.0 {
                preview::RED
            } else {
                preview::BLUE
            },
        })
        .collect();
    if let Some(grid) = &solid {
        layers.push(preview::Layer {
            grid,
            color: preview::GREY,
        });
    }
    preview::mid_slice(&layers, 1.0, 256)
}
