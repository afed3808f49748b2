//! # 06-6 — buoyant gas in a box around a slab, reflecting and sticky (fig 6.6)
//!
//! Reproduces the notes' fig 6.6 (§6.3): a buoyant gas (green) injected low in
//! a closed box (blue walls) rises into a rectangular slab (red), spreads
//! under it, spills round its edges and fills the upper box. Frames 11, 29,
//! 74, 124 and 200 of a 200-frame run, left to right, as mid-plane slices
//! (z = L/2; the renderer will replace them), one row per case:
//!
//! 1. QUICK, reflecting walls (eq 6.6);
//! 2. QUICK, sticky walls with α = 0.5 (eq 6.7);
//! 3. semi-Lagrangian, reflecting, and
//! 4. semi-Lagrangian, sticky with α = 0.5 — the notes' own advection, for
//!    comparison of dissipation and leakage.
//!
//! The notes do not give fig 6.6's grid; `--full` uses 50³, the resolution of
//! their other chapter-6 runs, and 200 frames. The default run is reduced to
//! **40³** (same 200 frames and physical setup) so that all four cases
//! finish in about 30 s on an idle 2-core machine (80 s with other builds
//! running); `--full` takes about twice as long; `--smoke` is 26³ and 12 frames.
//!
//! Run: `smokelab experiment 06-6` (`--full`, `--smoke`).
//!
//! Writes `results/06-6/`: `fig_6_6.png` (the four rows), `data.csv` (one
//! line per case: the largest density fraction deeper than one cell inside
//! obstacles, the largest rim inward velocity after a step, the mean fluid
//! divergence, final vs injected mass, the relative L2 difference of the final
//! density from the first row's, the mean conjugate-gradient iterations of
//! QUICK's open-face projection, wall time), and per case a
//! folder (`quick-reflect/`, `quick-sticky/`, `sl-reflect/`, `sl-sticky/`) with
//! `metrics.csv`, `manifest.json`, `preview_NNNN.png` and the volumes
//! (`density_NNNN.npy`, `vel_NNNN.npy`, `obstacle.npy`; git-ignored).

use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;
use std::path::Path;

use std::io::Write;

use anyhow::{Context as _, Result};
use image::RgbImage;

use crate::registry::{Context, Experiment, Size};
use crate::run::{self, RunOptions, SaveFrames};
use crate::table::Columns;
use smokelab::advection::Scheme;
use smokelab::boundary::{AsField, BoundaryRule, Obstacle};
use smokelab::grid::ScalarGrid;
use smokelab::io::{self, preview};
use smokelab::scenario::slab_box::SlabBoxConfig;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "06-6",
    folder: "06-6",
    reproduces: "fig 6.6",
    title: "buoyant gas in a box around a slab; reflect/sticky, QUICK and SL",
    cost: "~30 s",
    run,
};

/// The notes' frames.
const FRAMES: [usize; 5] = [11, 29, 74, 124, 200];

/// One row of the figure.
struct Case {
    name: &'static str,
    advection: Scheme,
    rule: BoundaryRule,
    alpha: f32,
}

const CASES: [Case; 4] = [
    Case {
        name: "quick-reflect",
        advection: Scheme::Quick,
        rule: BoundaryRule::Reflect,
        alpha: 1.0,
    },
    Case {
        name: "quick-sticky",
        advection: Scheme::Quick,
        rule: BoundaryRule::Sticky,
        alpha: 0.5,
    },
    Case {
        name: "sl-reflect",
        advection: Scheme::Sl,
        rule: BoundaryRule::Reflect,
        alpha: 1.0,
    },
    Case {
        name: "sl-sticky",
        advection: Scheme::Sl,
        rule: BoundaryRule::Sticky,
        alpha: 0.5,
    },
];

