//! Semi-Lagrangian advection (eqs 6.4–6.5), grid to grid, on the staggered
//! (MAC) velocity of [`FaceGrid`].
//!
//! For every sample point `x` — a cell centre for densities, a face centre of
//! its own lattice for each velocity component — the departure point `x_d` is
//! traced backwards through the velocity's point query (each component
//! trilinear on its own lattice, [`FaceGrid::sample_grid_coords`]) with the
//! chosen [`Backtrace`], and the advected quantity is interpolated trilinearly
//! there: `q_new(x) = q(x_d)`. The first velocity sample of every backtrace,
//! at the cell centre or face itself, is the exact average of the
//! neighbouring faces ([`FaceSampler::at_cell`], [`FaceSampler::at_face`]),
//! not an interpolation. Work is done in continuous cell-centre grid
//! coordinates (cell centres at integers, component `a`'s faces at
//! `(i, j, k) − ½e_a`): a velocity `u` moves a point by `u Δt / Δx` cells.
//!
//! All densities of one step move with the same velocity, so the departure
//! points of the cell centres are traced once per step and shared: by
//! [`Departures`] and [`interpolate_scalar`], or inside [`advect_fused`],
//! which does the whole step of a simulation — every density through one
//! stencil per cell, then each velocity component along its own faces'
//! departures — without storing any departure point.
//!
//! Parallel over z-slabs with rayon; no per-cell allocation.

#[cfg(target_arch = "x86_64")]
use std::ops::Range;

use glam::Vec3;
use rayon::prelude::*;

use super::Backtrace;
#[cfg(target_arch = "x86_64")]
use super::{simd, simd512};
use crate::domain::Domain;
use crate::grid::face::FaceSampler;
use crate::grid::{FaceGrid, ScalarGrid, Stencil, Wrap};

/// The departure point of every cell centre for one step, in grid coordinates.
#[derive(Clone, Debug)]
pub struct Departures {
    domain: Domain,
    points: Vec<Vec3>,
}

impl Departures {
    /// Storage for the departure points of `domain` (initially the cell centres).
    pub fn new(domain: Domain) -> Self {
        let [nx, ny, nz] = domain.dims;
        let points = (0..nz)
            .flat_map(|k| {
                (0..ny).flat_map(move |j| {
                    (0..nx).map(move |i| Vec3::new(i as f32, j as f32, k as f32))
                })
            })
            .collect();
        Self { domain, points }
    }

    /// The domain whose cells these are.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// Departure points, `[z][y][x]` order, in grid coordinates.
    pub fn points(&self) -> &[Vec3] {
        &self.points
    }

    /// Trace every cell centre back through `vel` over `dt`.
    ///
    /// # Panics
    /// If `vel` is on another domain.
    pub fn trace(&mut self, vel: &FaceGrid, dt: f32, backtrace: Backtrace) {
        assert_eq!(
            vel.domain(),
            &self.domain,
            "departures: velocity on another domain"
        );
        let [nx, ny, _] = self.domain.dims;
        let trace = RowTrace::new(vel, dt, backtrace);
        self.points
            .par_chunks_mut(nx * ny)
            .enumerate()
            .for_each_init(
                || [vec![0.0f32; nx], vec![0.0f32; nx], vec![0.0f32; nx]],
                |lanes, (k, out)| {
                    for (j, row) in out.chunks_exact_mut(nx).enumerate() {
                        trace.row(j, k, lanes);
                        for (i, p) in row.iter_mut().enumerate() {
                            *p = point(lanes, i);
                        }
                    }
                },
            );
    }
}

/// Departure point, in cell-centre grid coordinates, of an arbitrary point
/// `g` (grid coordinates) traced back through `vel` over `dt_cells = Δt/Δx`
/// cells.
///
/// The same arithmetic as [`Departures::trace`] and [`advect_fused`], so
/// gridless and SELMA densities follow exactly the characteristics of the
/// gridded path.
#[inline]
pub fn departure_point(vel: &FaceGrid, g: Vec3, dt_cells: f32, backtrace: Backtrace) -> Vec3 {
    let sampler = vel.sampler();
    departure(sampler, g, sampler.at(g), dt_cells, backtrace)
}

/// [`departure_point`] of every point of `g` (grid coordinates), in place,
/// unwrapped: sixteen at a time through the AVX-512 kernel
/// ([`simd512::points16`]) and eight through the AVX2 one ([`simd::points8`];
/// stencils wrapped or clamped as the scalar path's) when the CPU has them;
/// RK3, the remainder and the rare lanes the kernel leaves (points more than
/// a period outside) one by one. Both do the same floating-point operations
/// in the same order, so the points are the same to the bit on any CPU.
pub fn departure_points(vel: &FaceGrid, g: &mut [Vec3], dt_cells: f32, backtrace: Backtrace) {
    trace_points(vel, g, dt_cells, backtrace, false);
}

