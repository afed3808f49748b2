//! Cost of one noise evaluation, per kind: single points through the shared
//! `Arc<dyn VectorField>` (one dynamic call per point) and batches of 1024
//! points through `eval_batch` (one call per batch). Points are uniform in
//! `[0, 32)³`, fixed seed. Criterion reports time per iteration of 1024
//! evaluations and elements per second; ns per evaluation = time / 1024.
//!
//! `000_…` §3–4 claims fast simulation noise < value noise < smooth
//! simulation noise ("slightly"); the `lattice` group puts those three (and
//! their time-varying forms) side by side.
//!
//! Run: `cargo bench --bench noise` (about a minute; `-- lattice` for the
//! paper's comparison only).

use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, BenchmarkGroup, Criterion, Throughput};
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use smokelab::noise::spectral::{SpectralParams, SpectralTile};
use smokelab::noise::{NoiseKind, NoiseSpec};

const N: usize = 1024;

fn points() -> Vec<Vec3> {
    let mut rng = Pcg64::seed_from_u64(1);
    (0..N)
        .map(|_| Vec3::new(rng.random(), rng.random(), rng.random()) * 32.0)
        .collect()
}

fn configure(group: &mut BenchmarkGroup<'_, criterion::measurement::WallTime>) {
    group
        .throughput(Throughput::Elements(N as u64))
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(1))
        .sample_size(20);
}

fn bench_spec(c: &mut Criterion, group_name: &str, specs: &[(String, NoiseSpec)]) {
    let pts = points();
    let mut out = vec![Vec3::ZERO; N];
    let mut group = c.benchmark_group(group_name);
    configure(&mut group);
    for (name, spec) in specs {
        let field = spec.build().expect("valid spec");
        group.bench_function(format!("{name}/single"), |b| {
            b.iter(|| {
                for &p in &pts {
                    black_box(field.eval(black_box(p)));
                }
            })
        });
        group.bench_function(format!("{name}/batch"), |b| {
            b.iter(|| field.eval_batch(black_box(&pts), &mut out))
        });
    }
    group.finish();
}

/// The paper's comparison: value vs fast vs smooth simulation noise, static
/// (hash) and time-varying (two hashes per corner lookup).
fn lattice(c: &mut Criterion) {
    let mut specs = Vec::new();
    for kind in [NoiseKind::FastSim, NoiseKind::Value, NoiseKind::SmoothSim] {
        for time in [None, Some(0.37)] {
            let name = match time {
                None => kind.name().to_string(),
                Some(_) => format!("{}@t", kind.name()),
            };
            specs.push((
                name,
                NoiseSpec {
                    kind,
                    time,
                    ..Default::default()
                },
            ));
        }
    }
    bench_spec(c, "lattice", &specs);
}

/// Every kind, one octave, static.
fn all_kinds(c: &mut Criterion) {
    let specs: Vec<_> = NoiseKind::ALL
        .iter()
        .map(|&kind| {
            (
                kind.name().to_string(),
                NoiseSpec {
                    kind,
                    ..Default::default()
                },
            )
        })
        .collect();
    bench_spec(c, "kinds", &specs);
}

/// One-off cost of synthesising a spectral tile (planning included).
fn spectral_tile(c: &mut Criterion) {
    let mut group = c.benchmark_group("spectral_tile");
    group
        .warm_up_time(Duration::from_millis(300))
        .measurement_time(Duration::from_secs(2))
        .sample_size(10);
    for res in [32, 64] {
        let params = SpectralParams {
            res,
            ..Default::default()
        };
        group.bench_function(format!("{res}^3"), |b| {
            b.iter(|| SpectralTile::new(black_box(params), 1).unwrap())
        });
    }
    group.finish();
}

criterion_group!(benches, lattice, all_kinds, spectral_tile);
criterion_main!(benches);
