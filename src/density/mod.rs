//! Where a gas's density lives: gridded, gridless or SELMA (§6.2, ch. 7, ch. 8).
//!
//! The velocity is always a staggered grid ([`crate::grid::FaceGrid`]: the
//! pressure solve needs one); the density
//! of each gas can be held three ways, chosen by [`DensityMode`]:
//!
//! - [`gridded`] — the notes' FELT script of §6.1.1: advect, `cachewrite`,
//!   `cacheread` every step (eq 6.4). One grid, constant cost, numerical
//!   diffusion at every step.
//! - [`gridless`] — §6.2 and eqs 7.1–7.4: nothing is resampled; every step's
//!   velocity grid is kept and a query walks back through all of them,
//!   adding the source on the way. Exact up to the velocity's interpolation,
//!   but memory and query cost grow by one velocity grid per step.
//! - [`selma`] — ch. 8, eqs 8.1–8.8: a backward map `X` sampled on its own
//!   grid and advected every step, `ρ = ρ₀ ∘ X`; continuous injection is
//!   accumulated in the map's reference coordinates and the map is
//!   re-anchored when it has deformed too far (see [`selma`] for the design
//!   and its error). Constant memory and query cost.
//!
//! All three trace characteristics with the same backtrace as the velocity
//! ([`crate::advection::departure_point`]), so on the same velocity history
//! they differ only in how the density itself is represented.
//!
//! A [`DensityModel`] is stepped with the step's velocity ([`StepInput`]),
//! evaluated at the velocity grid's cell centres for the buoyancy force
//! ([`DensityModel::evaluate_centres`]), sampled onto any grid in parallel
//! batches ([`DensityModel::sample`]), handed to renderers as an immutable
//! field snapshot ([`DensityModel::field`]), and reports the memory it holds
//! from its actual buffers ([`DensityModel::buffers`]).

pub mod cell_average;
pub mod gridded;
pub mod gridless;
pub mod occupancy;
pub mod probe;
pub mod selma;
pub mod stored;

use std::sync::Arc;

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::advection::Backtrace;
use crate::boundary::WallStop;
use crate::domain::Domain;
pub(crate) use crate::domain::{wrap_grid, wrap_world};
use crate::error::InputError;
use crate::field::{Scalar, VectorField};
use crate::grid::{FaceGrid, ScalarGrid, VectorGrid};

pub use cell_average::CellSamples;
pub use gridded::Gridded;
pub use gridless::{Gridless, GridlessField, HistoryStep};
use selma::{advect_group, inject_group};
pub use selma::{step_group, MapState, Selma, SelmaField, SelmaState};

/// A backward characteristic map `X(x)`, evaluated at many points at once:
/// where the fluid now at `x` came from (gridless: the walk of eq 7.4;
/// SELMA: the map grid of eq 8.8).
pub trait BackwardMap: Send + Sync {
    /// `out[i] = X(points[i])`, wrapped into the box.
    ///
    /// # Panics
    /// If the slices differ in length.
    fn map_batch(&self, points: &[Vec3], out: &mut [Vec3]);
}

/// A [`BackwardMap`] as a vector field, to compose densities with
/// (`ops::compose(ρ₀, map)`, eq 8.8's `compose(initialdensity, Xmap)`).
pub struct MapField<M>(pub M);

impl<M: BackwardMap> VectorField for MapField<M> {
    fn eval(&self, p: Vec3) -> Vec3 {
        let mut out = [Vec3::ZERO];
        self.0.map_batch(&[p], &mut out);
        out[0]
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.0.map_batch(points, out);
    }
}

/// How the density of every gas is held.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum DensityMode {
    /// Sampled onto the velocity grid every step (eq 6.4).
    #[default]
    Gridded,
    /// Never sampled: a walk back through every stored velocity grid (§6.2, eq 7.4).
    Gridless,
    /// A grid-sampled backward map composed with the initial density (eq 8.8).
    Selma,
}

impl DensityMode {
    /// Every variant, for tests and listings.
    pub const ALL: [DensityMode; 3] = [
        DensityMode::Gridded,
        DensityMode::Gridless,
        DensityMode::Selma,
    ];

