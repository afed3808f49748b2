//! Density modes (§6.2, ch. 7, ch. 8): gridless is the exact composition of
//! the stored backtraces, converges to the exact flow as the velocity grid
//! refines, SELMA converges to gridless as its map refines, the mass each
//! mode keeps of what it injected (per scheme and time), memory measured by
//! the allocator beside the reported bytes, and every mode's field snapshot
//! matches its cell centres and outlives later steps.

use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;
use std::f32::consts::TAU;
use std::sync::Arc;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use smokelab::advection::{self, departure_point, Backtrace, Departures, Scheme};
use smokelab::boundary::WallStop;
use smokelab::density::gridless::REFINE_LEVEL;
use smokelab::density::probe::{integral, DensityMeasures, DensityProbe};
use smokelab::density::{
    CellSamples, DensityMode, DensityModel, DensityOptions, GridlessField, StepInput,
};
use smokelab::domain::Domain;
use smokelab::field::{Scalar, ScalarField, VectorField};
use smokelab::grid::{BoxKind, FaceGrid, ScalarGrid};
use smokelab::scenario::hot_cold::HotColdConfig;

mod common;
use common::on_every_isa;
use common::order::assert_order;
use smokelab::simd::Isa;

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

/// A batch walks the points a vector at a time through the kernel of every
/// width the CPU has (sixteen lanes AVX-512, eight AVX2, four NEON, one
/// scalar; for Euler and RK2) and a lone point through the scalar
/// backtrace; the densities must agree to the bit, for points inside the box
/// and near its faces (whose stencils the kernels wrap or clamp), in a
/// periodic and a closed box.
#[test]
fn batched_gridless_walk_is_the_single_point_walk_to_the_bit() {
    on_every_isa(|isa| {
        for kind in [BoxKind::Periodic, BoxKind::Closed] {
            let u = Arc::new(FaceGrid::from_field(
                Domain::cube(16, TAU).unwrap(),
                kind,
                &Abc,
            ));
            batched_walk_is_the_single_point_walk(&u, isa);
        }
    });
}

