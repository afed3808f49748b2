//! Grid-to-grid advection schemes.
//!
//! - [`semi_lagrangian`] implements eqs 6.4–6.5 of the notes: the new value at
//!   a cell centre is the old field interpolated at the point the flow brings
//!   there, `q(x, t+Δt) = q(x − u Δt, t)`. Unconditionally stable, dissipative.
//! - [`quick`] is the notes' other scheme (ch. 6 introduction): flux-form
//!   finite volumes with Leonard's quadratic upwind face values, SSP-RK3 in
//!   time, automatic CFL sub-steps, and an optional ULTIMATE limiter.
//! - [`maccormack`] is Selle et al.'s (2008) MacCormack scheme on top of the
//!   semi-Lagrangian steps: a forward and a backward step, half their round
//!   trip's error taken off, clamped to the forward stencil's range — second
//!   order in smooth flow, the stronger gridded baseline; BFECC (Dupont &
//!   Liu 2003) is the same round trip correcting the source instead, with
//!   a third SL step.
//!
//! [`Scheme`] chooses between them; an [`Advector`] holds the chosen scheme's
//! per-step state (departure points or frozen face velocities) so that every
//! density and the velocity itself move through the same prepared step.

mod closed_faces;
pub(crate) mod kernel;
mod lattice;
pub mod maccormack;
mod pollock;
pub mod quick;
pub mod semi_lagrangian;

use serde::{Deserialize, Serialize};

use crate::domain::Domain;
use crate::grid::{FaceGrid, ScalarGrid};
pub use maccormack::{
    bfecc_scalar, corrected_faces, corrected_scalar, maccormack_faces, maccormack_scalar,
    Correction, MacCormack,
};
pub use quick::{CflError, Limiter, Quick, QuickOptions};
pub(crate) use semi_lagrangian::departure_points_wrapped;
pub use semi_lagrangian::{
    advect_faces, advect_fused, advect_scalar, departure_point, departure_points,
    interpolate_scalar, sample_face_grid_points, sample_face_points, Departures,
};

/// How the departure point `x − ∫u dt` of a semi-Lagrangian step is traced.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Backtrace {
    /// One Euler step, `x − Δt u(x)`: first order in Δt.
    Euler,
    /// Midpoint rule, `x − d(x)` with `d(x) = Δt u(x − ½Δt u(x))`: second
    /// order in Δt. At the cell centres (the densities, the gridless and
    /// SELMA walks, any point) exactly that; the velocity's own faces, in
    /// the grid sweeps, take the mean of the displacements of the two
    /// cells each face separates, `x_f − ½(d(x_lo) + d(x_hi))` (a wall
    /// face its one cell's), which differs from `d(x_f)` by O(Δx²): one
    /// trace per cell shared by the cells and the faces.
    #[default]
    Rk2,
    /// Kutta's third-order rule.
    Rk3,
    /// The exact path through the RT0 velocity, cell by cell in closed
    /// form (Pollock 1988, module `pollock`): volume-preserving, and it never
    /// crosses a face of zero flux. Needs `interpolant = rt0`
    /// (`SolverConfig::validate`); every instruction set runs it as scalar
    /// code.
    Exact,
}

impl Backtrace {
    /// The time integrators, which follow any interpolant with a path
    /// error of their [`Self::order`] in Δt (convergence studies).
    pub const INTEGRATORS: [Backtrace; 3] = [Backtrace::Euler, Backtrace::Rk2, Backtrace::Rk3];

    /// Every variant, for tests and listings.
    pub const ALL: [Backtrace; 4] = [
        Backtrace::Euler,
        Backtrace::Rk2,
        Backtrace::Rk3,
        Backtrace::Exact,
    ];

    /// The name on the command line and in configurations.
    pub fn name(self) -> &'static str {
        match self {
            Backtrace::Euler => "euler",
            Backtrace::Rk2 => "rk2",
            Backtrace::Rk3 => "rk3",
            Backtrace::Exact => "exact",
        }
    }

    /// The order in Δt of a time integrator's path error; `None` for
    /// [`Backtrace::Exact`], whose path through the RT0 velocity has none.
    pub fn order(self) -> Option<u32> {
        match self {
            Backtrace::Euler => Some(1),
            Backtrace::Rk2 => Some(2),
            Backtrace::Rk3 => Some(3),
            Backtrace::Exact => None,
        }
    }
}

/// The advection scheme for velocity and densities.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Scheme {
    /// Semi-Lagrangian with trilinear interpolation (eqs 6.4–6.5).
    #[default]
    Sl,
    /// QUICK finite volumes with SSP-RK3 and CFL sub-steps.
    Quick,
    /// MacCormack (Selle et al. 2008) on the semi-Lagrangian steps, with
    /// the min/max clamp.
    #[serde(rename = "maccormack")]
    #[cfg_attr(feature = "clap", value(name = "maccormack"))]
    MacCormack,
    /// BFECC (Dupont & Liu 2003; Kim et al. 2005): the round trip's error
    /// corrects the source, stepped once more; MacCormack's clamp.
    Bfecc,
}