    /// The name used on the command line and in file names.
    pub fn name(self) -> &'static str {
        match self {
            DensityMode::Gridded => "gridded",
            DensityMode::Gridless => "gridless",
            DensityMode::Selma => "selma",
        }
    }
}

impl std::fmt::Display for DensityMode {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Default SELMA re-anchoring threshold: the tracked reference lattice's
/// deformation in map cells (see [`selma`]).
pub const DEFAULT_SELMA_REMAP: f32 = 2.0;

/// How the densities of a run are held; shared by all its gases.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct DensityOptions {
    /// The representation.
    pub mode: DensityMode,
    /// SELMA: cells along the longest axis of the map grid (`None`: the
    /// velocity grid's). Finer than the velocity is the notes' SELMA^fine.
    pub map_res: Option<usize>,
    /// SELMA: re-anchor the map when the tracked lattice has deformed by
    /// more than this many map cells (0: never; see [`selma`]).
    pub selma_remap: f32,
    /// Gridless and SELMA: how the density is put on the velocity grid for
    /// the force and the saved volumes ([`cell_average`]; `None`: the
    /// mode's default, [`CellSamples::default_for`]).
    pub cell_samples: Option<CellSamples>,
}

impl Default for DensityOptions {
    fn default() -> Self {
        Self {
            mode: DensityMode::Gridded,
            map_res: None,
            selma_remap: DEFAULT_SELMA_REMAP,
            cell_samples: None,
        }
    }
}

impl DensityOptions {
    /// Options for `mode` with every other setting at its default.
    pub fn mode(mode: DensityMode) -> Self {
        Self {
            mode,
            ..Self::default()
        }
    }

    /// The SELMA map grid for a velocity grid on `domain`.
    ///
    /// Fails when the map resolution is too small or does not tile the same
    /// periodic box as the velocity grid.
    pub fn map_domain(&self, domain: &Domain) -> Result<Domain, InputError> {
        let Some(res) = self.map_res else {
            return Ok(*domain);
        };
        let map = domain
            .with_resolution(res)
            .map_err(|e| InputError::new(format!("--map-res {res} is invalid: {e}")))?;
        let (a, b) = (map.size(), domain.size());
        if (a - b).abs().max_element() > 1e-4 * b.max_element() {
            let max = domain.dims.iter().copied().max().unwrap_or(1);
            let step = max / domain.dims.iter().copied().fold(0, gcd);
            return Err(InputError::new(format!(
                "--map-res {res} does not tile the {}×{}×{} box with cubic cells; use a multiple of {step}",
                b.x, b.y, b.z
            )));
        }
        Ok(map)
    }

    /// Check the options against the velocity grid's domain.
    pub fn validate(&self, domain: &Domain) -> Result<(), InputError> {
        if !(self.selma_remap.is_finite() && self.selma_remap >= 0.0) {
            return Err(InputError::new(format!(
                "selma_remap is {}; it must be a finite number of map cells ≥ 0 (0: never re-anchor)",
                self.selma_remap
            )));
        }
        self.map_domain(domain).map(|_| ())
    }
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// Everything one step of a density needs; shared by all gases of the step.
pub struct StepInput<'a> {
    /// The velocity the step advects with (the state before the step).
    pub velocity: &'a FaceGrid,
    /// A shared copy of that velocity for models that keep the history
    /// (gridless); `None` when no gas needs one.
    pub snapshot: Option<&'a Arc<FaceGrid>>,
    /// Time step Δt.
    pub dt: f32,
    /// Backtrace scheme (the same as the velocity's).
    pub backtrace: Backtrace,
}

/// One allocation held by a density representation: its address (so buffers
/// shared between gases are counted once) and its size in bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Buffer {
    /// Address of the first element.
    pub addr: usize,
    /// Size in bytes.
    pub bytes: usize,
}

impl Buffer {
    /// The buffer of a scalar grid.
    pub fn of_scalar(g: &ScalarGrid) -> Self {
        let s = g.as_slice();
        Self {
            addr: s.as_ptr() as usize,
            bytes: std::mem::size_of_val(s),
        }
    }

