//! SELMA — semi-Lagrangian mapping (ch. 8, eqs 8.1–8.8), with continuous
//! injection at bounded memory.
//!
//! # The map
//!
//! Gridless advection is a remapping of the initial density (eqs 8.1–8.7):
//! `ρ_n = ρ₀ ∘ X_n`, with the backward map advected like any other quantity,
//!
//! ```text
//! X_n(x) = X_{n−1}(B_n(x))            (eq 8.8, B_n = the step's backtrace)
//! ```
//!
//! and sampled onto its own grid every step (the notes' `XmapCache`). The
//! map grid has `--map-res` cells along the longest axis — by default the
//! velocity grid's, finer for the notes' SELMA^fine. `X` is the identity
//! plus a displacement, and the identity is not periodic: the grid stores
//! the **displacement** `D = X − x`, which is, so interpolating across the
//! periodic seam is exact. It is held one grid per component, the layout the
//! sweep kernels sample. `B_n` is [`crate::advection::departure_point`], the
//! backtrace of the gridded and gridless paths. When the map grid is the
//! velocity grid its nodes are the cell centres, and eq 8.8 is the gridded
//! path's cell sweep of three densities plus the trace's offset
//! ([`advect_map`]: rows traced and sampled through the vector kernels,
//! [`CellRows`]); the density at the cell centres reads `X`
//! off the nodes. A finer map grid traces its nodes [`NODE_GROUP`] points at
//! a time through the gridless walk's vector kernels. `D` and `R` are read
//! at arbitrary points through the sweeps' sampling kernels too
//! ([`crate::advection::semi_lagrangian::sample_points`]), in chunks on the
//! stack.
//!
//! # One map for all gases
//!
//! Every gas is moved by the same velocity, so the gases' maps and tracked
//! lattices are the same numbers; only `R` (below) differs. [`step_group`]
//! keeps one [`SelmaMap`] for the gases whose maps agree: advected and its
//! lattice moved once per step, each gas injecting its own source, all
//! gases re-anchored together when the shared lattice has deformed too far.
//! Each gas gets the bits it would get alone (`tests` below).
//!
//! # Continuous injection
//!
//! With a source, the density since the last *re-anchoring* at step `r` is
//!
//! ```text
//! ρ_n(x) = ρ_r(X_n(x)) + Σ_{k=r+1…n} S(X_{n→k}(x)) Δt
//! ```
//!
//! where `X_n` now maps step `n` back to step `r` and `X_{n→k}` maps it back
//! to step `k`. Because `X_{n→k} = Y_k ∘ X_n`, with `Y_k = X_k⁻¹` the forward
//! map from reference coordinates to step `k`, the injected sum is a function
//! of the reference point alone:
//!
//! ```text
//! ρ_n(x) = R(X_n(x)),    R(ξ) = ρ_r(ξ) + Σ_k S(Y_k(ξ)) Δt
//! ```
//!
//! — the source is accumulated in reference
//! coordinates on the map lattice. `Y_k(ξ)` of every lattice node is tracked
//! forward by inverting the step's backtrace with a fixed-point iteration,
//! `y' ← y + (y' − B(y'))`, so the injected gas lands where the backtrace
//! says (to `(Δt|∇u|)³` relative). The source is averaged over the 2×2×2
//! sub-points of a map cell around `Y_k(ξ)`, so the injected mass equals the
//! source integral at twice the map resolution — the quadrature the run's
//! fine metrics use.
//!
//! A forward-tracked lattice deforms without bound, and with it the sampling
//! of the fresh source: reference neighbours drift apart in the flow's
//! stretching directions, and gas injected at one node is interpolated
//! toward nodes now far away (streaks, lost mass). So the map is
//! **re-anchored** when the lattice has deformed
//! too far: when some pair of neighbouring reference nodes has moved more
//! than `τ` map cells relative to each other
//! ([`Selma::lattice_deformation`]; `--selma-remap τ`, default
//! [`super::DEFAULT_SELMA_REMAP`]). Re-anchoring resamples `R` as the 2×2×2
//! box average of the current density over each map cell, resets `X` to
//! the identity and the lattice to rest. In the hot/cold flow at 32³ this
//! happens every ~30 steps while the flow is slow and every ~10 once the
//! plumes collide. `τ = 0` never re-anchors (pure design (a), the notes'
//! SELMA for a source-free `ρ₀`).
//!
//! The measure sees every pair of neighbours in the box, gas or not, so a
//! velocity that jumps across the periodic seam re-anchors the map however
//! still the gas is. Zalesak's rigid rotation `ω(c − y, x − c, 0)` in a
//! periodic box jumps by `ωL` across `y = 0 ≡ L`: with one turn in 80 steps
//! at 32³ (experiment V-1), the rows either side of the seam part by
//! `2π/80 · 31 ≈ 2.4` cells a step, above the default τ = 2, so the map is
//! re-anchored at every step and the density box-filtered as often —
//! why V-1's re-anchored SELMA returns worse than SL there (L1 1.53 against
//! 1.18; measured with `smokelab run zalesak --res 32 --frames 80 --set
//! dt=7.85 --density selma`: τ = 2.6 gives L1 1.23, τ = 5 gives 1.04, and
//! τ = 0, one map interpolated across the seam's image, 1.00 with the mass
//! up 89 %).
//!
//! Memory: 9 floats per map cell for the shared map (`D` and its scratch,
//! the tracked lattice `Y`) and 2 per gas (`R` and its scratch), constant in
//! the number of steps; a query is one interpolation of `D` and one of `R`,
//! also constant.
//!
//! # Error
//!
//! Against gridless on the same velocity history, with map cell `h`:
//! - the map's interpolation, `O(h²)` per step on smooth maps (the notes'
//!   SELMA; `tests/density.rs` measures order ≈ 2 without sources);
//! - the fresh source sampled on the deformed lattice and reconstructed
//!   trilinearly in reference coordinates: edges of the injected gas blurred
//!   over about one (deformed) map cell — grows with the time since the
//!   last re-anchoring;
//! - one density resampling per re-anchoring (box filter of width `h` plus
//!   trilinear reconstruction), instead of the gridded path's every step;
//!   mass is kept to the fine quadrature's accuracy;
//! - `ρ₀` is composed analytically until the first re-anchoring, then
//!   carried on the map grid.
//!
//! Every term vanishes as `h → 0` for any `τ`, so SELMA converges to the
//! gridless density as the map grid refines.

use crate::density::BackwardMap;
use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::cell_average::{cell_points, cell_values, sub_points, sub_sum, CellSamples, SUB};
use super::{BoxWrap, Buffer, DensityMode, StepInput};
use crate::advection::semi_lagrangian::{sample_points, CellRows};
use crate::advection::{departure_points, Backtrace};
use crate::boundary::WallStop;
use crate::domain::Domain;
use crate::field::{eval_supported, Bounds, Scalar, ScalarField};
use crate::grid::{FaceGrid, ScalarGrid, VectorGrid};

/// Map nodes traced together: sixteen, the lanes of the AVX-512 walk kernel
/// (two groups of the AVX2 kernel's eight), kept on the stack.
const NODE_GROUP: usize = 16;

/// Corrector iterations of the forward (inverse-backtrace) step of the
/// tracked lattice, after the forward-trace predictor.
const FORWARD_ITERATIONS: usize = 1;

/// Map nodes per stack chunk of injection, re-anchoring and composed
/// evaluation: a chunk's 2×2×2 sub-points (256) stay in the L1 cache, and
/// nothing is allocated.
const CHUNK: usize = 32;

