//! The measures taken after every step (`run::StepMeasures::take`; the
//! target: ≤ 5 % of a 128³ step) and each of its two parts —
//! `velocity_stats` and the gases' `mirror_error` — and the interpolant's
//! divergence at the probe points, one of the fine measures taken every
//! `metrics_every` steps, on the 128³ hot/cold state, in the global rayon
//! pool. `warm/…` repeats each on cached data; `cold/…` first writes a
//! 64 MB buffer (untimed, as experiment P-1's bandwidth pass runs before
//! its measures), so the grids come from memory. `fine_128/…`: the fine
//! measures (`run::FineProbes::measure`) and their parts, warm.
//!
//! Run: `cargo bench -p smokelab-app --bench metrics` (about a minute).

mod warm;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use rayon::prelude::*;
use smokelab::advection::Backtrace;
use smokelab::metrics;
use smokelab_app::run::{FineProbes, StepMeasures, PROBE_POINTS};
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
    fine(c, &sim);
}

/// The fine measures (`run::FineProbes::measure`) and their parts, warm.
fn fine(c: &mut Criterion, sim: &smokelab::simulation::Simulation) {
    use smokelab::density::probe::{mean_gradient, DensityProbe};
    use smokelab::grid::ScalarGrid;
    use smokelab::metrics::SpectralShare;
    let domain = *sim.domain();
    let mut probes = FineProbes::new(domain);
    let mut probe = DensityProbe::new(domain);
    let fine_domain = domain.refined(2);
    let mut fine = ScalarGrid::zeros(fine_domain);
    sim.gases[0].model.sample(&mut fine);
    let mut spectrum = SpectralShare::new(fine_domain.dims);
    let mut ke = SpectralShare::new(domain.dims);
    let mut g = c.benchmark_group("fine_128");
    g.sample_size(10);
    g.bench_function("measure", |b| {
        b.iter(|| black_box(probes.measure(sim).ke_top_octave))
    });
    g.bench_function("one_gas", |b| {
        b.iter(|| black_box(probe.measure(&sim.gases[0].model)))
    });
    g.bench_function("sample_2x", |b| {
        b.iter(|| sim.gases[0].model.sample(&mut fine))
    });
    g.bench_function("grad_2x", |b| b.iter(|| black_box(mean_gradient(&fine))));
    g.bench_function("spectrum_2x", |b| {
        b.iter(|| black_box(spectrum.share_above(&[fine.as_slice()], [64, 64, 64])))
    });
    g.bench_function("ke_top_octave", |b| {
        b.iter(|| black_box(metrics::top_octave_share(&mut ke, &sim.velocity)))
    });
    g.finish();
}

criterion_group!(measures, benches);
criterion_main!(measures);
