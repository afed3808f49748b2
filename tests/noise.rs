//! Noise fields: divergence (flux through closed surfaces), continuity,
//! spectra, determinism, and the `smokelab noise` command.
//!
//! Fluxes are computed by Gauss–Legendre quadrature on each face of a box,
//! split at every line where the integrand's polynomial pieces meet (lattice
//! lines, shifted by ±h for finite differences). Inside a lattice cell the
//! lattice noises are polynomials of degree ≤ 12 per axis (bitangent: a
//! product of two Perlin gradients, each of degree 6), so 7 points per piece
//! integrate them exactly and the measured flux is the field's own, up to
//! round-off.

use std::sync::Arc;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rustfft::num_complex::Complex32;
use rustfft::FftPlanner;

use smokelab::field::VectorField;
use smokelab::noise::curl::{CurlFd, CurlFd2, FdScheme};
use smokelab::noise::lattice::keys;
use smokelab::noise::spectral::{SpectralNoise, SpectralParams, SpectralTile, Spectrum};
use smokelab::noise::{NoiseKind, NoiseSpec, Solenoidal};

mod common;
use common::order::assert_order;

/// Gauss–Legendre nodes and weights on [−1, 1] (Newton on P_n).
fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            loop {
                let (mut p0, mut p1) = (1.0, x);
                for k in 2..=n {
                    let p2 = ((2 * k - 1) as f64 * x * p1 - (k - 1) as f64 * p0) / k as f64;
                    p0 = p1;
                    p1 = p2;
                }
                let dp = n as f64 * (x * p1 - p0) / (x * x - 1.0);
                let dx = p1 / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    let w = 2.0 / ((1.0 - x * x) * dp * dp);
                    return (x, w);
                }
            }
        })
        .collect()
}

/// Where the integrand's pieces meet along an axis: lattice lines `m + s`
/// for each shift `s`, strictly inside `(lo, hi)`, with the ends, sorted.
fn pieces(lo: f64, hi: f64, shifts: &[f64]) -> Vec<f64> {
    let mut v = vec![lo, hi];
    for &s in shifts {
        let mut m = (lo - s).floor() + 1.0;
        while m + s < hi {
            if m + s > lo {
                v.push(m + s);
            }
            m += 1.0;
        }
    }
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// Net outward flux and total absolute flux of `field` through the box
/// `lo..hi`, with integrand pieces split at `pieces(…, shifts)` on every axis.
fn box_flux(field: &dyn VectorField, lo: [f64; 3], hi: [f64; 3], shifts: &[f64]) -> (f64, f64) {
    let gl = gauss_legendre(7);
    let (mut net, mut abs) = (0.0, 0.0);
    for a in 0..3 {
        let (b, c) = ((a + 1) % 3, (a + 2) % 3);
        let (pb, pc) = (pieces(lo[b], hi[b], shifts), pieces(lo[c], hi[c], shifts));
        for (side, sign) in [(lo[a], -1.0), (hi[a], 1.0)] {
            let mut points = Vec::new();
            let mut weights = Vec::new();
            for wb in pb.windows(2) {
                for wc in pc.windows(2) {
                    let (hb, hc) = ((wb[1] - wb[0]) / 2.0, (wc[1] - wc[0]) / 2.0);
                    for &(xb, vb) in &gl {
                        for &(xc, vc) in &gl {
                            let mut p = [0.0f64; 3];
                            p[a] = side;
                            p[b] = wb[0] + hb * (xb + 1.0);
                            p[c] = wc[0] + hc * (xc + 1.0);
                            points.push(Vec3::new(p[0] as f32, p[1] as f32, p[2] as f32));
                            weights.push(vb * vc * hb * hc);
                        }
                    }
                }
            }
            let mut out = vec![Vec3::ZERO; points.len()];
            field.eval_batch(&points, &mut out);
            for (v, w) in out.iter().zip(&weights) {
                net += sign * v[a] as f64 * w;
                abs += (v[a] as f64).abs() * w;
            }
        }
    }
    (net, abs)
}

/// Random boxes with corners in [−3, 3]³ and sides in [0.3, 2].
fn random_boxes(n: usize, seed: u64) -> Vec<([f64; 3], [f64; 3])> {
    let mut rng = Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            let lo: [f64; 3] = std::array::from_fn(|_| rng.random_range(-3.0..3.0));
            let hi = lo.map(|x| x + rng.random_range(0.3..2.0));
            (lo, hi)
        })
        .collect()
}

