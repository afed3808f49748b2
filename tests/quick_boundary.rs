//! QUICK advection (order, stability, limiter) and level-set obstacles with
//! the reflecting (eq 6.6) and sticky (eq 6.7) rules, up to the slab-box run.

use glam::Vec3;
use smokelab::advection::{self, quick, Backtrace, Limiter, QuickOptions};
use smokelab::domain::Domain;
use smokelab::field::{ops, ScalarField};
use smokelab::grid::{BoxKind, FaceGrid, ScalarGrid};
use smokelab::scenario::config::resolve;
use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;

mod common;
use common::order::assert_order;
use common::swirl;

/// A smooth periodic profile on the unit square (constant along z).
struct Smooth(Vec3);

impl ScalarField for Smooth {
    fn eval(&self, p: Vec3) -> f32 {
        let tau = std::f32::consts::TAU;
        let q = p - self.0;
        ((tau * q.x).sin() + 0.5 * (tau * q.y).cos()).exp()
    }
}

/// Max-norm error after advecting `Smooth` once around the unit square in x
/// (half-way in y) at Courant number `cfl` (per unit speed), with QUICK or SL.
fn smooth_error(n: usize, cfl: f32, scheme: advection::Scheme) -> (f64, f64) {
    let d = Domain::new(Vec3::ZERO, 1.0 / n as f32, [n, n, 4]).unwrap();
    let u = Vec3::new(1.0, 0.5, 0.0);
    let dt = cfl * d.cell;
    let steps = (1.0 / dt).round() as usize;
    let vel = FaceGrid::from_field(d, BoxKind::Periodic, &*ops::constant_vector(u));
    let mut q = ScalarGrid::from_field(d, &Smooth(Vec3::ZERO));
    let exact = ScalarGrid::from_field(d, &Smooth(u * (steps as f32 * dt)));
    let mut tmp = ScalarGrid::zeros(d);
    let mut quick = quick::Quick::new(d, QuickOptions::default());
    let mut dep = advection::Departures::new(d);
    quick.prepare(&vel, dt).unwrap();
    dep.trace(&vel, dt, Backtrace::Rk2);
    for _ in 0..steps {
        match scheme {
            advection::Scheme::Quick => quick.advect_scalar(&q, &mut tmp, Limiter::None),
            advection::Scheme::Sl => advection::interpolate_scalar(&q, &dep, &mut tmp),
            advection::Scheme::MacCormack => {
                advection::maccormack_scalar(&q, &vel, dt, Backtrace::Rk2, &mut tmp)
            }
            advection::Scheme::Bfecc => {
                advection::bfecc_scalar(&q, &vel, dt, Backtrace::Rk2, &mut tmp)
            }
        }
        std::mem::swap(&mut q, &mut tmp);
    }
    let e = q
        .as_slice()
        .iter()
        .zip(exact.as_slice())
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f32::max);
    (d.cell as f64, e as f64)
}

/// QUICK's phase error is θ³/24 per cell for a mode θ = kΔx, its damping θ⁴/16,
/// and SSP-RK3 is third order: at a fixed Courant number the error of a
/// smooth profile falls as Δx².
#[test]
fn quick_converges_at_second_order_and_beats_sl() {
    let cfl = 0.5;
    let (mut h, mut err) = (vec![], vec![]);
    println!("{:>5} {:>12} {:>12}", "n", "QUICK", "SL");
    for n in [16usize, 32, 64, 128] {
        let (hq, eq) = smooth_error(n, cfl, advection::Scheme::Quick);
        let (_, es) = smooth_error(n, cfl, advection::Scheme::Sl);
        println!("{n:>5} {eq:>12.4e} {es:>12.4e}");
        assert!(eq < 0.5 * es, "n = {n}: QUICK error {eq} vs SL {es}");
        h.push(hq);
        err.push(eq);
    }
    // The band [1.8, 2.3], centred.
    assert_order(
        &format!("QUICK, Courant number {cfl} per unit speed"),
        &h,
        &err,
        2.05,
        0.25,
    );
}

