//! Gridless density — §6.2 and eqs 7.1–7.4 of the notes.
//!
//! The density is never sampled onto a grid during the run. Each step keeps
//! its velocity grid `u_k` (shared between gases, [`Arc`]) and the density
//! after `n` steps is the procedural chain
//!
//! ```text
//! ρ_n(x) = ρ_{n−1}(B_n(x)) + S(x) Δt,        B_k = backtrace through u_k  (eq 7.4 + source)
//! ```
//!
//! evaluated by walking back:
//!
//! ```text
//! acc = 0
//! for k = n … 1 { acc += S(x) Δt;  x = B_k(x) }
//! acc += ρ₀(x)
//! ```
//!
//! `B_k` is [`crate::advection::departure_point`] — the very backtrace the
//! gridded path uses — so gridless and gridded densities on the same velocity
//! history differ only by the gridded path's per-step resampling. Positions
//! are wrapped into the periodic box after every backtrace, and `S`, `ρ₀` are
//! evaluated at wrapped points (the box is periodic for every field).
//!
//! # With obstacles: the walk's volume
//! With walls ([`GridlessField::set_walls`]) each sample is weighted by the
//! volume factor of the walk so far, `J = Π j_k` (`PastStep::scale_volumes`,
//! the Jacobian of `B_k` from the divergence of the velocity interpolant):
//!
//! ```text
//! acc = 0, J = 1
//! for k = n … 1 { acc += J S(x) Δt;  J *= j_k(x);  x = B_k(x) }
//! acc += J ρ₀(x)
//! ```
//!
//! — the conservative form of the chain, whose total is the injected
//! total for any velocity (change of variables), where the plain chain's is
//! only for a volume-preserving map. The discrete velocity is divergence
//! free per cell, but its trilinear interpolant is not between the cell
//! centres, least so where the flow stagnates against an obstacle: there
//! the plain walks from the layer under the slab of `slab-box` come to rest
//! beside the source instead of in it, and 20 % of the gas was lost by step
//! 200 (32³, SL; 98.4 % kept with the factor). Without obstacles the plain
//! chain keeps its injection within 2 % (`tests/density.rs`) and is left
//! as the notes have it. The positions are walked as without the factor
//! (the AVX2 kernel included); the factor takes the midpoint velocities in
//! a batch, then the interpolant's divergence there point by point
//! ([`crate::grid::face::FaceSampler::divergence_at`]), every step.
//!
//! With the RT0 interpolant ([`Interpolant::Rt0`]) the walks carry no
//! factor: its divergence is exactly the compact divergence of the cell
//! holding the point, zero to round-off in every wet cell, so `J` could
//! only differ from 1 where a walk crosses into a wall, whose extended
//! velocities are not divergence-free — and there it made the beads. On the
//! exact path through it ([`Backtrace::Exact`], Pollock's, cell by cell)
//! no walk crosses a closed face at all, so the chain is the exact
//! volume-preserving transport of the wet cells and keeps its gas; the
//! density is zero in the dry cells, as a gridded one
//! ([`WallStop::dry_world`]). Measured at slab-box 32³ (QUICK velocity, 80
//! steps; the field's integral at 4× the grid over the gas injected): the
//! exact path keeps 99.9 %, the midpoint rule on RT0 97 %, and the peak is
//! 2.19 against the gridded 2.06 (`tests/obstacles.rs`). The cells' cache
//! sums to less (91.7 %): the gas pressed against the slab's underside
//! forms layers thinner than a cell, between the cache's sample points.
//!
//! # One walk for several gases
//! The positions and `J` depend only on the start points, the velocity
//! history and the walls, which the gases of a simulation share (one
//! [`Arc`]'d snapshot per step). [`GridlessField::eval_batch_shared`] walks
//! once and lets each gas add its own `S Δt` and `ρ₀` along the walk, and
//! [`Gridless::evaluate_group`] evaluates all gases' cell centres so — the
//! per-gas operations in the per-gas order, so each gas gets the bits of a
//! walk of its own (`tests/density.rs`).
//!
//! Cost: memory grows by one velocity grid per step, and so does the cost of
//! every query — including the buoyancy term, which evaluates the density at
//! every velocity cell centre every step, so a run of `n` steps costs
//! `O(n²)` backtraces per cell. Queries are batched: a whole slice of points
//! walks back one step at a time, so each stored grid is streamed once per
//! batch and the source costs one batched call per step.

