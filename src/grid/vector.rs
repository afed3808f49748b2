//! Vector grid: three interleaved f32 components per cell centre.

use glam::Vec3;
use ndarray::{Array4, Ix4};
use rayon::prelude::*;

use super::samples::{write_slabs, Grid};
use super::{Stencil, Wrap};
use crate::domain::Domain;
use crate::field::VectorField;

/// Vector samples on the cell centres of a [`Domain`], shape `(nz, ny, nx, 3)`
/// with components `x, y, z` interleaved (the `.npy` layout smokelab writes).
pub type VectorGrid = Grid<Ix4>;

impl Grid<Ix4> {
    /// A grid of zero vectors, periodic.
    pub fn zeros(domain: Domain) -> Self {
        let (nz, ny, nx) = domain.shape();
        Self {
            domain,
            wrap: Wrap::Periodic,
            data: Array4::zeros((nz, ny, nx, 3)),
        }
    }

    /// Wrap an array of shape `(nz, ny, nx, 3)`.
    ///
    /// # Panics
    /// If the array's shape is not the domain's.
    pub fn from_array(domain: Domain, data: Array4<f32>) -> Self {
        let (nz, ny, nx) = domain.shape();
        Self::checked(domain, data, &[nz, ny, nx, 3])
    }

    /// `cachewrite`: sample a vector field at every cell centre, in parallel
    /// batches of one z-slab.
    pub fn from_field(domain: Domain, field: &dyn VectorField) -> Self {
        let mut grid = Self::zeros(domain);
        grid.write_field(field);
        grid
    }

    /// Overwrite the samples with `field` at every cell centre.
    pub fn write_field(&mut self, field: &dyn VectorField) {
        let domain = self.domain;
        write_slabs(domain, self.as_vec3_mut(), |p, out| {
            field.eval_batch(p, out)
        });
    }

    /// Samples as one [`Vec3`] per cell, `[z][y][x]` order.
    pub fn as_vec3(&self) -> &[Vec3] {
        let s = self.as_slice();
        // SAFETY: Vec3 is `#[repr(C)]` of three f32 with alignment 4, and the
        // slice holds a whole number of triples.
        unsafe { std::slice::from_raw_parts(s.as_ptr().cast::<Vec3>(), s.len() / 3) }
    }

    /// Samples as one mutable [`Vec3`] per cell.
    pub fn as_vec3_mut(&mut self) -> &mut [Vec3] {
        let s = self.as_slice_mut();
        // SAFETY: as in `as_vec3`; the borrow is unique.
        unsafe { std::slice::from_raw_parts_mut(s.as_mut_ptr().cast::<Vec3>(), s.len() / 3) }
    }

    /// Trilinear sample at continuous grid coordinates (cell centres at integers).
    #[inline]
    pub fn sample_grid_coords(&self, g: Vec3) -> Vec3 {
        Stencil::new(g, self.domain.dims, self.wrap).apply_vec3(self.as_slice())
    }

    /// Largest speed |u| over the grid.
    pub fn max_norm(&self) -> f32 {
        self.as_vec3()
            .par_iter()
            .map(|v| v.length())
            .reduce(|| 0.0, f32::max)
    }

    /// Root-mean-square speed (fixed chunks summed in parallel, their sums
    /// added in order: the same bits at any thread count).
    pub fn rms_norm(&self) -> f32 {
        let sums: Vec<f64> = (self.as_vec3().par_chunks(4096))
            .map(|c| c.iter().map(|v| v.length_squared() as f64).sum::<f64>())
            .collect();
        (sums.iter().sum::<f64>() / self.domain.len() as f64).sqrt() as f32
    }
}

impl VectorField for VectorGrid {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample_grid_coords(self.domain.grid_coords(p))
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        let data = self.as_slice();
        for (o, &p) in out.iter_mut().zip(points) {
            *o = Stencil::new(self.domain.grid_coords(p), self.domain.dims, self.wrap)
                .apply_vec3(data);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops;

    #[test]
    fn constant_vector_field_round_trips() {
        let d = Domain::cube(5, 1.0).unwrap();
        let v = Vec3::new(1.0, -2.0, 0.5);
        let g = VectorGrid::from_field(d, &*ops::constant_vector(v));
        assert_eq!(g.data()[[4, 3, 2, 1]], -2.0);
        assert!((g.eval(Vec3::new(0.13, 0.77, 0.5)) - v).length() < 1e-6);
        assert!((g.max_norm() - v.length()).abs() < 1e-6);
    }
}
