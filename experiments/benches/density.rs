//! Step time of the three density modes (§6.2, ch. 7, ch. 8) on the
//! hot/cold scenario at 32³ and 50³, after 10 and 40 steps: gridded is
//! constant, gridless grows with the number of stored velocity grids (its
//! buoyancy input walks back through all of them), SELMA is constant at a
//! higher constant than gridded. Each sample steps a clone of a simulation
//! warmed to that step count (cloning is not timed), so the step count does
//! not drift during measurement.
//!
//! `gridless/walk` times the gridless walk alone (eq 7.4): every cell
//! centre of a 32³ sphere-wall flow walked back through its 20 stored
//! velocity grids (RK2) on one thread; elements/s = cells × stored steps, so
//! its inverse is the cost per cell per stored step per thread.
//!
//! `selma_vs_gridded` times gridded and SELMA steps of the hot/cold flow at
//! 64³ and 128³ in one run (each simulation warmed 20 steps, then stepped
//! in place, so SELMA's periodic re-anchorings are in its mean): the ratio
//! of the two is SELMA's target (≤ 2).
//!
//! Run: `cargo bench --bench density` (a few minutes; the warm-up of the
//! 50³ gridless runs dominates); `cargo bench --bench density -- gridless/walk`
//! for the walk alone (seconds); `cargo bench --bench density --
//! selma_vs_gridded` for the ratio (about a minute).

use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion, Throughput};
use glam::Vec3;
use smokelab::density::{BackwardMap, DensityMode, GridlessField};
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::sphere_wall::{FlowHistory, SphereWallConfig};
use smokelab::simulation::Simulation;

/// A hot/cold simulation at `res`³ held as `mode`, stepped `steps` times.
fn warmed(res: usize, mode: DensityMode, steps: usize) -> Simulation {
    let config = HotColdConfig {
        solver: SolverConfig {
            res,
            density: mode,
            ..SolverConfig::default()
        },
        ..Default::default()
    };
    let mut sim = config.build().expect("valid config");
    for _ in 0..steps {
        sim.step();
    }
    sim
}

fn benches(c: &mut Criterion) {
    let mut g = c.benchmark_group("density_step");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    for res in [32usize, 50] {
        for mode in DensityMode::ALL {
            for steps in [10usize, 40] {
                let sim = warmed(res, mode, steps);
                g.throughput(Throughput::Elements(sim.domain().len() as u64));
                g.bench_function(BenchmarkId::new(format!("{mode}/{res}"), steps), |b| {
                    b.iter_batched(|| sim.clone(), |mut s| s.step(), BatchSize::LargeInput)
                });
            }
        }
    }
    g.finish();
}

/// Gridded and SELMA steps at 64³ and 128³, side by side.
fn selma_vs_gridded(c: &mut Criterion) {
    let mut g = c.benchmark_group("selma_vs_gridded");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(5));
    for res in [64usize, 128] {
        for mode in [DensityMode::Gridded, DensityMode::Selma] {
            let mut sim = warmed(res, mode, 20);
            g.throughput(Throughput::Elements(sim.domain().len() as u64));
            g.bench_function(BenchmarkId::new(mode.name(), res), |b| {
                b.iter(|| sim.step())
            });
        }
    }
    g.finish();
}

/// Cell centres of a 32³ flow walked back through its 20 stored steps.
fn walk(c: &mut Criterion) {
    let config = SphereWallConfig {
        res: 32,
        frames: 20,
        ..SphereWallConfig::default()
    };
    let flow = FlowHistory::record(&config).expect("valid config");
    let mut chain = GridlessField::new(flow.domain, None, None);
    for u in &flow.velocities {
        chain.push(u.clone(), flow.dt, flow.backtrace);
    }
    let d = flow.domain;
    let points: Vec<Vec3> = (0..d.len())
        .map(|i| {
            let [nx, ny, _] = d.dims;
            d.world_of(Vec3::new(
                (i % nx) as f32,
                (i / nx % ny) as f32,
                (i / (nx * ny)) as f32,
            ))
        })
        .collect();
    let mut out = vec![Vec3::ZERO; points.len()];
    let mut g = c.benchmark_group("gridless");
    g.sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3));
    g.throughput(Throughput::Elements((points.len() * chain.steps()) as u64));
    g.bench_function("walk", |b| b.iter(|| chain.map_batch(&points, &mut out)));
    g.finish();
}

criterion_group!(density, benches, walk, selma_vs_gridded);
criterion_main!(density);
