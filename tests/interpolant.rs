//! The velocity interpolants (`smokelab::grid::Interpolant`): what each
//! reproduces, and that RT0 (lowest-order Raviart–Thomas, Pollock's) is
//! divergence-free at every point of a projected velocity, carries each
//! face's flux exactly and none through a wall.
//!
//! Round-off budget: the projection (f64 transforms) leaves
//! `max|D u| Δx / max|u|` ≈ 1e-7; RT0's divergence inside a cell is that
//! cell's `D u`, and a difference quotient over 0.4 cells of an f32 value
//! adds ≈ 2ε/0.4 ≈ 3e-7. The bound 4e-6 (≈ 70 ε) fails on any real
//! compression: trilinear's is ≈ 0.1 on the same fields.

use std::sync::Arc;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use smokelab::advection::Backtrace;
use smokelab::boundary::WallStop;
use smokelab::density::GridlessField;
use smokelab::domain::Domain;
use smokelab::field::{ScalarField, VectorField};
use smokelab::grid::face::{BoxKind, FaceGrid};
use smokelab::grid::{Interpolant, ScalarGrid};
use smokelab::pressure::{PressurePrecision, PressureSolver};

/// A vector field from a function.
struct FnVector(fn(Vec3) -> Vec3);

impl VectorField for FnVector {
    fn eval(&self, p: Vec3) -> Vec3 {
        (self.0)(p)
    }
}

/// Non-cubic, odd and even.
fn domain() -> Domain {
    Domain::new(Vec3::new(-0.3, 0.2, 1.1), 0.37, [9, 12, 10]).unwrap()
}

/// Uniform random faces in [−1, 1], projected (f64 transforms): discretely
/// divergence-free to round-off, rough at the grid scale.
fn projected(d: Domain, kind: BoxKind, seed: u64, interpolant: Interpolant) -> FaceGrid {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut u = FaceGrid::zeros(d, kind);
    for a in 0..3 {
        for v in u.slice_mut(a) {
            *v = rng.random_range(-1.0..1.0);
        }
    }
    u.zero_walls();
    PressureSolver::with_precision(d, kind, PressurePrecision::F64).project(&mut u);
    u.with_interpolant(interpolant)
}

/// The divergence of `vel`'s point query per cell (grid coordinates) by
/// central differences over ±0.2 cells, at points at most 0.25 cells from
/// a cell centre (so each difference stays in one cell), relative to
/// max|u|: (rms, max).
fn divergence_inside_cells(vel: &FaceGrid, seed: u64) -> (f32, f32) {
    let d = *vel.domain();
    let s = vel.sampler();
    let mut rng = Pcg64::seed_from_u64(seed);
    let h = 0.2f32;
    let (mut sum2, mut max) = (0.0f64, 0.0f32);
    let n = 3000;
    for _ in 0..n {
        let c = Vec3::new(
            rng.random_range(0..d.dims[0]) as f32,
            rng.random_range(0..d.dims[1]) as f32,
            rng.random_range(0..d.dims[2]) as f32,
        );
        let g = c + Vec3::new(
            rng.random_range(-0.25..0.25),
            rng.random_range(-0.25..0.25),
            rng.random_range(-0.25..0.25),
        );
        let div: f32 = (0..3)
            .map(|a| {
                let e = Vec3::AXES[a] * h;
                (s.at(g + e)[a] - s.at(g - e)[a]) / (2.0 * h)
            })
            .sum();
        sum2 += (div as f64).powi(2);
        max = max.max(div.abs());
    }
    let scale = vel.max_norm();
    (((sum2 / n as f64).sqrt() as f32) / scale, max / scale)
}

#[test]
fn rt0_is_divergence_free_at_every_point_trilinear_is_not() {
    for kind in BoxKind::ALL {
        let d = domain();
        let rt0 = projected(d, kind, 3, Interpolant::Rt0);
        let (rms, max) = divergence_inside_cells(&rt0, 11);
        let tri = rt0.clone().with_interpolant(Interpolant::Trilinear);
        let (trms, tmax) = divergence_inside_cells(&tri, 11);
        println!("{kind}: relative divergence rt0 rms {rms:.2e} max {max:.2e}; trilinear rms {trms:.3} max {tmax:.3}");
        assert!(max < 4e-6, "{kind}: rt0 divergence {max:e}");
        // The same points see trilinear's compression: the test is not vacuous.
        assert!(trms > 1e-2, "{kind}: trilinear {trms}");
        // The analytic divergence of the interpolant, anywhere (faces too).
        let s = rt0.sampler();
        let mut rng = Pcg64::seed_from_u64(5);
        let size = Vec3::new(d.dims[0] as f32, d.dims[1] as f32, d.dims[2] as f32);
        for _ in 0..3000 {
            let g = Vec3::new(rng.random(), rng.random(), rng.random()) * size - 0.5;
            let div = s.divergence_at(g) / rt0.max_norm();
            assert!(div.abs() < 2e-6, "{kind} at {g}: {div:e}");
        }
    }
}

