//! Density modes (§6.2, ch. 7, ch. 8): gridless is the exact composition of
//! the stored backtraces, converges to the exact flow as the velocity grid
//! refines, SELMA converges to gridless as its map refines, the modes agree
//! on mass with sources, memory behaves as designed, and the gridded path is
//! bit-identical to the foundation's step.

use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;
use std::f32::consts::TAU;
use std::sync::Arc;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use smokelab::advection::{self, departure_point, Backtrace, Departures};
use smokelab::density::probe::DensityProbe;
use smokelab::density::{DensityMode, DensityModel, DensityOptions, GridlessField, StepInput};
use smokelab::domain::Domain;
use smokelab::field::{Scalar, ScalarField, VectorField};
use smokelab::grid::{BoxKind, FaceGrid, ScalarGrid};
use smokelab::scenario::hot_cold::HotColdConfig;

mod common;
use common::assert_order;

/// The Arnold–Beltrami–Childress flow on the periodic box `[0, 2π)³`:
/// steady, smooth and exactly divergence-free.
struct Abc;

impl Abc {
    fn at(p: Vec3) -> Vec3 {
        let (a, b, c) = (1.0, 0.8, 0.6);
        Vec3::new(
            a * p.z.sin() + c * p.y.cos(),
            b * p.x.sin() + a * p.z.cos(),
            c * p.y.sin() + b * p.x.cos(),
        )
    }
}

impl VectorField for Abc {
    fn eval(&self, p: Vec3) -> Vec3 {
        Self::at(p)
    }
}

/// A smooth blob, the initial density: `exp(−|x − c|²/2σ²)`, negligible at
/// the box's faces.
struct Blob;

impl ScalarField for Blob {
    fn eval(&self, p: Vec3) -> f32 {
        let c = Vec3::new(2.8, 3.3, 3.0);
        (-(p - c).length_squared() / (2.0 * 0.8f32.powi(2))).exp()
    }
}

fn abc_grid(res: usize) -> Arc<FaceGrid> {
    Arc::new(FaceGrid::from_field(
        Domain::cube(res, TAU).unwrap(),
        BoxKind::Periodic,
        &Abc,
    ))
}

/// A point wrapped into the periodic box `[0, 2π)³`.
fn wrap(p: Vec3) -> Vec3 {
    p.rem_euclid(Vec3::splat(TAU))
}

/// Seeded random points inside the box.
fn points(n: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|_| Vec3::new(rng.random(), rng.random(), rng.random()) * TAU)
        .collect()
}

/// Step a density model `steps` times with the steady velocity `u`.
fn run_model(model: &mut DensityModel, u: &Arc<FaceGrid>, steps: usize, dt: f32) {
    let mut dep = Departures::new(*u.domain());
    dep.trace(u, dt, Backtrace::Rk2);
    let source = ScalarGrid::zeros(*u.domain());
    let input = StepInput {
        velocity: u,
        snapshot: Some(u),
        dt,
        backtrace: Backtrace::Rk2,
    };
    for _ in 0..steps {
        // A gridded density is advected by its simulation's advector first.
        if let Some((rho, target)) = model.advection_pair() {
            advection::interpolate_scalar(rho, &dep, target);
        }
        model.step(&input, &source);
    }
}

fn eval(f: &dyn ScalarField, pts: &[Vec3]) -> Vec<f32> {
    let mut out = vec![0.0; pts.len()];
    f.eval_batch(pts, &mut out);
    out
}

#[test]
fn gridless_is_the_initial_density_at_the_composed_backtrace() {
    let u = abc_grid(16);
    let d = *u.domain();
    let (steps, dt) = (8, 0.3);
    let pts = points(2000, 1);
    for bt in Backtrace::ALL {
        let mut g = GridlessField::new(d, Some(Arc::new(Blob)), None);
        for _ in 0..steps {
            g.push(u.clone(), dt, bt);
        }
        let got = eval(&g, &pts);
        let mut worst = 0.0f32;
        for (p, v) in pts.iter().zip(&got) {
            let mut x = d.grid_coords(*p);
            for _ in 0..steps {
                x = departure_point(&u, x, dt / d.cell, bt);
            }
            // Periodic box: ρ₀ at the wrapped point (gridless wraps every
            // step, this wraps once — the same point up to round-off).
            let expect = Blob.eval(wrap(d.world_of(x)));
            worst = worst.max((v - expect).abs());
        }
        println!("{bt:?}: max |gridless − ρ₀(composed backtrace)| = {worst:.2e}");
        assert!(worst <= 2e-6, "{bt:?}: differs by {worst}");
    }
}