impl Scheme {
    /// Every variant, for tests and listings.
    pub const ALL: [Scheme; 4] = [Scheme::Sl, Scheme::Quick, Scheme::MacCormack, Scheme::Bfecc];

    /// The name on the command line and in configurations.
    pub fn name(self) -> &'static str {
        match self {
            Scheme::Sl => "sl",
            Scheme::Quick => "quick",
            Scheme::MacCormack => "maccormack",
            Scheme::Bfecc => "bfecc",
        }
    }
}

impl std::fmt::Display for Scheme {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
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

/// The chosen scheme and its per-step state: [`Advector::advect`] moves any
/// number of densities and the velocity itself through one step, all by the
/// velocity of the start of the step.
#[derive(Clone)]
pub enum Advector {
    /// Semi-Lagrangian: one fused sweep tracing each departure point once.
    SemiLagrangian {
        /// How departure points are traced.
        backtrace: Backtrace,
    },
    /// QUICK: face velocities frozen once per step.
    Quick {
        /// Face velocities, sub-step count and scratch.
        quick: Box<Quick>,
        /// Limiter applied to densities.
        density_limiter: Limiter,
    },
    /// MacCormack or BFECC: forward and backward semi-Lagrangian steps,
    /// corrected and clamped; its scratch kept between steps.
    MacCormack(Box<MacCormack>),
}

impl Advector {
    /// State for `options.scheme` on `domain`; SL traces with `backtrace`.
    pub fn new(domain: Domain, options: &AdvectionOptions, backtrace: Backtrace) -> Self {
        match options.scheme {
            Scheme::Sl => Advector::SemiLagrangian { backtrace },
            Scheme::Quick => Advector::Quick {
                quick: Box::new(Quick::new(domain, options.quick)),
                density_limiter: options.density_limiter,
            },
            Scheme::MacCormack => Advector::MacCormack(Box::new(MacCormack::new(backtrace))),
            Scheme::Bfecc => Advector::MacCormack(Box::new(MacCormack::with_correction(
                Correction::Bfecc,
                backtrace,
            ))),
        }
    }

    /// Move `srcs[i]` into `dsts[i]` (eq 6.4 without the source) and `vel`
    /// into `vel_out` (eq 6.5 without the force), all through `vel` over `dt`.
    ///
    /// # Errors
    /// QUICK's [`CflError`], before anything is written; the
    /// semi-Lagrangian scheme never fails.
    ///
    /// # Panics
    /// If the grids are on different domains or the slices differ in length.
    pub fn advect(
        &mut self,
        vel: &FaceGrid,
        dt: f32,
        srcs: &[&ScalarGrid],
        dsts: &mut [&mut ScalarGrid],
        vel_out: &mut FaceGrid,
    ) -> Result<(), CflError> {
        match self {
            Advector::SemiLagrangian { backtrace } => {
                advect_fused(vel, dt, *backtrace, srcs, dsts, vel_out);
            }
            Advector::Quick {
                quick,
                density_limiter,
            } => {
                assert_eq!(
                    srcs.len(),
                    dsts.len(),
                    "advect: sources and targets differ in number"
                );
                quick.prepare(vel, dt)?;
                for (src, dst) in srcs.iter().zip(dsts.iter_mut()) {
                    quick.advect_scalar(src, dst, *density_limiter);
                }
                quick.advect_faces(vel, vel_out);
            }
            Advector::MacCormack(mc) => mc.advect(vel, dt, srcs, dsts, vel_out),
        }
        Ok(())
    }

    /// Mark obstacle cells. QUICK closes every face touching one (no flux
    /// into or out of obstacles); the semi-Lagrangian scheme, as in the notes,
    /// keeps interpolating across obstacles and relies on the boundary rule,
    /// and so does MacCormack.
    pub fn set_solid(&mut self, solid: &[bool]) {
        if let Advector::Quick { quick, .. } = self {
            quick.set_solid(solid);
        }
    }

    /// QUICK's open-face projection of the last step around obstacles:
    /// conjugate-gradient iterations and the remaining cell divergence
    /// relative to the largest face Courant number (`None` for SL or without obstacles).
    pub fn face_projection_stats(&self) -> Option<(usize, f32)> {
        match self {
            Advector::SemiLagrangian { .. } | Advector::MacCormack(_) => None,
            Advector::Quick { quick, .. } => quick.face_projection_stats(),
        }
    }

    /// Sub-steps of the last step (always 1 for SL, MacCormack and BFECC).
    pub fn substeps(&self) -> usize {
        match self {
            Advector::SemiLagrangian { .. } | Advector::MacCormack(_) => 1,
            Advector::Quick { quick, .. } => quick.substeps(),
        }
    }
}
