//! Shared by the sphere-wall experiments 07-4 … 07-8, 08-1 (pictures of
//! holdings of the wall) and 07-10, 08-2 (render time and memory against
//! frames): sizes, the flow, rendering, `data.csv`, and the cost plots drawn
//! from the CSV with their fitted slopes.
//!
//! Sizes of 07-4 … 07-7 ([`figure_config`]): the notes' set-up, a 50³
//! passing flow and 60 frames (Δt 0.1, two solver steps each), at 640×480
//! by default and at `--full`;
//! `--smoke` a 24³ flow and 12 frames at 128×96. Of 07-8, 08-1 and the cost
//! studies ([`config`]): `--smoke` 16³ and 6 frames at 64×48; the default
//! 32³ and 30 frames (Δt 0.1), pictures 320×240 and cost studies 160×120;
//! `--full` 50³ and 60 frames at 640×480. The flow covers the same
//! simulated time at every size. "Cell" in a march step is the velocity
//! grid's cell.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use image::RgbImage;
use serde::{Deserialize, Serialize};

use crate::experiment::kit::{Context, Size};
use crate::experiment::shared::growth::{self, Criteria, Trend};
use crate::experiment::shared::memory;
use crate::figures::panels;
use crate::figures::plot::{Annotation, LegendPosition, Plot, Series, Style, PALETTE};
use crate::figures::render_difference;
use crate::figures::table::{read_rows, write_rows};
use smokelab::advection::MacCormack;
use smokelab::density::probe;
use smokelab::domain::Domain;
use smokelab::grid::ScalarGrid;
use smokelab::io::{self, preview};
use smokelab::metrics::picture;
use smokelab::render::camera::Camera;
use smokelab::render::output::{self, Display};
use smokelab::render::phase::Phase;
use smokelab::render::{look, render, RenderSettings, RenderStats, Scene, Volume};
use smokelab::scenario::hot_cold;
use smokelab::scenario::sphere_wall::{
    AdvectedWall, FlowHistory, GriddedWall, SelmaWall, SphereWallConfig, Wall,
};

/// The wall and flow of a run size.
pub(crate) fn config(size: Size) -> SphereWallConfig {
    let (res, frames) = size.pick((16, 6), (32, 30), (50, 60));
    SphereWallConfig {
        res,
        frames,
        ..SphereWallConfig::default()
    }
}

/// The wall and flow of figs 7.4–7.7 (07-4 … 07-7) at a run size: the
/// notes' 50³ and 60 frames by default and at `--full`; at `--smoke` 24³
/// and 12 frames, whose last sixth (eq 7.4's `k`) is 2 frames, not the one
/// gridless frame of 07-5 as at 6 frames.
///
/// The flow is the hot/cold run of §6.1.1 with the gases passing each
/// other (source offset [`hot_cold::DEFAULT_OFFSET`]), the wall placed at
/// 4.5 s, when the gases have passed and shear the wall's middle, and
/// moved over 6 s: each frame is two solver steps (Δt 0.1 per frame, the
/// solver's 0.05 at 50³), one backtrace per frame, as a film frame spans
/// several solver steps. Measured (finite-time stretching of the last 10
/// frames' gridless map over the wall at 50³, largest singular value of
/// its Jacobian, median / 90th percentile): 1.12 / 1.77 with the former
/// head-on flow, Δt 0.05 per frame and the wall placed at 1.5 s; 2.33 /
/// 6.69 with this one — the ten gridless frames compress the detail below
/// the march step only where the flow stretches that much. Four steps per
/// frame (Δt 0.2, 12 s) stretch more (3.9 / 9.8, 07-6's coherent error
/// 13.7× 07-4's) but mix the rows to grey and carry them across the box.
pub(crate) fn figure_config(size: Size) -> SphereWallConfig {
    let (res, frames) = size.pick((24, 12), (50, 60), (50, 60));
    SphereWallConfig {
        res,
        frames,
        duration: 6.0,
        warmup: 4.5,
        steps_per_frame: 2,
        offset: hot_cold::DEFAULT_OFFSET,
        ..SphereWallConfig::default()
    }
}

/// Image size of 07-4 … 07-7.
pub(crate) fn figure_size(size: Size) -> (u32, u32) {
    size.pick((128, 96), (640, 480), (640, 480))
}

/// What every sphere-wall experiment starts from: the run size's
/// configuration, the recorded flow and the unadvected wall. The flow is
/// recorded (and the configuration checked) before the output folder is
/// created, so a refused input writes nothing.
pub(crate) struct Setup {
    pub config: SphereWallConfig,
    pub flow: FlowHistory,
    pub wall: Wall,
}

impl Setup {
    /// The set-up of [`config`] at the run size.
    pub fn new(ctx: &Context) -> Result<Self> {
        Self::of(ctx, config(ctx.size))
    }

    /// The set-up of `config`.
    pub fn of(ctx: &Context, config: SphereWallConfig) -> Result<Self> {
        let flow = FlowHistory::record(&config)?;
        io::create_output_dir(&ctx.out)?;
        let wall = Wall::new(&config);
        Ok(Self { config, flow, wall })
    }

