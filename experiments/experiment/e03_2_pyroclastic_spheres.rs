//! # 03-2 — pyroclastic spheres (fig 3.2)
//!
//! Reproduces the notes' figure 3.2 (§3.3.1): spheres of uniform density
//! whose surface is displaced by `r(n) = a |Perlin(f n)|` sampled at the
//! direction `n` — the closed-form algorithm (eq 3.2 and its three steps),
//! evaluated directly by the renderer. Two looks side by side: broad lumps
//! (a = 0.25, f = 2) and finer, stronger ones (a = 0.35, f = 5), on spheres
//! of radius 0.5. The absolute value cuts sharp canyons between rounded
//! peaks.
//!
//! Run: `smokelab experiment 03-2` (about 2 s on 2 cores: 384² renders,
//! march step half a cell of a 96³ box; `--full` 768² and 160³, `--smoke`
//! 96² and 24³).
//!
//! Writes `results/03-2/`: `spheres.png` (the two renders side by side),
//! `data.csv` (per sphere: parameters and the volume of its density on the
//! render grid against the undisplaced sphere's) and `manifest.json`.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::model_render::render_densities;
use crate::figures::table::write_rows;
use smokelab::domain::Domain;
use smokelab::grid::ScalarGrid;
use smokelab::io;
use smokelab::model::cloud::PyroclasticSphere;
use smokelab::noise::perlin::Perlin;
use smokelab::render::look;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "03-2",
    folder: "03-2",
    reproduces: "fig 3.2",
    title: "pyroclastic spheres: closed-form displacement by |Perlin|",
    cost: "~2 s",
    run,
};

#[derive(Serialize, Clone, Copy)]
struct Sphere {
    radius: f32,
    amplitude: f32,
    frequency: f32,
    key: u64,
}

#[derive(Serialize)]
struct Config {
    spheres: [Sphere; 2],
    grid: usize,
    pixels: u32,
}

/// One row of `data.csv`.
#[derive(Serialize)]
struct Row {
    radius: f32,
    amplitude: f32,
    frequency: f32,
    volume: f64,
    undisplaced_volume: f64,
}

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let (grid, pixels) = ctx.size.pick((24, 96), (96, 384), (160, 768));
    let sphere = |amplitude, frequency, key| Sphere {
        radius: 0.5,
        amplitude,
        frequency,
        key,
    };
    let config = Config {
        spheres: [sphere(0.25, 2.0, 3), sphere(0.35, 5.0, 4)],
        grid,
        pixels,
    };
    io::create_output_dir(&ctx.out)?;
    let bounds = Domain::new(Vec3::splat(-1.0), 2.0 / grid as f32, [grid; 3])?;
    let mut images = Vec::new();
    let mut rows = Vec::new();
    for s in config.spheres {
        let field = PyroclasticSphere {
            center: Vec3::ZERO,
            radius: s.radius,
            amplitude: s.amplitude,
            frequency: s.frequency,
            noise: Perlin::new(s.key),
        };
        let volume = ScalarGrid::from_field(bounds, &field).total();
        rows.push(Row {
            radius: s.radius,
            amplitude: s.amplitude,
            frequency: s.frequency,
            volume,
            undisplaced_volume: 4.0 / 3.0 * std::f64::consts::PI * (s.radius as f64).powi(3),
        });
        let densities = vec![(
            "pyroclastic".to_string(),
            Arc::new(field) as _,
            Vec3::splat(0.9),
        )];
        images.push(render_densities(
            densities,
            bounds,
            pixels,
            0.5,
            20.0 * look::KAPPA,
        )?);
    }
    io::write_png(
        &ctx.out.join("spheres.png"),
        &io::preview::side_by_side(&images, 6),
    )?;
    write_rows(&ctx.out.join("data.csv"), &rows)?;
    ctx.write_manifest(config, 3, start, serde_json::json!({}))
}
