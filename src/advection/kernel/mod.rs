//! The semi-Lagrangian kernel (eqs 6.4–6.5), written once for any lane
//! width ([`body`]) and compiled for each instruction set of
//! [`crate::simd::Isa`]: [`scalar`] (one lane), `neon` (four), `avx2`
//! (eight) and `avx512` (sixteen).
//!
//! Each instruction set supplies a handful of lane-wise primitives —
//! arithmetic, comparisons, selects, conversions, contiguous loads — and
//! one fetch of a trilinear stencil's corners, the only place where the
//! instruction sets differ in more than their width: AVX-512 picks them out
//! of 32-value row windows by two-source permutes, AVX2 out of 16-value
//! windows by `vpermps`, and either gathers the lanes no window holds; NEON
//! and the scalar build load them one by one. Every lane does the scalar
//! reference's floating-point operations in its order (products and sums,
//! no fused multiply-add; [`crate::grid::Stencil`],
//! `semi_lagrangian::departure`), so every width gives the same bits by
//! construction. The lanes a vector cannot do — a periodic point more than
//! a period outside the box, NaN — are redone by that reference.
//!
//! What runs on the lanes: rows of faces or cells of one z-slab (the grid
//! sweeps: [`slab`], [`cell_points`]), trilinear samples at given points
//! ([`sample`]), backward steps of arbitrary points ([`points`]) and the
//! velocity at arbitrary points ([`velocities`]).

use glam::Vec3;

use super::semi_lagrangian::{departure, rk2_displacement};
use super::Backtrace;
use crate::grid::face::FaceSampler;
use crate::grid::{Stencil, Wrap};
use crate::simd::Isa;

#[macro_use]
mod body;
#[cfg(target_arch = "x86_64")]
#[macro_use]
mod windows;
#[cfg(target_arch = "x86_64")]
mod avx2;
#[cfg(target_arch = "x86_64")]
mod avx512;
#[cfg(target_arch = "aarch64")]
mod neon;
mod scalar;

/// Backtraces as constants, so that each is compiled on its own.
pub(crate) const EULER: u8 = 0;
pub(crate) const RK2: u8 = 1;
pub(crate) const RK3: u8 = 2;

/// Largest lane count of any instruction set.
pub(crate) const MAX_LANES: usize = 16;

/// The velocity as the kernel reads it: each component's slice and lattice
/// size, the domain's cells, the box's wrap, and the scalar point query for
/// the lanes the vectors leave.
#[derive(Clone, Copy)]
pub(crate) struct Vel<'a> {
    pub(crate) sampler: FaceSampler<'a>,
    pub(crate) data: [&'a [f32]; 3],
    pub(crate) dims: [[usize; 3]; 3],
    pub(crate) cells: [usize; 3],
    pub(crate) wrap: Wrap,
    /// Whether the velocity is read through the RT0 interpolant
    /// ([`crate::grid::Interpolant::Rt0`]) rather than trilinear.
    pub(crate) rt0: bool,
    /// Whether every lattice [`fits`] the lanes' `i32` indices; if not,
    /// everything takes the scalar reference ([`reference`]).
    fits: bool,
}

impl<'a> Vel<'a> {
    /// The kernel's view of a velocity's point query.
    pub(crate) fn new(sampler: FaceSampler<'a>) -> Self {
        let (data, dims, cells, wrap) = sampler.parts();
        Self {
            sampler,
            data,
            dims,
            cells,
            wrap,
            rt0: sampler.interpolant() == crate::grid::Interpolant::Rt0,
            fits: dims.iter().all(|&d| fits(d)) && fits(cells),
        }
    }
}

/// Whether a trace takes the scalar reference for every point: a lattice
/// too large for the lanes' indices ([`fits`]), or the exact RT0 path
/// ([`Backtrace::Exact`], data-dependent cell by cell).
fn by_reference(vel: &Vel, backtrace: Backtrace) -> bool {
    !vel.fits || backtrace == Backtrace::Exact
}

/// Whether a lattice of `dims` has fewer than 2³¹ values (the kernel's
/// indices are `i32`).
pub(crate) fn fits(dims: [usize; 3]) -> bool {
    dims.iter()
        .try_fold(1usize, |n, &d| n.checked_mul(d))
        .is_some_and(|n| n < i32::MAX as usize)
}

