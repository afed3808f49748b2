//! Solver benchmarks: one hot/cold step at 64³ and 128³ (RK2, the default,
//! and Euler, the peers' backtrace), the MAC pressure
//! projection alone (f32 and f64 transforms) and semi-Lagrangian advection
//! alone; and the fused semi-Lagrangian sweep once per kernel width this CPU
//! has (`sl_width/<isa>_<backtrace>/<res>`, each width selected with
//! `Isa::select`, as `SMOKELAB_SIMD` would). Planning and warm-up are
//! outside the timed region. Run: `cargo bench --bench solver`.

mod warm;

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use smokelab::advection::{advect_faces, advect_fused, interpolate_scalar, Backtrace, Departures};
use smokelab::grid::{BoxKind, ScalarGrid};
use smokelab::pressure::{PressurePrecision, PressureSolver};
use smokelab::simd::Isa;

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
        for precision in PressurePrecision::ALL {
            let d = *sim.domain();
            let mut pressure = PressureSolver::with_precision(d, BoxKind::Periodic, precision);
            let mut vel = sim.velocity.clone();
            g.bench_function(
                BenchmarkId::new(format!("projection_{precision}"), res),
                |b| b.iter(|| pressure.project(&mut vel)),
            );
        }
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

/// The fused sweep (velocity and both gases) of a warmed 64³ and 128³
/// hot/cold state on every kernel width, Euler and RK2; the default width
/// selected again at the end.
fn widths(c: &mut Criterion) {
    let default = Isa::selected();
    let mut g = c.benchmark_group("sl_width");
    g.sample_size(10);
    for res in [64usize, 128] {
        let sim = warm::hot_cold(res, Backtrace::Rk2);
        g.throughput(Throughput::Elements(sim.domain().len() as u64));
        let (mut rho, mut rho2) = (
            sim.gases[0].density().clone(),
            sim.gases[1].density().clone(),
        );
        let mut u = sim.velocity.clone();
        for isa in Isa::available() {
            isa.select().expect("an available width");
            for backtrace in [Backtrace::Euler, Backtrace::Rk2] {
                let name = format!("{isa}_{backtrace:?}").to_lowercase();
                g.bench_function(BenchmarkId::new(name, res), |b| {
                    b.iter(|| {
                        let srcs = [sim.gases[0].density(), sim.gases[1].density()];
                        advect_fused(
                            &sim.velocity,
                            0.05,
                            backtrace,
                            &srcs,
                            &mut [&mut rho, &mut rho2],
                            &mut u,
                        )
                    })
                });
            }
        }
    }
    g.finish();
    default.select().expect("the default width");
}

criterion_group!(solver, benches, widths);
criterion_main!(solver);