/// [`departure_points`], each point then wrapped into the periodic box of
/// `vel`'s domain as `crate::density::wrap_grid` does (in the kernel's
/// lanes too): one backward step of the gridless walk (eq 7.4's `B_k`).
pub(crate) fn departure_points_wrapped(
    vel: &FaceGrid,
    g: &mut [Vec3],
    dt_cells: f32,
    backtrace: Backtrace,
) {
    trace_points(vel, g, dt_cells, backtrace, true);
}

/// [`departure_points`], wrapped into the box when `wrap`.
fn trace_points(vel: &FaceGrid, g: &mut [Vec3], dt_cells: f32, backtrace: Backtrace, wrap: bool) {
    let dims = vel.domain().dims;
    let one = |p: &mut Vec3| {
        *p = departure_point(vel, *p, dt_cells, backtrace);
        if wrap {
            *p = crate::density::wrap_grid(*p, dims);
        }
    };
    #[cfg(target_arch = "x86_64")]
    if let Some(lat) = simd::lattices(vel.sampler()) {
        let (stencil, into_box) = (vel.kind().wrap(), wrap.then_some(dims));
        let redo = |points: &mut [Vec3], left: u32| {
            if left != 0 {
                for (l, p) in points.iter_mut().enumerate() {
                    if left & (1 << l) != 0 {
                        one(p);
                    }
                }
            }
        };
        // Sixteen at a time where the CPU has AVX-512, then eight.
        let g = if simd512::has_avx512() {
            let mut groups = g.chunks_exact_mut(16);
            for group in &mut groups {
                let points: &mut [Vec3; 16] = group.try_into().expect("groups of sixteen");
                // SAFETY: `has_avx512`, and `lattices` checked the lattice sizes.
                let left = unsafe {
                    simd512::points16(lat, stencil, points, dt_cells, backtrace, into_box)
                };
                redo(points, left);
            }
            groups.into_remainder()
        } else {
            g
        };
        let mut groups = g.chunks_exact_mut(8);
        for group in &mut groups {
            let points: &mut [Vec3; 8] = group.try_into().expect("groups of eight");
            // SAFETY: `lattices` checked AVX2 and the lattice sizes.
            let left =
                unsafe { simd::points8(lat, stencil, points, dt_cells, backtrace, into_box) };
            redo(points, left);
        }
        groups.into_remainder().iter_mut().for_each(one);
        return;
    }
    g.iter_mut().for_each(one);
}

/// Departure point, in grid coordinates, of the point `c` whose velocity is
/// `u0`, after `dt_cells = Δt/Δx`.
#[inline(always)]
fn departure(vel: FaceSampler, c: Vec3, u0: Vec3, dt_cells: f32, backtrace: Backtrace) -> Vec3 {
    match backtrace {
        Backtrace::Euler => c - dt_cells * u0,
        Backtrace::Rk2 => c - dt_cells * vel.at(c - 0.5 * dt_cells * u0),
        Backtrace::Rk3 => {
            // Kutta's RK3 for dx/dt = −u(x): k1 = −u(x), k2 = −u(x + ½k1),
            // k3 = −u(x − k1 + 2k2), x_d = x + (k1 + 4k2 + k3)/6 (times Δt).
            let k1 = -dt_cells * u0;
            let k2 = -dt_cells * vel.at(c + 0.5 * k1);
            let k3 = -dt_cells * vel.at(c - k1 + 2.0 * k2);
            c + (k1 + 4.0 * k2 + k3) / 6.0
        }
    }
}

/// `dst(x) = src(x_d)`: interpolate a scalar grid at the departure points.
///
/// # Panics
/// If the grids are not on the departures' domain.
pub fn interpolate_scalar(src: &ScalarGrid, dep: &Departures, dst: &mut ScalarGrid) {
    let d = dep.domain;
    assert_eq!(
        src.domain(),
        &d,
        "interpolate_scalar: source on another domain"
    );
    assert_eq!(
        dst.domain(),
        &d,
        "interpolate_scalar: target on another domain"
    );
    let (data, wrap) = (src.as_slice(), src.wrap());
    #[cfg(target_arch = "x86_64")]
    let lanes = Lanes::widest(simd::fits(d.dims));
    #[cfg(not(target_arch = "x86_64"))]
    let lanes = Lanes::One;
    let nx = d.dims[0];
    dst.as_slice_mut()
        .par_chunks_mut(nx)
        .zip(dep.points.par_chunks(nx))
        .for_each_init(
            || [vec![0.0f32; nx], vec![0.0f32; nx], vec![0.0f32; nx]],
            |points, (out, row)| {
                for (i, &g) in row.iter().enumerate() {
                    set_point(points, i, g);
                }
                sample_row(lanes, data, (d.dims, wrap), points, out);
            },
        );
}

/// `dst = src(x − ∫u dt)`: advect a scalar grid by `vel` over `dt` (eq 6.4
/// without the source). Allocates its departure points; time steps that move
/// several quantities use [`Departures`] or [`advect_fused`].
pub fn advect_scalar(
    src: &ScalarGrid,
    vel: &FaceGrid,
    dt: f32,
    backtrace: Backtrace,
    dst: &mut ScalarGrid,
) {
    let mut dep = Departures::new(*vel.domain());
    dep.trace(vel, dt, backtrace);
    interpolate_scalar(src, &dep, dst);
}

