//! # 06-1 — hot/cold, all gridded (figs 6.1 and 6.2)
//!
//! Reproduces the notes' hot/cold sequence (§6.1.1): red hot gas injected low
//! rises, blue cold gas injected high sinks, they collide in the middle and
//! flow around each other. Semi-Lagrangian advection, FFT projection, 50³ as
//! in the notes.
//!
//! Two runs: the scenario's default, the sources offset by ±0.5 along x, so
//! that the gases collide over part of their width and pass each other as
//! in the notes' figures; and the head-on variant (`offset = 0`, both sources
//! on one vertical axis), where the gases meet and spread into one disc and
//! the problem is exactly mirror-symmetric, so `metrics.csv`'s
//! `mirror_error` tests the whole step (in the offset run that column
//! measures the offset, not an error; experiment S-1 measures the half turn
//! the offset run keeps).
//!
//! The offset was chosen by a study that this experiment repeats at its
//! size: offsets 0, 0.25, 0.5, 0.75 and 1, the share of each gas that has
//! passed the mid-plane and the overlap of the two gases at six frames
//! ([`Passage`]).
//!
//! Semi-Lagrangian advection does not conserve mass: the new value of a cell
//! is the old field interpolated at its departure point, and the departure
//! points of a step are traced through the trilinear interpolant of the face
//! velocities, whose divergence is not zero between the faces
//! (`metrics.csv`'s `div_interp_*`), so the traced map compresses and
//! expands volume and the sum over the cells changes, by a sign and amount
//! that depend on the flow: in the head-on run, where the gases pile up
//! against each other, it grows; in the passing run it shrinks.
//! `data.csv`'s `hot_mass_over_injected` reports it at the last frame (above
//! 1 is mass gained), and `hot_advection_over_injected` the part that
//! advection added or removed (`Gas::budget`); QUICK (flux form) conserves
//! mass to round-off.
//!
//! Run: `smokelab experiment 06-1` (about 1 min on 2 cores; `--full` is the
//! same 50³ runs with twice the frames; `--smoke` is 16³ for tests).
//!
//! Writes `results/06-1/`: `sequence.png` (volume renders of six frames,
//! fig 6.1, the offset run over the head-on one, rows and columns labelled),
//! `render_NNNN.png`/`.exr` per saved frame of the offset run (fig 6.2 is
//! the last), `slices.png` (mid-plane slices, a diagnostic, laid out as
//! `sequence.png`) and `preview_NNNN.png`, `metrics.csv`, `manifest.json`,
//! the volumes `*_NNNN.npy` (git-ignored); the head-on run the same into
//! `head_on/`; `data.csv` (both runs at each rendered frame: [`Passage`] and
//! the hot and cold gases' mass over what was injected) and
//! `offset_study.csv` (the same measures for every studied offset).

use std::path::{Path, PathBuf};

use anyhow::Result;
use image::RgbImage;
use serde::Serialize;
use smokelab::io;
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::{Scenario, SolverConfig};
use smokelab::simulation::{Gas, Simulation};

use crate::experiment::kit::{Context, Experiment, Size};
use crate::figures::panels::{self, Labels};
use crate::figures::table::write_rows;
use crate::run::frames::FrameRender;
use crate::run::frames::SaveFrames;
use crate::run::{self, RunOptions};

