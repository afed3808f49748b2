//! Obstacles the flow cannot enter (issue 15): the obstacle-aware pressure
//! solve against the fast solver, hydrostatic balance, a sphere in a
//! stream, and the gas the slab-box run keeps with each method and scheme.

use std::sync::Arc;

use glam::Vec3;
use smokelab::advection::{Backtrace, Scheme};
use smokelab::boundary::{
    Boundary, BoundaryOptions, BoundaryRule, Obstacle, ObstacleMethod, Sphere,
};
use smokelab::density::{probe, DensityMode};
use smokelab::domain::Domain;
use smokelab::grid::{BoxKind, FaceGrid, Interpolant};
use smokelab::pressure::obstacles::{ObstacleProjection, TOLERANCE};
use smokelab::pressure::PressureSolver;
use smokelab::scenario::slab_box::SlabBoxConfig;
use smokelab::scenario::{Scenario, SolverConfig};
use smokelab::simulation::Simulation;

mod common;
use common::max_face_diff;

/// Largest flux divergence of a wet cell after the exact projection,
/// relative to max|u|/Δx: the CG tolerance (1e-6 of the right-hand side's
/// 2-norm) plus the rounding of the faces to f32 (measured ≤ 1.03e-6 at 64³).
const DIV_BOUND: f64 = 3e-6;

fn exact(rule: BoundaryRule, alpha: f32) -> BoundaryOptions {
    BoundaryOptions {
        method: ObstacleMethod::Exact,
        rule,
        alpha,
        passes: 1,
    }
}

fn random_velocity(d: Domain, seed: u64) -> FaceGrid {
    use rand::{Rng, SeedableRng};
    let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
    let mut v = FaceGrid::zeros(d, BoxKind::Periodic);
    for a in 0..3 {
        for x in v.slice_mut(a) {
            *x = rng.random_range(-1.0..1.0);
        }
    }
    v
}

/// With no obstacle cell the conjugate gradients, preconditioned by the
/// fast solver, are the fast solver: one iteration, the same faces to 1e-6.
#[test]
fn without_obstacles_the_solve_is_the_fast_one() {
    let d = Domain::cube(24, 3.0).unwrap();
    // A sphere at a cell corner, smaller than the gap to the nearest cell
    // centre: no cell inside.
    let nothing: Obstacle = Arc::new(Sphere {
        center: Vec3::splat(1.0),
        radius: 0.01,
    });
    let b = Boundary::new(d, &nothing, exact(BoundaryRule::Reflect, 1.0)).unwrap();
    assert!(b.open_faces().wet().iter().all(|&w| w));
    let u0 = random_velocity(d, 3);
    let (mut fast_u, mut cg_u) = (u0.clone(), u0.clone());
    let mut fast = PressureSolver::new(d, BoxKind::Periodic);
    fast.project(&mut fast_u);
    let mut cg = ObstacleProjection::new(b.open_faces(), TOLERANCE);
    let report = cg.project(&mut cg_u, b.open_faces(), &mut fast);
    assert_eq!(report.iterations, 1, "{report:?}");
    assert!(report.residual < 1e-12, "{report:?}");
    let diff = max_face_diff(&fast_u, &cg_u);
    assert!(diff <= 1e-6 * u0.max_norm(), "faces differ by {diff}");
}

/// What a slab-box run showed.
struct SlabRun {
    /// Gas in the fluid cells over gas injected, after the last step.
    retained: f64,
    /// Lowest and highest `retained` over every 25th step.
    retained_range: (f64, f64),
    /// Most CG iterations in a step.
    iterations: usize,
    /// Largest speed through a closed face.
    flux: f32,
    /// Largest flux divergence of a wet cell, relative to max|u|/Δx.
    div: f32,
}

/// Semi-Lagrangian velocity traced at second order, slab-box's default.
const SL: (Scheme, Backtrace) = (Scheme::Sl, Backtrace::Rk2);

