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
//! which does the whole step of a simulation in one pass over z-slabs —
//! in each slab each velocity component along its own faces' departures,
//! then every density through one stencil per cell — without storing any
//! departure point.
//!
//! The lanes are the kernel's ([`super::kernel`]): written once, compiled
//! for each instruction set ([`Isa`]), the same bits on every one. The free
//! functions run on [`Isa::selected`]; the same methods of [`Isa`] on a
//! given one.
//!
//! Parallel over z-slabs with rayon; no per-cell allocation.

use glam::Vec3;
use rayon::prelude::*;

use super::kernel::{self, Scratch, SlabOut, Sweep, Vel};
use super::Backtrace;
use crate::domain::Domain;
use crate::grid::face::FaceSampler;
use crate::grid::{FaceGrid, ScalarGrid, Wrap};
use crate::simd::Isa;

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
        Isa::selected().trace_departures(self, vel, dt, backtrace);
    }
}

/// Departure point, in cell-centre grid coordinates, of an arbitrary point
/// `g` (grid coordinates) traced back through `vel` over `dt_cells = Δt/Δx`
/// cells.
///
/// The scalar reference of every sweep's lanes ([`super::kernel`]): gridless
/// and SELMA densities follow exactly the characteristics of the gridded
/// path.
#[inline]
pub fn departure_point(vel: &FaceGrid, g: Vec3, dt_cells: f32, backtrace: Backtrace) -> Vec3 {
    let sampler = vel.sampler();
    departure(sampler, g, sampler.at(g), dt_cells, backtrace)
}

/// [`departure_point`] of every point of `g` (grid coordinates), in place,
/// unwrapped, the kernel's lanes at a time: the same bits as one by one.
pub fn departure_points(vel: &FaceGrid, g: &mut [Vec3], dt_cells: f32, backtrace: Backtrace) {
    Isa::selected().departure_points(vel, g, dt_cells, backtrace);
}

/// [`departure_points`], each point then wrapped into the periodic box of
/// `vel`'s domain as `crate::domain::wrap_grid` does (in the kernel's
/// lanes too): one backward step of the gridless walk (eq 7.4's `B_k`).
pub(crate) fn departure_points_wrapped(
    vel: &FaceGrid,
    g: &mut [Vec3],
    dt_cells: f32,
    backtrace: Backtrace,
) {
    let into_box = Some(vel.domain().dims);
    kernel::points(
        Isa::selected(),
        (&Vel::new(vel.sampler()), dt_cells, backtrace),
        g,
        into_box,
    );
}

/// Departure point, in grid coordinates, of the point `c` whose velocity is
/// `u0`, after `dt_cells = Δt/Δx`: the scalar reference of the kernel's
/// lanes.
#[inline(always)]
pub(crate) fn departure(
    vel: FaceSampler,
    c: Vec3,
    u0: Vec3,
    dt_cells: f32,
    backtrace: Backtrace,
) -> Vec3 {
    match backtrace {
        Backtrace::Euler => c - dt_cells * u0,
        Backtrace::Rk2 => c - rk2_displacement(vel, c, u0, dt_cells),
        Backtrace::Rk3 => {
            // Kutta's RK3 for dx/dt = −u(x): k1 = −u(x), k2 = −u(x + ½k1),
            // k3 = −u(x − k1 + 2k2), x_d = x + (k1 + 4k2 + k3)/6 (times Δt).
            let k1 = -dt_cells * u0;
            let k2 = -dt_cells * vel.at(c + 0.5 * k1);
            let k3 = -dt_cells * vel.at(c - k1 + 2.0 * k2);
            c + (k1 + 4.0 * k2 + k3) / 6.0
        }
        Backtrace::Exact => super::pollock::departure(vel, c, dt_cells),
    }
}

/// The midpoint rule's displacement, in cells, of the point `c` whose
/// velocity is `u0`: `Δt u(c − ½Δt u0)`, so that `x_d = c − d`. The RK2
/// sweep keeps it per cell and traces each face by the mean of its two
/// cells' ([`Backtrace::Rk2`]).
#[inline(always)]
pub(crate) fn rk2_displacement(vel: FaceSampler, c: Vec3, u0: Vec3, dt_cells: f32) -> Vec3 {
    dt_cells * vel.at(c - 0.5 * dt_cells * u0)
}