    /// The buffer of a vector grid.
    pub fn of_vector(g: &VectorGrid) -> Self {
        let s = g.as_slice();
        Self {
            addr: s.as_ptr() as usize,
            bytes: std::mem::size_of_val(s),
        }
    }

    /// The three component arrays of a staggered velocity, as one buffer
    /// named by the first component's address.
    pub fn of_faces(g: &FaceGrid) -> Self {
        Self {
            addr: g.slice(0).as_ptr() as usize,
            bytes: (0..3).map(|a| std::mem::size_of_val(g.slice(a))).sum(),
        }
    }
}

/// Total bytes of `buffers`, each distinct allocation counted once.
pub fn total_bytes(buffers: impl IntoIterator<Item = Buffer>) -> usize {
    let mut v: Vec<Buffer> = buffers.into_iter().collect();
    v.sort_unstable();
    v.dedup_by_key(|b| b.addr);
    v.iter().map(|b| b.bytes).sum()
}

/// The density of one gas, held one of three ways (see the module docs).
#[derive(Clone)]
pub enum DensityModel {
    /// A grid on the velocity grid's cells (eq 6.4).
    Gridded(Gridded),
    /// The velocity history and the source (eq 7.4).
    Gridless(Gridless),
    /// A backward map on its own grid (eq 8.8), boxed: it is the largest.
    Selma(Box<Selma>),
}

impl DensityModel {
    /// A density on the velocity grid `domain` with initial value `initial`
    /// (`None`: empty) and injection rate `source` (`None`: no source; the
    /// gridded model receives its source sampled on the grid at each step).
    ///
    /// # Panics
    /// If `options` fail [`DensityOptions::validate`] for `domain`.
    pub fn new(
        options: &DensityOptions,
        domain: Domain,
        initial: Option<Scalar>,
        source: Option<Scalar>,
    ) -> Self {
        let samples = options
            .cell_samples
            .unwrap_or(CellSamples::default_for(options.mode));
        match options.mode {
            DensityMode::Gridded => DensityModel::Gridded(Gridded::new(domain, initial.as_ref())),
            DensityMode::Gridless => DensityModel::Gridless(
                Gridless::new(domain, initial, source).with_cell_samples(samples),
            ),
            DensityMode::Selma => {
                let map = options
                    .map_domain(&domain)
                    .unwrap_or_else(|e| panic!("invalid density options: {e}"));
                DensityModel::Selma(Box::new(
                    Selma::new(domain, map, initial, source, options.selma_remap)
                        .with_cell_samples(samples),
                ))
            }
        }
    }

    /// Which representation this is.
    pub fn mode(&self) -> DensityMode {
        match self {
            DensityModel::Gridded(_) => DensityMode::Gridded,
            DensityModel::Gridless(_) => DensityMode::Gridless,
            DensityModel::Selma(_) => DensityMode::Selma,
        }
    }

    /// Whether [`Self::step`] needs [`StepInput::snapshot`].
    pub fn keeps_velocity(&self) -> bool {
        matches!(self, DensityModel::Gridless(_))
    }

    /// The gridded density and the target of its advection, for the
    /// simulation's [`crate::advection::Advector`] (`None` for gridless and
    /// SELMA, which advect themselves in [`Self::step`]).
    pub fn advection_pair(&mut self) -> Option<(&ScalarGrid, &mut ScalarGrid)> {
        match self {
            DensityModel::Gridded(g) => Some(g.advection_pair()),
            _ => None,
        }
    }

    /// Obstacles for a gridless or SELMA density: zero inside them, and
    /// SELMA's map and lattice stopped at their surface (a gridded density
    /// is cleared in the dry cells by the simulation instead).
    pub fn set_walls(&mut self, walls: &Arc<WallStop>) {
        match self {
            DensityModel::Gridded(_) => {}
            DensityModel::Gridless(g) => g.set_walls(walls.clone()),
            DensityModel::Selma(s) => s.set_walls(walls.clone()),
        }
    }

    /// The gridded density's total `Σ ρ Δx³` ([`Gridded::total`]; `None`
    /// for gridless and SELMA).
    pub fn gridded_total(&self) -> Option<f64> {
        match self {
            DensityModel::Gridded(g) => Some(g.total()),
            _ => None,
        }
    }

