//! Convergence studies against exact solutions, refined at a fixed CFL number.
//!
//! Each function runs one study over the given resolutions and returns a
//! [`Study`]: its spacings, errors and the order it is expected to show (with
//! the reason in the function's doc). Errors are root-mean-square over the
//! cells.

use std::f32::consts::{PI, TAU};

use glam::Vec3;

use super::{observed_order, ObservedOrder};
use crate::advection::{advect_scalar, Backtrace};
use crate::domain::Domain;
use crate::field::{ScalarField, VectorField};
use crate::grid::{ScalarGrid, VectorGrid};
use crate::projection::{Operator, Projection};
use crate::simulation::{Simulation, StepParams};

/// One convergence study.
#[derive(Clone, Debug)]
pub struct Study {
    /// Short name, used for file names.
    pub name: String,
    /// The order the scheme should show.
    pub expected: f64,
    /// Spacings, coarse to fine.
    pub h: Vec<f64>,
    /// Errors at each spacing.
    pub error: Vec<f64>,
}

impl Study {
    /// The fitted order and table.
    pub fn fit(&self) -> ObservedOrder {
        observed_order(&self.h, &self.error)
    }
}

/// Root-mean-square difference of two equally long slices.
fn rms_diff(a: &[f32], b: &[f32]) -> f64 {
    let s: f64 = a.iter().zip(b).map(|(x, y)| ((x - y) as f64).powi(2)).sum();
    (s / a.len() as f64).sqrt()
}

/// A scalar field from a closure.
struct FnScalar<F>(F);
impl<F: Fn(Vec3) -> f32 + Send + Sync> ScalarField for FnScalar<F> {
    fn eval(&self, p: Vec3) -> f32 {
        (self.0)(p)
    }
}

/// A vector field from a closure.
struct FnVector<F>(F);
impl<F: Fn(Vec3) -> Vec3 + Send + Sync> VectorField for FnVector<F> {
    fn eval(&self, p: Vec3) -> Vec3 {
        (self.0)(p)
    }
}

/// A thin periodic box `[0, L]² × 4Δx` with `n` cells across.
fn slab_domain(n: usize, size: f32) -> Domain {
    Domain::new(Vec3::ZERO, size / n as f32, [n, n, 4]).expect("valid study domain")
}

/// Semi-Lagrangian advection of `exp(sin 2πx)` by a uniform unit velocity
/// over a quarter period at CFL 0.4. Trilinear interpolation damps each step
/// by O(Δx²) and the number of steps grows as 1/Δx: **order 1** for every
/// backtrace (the backtrace is exact for uniform flow).
pub fn sl_uniform(backtrace: Backtrace, resolutions: &[usize]) -> Study {
    let mut study = Study {
        name: format!("sl_uniform_{backtrace:?}").to_lowercase(),
        expected: 1.0,
        h: vec![],
        error: vec![],
    };
    for &n in resolutions {
        let d = Domain::new(Vec3::ZERO, 1.0 / n as f32, [n, 4, 4]).expect("valid study domain");
        let dt = 0.4 * d.cell;
        let steps = (0.25 / dt).round() as usize;
        let shift = steps as f32 * dt;
        let profile = |x: f32| (TAU * x).sin().exp();
        let vel = VectorGrid::from_field(d, &FnVector(|_| Vec3::X));
        let mut q = ScalarGrid::from_field(d, &FnScalar(|p: Vec3| profile(p.x)));
        let exact = ScalarGrid::from_field(d, &FnScalar(|p: Vec3| profile(p.x - shift)));
        let mut tmp = ScalarGrid::zeros(d);
        for _ in 0..steps {
            advect_scalar(&q, &vel, dt, backtrace, &mut tmp);
            std::mem::swap(&mut q, &mut tmp);
        }
        study.h.push(d.cell as f64);
        study.error.push(rms_diff(q.as_slice(), exact.as_slice()));
    }
    study
}

/// Semi-Lagrangian advection of a Gaussian blob (σ = 0.08) by solid-body
/// rotation about the box centre, a quarter turn, with Δt = Δx/2 (CFL ≈ 0.8 at
/// the blob). The velocity is linear, so its trilinear interpolation is exact
/// and only the backtrace and the density interpolation err: the Euler
/// backtrace's O(Δt²) per step and trilinear damping's O(Δx²) per step both
/// give **order 1** overall; RK2 and RK3 remove the first but not the second.
pub fn sl_rotation(backtrace: Backtrace, resolutions: &[usize]) -> Study {
    let mut study = Study {
        name: format!("sl_rotation_{backtrace:?}").to_lowercase(),
        expected: 1.0,
        h: vec![],
        error: vec![],
    };
    let (omega, c, sigma) = (TAU, Vec3::new(0.5, 0.5, 0.0), 0.08f32);
    let blob = move |p: Vec3, at: Vec3| {
        (-((p - at) * Vec3::new(1.0, 1.0, 0.0)).length_squared() / (2.0 * sigma * sigma)).exp()
    };
    for &n in resolutions {
        let d = slab_domain(n, 1.0);
        let dt = 0.5 * d.cell;
        let steps = (0.25 / dt).round() as usize;
        let angle = omega * steps as f32 * dt;
        let start = c + Vec3::new(0.25, 0.0, 0.0);
        let end = c + 0.25 * Vec3::new(angle.cos(), angle.sin(), 0.0);
        let vel = VectorGrid::from_field(
            d,
            &FnVector(move |p: Vec3| omega * Vec3::new(c.y - p.y, p.x - c.x, 0.0)),
        );
        let mut q = ScalarGrid::from_field(d, &FnScalar(move |p| blob(p, start)));
        let exact = ScalarGrid::from_field(d, &FnScalar(move |p| blob(p, end)));
        let mut tmp = ScalarGrid::zeros(d);
        for _ in 0..steps {
            advect_scalar(&q, &vel, dt, backtrace, &mut tmp);
            std::mem::swap(&mut q, &mut tmp);
        }
        study.h.push(d.cell as f64);
        study.error.push(rms_diff(q.as_slice(), exact.as_slice()));
    }
    study
}