/// A sharp-edged box of density 1 in a periodic cube.
fn sharp_box(d: Domain) -> ScalarGrid {
    let mut q = ScalarGrid::zeros(d);
    for ((k, j, i), v) in q.data_mut().indexed_iter_mut() {
        if (4..11).contains(&i) && (5..12).contains(&j) && (3..9).contains(&k) {
            *v = 1.0;
        }
    }
    q
}

fn min_max(q: &ScalarGrid) -> (f32, f32) {
    q.as_slice()
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &v| {
            (a.min(v), b.max(v))
        })
}

/// 100 steps of a sharp-edged, non-negative density: with the limiter it
/// stays within [0, 1] (plain QUICK undershoots, so the bound is not vacuous).
#[test]
fn limiter_keeps_a_sharp_density_within_its_bounds() {
    let d = Domain::cube(16, std::f32::consts::TAU).unwrap();
    let velocities = [
        (
            "diagonal",
            FaceGrid::from_field(
                d,
                BoxKind::Periodic,
                &*ops::constant_vector(Vec3::new(1.0, 0.6, 0.3)),
            ),
        ),
        ("swirl", swirl(d)),
    ];
    for (name, vel) in velocities {
        let dt = 0.9 * d.cell / vel.max_norm() / 1.9;
        for limiter in Limiter::ALL {
            let mut q = sharp_box(d);
            let mass = q.total();
            let mut tmp = ScalarGrid::zeros(d);
            let mut adv = quick::Quick::new(d, QuickOptions::default());
            adv.prepare(&vel, dt).unwrap();
            for _ in 0..100 {
                adv.advect_scalar(&q, &mut tmp, limiter);
                std::mem::swap(&mut q, &mut tmp);
            }
            let (lo, hi) = min_max(&q);
            let drift = (q.total() - mass).abs() / mass;
            println!("{name}, {limiter:?}: min {lo:.3e}, max {hi:.6}, mass drift {drift:.1e}");
            assert!(drift < 1e-5, "{name} {limiter:?}: mass drift {drift}");
            match limiter {
                Limiter::Ultimate => {
                    assert!(lo >= 0.0, "{name}: negative density {lo}");
                    assert!(hi <= 1.0 + 1e-6, "{name}: overshoot {hi}");
                }
                Limiter::None => {
                    assert!(lo < -1e-2, "{name}: plain QUICK did not undershoot ({lo})")
                }
            }
        }
    }
}

/// Far beyond the stability limit the step is split (bounded result) or,
/// when sub-steps are forbidden, refused with a message — never NaN.
#[test]
fn courant_beyond_stability_substeps_or_refuses() {
    let d = Domain::cube(16, 16.0).unwrap();
    let vel = FaceGrid::from_field(
        d,
        BoxKind::Periodic,
        &*ops::constant_vector(Vec3::new(3.0, 2.0, 1.0)),
    );
    let dt = 1.0; // Courant number 6, over three times QUICK's limit of 1.85.
    let src = sharp_box(d);
    let mut dst = ScalarGrid::zeros(d);
    for limiter in Limiter::ALL {
        let n = quick::advect_scalar(&src, &vel, dt, QuickOptions::default(), limiter, &mut dst)
            .unwrap();
        assert_eq!(n, 6, "sub-steps at Courant number 6");
        let (lo, hi) = min_max(&dst);
        // Plain QUICK rings at the sharp edges (measured range [−0.221, 1.464])
        // but does not grow — an unstable step would leave any band, and NaN
        // fails the comparisons; limited QUICK stays exactly within [0, 1].
        let (min, max) = match limiter {
            Limiter::None => (-0.3, 1.5),
            Limiter::Ultimate => (0.0, 1.0 + 1e-6),
        };
        println!("{limiter:?}: range [{lo}, {hi}] after 6 sub-steps");
        assert!(lo >= min && hi <= max, "{limiter:?}: range [{lo}, {hi}]");
    }
    let forbid = QuickOptions {
        substeps: false,
        ..Default::default()
    };
    let before = dst.clone();
    let e = quick::advect_scalar(&src, &vel, dt, forbid, Limiter::Ultimate, &mut dst).unwrap_err();
    let msg = e.to_string();
    println!("{msg}");
    assert!(msg.contains("Courant number 6.000") && msg.contains("sub-stepping is disabled"));
    assert_eq!(
        dst.as_slice(),
        before.as_slice(),
        "a refused step wrote its output"
    );
}

