//! Shared by experiments 06-3 and 06-5: run the hot/cold scenario with the
//! density held each way, capture pictures at chosen frames, and plot the
//! per-step metrics of the modes against each other.
//!
//! Every mode runs the same configuration but for the density mode, so the
//! runs differ only by how the density is held (and by the flow that
//! density then drives). Each writes `<out>/<label>/` (metrics.csv,
//! manifest.json, slice previews; volumes are git-ignored). Pictures:
//! - **slices**: the mid-plane `z = L/2` of the density *fields*, queried
//!   pixel by pixel ([`preview::field_slice`]) — resolution independent, so
//!   gridless and SELMA detail finer than the grid shows;
//! - **renders**: the ray marcher (appendix A) on every gas sampled at twice
//!   the velocity grid's resolution — the sampling the metrics use — with
//!   a march step of half that fine cell. Rendering the gridless chain
//!   itself at every march sample would cost (pixels × samples × steps)
//!   walks, minutes per frame; the 2× cache keeps every mode on equal terms.

use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use anyhow::{Context as _, Result};
use image::RgbImage;
use serde::Serialize;

use crate::experiment::kit::{Context, Size};
use crate::figures::panels::{self, Labels};
use crate::figures::plot::{Annotation, LegendPosition, Plot, Series, Style, PALETTE};
use crate::figures::table::Columns;
use crate::run::frames::SaveFrames;
use crate::run::{self, RunOptions};
use smokelab::advection::Scheme;
use smokelab::density::probe;
use smokelab::density::{DensityMode, DensityModel};
use smokelab::field::Scalar;
use smokelab::grid::ScalarGrid;
use smokelab::io::{self, preview};
use smokelab::render::camera::Camera;
use smokelab::render::output::{self, Display};
use smokelab::render::phase::Phase;
use smokelab::render::{look, render, RenderSettings, Scene};
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::simulation::Simulation;

/// The `metrics.csv` columns of a step's own stages, whose sum is the wall
/// time of a step.
const STEP_STAGES: [&str; 6] = [
    "t_advect",
    "t_inject",
    "t_density",
    "t_force",
    "t_project",
    "t_boundary",
];

/// One density mode to run.
pub(crate) struct ModeRun {
    /// Folder and legend name (`gridded`, `gridless`, `selma`, `selma-fine`,
    /// `gridded-maccormack`).
    pub label: String,
    /// The hot/cold configuration, density mode included.
    pub config: HotColdConfig,
}

impl ModeRun {
    /// `base` with the density held as `mode`.
    pub fn new(base: &HotColdConfig, mode: DensityMode) -> Self {
        Self {
            label: mode.name().into(),
            config: HotColdConfig {
                solver: SolverConfig {
                    density: mode,
                    ..base.clone().solver
                },
                ..base.clone()
            },
        }
    }

    /// Gridded with velocity and densities advected by MacCormack instead of
    /// the base's scheme (`gridded-maccormack`): the gridded baseline a
    /// peer's user would compare against (Selle et al. 2008), so that each
    /// claim of the notes is measured against the stronger gridded scheme
    /// as well as the notes' semi-Lagrangian one.
    pub fn gridded_maccormack(base: &HotColdConfig) -> Self {
        Self {
            label: "gridded-maccormack".into(),
            config: HotColdConfig {
                solver: SolverConfig {
                    density: DensityMode::Gridded,
                    advection: Scheme::MacCormack,
                    ..base.clone().solver
                },
                ..base.clone()
            },
        }
    }

    /// Gridless with injection spheres of smooth edge `edge` instead of the
    /// notes' solid mask: the symmetry control.
    pub fn gridless_smooth(base: &HotColdConfig, edge: f32) -> Self {
        Self {
            label: "gridless-smooth".into(),
            config: HotColdConfig {
                solver: SolverConfig {
                    density: DensityMode::Gridless,
                    ..base.clone().solver
                },
                source_edge: edge,
                ..base.clone()
            },
        }
    }

    /// SELMA with its map grid `factor` times finer than the velocity (SELMA^fine).
    pub fn selma_fine(base: &HotColdConfig, factor: usize) -> Self {
        Self {
            label: "selma-fine".into(),
            config: HotColdConfig {
                solver: SolverConfig {
                    density: DensityMode::Selma,
                    map_res: Some(factor * base.solver.res),
                    ..base.clone().solver
                },
                ..base.clone()
            },
        }
    }
}