/// `dst = src(x − ∫u dt)` for a staggered field (eq 6.5 without the force):
/// each component of `src` interpolated on its own lattice at the departure
/// points of its own faces. In a closed box the wall faces stay zero.
///
/// # Panics
/// If the grids differ in domain or box kind.
pub fn advect_faces(
    src: &FaceGrid,
    vel: &FaceGrid,
    dt: f32,
    backtrace: Backtrace,
    dst: &mut FaceGrid,
) {
    for g in [src, &*dst] {
        assert_eq!(g.domain(), vel.domain(), "advect_faces: another domain");
        assert_eq!(g.kind(), vel.kind(), "advect_faces: another box kind");
    }
    let sampler = vel.sampler();
    let dt_cells = dt / vel.domain().cell;
    let dims: [[usize; 3]; 3] = std::array::from_fn(|a| dst.face_dims(a));
    let trace = (sampler, dt_cells, backtrace);
    let cells = (vel.domain().dims, vel.kind().wrap());
    face_sweep::<0>(trace, src.slice(0), dst.slice_mut(0), dims[0], cells);
    face_sweep::<1>(trace, src.slice(1), dst.slice_mut(1), dims[1], cells);
    face_sweep::<2>(trace, src.slice(2), dst.slice_mut(2), dims[2], cells);
    dst.zero_walls();
}

/// Component `A` of [`advect_faces`]: `out[f] = data(x_d(f))` for every
/// face `f` of the lattice `dims`, `x_d` traced back from the face centre
/// through `(velocity, Δt/Δx, backtrace)`. The axis is a constant so that
/// the face's offset and the component's lattice fold into each sweep.
fn face_sweep<const A: usize>(
    (vel, dt_cells, backtrace): (FaceSampler, f32, Backtrace),
    data: &[f32],
    out: &mut [f32],
    dims: [usize; 3],
    (cells, wrap): ([usize; 3], Wrap),
) {
    assert_eq!(
        data.len(),
        dims.iter().product::<usize>(),
        "advect_faces: lattice"
    );
    #[cfg(target_arch = "x86_64")]
    let simd = simd::lattices(vel);
    #[cfg(target_arch = "x86_64")]
    let sixteen = simd.filter(|_| cells[0] >= 18 && simd512::has_avx512());
    #[cfg(not(target_arch = "x86_64"))]
    let _ = (cells, wrap);
    let scalar = |f: [usize; 3]| {
        let (c, u0) = face_start::<A>(vel, f);
        let g = departure(vel, c, u0, dt_cells, backtrace);
        vel.component_of(A, data, g)
    };
    out.par_chunks_mut(dims[0] * dims[1])
        .enumerate()
        .for_each(|(k, slab)| {
            // Faces 1 … n_x − 2 of each row in groups of sixteen (the last
            // overlapping its predecessor), their velocities by vector loads
            // from lane 0's neighbours (wrapped or clamped along y and z as
            // `at_face` does); then the rows' ends, sixteen at a time
            // ([`row_ends16`]). The lanes the kernels leave, one by one.
            #[cfg(target_arch = "x86_64")]
            if let Some(lat) = sixteen {
                let covered = 1..cells[0] - 1;
                for (j, row) in slab.chunks_exact_mut(dims[0]).enumerate() {
                    // Face (1, j, k)'s neighbours; face i's are i − 1 on.
                    let first = |b| match b == A {
                        true => [0; 4],
                        false => vel.face_neighbours(A, b, [1, j, k]),
                    };
                    let first = [first(0), first(1), first(2)];
                    // Two groups at a time, their interpolations
                    // interleaved (`simd512::faces16`); an odd one alone.
                    let trace = (dt_cells, backtrace);
                    let mut starts = group_starts(covered.clone(), 16);
                    while let Some(i) = starts.next() {
                        // SAFETY: AVX-512F (`sixteen`), lattice sizes checked
                        // by simd::lattices, `data` has A's lattice length
                        // (asserted above); 1 ≤ i, i + 16 ≤ n_x − 1 for each
                        // start, so no lane's faces wrap along x
                        // (`face_velocities16`).
                        let left = unsafe {
                            let dst = (data, &mut *row);
                            match starts.next() {
                                Some(i2) => {
                                    let at = ([i, i2], j, k);
                                    let [l, l2] =
                                        simd512::faces16::<A, 2>(lat, wrap, dst, at, &first, trace);
                                    [(i, l), (i2, l2)]
                                }
                                None => {
                                    let at = ([i], j, k);
                                    let [l] =
                                        simd512::faces16::<A, 1>(lat, wrap, dst, at, &first, trace);
                                    [(i, l), (i, 0)]
                                }
                            }
                        };
                        for (i, left) in left {
                            for n in lanes_in(left) {
                                row[i + n] = scalar([i + n, j, k]);
                            }
                        }
                    }
                }
                let ends = (0..covered.start).chain(covered.end..dims[0]);
                let faces = (0..dims[1]).flat_map(|j| ends.clone().map(move |i| [i, j, k]));
                let trace = (vel, dt_cells, backtrace);
                row_ends16::<A>((lat, wrap), (data, slab, dims[0]), faces, trace, &scalar);
                return;
            }
            for (j, row) in slab.chunks_exact_mut(dims[0]).enumerate() {
                // Faces 1 … n_x − 2 in groups of eight (the kernel's
                // precondition: away from the box's edges), where their
                // stencils stay inside; the rest one by one.
                #[cfg(target_arch = "x86_64")]
                if let Some(lat) = simd
                    .filter(|_| (1..cells[1] - 1).contains(&j) && (1..cells[2] - 1).contains(&k))
                {
                    let covered = eight_wide(1, cells[0] - 1);
                    for i in group_starts(covered.clone(), 8) {
                        // SAFETY: AVX2 and lattice sizes checked by
                        // simd::lattices; `data` has A's lattice length
                        // (asserted above); 1 ≤ i, i + 8 ≤ n_x − 1 and j, k
                        // inside as faces8 requires.
                        let done = unsafe {
                            simd::faces8::<A>(
                                lat,
                                data,
                                [i, j, k],
                                dt_cells,
                                backtrace,
                                &mut row[i..],
                            )
                        };
                        if !done {
                            for (n, o) in row[i..i + 8].iter_mut().enumerate() {
                                *o = scalar([i + n, j, k]);
                            }
                        }
                    }
                    for i in (0..covered.start).chain(covered.end..row.len()) {
                        row[i] = scalar([i, j, k]);
                    }
                    continue;
                }
                for (i, o) in row.iter_mut().enumerate() {
                    *o = scalar([i, j, k]);
                }
            }
        });
}

