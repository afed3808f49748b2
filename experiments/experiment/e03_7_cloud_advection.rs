//! # 03-7 — gridless advection of a modelled cloud (fig 3.7)
//!
//! Reproduces the notes' figure 3.7 (§3.5): the three-layer bunny cloud
//! with billow 1 (03-4), its density advected gridlessly for 8 steps of
//! Δt = 0.05 by a noisy velocity built from eq 3.9 — Perlin noise at three
//! offset points — in three octaves (frequencies 3, 6, 12, each with half
//! the amplitude of the one below; "a wide variety of looks can be created
//! by adjusting the setting of each octave"): no advection, medium
//! (amplitude 1.5) and strong (amplitude 4). The density is soft,
//! `clamp(ℓ / 0.1, 0, 1)`, rising from 0 at the surface to 1 a tenth
//! inside. The advected density is never gridded: each render query walks
//! back 8 steps (eq 7.4 without sources).
//!
//! Why octaves. With the first octave alone the strong panel shows hard
//! planar facets: eq 3.9 is not divergence-free, and where it converges
//! it squeezes the soft edge into thin sheets whose rims are sharp.
//! Sub-stepping the walk does not change them (the same facets at 4
//! sub-steps per step), so they are the velocity's, not the backtrace's
//! folding. The finer octaves break those sheets into feathered filaments
//! and carry small pieces of cloud off the main body.
//!
//! Run: `smokelab experiment 03-7` (about 80 s on 2 cores, most of it the
//! bunny's mesh distance on the 64³ base grid; 256² panels; `--full` 128³
//! and 512², `--smoke` 16³ and 64² in about 2 s).
//!
//! Measures: the volume `∫ρ` on the base grid (eq 3.9 is not
//! divergence-free, so it changes); on the base grid's cell averages `ρ̄`
//! (2³ sub-cells each, what a cell of the picture holds), the number of 26-connected pieces of
//! `ρ̄ > ½` and the fraction of their volume outside the largest (cloud
//! separated from the main body); the soft share, the share of the mass in
//! cells with `0.1 < ρ̄ < 0.9`. Advection does not widen the density's own
//! ramp — point samples show it steepened where the flow converges — but
//! it frays the surface into filaments finer than a cell, which the cell
//! averages, like the picture, show as soft.
//!
//! Writes `results/03-7/`: `advection.png` (none, medium, strong, left to
//! right, labelled), `data.csv` (one row per amplitude: `volume`,
//! `pieces`, `detached_fraction`, `soft_share`), `manifest.json`.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::cloud_figures::{
    billowed, domain, write_panels, write_table, Look, Panel,
};
use smokelab::density::probe::cell_averages;
use smokelab::domain::Domain;
use smokelab::field::algebra::clamp;
use smokelab::field::{ops, Scalar, Vector};
use smokelab::grid::ScalarGrid;
use smokelab::io;
use smokelab::model::cloud::{advected, NoisyVelocity};
use smokelab::model::cut::{label_pieces, PieceSet};
use smokelab::noise::perlin::Perlin;

/// Sub-cells per axis of the cell averages the measures are taken on.
const SUPERSAMPLE: usize = 2;

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
    /// Frequency of the first octave; each next octave doubles it and
    /// halves the amplitude.
    frequency: f32,
    octaves: usize,
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
    /// Share of the mass in cells whose average density is strictly
    /// between 0.1 and 0.9: the soft edge, and filaments finer than a cell.
    soft_share: f64,
}

/// The noisy velocity of eq 3.9 in `octaves` octaves: octave `o` has
/// frequency `frequency · 2^o` and amplitude `amplitude / 2^o`.
fn noisy_velocity(amplitude: f32, frequency: f32, octaves: usize) -> Vector {
    (0..octaves)
        .map(|o| -> Vector {
            let k = 2f32.powi(o as i32);
            Arc::new(NoisyVelocity {
                noise: Perlin::new(0xa1 + o as u64),
                amplitude: amplitude / k,
                frequency: frequency * k,
                offsets: [Vec3::new(17.3, -4.1, 9.7), Vec3::new(-8.6, 23.2, 5.5)],
            })
        })
        .reduce(ops::vector_sum)
        .unwrap_or_else(|| ops::constant_vector(Vec3::ZERO))
}

/// The share of the mass of `density` (cell averages) in the cells where
/// it is strictly between 0.1 and 0.9: the soft part of the cloud.
fn soft_share(density: &ScalarGrid) -> f64 {
    let (soft, total) = density
        .as_slice()
        .iter()
        .fold((0.0, 0.0), |(soft, total), &r| {
            let r = f64::from(r);
            let soft = if r > 0.1 && r < 0.9 { soft + r } else { soft };
            (soft, total + r)
        });
    if total > 0.0 {
        soft / total
    } else {
        0.0
    }
}

/// The pieces of `{ρ̄ > ½}` (`surface` is `ρ̄ − ½`, `ρ̄` the cell averages)
/// on `dom`: their count and the fraction of their volume outside the
/// largest.
fn detachment(surface: Scalar, dom: Domain) -> (usize, f64) {
    let set = PieceSet {
        sides: Vec::new(),
        level_set: surface,
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
        amplitudes: [0.0, 1.5, 4.0],
        frequency: 3.0,
        octaves: 3,
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
        let velocity = noisy_velocity(amplitude, config.frequency, config.octaves);
        let density = advected(
            clamp(ops::scale(level_set.clone(), 1.0 / config.edge), 0.0, 1.0),
            velocity,
            config.dt,
            config.steps,
        );
        let averaged = cell_averages(&*density, &dom, SUPERSAMPLE);
        let soft = soft_share(&averaged);
        let surface = ops::sum(Arc::new(averaged), ops::constant(-0.5));
        let (pieces, detached) = detachment(surface, dom);
        measured.push((pieces, detached, soft));
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
            "gridless advection by noisy velocity (eq 3.9, 3 octaves), billow 1",
            "advection.png",
        ),
    )?;
    let rows: Vec<Row> = config
        .amplitudes
        .iter()
        .zip(measured)
        .zip(shown)
        .map(
            |((&amplitude, (pieces, detached_fraction, soft_share)), s)| Row {
                amplitude,
                volume: s.volume,
                pieces,
                detached_fraction,
                soft_share,
            },
        )
        .collect();
    write_table(ctx, config, &rows, start)
}
