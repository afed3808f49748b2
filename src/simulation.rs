//! The time step, as the notes' FELT script of §6.1.1 reads:
//!
//! ```text
//! hot  = advect(hot,  velocity, dt) + inject(hotpoint,  dt);   // eq 6.4
//! cold = advect(cold, velocity, dt) + inject(coldpoint, dt);   // eq 6.4
//! velocity = advect(velocity, velocity, dt)
//!          + dt*gravity*(cold - hot);                          // eq 6.5
//! velocity = fftdivfree(velocity, region);                      // eq 6.3
//! ```
//!
//! The velocity lives on the faces of the cells ([`FaceGrid`], the MAC grid;
//! `ARCHITECTURE.md`, "One step, following the data"), the densities at the
//! cell centres.
//! `fftdivfree` is the exact pressure solve of [`PressureSolver`].
//!
//! [`Simulation::try_step`] is those lines as verbs, each one call:
//! [`Simulation::advect`] (every `advect(…, velocity, dt)` above, each gas
//! in its own representation — [`crate::density`]), [`Simulation::inject`]
//! (`+ inject(…, dt)`), [`Simulation::clear_dry`] (the densities' side of
//! the obstacles), [`Simulation::evaluate_densities`] (gridless and SELMA
//! densities sampled at the cell centres for the force),
//! [`Simulation::add_buoyancy`] with [`Simulation::add_confinement`]
//! (vorticity confinement, off by default), [`Simulation::project`] and
//! [`Simulation::apply_boundary`] (§6.3: with the exact method the
//! projection is the obstacle-aware solve of
//! [`crate::pressure::obstacles`]; with the notes' method eqs 6.6–6.7
//! follow the periodic projection). Gridded densities and the velocity move
//! together through the chosen [`Advector`]: semi-Lagrangian in one sweep
//! that traces each departure point once, or QUICK through face velocities
//! frozen once. The densities are advected by the velocity of the start of
//! the step, as in the script. Every buffer is allocated once in
//! [`Simulation::new`].

use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::advection::{AdvectionOptions, Advector, Backtrace, CflError};
use crate::boundary::{Boundary, ObstacleMethod};
use crate::confinement::Confinement;
use crate::density::probe::cell_averages;
use crate::density::{total_bytes, DensityModel, DensityOptions, DensityState, StepInput};
use crate::domain::Domain;
use crate::error::{check_non_negative, InputError};
use crate::field::{Scalar, VectorField};
use crate::forces;
use crate::grid::{BoxKind, FaceGrid, Interpolant, ScalarGrid};
use crate::pressure::obstacles::{CgReport, ObstacleProjection, TOLERANCE};
use crate::pressure::{PressurePrecision, PressureSolver};
use crate::timing::{timed, StageTimes};

/// Sub-cells per axis of the quadrature of a gas's source: the gridded
/// injection rate is the source's cell average over `8³` sub-cell centres,
/// so that `Σ S̄ Δx³` is the `∫S dV` every mode is budgeted against (the
/// gridless and SELMA densities evaluate `S` anywhere). For the hot/cold
/// scenario's solid unit sphere its error is +0.09 % at 40³, +0.06 % at 32³,
/// +0.005 % at 50³ (+0.6 % at 20³); the 4× midpoint rule gave +0.58 % at 40³
/// and the point samples at the cell centres +4.5 % (computed from the
/// lattice points inside the sphere).
pub const SOURCE_REFINE: usize = 8;

/// Where a gridded gas's mass went, cumulative over the steps: each stage's
/// change of the grid's `Σ ρ Δx³`, measured by a sum over the grid before
/// and after it. With the injection `∫S dV · t` ([`Gas::injected_per_step`])
/// they close the budget, `mass = injected + advection + cleared`, to the
/// f32 rounding of the additions (`experiments/tests/mass_budget.rs`).
/// Gridless and SELMA gases are not held on the grid and leave it at zero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct MassBudget {
    /// Change by advection: semi-Lagrangian resampling is not conservative
    /// (trilinear weights of the departure points need not sum to one per
    /// cell); flux-form QUICK is, to round-off.
    pub advection: f64,
    /// Change by clearing the dry cells after the step (exact obstacles), ≤ 0.
    pub cleared: f64,
}

