//! Buoyant gas in a closed box around a slab (§6.3, fig 6.6).
//!
//! One buoyant gas (green in the figure) is injected as a solid sphere low in
//! a closed box (blue boundary) and rises into a rectangular slab (red) that
//! it must flow around. Both obstacles are level sets ([`crate::boundary`]):
//! the box is [`Walls`] — solid outside its interior, a wall of thickness
//! `wall` inside the periodic domain, so the periodic FFT projection and QUICK
//! stencils never couple the fluid across the box — and the slab is a
//! [`Cuboid`]. By default the pressure solve knows both (cut cells,
//! [`ObstacleMethod::Exact`]) and no flow enters them; with the notes'
//! method fluid flowing into either is reflected (eq 6.6) or sent back with
//! a fraction α of its normal speed (sticky, eq 6.7) after a periodic
//! projection.
//!
//! Defaults (box edge 10, wall 0.8, slab `[2.5, 7.5] × [5.5, 6.3] × [1.5, 8.5]`,
//! source of radius 1 at `(4.2, 2, 5)`, off the slab's centre so the gas turns
//! mostly one way) are chosen to show the notes' story within 200 frames: the
//! plume reaches the slab, spreads under it, spills round its edges and fills
//! the upper box.

use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::config::check_sources;
use super::{Scenario, SolverConfig};
use crate::advection::Scheme;
use crate::boundary::{
    Boundary, BoundaryOptions, BoundaryRule, Cuboid, LevelSet, Obstacle, ObstacleMethod, Union,
    Walls,
};
use crate::error::{check_positive, InputError};
use crate::field::ops;
use crate::simulation::{Gas, Simulation};

/// Parameters of a slab-box run: the solver's, the source's and the
/// obstacles'. Every key has a default.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SlabBoxConfig {
    /// Resolution, time step, schemes, cadence, seed (defaults: see
    /// [`SlabBoxConfig::default_solver`]).
    #[serde(flatten)]
    pub solver: SolverConfig,
    /// Radius of the injection sphere.
    pub radius: f32,
    /// Centre of the injection sphere.
    pub source_center: [f32; 3],
    /// Thickness of the box walls, world units: at least two cells and less
    /// than a quarter of the box (the default 0.8 is four cells at 50³, two
    /// at 25³).
    pub wall: f32,
    /// Lower corner of the slab.
    pub slab_min: [f32; 3],
    /// Upper corner of the slab.
    pub slab_max: [f32; 3],
    /// How the pressure solve treats the obstacles: `exact` (whole faces, no
    /// flux through closed faces) or `notes` (eqs 6.6–6.7 with the periodic
    /// projection).
    pub obstacles: ObstacleMethod,
    /// Reflecting (eq 6.6) or sticky (eq 6.7); with exact obstacles, free
    /// slip or the tangential velocity in the wall scaled by α.
    pub boundary: BoundaryRule,
    /// Fraction α of normal velocity a sticky boundary sends back.
    pub alpha: f32,
    /// Boundary-rule/projection pairs per step (notes' method).
    pub boundary_passes: usize,
}

impl Default for SlabBoxConfig {
    fn default() -> Self {
        Self {
            solver: Self::default_solver(),
            radius: 1.0,
            source_center: [4.2, 2.0, 5.0],
            wall: 0.8,
            slab_min: [2.5, 5.5, 1.5],
            slab_max: [7.5, 6.3, 8.5],
            obstacles: ObstacleMethod::Exact,
            boundary: BoundaryRule::Reflect,
            alpha: 0.5,
            boundary_passes: 4,
        }
    }
}

/// Rough bytes per cell: velocity and scratch (24), one gas with source and
/// scratch (12), six half-size spectra (24), QUICK scratch (44), the level
/// set and normals (16), divergence diagnostic (4), plus slack.
const BYTES_PER_CELL: u64 = 160;

impl SlabBoxConfig {
    /// The solver defaults of fig 6.6: 50³ in a cube of edge 10, Δt 0.1,
    /// 200 frames, QUICK advection, gridded density.
    pub fn default_solver() -> SolverConfig {
        SolverConfig {
            frames: 200,
            dt: 0.1,
            advection: Scheme::Quick,
            ..SolverConfig::default()
        }
    }

    /// The box walls: solid outside `[wall, size − wall]³`.
    pub fn walls(&self) -> Walls {
        Walls {
            interior: Cuboid {
                min: Vec3::splat(self.wall),
                max: Vec3::splat(self.solver.size - self.wall),
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
            method: self.obstacles,
            rule: self.boundary,
            alpha: self.alpha,
            passes: self.boundary_passes,
        }
    }

    /// Estimated bytes the run holds in memory.
    pub fn memory_estimate(&self) -> u64 {
        (self.solver.res as u64)
            .saturating_pow(3)
            .saturating_mul(BYTES_PER_CELL)
    }
}

impl Scenario for SlabBoxConfig {
    const NAME: &'static str = "slab-box";

    fn solver(&self) -> &SolverConfig {
        &self.solver
    }

    fn validate(&self) -> Result<(), InputError> {
        let s = &self.solver;
        s.validate()?;
        if s.box_kind != crate::grid::BoxKind::Periodic {
            return Err(InputError::new(format!(
                "box {} is not available for slab-box: its walls are obstacles in a periodic box (box periodic)",
                s.box_kind
            )));
        }
        if let Some(avail) = crate::timing::available_memory_bytes() {
            let need = self.memory_estimate();
            if need > avail {
                return Err(InputError::new(format!(
                    "resolution {} needs about {:.1} GiB but only {:.1} GiB is available; use a smaller --res",
                    s.res,
                    need as f64 / 2f64.powi(30),
                    avail as f64 / 2f64.powi(30)
                )));
            }
        }
        check_positive("radius", self.radius)?;
        self.boundary_options().validate()?;
        let cell = s.size / s.res as f32;
        if !(self.wall >= 2.0 * cell && self.wall < 0.25 * s.size) {
            return Err(InputError::new(format!(
                "wall is {}; it must be at least two cells ({}) and less than a quarter of the box ({}): set the key `wall`",
                self.wall,
                2.0 * cell,
                0.25 * s.size
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
                s.size - self.wall
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

    /// The simulation at rest with the source and obstacles in place.
    fn build(&self) -> Result<Simulation, InputError> {
        self.validate()?;
        let s = &self.solver;
        let domain = s.domain()?;
        let source = ops::mask(ops::sphere(Vec3::from(self.source_center), self.radius));
        let gases = vec![Gas::with_density(
            "density",
            domain,
            &source,
            1.0,
            &s.density_options(),
        )];
        check_sources(&gases, s)?;
        let boundary = Boundary::new(domain, &self.obstacle(), self.boundary_options())?;
        Ok(Simulation::new(domain, s.step_params(), gases)
            .with_advection(&s.advection_options())
            .with_pressure_precision(s.pressure_precision)
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