/// `dst(x) = src(x_d)`: interpolate a scalar grid at the departure points.
///
/// # Panics
/// If the grids are not on the departures' domain.
pub fn interpolate_scalar(src: &ScalarGrid, dep: &Departures, dst: &mut ScalarGrid) {
    Isa::selected().interpolate_scalar(src, dep, dst);
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
    Isa::selected().advect_scalar(src, vel, dt, backtrace, dst);
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
    Isa::selected().advect_faces(src, vel, dt, backtrace, dst);
}

/// One semi-Lagrangian step for everything that moves with `vel`:
/// `vel_out = vel(x_d)` along each component's faces ([`advect_faces`])
/// and `dsts[n] = srcs[n](x_d)` at the cell centres, the departure point
/// `x_d` traced once per cell and shared through one stencil (eqs 6.4–6.5
/// without sources and forces), in one pass over z-slabs.
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
    Isa::selected().advect_fused(vel, dt, backtrace, srcs, dsts, vel_out);
}

/// The semi-Lagrangian sweeps on one instruction set: the same bits on
/// every one ([`super::kernel`]).
impl Isa {
    /// [`Departures::trace`] on this instruction set.
    ///
    /// # Panics
    /// If `vel` is on another domain, or this CPU cannot run `self`.
    pub fn trace_departures(
        self,
        dep: &mut Departures,
        vel: &FaceGrid,
        dt: f32,
        backtrace: Backtrace,
    ) {
        assert_eq!(
            vel.domain(),
            &dep.domain,
            "departures: velocity on another domain"
        );
        let [nx, ny, _] = dep.domain.dims;
        let v = Vel::new(vel.sampler());
        let trace = (&v, dt / vel.domain().cell, backtrace);
        dep.points
            .par_chunks_mut(nx * ny)
            .enumerate()
            .for_each_init(
                || Scratch::new(nx),
                |scratch, (k, out)| {
                    for (j, row) in out.chunks_exact_mut(nx).enumerate() {
                        let mut p = std::mem::take(&mut scratch.points);
                        let [x, y, z] = p.each_mut().map(|l| &mut l[..nx]);
                        kernel::cell_points(self, trace, (j, k), [x, y, z], scratch);
                        for (i, q) in row.iter_mut().enumerate() {
                            *q = Vec3::new(p[0][i], p[1][i], p[2][i]);
                        }
                        scratch.points = p;
                    }
                },
            );
    }

    /// [`departure_points`] on this instruction set.
    ///
    /// # Panics
    /// If this CPU cannot run `self`.
    pub fn departure_points(
        self,
        vel: &FaceGrid,
        g: &mut [Vec3],
        dt_cells: f32,
        backtrace: Backtrace,
    ) {
        kernel::points(
            self,
            (&Vel::new(vel.sampler()), dt_cells, backtrace),
            g,
            None,
        );
    }

    /// [`interpolate_scalar`] on this instruction set.
    ///
    /// # Panics
    /// If the grids are not on the departures' domain, or this CPU cannot
    /// run `self`.
    pub fn interpolate_scalar(self, src: &ScalarGrid, dep: &Departures, dst: &mut ScalarGrid) {
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
        let nx = d.dims[0];
        dst.as_slice_mut()
            .par_chunks_mut(nx)
            .zip(dep.points.par_chunks(nx))
            .for_each_init(
                || Scratch::new(nx),
                |scratch, (out, row)| {
                    let [x, y, z] = scratch.points.each_mut().map(|l| &mut l[..nx]);
                    for (i, g) in row.iter().enumerate() {
                        (x[i], y[i], z[i]) = (g.x, g.y, g.z);
                    }
                    kernel::sample(
                        self,
                        &[data],
                        (d.dims, wrap),
                        [x, y, z].map(|l| &*l),
                        &mut [out],
                    );
                },
            );
    }

    /// [`advect_scalar`] on this instruction set.
    ///
    /// # Panics
    /// If this CPU cannot run `self`.
    pub fn advect_scalar(
        self,
        src: &ScalarGrid,
        vel: &FaceGrid,
        dt: f32,
        backtrace: Backtrace,
        dst: &mut ScalarGrid,
    ) {
        let mut dep = Departures::new(*vel.domain());
        self.trace_departures(&mut dep, vel, dt, backtrace);
        self.interpolate_scalar(src, &dep, dst);
    }