/// One buoyant gas: its density, where it is injected, and how it lifts.
#[derive(Clone)]
pub struct Gas {
    /// Name used for output files (`<name>_NNNN.npy`).
    pub name: String,
    /// How the density is held (gridded, gridless or SELMA).
    pub model: DensityModel,
    /// Injection rate on the grid: the cell averages of S(x) (the notes'
    /// `inject` without Δt) by [`SOURCE_REFINE`]³ sub-cells.
    pub source: ScalarGrid,
    /// Injection rate S(x) as a field, for the modes that query it anywhere.
    pub source_field: Scalar,
    /// Buoyancy coefficient: the force is `−g⃗ · lift · ρ`, so +1 rises (hot) and −1 sinks (cold).
    pub lift: f32,
    /// Stage changes of a gridded gas's mass since the start.
    pub budget: MassBudget,
}

impl Gas {
    /// A gridded gas starting empty, injected at rate `source(x)` per unit time.
    pub fn new(name: impl Into<String>, domain: Domain, source: &Scalar, lift: f32) -> Self {
        Self::with_density(name, domain, source, lift, &DensityOptions::default())
    }

    /// A gas starting empty, held as `density` says.
    ///
    /// # Panics
    /// If `density` fails [`DensityOptions::validate`] on `domain`.
    pub fn with_density(
        name: impl Into<String>,
        domain: Domain,
        source: &Scalar,
        lift: f32,
        density: &DensityOptions,
    ) -> Self {
        Self {
            name: name.into(),
            model: DensityModel::new(density, domain, None, Some(source.clone())),
            source: cell_averages(&**source, &domain, SOURCE_REFINE),
            source_field: source.clone(),
            lift,
            budget: MassBudget::default(),
        }
    }

    /// The density at the velocity grid's cell centres, as of the last
    /// [`Simulation::evaluate_densities`] (which a forced step calls; after
    /// a prescribed step, call it before reading a gridless or SELMA gas).
    ///
    /// # Panics
    /// If the gas is gridless or SELMA and was stepped or restored since its
    /// last evaluation (a stale read): call
    /// [`Simulation::evaluate_densities`] first.
    pub fn density(&self) -> &ScalarGrid {
        self.model.density()
    }

    /// Mass injected per step in every density mode, `∫S dV Δt`: the total
    /// of the cell-averaged source, `Σ S̄ Δx³ Δt`.
    pub fn injected_per_step(&self, dt: f32) -> f64 {
        self.source.total() * dt as f64
    }
}

/// The evolving state of a [`Simulation`] ([`Simulation::state`]).
///
/// Serialized (serde) field by field in this order; the gases through
/// [`crate::density::stored`], which keeps the gridless velocity grids
/// they share once.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SimulationState {
    /// Steps taken.
    pub step_index: usize,
    /// The velocity on the faces.
    pub velocity: FaceGrid,
    /// Per gas, its mass budget and density state.
    #[serde(with = "crate::density::stored")]
    pub gases: Vec<(MassBudget, DensityState)>,
    /// The obstacle-aware projection's warm start, the last step's pressure
    /// (exact obstacles only).
    pub obstacle_pressure: Option<Vec<f64>>,
    /// QUICK's open-face projection's warm start, the last step's potential
    /// (QUICK with obstacles only).
    pub face_potential: Option<Vec<f32>>,
}

/// A velocity given for all time, `u(x, t)` in world units: a
/// prescribed-flow scenario's ([`crate::scenario::prescribed`]). A
/// simulation carrying one samples it on the faces every step instead of
/// advecting, forcing and projecting the velocity.
pub trait PrescribedVelocity: Send + Sync {
    /// The velocity at world point `p` and time `t`.
    fn at(&self, p: Vec3, t: f32) -> Vec3;
}