/// The hot/cold run of 06-3 and 06-5 and its pictures at `size`: `--smoke`
/// 16³ and 12 frames, metrics every 4 steps, 128-pixel slices and 64-pixel
/// renders; by default `default_res`³ (the scenario's own if `None`) and
/// 100 frames, 320 and 256 pixels; `--full` the scenario's own resolution
/// and frames, 400 and 320 pixels; metrics every 10 steps beyond smoke.
pub(crate) fn hot_cold_size(size: Size, default_res: Option<usize>) -> (HotColdConfig, Look) {
    let base = HotColdConfig::default();
    let own = (base.solver.res, base.solver.frames, 10);
    let default = (default_res.unwrap_or(own.0), 100, 10);
    let (res, frames, metrics_every) = size.pick((16, 12, 4), default, own);
    let look = size.pick(
        Look {
            slice: 128,
            render: 64,
        },
        Look {
            slice: 320,
            render: 256,
        },
        Look {
            slice: 400,
            render: 320,
        },
    );
    let config = HotColdConfig {
        solver: SolverConfig {
            res,
            frames,
            metrics_every,
            ..base.solver.clone()
        },
        ..base
    };
    (config, look)
}

/// Picture sizes.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Look {
    /// Width of a slice in pixels.
    pub slice: u32,
    /// Side of a square render in pixels.
    pub render: u32,
}

/// The pictures of one frame.
pub(crate) struct Captured {
    /// Mid-plane slice of the fields.
    pub slice: RgbImage,
    /// Ray-marched render of the 2× sampling.
    pub render: RgbImage,
}

/// What one mode's run produced.
pub(crate) struct ModeResult {
    /// Legend name.
    pub label: String,
    /// The run's folder.
    pub dir: PathBuf,
    /// Pictures at the captured frames, in frame order.
    pub frames: Vec<Captured>,
    /// SELMA re-anchorings of the hot gas over the run (0 otherwise).
    pub restarts: usize,
    /// Hot mass at the last frame by 4× sampling (checks the 2× metric).
    pub hot_mass_4x: f64,
    /// The simulation at its last frame.
    pub sim: Simulation,
}

/// Mid-plane slice of every gas of `sim`.
pub(crate) fn slice(sim: &Simulation, width: u32) -> RgbImage {
    let fields: Vec<Scalar> = sim.gases.iter().map(|g| g.model.field()).collect();
    let layers: Vec<preview::FieldLayer> = sim
        .gases
        .iter()
        .zip(&fields)
        .map(|(g, f)| preview::FieldLayer {
            field: &**f,
            color: if g.lift >= 0.0 {
                preview::RED
            } else {
                preview::BLUE
            },
        })
        .collect();
    preview::field_slice(&layers, sim.domain(), width, 1.0)
}

/// Ray-marched render of every gas of `sim`, sampled at 2× (see the module docs).
pub(crate) fn render_fine(sim: &Simulation, side: u32) -> Result<RgbImage> {
    let fine = sim.domain().refined(probe::REFINE);
    let volumes = sim
        .gases
        .iter()
        .map(|g| {
            let mut grid = ScalarGrid::zeros(fine);
            g.model.sample(&mut grid);
            let color = if g.lift >= 0.0 { look::HOT } else { look::COLD };
            look::smoke(&g.name, Arc::new(grid), color, look::KAPPA, look::GLOW)
        })
        .collect();
    let scene = Scene {
        bounds: fine,
        volumes,
        lights: vec![look::key_light(&fine)],
        phase: Phase::Isotropic,
    };
    // Half a fine cell per march step: gridless edges are sharp enough to
    // alias at one (the notes' figs 7.6–7.7).
    let settings = RenderSettings {
        step: Some(0.5 * fine.cell),
        ..RenderSettings::new(Camera::framing(&fine, side, side, 0.9))
    };
    let r = render(&scene, &settings)?;
    Ok(output::preview(&r.image, &Display::default()))
}

/// Run every one of `modes` ([`run_mode`]) after checking all their
/// configurations and announcing them as the experiment's stages.
pub(crate) fn run_modes(
    ctx: &Context,
    modes: &[ModeRun],
    capture: &[usize],
    look: Look,
) -> Result<Vec<ModeResult>> {
    for m in modes {
        m.config.validate()?;
    }
    plan(modes);
    modes
        .iter()
        .map(|m| run_mode(ctx, m, capture, look))
        .collect()
}

/// Announce the runs of `modes` as the experiment's stages (one overall
/// progress bar with an overall ETA).
fn plan(modes: &[ModeRun]) {
    let stages: Vec<(&str, u64, crate::run::progress::Growth)> = modes
        .iter()
        .map(|m| {
            let s = &m.config.solver;
            (
                m.label.as_str(),
                s.frames as u64,
                crate::run::progress::growth_of(s.density),
            )
        })
        .collect();
    crate::run::progress::plan(&stages);
}

