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
//! [`Simulation::step`] is those lines in four verbs: [`Simulation::advect`]
//! (every `advect(…, velocity, dt)` above, in one sweep that traces each
//! departure point once), [`Simulation::inject_sources`],
//! [`Simulation::add_buoyancy`] and [`Simulation::project`]. The densities
//! are advected by the velocity of the start of the step, as in the script.
//! Every buffer is allocated once in [`Simulation::new`].

use glam::Vec3;
use rayon::prelude::*;

use crate::advection::{self, Backtrace};
use crate::domain::Domain;
use crate::field::Scalar;
use crate::grid::{ScalarGrid, VectorGrid};
use crate::projection::Projection;
use crate::timing::{timed, StageTimes};

/// One buoyant gas: its density, where it is injected, and how it lifts.
pub struct Gas {
    /// Name used for output files (`<name>_NNNN.npy`).
    pub name: String,
    /// Density on the velocity grid.
    pub density: ScalarGrid,
    /// Injection rate S(x) sampled on the grid (the notes' `inject` without Δt).
    pub source: ScalarGrid,
    /// Buoyancy coefficient: the force is `−g⃗ · lift · ρ`, so +1 rises (hot) and −1 sinks (cold).
    pub lift: f32,
    /// Scratch for the advected density.
    scratch: ScalarGrid,
}

impl Gas {
    /// A gas starting empty, injected at rate `source(x)` per unit time.
    pub fn new(name: impl Into<String>, domain: Domain, source: &Scalar, lift: f32) -> Self {
        Self {
            name: name.into(),
            density: ScalarGrid::zeros(domain),
            source: ScalarGrid::from_field(domain, &**source),
            lift,
            scratch: ScalarGrid::zeros(domain),
        }
    }

    /// Mass injected per step, `Σ S Δt Δx³`, as sampled on the grid.
    pub fn injected_per_step(&self, dt: f32) -> f64 {
        self.source.total() * dt as f64
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
}

/// Velocity, gases and the planned projection for one run.
pub struct Simulation {
    /// Parameters of every step.
    pub params: StepParams,
    /// Velocity at cell centres, divergence-free after each step.
    pub velocity: VectorGrid,
    /// The gases, advected and injected every step.
    pub gases: Vec<Gas>,
    /// Steps taken.
    pub step_index: usize,
    /// Wall time per stage of the last step.
    pub times: StageTimes,
    velocity_scratch: VectorGrid,
    projection: Projection,
}

impl Simulation {
    /// A fluid at rest on `domain` carrying `gases`.
    pub fn new(domain: Domain, params: StepParams, gases: Vec<Gas>) -> Self {
        Self {
            params,
            velocity: VectorGrid::zeros(domain),
            gases,
            step_index: 0,
            times: StageTimes::default(),
            velocity_scratch: VectorGrid::zeros(domain),
            projection: Projection::new(domain),
        }
    }

    /// The grid everything lives on.
    pub fn domain(&self) -> &Domain {
        self.velocity.domain()
    }

    /// Simulated time.
    pub fn time(&self) -> f32 {
        self.step_index as f32 * self.params.dt
    }

    /// One time step: eqs 6.4, 6.5 and the projection (6.3).
    pub fn step(&mut self) {
        let mut times = StageTimes::default();
        timed(&mut times.advect, || self.advect());
        timed(&mut times.force, || self.inject_sources());
        timed(&mut times.force, || self.add_buoyancy());
        timed(&mut times.project, || self.project());
        self.step_index += 1;
        self.times = times;
    }

    /// Eqs 6.4–6.5, transport: `ρ ← ρ(x − uΔt)` for every gas and
    /// `u ← u(x − uΔt)`, sharing one backtrace per cell.
    pub fn advect(&mut self) {
        let p = self.params;
        let (srcs, mut dsts): (Vec<&ScalarGrid>, Vec<&mut ScalarGrid>) = self
            .gases
            .iter_mut()
            .map(|g| (&g.density, &mut g.scratch))
            .unzip();
        advection::advect_fused(
            &self.velocity,
            p.dt,
            p.backtrace,
            &srcs,
            &mut dsts,
            &mut self.velocity_scratch,
        );
        std::mem::swap(&mut self.velocity, &mut self.velocity_scratch);
        for gas in &mut self.gases {
            std::mem::swap(&mut gas.density, &mut gas.scratch);
        }
    }

    /// Eq 6.4, source: `ρ += S Δt` (the notes' `inject(point, dt)`).
    pub fn inject_sources(&mut self) {
        let dt = self.params.dt;
        for gas in &mut self.gases {
            gas.density
                .as_slice_mut()
                .par_iter_mut()
                .zip(gas.source.as_slice().par_iter())
                .for_each(|(rho, s)| *rho += s * dt);
        }
    }

    /// Eq 6.5, force: `u += −Δt g⃗ Σ lift·ρ` — with hot lift +1 and cold −1
    /// this is the notes' `dt*gravity*(cold − hot)`.
    pub fn add_buoyancy(&mut self) {
        let p = self.params;
        let gases = &self.gases;
        let slab = self.domain().dims[0] * self.domain().dims[1];
        self.velocity
            .as_vec3_mut()
            .par_chunks_mut(slab)
            .enumerate()
            .for_each(|(k, u)| {
                let base = k * slab;
                for (n, un) in u.iter_mut().enumerate() {
                    let mut lift = 0.0;
                    for g in gases {
                        lift += g.lift * g.density.as_slice()[base + n];
                    }
                    *un -= p.dt * lift * p.gravity;
                }
            });
    }

    /// Eq 6.3: make the velocity divergence-free (and diffuse it if ν > 0).
    pub fn project(&mut self) {
        let p = self.params;
        self.projection
            .project(&mut self.velocity, p.viscosity, p.dt);
    }
}
