//! The hot/cold scenario of §6.1.1 (figs 6.1–6.2).
//!
//! Two gases in a periodic cube `[0, L]³`: *hot* is injected as a solid sphere
//! (the notes' `inject`) low in the box and rises, *cold* is injected at the
//! mirror image of that point through the mid-plane `y = L/2` and sinks. Both
//! force the velocity through `dt·gravity·(cold − hot)`. Because the cold
//! source is the exact mirror of the hot one and every operator is
//! mirror-symmetric, the discrete problem is symmetric under
//! hot ↔ cold, y ↔ L − y; [`crate::metrics::mirror_error`] measures how well that holds.

use std::path::Path;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::advection::{AdvectionOptions, Backtrace, Limiter, QuickOptions, Scheme};
use crate::domain::Domain;
use crate::error::InputError;
use crate::field::ops;
use crate::simulation::{Gas, Simulation, StepParams};

/// Parameters of a hot/cold run. Every field has a default; a TOML file may
/// set any subset, and unknown keys are an error.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct HotColdConfig {
    /// Cells per axis (the notes use 50).
    pub res: usize,
    /// Edge length L of the cubic box, world units.
    pub size: f32,
    /// Number of time steps (one step per frame).
    pub frames: usize,
    /// Time step Δt.
    pub dt: f32,
    /// Kinematic viscosity ν (0: inviscid, as the notes).
    pub nu: f32,
    /// Magnitude of gravity; g⃗ = (0, −g, 0).
    pub gravity: f32,
    /// Radius of the injection spheres (the notes' unit sphere).
    pub radius: f32,
    /// Centre of the hot source; cold's is its mirror through y = L/2.
    /// Default `(L/2, L/4, L/2)`.
    pub hot_center: Option<[f32; 3]>,
    /// Semi-Lagrangian backtrace.
    pub backtrace: Backtrace,
    /// Advection scheme for velocity and densities (`sl` or `quick`).
    pub advection: Scheme,
    /// QUICK: split steps beyond the CFL bound into sub-steps (false: refuse them).
    pub substeps: bool,
    /// QUICK: limiter for the densities.
    pub limiter: Limiter,
    /// Write volumes and a preview every this many frames (0: metrics only).
    pub save_every: usize,
    /// Random seed (recorded; the scenario itself is deterministic).
    pub seed: u64,
}

impl Default for HotColdConfig {
    fn default() -> Self {
        Self {
            res: 50,
            size: 10.0,
            frames: 150,
            dt: 0.05,
            nu: 0.0,
            gravity: 1.0,
            radius: 1.0,
            hot_center: None,
            backtrace: Backtrace::Rk2,
            advection: Scheme::Sl,
            substeps: true,
            limiter: Limiter::Ultimate,
            save_every: 10,
            seed: 0,
        }
    }
}

/// Rough bytes per cell a run holds: velocity and its scratch (24), two gases
/// with source and scratch (24), six complex spectra of half size (24) and
/// the divergence diagnostic (4), plus slack.
const BYTES_PER_CELL: u64 = 96;

impl HotColdConfig {
    /// Read a TOML file; unknown keys and malformed values are errors.
    pub fn from_toml_file(path: &Path) -> Result<Self, InputError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| InputError::new(format!("cannot read config {}: {e}", path.display())))?;
        toml::from_str(&text).map_err(|e| {
            InputError::new(format!(
                "config {} is not a valid hot-cold config: {}",
                path.display(),
                e.message()
            ))
        })
    }

    /// The cubic domain `[0, size]³` with `res` cells per axis.
    pub fn domain(&self) -> Result<Domain, InputError> {
        Domain::cube(self.res, self.size)
    }

    /// Centre of the hot source.
    pub fn hot_center(&self) -> Vec3 {
        self.hot_center
            .map(Vec3::from)
            .unwrap_or(Vec3::new(0.5, 0.25, 0.5) * self.size)
    }

    /// Centre of the cold source: the hot one mirrored through y = L/2.
    pub fn cold_center(&self) -> Vec3 {
        let h = self.hot_center();
        Vec3::new(h.x, self.size - h.y, h.z)
    }

    /// Estimated bytes the run holds in memory.
    pub fn memory_estimate(&self) -> u64 {
        (self.res as u64).pow(3) * BYTES_PER_CELL
    }

    /// Check every parameter; the message names the bad value and what is valid.
    pub fn validate(&self) -> Result<(), InputError> {
        if self.res < crate::domain::MIN_CELLS {
            return Err(InputError::new(format!(
                "resolution {} is too small; it must be at least {}",
                self.res,
                crate::domain::MIN_CELLS
            )));
        }
        if let Some(avail) = crate::timing::available_memory_bytes() {
            let need = self.memory_estimate();
            if need > avail {
                return Err(InputError::new(format!(
                    "resolution {} needs about {:.1} GiB but only {:.1} GiB is available; use a smaller --res",
                    self.res,
                    need as f64 / 2f64.powi(30),
                    avail as f64 / 2f64.powi(30)
                )));
            }
        }
        let positive = |name: &str, v: f32| {
            if v.is_finite() && v > 0.0 {
                Ok(())
            } else {
                Err(InputError::new(format!(
                    "{name} is {v}; it must be a positive finite number"
                )))
            }
        };
        positive("dt", self.dt)?;
        positive("size", self.size)?;
        positive("radius", self.radius)?;
        if !(self.nu.is_finite() && self.nu >= 0.0) {
            return Err(InputError::new(format!(
                "nu is {}; it must be a finite number ≥ 0",
                self.nu
            )));
        }
        if !self.gravity.is_finite() {
            return Err(InputError::new(format!(
                "gravity is {}; it must be finite",
                self.gravity
            )));
        }
        let h = self.hot_center();
        if !(h.is_finite() && h.cmpge(Vec3::ZERO).all() && h.cmple(Vec3::splat(self.size)).all()) {
            return Err(InputError::new(format!(
                "hot_center is {h}; it must lie inside the box [0, {}]³",
                self.size
            )));
        }
        Ok(())
    }

    /// The advection options these parameters select.
    pub fn advection_options(&self) -> AdvectionOptions {
        AdvectionOptions {
            scheme: self.advection,
            quick: QuickOptions {
                substeps: self.substeps,
                ..Default::default()
            },
            density_limiter: self.limiter,
        }
    }

    /// Build the simulation at rest with both sources in place.
    pub fn build(&self) -> Result<Simulation, InputError> {
        self.validate()?;
        let domain = self.domain()?;
        let source = |c| ops::mask(ops::sphere(c, self.radius));
        let gases = vec![
            Gas::new("hot", domain, &source(self.hot_center()), 1.0),
            Gas::new("cold", domain, &source(self.cold_center()), -1.0),
        ];
        let params = StepParams {
            dt: self.dt,
            viscosity: self.nu,
            gravity: Vec3::new(0.0, -self.gravity, 0.0),
            backtrace: self.backtrace,
        };
        Ok(Simulation::new(domain, params, gases).with_advection(&self.advection_options()))
    }
}
