//! # 03-4 and 03-5 — clearing the canyons with `billow` (figs 3.4, 3.5)
//!
//! Reproduces the notes' figures 3.4 (geometry) and 3.5 (volume renders),
//! §3.4: the three-layer cloud of 03-3 with every layer after the first
//! cleared by eq 3.8, `N_i^c = N_i · clamp(|N_{i−1}^c| / Q, 0, 1)^billow`,
//! for billow = 0.33, 0.5, 0.67, 1, 2 and `Q` half the first layer's
//! amplitude. Larger billow clears the finer layers from the valleys of
//! the coarser ones, leaving them only on the peaks.
//!
//! Run: `smokelab experiment 03-4` (geometry: hard-surfaced renders and
//! meshes) or `smokelab experiment 03-5` (soft volume renders), each about
//! 5 s on 2 cores (64³ base grid, layers cached on 64³, 96³, 128³, 256²
//! panels; `--full` 128³ and 512², `--smoke` 16³ and 64²).
//!
//! Writes `results/03-4/` (`billow.png`, `billow_<b>.obj`) or
//! `results/03-5/` (`billow.png`), each with `data.csv` (volume and
//! triangles per panel) and `manifest.json`.

use anyhow::Result;
use serde::Serialize;

use crate::cloud_figures::{cloud, layers, write_panels, Look, Panel, SCALE};
use crate::model_render::by_size;
use crate::registry::{Context, Experiment};
use smokelab::field::ops::constant;
use smokelab::io;
use smokelab::model::cloud::billow;

/// Registry entry of the geometry (fig 3.4).
pub const GEOMETRY: Experiment = Experiment {
    id: "03-4",
    folder: "03-4",
    reproduces: "fig 3.4",
    title: "billow 0.33, 0.5, 0.67, 1, 2 clearing the canyons (geometry)",
    cost: "~5 s",
    run: run_geometry,
};

/// Registry entry of the volume renders (fig 3.5).
pub const RENDERS: Experiment = Experiment {
    id: "03-5",
    folder: "03-5",
    reproduces: "fig 3.5",
    title: "billow 0.33, 0.5, 0.67, 1, 2 clearing the canyons (volume renders)",
    cost: "~5 s",
    run: run_renders,
};

/// The billow values of the notes' wedge.
pub(crate) const BILLOWS: [f32; 5] = [0.33, 0.5, 0.67, 1.0, 2.0];

#[derive(Serialize)]
struct Config {
    billows: [f32; 5],
    q: f32,
    scale: f32,
    grid: usize,
    pixels: u32,
}

/// The three-layer cloud with canyon clearing `b` (eq 3.8).
pub(crate) fn billowed(b: f32, grid: usize) -> Result<smokelab::field::Scalar> {
    let cleared = billow(&layers(3, constant(SCALE)), 0.5 * SCALE, constant(b));
    cloud(&cleared, grid)
}

fn run_wedge(ctx: &Context, look: Look) -> Result<()> {
    let (grid, pixels) = by_size(ctx.size, [(16, 64), (64, 256), (128, 512)]);
    io::create_output_dir(&ctx.out)?;
    let panels = BILLOWS
        .iter()
        .map(|&b| {
            Ok(Panel {
                label: format!("billow_{b}"),
                level_set: billowed(b, grid)?,
                density: None,
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let config = Config {
        billows: BILLOWS,
        q: 0.5 * SCALE,
        scale: SCALE,
        grid,
        pixels,
    };
    write_panels(ctx, config, panels, (grid, pixels), look, "billow.png")
}

fn run_geometry(ctx: &Context) -> Result<()> {
    run_wedge(ctx, Look::Geometry)
}

fn run_renders(ctx: &Context) -> Result<()> {
    run_wedge(ctx, Look::Volume)
}
