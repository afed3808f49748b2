//! Buoyant gas in a closed box around a slab (§6.3, fig 6.6).
//!
//! One buoyant gas (green in the figure) is injected as a solid sphere low in
//! a closed box (blue boundary) and rises into a rectangular slab (red) that
//! it must flow around. Both obstacles are level sets ([`crate::boundary`]):
//! the box is [`Walls`] — solid outside its interior, a wall of thickness
//! `wall` inside the periodic domain, so the periodic FFT projection and QUICK
//! stencils never couple the fluid across the box — and the slab is a
//! [`Cuboid`]. Fluid flowing into either is reflected (eq 6.6) or sent back
//! with a fraction α of its normal speed (sticky, eq 6.7).
//!
//! Defaults (box edge 10, wall 0.8, slab `[2.5, 7.5] × [5.5, 6.3] × [1.5, 8.5]`,
//! source of radius 1 at `(4.2, 2, 5)`, off the slab's centre so the gas turns
//! mostly one way) are chosen to show the notes' story within 200 frames: the
//! plume reaches the slab, spreads under it, spills round its edges and fills
//! the upper box.

use std::path::Path;
use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::advection::{AdvectionOptions, Backtrace, Limiter, QuickOptions, Scheme};
use crate::boundary::{
    Boundary, BoundaryOptions, BoundaryRule, Cuboid, LevelSet, Obstacle, Union, Walls,
};
use crate::domain::Domain;
use crate::error::InputError;
use crate::field::ops;
use crate::simulation::{Gas, Simulation, StepParams};

/// Parameters of a slab-box run. Every field has a default; a TOML file may
/// set any subset, and unknown keys are an error.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SlabBoxConfig {
    /// Cells per axis.
    pub res: usize,
    /// Edge length L of the cubic domain, world units.
    pub size: f32,
    /// Number of time steps (one step per frame; the notes show 200).
    pub frames: usize,
    /// Time step Δt.
    pub dt: f32,
    /// Kinematic viscosity ν.
    pub nu: f32,
    /// Magnitude of gravity; g⃗ = (0, −g, 0).
    pub gravity: f32,
    /// Radius of the injection sphere.
    pub radius: f32,
    /// Centre of the injection sphere.
    pub source_center: [f32; 3],
    /// Thickness of the box walls (at least two cells).
    pub wall: f32,
    /// Lower corner of the slab.
    pub slab_min: [f32; 3],
    /// Upper corner of the slab.
    pub slab_max: [f32; 3],
    /// Reflecting (eq 6.6) or sticky (eq 6.7).
    pub boundary: BoundaryRule,
    /// Fraction α of normal velocity a sticky boundary sends back.
    pub alpha: f32,
    /// Boundary-rule/projection pairs per step.
    pub boundary_passes: usize,
    /// Semi-Lagrangian backtrace.
    pub backtrace: Backtrace,
    /// Advection scheme for velocity and density (`sl` or `quick`).
    pub advection: Scheme,
    /// QUICK: split steps beyond the CFL bound into sub-steps (false: refuse them).
    pub substeps: bool,
    /// QUICK: limiter for the density.
    pub limiter: Limiter,
    /// Write volumes and a preview every this many frames (0: metrics only).
    pub save_every: usize,
    /// Random seed (recorded; the scenario itself is deterministic).
    pub seed: u64,
}

impl Default for SlabBoxConfig {
    fn default() -> Self {
        Self {
            res: 50,
            size: 10.0,
            frames: 200,
            dt: 0.1,
            nu: 0.0,
            gravity: 1.0,
            radius: 1.0,
            source_center: [4.2, 2.0, 5.0],
            wall: 0.8,
            slab_min: [2.5, 5.5, 1.5],
            slab_max: [7.5, 6.3, 8.5],
            boundary: BoundaryRule::Reflect,
            alpha: 0.5,
            boundary_passes: 4,
            backtrace: Backtrace::Rk2,
            advection: Scheme::Quick,
            substeps: true,
            limiter: Limiter::Ultimate,
            save_every: 10,
            seed: 0,
        }
    }
}

/// Rough bytes per cell: velocity and scratch (24), one gas with source and
/// scratch (12), six half-size spectra (24), QUICK scratch (44), the level
/// set and normals (16), divergence diagnostic (4), plus slack.
const BYTES_PER_CELL: u64 = 160;

