//! # 06-6 — buoyant gas in a box around a slab (fig 6.6)
//!
//! Reproduces the notes' fig 6.6 (§6.3): a buoyant gas (green) injected low in
//! a closed box (blue walls) rises into a rectangular slab (red), spreads
//! under it, spills round its edges and fills the upper box. "To capture
//! detail, the density was handled with gridless advection": the first rows
//! are the notes' own setup, semi-Lagrangian velocity with a gridless
//! density. Frames 11, 29, 74, 124 and 200 of a 200-frame run, left to
//! right, as mid-plane slices (z = L/2), one row per case:
//!
//! 1. SL, gridless, reflecting walls; 2. the same on the exact path through
//!    the RT0 velocity (`--interpolant rt0 --backtrace exact`), whose walks
//!    need no volume factor; 3. row 1 sticky, α = 0.5;
//! 4. SL, gridded, reflecting; 5. SL, SELMA, reflecting; 6. SELMA on the
//!    exact RT0 path; 7. QUICK, gridded, reflecting; 8. QUICK, gridded,
//!    sticky α = 0.5 — all with the exact obstacle projection
//!    (`--obstacles exact`);
//! 9. SL, gridded, reflecting with the notes' method (`--obstacles notes`:
//!    eqs 6.6–6.7 after a periodic projection), for comparison.
//!
//! The notes do not give fig 6.6's grid; `--full` uses 50³, the resolution of
//! their other chapter-6 runs, and 200 frames. The default run is reduced to
//! **40³** (same 200 frames and physical setup): about 6 minutes on a
//! 2-core machine (15 with builds running), most of it the three gridless rows;
//! `--smoke` is 26³ and 12 frames.
//!
//! Run: `smokelab experiment 06-6` (`--full`, `--smoke`).
//!
//! Writes `results/06-6/`: `fig_6_6_render.png` (the nine rows as volume
//! renders: green gas, the box's walls as a faint blue haze, the red slab),
//! `fig_6_6.png` (the same as mid-plane slices), `retained.png` /
//! `.svg` (gas in the fluid cells over gas injected, per step and case),
//! `data.csv` (one line per case: its interpolant and backtrace, the
//! largest share of the gas inside obstacles, the largest speed through a
//! closed face, the mean flux divergence of the fluid cells, the final and
//! lowest retained fraction, final vs injected mass at 2× sampling, the
//! peak density at 2× sampling (`density_max`, every `metrics_every`
//! steps) and its ratio to the SL gridded run's, the share of the last saved
//! density's mass in isolated blobs (`smokelab::metrics::blobs`: components
//! of fewer than 8 cells above 5 % of the maximum), the mean conjugate-gradient
//! iterations of the obstacle solve and of QUICK's open-face projection,
//! wall time), and per case a folder (`sl-gridless-reflect/`, …) with
//! `metrics.csv`, `manifest.json`, `preview_NNNN.png` and the volumes
//! (`density_NNNN.npy`, `vel_NNNN.npy`, `obstacle.npy`; git-ignored).

use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;
use std::path::Path;

use std::io::Write;

use std::sync::Arc;

use anyhow::{Context as _, Result};
use glam::Vec3;
use image::RgbImage;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::model_render::render_densities;
use crate::figures::panels::{self, Labels};
use crate::figures::plot::{LegendPosition, Plot, Series};
use crate::figures::table::Columns;
use crate::run::frames::SaveFrames;
use crate::run::{self, RunOptions};
use smokelab::advection::{Backtrace, Scheme};
use smokelab::boundary::{AsField, BoundaryRule, Obstacle, ObstacleMethod};
use smokelab::density::DensityMode;
use smokelab::domain::Domain;
use smokelab::field::Scalar;
use smokelab::grid::{Interpolant, ScalarGrid};
use smokelab::io::{self, preview};
use smokelab::metrics::{isolated_mass_share, BLOB_CELLS, BLOB_LEVEL};
use smokelab::scenario::slab_box::SlabBoxConfig;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "06-6",
    folder: "06-6",
    reproduces: "fig 6.6",
    title: "buoyant gas in a box around a slab; gridless as the notes ran it, every mode, exact and notes' obstacles",
    cost: "~6 min",
    run,
};

/// The notes' frames.
const FRAMES: [usize; 5] = [11, 29, 74, 124, 200];

/// One row of the figure.
struct Case {
    name: &'static str,
    advection: Scheme,
    density: DensityMode,
    method: ObstacleMethod,
    rule: BoundaryRule,
    alpha: f32,
    /// Trilinear with the midpoint rule (the notes'), or the exact path
    /// through the RT0 velocity.
    rt0_exact: bool,
}

impl Case {
    const fn exact(
        name: &'static str,
        advection: Scheme,
        density: DensityMode,
        rule: BoundaryRule,
        alpha: f32,
    ) -> Self {
        Self {
            name,
            advection,
            density,
            method: ObstacleMethod::Exact,
            rule,
            alpha,
            rt0_exact: false,
        }
    }

