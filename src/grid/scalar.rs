//! Scalar grid: one f32 per cell centre.

use glam::Vec3;
use ndarray::{Array3, Ix3};
use rayon::prelude::*;

use super::samples::{write_slabs, Grid};
use super::{Stencil, Wrap};
use crate::domain::Domain;
use crate::field::ScalarField;

/// Scalar samples on the cell centres of a [`Domain`], shape `(nz, ny, nx)`.
///
/// As a [`ScalarField`] it interpolates trilinearly (`cacheread`), periodic or
/// clamped according to its [`Wrap`].
pub type ScalarGrid = Grid<Ix3>;

impl Grid<Ix3> {
    /// A grid of zeros, periodic.
    pub fn zeros(domain: Domain) -> Self {
        Self {
            domain,
            wrap: Wrap::Periodic,
            data: Array3::zeros(domain.shape()),
        }
    }

    /// Wrap an array of shape `(nz, ny, nx)`.
    ///
    /// # Panics
    /// If the array's shape is not the domain's.
    pub fn from_array(domain: Domain, data: Array3<f32>) -> Self {
        let (nz, ny, nx) = domain.shape();
        Self::checked(domain, data, &[nz, ny, nx])
    }

    /// `cachewrite`: sample a field at every cell centre, in parallel batches
    /// of one z-slab.
    pub fn from_field(domain: Domain, field: &dyn ScalarField) -> Self {
        let mut grid = Self::zeros(domain);
        grid.write_field(field);
        grid
    }

    /// Overwrite the samples with `field` at every cell centre.
    pub fn write_field(&mut self, field: &dyn ScalarField) {
        let domain = self.domain;
        write_slabs(domain, self.as_slice_mut(), |p, out| {
            field.eval_batch(p, out)
        });
    }

    /// Trilinear sample at continuous grid coordinates (cell centres at integers).
    #[inline]
    pub fn sample_grid_coords(&self, g: Vec3) -> f32 {
        Stencil::new(g, self.domain.dims, self.wrap).apply(self.as_slice())
    }

    /// Integral over the box, `Σ ρ Δx³`, accumulated in f64.
    pub fn total(&self) -> f64 {
        let sum: f64 = self
            .as_slice()
            .par_chunks(4096)
            .map(|c| c.iter().map(|&v| v as f64).sum::<f64>())
            .sum();
        sum * self.domain.cell_volume() as f64
    }

    /// Largest absolute sample.
    pub fn max_abs(&self) -> f32 {
        self.as_slice()
            .par_iter()
            .map(|v| v.abs())
            .reduce(|| 0.0, f32::max)
    }

    /// Centre of mass `Σ ρ x / Σ ρ` (undefined for an empty grid: returns the box centre).
    pub fn center_of_mass(&self) -> Vec3 {
        let d = self.domain;
        let (mut m, mut c) = (0.0f64, [0.0f64; 3]);
        for ((k, j, i), &v) in self.data.indexed_iter() {
            let p = d.cell_center(i, j, k);
            m += v as f64;
            c[0] += v as f64 * p.x as f64;
            c[1] += v as f64 * p.y as f64;
            c[2] += v as f64 * p.z as f64;
        }
        if m == 0.0 {
            return d.origin + 0.5 * d.size();
        }
        Vec3::new((c[0] / m) as f32, (c[1] / m) as f32, (c[2] / m) as f32)
    }
}

impl ScalarField for ScalarGrid {
    fn eval(&self, p: Vec3) -> f32 {
        self.sample_grid_coords(self.domain.grid_coords(p))
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        let data = self.as_slice();
        for (o, &p) in out.iter_mut().zip(points) {
            *o = Stencil::new(self.domain.grid_coords(p), self.domain.dims, self.wrap).apply(data);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops;

    #[test]
    fn cachewrite_then_cacheread_reproduces_linear_fields() {
        let d = Domain::new(Vec3::ZERO, 0.5, [6, 5, 4]).unwrap();
        struct Linear;
        impl ScalarField for Linear {
            fn eval(&self, p: Vec3) -> f32 {
                1.0 + 2.0 * p.x - p.y + 0.5 * p.z
            }
        }
        let g = ScalarGrid::from_field(d, &Linear).with_wrap(Wrap::Clamped);
        // Inside the hull of the cell centres trilinear interpolation is exact for linear data.
        for p in [Vec3::new(0.4, 0.8, 0.3), Vec3::new(2.6, 2.2, 1.7)] {
            assert!((g.eval(p) - Linear.eval(p)).abs() < 1e-5);
        }
        assert_eq!(g.data()[[1, 2, 3]], Linear.eval(d.cell_center(3, 2, 1)));
    }

    #[test]
    fn total_of_constant_is_volume() {
        let d = Domain::cube(8, 2.0).unwrap();
        let g = ScalarGrid::from_field(d, &*ops::constant(3.0));
        assert!((g.total() - 24.0).abs() < 1e-9);
    }
}