fn batched_walk_is_the_single_point_walk(u: &Arc<FaceGrid>, isa: Isa) {
    let d = *u.domain();
    let pts = points(4000, 7);
    for bt in Backtrace::ALL {
        let mut g = GridlessField::new(d, Some(Arc::new(Blob)), None);
        for _ in 0..6 {
            g.push(u.clone(), 0.3, bt);
        }
        let batch = eval(&g, &pts);
        let differ = pts
            .iter()
            .zip(&batch)
            .filter(|&(&p, v)| g.eval(p).to_bits() != v.to_bits())
            .count();
        let kind = u.kind();
        assert_eq!(
            differ,
            0,
            "{isa} {kind} {bt:?}: {differ} of {} points differ",
            pts.len()
        );
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

/// Mass of the hot gas over the mass its own representation injected, for
/// gridded, gridless and SELMA, after each of `checkpoints` steps of a
/// hot/cold run at `res`³ with `advection`.
///
/// Each mode is divided by what it adds: gridded adds the grid `Gas::source`
/// (`Gas::injected_per_step`, `Σ S Δx³ Δt`; point-sampled at the cell
/// centres, the solid unit sphere has 47 % of its volume at 16³, 98 % at
/// 24³ — the reason total masses of the modes cannot be compared), gridless
/// and SELMA add `∫ S dV Δt` (4× midpoint quadrature). Gridded mass is its
/// grid total, gridless and SELMA are integrated at 4× — the 2× probe
/// over-counts the solid sources' edges by 2–3 %. So a change of the
/// gridded injection (e.g. to the cell average of `S`) moves numerator and
/// denominator together.
fn mass_over_injected(res: usize, advection: Scheme, checkpoints: &[usize]) -> Vec<[f64; 3]> {
    let mut out = vec![[0.0; 3]; checkpoints.len()];
    for (m, mode) in DensityMode::ALL.into_iter().enumerate() {
        let config = HotColdConfig {
            solver: SolverConfig {
                res,
                frames: *checkpoints.last().unwrap(),
                advection,
                density: mode,
                ..SolverConfig::default()
            },
            ..HotColdConfig::head_on()
        };
        let dt = config.solver.dt;
        let mut sim = config.build().unwrap();
        let d = *sim.domain();
        let hot = &sim.gases[0];
        let per_step = match mode {
            DensityMode::Gridded => hot.injected_per_step(dt),
            _ => integral(&*hot.source_field, &d, 4) * dt as f64,
        };
        let mut done = 0;
        for (c, &n) in checkpoints.iter().enumerate() {
            for _ in done..n {
                sim.step();
            }
            done = n;
            let model = &sim.gases[0].model;
            let mass = match mode {
                DensityMode::Gridded => model.density().total(),
                _ => integral(&*model.field(), &d, 4),
            };
            out[c][m] = mass / (per_step * n as f64);
        }
    }
    out
}

/// Which mode keeps more of what it injected depends on the advection
/// scheme and the time, so this states the measured relation per case
/// (hot/cold head-on, Δt 0.05, mass over own injection at t = 1 and t = 2):
///
/// | case | gridded | gridless | SELMA |
/// |---|---|---|---|
/// | 16³ SL    | 0.9792 / 0.8905 | 0.9969 / 1.0187 | 1.0099 / 1.0122 |
/// | 16³ QUICK | 1.0000 / 1.0000 | 0.9969 / 1.0176 | 1.0099 / 1.0136 |
/// | 24³ SL    | 0.9875 / 0.9370 | 1.0141 / 1.0175 | 1.0345 / 1.0204 |
///
/// (At 32³ SL, not run here for time: gridded 0.9919 / 0.9656, gridless
/// 1.0062 / 1.0063, SELMA 0.9930 / 0.9936.)
///
/// - Gridless keeps its injection to within 2 % (not exactly: the stored
///   backtraces of a discretely divergence-free velocity are not volume
///   preserving), SELMA within 3.5 %, and the two agree within 2 %.
/// - Gridded with QUICK conserves (flux form): it keeps exactly what it adds.
/// - Gridded with SL loses mass, more as time goes on and less on finer
///   grids (11 % at 16³, 6.3 % at 24³ by t = 2). With the source injected
///   as its cell average instead of point-sampled (measured by replacing
///   `Gas::source` in a scratch run) it loses less: 0.9926 / 0.9543 at 16³,
///   0.9934 / 0.9594 at 24³ — the asserted relations hold for both.
/// - So "gridless keeps more mass than gridded" holds against SL gridded at
///   t = 2 (by 13 and 8 points; 6 and 6 with cell-average injection). At
///   t = 1 it depends on the injection (16³: gridless 0.9969 against
///   0.9792 point-sampled, 0.9926 cell-averaged) and is not asserted. It
///   does not hold against QUICK gridded, which keeps all it adds: there
///   gridless is 0.3 % below at t = 1 and 1.8 % above at t = 2, within its
///   own error.
#[test]
fn mass_kept_over_own_injection_per_mode_and_scheme() {
    let checkpoints = [20, 40];
    // SL gridded's share kept at t = 2, per resolution.
    let mut sl_kept = vec![];
    for (res, advection) in [(16, Scheme::Sl), (16, Scheme::Quick), (24, Scheme::Sl)] {
        let r = mass_over_injected(res, advection, &checkpoints);
        for (&n, [gridded, gridless, selma]) in checkpoints.iter().zip(&r) {
            let case = format!("{res}³ {advection:?}, step {n}");
            println!("{case}: mass / own injection: gridded {gridded:.5}, gridless {gridless:.5}, selma {selma:.5}");
            assert!(
                (gridless - 1.0).abs() <= 0.03,
                "{case}: gridless {gridless}"
            );
            assert!((selma - 1.0).abs() <= 0.05, "{case}: selma {selma}");
            assert!(
                (selma - gridless).abs() <= 0.03,
                "{case}: SELMA {selma} and gridless {gridless} disagree"
            );
            if advection == Scheme::Quick {
                assert!(
                    (gridded - 1.0).abs() <= 1e-4,
                    "{case}: QUICK gridded {gridded}"
                );
            } else {
                assert!(*gridded < 1.0, "{case}: SL gridded gained ({gridded})");
            }
        }
        if advection == Scheme::Sl {
            let ([g1, ..], [g2, gl2, _]) = (r[0], r[1]);
            // The loss grows with time, and by t = 2 gridless keeps more.
            assert!(g2 < g1 - 0.02, "{res}³: SL gridded {g1} → {g2}");
            assert!(gl2 > g2 + 0.04, "{res}³: gridless {gl2} vs SL gridded {g2}");
            sl_kept.push((res, g2));
        }
    }
    // SL's loss is a discretisation error (the trilinear interpolation's
    // smoothing of the injected blobs), so it shrinks as the grid refines:
    // the finer grid keeps more of what it injected.
    let [(coarse, g_coarse), (fine, g_fine)] = sl_kept[..] else {
        panic!("two SL resolutions: {sl_kept:?}")
    };
    assert!(
        1.0 - g_fine < 1.0 - g_coarse,
        "SL gridded loses {:.4} at {fine}³, not less than {:.4} at {coarse}³",
        1.0 - g_fine,
        1.0 - g_coarse
    );
}

/// Bytes allocated minus bytes freed by the current thread, counted by the
/// test binary's allocator: the memory a thread's own work holds, measured
/// independently of [`DensityModel::buffers`].
mod allocated {
    use std::alloc::{GlobalAlloc, Layout, System};
    use std::cell::Cell;

    thread_local! {
        static NET: Cell<i64> = const { Cell::new(0) };
    }

    fn add(bytes: i64) {
        // During thread teardown the counter may be gone; nothing to count then.
        let _ = NET.try_with(|c| c.set(c.get() + bytes));
    }

    /// The current thread's net allocated bytes.
    pub fn net() -> i64 {
        NET.with(Cell::get)
    }

    pub struct Counting;

    // SAFETY: every call is forwarded to `System` unchanged; only sizes are counted.
    unsafe impl GlobalAlloc for Counting {
        unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
            let p = unsafe { System.alloc(layout) };
            if !p.is_null() {
                add(layout.size() as i64);
            }
            p
        }

        unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
            let p = unsafe { System.alloc_zeroed(layout) };
            if !p.is_null() {
                add(layout.size() as i64);
            }
            p
        }

        unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
            unsafe { System.dealloc(ptr, layout) };
            add(-(layout.size() as i64));
        }

        unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
            let p = unsafe { System.realloc(ptr, layout, new_size) };
            if !p.is_null() {
                add(new_size as i64 - layout.size() as i64);
            }
            p
        }
    }
}