/// Where a backtrace from face `f` of component `A` starts: the face's
/// grid coordinates (cell centres at integers, so `−½` along `A`) and its
/// velocity (`FaceSampler::at_face`).
#[inline(always)]
fn face_start<const A: usize>(vel: FaceSampler, f: [usize; 3]) -> (Vec3, Vec3) {
    let mut c = Vec3::new(f[0] as f32, f[1] as f32, f[2] as f32);
    c[A] -= 0.5;
    (c, vel.at_face(A, f))
}

/// The faces `faces` of component `A` in one slab (`slab`, rows `nx`
/// long; the rows' ends, whose neighbours wrap or clamp along x) sixteen
/// at a time by [`simd512::face_points16`]: each face's velocity by the
/// scalar `at_face`, its trace and interpolation vectorised; the lanes the
/// kernel leaves by `scalar`. One by one, they had taken 8 % of a 128³
/// Euler step for 2 % of its faces.
#[cfg(target_arch = "x86_64")]
fn row_ends16<const A: usize>(
    (lat, wrap): (simd::Lattices, Wrap),
    (data, slab, nx): (&[f32], &mut [f32], usize),
    faces: impl Iterator<Item = [usize; 3]>,
    (vel, dt_cells, backtrace): (FaceSampler, f32, Backtrace),
    scalar: &impl Fn([usize; 3]) -> f32,
) {
    let mut faces = faces.peekable();
    while faces.peek().is_some() {
        let mut group = [[0; 3]; 16];
        let mut n = 0;
        for (slot, f) in group.iter_mut().zip(&mut faces) {
            *slot = f;
            n += 1;
        }
        // Lanes past the last face repeat the first (and are not written).
        let first = group[0];
        group[n..].fill(first);
        let (mut c, mut u0) = ([[0.0f32; 16]; 3], [[0.0f32; 16]; 3]);
        for (l, &f) in group.iter().enumerate() {
            let (p, u) = face_start::<A>(vel, f);
            for a in 0..3 {
                (c[a][l], u0[a][l]) = (p[a], u[a]);
            }
        }
        let mut v = [0.0; 16];
        // SAFETY: AVX-512F and lattice sizes checked by the caller
        // (`sixteen`); `data` has A's lattice length (asserted there).
        let left = unsafe {
            let trace = (dt_cells, backtrace);
            simd512::face_points16::<A>(lat, wrap, (data, &mut v), (&c, &u0), trace)
        };
        for (l, &f) in group[..n].iter().enumerate() {
            let value = if left & (1 << l) != 0 {
                scalar(f)
            } else {
                v[l]
            };
            slab[f[1] * nx + f[0]] = value;
        }
    }
}

