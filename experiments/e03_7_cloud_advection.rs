//! # 03-7 — gridless advection of a modelled cloud (fig 3.7)
//!
//! Reproduces the notes' figure 3.7 (§3.5): the three-layer cloud with
//! billow 1 (03-4), its density `mask(ℓ)` advected gridlessly by the noisy
//! velocity of eq 3.9 — Perlin noise at three offset points, frequency 3 —
//! for 4 steps of Δt = 0.05: no advection, medium (amplitude 0.6) and
//! strong (amplitude 1.8). The advected density is never gridded: each
//! render query walks back 4 steps (eq 7.4 without sources). Strong
//! advection tears wisps from the main body.
//!
//! Run: `smokelab experiment 03-7` (about 3 s on 2 cores: 64³ base grid,
//! 256² panels; `--full` 128³ and 512², `--smoke` 16³ and 64²).
//!
//! Writes `results/03-7/`: `advection.png` (none, medium, strong, left to
//! right), `data.csv` (volume per panel on the base grid: eq 3.9 is not
//! divergence-free, so the volume changes), `manifest.json`.

use std::sync::Arc;

use anyhow::Result;
use glam::Vec3;
use serde::Serialize;

use crate::cloud_figures::{write_panels, Look, Panel};
use crate::e03_4_billow::billowed;
use crate::model_render::by_size;
use crate::registry::{Context, Experiment};
use smokelab::field::ops;
use smokelab::io;
use smokelab::model::cloud::{advected, NoisyVelocity};
use smokelab::noise::perlin::Perlin;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "03-7",
    folder: "03-7",
    reproduces: "fig 3.7",
    title: "a modelled cloud gridlessly advected by noisy velocity: none, medium, strong",
    cost: "~3 s",
    run,
};

#[derive(Serialize)]
struct Config {
    amplitudes: [f32; 3],
    frequency: f32,
    steps: usize,
    dt: f32,
    billow: f32,
    grid: usize,
    pixels: u32,
}

fn run(ctx: &Context) -> Result<()> {
    let (grid, pixels) = by_size(ctx.size, [(16, 64), (64, 256), (128, 512)]);
    let config = Config {
        amplitudes: [0.0, 0.6, 1.8],
        frequency: 3.0,
        steps: 4,
        dt: 0.05,
        billow: 1.0,
        grid,
        pixels,
    };
    io::create_output_dir(&ctx.out)?;
    let level_set = billowed(config.billow, grid)?;
    let panels = config
        .amplitudes
        .iter()
        .map(|&amplitude| {
            let velocity = Arc::new(NoisyVelocity {
                noise: Perlin::new(0xa1),
                amplitude,
                frequency: config.frequency,
                offsets: [Vec3::new(17.3, -4.1, 9.7), Vec3::new(-8.6, 23.2, 5.5)],
            });
            let density = advected(
                ops::mask(level_set.clone()),
                velocity,
                config.dt,
                config.steps,
            );
            Panel {
                label: format!("amplitude_{amplitude}"),
                level_set: level_set.clone(),
                density: Some(density),
            }
        })
        .collect();
    write_panels(
        ctx,
        config,
        panels,
        (grid, pixels),
        Look::Volume,
        "advection.png",
    )
}