use crate::density::BackwardMap;
use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;

use super::cell_average::{cell_points, cell_values, CellSamples};
use super::{wrap_grid, Buffer, DensityMode, StepInput};
use crate::advection::{departure_points_wrapped, Backtrace};
use crate::boundary::WallStop;
use crate::domain::Domain;
use crate::field::{Scalar, ScalarField};
use crate::grid::{FaceGrid, Interpolant, ScalarGrid};

/// One stored step of the velocity history.
#[derive(Clone)]
struct PastStep {
    velocity: Arc<FaceGrid>,
    dt: f32,
    backtrace: Backtrace,
}

impl PastStep {
    /// Move grid coordinates `g` back through this step (its backtrace,
    /// [`departure_points_wrapped`]: the AVX2 kernel eight at a time, the
    /// same bits on any CPU), wrapped into the box.
    fn walk_back(&self, d: &Domain, g: &mut [Vec3]) {
        departure_points_wrapped(&self.velocity, g, self.dt / d.cell, self.backtrace);
    }
}

impl PastStep {
    /// The volume factor `j = det ∂B/∂x` of this step's backward map at
    /// each grid point `x` of `g`, multiplied into `volume`, from the
    /// divergence of the velocity interpolant at the backtrace's midpoint
    /// (its start for Euler):
    ///
    /// ```text
    /// a = Δt ∇·u(x − ½Δt u(x)),      j = (1 − a/2) / (1 + a/2)  ≈ e^{−a}
    /// ```
    ///
    /// (Cayley's rational form of `exp(−Δt ∇·u)`, the Jacobian of a
    /// backward step through a velocity of divergence `∇·u`; `a` is clamped
    /// to ±1 so that `j > 0`). The discrete velocity's cell divergences are
    /// zero, but its trilinear interpolant's divergence between the cell
    /// centres is not: at an obstacle's stagnating underside it is what
    /// loses the walks their way to the source (README, "Exact obstacles,
    /// measured").
    ///
    /// The midpoints' velocities come in one batch
    /// ([`crate::advection::sample_face_grid_points`], the same bits as the point
    /// query), into the scratch `u`.
    fn scale_volumes(&self, d: &Domain, g: &[Vec3], volume: &mut [f32], u: &mut Vec<Vec3>) {
        let dt_cells = self.dt / d.cell;
        let s = self.velocity.sampler();
        let euler = self.backtrace == Backtrace::Euler;
        u.resize(g.len(), Vec3::ZERO);
        if !euler {
            crate::advection::sample_face_grid_points(&self.velocity, g, u);
        }
        for ((v, &gi), &ui) in volume.iter_mut().zip(g).zip(u.iter()) {
            let mid = if euler { gi } else { gi - 0.5 * dt_cells * ui };
            let a = (dt_cells * s.divergence_at(mid)).clamp(-1.0, 1.0);
            *v *= (1.0 - 0.5 * a) / (1.0 + 0.5 * a);
        }
    }
}

/// The gridless density as a field: the velocity history, the source and
/// the initial density. Cloning it is cheap (the grids are shared) and the
/// clone is an immutable snapshot.
#[derive(Clone)]
pub struct GridlessField {
    domain: Domain,
    steps: Vec<PastStep>,
    initial: Option<Scalar>,
    source: Option<Scalar>,
    /// Obstacles: the density is zero inside them.
    walls: Option<Arc<WallStop>>,
}

impl GridlessField {
    /// No steps yet: the field is `initial` (zero if `None`), wrapped
    /// periodically into `domain`, the velocity grid's box.
    pub fn new(domain: Domain, initial: Option<Scalar>, source: Option<Scalar>) -> Self {
        Self {
            domain,
            steps: Vec::new(),
            initial,
            source,
            walls: None,
        }
    }

    /// Read zero inside `walls`, and weight the walks by their volume
    /// (module documentation; not through an RT0 velocity). Walks are *not* stopped at their surface:
    /// measured, stopping them loses more gas (slab-box 32³, SL, step 100:
    /// 62 % of the injected gas in the fluid cells with the stop, 94 %
    /// without; moving them to the surface after every stored step, on the
    /// plain run's history, 69 % against 94 %) — a walk stopped on a wall
    /// stays in its stagnant flow and does not reach the source again.
    pub fn set_walls(&mut self, walls: Arc<WallStop>) {
        self.walls = Some(walls);
    }

