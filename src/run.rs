//! Driving a [`Simulation`] through its frames and writing what it produced.
//!
//! Output folder layout (see the README):
//! - `<gas>_NNNN.npy` — f32 `(nz, ny, nx)` density at the cell centres;
//! - `vel_NNNN.npy` — f32 `(nz, ny, nx, 3)` velocity, as the projection left it;
//! - `preview_NNNN.png` — mid-plane slice of the gases (obstacles grey);
//! - `render_NNNN.exr`, `render_NNNN.png` — volume renders (with `--render`);
//! - `obstacle.npy` — f32 `(nz, ny, nx)` obstacle level set at the cell
//!   centres, positive inside, world units (runs with obstacles);
//! - `metrics.csv` — one row per step, rewritten whole at every saved frame;
//! - `manifest.json` — configuration, machine, commit, wall time, peak memory.
//!
//! Frame `N` is the state after `N` steps.

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::{bail, Result};
use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;

use crate::boundary::Leak;
use crate::io::{self, manifest::Manifest, preview, CsvLog};
use crate::metrics;
use crate::render::frames::{FrameRecord, FrameRender};
use crate::simulation::Simulation;
use crate::timing::timed;

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
    /// Frames to volume-render, and how (`None`: no renders).
    pub render: Option<FrameRender>,
}

/// The frames whose volumes and previews are written.
#[derive(Clone, Debug)]
pub enum SaveFrames {
    /// Every K-th frame and the last (K = 0: none).
    Every(usize),
    /// Exactly these frames.
    List(Vec<usize>),
}

impl SaveFrames {
    /// Whether `frame` of a run of `last` frames is selected.
    pub fn contains(&self, frame: usize, last: usize) -> bool {
        match self {
            SaveFrames::Every(0) => false,
            SaveFrames::Every(k) => frame % k == 0 || frame == last,
            SaveFrames::List(l) => l.contains(&frame),
        }
    }
}

/// What a run wrote and what it cost.
#[derive(Clone, Debug, Serialize)]
pub struct RunSummary {
    /// Wall time of the whole run, seconds.
    pub wall_seconds: f64,
    /// Frames whose volumes were written.
    pub saved_frames: Vec<usize>,
    /// Preview images written, in frame order.
    pub previews: Vec<PathBuf>,
    /// Seconds per stage summed over the run.
    pub stage_seconds: crate::timing::StageTimes,
    /// Mirror-symmetry error at the last step (two-gas scenarios).
    pub final_mirror_error: Option<f32>,
    /// Volume renders written, in frame order, with their statistics.
    pub renders: Vec<FrameRecord>,
}

/// Column names of `metrics.csv` for a simulation's gases.
fn metric_columns(sim: &Simulation) -> Vec<String> {
    let mut cols: Vec<String> = ["step", "time", "max_u", "cfl", "div_rms", "div_max"]
        .map(String::from)
        .to_vec();
    cols.extend(sim.gases.iter().map(|g| format!("{}_mass", g.name)));
    if sim.gases.len() == 2 {
        cols.push("mirror_error".into());
    }
    cols.push("substeps".into());
    if sim.boundary.is_some() {
        cols.extend(Leak::COLUMNS.map(String::from));
        cols.extend(["face_cg_iterations", "face_div_rel"].map(String::from));
    }
    cols.extend(["t_advect", "t_force", "t_project", "t_output"].map(String::from));
    cols
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
    let start = Instant::now();
    let cols = metric_columns(sim);
    let col_refs: Vec<&str> = cols.iter().map(String::as_str).collect();
    let mut csv = CsvLog::new(opts.out.join("metrics.csv"), &col_refs);
    let bar = if opts.progress {
        ProgressBar::new(opts.frames as u64).with_style(
            ProgressStyle::with_template("{elapsed_precise} [{bar:40}] {pos}/{len} steps {msg}")
                .expect("static template"),
        )
    } else {
        ProgressBar::hidden()
    };
    let mut summary = RunSummary {
        wall_seconds: 0.0,
        saved_frames: vec![],
        previews: vec![],
        stage_seconds: Default::default(),
        final_mirror_error: None,
        renders: vec![],
    };
    if let Some(b) = &sim.boundary {
        io::write_npy3(&opts.out.join("obstacle.npy"), b.level().data())?;
    }
    for frame in 1..=opts.frames {
        if let Err(e) = sim.try_step() {
            csv.flush()?;
            bail!(
                "step {frame}: {e}; frames written so far are in {}",
                opts.out.display()
            );
        }
        let mut times = sim.times;
        let finite = sim.velocity.is_finite();
        if !finite {
            csv.flush()?;
            bail!(
                "velocity became non-finite at step {frame}; frames written so far are in {}",
                opts.out.display()
            );
        }
        let max_u = sim.velocity.max_norm();
        let div = metrics::divergence_stats(&sim.velocity);
        let mirror = (sim.gases.len() == 2)
            .then(|| metrics::mirror_error(&sim.gases[0].density, &sim.gases[1].density));
        if opts.save.contains(frame, opts.frames) {
            timed(&mut times.output, || write_frame(sim, &opts.out, frame))?;
            summary.saved_frames.push(frame);
            summary.previews.push(preview_path(&opts.out, frame));
        }
        if let Some(r) = opts.render.as_ref().filter(|r| r.wants(frame, opts.frames)) {
            let record = timed(&mut times.output, || r.render_frame(sim, &opts.out, frame))?;
            summary.renders.push(record);
        }
        let mut row = vec![
            frame as f64,
            sim.time() as f64,
            max_u as f64,
            (max_u * sim.params.dt / sim.domain().cell) as f64,
            div.rms as f64,
            div.max as f64,
        ];
        row.extend(sim.gases.iter().map(|g| g.density.total()));
        row.extend(mirror.map(|m| m as f64));
        row.push(sim.advector().substeps() as f64);
        if let Some(b) = &sim.boundary {
            let densities: Vec<_> = sim.gases.iter().map(|g| &g.density).collect();
            row.extend(b.leak(&sim.velocity, &densities).row());
            let (iterations, residual) = sim.advector().face_projection_stats().unwrap_or((0, 0.0));
            row.extend([iterations as f64, residual as f64]);
        }
        row.extend([times.advect, times.force, times.project, times.output]);
        csv.push(&row);
        if summary.saved_frames.last() == Some(&frame) {
            csv.flush()?;
        }
        let s = &mut summary.stage_seconds;
        s.advect += times.advect;
        s.force += times.force;
        s.project += times.project;
        s.output += times.output;
        summary.final_mirror_error = mirror;
        bar.set_message(format!("max|u| {max_u:.3}"));
        bar.inc(1);
    }
    bar.finish_and_clear();
    csv.flush()?;
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

/// Write the volumes and the preview of one frame.
pub fn write_frame(sim: &Simulation, out: &Path, frame: usize) -> Result<()> {
    for g in &sim.gases {
        io::write_npy3(
            &out.join(format!("{}_{frame:04}.npy", g.name)),
            g.density.data(),
        )?;
    }
    io::write_npy4(
        &out.join(format!("vel_{frame:04}.npy")),
        sim.velocity.data(),
    )?;
    io::write_png(&preview_path(out, frame), &preview_image(sim))
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
            grid: &g.density,
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
