//! Empty-space skipping: a provable bound of where a density may be positive.
//!
//! The march (eqs A.24–A.25) adds nothing at a sample whose densities are
//! all `≤ 0` (`σ = 0`, no emission, no scattering), so a sample that is
//! *known* to be there need not be evaluated. An [`Occupancy`] is a coarse
//! grid of blocks of [`BLOCK`]³ velocity cells, each flagged when the density
//! may be positive somewhere in its closed box; where it is clear the density
//! is `≤ 0` everywhere, and the renderer's march ([`crate::render::march`]) does not query it.
//!
//! # The bound of a gridless chain (eq 7.4)
//!
//! A point `x` of the box is walked back through the stored steps, newest
//! first, `x_n = x`, `x_{k−1} = B_k(x_k)`, and the density is
//! `ρ = Σ_k S(x_k) Δt + ρ₀(x_0)` (the source-free chain: `ρ₀ ∘ X`). It can be
//! positive only if some `x_k` lies where `S > 0` or `x_0` where `ρ₀ > 0`.
//! For a block `C` the bound carries a box `D_k ∋ x_k` for every `x ∈ C`
//! back through the chain, `D_n = C`:
//!
//! - each velocity component is the trilinear interpolant of its faces
//!   ([`FaceSampler::at`](crate::grid::face::FaceSampler::at)), a convex
//!   combination of the 2³ faces around the point, so over a box `D` it lies
//!   in `U(D) = [min, max]` of the faces of every stencil that meets `D`
//!   (the face-index window `⌊lo⌋ … ⌊hi⌋ + 1` on the component's lattice,
//!   wrapped or clamped as the sampler reads it; computed here over tiles of
//!   [`TILE`]³ faces, a superset);
//! - the backtrace ([`departure_point`](crate::advection::departure_point))
//!   is then bounded by interval arithmetic, per component:
//!   Euler `x − Δt u(x) ∈ D − Δt U(D)`; RK2 `m = x − ½Δt u(x) ∈ M = D − ½Δt U(D)`
//!   and `x − Δt u(m) ∈ D − Δt U(M)`; RK3 likewise through its three stages;
//!   the exact RT0 path (whose velocity, a convex combination of a cell's
//!   two faces, lies in the same `U`) stays in any box `R ⊇ D − [0, Δt] U(R)`,
//!   found by growing `R` from `D` ([`MAX_GROWTH`] times at most, else the
//!   whole box);
//! - the walk wraps positions into the periodic box after every step; a
//!   periodic velocity reads the same faces at a point and at its periodic
//!   images, so `D` is carried unwrapped and `ρ₀`, `S` are tested on its
//!   periodic images. In a closed box an axis on which `D` leaves the box is
//!   widened to the whole box (the wrapped point is somewhere in it).
//!
//! Every `D_k` is widened by [`PAD`] cells on each side, which covers the
//! walk's f32 rounding (trilinear weights, products, wraps: a few ulps of
//! grid coordinates, `< 10⁻⁵` cells on grids below 10³ cells). `C` is
//! flagged iff `S`'s support meets some `D_k` (`k = n … 1`) or `ρ₀`'s meets
//! `D_0`. The supports are [`Support`]s, cell masks: for a [`ScalarGrid`]
//! the cells within one cell of a positive sample (a trilinear value is a
//! convex combination of its 2³ samples, positive only if one of them is).
//! Obstacles (`set_walls`) only zero the density and weight it by positive
//! volume factors, so the bound holds with them.
//!
//! Unlike forward propagation of block flags (which rounds the front up to
//! a whole block every step, so a sub-cell motion spreads one block per
//! step), each block's box grows only by `Δt` times the velocity's spread
//! over it; `tests/occupancy.rs` measures the bound's tightness on 07-10's
//! flow and checks that no point of positive density is outside it.

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use super::GridlessField;
use crate::advection::Backtrace;
use crate::domain::Domain;
use crate::grid::{BoxKind, FaceGrid, ScalarGrid, Wrap};