/// The map's displacement `D = X − x` on the map lattice, world units, one
/// cell-centred grid per component.
#[derive(Clone)]
struct Displacement([ScalarGrid; 3]);

impl Displacement {
    /// `D = 0`: the identity map.
    fn zeros(md: Domain) -> Self {
        Self(std::array::from_fn(|_| ScalarGrid::zeros(md)))
    }

    fn domain(&self) -> &Domain {
        self.0[0].domain()
    }

    /// `D` at the grid coordinates `g` (x, y, z lanes) into `out`
    /// (component lanes), through [`sample_points`].
    fn sample(&self, g: [&[f32]; 3], out: [&mut [f32]; 3]) {
        for (c, out) in self.0.iter().zip(out) {
            sample_points(c.as_slice(), (c.domain().dims, c.wrap()), g, out);
        }
    }

    /// Every component's samples.
    fn slices(&self) -> [&[f32]; 3] {
        self.0.each_ref().map(|c| c.as_slice())
    }

    /// As one interleaved grid (a checkpoint's [`MapState::disp`]).
    fn to_vector(&self) -> VectorGrid {
        let mut v = VectorGrid::zeros(*self.domain());
        let [dx, dy, dz] = self.slices();
        for (n, o) in v.as_vec3_mut().iter_mut().enumerate() {
            *o = Vec3::new(dx[n], dy[n], dz[n]);
        }
        v
    }

    /// From one interleaved grid.
    fn from_vector(v: &VectorGrid) -> Self {
        let mut d = Self::zeros(*v.domain());
        for (n, x) in v.as_vec3().iter().enumerate() {
            for (c, x) in d.0.iter_mut().zip(x.to_array()) {
                c.as_slice_mut()[n] = x;
            }
        }
        d
    }
}

/// Grid coordinates on `d` of `points`, as x, y, z lanes in `out` (each
/// `points.len()` long): [`Domain::grid_coords`]'s operations, one lane at
/// a time so that the divisions run in vector registers (the same bits).
fn grid_lanes<'a>(d: &Domain, points: &[Vec3], out: [&'a mut [f32]; 3]) -> [&'a [f32]; 3] {
    let [gx, gy, gz] = out;
    for (a, lane) in [&mut *gx, &mut *gy, &mut *gz].into_iter().enumerate() {
        for (g, p) in lane.iter_mut().zip(points) {
            *g = p[a];
        }
        let (o, h) = (d.origin[a], d.cell);
        for g in lane.iter_mut() {
            *g = (*g - o) / h - 0.5;
        }
    }
    [gx, gy, gz]
}

/// Three lanes of `8·CHUNK` floats on the stack, cut to `n`.
fn lanes(buf: &mut [[f32; 8 * CHUNK]; 3], n: usize) -> [&mut [f32]; 3] {
    let [x, y, z] = buf;
    [&mut x[..n], &mut y[..n], &mut z[..n]]
}

/// The SELMA density as a field, `ρ(x) = ρ₀(X(x)) + R(X(x))` with
/// `X(x) = x + D(x)`. Cloning shares the grids (copy-on-write in the model),
/// so a clone is an immutable snapshot.
#[derive(Clone)]
pub struct SelmaField {
    /// `D = X − x` on the map lattice, world units.
    disp: Arc<Displacement>,
    /// `R(ξ)`: the density in reference coordinates.
    reference: Arc<ScalarGrid>,
    /// `ρ₀`, composed analytically until the first re-anchoring.
    initial: Option<Scalar>,
    /// Obstacles: map and lattice updates stop at their surface, the
    /// density is zero inside.
    walls: Option<Arc<WallStop>>,
}

impl BackwardMap for SelmaField {
    /// The map `X(x)` at world points (wrapped into the box).
    fn map_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(points.len(), out.len(), "map_batch: slice lengths differ");
        let md = self.disp.domain();
        let into_box = BoxWrap::new(md);
        let (mut g, mut d) = ([[0.0; 8 * CHUNK]; 3], [[0.0; 8 * CHUNK]; 3]);
        for (points, out) in points.chunks(8 * CHUNK).zip(out.chunks_mut(8 * CHUNK)) {
            let n = points.len();
            self.disp
                .sample(grid_lanes(md, points, lanes(&mut g, n)), lanes(&mut d, n));
            for (m, (x, &p)) in out.iter_mut().zip(points).enumerate() {
                *x = into_box.wrap(p + Vec3::new(d[0][m], d[1][m], d[2][m]));
            }
        }
    }
}

impl ScalarField for SelmaField {
    fn eval(&self, p: Vec3) -> f32 {
        let mut out = [0.0];
        self.eval_batch(&[p], &mut out);
        out[0]
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        self.composed(points, out);
        self.clear_dry(points, out);
    }
}

impl SelmaField {
    /// `ρ₀(X(x)) + R(X(x))` at every point, inside obstacles too (where the
    /// stopped map reads the density at their surface): what re-anchoring
    /// resamples, so that a reference cell straddling a wall keeps its gas.
    fn composed(&self, points: &[Vec3], out: &mut [f32]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        let mut xi = [Vec3::ZERO; 8 * CHUNK];
        for (points, out) in points.chunks(8 * CHUNK).zip(out.chunks_mut(8 * CHUNK)) {
            let xi = &mut xi[..points.len()];
            self.map_batch(points, xi);
            self.at_reference(xi, out);
        }
    }

    /// `ρ₀(ξ) + R(ξ)` at reference points `xi`; `R` through
    /// [`sample_points`], the bits of its point query.
    fn at_reference(&self, xi: &[Vec3], out: &mut [f32]) {
        assert_eq!(xi.len(), out.len(), "at_reference: slice lengths differ");
        let r = &*self.reference;
        let mut g = [[0.0; 8 * CHUNK]; 3];
        for (xi, out) in xi.chunks(8 * CHUNK).zip(out.chunks_mut(8 * CHUNK)) {
            let g = grid_lanes(r.domain(), xi, lanes(&mut g, xi.len()));
            sample_points(r.as_slice(), (r.domain().dims, r.wrap()), g, out);
        }
        if let Some(initial) = &self.initial {
            let mut r0 = [0.0; 8 * CHUNK];
            for (xi, out) in xi.chunks(8 * CHUNK).zip(out.chunks_mut(8 * CHUNK)) {
                let r0 = &mut r0[..xi.len()];
                initial.eval_batch(xi, r0);
                for (o, r) in out.iter_mut().zip(&*r0) {
                    *o += r;
                }
            }
        }
    }

    /// Zero where `points` lie in dry cells ([`WallStop::dry_world`]).
    fn clear_dry(&self, points: &[Vec3], out: &mut [f32]) {
        if let Some(w) = &self.walls {
            for (o, &p) in out.iter_mut().zip(points) {
                if w.dry_world(p) {
                    *o = 0.0;
                }
            }
        }
    }
}

/// The backward map `X = x + D` and the tracked reference lattice `Y`,
/// advected once per step for every SELMA gas that shares them: the gases
/// of a run are moved by the same velocity, so their maps and lattices are
/// the same numbers, and only the reference densities `R` differ.
#[derive(Clone)]
pub struct SelmaMap {
    /// `D = X − x` on the map lattice, world units; each sharing gas's
    /// field holds a clone of this `Arc`.
    disp: Arc<Displacement>,
    /// The previous `D`, overwritten by the next step (unshared then, so
    /// nothing is copied; a live snapshot makes the step allocate instead).
    spare: Arc<Displacement>,
    /// World positions `Y(ξ)` of the reference lattice nodes, wrapped.
    lattice: VectorGrid,
    /// Re-anchoring threshold in map cells (0: never).
    remap: f32,
    /// Obstacles: the map and the lattice stop at their surface.
    walls: Option<Arc<WallStop>>,
}