#[test]
fn rt0_carries_each_face_value_over_the_whole_face() {
    // The normal component anywhere on a face is the face's value, to the
    // bit: the flux through the face is exactly u_f Δx², and the normal
    // component is continuous across it (the same value from either cell).
    for kind in BoxKind::ALL {
        let d = domain();
        let vel = projected(d, kind, 4, Interpolant::Rt0);
        let s = vel.sampler();
        let mut rng = Pcg64::seed_from_u64(9);
        for a in 0..3 {
            let l = vel.face_dims(a);
            for _ in 0..500 {
                let f = [0, 1, 2].map(|b| rng.random_range(0..l[b]));
                let mut g = Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32);
                g[a] -= 0.5;
                // Anywhere on the face: across it up to ±½ cell.
                for b in (0..3).filter(|&b| b != a) {
                    g[b] += rng.random_range(-0.49..0.49);
                }
                let want = vel.component(a)[[f[2], f[1], f[0]]];
                assert_eq!(s.at(g)[a].to_bits(), want.to_bits(), "{kind} {a} {f:?}");
                // Either side, a hair away: the same value to first order.
                let e = Vec3::AXES[a] * 1e-3;
                for side in [s.at(g - e)[a], s.at(g + e)[a]] {
                    assert!((side - want).abs() < 1e-2 * vel.max_norm(), "{side} {want}");
                }
            }
        }
    }
}

#[test]
fn rt0_lets_nothing_through_the_walls() {
    // Closed box: on the wall planes and beyond them the normal component
    // is exactly zero.
    let d = domain();
    let vel = projected(d, BoxKind::Closed, 6, Interpolant::Rt0);
    let s = vel.sampler();
    let mut rng = Pcg64::seed_from_u64(2);
    let size = Vec3::new(d.dims[0] as f32, d.dims[1] as f32, d.dims[2] as f32);
    for a in 0..3 {
        for _ in 0..500 {
            let mut g = Vec3::new(rng.random(), rng.random(), rng.random()) * size - 0.5;
            for wall in [-0.5, size[a] - 0.5, -0.9, size[a] + 0.3] {
                g[a] = wall;
                assert_eq!(s.at(g)[a], 0.0, "component {a} at {g}");
            }
        }
    }
}

/// `(U + αx, V + βy, W + γz)` with `α + β + γ = 0`.
fn axis_linear(p: Vec3) -> Vec3 {
    Vec3::new(0.3 + 0.8 * p.x, -0.2 - 0.5 * p.y, 0.1 - 0.3 * p.z)
}

/// A rotation about z plus a shear: divergence-free, linear, not axis-linear.
fn rotation(p: Vec3) -> Vec3 {
    Vec3::new(-p.y, p.x, 0.4 * p.x)
}

/// Largest |query − field| over points of the interior cells (away from
/// the periodic seam), relative to the field's largest value there.
fn reproduction_error(interpolant: Interpolant, field: fn(Vec3) -> Vec3) -> f32 {
    let d = domain();
    let vel =
        FaceGrid::from_field(d, BoxKind::Periodic, &FnVector(field)).with_interpolant(interpolant);
    let mut rng = Pcg64::seed_from_u64(1);
    let (mut err, mut scale) = (0.0f32, 0.0f32);
    for _ in 0..2000 {
        let g = Vec3::new(
            rng.random_range(1.0..d.dims[0] as f32 - 2.0),
            rng.random_range(1.0..d.dims[1] as f32 - 2.0),
            rng.random_range(1.0..d.dims[2] as f32 - 2.0),
        );
        let p = d.world_of(g);
        let want = field(p);
        err = err.max((vel.sample(p) - want).abs().max_element());
        scale = scale.max(want.abs().max_element());
    }
    err / scale
}

#[test]
fn which_linear_fields_each_interpolant_reproduces() {
    // RT0: fields whose component a is linear in x_a alone (uniform flows,
    // pure strains); trilinear: every linear field.
    for i in Interpolant::ALL {
        let e = reproduction_error(i, axis_linear);
        assert!(e < 1e-5, "{i}: axis-linear field off by {e:e}");
    }
    let tri = reproduction_error(Interpolant::Trilinear, rotation);
    assert!(tri < 1e-5, "trilinear: rotation off by {tri:e}");
    // RT0 is first order across: a rotation is off by up to half a cell's
    // change (Δx/2 · |ω| against |u| ≈ L |ω|, here ≈ 0.1).
    let rt0 = reproduction_error(Interpolant::Rt0, rotation);
    assert!(rt0 > 0.03 && rt0 < 0.2, "rt0: rotation off by {rt0}");
}

