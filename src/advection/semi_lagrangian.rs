//! Semi-Lagrangian advection (eqs 6.4–6.5), grid to grid.
//!
//! For every cell centre `x` the departure point `x_d` is traced backwards
//! through the velocity grid with the chosen [`Backtrace`], and the advected
//! quantity is interpolated trilinearly there: `q_new(x) = q(x_d)`.
//!
//! All quantities of one step (every density and the velocity itself) move
//! with the same velocity, so the departure points are traced once per step
//! into [`Departures`] and reused by every [`interpolate_scalar`] /
//! [`interpolate_vector`]. Work is done in continuous grid coordinates (cell
//! centres at integers): a velocity `u` moves a point by `u Δt / Δx` cells,
//! and the first velocity sample of every backtrace is the cell's own value,
//! read without interpolation.
//!
//! [`advect_fused`] does the whole step of a simulation in one pass: for each
//! cell it traces the departure point once and interpolates the velocity and
//! every density there with one shared stencil, so memory is swept once.
//!
//! Parallel over z-slabs with rayon; no per-cell allocation.

use glam::Vec3;
use rayon::prelude::*;

use super::Backtrace;
use crate::domain::Domain;
use crate::grid::{ScalarGrid, Stencil, VectorGrid, Wrap};

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
    pub fn trace(&mut self, vel: &VectorGrid, dt: f32, backtrace: Backtrace) {
        assert_eq!(
            vel.domain(),
            &self.domain,
            "departures: velocity on another domain"
        );
        let dt_cells = dt / self.domain.cell;
        let [nx, ny, _] = self.domain.dims;
        let u = vel.as_vec3();
        let sampler = VelocitySampler::new(vel);
        self.points
            .par_chunks_mut(nx * ny)
            .zip(u.par_chunks(nx * ny))
            .enumerate()
            .for_each(|(k, (out, u0))| {
                for j in 0..ny {
                    for i in 0..nx {
                        let n = j * nx + i;
                        let c = Vec3::new(i as f32, j as f32, k as f32);
                        out[n] = departure(sampler, c, u0[n], dt_cells, backtrace);
                    }
                }
            });
    }
}

/// Departure point, in grid coordinates, of an arbitrary point `g` (grid
/// coordinates) traced back through `vel` over `dt_cells = Δt/Δx` cells.
///
/// The same arithmetic as [`Departures::trace`]: at a cell centre the result
/// is bit-identical (trilinear interpolation at an integer point returns the
/// sample itself). Gridless and SELMA densities use it so that their
/// characteristics are exactly those of the gridded path.
#[inline]
pub fn departure_point(vel: &VectorGrid, g: Vec3, dt_cells: f32, backtrace: Backtrace) -> Vec3 {
    let vel = VelocitySampler::new(vel);
    departure(vel, g, vel.at(g), dt_cells, backtrace)
}

/// Trilinear velocity lookups with the grid's slice and layout hoisted out of
/// the per-cell loop.
#[derive(Clone, Copy)]
struct VelocitySampler<'a> {
    data: &'a [f32],
    dims: [usize; 3],
    wrap: Wrap,
}

impl<'a> VelocitySampler<'a> {
    fn new(vel: &'a VectorGrid) -> Self {
        Self {
            data: vel.as_slice(),
            dims: vel.domain().dims,
            wrap: vel.wrap(),
        }
    }

    #[inline(always)]
    fn at(&self, g: Vec3) -> Vec3 {
        Stencil::new(g, self.dims, self.wrap).apply_vec3(self.data)
    }
}

/// Departure point, in grid coordinates, of the cell centre `c` whose own
/// velocity is `u0`, after `dt_cells = Δt/Δx`.
#[inline(always)]
fn departure(vel: VelocitySampler, c: Vec3, u0: Vec3, dt_cells: f32, backtrace: Backtrace) -> Vec3 {
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
    dst.as_slice_mut()
        .par_chunks_mut(4096)
        .zip(dep.points.par_chunks(4096))
        .for_each(|(out, pts)| {
            for (o, &g) in out.iter_mut().zip(pts) {
                *o = Stencil::new(g, d.dims, wrap).apply(data);
            }
        });
}

/// `dst(x) = src(x_d)` for a vector grid.
///
/// # Panics
/// If the grids are not on the departures' domain.
pub fn interpolate_vector(src: &VectorGrid, dep: &Departures, dst: &mut VectorGrid) {
    let d = dep.domain;
    assert_eq!(
        src.domain(),
        &d,
        "interpolate_vector: source on another domain"
    );
    assert_eq!(
        dst.domain(),
        &d,
        "interpolate_vector: target on another domain"
    );
    let (data, wrap) = (src.as_slice(), src.wrap());
    dst.as_vec3_mut()
        .par_chunks_mut(4096)
        .zip(dep.points.par_chunks(4096))
        .for_each(|(out, pts)| {
            for (o, &g) in out.iter_mut().zip(pts) {
                *o = Stencil::new(g, d.dims, wrap).apply_vec3(data);
            }
        });
}