/// One grid sweep: the faces of every component (`faces`: the data
/// advected along each component's own lattice, laid out like it) and the
/// cell-centred `gases`, moved through `vel` over `dt` cells with
/// `backtrace`.
pub(crate) struct Sweep<'a> {
    pub(crate) vel: Vel<'a>,
    pub(crate) dt: f32,
    pub(crate) backtrace: Backtrace,
    pub(crate) faces: [&'a [f32]; 3],
    pub(crate) gases: Vec<(&'a [f32], Wrap)>,
}

/// The outputs of one z-slab `k` of a [`Sweep`]: each component's slab
/// of faces (`None`: not swept, or past that lattice's last slab) and
/// each gas's slab of cells.
pub(crate) struct SlabOut<'o> {
    pub(crate) k: usize,
    pub(crate) faces: [Option<&'o mut [f32]>; 3],
    pub(crate) gases: Vec<&'o mut [f32]>,
}

/// Per-thread rows: start velocities (or the faces' mean displacements)
/// and points, each long enough for a row of `n` plus two groups of
/// lanes; and, for the RK2 sweep ([`chunk`]), the cells' displacements of
/// two consecutive z-slabs (each three planes, x, y, z, of the slab's
/// cells), sized on first use.
pub(crate) struct Scratch {
    pub(crate) u0: [Vec<f32>; 3],
    pub(crate) points: [Vec<f32>; 3],
    pub(crate) slabs: [Vec<f32>; 2],
}

impl Scratch {
    /// Rows for rows up to `n` long.
    pub(crate) fn new(n: usize) -> Self {
        let row = || vec![0.0; n + 2 * MAX_LANES];
        Self {
            u0: [row(), row(), row()],
            points: [row(), row(), row()],
            slabs: [vec![], vec![]],
        }
    }

    fn fit(&mut self, n: usize) {
        for r in self.u0.iter_mut().chain(self.points.iter_mut()) {
            if r.len() < n + 2 * MAX_LANES {
                r.resize(n + 2 * MAX_LANES, 0.0);
            }
        }
    }
}

/// Call the kernel function `$f` of `$isa` with `$args`, after checking
/// that this CPU has it.
macro_rules! dispatch {
    ($isa:expr, $f:ident($($arg:expr),* $(,)?)) => {
        match $isa {
            Isa::Scalar => scalar::$f($($arg),*),
            #[cfg(target_arch = "aarch64")]
            Isa::Neon => neon::$f($($arg),*),
            #[cfg(target_arch = "x86_64")]
            Isa::Avx2 => {
                assert!(is_x86_feature_detected!("avx2"), "this CPU has no AVX2");
                // SAFETY: the CPU has AVX2 (asserted).
                unsafe { avx2::$f($($arg),*) }
            }
            #[cfg(target_arch = "x86_64")]
            Isa::Avx512 => {
                assert!(is_x86_feature_detected!("avx512f"), "this CPU has no AVX-512F");
                // SAFETY: the CPU has AVX-512F (asserted).
                unsafe { avx512::$f($($arg),*) }
            }
            #[allow(unreachable_patterns)]
            other => panic!("{other}: not an instruction set of this architecture"),
        }
    };
}

/// Everything point by point through the scalar reference: for grids of
/// 2³¹ values or more, whose indices the lanes' `i32` cannot hold.
mod reference {
    use super::*;

    pub(super) fn slab(sw: &Sweep, out: &mut SlabOut) {
        let (vel, trace) = (&sw.vel, (sw.dt, sw.backtrace));
        let k = out.k;
        let [u, v, w] = &mut out.faces;
        fn faces<const A: usize>(
            vel: &Vel,
            t: (f32, Backtrace),
            d: &[f32],
            k: usize,
            o: &mut [f32],
        ) {
            let l = vel.dims[A];
            for (n, o) in o.iter_mut().enumerate() {
                let f = [n % l[0], n / l[0], k];
                *o = match t.1 {
                    Backtrace::Rk2 => {
                        let mean = face_displacement_by_reference::<A>(vel, t.0, f);
                        shared_face_by_reference::<A>(vel, d, f, mean)
                    }
                    _ => face_by_reference::<A>(vel, t, d, f),
                };
            }
        }
        if let Some(u) = u {
            faces::<0>(vel, trace, sw.faces[0], k, u);
        }
        if let Some(v) = v {
            faces::<1>(vel, trace, sw.faces[1], k, v);
        }
        if let Some(w) = w {
            faces::<2>(vel, trace, sw.faces[2], k, w);
        }
        if k < vel.cells[2] && !sw.gases.is_empty() {
            let nx = vel.cells[0];
            for n in 0..nx * vel.cells[1] {
                let g = cell_by_reference(vel, trace, [n % nx, n / nx, k]);
                for ((data, wrap), o) in sw.gases.iter().zip(out.gases.iter_mut()) {
                    o[n] = sample_by_reference(data, (vel.cells, *wrap), g);
                }
            }
        }
    }
}

/// The consecutive slabs `outs` of `sweep`, row by row, `isa`'s lanes at
/// a time. Euler and RK3: in each slab each component's faces, then the
/// gases' cells. RK2: in each slab first the cells — the gases, and each
/// cell's displacement `d_c = Δt u(x_c − ½Δt u(x_c))` (the midpoint rule)
/// kept for this slab and the next — then each component's faces, each
/// traced back by the mean of the displacements of the two cells it
/// separates ([`face_row_displacements`]); the cells of the slab below
/// the first are traced once more for its z-faces. The bits do not depend
/// on how the slabs are chunked.
///
/// # Panics
/// If an output slab is shorter than its lattice's.
pub(crate) fn chunk(isa: Isa, sweep: &Sweep, outs: &mut [SlabOut], scratch: &mut Scratch) {
    if by_reference(&sweep.vel, sweep.backtrace) {
        for out in outs {
            reference::slab(sweep, out);
        }
        return;
    }
    scratch.fit(sweep.vel.dims.iter().map(|d| d[0]).max().unwrap_or(0));
    if sweep.backtrace == Backtrace::Rk2 {
        let slab = 3 * sweep.vel.cells[0] * sweep.vel.cells[1];
        for s in &mut scratch.slabs {
            s.resize(slab, 0.0);
        }
    }
    dispatch!(isa, chunk(sweep, outs, scratch))
}

/// The RK2 displacements `Δt u(x_c − ½Δt u(x_c))` of the cells of slab
/// `k` of `vel` over `dt` cells into `out` (three planes, x, y, z, of the
/// slab's cells): those of the RK2 sweep ([`chunk`]).
///
/// # Panics
/// If `out` is shorter than three planes.
pub(crate) fn displacements(
    isa: Isa,
    (vel, dt): (&Vel, f32),
    k: usize,
    out: &mut [f32],
    scratch: &mut Scratch,
) {
    let [nx, ny, _] = vel.cells;
    if !vel.fits {
        for n in 0..nx * ny {
            let d = cell_displacement_by_reference(vel, dt, [n % nx, n / nx, k]);
            for a in 0..3 {
                out[a * nx * ny + n] = d[a];
            }
        }
        return;
    }
    scratch.fit(nx);
    let sweep = Sweep {
        vel: *vel,
        dt,
        backtrace: Backtrace::Rk2,
        faces: [&[]; 3],
        gases: vec![],
    };
    dispatch!(isa, displacements(&sweep, k, out, scratch))
}

/// The departure points of the cell centres of row `(j, k)` traced back
/// through `vel` over `dt` cells, into `out = [x, y, z]` (each at least
/// the row long).
pub(crate) fn cell_points(
    isa: Isa,
    (vel, dt, backtrace): (&Vel, f32, Backtrace),
    (j, k): (usize, usize),
    out: [&mut [f32]; 3],
    scratch: &mut Scratch,
) {
    if by_reference(vel, backtrace) {
        let [x, y, z] = out;
        for i in 0..vel.cells[0] {
            let p = cell_by_reference(vel, (dt, backtrace), [i, j, k]);
            (x[i], y[i], z[i]) = (p.x, p.y, p.z);
        }
        return;
    }
    scratch.fit(vel.cells[0]);
    dispatch!(isa, cell_points(vel, dt, backtrace, j, k, out, scratch))
}

/// `datas` (cell-centred grids of `cells`, `wrap`ped, each at least that
/// long) interpolated at the points `g` (grid coordinates, `[x, y, z]`
/// lanes) into `outs` (one per grid): the stencil found once per point.
///
/// # Panics
/// If the lanes and outputs differ in length, or `datas` and `outs` in number.
pub(crate) fn sample(
    isa: Isa,
    datas: &[&[f32]],
    (cells, wrap): ([usize; 3], Wrap),
    g: [&[f32]; 3],
    outs: &mut [&mut [f32]],
) {
    let n = g[0].len();
    assert!(
        g.iter().all(|l| l.len() == n) && outs.iter().all(|o| o.len() == n),
        "sample: lane lengths differ"
    );
    assert_eq!(datas.len(), outs.len(), "sample: grids and outputs differ");
    let len = cells.iter().product::<usize>();
    assert!(
        datas.iter().all(|d| d.len() >= len),
        "sample: data shorter than the grid"
    );
    if !fits(cells) {
        for i in 0..n {
            let p = Vec3::new(g[0][i], g[1][i], g[2][i]);
            for (data, out) in datas.iter().zip(outs.iter_mut()) {
                out[i] = sample_by_reference(data, (cells, wrap), p);
            }
        }
        return;
    }
    dispatch!(isa, sample(datas, cells, wrap, g, outs))
}

/// Each point of `g` (grid coordinates), in place, traced back through
/// `vel` over `dt` cells and, with `into_box = Some(dims)`, wrapped into
/// the periodic box as `crate::domain::wrap_grid`.
pub(crate) fn points(
    isa: Isa,
    (vel, dt, backtrace): (&Vel, f32, Backtrace),
    g: &mut [Vec3],
    into_box: Option<[usize; 3]>,
) {
    if by_reference(vel, backtrace) {
        for p in g {
            *p = point_by_reference(vel, (dt, backtrace), *p, into_box);
        }
        return;
    }
    dispatch!(isa, points(vel, dt, backtrace, g, into_box))
}

/// The velocity at each point of `g` (grid coordinates), into `out`, as
/// [`FaceSampler::at`].
///
/// # Panics
/// If `g` and `out` differ in length.
pub(crate) fn velocities(isa: Isa, vel: &Vel, g: &[Vec3], out: &mut [Vec3]) {
    assert_eq!(g.len(), out.len(), "velocities: lengths differ");
    if !vel.fits {
        for (o, p) in out.iter_mut().zip(g) {
            *o = vel.sampler.at(*p);
        }
        return;
    }
    dispatch!(isa, velocities(vel, g, out))
}

/// The start velocities of the faces `0..m_x` of component `A` in row
/// `(j, k)` of its lattice, as [`FaceSampler::at_face`] finds them (the
/// same four faces summed in its order), into `u0[b][0..m_x]`: each
/// component a row loop, the faces whose neighbours wrap or clamp along x
/// through [`FaceSampler::face_neighbours`] itself. Always inlined: in
/// the kernel's entry points its loops vectorise for their instruction set.
#[inline(always)]
pub(crate) fn face_row_velocities<const A: usize>(
    vel: &Vel,
    (j, k): (usize, usize),
    u0: &mut [Vec<f32>; 3],
) {
    let s = &vel.sampler;
    let m = vel.dims[A][0];
    for (b, out) in u0.iter_mut().enumerate() {
        let (data, d) = (vel.data[b], vel.dims[b]);
        let out = &mut out[..m];
        if b == A {
            let at = (k * d[1] + j) * d[0];
            out.copy_from_slice(&data[at..at + m]);
            continue;
        }
        let quad = |n: [usize; 4]| {
            let mut sum = 0.0;
            for p in n {
                sum += data[p];
            }
            0.25 * sum
        };
        if A != 0 && b != 0 {
            // Every neighbour at x = i: four rows.
            let [r0, r1, r2, r3] = s.face_neighbours(A, b, [0, j, k]).map(|p| &data[p..p + m]);
            for ((((o, a), b), c), d) in out.iter_mut().zip(r0).zip(r1).zip(r2).zip(r3) {
                *o = 0.25 * ((((0.0 + a) + b) + c) + d);
            }
        } else if A == 0 {
            // Along x below and at the face: x = i − 1 and i in two rows
            // of b's lattice (wrapped or clamped at the row's ends).
            let n = s.face_neighbours(A, b, [1, j, k]);
            let inner = 1..m.min(d[0]);
            if !inner.is_empty() {
                let (lo, hi) = (&data[n[0]..n[0] + inner.end], &data[n[1]..n[1] + inner.end]);
                let four = lo.iter().zip(&lo[1..]).zip(hi.iter().zip(&hi[1..]));
                for (o, ((l0, l1), (h0, h1))) in out[inner.clone()].iter_mut().zip(four) {
                    *o = 0.25 * ((((0.0 + l0) + h0) + l1) + h1);
                }
            }
            for i in (0..inner.start).chain(inner.end.max(1)..m) {
                out[i] = quad(s.face_neighbours(A, b, [i, j, k]));
            }
        } else {
            // b = x: at and after the face along x, in two rows of u's
            // lattice (the upper wrapped at the row's end).
            let n = s.face_neighbours(A, b, [0, j, k]);
            let inner = m.min(d[0] - 1);
            let (lo, hi) = (&data[n[0]..n[0] + inner + 1], &data[n[2]..n[2] + inner + 1]);
            let four = lo.iter().zip(&lo[1..]).zip(hi.iter().zip(&hi[1..]));
            for (o, ((l0, l1), (h0, h1))) in out[..inner].iter_mut().zip(four) {
                *o = 0.25 * ((((0.0 + l0) + l1) + h0) + h1);
            }
            for (i, o) in out.iter_mut().enumerate().skip(inner) {
                *o = quad(s.face_neighbours(A, b, [i, j, k]));
            }
        }
    }
}

/// The start velocities of the cells of row `(j, k)`, as
/// [`FaceSampler::at_cell`] finds them (each component the mean of the
/// cell's two faces), into `u0[a][0..n_x]`. Always inlined, as
/// [`face_row_velocities`].
#[inline(always)]
pub(crate) fn cell_row_velocities(vel: &Vel, (j, k): (usize, usize), u0: &mut [Vec<f32>; 3]) {
    let s = &vel.sampler;
    let nx = vel.cells[0];
    for (a, out) in u0.iter_mut().enumerate() {
        let data = vel.data[a];
        let [lo, hi] = s.cell_faces(a, [0, j, k]);
        let out = &mut out[..nx];
        if a == 0 {
            // The upper x-face of the last cell wraps to the row's first.
            let inner = nx.min(vel.dims[0][0] - 1);
            let row = &data[lo..lo + inner + 1];
            for (o, (l, h)) in out[..inner].iter_mut().zip(row.iter().zip(&row[1..])) {
                *o = 0.5 * (l + h);
            }
            for (i, o) in out.iter_mut().enumerate().skip(inner) {
                let [lo, hi] = s.cell_faces(a, [i, j, k]);
                *o = 0.5 * (data[lo] + data[hi]);
            }
        } else {
            let (l, h) = (&data[lo..lo + nx], &data[hi..hi + nx]);
            for ((o, l), h) in out.iter_mut().zip(l).zip(h) {
                *o = 0.5 * (l + h);
            }
        }
    }
}

/// The scalar reference for a face the lanes left: `data` on component
/// `A`'s lattice at the departure point of face `f`.
#[inline(never)]
pub(crate) fn face_by_reference<const A: usize>(
    vel: &Vel,
    (dt, backtrace): (f32, Backtrace),
    data: &[f32],
    f: [usize; 3],
) -> f32 {
    let s = vel.sampler;
    let mut c = Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32);
    c[A] -= 0.5;
    let g = departure(s, c, s.at_face(A, f), dt, backtrace);
    s.component_of(A, data, g)
}

