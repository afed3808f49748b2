//! # N-4 — artist-controlled flow along a spline (`000_…` §5, fig 4)
//!
//! Patel & Taylor's figure 4 shows particles following "a flow derived from
//! one spline". Here one closed spline — a circle of radius 2.6 lattice cells
//! in the plane z = ½, speed 1.5 — is turned into constrained lattice edges
//! by the paper's greedy solve (`noise::artist`), over random edges scaled by
//! ¼, and read as fast (left) and smooth (right) simulation noise. The flow is
//! drawn by line integral convolution coloured by speed on the plane z = ½
//! over `[0, 8]²`. The loop follows the lattice faces the circle crosses, so
//! it is a rounded square; the field stays divergence-free. One lattice, not
//! the paper's eight superimposed octaves.
//!
//! Run: `smokelab experiment N-4` (about 3 s; `--full` 1024², `--smoke` 96²).
//!
//! Writes `results/N-4/`: `fig4.png`, `data.csv` (per kind: faces crossed,
//! faces ignored, mean and max |V·n − target| at the honoured crossings),
//! `manifest.json`.

use std::io::Write;
use std::time::Instant;

use anyhow::Result;
use glam::{Vec2, Vec3};
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use smokelab::io;
use smokelab::noise::artist::{artist_noise, Spline};
use smokelab::noise::lic;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "N-4",
    folder: "N-4",
    reproduces: "Patel & Taylor fig 4",
    title: "flow along a spline by constrained simulation-noise edges",
    cost: "~3 s",
    run,
};

#[derive(Serialize)]
struct Config {
    radius: f32,
    centre: [f32; 3],
    speed: f32,
    random_scale: f32,
    extent: f32,
    pixels: usize,
    seed: u64,
}

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let pixels = ctx.size.pick(96, 512, 1024);
    let config = Config {
        radius: 2.6,
        centre: [4.0, 4.0, 0.5],
        speed: 1.5,
        random_scale: 0.25,
        extent: 8.0,
        pixels,
        seed: 3,
    };
    let c = Vec3::from(config.centre);
    let circle = Spline {
        points: (0..=64)
            .map(|i| {
                let a = i as f32 / 64.0 * std::f32::consts::TAU;
                c + config.radius * Vec3::new(a.cos(), a.sin(), 0.0)
            })
            .collect(),
        speed: config.speed,
    };
    io::create_output_dir(&ctx.out)?;
    let mut csv = String::from("kind,faces,ignored,mean_flux_error,max_flux_error\n");
    let mut panels = Vec::new();
    for (name, smooth) in [("fast-sim", false), ("smooth-sim", true)] {
        let a = artist_noise(
            config.seed,
            std::slice::from_ref(&circle),
            config.random_scale,
            smooth,
        )?;
        // At a crossing the normal velocity is the face flux times the bell
        // factors of the crossing point (1 for the fast noise).
        let errors: Vec<f32> = a
            .honoured
            .iter()
            .map(|x| {
                let v = a.field.eval(x.point)[x.axis];
                let bell = |t: f32| {
                    let s = t - t.floor();
                    16.0 * (s * (1.0 - s)).powi(2)
                };
                let factor = if smooth {
                    (0..3)
                        .filter(|&b| b != x.axis)
                        .map(|b| bell(x.point[b]))
                        .product()
                } else {
                    1.0
                };
                (v - factor * x.target).abs()
            })
            .collect();
        let mean = errors.iter().sum::<f32>() / errors.len().max(1) as f32;
        let max = errors.iter().cloned().fold(0.0, f32::max);
        csv.push_str(&format!(
            "{name},{},{},{mean},{max}\n",
            a.report.faces, a.report.ignored
        ));
        let vel = lic::slice(
            &*a.field,
            Vec2::ZERO,
            Vec2::splat(config.extent),
            c.z,
            pixels,
            pixels,
        );
        panels.push(lic::render(&vel, pixels, pixels, pixels as f32 / 40.0, 1));
    }
    io::write_png(
        &ctx.out.join("fig4.png"),
        &io::preview::side_by_side(&panels, 6),
    )?;
    io::write_atomic(&ctx.out.join("data.csv"), |w| {
        Ok(w.write_all(csv.as_bytes())?)
    })?;
    let seed = config.seed;
    ctx.write_manifest(config, seed, start, serde_json::Value::Null)
}
