//! # N-3 — 2D fractal fields on value, fast and smooth simulation noise (`000_…` fig 3)
//!
//! Reproduces Patel & Taylor's figure 3: the same random lattice data read as
//! value noise (left), fast simulation noise (middle) and smooth simulation
//! noise (right), each summed into a fractal with dimension 0.2, lacunarity
//! 1.77 and 3 octaves (gain `1.77^−0.2 ≈ 0.892`, see `noise::fractal`). The
//! flow is drawn by line integral convolution coloured by speed (viridis,
//! normalised per panel by its 99th percentile), over `[0, 4]²` lattice cells
//! of the first octave. The paper's reading: "simulation noise shows areas of
//! high flow rate feeding into other areas of high flow rate more
//! realistically than value noise"; fast simulation noise shows its jumps at
//! cell faces, smooth simulation noise its dead spots on lattice points.
//!
//! Run: `smokelab experiment N-3` (about 5 s on 2 cores at 384² per panel;
//! `--full` 1024², `--smoke` 96²).
//!
//! Writes `results/N-3/`: `fig3.png` (the three panels side by side, left to
//! right value, fast, smooth), `data.csv` (per panel: RMS
//! and 99th-percentile speed, mean |∇·V| and mean |∇V| by central differences
//! with h = 10⁻³ on a 128² subgrid, and their ratio), `manifest.json`.
//! The central-difference ratio is O(1) for value noise, O(h²) for smooth
//! simulation noise, and O(h) for fast simulation noise: not divergence —
//! its flux through any closed curve is zero — but stencils that straddle a
//! cell face see the kink of `V_x` there, and `|∇V|` picks up its jumps.

use std::time::Instant;

use anyhow::Result;
use glam::{Vec2, Vec3};
use serde::Serialize;

use crate::registry::{Context, Experiment, Size};
use crate::table::write_rows;
use smokelab::field::VectorField;
use smokelab::io::{self, manifest::Manifest};
use smokelab::noise::fractal::Fractal;
use smokelab::noise::{lic, NoiseKind, NoiseSpec};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "N-3",
    folder: "N-3",
    reproduces: "Patel & Taylor fig 3",
    title: "2D fractal value / fast / smooth simulation noise, LIC by speed",
    cost: "~5 s",
    run,
};

#[derive(Serialize)]
struct Config {
    kinds: [NoiseKind; 3],
    fractal: Fractal,
    dimension: f32,
    extent: f32,
    pixels: usize,
    seed: u64,
}

/// Divergence and gradient statistics of a planar field on an `n × n` grid
/// over `[0, extent]²`, by central differences with step `h`.
fn divergence_stats(field: &dyn VectorField, extent: f32, n: usize, h: f32) -> (f64, f64) {
    let (mut div, mut grad) = (0.0f64, 0.0f64);
    let offsets = [Vec3::X * h, -Vec3::X * h, Vec3::Y * h, -Vec3::Y * h];
    let mut points = Vec::with_capacity(4 * n);
    let mut values = vec![Vec3::ZERO; 4 * n];
    for j in 0..n {
        points.clear();
        for i in 0..n {
            let p = Vec3::new(i as f32 + 0.5, j as f32 + 0.5, 0.0) * (extent / n as f32);
            points.extend(offsets.iter().map(|&o| p + o));
        }
        field.eval_batch(&points, &mut values);
        for v in values.chunks_exact(4) {
            let dx = (v[0] - v[1]) / (2.0 * h);
            let dy = (v[2] - v[3]) / (2.0 * h);
            div += (dx.x + dy.y).abs() as f64;
            grad += (dx.truncate().length_squared() + dy.truncate().length_squared()).sqrt() as f64;
        }
    }
    let cells = (n * n) as f64;
    (div / cells, grad / cells)
}

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let pixels = match ctx.size {
        Size::Smoke => 96,
        Size::Default => 384,
        Size::Full => 1024,
    };
    let dimension = 0.2;
    let config = Config {
        kinds: [
            NoiseKind::Value2d,
            NoiseKind::FastSim2d,
            NoiseKind::SmoothSim2d,
        ],
        fractal: Fractal::from_dimension(3, 1.77, dimension),
        dimension,
        extent: 4.0,
        pixels,
        seed: 3,
    };
    io::create_output_dir(&ctx.out)?;
    /// One row of `data.csv`.
    #[derive(Serialize)]
    struct Row {
        kind: &'static str,
        rms_speed: f64,
        p99_speed: f32,
        mean_abs_divergence: f64,
        mean_abs_gradient: f64,
        relative_divergence: f64,
    }
    let mut rows = Vec::new();
    let mut panels = Vec::new();
    let mut extra = serde_json::Map::new();
    for kind in &config.kinds {
        let field = NoiseSpec {
            kind: *kind,
            seed: config.seed,
            fractal: config.fractal,
            ..Default::default()
        }
        .build()?;
        let vel = lic::slice(
            &*field,
            Vec2::ZERO,
            Vec2::splat(config.extent),
            0.0,
            pixels,
            pixels,
        );
        panels.push(lic::render(
            &vel,
            pixels,
            pixels,
            pixels as f32 / 40.0,
            config.seed,
        ));
        let rms =
            (vel.iter().map(|v| v.length_squared() as f64).sum::<f64>() / vel.len() as f64).sqrt();
        let p99 = lic::speed_scale(&vel);
        let (div, grad) = divergence_stats(&*field, config.extent, 128, 1e-3);
        rows.push(Row {
            kind: kind.name(),
            rms_speed: rms,
            p99_speed: p99,
            mean_abs_divergence: div,
            mean_abs_gradient: grad,
            relative_divergence: div / grad,
        });
        extra.insert(
            kind.name().into(),
            serde_json::json!({ "rms_speed": rms, "relative_divergence": div / grad }),
        );
    }
    io::write_png(
        &ctx.out.join("fig3.png"),
        &io::preview::side_by_side(&panels, 6),
    )?;
    write_rows(&ctx.out.join("data.csv"), &rows)?;
    let seed = config.seed;
    io::write_json(
        &ctx.out.join("manifest.json"),
        &Manifest::new(
            config,
            seed,
            start.elapsed().as_secs_f64(),
            serde_json::Value::Object(extra),
        ),
    )
}