/// `ρ₀` at the exact flow's backward map over time `t`: classical RK4 with
/// a tiny step on the analytic velocity.
fn exact_backward(p: Vec3, t: f32) -> Vec3 {
    let n = 400;
    let h = -t / n as f32;
    let mut x = p;
    for _ in 0..n {
        let k1 = Abc::at(x);
        let k2 = Abc::at(x + 0.5 * h * k1);
        let k3 = Abc::at(x + 0.5 * h * k2);
        let k4 = Abc::at(x + h * k3);
        x += h / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4);
    }
    x
}

/// The RK2 backtrace with the analytic velocity: the gridless scheme without
/// the velocity grid.
fn analytic_rk2_backward(p: Vec3, dt: f32, steps: usize) -> Vec3 {
    let mut x = p;
    for _ in 0..steps {
        x -= dt * Abc::at(x - 0.5 * dt * Abc::at(x));
    }
    x
}

#[test]
fn gridless_converges_to_the_exact_flow_as_the_velocity_grid_refines() {
    // Only the velocity is discretised: the errors below are the velocity
    // grid's interpolation error (against the same RK2 on the analytic
    // velocity), and that plus RK2's time error (against the exact flow).
    let (steps, dt) = (10, 0.1);
    let pts = points(4000, 2);
    let same_scheme: Vec<f32> = pts
        .iter()
        .map(|&p| Blob.eval(wrap(analytic_rk2_backward(p, dt, steps))))
        .collect();
    let exact: Vec<f32> = pts
        .iter()
        .map(|&p| Blob.eval(wrap(exact_backward(p, steps as f32 * dt))))
        .collect();
    let rms = |a: &[f32], b: &[f32]| {
        (a.iter()
            .zip(b)
            .map(|(x, y)| ((x - y) as f64).powi(2))
            .sum::<f64>()
            / a.len() as f64)
            .sqrt()
    };
    let (mut h, mut interp, mut total) = (vec![], vec![], vec![]);
    for res in [16, 32, 64] {
        let u = abc_grid(res);
        let mut g = GridlessField::new(*u.domain(), Some(Arc::new(Blob)), None);
        for _ in 0..steps {
            g.push(u.clone(), dt, Backtrace::Rk2);
        }
        let got = eval(&g, &pts);
        h.push(u.domain().cell as f64);
        interp.push(rms(&got, &same_scheme));
        total.push(rms(&got, &exact));
    }
    println!("time error of RK2 alone: {:.3e}", rms(&same_scheme, &exact));
    println!("gridless vs exact flow: {total:?}");
    assert_order(
        "gridless vs RK2 on the analytic velocity",
        &h,
        &interp,
        2.0,
        0.4,
    );
    assert!(
        total[0] > total[1] && total[1] > total[2],
        "error against the exact flow does not shrink: {total:?}"
    );
}

#[test]
fn selma_converges_to_gridless_as_the_map_refines() {
    let u = abc_grid(16);
    let d = *u.domain();
    let (steps, dt) = (8, 0.2);
    let pts = points(8000, 3);
    let mut gridless = DensityModel::new(
        &DensityOptions::mode(DensityMode::Gridless),
        d,
        Some(Arc::new(Blob)),
        None,
    );
    run_model(&mut gridless, &u, steps, dt);
    let reference = eval(&*gridless.field(), &pts);
    // Pure SELMA (never re-anchored: ρ₀ composed with the map), and SELMA
    // re-anchored when its lattice deforms by 0.3 map cells (the resampled
    // density carried on the map grid).
    for remap in [0.0, 0.3] {
        let (mut h, mut err, mut restarts) = (vec![], vec![], vec![]);
        for map_res in [16, 32, 64] {
            let opts = DensityOptions {
                map_res: Some(map_res),
                selma_remap: remap,
                ..DensityOptions::mode(DensityMode::Selma)
            };
            let mut selma = DensityModel::new(&opts, d, Some(Arc::new(Blob)), None);
            run_model(&mut selma, &u, steps, dt);
            if let DensityModel::Selma(s) = &selma {
                restarts.push(s.restarts());
            }
            let got = eval(&*selma.field(), &pts);
            let l1 = got
                .iter()
                .zip(&reference)
                .map(|(a, b)| (a - b).abs() as f64)
                .sum::<f64>()
                / pts.len() as f64;
            h.push(TAU as f64 / map_res as f64);
            err.push(l1);
        }
        assert_order(
            &format!("SELMA (remap {remap}, re-anchorings {restarts:?}) vs gridless, mean |Δρ| by map cell"),
            &h,
            &err,
            2.0,
            0.4,
        );
        if remap > 0.0 {
            assert!(
                restarts.iter().all(|&r| r > 0),
                "no re-anchoring: {restarts:?}"
            );
        } else {
            assert!(restarts.iter().all(|&r| r == 0), "{restarts:?}");
        }
    }
}