    /// The set-up of a cost study (07-10, 08-2) at the run size, with its
    /// image size ([`study_size`]), after one untimed gridless render has
    /// warmed the caches.
    pub fn warmed_study(ctx: &Context) -> Result<(Self, (u32, u32))> {
        let size = study_size(ctx.size);
        let setup = Self::new(ctx)?;
        let state = AdvectedWall::gridless(&setup.wall, None, &setup.flow, 0)?;
        warm_up(&state, &setup.flow, size)?;
        Ok((setup, size))
    }
}

/// Image size of the one-picture experiments.
pub(crate) fn picture_size(size: Size) -> (u32, u32) {
    size.pick((64, 48), (320, 240), (640, 480))
}

/// Image size of the cost studies (many renders each).
pub(crate) fn study_size(size: Size) -> (u32, u32) {
    size.pick((64, 48), (160, 120), (640, 480))
}

/// How one picture holds the wall over the `F` recorded frames.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub(crate) enum Holding {
    /// Gridded for `F − k` frames, then `k` gridless (eqs 7.1–7.4).
    Gridless {
        /// Gridless frames `k` (`usize::MAX`: all `F`).
        frames: usize,
    },
    /// SELMA over all frames, map grid `factor` × the velocity's (eq 8.8).
    Selma {
        /// Map refinement.
        factor: usize,
    },
    /// Gridded for all `F` frames as [`Holding::Gridless`] with no
    /// gridless frame, but each frame advected by MacCormack (Selle et al.
    /// 2008: the semi-Lagrangian step, half its round trip's error taken
    /// off, clamped to the stencil's range) instead of the notes'
    /// semi-Lagrangian step: the stronger gridded baseline.
    #[serde(rename = "maccormack")]
    MacCormack,
}

impl Holding {
    /// Build the wall after all `F` frames; with gridded frames, also the
    /// rows' grid mass `Σ ρ Δx³` when sampled (frame 0) and after the
    /// gridded frames.
    fn advect(self, wall: &Wall, flow: &FlowHistory) -> Result<(AdvectedWall, Option<[f64; 2]>)> {
        let f = flow.frames();
        let total = |g: &GriddedWall| g.grids.iter().map(|r| r.total()).sum::<f64>();
        Ok(match self {
            Holding::Gridless { frames } => {
                let k = frames.min(f);
                if k == f {
                    (AdvectedWall::gridless(wall, None, flow, f)?, None)
                } else {
                    let mut g = GriddedWall::new(wall, flow.domain);
                    let sampled = total(&g);
                    for _ in 0..f - k {
                        g.advance(flow);
                    }
                    let advected = total(&g);
                    (
                        AdvectedWall::gridless(wall, Some(&g), flow, k)?,
                        Some([sampled, advected]),
                    )
                }
            }
            Holding::Selma { factor } => {
                let mut s = SelmaWall::new(flow, Some(factor * flow.domain.dims[0]))?;
                for _ in 0..f {
                    s.advance(flow);
                }
                (AdvectedWall::selma(wall, &s), None)
            }
            Holding::MacCormack => {
                let mut g = GriddedWall::new(wall, flow.domain);
                let sampled = total(&g);
                maccormack_frames(&mut g, flow);
                let advected = total(&g);
                (AdvectedWall::gridded(&g), Some([sampled, advected]))
            }
        })
    }
}

/// Advect every row of `g` through all recorded frames by MacCormack
/// ([`MacCormack::advect`]: the frame's velocity, Δt and backtrace, as
/// [`GriddedWall::advance`] takes them for its semi-Lagrangian step). The
/// scheme also steps a velocity, which nothing here reads: its output is a
/// scratch grid.
fn maccormack_frames(g: &mut GriddedWall, flow: &FlowHistory) {
    let Some(first) = flow.velocities.first() else {
        return;
    };
    let mut scheme = MacCormack::new(flow.backtrace);
    let mut next = g.grids.clone();
    let mut velocity_scratch = (**first).clone();
    for u in &flow.velocities {
        let srcs: Vec<&ScalarGrid> = g.grids.iter().collect();
        let mut dsts: Vec<&mut ScalarGrid> = next.iter_mut().collect();
        scheme.advect(u, flow.dt, &srcs, &mut dsts, &mut velocity_scratch);
        std::mem::swap(&mut g.grids, &mut next);
    }
}

/// Display colours of the rows, top to bottom (cycled past six).
const ROW_COLORS: [Vec3; 6] = [
    Vec3::new(0.9, 0.08, 0.05),
    Vec3::new(0.95, 0.45, 0.04),
    Vec3::new(0.9, 0.85, 0.08),
    Vec3::new(0.1, 0.75, 0.15),
    Vec3::new(0.08, 0.35, 0.95),
    Vec3::new(0.6, 0.12, 0.85),
];

/// Extinction per unit density of the wall's render.
const KAPPA: f32 = 4.0;