fn small_spec(kind: NoiseKind, seed: u64) -> NoiseSpec {
    NoiseSpec {
        kind,
        seed,
        spectral: SpectralParams {
            res: 16,
            ..Default::default()
        },
        ..Default::default()
    }
}

/// Net flux / total flux through 40 random boxes, for every lattice kind,
/// static and (where the kind has time) at t = 0.37: ≤ 1e-4 for the
/// divergence-free constructions, clearly non-zero for value and Perlin noise.
#[test]
fn flux_through_random_boxes() {
    let boxes = random_boxes(40, 1);
    for &kind in NoiseKind::ALL {
        let expect_zero = match kind.solenoidal() {
            Solenoidal::Exact | Solenoidal::Discontinuous => true,
            Solenoidal::No => false,
            // Tested at their own scales below.
            Solenoidal::Approximate | Solenoidal::TileCubes => continue,
        };
        let times: &[Option<f32>] = if kind.time_varying() {
            &[None, Some(0.37)]
        } else {
            &[None]
        };
        for &time in times {
            let field = NoiseSpec {
                time,
                ..small_spec(kind, 5)
            }
            .build()
            .unwrap();
            let rel: Vec<f64> = boxes
                .iter()
                .map(|(lo, hi)| {
                    let (net, abs) = box_flux(&*field, *lo, *hi, &[0.0]);
                    net.abs() / abs
                })
                .collect();
            let max = rel.iter().cloned().fold(0.0, f64::max);
            let mean = rel.iter().sum::<f64>() / rel.len() as f64;
            println!(
                "{:<14} t={time:?}: relative flux max {max:.2e}, mean {mean:.2e}",
                kind.name()
            );
            if expect_zero {
                assert!(max <= 1e-4, "{kind:?} t={time:?}: relative flux {max:e}");
            } else {
                assert!(mean >= 1e-2, "{kind:?}: relative flux only {mean:e}");
            }
        }
    }
}

/// Fast simulation noise: the flux through each lattice cell, from the field
/// on its faces, is zero to round-off; `V_x` is constant on an x-face.
#[test]
fn fast_sim_flux_per_lattice_cell_is_round_off() {
    for kind in [NoiseKind::FastSim, NoiseKind::FastSim2d] {
        let v = small_spec(kind, 9).build().unwrap();
        let dims = kind.dims();
        let mut worst = 0.0f32;
        for i in -4..4 {
            for j in -4..4 {
                for k in -2..2 {
                    let c = Vec3::new(i as f32, j as f32, k as f32) + Vec3::splat(0.5);
                    let (mut net, mut abs) = (0.0f32, 0.0f32);
                    for a in 0..dims {
                        let e = Vec3::AXES[a] * 0.5;
                        let (hi, lo) = (v.eval(c + e)[a], v.eval(c - e)[a]);
                        // Another point of the same face gives the same value.
                        let t = Vec3::AXES[(a + 1) % dims] * 0.3;
                        assert_eq!(v.eval(c + e + t)[a], hi, "{kind:?}: V_a varies on a face");
                        net += hi - lo;
                        abs += hi.abs() + lo.abs();
                    }
                    worst = worst.max(net.abs() / abs);
                }
            }
        }
        println!("{}: worst per-cell relative flux {worst:.2e}", kind.name());
        assert!(worst <= 1e-6, "{kind:?}: per-cell flux {worst:e}");
    }
}

