//! Analytic flows and helpers the library's tests share. Each test file
//! declares `mod common;` and uses what it needs.
#![allow(dead_code)]

use glam::Vec3;
use smokelab::domain::Domain;
use smokelab::field::VectorField;
use smokelab::fit::{observed_order, ObservedOrder};
use smokelab::grid::{BoxKind, FaceGrid};
use smokelab::pressure::PressureSolver;

/// The Taylor–Green vortex `u = A sin x cos y, v = −A cos x sin y, w = 0`
/// sampled on the faces of `domain` (a `2π`-periodic box solves the
/// Navier–Stokes equations with amplitude `A e^{−2νt}`).
pub fn taylor_green(domain: Domain, amplitude: f32) -> FaceGrid {
    struct TaylorGreen(f32);
    impl VectorField for TaylorGreen {
        fn eval(&self, p: Vec3) -> Vec3 {
            self.0 * Vec3::new(p.x.sin() * p.y.cos(), -p.x.cos() * p.y.sin(), 0.0)
        }
    }
    FaceGrid::from_field(domain, BoxKind::Periodic, &TaylorGreen(amplitude))
}

/// A swirling velocity on the faces of `domain`, projected divergence-free.
pub fn swirl(domain: Domain) -> FaceGrid {
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
    let mut v = FaceGrid::from_field(domain, BoxKind::Periodic, &Swirl);
    PressureSolver::new(domain, BoxKind::Periodic).project(&mut v);
    v
}

/// `max_a max_f |a_a[f] − b_a[f]|` of two staggered fields on one grid.
pub fn max_face_diff(a: &FaceGrid, b: &FaceGrid) -> f32 {
    (0..3)
        .flat_map(|c| {
            a.slice(c)
                .iter()
                .zip(b.slice(c))
                .map(|(x, y)| (x - y).abs())
        })
        .fold(0.0, f32::max)
}

/// Hot/cold at `res`³ with `density` held as asked, default otherwise,
/// after `frames` steps.
pub fn hot_cold_after(
    res: usize,
    frames: usize,
    density: smokelab::density::DensityMode,
) -> smokelab::simulation::Simulation {
    use smokelab::scenario::{hot_cold::HotColdConfig, Scenario, SolverConfig};
    let config = HotColdConfig {
        solver: SolverConfig {
            res,
            frames,
            density,
            ..SolverConfig::default()
        },
        ..Default::default()
    };
    let mut sim = config.build().expect("valid hot/cold config");
    for _ in 0..frames {
        sim.step();
    }
    sim
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