/// The offsets of the study (world units; the sources have radius 1).
const STUDY_OFFSETS: [f32; 5] = [0.0, 0.25, 0.5, 0.75, 1.0];

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "06-1",
    folder: "06-1",
    reproduces: "figs 6.1, 6.2",
    title: "hot/cold buoyant gases, all gridded, 50³",
    cost: "~1 min",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    let base = HotColdConfig::default();
    let config = match ctx.size {
        // Long enough at 16³ for the gases to meet and pass (t = 6).
        Size::Smoke => HotColdConfig {
            solver: SolverConfig {
                res: 16,
                frames: 120,
                ..base.solver.clone()
            },
            ..base
        },
        Size::Default => base,
        Size::Full => HotColdConfig {
            solver: SolverConfig {
                frames: 2 * base.solver.frames,
                ..base.solver.clone()
            },
            ..base
        },
    };
    let frames: Vec<usize> = (1..=6).map(|i| i * config.solver.frames / 6).collect();
    let head_on = HotColdConfig {
        offset: 0.0,
        ..config.clone()
    };
    let cases = [
        (
            format!("passing, offset {}", config.offset),
            &config,
            ctx.out.clone(),
        ),
        ("head-on".to_string(), &head_on, ctx.out.join("head_on")),
    ];
    let names: Vec<String> = cases
        .iter()
        .map(|c| crate::run::progress::stage_name(&c.2))
        .collect();
    let stages: Vec<_> = names
        .iter()
        .map(|n| {
            (
                n.as_str(),
                config.solver.frames as u64,
                crate::run::progress::Growth::Constant,
            )
        })
        .collect();
    crate::run::progress::plan(&stages);
    let (mut renders, mut slices, mut rows) = (vec![], vec![], vec![]);
    for (_, case, out) in &cases {
        let (r, s, measures) = run_one(ctx, case, out, &frames)?;
        renders.push(r);
        slices.push(s);
        rows.extend(measures);
    }
    write_rows(&ctx.out.join("data.csv"), &rows)?;
    let names: Vec<String> = cases.iter().map(|c| c.0.clone()).collect();
    let dt = config.solver.dt;
    let columns: Vec<String> = frames
        .iter()
        .map(|&f| panels::frame_heading(f, dt))
        .collect();
    let res = config.solver.res;
    for (file, panels, what) in [
        ("sequence.png", renders, "volume renders"),
        ("slices.png", slices, "mid-plane slices"),
    ] {
        let title = format!("06-1 hot (red) and cold (blue) gas, gridded {res}³: {what}");
        let labels = Labels {
            title: &title,
            rows: &names,
            columns: &columns,
        };
        panels::save(&ctx.out.join(file), &panels, 4, &labels)?;
    }
    let study = offset_study(&config, &frames)?;
    write_rows(&ctx.out.join("offset_study.csv"), &study)
}

/// One run of `config` into `out`, rendering `frames`: its renders and
/// mid-plane slices, and its [`Passage`] row at each of the frames.
fn run_one(
    ctx: &Context,
    config: &HotColdConfig,
    out: &Path,
    frames: &[usize],
) -> Result<(Vec<RgbImage>, Vec<RgbImage>, Vec<Passage>)> {
    let render = FrameRender::new(
        SaveFrames::List(frames.to_vec()),
        (256, 256),
        None,
        &config.solver.domain()?,
    )?;
    let mut sim = config.build()?;
    io::create_output_dir(out)?;
    let opts = RunOptions {
        out: out.to_path_buf(),
        frames: config.solver.frames,
        save: SaveFrames::List(frames.to_vec()),
        progress: ctx.progress,
        metrics_every: config.solver.metrics_every,
        // Every step's mirror errors: the experiment's series and maxima.
        diagnostics_every: 1,
        sample_res: config.solver.sample_res,
        render: Some(render),
        vdb: None,
        paraview: false,
    };
    let summary = run::run(&mut sim, &opts, config, config.solver.seed)?;
    let open = |paths: &mut dyn Iterator<Item = &PathBuf>| {
        paths
            .map(|p| Ok(image::open(p)?.to_rgb8()))
            .collect::<Result<Vec<_>>>()
    };
    let renders = open(&mut summary.renders.iter().map(|r| &r.png))?;
    let slices = open(&mut summary.previews.iter())?;
    // The run's volumes at the rendered frames, measured as the study does.
    let mut rows = vec![];
    for &f in frames {
        let read = |gas: &str| -> Result<ndarray::Array3<f32>> {
            Ok(ndarray_npy::read_npy(
                out.join(format!("{gas}_{f:04}.npy")),
            )?)
        };
        let (hot, cold) = (read("hot")?, read("cold")?);
        let flat =
            |a: &ndarray::Array3<f32>| a.as_slice().expect("a standard-layout array").to_vec();
        rows.push(Passage::measure(config, f, [&flat(&hot), &flat(&cold)]));
    }
    // The masses are known at the end of the run: the last row's.
    if let Some(last) = rows.last_mut() {
        last.set_masses(&sim, config.solver.frames, config.solver.dt);
    }
    Ok((renders, slices, rows))
}