/// Velocity cells per block edge of an [`Occupancy`] (measured on 07-10's
/// flow in `tests/occupancy.rs`: smaller blocks give a tighter bound).
pub const BLOCK: usize = 2;

/// Faces per tile edge of the velocity ranges.
pub const TILE: usize = 2;

/// Widening of every box of the bound, cells (covers the walk's rounding).
pub const PAD: f64 = 1e-3;

/// How many times the exact path's box is grown before the bound gives up
/// and takes the whole box (module documentation): each growth reads the
/// velocity over a larger box, so it settles once the box holds the flow's
/// reach, a few growths at the solver's CFL numbers.
pub const MAX_GROWTH: usize = 32;

/// Inclusive index ranges `(first, last)` of one axis that a window
/// `i0 ..= i1` covers on `n` entries, periodic (one or two ranges) or
/// clamped.
fn axis_ranges(i0: i64, i1: i64, n: usize, periodic: bool) -> ([(usize, usize); 2], usize) {
    let n = n as i64;
    if periodic {
        if i1 - i0 + 1 >= n {
            return ([(0, n as usize - 1), (0, 0)], 1);
        }
        let s = i0.rem_euclid(n);
        let e = s + (i1 - i0);
        if e < n {
            ([(s as usize, e as usize), (0, 0)], 1)
        } else {
            ([(s as usize, n as usize - 1), (0, (e - n) as usize)], 2)
        }
    } else {
        let c = |i: i64| i.clamp(0, n - 1) as usize;
        ([(c(i0), c(i1)), (0, 0)], 1)
    }
}

/// Cells of a domain where a density may be positive, with a summed-area
/// table for box queries.
#[derive(Clone, Debug)]
pub struct Support {
    dims: [usize; 3],
    /// How far from a marked cell's centre the density may be positive,
    /// per axis: `½` closed (the cell's box) for a mask, `1` open (the
    /// trilinear footprint of a sample) for a grid.
    reach: f64,
    open: bool,
    /// `(nz+1)(ny+1)(nx+1)` prefix counts of the marked cells.
    sum: Vec<u32>,
    marked: usize,
}

impl Support {
    /// From a cell mask in `[z][y][x]` order: the density may be positive
    /// in the closed boxes of the marked cells.
    ///
    /// # Panics
    /// If the mask's length is not the cell count.
    pub fn from_mask(domain: &Domain, mask: &[bool]) -> Self {
        Self::with_reach(domain, mask, 0.5, false)
    }