    /// [`advect_faces`] on this instruction set.
    ///
    /// # Panics
    /// If the grids differ in domain or box kind, or this CPU cannot run
    /// `self`.
    pub fn advect_faces(
        self,
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
        let faces = [src.slice(0), src.slice(1), src.slice(2)];
        sweep(self, vel, (dt, backtrace), (faces, dst), (&[], &mut []));
    }

    /// [`advect_fused`] on this instruction set.
    ///
    /// # Panics
    /// If a grid is on another domain, `srcs` and `dsts` differ in length,
    /// or this CPU cannot run `self`.
    pub fn advect_fused(
        self,
        vel: &FaceGrid,
        dt: f32,
        backtrace: Backtrace,
        srcs: &[&ScalarGrid],
        dsts: &mut [&mut ScalarGrid],
        vel_out: &mut FaceGrid,
    ) {
        assert_eq!(
            srcs.len(),
            dsts.len(),
            "advect_fused: {} sources but {} targets",
            srcs.len(),
            dsts.len()
        );
        let d = vel.domain();
        for g in srcs
            .iter()
            .map(|g| g.domain())
            .chain(dsts.iter().map(|g| g.domain()))
        {
            assert_eq!(g, d, "advect_fused: density on another domain");
        }
        assert_eq!(
            vel_out.domain(),
            d,
            "advect_fused: velocity on another domain"
        );
        assert_eq!(vel_out.kind(), vel.kind(), "advect_fused: another box kind");
        let faces = [vel.slice(0), vel.slice(1), vel.slice(2)];
        sweep(self, vel, (dt, backtrace), (faces, vel_out), (srcs, dsts));
    }
}

/// One pass over the z-slabs of `vel`'s domain on `isa`: in each, the
/// faces of every component (`faces`: the data moved along each
/// component's own lattice, and where it goes; its wall faces then zeroed)
/// and the cells of every gas; with RK2 the faces traced by their cells'
/// mean displacement ([`kernel::chunk`], [`Backtrace::Rk2`]).
fn sweep(
    isa: Isa,
    vel: &FaceGrid,
    (dt, backtrace): (f32, Backtrace),
    (faces, dst): ([&[f32]; 3], &mut FaceGrid),
    (srcs, dsts): (&[&ScalarGrid], &mut [&mut ScalarGrid]),
) {
    let d = *vel.domain();
    let [nx, ny, nz] = d.dims;
    let lattices: [[usize; 3]; 3] = std::array::from_fn(|a| vel.face_dims(a));
    for (data, l) in faces.iter().zip(&lattices) {
        assert_eq!(
            data.len(),
            l.iter().product::<usize>(),
            "advect_faces: lattice"
        );
    }
    // A closed box's w-lattice has a slab more than the cells.
    let slabs = lattices.iter().map(|l| l[2]).fold(nz, usize::max);
    let mut out: Vec<SlabOut> = (0..slabs)
        .map(|k| SlabOut {
            k,
            faces: [None, None, None],
            gases: Vec::with_capacity(dsts.len()),
        })
        .collect();
    for (a, comp) in dst.slices_mut().into_iter().enumerate() {
        let l = lattices[a];
        for (slab, chunk) in out.iter_mut().zip(comp.chunks_mut(l[0] * l[1])) {
            slab.faces[a] = Some(chunk);
        }
    }
    for g in dsts.iter_mut() {
        for (slab, chunk) in out.iter_mut().zip(g.as_slice_mut().chunks_mut(nx * ny)) {
            slab.gases.push(chunk);
        }
    }
    let sw = Sweep {
        vel: Vel::new(vel.sampler()),
        dt: dt / d.cell,
        backtrace,
        faces,
        gases: srcs.iter().map(|g| (g.as_slice(), g.wrap())).collect(),
    };
    let row = lattices.iter().map(|l| l[0]).fold(nx, usize::max);
    // RK2 traces the cells below a chunk's first slab once more: chunks
    // of several slabs, a few per thread.
    let chunk = match backtrace {
        Backtrace::Rk2 => (slabs / (4 * rayon::current_num_threads())).max(4),
        Backtrace::Euler | Backtrace::Rk3 | Backtrace::Exact => 1,
    };
    out.par_chunks_mut(chunk).for_each_init(
        || Scratch::new(row),
        |scratch, slabs| kernel::chunk(isa, &sw, slabs, scratch),
    );
    dst.zero_walls();
}

