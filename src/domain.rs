//! The simulation box: origin, cell size and cell counts.
//!
//! Conventions used everywhere in smokelab:
//! - world units, y is up, gravity points along −y;
//! - cell `(i, j, k)` has its centre at `origin + (i + ½, j + ½, k + ½) Δx`;
//! - arrays are stored `[z][y][x]` (x fastest), so the ndarray shape is
//!   `(nz, ny, nx)` and vector grids add a trailing axis of 3 components.

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use crate::error::InputError;

/// Smallest cell count per axis: QUICK's stencil (two cells upwind, one
/// downwind) and the pressure solve's tests need at least four cells.
pub const MIN_CELLS: usize = 4;

/// Most cells a box may have (2^40, about 13 TB for one vector grid of f32):
/// bigger boxes are refused before any size arithmetic could overflow.
pub const MAX_CELLS: u64 = 1 << 40;

/// A box of `nx × ny × nz` cubic cells of edge `cell`, lower corner `origin`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Domain {
    /// Lower corner of the box in world units.
    pub origin: Vec3,
    /// Edge length Δx of one cubic cell.
    pub cell: f32,
    /// Cell counts `[nx, ny, nz]`.
    pub dims: [usize; 3],
}

impl Domain {
    /// A box with the given corner, cell size and cell counts.
    ///
    /// Fails when a count is below [`MIN_CELLS`] or the cell size is not a
    /// positive finite number.
    pub fn new(origin: Vec3, cell: f32, dims: [usize; 3]) -> Result<Self, InputError> {
        for (axis, &n) in ["x", "y", "z"].iter().zip(&dims) {
            if n < MIN_CELLS {
                return Err(InputError::new(format!(
                    "cell count along {axis} is {n}; it must be at least {MIN_CELLS}"
                )));
            }
        }
        let cells = dims.iter().try_fold(1u64, |a, &n| a.checked_mul(n as u64));
        if cells.is_none_or(|c| c > MAX_CELLS) {
            return Err(InputError::new(format!(
                "{} × {} × {} cells is more than the {MAX_CELLS} cells a grid may hold; use a smaller resolution",
                dims[0], dims[1], dims[2]
            )));
        }
        if !(cell.is_finite() && cell > 0.0) {
            return Err(InputError::new(format!(
                "cell size is {cell}; it must be a positive finite number"
            )));
        }
        if !origin.is_finite() {
            return Err(InputError::new(format!(
                "domain origin is {origin}; it must be finite"
            )));
        }
        Ok(Self { origin, cell, dims })
    }

    /// A cube `[0, size]³` with `res` cells per axis.
    pub fn cube(res: usize, size: f32) -> Result<Self, InputError> {
        Self::new(Vec3::ZERO, size / res as f32, [res; 3])
    }

    /// The same box with `factor` times as many cells per axis.
    pub fn refined(&self, factor: usize) -> Self {
        Self {
            origin: self.origin,
            cell: self.cell / factor as f32,
            dims: self.dims.map(|n| n * factor),
        }
    }

    /// The same box resampled with `res` cells along its longest axis.
    pub fn with_resolution(&self, res: usize) -> Result<Self, InputError> {
        let size = self.size();
        let cell = size.max_element() / res as f32;
        let dims = [size.x, size.y, size.z].map(|s| ((s / cell).round() as usize).max(1));
        Self::new(self.origin, cell, dims)
    }

    /// Edge lengths of the box.
    pub fn size(&self) -> Vec3 {
        Vec3::new(
            self.dims[0] as f32,
            self.dims[1] as f32,
            self.dims[2] as f32,
        ) * self.cell
    }

    /// Upper corner of the box.
    pub fn max_corner(&self) -> Vec3 {
        self.origin + self.size()
    }

    /// Number of cells.
    pub fn len(&self) -> usize {
        self.dims.iter().product()
    }

    /// Always false: a domain has at least [`MIN_CELLS`]³ cells.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// ndarray shape `(nz, ny, nx)`.
    pub fn shape(&self) -> (usize, usize, usize) {
        (self.dims[2], self.dims[1], self.dims[0])
    }

    /// Volume of one cell, Δx³.
    pub fn cell_volume(&self) -> f32 {
        self.cell * self.cell * self.cell
    }

    /// World position of the centre of cell `(i, j, k)`.
    #[inline]
    pub fn cell_center(&self, i: usize, j: usize, k: usize) -> Vec3 {
        self.origin + (Vec3::new(i as f32, j as f32, k as f32) + 0.5) * self.cell
    }

    /// Continuous grid coordinates of a world point: cell centres sit at
    /// integer values.
    #[inline]
    pub fn grid_coords(&self, p: Vec3) -> Vec3 {
        (p - self.origin) / self.cell - 0.5
    }

    /// World point of continuous grid coordinates (inverse of [`Self::grid_coords`]).
    #[inline]
    pub fn world_of(&self, g: Vec3) -> Vec3 {
        self.origin + (g + 0.5) * self.cell
    }

    /// Linear index of cell `(i, j, k)` in `[z][y][x]` order.
    #[inline]
    pub fn index(&self, i: usize, j: usize, k: usize) -> usize {
        (k * self.dims[1] + j) * self.dims[0] + i
    }

    /// Linear index of cell `c` moved `step` cells along `axis`, wrapped
    /// (periodic).
    #[inline]
    pub fn neighbour(&self, c: [usize; 3], axis: usize, step: isize) -> usize {
        let mut c = c;
        c[axis] = (c[axis] as isize + step).rem_euclid(self.dims[axis] as isize) as usize;
        self.index(c[0], c[1], c[2])
    }

