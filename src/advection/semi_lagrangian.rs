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
//! Parallel over z-slabs with rayon; no allocation after [`Departures::new`].

use glam::Vec3;
use rayon::prelude::*;

use super::Backtrace;
use crate::domain::Domain;
use crate::grid::{ScalarGrid, Stencil, VectorGrid};

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
        self.points
            .par_chunks_mut(nx * ny)
            .zip(u.par_chunks(nx * ny))
            .enumerate()
            .for_each(|(k, (out, u0))| {
                for j in 0..ny {
                    for i in 0..nx {
                        let n = j * nx + i;
                        let c = Vec3::new(i as f32, j as f32, k as f32);
                        out[n] = departure(vel, c, u0[n], dt_cells, backtrace);
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
    departure(vel, g, vel.sample_grid_coords(g), dt_cells, backtrace)
}

/// Departure point, in grid coordinates, of the cell centre `c` whose own
/// velocity is `u0`, after `dt_cells = Δt/Δx`.
#[inline(always)]
fn departure(vel: &VectorGrid, c: Vec3, u0: Vec3, dt_cells: f32, backtrace: Backtrace) -> Vec3 {
    let u = |g: Vec3| vel.sample_grid_coords(g);
    match backtrace {
        Backtrace::Euler => c - dt_cells * u0,
        Backtrace::Rk2 => c - dt_cells * u(c - 0.5 * dt_cells * u0),
        Backtrace::Rk3 => {
            // Kutta's RK3 for dx/dt = −u(x): k1 = −u(x), k2 = −u(x + ½k1),
            // k3 = −u(x − k1 + 2k2), x_d = x + (k1 + 4k2 + k3)/6 (times Δt).
            let k1 = -dt_cells * u0;
            let k2 = -dt_cells * u(c + 0.5 * k1);
            let k3 = -dt_cells * u(c - k1 + 2.0 * k2);
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