/// Run one mode into `<ctx.out>/<label>/`, capturing `capture` frames.
fn run_mode(ctx: &Context, mode: &ModeRun, capture: &[usize], look: Look) -> Result<ModeResult> {
    let config = &mode.config;
    let mut sim = config.build()?;
    let dir = ctx.out.join(&mode.label);
    io::create_output_dir(&dir)?;
    let opts = RunOptions {
        out: dir.clone(),
        frames: config.solver.frames,
        save: SaveFrames::List(capture.to_vec()),
        progress: ctx.progress,
        metrics_every: config.solver.metrics_every,
        // Every step's mirror errors: the experiment's series and maxima.
        diagnostics_every: 1,
        sample_res: None,
        render: None,
        vdb: None,
        paraview: false,
    };
    let mut frames = Vec::new();
    run::run_with(&mut sim, &opts, config, config.solver.seed, |sim, _| {
        frames.push(Captured {
            slice: slice(sim, look.slice),
            render: render_fine(sim, look.render)?,
        });
        Ok(())
    })?;
    let restarts = match &sim.gases[0].model {
        DensityModel::Selma(s) => s.restarts(),
        _ => 0,
    };
    let hot_mass_4x = probe::integral(&*sim.gases[0].model.field(), sim.domain(), 4);
    Ok(ModeResult {
        label: mode.label.clone(),
        dir,
        frames,
        restarts,
        hot_mass_4x,
        sim,
    })
}

/// Rows of images (plots, each titled in its own pixels) stacked, each row
/// side by side, with `gap`-pixel dark separators.
pub(crate) fn grid(rows: &[Vec<RgbImage>], gap: u32) -> RgbImage {
    let rows: Vec<RgbImage> = rows.iter().map(|r| preview::side_by_side(r, gap)).collect();
    preview::stacked(&rows, gap)
}

/// The captured pictures of each result, one row per result named by its
/// label, one column per frame headed by its time (`capture`, steps of
/// `dt`): the mid-plane slices into `out/<stem>.png` and the volume renders
/// into `out/<stem>_render.png`, each titled `title` and what it shows,
/// with its caption ([`panels::save`]).
pub(crate) fn save_frames(
    (out, stem): (&Path, &str),
    title: &str,
    results: &[&ModeResult],
    (capture, dt): (&[usize], f32),
) -> Result<()> {
    let names: Vec<String> = results.iter().map(|r| r.label.clone()).collect();
    let columns: Vec<String> = capture
        .iter()
        .map(|&f| panels::frame_heading(f, dt))
        .collect();
    type Pick = fn(&Captured) -> RgbImage;
    let figures: [(String, Pick, &str); 2] = [
        (
            format!("{stem}.png"),
            |f| f.slice.clone(),
            "mid-plane slices",
        ),
        (
            format!("{stem}_render.png"),
            |f| f.render.clone(),
            "volume renders",
        ),
    ];
    for (file, pick, what) in figures {
        let rows: Vec<Vec<RgbImage>> = results
            .iter()
            .map(|r| r.frames.iter().map(pick).collect())
            .collect();
        let title = format!("{title}: {what}");
        let labels = Labels {
            title: &title,
            rows: &names,
            columns: &columns,
        };
        panels::save(&out.join(file), &rows, 4, &labels)?;
    }
    Ok(())
}

/// The colour of a mode in every plot.
fn color(label: &str) -> plotters::style::RGBColor {
    match label {
        "gridded" => PALETTE[0],
        "gridless" => PALETTE[3],
        "selma" => PALETTE[2],
        "gridless-smooth" => PALETTE[1],
        "gridded-offset" => PALETTE[5],
        "selma-offset" => PALETTE[6],
        "gridless-offset" => PALETTE[7],
        "gridded-maccormack" => PALETTE[9],
        _ => PALETTE[4],
    }
}

/// One plot of the metrics sheet: its file name (`metrics_<name>`), what
/// it shows (after the sheet's title), its y axis, and the series of one
/// run's `metrics.csv` (an empty series name: the run's label alone).
struct MetricPlot {
    name: &'static str,
    what: &'static str,
    y: &'static str,
    log_y: bool,
    legend: LegendPosition,
    note: Option<&'static str>,
    series: fn(&Columns) -> Result<Vec<Series>>,
}