    /// Append one step: advect with `velocity` over `dt`, then inject `S Δt`.
    ///
    /// # Panics
    /// If `velocity` is on another domain.
    pub fn push(&mut self, velocity: Arc<FaceGrid>, dt: f32, backtrace: Backtrace) {
        assert_eq!(
            velocity.domain(),
            &self.domain,
            "gridless: velocity on another domain"
        );
        self.steps.push(PastStep {
            velocity,
            dt,
            backtrace,
        });
    }

    /// Number of steps taken.
    pub fn steps(&self) -> usize {
        self.steps.len()
    }

    /// The stored velocity grids, oldest first.
    pub fn velocities(&self) -> impl Iterator<Item = &Arc<FaceGrid>> {
        self.steps.iter().map(|s| &s.velocity)
    }

    /// The stored steps, oldest first: velocity grid, Δt and backtrace
    /// (what a bound on the chain's support needs, [`super::occupancy`]).
    pub fn history(&self) -> impl DoubleEndedIterator<Item = (&FaceGrid, f32, Backtrace)> {
        self.steps.iter().map(|s| (&*s.velocity, s.dt, s.backtrace))
    }

    /// The velocity grid's domain, the box the walk is wrapped into.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// Whether the chain injects a source `S Δt` at every step.
    pub fn has_source(&self) -> bool {
        self.source.is_some()
    }
}

impl BackwardMap for GridlessField {
    /// The backward map of the whole chain, `X_n = B_1 ∘ B_2 ∘ … ∘ B_n`
    /// (eq 7.4 without the source): each world point walked back through
    /// every stored step, newest first, wrapped into the box. The
    /// source-free gridless density is `ρ₀ ∘ X_n`.
    ///
    /// # Panics
    /// If the slices differ in length.
    fn map_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(points.len(), out.len(), "map_batch: slice lengths differ");
        let d = &self.domain;
        for (o, &p) in out.iter_mut().zip(points) {
            *o = wrap_grid(d.grid_coords(p), d.dims);
        }
        for step in self.steps.iter().rev() {
            step.walk_back(d, out);
        }
        for o in out.iter_mut() {
            *o = d.world_of(*o);
        }
    }
}

impl ScalarField for GridlessField {
    fn eval(&self, p: Vec3) -> f32 {
        let mut out = [0.0];
        self.eval_batch(&[p], &mut out);
        out[0]
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        Self::eval_batch_shared(&[self], points, &mut [out]);
    }
}

impl GridlessField {
    /// Whether `other` walks back the same way as `self`: the same domain,
    /// the same stored steps (the same shared velocity grids, Δt and
    /// backtraces) and the same walls — the walk's positions and volume
    /// depend on nothing else, so two such fields can share one walk
    /// ([`Self::eval_batch_shared`]).
    pub fn same_walk(&self, other: &GridlessField) -> bool {
        let same_step = |a: &PastStep, b: &PastStep| {
            Arc::ptr_eq(&a.velocity, &b.velocity)
                && a.dt.to_bits() == b.dt.to_bits()
                && a.backtrace == b.backtrace
        };
        let same_walls = match (&self.walls, &other.walls) {
            (None, None) => true,
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            _ => false,
        };
        self.domain == other.domain
            && self.steps.len() == other.steps.len()
            && self
                .steps
                .iter()
                .zip(&other.steps)
                .all(|(a, b)| same_step(a, b))
            && same_walls
    }