/// Just below the advertised stability limit (Courant number 1.85 per
/// step) the energy of random data does not grow: every Fourier mode is
/// damped, so the constant is not optimistic.
#[test]
fn stable_at_the_advertised_limit() {
    let n = 32;
    let d = Domain::new(Vec3::ZERO, 1.0 / n as f32, [n, 4, 4]).unwrap();
    let vel = FaceGrid::from_field(d, BoxKind::Periodic, &*ops::constant_vector(Vec3::X));
    let opts = QuickOptions {
        max_courant: quick::STABILITY_LIMIT,
        substeps: false,
    };
    let mut adv = quick::Quick::new(d, opts);
    adv.prepare(&vel, 0.999 * quick::STABILITY_LIMIT * d.cell)
        .unwrap();
    let mut q = ScalarGrid::zeros(d);
    for (n, v) in q.as_slice_mut().iter_mut().enumerate() {
        *v = ((n * 7919) % 101) as f32 / 101.0;
    }
    let energy = |q: &ScalarGrid| {
        q.as_slice()
            .iter()
            .map(|v| (*v as f64).powi(2))
            .sum::<f64>()
    };
    let mut tmp = ScalarGrid::zeros(d);
    let mut last = energy(&q);
    for step in 0..400 {
        adv.advect_scalar(&q, &mut tmp, Limiter::None);
        std::mem::swap(&mut q, &mut tmp);
        let e = energy(&q);
        assert!(
            e <= last * (1.0 + 1e-6),
            "energy grew at step {step}: {last} → {e}"
        );
        last = e;
    }
}

use smokelab::advection::Scheme;
use smokelab::boundary::BoundaryRule;
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::slab_box::SlabBoxConfig;

/// A fluid at rest next to obstacles stays at rest: with no buoyancy the
/// gas is injected but nothing moves, under every scheme and rule.
#[test]
fn fluid_at_rest_next_to_obstacles_stays_at_rest() {
    for advection in Scheme::ALL {
        for boundary in BoundaryRule::ALL {
            let config = SlabBoxConfig {
                solver: SolverConfig {
                    res: 26,
                    gravity: 0.0,
                    advection,
                    ..SlabBoxConfig::default_solver()
                },
                boundary,
                boundary_passes: 2,
                ..Default::default()
            };
            let mut sim = config.build().unwrap();
            for _ in 0..5 {
                sim.try_step().unwrap();
            }
            assert_eq!(sim.velocity.max_norm(), 0.0, "{advection:?} {boundary:?}");
            let injected = sim.gases[0].injected_per_step(config.solver.dt) * 5.0;
            let mass = sim.gases[0].density().total();
            assert!(
                (mass - injected).abs() < 1e-5 * injected,
                "{mass} vs {injected}"
            );
        }
    }
}

#[test]
fn advection_and_boundary_are_config_keys() {
    let layer = |text: &str| vec![("test".to_string(), toml::from_str(text).unwrap())];
    let c: HotColdConfig = resolve(
        &layer("advection = \"quick\"\nsubsteps = false\nlimiter = \"none\"\n"),
        &[],
    )
    .unwrap();
    assert_eq!(
        (c.solver.advection, c.solver.substeps, c.solver.limiter),
        (Scheme::Quick, false, Limiter::None)
    );
    let c: SlabBoxConfig = resolve(
        &layer("advection = \"sl\"\nboundary = \"sticky\"\nalpha = 0.25\nboundary_passes = 2\n"),
        &[],
    )
    .unwrap();
    assert_eq!(
        (c.solver.advection, c.boundary, c.alpha, c.boundary_passes),
        (Scheme::Sl, BoundaryRule::Sticky, 0.25, 2)
    );
    let bad = resolve::<SlabBoxConfig>(&layer("boundary = \"bouncy\"\n"), &[]).unwrap_err();
    assert!(
        bad.to_string().contains("boundary = \"bouncy\" (test)"),
        "{bad}"
    );
}
