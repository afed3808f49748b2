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
//! [`Simulation::step`] is exactly those four lines: [`Simulation::advect_densities`],
//! [`Simulation::advect_velocity`], [`Simulation::add_buoyancy`] and
//! [`Simulation::project`] — plus, for gridless and SELMA densities
//! ([`crate::density`]), [`Simulation::evaluate_densities`], which samples
//! them at the cell centres for the buoyancy force. The departure points of the step are traced once
//! (all quantities move with the same velocity) and shared by every
//! interpolation. Every buffer is allocated once in [`Simulation::new`]; a
//! step allocates nothing but the projection's per-task scratch.

use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;

use crate::advection::{self, Backtrace, Departures};
use crate::density::{total_bytes, DensityModel, DensityOptions, StepInput};
use crate::domain::Domain;
use crate::field::Scalar;
use crate::grid::{ScalarGrid, VectorGrid};
use crate::projection::Projection;
use crate::timing::{timed, StageTimes};

/// One buoyant gas: its density, where it is injected, and how it lifts.
#[derive(Clone)]
pub struct Gas {
    /// Name used for output files (`<name>_NNNN.npy`).
    pub name: String,
    /// How the density is held (gridded, gridless or SELMA).
    pub model: DensityModel,
    /// Injection rate S(x) sampled on the grid (the notes' `inject` without Δt).
    pub source: ScalarGrid,
    /// Injection rate S(x) as a field, for the modes that query it anywhere.
    pub source_field: Scalar,
    /// Buoyancy coefficient: the force is `−g⃗ · lift · ρ`, so +1 rises (hot) and −1 sinks (cold).
    pub lift: f32,
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
            source: ScalarGrid::from_field(domain, &**source),
            source_field: source.clone(),
            lift,
        }
    }

    /// The density at the velocity grid's cell centres after the last step.
    pub fn density(&self) -> &ScalarGrid {
        self.model.density()
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
///
/// A clone copies every grid but shares a gridless density's stored
/// velocity grids (immutable, [`Arc`]): the clone and the original step on
/// independently (benchmarks time one step of a warmed clone).
#[derive(Clone)]
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
    departures: Departures,
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
            departures: Departures::new(domain),
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
        timed(&mut times.advect, || self.trace_departures());
        timed(&mut times.advect, || self.advect_densities());
        timed(&mut times.advect, || self.advect_velocity());
        timed(&mut times.density, || self.evaluate_densities());
        timed(&mut times.force, || self.add_buoyancy());
        timed(&mut times.project, || self.project());
        self.step_index += 1;
        self.times = times;
    }

    /// The departure points `x − ∫u dt` of every cell for this step.
    pub fn trace_departures(&mut self) {
        let p = self.params;
        self.departures.trace(&self.velocity, p.dt, p.backtrace);
    }

    /// Eq 6.4: `ρ ← ρ(x − uΔt) + S Δt` for every gas, in its own
    /// representation (gridded: eq 6.4 on the grid; gridless: keep the
    /// velocity, eq 7.4; SELMA: advect the map, eq 8.8).
    pub fn advect_densities(&mut self) {
        let p = self.params;
        let snapshot = self
            .gases
            .iter()
            .any(|g| g.model.keeps_velocity())
            .then(|| Arc::new(self.velocity.clone()));
        let input = StepInput {
            velocity: &self.velocity,
            snapshot: snapshot.as_ref(),
            departures: &self.departures,
            dt: p.dt,
            backtrace: p.backtrace,
        };
        for gas in &mut self.gases {
            gas.model.step(&input, &gas.source);
        }
    }

    /// Evaluate gridless and SELMA densities at the cell centres, the input
    /// of the buoyancy force (gridded densities already live there).
    pub fn evaluate_densities(&mut self) {
        for gas in &mut self.gases {
            gas.model.evaluate_centres();
        }
    }

    /// Bytes held by the density representations of all gases, each shared
    /// buffer (a gridless velocity grid) counted once.
    pub fn density_bytes(&self) -> usize {
        total_bytes(self.gases.iter().flat_map(|g| g.model.buffers()))
    }

    /// Eq 6.5, first term: `u ← u(x − uΔt)`.
    pub fn advect_velocity(&mut self) {
        advection::interpolate_vector(&self.velocity, &self.departures, &mut self.velocity_scratch);
        std::mem::swap(&mut self.velocity, &mut self.velocity_scratch);
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
                        lift += g.lift * g.density().as_slice()[base + n];
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