    fn with_reach(domain: &Domain, mask: &[bool], reach: f64, open: bool) -> Self {
        let [nx, ny, nz] = domain.dims;
        assert_eq!(mask.len(), nx * ny * nz, "support: mask length");
        let (sx, sy) = (nx + 1, (nx + 1) * (ny + 1));
        let mut sum = vec![0u32; sy * (nz + 1)];
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let m = mask[(k * ny + j) * nx + i] as u32;
                    let at = (k + 1) * sy + (j + 1) * sx + i + 1;
                    sum[at] = m + sum[at - 1] + sum[at - sx] + sum[at - sy]
                        - sum[at - sx - 1]
                        - sum[at - sy - 1]
                        - sum[at - sy - sx]
                        + sum[at - sy - sx - 1];
                }
            }
        }
        Self {
            dims: domain.dims,
            reach,
            open,
            marked: mask.iter().filter(|&&m| m).count(),
            sum,
        }
    }

    /// Where any of `grids` (all on one domain, periodic) may be positive:
    /// the open boxes `(s − 1, s + 1)³` around their positive samples `s`.
    /// A point's trilinear stencil is the samples `⌊g⌋, ⌊g⌋ + 1` per axis,
    /// a convex combination (sums of non-positive products stay `≤ 0` in
    /// floating point too), so it is positive only if one of them is, less
    /// than one cell away on every axis.
    ///
    /// # Panics
    /// If `grids` is empty, they are on different domains or one is
    /// clamped (it reads its edge samples beyond the box).
    pub fn of_grids(grids: &[&ScalarGrid]) -> Self {
        let d = *grids.first().expect("support of no grids").domain();
        let mut mask = vec![false; d.dims.iter().product()];
        for g in grids {
            assert_eq!(g.domain(), &d, "support: grids on different domains");
            assert_eq!(g.wrap(), Wrap::Periodic, "support: a clamped grid");
            for (m, &v) in mask.iter_mut().zip(g.as_slice()) {
                *m |= v > 0.0;
            }
        }
        Self::with_reach(&d, &mask, 1.0, true)
    }

    /// Marked cells.
    pub fn marked(&self) -> usize {
        self.marked
    }

    /// Marked cells in the inclusive cell ranges (no wrap).
    fn count(&self, r: [(usize, usize); 3]) -> u32 {
        let [nx, ny, _] = self.dims;
        let (sx, sy) = (nx + 1, (nx + 1) * (ny + 1));
        let at = |i: usize, j: usize, k: usize| self.sum[k * sy + j * sx + i];
        let ((x0, x1), (y0, y1), (z0, z1)) = (r[0], r[1], r[2]);
        let (x1, y1, z1) = (x1 + 1, y1 + 1, z1 + 1);
        at(x1, y1, z1) + at(x0, y0, z1) + at(x0, y1, z0) + at(x1, y0, z0)
            - at(x0, y1, z1)
            - at(x1, y0, z1)
            - at(x1, y1, z0)
            - at(x0, y0, z0)
    }

    /// Whether the box `[lo, hi]` of cell-centre grid coordinates, or one
    /// of its periodic images, meets the support: a marked cell `c` whose
    /// reach (closed `[c − r, c + r]` or open `(c − r, c + r)` per axis)
    /// meets it.
    pub fn meets(&self, lo: DVec3, hi: DVec3) -> bool {
        if self.marked == 0 {
            return false;
        }
        let r: [_; 3] = std::array::from_fn(|a| {
            let (c0, c1) = if self.open {
                (
                    (lo[a] - self.reach).floor() + 1.0,
                    (hi[a] + self.reach).ceil() - 1.0,
                )
            } else {
                ((lo[a] - self.reach).ceil(), (hi[a] + self.reach).floor())
            };
            axis_ranges(c0 as i64, c1 as i64, self.dims[a], true)
        });
        let mut hit = false;
        for &x in &r[0].0[..r[0].1] {
            for &y in &r[1].0[..r[1].1] {
                for &z in &r[2].0[..r[2].1] {
                    hit |= self.count([x, y, z]) > 0;
                }
            }
        }
        hit
    }
}

/// Call `f(x, y, z)` for every cell of the per-axis range lists.
fn for_each_cell(r: &[([(usize, usize); 2], usize); 3], mut f: impl FnMut(usize, usize, usize)) {
    for &(z0, z1) in &r[2].0[..r[2].1] {
        for z in z0..=z1 {
            for &(y0, y1) in &r[1].0[..r[1].1] {
                for y in y0..=y1 {
                    for &(x0, x1) in &r[0].0[..r[0].1] {
                        for x in x0..=x1 {
                            f(x, y, z);
                        }
                    }
                }
            }
        }
    }
}

/// Per-tile `[min, max]` of one velocity component's faces.
struct TileRange {
    /// Face lattice size.
    lattice: [usize; 3],
    tiles: [usize; 3],
    lo: Vec<f32>,
    hi: Vec<f32>,
}

impl TileRange {
    fn new(lattice: [usize; 3], data: &[f32]) -> Self {
        let tiles = lattice.map(|m| m.div_ceil(TILE));
        let count = tiles[0] * tiles[1] * tiles[2];
        let (mut lo, mut hi) = (vec![f32::INFINITY; count], vec![f32::NEG_INFINITY; count]);
        let [mx, my, mz] = lattice;
        for k in 0..mz {
            for j in 0..my {
                for i in 0..mx {
                    let v = data[(k * my + j) * mx + i];
                    let t = ((k / TILE) * tiles[1] + j / TILE) * tiles[0] + i / TILE;
                    lo[t] = lo[t].min(v);
                    hi[t] = hi[t].max(v);
                }
            }
        }
        Self {
            lattice,
            tiles,
            lo,
            hi,
        }
    }