#[global_allocator]
static ALLOCATOR: allocated::Counting = allocated::Counting;

/// The stored velocity grids of a gridless gas.
fn stored(model: &DensityModel) -> Vec<Arc<FaceGrid>> {
    match model {
        DensityModel::Gridless(g) => g.field().velocities().cloned().collect(),
        _ => panic!("not gridless"),
    }
}

/// Memory is checked three ways. (1) The reported bytes
/// ([`DensityModel::bytes`], summed from the buffers the models hold).
/// (2) The allocator: the velocity snapshot is cloned on the stepping thread
/// ([`smokelab::simulation::Simulation::advect`]), so the bytes this thread
/// allocates and does not free over a step are what the step keeps; the
/// parallel work runs on rayon's threads and is not counted. (3) For
/// gridless, what is kept: distinct allocations shared by the two gases, each a copy of that step's velocity, and freed when
/// the simulation is dropped.
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
    let (mut grown, mut selma_grown) = (vec![], vec![]);
    let mut selma_at_10 = 0;
    for n in 1..=40 {
        let before = gridless.velocity.clone();
        let net = allocated::net();
        gridless.step();
        grown.push(allocated::net() - net);
        let net = allocated::net();
        selma.step();
        if n > 10 {
            selma_grown.push(allocated::net() - net);
        }
        // (1) Reported.
        let held = gridless.gases[0].model.bytes() - cache;
        assert_eq!(
            held,
            n * velocity_bytes,
            "gridless reports {held} B after {n} steps"
        );
        assert_eq!(gridless.density_bytes(), n * velocity_bytes + 2 * cache);
        if n == 10 {
            selma_at_10 = selma.density_bytes();
        }
        if n >= 10 {
            let b = selma.density_bytes();
            assert!(
                b.abs_diff(selma_at_10) * 20 <= selma_at_10,
                "SELMA reports {b} B at step {n}, {} B at step 10",
                selma_at_10
            );
        }
        // (3) Kept: one new distinct grid per step, shared by both gases,
        // holding the velocity the step advected with.
        let (hot, cold) = (
            stored(&gridless.gases[0].model),
            stored(&gridless.gases[1].model),
        );
        assert_eq!(hot.len(), n);
        assert!(hot.iter().zip(&cold).all(|(a, b)| Arc::ptr_eq(a, b)));
        // Four owners: the two gases and the clones in `hot` and `cold`.
        assert!(hot.iter().all(|a| Arc::strong_count(a) == 4));
        let last = hot.last().unwrap();
        assert_eq!(common::max_face_diff(last, &before), 0.0);
        assert_ne!(last.slice(0).as_ptr(), gridless.velocity.slice(0).as_ptr());
        let mut addrs: Vec<_> = hot.iter().map(|a| a.slice(0).as_ptr()).collect();
        addrs.sort_unstable();
        addrs.dedup();
        assert_eq!(addrs.len(), n, "stored grids alias each other");
    }
    // (2) Measured by the allocator. Gridless keeps 49 528 B per step at
    // 16³ (the 49 152 B grid, the Arc and the step record), and on some
    // steps 1 520 B more that SELMA's steps show too: a block of rayon's
    // job injector (63 slots of 24 B and a link), allocated by this thread
    // and freed by a worker. SELMA keeps those blocks only: 15 200 and
    // 21 280 B over its last 30 steps in two runs, under half a velocity
    // grid, where gridless keeps 30 grids. The cell average's refinement
    // lists (`gridless::refined_cells`) are built by rayon's workers and
    // freed by this thread, which counts them as up to 2 256 B freed: kept
    // per step measured 47 272–49 816 B.
    println!("gridless: bytes kept per step {grown:?} (one velocity grid: {velocity_bytes} B)");
    println!("SELMA: bytes kept per step after step 10 {selma_grown:?}");
    let v = velocity_bytes as i64;
    for (n, &g) in grown.iter().enumerate() {
        assert!(
            (v - 4096..=v + 4096).contains(&g),
            "gridless step {} kept {g} B; one velocity grid is {v} B",
            n + 1
        );
    }
    let selma_total: i64 = selma_grown.iter().sum();
    assert!(
        selma_grown.iter().all(|&g| g.abs() <= 4096) && selma_total.abs() <= 2 * v,
        "SELMA kept {selma_grown:?} B over steps 11..=40"
    );
    let weak: Vec<_> = stored(&gridless.gases[0].model)
        .iter()
        .map(Arc::downgrade)
        .collect();
    drop(gridless);
    assert!(
        weak.iter().all(|w| w.upgrade().is_none()),
        "stored velocity grids outlive the simulation"
    );
}