    /// The 3×3×3 block of cells around cell `[i, j, k]` (itself the
    /// thirteenth, its 26 neighbours around it), as linear indices, wrapped
    /// periodically; on an axis of fewer than three cells a cell appears
    /// more than once.
    pub fn block(&self, c: [usize; 3]) -> impl Iterator<Item = usize> + '_ {
        let step = |c: usize, d: usize, len: usize| (c + len + d - 1) % len;
        (0..27).map(move |o| {
            let [nx, ny, nz] = self.dims;
            let (a, b, e) = (o % 3, (o / 3) % 3, o / 9);
            self.index(step(c[0], a, nx), step(c[1], b, ny), step(c[2], e, nz))
        })
    }

    /// Call `f(n, [i, j, k], &mut values[n])` for every cell of a `[z][y][x]`
    /// array (or a periodic face component, which has the same layout), in
    /// parallel over z-slabs.
    ///
    /// # Panics
    /// If `values` does not have one entry per cell.
    pub fn par_for_each_cell<T: Send>(
        &self,
        values: &mut [T],
        f: impl Fn(usize, [usize; 3], &mut T) + Sync,
    ) {
        assert_eq!(values.len(), self.len(), "one value per cell");
        let [nx, ny, _] = self.dims;
        values
            .par_chunks_mut(nx * ny)
            .enumerate()
            .for_each(|(k, slab)| {
                for (m, v) in slab.iter_mut().enumerate() {
                    f(k * nx * ny + m, [m % nx, m / nx, k], v);
                }
            });
    }

    /// Whether a world point lies inside the box (lower faces included).
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.origin).all() && p.cmplt(self.max_corner()).all()
    }

    /// Cell centres of one z-slab, in `[y][x]` order, written into `out`.
    pub fn slab_centers(&self, k: usize, out: &mut Vec<Vec3>) {
        out.clear();
        for j in 0..self.dims[1] {
            for i in 0..self.dims[0] {
                out.push(self.cell_center(i, j, k));
            }
        }
    }
}

/// Wrap `x` into `[lo, lo + len)`.
#[inline(always)]
pub(crate) fn wrap1(x: f32, lo: f32, len: f32) -> f32 {
    if x < lo {
        let y = x + len;
        if y >= lo {
            y
        } else {
            lo + (x - lo).rem_euclid(len)
        }
    } else if x >= lo + len {
        let y = x - len;
        if y < lo + len {
            y
        } else {
            lo + (x - lo).rem_euclid(len)
        }
    } else {
        x
    }
}

/// Continuous grid coordinates wrapped into one period (the periodic box
/// convention every periodic sampler shares), `[−½, n − ½)` per
/// axis (the periodic box); points inside are returned unchanged.
#[inline(always)]
pub(crate) fn wrap_grid(g: Vec3, dims: [usize; 3]) -> Vec3 {
    Vec3::new(
        wrap1(g.x, -0.5, dims[0] as f32),
        wrap1(g.y, -0.5, dims[1] as f32),
        wrap1(g.z, -0.5, dims[2] as f32),
    )
}

/// A world point wrapped into the periodic box of `d`; points inside are
/// returned unchanged.
#[inline(always)]
pub(crate) fn wrap_world(d: &Domain, p: Vec3) -> Vec3 {
    let (o, s) = (d.origin, d.size());
    Vec3::new(
        wrap1(p.x, o.x, s.x),
        wrap1(p.y, o.y, s.y),
        wrap1(p.z, o.z, s.z),
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn grid_wrapping_folds_into_one_period() {
        let g = super::wrap_grid(glam::Vec3::new(-0.6, 7.5, 3.0), [8, 8, 8]);
        assert!((g - glam::Vec3::new(7.4, -0.5, 3.0)).length() < 1e-5);
    }

    use super::*;

    #[test]
    fn centres_and_coords_round_trip() {
        let d = Domain::new(Vec3::new(1.0, -2.0, 0.5), 0.25, [8, 6, 5]).unwrap();
        let c = d.cell_center(3, 2, 4);
        assert_eq!(d.grid_coords(c), Vec3::new(3.0, 2.0, 4.0));
        assert_eq!(d.world_of(Vec3::new(3.0, 2.0, 4.0)), c);
        assert_eq!(d.index(3, 2, 4), (4 * 6 + 2) * 8 + 3);
        assert_eq!(d.shape(), (5, 6, 8));
    }

    #[test]
    fn rejects_tiny_and_degenerate_domains() {
        assert!(Domain::new(Vec3::ZERO, 1.0, [3, 8, 8]).is_err());
        assert!(Domain::new(Vec3::ZERO, 0.0, [8, 8, 8]).is_err());
        assert!(Domain::new(Vec3::ZERO, f32::NAN, [8, 8, 8]).is_err());
    }

    /// `--res 2097152` used to overflow `nx·ny·nz` to 0 and panic later.
    #[test]
    fn rejects_cell_counts_whose_product_overflows() {
        let e = Domain::cube(2_097_152, 10.0).unwrap_err().to_string();
        assert!(e.contains("2097152 × 2097152 × 2097152 cells"), "{e}");
        assert!(Domain::new(Vec3::ZERO, 1.0, [usize::MAX, 8, 8]).is_err());
        let at_limit = (MAX_CELLS as f64).cbrt() as usize;
        assert!(Domain::cube(at_limit, 1.0).is_ok());
        assert!(Domain::cube(at_limit + 1, 1.0).is_err());
    }
}