/// One semi-Lagrangian step for everything that moves with `vel`:
/// `dsts[n] = srcs[n](x_d)` at the cell centres, the departure point `x_d`
/// traced once per cell and shared through one stencil, then
/// `vel_out = vel(x_d)` along each component's faces ([`advect_faces`])
/// (eqs 6.4–6.5 without sources and forces).
///
/// # Panics
/// If a grid is on another domain, or `srcs` and `dsts` differ in length.
pub fn advect_fused(
    vel: &FaceGrid,
    dt: f32,
    backtrace: Backtrace,
    srcs: &[&ScalarGrid],
    dsts: &mut [&mut ScalarGrid],
    vel_out: &mut FaceGrid,
) {
    let d = *vel.domain();
    assert_eq!(
        srcs.len(),
        dsts.len(),
        "advect_fused: {} sources but {} targets",
        srcs.len(),
        dsts.len()
    );
    for g in srcs
        .iter()
        .map(|g| g.domain())
        .chain(dsts.iter().map(|g| g.domain()))
    {
        assert_eq!(g, &d, "advect_fused: density on another domain");
    }
    advect_faces(vel, vel, dt, backtrace, vel_out);
    if srcs.is_empty() {
        return;
    }
    let [nx, ny, _] = d.dims;
    let slab = nx * ny;
    let src: Vec<(&[f32], Wrap)> = srcs.iter().map(|g| (g.as_slice(), g.wrap())).collect();
    // Split every target into z-slabs and regroup them per slab.
    let mut slabs: Vec<Vec<&mut [f32]>> = (0..d.dims[2])
        .map(|_| Vec::with_capacity(dsts.len()))
        .collect();
    for dst in dsts.iter_mut() {
        for (s, chunk) in slabs.iter_mut().zip(dst.as_slice_mut().chunks_mut(slab)) {
            s.push(chunk);
        }
    }
    // One row at a time: trace the row's departure points into `points`
    // (x, y, z lanes), then sweep each density through them.
    let trace = RowTrace::new(vel, dt, backtrace);
    slabs.into_par_iter().enumerate().for_each_init(
        || [vec![0.0f32; nx], vec![0.0f32; nx], vec![0.0f32; nx]],
        |points, (k, mut outs)| {
            for j in 0..ny {
                trace.row(j, k, points);
                sample_rows(trace.lanes, (&src, d.dims), points, (&mut outs, j * nx));
            }
        },
    );
}

/// The backtrace of the cell centres of one row at a time (eqs 6.4–6.5),
/// shared by [`advect_fused`], [`Departures::trace`] and
/// [`interpolate_scalar`]: sixteen cells at once through the AVX-512
/// kernels ([`simd512::cells16`], [`simd512::sample16`]) where the CPU has
/// them, else eight through the AVX2 ones ([`simd::cells8`],
/// [`simd::sample8`]) where they apply; the scalar [`departure`] and
/// [`Stencil`] elsewhere — the same operations, so the same bits.
#[derive(Clone, Copy)]
struct RowTrace<'a> {
    sampler: FaceSampler<'a>,
    #[cfg(target_arch = "x86_64")]
    simd: Option<simd::Lattices<'a>>,
    lanes: Lanes,
    #[cfg(target_arch = "x86_64")]
    wrap: Wrap,
    cells: [usize; 3],
    dt_cells: f32,
    backtrace: Backtrace,
}

impl<'a> RowTrace<'a> {
    fn new(vel: &'a FaceGrid, dt: f32, backtrace: Backtrace) -> Self {
        let sampler = vel.sampler();
        #[cfg(target_arch = "x86_64")]
        let simd = simd::lattices(sampler);
        #[cfg(not(target_arch = "x86_64"))]
        let simd: Option<()> = None;
        Self {
            sampler,
            #[cfg(target_arch = "x86_64")]
            simd,
            lanes: Lanes::widest(simd.is_some()),
            #[cfg(target_arch = "x86_64")]
            wrap: vel.kind().wrap(),
            cells: vel.domain().dims,
            dt_cells: dt / vel.domain().cell,
            backtrace,
        }
    }