/// A [`PrescribedVelocity`] frozen at one time, as a field.
pub struct AtTime<'a>(pub &'a dyn PrescribedVelocity, pub f32);

impl VectorField for AtTime<'_> {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.0.at(p, self.1)
    }
}

/// Physical and numerical parameters of the step.
#[derive(Clone, Copy, Debug)]
pub struct StepParams {
    /// Time step Δt.
    pub dt: f32,
    /// Kinematic viscosity ν (0 = inviscid, the notes' eq 6.2).
    pub viscosity: f32,
    /// Gravity vector g⃗ (points down, along −y).
    pub gravity: Vec3,
    /// Backtrace of the semi-Lagrangian steps.
    pub backtrace: Backtrace,
    /// How every trace reads the velocity between its faces
    /// ([`Interpolant`]); set on the velocity at the start of every step.
    pub interpolant: Interpolant,
    /// Vorticity confinement ε (Fedkiw, Stam & Jensen 2001, eq 11;
    /// [`crate::confinement`]), 0 = off.
    pub confinement: f32,
}

impl StepParams {
    /// `Ok` when Δt, ν and the confinement ε are finite numbers ≥ 0, else
    /// an error naming the bad value.
    pub fn check(&self) -> Result<(), InputError> {
        check_non_negative("time step", self.dt)?;
        check_non_negative("viscosity", self.viscosity)?;
        check_non_negative("confinement", self.confinement)
    }
}

