//! Semi-Lagrangian advection: invariants and first-order convergence.

use glam::Vec3;
use smokelab::advection::{advect_scalar, Backtrace};
use smokelab::domain::Domain;
use smokelab::field::ops;
use smokelab::grid::{BoxKind, FaceGrid, ScalarGrid};

mod common;
use common::order::assert_order;
use common::swirl;

#[test]
fn constant_field_stays_constant() {
    let d = Domain::cube(16, std::f32::consts::TAU).unwrap();
    let vel = swirl(d);
    for bt in Backtrace::ALL {
        let src = ScalarGrid::from_field(d, &*ops::constant(2.5));
        let mut dst = ScalarGrid::zeros(d);
        advect_scalar(&src, &vel, 0.7, bt, &mut dst);
        let err = dst
            .as_slice()
            .iter()
            .map(|v| (v - 2.5).abs())
            .fold(0.0, f32::max);
        assert!(err <= 1e-6, "{bt:?}: constant changed by {err}");
    }
}

#[test]
fn whole_cell_shifts_are_exact() {
    // Δx = 1 and Δt = 0.5 with u = (4, 0, −2): two cells in +x, one in −z.
    let d = Domain::new(Vec3::ZERO, 1.0, [8, 6, 5]).unwrap();
    let vel = FaceGrid::from_field(
        d,
        BoxKind::Periodic,
        &*ops::constant_vector(Vec3::new(4.0, 0.0, -2.0)),
    );
    let mut src = ScalarGrid::zeros(d);
    for (n, v) in src.as_slice_mut().iter_mut().enumerate() {
        *v = (n * 37 % 101) as f32;
    }
    // Each face component moves the same whole cells on its own lattice.
    let mut faces = FaceGrid::zeros(d, BoxKind::Periodic);
    for c in 0..3 {
        faces.slice_mut(c).copy_from_slice(src.as_slice());
    }
    for bt in Backtrace::ALL {
        let mut dst = ScalarGrid::zeros(d);
        advect_scalar(&src, &vel, 0.5, bt, &mut dst);
        let mut moved = FaceGrid::zeros(d, BoxKind::Periodic);
        smokelab::advection::advect_faces(&faces, &vel, 0.5, bt, &mut moved);
        for ((k, j, i), &v) in dst.data().indexed_iter() {
            let expect = src.data()[[(k + 1) % 5, j, (i + 6) % 8]];
            assert_eq!(v, expect, "{bt:?} at ({i},{j},{k})");
            for c in 0..3 {
                assert_eq!(moved.component(c)[[k, j, i]], expect, "{bt:?} face {c}");
            }
        }
    }
}

/// Trilinear SL at a fixed Courant number behaves like the upwind scheme:
/// error per step O(Δx²), steps ∝ 1/Δx, so first order overall.
#[test]
fn smooth_bump_converges_at_first_order() {
    let (cfl, speed, period) = (0.4f32, 1.0f32, 1.0f32);
    let bump = |x: f32| (std::f32::consts::TAU * x / period).sin().exp();
    let mut h = vec![];
    let mut err = vec![];
    for n in [32usize, 64, 128, 256] {
        let d = Domain::new(Vec3::ZERO, period / n as f32, [n, 4, 4]).unwrap();
        let dt = cfl * d.cell / speed;
        let steps = (0.25 * period / speed / dt).round() as usize; // a quarter period
        let vel = FaceGrid::from_field(
            d,
            BoxKind::Periodic,
            &*ops::constant_vector(Vec3::X * speed),
        );
        struct Bump<F>(F);
        impl<F: Fn(f32) -> f32 + Send + Sync> smokelab::field::ScalarField for Bump<F> {
            fn eval(&self, p: Vec3) -> f32 {
                (self.0)(p.x)
            }
        }
        let mut q = ScalarGrid::from_field(d, &Bump(bump));
        let shift = steps as f32 * dt * speed;
        let exact = ScalarGrid::from_field(d, &Bump(move |x| bump(x - shift)));
        let mut tmp = ScalarGrid::zeros(d);
        for _ in 0..steps {
            advect_scalar(&q, &vel, dt, Backtrace::Rk2, &mut tmp);
            std::mem::swap(&mut q, &mut tmp);
        }
        let e = q
            .as_slice()
            .iter()
            .zip(exact.as_slice())
            .map(|(a, b)| (a - b).abs())
            .fold(0.0, f32::max);
        h.push(d.cell as f64);
        err.push(e as f64);
    }
    // The band [0.8, 1.3], centred.
    assert_order(&format!("trilinear SL, CFL {cfl}"), &h, &err, 1.05, 0.25);
}

#[test]
fn fused_step_matches_separate_advection_bit_for_bit() {
    let d = Domain::new(Vec3::ZERO, 0.4, [12, 10, 9]).unwrap();
    let vel = swirl(d);
    let a = ScalarGrid::from_field(d, &*ops::sphere(Vec3::new(2.0, 2.0, 1.5), 1.5));
    let b = ScalarGrid::from_field(d, &*ops::sphere(Vec3::new(1.0, 3.0, 2.0), 1.0));
    for bt in Backtrace::ALL {
        let (mut fa, mut fb, mut fu) = (
            ScalarGrid::zeros(d),
            ScalarGrid::zeros(d),
            FaceGrid::zeros(d, BoxKind::Periodic),
        );
        smokelab::advection::advect_fused(
            &vel,
            0.3,
            bt,
            &[&a, &b],
            &mut [&mut fa, &mut fb],
            &mut fu,
        );
        let (mut sa, mut sb, mut su) = (
            ScalarGrid::zeros(d),
            ScalarGrid::zeros(d),
            FaceGrid::zeros(d, BoxKind::Periodic),
        );
        advect_scalar(&a, &vel, 0.3, bt, &mut sa);
        advect_scalar(&b, &vel, 0.3, bt, &mut sb);
        smokelab::advection::advect_faces(&vel, &vel, 0.3, bt, &mut su);
        assert_eq!(fa.as_slice(), sa.as_slice(), "{bt:?}");
        assert_eq!(fb.as_slice(), sb.as_slice(), "{bt:?}");
        for c in 0..3 {
            assert_eq!(fu.slice(c), su.slice(c), "{bt:?} component {c}");
        }
    }
}