    /// `[min, max]` of the component over the box `[lo, hi]` of lattice
    /// coordinates: every face of every stencil that meets it (a superset:
    /// whole tiles).
    fn over(&self, lo: DVec3, hi: DVec3, periodic: bool) -> (f64, f64) {
        let r: [_; 3] = std::array::from_fn(|a| {
            let (i0, i1) = (lo[a].floor() as i64, hi[a].floor() as i64 + 1);
            let (mut r, n) = axis_ranges(i0, i1, self.lattice[a], periodic);
            for e in &mut r[..n] {
                *e = (e.0 / TILE, e.1 / TILE);
            }
            (r, n)
        });
        let (mut vmin, mut vmax) = (f32::INFINITY, f32::NEG_INFINITY);
        let [tx, ty, _] = self.tiles;
        for_each_cell(&r, |x, y, z| {
            let t = (z * ty + y) * tx + x;
            vmin = vmin.min(self.lo[t]);
            vmax = vmax.max(self.hi[t]);
        });
        (vmin as f64, vmax as f64)
    }
}

/// One stored step's velocity ranges and how it moves a box.
struct StepBound {
    comps: [TileRange; 3],
    periodic: bool,
    dims: [usize; 3],
    dt_cells: f64,
    backtrace: Backtrace,
}

/// A box `[lo, hi]` of cell-centre grid coordinates.
type Bx = (DVec3, DVec3);

impl StepBound {
    fn new(u: &FaceGrid, dt: f32, backtrace: Backtrace) -> Self {
        let d = u.domain();
        Self {
            comps: std::array::from_fn(|a| TileRange::new(u.face_dims(a), u.slice(a))),
            periodic: u.kind() == BoxKind::Periodic,
            dims: d.dims,
            dt_cells: (dt / d.cell) as f64,
            backtrace,
        }
    }

    /// Per component `[min, max]` of the velocity over the box.
    fn velocity(&self, (lo, hi): Bx) -> Bx {
        let mut r = (DVec3::ZERO, DVec3::ZERO);
        for a in 0..3 {
            let mut e = DVec3::ZERO;
            e[a] = 0.5;
            let (vmin, vmax) = self.comps[a].over(lo + e, hi + e, self.periodic);
            r.0[a] = vmin;
            r.1[a] = vmax;
        }
        r
    }