/// The faces' departure points as the sweeps trace them, for passes that
/// need them again (MacCormack's clamp): RK2's from every cell's
/// displacement, traced once for the whole grid ([`FaceTraces::new`]);
/// Euler's and RK3's point by point ([`departure_points`]).
pub(crate) struct FaceTraces<'a> {
    vel: Vel<'a>,
    grid: &'a FaceGrid,
    dt_cells: f32,
    backtrace: Backtrace,
    /// RK2: each z-slab's cells' displacements, three planes (x, y, z).
    disp: &'a [f32],
}

impl<'a> FaceTraces<'a> {
    /// The faces of `vel` traced back over `dt` (world time) by
    /// `backtrace`; `disp` holds the cells' displacements (RK2), resized
    /// to fit.
    pub(crate) fn new(
        vel: &'a FaceGrid,
        (dt, backtrace): (f32, Backtrace),
        disp: &'a mut Vec<f32>,
    ) -> Self {
        let (v, dt_cells) = (Vel::new(vel.sampler()), dt / vel.domain().cell);
        if backtrace == Backtrace::Rk2 {
            let [nx, ny, nz] = vel.domain().dims;
            let isa = Isa::selected();
            disp.resize(3 * nx * ny * nz, 0.0);
            disp.par_chunks_mut(3 * nx * ny).enumerate().for_each_init(
                || Scratch::new(nx),
                |scratch, (k, out)| kernel::displacements(isa, (&v, dt_cells), k, out, scratch),
            );
        }
        Self {
            vel: v,
            grid: vel,
            dt_cells,
            backtrace,
            disp,
        }
    }

    /// The departure points of the faces of row `(j, k)` of component
    /// `a`'s lattice into `row` (its length set), in cell-centre grid
    /// coordinates; `mean`, three rows of scratch.
    pub(crate) fn row(
        &self,
        a: usize,
        (j, k): (usize, usize),
        row: &mut Vec<Vec3>,
        mean: &mut [Vec<f32>; 3],
    ) {
        let m = self.vel.dims[a][0];
        row.clear();
        row.extend((0..m).map(|i| {
            let mut g = Vec3::new(i as f32, j as f32, k as f32);
            g[a] -= 0.5;
            g
        }));
        if self.backtrace != Backtrace::Rk2 {
            departure_points(self.grid, row, self.dt_cells, self.backtrace);
            return;
        }
        for r in mean.iter_mut() {
            r.resize(m, 0.0);
        }
        let slab = 3 * self.vel.cells[0] * self.vel.cells[1];
        let at = |k: usize| &self.disp[k * slab..(k + 1) * slab];
        match a {
            0 => kernel::face_row_displacements::<0>(&self.vel, j, [at(k), at(k)], mean),
            1 => kernel::face_row_displacements::<1>(&self.vel, j, [at(k), at(k)], mean),
            _ => {
                let [lo, hi] = kernel::face_cells::<2>(&self.vel, [0, j, k]);
                kernel::face_row_displacements::<2>(&self.vel, j, [at(lo[2]), at(hi[2])], mean)
            }
        }
        for (i, g) in row.iter_mut().enumerate() {
            *g -= Vec3::new(mean[0][i], mean[1][i], mean[2][i]);
        }
    }
}

/// `data` (a cell-centred grid of `cells`, `wrap`ped) interpolated at the
/// points `g` (grid coordinates, `[x, y, z]` lanes) into `out`:
/// [`crate::grid::Stencil`]'s trilinear in the kernel's lanes, the same
/// bits as point by point.
///
/// # Panics
/// If a lane's length differs from `out`'s, or `data` is shorter than `cells`.
pub(crate) fn sample_points(
    data: &[f32],
    (cells, wrap): ([usize; 3], Wrap),
    g: [&[f32]; 3],
    out: &mut [f32],
) {
    kernel::sample(Isa::selected(), &[data], (cells, wrap), g, &mut [out]);
}