impl SelmaMap {
    /// The identity map on `map`, at rest.
    fn new(map: Domain, remap: f32, walls: Option<Arc<WallStop>>) -> Self {
        let mut lattice = VectorGrid::zeros(map);
        reset_lattice(&mut lattice);
        Self {
            disp: Arc::new(Displacement::zeros(map)),
            spare: Arc::new(Displacement::zeros(map)),
            lattice,
            remap,
            walls,
        }
    }

    fn domain(&self) -> &Domain {
        self.disp.domain()
    }

    /// Whether `other` is this map with the same settings, to the bit: a
    /// gas holding it may share this one instead.
    fn same_as(&self, other: &Self) -> bool {
        let bits = |a: &[f32], b: &[f32]| a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits());
        let walls = match (&self.walls, &other.walls) {
            (None, None) => true,
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            _ => false,
        };
        walls
            && self.remap.to_bits() == other.remap.to_bits()
            && self.domain() == other.domain()
            && (self.disp.slices().iter().zip(other.disp.slices())).all(|(a, b)| bits(a, b))
            && bits(self.lattice.as_slice(), other.lattice.as_slice())
    }

    /// The grid the next `D` is written to: the spare, or a fresh one when
    /// a snapshot still holds it.
    fn spare_mut(&mut self) -> &mut Displacement {
        if Arc::get_mut(&mut self.spare).is_none() {
            self.spare = Arc::new(Displacement::zeros(*self.domain()));
        }
        Arc::get_mut(&mut self.spare).expect("a fresh grid is unshared")
    }

    /// Eq 8.8 on the displacement: `D_n(x) = (B_n(x) − x) + D_{n−1}(B_n(x))`.
    /// On the velocity grid the cell sweep [`advect_map`]; on a finer map
    /// grid [`NODE_GROUP`] nodes traced at a time ([`departure_points`]).
    fn advect(&mut self, input: &StepInput<'_>) {
        let md = *self.domain();
        let vd = *input.velocity.domain();
        let old = Arc::clone(&self.disp);
        let walls = self.walls.clone();
        let walls = walls.as_deref();
        let (u, dt_cells, bt) = (input.velocity, input.dt / vd.cell, input.backtrace);
        let out = self.spare_mut();
        if md == vd {
            let stop = walls.map(|w| move |g| w.stop(g));
            let stop = stop.as_ref().map(|f| f as &(dyn Fn(Vec3) -> Vec3 + Sync));
            let [ox, oy, oz] = &mut out.0;
            let src = old.0.each_ref();
            advect_map(u, (input.dt, bt), src, [ox, oy, oz], md.cell, stop);
        } else {
            let slab = md.dims[0] * md.dims[1];
            let nx = md.dims[0];
            let (old, wrap) = (old.slices(), old.0[0].wrap());
            // `D` at grid coordinates: one stencil applied to each component
            // (the bits of an interleaved grid's trilinear).
            let old_at = |g| {
                let s = crate::grid::Stencil::new(g, md.dims, wrap);
                Vec3::from_array(old.map(|c| s.apply(c)))
            };
            let [ox, oy, oz] = &mut out.0;
            (ox.as_slice_mut().par_chunks_mut(slab))
                .zip(oy.as_slice_mut().par_chunks_mut(slab))
                .zip(oz.as_slice_mut().par_chunks_mut(slab))
                .enumerate()
                .for_each(|(k, ((ox, oy), oz))| {
                    // Groups of nodes on the stack: the step allocates nothing.
                    for first in (0..slab).step_by(NODE_GROUP) {
                        let len = NODE_GROUP.min(slab - first);
                        let node = |n: usize| md.cell_center((first + n) % nx, (first + n) / nx, k);
                        let mut deps = [Vec3::ZERO; NODE_GROUP];
                        for (n, s) in deps.iter_mut().enumerate().take(len) {
                            *s = vd.grid_coords(node(n));
                        }
                        departure_points(u, &mut deps[..len], dt_cells, bt);
                        for (n, &dep) in deps.iter().enumerate().take(len) {
                            let dep = walls.map_or(dep, |w| w.stop(dep));
                            let d = vd.world_of(dep);
                            let o = (d - node(n)) + old_at(md.grid_coords(d));
                            (ox[first + n], oy[first + n], oz[first + n]) = (o.x, o.y, o.z);
                        }
                    }
                });
        }
        drop(old);
        std::mem::swap(&mut self.disp, &mut self.spare);
    }

    /// Move every lattice node by the inverse of the step's backtrace:
    /// solve `B(y') = y` by `y' ← y + (y' − B(y'))` from the predictor
    /// `y' = F(y)`, the same scheme traced forward (`Δt → −Δt`: for RK2
    /// `y + Δt u(y + ½Δt u(y))`), which matches the inverse to `O(Δt³)`
    /// — one order better than `y + (y − B(y))`, so one correction leaves
    /// a residual of the order that predictor left after two;
    /// [`NODE_GROUP`] nodes traced at a time ([`departure_points`]).
    ///
    /// The groups follow the lattice rows: the nodes of a row away from its
    /// two ends in runs of [`NODE_GROUP`] (the last overlapping its
    /// predecessor), whose stencils mostly fall in one lattice row of the
    /// velocity (the kernel's row windows, no gathers); the rows' end
    /// nodes, whose stencils mostly wrap, gathered into groups of their
    /// own. A node's result does not depend on its group: the same bits.
    fn track_lattice(&mut self, input: &StepInput<'_>) {
        let vd = *input.velocity.domain();
        let [nx, ny, _] = self.lattice.domain().dims;
        let (u, dt_cells, bt) = (input.velocity, input.dt / vd.cell, input.backtrace);
        let walls = self.walls.as_deref();
        let into_box = BoxWrap::new(&vd);
        // Up to NODE_GROUP nodes moved in place, on the stack.
        let track = |ys: &mut [Vec3]| {
            let n = ys.len();
            let mut g0 = [Vec3::ZERO; NODE_GROUP];
            for (g, &y) in g0.iter_mut().zip(&*ys) {
                *g = vd.grid_coords(y);
            }
            let mut g = g0;
            departure_points(u, &mut g[..n], -dt_cells, bt);
            for _ in 0..FORWARD_ITERATIONS {
                let mut back = g;
                departure_points(u, &mut back[..n], dt_cells, bt);
                for ((g, &g0), &b) in g.iter_mut().zip(&g0).zip(&back).take(n) {
                    *g = g0 + (*g - b);
                }
            }
            for (y, &g) in ys.iter_mut().zip(&g) {
                let g = walls.map_or(g, |w| w.stop(g));
                *y = into_box.wrap(vd.world_of(g));
            }
        };
        self.lattice
            .as_vec3_mut()
            .par_chunks_mut(nx * ny)
            .for_each(|slab| {
                // Nodes left to the mixed groups: their indices in the slab.
                let (mut pending, mut count) = ([0usize; NODE_GROUP], 0);
                let flush = |slab: &mut [Vec3], pending: &[usize]| {
                    let mut group = [Vec3::ZERO; NODE_GROUP];
                    for (g, &n) in group.iter_mut().zip(pending) {
                        *g = slab[n];
                    }
                    track(&mut group[..pending.len()]);
                    for (g, &n) in group.iter().zip(pending) {
                        slab[n] = *g;
                    }
                };
                for j in 0..ny {
                    let row = j * nx..(j + 1) * nx;
                    let inner = row.start + 1..row.end - 1;
                    let ends = [row.start, row.end - 1];
                    let rest: &[usize] = if inner.len() >= NODE_GROUP {
                        // The overlapping last run first, from the nodes
                        // as they were; the runs before it in place.
                        let last = inner.end - NODE_GROUP;
                        let mut tail = [Vec3::ZERO; NODE_GROUP];
                        tail.copy_from_slice(&slab[last..inner.end]);
                        track(&mut tail);
                        let mut s = inner.start;
                        while s + NODE_GROUP <= inner.end {
                            track(&mut slab[s..s + NODE_GROUP]);
                            s += NODE_GROUP;
                        }
                        slab[s..inner.end].copy_from_slice(&tail[s - last..]);
                        &ends
                    } else {
                        &[]
                    };
                    let short = row.clone().filter(|_| rest.is_empty());
                    for n in rest.iter().copied().chain(short) {
                        pending[count] = n;
                        count += 1;
                        if count == NODE_GROUP {
                            flush(slab, &pending);
                            count = 0;
                        }
                    }
                }
                flush(slab, &pending[..count]);
            });
    }

    /// How far the tracked lattice has deformed since the last
    /// re-anchoring: the largest `|Y(ξ + h e_a) − Y(ξ) − h e_a| / h` over
    /// nodes `ξ` and axes `a` — in map cells, how far some pair of
    /// neighbouring reference nodes has moved relative to each other.
    fn deformation(&self) -> f32 {
        let md = *self.domain();
        let [nx, ny, nz] = md.dims;
        let (size, h) = (md.size(), md.cell);
        let half = 0.5 * size;
        let y = self.lattice.as_vec3();
        (0..nz)
            .into_par_iter()
            .map(|k| {
                // The largest squared length, its root taken once (the root
                // is monotone and correctly rounded: the same bits).
                let mut m = 0.0f32;
                for j in 0..ny {
                    let row = |j, k| &y[md.index(0, j, k)..][..nx];
                    let (here, up_y, up_z) =
                        (row(j, k), row((j + 1) % ny, k), row(j, (k + 1) % nz));
                    for (i, &p) in here.iter().enumerate() {
                        let up_x = here[if i + 1 == nx { 0 } else { i + 1 }];
                        for (q, e) in [(up_x, Vec3::X), (up_y[i], Vec3::Y), (up_z[i], Vec3::Z)] {
                            m = m.max((nearest_image(q - p, size, half) - h * e).length_squared());
                        }
                    }
                }
                m.sqrt() / h
            })
            .reduce(|| 0.0, f32::max)
    }

    /// `X ←` identity, lattice at rest.
    fn reset(&mut self) {
        for c in &mut self.spare_mut().0 {
            c.as_slice_mut().fill(0.0);
        }
        std::mem::swap(&mut self.disp, &mut self.spare);
        reset_lattice(&mut self.lattice);
    }
}

