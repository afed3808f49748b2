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
use crate::density::{DensityMode, DensityOptions, DEFAULT_SELMA_REMAP};
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
    /// Width of a smooth edge of the injection spheres (0: the notes' solid
    /// `mask`). A continuous source keeps a gridless density's mirror
    /// symmetry at round-off; a solid one turns round-off in a path into a
    /// whole `S Δt` where the path grazes the sphere.
    pub source_edge: f32,
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
    /// How the densities are held: gridded, gridless or selma.
    pub density: DensityMode,
    /// SELMA map grid cells along the longest axis (default: `res`).
    pub map_res: Option<usize>,
    /// SELMA: re-anchor the map when its tracked lattice has deformed by
    /// more than this many map cells (0: never).
    pub selma_remap: f32,
    /// Also write the densities sampled at this resolution (`<gas>_fine_NNNN.npy`).
    pub sample_res: Option<usize>,
    /// Compute the fine-sampled density metrics every this many steps (≥ 1).
    pub metrics_every: usize,
    /// Run even if the memory estimate exceeds the available memory.
    pub force: bool,
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
            source_edge: 0.0,
            hot_center: None,
            backtrace: Backtrace::Rk2,
            advection: Scheme::Sl,
            substeps: true,
            limiter: Limiter::Ultimate,
            save_every: 10,
            density: DensityMode::Gridded,
            map_res: None,
            selma_remap: DEFAULT_SELMA_REMAP,
            sample_res: None,
            metrics_every: 1,
            force: false,
            seed: 0,
        }
    }
}

/// Rough bytes per velocity cell a gridded run holds: velocity and its
/// scratch (24), two gases with source and scratch (24), six complex spectra
/// of half size (24) and the divergence diagnostic (4), plus slack.
const BYTES_PER_CELL: u64 = 96;

/// Bytes per fine (2×) cell of the density metrics: the sampling (4) and two
/// half-size complex spectra (8).
const PROBE_BYTES_PER_FINE_CELL: u64 = 12;

/// Bytes per map cell of one SELMA gas (11 floats, see [`crate::density::selma`]).
const SELMA_BYTES_PER_MAP_CELL: u64 = 44;

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

    /// The density options of the run.
    pub fn density_options(&self) -> DensityOptions {
        DensityOptions {
            mode: self.density,
            map_res: self.map_res,
            selma_remap: self.selma_remap,
        }
    }

    /// Estimated peak bytes of the run: the gridded solver, the fine metrics
    /// and the density representation — for gridless, one velocity grid per
    /// step (`frames × 12 B × res³`), which dominates long runs.
    pub fn memory_estimate(&self) -> u64 {
        let cells = (self.res as f64).powi(3);
        let density = match self.density {
            DensityMode::Gridded => 0.0,
            DensityMode::Gridless => (self.frames as f64 * 12.0 + 8.0) * cells,
            DensityMode::Selma => {
                let map = (self.map_res.unwrap_or(self.res) as f64).powi(3);
                2.0 * (SELMA_BYTES_PER_MAP_CELL as f64 * map + 4.0 * cells)
            }
        };
        let sampled = self.sample_res.map_or(0.0, |r| 8.0 * (r as f64).powi(3));
        let bytes = cells * BYTES_PER_CELL as f64
            + 8.0 * cells * PROBE_BYTES_PER_FINE_CELL as f64
            + density
            + sampled;
        bytes.min(u64::MAX as f64) as u64
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
        if !(self.source_edge.is_finite() && self.source_edge >= 0.0) {
            return Err(InputError::new(format!(
                "source_edge is {}; it must be a finite width ≥ 0 (0: solid sphere)",
                self.source_edge
            )));
        }
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
        if self.metrics_every == 0 {
            return Err(InputError::new(
                "metrics_every is 0; it must be at least 1 (fine metrics every K steps)",
            ));
        }
        if let Some(r) = self.sample_res {
            if r < crate::domain::MIN_CELLS {
                return Err(InputError::new(format!(
                    "sample_res {r} is too small; it must be at least {}",
                    crate::domain::MIN_CELLS
                )));
            }
        }
        if let Some(r) = self.map_res {
            if self.density != DensityMode::Selma {
                return Err(InputError::new(format!(
                    "map_res {r} is only used by --density selma (density is {})",
                    self.density
                )));
            }
        }
        self.density_options().validate(&self.domain()?)?;
        if let Some(avail) = crate::timing::available_memory_bytes() {
            let need = self.memory_estimate();
            if need > avail && !self.force {
                return Err(InputError::new(format!(
                    "this {} run ({}³, {} frames) needs about {:.1} GiB but only {:.1} GiB is available; use a smaller --res or fewer --frames{}, or --force",
                    self.density,
                    self.res,
                    self.frames,
                    need as f64 / 2f64.powi(30),
                    avail as f64 / 2f64.powi(30),
                    if self.density == DensityMode::Gridless {
                        " (gridless keeps one velocity grid per step)"
                    } else {
                        ""
                    }
                )));
            }
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
        let source = |c| {
            if self.source_edge > 0.0 {
                ops::smooth_ball(c, self.radius, self.source_edge)
            } else {
                ops::mask(ops::sphere(c, self.radius))
            }
        };
        let density = self.density_options();
        let gases = vec![
            Gas::with_density("hot", domain, &source(self.hot_center()), 1.0, &density),
            Gas::with_density("cold", domain, &source(self.cold_center()), -1.0, &density),
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