    /// [`ScalarField::eval_batch`] of every field of `fields` at the same
    /// `points` into `outs[f]`, with one walk (module documentation): the
    /// positions and the volume factor are computed once, and each field
    /// adds its own source `S Δt` along the walk and its `ρ₀` at the end —
    /// per field the same operations in the same order as a walk of its
    /// own, so the same bits.
    ///
    /// # Panics
    /// If `fields` is empty, a field does not walk as the first
    /// ([`Self::same_walk`]), or the slices differ in length.
    pub fn eval_batch_shared(fields: &[&GridlessField], points: &[Vec3], outs: &mut [&mut [f32]]) {
        let first = fields.first().expect("eval_batch_shared: no fields");
        assert!(
            fields.iter().all(|f| first.same_walk(f)),
            "eval_batch_shared: the fields walk different histories"
        );
        assert_eq!(
            fields.len(),
            outs.len(),
            "eval_batch_shared: one output per field"
        );
        assert!(
            outs.iter().all(|o| o.len() == points.len()),
            "eval_batch_shared: slice lengths differ"
        );
        let d = &first.domain;
        let mut g: Vec<Vec3> = points
            .iter()
            .map(|&p| wrap_grid(d.grid_coords(p), d.dims))
            .collect();
        let mut world = vec![Vec3::ZERO; points.len()];
        let mut values = vec![0.0f32; points.len()];
        // With obstacles, the volume carried along each walk (module
        // documentation); without, 1.
        let mut volume = vec![1.0f32; points.len()];
        let mut velocity = Vec::new();
        for out in outs.iter_mut() {
            out.fill(0.0);
        }
        // Add `scale · term(x) · J` of each field's `term` (its source or
        // its ρ₀) at the walk's current points `x` into its output; the
        // world points are computed once for all fields.
        let mut add = |g: &[Vec3],
                       term: &dyn Fn(&GridlessField) -> Option<&Scalar>,
                       scale: f32,
                       volume: &[f32]| {
            let mut world_done = false;
            for (field, out) in fields.iter().zip(outs.iter_mut()) {
                let Some(term) = term(field) else { continue };
                if !world_done {
                    for (w, &gi) in world.iter_mut().zip(g) {
                        *w = d.world_of(gi);
                    }
                    world_done = true;
                }
                term.eval_batch(&world, &mut values);
                for ((o, s), v) in out.iter_mut().zip(&values).zip(volume) {
                    *o += s * scale * v;
                }
            }
        };
        for step in first.steps.iter().rev() {
            add(&g, &|f| f.source.as_ref(), step.dt, &volume);
            if first.walls.is_some() && step.velocity.interpolant() != Interpolant::Rt0 {
                step.scale_volumes(d, &g, &mut volume, &mut velocity);
            }
            step.walk_back(d, &mut g);
        }
        add(&g, &|f| f.initial.as_ref(), 1.0, &volume);
        first.clear_dry(points, outs);
    }

    /// Zero every output of `outs` at the `points` in dry cells ([`WallStop::dry_world`]).
    fn clear_dry(&self, points: &[Vec3], outs: &mut [&mut [f32]]) {
        if let Some(w) = &self.walls {
            for (p, i) in points.iter().zip(0..) {
                if w.dry_world(*p) {
                    for out in outs.iter_mut() {
                        out[i] = 0.0;
                    }
                }
            }
        }
    }
}

/// A gridless density and its cache on the velocity grid's cells: the cell
/// averages, or the values at the centres ([`CellSamples`]).
#[derive(Clone)]
pub struct Gridless {
    field: GridlessField,
    samples: CellSamples,
    centres: ScalarGrid,
    /// Whether the history moved on (or was restored) since `centres` was
    /// last evaluated.
    stale: bool,
}

impl Gridless {
    /// A density starting at `initial`, injected at rate `source`, on the
    /// velocity grid `domain`, cached as cell averages.
    pub fn new(domain: Domain, initial: Option<Scalar>, source: Option<Scalar>) -> Self {
        let mut gas = Self {
            field: GridlessField::new(domain, initial, source),
            samples: CellSamples::default_for(DensityMode::Gridless),
            centres: ScalarGrid::zeros(domain),
            stale: true,
        };
        gas.evaluate_centres();
        gas
    }

    /// The same density cached with `samples` points per cell (the cache
    /// re-evaluated).
    pub fn with_cell_samples(mut self, samples: CellSamples) -> Self {
        if samples != self.samples {
            self.samples = samples;
            self.evaluate_centres();
        }
        self
    }

    /// Keep the step's velocity (no computation: the work is in every query).
    ///
    /// # Panics
    /// If the input has no velocity snapshot.
    pub fn step(&mut self, input: &StepInput<'_>) {
        let u = input
            .snapshot
            .expect("gridless density needs the step's velocity snapshot");
        self.field.push(Arc::clone(u), input.dt, input.backtrace);
        self.stale = true;
    }

    /// Zero density inside `walls` ([`GridlessField::set_walls`]).
    pub fn set_walls(&mut self, walls: Arc<WallStop>) {
        self.field.set_walls(walls);
    }

    /// Walk back from every cell's sample points (the buoyancy input and
    /// the saved volumes): the cell averages `ρ̄_c ≈ (1/8) Σ_s ρ(X(x_c +
    /// δ_s Δx))` over the 2×2×2 sub-cell points, or the centre values
    /// ([`CellSamples`], [`super::cell_average`]); zero in the cells whose
    /// centres lie inside the walls, as a gridded density's dry cells.
    pub fn evaluate_centres(&mut self) {
        Self::evaluate_group(&mut [self]);
    }