/// [`FaceGrid::sample`] at each of `points` into `out`, the same values
/// to the bit: the kernel's lanes at a time, the points it leaves (more
/// than a period outside, NaN) through [`FaceSampler::at`].
///
/// # Panics
/// If `points` and `out` differ in length.
pub fn sample_face_points(vel: &FaceGrid, points: &[Vec3], out: &mut [Vec3]) {
    sample_faces_mapped(vel, points, out, |p| vel.domain().grid_coords(p));
}

/// [`sample_face_points`] at cell-centre grid coordinates (as
/// [`FaceGrid::sample_grid_coords`]).
///
/// # Panics
/// If `g` and `out` differ in length.
pub fn sample_face_grid_points(vel: &FaceGrid, g: &[Vec3], out: &mut [Vec3]) {
    sample_faces_mapped(vel, g, out, |g| g);
}

/// The face sampler at `g(p)` for each of `points`, batched as
/// [`sample_face_points`] says.
fn sample_faces_mapped(
    vel: &FaceGrid,
    points: &[Vec3],
    out: &mut [Vec3],
    g: impl Fn(Vec3) -> Vec3,
) {
    assert_eq!(
        points.len(),
        out.len(),
        "sample_face_points: slice lengths differ"
    );
    let sampler = Vel::new(vel.sampler());
    let isa = Isa::selected();
    let mut at = [Vec3::ZERO; 256];
    for (p, o) in points.chunks(at.len()).zip(out.chunks_mut(at.len())) {
        let at = &mut at[..p.len()];
        for (a, &p) in at.iter_mut().zip(p) {
            *a = g(p);
        }
        kernel::velocities(isa, &sampler, at, o);
    }
}

/// The cell sweep of [`advect_fused`] row by row, for other sweeps over
/// the velocity's cells (SELMA's map, eq 8.8): each row's departure points
/// traced through the kernel's lanes ([`CellRows::trace`]) and cell-centred
/// grids sampled there, one stencil per point ([`CellRows::sample`]) — the
/// same bits as [`departure_point`] and [`crate::grid::Stencil`] point by
/// point.
pub(crate) struct CellRows<'a> {
    isa: Isa,
    vel: Vel<'a>,
    dt_cells: f32,
    backtrace: Backtrace,
}

/// One thread's rows for [`CellRows::trace`]: the kernel's and the traced
/// points'.
pub(crate) struct RowScratch {
    kernel: Scratch,
    points: [Vec<f32>; 3],
}

impl<'a> CellRows<'a> {
    /// Backtraces through `vel` over `dt` (world time) by `backtrace`.
    pub(crate) fn new(vel: &'a FaceGrid, (dt, backtrace): (f32, Backtrace)) -> Self {
        Self {
            isa: Isa::selected(),
            vel: Vel::new(vel.sampler()),
            dt_cells: dt / vel.domain().cell,
            backtrace,
        }
    }

    /// Rows for one thread.
    pub(crate) fn scratch(&self) -> RowScratch {
        let nx = self.vel.cells[0];
        RowScratch {
            kernel: Scratch::new(nx),
            points: std::array::from_fn(|_| vec![0.0; nx]),
        }
    }

    /// The departure points of the cell centres of row `(j, k)` (grid
    /// coordinates, `[x, y, z]` lanes a row long), in `scratch`.
    pub(crate) fn trace<'s>(
        &self,
        (j, k): (usize, usize),
        scratch: &'s mut RowScratch,
    ) -> [&'s mut [f32]; 3] {
        let trace = (&self.vel, self.dt_cells, self.backtrace);
        let points = scratch.points.each_mut().map(|l| &mut l[..]);
        kernel::cell_points(self.isa, trace, (j, k), points, &mut scratch.kernel);
        scratch.points.each_mut().map(|l| &mut l[..])
    }

    /// `datas` (grids on the velocity's cells, `wrap`ped) at the points `g`
    /// into `outs` (one per grid): the stencil found once per point.
    ///
    /// # Panics
    /// If the lanes and outputs differ in length, or `datas` and `outs` in
    /// number.
    pub(crate) fn sample(
        &self,
        datas: &[&[f32]],
        wrap: Wrap,
        g: [&[f32]; 3],
        outs: &mut [&mut [f32]],
    ) {
        kernel::sample(self.isa, datas, (self.vel.cells, wrap), g, outs);
    }
}
