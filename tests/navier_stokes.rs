//! Full steps: Taylor–Green viscous decay (and its convergence through
//! `smokelab run taylor-green`), the hot/cold mirror symmetry, and
//! the buoyant rise against its small-displacement estimate.

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
        interpolant: Default::default(),
        confinement: 0.0,
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

/// The hot gas's centre-of-mass rise from step 1 to step `n` while the
/// displacement is small against the source's radius: inside a uniformly
/// forced ball the projection keeps `2/3` of the force (the gradient part of
/// `f·1_B` is `f/3` inside the ball), so the velocity there after step `k`
/// is `v_k = (2/3) g S Δt² k(k+1)/2` (the density is `k S Δt` when the
/// buoyancy of step `k` is added). Gas injected at step `j` then moves by
/// `Σ_{k=j}^{n−1} v_k Δt`, so the centre of mass of the `n` equal
/// injections rises by `(Δt/n) Σ_{k=1}^{n−1} k v_k`. The mirrored cold
/// source and the periodic images change this by well under 1 % (dipole
/// fields of relative size `(4π/3)·2/(4π·5³)` and `(4π/3)/10³`).
fn buoyant_rise(n: usize, dt: f64, gravity: f64, rate: f64) -> f64 {
    let v = |k: f64| 2.0 / 3.0 * gravity * rate * dt * dt * k * (k + 1.0) / 2.0;
    (1..n).map(|k| k as f64 * v(k as f64)).sum::<f64>() * dt / n as f64
}

/// The discrete hot/cold problem is symmetric under hot ↔ cold, y ↔ L − y
/// (the cold source is the mirror of the hot one and every operator is
/// mirror-symmetric): for every advection scheme and density mode, after 20
/// steps at 32³ the densities at the cell centres mirror each other to
/// round-off, and hot has risen (cold sunk) by the small-displacement
/// buoyancy estimate [`buoyant_rise`], 0.0804 at t = 1.
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
                ..HotColdConfig::head_on()
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
            let err = smokelab::metrics::mirror_error(hot, cold);
            let (hot1, cold1) = (hot.center_of_mass(), cold.center_of_mass());
            let s = &config.solver;
            let expect = buoyant_rise(s.frames, s.dt as f64, s.gravity as f64, 1.0);
            let (rise, sink) = ((hot1.y - hot0.y) as f64, (cold0.y - cold1.y) as f64);
            println!(
                "{case}: mirror error {err:.3e}; hot rose {rise:.4}, cold sank {sink:.4}, estimate {expect:.4} (ratio {:.3})",
                rise / expect
            );
            assert!(
                err <= 1e-4,
                "{case}: hot and mirrored cold differ by {err} (relative)"
            );
            // Measured 0.757 (gridless, SELMA) to 0.892 (QUICK gridded) of
            // the estimate: at 32³ the resolved rise falls short of it (see
            // the convergence test below). MacCormack's gridded gas rises
            // 0.631 of it: the solid source re-sharpens the gas's edges every
            // step, and at this Courant number (≈ 0.05) MacCormack moves a
            // step edge about half as far as SL does (the corrected value
            // overshoots beside the edge and reverts to SL's, while the edge
            // cell gets `c/2 + c²/2` for SL's `c`).
            let lowest = match (advection, density) {
                (Scheme::MacCormack | Scheme::Bfecc, DensityMode::Gridded) => 0.6,
                _ => 0.65,
            };
            for (what, r) in [("hot rose", rise), ("cold sank", sink)] {
                assert!(
                    (lowest..=0.98).contains(&(r / expect)),
                    "{case}: {what} {r}, estimate {expect}"
                );
            }
        }
    }
}