    /// [`Self::evaluate_centres`] for every gas of `gases`: the gases that
    /// walk the same history ([`GridlessField::same_walk`] — in a simulation,
    /// all of them: they share its velocity snapshots) and sample alike with
    /// one walk per z-slab of sample points
    /// ([`GridlessField::eval_batch_shared`]), in parallel slabs; the same
    /// bits as evaluating each gas alone.
    pub fn evaluate_group(gases: &mut [&mut Gridless]) {
        let samples: Vec<CellSamples> = gases.iter().map(|g| g.samples).collect();
        let (fields, mut centres): (Vec<_>, Vec<_>) =
            gases.iter_mut().map(|g| (&g.field, &mut g.centres)).unzip();
        write_grouped(&fields, &samples, &mut centres);
        for g in gases.iter_mut() {
            g.stale = false;
        }
    }

    /// Whether the history moved on (or was restored) since the cache was
    /// last evaluated.
    pub fn stale(&self) -> bool {
        self.stale
    }

    /// The density on the cells, as evaluated by [`Self::evaluate_centres`].
    ///
    /// # Panics
    /// If the gas stepped or was restored since (call
    /// `Simulation::evaluate_densities` first): a stale cache is never read.
    pub fn density(&self) -> &ScalarGrid {
        assert!(
            !self.stale,
            "gridless density read before it was evaluated after a step \
             (call Simulation::evaluate_densities first)"
        );
        &self.centres
    }

    /// The density as a field.
    pub fn field(&self) -> &GridlessField {
        &self.field
    }

    pub(super) fn buffers(&self, out: &mut Vec<Buffer>) {
        out.push(Buffer::of_scalar(&self.centres));
        out.extend(self.field.velocities().map(|u| Buffer::of_faces(u)));
    }
    /// The stored steps, oldest first, and the cell-centre cache: what a
    /// checkpoint keeps (the initial density, source and walls are rebuilt
    /// from the configuration).
    pub fn state(&self) -> (Vec<HistoryStep>, ScalarGrid) {
        let steps = self.field.steps.iter();
        let history = steps
            .map(|s| (Arc::clone(&s.velocity), s.dt, s.backtrace))
            .collect();
        (history, self.centres.clone())
    }

    /// Put back what [`Self::state`] returned (history and cache).
    ///
    /// # Panics
    /// If a grid is on another domain.
    pub fn restore(&mut self, history: Vec<HistoryStep>, centres: ScalarGrid) {
        assert_eq!(
            centres.domain(),
            self.centres.domain(),
            "gridless: cache domain"
        );
        self.field.steps.clear();
        for (velocity, dt, backtrace) in history {
            self.field.push(velocity, dt, backtrace);
        }
        self.centres = centres;
        self.stale = true;
    }
}

/// `grids[f] = fields[f]` on the cells of the grids (one domain), sampled
/// with `samples` per cell ([`CellSamples`]; cells whose centres lie inside
/// the walls zero), from one walk per z-slab: the fields walk alike
/// ([`GridlessField::eval_batch_shared`]).
///
/// The cell average is adaptive: every centre is walked first, and then the
/// cells whose 3×3×3 block of centre values varies by more than
/// [`REFINE_LEVEL`] of the field's maximum are walked again from their eight
/// sub-cell points ([`refined_cells`]). Elsewhere the field is resolved at
/// the centres' spacing and the centre value is the cell average to within
/// that variation. Gas reaches few of the cells (slab-box at 32³: 15 % of
/// the blocks hold any by step 100), so the average costs about
/// `1 + 8 × (share of cells refined)` walks per cell instead of eight. Each
/// field's cells are chosen from its own values, so each gets the bits it
/// would get alone.
fn write_shared(fields: &[&GridlessField], samples: CellSamples, grids: &mut [&mut ScalarGrid]) {
    let domain = *grids[0].domain();
    assert!(
        grids.iter().all(|g| *g.domain() == domain),
        "gridless: the grids of a shared walk are on one domain"
    );
    let order = walk_order(domain.dims[0], domain.dims[1]);
    let every = SlabCells {
        writes: vec![true; order.len() * fields.len()],
        cells: order,
    };
    let all = vec![every; domain.dims[2]];
    walk_cells(fields, CellSamples::Centre, grids, &all);
    if samples == CellSamples::Average {
        let refined = refined_cells(grids, &all[0].cells);
        walk_cells(fields, samples, grids, &refined);
    }
}