/// The largest f32 below `x > 0`.
fn below(x: f32) -> f32 {
    f32::from_bits(x.to_bits() - 1)
}

/// Across cell faces the smooth noise is continuous (jump ≤ 1e-5); the fast
/// noise keeps its normal component but its tangential components jump, as
/// `000_…` §3 says.
#[test]
fn continuity_across_cell_faces() {
    let mut rng = Pcg64::seed_from_u64(2);
    for kind in [
        NoiseKind::SmoothSim,
        NoiseKind::SmoothSim2d,
        NoiseKind::FastSim,
        NoiseKind::FastSim2d,
    ] {
        let v = small_spec(kind, 4).build().unwrap();
        let (mut normal, mut tangential) = (0.0f32, 0.0f32);
        for _ in 0..300 {
            let a = rng.random_range(0..kind.dims());
            let mut p = Vec3::new(
                rng.random_range(0.5..3.5),
                rng.random_range(0.5..3.5),
                rng.random_range(0.5..3.5),
            );
            p[a] = rng.random_range(1..4) as f32;
            let mut q = p;
            q[a] = below(p[a]);
            let jump = v.eval(p) - v.eval(q);
            normal = normal.max(jump[a].abs());
            for b in (0..3).filter(|&b| b != a) {
                tangential = tangential.max(jump[b].abs());
            }
        }
        println!(
            "{}: jump normal {normal:.2e}, tangential {tangential:.2e}",
            kind.name()
        );
        assert!(normal <= 1e-5, "{kind:?}: normal jump {normal}");
        match kind.solenoidal() {
            Solenoidal::Exact => assert!(tangential <= 1e-5, "{kind:?}: jump {tangential}"),
            _ => assert!(
                tangential >= 0.1,
                "{kind:?}: tangential jump only {tangential}"
            ),
        }
    }
}

/// The finite-difference curl's divergence (net flux through boxes, summed)
/// shrinks as h → 0 at the rule's order: 2 for central, 1 for `001_…`'s
/// backward differences; fitted over h = 0.2 … 0.025, asserted ± 0.25.
#[test]
fn finite_difference_curl_divergence_order() {
    let boxes = random_boxes(12, 3);
    let steps = [0.2, 0.1, 0.05, 0.025];
    let k = keys::<3>(17);
    for (scheme, order) in [(FdScheme::Central, 2.0), (FdScheme::Backward, 1.0)] {
        for dims in [3, 2] {
            let errors: Vec<f64> = steps
                .iter()
                .map(|&h| {
                    let field: Arc<dyn VectorField> = if dims == 3 {
                        Arc::new(CurlFd::new(k, h as f32, scheme))
                    } else {
                        Arc::new(CurlFd2::new(k[0], h as f32, scheme))
                    };
                    let (net, abs) = boxes.iter().fold((0.0, 0.0), |acc, (lo, hi)| {
                        let (n, a) = box_flux(&*field, *lo, *hi, &[-h, 0.0, h]);
                        (acc.0 + n.abs(), acc.1 + a)
                    });
                    net / abs
                })
                .collect();
            assert_order(
                &format!("curl-fd {dims}D {scheme:?}, relative net flux"),
                &steps,
                &errors,
                order,
                0.25,
            );
        }
    }
}

