//! Grid-to-grid advection schemes.
//!
//! - [`semi_lagrangian`] implements eqs 6.4–6.5 of the notes: the new value at
//!   a cell centre is the old field interpolated at the point the flow brings
//!   there, `q(x, t+Δt) = q(x − u Δt, t)`. Unconditionally stable, dissipative.
//! - [`quick`] is the notes' other scheme (ch. 6 introduction): flux-form
//!   finite volumes with Leonard's quadratic upwind face values, SSP-RK3 in
//!   time, automatic CFL sub-steps, and an optional ULTIMATE limiter.
//!
//! [`Scheme`] chooses between them; an [`Advector`] holds the chosen scheme's
//! per-step state (departure points or frozen face velocities) so that every
//! density and the velocity itself move through the same prepared step.

mod closed_faces;
mod lattice;
pub mod quick;
pub mod semi_lagrangian;

use serde::{Deserialize, Serialize};

use crate::domain::Domain;
use crate::grid::{ScalarGrid, VectorGrid};
pub use quick::{CflError, Limiter, Quick, QuickOptions};
pub use semi_lagrangian::{
    advect_scalar, advect_vector, interpolate_scalar, interpolate_vector, Departures,
};

/// How the departure point `x − ∫u dt` of a semi-Lagrangian step is traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Backtrace {
    /// One Euler step, `x − Δt u(x)`: first order in Δt.
    Euler,
    /// Midpoint rule, `x − Δt u(x − ½Δt u(x))`: second order in Δt.
    #[default]
    Rk2,
    /// Kutta's third-order rule.
    Rk3,
}

impl Backtrace {
    /// Every variant, for tests and listings.
    pub const ALL: [Backtrace; 3] = [Backtrace::Euler, Backtrace::Rk2, Backtrace::Rk3];
}

/// The advection scheme for velocity and densities.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Scheme {
    /// Semi-Lagrangian with trilinear interpolation (eqs 6.4–6.5).
    #[default]
    Sl,
    /// QUICK finite volumes with SSP-RK3 and CFL sub-steps ([`quick`]).
    Quick,
}

impl Scheme {
    /// Every variant, for tests and listings.
    pub const ALL: [Scheme; 2] = [Scheme::Sl, Scheme::Quick];
}

/// Everything that selects and tunes the advection of a simulation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdvectionOptions {
    /// Scheme for velocity and densities alike.
    pub scheme: Scheme,
    /// QUICK sub-stepping (QUICK only).
    pub quick: QuickOptions,
    /// QUICK limiter for densities (QUICK only; the velocity is never limited).
    pub density_limiter: Limiter,
}

impl Default for AdvectionOptions {
    fn default() -> Self {
        Self {
            scheme: Scheme::Sl,
            quick: QuickOptions::default(),
            density_limiter: Limiter::Ultimate,
        }
    }
}

/// The per-step state of the chosen scheme: [`Advector::prepare`] once per
/// step with the advecting velocity, then move any number of densities and
/// the velocity through that step.
pub enum Advector {
    /// Semi-Lagrangian: departure points traced once per step.
    SemiLagrangian {
        /// Departure points of the prepared step.
        departures: Departures,
        /// How they are traced.
        backtrace: Backtrace,
    },
    /// QUICK: face velocities frozen once per step.
    Quick {
        /// Face velocities, sub-step count and scratch.
        quick: Box<Quick>,
        /// Limiter applied to densities.
        density_limiter: Limiter,
    },
}

impl Advector {
    /// State for `options.scheme` on `domain`; SL traces with `backtrace`.
    pub fn new(domain: Domain, options: &AdvectionOptions, backtrace: Backtrace) -> Self {
        match options.scheme {
            Scheme::Sl => Advector::SemiLagrangian {
                departures: Departures::new(domain),
                backtrace,
            },
            Scheme::Quick => Advector::Quick {
                quick: Box::new(Quick::new(domain, options.quick)),
                density_limiter: options.density_limiter,
            },
        }
    }

    /// Prepare a step of `dt` through `vel` (trace departures, or freeze face
    /// velocities and choose sub-steps).
    ///
    /// # Errors
    /// QUICK's [`CflError`]; the semi-Lagrangian scheme never fails.
    pub fn prepare(&mut self, vel: &VectorGrid, dt: f32) -> Result<(), CflError> {
        match self {
            Advector::SemiLagrangian {
                departures,
                backtrace,
            } => {
                departures.trace(vel, dt, *backtrace);
                Ok(())
            }
            Advector::Quick { quick, .. } => quick.prepare(vel, dt).map(|_| ()),
        }
    }

    /// Mark obstacle cells. QUICK closes every face touching one (no flux
    /// into or out of obstacles); the semi-Lagrangian scheme, as in the notes,
    /// keeps interpolating across obstacles and relies on the boundary rule.
    pub fn set_solid(&mut self, solid: &[bool]) {
        if let Advector::Quick { quick, .. } = self {
            quick.set_solid(solid);
        }
    }

    /// QUICK's open-face projection of the prepared step around obstacles:
    /// conjugate-gradient iterations and the remaining cell divergence
    /// relative to the largest face Courant number (`None` for SL or without obstacles).
    pub fn face_projection_stats(&self) -> Option<(usize, f32)> {
        match self {
            Advector::SemiLagrangian { .. } => None,
            Advector::Quick { quick, .. } => quick.face_projection_stats(),
        }
    }

    /// Sub-steps of the prepared step (always 1 for SL).
    pub fn substeps(&self) -> usize {
        match self {
            Advector::SemiLagrangian { .. } => 1,
            Advector::Quick { quick, .. } => quick.substeps(),
        }
    }

    /// Move a density through the prepared step (eq 6.4 without the source).
    pub fn density(&mut self, src: &ScalarGrid, dst: &mut ScalarGrid) {
        match self {
            Advector::SemiLagrangian { departures, .. } => interpolate_scalar(src, departures, dst),
            Advector::Quick {
                quick,
                density_limiter,
            } => quick.advect_scalar(src, dst, *density_limiter),
        }
    }

    /// Move a vector grid (the velocity itself, eq 6.5) through the prepared step.
    pub fn vector(&mut self, src: &VectorGrid, dst: &mut VectorGrid) {
        match self {
            Advector::SemiLagrangian { departures, .. } => interpolate_vector(src, departures, dst),
            Advector::Quick { quick, .. } => quick.advect_vector(src, dst, Limiter::None),
        }
    }
}