/// `dst = src(x − ∫u dt)`: advect a scalar grid by `vel` over `dt` (eq 6.4
/// without the source). Allocates its departure points; time steps that move
/// several quantities use [`Departures`] directly.
pub fn advect_scalar(
    src: &ScalarGrid,
    vel: &VectorGrid,
    dt: f32,
    backtrace: Backtrace,
    dst: &mut ScalarGrid,
) {
    let mut dep = Departures::new(*vel.domain());
    dep.trace(vel, dt, backtrace);
    interpolate_scalar(src, &dep, dst);
}

/// `dst = src(x − ∫u dt)` for a vector grid (eq 6.5 without the force).
pub fn advect_vector(
    src: &VectorGrid,
    vel: &VectorGrid,
    dt: f32,
    backtrace: Backtrace,
    dst: &mut VectorGrid,
) {
    let mut dep = Departures::new(*vel.domain());
    dep.trace(vel, dt, backtrace);
    interpolate_vector(src, &dep, dst);
}

/// One semi-Lagrangian step for everything that moves with `vel`:
/// `vel_out = vel(x_d)` and `dsts[n] = srcs[n](x_d)` with the departure point
/// `x_d` traced once per cell (eqs 6.4–6.5 without sources and forces).
///
/// # Panics
/// If a grid is on another domain, or `srcs` and `dsts` differ in length.
pub fn advect_fused(
    vel: &VectorGrid,
    dt: f32,
    backtrace: Backtrace,
    srcs: &[&ScalarGrid],
    dsts: &mut [&mut ScalarGrid],
    vel_out: &mut VectorGrid,
) {
    let d = *vel.domain();
    assert_eq!(
        srcs.len(),
        dsts.len(),
        "advect_fused: {} sources but {} targets",
        srcs.len(),
        dsts.len()
    );
    assert_eq!(
        vel_out.domain(),
        &d,
        "advect_fused: velocity target on another domain"
    );
    for g in srcs
        .iter()
        .map(|g| g.domain())
        .chain(dsts.iter().map(|g| g.domain()))
    {
        assert_eq!(g, &d, "advect_fused: density on another domain");
    }
    let [nx, ny, _] = d.dims;
    let slab = nx * ny;
    let dt_cells = dt / d.cell;
    let (u, sampler) = (vel.as_vec3(), VelocitySampler::new(vel));
    let src: Vec<(&[f32], Wrap)> = srcs.iter().map(|g| (g.as_slice(), g.wrap())).collect();
    // Split every target into z-slabs and regroup them per slab.
    let mut slabs: Vec<(&mut [Vec3], Vec<&mut [f32]>)> = vel_out
        .as_vec3_mut()
        .chunks_mut(slab)
        .map(|c| (c, Vec::with_capacity(dsts.len())))
        .collect();
    for dst in dsts.iter_mut() {
        for (s, chunk) in slabs.iter_mut().zip(dst.as_slice_mut().chunks_mut(slab)) {
            s.1.push(chunk);
        }
    }
    // One row at a time: trace and build the stencils of the row, then sweep
    // each quantity through them (tight loops, stencils hot in L1).
    slabs.into_par_iter().enumerate().for_each_init(
        || (Vec::with_capacity(nx), Vec::with_capacity(nx)),
        |(points, stencils), (k, (vout, mut outs))| {
            for j in 0..ny {
                let row = j * nx..(j + 1) * nx;
                points.clear();
                stencils.clear();
                for (i, &u0) in u[k * slab + j * nx..][..nx].iter().enumerate() {
                    let c = Vec3::new(i as f32, j as f32, k as f32);
                    let g = departure(sampler, c, u0, dt_cells, backtrace);
                    points.push(g);
                    stencils.push(Stencil::new(g, d.dims, sampler.wrap));
                }
                for (o, st) in vout[row.clone()].iter_mut().zip(stencils.iter()) {
                    *o = st.apply_vec3(sampler.data);
                }
                for ((data, wrap), out) in src.iter().zip(outs.iter_mut()) {
                    let out = &mut out[row.clone()];
                    if *wrap == sampler.wrap {
                        for (o, st) in out.iter_mut().zip(stencils.iter()) {
                            *o = st.apply(data);
                        }
                    } else {
                        for (o, &g) in out.iter_mut().zip(points.iter()) {
                            *o = Stencil::new(g, d.dims, *wrap).apply(data);
                        }
                    }
                }
            }
        },
    );
}