/// slab-box at `res` with the default source for `steps` steps, its
/// semi-Lagrangian steps traced by `backtrace`.
fn slab_box(
    res: usize,
    steps: usize,
    (advection, backtrace): (Scheme, Backtrace),
    method: ObstacleMethod,
    density: DensityMode,
) -> SlabRun {
    let config = SlabBoxConfig {
        solver: SolverConfig {
            res,
            frames: steps,
            advection,
            backtrace,
            density,
            ..SlabBoxConfig::default_solver()
        },
        obstacles: method,
        ..Default::default()
    };
    let mut sim = config.build().unwrap();
    let rate = |sim: &Simulation| {
        // ∫S dV per unit time as the representation injects it (gridded: at
        // the cell centres; gridless and SELMA: the field, supersampled).
        let gas = &sim.gases[0];
        match density {
            DensityMode::Gridded => gas.injected_per_step(1.0),
            _ => probe::integral(&*gas.source_field, sim.domain(), 4),
        }
    };
    let rate = rate(&sim);
    let mut run = SlabRun {
        retained: 0.0,
        retained_range: (f64::INFINITY, 0.0),
        iterations: 0,
        flux: 0.0,
        div: 0.0,
    };
    for step in 1..=steps {
        // The step evaluates gridless and SELMA densities at the cell
        // centres after advecting them (the buoyancy's input): they are
        // current.
        sim.try_step().unwrap();
        let b = sim.boundary.as_ref().unwrap();
        let leak = b.leak(&sim.velocity, &[sim.gases[0].density()]);
        run.iterations = run
            .iterations
            .max(sim.cg_report().map_or(0, |r| r.iterations));
        run.flux = run.flux.max(leak.closed_flux_max);
        let scale = sim.velocity.max_norm() / sim.domain().cell;
        run.div = run.div.max(leak.div_fluid.max / scale);
        run.retained = leak.mass_fluid / (rate * config.solver.dt as f64 * step as f64);
        if step % 25 == 0 {
            let (lo, hi) = run.retained_range;
            run.retained_range = (lo.min(run.retained), hi.max(run.retained));
        }
    }
    run
}

/// The exact method at 32³ over the 200 frames of fig 6.6: nothing flows
/// through a closed face, the flux divergence of every wet cell is at the
/// solver tolerance and the f32 rounding of the faces ([`DIV_BOUND`] of
/// max|u|/Δx; the notes' method leaves ~0.3), and the gas stays in the fluid
/// — semi-Lagrangian within 95–106 % of what was injected (it gains a
/// little: the MAC interpolant is not conservative), QUICK to 1e-4. The
/// notes' method keeps less than 85 % in the fluid (the rest is carried
/// into the walls and the slab): the switch means something.
#[test]
fn slab_box_keeps_its_gas_with_exact_obstacles() {
    use DensityMode::Gridded;
    let sl = slab_box(32, 200, SL, ObstacleMethod::Exact, Gridded);
    let (r, it, flux, div) = (sl.retained, sl.iterations, sl.flux, sl.div);
    println!("SL exact: retained {r:.4}, CG ≤ {it}, flux {flux:e}, div {div:e}");
    assert_eq!(flux, 0.0, "flow through a closed face");
    assert!(
        div as f64 <= DIV_BOUND,
        "flux divergence {div:e} of max|u|/Δx"
    );
    assert!(it <= 30, "{it} CG iterations");
    // Issue 15 asks ≥ 95 %; semi-Lagrangian resampling gains a little
    // (measured 1.015 against the one budget ∫S dV·t; 1.030 when the gridded
    // source was point-sampled and its own budget).
    assert!((0.95..=1.04).contains(&r), "SL retained {r}");
    let quick = slab_box(
        32,
        200,
        (Scheme::Quick, Backtrace::Rk2),
        ObstacleMethod::Exact,
        Gridded,
    )
    .retained;
    println!("QUICK exact: retained {quick:.6}");
    assert!((quick - 1.0).abs() <= 1e-4, "QUICK retained {quick}");
    let notes = slab_box(32, 200, SL, ObstacleMethod::Notes, Gridded);
    println!(
        "SL notes: retained {:.4}, flux {:e}",
        notes.retained, notes.flux
    );
    assert!(
        notes.retained < 0.85,
        "notes' method retained {}",
        notes.retained
    );
    assert!(
        notes.flux > 0.1,
        "notes' method: closed-face speed {}",
        notes.flux
    );
}

/// SELMA density in the slab box with exact obstacles (SL velocity): its
/// map stopped at the walls, it stays within 90–106 % of the injected gas at
/// every 25th of 200 steps (93–97 % measured); without the stop it gains
/// (127 %).
#[test]
fn slab_box_selma_with_exact_obstacles() {
    let selma = slab_box(32, 200, SL, ObstacleMethod::Exact, DensityMode::Selma);
    println!(
        "SELMA: retained {:.4}, range {:?}",
        selma.retained, selma.retained_range
    );
    let (lo, hi) = selma.retained_range;
    assert!(lo >= 0.90 && hi <= 1.06, "SELMA retained {lo}–{hi}");
    assert_eq!(selma.flux, 0.0);
}