    /// The departure points of the cell centres of row `(j, k)` into
    /// `points` (x, y, z lanes, each at least a row long).
    fn row(&self, j: usize, k: usize, points: &mut [Vec<f32>; 3]) {
        let nx = self.cells[0];
        let scalar = |i: usize| {
            let g = Vec3::new(i as f32, j as f32, k as f32);
            let u0 = self.sampler.at_cell([i, j, k]);
            departure(self.sampler, g, u0, self.dt_cells, self.backtrace)
        };
        #[cfg(target_arch = "x86_64")]
        if let Some(lat) = self
            .simd
            .filter(|_| self.lanes == Lanes::Sixteen && nx >= 18)
        {
            // Groups of sixteen (the last overlapping its predecessor): the
            // cells whose upper x-faces are inside u's lattice, their
            // velocities by vector loads from lane 0's faces (the upper y-
            // and z-faces wrapped as `at_cell` does), and the rest of the
            // row one by one. The lanes the kernel leaves, one by one.
            let covered = 0..(lat.dims[0][0] - 1).min(nx);
            // Cell (0, j, k)'s faces; cell i's are i on.
            let first = |a| self.sampler.cell_faces(a, [0, j, k]);
            let first = [first(0), first(1), first(2)];
            for i in group_starts(covered.clone(), 16) {
                let f = [i, j, k];
                let faces = first.map(|p| p.map(|p| p + i));
                let [px, py, pz] = &mut *points;
                let out = [&mut px[i..], &mut py[i..], &mut pz[i..]];
                let trace = (self.dt_cells, self.backtrace);
                // SAFETY: AVX-512F (`Lanes::widest`), lattice sizes checked
                // by simd::lattices; i + 16 < m_x of u, so no lane's upper
                // x-face wraps (`cell_velocities16`).
                let left = unsafe { simd512::cells16(lat, self.wrap, f, &faces, trace, out) };
                for n in lanes_in(left) {
                    set_point(points, i + n, scalar(i + n));
                }
            }
            for i in covered.end..nx {
                set_point(points, i, scalar(i));
            }
            return;
        }
        // Cells 1 … in groups of eight while their upper faces are inside
        // the lattices (`i + 8 < m_x` of u, `j + 1 < m_y` of v, `k + 1 <
        // m_z` of w), where the RK2 midpoints' stencils stay inside; the
        // rest one by one.
        #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
        let mut covered = 0..0;
        #[cfg(target_arch = "x86_64")]
        if let Some(lat) = self
            .simd
            .filter(|l| j + 1 < l.dims[1][1] && k + 1 < l.dims[2][2])
        {
            covered = eight_wide(1, (lat.dims[0][0] - 1).min(nx));
            for i in group_starts(covered.clone(), 8) {
                let [px, py, pz] = &mut *points;
                let lanes = [&mut px[i..], &mut py[i..], &mut pz[i..]];
                // SAFETY: AVX2 and lattice sizes checked by simd::lattices;
                // the cells' upper faces are inside (as above), and every
                // lane slice holds eight.
                let traced =
                    unsafe { simd::cells8(lat, [i, j, k], self.dt_cells, self.backtrace, lanes) };
                if !traced {
                    for i in i..i + 8 {
                        set_point(points, i, scalar(i));
                    }
                }
            }
        }
        for i in (0..covered.start).chain(covered.end..nx) {
            set_point(points, i, scalar(i));
        }
    }
}

/// `data` (a cell-centred grid of `cells`, `wrap`ped) interpolated at a
/// row's departure points `points` ([`RowTrace::row`]) into `out` (one
/// row): sixteen at a time through [`simd512::sample16`] or eight through
/// [`simd::sample8`] as `lanes` allows ([`Lanes::widest`]), the rest one
/// by one.
fn sample_row(
    lanes: Lanes,
    data: &[f32],
    (cells, wrap): ([usize; 3], Wrap),
    points: &[Vec<f32>; 3],
    out: &mut [f32],
) {
    let scalar = |i| Stencil::new(point(points, i), cells, wrap).apply(data);
    // Cells 1 … n_x − 2 in groups of sixteen or eight (the last
    // overlapping its predecessor), where the stencils mostly lie inside
    // the grid (the edge cells' rarely do); the rest one by one.
    #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
    let mut covered = 0..0;
    #[cfg(not(target_arch = "x86_64"))]
    let _ = lanes;
    #[cfg(target_arch = "x86_64")]
    let [px, py, pz] = points;
    #[cfg(target_arch = "x86_64")]
    if lanes == Lanes::Sixteen && cells[0] >= 18 {
        covered = 1..cells[0] - 1;
        for i in group_starts(covered.clone(), 16) {
            let g = [&px[i..], &py[i..], &pz[i..]];
            // SAFETY: AVX-512F and a grid that fits (`Lanes::widest`).
            let left = unsafe { simd512::sample16(data, (cells, wrap), g, &mut out[i..]) };
            for n in lanes_in(left) {
                out[i + n] = scalar(i + n);
            }
        }
    } else if lanes != Lanes::One {
        covered = eight_wide(1, cells[0] - 1);
        for i in group_starts(covered.clone(), 8) {
            let g = [&px[i..], &py[i..], &pz[i..]];
            // SAFETY: AVX2 and a grid that fits (`Lanes::widest`).
            if !unsafe { simd::sample8(data, cells, g, &mut out[i..]) } {
                for (n, o) in out[i..i + 8].iter_mut().enumerate() {
                    *o = scalar(i + n);
                }
            }
        }
    }
    for i in (0..covered.start).chain(covered.end..out.len()) {
        out[i] = scalar(i);
    }
}

/// [`sample_row`] for every grid of `src` (cell-centred grids of `cells`)
/// at the same row of points, into `outs[n][at..at + n_x]`: with sixteen
/// lanes and two or three grids, each group's corners found once for all of
/// them ([`simd512::sample16_grids`]) where every stencil is inside, the
/// grids one by one ([`simd512::sample16`]) elsewhere and the row's ends
/// by the scalar path; else [`sample_row`] per grid.
fn sample_rows(
    lanes: Lanes,
    (src, cells): (&[(&[f32], Wrap)], [usize; 3]),
    points: &[Vec<f32>; 3],
    (outs, at): (&mut [&mut [f32]], usize),
) {
    #[cfg(target_arch = "x86_64")]
    if lanes == Lanes::Sixteen && cells[0] >= 18 {
        let done = match src.len() {
            2 => sample_rows16::<2>((src, cells), points, (outs, at)),
            3 => sample_rows16::<3>((src, cells), points, (outs, at)),
            _ => false,
        };
        if done {
            return;
        }
    }
    for (&(data, wrap), out) in src.iter().zip(outs.iter_mut()) {
        sample_row(
            lanes,
            data,
            (cells, wrap),
            points,
            &mut out[at..at + cells[0]],
        );
    }
}