    /// The gridded density, to edit (`None` for gridless and SELMA).
    pub fn gridded_mut(&mut self) -> Option<&mut ScalarGrid> {
        match self {
            DensityModel::Gridded(g) => Some(g.density_mut()),
            _ => None,
        }
    }

    /// Advance one step: advect with the input velocity and inject the
    /// source for Δt (eq 6.4 / 7.4 / 8.8). The gridded model was advected
    /// into its target by the caller (see [`Self::advection_pair`]) and here
    /// takes it and adds `source`, the injection rate at the velocity grid's
    /// cell centres; gridless and SELMA evaluate the source field they were
    /// built with.
    ///
    /// For gridless and SELMA this does not update [`Self::density`]; call
    /// [`Self::evaluate_centres`] for that (the buoyancy input).
    ///
    /// A SELMA model steps its own map here; the gases of a simulation
    /// share one map through [`Self::advect_all`] and [`Self::inject_all`]
    /// instead.
    ///
    /// Returns, for the gridded model, the advected density's total before
    /// the injection ([`Gridded::step`]: its mass budget's advection term
    /// is that less [`Self::gridded_total`] before the advection).
    ///
    /// # Panics
    /// If a gridless model gets no snapshot, a SELMA model shares another
    /// gas's map, or grids are on other domains.
    pub fn step(&mut self, input: &StepInput<'_>, source: &ScalarGrid) -> Option<f64> {
        match self {
            DensityModel::Gridded(g) => return Some(g.step(source, input.dt)),
            DensityModel::Gridless(g) => g.step(input),
            DensityModel::Selma(s) => s.step(input),
        }
        None
    }