/// The seven plots of [`plot_metrics`], in the sheet's order.
const METRIC_PLOTS: [MetricPlot; 7] = [
    MetricPlot {
        name: "mass",
        what: "hot mass / injected",
        y: "∫ρ (2× sampling) / Σ S Δt",
        log_y: false,
        legend: LegendPosition::LowerLeft,
        note: None,
        series: |t| {
            let (m, i) = (t.index("hot_mass")?, t.index("hot_injected")?);
            Ok(vec![
                Series::line("", t.series(|r| r[m] / r[i])?).styled(Style::LineMarkers)
            ])
        },
    },
    MetricPlot {
        name: "peak",
        what: "peak density",
        y: "max ρ_hot (2× sampling)",
        log_y: false,
        legend: LegendPosition::UpperLeft,
        note: None,
        series: |t| {
            let m = t.index("hot_max")?;
            Ok(vec![
                Series::line("", t.series(|r| r[m])?).styled(Style::LineMarkers)
            ])
        },
    },
    MetricPlot {
        name: "symmetry",
        what: "mirror-symmetry error",
        y: "relative max error",
        log_y: true,
        legend: LegendPosition::UpperLeft,
        note: Some("solid: densities · dashed: velocity (0 is not drawn)"),
        series: |t| {
            let (d, v) = (t.index("mirror_error")?, t.index("vel_mirror_error")?);
            Ok(vec![
                Series::line("ρ", t.series(|r| r[d])?),
                Series::line("u", t.series(|r| r[v])?).styled(Style::Dashed),
            ])
        },
    },
    MetricPlot {
        name: "gradient",
        what: "detail",
        y: "mean |∇ρ_hot| (2× sampling)",
        log_y: false,
        legend: LegendPosition::UpperLeft,
        note: None,
        series: |t| {
            let g = t.index("hot_grad")?;
            Ok(vec![
                Series::line("", t.series(|r| r[g])?).styled(Style::LineMarkers)
            ])
        },
    },
    MetricPlot {
        name: "subgrid",
        what: "sub-grid detail",
        y: "energy beyond the velocity grid's Nyquist",
        log_y: true,
        legend: LegendPosition::LowerRight,
        note: None,
        series: |t| {
            let g = t.index("hot_subgrid")?;
            Ok(vec![
                Series::line("", t.series(|r| r[g])?).styled(Style::LineMarkers)
            ])
        },
    },
    MetricPlot {
        name: "time",
        what: "wall time per step",
        y: "seconds (advect + inject + density + force + project + boundary)",
        log_y: true,
        legend: LegendPosition::UpperLeft,
        note: None,
        series: |t| {
            let c: Vec<usize> = STEP_STAGES
                .iter()
                .map(|n| t.index(n))
                .collect::<Result<_>>()?;
            Ok(vec![Series::line(
                "",
                t.series(|r| c.iter().map(|&i| r[i]).sum())?,
            )])
        },
    },
    MetricPlot {
        name: "memory",
        what: "memory of the densities",
        y: "MiB held (both gases)",
        log_y: true,
        legend: LegendPosition::UpperLeft,
        note: None,
        series: |t| {
            let b = t.index("density_bytes")?;
            Ok(vec![Series::line("", t.series(|r| r[b] / 1048576.0)?)])
        },
    },
];

/// Plot the metrics of `results` over time: `<out>/metrics_<name>.{png,svg}`
/// for mass retained, peak density, symmetry, mean gradient, sub-grid
/// energy, time per step and memory ([`METRIC_PLOTS`]), plus
/// `metrics.png`, all seven on one sheet. Reads the runs' `metrics.csv`,
/// so the plots can be redrawn without simulating.
pub(crate) fn plot_metrics(out: &Path, results: &[ModeResult], title: &str) -> Result<()> {
    let tables: Vec<(String, Columns)> = results
        .iter()
        .map(|r| Ok((r.label.clone(), Columns::read(&r.dir.join("metrics.csv"))?)))
        .collect::<Result<_>>()?;
    let mut plots = vec![];
    for m in &METRIC_PLOTS {
        let mut p = Plot::new(format!("{title}: {}", m.what), "simulated time", m.y);
        if m.log_y {
            p = p.log_y();
        }
        p = p.legend(m.legend.clone());
        if let Some(note) = m.note {
            p = p.annotate(Annotation::at_fraction(0.35, 0.9, note));
        }
        for (label, t) in &tables {
            for s in (m.series)(t)? {
                let name = if s.name.is_empty() {
                    label.clone()
                } else {
                    format!("{label} {}", s.name)
                };
                p = p.series(Series { name, ..s }.colored(color(label)));
            }
        }
        plots.push((m.name, p));
    }
    let mut pngs = vec![];
    for (name, p) in &plots {
        let [png, _] = p.write(&out.join(format!("metrics_{name}")))?;
        pngs.push(image::open(&png)?.to_rgb8());
    }
    // White blanks fill the last row, so the sheet has no dark corner.
    let blank = RgbImage::from_pixel(pngs[0].width(), pngs[0].height(), image::Rgb([255; 3]));
    while pngs.len() % 4 != 0 {
        pngs.push(blank.clone());
    }
    let rows: Vec<Vec<RgbImage>> = pngs.chunks(4).map(|c| c.to_vec()).collect();
    io::write_png(&out.join("metrics.png"), &grid(&rows, 0))
}

