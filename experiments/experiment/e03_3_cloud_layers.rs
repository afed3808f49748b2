//! # 03-3 — layers of pyroclastic displacement (fig 3.3)
//!
//! Reproduces the notes' figure 3.3 (§3.3.2–3.3.3): the base cloud (the
//! Stanford bunny's signed distance, see `cloud_figures`) with no
//! displacement, then one, two
//! and three layers of `cumulo` (eq 3.5) from the `NoiseLayers` script (eqs
//! 3.6–3.7): each layer samples its noise on the surface left by the
//! previous ones (`levelsetsurface`, eq 3.3) and is cached on a finer grid
//! before the next. Shown as geometry: a hard-surfaced render of `mask(ℓ)`
//! and the surface-net mesh of each panel.
//!
//! Run: `smokelab experiment 03-3` (about 70 s on 2 cores, most of it the
//! bunny's mesh distance — every triangle per query — cached on the 64³
//! base grid; layers cached on 64³, 96³, 128³, 256² panels; `--full` 128³
//! and 512², `--smoke` 16³ and 64² in about 1 s).
//!
//! Writes `results/03-3/`: `layers.png` (base, 1, 2, 3 layers left to
//! right, labelled), `layers_<n>.obj`, `data.csv` (volume and triangles per
//! panel; the base's volume is the bunny's, 0.548 inside the scaled mesh),
//! `manifest.json`.

use std::time::Instant;

use anyhow::Result;
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::cloud_figures::{
    base, cloud, layers, panel_rows, write_panels, write_table, Look, Panel, SCALE,
};
use smokelab::field::ops::constant;
use smokelab::io;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "03-3",
    folder: "03-3",
    reproduces: "fig 3.3",
    title: "cumulo: 0, 1, 2, 3 layers of pyroclastic displacement (geometry)",
    cost: "~70 s",
    run,
};

#[derive(Serialize)]
struct Config {
    layers: [usize; 4],
    scale: f32,
    grid: usize,
    pixels: u32,
}

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let (grid, pixels) = ctx.size.pick((16, 64), (64, 256), (128, 512));
    io::create_output_dir(&ctx.out)?;
    let all = layers(3, constant(SCALE));
    let bunny = base(grid)?;
    let mut panels = Vec::new();
    for n in 0..=3 {
        panels.push(Panel {
            label: format!("layers_{n}"),
            heading: match n {
                0 => "base".to_string(),
                1 => "1 layer".to_string(),
                _ => format!("{n} layers"),
            },
            level_set: cloud(bunny.clone(), &all[..n], 0, grid)?,
            density: None,
        });
    }
    let labels: Vec<String> = panels.iter().map(|p| p.label.clone()).collect();
    let shown = write_panels(
        ctx,
        panels,
        (grid, pixels),
        Look::Geometry,
        ("cumulo on the Stanford bunny", "layers.png"),
    )?;
    let rows = panel_rows(labels, shown);
    let config = Config {
        layers: [0, 1, 2, 3],
        scale: SCALE,
        grid,
        pixels,
    };
    write_table(ctx, config, &rows, start)
}
