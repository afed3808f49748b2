//! # 03-4 and 03-5 — clearing the canyons with `billow` (figs 3.4, 3.5)
//!
//! Reproduces the notes' figures 3.4 (geometry) and 3.5 (volume renders),
//! §3.4: the three-layer bunny cloud of 03-3 with every layer after the
//! first cleared by eq 3.8, `N_i^c = N_i · clamp(|N_{i−1}^c| / Q_i, 0, 1)^billow`,
//! for billow = 0.33, 0.5, 0.67, 1, 2. The notes' `Q = 1` is for
//! unit-amplitude noise; ours sets `Q_i` against the previous cleared
//! layer's amplitude, its maximum over the bunny's surface
//! ([`crate::experiment::shared::cloud_figures::QUANTILE`]), so the clamp never saturates and
//! larger billow clears the finer layers from the valleys of the coarser
//! ones, leaving them only on the peaks.
//!
//! Run: `smokelab experiment 03-4` (geometry: hard-surfaced renders and
//! meshes) or `smokelab experiment 03-5` (soft volume renders), 50 s and
//! 45 s on 2 cores, most of it the bunny's mesh distance on the 64³ base
//! grid (layers cached on 64³, 96³, 128³, 256² panels; `--full` 128³ and
//! 512², `--smoke` 16³ and 64² in about 1 s).
//!
//! What shows. At panel size the whole bunnies look alike: the first layer
//! (which eq 3.8 leaves alone) makes most of the relief, and the cleared
//! layers add at most `Q_2 ≈ 0.14` to it. So each figure has a second row
//! that separates the two: the material the cleared layers add to the
//! first layer's cloud, `mask(ℓ) − mask(ℓ_1)`, in orange over the first
//! layer's cloud in white — for 03-4 a ×3 close-up of the middle of the
//! framed box under the same light, for 03-5 the section through the
//! box's mid-plane. At billow 0.33 the orange covers the surface, canyons
//! included; with rising billow it withdraws to the peaks of the first
//! layer, and at billow 2 the canyons are bare white. Measured
//! (`smokelab experiment 03-4`, default size): the mean cleared
//! displacement falls from 0.0217 to 0.0050 (23 %), and the share of the
//! surface the cleared layers raise by less than 0.01 (`bare_share`)
//! rises from 0.26 to 0.84.
//!
//! Writes `results/03-4/` (`billow.png`, `billow_<b>.obj`) or
//! `results/03-5/` (`billow.png`), rows and columns labelled, with
//! `data.csv` (per billow: the measured `Q_2`, `Q_3`, volume, triangles,
//! the mean displacement `Σ|N_i^c|` over the bunny's surface of all layers
//! and of the cleared ones, and `bare_share`) and `manifest.json`.

use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::cloud_figures::{
    domain, mean, render_panels, write_table, Look, Panel, Wedge, CLOUD_COLOR, QUANTILE, SCALE,
};
use crate::experiment::shared::model_render::render_framed;
use crate::figures::panels;
use smokelab::domain::Domain;
use smokelab::field::ops;
use smokelab::field::Scalar;
use smokelab::io::{self, preview};

/// Registry entry of the geometry (fig 3.4).
pub const GEOMETRY: Experiment = Experiment {
    id: "03-4",
    folder: "03-4",
    reproduces: "fig 3.4",
    title: "billow 0.33, 0.5, 0.67, 1, 2 clearing the canyons (geometry)",
    cost: "~80 s",
    run: run_geometry,
};

/// Registry entry of the volume renders (fig 3.5).
pub const RENDERS: Experiment = Experiment {
    id: "03-5",
    folder: "03-5",
    reproduces: "fig 3.5",
    title: "billow 0.33, 0.5, 0.67, 1, 2 clearing the canyons (volume renders)",
    cost: "~80 s",
    run: run_renders,
};

/// The billow values of the notes' wedge.
pub(crate) const BILLOWS: [f32; 5] = [0.33, 0.5, 0.67, 1.0, 2.0];
/// A surface point the cleared layers raise by less than this is bare
/// (`bare_share`): a twentieth of the first layer's amplitude [`SCALE`].
const BARE: f64 = 0.01;
/// Magnification of the close-up row of the geometry figure.
const CLOSE_UP: f32 = 3.0;
/// Display colour of the material the cleared layers add.
const ADDED_COLOR: Vec3 = Vec3::new(1.0, 0.5, 0.15);

#[derive(Serialize)]
struct Config {
    billows: [f32; 5],
    quantile: f32,
    scale: f32,
    bare_below: f64,
    close_up: f32,
    grid: usize,
    pixels: u32,
}

