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

/// `u = A (x − c)` with a non-normal `A`, centred in a periodic box of
/// unit cells.
struct Linear;

const A: [[f64; 3]; 3] = [[0.0, -1.0, 0.2], [1.0, 0.0, 0.0], [0.0, 0.5, 0.0]];

impl smokelab::field::VectorField for Linear {
    fn eval(&self, p: Vec3) -> Vec3 {
        let r = (p - Vec3::splat(12.5)).as_dvec3().to_array();
        Vec3::from_array(std::array::from_fn(|a| {
            (0..3).map(|b| A[a][b] * r[b]).sum::<f64>() as f32
        }))
    }
}

/// `e^{−AΔt}`, by its series (`‖AΔt‖ < 1`).
fn exp_minus(dt: f64) -> [[f64; 3]; 3] {
    let mut sum = [[0.0; 3]; 3];
    let mut term = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    for n in 1..30 {
        for (s, t) in sum.iter_mut().flatten().zip(term.iter().flatten()) {
            *s += t;
        }
        term = std::array::from_fn(|i| {
            std::array::from_fn(|j| {
                (0..3).map(|k| -dt * term[i][k] * A[k][j]).sum::<f64>() / n as f64
            })
        });
    }
    sum
}

/// On a linear velocity the trilinear interpolation and the faces'
/// averages are exact, so the grid sweep's RK2 — Euler through the
/// midpoint velocity, the velocity's own Euler step over ½Δt
/// (`advection::Midpoint`) — is the midpoint rule itself: one step's
/// departure points miss the exact flow `c + e^{−AΔt}(x − c)` by `O(Δt³)`
/// (second order over a fixed time), Euler's by `O(Δt²)`. A midpoint
/// velocity over the whole step, or none, would give order 2.
#[test]
fn grid_rk2_departures_are_third_order_per_step_on_a_linear_flow() {
    let d = Domain::new(Vec3::ZERO, 1.0, [24, 24, 24]).unwrap();
    let vel = FaceGrid::from_field(d, BoxKind::Periodic, &Linear);
    for (bt, order) in [(Backtrace::Rk2, 3.0), (Backtrace::Euler, 2.0)] {
        let (mut h, mut err) = (Vec::new(), Vec::new());
        for dt in [0.4f32, 0.2, 0.1, 0.05] {
            let mut dep = smokelab::advection::Departures::new(d);
            dep.trace(&vel, dt, bt);
            let e = exp_minus(dt as f64);
            let mut worst = 0.0f64;
            for (n, got) in dep.points().iter().enumerate() {
                let c = [n % 24, n / 24 % 24, n / 576].map(|x| x as f64 - 12.0);
                // Cells within five of the centre: every stencil inside.
                if c.iter().any(|x| x.abs() > 5.0) {
                    continue;
                }
                for a in 0..3 {
                    let want = 12.0 + (0..3).map(|b| e[a][b] * c[b]).sum::<f64>();
                    worst = worst.max((got[a] as f64 - want).abs());
                }
            }
            h.push(dt as f64);
            err.push(worst);
        }
        assert_order(
            &format!("grid {bt:?} departures, one step"),
            &h,
            &err,
            order,
            0.15,
        );
    }
}