/// Why [`Simulation::try_step`] refused a step; the state is then unchanged.
#[derive(Debug, thiserror::Error)]
pub enum StepError {
    /// QUICK's CFL bound ([`CflError`]).
    #[error(transparent)]
    Cfl(#[from] CflError),
    /// A time step or viscosity that is negative or not finite
    /// ([`StepParams::check`]).
    #[error(transparent)]
    Params(#[from] InputError),
}

/// Velocity, gases and the planned projection for one run.
///
/// A clone copies every grid but shares a gridless density's stored
/// velocity grids (immutable, [`Arc`]): the clone and the original step on
/// independently (benchmarks time one step of a warmed clone).
#[derive(Clone)]
pub struct Simulation {
    /// Parameters of every step.
    pub params: StepParams,
    /// Velocity on the cell faces, discretely divergence-free after each step.
    pub velocity: FaceGrid,
    /// The gases, advected and injected every step.
    pub gases: Vec<Gas>,
    /// Steps taken.
    pub step_index: usize,
    /// Wall time per stage of the last step.
    pub times: StageTimes,
    /// Obstacles and their rule (eqs 6.6–6.7), if any.
    pub boundary: Option<Boundary>,
    velocity_scratch: FaceGrid,
    advector: Advector,
    pressure: PressureSolver,
    /// The obstacle-aware pressure solve, with obstacles and the exact method.
    obstacle_projection: Option<ObstacleProjection>,
    /// The vorticity confinement's buffers (allocated at its first use).
    confinement: Confinement,
    /// A velocity given for all time ([`Self::with_prescribed_velocity`]).
    prescribed: Option<Arc<dyn PrescribedVelocity>>,
}

impl Simulation {
    /// A fluid at rest on `domain` carrying `gases`, advected semi-Lagrangian.
    pub fn new(domain: Domain, params: StepParams, gases: Vec<Gas>) -> Self {
        Self {
            params,
            velocity: FaceGrid::zeros(domain, BoxKind::Periodic)
                .with_interpolant(params.interpolant),
            gases,
            step_index: 0,
            times: StageTimes::default(),
            boundary: None,
            velocity_scratch: FaceGrid::zeros(domain, BoxKind::Periodic)
                .with_interpolant(params.interpolant),
            advector: Advector::new(domain, &AdvectionOptions::default(), params.backtrace),
            pressure: PressureSolver::with_precision(
                domain,
                BoxKind::Periodic,
                PressurePrecision::default(),
            ),
            obstacle_projection: None,
            confinement: Confinement::default(),
            prescribed: None,
        }
    }

    /// The same simulation with its velocity prescribed: each step sets the
    /// faces to `flow` at the step's midpoint time `(n + ½)Δt` (each
    /// component sampled at its face centres, [`FaceGrid::write_field`]) and
    /// moves the gases through it; the velocity is neither advected nor
    /// forced nor projected, so gravity and viscosity play no part.
    pub fn with_prescribed_velocity(mut self, flow: Arc<dyn PrescribedVelocity>) -> Self {
        self.prescribed = Some(flow);
        self
    }

    /// Whether the velocity is prescribed ([`Self::with_prescribed_velocity`]).
    pub fn is_prescribed(&self) -> bool {
        self.prescribed.is_some()
    }

    /// The same simulation at rest in a box of `kind`: closed walls hold the
    /// normal velocity at zero, the pressure solve uses cosine transforms,
    /// and gridded densities are read clamped to the box (no wrap).
    ///
    /// # Panics
    /// For a closed box with QUICK advection or a gridless or SELMA gas
    /// (their lattices and walks are periodic; configurations refuse these
    /// with an error first), or with obstacles.
    pub fn with_box(mut self, kind: BoxKind) -> Self {
        let d = *self.domain();
        if kind == BoxKind::Closed {
            assert!(
                !matches!(self.advector, Advector::Quick { .. }),
                "closed box: QUICK is periodic"
            );
            assert!(
                self.boundary.is_none(),
                "closed box: obstacles are periodic"
            );
        }
        let interpolant = self.params.interpolant;
        self.velocity = FaceGrid::zeros(d, kind).with_interpolant(interpolant);
        self.velocity_scratch = FaceGrid::zeros(d, kind).with_interpolant(interpolant);
        self.pressure = PressureSolver::with_precision(d, kind, self.pressure.precision());
        for gas in &mut self.gases {
            match &mut gas.model {
                DensityModel::Gridded(g) => g.set_wrap(kind.wrap()),
                _ => assert_eq!(kind, BoxKind::Periodic, "closed box: {} gas", gas.name),
            }
        }
        self
    }

    /// The same simulation with its pressure solve's transforms in
    /// `precision` (f32 by default; [`PressurePrecision`]).
    pub fn with_pressure_precision(mut self, precision: PressurePrecision) -> Self {
        let d = *self.domain();
        self.pressure = PressureSolver::with_precision(d, self.pressure.kind(), precision);
        self
    }

    /// The same simulation advecting with `options` (scheme, QUICK sub-steps, limiter).
    pub fn with_advection(mut self, options: &AdvectionOptions) -> Self {
        self.advector = Advector::new(*self.domain(), options, self.params.backtrace);
        if let Some(b) = &self.boundary {
            self.advector.set_solid(&b.solid());
        }
        self
    }

    /// The same simulation with obstacles (QUICK closes the faces of their
    /// cells); with [`ObstacleMethod::Exact`] the projection becomes the
    /// obstacle-aware solve over the wet cells.
    ///
    /// # Panics
    /// If the boundary was sampled on another domain.
    pub fn with_boundary(mut self, boundary: Boundary) -> Self {
        assert_eq!(
            boundary.level().domain(),
            self.domain(),
            "boundary sampled on another domain"
        );
        self.advector.set_solid(&boundary.solid());
        let exact = boundary.options().method == ObstacleMethod::Exact;
        self.obstacle_projection =
            exact.then(|| ObstacleProjection::new(boundary.open_faces(), TOLERANCE));
        if exact {
            let walls = Arc::new(boundary.wall_stop());
            for gas in &mut self.gases {
                gas.model.set_walls(&walls);
            }
        }
        self.boundary = Some(boundary);
        self
    }

    /// Iterations and relative residual of the last obstacle-aware solve (exact
    /// obstacles only).
    pub fn cg_report(&self) -> Option<CgReport> {
        self.obstacle_projection.as_ref().map(|c| c.report())
    }

    /// The advection state of the last step (e.g. its QUICK sub-step count).
    pub fn advector(&self) -> &Advector {
        &self.advector
    }

    /// The grid everything lives on.
    pub fn domain(&self) -> &Domain {
        self.velocity.domain()
    }

    /// Simulated time.
    pub fn time(&self) -> f32 {
        self.step_index as f32 * self.params.dt
    }

    /// One time step: eqs 6.4, 6.5, the projection (6.3) and the boundary
    /// rule (6.6/6.7), each stage's wall time in [`Self::times`]. A
    /// prescribed velocity ([`Self::with_prescribed_velocity`]) is set on
    /// the faces instead of being forced and projected, and the gases'
    /// [`Gas::density`] is left for [`Self::evaluate_densities`] to update
    /// when it is read.
    ///
    /// # Errors
    /// A [`StepError`]: the parameters fail [`StepParams::check`], or a
    /// QUICK step would break its CFL bound and may not be split into
    /// sub-steps; the state is then unchanged.
    pub fn try_step(&mut self) -> Result<(), StepError> {
        self.params.check()?;
        let mut t = StageTimes::default();
        if let Some(flow) = &self.prescribed {
            let time = (self.step_index as f32 + 0.5) * self.params.dt;
            self.velocity.write_field(&AtTime(&**flow, time));
        }
        timed(&mut t.advect, || self.advect())?;
        timed(&mut t.inject, || self.inject());
        timed(&mut t.boundary, || self.clear_dry());
        if self.prescribed.is_none() {
            timed(&mut t.density, || self.evaluate_densities());
            timed(&mut t.force, || {
                self.add_buoyancy();
                self.add_confinement();
            });
            timed(&mut t.project, || self.project())?;
            timed(&mut t.boundary, || self.apply_boundary());
        }
        self.step_index += 1;
        self.times = t;
        Ok(())
    }

    /// [`Self::try_step`] for callers that cannot recover from a refused step.
    ///
    /// # Panics
    /// With the [`StepError`] message if the step is refused.
    pub fn step(&mut self) {
        if let Err(e) = self.try_step() {
            panic!("step {}: {e}", self.step_index + 1);
        }
    }

    /// Eqs 6.4–6.5, transport: every gas and the velocity itself moved by
    /// the velocity of the start of the step. Gridded densities and the
    /// velocity go through the [`Advector`] together (semi-Lagrangian:
    /// `ρ ← ρ(x − uΔt)`, `u ← u(x − uΔt)` sharing one backtrace per cell;
    /// QUICK: finite volumes through the same frozen face velocities), the
    /// densities into their targets, which [`Self::inject`] takes; gridless
    /// densities keep a shared snapshot of the velocity (eq 7.4) and SELMA
    /// advects one map for all its gases (eq 8.8), both with the
    /// semi-Lagrangian backtrace whatever the scheme
    /// ([`DensityModel::advect_all`]). A prescribed velocity stays the one
    /// the step moved the gases by.
    ///
    /// # Errors
    /// As [`Advector::advect`]; nothing is changed then.
    pub fn advect(&mut self) -> Result<(), CflError> {
        let p = self.params;
        self.velocity.set_interpolant(p.interpolant);
        self.velocity_scratch.set_interpolant(p.interpolant);
        let snapshot = self
            .gases
            .iter()
            .any(|g| g.model.keeps_velocity())
            .then(|| Arc::new(self.velocity.clone()));
        let (srcs, mut dsts): (Vec<&ScalarGrid>, Vec<&mut ScalarGrid>) = self
            .gases
            .iter_mut()
            .filter_map(|g| g.model.advection_pair())
            .unzip();
        self.advector.advect(
            &self.velocity,
            p.dt,
            &srcs,
            &mut dsts,
            &mut self.velocity_scratch,
        )?;
        let input = StepInput {
            velocity: &self.velocity,
            snapshot: snapshot.as_ref(),
            dt: p.dt,
            backtrace: p.backtrace,
        };
        DensityModel::advect_all(self.gases.iter_mut().map(|g| &mut g.model), &input);
        if self.prescribed.is_none() {
            std::mem::swap(&mut self.velocity, &mut self.velocity_scratch);
        }
        Ok(())
    }

    /// Eq 6.4's `+ inject(source, dt)`, after [`Self::advect`]
    /// ([`DensityModel::inject_all`]): a gridded gas adds `S̄ Δt` to its
    /// advected density in one pass that also sums the advected and the new
    /// totals, which close its [`MassBudget`]'s advection term (the total
    /// before, unchanged by the advection into the target, less the
    /// advected one); a gridless gas's walk integrates its source (eq 7.4);
    /// SELMA injects in reference coordinates and re-anchors.
    pub fn inject(&mut self) {
        let before: Vec<Option<f64>> = self.gases.iter().map(|g| g.model.gridded_total()).collect();
        let advected = DensityModel::inject_all(
            self.gases.iter_mut().map(|g| (&mut g.model, &g.source)),
            self.params.dt,
        );
        for ((gas, before), advected) in self.gases.iter_mut().zip(before).zip(advected) {
            if let (Some(before), Some(advected)) = (before, advected) {
                gas.budget.advection += advected - before;
            }
        }
    }

    /// With exact obstacles, a gridded density holds nothing in the dry
    /// cells ([`crate::boundary::OpenFaces::clear_dry`]): what a backtrace
    /// carried there is lost, and counted so by the retained mass and the
    /// [`MassBudget`]'s cleared term. Gridless and SELMA densities are zero
    /// inside the walls by construction.
    pub fn clear_dry(&mut self) {
        let Some(faces) = (self.obstacle_projection.is_some())
            .then(|| self.boundary.as_ref().map(|b| b.open_faces()))
            .flatten()
        else {
            return;
        };
        for gas in &mut self.gases {
            if let Some(kept) = gas.model.gridded_total() {
                let rho = gas.model.gridded_mut().expect("a gridded gas");
                faces.clear_dry(rho.as_slice_mut());
                gas.budget.cleared += rho.total() - kept;
            }
        }
    }

    /// Evaluate gridless and SELMA densities at the cell centres, the input
    /// of the buoyancy force and what [`Gas::density`] reads (gridded
    /// densities already live there); the gridless gases walk back once for
    /// all ([`DensityModel::evaluate_all`]). Nothing to do for a gas
    /// evaluated since its last step.
    pub fn evaluate_densities(&mut self) {
        DensityModel::evaluate_all(self.gases.iter_mut().map(|g| &mut g.model));
    }

    /// Bytes held by the density representations of all gases, each shared
    /// buffer (a gridless velocity grid) counted once.
    pub fn density_bytes(&self) -> usize {
        total_bytes(self.gases.iter().flat_map(|g| g.model.buffers()))
    }

    /// Eq 6.5, force: `u += −Δt g⃗ Σ lift·ρ` — with hot lift +1 and cold −1
    /// this is the notes' `dt*gravity*(cold − hot)` — each face getting the
    /// mean of the two cells it separates ([`crate::forces::add_buoyancy`]).
    pub fn add_buoyancy(&mut self) {
        let p = self.params;
        let gases: Vec<_> = self.gases.iter().map(|g| (g.density(), g.lift)).collect();
        forces::add_buoyancy(&mut self.velocity, p.dt, p.gravity, &gases);
    }

    /// Vorticity confinement with the buoyancy, in the force verb: `u +=
    /// Δt ε Δx (N × ω)` on the faces (Fedkiw, Stam & Jensen 2001, eqs 9–11;
    /// [`Confinement::add`]), none on the faces obstacles close. Nothing
    /// is done at `ε = 0`, the default.
    pub fn add_confinement(&mut self) {
        let p = self.params;
        let open = self
            .boundary
            .as_ref()
            .map(|b| b.open_faces())
            .map(|o| [o.open(0), o.open(1), o.open(2)]);
        self.confinement
            .add(&mut self.velocity, p.dt, p.confinement, open);
    }

    /// Eq 6.3: make the velocity exactly (discretely) divergence-free with
    /// the pressure solve, after diffusing it exactly if ν > 0 (the two
    /// commute, [`crate::pressure`]). With exact obstacles the solve is the
    /// obstacle-aware one (the viscosity still ignores obstacles).
    ///
    /// # Errors
    /// If the viscosity or Δt is negative or not finite; nothing is changed
    /// then.
    pub fn project(&mut self) -> Result<(), InputError> {
        let p = self.params;
        self.pressure
            .diffuse(&mut self.velocity, p.viscosity, p.dt)?;
        match (&mut self.obstacle_projection, &self.boundary) {
            (Some(c), Some(b)) => {
                c.project(&mut self.velocity, b.open_faces(), &mut self.pressure);
            }
            _ => self.pressure.project(&mut self.velocity),
        }
        Ok(())
    }

    /// What changes as the simulation steps — the step count, the velocity,
    /// every gas's density state and mass budget, and the warm starts of
    /// the obstacle solves — for a checkpoint. Everything else (sources,
    /// obstacles, transform plans, scratch buffers) is rebuilt from the
    /// configuration and overwritten before it is read.
    pub fn state(&self) -> SimulationState {
        SimulationState {
            step_index: self.step_index,
            velocity: self.velocity.clone(),
            gases: self
                .gases
                .iter()
                .map(|g| (g.budget, g.model.state()))
                .collect(),
            obstacle_pressure: (self.obstacle_projection.as_ref()).map(|c| c.pressure().to_vec()),
            face_potential: match &self.advector {
                Advector::Quick { quick, .. } => quick.warm_start().map(<[f32]>::to_vec),
                Advector::SemiLagrangian { .. } | Advector::MacCormack(_) => None,
            },
        }
    }

    /// Put back a [`Self::state`] of a simulation built from the same
    /// configuration: stepping on then reproduces the original run bitwise.
    ///
    /// # Errors
    /// If the state does not fit this simulation (grid sizes, gases, modes).
    pub fn restore(&mut self, state: SimulationState) -> Result<(), InputError> {
        let v = &state.velocity;
        if v.domain() != self.domain()
            || v.kind() != self.velocity.kind()
            || state.gases.len() != self.gases.len()
        {
            return Err(InputError::new(
                "the state's grid or gases differ from the configuration's",
            ));
        }
        let misfit =
            || InputError::new("the state's obstacle solves differ from the configuration's");
        let pressure_fits = match (&mut self.obstacle_projection, &state.obstacle_pressure) {
            (Some(c), Some(p)) => c.set_pressure(p),
            (c, p) => c.is_none() && p.is_none(),
        };
        let potential_fits = match (&mut self.advector, &state.face_potential) {
            (Advector::Quick { quick, .. }, Some(p)) => quick.set_warm_start(p),
            (Advector::Quick { quick, .. }, None) => quick.warm_start().is_none(),
            (Advector::SemiLagrangian { .. } | Advector::MacCormack(_), p) => p.is_none(),
        };
        if !(pressure_fits && potential_fits) {
            return Err(misfit());
        }
        // A SELMA gas sharing a map needs an earlier SELMA gas owning one.
        let first_selma = state.gases.iter().find_map(|(_, d)| match d {
            DensityState::Selma(s) => Some(s.map.is_some()),
            _ => None,
        });
        if first_selma == Some(false) {
            return Err(InputError::new(
                "the state's first SELMA gas shares a map no earlier gas owns",
            ));
        }
        for (gas, (budget, density)) in self.gases.iter_mut().zip(state.gases) {
            gas.model.restore(density)?;
            gas.budget = budget;
        }
        self.velocity = state.velocity.with_interpolant(self.params.interpolant);
        self.step_index = state.step_index;
        Ok(())
    }

    /// The obstacles' closed faces. Exact method: surface faces set to zero
    /// and the α-scaled velocity extended into the walls
    /// ([`crate::boundary::OpenFaces::extend`]). Notes' method: eqs 6.6/6.7,
    /// alternated with the (periodic) projection [`Boundary::passes`] times
    /// and ending with the rule; the divergence it leaves near obstacles is
    /// what `metrics.csv` reports.
    pub fn apply_boundary(&mut self) {
        let Some(b) = &self.boundary else { return };
        if self.obstacle_projection.is_some() {
            b.open_faces()
                .extend(&mut self.velocity, b.options().retained());
            return;
        }
        b.apply(&mut self.velocity);
        for _ in 1..b.passes() {
            self.pressure.project(&mut self.velocity);
            b.apply(&mut self.velocity);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops;

    /// A step with a negative viscosity is refused with an error naming the
    /// value (the projection used to panic on it, after the gases had
    /// moved), and the state is unchanged; with ν fixed the same simulation
    /// steps on.
    #[test]
    fn a_negative_viscosity_is_refused_before_anything_moves() {
        let domain = Domain::new(Vec3::ZERO, 1.0, [8, 8, 8]).unwrap();
        let source = ops::mask(ops::sphere(Vec3::splat(4.0), 2.0));
        let params = StepParams {
            dt: 0.1,
            viscosity: -1.0,
            gravity: Vec3::new(0.0, -1.0, 0.0),
            backtrace: Backtrace::Rk2,
            interpolant: Interpolant::Trilinear,
            confinement: 0.0,
        };
        let gas = Gas::new("hot", domain, &source, 1.0);
        let mut sim = Simulation::new(domain, params, vec![gas]);
        let err = sim.try_step().unwrap_err();
        assert!(matches!(err, StepError::Params(_)), "{err:?}");
        assert!(err.to_string().contains("viscosity is -1"), "{err}");
        assert_eq!(sim.step_index, 0);
        assert_eq!(sim.gases[0].density().total(), 0.0);
        sim.params.viscosity = 0.0;
        sim.try_step().unwrap();
        assert_eq!(sim.step_index, 1);
        assert!(sim.gases[0].density().total() > 0.0);
    }

    /// Confinement in the force verb: ε = 0 gives the step of a simulation
    /// that never heard of it, bit for bit; ε > 0 changes the velocity and
    /// keeps it divergence-free (the force comes before the projection); a
    /// negative ε is refused before anything moves.
    #[test]
    fn confinement_is_a_force_before_the_projection() {
        let domain = Domain::new(Vec3::ZERO, 1.0, [12, 12, 12]).unwrap();
        let source = ops::mask(ops::sphere(Vec3::new(6.0, 3.0, 6.0), 2.0));
        let params = |confinement| StepParams {
            dt: 0.2,
            viscosity: 0.0,
            gravity: Vec3::new(0.0, -1.0, 0.0),
            backtrace: Backtrace::Rk2,
            confinement,
            interpolant: Interpolant::Trilinear,
        };
        let run = |confinement: f32, steps: usize| {
            let gas = Gas::new("hot", domain, &source, 1.0);
            let mut sim = Simulation::new(domain, params(confinement), vec![gas]);
            for _ in 0..steps {
                sim.try_step().unwrap();
            }
            sim
        };
        let plain = run(0.0, 6);
        let off = run(0.0, 6);
        let on = run(0.5, 6);
        let bits = |s: &Simulation| -> Vec<u32> {
            (0..3)
                .flat_map(|a| {
                    s.velocity
                        .slice(a)
                        .iter()
                        .map(|v| v.to_bits())
                        .collect::<Vec<_>>()
                })
                .collect()
        };
        assert_eq!(bits(&plain), bits(&off));
        assert_ne!(bits(&plain), bits(&on));
        let mut div = ScalarGrid::zeros(domain);
        on.velocity.divergence(&mut div);
        let worst = div.as_slice().iter().fold(0.0f32, |m, d| m.max(d.abs()));
        assert!(worst < 1e-5 * on.velocity.max_norm(), "max|D u| {worst}");
        let mut bad = run(0.0, 0);
        bad.params.confinement = -0.1;
        let err = bad.try_step().unwrap_err();
        assert!(err.to_string().contains("confinement is -0.1"), "{err}");
        assert_eq!(bad.step_index, 0);
    }
}