/// `n` steps of a gridless walk through `vel` in a closed box, its volume
/// factor on (a wall-free level set), of a uniform initial density: the
/// factor `J = Π j_k` at points over the box, min and max.
fn volume_factor_range(vel: &FaceGrid, steps: usize) -> (f32, f32) {
    let d = *vel.domain();
    let uniform: smokelab::field::Scalar = smokelab::field::ops::constant(1.0);
    let mut g = GridlessField::new(d, Some(uniform), None);
    let mut level = ScalarGrid::zeros(d);
    level.as_slice_mut().fill(-1.0);
    g.set_walls(Arc::new(WallStop::new(level)));
    let vel = Arc::new(vel.clone());
    let dt = 0.4 * d.cell / vel.max_norm();
    for _ in 0..steps {
        g.push(vel.clone(), dt, Backtrace::Rk2);
    }
    let mut rng = Pcg64::seed_from_u64(8);
    let points: Vec<Vec3> = (0..2000)
        .map(|_| d.origin + d.size() * Vec3::new(rng.random(), rng.random(), rng.random()))
        .collect();
    let mut out = vec![0.0; points.len()];
    g.eval_batch(&points, &mut out);
    out.iter()
        .fold((f32::MAX, f32::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)))
}

#[test]
fn a_uniform_gridless_density_stays_uniform_in_the_closed_box_with_rt0() {
    // The walk's volume factor J (the Jacobian of the backward map, from the
    // interpolant's divergence) is what a uniform density becomes under
    // the conservative chain: RT0 keeps it at 1, so the plain chain
    // (without J) already conserves; trilinear's compresses by percents.
    let d = domain();
    let rt0 = projected(d, BoxKind::Closed, 7, Interpolant::Rt0);
    let (lo, hi) = volume_factor_range(&rt0, 40);
    println!("rt0: J in [{lo}, {hi}]");
    assert!(lo > 1.0 - 1e-4 && hi < 1.0 + 1e-4, "rt0: J in [{lo}, {hi}]");
    let tri = rt0.clone().with_interpolant(Interpolant::Trilinear);
    let (lo, hi) = volume_factor_range(&tri, 40);
    println!("trilinear: J in [{lo}, {hi}]");
    assert!(hi - lo > 0.1, "trilinear: J in [{lo}, {hi}]");
}

#[test]
fn the_velocity_as_a_field_reads_through_its_interpolant() {
    // eval_batch, the point query and the sampler agree to the bit.
    for kind in BoxKind::ALL {
        for i in Interpolant::ALL {
            let d = domain();
            let vel = projected(d, kind, 12, i);
            let mut rng = Pcg64::seed_from_u64(4);
            let pts: Vec<Vec3> = (0..500)
                .map(|_| {
                    d.origin
                        + (d.size() + 2.0 * d.cell)
                            * Vec3::new(rng.random(), rng.random(), rng.random())
                        - d.cell
                })
                .collect();
            let mut batch = vec![Vec3::ZERO; pts.len()];
            vel.eval_batch(&pts, &mut batch);
            let mut lanes = vec![Vec3::ZERO; pts.len()];
            smokelab::advection::sample_face_points(&vel, &pts, &mut lanes);
            for ((p, b), l) in pts.iter().zip(&batch).zip(&lanes) {
                let one = vel.eval(*p);
                assert_eq!(
                    one.to_array().map(f32::to_bits),
                    b.to_array().map(f32::to_bits),
                    "{kind} {i}"
                );
                assert_eq!(
                    one.to_array().map(f32::to_bits),
                    l.to_array().map(f32::to_bits),
                    "{kind} {i}"
                );
            }
        }
    }
}

#[test]
fn the_pointwise_divergence_metric_tells_the_interpolants_apart() {
    for kind in BoxKind::ALL {
        let d = domain();
        let points = smokelab::metrics::probe_points(&d, 4096, 1);
        let rt0 = projected(d, kind, 13, Interpolant::Rt0);
        let r = smokelab::metrics::face_pointwise_divergence(&rt0, &points);
        let t = smokelab::metrics::face_pointwise_divergence(
            &rt0.clone().with_interpolant(Interpolant::Trilinear),
            &points,
        );
        println!("{kind}: rt0 {r:?}, trilinear {t:?}");
        assert!(r.max < 2e-6, "{kind}: rt0 {r:?}");
        assert!(t.rms > 1e-2 && t.max > t.rms, "{kind}: trilinear {t:?}");
    }
}