/// A SELMA density: its reference density `R`, its source, the cache at
/// the velocity grid's cell centres, and the map and lattice — its own, or
/// shared with the SELMA gas before it ([`step_group`]).
#[derive(Clone)]
pub struct Selma {
    field: SelmaField,
    /// The map this gas advances; `None` when it shares the map of the
    /// nearest earlier gas of its group that has one.
    map: Option<Box<SelmaMap>>,
    /// Re-anchoring threshold, kept to rebuild a map on restore.
    remap: f32,
    /// Scratch for re-anchoring (absent when `remap == 0`).
    fresh: Option<ScalarGrid>,
    source: Option<Scalar>,
    restarts: usize,
    /// Points per cell of the cache ([`CellSamples`]).
    samples: CellSamples,
    centres: ScalarGrid,
    /// Whether the map or reference moved on (or was restored) since
    /// `centres` was last evaluated.
    stale: bool,
}

impl Selma {
    /// A density on the velocity grid `domain` with its map on `map`
    /// (which must tile the same box), starting at `initial`, injected at
    /// rate `source`, re-anchored when the lattice deformation exceeds
    /// `remap` map cells (0: never).
    ///
    /// # Panics
    /// If `map` is not the same box as `domain`.
    pub fn new(
        domain: Domain,
        map: Domain,
        initial: Option<Scalar>,
        source: Option<Scalar>,
        remap: f32,
    ) -> Self {
        assert!(
            (map.origin - domain.origin).abs().max_element() <= 1e-5 * domain.size().max_element()
                && (map.size() - domain.size()).abs().max_element()
                    <= 1e-4 * domain.size().max_element(),
            "selma: the map grid must tile the velocity grid's box"
        );
        let own = SelmaMap::new(map, remap, None);
        let field = SelmaField {
            disp: Arc::clone(&own.disp),
            reference: Arc::new(ScalarGrid::zeros(map)),
            initial,
            walls: None,
        };
        let mut gas = Self {
            field,
            map: Some(Box::new(own)),
            remap,
            fresh: (remap > 0.0).then(|| ScalarGrid::zeros(map)),
            source,
            restarts: 0,
            samples: CellSamples::default_for(DensityMode::Selma),
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

    /// The map grid.
    pub fn map_domain(&self) -> &Domain {
        self.field.disp.domain()
    }

    /// Re-anchorings so far.
    pub fn restarts(&self) -> usize {
        self.restarts
    }

    /// Whether this gas advances its own map (`false`: it shares an
    /// earlier gas's, [`step_group`]).
    pub fn owns_map(&self) -> bool {
        self.map.is_some()
    }

    /// How far the tracked lattice of this gas's own map has deformed since
    /// the last re-anchoring, in map cells (see [`SelmaMap`]); `None` when
    /// it shares another gas's map.
    pub fn lattice_deformation(&self) -> Option<f32> {
        self.map.as_ref().map(|m| m.deformation())
    }

    /// Stop map and lattice updates at the surface of `walls`; zero density
    /// inside them ([`crate::boundary::wall_stop`]).
    pub fn set_walls(&mut self, walls: Arc<WallStop>) {
        if let Some(m) = &mut self.map {
            m.walls = Some(walls.clone());
        }
        self.field.walls = Some(walls);
    }

    /// Advect the map (eq 8.8), move the reference lattice forward, inject
    /// the source in reference coordinates, and re-anchor when the lattice
    /// has deformed by more than the threshold: [`step_group`] of this gas
    /// alone.
    ///
    /// # Panics
    /// If this gas shares another gas's map.
    pub fn step(&mut self, input: &StepInput<'_>) {
        step_group(&mut [self], input);
    }

    /// The field and the re-anchoring scratch grid's samples ([`reanchor`]).
    fn reanchor_scratch(&mut self) -> (&SelmaField, &mut [f32]) {
        let fresh = self
            .fresh
            .as_mut()
            .expect("re-anchoring needs its scratch grid");
        (&self.field, fresh.as_slice_mut())
    }

    /// Evaluate `ρ₀∘X + R∘X` on every velocity cell (the buoyancy input and
    /// the saved volumes): the cell averages `ρ̄_c ≈ (1/8) Σ_s ρ(X(x_c +
    /// δ_s Δx))` over the 2×2×2 sub-cell points, or the centre values
    /// ([`CellSamples`], [`super::cell_average`]); zero in the cells whose
    /// centres lie inside the walls. At the centres, when the map grid is
    /// the velocity grid its nodes are these centres, and `X = x + D` is
    /// read off the lattice, not interpolated.
    pub fn evaluate_centres(&mut self) {
        let d = *self.centres.domain();
        let field = &self.field;
        let samples = self.samples;
        let md = *field.disp.domain();
        let into_box = BoxWrap::new(&md);
        let [dx, dy, dz] = field.disp.slices();
        let slab = d.dims[0] * d.dims[1];
        self.centres
            .as_slice_mut()
            .par_chunks_mut(slab)
            .enumerate()
            .for_each_init(
                || (Vec::new(), Vec::new(), Vec::new(), Vec::new()),
                |(centres, points, xi, values), (k, out)| {
                    d.slab_centers(k, centres);
                    xi.clear();
                    if md == d && samples == CellSamples::Centre {
                        let nodes = k * slab..;
                        xi.extend(
                            (centres.iter().zip(nodes))
                                .map(|(&p, n)| into_box.wrap(p + Vec3::new(dx[n], dy[n], dz[n]))),
                        );
                    } else {
                        cell_points(&d, samples, centres, points);
                        xi.resize(points.len(), Vec3::ZERO);
                        field.map_batch(points, xi);
                    }
                    values.resize(xi.len(), 0.0);
                    field.at_reference(xi, values);
                    cell_values(samples, values, out);
                    field.clear_dry(centres, out);
                },
            );
        self.stale = false;
    }

    /// Whether the map or reference moved on (or was restored) since the
    /// cache was last evaluated.
    pub fn stale(&self) -> bool {
        self.stale
    }

    /// The density at the velocity cell centres, as evaluated by
    /// [`Self::evaluate_centres`].
    ///
    /// # Panics
    /// If the gas stepped or was restored since (call
    /// `Simulation::evaluate_densities` first): a stale cache is never read.
    pub fn density(&self) -> &ScalarGrid {
        assert!(
            !self.stale,
            "SELMA density read before it was evaluated after a step \
             (call Simulation::evaluate_densities first)"
        );
        &self.centres
    }

    /// The density as a field.
    pub fn field(&self) -> &SelmaField {
        &self.field
    }

    /// Every buffer held (see [`super::DensityModel::buffers`]); a shared
    /// map's `D` is listed by every gas sharing it (same address, counted
    /// once), its spare and lattice by its owner.
    pub fn buffers(&self, out: &mut Vec<Buffer>) {
        out.push(Buffer::of_scalar(&self.centres));
        out.extend(self.field.disp.0.iter().map(Buffer::of_scalar));
        out.push(Buffer::of_scalar(&self.field.reference));
        if let Some(m) = &self.map {
            out.extend(m.spare.0.iter().map(Buffer::of_scalar));
            out.push(Buffer::of_vector(&m.lattice));
        }
        out.extend(self.fresh.iter().map(Buffer::of_scalar));
    }

    /// What changes as the density steps, for a checkpoint (the scratch
    /// grids are overwritten before they are read; `ρ₀`, the source and the
    /// walls come from the configuration).
    pub fn state(&self) -> SelmaState {
        SelmaState {
            map: self.map.as_ref().map(|m| MapState {
                disp: m.disp.to_vector(),
                lattice: m.lattice.clone(),
            }),
            reference: (*self.field.reference).clone(),
            composes_initial: self.field.initial.is_some(),
            restarts: self.restarts,
            centres: self.centres.clone(),
        }
    }

    /// Put back what [`Self::state`] returned (a state without a map makes
    /// this gas share the map of the SELMA gas before it).
    ///
    /// # Panics
    /// If a grid is on another domain than this density's.
    pub fn restore(&mut self, state: SelmaState) {
        let md = *self.map_domain();
        assert!(
            state
                .map
                .as_ref()
                .is_none_or(|m| *m.disp.domain() == md && *m.lattice.domain() == md)
                && *state.reference.domain() == md
                && state.centres.domain() == self.centres.domain(),
            "selma: checkpoint grids on another domain"
        );
        self.map = state.map.map(|m| {
            let mut own = SelmaMap::new(md, self.remap, self.field.walls.clone());
            own.disp = Arc::new(Displacement::from_vector(&m.disp));
            own.lattice = m.lattice;
            Box::new(own)
        });
        if let Some(m) = &self.map {
            self.field.disp = Arc::clone(&m.disp);
        }
        self.field.reference = Arc::new(state.reference);
        if !state.composes_initial {
            self.field.initial = None;
        }
        self.restarts = state.restarts;
        self.centres = state.centres;
        self.stale = true;
    }
}

/// One step of SELMA gases in a fixed order, sharing maps:
/// [`advect_group`] then [`inject_group`]. Each gas gets the numbers it
/// would get alone.
///
/// # Panics
/// If the first gas shares a map (no earlier gas has one).
pub fn step_group(gases: &mut [&mut Selma], input: &StepInput<'_>) {
    advect_group(gases, input);
    inject_group(gases, input.dt);
}

/// The transport half of [`step_group`]: a gas whose map is, to the bit
/// and with the same settings, the map of the nearest earlier gas that has
/// one gives its own up and shares that one (so the gases of a run, built
/// alike and moved by one velocity, share a map from their first step; a
/// gas added later with another map keeps it). Then per map: advect it
/// (eq 8.8) and move its lattice forward once.
///
/// # Panics
/// If the first gas shares a map (no earlier gas has one).
pub fn advect_group(gases: &mut [&mut Selma], input: &StepInput<'_>) {
    for g in gases.iter_mut() {
        g.stale = true;
    }
    let mut owner = None;
    for n in 0..gases.len() {
        let Some(map) = &gases[n].map else { continue };
        let shared = owner
            .and_then(|o: usize| gases[o].map.as_deref())
            .filter(|shared| shared.same_as(map))
            .map(|shared| Arc::clone(&shared.disp));
        match shared {
            Some(disp) => {
                gases[n].map = None;
                gases[n].field.disp = disp;
            }
            None => owner = Some(n),
        }
    }
    for_each_map(gases, |gases, map| {
        map.advect(input);
        map.track_lattice(input);
        for g in gases.iter_mut() {
            g.field.disp = Arc::clone(&map.disp);
        }
    });
}

/// The injection half of [`step_group`], after [`advect_group`]: per map,
/// inject every sharing gas's source at the moved lattice ([`inject`]) and,
/// when the lattice has deformed by more than the threshold, re-anchor
/// every sharing gas's reference against the current map before resetting
/// the map (the re-anchoring takes the injected reference, so it follows
/// the injection).
///
/// # Panics
/// If the first gas shares a map.
pub fn inject_group(gases: &mut [&mut Selma], dt: f32) {
    for g in gases.iter_mut() {
        g.stale = true;
    }
    for_each_map(gases, |gases, map| {
        inject(gases, &map.lattice, dt);
        if map.remap > 0.0 && map.deformation() > map.remap {
            reanchor(gases);
            map.reset();
            for g in gases.iter_mut() {
                g.field.disp = Arc::clone(&map.disp);
            }
        }
    });
}

/// Call `f(group, map)` for each run of gases sharing one map: its owner
/// first, then the gases without a map of their own; the map is taken from
/// its owner for the call and given back.
fn for_each_map(gases: &mut [&mut Selma], mut f: impl FnMut(&mut [&mut Selma], &mut SelmaMap)) {
    let mut start = 0;
    while start < gases.len() {
        let len = 1 + gases[start + 1..]
            .iter()
            .take_while(|g| g.map.is_none())
            .count();
        let group = &mut gases[start..start + len];
        let mut map = group[0]
            .map
            .take()
            .expect("the first SELMA gas of a group owns its map");
        f(group, &mut map);
        group[0].map = Some(map);
        start += len;
    }
}

/// `R(ξ) += Δt · mean_{2×2×2} S(Y(ξ) + o)` for every gas with a source,
/// the sub-points of the shared lattice `Y` computed once for two gases.
fn inject(gases: &mut [&mut Selma], lattice: &VectorGrid, dt: f32) {
    let md = *lattice.domain();
    let slab = md.dims[0] * md.dims[1];
    let ys = lattice.as_vec3();
    let mut targets = gases.iter_mut().filter_map(|g| {
        let source = g.source.as_ref()?;
        let source = (source, source.support());
        Some((source, Arc::make_mut(&mut g.field.reference).as_slice_mut()))
    });
    while let Some((sa, ra)) = targets.next() {
        let slabs = ra.par_chunks_mut(slab).zip(ys.par_chunks(slab));
        match targets.next() {
            Some((sb, rb)) => slabs
                .zip(rb.par_chunks_mut(slab))
                .for_each(|((ra, ys), rb)| {
                    inject_slab(&md, ys, dt, [Some((sa, ra)), Some((sb, rb))]);
                }),
            None => slabs.for_each(|(ra, ys)| inject_slab(&md, ys, dt, [Some((sa, ra)), None])),
        }
    }
}

/// A gas's source and its support ([`ScalarField::support`]).
type SourceBound<'a> = (&'a Scalar, Option<Bounds>);

/// [`inject`] on one slab: lattice nodes `ys`, each gas's source and
/// reference slab; the source is not evaluated outside its support
/// ([`eval_supported`]).
fn inject_slab(
    md: &Domain,
    ys: &[Vec3],
    dt: f32,
    mut gases: [Option<(SourceBound, &mut [f32])>; 2],
) {
    let mut points = [Vec3::ZERO; 8 * CHUNK];
    let mut values = [0.0f32; 8 * CHUNK];
    for (c, ys) in ys.chunks(CHUNK).enumerate() {
        let (points, values) = (&mut points[..8 * ys.len()], &mut values[..8 * ys.len()]);
        // A source whose support misses every sub-point of the chunk gives
        // `+0.0` there: not evaluated, and no sub-points made if none needs them.
        let around = sub_bounds(md, ys);
        let misses =
            |support: &Option<Bounds>| around.zip(*support).is_some_and(|(a, s)| !s.overlaps(&a));
        if gases.iter().flatten().any(|((_, s), _)| !misses(s)) {
            sub_points(md, ys, points);
        }
        for ((source, support), r) in gases.iter_mut().flatten() {
            if misses(support) {
                values.fill(0.0);
            } else {
                eval_supported(&***source, *support, points, values);
            }
            for (m, r) in r[c * CHUNK..][..ys.len()].iter_mut().enumerate() {
                *r += dt * (sub_sum(values, m) * 0.125);
            }
        }
    }
}

/// Re-anchor the references of `gases`, which share one map: `R ←` the
/// 2×2×2 box average of the current density over each map cell, `ρ₀`
/// dropped (the map is reset afterwards by its owner). Two gases at a time
/// share the map's evaluation at the sub-points.
fn reanchor(gases: &mut [&mut Selma]) {
    for pair in gases.chunks_mut(2) {
        let (a, rest) = pair.split_first_mut().expect("chunks are not empty");
        let b = rest.first_mut();
        let md = *a.map_domain();
        let slab = md.dims[0] * md.dims[1];
        let (fa, oa) = a.reanchor_scratch();
        let slabs = oa.par_chunks_mut(slab).enumerate();
        match b {
            Some(b) => {
                let (fb, ob) = b.reanchor_scratch();
                assert!(
                    Arc::ptr_eq(&fa.disp, &fb.disp),
                    "re-anchored gases share the map"
                );
                slabs
                    .zip(ob.par_chunks_mut(slab))
                    .for_each(|((k, oa), ob)| {
                        reanchor_slab(&md, k, fa, [Some((fa, oa)), Some((fb, ob))]);
                    });
            }
            None => slabs.for_each(|(k, oa)| reanchor_slab(&md, k, fa, [Some((fa, oa)), None])),
        }
        for g in pair.iter_mut() {
            let fresh = g
                .fresh
                .as_mut()
                .expect("re-anchoring needs its scratch grid");
            std::mem::swap(Arc::make_mut(&mut g.field.reference), fresh);
            g.field.initial = None;
            g.restarts += 1;
        }
    }
}

/// [`reanchor`] of slab `k` of the map grid: the map `X` (any sharing
/// gas's field), and each gas's field and new reference slab.
fn reanchor_slab(
    md: &Domain,
    k: usize,
    map: &SelmaField,
    mut gases: [Option<(&SelmaField, &mut [f32])>; 2],
) {
    let nx = md.dims[0];
    let mut centres = [Vec3::ZERO; CHUNK];
    let mut points = [Vec3::ZERO; 8 * CHUNK];
    let mut xi = [Vec3::ZERO; 8 * CHUNK];
    let mut values = [0.0f32; 8 * CHUNK];
    let slab = md.dims[0] * md.dims[1];
    for first in (0..slab).step_by(CHUNK) {
        let len = CHUNK.min(slab - first);
        let centres = &mut centres[..len];
        for (m, c) in centres.iter_mut().enumerate() {
            let n = first + m;
            *c = md.cell_center(n % nx, n / nx, k);
        }
        let (points, xi, values) = (
            &mut points[..8 * len],
            &mut xi[..8 * len],
            &mut values[..8 * len],
        );
        sub_points(md, centres, points);
        map.map_batch(points, xi);
        for (field, out) in gases.iter_mut().flatten() {
            field.at_reference(xi, values);
            for (m, o) in out[first..][..len].iter_mut().enumerate() {
                *o = sub_sum(values, m) * 0.125;
            }
        }
    }
}

/// The evolving part of a [`Selma`] density ([`Selma::state`]); serialized
/// (serde) field by field, in this order.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SelmaState {
    /// The map and lattice, if this gas owns them (`None`: it shares the
    /// map of the SELMA gas before it).
    pub map: Option<MapState>,
    /// `R(ξ)`, the density in reference coordinates.
    pub reference: ScalarGrid,
    /// Whether `ρ₀` is still composed (no re-anchoring yet).
    pub composes_initial: bool,
    /// Re-anchorings so far.
    pub restarts: usize,
    /// The density at the velocity grid's cell centres.
    pub centres: ScalarGrid,
}