/// Gridless density in the slab box with exact obstacles (SL velocity),
/// its walks weighted by the volume factor of the backward map
/// (`GridlessField`). The gas it keeps swings as the plume reaches the slab
/// and spills round it, and where it ends depends on the trace: measured
/// at every 25th step, the second-order trace keeps 0.807–1.002 and 0.954 at
/// step 200, the third-order one 0.818–1.013 and 0.918. Every consistent
/// trace must keep ≥ 90 % at step 200 and never less than 78 % or more than
/// 116 % on the way; without the volume factor the same run keeps 0.672–1.000
/// and 0.691 at step 200 (the third-order trace is down to 0.664 by step
/// 150), and fails both lower bounds.
#[test]
fn slab_box_gridless_with_exact_obstacles() {
    for backtrace in [Backtrace::Rk2, Backtrace::Rk3] {
        let gridless = slab_box(
            32,
            200,
            (Scheme::Sl, backtrace),
            ObstacleMethod::Exact,
            DensityMode::Gridless,
        );
        println!(
            "gridless {backtrace:?}: retained {:.4}, range {:?}",
            gridless.retained, gridless.retained_range
        );
        assert!(
            gridless.retained >= 0.90,
            "gridless {backtrace:?} retained {}",
            gridless.retained
        );
        let (lo, hi) = gridless.retained_range;
        assert!(
            lo >= 0.78 && hi <= 1.16,
            "gridless {backtrace:?} retained {lo}–{hi}"
        );
        assert_eq!(gridless.flux, 0.0);
    }
}

/// Gridless density on the exact RT0 path in the slab box: its walks carry
/// no volume factor and never enter a dry cell (`advection::pollock`), so
/// the field keeps the gas it was given — its integral at 4× the grid within
/// 4 % of the injection at 80 steps — and its peak stays near the gridded
/// run's instead of beading. Measured at 32³ (QUICK velocity): the field's
/// integral 99.9 % at 4× (99.6 % at 5×), the cells' cache 91.7 % (layers
/// under the slab thinner than a cell between its sample points), the peak
/// 2.19 against the gridded 2.06; the midpoint rule on RT0 keeps 97 %.
#[test]
fn slab_box_gridless_exact_path_keeps_its_gas() {
    let steps = 80;
    let run = |density| {
        let config = SlabBoxConfig {
            solver: SolverConfig {
                res: 32,
                frames: steps,
                density,
                interpolant: Interpolant::Rt0,
                backtrace: Backtrace::Exact,
                ..SlabBoxConfig::default_solver()
            },
            obstacles: ObstacleMethod::Exact,
            ..Default::default()
        };
        let mut sim = config.build().unwrap();
        let injected = match density {
            DensityMode::Gridded => sim.gases[0].injected_per_step(1.0),
            _ => probe::integral(&*sim.gases[0].source_field, sim.domain(), 4),
        } * (config.solver.dt * steps as f32) as f64;
        for _ in 0..steps {
            sim.try_step().unwrap();
        }
        let gas = &sim.gases[0];
        let kept = probe::integral(&*gas.model.field(), sim.domain(), 4) / injected;
        (gas.density().max_abs(), kept)
    };
    let (gridded_peak, _) = run(DensityMode::Gridded);
    let (peak, kept) = run(DensityMode::Gridless);
    println!("exact RT0 path: gridless peak {peak} (gridded {gridded_peak}), kept {kept:.4}");
    assert!(
        peak <= 1.5 * gridded_peak,
        "peak {peak} against {gridded_peak}"
    );
    assert!((0.96..=1.04).contains(&kept), "kept {kept}");
}

/// The CG iterations at 64³ stay under the bound measured (README,
/// "Obstacles"): the fast preconditioner does not degrade with resolution.
#[test]
fn slab_box_iterations_stay_bounded_at_64() {
    let run = slab_box(64, 40, SL, ObstacleMethod::Exact, DensityMode::Gridded);
    let (it, flux, div) = (run.iterations, run.flux, run.div);
    println!("64³: CG ≤ {it}, flux {flux:e}, div {div:e}");
    assert!(it <= 30, "{it} CG iterations");
    assert_eq!(flux, 0.0);
    assert!(div as f64 <= DIV_BOUND, "flux divergence {div:e}");
}

