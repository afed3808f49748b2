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
//! right value, fast, smooth), `costs.csv` (the cost claim of `000_…` §3–4,
//! fast < value < smooth: ns per evaluation of each basis noise, 3D and
//! 2D, one octave, measured in this run — [`costs`]; `manifest.json` says
//! whether the ordering holds), `data.csv` (per panel: RMS
//! and 99th-percentile speed, mean |∇·V| and mean |∇V| by central differences
//! with h = 10⁻³ on a 128² subgrid, and their ratio), `manifest.json`.
//! The central-difference ratio is O(1) for value noise, O(h²) for smooth
//! simulation noise, and O(h) for fast simulation noise: not divergence —
//! its flux through any closed curve is zero — but stencils that straddle a
//! cell face see the kink of `V_x` there, and `|∇V|` picks up its jumps.
//!
//! The costs, measured (three default runs on a loaded 2-core machine,
//! ratios stable to 3 %): fast 13.8 ns, smooth 1.03× fast, value 1.60–1.64×
//! fast in 3D; in 2D smooth 1.05×, value 1.93×. Fast < smooth holds,
//! narrowly; value is the dearest, so `000_…`'s fast < value < smooth does
//! not hold for this implementation. Operation counts are not counted.

use std::time::Instant;

use anyhow::Result;
use glam::{Vec2, Vec3};
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::figures::table::write_rows;
use smokelab::field::VectorField;
use smokelab::io;
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

/// One row of `costs.csv`.
#[derive(Serialize)]
struct CostRow {
    kind: &'static str,
    /// Median over rounds of the wall time per evaluation, ns.
    ns_per_eval: f64,
    /// `ns_per_eval` over the fast simulation noise's of the same dimension.
    relative_to_fast: f64,
}

/// The cost of one evaluation of each kind in `groups` (each group: fast,
/// value, smooth of one dimension): `eval_batch` over the same 1024 points,
/// uniform in `[0, 32)³` (`z = 0` in 2D), repeated `rounds` times with the
/// kinds interleaved within each round, so a load change on the shared
/// machine hits all of them alike; the median round per kind. Wall times
/// are only compared within this run (ratios); the criterion benchmark
/// `benches/noise.rs` measures the same on an idle machine.
fn costs(groups: &[[NoiseKind; 3]], rounds: usize) -> Result<Vec<CostRow>> {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg64::seed_from_u64(1);
    let kinds: Vec<NoiseKind> = groups.iter().flatten().copied().collect();
    let fields = kinds
        .iter()
        .map(|&kind| {
            NoiseSpec {
                kind,
                seed: 1,
                ..Default::default()
            }
            .build()
        })
        .collect::<Result<Vec<_>, _>>()?;
    let points: Vec<Vec3> = (0..1024)
        .map(|_| Vec3::new(rng.random(), rng.random(), rng.random()) * 32.0)
        .collect();
    let mut out = vec![Vec3::ZERO; points.len()];
    let mut times = vec![Vec::with_capacity(rounds); kinds.len()];
    for _ in 0..rounds {
        for (field, t) in fields.iter().zip(&mut times) {
            let start = Instant::now();
            field.eval_batch(&points, &mut out);
            std::hint::black_box(&out);
            t.push(start.elapsed().as_secs_f64() * 1e9 / points.len() as f64);
        }
    }
    let medians: Vec<f64> = times
        .iter_mut()
        .map(|t| {
            t.sort_by(f64::total_cmp);
            t[t.len() / 2]
        })
        .collect();
    Ok(kinds
        .iter()
        .zip(&medians)
        .enumerate()
        .map(|(i, (kind, &ns))| CostRow {
            kind: kind.name(),
            ns_per_eval: ns,
            relative_to_fast: ns / medians[i - i % 3],
        })
        .collect())
}

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let pixels = ctx.size.pick(96, 384, 1024);
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
    let rounds = ctx.size.pick(20, 400, 400);
    let cost = costs(
        &[
            [NoiseKind::FastSim, NoiseKind::Value, NoiseKind::SmoothSim],
            [
                NoiseKind::FastSim2d,
                NoiseKind::Value2d,
                NoiseKind::SmoothSim2d,
            ],
        ],
        rounds,
    )?;
    write_rows(&ctx.out.join("costs.csv"), &cost)?;
    let holds: Vec<bool> = cost
        .chunks(3)
        .map(|g| g[0].ns_per_eval < g[1].ns_per_eval && g[1].ns_per_eval < g[2].ns_per_eval)
        .collect();
    extra.insert(
        "costs".into(),
        serde_json::json!({
            "rounds": rounds,
            "points": 1024,
            "ns_per_eval": cost.iter().map(|c| (c.kind, c.ns_per_eval)).collect::<std::collections::BTreeMap<_, _>>(),
            "fast_lt_value_lt_smooth": {"3d": holds[0], "2d": holds[1]},
        }),
    );
    io::write_png(
        &ctx.out.join("fig3.png"),
        &io::preview::side_by_side(&panels, 6),
    )?;
    write_rows(&ctx.out.join("data.csv"), &rows)?;
    let seed = config.seed;
    ctx.write_manifest(config, seed, start, serde_json::Value::Object(extra))
}
