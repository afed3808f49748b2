//! Grid-to-grid advection schemes.
//!
//! [`semi_lagrangian`] implements eqs 6.4–6.5 of the notes: the new value at a
//! cell centre is the old field interpolated at the point the flow brings
//! there, `q(x, t+Δt) = q(x − u Δt, t)`. Later schemes (QUICK) sit beside it
//! and are chosen by [`Scheme`].

pub mod semi_lagrangian;

use serde::{Deserialize, Serialize};

pub use semi_lagrangian::{
    advect_scalar, advect_vector, departure_point, interpolate_scalar, interpolate_vector,
    Departures,
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
}

impl Scheme {
    /// Every variant, for tests and listings.
    pub const ALL: [Scheme; 1] = [Scheme::Sl];
}