/// One line of `summary.csv`.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct SummaryRow {
    /// Mode label.
    pub mode: String,
    /// Hot mass at the last frame, 2× sampling.
    pub hot_mass: f64,
    /// Peak hot density at the last frame, 2× sampling.
    pub hot_max: f64,
    /// Hot mass at the last frame, 4× sampling.
    pub hot_mass_4x: f64,
    /// Exact injected hot mass.
    pub hot_injected: f64,
    /// Largest density mirror error over the run.
    pub max_mirror_error: f64,
    /// Largest velocity mirror error over the run.
    pub max_vel_mirror_error: f64,
    /// Mean |∇ρ_hot| at the last frame.
    pub hot_grad: f64,
    /// Sub-grid energy fraction of the hot gas at the last frame.
    pub hot_subgrid: f64,
    /// Wall seconds per step ([`STEP_STAGES`]), mean over the run.
    pub mean_step_seconds: f64,
    /// The same, over the last tenth of the run.
    pub last_step_seconds: f64,
    /// Bytes held by the densities at the last frame.
    pub density_bytes: f64,
    /// SELMA re-anchorings of the hot gas.
    pub restarts: usize,
}

/// Summarise each mode from its `metrics.csv`; write `<out>/summary.csv`.
pub(crate) fn summarise(out: &Path, results: &[ModeResult]) -> Result<Vec<SummaryRow>> {
    let mut rows = vec![];
    for r in results {
        let t = Columns::read(&r.dir.join("metrics.csv"))?;
        let last = t.rows.last().context("empty metrics.csv")?;
        let c = |n: &str| t.index(n);
        let max = |i: usize| t.rows.iter().map(|r| r[i]).fold(0.0, f64::max);
        let step: Vec<usize> = STEP_STAGES.iter().map(|n| c(n)).collect::<Result<_>>()?;
        let per_step: Vec<f64> = t
            .rows
            .iter()
            .map(|r| step.iter().map(|&i| r[i]).sum())
            .collect();
        let tail = &per_step[per_step.len() - per_step.len().div_ceil(10)..];
        rows.push(SummaryRow {
            mode: r.label.clone(),
            hot_mass: last[c("hot_mass")?],
            hot_max: last[c("hot_max")?],
            hot_mass_4x: r.hot_mass_4x,
            hot_injected: last[c("hot_injected")?],
            max_mirror_error: max(c("mirror_error")?),
            max_vel_mirror_error: max(c("vel_mirror_error")?),
            hot_grad: last[c("hot_grad")?],
            hot_subgrid: last[c("hot_subgrid")?],
            mean_step_seconds: per_step.iter().sum::<f64>() / per_step.len() as f64,
            last_step_seconds: tail.iter().sum::<f64>() / tail.len() as f64,
            density_bytes: last[c("density_bytes")?],
            restarts: r.restarts,
        });
    }
    let cols = [
        "mode",
        "hot_mass",
        "hot_max",
        "hot_mass_4x",
        "hot_injected",
        "max_mirror_error",
        "max_vel_mirror_error",
        "hot_grad",
        "hot_subgrid",
        "mean_step_seconds",
        "last_step_seconds",
        "density_bytes",
        "restarts",
    ];
    let mut text = cols.join(",") + "\n";
    for r in &rows {
        text.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            r.mode,
            r.hot_mass,
            r.hot_max,
            r.hot_mass_4x,
            r.hot_injected,
            r.max_mirror_error,
            r.max_vel_mirror_error,
            r.hot_grad,
            r.hot_subgrid,
            r.mean_step_seconds,
            r.last_step_seconds,
            r.density_bytes,
            r.restarts
        ));
    }
    io::write_atomic(&out.join("summary.csv"), |w| {
        Ok(std::io::Write::write_all(w, text.as_bytes())?)
    })?;
    Ok(rows)
}