/// The evolving part of a [`SelmaMap`]; serialized (serde) field by field.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MapState {
    /// The map's displacement `D = X − x`.
    pub disp: VectorGrid,
    /// The tracked lattice `Y(ξ)`.
    pub lattice: VectorGrid,
}

/// A box holding the [`sub_points`] of every one of `centres` when none
/// of them wraps (rounding is monotone: `c + o` lies between the lowest
/// centre plus the lowest offset and the highest plus the highest); `None`
/// when some may wrap, or there are no centres.
fn sub_bounds(md: &Domain, centres: &[Vec3]) -> Option<Bounds> {
    let into_box = BoxWrap::new(md);
    let (low, high) = (SUB[0] * md.cell, SUB[7] * md.cell);
    let b = Bounds::of(centres)?;
    let (min, max) = (b.min + low, b.max + high);
    (into_box.inside(min) && into_box.inside(max)).then_some(Bounds { min, max })
}

/// The periodic image of the offset `d` nearest zero, `d − L·round(d/L)`
/// (box size `L = 2·half`): `d` itself within half a box, without the
/// division. (Only an offset within one rounding of half a box could take
/// the other branch than a test of `|d/L| < ½`, and either image then
/// measures a lattice deformed by half a box, far past any threshold.)
#[inline(always)]
fn nearest_image(d: Vec3, size: Vec3, half: Vec3) -> Vec3 {
    if d.abs().cmplt(half).all() {
        d
    } else {
        d - size * (d / size).round()
    }
}