    /// This case on the exact path through the RT0 velocity, as `name`.
    const fn rt0_exact(self, name: &'static str) -> Self {
        Self {
            name,
            rt0_exact: true,
            ..self
        }
    }
}

use BoundaryRule::{Reflect, Sticky};
use DensityMode::{Gridded, Gridless, Selma};

const CASES: [Case; 9] = [
    Case::exact("sl-gridless-reflect", Scheme::Sl, Gridless, Reflect, 1.0),
    Case::exact("", Scheme::Sl, Gridless, Reflect, 1.0).rt0_exact("sl-gridless-reflect-rt0"),
    Case::exact("sl-gridless-sticky", Scheme::Sl, Gridless, Sticky, 0.5),
    Case::exact("sl-gridded-reflect", Scheme::Sl, Gridded, Reflect, 1.0),
    Case::exact("sl-selma-reflect", Scheme::Sl, Selma, Reflect, 1.0),
    Case::exact("", Scheme::Sl, Selma, Reflect, 1.0).rt0_exact("sl-selma-reflect-rt0"),
    Case::exact(
        "quick-gridded-reflect",
        Scheme::Quick,
        Gridded,
        Reflect,
        1.0,
    ),
    Case::exact("quick-gridded-sticky", Scheme::Quick, Gridded, Sticky, 0.5),
    Case {
        name: "sl-gridded-reflect-notes",
        advection: Scheme::Sl,
        density: Gridded,
        method: ObstacleMethod::Notes,
        rule: Reflect,
        alpha: 1.0,
        rt0_exact: false,
    },
];

/// The case whose peak density the others' are measured against.
const GRIDDED: &str = "sl-gridded-reflect";

fn run(ctx: &Context) -> Result<()> {
    let base = SlabBoxConfig::default();
    let (res, frames) = ctx
        .size
        .pick((26, 12), (40, base.solver.frames), (50, base.solver.frames));
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
                density: c.density,
                interpolant: if c.rt0_exact {
                    Interpolant::Rt0
                } else {
                    Interpolant::Trilinear
                },
                backtrace: if c.rt0_exact {
                    Backtrace::Exact
                } else {
                    Backtrace::Rk2
                },
                ..base.clone().solver
            },
            obstacles: c.method,
            boundary: c.rule,
            alpha: c.alpha,
            ..base.clone()
        })
        .collect();
    for c in &configs {
        c.validate()?;
    }
    let stages: Vec<_> = CASES
        .iter()
        .map(|c| {
            (
                c.name,
                frames as u64,
                crate::run::progress::growth_of(c.density),
            )
        })
        .collect();
    crate::run::progress::plan(&stages);
    io::create_output_dir(&ctx.out)?;
    let mut data = String::from(
        "case,res,frames,alpha,interpolant,backtrace,max_obstacle_fraction,max_closed_flux,\
         mean_div_fluid_rms,final_retained,min_retained,final_mass,injected_mass,\
         density_max,density_max_over_gridded,isolated_blob_mass,mean_cg_iterations,\
         mean_face_cg_iterations,wall_seconds\n",
    );
    let (mut rows, mut render_rows) = (vec![], vec![]);
    let mut plot = Plot::new(
        "06-6: gas in the fluid over gas injected",
        "step",
        "retained",
    )
    .legend(LegendPosition::LowerRight);
    let mut done = vec![];
    for (case, config) in CASES.iter().zip(&configs) {
        done.push(run_case(ctx, case, config, &saved)?);
    }
    let gridded_max = CASES
        .iter()
        .zip(&done)
        .find(|(c, _)| c.name == GRIDDED)
        .map(|(_, d)| d.density_max)
        .expect("06-6 runs the gridded reflect case");
    for (case, done) in CASES.iter().zip(done) {
        data.push_str(&format!(
            "{},{:.4},{:.4},{}\n",
            done.data,
            done.density_max,
            done.density_max / gridded_max,
            done.tail
        ));
        plot = plot.series(Series::line(case.name, done.retained));
        rows.push(done.slices);
        render_rows.push(done.renders);
    }
    io::write_atomic(&ctx.out.join("data.csv"), |w| {
        Ok(w.write_all(data.as_bytes())?)
    })?;
    plot.write(&ctx.out.join("retained"))?;
    let names: Vec<String> = CASES.iter().map(|c| c.name.to_string()).collect();
    let dt = base.solver.dt;
    let columns: Vec<String> = saved
        .iter()
        .map(|&f| panels::frame_heading(f, dt))
        .collect();
    for (file, rows, what) in [
        ("fig_6_6.png", rows, "mid-plane slices"),
        ("fig_6_6_render.png", render_rows, "volume renders"),
    ] {
        let title =
            format!("06-6 buoyant gas (green) around a slab (red) in a closed box, {res}³: {what}");
        let labels = Labels {
            title: &title,
            rows: &names,
            columns: &columns,
        };
        panels::save(&ctx.out.join(file), &rows, 6, &labels)?;
    }
    Ok(())
}