/// A cell is walked again from its sub-cell points when the centre values
/// of its 3×3×3 block span more than this share of the field's maximum:
/// below the 5 % level of the isolated-blob measure
/// ([`crate::metrics::blobs`]), so that no speck above it is left a point
/// sample.
pub const REFINE_LEVEL: f32 = 0.01;

/// The cells of one z-slab to walk (slab indices, in walk order) and, for
/// cell `i` and field `f`, whether `f` takes the result (`writes[i·F + f]`,
/// `F` fields).
#[derive(Clone)]
struct SlabCells {
    cells: Vec<usize>,
    writes: Vec<bool>,
}

/// Per z-slab, the cells (in `order`) whose 3×3×3 block of values in some
/// grid of `grids` spans more than [`REFINE_LEVEL`] of that grid's maximum
/// (periodic neighbours), and which grids those are. Deterministic: maxima
/// and spans are exact in any order.
fn refined_cells(grids: &[&mut ScalarGrid], order: &[usize]) -> Vec<SlabCells> {
    let d = *grids[0].domain();
    let [nx, _, nz] = d.dims;
    let levels: Vec<f32> = grids
        .iter()
        .map(|g| REFINE_LEVEL * g.as_slice().par_iter().copied().reduce(|| 0.0, f32::max))
        .collect();
    let varies = |g: &ScalarGrid, level: f32, c: [usize; 3]| {
        let v = g.as_slice();
        let (lo, hi) = (d.block(c).map(|n| v[n]))
            .fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), x| {
                (lo.min(x), hi.max(x))
            });
        hi - lo > level
    };
    (0..nz)
        .into_par_iter()
        .map(|k| {
            let mut slab = SlabCells {
                cells: Vec::new(),
                writes: Vec::new(),
            };
            for &c in order {
                let at = [c % nx, c / nx, k];
                let writes = grids.iter().zip(&levels).map(|(g, &l)| varies(g, l, at));
                let start = slab.writes.len();
                slab.writes.extend(writes);
                if slab.writes[start..].contains(&true) {
                    slab.cells.push(c);
                } else {
                    slab.writes.truncate(start);
                }
            }
            slab
        })
        .collect()
}

/// `grids[f] = fields[f]` on the chosen cells of each z-slab (`slabs[k]`),
/// sampled with `samples` per cell ([`cell_points`], [`cell_values`]; zero
/// where the centre lies inside the walls), the slabs in parallel, each
/// with one walk for all fields; the other cells are left as they are.
fn walk_cells(
    fields: &[&GridlessField],
    samples: CellSamples,
    grids: &mut [&mut ScalarGrid],
    slabs: &[SlabCells],
) {
    let domain = *grids[0].domain();
    let slab = domain.dims[0] * domain.dims[1];
    let mut chunks: Vec<_> = grids
        .iter_mut()
        .map(|g| g.as_slice_mut().chunks_mut(slab))
        .collect();
    let outs: Vec<Vec<&mut [f32]>> = (0..domain.dims[2])
        .map(|_| {
            let next = chunks.iter_mut().map(|c| c.next());
            next.map(|s| s.expect("one slab per z")).collect()
        })
        .collect();
    outs.into_par_iter().zip(slabs).enumerate().for_each_init(
        || {
            let points = (Vec::new(), Vec::new(), Vec::new());
            (
                points,
                vec![Vec::new(); fields.len()],
                vec![Vec::new(); fields.len()],
            )
        },
        |((centres, chosen, points), values, means), (k, (outs, slab))| {
            if slab.cells.is_empty() {
                return;
            }
            domain.slab_centers(k, centres);
            chosen.clear();
            chosen.extend(slab.cells.iter().map(|&c| centres[c]));
            cell_points(&domain, samples, chosen, points);
            for (v, m) in values.iter_mut().zip(means.iter_mut()) {
                v.resize(points.len(), 0.0);
                m.resize(chosen.len(), 0.0);
            }
            let mut walked: Vec<&mut [f32]> = values.iter_mut().map(|v| &mut v[..]).collect();
            GridlessField::eval_batch_shared(fields, points, &mut walked);
            for (v, m) in values.iter().zip(means.iter_mut()) {
                cell_values(samples, v, m);
            }
            let mut dry: Vec<&mut [f32]> = means.iter_mut().map(|m| &mut m[..]).collect();
            fields[0].clear_dry(chosen, &mut dry);
            let nf = fields.len();
            for (f, (out, m)) in outs.into_iter().zip(&*means).enumerate() {
                for (i, (&c, &v)) in slab.cells.iter().zip(m).enumerate() {
                    if slab.writes[i * nf + f] {
                        out[c] = v;
                    }
                }
            }
        },
    );
}