/// The rows of `state` as coloured smoke volumes in the box `bounds`, lit by
/// the default key light.
fn wall_scene(state: &AdvectedWall, bounds: Domain) -> Scene {
    let volumes = state
        .rows
        .iter()
        .enumerate()
        .map(|(i, r)| {
            let color = ROW_COLORS[i % ROW_COLORS.len()];
            Volume {
                occupancy: state.occupancy.clone(),
                ..look::smoke(format!("row{i}"), r.clone(), color, KAPPA, look::GLOW)
            }
        })
        .collect();
    Scene {
        bounds,
        volumes,
        lights: vec![look::key_light(&bounds)],
        phase: Phase::Isotropic,
    }
}

/// How the camera rays are marched: step `Δs = cell / div`, one sub-step
/// sampled at a uniformly random point inside it (`jitter`, the stratified
/// form of eq A.29) or at its midpoint (a fixed step, the same sample
/// positions along every ray from its box entry).
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub(crate) struct March {
    /// Velocity cells per march step.
    pub div: f32,
    /// Jittered sample positions.
    pub jitter: bool,
}

impl March {
    /// The notes' coarse march of figs 7.4–7.6: one cell, fixed.
    pub const CELL: March = March {
        div: 1.0,
        jitter: false,
    };
    /// The notes' fine march of fig 7.7: a tenth of a cell, fixed.
    pub const FINE: March = March {
        div: 10.0,
        jitter: false,
    };

    /// A jittered march of step `cell / div` (the cost studies, 07-8, 08-1).
    pub const fn jittered(div: f32) -> Self {
        Self { div, jitter: true }
    }

    /// "fixed step cell/10", "jittered step cell" and the like.
    pub fn label(self) -> String {
        let step = if self.div == 1.0 {
            "cell".to_string()
        } else {
            format!("cell/{}", self.div)
        };
        let kind = if self.jitter { "jittered" } else { "fixed" };
        format!("{kind} step {step}")
    }
}

/// Render the wall with `march`.
pub(crate) fn render_wall(
    state: &AdvectedWall,
    flow: &FlowHistory,
    march: March,
    (width, height): (u32, u32),
) -> Result<(RgbImage, RenderStats)> {
    let d = flow.domain;
    let scene = wall_scene(state, d);
    // Frame the wall's neighbourhood: 90 % of the box across, a slab of
    // 30 % of it in depth around the wall's plane.
    let size = d.size();
    let view = Domain::new(
        d.origin + size * Vec3::new(0.05, 0.05, 0.35),
        0.05 * size.x,
        [18, 18, 6],
    )?;
    let settings = RenderSettings {
        step: Some(d.cell / march.div),
        jitter: march.jitter,
        ..RenderSettings::new(Camera::framing(&view, width, height, 0.95))
    };
    let r = render(&scene, &settings)?;
    Ok((output::preview(&r.image, &Display::default()), r.stats))
}

/// Refinement of the sampling that measures the wall, per axis.
const MEASURE_REFINE: usize = 2;

/// Of the wall sampled at [`MEASURE_REFINE`]× the velocity grid: its mass
/// `Σ_rows ∫ρ dV` and the mean over rows of each row's largest density
/// (the peak, what diffusion lowers even where mass is kept).
fn measure(state: &AdvectedWall, flow: &FlowHistory) -> (f64, f64) {
    let mut grid = ScalarGrid::zeros(flow.domain.refined(MEASURE_REFINE));
    let (mut mass, mut peak) = (0.0, 0.0);
    for r in &state.rows {
        grid.write_field(&**r);
        mass += grid.total();
        peak += grid.max_abs() as f64;
    }
    (mass, peak / state.rows.len() as f64)
}

/// Refinement of the quadrature of the analytic wall's `∫ρ₀ dV`.
const EXACT_REFINE: usize = 8;

/// One panel of a picture experiment: a holding of the wall rendered with a
/// march, named by what sets it apart from the other panels.
pub(crate) struct Panel {
    /// Row name in the figure and `panel` in `data.csv` (no commas).
    pub name: String,
    /// How the wall is held over the frames.
    pub holding: Holding,
    /// How its render is marched.
    pub march: March,
}

impl Panel {
    /// A panel named by its march (the panels differ in march only).
    pub fn marched(holding: Holding, march: March) -> Self {
        Self {
            name: march.label(),
            holding,
            march,
        }
    }
}

/// A picture experiment: the wall and flow, the image size, and the panels,
/// the first of which is the experiment's own figure.
pub(crate) struct Picture {
    /// What all panels share, printed over the figure (the frame and its
    /// time are added).
    pub title: String,
    /// The wall and flow.
    pub config: SphereWallConfig,
    /// Image size of each render.
    pub size: (u32, u32),
    /// The renders, the experiment's own first.
    pub panels: Vec<Panel>,
}

/// The picture of 07-8 and 08-1 at the sizes of [`config`]: `holding` alone,
/// marched with a jittered tenth of a cell; `title` of the frame count.
pub(crate) fn fine_picture(
    ctx: &Context,
    title: impl Fn(usize) -> String,
    holding: Holding,
) -> Picture {
    let config = config(ctx.size);
    Picture {
        title: title(config.frames),
        config,
        size: picture_size(ctx.size),
        panels: vec![Panel::marched(holding, March::jittered(10.0))],
    }
}