/// A uniform density beside the slab and walls, under gravity: the pressure
/// balances the buoyancy exactly (hydrostatic) and the fluid stays at rest
/// to 1e-6 with the exact method; the notes' periodic projection cannot
/// balance it and the fluid moves.
#[test]
fn uniform_density_under_gravity_stays_at_rest() {
    for (method, at_rest) in [
        (ObstacleMethod::Exact, true),
        (ObstacleMethod::Notes, false),
    ] {
        let config = SlabBoxConfig {
            solver: SolverConfig {
                res: 26,
                ..SlabBoxConfig::default_solver()
            },
            obstacles: method,
            ..Default::default()
        };
        let mut sim = config.build().unwrap();
        let wet = sim.boundary.as_ref().unwrap().open_faces().wet().to_vec();
        let gas = &mut sim.gases[0];
        gas.source = smokelab::grid::ScalarGrid::zeros(*gas.source.domain());
        let rho = gas.model.gridded_mut().unwrap();
        for (r, &w) in rho.as_slice_mut().iter_mut().zip(&wet) {
            *r = if w { 1.0 } else { 0.0 };
        }
        for _ in 0..10 {
            sim.try_step().unwrap();
        }
        let speed = sim.velocity.max_norm();
        println!("{method:?}: max|u| {speed:e} after 10 steps (Δt g = 0.98)");
        if at_rest {
            assert!(speed <= 1e-6, "{method:?}: max|u| {speed}");
        } else {
            assert!(speed > 1e-2, "{method:?}: max|u| {speed}");
        }
    }
}

/// A sphere in a uniform stream, projected once: no flow through its closed
/// faces, the stream speeds up over its top as free-slip (potential) flow
/// does, and the velocity carried into the wall is the fluid's times α.
#[test]
fn sphere_in_a_stream_slips_with_reflect_and_sticks_with_alpha_zero() {
    let d = Domain::cube(32, 4.0).unwrap();
    let sphere = Sphere {
        center: Vec3::splat(2.0),
        radius: 0.8,
    };
    let obstacle: Obstacle = Arc::new(sphere);
    let top = |u: &FaceGrid| {
        // Point query half a cell above the sphere's top, and half a cell
        // inside it.
        let above = u.sample(sphere.center + Vec3::Y * (sphere.radius + 0.5 * d.cell));
        let inside = u.sample(sphere.center + Vec3::Y * (sphere.radius - 0.5 * d.cell));
        (above.x, inside.x)
    };
    let mut seen = vec![];
    for (rule, alpha) in [(BoundaryRule::Reflect, 1.0), (BoundaryRule::Sticky, 0.0)] {
        let b = Boundary::new(d, &obstacle, exact(rule, alpha)).unwrap();
        let mut u = FaceGrid::zeros(d, BoxKind::Periodic);
        u.slice_mut(0).fill(1.0);
        let mut fast = PressureSolver::new(d, BoxKind::Periodic);
        let mut cg = ObstacleProjection::new(b.open_faces(), TOLERANCE);
        let report = cg.project(&mut u, b.open_faces(), &mut fast);
        b.open_faces().extend(&mut u, b.options().retained());
        let leak = b.leak(&u, &[]);
        let (above, inside) = top(&u);
        println!("{rule:?} α {alpha}: {report:?}, above {above:.3}, inside {inside:.3}");
        assert!(report.residual <= TOLERANCE, "{report:?}");
        assert_eq!(leak.closed_flux_max, 0.0);
        assert!(leak.div_fluid.max <= 1e-5, "{:?}", leak.div_fluid);
        seen.push((above, inside));
    }
    let ((above, slip), (_, stuck)) = (seen[0], seen[1]);
    // Potential flow past a sphere reaches 1.4 U half a cell above its top;
    // a staircase sphere of 13 cells across reaches 1.21 U there.
    assert!(above > 1.1, "top speed {above}");
    // Free slip: half a cell inside the wall the flow moves with the fluid
    // beside it; α = 0: the faces inside hold zero, so the point query
    // there is a fraction of the speed above (0.40 measured).
    assert!(
        slip > 0.9 * above,
        "reflect: {slip} inside vs {above} above"
    );
    assert!(
        stuck < 0.6 * above,
        "sticky α = 0: {stuck} inside vs {above} above"
    );
}