/// [`sample_rows`] of exactly `N` grids with sixteen lanes (the caller
/// checked AVX-512F and a row of at least 18 cells); `false`, having done
/// nothing, if `src` or `outs` does not hold `N`.
#[cfg(target_arch = "x86_64")]
fn sample_rows16<const N: usize>(
    (src, cells): (&[(&[f32], Wrap)], [usize; 3]),
    points: &[Vec<f32>; 3],
    (outs, at): (&mut [&mut [f32]], usize),
) -> bool {
    let (Ok(src), Ok(outs)) = (
        <&[_; N]>::try_from(src),
        <&mut [&mut [f32]; N]>::try_from(outs),
    ) else {
        return false;
    };
    let datas = src.map(|(data, _)| data);
    let [px, py, pz] = points;
    let covered = 1..cells[0] - 1;
    // Two groups at a time, their interpolations interleaved; an odd one
    // alone. A group not written, grid by grid.
    let mut starts = group_starts(covered.clone(), 16);
    while let Some(i) = starts.next() {
        let g = [&px[..], &py[..], &pz[..]];
        let group = outs.each_mut().map(|o| &mut **o);
        // SAFETY: AVX-512F and a grid that fits (`Lanes::widest`, caller).
        let wrote = unsafe {
            match starts.next() {
                Some(i2) => {
                    let [w, w2] = simd512::sample16_grids(datas, cells, (g, [i, i2]), (group, at));
                    [(i, w), (i2, w2)]
                }
                None => {
                    let [w] = simd512::sample16_grids(datas, cells, (g, [i]), (group, at));
                    [(i, w), (i, true)]
                }
            }
        };
        for (i, _) in wrote.into_iter().filter(|&(_, w)| !w) {
            let g = [&px[i..], &py[i..], &pz[i..]];
            for (&(data, wrap), out) in src.iter().zip(outs.iter_mut()) {
                let out = &mut out[at + i..];
                // SAFETY: as above.
                let left = unsafe { simd512::sample16(data, (cells, wrap), g, out) };
                for n in lanes_in(left) {
                    out[n] = Stencil::new(point(points, i + n), cells, wrap).apply(data);
                }
            }
        }
    }
    for (&(data, wrap), out) in src.iter().zip(outs.iter_mut()) {
        for i in (0..covered.start).chain(covered.end..cells[0]) {
            out[at + i] = Stencil::new(point(points, i), cells, wrap).apply(data);
        }
    }
    true
}

/// The widest vector kernels a sweep runs: sixteen lanes (AVX-512F), eight
/// (AVX2) or one (the scalar path).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Lanes {
    One,
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    Eight,
    #[cfg_attr(not(target_arch = "x86_64"), allow(dead_code))]
    Sixteen,
}

impl Lanes {
    /// The widest this CPU offers, for grids that `fit` the kernels
    /// ([`simd::fits`], [`simd::lattices`]).
    fn widest(fit: bool) -> Self {
        #[cfg(target_arch = "x86_64")]
        if fit {
            return if simd512::has_avx512() {
                Lanes::Sixteen
            } else {
                Lanes::Eight
            };
        }
        let _ = fit;
        Lanes::One
    }
}

/// The lanes set in a kernel's mask of lanes left to the scalar path.
#[cfg(target_arch = "x86_64")]
fn lanes_in(mask: u32) -> impl Iterator<Item = usize> {
    (0..32).filter(move |l| mask & (1 << l) != 0)
}

/// `first..end` if it holds a group of eight, else `0..0`: the points of a
/// row that an eight-wide sweep covers.
#[cfg(target_arch = "x86_64")]
fn eight_wide(first: usize, end: usize) -> Range<usize> {
    if end >= first + 8 {
        first..end
    } else {
        0..0
    }
}

/// Starts of the groups of `width` covering `range`: every `width`-th point from its start, the last group
/// moved back to end at `range.end`, overlapping its predecessor (a
/// point's value does not depend on its group, so the overlap writes the
/// same bits twice).
#[cfg(target_arch = "x86_64")]
fn group_starts(range: Range<usize>, width: usize) -> impl Iterator<Item = usize> {
    let last = range.end.saturating_sub(width);
    (range.start..last)
        .step_by(width)
        .chain((range.len() >= width).then_some(last))
}

/// Point `i` of a row's departure points held as `[x, y, z]` lanes.
#[inline(always)]
fn point(points: &[Vec<f32>; 3], i: usize) -> Vec3 {
    Vec3::new(points[0][i], points[1][i], points[2][i])
}