/// Zoom of the crops beside each full frame: a window of half the
/// picture's width and height, 2× enlarged, where the figure's first
/// difference is largest ([`render_difference::busiest_window`]).
const ZOOM: u32 = 2;

/// A difference between two panels of a picture experiment, drawn as a row
/// of its figure ([`render_difference`]): panel `of` minus panel `minus`.
pub(crate) struct Difference {
    /// Row name in the figure, without the amplification.
    pub name: String,
    pub of: usize,
    pub minus: usize,
}

impl Difference {
    /// The differences of each panel from the fine fixed march of the same
    /// holding (the panels with error columns in `data.csv`), named by
    /// march kind: "fixed − cell/10", "jittered − cell/10".
    fn against_fine(panels: &[Panel]) -> Vec<Self> {
        let mut out = vec![];
        for (of, p) in panels.iter().enumerate() {
            let fine = panels
                .iter()
                .position(|q| q.holding == p.holding && q.march == March::FINE);
            if let Some(minus) = fine.filter(|_| p.march != March::FINE) {
                let kind = if p.march.jitter { "jittered" } else { "fixed" };
                out.push(Self {
                    name: format!("{kind} − cell/{}", March::FINE.div),
                    of,
                    minus,
                });
            }
        }
        out
    }
}

/// A row of a picture experiment's `data.csv`: one panel.
#[derive(Serialize)]
struct PanelRow {
    /// The panel's name.
    panel: String,
    gridded_frames: usize,
    gridless_frames: usize,
    selma_map_res: usize,
    /// Δs in length units.
    march_step: f32,
    jitter: bool,
    render_seconds: f64,
    samples: u64,
    density_bytes: usize,
    /// `∫ρ_F / ∫ρ₀`, both at 2× sampling, `ρ₀` the analytic wall.
    mass_kept: f64,
    /// The same of the mean row peak.
    peak_kept: f64,
    /// Gridded holdings: the rows sampled at the cell centres, `Σ ρ Δx³`,
    /// over `∫ρ₀` at [`EXACT_REFINE`]× (`NaN` without gridded frames).
    mass_sampled: f64,
    /// Gridded holdings: `Σ ρ Δx³` after the gridded frames over that at
    /// frame 0 (`NaN` without gridded frames).
    mass_advected: f64,
    /// Seconds building the holding.
    setup_seconds: f64,
    /// Gradient energy of the picture, grey levels² per pixel
    /// ([`picture::gradient_energy`]).
    sharpness: f64,
    /// Against the panel of the same holding marched with [`March::FINE`]
    /// (`NaN` where there is none, and for that panel itself): rms error,
    /// grey levels ([`picture::error_spread`]).
    error_rms: f64,
    /// The rms of the error's part coherent between neighbouring pixels.
    coherent_error: f64,
    /// The share of the error's energy that is coherent.
    coherent_share: f64,
}

/// What a holding is and keeps, the same in every panel that shows it:
/// the holding's columns of [`PanelRow`].
#[derive(Clone, Copy)]
struct HoldingMeasures {
    gridded_frames: usize,
    gridless_frames: usize,
    selma_map_res: usize,
    density_bytes: usize,
    mass_kept: f64,
    peak_kept: f64,
    mass_sampled: f64,
    mass_advected: f64,
    setup_seconds: f64,
}

/// A holding built once for every panel that shows it.
struct Built {
    holding: Holding,
    state: AdvectedWall,
    measures: HoldingMeasures,
}

impl Built {
    /// Build `holding` of `setup`'s wall in its flow, timed, and measure it
    /// against the initial mass and peak `[m0, p0]` and the wall's `exact`
    /// mass.
    fn new(holding: Holding, setup: &Setup, [m0, p0]: [f64; 2], exact: f64) -> Result<Self> {
        let Setup { config, flow, wall } = setup;
        let f = flow.frames();
        let t = Instant::now();
        let (state, grid_mass) = holding.advect(wall, flow)?;
        let setup_seconds = t.elapsed().as_secs_f64();
        let (gridded_frames, gridless_frames, selma_map_res) = match holding {
            Holding::Gridless { frames } => (f - frames.min(f), frames.min(f), 0),
            Holding::Selma { factor } => (0, 0, factor * config.res),
            Holding::MacCormack => (f, 0, 0),
        };
        let (m, p) = measure(&state, flow);
        let [mass_sampled, mass_advected] =
            grid_mass.map_or([f64::NAN; 2], |[m0, mf]| [m0 / exact, mf / m0]);
        let measures = HoldingMeasures {
            gridded_frames,
            gridless_frames,
            selma_map_res,
            density_bytes: state.bytes(),
            mass_kept: m / m0,
            peak_kept: p / p0,
            mass_sampled,
            mass_advected,
            setup_seconds,
        };
        Ok(Self {
            holding,
            state,
            measures,
        })
    }
}