/// Put every lattice node at its own cell centre.
fn reset_lattice(lattice: &mut VectorGrid) {
    let md = *lattice.domain();
    let slab = md.dims[0] * md.dims[1];
    lattice
        .as_vec3_mut()
        .par_chunks_mut(slab)
        .enumerate()
        .for_each_init(Vec::new, |centres, (k, out)| {
            md.slab_centers(k, centres);
            out.copy_from_slice(centres);
        });
}

/// Eq 8.8 at the cell centres of `vel`'s grid for a backward map held as its
/// displacement `D = X − x` (three cell-centred components `src`):
/// `dst_a(x) = (x_d − x)_a · scale + src_a(x_d)`, with `x_d` the departure
/// point of the centre `x` (grid coordinates; `scale` the map's cell size
/// for world units), moved by `stop` first when given (obstacles). The cell
/// sweep of the gridded path ([`CellRows`]): each row's departure points
/// traced once and the three components sampled through one stencil — the
/// same bits as [`crate::advection::departure_point`] and
/// [`crate::grid::Stencil`] point by point.
///
/// # Panics
/// If a component is on another domain than `vel`.
fn advect_map(
    vel: &FaceGrid,
    trace: (f32, Backtrace),
    src: [&ScalarGrid; 3],
    dst: [&mut ScalarGrid; 3],
    scale: f32,
    stop: Option<&(dyn Fn(Vec3) -> Vec3 + Sync)>,
) {
    let d = *vel.domain();
    for g in src
        .iter()
        .map(|g| g.domain())
        .chain(dst.iter().map(|g| g.domain()))
    {
        assert_eq!(g, &d, "advect_map: component on another domain");
    }
    let [nx, ny, _] = d.dims;
    let slab = nx * ny;
    let wraps = src.map(|g| g.wrap());
    let data = src.map(|g| g.as_slice());
    let [dx, dy, dz] = dst;
    let rows = CellRows::new(vel, trace);
    (dx.as_slice_mut().par_chunks_mut(slab))
        .zip(dy.as_slice_mut().par_chunks_mut(slab))
        .zip(dz.as_slice_mut().par_chunks_mut(slab))
        .enumerate()
        .for_each_init(
            || rows.scratch(),
            |scratch, (k, ((ox, oy), oz))| {
                for j in 0..ny {
                    let [px, py, pz] = rows.trace((j, k), scratch);
                    if let Some(stop) = stop {
                        for ((x, y), z) in px.iter_mut().zip(&mut *py).zip(&mut *pz) {
                            let q = stop(Vec3::new(*x, *y, *z));
                            (*x, *y, *z) = (q.x, q.y, q.z);
                        }
                    }
                    let row = j * nx..(j + 1) * nx;
                    let mut outs = [&mut ox[row.clone()], &mut oy[row.clone()], &mut oz[row]];
                    let p = [&*px, &*py, &*pz];
                    if wraps.iter().all(|&w| w == wraps[0]) {
                        rows.sample(&data, wraps[0], p, &mut outs);
                    } else {
                        for ((data, wrap), out) in data.iter().zip(wraps).zip(outs.iter_mut()) {
                            rows.sample(&[data], wrap, p, &mut [&mut **out]);
                        }
                    }
                    for (a, out) in outs.into_iter().enumerate() {
                        let c = [0.0, j as f32, k as f32][a];
                        for (i, (o, &q)) in out.iter_mut().zip(p[a]).enumerate() {
                            let c = if a == 0 { i as f32 } else { c };
                            *o += (q - c) * scale;
                        }
                    }
                }
            },
        );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::advection::{departure_point, Backtrace, Departures};
    use crate::density::wrap_world;
    use crate::grid::{BoxKind, FaceGrid};

    /// A shear-and-swirl velocity on a 16³ box of edge 8.
    fn velocity() -> FaceGrid {
        velocity_on(16)
    }

    /// The shear-and-swirl velocity on an `n`³ box of edge 8.
    fn velocity_on(n: usize) -> FaceGrid {
        struct Swirl;
        impl crate::field::VectorField for Swirl {
            fn eval(&self, p: Vec3) -> Vec3 {
                let k = std::f32::consts::TAU / 8.0;
                Vec3::new((k * p.y).sin(), (k * p.z).cos(), 0.5 * (k * p.x).sin())
            }
        }
        FaceGrid::from_field(Domain::cube(n, 8.0).unwrap(), BoxKind::Periodic, &Swirl)
    }

    /// Bits of a vector, for exact comparisons.
    fn bits3(v: Vec3) -> [u32; 3] {
        v.to_array().map(f32::to_bits)
    }

    /// The map's update by the row sweep ([`advect_map`]) and the lattice's
    /// by row runs are, node by node, the scalar point trace and stencil: a
    /// 24³ grid (rows of 22 inner nodes: a run and an overlapping one),
    /// second step (a non-zero `D`), with and without an obstacle stopping
    /// the departure points.
    #[test]
    fn the_row_sweeps_give_the_point_traces_bits() {
        let u = velocity_on(24);
        let d = *u.domain();
        let (dt, bt) = (0.4, Backtrace::Rk2);
        let input = StepInput {
            velocity: &u,
            snapshot: None,
            dt,
            backtrace: bt,
        };
        let ball = crate::field::ops::sphere(Vec3::splat(5.0), 1.2);
        let walls = Arc::new(WallStop::new(ScalarGrid::from_field(d, &*ball)));
        for walls in [None, Some(walls)] {
            let mut s = Selma::new(d, d, None, None, 0.0);
            if let Some(w) = &walls {
                s.set_walls(Arc::clone(w));
            }
            s.step(&input);
            let map = s.map.as_ref().unwrap();
            let (old, lattice) = (Arc::clone(&map.disp), map.lattice.clone());
            s.step(&input);
            let map = s.map.as_ref().unwrap();
            let stop = |g: Vec3| walls.as_ref().map_or(g, |w| w.stop(g));
            let old_at = |g: Vec3| {
                let st = crate::grid::Stencil::new(g, d.dims, crate::grid::Wrap::Periodic);
                Vec3::from_array(old.slices().map(|c| st.apply(c)))
            };
            let [dx, dy, dz] = map.disp.slices();
            let dt_cells = dt / d.cell;
            let mut moved = 0;
            for n in 0..d.dims.iter().product() {
                let (i, j, k) = (n % 24, (n / 24) % 24, n / 576);
                let c = Vec3::new(i as f32, j as f32, k as f32);
                let raw = departure_point(&u, c, dt_cells, bt);
                let dep = stop(raw);
                let want = (dep - c) * d.cell + old_at(dep);
                assert_eq!(
                    bits3(Vec3::new(dx[n], dy[n], dz[n])),
                    bits3(want),
                    "D at {n}"
                );
                let g0 = d.grid_coords(lattice.as_vec3()[n]);
                let g = departure_point(&u, g0, -dt_cells, bt);
                let g = g0 + (g - departure_point(&u, g, dt_cells, bt));
                let y = wrap_world(&d, d.world_of(stop(g)));
                assert_eq!(bits3(map.lattice.as_vec3()[n]), bits3(y), "Y at {n}");
                moved += usize::from(dep != raw);
            }
            // With the obstacle some departure points were stopped (measured:
            // 183 of the 13824 nodes), so its branch was exercised.
            println!("{moved} departure points stopped");
            assert_eq!(
                walls.is_some(),
                moved > 0,
                "{moved} departure points stopped"
            );
        }
    }

    /// [`sample_points`] (sixteen lanes, eight, or one by one) gives the
    /// [`crate::grid::Stencil`]'s bits at any points: inside, across the
    /// periodic seam, periods away, in runs of every length up to 40.
    #[test]
    fn sampled_lanes_are_the_stencils_bits() {
        let d = Domain::cube(20, 5.0).unwrap();
        let f = crate::field::ops::sphere(Vec3::splat(2.0), 1.5);
        let grid = ScalarGrid::from_field(d, &*f);
        let mut seed = 0x2545_f491_u32;
        let mut next = || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed as f32 / u32::MAX as f32
        };
        for n in 0..=40 {
            let g: Vec<Vec3> = (0..n)
                .map(|_| Vec3::new(next(), next(), next()) * 64.0 - 22.0)
                .collect();
            let lanes: [Vec<f32>; 3] = std::array::from_fn(|a| g.iter().map(|p| p[a]).collect());
            let mut out = vec![0.0; n];
            let at = [&lanes[0][..], &lanes[1][..], &lanes[2][..]];
            sample_points(grid.as_slice(), (d.dims, grid.wrap()), at, &mut out);
            for (o, &p) in out.iter().zip(&g) {
                assert_eq!(o.to_bits(), grid.sample_grid_coords(p).to_bits(), "at {p}");
            }
        }
    }

    #[test]
    fn the_tracked_lattice_inverts_the_backtrace() {
        let u = velocity();
        let d = *u.domain();
        let (dt, bt) = (0.4, Backtrace::Rk2);
        let mut dep = Departures::new(d);
        dep.trace(&u, dt, bt);
        let mut s = Selma::new(d, d, None, None, 0.0);
        let input = StepInput {
            velocity: &u,
            snapshot: None,
            dt,
            backtrace: bt,
        };
        s.step(&input);
        // B(Y(ξ)) = ξ: moving forward then back returns every node home.
        let mut worst = 0.0f32;
        for (n, y) in s.map.as_ref().unwrap().lattice.as_vec3().iter().enumerate() {
            let (i, j, k) = (n % 16, (n / 16) % 16, n / 256);
            let back = departure_point(&u, d.grid_coords(*y), dt / d.cell, bt);
            let home = Vec3::new(i as f32, j as f32, k as f32);
            let miss = back - home;
            let miss = miss - 16.0 * (miss / 16.0).round();
            worst = worst.max(miss.length());
        }
        // Displacement ≤ 0.9 cells and Δt|∇u| ≤ 0.4·(2π/8) ≈ 0.31: the
        // forward-trace predictor is off by O((Δt|∇u|)²) of it, one correction
        // leaves ≤ 0.31³ · 0.9 ≈ 0.027; measured 5.8e-4 cells.
        println!("lattice residual |B(Y(ξ)) − ξ|: {worst:.3e} cells");
        assert!(
            worst < 2e-3,
            "lattice misses its backtrace by {worst} cells"
        );
        // And the map X(x) = x + D(x) at the nodes is the backtrace itself.
        let [dx, dy, dz] = s.field.disp.slices();
        let x0 = Vec3::new(dx[0], dy[0], dz[0]) / d.cell;
        assert!((x0 - (dep.points()[0] - Vec3::ZERO)).length() < 1e-5);
    }

    #[test]
    fn re_anchoring_resets_the_map_and_keeps_the_density() {
        let u = velocity();
        let d = *u.domain();
        let (dt, bt) = (0.4, Backtrace::Rk2);
        let mut dep = Departures::new(d);
        dep.trace(&u, dt, bt);
        let source: Scalar =
            crate::field::ops::mask(crate::field::ops::sphere(Vec3::splat(4.0), 1.5));
        let mut s = Selma::new(d, d, None, Some(source), 1e-3);
        let input = StepInput {
            velocity: &u,
            snapshot: None,
            dt,
            backtrace: bt,
        };
        s.step(&input);
        s.step(&input);
        assert_eq!(s.restarts(), 2);
        assert!(s
            .field
            .disp
            .slices()
            .iter()
            .all(|c| c.iter().all(|&v| v == 0.0)));
        assert_eq!(s.lattice_deformation(), Some(0.0));
        // Two steps of a 1.5-radius sphere at rate 1: mass ≈ 2 Δt (4/3)π 1.5³.
        let mass = s.field.reference.total();
        let expect = 2.0 * 0.4 * 4.0 / 3.0 * std::f64::consts::PI * 1.5f64.powi(3);
        assert!((mass - expect).abs() < 0.03 * expect, "{mass} vs {expect}");
    }

    #[test]
    fn gases_sharing_a_map_get_the_bits_they_get_alone() {
        let u = velocity();
        let d = *u.domain();
        let input = StepInput {
            velocity: &u,
            snapshot: None,
            dt: 0.4,
            backtrace: Backtrace::Rk2,
        };
        let gas = |c: f32| {
            let source = crate::field::ops::mask(crate::field::ops::sphere(Vec3::splat(c), 1.5));
            Selma::new(d, d, None, Some(source), 0.5)
        };
        let (mut a, mut b) = (gas(3.0), gas(5.0));
        let (mut alone_a, mut alone_b) = (a.clone(), b.clone());
        for _ in 0..6 {
            step_group(&mut [&mut a, &mut b], &input);
            alone_a.step(&input);
            alone_b.step(&input);
        }
        // One map, owned by the first gas, shared by the second.
        assert!(a.owns_map() && !b.owns_map());
        assert!(Arc::ptr_eq(&a.field.disp, &b.field.disp));
        // Re-anchored together (the swirl deforms the lattice past 0.5
        // cells within the six steps), each gas to the bit as alone.
        assert!(a.restarts() > 0 && a.restarts() == b.restarts());
        assert_eq!(a.restarts(), alone_a.restarts());
        let bits = |g: &ScalarGrid| g.as_slice().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        for (shared, alone) in [(&mut a, &mut alone_a), (&mut b, &mut alone_b)] {
            shared.evaluate_centres();
            alone.evaluate_centres();
            assert_eq!(bits(&shared.field.reference), bits(&alone.field.reference));
            assert_eq!(bits(&shared.centres), bits(&alone.centres));
            assert!(shared.centres.total() > 0.0);
        }
        // The second gas holds no map of its own: its buffers beyond the
        // shared displacement are its reference, scratch and cache.
        let bytes = |g: &Selma| {
            let mut v = Vec::new();
            g.buffers(&mut v);
            super::super::total_bytes(v)
        };
        assert!(bytes(&b) < bytes(&alone_b));
    }
}
