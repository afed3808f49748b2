//! The hot/cold scenario of §6.1.1 (figs 6.1–6.2).
//!
//! Two gases in a periodic cube `[0, L]³`: *hot* is injected as a solid sphere
//! (the notes' `inject`) low in the box and rises, *cold* is injected at the
//! mirror image of that point through the mid-plane `y = L/2` and sinks. Both
//! force the velocity through `dt·gravity·(cold − hot)`. Because the cold
//! source is the exact mirror of the hot one and every operator is
//! mirror-symmetric, the discrete problem is symmetric under
//! hot ↔ cold, y ↔ L − y; [`crate::metrics::mirror_error`] measures how well that holds.
//!
//! `offset = d` moves the hot source by `+d` and the cold one by `−d` along
//! x (world units), so that the rising and sinking gases collide over part
//! of their width and flow around each other, as figs 6.1–6.5 show. The
//! default is `d = 0.5` (half the unit source radius), chosen by the offset
//! study of experiment 06-1 (`offset_study.csv`: the share of each gas past
//! the mid-plane and the two gases' overlap, for `d = 0 … 1`): head-on, the
//! gases flatten into one disc and almost none passes; `0.5` is the
//! smallest offset that lets about half of each gas past the other by frame
//! 100 while the two still overlap where they meet (larger offsets mostly
//! slide by). The offset problem keeps the half turn
//! `(x, y) ↦ (L − x, L − y)` about the box's z-parallel centre line,
//! hot ↔ cold, as an exact symmetry; the mirror `y ↦ L − y` that
//! [`crate::metrics::mirror_error`] tests holds only for the head-on case
//! ([`HotColdConfig::head_on`], `offset = 0`), which the symmetry tests and
//! experiment S-1 use.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::config::check_sources;
use super::{Scenario, SolverConfig};
use crate::density::DensityMode;
use crate::error::{check_non_negative, check_positive, InputError};
use crate::field::ops;
use crate::simulation::{Gas, Simulation};

/// Parameters of a hot/cold run: the solver's and the sources'. Every key
/// has a default (see [`SolverConfig::default`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HotColdConfig {
    /// Resolution, time step, schemes, density mode, cadence, seed.
    #[serde(flatten)]
    pub solver: SolverConfig,
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
    /// Horizontal offset d of the sources (world units): hot moves by `+d`
    /// and cold by `−d` along x. Default 0.5: the gases collide and pass
    /// (see the module doc); 0: both on one vertical axis, head-on and
    /// mirror-symmetric ([`HotColdConfig::head_on`]).
    pub offset: f32,
}

impl Default for HotColdConfig {
    fn default() -> Self {
        Self {
            solver: SolverConfig::default(),
            radius: 1.0,
            source_edge: 0.0,
            hot_center: None,
            offset: DEFAULT_OFFSET,
        }
    }
}

/// The default source offset (world units; the sources have radius 1).
pub const DEFAULT_OFFSET: f32 = 0.5;

impl HotColdConfig {
    /// The head-on variant: both sources on one vertical axis
    /// (`offset = 0`), so that the cold problem is the exact mirror image of
    /// the hot one through `y = L/2` and `metrics.csv`'s `mirror_error`
    /// tests the whole step. The gases meet and spread into one disc.
    pub fn head_on() -> Self {
        Self {
            offset: 0.0,
            ..Self::default()
        }
    }
}

/// Rough bytes per velocity cell a gridded run holds: velocity and its
/// scratch (24), two gases with source and scratch (24), six complex spectra
/// of half size (24) and the divergence diagnostic (4), plus slack.
const BYTES_PER_CELL: u64 = 96;

/// Bytes per fine (2×) cell of the density metrics: the sampling (4) and one
/// half-size complex spectrum (4).
const PROBE_BYTES_PER_FINE_CELL: u64 = 8;

/// Bytes per map cell of one SELMA gas (11 floats, see [`crate::density::selma`]).
const SELMA_BYTES_PER_MAP_CELL: u64 = 44;

impl HotColdConfig {
    /// Centre of the hot source before the offset (`hot_center` or its default).
    fn base_center(&self) -> Vec3 {
        self.hot_center
            .map(Vec3::from)
            .unwrap_or(Vec3::new(0.5, 0.25, 0.5) * self.solver.size)
    }

