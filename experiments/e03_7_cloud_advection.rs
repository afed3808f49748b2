//! # 03-7 — gridless advection of a modelled cloud (fig 3.7)
//!
//! Reproduces the notes' figure 3.7 (§3.5): the three-layer bunny cloud
//! with billow 1 (03-4), its density advected gridlessly by the noisy
//! velocity of eq 3.9 — Perlin noise at three offset points, frequency 3 —
//! for 8 steps of Δt = 0.05: no advection, medium (amplitude 1) and strong
//! (amplitude 3). The density is soft, `clamp(ℓ / 0.1, 0, 1)`, rising from 0
//! at the surface to 1 a tenth inside, so the advected edges stay soft. The
//! advected density is never gridded: each render query walks back 8 steps
//! (eq 7.4 without sources). Strong advection folds the backtrace (Δt |∇u|
//! near 1) and separates portions of cloud from the main body, as in the
//! notes; `data.csv` counts them.
//!
//! Run: `smokelab experiment 03-7` (about 80 s on 2 cores, most of it the
//! bunny's mesh distance on the 64³ base grid; 256² panels; `--full` 128³
//! and 512², `--smoke` 16³ and 64² in about 2 s).
//!
//! Writes `results/03-7/`: `advection.png` (none, medium, strong, left to
//! right, labelled), `data.csv` (per amplitude: volume `∫ρ` on the base
//! grid — eq 3.9 is not divergence-free, so it changes —, the number of
//! 26-connected pieces of `ρ > ½` and the fraction of their volume outside
//! the largest), `manifest.json`.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use serde::Serialize;

use crate::cloud_figures::{billowed, domain, write_panels, write_table, Look, Panel};
use crate::registry::{Context, Experiment};
use smokelab::domain::Domain;
use smokelab::field::algebra::clamp;
use smokelab::field::{ops, Scalar};
use smokelab::io;
use smokelab::model::cloud::{advected, NoisyVelocity};
use smokelab::model::cut::{label_pieces, PieceSet};
use smokelab::noise::perlin::Perlin;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "03-7",
    folder: "03-7",
    reproduces: "fig 3.7",
    title: "a modelled cloud gridlessly advected by noisy velocity: none, medium, strong",
    cost: "~80 s",
    run,
};

#[derive(Serialize)]
struct Config {
    amplitudes: [f32; 3],
    frequency: f32,
    steps: usize,
    dt: f32,
    /// Depth inside the surface over which the density ramps from 0 to 1.
    edge: f32,
    billow: f32,
    grid: usize,
    pixels: u32,
}

/// One row of `data.csv`.
#[derive(Serialize)]
struct Row {
    amplitude: f32,
    /// `∫ρ` on the base grid (eq 3.9 is not divergence-free, so it changes).
    volume: f64,
    /// 26-connected pieces of `ρ > ½` on the base grid.
    pieces: usize,
    /// Volume of `ρ > ½` outside its largest piece, as a fraction of the
    /// whole: cloud separated from the main body.
    detached_fraction: f64,
}

/// The pieces of `{ρ > ½}` sampled on `dom`: their count and the fraction
/// of their volume outside the largest.
fn detachment(density: &Scalar, dom: Domain) -> (usize, f64) {
    let set = PieceSet {
        sides: Vec::new(),
        level_set: ops::sum(density.clone(), ops::constant(-0.5)),
    };
    let pieces = label_pieces(&[set], dom).pieces;
    let total: f64 = pieces.iter().map(|p| p.volume).sum();
    let largest = pieces.iter().map(|p| p.volume).fold(0.0, f64::max);
    let detached = if total > 0.0 {
        (total - largest) / total
    } else {
        0.0
    };
    (pieces.len(), detached)
}

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let (grid, pixels) = ctx.size.pick((16, 64), (64, 256), (128, 512));
    let config = Config {
        amplitudes: [0.0, 1.0, 3.0],
        frequency: 3.0,
        steps: 8,
        dt: 0.05,
        edge: 0.1,
        billow: 1.0,
        grid,
        pixels,
    };
    io::create_output_dir(&ctx.out)?;
    let level_set = billowed(config.billow, grid)?;
    let dom = domain(grid)?;
    let mut panels = Vec::new();
    let mut measured = Vec::new();
    for (&amplitude, name) in config.amplitudes.iter().zip(["none", "medium", "strong"]) {
        let velocity = Arc::new(NoisyVelocity {
            noise: Perlin::new(0xa1),
            amplitude,
            frequency: config.frequency,
            offsets: [Vec3::new(17.3, -4.1, 9.7), Vec3::new(-8.6, 23.2, 5.5)],
        });
        let density = advected(
            clamp(ops::scale(level_set.clone(), 1.0 / config.edge), 0.0, 1.0),
            velocity,
            config.dt,
            config.steps,
        );
        measured.push(detachment(&density, dom));
        panels.push(Panel {
            label: format!("amplitude_{amplitude}"),
            heading: format!("{name} (amplitude {amplitude})"),
            level_set: level_set.clone(),
            density: Some(density),
        });
    }
    let shown = write_panels(
        ctx,
        panels,
        (grid, pixels),
        Look::Volume,
        (
            "gridless advection by noisy velocity (eq 3.9), billow 1",
            "advection.png",
        ),
    )?;
    let rows: Vec<Row> = config
        .amplitudes
        .iter()
        .zip(measured)
        .zip(shown)
        .map(|((&amplitude, (pieces, detached_fraction)), s)| Row {
            amplitude,
            volume: s.volume,
            pieces,
            detached_fraction,
        })
        .collect();
    write_table(ctx, config, &rows, start)
}