    /// The transport half of [`Self::step`] for every gas: gridless gases
    /// keep the step's velocity (eq 7.4), the SELMA gases advect their maps
    /// together ([`selma::advect_group`]), sharing one map where their maps
    /// agree. Gridded gases have nothing to do here: the simulation's
    /// advector moved them into their targets ([`Self::advection_pair`]).
    pub fn advect_all<'a>(
        gases: impl IntoIterator<Item = &'a mut DensityModel>,
        input: &StepInput<'_>,
    ) {
        let mut selma = Vec::new();
        for model in gases {
            match model {
                DensityModel::Gridded(_) => {}
                DensityModel::Gridless(g) => g.step(input),
                DensityModel::Selma(s) => selma.push(&mut **s),
            }
        }
        advect_group(&mut selma, input);
    }

    /// The injection half of [`Self::step`] for every gas, after
    /// [`Self::advect_all`], each with its source at the cell centres: a
    /// gridded gas takes its advected density and adds `S Δt`; a gridless
    /// gas has nothing to add (its walk integrates the source, eq 7.4); the
    /// SELMA gases inject in reference coordinates and re-anchor together
    /// ([`selma::inject_group`]). Returns, per gas, what [`Self::step`]
    /// returns: a gridded gas's advected total, summed in the injection's
    /// pass.
    pub fn inject_all<'a>(
        gases: impl IntoIterator<Item = (&'a mut DensityModel, &'a ScalarGrid)>,
        dt: f32,
    ) -> Vec<Option<f64>> {
        let mut selma = Vec::new();
        let mut advected = Vec::new();
        for (model, source) in gases {
            advected.push(match model {
                DensityModel::Gridded(g) => Some(g.step(source, dt)),
                DensityModel::Gridless(_) => None,
                DensityModel::Selma(s) => {
                    selma.push(&mut **s);
                    None
                }
            });
        }
        inject_group(&mut selma, dt);
        advected
    }

    /// Evaluate the density at the velocity grid's cell centres into
    /// [`Self::density`] (nothing to do for the gridded model).
    pub fn evaluate_centres(&mut self) {
        match self {
            DensityModel::Gridded(_) => {}
            DensityModel::Gridless(g) => g.evaluate_centres(),
            DensityModel::Selma(s) => s.evaluate_centres(),
        }
    }

    /// [`Self::evaluate_centres`] for every gas whose cache is stale (it
    /// stepped or was restored since its last evaluation); the gridless
    /// gases together ([`Gridless::evaluate_group`]), with one walk for
    /// those that share their velocity history.
    pub fn evaluate_all<'a>(gases: impl IntoIterator<Item = &'a mut DensityModel>) {
        let mut gridless = Vec::new();
        for model in gases {
            match model {
                DensityModel::Gridless(g) if g.stale() => gridless.push(g),
                DensityModel::Selma(s) if s.stale() => s.evaluate_centres(),
                _ => {}
            }
        }
        Gridless::evaluate_group(&mut gridless);
    }

    /// The density at the velocity grid's cell centres, as of the last
    /// [`Self::evaluate_centres`] (gridded: the representation itself).
    pub fn density(&self) -> &ScalarGrid {
        match self {
            DensityModel::Gridded(g) => g.density(),
            DensityModel::Gridless(g) => g.density(),
            DensityModel::Selma(s) => s.density(),
        }
    }

    /// Sample the current density at the cell centres of `grid`, in
    /// parallel batches of one z-slab (`cachewrite`).
    pub fn sample(&self, grid: &mut ScalarGrid) {
        match self {
            DensityModel::Gridded(g) => g.sample(grid),
            DensityModel::Gridless(g) => grid.write_field(g.field()),
            DensityModel::Selma(s) => grid.write_field(s.field()),
        }
    }

    /// [`Self::sample`] of every model into its grid (`grids[n]` for
    /// `models[n]`, one domain); gridless models that walk alike walk once
    /// for all ([`GridlessField::same_walk`]), each with its own bits.
    ///
    /// # Panics
    /// If the slices differ in length or the grids in domain.
    pub fn sample_all(models: &[&DensityModel], grids: &mut [&mut ScalarGrid]) {
        assert_eq!(models.len(), grids.len(), "sample_all: one grid per model");
        let mut gridless = Vec::new();
        let mut targets = Vec::new();
        for (model, grid) in models.iter().zip(grids.iter_mut()) {
            match model {
                DensityModel::Gridless(g) => {
                    gridless.push(g.field());
                    targets.push(&mut **grid);
                }
                other => other.sample(grid),
            }
        }
        let centres = vec![CellSamples::Centre; gridless.len()];
        gridless::write_grouped(&gridless, &centres, &mut targets);
    }

    /// An immutable snapshot of the current density as a field (for
    /// renderers): later steps do not change it.
    pub fn field(&self) -> Scalar {
        match self {
            DensityModel::Gridded(g) => g.field(),
            DensityModel::Gridless(g) => Arc::new(g.field().clone()),
            DensityModel::Selma(s) => Arc::new(s.field().clone()),
        }
    }

    /// Every buffer the representation holds (including its scratch and the
    /// cell-centre cache), for memory accounting.
    pub fn buffers(&self) -> Vec<Buffer> {
        let mut out = Vec::new();
        match self {
            DensityModel::Gridded(g) => g.buffers(&mut out),
            DensityModel::Gridless(g) => g.buffers(&mut out),
            DensityModel::Selma(s) => s.buffers(&mut out),
        }
        out
    }

    /// Bytes held, from [`Self::buffers`].
    pub fn bytes(&self) -> usize {
        total_bytes(self.buffers())
    }
    /// What changes as the density steps: the state a checkpoint keeps.
    pub fn state(&self) -> DensityState {
        match self {
            DensityModel::Gridded(g) => DensityState::Gridded(g.density().clone()),
            DensityModel::Gridless(g) => {
                let (history, centres) = g.state();
                DensityState::Gridless { history, centres }
            }
            DensityModel::Selma(s) => DensityState::Selma(Box::new(s.state())),
        }
    }

    /// Put back a [`Self::state`] of a density built with the same options.
    ///
    /// # Errors
    /// If the state is of another mode or its grids have other sizes.
    pub fn restore(&mut self, state: DensityState) -> Result<(), InputError> {
        let mismatch = || InputError::new("density state of another mode or size");
        match (self, state) {
            (DensityModel::Gridded(g), DensityState::Gridded(d)) => {
                let rho = g.density_mut();
                if d.domain() != rho.domain() {
                    return Err(mismatch());
                }
                rho.as_slice_mut().copy_from_slice(d.as_slice());
            }
            (DensityModel::Gridless(g), DensityState::Gridless { history, centres }) => {
                let d = *g.density().domain();
                if centres.domain() != &d || history.iter().any(|h| h.0.domain() != &d) {
                    return Err(mismatch());
                }
                g.restore(history, centres);
            }
            (DensityModel::Selma(s), DensityState::Selma(state)) => {
                let (md, d) = (*s.map_domain(), *s.density().domain());
                let on = |g: &Domain, e: &Domain| g == e;
                let map_on = (state.map.as_ref())
                    .is_none_or(|m| on(m.disp.domain(), &md) && on(m.lattice.domain(), &md));
                if !(map_on && on(state.reference.domain(), &md) && on(state.centres.domain(), &d))
                {
                    return Err(mismatch());
                }
                s.restore(*state);
            }
            _ => return Err(mismatch()),
        }
        Ok(())
    }
}