/// The rise approaches [`buoyant_rise`] as the grid refines, so the
/// estimate is the flow's and the shortfall the discretisation's (smeared
/// staircase source, damped velocity). Measured with gridded densities at
/// t = 1 (20 steps), rise over the estimate at 16³ / 32³ / 48³ / 64³:
/// SL 0.593 / 0.788 / 0.843 / 0.873, QUICK 0.814 / 0.892 / 0.917 / 0.935
/// (the same to 0.001 with 40 steps of Δt 0.025). The shortfall falls by
/// 1.67 (both schemes) from 32³ to 64³, about first order; extrapolated at
/// first order the ratio tends to 0.957 (SL) and 0.978 (QUICK). With the
/// source injected as its cell average instead of point-sampled (a scratch
/// run replacing `Gas::source`) the ratios at 32³ / 64³ drop to SL 0.729 /
/// 0.843, QUICK 0.814 / 0.895, and the limits stay 0.957 and 0.976.
/// MacCormack is left out: its gridded gas rises 0.625 / 0.714 of the
/// estimate (shortfall × 0.76, extrapolated at first order 0.80), slowed at
/// the solid source's re-sharpened edges (see the test above); whether it
/// approaches the estimate is not measured here.
#[test]
fn hot_cold_rise_converges_to_the_buoyancy_estimate() {
    for advection in [Scheme::Sl, Scheme::Quick] {
        let ratio = |res| {
            let config = HotColdConfig {
                solver: SolverConfig {
                    res,
                    frames: 20,
                    advection,
                    ..SolverConfig::default()
                },
                ..Default::default()
            };
            let mut sim = config.build().unwrap();
            sim.step();
            let y0 = sim.gases[0].density().center_of_mass().y;
            for _ in 1..config.solver.frames {
                sim.step();
            }
            let rise = (sim.gases[0].density().center_of_mass().y - y0) as f64;
            let s = &config.solver;
            rise / buoyant_rise(s.frames, s.dt as f64, s.gravity as f64, 1.0)
        };
        let (coarse, fine) = (ratio(32), ratio(64));
        let limit = 2.0 * fine - coarse;
        println!(
            "{advection:?}: rise / estimate {coarse:.3} at 32³, {fine:.3} at 64³, first-order limit {limit:.3}"
        );
        assert!(
            (1.0 - fine) <= 0.75 * (1.0 - coarse),
            "{advection:?}: shortfall {:.3} at 32³, {:.3} at 64³",
            1.0 - coarse,
            1.0 - fine
        );
        assert!(
            (0.93..=1.03).contains(&limit),
            "{advection:?}: extrapolated rise / estimate {limit:.3}"
        );
    }
}

/// `smokelab run taylor-green` at 16³, 32³, 64³ to t = π/2 (Δt = Δx/2,
/// ν = 0.05): the solver's velocity (advection, exact viscosity,
/// projection) against the exact decaying vortex. For every scheme the
/// relative L2 error and the error of the kinetic energy's decay rate
/// (fitted `−d ln E/dt` against `4νk²`) fall at **order 1** in Δx: the
/// step advects the velocity frozen at the start of the step, an O(Δt²)
/// splitting error per step (see `convergence_cases::taylor_green_quick`).
#[test]
fn taylor_green_scenario_converges_at_first_order_for_every_scheme() {
    use smokelab::fit::{linear_fit, observed_order};
    use smokelab::scenario::taylor_green::TaylorGreenConfig;
    let mut finest = vec![];
    for scheme in Scheme::ALL {
        let (mut h, mut l2, mut rate_err) = (vec![], vec![], vec![]);
        for res in [16, 32, 64] {
            let mut c = TaylorGreenConfig::default();
            c.solver.res = res;
            c.solver.dt = 0.5 * c.solver.size / res as f32;
            c.solver.advection = scheme;
            let flow = c.flow();
            let mut sim = c.build().unwrap();
            let mut log_energy = vec![];
            for _ in 0..res / 2 {
                sim.step();
                let m = flow.measure(&sim.velocity, sim.time());
                log_energy.push((sim.time() as f64, m.energy.ln()));
            }
            let m = flow.measure(&sim.velocity, sim.time());
            let rate = -linear_fit(&log_energy).unwrap().slope;
            let exact_rate = 4.0 * (c.solver.nu * flow.k() * flow.k()) as f64;
            println!(
                "{scheme:?} {res}³: L2 {:.4e}, L∞ {:.4e}, E/E0 {:.5} (exact {:.5}), decay rate {rate:.4} (exact {exact_rate})",
                m.l2, m.linf, m.energy, m.energy_exact
            );
            h.push(c.solver.size as f64 / res as f64);
            l2.push(m.l2);
            rate_err.push(rate - exact_rate);
        }
        let (order, rate_order) = (observed_order(&h, &l2), observed_order(&h, &rate_err));
        println!("{scheme:?}: L2\n{order}\ndecay rate\n{rate_order}");
        // Measured: L2 0.89 (SL), 0.95 (QUICK), 0.91 (MacCormack); the
        // decay rate's error 0.93, 0.95, 0.91.
        for (what, fit) in [("L2 error", &order), ("decay-rate error", &rate_order)] {
            assert!(
                (0.85..=1.05).contains(&fit.order),
                "{scheme:?}: {what} observed order {:.3}, expected 1 (0.85..=1.05)",
                fit.order
            );
        }
        finest.push((scheme, l2[2]));
    }
    // The second-order advections halve SL's damping at 64³ and beyond
    // (measured 0.29 and 0.29 of SL's error).
    let sl = finest.iter().find(|(s, _)| *s == Scheme::Sl).unwrap().1;
    for &(scheme, e) in &finest {
        if scheme != Scheme::Sl {
            assert!(e < 0.4 * sl, "{scheme:?}: L2 {e} at 64³ against SL's {sl}");
        }
    }
}