fn run(ctx: &Context) -> Result<()> {
    let base = SlabBoxConfig::default();
    let (res, frames) = match ctx.size {
        Size::Smoke => (26, 12),
        Size::Default => (40, base.solver.frames),
        Size::Full => (50, base.solver.frames),
    };
    // The notes' frames, scaled to shorter runs.
    let saved: Vec<usize> = FRAMES
        .iter()
        .map(|&f| (f * frames).div_ceil(base.solver.frames).max(1))
        .collect();
    let configs: Vec<SlabBoxConfig> = CASES
        .iter()
        .map(|c| SlabBoxConfig {
            solver: SolverConfig {
                res,
                frames,
                advection: c.advection,
                ..base.clone().solver
            },
            boundary: c.rule,
            alpha: c.alpha,
            ..base.clone()
        })
        .collect();
    for c in &configs {
        c.validate()?;
    }
    io::create_output_dir(&ctx.out)?;
    let mut data = String::from(
        "case,res,frames,alpha,max_obstacle_fraction,max_closed_flux,\
         mean_div_fluid_rms,final_mass,injected_mass,diff_vs_quick_reflect,\
         mean_face_cg_iterations,wall_seconds\n",
    );
    let mut rows = vec![];
    let mut reference: Option<ScalarGrid> = None;
    for (case, config) in CASES.iter().zip(&configs) {
        let out = ctx.out.join(case.name);
        let mut sim = config.build()?;
        io::create_output_dir(&out)?;
        let opts = RunOptions {
            out: out.clone(),
            frames: config.solver.frames,
            save: SaveFrames::List(saved.clone()),
            progress: ctx.progress,
            metrics_every: 1,
            sample_res: None,
            render: None,
            vdb: false,
            paraview: false,
        };
        let summary = run::run(&mut sim, &opts, config, config.solver.seed)?;
        let m = Columns::read(&out.join("metrics.csv"))?;
        let gas = &sim.gases[0];
        let injected = gas.injected_per_step(config.solver.dt) * frames as f64;
        let reference = reference.get_or_insert_with(|| gas.density().clone());
        data.push_str(&format!(
            "{},{res},{frames},{},{:.6e},{:.6e},{:.6e},{:.6},{:.6},{:.4},{:.1},{:.2}\n",
            case.name,
            config.boundary_options().retained(),
            m.max("obstacle_fraction")?,
            m.max("closed_flux_max")?,
            m.mean("div_fluid_rms")?,
            m.last("density_mass")?,
            injected,
            relative_difference(gas.density(), reference),
            m.mean("face_cg_iterations")?,
            summary.wall_seconds,
        ));
        rows.push(figure_row(config, &out, &saved)?);
    }
    io::write_atomic(&ctx.out.join("data.csv"), |w| {
        Ok(w.write_all(data.as_bytes())?)
    })?;
    io::write_png(&ctx.out.join("fig_6_6.png"), &preview::stacked(&rows, 6))
}

/// The saved frames of one case as green gas, blue walls and a red slab.
fn figure_row(config: &SlabBoxConfig, dir: &Path, frames: &[usize]) -> Result<RgbImage> {
    let domain = config.solver.domain()?;
    let solid = |o: Obstacle| {
        let mut g = ScalarGrid::from_field(domain, &AsField(o));
        g.as_slice_mut()
            .iter_mut()
            .for_each(|v| *v = if *v >= 0.0 { 3.0 } else { 0.0 });
        g
    };
    let walls = solid(std::sync::Arc::new(config.walls()));
    let slab = solid(std::sync::Arc::new(config.slab()));
    let images = frames
        .iter()
        .map(|f| {
            let path = dir.join(format!("density_{f:04}.npy"));
            let rho: ndarray::Array3<f32> = ndarray_npy::read_npy(&path)
                .with_context(|| format!("cannot read {}", path.display()))?;
            let rho = ScalarGrid::from_array(domain, rho);
            let layers = [
                preview::Layer {
                    grid: &rho,
                    color: preview::GREEN,
                },
                preview::Layer {
                    grid: &walls,
                    color: preview::BLUE,
                },
                preview::Layer {
                    grid: &slab,
                    color: preview::RED,
                },
            ];
            Ok(preview::mid_slice(&layers, 1.0, 200))
        })
        .collect::<Result<Vec<_>>>()?;
    Ok(preview::side_by_side(&images, 4))
}

/// `‖a − b‖₂ / ‖b‖₂` (0 when `b` is empty).
fn relative_difference(a: &ScalarGrid, b: &ScalarGrid) -> f64 {
    let (mut diff, mut norm) = (0.0f64, 0.0f64);
    for (x, y) in a.as_slice().iter().zip(b.as_slice()) {
        diff += ((x - y) as f64).powi(2);
        norm += (*y as f64).powi(2);
    }
    if norm > 0.0 {
        (diff / norm).sqrt()
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn notes_frames_scale_to_short_runs() {
        let scaled: Vec<usize> = FRAMES
            .iter()
            .map(|&f| (f * 12).div_ceil(200).max(1))
            .collect();
        assert_eq!(scaled, [1, 2, 5, 8, 12]);
    }
}