/// Gridless frames at the end of the run: the notes' 10 of 60.
fn last_sixth(frames: usize) -> usize {
    (frames / 6).max(1)
}

/// The picture of 07-6 and 07-7: the wall gridded but for its last sixth
/// of frames, rendered with each of `marches`, the experiment's own first.
pub(crate) fn last_sixth_picture(ctx: &Context, id: &str, marches: &[March]) -> Picture {
    let config = figure_config(ctx.size);
    let f = config.frames;
    let k = last_sixth(f);
    let holding = Holding::Gridless { frames: k };
    Picture {
        title: format!("{id}: {} gridded + {k} gridless", f - k),
        config,
        size: figure_size(ctx.size),
        panels: marches
            .iter()
            .map(|&m| Panel::marched(holding, m))
            .collect(),
    }
}

/// The picture experiments: run the flow, build each panel's holding (once
/// per holding), render it with the panel's march, and write
///
/// - `render.png`: the first panel, the experiment's figure;
/// - `figure.png`: every panel as a row, full frame (the crop window
///   outlined) and the crop [`ZOOM`]× enlarged side by side, then a row per
///   [`Difference`] — each panel's against the fine fixed march of the
///   same holding, then `extra` — amplified, all labelled in the pixels
///   (the panel, the frame and its time, the march, the amplification);
/// - `initial_final.png`: fig 7.3 (frame 0, the analytic wall, marched at
///   a jittered cell/10) beside the first panel, labelled;
/// - `data.csv`: a [`PanelRow`] per panel — frames gridded and gridless,
///   SELMA map cells, march step and jitter, render seconds and samples,
///   density bytes, mass and peak kept, the gridded part's mass factors,
///   the picture's sharpness and its error against the fine fixed march of
///   the same holding, in whole and coherent;
/// - `manifest.json`.
pub(crate) fn run_picture(ctx: &Context, pic: Picture) -> Result<()> {
    run_compared(ctx, pic, vec![])
}

/// [`run_picture`] with the `extra` differences drawn after the ones
/// against the fine march.
pub(crate) fn run_compared(ctx: &Context, pic: Picture, extra: Vec<Difference>) -> Result<()> {
    let start = Instant::now();
    let setup = Setup::of(ctx, pic.config)?;
    let Setup { config, flow, wall } = &setup;
    let f = flow.frames();
    let initial = AdvectedWall::gridless(wall, None, flow, 0)?;
    let (m0, p0) = measure(&initial, flow);
    let exact: f64 = wall
        .rows
        .iter()
        .map(|r| probe::integral(&**r, &flow.domain, EXACT_REFINE))
        .sum();
    let mut built: Vec<Built> = vec![];
    let mut renders = vec![];
    for panel in &pic.panels {
        let i = match built.iter().position(|b| b.holding == panel.holding) {
            Some(i) => i,
            None => {
                built.push(Built::new(panel.holding, &setup, [m0, p0], exact)?);
                built.len() - 1
            }
        };
        let (img, stats) = render_wall(&built[i].state, flow, panel.march, pic.size)?;
        renders.push((i, img, stats));
    }
    let rows = panel_rows(&pic.panels, &renders, &built)?;
    let time = |frame: usize| format!("frame {frame}, t = {:.2} s", frame as f32 * flow.dt);
    let title = format!("{} · {} · {}³ flow", pic.title, time(f), config.res);
    let names: Vec<String> = pic.panels.iter().map(|p| p.name.clone()).collect();
    let figure = difference_figure(&pic.panels, &renders, extra);
    let row_names: Vec<String> = names.iter().chain(&figure.names).cloned().collect();
    let (w, h) = pic.size;
    let columns = [format!("full frame {w}×{h}"), figure.crop_heading()];
    let title = if figure.gains.is_empty() {
        title
    } else {
        format!("{title} · differences of luma: orange +, blue −")
    };
    panels::save(
        &ctx.out.join("figure.png"),
        &figure.grid,
        6,
        &panels::Labels {
            title: &title,
            rows: &row_names,
            columns: &columns,
        },
    )?;
    let first = &renders[0].1;
    io::write_png(&ctx.out.join("render.png"), first)?;
    let (img0, _) = render_wall(&initial, flow, March::jittered(10.0), pic.size)?;
    let headings = [
        format!("{} · fig 7.3", time(0)),
        format!("{} · {}", time(f), names[0]),
    ];
    panels::save_row(
        &ctx.out.join("initial_final.png"),
        &[img0, first.clone()],
        6,
        &pic.title,
        &headings,
    )?;
    write_rows(&ctx.out.join("data.csv"), &rows)?;
    let holdings: Vec<&Holding> = built.iter().map(|b| &b.holding).collect();
    let marches: Vec<March> = pic.panels.iter().map(|p| p.march).collect();
    let extra = serde_json::json!({
        "title": pic.title,
        "panels": names,
        "holdings": holdings,
        "marches": marches,
        "image": pic.size,
        "frames": f,
        "dt": flow.dt,
        "max_speed": flow.max_speed(),
        "renders": renders.iter().map(|r| r.2).collect::<Vec<_>>(),
        "rows": rows,
        "difference_gains": figure.gains,
        "crop": figure.crop,
    });
    ctx.write_manifest(config, 0, start, extra)
}

