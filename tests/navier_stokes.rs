//! Full steps: Taylor–Green viscous decay and the hot/cold mirror symmetry.

use glam::Vec3;
use smokelab::advection::Scheme;
use smokelab::density::DensityMode;
use smokelab::domain::Domain;
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;
use smokelab::simulation::{Simulation, StepParams};

mod common;
use common::{max_face_diff, taylor_green};

/// The Taylor–Green vortex solves the full Navier–Stokes equations with
/// amplitude `e^{−2νt}`. On the MAC grid viscosity is applied exactly per
/// mode with the continuum `|k|²`, so the only error is the trilinear
/// semi-Lagrangian damping, about `α (kΔx)²/2` per step and axis for a
/// Courant number α. The amplitude is kept small (α ≈ 2.5e-5) so that damping
/// stays far below the 1e-4 tolerance: the test isolates the viscous decay
/// with advection, pressure solve and projection on. (With the 7-point
/// symbol for viscosity the amplitude would be off by ~1e-3.)
#[test]
fn taylor_green_decays_as_exp_minus_two_nu_t() {
    let n = 32;
    let d = Domain::new(Vec3::ZERO, std::f32::consts::TAU / n as f32, [n, n, 4]).unwrap();
    let (nu, dt, steps, amplitude) = (0.2f32, 0.05f32, 50, 1e-4f32);
    let params = StepParams {
        dt,
        viscosity: nu,
        gravity: Vec3::ZERO,
        backtrace: Default::default(),
    };
    let mut sim = Simulation::new(d, params, vec![]);
    sim.velocity = taylor_green(d, amplitude);
    for _ in 0..steps {
        sim.step();
    }
    let t = steps as f32 * dt;
    let exact = taylor_green(d, amplitude * (-2.0 * nu * t).exp());
    let rel = max_face_diff(&sim.velocity, &exact) / exact.max_norm();
    println!("Taylor–Green after t = {t}: relative error {rel:.3e}");
    assert!(rel <= 1e-4, "relative error {rel} after {steps} steps");
}

/// The discrete hot/cold problem is symmetric under hot ↔ cold, y ↔ L − y
/// (the cold source is the mirror of the hot one and every operator is
/// mirror-symmetric): for every advection scheme and density mode, after 20
/// steps at 32³ the densities at the cell centres mirror each other to
/// round-off, hot has risen and cold has sunk.
#[test]
fn hot_cold_is_mirror_symmetric_and_buoyant_for_every_scheme_and_mode() {
    for advection in Scheme::ALL {
        for density in DensityMode::ALL {
            let config = HotColdConfig {
                solver: SolverConfig {
                    res: 32,
                    frames: 20,
                    advection,
                    density,
                    ..SolverConfig::default()
                },
                ..Default::default()
            };
            let case = format!("{advection:?} × {density:?}");
            let mut sim = config.build().unwrap();
            // Start with some gas in place so the centres of mass are defined.
            sim.step();
            let (hot0, cold0) = (
                sim.gases[0].density().center_of_mass(),
                sim.gases[1].density().center_of_mass(),
            );
            for _ in 1..config.solver.frames {
                sim.step();
            }
            let (hot, cold) = (sim.gases[0].density(), sim.gases[1].density());
            assert!(sim.velocity.is_finite(), "{case}");
            assert!(
                hot.as_slice()
                    .iter()
                    .chain(cold.as_slice())
                    .all(|v| v.is_finite()),
                "{case}"
            );
            let err = smokelab::metrics::mirror_error(hot, cold);
            let (hot1, cold1) = (hot.center_of_mass(), cold.center_of_mass());
            println!(
                "{case}: mirror error {err:.3e}; hot y {} → {}, cold y {} → {}",
                hot0.y, hot1.y, cold0.y, cold1.y
            );
            assert!(
                err <= 1e-4,
                "{case}: hot and mirrored cold differ by {err} (relative)"
            );
            assert!(hot1.y > hot0.y + 0.01, "{case}: hot gas did not rise");
            assert!(cold1.y < cold0.y - 0.01, "{case}: cold gas did not sink");
        }
    }
}