/// The RK2 sweep's scalar reference for a face the lanes left: `data` on
/// component `A`'s lattice at `x_f − d̄`, `mean` the face's mean
/// displacement `d̄` ([`face_row_displacements`]).
#[inline(never)]
pub(crate) fn shared_face_by_reference<const A: usize>(
    vel: &Vel,
    data: &[f32],
    f: [usize; 3],
    mean: Vec3,
) -> f32 {
    let mut c = Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32);
    c[A] -= 0.5;
    vel.sampler.component_of(A, data, c - mean)
}

/// The two cells a face of component `A` separates along `A` (`f` in its
/// lattice): below and above it, the box's wall faces' one inside cell
/// twice, a periodic box's first face's lower cell the last.
#[inline(always)]
pub(crate) fn face_cells<const A: usize>(vel: &Vel, f: [usize; 3]) -> [[usize; 3]; 2] {
    let n = vel.cells[A];
    let (mut lo, mut hi) = (f, f);
    (lo[A], hi[A]) = match vel.wrap {
        Wrap::Periodic => ((f[A] + n - 1) % n, f[A]),
        Wrap::Clamped => (f[A].saturating_sub(1), f[A].min(n - 1)),
    };
    [lo, hi]
}

/// The scalar reference of a face's mean displacement: `½(d_lo + d_hi)` of
/// its two cells' ([`face_cells`], [`cell_displacement_by_reference`]).
pub(crate) fn face_displacement_by_reference<const A: usize>(
    vel: &Vel,
    dt: f32,
    f: [usize; 3],
) -> Vec3 {
    let [lo, hi] = face_cells::<A>(vel, f);
    let (lo, hi) = (
        cell_displacement_by_reference(vel, dt, lo),
        cell_displacement_by_reference(vel, dt, hi),
    );
    0.5 * (lo + hi)
}