impl SlabBoxConfig {
    /// Read a TOML file; unknown keys and malformed values are errors.
    pub fn from_toml_file(path: &Path) -> Result<Self, InputError> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| InputError::new(format!("cannot read config {}: {e}", path.display())))?;
        toml::from_str(&text).map_err(|e| {
            InputError::new(format!(
                "config {} is not a valid slab-box config: {}",
                path.display(),
                e.message()
            ))
        })
    }

    /// The cubic domain `[0, size]³` with `res` cells per axis.
    pub fn domain(&self) -> Result<Domain, InputError> {
        Domain::cube(self.res, self.size)
    }

    /// The box walls: solid outside `[wall, size − wall]³`.
    pub fn walls(&self) -> Walls {
        Walls {
            interior: Cuboid {
                min: Vec3::splat(self.wall),
                max: Vec3::splat(self.size - self.wall),
            },
        }
    }

    /// The slab.
    pub fn slab(&self) -> Cuboid {
        Cuboid {
            min: Vec3::from(self.slab_min),
            max: Vec3::from(self.slab_max),
        }
    }

    /// Walls and slab as one level set.
    pub fn obstacle(&self) -> Obstacle {
        Arc::new(Union(vec![Arc::new(self.walls()), Arc::new(self.slab())]))
    }

    /// The rule, α and passes.
    pub fn boundary_options(&self) -> BoundaryOptions {
        BoundaryOptions {
            rule: self.boundary,
            alpha: self.alpha,
            passes: self.boundary_passes,
        }
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
        self.boundary_options().validate()?;
        let cell = self.size / self.res as f32;
        if !(self.wall >= 2.0 * cell && self.wall < 0.25 * self.size) {
            return Err(InputError::new(format!(
                "wall is {}; it must be at least two cells ({}) and less than a quarter of the box ({})",
                self.wall,
                2.0 * cell,
                0.25 * self.size
            )));
        }
        let interior = self.walls().interior;
        let slab = self.slab();
        let inside = |p: Vec3| p.cmpge(interior.min).all() && p.cmple(interior.max).all();
        if !(slab.min.is_finite()
            && slab.max.is_finite()
            && slab.min.cmplt(slab.max).all()
            && inside(slab.min)
            && inside(slab.max))
        {
            return Err(InputError::new(format!(
                "slab {} – {} must be a non-empty box inside the walls' interior [{}, {}]³",
                slab.min,
                slab.max,
                self.wall,
                self.size - self.wall
            )));
        }
        let c = Vec3::from(self.source_center);
        if !(c.is_finite() && interior.value(c) > self.radius && slab.value(c) < -self.radius) {
            return Err(InputError::new(format!(
                "source_center {c} with radius {} must lie in the fluid, clear of the walls and the slab",
                self.radius
            )));
        }
        Ok(())
    }

    /// Build the simulation at rest with the source and obstacles in place.
    pub fn build(&self) -> Result<Simulation, InputError> {
        self.validate()?;
        let domain = self.domain()?;
        let source = ops::mask(ops::sphere(Vec3::from(self.source_center), self.radius));
        let gases = vec![Gas::new("density", domain, &source, 1.0)];
        let params = StepParams {
            dt: self.dt,
            viscosity: self.nu,
            gravity: Vec3::new(0.0, -self.gravity, 0.0),
            backtrace: self.backtrace,
        };
        let boundary = Boundary::new(domain, &self.obstacle(), self.boundary_options())?;
        Ok(Simulation::new(domain, params, gases)
            .with_advection(&self.advection_options())
            .with_boundary(boundary))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn default_is_valid_and_bad_geometry_is_named() {
        SlabBoxConfig::default().validate().unwrap();
        let bad = |c: SlabBoxConfig, needle: &str| {
            let e = c.validate().unwrap_err().to_string();
            assert!(e.contains(needle), "{e}");
        };
        let d = SlabBoxConfig::default();
        bad(
            SlabBoxConfig {
                wall: 0.1,
                ..d.clone()
            },
            "wall is 0.1",
        );
        bad(
            SlabBoxConfig {
                slab_max: [7.5, 5.0, 8.5],
                ..d.clone()
            },
            "slab",
        );
        bad(
            SlabBoxConfig {
                source_center: [5.0, 5.9, 5.0],
                ..d.clone()
            },
            "source_center",
        );
        bad(SlabBoxConfig { alpha: 2.0, ..d }, "alpha is 2");
    }
}
