//! The FFT projection: discrete divergence at round-off, idempotence,
//! divergence-free fields untouched, and the removed part curl-free.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use smokelab::domain::Domain;
use smokelab::grid::VectorGrid;
use smokelab::metrics::{divergence_stats, rms_max};
use smokelab::projection::Projection;

mod common;
use common::taylor_green;

fn random_field(domain: Domain, seed: u64) -> VectorGrid {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut g = VectorGrid::zeros(domain);
    for v in g.as_slice_mut() {
        *v = rng.random_range(-1.0..1.0);
    }
    g
}

fn max_diff(a: &VectorGrid, b: &VectorGrid) -> f32 {
    a.as_slice()
        .iter()
        .zip(b.as_slice())
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max)
}

fn max_abs(a: &VectorGrid) -> f32 {
    a.as_slice().iter().fold(0.0f32, |m, v| m.max(v.abs()))
}

const SHAPES: [[usize; 3]; 4] = [[16, 16, 16], [17, 12, 20], [9, 10, 11], [32, 32, 32]];

#[test]
fn random_fields_become_discretely_divergence_free() {
    for (n, dims) in SHAPES.into_iter().enumerate() {
        let d = Domain::new(Vec3::new(-1.0, 0.0, 2.0), 0.3, dims).unwrap();
        let mut u = random_field(d, n as u64);
        let before = divergence_stats(&u);
        Projection::new(d).project(&mut u, 0.0, 0.1);
        let after = divergence_stats(&u);
        let bound = 1e-5 * u.rms_norm() / d.cell;
        println!(
            "{dims:?}: max div {:.3e} → {:.3e} (bound {bound:.3e})",
            before.max, after.max
        );
        assert!(
            after.max <= bound,
            "{dims:?}: max divergence {} > {bound}",
            after.max
        );
        assert!(
            before.max > 1e3 * bound,
            "the random field should have been divergent"
        );
    }
}

#[test]
fn projecting_twice_changes_nothing() {
    for (n, dims) in SHAPES.into_iter().enumerate() {
        let d = Domain::new(Vec3::ZERO, 1.0, dims).unwrap();
        let mut p = Projection::new(d);
        let mut once = random_field(d, 10 + n as u64);
        p.project(&mut once, 0.0, 1.0);
        let mut twice = once.clone();
        p.project(&mut twice, 0.0, 1.0);
        let diff = max_diff(&once, &twice);
        assert!(
            diff <= 1e-5 * max_abs(&once),
            "{dims:?}: second projection moved the field by {diff}"
        );
    }
}

#[test]
fn taylor_green_passes_through_unchanged() {
    let n = 24;
    let d = Domain::new(Vec3::ZERO, std::f32::consts::TAU / n as f32, [n, n, 8]).unwrap();
    let tg = taylor_green(d, 1.0);
    let mut u = tg.clone();
    Projection::new(d).project(&mut u, 0.0, 1.0);
    let diff = max_diff(&u, &tg);
    assert!(
        diff <= 1e-5,
        "projection changed a divergence-free field by {diff}"
    );
}

/// Central-difference gradient of a periodic scalar array.
fn gradient(d: Domain, phi: &[f32]) -> VectorGrid {
    let [nx, ny, nz] = d.dims;
    let at = |i: usize, j: usize, k: usize| phi[d.index(i % nx, j % ny, k % nz)];
    let mut g = VectorGrid::zeros(d);
    let h = 2.0 * d.cell;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let v = &mut g.as_vec3_mut()[d.index(i, j, k)];
                v.x = (at(i + 1, j, k) - at(i + nx - 1, j, k)) / h;
                v.y = (at(i, j + 1, k) - at(i, j + ny - 1, k)) / h;
                v.z = (at(i, j, k + 1) - at(i, j, k + nz - 1)) / h;
            }
        }
    }
    g
}

/// Central-difference curl of a periodic vector grid.
fn curl(u: &VectorGrid) -> Vec<Vec3> {
    let d = *u.domain();
    let [nx, ny, nz] = d.dims;
    let v = u.as_vec3();
    let at = |i: usize, j: usize, k: usize| v[d.index(i % nx, j % ny, k % nz)];
    let h = 2.0 * d.cell;
    let mut out = Vec::with_capacity(d.len());
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let dx = (at(i + 1, j, k) - at(i + nx - 1, j, k)) / h;
                let dy = (at(i, j + 1, k) - at(i, j + ny - 1, k)) / h;
                let dz = (at(i, j, k + 1) - at(i, j, k + nz - 1)) / h;
                out.push(Vec3::new(dy.z - dz.y, dz.x - dx.z, dx.y - dy.x));
            }
        }
    }
    out
}

#[test]
fn removed_part_is_the_curl_free_gradient() {
    for (n, dims) in SHAPES.into_iter().enumerate() {
        let d = Domain::new(Vec3::ZERO, 0.5, dims).unwrap();
        let mut p = Projection::new(d);
        // u = ∇φ + w with w divergence-free: the projection must return w and remove ∇φ.
        let mut w = random_field(d, 20 + n as u64);
        p.project(&mut w, 0.0, 1.0);
        let mut rng = Pcg64::seed_from_u64(30 + n as u64);
        let phi: Vec<f32> = (0..d.len()).map(|_| rng.random_range(-1.0..1.0)).collect();
        let grad = gradient(d, &phi);
        let mut u = w.clone();
        for (a, b) in u.as_slice_mut().iter_mut().zip(grad.as_slice()) {
            *a += b;
        }
        let before = u.clone();
        p.project(&mut u, 0.0, 1.0);
        let recovered = max_diff(&u, &w);
        assert!(
            recovered <= 1e-5 * max_abs(&before),
            "{dims:?}: solenoidal part off by {recovered}"
        );
        let mut removed = before.clone();
        for (r, a) in removed.as_slice_mut().iter_mut().zip(u.as_slice()) {
            *r -= a;
        }
        let c: Vec<f32> = curl(&removed).iter().map(|v| v.length()).collect();
        let c = rms_max(&c);
        let scale = removed.rms_norm() / d.cell;
        assert!(
            c.max <= 1e-5 * scale,
            "{dims:?}: removed part has curl {} (scale {scale})",
            c.max
        );
    }
}