/// The order in which one z-slab's cell centres (rows of `nx`, `ny` rows)
/// are walked, so that the groups of the sixteen-lane kernel keep to few
/// lattice rows and away from the box's x edge, where their stencils are
/// fetched by row windows ([`crate::advection::departure_points`]): runs of
/// sixteen cells inside each row from its second cell on; then the inner
/// cells the runs leave, row after row; then the rows' two ends, whose
/// stencils wrap. A point's walk does not depend on its group: the same
/// bits in any order. (Walked in plain row order, a group took in a row's
/// end whenever `nx` is not a multiple of sixteen.)
fn walk_order(nx: usize, ny: usize) -> Vec<usize> {
    const RUN: usize = 16;
    let runs = 1..1 + nx.saturating_sub(2) / RUN * RUN;
    let inner = 1..nx.saturating_sub(1).max(1);
    let rows = |cells: &dyn Fn(usize) -> bool| -> Vec<usize> {
        (0..ny)
            .flat_map(|j| (0..nx).filter(|&i| cells(i)).map(move |i| j * nx + i))
            .collect()
    };
    let mut order = rows(&|i| runs.contains(&i));
    order.extend(rows(&|i| inner.contains(&i) && !runs.contains(&i)));
    order.extend(rows(&|i| !inner.contains(&i)));
    order
}

/// `grids[f] = fields[f]` on the cells of the grids (one domain) with
/// `samples[f]` points per cell, one walk per group of fields that walk
/// alike ([`GridlessField::same_walk`]) and sample alike.
pub(super) fn write_grouped(
    fields: &[&GridlessField],
    samples: &[CellSamples],
    grids: &mut [&mut ScalarGrid],
) {
    let mut groups: Vec<Vec<usize>> = Vec::new();
    for (n, f) in fields.iter().enumerate() {
        let alike = |g: &&mut Vec<usize>| fields[g[0]].same_walk(f) && samples[g[0]] == samples[n];
        match groups.iter_mut().find(alike) {
            Some(g) => g.push(n),
            None => groups.push(vec![n]),
        }
    }
    for group in groups {
        let members: Vec<&GridlessField> = group.iter().map(|&n| fields[n]).collect();
        let mut targets: Vec<&mut ScalarGrid> = (grids.iter_mut().enumerate())
            .filter(|(n, _)| group.contains(n))
            .map(|(_, g)| &mut **g)
            .collect();
        write_shared(&members, samples[group[0]], &mut targets);
    }
}

/// One stored step of a gridless history: its velocity grid (shared between
/// gases), Δt and backtrace.
pub type HistoryStep = (Arc<FaceGrid>, f32, Backtrace);

#[cfg(test)]
mod tests {
    use super::walk_order;

    /// Every cell once; the first groups of sixteen each inside one row and
    /// off its ends; the ends last.
    #[test]
    fn walk_order_is_a_permutation_with_row_runs_first() {
        for (nx, ny) in [(40, 3), (50, 2), (18, 4), (17, 2), (2, 3), (1, 1)] {
            let order = walk_order(nx, ny);
            let mut seen = order.clone();
            seen.sort_unstable();
            assert_eq!(seen, (0..nx * ny).collect::<Vec<_>>(), "{nx}×{ny}");
            let runs = (nx.saturating_sub(2) / 16) * ny;
            for group in order.chunks_exact(16).take(runs) {
                let row = group[0] / nx;
                assert!(
                    group
                        .iter()
                        .all(|&c| c / nx == row && c % nx != 0 && c % nx != nx - 1),
                    "{nx}×{ny}: {group:?}"
                );
            }
            let ends = if nx > 1 { 2 * ny } else { ny };
            assert!(
                order[nx * ny - ends..]
                    .iter()
                    .all(|&c| c % nx == 0 || c % nx == nx - 1),
                "{nx}×{ny}: the rows' ends come last"
            );
        }
    }
}