/// The [`PanelRow`] of each panel rendered as `renders` (the index of its
/// holding in `built`, the picture, the render's statistics).
fn panel_rows(
    panels: &[Panel],
    renders: &[(usize, RgbImage, RenderStats)],
    built: &[Built],
) -> Result<Vec<PanelRow>> {
    let mut rows = vec![];
    for ((i, img, stats), panel) in renders.iter().zip(panels) {
        let reference = renders
            .iter()
            .zip(panels)
            .find(|((j, ..), p)| j == i && p.march == March::FINE && p.march != panel.march);
        let spread = match reference {
            Some(((_, r, _), _)) => Some(picture::error_spread(img, r)?),
            None => None,
        };
        let m = built[*i].measures;
        rows.push(PanelRow {
            panel: panel.name.clone(),
            gridded_frames: m.gridded_frames,
            gridless_frames: m.gridless_frames,
            selma_map_res: m.selma_map_res,
            march_step: stats.step,
            jitter: panel.march.jitter,
            render_seconds: stats.seconds,
            samples: stats.samples,
            density_bytes: m.density_bytes,
            mass_kept: m.mass_kept,
            peak_kept: m.peak_kept,
            mass_sampled: m.mass_sampled,
            mass_advected: m.mass_advected,
            setup_seconds: m.setup_seconds,
            sharpness: picture::gradient_energy(img),
            error_rms: spread.map_or(f64::NAN, |s| s.rms),
            coherent_error: spread.map_or(f64::NAN, |s| s.coherent),
            coherent_share: spread.map_or(f64::NAN, |s| s.coherent_share),
        });
    }
    Ok(rows)
}

/// The rows of a picture experiment's `figure.png` and what they show.
struct DifferenceFigure {
    /// Per panel its full frame and crop, then per difference the same.
    grid: Vec<Vec<RgbImage>>,
    /// The differences' row names, with their amplification.
    names: Vec<String>,
    /// The amplification of each difference row.
    gains: Vec<u32>,
    /// The crop window: left, top, width, height in pixels.
    crop: [u32; 4],
}

impl DifferenceFigure {
    /// The crop column's heading: the zoom and the window's place.
    fn crop_heading(&self) -> String {
        let [x, y, w, h] = self.crop;
        format!("crop {ZOOM}×: x {x}–{}, y {y}–{}", x + w, y + h)
    }
}

/// The figure rows of `renders` (one per panel) and of their differences
/// ([`Difference::against_fine`], then `extra`), each amplified to be seen
/// ([`render_difference::gain`], stated in its row name); the crops at the window where the first
/// difference is largest (the middle without any), outlined on the full
/// frames.
fn difference_figure(
    panels: &[Panel],
    renders: &[(usize, RgbImage, RenderStats)],
    extra: Vec<Difference>,
) -> DifferenceFigure {
    let mut diffs = Difference::against_fine(panels);
    diffs.extend(extra);
    let img = |i: usize| &renders[i].1;
    let (w, h) = img(0).dimensions();
    let window = (w / ZOOM, h / ZOOM);
    let values: Vec<Vec<f64>> = diffs
        .iter()
        .map(|d| render_difference::luma_difference(img(d.of), img(d.minus)))
        .collect();
    let origin = match values.first() {
        Some(d) => render_difference::busiest_window(d, w, window),
        None => ((w - window.0) / 2, (h - window.1) / 2),
    };
    let gains: Vec<u32> = values.iter().map(|d| render_difference::gain(d)).collect();
    let row = |full: &RgbImage| {
        let crop = render_difference::zoom_window(full, origin, window, ZOOM);
        vec![render_difference::outlined(full, origin, window), crop]
    };
    let mut grid: Vec<Vec<RgbImage>> = renders.iter().map(|(_, i, _)| row(i)).collect();
    grid.extend(
        values
            .iter()
            .zip(&gains)
            .map(|(d, &k)| row(&render_difference::image(d, w, k))),
    );
    DifferenceFigure {
        grid,
        names: diffs
            .iter()
            .zip(&gains)
            .map(|(d, k)| format!("{}, ×{k}", d.name))
            .collect(),
        gains,
        crop: [origin.0, origin.1, window.0, window.1],
    }
}

/// Passes of the cost studies over all their points after the measured
/// one, each rendering every point once more; a point's time is the
/// fastest of all its renders. A slow spell of the shared machine
/// outlasted the measured pass's three back-to-back renders of a point
/// (08-2's flat SELMA time fitted "unclear" at 4ff6aa6, one point 12–45 %
/// slow; 07-10's gridless time at 90a358d, r² 0.90); a pass apart, it
/// rarely hits all.
pub(crate) const TIMING_PASSES: usize = 2;

/// Renders of each cost point; its time is the fastest. On a shared
/// machine one render in ten or so runs 10–20 % slow, and one such frame
/// had made 08-2's flat SELMA render time fit as "unclear".
const RENDER_REPEATS: usize = 3;