#[test]
fn every_mode_runs_and_its_field_snapshot_matches_its_cell_centres() {
    for mode in DensityMode::ALL {
        let mut sim = common::hot_cold_after(16, 12, mode);
        let d = *sim.domain();
        for gas in &sim.gases {
            let snapshot = gas.model.field();
            // Gridded: the grid's interpolant, at the centres; SELMA: the
            // field at the centres (its default); gridless: its own walks,
            // adaptively averaged.
            let sampled = match mode {
                DensityMode::Gridded | DensityMode::Selma => eval(&*snapshot, &centres(&d)),
                DensityMode::Gridless => {
                    assert_own_walk(&[(&gas.model, None)], "hot/cold");
                    continue;
                }
            };
            assert_eq!(sampled, gas.density().as_slice(), "{mode}");
            // Guard: equal all-zero grids would make the comparison above vacuous.
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

/// Every cell centre of `d`, `[z][y][x]`.
fn centres(d: &Domain) -> Vec<Vec3> {
    let mut all = Vec::with_capacity(d.len());
    let mut slab = Vec::new();
    for k in 0..d.dims[2] {
        d.slab_centers(k, &mut slab);
        all.extend_from_slice(&slab);
    }
    all
}

/// The cell averages of `f` on the cells of `d` as the cache of a gridless
/// or SELMA density holds them: the mean of its eight sub-cell points
/// (offsets ±¼ cell, summed in the offsets' order, x fastest), and zero in
/// the dry cells of `walls` ([`WallStop::dry_world`]).
fn cell_means(f: &dyn ScalarField, d: &Domain, walls: Option<&WallStop>) -> Vec<f32> {
    let subs: Vec<Vec3> = (0..8)
        .map(|s: u32| {
            let bit = |b: u32| ((s >> b) & 1) as f32 - 0.5;
            Vec3::new(bit(0), bit(1), bit(2)) * 0.5 * d.cell
        })
        .collect();
    let c = centres(d);
    let points: Vec<Vec3> = subs
        .iter()
        .flat_map(|&o| c.iter().map(move |&p| p + o))
        .collect();
    let values = eval(f, &points);
    (0..c.len())
        .map(|m| match walls {
            Some(w) if w.dry_world(c[m]) => 0.0,
            _ => (0..8).map(|s| values[s * c.len() + m]).sum::<f32>() * 0.125,
        })
        .collect()
}

/// Each gridless model's cells are, to the bit, its own field's walks
/// ([`GridlessField`]'s `eval_batch`): the walk from the centre (zero in the
/// dry cells of `walls`), or, in the cells whose 3×3×3 block of centre values spans more
/// than `REFINE_LEVEL` of their maximum, the mean of the walks from the
/// sub-cell points ([`cell_means`]) — and some cells are such.
fn assert_own_walk(models: &[(&DensityModel, Option<&WallStop>)], case: &str) {
    for (n, &(model, walls)) in models.iter().enumerate() {
        let DensityModel::Gridless(g) = model else {
            panic!("{case}: not gridless")
        };
        let d = *g.density().domain();
        let c = centres(&d);
        let at_centres = eval(g.field(), &c);
        let means = cell_means(g.field(), &d, walls);
        // The gas's own centre values choose its averaged cells.
        let level = REFINE_LEVEL * at_centres.iter().copied().fold(0.0, f32::max);
        let refined: Vec<bool> = (0..d.len())
            .map(|m| {
                let [nx, ny] = [d.dims[0], d.dims[1]];
                let block = d.block([m % nx, (m / nx) % ny, m / (nx * ny)]);
                let v: Vec<f32> = block.map(|b| at_centres[b]).collect();
                let (lo, hi) = v
                    .iter()
                    .fold((f32::MAX, f32::MIN), |(l, h), &x| (l.min(x), h.max(x)));
                hi - lo > level
            })
            .collect();
        assert!(refined.contains(&true), "{case}: gas {n}: no cell averaged");
        let own: Vec<f32> = (0..d.len())
            .map(|m| if refined[m] { means[m] } else { at_centres[m] })
            .collect();
        let shared = g.density().as_slice();
        let differ = own
            .iter()
            .zip(shared)
            .filter(|(a, b)| a.to_bits() != b.to_bits());
        assert_eq!(
            differ.count(),
            0,
            "{case}: gas {n} differs from its own walk"
        );
        // Guard: all-zero caches would make the comparison vacuous.
        assert!(g.density().total() > 0.0, "{case}: gas {n} is empty");
    }
}

/// One walk for all gridless gases ([`DensityModel::evaluate_all`], what
/// [`smokelab::simulation::Simulation::evaluate_densities`] calls) gives
/// each gas the bits of a walk of its own: the two gases of a hot/cold run
/// (different sources, one shared history), and, with obstacles (the volume
/// factor), two gases sharing walls beside a third without, which walks
/// another way ([`GridlessField::same_walk`]) and so alone.
#[test]
fn one_walk_for_all_gridless_gases_gives_each_gas_its_own_walks_bits() {
    let sim = common::hot_cold_after(16, 12, DensityMode::Gridless);
    let (hot, cold) = (&sim.gases[0].model, &sim.gases[1].model);
    assert!(
        hot.density().as_slice() != cold.density().as_slice(),
        "hot = cold"
    );
    assert_own_walk(&[(hot, None), (cold, None)], "hot/cold");

    let u = abc_grid(16);
    let d = *u.domain();
    let ball = smokelab::field::ops::sphere(Vec3::new(3.0, 3.0, 4.5), 0.8);
    let walls = Arc::new(WallStop::new(ScalarGrid::from_field(d, &*ball)));
    let options = DensityOptions::mode(DensityMode::Gridless);
    let blob: Scalar = Arc::new(Blob);
    let mut models = [
        DensityModel::new(
            &options,
            d,
            Some(Arc::clone(&blob)),
            Some(Arc::clone(&blob)),
        ),
        DensityModel::new(
            &options,
            d,
            Some(Arc::clone(&blob)),
            Some(Arc::clone(&blob)),
        ),
        DensityModel::new(&options, d, None, Some(blob)),
    ];
    models[0].set_walls(&walls);
    models[2].set_walls(&walls);
    for model in &mut models {
        run_model(model, &u, 8, 0.1);
    }
    DensityModel::evaluate_all(&mut models);
    let [a, b, c] = &models;
    // The same gas with and without walls: the walls are in the walk.
    assert!(
        a.density().as_slice() != b.density().as_slice(),
        "walls changed nothing"
    );
    assert_own_walk(&[(a, Some(&walls)), (b, None), (c, Some(&walls))], "walls");
}

/// The fine measures of gridless gases sampled together
/// ([`DensityProbe::measure_all`], one walk for those sharing a history)
/// are, to the bit, those of each gas sampled alone
/// ([`DensityProbe::measure`]): two gridless gases of different initial
/// densities with a gridded one between them (each result in its model's
/// place).
#[test]
fn gridless_gases_measured_together_give_each_gas_its_own_measures() {
    let u = abc_grid(16);
    let d = *u.domain();
    let blob: Scalar = Arc::new(Blob);
    let mode = |m| DensityOptions::mode(m);
    let mut models = [
        DensityModel::new(
            &mode(DensityMode::Gridless),
            d,
            Some(Arc::clone(&blob)),
            Some(Arc::clone(&blob)),
        ),
        DensityModel::new(
            &mode(DensityMode::Gridded),
            d,
            Some(Arc::clone(&blob)),
            None,
        ),
        DensityModel::new(&mode(DensityMode::Gridless), d, None, Some(blob)),
    ];
    for model in &mut models {
        run_model(model, &u, 8, 0.1);
    }
    let models: Vec<&DensityModel> = models.iter().collect();
    let mut probe = DensityProbe::new(d);
    let alone: Vec<DensityMeasures> = models.iter().map(|m| probe.measure(m)).collect();
    let together = probe.measure_all(&models);
    let bits = |m: &DensityMeasures| {
        [m.mass, m.max, m.mean_gradient, m.subgrid_fraction].map(f64::to_bits)
    };
    assert_eq!(together.len(), 3);
    for (n, (a, t)) in alone.iter().zip(&together).enumerate() {
        assert_eq!(bits(a), bits(t), "gas {n}: {a:?} alone, {t:?} together");
        assert!(a.mass > 0.0, "gas {n} is empty");
    }
    // Guard: distinct gases, so a swap would show.
    for (m, n) in [(0, 1), (0, 2), (1, 2)] {
        assert_ne!(bits(&alone[m]), bits(&alone[n]), "gases {m} and {n}");
    }
}

/// `x² + y/2` on the world point: linear in y, quadratic in x.
struct Parabola;

impl ScalarField for Parabola {
    fn eval(&self, p: Vec3) -> f32 {
        p.x * p.x + 0.5 * p.y
    }
}

/// With a velocity history at rest, the cells of a gridless and a SELMA
/// density are the 2×2×2 cell averages of `ρ₀` (`density::cell_average`):
/// for `ρ₀ = x² + y/2` on cells of width `h` centred at `x_c`, the
/// midpoint rule's `x_c² + (h/4)² + y_c/2` — the exact average
/// `x_c² + h²/12 + y_c/2` of the linear part and of `x²` up to the rule's
/// `h²/48` — and with `cell_samples = 1` the centre value `x_c² + y_c/2`.
/// The box of edge 4 in 8 cells makes every number dyadic: exact equality.
#[test]
fn cell_average_of_a_quadratic_at_rest_is_the_midpoint_rule() {
    let d = Domain::cube(8, 4.0).unwrap();
    let rest = Arc::new(FaceGrid::zeros(d, BoxKind::Periodic));
    let h = d.cell;
    for mode in [DensityMode::Gridless, DensityMode::Selma] {
        for (samples, bump) in [
            (CellSamples::Average, h * h / 16.0),
            (CellSamples::Centre, 0.0),
        ] {
            let options = DensityOptions {
                cell_samples: Some(samples),
                ..DensityOptions::mode(mode)
            };
            let mut model = DensityModel::new(&options, d, Some(Arc::new(Parabola)), None);
            run_model(&mut model, &rest, 3, 0.1);
            model.evaluate_centres();
            let expected: Vec<f32> = centres(&d)
                .iter()
                .map(|c| c.x * c.x + bump + 0.5 * c.y)
                .collect();
            assert_eq!(model.density().as_slice(), expected, "{mode}, {samples:?}");
        }
    }
}
