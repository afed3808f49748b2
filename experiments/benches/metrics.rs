//! The measures taken after every step (`run::StepMeasures::take`; the
//! target: ≤ 5 % of a 128³ step) and each of its two parts —
//! `velocity_stats` and the gases' `mirror_error` — and the interpolant's
//! divergence at the probe points, one of the fine measures taken every
//! `metrics_every` steps, on the 128³ hot/cold state, in the global rayon
//! pool. `warm/…` repeats each on cached data; `cold/…` first writes a
//! 64 MB buffer (untimed, as experiment P-1's bandwidth pass runs before
//! its measures), so the grids come from memory.
//!
//! Run: `cargo bench -p smokelab-app --bench metrics` (about a minute).

mod warm;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use rayon::prelude::*;
use smokelab::advection::Backtrace;
use smokelab::metrics;
use smokelab_app::run::{StepMeasures, PROBE_POINTS};
use std::hint::black_box;

/// Bytes written before each cold measure: twice the L3 cache.
const FLUSH_BYTES: usize = 64 << 20;

fn benches(c: &mut Criterion) {
    let sim = warm::hot_cold(128, Backtrace::Rk2);
    let points = metrics::probe_points(sim.domain(), PROBE_POINTS, 1);
    let (a, b) = (sim.gases[0].density(), sim.gases[1].density());
    let parts: [(&str, &(dyn Fn() + Sync)); 4] = [
        ("take", &|| {
            black_box(StepMeasures::take(&sim));
        }),
        ("velocity_stats", &|| {
            black_box(metrics::velocity_stats(&sim.velocity));
        }),
        ("probe", &|| {
            black_box(metrics::face_interpolant_divergence(&sim.velocity, &points));
        }),
        ("gas_mirror", &|| {
            black_box(metrics::mirror_error(a, b));
        }),
    ];
    let mut g = c.benchmark_group("measures_128");
    g.sample_size(20);
    let mut flush = vec![0.0f32; FLUSH_BYTES / 4];
    for (name, f) in parts {
        g.bench_function(format!("warm/{name}"), |bench| bench.iter(f));
        g.bench_function(format!("cold/{name}"), |bench| {
            bench.iter_batched(
                || {
                    flush
                        .par_chunks_mut(1 << 16)
                        .for_each(|c| c.iter_mut().for_each(|v| *v += 1.0));
                },
                |()| f(),
                BatchSize::PerIteration,
            )
        });
    }
    g.finish();
}

criterion_group!(measures, benches);
criterion_main!(measures);
