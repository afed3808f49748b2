//! # 03-8 — spatial control of the displacement by fields (fig 3.8)
//!
//! Reproduces the notes' figure 3.8 (§3.6), a volumetric bunny with spatial
//! control over the pyroclastic displacement: the parameters of the
//! `NoiseLayers` script are fields, so the character of the cloud changes
//! from place to place. Here the amplitude is a smooth ramp along x —
//! zero on the left, the full 0.2 on the right — and the roughness rises
//! from 0.3 to 0.7 along y, over three billow-free layers on the Stanford
//! bunny (see `cloud_figures`). Beside it, the same cloud with constant
//! amplitude for comparison.
//!
//! Run: `smokelab experiment 03-8` (about 70 s on 2 cores, most of it the
//! bunny's mesh distance on the 64³ base grid; 320² panels; `--full` 128³
//! and 640², `--smoke` 16³ and 64² in about 1 s).
//!
//! Writes `results/03-8/`: `control.png` (ramped, constant; labelled),
//! `data.csv` (volume and surface-net triangles per panel),
//! `manifest.json`.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::cloud_figures::{
    base, cloud, panel_rows, write_panels, write_table, Look, Panel, SCALE,
};
use smokelab::field::ops::constant;
use smokelab::field::{Scalar, ScalarField};
use smokelab::io;
use smokelab::model::cloud::noise_layers;
use smokelab::noise::perlin::Perlin;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "03-8",
    folder: "03-8",
    reproduces: "fig 3.8",
    title: "spatial control: displacement amplitude and roughness as fields",
    cost: "~70 s",
    run,
};

/// `lo + (hi − lo) · smoothstep(−0.6, 0.6, x · axis)`.
struct Ramp {
    axis: Vec3,
    lo: f32,
    hi: f32,
}

impl ScalarField for Ramp {
    fn eval(&self, p: Vec3) -> f32 {
        let t = ((p.dot(self.axis) + 0.6) / 1.2).clamp(0.0, 1.0);
        self.lo + (self.hi - self.lo) * t * t * (3.0 - 2.0 * t)
    }
}

#[derive(Serialize)]
struct Config {
    amplitude: [f32; 2],
    roughness: [f32; 2],
    grid: usize,
    pixels: u32,
}

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let (grid, pixels) = ctx.size.pick((16, 64), (64, 320), (128, 640));
    io::create_output_dir(&ctx.out)?;
    let noise: Scalar = Arc::new(Perlin::new(0xc10d));
    let ramp = |axis, lo, hi| -> Scalar { Arc::new(Ramp { axis, lo, hi }) };
    let controlled = noise_layers(
        3,
        noise.clone(),
        ramp(Vec3::X, 0.0, SCALE),
        constant(2.0),
        constant(2.2),
        ramp(Vec3::Y, 0.3, 0.7),
    );
    let uniform = noise_layers(
        3,
        noise,
        constant(SCALE),
        constant(2.0),
        constant(2.2),
        constant(0.5),
    );
    let bunny = base(grid)?;
    let panels = vec![
        Panel {
            label: "controlled".into(),
            heading: "ramped".into(),
            level_set: cloud(bunny.clone(), &controlled, 0, grid)?,
            density: None,
        },
        Panel {
            label: "uniform".into(),
            heading: "uniform".into(),
            level_set: cloud(bunny, &uniform, 0, grid)?,
            density: None,
        },
    ];
    let labels: Vec<String> = panels.iter().map(|p| p.label.clone()).collect();
    let shown = write_panels(
        ctx,
        panels,
        (grid, pixels),
        Look::Volume,
        ("spatial control of the displacement", "control.png"),
    )?;
    let rows = panel_rows(labels, shown);
    let config = Config {
        amplitude: [0.0, SCALE],
        roughness: [0.3, 0.7],
        grid,
        pixels,
    };
    write_table(ctx, config, &rows, start)
}