/// [`render_wall`] [`RENDER_REPEATS`] times: the picture, the statistics
/// with the fastest time (and the rates from it), and the gridless walk
/// steps of the first render alone.
pub(crate) fn fastest_render(
    state: &AdvectedWall,
    flow: &FlowHistory,
    march_div: f32,
    size: (u32, u32),
) -> Result<(RgbImage, RenderStats, u64)> {
    let (img, mut stats) = render_wall(state, flow, March::jittered(march_div), size)?;
    let walk_steps = state.walk_steps();
    for _ in 1..RENDER_REPEATS {
        let (_, again) = render_wall(state, flow, March::jittered(march_div), size)?;
        stats.seconds = stats.seconds.min(again.seconds);
    }
    let seconds = stats.seconds.max(1e-12);
    stats.samples_per_second = stats.samples as f64 / seconds;
    stats.substeps_per_second = (stats.samples + stats.skipped) as f64 / seconds;
    Ok((img, stats, walk_steps))
}

/// One measured render of a cost study: a row of its `data.csv`.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub(crate) struct CostRow {
    /// Series name (`march=cell`, `selma-fine`, …).
    pub series: String,
    /// The x of the plots: gridless frames (07-10) or advected frames (08-2).
    pub frames: usize,
    /// Render wall time, seconds: the fastest of [`RENDER_REPEATS`] renders,
    /// then of the later passes' ([`Self::time_again`]).
    pub render_seconds: f64,
    /// Bytes held by the density representation, counted (each buffer once).
    pub density_bytes: usize,
    /// Measured: the most the heap held at once above its level before,
    /// while the holding was built and rendered ([`memory::measure`]).
    pub heap_peak_bytes: usize,
    /// Measured: the resident set's high-water mark above its level before,
    /// over the same work (empty where `/proc` cannot be used).
    pub rss_peak_bytes: Option<usize>,
    /// Camera-ray samples.
    pub samples: u64,
    /// Backward steps walked by the gridless chain over the build and the
    /// first render ([`AdvectedWall::walk_steps`]; zero without a chain).
    pub walk_steps: u64,
}

impl CostRow {
    /// Build a holding with `build`, render it with march step
    /// `cell / march_div`, and record what it cost: the row, and the picture.
    /// The holding is built inside the measurement and dropped before it
    /// ends, so everything it allocates is measured; `build` must allocate
    /// what the holding keeps (see [`owned_frames`]).
    pub fn measure(
        series: &str,
        frames: usize,
        build: impl FnOnce() -> Result<AdvectedWall>,
        flow: &FlowHistory,
        march_div: f32,
        size: (u32, u32),
    ) -> Result<(Self, RgbImage)> {
        let (out, peak) = memory::measure(|| -> Result<_> {
            let state = build()?;
            let (img, stats, walk_steps) = fastest_render(&state, flow, march_div, size)?;
            Ok((img, stats, state.bytes(), walk_steps))
        });
        let (img, stats, density_bytes, walk_steps) = out?;
        let row = Self {
            series: series.into(),
            frames,
            render_seconds: stats.seconds,
            density_bytes,
            heap_peak_bytes: peak.heap_bytes,
            rss_peak_bytes: peak.rss_bytes,
            samples: stats.samples,
            walk_steps,
        };
        Ok((row, img))
    }

    /// A later timing pass ([`TIMING_PASSES`]): render `state` (the point
    /// rebuilt) once more; `render_seconds` keeps the fastest.
    pub fn time_again(
        &mut self,
        state: &AdvectedWall,
        flow: &FlowHistory,
        march_div: f32,
        size: (u32, u32),
    ) -> Result<()> {
        let (_, stats) = render_wall(state, flow, March::jittered(march_div), size)?;
        self.render_seconds = self.render_seconds.min(stats.seconds);
        Ok(())
    }
}

/// Render `state` once, unmeasured: the first render of a kind of holding
/// starts the worker threads and their thread-local caches, which would
/// otherwise be measured in the first point of a cost study (at smoke size
/// 1 MiB of RSS for the first render, 75 kB of heap for the first SELMA one).
pub(crate) fn warm_up(state: &AdvectedWall, flow: &FlowHistory, size: (u32, u32)) -> Result<()> {
    render_wall(state, flow, March::jittered(1.0), size)?;
    Ok(())
}

/// `flow` with frames `range` deep-copied. A gridless holding keeps its
/// velocity grids; here they would otherwise be shared with the recorded
/// history (and cost nothing measurable), whereas a simulation keeps them
/// only for its gridless gases.
pub(crate) fn owned_frames(flow: &FlowHistory, range: std::ops::Range<usize>) -> FlowHistory {
    FlowHistory {
        domain: flow.domain,
        dt: flow.dt,
        backtrace: flow.backtrace,
        velocities: flow
            .velocities
            .iter()
            .enumerate()
            .map(|(i, u)| {
                if range.contains(&i) {
                    Arc::new((**u).clone())
                } else {
                    Arc::clone(u)
                }
            })
            .collect(),
    }
}

