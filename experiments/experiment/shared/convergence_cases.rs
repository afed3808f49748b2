//! Convergence studies against exact solutions, refined at a fixed CFL number.
//!
//! Each function runs one study over the given resolutions and returns a
//! [`Study`]: its spacings, errors and the order it is expected to show (with
//! the reason in the function's doc). Errors are root-mean-square over the
//! cells (or over a fixed set of sample points for the field studies) unless
//! [`Study::norm`] says otherwise.
//!
//! Most studies refine the grid at a fixed CFL number; the gridless studies
//! refine only the time step, SELMA only its map grid and the curl-noise
//! study only its finite-difference step — [`Study::refined`] names the
//! quantity.

use std::f32::consts::{PI, TAU};
use std::sync::Arc;

use glam::Vec3;

use smokelab::advection::{
    advect_scalar, bfecc_scalar, maccormack_scalar, AdvectionOptions, Backtrace, Limiter, Quick,
    Scheme,
};
use smokelab::density::{GridlessField, Selma, StepInput};
use smokelab::domain::Domain;
use smokelab::field::{ops, Scalar, ScalarField, Vector, VectorField};
use smokelab::fit::{observed_order, ObservedOrder};
use smokelab::grid::{BoxKind, FaceGrid, ScalarGrid};
use smokelab::noise::curl::{CurlFd, FdScheme};
use smokelab::noise::lattice;
use smokelab::pressure::{PressurePrecision, PressureSolver};
use smokelab::simulation::{Simulation, StepParams};

/// One convergence study.
#[derive(Clone, Debug)]
pub struct Study {
    /// Short name, used for file names.
    pub name: String,
    /// The order the scheme should show.
    pub expected: f64,
    /// What is refined, e.g. "Δx (CFL 0.4)", for tables and plot axes.
    pub refined: &'static str,
    /// How the error is measured: "rms", or "mean abs" where the function's
    /// doc says why.
    pub norm: &'static str,
    /// Spacings, coarse to fine.
    pub h: Vec<f64>,
    /// Errors at each spacing.
    pub error: Vec<f64>,
}

