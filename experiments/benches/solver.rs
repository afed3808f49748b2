//! Solver benchmarks: one hot/cold step at 64³ and 128³, the projection alone
//! and semi-Lagrangian advection alone. Planning and warm-up are outside the
//! timed region. Run: `cargo bench --bench solver`.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use smokelab::advection::{
    advect_fused, interpolate_scalar, interpolate_vector, Backtrace, Departures,
};
use smokelab::grid::ScalarGrid;
use smokelab::projection::Projection;
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;

/// A hot/cold simulation at `res`³ stepped until the gases move.
fn warmed(res: usize) -> smokelab::simulation::Simulation {
    let config = HotColdConfig {
        solver: SolverConfig {
            res,
            ..SolverConfig::default()
        },
        ..Default::default()
    };
    let mut sim = config.build().expect("valid config");
    for _ in 0..40 {
        sim.step();
    }
    sim
}

fn benches(c: &mut Criterion) {
    let mut g = c.benchmark_group("hot_cold");
    g.sample_size(10);
    for res in [64usize, 128] {
        let mut sim = warmed(res);
        let cells = sim.domain().len() as u64;
        g.throughput(Throughput::Elements(cells));
        g.bench_function(BenchmarkId::new("step", res), |b| b.iter(|| sim.step()));
        let mut projection = Projection::new(*sim.domain());
        let mut vel = sim.velocity.clone();
        g.bench_function(BenchmarkId::new("projection", res), |b| {
            b.iter(|| projection.project(&mut vel, 0.0, 0.05))
        });
        let mut dep = Departures::new(*sim.domain());
        g.bench_function(BenchmarkId::new("sl_trace_rk2", res), |b| {
            b.iter(|| dep.trace(&sim.velocity, 0.05, Backtrace::Rk2))
        });
        let mut rho = ScalarGrid::zeros(*sim.domain());
        g.bench_function(BenchmarkId::new("sl_interpolate_scalar", res), |b| {
            b.iter(|| interpolate_scalar(sim.gases[0].density(), &dep, &mut rho))
        });
        let mut u = sim.velocity.clone();
        g.bench_function(BenchmarkId::new("sl_interpolate_vector", res), |b| {
            b.iter(|| interpolate_vector(&sim.velocity, &dep, &mut u))
        });
        let mut rho2 = rho.clone();
        g.bench_function(BenchmarkId::new("sl_fused_two_gases", res), |b| {
            b.iter(|| {
                let srcs = [sim.gases[0].density(), sim.gases[1].density()];
                advect_fused(
                    &sim.velocity,
                    0.05,
                    Backtrace::Rk2,
                    &srcs,
                    &mut [&mut rho, &mut rho2],
                    &mut u,
                )
            })
        });
    }
    g.finish();
}

criterion_group!(solver, benches);
criterion_main!(solver);