/// Every offset of [`STUDY_OFFSETS`] run as `config` (no files written),
/// measured at `frames`.
fn offset_study(config: &HotColdConfig, frames: &[usize]) -> Result<Vec<Passage>> {
    let mut rows = vec![];
    for offset in STUDY_OFFSETS {
        let case = HotColdConfig {
            offset,
            ..config.clone()
        };
        let mut sim = case.build()?;
        for step in 1..=case.solver.frames {
            sim.step();
            if frames.contains(&step) {
                let (h, c) = (sim.gases[0].density(), sim.gases[1].density());
                let mut row = Passage::measure(&case, step, [h.as_slice(), c.as_slice()]);
                row.set_masses(&sim, step, case.solver.dt);
                rows.push(row);
            }
        }
    }
    Ok(rows)
}

/// How far two gases have passed each other at one frame.
#[derive(Serialize)]
struct Passage {
    /// The source offset d (0: head-on).
    offset: f32,
    frame: usize,
    /// Simulated time, seconds.
    time: f32,
    /// Share of the hot gas above the mid-plane `y = L/2` (it starts below).
    hot_past_mid: f64,
    /// Share of the cold gas below the mid-plane (it starts above).
    cold_past_mid: f64,
    /// How much the gases share the same cells: `Σ min(ĥ, ĉ) / Σ ĥ` with
    /// each gas scaled by its maximum (0: apart, 1: the hot gas lies wholly
    /// inside the cold).
    overlap: f64,
    /// The hot gas's total over what was injected (above 1: mass gained by
    /// advection); empty where not measured.
    hot_mass_over_injected: Option<f64>,
    /// The part of the hot gas's total that advection added, over what was
    /// injected ([`smokelab::simulation::MassBudget::advection`]).
    hot_advection_over_injected: Option<f64>,
    /// The cold gas's total over what was injected.
    cold_mass_over_injected: Option<f64>,
}

impl Passage {
    /// The passage measures of the hot and cold densities (flat `[z][y][x]`
    /// arrays of the run's cells) at `frame`.
    fn measure(config: &HotColdConfig, frame: usize, [hot, cold]: [&[f32]; 2]) -> Self {
        let n = config.solver.res;
        // Row `j` of cell `c` is `(c / n) % n`; the mid-plane lies between
        // rows n/2 − 1 and n/2.
        let above = |c: usize| (c / n) % n >= n / 2;
        let past = |g: &[f32], upper: bool| {
            let all: f64 = g.iter().map(|&v| f64::from(v)).sum();
            let past: f64 = g
                .iter()
                .enumerate()
                .filter(|&(c, _)| above(c) == upper)
                .map(|(_, &v)| f64::from(v))
                .sum();
            if all > 0.0 {
                past / all
            } else {
                0.0
            }
        };
        let peak = |g: &[f32]| g.iter().fold(f32::MIN_POSITIVE, |m, &v| m.max(v));
        let (mh, mc) = (peak(hot), peak(cold));
        let (mut shared, mut hot_sum) = (0.0f64, 0.0f64);
        for (&h, &c) in hot.iter().zip(cold) {
            let (h, c) = (f64::from((h / mh).max(0.0)), f64::from((c / mc).max(0.0)));
            shared += h.min(c);
            hot_sum += h;
        }
        Self {
            offset: config.offset,
            frame,
            time: frame as f32 * config.solver.dt,
            hot_past_mid: past(hot, true),
            cold_past_mid: past(cold, false),
            overlap: if hot_sum > 0.0 { shared / hot_sum } else { 0.0 },
            hot_mass_over_injected: None,
            hot_advection_over_injected: None,
            cold_mass_over_injected: None,
        }
    }

    /// The mass ratios of `sim` after `steps` steps of `dt`.
    fn set_masses(&mut self, sim: &Simulation, steps: usize, dt: f32) {
        let injected = |g: &Gas| g.injected_per_step(dt) * steps as f64;
        let (hot, cold) = (&sim.gases[0], &sim.gases[1]);
        self.hot_mass_over_injected = Some(hot.density().total() / injected(hot));
        self.hot_advection_over_injected = Some(hot.budget.advection / injected(hot));
        self.cold_mass_over_injected = Some(cold.density().total() / injected(cold));
    }
}