/// The scalar reference of a cell's RK2 displacement, in cells:
/// `Δt u(x_c − ½Δt u(x_c))` (`semi_lagrangian::rk2_displacement`).
#[inline(never)]
pub(crate) fn cell_displacement_by_reference(vel: &Vel, dt: f32, c: [usize; 3]) -> Vec3 {
    let s = vel.sampler;
    let g = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32);
    rk2_displacement(s, g, s.at_cell(c), dt)
}

/// The mean displacements `d̄ = ½(d_lo + d_hi)` of the faces of row `j`
/// of component `A`'s lattice in one z-slab, into `out[b][0..m_x]`: each
/// face's two cells' ([`face_cells`]) taken from `below` and `at`, the
/// cells' displacements (three planes, x, y, z) of the slab below the
/// faces and of their own (the same slab but for `A = z`). Always inlined,
/// as [`face_row_velocities`].
#[inline(always)]
pub(crate) fn face_row_displacements<'s, const A: usize>(
    vel: &Vel,
    j: usize,
    [below, at]: [&'s [f32]; 2],
    out: &mut [Vec<f32>; 3],
) {
    let [nx, ny, _] = vel.cells;
    let nxy = nx * ny;
    let m = vel.dims[A][0];
    let periodic = vel.wrap == Wrap::Periodic;
    for (b, out) in out.iter_mut().enumerate() {
        let plane = |s: &'s [f32], j: usize| -> &'s [f32] {
            let at = b * nxy + j * nx;
            &s[at..at + nx]
        };
        let out = &mut out[..m];
        let (lo, hi) = match A {
            0 => {
                // Along the row: x = i − 1 and i (wrapped, or the walls'
                // one cell).
                let r = plane(at, j);
                out[0] = 0.5 * (r[if periodic { nx - 1 } else { 0 }] + r[0]);
                for (o, (l, h)) in out[1..nx].iter_mut().zip(r.iter().zip(&r[1..])) {
                    *o = 0.5 * (l + h);
                }
                if m > nx {
                    out[nx] = 0.5 * (r[nx - 1] + r[nx - 1]);
                }
                continue;
            }
            1 => {
                let [lo, hi] = face_cells::<1>(vel, [0, j, 0]);
                (plane(at, lo[1]), plane(at, hi[1]))
            }
            _ => (plane(below, j), plane(at, j)),
        };
        for ((o, l), h) in out.iter_mut().zip(lo).zip(hi) {
            *o = 0.5 * (l + h);
        }
    }
}