    /// A box holding `B(x)` for every `x` of `(lo, hi)`, widened by [`PAD`].
    fn departures(&self, (lo, hi): Bx) -> Bx {
        let dt = self.dt_cells;
        // x − s·U for x ∈ [lo, hi], U ∈ [ulo, uhi], s ≥ 0.
        let back = |(lo, hi): Bx, s: f64, (ulo, uhi): Bx| (lo - s * uhi, hi - s * ulo);
        let u0 = self.velocity((lo, hi));
        let (mut a, mut b) = match self.backtrace {
            Backtrace::Euler => back((lo, hi), dt, u0),
            Backtrace::Rk2 => {
                let mid = back((lo, hi), 0.5 * dt, u0);
                back((lo, hi), dt, self.velocity(mid))
            }
            Backtrace::Rk3 => {
                // k = −Δt u per stage; x_d = x + (k1 + 4k2 + k3)/6.
                let k = |(ulo, uhi): Bx| (-dt * uhi, -dt * ulo);
                let k1 = k(u0);
                let k2 = k(self.velocity((lo + 0.5 * k1.0, hi + 0.5 * k1.1)));
                let p3 = (lo - k1.1 + 2.0 * k2.0, hi - k1.0 + 2.0 * k2.1);
                let k3 = k(self.velocity(p3));
                (
                    lo + (k1.0 + 4.0 * k2.0 + k3.0) / 6.0,
                    hi + (k1.1 + 4.0 * k2.1 + k3.1) / 6.0,
                )
            }
            Backtrace::Exact => {
                // The path stays in any box R ⊇ D − [0, Δt] U(R): grown
                // from D until it holds; the whole box if it does not.
                let mut r = (lo, hi);
                let mut closed = false;
                for _ in 0..MAX_GROWTH {
                    let (a, b) = back((lo, hi), dt, self.velocity(r));
                    let next = (r.0.min(a), r.1.max(b));
                    if next == r {
                        closed = true;
                        break;
                    }
                    r = next;
                }
                let whole = DVec3::new(
                    self.dims[0] as f64,
                    self.dims[1] as f64,
                    self.dims[2] as f64,
                );
                match closed {
                    true => r,
                    false => (lo - whole, hi + whole),
                }
            }
        };
        a -= PAD;
        b += PAD;
        if !self.periodic {
            // The walk wraps the point into the box: somewhere in it.
            for ax in 0..3 {
                let top = self.dims[ax] as f64 - 0.5;
                if a[ax] < -0.5 || b[ax] > top {
                    (a[ax], b[ax]) = (-0.5, top);
                }
            }
        }
        (a, b)
    }

    /// Whether the box spans the whole period on every axis.
    fn covers_all(&self, (lo, hi): Bx) -> bool {
        (0..3).all(|a| hi[a] - lo[a] >= self.dims[a] as f64)
    }
}

/// Blocks of [`BLOCK`]³ cells of a domain, each flagged when a density may
/// be positive in its closed box (module documentation).
#[derive(Clone, Debug)]
pub struct Occupancy {
    domain: Domain,
    block: usize,
    blocks: [usize; 3],
    flags: Vec<bool>,
}

impl Occupancy {
    /// The closed boxes, in cell-centre grid coordinates, of the blocks of
    /// `block`³ cells of `domain`, in `[z][y][x]` order.
    fn boxes(domain: &Domain, block: usize) -> ([usize; 3], Vec<Bx>) {
        assert!(block > 0, "occupancy: block of zero cells");
        let n = domain.dims;
        let blocks = n.map(|n| n.div_ceil(block));
        let mut out = Vec::with_capacity(blocks.iter().product());
        for k in 0..blocks[2] {
            for j in 0..blocks[1] {
                for i in 0..blocks[0] {
                    let c = [i, j, k];
                    let lo = DVec3::from_array(c.map(|c| (c * block) as f64 - 0.5));
                    let hi = DVec3::from_array(std::array::from_fn(|a| {
                        ((c[a] + 1) * block).min(n[a]) as f64 - 0.5
                    }));
                    out.push((lo, hi));
                }
            }
        }
        (blocks, out)
    }

    /// The blocks that meet `support` (a gridded density, `k = 0`).
    pub fn of_support(domain: Domain, support: &Support, block: usize) -> Self {
        let (blocks, boxes) = Self::boxes(&domain, block);
        Self {
            domain,
            block,
            blocks,
            flags: boxes.iter().map(|b| support.meets(b.0, b.1)).collect(),
        }
    }

