//! Semi-Lagrangian advection (eqs 6.4–6.5), grid to grid.
//!
//! For every cell centre `x` the departure point `x_d` is traced backwards
//! through the velocity grid with the chosen [`Backtrace`], and the advected
//! quantity is interpolated trilinearly there: `q_new(x) = q(x_d)`. Work is
//! done in continuous grid coordinates (cell centres at integers), so a
//! velocity `u` moves a point by `u Δt / Δx` cells. The first velocity sample
//! of every backtrace is the cell's own value, read without interpolation.
//!
//! Parallel over z-slabs with rayon; no allocation.

use glam::Vec3;
use rayon::prelude::*;

use super::Backtrace;
use crate::grid::{ScalarGrid, Stencil, VectorGrid};

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

/// `dst = src(x − ∫u dt)`: advect a scalar grid by `vel` over `dt` (eq 6.4
/// without the source).
///
/// # Panics
/// If the three grids do not share one domain.
pub fn advect_scalar(
    src: &ScalarGrid,
    vel: &VectorGrid,
    dt: f32,
    backtrace: Backtrace,
    dst: &mut ScalarGrid,
) {
    let d = *vel.domain();
    assert_eq!(
        src.domain(),
        &d,
        "advect_scalar: source and velocity domains differ"
    );
    assert_eq!(
        dst.domain(),
        &d,
        "advect_scalar: target and velocity domains differ"
    );
    let dt_cells = dt / d.cell;
    let [nx, ny, _] = d.dims;
    let (data, wrap, u) = (src.as_slice(), src.wrap(), vel.as_vec3());
    dst.as_slice_mut()
        .par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(k, slab)| {
            for j in 0..ny {
                for i in 0..nx {
                    let n = j * nx + i;
                    let c = Vec3::new(i as f32, j as f32, k as f32);
                    let g = departure(vel, c, u[k * nx * ny + n], dt_cells, backtrace);
                    slab[n] = Stencil::new(g, d.dims, wrap).apply(data);
                }
            }
        });
}

/// `dst = src(x − ∫u dt)` for a vector grid (eq 6.5 without the force);
/// `src` may be `vel` itself (self-advection).
///
/// # Panics
/// If the three grids do not share one domain.
pub fn advect_vector(
    src: &VectorGrid,
    vel: &VectorGrid,
    dt: f32,
    backtrace: Backtrace,
    dst: &mut VectorGrid,
) {
    let d = *vel.domain();
    assert_eq!(
        src.domain(),
        &d,
        "advect_vector: source and velocity domains differ"
    );
    assert_eq!(
        dst.domain(),
        &d,
        "advect_vector: target and velocity domains differ"
    );
    let dt_cells = dt / d.cell;
    let [nx, ny, _] = d.dims;
    let (data, wrap, u) = (src.as_slice(), src.wrap(), vel.as_vec3());
    dst.as_vec3_mut()
        .par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(k, slab)| {
            for j in 0..ny {
                for i in 0..nx {
                    let n = j * nx + i;
                    let c = Vec3::new(i as f32, j as f32, k as f32);
                    let g = departure(vel, c, u[k * nx * ny + n], dt_cells, backtrace);
                    slab[n] = Stencil::new(g, d.dims, wrap).apply_vec3(data);
                }
            }
        });
}