/// The scalar reference for a cell the lanes left: its departure point.
#[inline(never)]
pub(crate) fn cell_by_reference(
    vel: &Vel,
    (dt, backtrace): (f32, Backtrace),
    c: [usize; 3],
) -> Vec3 {
    let s = vel.sampler;
    let g = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32);
    departure(s, g, s.at_cell(c), dt, backtrace)
}

/// The scalar reference of one trilinear sample.
#[inline(never)]
pub(crate) fn sample_by_reference(data: &[f32], (cells, wrap): ([usize; 3], Wrap), g: Vec3) -> f32 {
    Stencil::new(g, cells, wrap).apply(data)
}

/// The scalar reference for an arbitrary point the lanes left.
#[inline(never)]
pub(crate) fn point_by_reference(
    vel: &Vel,
    (dt, backtrace): (f32, Backtrace),
    g: Vec3,
    into_box: Option<[usize; 3]>,
) -> Vec3 {
    let s = vel.sampler;
    let p = departure(s, g, s.at(g), dt, backtrace);
    match into_box {
        Some(dims) => crate::domain::wrap_grid(p, dims),
        None => p,
    }
}

/// The low `n` lanes of a lane mask.
#[inline(always)]
pub(crate) fn low_lanes(n: usize) -> u32 {
    if n >= 32 {
        u32::MAX
    } else {
        (1 << n) - 1
    }
}

/// The lanes set in a lane mask, lowest first.
#[inline(always)]
pub(crate) fn lanes_in(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        let l = mask.trailing_zeros();
        mask &= mask.wrapping_sub(1);
        (l < 32).then_some(l as usize)
    })
}

#[cfg(test)]
mod tests;