/// `A sin x cos y, −A cos x sin y` on a `2π` box.
fn taylor_green(d: Domain, amplitude: f32) -> VectorGrid {
    VectorGrid::from_field(
        d,
        &FnVector(move |p: Vec3| {
            amplitude * Vec3::new(p.x.sin() * p.y.cos(), -p.x.cos() * p.y.sin(), 0.0)
        }),
    )
}

/// The full Navier–Stokes step (advection, exact viscous diffusion,
/// projection) on the Taylor–Green vortex, ν = 0.05, to t = π/2 with
/// Δt = Δx/2 (CFL 0.5). The solution is exact with amplitude `e^{−2νt}`; the
/// semi-Lagrangian trilinear damping makes the scheme **order 1**.
pub fn taylor_green_sl(resolutions: &[usize]) -> Study {
    let mut study = Study {
        name: "taylor_green_sl".into(),
        expected: 1.0,
        h: vec![],
        error: vec![],
    };
    let nu = 0.05f32;
    for &n in resolutions {
        let d = slab_domain(n, TAU);
        let dt = 0.5 * d.cell;
        let steps = n / 2; // t = π/2
        let params = StepParams {
            dt,
            viscosity: nu,
            gravity: Vec3::ZERO,
            backtrace: Backtrace::Rk2,
        };
        let mut sim = Simulation::new(d, params, vec![]);
        sim.velocity = taylor_green(d, 1.0);
        for _ in 0..steps {
            sim.step();
        }
        let t = steps as f32 * dt;
        let exact = taylor_green(d, (-2.0 * nu * t).exp());
        study.h.push(d.cell as f64);
        study
            .error
            .push(rms_diff(sim.velocity.as_slice(), exact.as_slice()));
    }
    study
}

/// Manufactured Helmholtz split `u = ∇φ + w` on a `2π` cube with
/// `φ = sin x sin 2y sin 3z` and `w = ∇ × (cos 2z, sin 3x, cos y)`, both
/// sampled from their continuous formulas. The projection should return `w`.
/// With the central-difference wavenumbers `k̃ = k (1 − k²Δx²/6 + …)` the
/// removed direction is off by O(Δx²): **order 2** against the continuous
/// answer. Returns the error of the recovered solenoidal part.
pub fn projection_error(n: usize, operator: Operator) -> f64 {
    let d = Domain::cube(n, TAU).expect("valid study domain");
    let grad_phi = |p: Vec3| {
        Vec3::new(
            p.x.cos() * (2.0 * p.y).sin() * (3.0 * p.z).sin(),
            2.0 * p.x.sin() * (2.0 * p.y).cos() * (3.0 * p.z).sin(),
            3.0 * p.x.sin() * (2.0 * p.y).sin() * (3.0 * p.z).cos(),
        )
    };
    // curl of A = (cos 2z, sin 3x, cos y): (∂y Az − ∂z Ay, ∂z Ax − ∂x Az, ∂x Ay − ∂y Ax)
    let w = |p: Vec3| {
        Vec3::new(
            -p.y.sin(),
            -2.0 * (2.0 * p.z).sin(),
            3.0 * (3.0 * p.x).cos(),
        )
    };
    let mut u = VectorGrid::from_field(d, &FnVector(move |p| grad_phi(p) + w(p)));
    let exact = VectorGrid::from_field(d, &FnVector(w));
    Projection::with_operator(d, operator).project(&mut u, 0.0, 1.0);
    rms_diff(u.as_slice(), exact.as_slice())
}

/// [`projection_error`] with central-difference wavenumbers over
/// `resolutions`: **order 2**.
pub fn projection_discrete(resolutions: &[usize]) -> Study {
    Study {
        name: "projection_discrete".into(),
        expected: 2.0,
        h: resolutions
            .iter()
            .map(|&n| (TAU / n as f32) as f64)
            .collect(),
        error: resolutions
            .iter()
            .map(|&n| projection_error(n, Operator::CentralDifference))
            .collect(),
    }
}

/// Spacing of a `2π` box with `n` cells, for tables.
pub fn spacing_2pi(n: usize) -> f64 {
    (2.0 * PI / n as f32) as f64
}
