//! Analytic flows and helpers the library's tests share. Each test file
//! declares `mod common;` and uses what it needs.
#![allow(dead_code)]

use glam::Vec3;
use smokelab::domain::Domain;
use smokelab::field::VectorField;
use smokelab::fit::{observed_order, ObservedOrder};
use smokelab::grid::VectorGrid;
use smokelab::projection::Projection;

/// The Taylor–Green vortex `u = A sin x cos y, v = −A cos x sin y, w = 0`
/// sampled at the cell centres of `domain` (a `2π`-periodic box solves the
/// Navier–Stokes equations with amplitude `A e^{−2νt}`).
pub fn taylor_green(domain: Domain, amplitude: f32) -> VectorGrid {
    struct TaylorGreen(f32);
    impl VectorField for TaylorGreen {
        fn eval(&self, p: Vec3) -> Vec3 {
            self.0 * Vec3::new(p.x.sin() * p.y.cos(), -p.x.cos() * p.y.sin(), 0.0)
        }
    }
    VectorGrid::from_field(domain, &TaylorGreen(amplitude))
}

/// A swirling velocity, projected divergence-free on `domain`.
pub fn swirl(domain: Domain) -> VectorGrid {
    struct Swirl;
    impl VectorField for Swirl {
        fn eval(&self, p: Vec3) -> Vec3 {
            Vec3::new(
                p.y.sin() + p.z.cos(),
                p.z.sin() + 0.3 * p.x.cos(),
                p.x.sin(),
            )
        }
    }
    let mut v = VectorGrid::from_field(domain, &Swirl);
    Projection::new(domain).project(&mut v, 0.0, 1.0);
    v
}

/// Fit the observed order of `errors` against `h`, print the table under
/// `label`, and assert `|order − expected| ≤ band`.
pub fn assert_order(
    label: &str,
    h: &[f64],
    errors: &[f64],
    expected: f64,
    band: f64,
) -> ObservedOrder {
    let fit = observed_order(h, errors);
    println!("{label}:\n{fit}");
    assert!(
        (fit.order - expected).abs() <= band,
        "{label}: observed order {:.3}, expected {expected} ± {band}\n{fit}",
        fit.order
    );
    fit
}