/// The spectral tile's reported discrete divergence, and the flux of the
/// sampled field through tile cubes, are round-off (static and 4D).
#[test]
fn spectral_noise_is_discretely_divergence_free() {
    for frames in [1, 6] {
        let params = SpectralParams {
            res: 24,
            frames,
            period: 3.0,
            ..Default::default()
        };
        let tile = Arc::new(SpectralTile::new(params, 8).unwrap());
        let d = tile.divergence();
        println!("spectral frames={frames}: {d:?}");
        assert!(d.relative <= 1e-5, "tile divergence {d:?}");
        // Through the field: cubes between tile samples (spacing 1/8) at a
        // time between frames.
        let field = SpectralNoise::new(tile, 2.3);
        let s = 3.0 / 24.0;
        let mut worst = 0.0f64;
        for (lo, _) in random_boxes(30, 4) {
            let lo = lo.map(|x| (x / s).floor() * s);
            let hi = lo.map(|x| x + s);
            let (net, abs) = box_flux(&field, lo, hi, &[]);
            worst = worst.max(net.abs() / abs);
        }
        println!("spectral frames={frames}: worst cube flux {worst:.2e}");
        assert!(worst <= 1e-5, "cube flux {worst:e}");
    }
}

/// Energy per integer shell |k| ∈ [n − ½, n + ½) of a tile, measured by a
/// forward FFT and divided by the known normalisation, and the prescribed
/// expectation Σ 2 S(|k|/N)² over the same modes.
fn shell_spectra(tile: &SpectralTile) -> (Vec<f64>, Vec<f64>) {
    let p = tile.params();
    let n = p.res;
    let data = tile.frame(0);
    let fft = FftPlanner::<f32>::new().plan_fft_forward(n);
    let shells = n / 2;
    let mut measured = vec![0.0f64; shells];
    let mut prescribed = vec![0.0f64; shells];
    let norm = (tile.scale() as f64 * (n * n * n) as f64).powi(2);
    let mut spectra = Vec::new();
    for c in 0..3 {
        let mut buf: Vec<Complex32> = data.chunks(3).map(|v| Complex32::new(v[c], 0.0)).collect();
        // x lines are contiguous; then y and z by gathering.
        for line in buf.chunks_mut(n) {
            fft.process(line);
        }
        for stride in [n, n * n] {
            for block in buf.chunks_mut(n * stride) {
                for s in 0..stride {
                    let mut line: Vec<Complex32> = (0..n).map(|m| block[m * stride + s]).collect();
                    fft.process(&mut line);
                    for m in 0..n {
                        block[m * stride + s] = line[m];
                    }
                }
            }
        }
        spectra.push(buf);
    }
    let signed = |m: usize| {
        if m <= n / 2 {
            m as f64
        } else {
            m as f64 - n as f64
        }
    };
    for kz in 0..n {
        for ky in 0..n {
            for kx in 0..n {
                let r = (signed(kx).powi(2) + signed(ky).powi(2) + signed(kz).powi(2)).sqrt();
                let shell = r.round() as usize;
                if shell >= shells {
                    continue;
                }
                let i = (kz * n + ky) * n + kx;
                let e: f64 = spectra.iter().map(|s| s[i].norm_sqr() as f64).sum();
                measured[shell] += e / norm;
                let s = p.spectrum.amplitude((r / n as f64) as f32) as f64;
                prescribed[shell] += if r > 0.0 { 2.0 * s * s } else { 0.0 };
            }
        }
    }
    (measured, prescribed)
}