/// Hot mass of a hot/cold run at 32³ after 30 steps, fine-sampled.
fn hot_mass(mode: DensityMode) -> f64 {
    let config = HotColdConfig {
        solver: SolverConfig {
            res: 32,
            frames: 30,
            density: mode,
            ..SolverConfig::default()
        },
        ..Default::default()
    };
    let mut sim = config.build().unwrap();
    for _ in 0..config.solver.frames {
        sim.step();
    }
    DensityProbe::new(*sim.domain())
        .measure(&sim.gases[0].model)
        .mass
}

#[test]
fn with_sources_selma_and_gridless_agree_on_mass_and_gridless_keeps_more_than_gridded() {
    let [gridded, gridless, selma] = DensityMode::ALL.map(hot_mass);
    println!("hot mass after 30 steps at 32³: gridded {gridded:.4}, gridless {gridless:.4}, selma {selma:.4}");
    let rel = (selma - gridless).abs() / gridless;
    assert!(
        rel <= 0.02,
        "SELMA and gridless hot mass differ by {rel:.4}"
    );
    assert!(
        gridless >= gridded,
        "gridless keeps {gridless}, gridded {gridded}"
    );
}

#[test]
fn gridless_memory_grows_by_one_velocity_grid_per_step_and_selma_memory_is_constant() {
    let config = |density| HotColdConfig {
        solver: SolverConfig {
            res: 16,
            frames: 40,
            density,
            ..SolverConfig::default()
        },
        ..Default::default()
    };
    let mut gridless = config(DensityMode::Gridless).build().unwrap();
    let mut selma = config(DensityMode::Selma).build().unwrap();
    let velocity_bytes = 3 * 4 * gridless.domain().len();
    // Before any step a gridless gas holds only its cell-centre cache.
    let cache = gridless.gases[0].model.bytes();
    assert_eq!(cache, velocity_bytes / 3);
    let mut selma_at_10 = 0;
    for n in 1..=40 {
        gridless.step();
        selma.step();
        let held = gridless.gases[0].model.bytes() - cache;
        let expect = n * velocity_bytes;
        assert!(
            held.abs_diff(expect) * 10 <= velocity_bytes,
            "gridless after {n} steps holds {held} B besides its cache, expected {expect} B ± 10% of one velocity grid"
        );
        // Both gases share the velocity grids: the total grows by exactly one per step.
        assert_eq!(gridless.density_bytes(), expect + 2 * cache);
        if n == 10 {
            selma_at_10 = selma.density_bytes();
        }
        if n >= 10 {
            let b = selma.density_bytes();
            assert!(
                b.abs_diff(selma_at_10) * 20 <= selma_at_10,
                "SELMA bytes {b} at step {n}, {selma_at_10} at step 10"
            );
        }
    }
}

#[test]
fn every_mode_runs_and_its_field_snapshot_matches_its_cell_centres() {
    for mode in DensityMode::ALL {
        let mut sim = common::hot_cold_after(16, 12, mode);
        let d = *sim.domain();
        for gas in &sim.gases {
            let snapshot = gas.model.field();
            let mut sampled = ScalarGrid::zeros(d);
            sampled.write_field(&*snapshot);
            assert_eq!(sampled.as_slice(), gas.density().as_slice(), "{mode}");
            assert!(gas.density().total() > 0.0, "{mode}: no {} gas", gas.name);
        }
        // A snapshot does not change when the simulation steps on.
        let before: Scalar = sim.gases[0].model.field();
        let p = [Vec3::new(5.0, 3.0, 5.0)];
        let v0 = eval(&*before, &p);
        sim.step();
        assert_eq!(eval(&*before, &p), v0, "{mode}: snapshot changed");
    }
}