/// The evolving state of a [`DensityModel`] ([`DensityModel::state`]): the
/// initial density, the source, obstacles and scratch buffers are not in
/// it — they are rebuilt from the configuration. A list of them is
/// serialized through [`stored`], which keeps the gridless velocity grids
/// the gases share once.
#[derive(Clone, Debug)]
pub enum DensityState {
    /// The density grid.
    Gridded(ScalarGrid),
    /// The velocity history (grids shared between gases) and the
    /// cell-centre cache.
    Gridless {
        /// Stored steps, oldest first.
        history: Vec<HistoryStep>,
        /// The density at the cell centres after the last step.
        centres: ScalarGrid,
    },
    /// The reference density, and the map and tracked lattice if the gas
    /// owns them.
    Selma(Box<SelmaState>),
}

/// [`wrap_world`] for many points of one box, its bounds computed once:
/// the same bits.
#[derive(Clone, Copy)]
pub(crate) struct BoxWrap {
    domain: Domain,
    lo: Vec3,
    hi: Vec3,
}

impl BoxWrap {
    pub(crate) fn new(domain: &Domain) -> Self {
        let (lo, size) = (domain.origin, domain.size());
        Self {
            domain: *domain,
            lo,
            hi: lo + size,
        }
    }

    /// Whether `p` lies in the box, `lo ≤ p < hi`: where `wrap_world` keeps it.
    #[inline(always)]
    pub(crate) fn inside(&self, p: Vec3) -> bool {
        (p.cmpge(self.lo) & p.cmplt(self.hi)).bitmask() == 0b111
    }

    /// `p` wrapped into the box (unchanged inside it, as `wrap_world`).
    #[inline(always)]
    pub(crate) fn wrap(&self, p: Vec3) -> Vec3 {
        if self.inside(p) {
            p
        } else {
            wrap_world(&self.domain, p)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrapping_keeps_inside_points_and_folds_outside_ones() {
        let d = Domain::cube(8, 4.0).unwrap();
        let p = Vec3::new(0.3, 3.99, 2.0);
        assert_eq!(wrap_world(&d, p), p);
        let q = wrap_world(&d, Vec3::new(-0.5, 4.25, 13.0));
        assert!((q - Vec3::new(3.5, 0.25, 1.0)).length() < 1e-5);
    }

    #[test]
    fn shared_buffers_are_counted_once() {
        let b = [
            Buffer {
                addr: 16,
                bytes: 100,
            },
            Buffer {
                addr: 16,
                bytes: 100,
            },
            Buffer {
                addr: 400,
                bytes: 8,
            },
        ];
        assert_eq!(total_bytes(b), 108);
    }

    #[test]
    fn map_resolution_is_checked() {
        let d = Domain::cube(16, 10.0).unwrap();
        let opts = |r| DensityOptions {
            map_res: Some(r),
            ..DensityOptions::mode(DensityMode::Selma)
        };
        assert_eq!(opts(32).map_domain(&d).unwrap().dims, [32; 3]);
        assert!(opts(2).validate(&d).is_err());
        let flat = Domain::new(Vec3::ZERO, 1.0, [16, 8, 16]).unwrap();
        assert!(opts(24).validate(&flat).is_ok());
        assert!(opts(20).validate(&flat).is_ok());
        assert!(opts(21).validate(&flat).is_err());
    }
}
