//! Analytic flows and helpers the library's tests share. Each test file
//! declares `mod common;` and uses what it needs.
#![allow(dead_code)]

pub mod order;

use glam::Vec3;
use smokelab::domain::Domain;
use smokelab::field::VectorField;
use smokelab::grid::{BoxKind, FaceGrid};
use smokelab::pressure::PressureSolver;
use smokelab::simd::Isa;

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

/// Run `f` once with each instruction set this CPU has selected for the
/// semi-Lagrangian kernel ([`Isa::select`], as `SMOKELAB_SIMD` would),
/// narrowest first, then restore the one selected before.
///
/// The selection is the process's: a lock keeps two such loops of one test
/// binary from switching it under each other. Other tests running at the
/// same time may run on any width, which gives the same bits.
pub fn on_every_isa(mut f: impl FnMut(Isa)) {
    static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _held = LOCK.lock().unwrap_or_else(|e| e.into_inner());
    let before = Isa::selected();
    for isa in Isa::available() {
        isa.select().expect("an available instruction set");
        assert_eq!(Isa::selected(), isa);
        f(isa);
    }
    before
        .select()
        .expect("the instruction set selected before");
}