    /// Centre of the hot source: the base centre moved by `+offset` along x.
    pub fn hot_center(&self) -> Vec3 {
        self.base_center() + Vec3::X * self.offset
    }

    /// Centre of the cold source: the base centre mirrored through y = L/2,
    /// moved by `−offset` along x.
    pub fn cold_center(&self) -> Vec3 {
        let h = self.base_center();
        Vec3::new(h.x - self.offset, self.solver.size - h.y, h.z)
    }

    /// Estimated peak bytes of the run: the gridded solver, the fine metrics
    /// and the density representation — for gridless, one velocity grid per
    /// step (`frames × 12 B × res³`), which dominates long runs.
    pub fn memory_estimate(&self) -> u64 {
        let s = &self.solver;
        let cells = (s.res as f64).powi(3);
        let density = match s.density {
            DensityMode::Gridded => 0.0,
            DensityMode::Gridless => (s.frames as f64 * 12.0 + 8.0) * cells,
            DensityMode::Selma => {
                let map = (s.map_res.unwrap_or(s.res) as f64).powi(3);
                2.0 * (SELMA_BYTES_PER_MAP_CELL as f64 * map + 4.0 * cells)
            }
        };
        let sampled = s.sample_res.map_or(0.0, |r| 8.0 * (r as f64).powi(3));
        let bytes = cells * BYTES_PER_CELL as f64
            + 8.0 * cells * PROBE_BYTES_PER_FINE_CELL as f64
            + density
            + sampled;
        bytes.min(u64::MAX as f64) as u64
    }
}

impl Scenario for HotColdConfig {
    const NAME: &'static str = "hot-cold";

    fn solver(&self) -> &SolverConfig {
        &self.solver
    }

    fn validate(&self) -> Result<(), InputError> {
        let s = &self.solver;
        s.validate()?;
        check_positive("radius", self.radius)?;
        check_non_negative("source_edge", self.source_edge)?;
        let h = self.base_center();
        if !(h.is_finite() && h.cmpge(Vec3::ZERO).all() && h.cmple(Vec3::splat(s.size)).all()) {
            return Err(InputError::new(format!(
                "hot_center is {h}; it must lie inside the box [0, {}]³",
                s.size
            )));
        }
        let (hx, cx) = (self.hot_center().x, self.cold_center().x);
        let inside = |x: f32| (0.0..=s.size).contains(&x);
        if !(self.offset.is_finite() && inside(hx) && inside(cx)) {
            return Err(InputError::new(format!(
                "offset is {}; the sources' x ({hx} hot, {cx} cold) must stay inside [0, {}]",
                self.offset, s.size
            )));
        }
        if let Some(avail) = crate::timing::available_memory_bytes() {
            let need = self.memory_estimate();
            if need > avail && !s.force {
                return Err(InputError::new(format!(
                    "this {} run ({}³, {} frames) needs about {:.1} GiB but only {:.1} GiB is available; use a smaller --res or fewer --frames{}, or --force",
                    s.density,
                    s.res,
                    s.frames,
                    need as f64 / 2f64.powi(30),
                    avail as f64 / 2f64.powi(30),
                    if s.density == DensityMode::Gridless {
                        " (gridless keeps one velocity grid per step)"
                    } else {
                        ""
                    }
                )));
            }
        }
        Ok(())
    }

    /// The simulation at rest with both sources in place.
    fn build(&self) -> Result<Simulation, InputError> {
        self.validate()?;
        let s = &self.solver;
        let domain = s.domain()?;
        let source = |c| {
            if self.source_edge > 0.0 {
                ops::smooth_ball(c, self.radius, self.source_edge)
            } else {
                ops::mask(ops::sphere(c, self.radius))
            }
        };
        let density = s.density_options();
        let gases = vec![
            Gas::with_density("hot", domain, &source(self.hot_center()), 1.0, &density),
            Gas::with_density("cold", domain, &source(self.cold_center()), -1.0, &density),
        ];
        check_sources(&gases, s)?;
        Ok(Simulation::new(domain, s.step_params(), gases)
            .with_advection(&s.advection_options())
            .with_pressure_precision(s.pressure_precision)
            .with_box(s.box_kind))
    }
}