/// Shell-averaged energy within 10 % of the prescribed spectrum on every
/// resolved shell (4 ≤ n < N/2, prescribed energy ≥ 1e-6 of the peak),
/// Gaussian and Kolmogorov; the Kolmogorov shells fall as n^{−5/3}.
#[test]
fn spectral_energy_spectrum_follows_the_prescribed_one() {
    for spectrum in [
        Spectrum::Gaussian { b: 0.1 },
        Spectrum::Kolmogorov { cutoff: 0.06 },
    ] {
        let params = SpectralParams {
            res: 64,
            spectrum,
            ..Default::default()
        };
        let tile = SpectralTile::new(params, 21).unwrap();
        let (measured, prescribed) = shell_spectra(&tile);
        let peak = prescribed.iter().cloned().fold(0.0, f64::max);
        let mut resolved = Vec::new();
        for n in 4..measured.len() {
            if prescribed[n] >= 1e-6 * peak {
                let ratio = measured[n] / prescribed[n];
                println!("{spectrum:?} shell {n:2}: measured/prescribed {ratio:.3}");
                assert!(
                    (ratio - 1.0).abs() <= 0.1,
                    "{spectrum:?} shell {n}: ratio {ratio}"
                );
                resolved.push(n);
            }
        }
        assert!(
            resolved.len() >= 10,
            "only {} resolved shells",
            resolved.len()
        );
        if let Spectrum::Kolmogorov { cutoff } = spectrum {
            // Shells well above the cutoff (the shell straddling it is cut).
            let (ns, es): (Vec<f64>, Vec<f64>) = resolved
                .iter()
                .filter(|&&n| n as f32 >= 2.0 * cutoff * params.res as f32)
                .map(|&n| (n as f64, measured[n]))
                .unzip();
            // The log-log slope of the shell energy, −5/3 within 0.05.
            assert_order(
                &format!("Kolmogorov shells {ns:?}"),
                &ns,
                &es,
                -5.0 / 3.0,
                0.05,
            );
        }
    }
}

/// Same seed → identical values; another seed → a different field. Every
/// kind, single and fractal.
#[test]
fn seeds_are_deterministic_and_distinct() {
    let mut rng = Pcg64::seed_from_u64(6);
    let points: Vec<Vec3> = (0..64)
        .map(|_| {
            Vec3::new(
                rng.random_range(-4.0..4.0),
                rng.random_range(-4.0..4.0),
                rng.random_range(-4.0..4.0),
            )
        })
        .collect();
    let sample = |spec: NoiseSpec| -> Vec<Vec3> {
        let f = spec.build().unwrap();
        let mut out = vec![Vec3::ZERO; points.len()];
        f.eval_batch(&points, &mut out);
        // Batches agree with single evaluation.
        for (p, o) in points.iter().zip(&out) {
            assert_eq!(
                f.eval(*p),
                *o,
                "{:?}: eval and eval_batch differ",
                spec.kind
            );
        }
        out
    };
    for &kind in NoiseKind::ALL {
        for octaves in [1, 3] {
            let spec = |seed| NoiseSpec {
                fractal: smokelab::noise::fractal::Fractal {
                    octaves,
                    ..Default::default()
                },
                ..small_spec(kind, seed)
            };
            let (a, b, c) = (sample(spec(11)), sample(spec(11)), sample(spec(12)));
            assert_eq!(a, b, "{kind:?}: same seed, different values");
            let rms = |v: &[Vec3]| {
                (v.iter().map(|x| x.length_squared()).sum::<f32>() / v.len() as f32).sqrt()
            };
            let diff: Vec<Vec3> = a.iter().zip(&c).map(|(x, y)| *x - *y).collect();
            assert!(
                rms(&diff) >= 0.3 * rms(&a),
                "{kind:?}: seeds 11 and 12 too alike"
            );
        }
    }
}

/// Time-varying simulation noise changes continuously in time, including
/// across integer times, and is a different field a few time units later.
#[test]
fn time_varying_noise_is_continuous_in_time() {
    let p = Vec3::new(0.3, 1.6, -0.8);
    for kind in [
        NoiseKind::SmoothSim,
        NoiseKind::FastSim,
        NoiseKind::Spectral,
    ] {
        let at = |t: f32| {
            NoiseSpec {
                time: Some(t),
                spectral: SpectralParams {
                    res: 16,
                    frames: 8,
                    ..Default::default()
                },
                ..small_spec(kind, 3)
            }
            .build()
            .unwrap()
            .eval(p)
        };
        let step = (at(below(2.0)) - at(2.0)).length();
        assert!(step <= 1e-5, "{kind:?}: jump at t = 2: {step}");
        let small = (at(1.5) - at(1.501)).length();
        let large = (at(1.5) - at(4.5)).length();
        assert!(small < 0.01 * large, "{kind:?}: {small} vs {large}");
    }
}
