//! Solver benchmarks: one hot/cold step at 64³ and 128³ (RK2, the default,
//! and Euler, the peers' backtrace), the MAC pressure
//! projection alone and semi-Lagrangian advection alone. Planning and warm-up are outside the
//! timed region. Run: `cargo bench --bench solver`.

mod warm;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use smokelab::advection::{advect_faces, advect_fused, interpolate_scalar, Backtrace, Departures};
use smokelab::grid::{BoxKind, ScalarGrid};
use smokelab::pressure::PressureSolver;

fn benches(c: &mut Criterion) {
    let mut g = c.benchmark_group("hot_cold");
    g.sample_size(10);
    for res in [64usize, 128] {
        let mut sim = warm::hot_cold(res, Backtrace::Euler);
        let cells = sim.domain().len() as u64;
        g.throughput(Throughput::Elements(cells));
        // The peers' backtrace (`../shared/peers/taichi_advect.py` is Euler).
        g.bench_function(BenchmarkId::new("step_euler", res), |b| {
            b.iter(|| sim.step())
        });
        let mut sim = warm::hot_cold(res, Backtrace::Rk2);
        g.bench_function(BenchmarkId::new("step", res), |b| b.iter(|| sim.step()));
        let mut pressure = PressureSolver::new(*sim.domain(), BoxKind::Periodic);
        let mut vel = sim.velocity.clone();
        g.bench_function(BenchmarkId::new("projection", res), |b| {
            b.iter(|| pressure.project(&mut vel))
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
        g.bench_function(BenchmarkId::new("sl_advect_faces", res), |b| {
            b.iter(|| advect_faces(&sim.velocity, &sim.velocity, 0.05, Backtrace::Rk2, &mut u))
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