/// Thresholds of the trends reported in `summary.csv`: linear if the fit
/// grows by ≥ 20 % of the mean over the frames with r² ≥ 0.9, flat within
/// ±5 %.
pub(crate) const TRENDS: Criteria = Criteria {
    min_growth: 0.2,
    min_r2: 0.9,
    max_flat: 0.05,
};

/// One line of a cost study's `summary.csv`: a fitted quantity of a series.
#[derive(Clone, Debug, Serialize)]
pub(crate) struct SeriesFit {
    /// Series name.
    pub series: String,
    /// `render_seconds`, `counted_mib`, `heap_mib` or `rss_mib`.
    pub quantity: &'static str,
    /// Least-squares slope per frame (seconds or MiB).
    pub slope: f64,
    /// Fitted change over the frames relative to the mean ([`growth`]).
    pub relative_growth: f64,
    /// r² of the line.
    pub r2: f64,
    /// The verdict under [`TRENDS`].
    pub trend: Trend,
}

const MIB: f64 = 1048576.0;

/// The quantities of a cost row that are fitted: name and value.
type Quantity = (&'static str, fn(&CostRow) -> Option<f64>);

const QUANTITIES: [Quantity; 4] = [
    ("render_seconds", |r| Some(r.render_seconds)),
    ("counted_mib", |r| Some(r.density_bytes as f64 / MIB)),
    ("heap_mib", |r| Some(r.heap_peak_bytes as f64 / MIB)),
    ("rss_mib", |r| r.rss_peak_bytes.map(|b| b as f64 / MIB)),
];

/// Plot render time and memory against frames from `data.csv` of `dir`:
/// `time.{png,svg}`; `memory.{png,svg}` with the counted bytes (solid) and
/// the measured heap peak (dashed) of each series; `rss.{png,svg}`, the
/// measured resident-set peak; all three on `costs.png`. Each quantity of
/// each series is fitted ([`growth::classify`]); the fits are printed on the
/// plots, written to `summary.csv` and returned.
pub(crate) fn plot_costs(dir: &Path, title: &str, x_label: &str) -> Result<Vec<SeriesFit>> {
    let rows: Vec<CostRow> = read_rows(&dir.join("data.csv"))?;
    let mut names: Vec<String> = vec![];
    for r in &rows {
        if !names.contains(&r.series) {
            names.push(r.series.clone());
        }
    }
    // Per plot (time, memory, rss): its series and their fit labels.
    let mut parts: [Vec<(Series, String)>; 3] = Default::default();
    let mut fits = vec![];
    for (i, name) in names.iter().enumerate() {
        let color = PALETTE[i % PALETTE.len()];
        for (q, (quantity, value)) in QUANTITIES.iter().enumerate() {
            let pts: Vec<(f64, f64)> = rows
                .iter()
                .filter(|r| &r.series == name)
                .filter_map(|r| Some((r.frames as f64, value(r)?)))
                .collect();
            let g = growth::classify(&pts, &TRENDS);
            let unit = if q == 0 { "s" } else { "MiB" };
            let short = quantity.split('_').next().unwrap_or(quantity);
            let label = g.map_or(format!("{name} {short}: no fit"), |g| {
                format!(
                    "{name} {short}: {:.4} {unit}/frame, r² {:.2}",
                    g.fit.slope, g.r2
                )
            });
            let (plot, style) = match q {
                0 => (0, Style::LineMarkers),
                1 => (1, Style::LineMarkers),
                2 => (1, Style::Dashed),
                _ => (2, Style::LineMarkers),
            };
            let series = Series::line(format!("{name} {short}"), pts)
                .styled(style)
                .colored(color);
            parts[plot].push((series, label));
            if let Some(g) = g {
                fits.push(SeriesFit {
                    series: name.clone(),
                    quantity,
                    slope: g.fit.slope,
                    relative_growth: g.relative,
                    r2: g.r2,
                    trend: g.trend,
                });
            }
        }
    }
    let plots = [
        ("time", format!("{title}: render time"), "render seconds"),
        (
            "memory",
            format!("{title}: memory counted (solid), heap peak measured (dashed)"),
            "MiB",
        ),
        ("rss", format!("{title}: resident-set peak measured"), "MiB"),
    ];
    let mut imgs = vec![];
    for ((base, heading, y_label), part) in plots.into_iter().zip(parts) {
        let mut plot = Plot::new(heading, x_label, y_label).legend(LegendPosition::UpperLeft);
        for (j, (series, label)) in part.into_iter().enumerate() {
            plot = plot.series(series).annotate(Annotation::at_fraction(
                0.35,
                0.06 + 0.06 * j as f64,
                label,
            ));
        }
        let [png, _] = plot.write(&dir.join(base))?;
        imgs.push(image::open(&png)?.to_rgb8());
    }
    write_rows(&dir.join("summary.csv"), &fits)?;
    io::write_png(&dir.join("costs.png"), &preview::side_by_side(&imgs, 0))?;
    Ok(fits)
}