/// What one case's run gives the figures: its row of `data.csv` (the
/// columns before and after the peak's, which needs the gridded case's),
/// its peak density, its retained share by step, and its row of slices and
/// of renders.
struct CaseRun {
    data: String,
    density_max: f64,
    tail: String,
    retained: Vec<(f64, f64)>,
    slices: Vec<RgbImage>,
    renders: Vec<RgbImage>,
}

/// Run `case` as `config` into `<out>/<case>/`, saving the frames `saved`.
fn run_case(
    ctx: &Context,
    case: &Case,
    config: &SlabBoxConfig,
    saved: &[usize],
) -> Result<CaseRun> {
    let (res, frames) = (config.solver.res, config.solver.frames);
    let out = ctx.out.join(case.name);
    let mut sim = config.build()?;
    io::create_output_dir(&out)?;
    let opts = RunOptions {
        out: out.clone(),
        frames: config.solver.frames,
        save: SaveFrames::List(saved.to_vec()),
        progress: ctx.progress,
        metrics_every: config.solver.metrics_every,
        diagnostics_every: config.solver.diagnostics_every,
        sample_res: None,
        render: None,
        vdb: None,
        paraview: false,
    };
    let summary = run::run(&mut sim, &opts, config, config.solver.seed)?;
    let m = Columns::read(&out.join("metrics.csv"))?;
    let (steps, retained) = (m.column("step")?, m.column("retained")?);
    let lowest = retained
        .iter()
        .skip(steps.len() / 10)
        .fold(f64::INFINITY, |a, &b| a.min(b));
    let last = *saved.last().expect("the notes' frames are saved");
    let final_density = read_density(&config.solver.domain()?, &out, last)?;
    let data = format!(
        "{},{res},{frames},{},{},{},{:.6e},{:.6e},{:.6e},{:.4},{:.4},{:.6},{:.6}",
        case.name,
        config.boundary_options().retained(),
        config.solver.interpolant,
        config.solver.backtrace.name(),
        m.max("obstacle_fraction")?,
        m.max("closed_flux_max")?,
        m.mean("div_fluid_rms")?,
        m.last("retained")?,
        lowest,
        m.last("density_mass")?,
        m.last("density_injected")?,
    );
    let tail = format!(
        "{:.4},{:.1},{:.1},{:.2}",
        isolated_mass_share(&final_density, BLOB_LEVEL, BLOB_CELLS),
        m.mean("cg_iterations")?,
        m.mean("face_cg_iterations")?,
        summary.wall_seconds,
    );
    let (slices, renders) = figure_row(config, &out, saved)?;
    Ok(CaseRun {
        data,
        density_max: m.max("density_max")?,
        tail,
        retained: steps.into_iter().zip(retained).collect(),
        slices,
        renders,
    })
}

/// The saved frames of one case as green gas, blue walls and a red slab:
/// mid-plane slices, and volume renders (appendix-A marcher, key light) in
/// which the walls are a faint blue haze and the slab is opaque.
fn figure_row(
    config: &SlabBoxConfig,
    dir: &Path,
    frames: &[usize],
) -> Result<(Vec<RgbImage>, Vec<RgbImage>)> {
    let domain = config.solver.domain()?;
    let solid = |o: Obstacle, value: f32| {
        let mut g = ScalarGrid::from_field(domain, &AsField(o));
        g.as_slice_mut()
            .iter_mut()
            .for_each(|v| *v = if *v >= 0.0 { value } else { 0.0 });
        g
    };
    let walls = solid(std::sync::Arc::new(config.walls()), 3.0);
    let slab = solid(std::sync::Arc::new(config.slab()), 3.0);
    let haze: Scalar = Arc::new(solid(std::sync::Arc::new(config.walls()), 0.01));
    let slab_volume: Scalar = Arc::new(slab.clone());
    let mut slices = vec![];
    let mut renders = vec![];
    for &f in frames {
        let rho = read_density(&domain, dir, f)?;
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
        slices.push(preview::mid_slice(&layers, 1.0, 200));
        let to_rgb = |c: [f32; 3]| Vec3::from(c);
        renders.push(render_densities(
            vec![
                (
                    "density".into(),
                    Arc::new(rho) as Scalar,
                    to_rgb(preview::GREEN),
                ),
                ("walls".into(), haze.clone(), to_rgb(preview::BLUE)),
                ("slab".into(), slab_volume.clone(), to_rgb(preview::RED)),
            ],
            domain,
            200,
            0.5,
            4.0,
        )?);
    }
    Ok((slices, renders))
}

/// The density a run saved in `dir` at `frame`, on `domain`.
fn read_density(domain: &Domain, dir: &Path, frame: usize) -> Result<ScalarGrid> {
    let path = dir.join(format!("density_{frame:04}.npy"));
    let rho: ndarray::Array3<f32> =
        ndarray_npy::read_npy(&path).with_context(|| format!("cannot read {}", path.display()))?;
    Ok(ScalarGrid::from_array(*domain, rho))
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
