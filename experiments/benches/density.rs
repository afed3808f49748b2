//! Step time of the three density modes (§6.2, ch. 7, ch. 8) on the
//! hot/cold scenario at 32³ and 50³, after 10 and 40 steps: gridded is
//! constant, gridless grows with the number of stored velocity grids (its
//! buoyancy input walks back through all of them), SELMA is constant at a
//! higher constant than gridded. Each sample steps a clone of a simulation
//! warmed to that step count (cloning is not timed), so the step count does
//! not drift during measurement.
//!
//! Run: `cargo bench --bench density` (a few minutes; the warm-up of the
//! 50³ gridless runs dominates).

use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BatchSize, BenchmarkId, Criterion, Throughput};
use smokelab::density::DensityMode;
use smokelab::scenario::hot_cold::HotColdConfig;
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

criterion_group!(density, benches);
criterion_main!(density);