impl Study {
    /// An empty study, filled level by level.
    fn new(name: impl Into<String>, expected: f64, refined: &'static str) -> Self {
        Self {
            name: name.into(),
            expected,
            refined,
            norm: "rms",
            h: vec![],
            error: vec![],
        }
    }

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

/// [`rms_diff`] over every face of two staggered fields.
fn face_rms_diff(a: &FaceGrid, b: &FaceGrid) -> f64 {
    let (mut s, mut n) = (0.0, 0);
    for c in 0..3 {
        s += rms_diff(a.slice(c), b.slice(c)).powi(2) * a.slice(c).len() as f64;
        n += a.slice(c).len();
    }
    (s / n as f64).sqrt()
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

/// The smooth periodic profile of the uniform-flow studies, `exp(sin 2πx)`.
fn line_profile(x: f64) -> f64 {
    (std::f64::consts::TAU * x).sin().exp()
}

/// How a study's initial data and exact solution are put on the grid.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Sampling {
    /// Point values at the cell centres.
    Point,
    /// Cell averages (finite-volume data), by 3-point Gauss–Legendre
    /// quadrature per cell (error O(Δx⁶), far below the studied error).
    CellAverage,
}

/// The uniform-flow study's initial and exact grids on `[0, 1] × 4Δx × 4Δx`
/// with `n` cells along x: the profile and its copy shifted by `shift`.
fn line_grids(n: usize, shift: f32, sampling: Sampling) -> (ScalarGrid, ScalarGrid) {
    let d = Domain::new(Vec3::ZERO, 1.0 / n as f32, [n, 4, 4]).expect("valid study domain");
    let h = d.cell as f64;
    let value = |i: usize, s: f64| {
        let lo = i as f64 * h - s;
        match sampling {
            Sampling::Point => line_profile(lo + 0.5 * h),
            Sampling::CellAverage => {
                let a = 0.6f64.sqrt();
                let at = |t: f64| line_profile(lo + 0.5 * h * (1.0 + t));
                (5.0 * at(-a) + 8.0 * at(0.0) + 5.0 * at(a)) / 18.0
            }
        }
    };
    let mut q = ScalarGrid::zeros(d);
    let mut exact = ScalarGrid::zeros(d);
    for (m, (v, e)) in q
        .as_slice_mut()
        .iter_mut()
        .zip(exact.as_slice_mut())
        .enumerate()
    {
        *v = value(m % n, 0.0) as f32;
        *e = value(m % n, shift as f64) as f32;
    }
    (q, exact)
}

/// Semi-Lagrangian advection of `exp(sin 2πx)` by a uniform unit velocity
/// over a quarter period at CFL 0.4. Trilinear interpolation damps each step
/// by O(Δx²) and the number of steps grows as 1/Δx: **order 1** for every
/// backtrace (the backtrace is exact for uniform flow).
pub fn sl_uniform(backtrace: Backtrace, resolutions: &[usize]) -> Study {
    let name = format!("sl_uniform_{backtrace:?}").to_lowercase();
    uniform_study(
        Study::new(name, 1.0, "Δx (CFL 0.4)"),
        backtrace,
        resolutions,
        advect_scalar,
    )
}

/// One grid-to-grid step of a scheme: `dst = step(src, vel, Δt, backtrace)`.
type Step = fn(&ScalarGrid, &FaceGrid, f32, Backtrace, &mut ScalarGrid);

/// [`sl_uniform`]'s problem advected by `step`, filling `study`.
fn uniform_study(
    mut study: Study,
    backtrace: Backtrace,
    resolutions: &[usize],
    step: Step,
) -> Study {
    for &n in resolutions {
        let dt = 0.4 / n as f32;
        let steps = (0.25 / dt).round() as usize;
        let (mut q, exact) = line_grids(n, steps as f32 * dt, Sampling::Point);
        let d = *q.domain();
        let vel = FaceGrid::from_field(d, BoxKind::Periodic, &FnVector(|_| Vec3::X));
        let mut tmp = ScalarGrid::zeros(d);
        for _ in 0..steps {
            step(&q, &vel, dt, backtrace, &mut tmp);
            std::mem::swap(&mut q, &mut tmp);
        }
        study.h.push(d.cell as f64);
        study.error.push(rms_diff(q.as_slice(), exact.as_slice()));
    }
    study
}

/// MacCormack (Selle et al. 2008, with its min/max clamp) on
/// [`sl_uniform`]'s problem: `exp(sin 2πx)`, uniform unit velocity, a
/// quarter period at CFL 0.4. The backward step's trilinear damping equals
/// the forward step's, so the correction `½(φⁿ − φ̂ⁿ)` takes off SL's
/// O(Δx²) per-step error and leaves O(Δx³), order 2 after the O(1/Δx)
/// steps — where the clamp lets it. At the profile's maximum and minimum
/// the corrected value overshoots the range of its stencil's corners and
/// reverts to the SL value: a few cells each step carry SL's error, which
/// in the rms over the cells falls as Δx^1.5. **Order 1.75**, between the
/// two: measured 1.73 (pairwise 1.75, 1.73, 1.70 from 32 to 256 cells,
/// the same for every backtrace, which is exact in uniform flow).
pub fn maccormack_uniform(backtrace: Backtrace, resolutions: &[usize]) -> Study {
    let name = format!("maccormack_uniform_{backtrace:?}").to_lowercase();
    let study = Study::new(name, 1.75, "Δx (CFL 0.4)");
    uniform_study(study, backtrace, resolutions, maccormack_scalar)
}

/// BFECC (Dupont & Liu 2003, MacCormack's clamp) on [`sl_uniform`]'s
/// problem. The round trip's error corrects the source, which one more SL
/// step then moves: SL's O(Δx²) per-step error is taken off as in
/// [`maccormack_uniform`], and the clamp reverts the cells at the profile's
/// extrema to SL as there. **Order 1.75**, as MacCormack's: measured 1.80
/// (32 to 256 cells, every backtrace).
pub fn bfecc_uniform(backtrace: Backtrace, resolutions: &[usize]) -> Study {
    let name = format!("bfecc_uniform_{backtrace:?}").to_lowercase();
    let study = Study::new(name, 1.75, "Δx (CFL 0.4)");
    uniform_study(study, backtrace, resolutions, bfecc_scalar)
}

/// `steps` unlimited QUICK steps of `q` through the steady velocity `vel`.
fn quick_steps(q: &mut ScalarGrid, vel: &FaceGrid, dt: f32, steps: usize) {
    let d = *q.domain();
    let mut quick = Quick::new(d, Default::default());
    quick
        .prepare(vel, dt)
        .expect("the study's velocity is within QUICK's sub-step limits");
    let mut tmp = ScalarGrid::zeros(d);
    for _ in 0..steps {
        quick.advect_scalar(q, &mut tmp, Limiter::None);
        std::mem::swap(q, &mut tmp);
    }
}

/// QUICK (unlimited, SSP-RK3) on [`sl_uniform`]'s problem: `exp(sin 2πx)`,
/// uniform unit velocity, a quarter period at CFL 0.4.
///
/// **Order 2, not 3.** QUICK's face value is the upwind quadratic through
/// three *point values*, exact to O(Δx³), but the flux form
/// `∂q/∂t = −u (q_{i+½} − q_{i−½})/Δx` (the module doc of
/// [`smokelab::advection::quick`]) turns even exact face values into the
/// one-cell central difference `(q(x+½Δx) − q(x−½Δx))/Δx = q′ + Δx²/24 q‴`.
/// For one Fourier mode the operator's modified wavenumber is
/// `Im[(1 − e^{−iθ})(¾ + ⅜e^{iθ} − ⅛e^{−iθ})] = θ − θ³/24 + …` (θ = kΔx): the
/// phase error `θ³/24` per cell crossed, `ku t θ²/24` after time t, is
/// **O(Δx²)**; the damping `θ⁴/16` per cell is O(Δx³) and SSP-RK3 at fixed
/// CFL O(Δt³). Reading the unknowns as cell averages ([`Sampling::CellAverage`])
/// does not restore third order: the flux difference is then exact, but the
/// QUICK weights interpolate point values, and on averages
/// `q̄ = q + Δx²/24 q″ + …` the face value is off by `Δx²/24 q″`, the same
/// `−u Δx²/24 q‴` leading error (Leonard, *Appl. Math. Modelling* 19, 1995).
pub fn quick_uniform(sampling: Sampling, resolutions: &[usize]) -> Study {
    let name = match sampling {
        Sampling::Point => "quick_uniform",
        Sampling::CellAverage => "quick_uniform_cell_average",
    };
    let mut study = Study::new(name, 2.0, "Δx (CFL 0.4)");
    for &n in resolutions {
        let dt = 0.4 / n as f32;
        let steps = (0.25 / dt).round() as usize;
        let (mut q, exact) = line_grids(n, steps as f32 * dt, sampling);
        let vel = FaceGrid::from_field(*q.domain(), BoxKind::Periodic, &FnVector(|_| Vec3::X));
        quick_steps(&mut q, &vel, dt, steps);
        study.h.push(q.domain().cell as f64);
        study.error.push(rms_diff(q.as_slice(), exact.as_slice()));
    }
    study
}

/// The solid-body rotation study at `n` cells across the unit slab: the
/// velocity `ω (c_y − y, x − c_x, 0)` about the box centre (ω = 2π), a
/// Gaussian blob (σ = 0.08) at radius ¼, and, after a quarter turn with
/// Δt = Δx/2, the blob rotated exactly. Returns `(velocity, initial, exact,
/// Δt, steps)`.
fn rotation_case(n: usize) -> (FaceGrid, ScalarGrid, ScalarGrid, f32, usize) {
    let (omega, c, sigma) = (TAU, Vec3::new(0.5, 0.5, 0.0), 0.08f32);
    let blob = move |p: Vec3, at: Vec3| {
        (-((p - at) * Vec3::new(1.0, 1.0, 0.0)).length_squared() / (2.0 * sigma * sigma)).exp()
    };
    let d = slab_domain(n, 1.0);
    let dt = 0.5 * d.cell;
    let steps = (0.25 / dt).round() as usize;
    let angle = omega * steps as f32 * dt;
    let start = c + Vec3::new(0.25, 0.0, 0.0);
    let end = c + 0.25 * Vec3::new(angle.cos(), angle.sin(), 0.0);
    let vel = FaceGrid::from_field(d, BoxKind::Periodic, &FnVector(rotation_velocity));
    let q = ScalarGrid::from_field(d, &FnScalar(move |p| blob(p, start)));
    let exact = ScalarGrid::from_field(d, &FnScalar(move |p| blob(p, end)));
    (vel, q, exact, dt, steps)
}

/// Semi-Lagrangian advection of a Gaussian blob (σ = 0.08) by solid-body
/// rotation about the box centre, a quarter turn, with Δt = Δx/2 (CFL ≈ 0.8 at
/// the blob). The velocity is linear, so its trilinear interpolation is exact
/// and only the backtrace and the density interpolation err: the Euler
/// backtrace's O(Δt²) per step and trilinear damping's O(Δx²) per step both
/// give **order 1** overall; RK2 and RK3 remove the first but not the second.
pub fn sl_rotation(backtrace: Backtrace, resolutions: &[usize]) -> Study {
    let name = format!("sl_rotation_{backtrace:?}").to_lowercase();
    let study = Study::new(name, 1.0, "Δx (Δt = Δx/2)");
    rotation_study(study, backtrace, resolutions, advect_scalar)
}

/// [`sl_rotation`]'s problem advected by `step`, filling `study`.
fn rotation_study(
    mut study: Study,
    backtrace: Backtrace,
    resolutions: &[usize],
    step: Step,
) -> Study {
    for &n in resolutions {
        let (vel, mut q, exact, dt, steps) = rotation_case(n);
        let mut tmp = ScalarGrid::zeros(*q.domain());
        for _ in 0..steps {
            step(&q, &vel, dt, backtrace, &mut tmp);
            std::mem::swap(&mut q, &mut tmp);
        }
        study.h.push(q.domain().cell as f64);
        study.error.push(rms_diff(q.as_slice(), exact.as_slice()));
    }
    study
}

/// MacCormack on [`sl_rotation`]'s problem: the Gaussian blob a quarter
/// turn, Δt = Δx/2. The velocity is linear, so only the backtrace and the
/// interpolation err; the correction removes the leading part of both
/// (the backward step's errors mirror the forward step's), **order 2**
/// for every backtrace — Euler's outward drift, O(Δt²) per step, is the
/// same forwards and backwards and is taken off too. Measured 1.91–1.92
/// (32 to 128 cells; the clamp acts only at the blob's peak).
pub fn maccormack_rotation(backtrace: Backtrace, resolutions: &[usize]) -> Study {
    let name = format!("maccormack_rotation_{backtrace:?}").to_lowercase();
    let study = Study::new(name, 2.0, "Δx (Δt = Δx/2)");
    rotation_study(study, backtrace, resolutions, maccormack_scalar)
}

/// BFECC on [`sl_rotation`]'s problem: as [`maccormack_rotation`], the
/// round trip's error estimate removes the leading part of the backtrace's
/// and the interpolation's errors, **order 2** for every backtrace
/// (measured 2.02 Euler, 2.09 RK2, 2.10 RK3 from 32 to 128 cells).
pub fn bfecc_rotation(backtrace: Backtrace, resolutions: &[usize]) -> Study {
    let name = format!("bfecc_rotation_{backtrace:?}").to_lowercase();
    let study = Study::new(name, 2.0, "Δx (Δt = Δx/2)");
    rotation_study(study, backtrace, resolutions, bfecc_scalar)
}

/// QUICK (unlimited) on [`sl_rotation`]'s problem: the blob a quarter turn
/// round the box centre, Δt = Δx/2. A corner cell's Courant number
/// `ωΔt/Δx (|x − c_x| + |y − c_y|)` is about π at every resolution, so every
/// step takes the same 4 sub-steps of QUICK's default limit 1: the CFL
/// number stays fixed. The face velocities, averages of
/// a linear field, are exact; the error is QUICK's **O(Δx²)** phase error
/// (see [`quick_uniform`]: `−Δx²/24 u·∂³q` along each axis), SSP-RK3's
/// O(Δt³) being smaller. **Order 2** — up to 128 cells: from 128 to 256 the
/// rate drops to ≈ 1 at an error near 10⁻⁴, a floor not yet explained
/// (likely the blob's tail, ~7·10⁻³ of its peak at the box edge, crossing
/// the periodic seam where the rotation's tangential velocity jumps).
pub fn quick_rotation(resolutions: &[usize]) -> Study {
    let mut study = Study::new("quick_rotation", 2.0, "Δx (Δt = Δx/2)");
    for &n in resolutions {
        let (vel, mut q, exact, dt, steps) = rotation_case(n);
        quick_steps(&mut q, &vel, dt, steps);
        study.h.push(q.domain().cell as f64);
        study.error.push(rms_diff(q.as_slice(), exact.as_slice()));
    }
    study
}

/// `A sin x cos y, −A cos x sin y` on a `2π` box.
fn taylor_green(d: Domain, amplitude: f32) -> FaceGrid {
    FaceGrid::from_field(
        d,
        BoxKind::Periodic,
        &FnVector(move |p: Vec3| {
            amplitude * Vec3::new(p.x.sin() * p.y.cos(), -p.x.cos() * p.y.sin(), 0.0)
        }),
    )
}

/// The Taylor–Green study: `steps = n/2` full Navier–Stokes steps with
/// `scheme`, ν = 0.05, Δt = Δx/2, to t = π/2; the rms error against the
/// exact decay `e^{−2νt}` at each resolution.
fn taylor_green_study(scheme: Scheme, resolutions: &[usize]) -> Study {
    let name = format!("taylor_green_{scheme:?}").to_lowercase();
    let mut study = Study::new(name, 1.0, "Δx (CFL 0.5)");
    let nu = 0.05f32;
    let options = AdvectionOptions {
        scheme,
        ..Default::default()
    };
    for &n in resolutions {
        let d = slab_domain(n, TAU);
        let dt = 0.5 * d.cell;
        let steps = n / 2; // t = π/2
        let params = StepParams {
            dt,
            viscosity: nu,
            gravity: Vec3::ZERO,
            backtrace: Backtrace::Rk2,
            interpolant: Default::default(),
            confinement: 0.0,
        };
        // f64 transforms: the study measures the scheme's error, not the
        // f32 solve's round-off.
        let mut sim = Simulation::new(d, params, vec![])
            .with_advection(&options)
            .with_pressure_precision(PressurePrecision::F64);
        sim.velocity = taylor_green(d, 1.0);
        for _ in 0..steps {
            sim.step();
        }
        let t = steps as f32 * dt;
        let exact = taylor_green(d, (-2.0 * nu * t).exp());
        study.h.push(d.cell as f64);
        study.error.push(face_rms_diff(&sim.velocity, &exact));
    }
    study
}

/// The full Navier–Stokes step (advection, exact viscous diffusion,
/// projection) on the Taylor–Green vortex, ν = 0.05, to t = π/2 with
/// Δt = Δx/2 (CFL 0.5). The solution is exact with amplitude `e^{−2νt}`; the
/// semi-Lagrangian trilinear damping makes the scheme **order 1**.
pub fn taylor_green_sl(resolutions: &[usize]) -> Study {
    taylor_green_study(Scheme::Sl, resolutions)
}

/// [`taylor_green_sl`] with QUICK advection. QUICK's spatial error is
/// O(Δx²), but the step is still **order 1**: it advects the velocity by
/// itself *frozen* at the start of the step, then diffuses, then projects
/// (eqs 6.5 and 6.3 in sequence). For Taylor–Green `u·∇u = −∇p` is a pure
/// gradient, removed exactly by the projection, but the frozen-velocity
/// update's `Δt²/2 (u·∇)(u·∇u)` term is not: an O(Δt²) splitting error per
/// step, O(Δt) after a fixed time, and Δt ∝ Δx at fixed CFL.
pub fn taylor_green_quick(resolutions: &[usize]) -> Study {
    taylor_green_study(Scheme::Quick, resolutions)
}

/// [`taylor_green_sl`] with MacCormack advection of the velocity: its
/// advection error is O(Δx²) per unit time, but as for QUICK the step
/// advects the velocity frozen at the start of the step, then diffuses and
/// projects, an O(Δt²) splitting error per step: **order 1** (measured
/// 0.91 from 16 to 64 cells).
pub fn taylor_green_maccormack(resolutions: &[usize]) -> Study {
    taylor_green_study(Scheme::MacCormack, resolutions)
}

/// [`taylor_green_maccormack`] with BFECC: the same splitting error,
/// **order 1** (measured 0.98 from 16 to 64 cells).
pub fn taylor_green_bfecc(resolutions: &[usize]) -> Study {
    taylor_green_study(Scheme::Bfecc, resolutions)
}

/// The gridless density's return error in LeVeque's deformation (the
/// `deformation` scenario at 32³, RK2, one period T = 3 in `steps` steps):
/// L1 `Σ|ρ_T − ρ₀| / Σρ₀` against the initial grid, refining Δt. The walk
/// is exact in space, so only the backtraces err; the time-reversed flow
/// (`cos(πt/T)`) cancels RK2's leading O(Δt²) over the period, and the
/// return error is **order 3** in Δt (measured 2.98: 0.070, 0.0089, 0.0011
/// at 48, 96, 192 steps; Euler at 96 steps does not return, L1 1.03).
/// Not round-off: the explicit backtraces are not time-symmetric.
pub fn deformation_gridless_return(steps: &[usize]) -> Study {
    use smokelab::density::DensityMode;
    use smokelab::scenario::prescribed::DeformationConfig;
    use smokelab::scenario::Scenario;
    let mut study = Study::new("deformation_gridless_return", 3.0, "Δt (32³, one period)");
    study.norm = "L1 relative";
    for &n in steps {
        let mut c = DeformationConfig::default();
        c.solver.res = 32;
        c.solver.density = DensityMode::Gridless;
        c.solver.frames = n;
        c.solver.dt = c.keys.period / n as f32;
        let mut sim = c.build().expect("a valid deformation configuration");
        let exact = c.exact(&sim).expect("deformation knows its exact solution");
        for _ in 0..n {
            sim.step();
        }
        // A prescribed step leaves the gridless density unevaluated.
        sim.evaluate_densities();
        let m = exact.measure(sim.gases[0].density(), sim.time(), c.solver.dt);
        study.h.push(c.solver.dt as f64);
        study.error.push(m.l1);
    }
    study
}

/// Solid-body rotation about the centre `c` of the unit slab,
/// `ω (c_y − y, x − c_x, 0)` with ω = 2π.
fn rotation_velocity(p: Vec3) -> Vec3 {
    let c = Vec3::new(0.5, 0.5, 0.0);
    TAU * Vec3::new(c.y - p.y, p.x - c.x, 0.0)
}

/// The gridless studies' blob, `exp(−|x − x₀|²/2σ²)` in the xy-plane with
/// σ = 0.08 at radius 0.2 from the slab's centre, and `ρ₀` rotated exactly
/// by `angle` about the centre.
fn rotated_blob(p: Vec3, angle: f32) -> f32 {
    let c = Vec3::new(0.5, 0.5, p.z);
    let (s, co) = (-angle).sin_cos();
    let r = p - c;
    let back = c + Vec3::new(co * r.x - s * r.y, s * r.x + co * r.y, 0.0);
    let at = Vec3::new(0.7, 0.5, p.z);
    (-(back - at).length_squared() / (2.0 * 0.08f32 * 0.08)).exp()
}

/// Sample points of the gridless studies: a 48 × 48 lattice over the unit
/// slab's mid-plane, kept within radius 0.35 of the centre (so every
/// backtrace, even Euler's outward spiral, stays clear of the periodic seam
/// where the sampled rotation is not linear).
fn disc_points() -> Vec<Vec3> {
    let m = 48;
    (0..m * m)
        .map(|n| {
            let (i, j) = ((n % m) as f32, (n / m) as f32);
            Vec3::new((i + 0.5) / m as f32, (j + 0.5) / m as f32, 0.125)
        })
        .filter(|p| (*p - Vec3::new(0.5, 0.5, 0.125)).length() <= 0.35)
        .collect()
}

/// Values of `f` at `points`.
fn eval_points(f: &dyn ScalarField, points: &[Vec3]) -> Vec<f32> {
    let mut out = vec![0.0; points.len()];
    f.eval_batch(points, &mut out);
    out
}

/// Gridless advection (eq 7.4, [`GridlessField`]) of the blob a quarter turn
/// round the unit slab's centre in `steps` steps, against the exactly
/// rotated blob; Δt = ¼/steps is refined, the 16 × 16 × 4 velocity grid is
/// not. The rotation is linear, so its trilinear interpolation is exact
/// (away from the periodic seam, which [`disc_points`] avoid) and the only
/// error is the backtrace's: its local error O(Δt^{p+1}) over `T/Δt` steps
/// gives **order p** in Δt — 1 for Euler `x − Δt u(x)`, 2 for the midpoint
/// rule, 3 for Kutta's RK3 ([`Backtrace`]). RK3's error reaches f32
/// round-off (~10⁻⁶ of the blob) below Δt ≈ 1/128: refine it from coarser steps.
pub fn gridless_rotation(backtrace: Backtrace, steps: &[usize]) -> Study {
    let name = format!("gridless_{backtrace:?}").to_lowercase();
    let expected = backtrace
        .order()
        .expect("gridless_rotation: a time integrator (Backtrace::INTEGRATORS)")
        as f64;
    let mut study = Study::new(name, expected, "Δt (grid fixed)");
    let d = slab_domain(16, 1.0);
    let vel = Arc::new(FaceGrid::from_field(
        d,
        BoxKind::Periodic,
        &FnVector(rotation_velocity),
    ));
    let rho0: Scalar = Arc::new(FnScalar(|p| rotated_blob(p, 0.0)));
    let points = disc_points();
    let exact: Vec<f32> = points.iter().map(|&p| rotated_blob(p, TAU / 4.0)).collect();
    for &n in steps {
        let dt = 0.25 / n as f32;
        let mut field = GridlessField::new(d, Some(rho0.clone()), None);
        for _ in 0..n {
            field.push(vel.clone(), dt, backtrace);
        }
        study.h.push(dt as f64);
        study
            .error
            .push(rms_diff(&eval_points(&field, &points), &exact));
    }
    study
}

/// The notes' FELT chain `ρ_k = advect(ρ_{k−1}, u, Δt)` (eq 6.4 without the
/// source, [`ops::advect`]) built from field combinators with the *analytic*
/// rotation — no grid at all — a quarter turn in `steps` steps, against the
/// exactly rotated blob. Each link is the Euler backtrace `x − Δt u(x)`:
/// local error O(Δt²), **order 1** in Δt — the errors of
/// [`gridless_rotation`] with [`Backtrace::Euler`] to round-off, since there
/// the sampled rotation interpolates exactly.
pub fn gridless_field_chain(steps: &[usize]) -> Study {
    let mut study = Study::new("gridless_field_chain", 1.0, "Δt");
    let velocity: Vector = Arc::new(FnVector(rotation_velocity));
    let points = disc_points();
    let exact: Vec<f32> = points.iter().map(|&p| rotated_blob(p, TAU / 4.0)).collect();
    for &n in steps {
        let dt = 0.25 / n as f32;
        let mut rho: Scalar = Arc::new(FnScalar(|p| rotated_blob(p, 0.0)));
        for _ in 0..n {
            rho = ops::advect(rho, velocity.clone(), dt);
        }
        study.h.push(dt as f64);
        study
            .error
            .push(rms_diff(&eval_points(&*rho, &points), &exact));
    }
    study
}

/// `n` quasi-random points (the additive R₃ sequence, low discrepancy and
/// deterministic) in the box `[lo, lo + size)`.
fn quasi_random_points(n: usize, lo: Vec3, size: Vec3) -> Vec<Vec3> {
    // 1/φ₃, 1/φ₃², 1/φ₃³ with φ₃ the real root of x⁴ = x + 1.
    let phi = 1.220_744_084_605_759_5f64;
    let alpha = [1.0 / phi, 1.0 / (phi * phi), 1.0 / (phi * phi * phi)];
    (1..=n)
        .map(|k| {
            let f = |a: f64| (0.5 + a * k as f64).fract() as f32;
            lo + size * Vec3::new(f(alpha[0]), f(alpha[1]), f(alpha[2]))
        })
        .collect()
}

/// SELMA (eq 8.8, [`Selma`], never re-anchored, so `ρ = ρ₀ ∘ X`) against
/// gridless (eq 7.4) on the same velocity history as the map grid refines:
/// 4 RK2 steps of Δt = 0.025 (0.8 velocity cells a step) through the
/// cellular flow `(sin 2πx cos 2πy, −cos 2πx sin 2πy, 0)` sampled on a
/// 32 × 32 × 8 slab, `ρ₀ = exp(sin 2πx) (1 + ½ cos 2π(y + 0.15))`. Both
/// follow the same backtraces, so the only difference is SELMA's map: each
/// step `D_n(x) = (B_n(x) − x) + D_{n−1}(B_n(x))` reads the previous
/// displacement by trilinear interpolation, O(h²) for a smooth map, and the
/// query interpolates `D_n` once more; with the step count fixed the errors
/// add up to **order 2** in the map cell `h` (Δt and the velocity grid are
/// not refined). The run is short so that the map stays mildly deformed:
/// with 8 steps of 0.05 (stretching `~e^{2π·0.4}` at the flow's saddles) the
/// pairwise rates are still climbing (1.60, 1.73, 1.96 from 16 to 128 cells).
///
/// The error is the **mean absolute** difference (as in `tests/density.rs`):
/// the map inherits the kinks of the trilinearly interpolated velocity along
/// the velocity grid's cell centres, and in the fraction ~h/Δx_u of map
/// cells a kink crosses, interpolating it errs by O(h), not O(h²) — still
/// O(h²) in the mean, but O(h^{3/2}) asymptotically in the rms. (Where the
/// map nodes coincide with the velocity nodes, 32 cells, one step's map is
/// reproduced exactly, which makes the rates uneven around that level.)
pub fn selma_to_gridless(map_res: &[usize]) -> Study {
    let mut study = Study::new("selma_to_gridless", 2.0, "map Δx (Δt fixed)");
    study.norm = "mean abs";
    // 8 cells deep, so that the coarsest map (16 across) is still 4 deep.
    let d = Domain::new(Vec3::ZERO, 1.0 / 32.0, [32, 32, 8]).expect("valid study domain");
    let cellular = |p: Vec3| {
        let (x, y) = (TAU * p.x, TAU * p.y);
        Vec3::new(x.sin() * y.cos(), -x.cos() * y.sin(), 0.0)
    };
    let vel = Arc::new(FaceGrid::from_field(
        d,
        BoxKind::Periodic,
        &FnVector(cellular),
    ));
    let rho0: Scalar = Arc::new(FnScalar(|p: Vec3| {
        (TAU * p.x).sin().exp() * (1.0 + 0.5 * (TAU * (p.y + 0.15)).cos())
    }));
    let (steps, dt, bt) = (4, 0.025, Backtrace::Rk2);
    let points = quasi_random_points(4096, Vec3::ZERO, d.size());
    let mut gridless = GridlessField::new(d, Some(rho0.clone()), None);
    for _ in 0..steps {
        gridless.push(vel.clone(), dt, bt);
    }
    let reference = eval_points(&gridless, &points);
    let input = StepInput {
        velocity: &vel,
        snapshot: None,
        dt,
        backtrace: bt,
    };
    for &res in map_res {
        let map = d.with_resolution(res).expect("valid map grid");
        let mut selma = Selma::new(d, map, Some(rho0.clone()), None, 0.0);
        for _ in 0..steps {
            selma.step(&input);
        }
        let got = eval_points(selma.field(), &points);
        let l1: f64 = got
            .iter()
            .zip(&reference)
            .map(|(a, b)| (a - b).abs() as f64)
            .sum();
        study.h.push(map.cell as f64);
        study.error.push(l1 / points.len() as f64);
    }
    study
}

/// The divergence of finite-difference curl noise ([`CurlFd`], three Perlin
/// potentials) as its step `h` refines: rms of the exact divergence of the
/// FD field ([`CurlFd::divergence`], no second finite difference) over 4096
/// quasi-random points of an 8³-lattice-cell box. The analytic curl is
/// exactly divergence-free (`∇·∇×ψ = 0`, `001_…`); with `D_a` the FD
/// operator the FD field's divergence is `Σ (D_b ∂_a − D_a ∂_b) ψ_c`, and
/// `D_a = ∂_a + (h²/6) ∂_a³ + …` for central differences, `∂_a − (h/2) ∂_a² + …`
/// for backward ones. Perlin noise is C² with bounded third derivatives,
/// so the remainders hold everywhere: **order 2** (central), **order 1**
/// (backward, `001_…`'s scheme).
pub fn curl_fd_divergence(scheme: FdScheme, steps: &[f32]) -> Study {
    let (name, expected) = match scheme {
        FdScheme::Central => ("curl_fd_divergence_central", 2.0),
        FdScheme::Backward => ("curl_fd_divergence_backward", 1.0),
    };
    let mut study = Study::new(name, expected, "FD step h");
    let points = quasi_random_points(4096, Vec3::splat(0.0), Vec3::splat(8.0));
    let keys = lattice::keys::<3>(8);
    for &h in steps {
        let curl = CurlFd::new(keys, h, scheme);
        let div: Vec<f32> = points.iter().map(|&p| curl.divergence(p)).collect();
        study.h.push(h as f64);
        study.error.push(rms_diff(&div, &vec![0.0; div.len()]));
    }
    study
}

/// Manufactured Helmholtz split `u = ∇φ + w` on a `2π` cube with
/// `φ = sin x sin 2y sin 3z` and `w = ∇ × (cos 2z, sin 3x, cos y)`, both
/// sampled on the faces from their continuous formulas. The MAC pressure
/// solve should return `w`; its compact operators `D`, `G` are second-order
/// accurate, so the removed gradient is off by O(Δx²): **order 2** against
/// the continuous answer. Returns the rms face error of the recovered
/// solenoidal part.
pub fn projection_error(n: usize) -> f64 {
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
    let mut u = FaceGrid::from_field(d, BoxKind::Periodic, &FnVector(move |p| grad_phi(p) + w(p)));
    let exact = FaceGrid::from_field(d, BoxKind::Periodic, &FnVector(w));
    PressureSolver::new(d, BoxKind::Periodic).project(&mut u);
    face_rms_diff(&u, &exact)
}

/// [`projection_error`] over `resolutions`: **order 2**.
pub fn projection_mac(resolutions: &[usize]) -> Study {
    Study {
        name: "projection_mac".into(),
        expected: 2.0,
        refined: "Δx",
        norm: "rms",
        h: resolutions
            .iter()
            .map(|&n| (TAU / n as f32) as f64)
            .collect(),
        error: resolutions.iter().map(|&n| projection_error(n)).collect(),
    }
}

/// Spacing of a `2π` box with `n` cells, for tables.
pub fn spacing_2pi(n: usize) -> f64 {
    (2.0 * PI / n as f32) as f64
}