/// One row of `data.csv`.
#[derive(Serialize)]
struct Row {
    billow: f32,
    /// `Q_2`, `Q_3` of eq 3.8 as measured.
    q2: f32,
    q3: f32,
    volume: f64,
    triangles: usize,
    /// Mean over the bunny's surface of `Σ_i |N_i^c|`, all three layers:
    /// the displacement of the surface from the undisplaced base (eq 3.4
    /// adds `|N_i^c|` at the surface point, eq 3.5 sums the layers).
    displacement_total: f64,
    /// The same for the two cleared layers alone (`i ≥ 1`), what billow
    /// acts on (eq 3.8 leaves `N_0` as it is).
    displacement_cleared: f64,
    /// Share of the bunny's surface points where the cleared layers
    /// displace by less than [`BARE`]: the canyons they leave bare, which
    /// the figure shows white.
    bare_share: f64,
}

fn run_wedge(ctx: &Context, look: Look) -> Result<()> {
    let start = Instant::now();
    let (grid, pixels) = ctx.size.pick((16, 64), (64, 256), (128, 512));
    io::create_output_dir(&ctx.out)?;
    let wedge = Wedge::new(grid)?;
    let mut panels = Vec::new();
    let mut rows = Vec::new();
    for &b in &BILLOWS {
        let c = wedge.cloud(b)?;
        let per_point = wedge.displacements(&c.cleared[1..]);
        rows.push(Row {
            billow: b,
            q2: c.q[0],
            q3: c.q[1],
            volume: 0.0,
            triangles: 0,
            displacement_total: wedge.displacement(&c.cleared),
            displacement_cleared: mean(&per_point),
            bare_share: per_point.iter().filter(|&&d| d < BARE).count() as f64
                / per_point.len() as f64,
        });
        panels.push(Panel {
            label: format!("billow_{b}"),
            heading: format!("billow = {b}"),
            level_set: c.level_set,
            density: None,
        });
    }
    let headings: Vec<String> = panels.iter().map(|p| p.heading.clone()).collect();
    let added: Vec<Scalar> = panels.iter().map(|p| wedge.added(&p.level_set)).collect();
    let labels: Vec<String> = panels.iter().map(|p| p.label.clone()).collect();
    let rendered = render_panels(ctx, panels, (grid, pixels), look)?;
    let dom = domain(grid)?;
    let core = ops::mask(wedge.first.clone());
    let (title, row_names, images) = match look {
        Look::Geometry => {
            let close = close_up(rendered.frame, CLOSE_UP)?;
            let coloured = labels
                .iter()
                .zip(&added)
                .map(|(label, added)| {
                    render_framed(
                        vec![
                            (format!("{label}_core"), core.clone(), CLOUD_COLOR),
                            (format!("{label}_added"), added.clone(), ADDED_COLOR),
                        ],
                        (dom, close),
                        pixels,
                        0.25,
                        look.kappa(),
                    )
                })
                .collect::<Result<Vec<_>>>()?;
            (
                "canyon clearing (eq 3.8): geometry; orange = raised by layers 2–3",
                vec!["whole cloud".to_string(), format!("centre, ×{CLOSE_UP}")],
                vec![rendered.images, coloured],
            )
        }
        Look::Volume => {
            let sections = added
                .iter()
                .map(|added| {
                    preview::field_slice(
                        &[
                            preview::FieldLayer {
                                field: &*core,
                                color: CLOUD_COLOR.to_array(),
                            },
                            preview::FieldLayer {
                                field: &**added,
                                color: ADDED_COLOR.to_array(),
                            },
                        ],
                        &rendered.frame,
                        pixels,
                        4.0,
                    )
                })
                .collect();
            (
                "canyon clearing (eq 3.8): volume renders; orange = raised by layers 2–3",
                vec!["volume render".to_string(), "mid-plane section".to_string()],
                vec![rendered.images, sections],
            )
        }
    };
    panels::save(
        &ctx.out.join("billow.png"),
        &images,
        6,
        &panels::Labels {
            title,
            rows: &row_names,
            columns: &headings,
        },
    )?;
    for (row, s) in rows.iter_mut().zip(rendered.shown) {
        row.volume = s.volume;
        row.triangles = s.mesh.triangles.len();
    }
    let config = Config {
        billows: BILLOWS,
        quantile: QUANTILE,
        scale: SCALE,
        bare_below: BARE,
        close_up: CLOSE_UP,
        grid,
        pixels,
    };
    write_table(ctx, config, &rows, start)
}

/// The middle of `frame`, `1/zoom` of its size along each axis: what the
/// close-up renders frame.
fn close_up(frame: Domain, zoom: f32) -> Result<Domain> {
    let size = frame.size() / zoom;
    Ok(Domain::new(
        frame.origin + 0.5 * (frame.size() - size),
        frame.cell / zoom,
        frame.dims,
    )?)
}

fn run_geometry(ctx: &Context) -> Result<()> {
    run_wedge(ctx, Look::Geometry)
}

fn run_renders(ctx: &Context) -> Result<()> {
    run_wedge(ctx, Look::Volume)
}