    /// The bound of a gridless chain (module documentation): `initial` the
    /// support of `ρ₀`, `source` that of `S` (required when the chain has
    /// a source). The boxes of all blocks go back one stored step at a time,
    /// so only one step's velocity ranges are held.
    ///
    /// # Panics
    /// If the chain has a source and `source` is `None`.
    pub fn gridless(
        chain: &GridlessField,
        initial: &Support,
        source: Option<&Support>,
        block: usize,
    ) -> Self {
        assert!(
            !chain.has_source() || source.is_some(),
            "occupancy: the chain has a source; give its support"
        );
        let domain = *chain.domain();
        let any = initial.marked() > 0 || source.is_some_and(|s| s.marked() > 0);
        let (blocks, boxes) = Self::boxes(&domain, block);
        // Each block's box and, once known, its flag.
        let mut state: Vec<(Bx, Option<bool>)> = boxes
            .into_iter()
            .map(|(lo, hi)| ((lo - PAD, hi + PAD), None))
            .collect();
        for (u, dt, bt) in chain.history().rev() {
            let step = StepBound::new(u, dt, bt);
            state.par_iter_mut().for_each(|(b, flag)| {
                if flag.is_some() {
                    return;
                }
                if source.is_some_and(|src| src.meets(b.0, b.1)) {
                    *flag = Some(true);
                } else if step.covers_all(*b) {
                    *flag = Some(any);
                } else {
                    *b = step.departures(*b);
                }
            });
        }
        let flags = state
            .par_iter()
            .map(|(b, flag)| flag.unwrap_or_else(|| initial.meets(b.0, b.1)))
            .collect();
        Self {
            domain,
            block,
            blocks,
            flags,
        }
    }

    /// Whether the density may be positive at world point `p`: `true`
    /// outside the domain, else the flag of `p`'s block (`p`'s cell as the
    /// densities compute it, [`Domain::grid_coords`]).
    #[inline]
    pub fn may_be_positive(&self, p: Vec3) -> bool {
        let g = self.domain.grid_coords(p);
        let mut b = [0usize; 3];
        for a in 0..3 {
            let n = self.domain.dims[a];
            let x = g[a] + 0.5;
            if !(x >= 0.0 && x <= n as f32) {
                return true;
            }
            b[a] = (x as usize).min(n - 1) / self.block;
        }
        self.flags[(b[2] * self.blocks[1] + b[1]) * self.blocks[0] + b[0]]
    }

    /// Share of the domain's cells in flagged blocks.
    pub fn fraction(&self) -> f64 {
        let d = self.domain.dims;
        let mut cells = 0usize;
        for (i, &f) in self.flags.iter().enumerate() {
            if f {
                let c = [
                    i % self.blocks[0],
                    (i / self.blocks[0]) % self.blocks[1],
                    i / (self.blocks[0] * self.blocks[1]),
                ];
                cells += (0..3)
                    .map(|a| ((c[a] + 1) * self.block).min(d[a]) - c[a] * self.block)
                    .product::<usize>();
            }
        }
        cells as f64 / (d[0] * d[1] * d[2]) as f64
    }

    /// The domain whose cells the blocks group.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn support_meets_boxes_and_their_periodic_images() {
        let d = Domain::cube(8, 1.0).unwrap();
        let mut mask = vec![false; 512];
        mask[(2 * 8 + 3) * 8 + 7] = true; // cell (7, 3, 2)
        let s = Support::from_mask(&d, &mask);
        let at = |lo: [f64; 3], hi: [f64; 3]| s.meets(DVec3::from(lo), DVec3::from(hi));
        assert!(at([6.6, 2.6, 1.6], [6.7, 3.0, 2.0]));
        assert!(!at([5.0, 2.6, 1.6], [6.4, 3.0, 2.0]));
        // Cell 7 wrapped is cell −1: the box [−1.2, −0.8] meets it.
        assert!(at([-1.2, 2.6, 1.6], [-0.8, 3.0, 2.0]));
        assert!(!at([-0.4, 2.6, 1.6], [5.0, 3.0, 2.0]));
        assert!(at([-30.0, -30.0, -30.0], [30.0, 30.0, 30.0]));
    }

    #[test]
    fn axis_ranges_wrap_and_clamp() {
        assert_eq!(axis_ranges(-2, 1, 8, true), ([(6, 7), (0, 1)], 2));
        assert_eq!(axis_ranges(3, 5, 8, true), ([(3, 5), (0, 0)], 1));
        assert_eq!(axis_ranges(-20, 30, 8, true).0[0], (0, 7));
        assert_eq!(axis_ranges(-2, 9, 8, false).0[0], (0, 7));
    }
}