/// Store `g` as point `i` of a row's departure points.
#[inline(always)]
fn set_point(points: &mut [Vec<f32>; 3], i: usize, g: Vec3) {
    for (lane, v) in points.iter_mut().zip(g.to_array()) {
        lane[i] = v;
    }
}

/// `data` (a cell-centred grid of `cells`, `wrap`ped) interpolated at the
/// points `g` (grid coordinates, `[x, y, z]` lanes) into `out`:
/// [`Stencil`]'s trilinear, sixteen points at a time through
/// [`simd512::sample16`] (the last group overlapping its predecessor) or
/// eight through [`simd::sample8`] where the CPU has them, the rest and the
/// lanes the kernels leave one by one — the same bits either way.
///
/// # Panics
/// If a lane's length differs from `out`'s, or `data` is shorter than `cells`.
pub(crate) fn sample_points(
    data: &[f32],
    (cells, wrap): ([usize; 3], Wrap),
    g: [&[f32]; 3],
    out: &mut [f32],
) {
    let n = out.len();
    assert!(
        g.iter().all(|lane| lane.len() == n),
        "sample_points: lane lengths differ"
    );
    assert!(
        data.len() >= cells.iter().product::<usize>(),
        "sample_points: data shorter than the grid"
    );
    let scalar =
        |i: usize| Stencil::new(Vec3::new(g[0][i], g[1][i], g[2][i]), cells, wrap).apply(data);
    #[cfg_attr(not(target_arch = "x86_64"), allow(unused_mut))]
    let mut covered = 0..0;
    #[cfg(target_arch = "x86_64")]
    {
        let lanes = Lanes::widest(simd::fits(cells));
        let width = if lanes == Lanes::Sixteen { 16 } else { 8 };
        if lanes != Lanes::One && n >= width {
            covered = 0..n;
        }
        for i in group_starts(covered.clone(), width) {
            let at = [&g[0][i..], &g[1][i..], &g[2][i..]];
            if lanes == Lanes::Sixteen {
                // SAFETY: AVX-512F and a grid that fits (`Lanes::widest`).
                let left = unsafe { simd512::sample16(data, (cells, wrap), at, &mut out[i..]) };
                for l in lanes_in(left) {
                    out[i + l] = scalar(i + l);
                }
            // SAFETY: AVX2 and a grid that fits (`Lanes::widest`).
            } else if !unsafe { simd::sample8(data, cells, at, &mut out[i..]) } {
                for (l, o) in out[i..i + 8].iter_mut().enumerate() {
                    *o = scalar(i + l);
                }
            }
        }
    }
    for (i, o) in out.iter_mut().enumerate().skip(covered.end) {
        *o = scalar(i);
    }
}

/// Eq 8.8 at the cell centres of `vel`'s grid for a backward map held as its
/// displacement `D = X − x` (three cell-centred components `src`):
/// `dst_a(x) = (x_d − x)_a · scale + src_a(x_d)`, with `x_d` the departure
/// point of the centre `x` (grid coordinates; `scale` the map's cell size
/// for world units), moved by `stop` first when given (obstacles). The cell
/// sweep of [`advect_fused`]: each row's departure points traced once
/// ([`RowTrace`]) and the three components sampled through them
/// ([`sample_row`]) — the same bits as [`departure_point`] and
/// [`Stencil`] point by point.
///
/// # Panics
/// If a component is on another domain than `vel`.
pub(crate) fn advect_map(
    vel: &FaceGrid,
    (dt, backtrace): (f32, Backtrace),
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
    let src = src.map(|g| (g.as_slice(), g.wrap()));
    let [dx, dy, dz] = dst;
    let trace = RowTrace::new(vel, dt, backtrace);
    (dx.as_slice_mut().par_chunks_mut(slab))
        .zip(dy.as_slice_mut().par_chunks_mut(slab))
        .zip(dz.as_slice_mut().par_chunks_mut(slab))
        .enumerate()
        .for_each_init(
            || [vec![0.0f32; nx], vec![0.0f32; nx], vec![0.0f32; nx]],
            |points, (k, ((ox, oy), oz))| {
                for j in 0..ny {
                    trace.row(j, k, points);
                    if let Some(stop) = stop {
                        for i in 0..nx {
                            let p = stop(point(points, i));
                            set_point(points, i, p);
                        }
                    }
                    let row = j * nx..(j + 1) * nx;
                    let mut outs = [&mut ox[row.clone()], &mut oy[row.clone()], &mut oz[row]];
                    sample_rows(trace.lanes, (&src, d.dims), points, (&mut outs, 0));
                    for (a, out) in outs.into_iter().enumerate() {
                        let c = [0.0, j as f32, k as f32][a];
                        for (i, (o, &p)) in out.iter_mut().zip(&points[a]).enumerate() {
                            let c = if a == 0 { i as f32 } else { c };
                            *o += (p - c) * scale;
                        }
                    }
                }
            },
        );
}
