//! What every grid shares: samples of f32 on the cell centres of a
//! [`Domain`], `[z][y][x]` in standard layout, and an out-of-range rule.
//!
//! Serialized (serde) as the tuple `(domain, wrap, samples)`, the samples
//! a flat sequence of f32 in that order; reading checks their count
//! against the domain.

use glam::Vec3;
use ndarray::{Array, Dimension};
use rayon::prelude::*;
use serde::de::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};

use super::Wrap;
use crate::domain::Domain;

/// Samples on the cell centres of a [`Domain`]: an array of shape
/// `(nz, ny, nx)` (a [`ScalarGrid`](super::ScalarGrid)) or `(nz, ny, nx, 3)`
/// (a [`VectorGrid`](super::VectorGrid)), always in standard layout.
#[derive(Clone, Debug)]
pub struct Grid<D: Dimension> {
    pub(super) domain: Domain,
    pub(super) wrap: Wrap,
    pub(super) data: Array<f32, D>,
}

impl<D: Dimension> Grid<D> {
    /// Wrap `data`, periodic, after checking its shape is `shape`.
    ///
    /// # Panics
    /// If it is not.
    pub(super) fn checked(domain: Domain, data: Array<f32, D>, shape: &[usize]) -> Self {
        assert_eq!(data.shape(), shape, "array shape is not the domain's");
        Self {
            domain,
            wrap: Wrap::Periodic,
            data: data.as_standard_layout().into_owned(),
        }
    }

    /// Change the out-of-range rule in place.
    pub fn set_wrap(&mut self, wrap: Wrap) {
        self.wrap = wrap;
    }

    /// The same grid with a different out-of-range rule.
    pub fn with_wrap(mut self, wrap: Wrap) -> Self {
        self.wrap = wrap;
        self
    }

    /// The domain the samples live on.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// Out-of-range rule used by interpolation.
    pub fn wrap(&self) -> Wrap {
        self.wrap
    }

    /// The samples.
    pub fn data(&self) -> &Array<f32, D> {
        &self.data
    }

    /// The samples, mutable.
    pub fn data_mut(&mut self) -> &mut Array<f32, D> {
        &mut self.data
    }

    /// Take the samples.
    pub fn into_array(self) -> Array<f32, D> {
        self.data
    }

    /// Samples as a flat slice, `[z][y][x]` order (components interleaved).
    pub fn as_slice(&self) -> &[f32] {
        self.data.as_slice().expect("grids are in standard layout")
    }

    /// Samples as a flat mutable slice.
    pub fn as_slice_mut(&mut self) -> &mut [f32] {
        self.data
            .as_slice_mut()
            .expect("grids are in standard layout")
    }

    /// Whether every sample is finite.
    pub fn is_finite(&self) -> bool {
        self.as_slice().par_iter().all(|v| v.is_finite())
    }
}

impl<D: Dimension> Serialize for Grid<D> {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        (&self.domain, self.wrap, self.as_slice()).serialize(s)
    }
}

impl<'de, D: Dimension> Deserialize<'de> for Grid<D> {
    /// # Errors
    /// If the samples are not one per cell (three for a vector grid).
    fn deserialize<De: Deserializer<'de>>(de: De) -> Result<Self, De::Error> {
        let (domain, wrap, samples): (Domain, Wrap, Vec<f32>) = Deserialize::deserialize(de)?;
        // The cell shape `(nz, ny, nx)`, and a vector grid's axis of 3.
        let (nz, ny, nx) = domain.shape();
        let mut shape = D::zeros(D::NDIM.unwrap_or(3));
        let ndim = shape.ndim();
        shape.slice_mut().copy_from_slice(&[nz, ny, nx, 3][..ndim]);
        let count = samples.len();
        let data = Array::from_shape_vec(shape, samples).map_err(|_| {
            De::Error::custom(format!(
                "a grid of {count} samples on a domain of {:?} cells",
                domain.dims
            ))
        })?;
        Ok(Self { domain, wrap, data })
    }
}

/// `cachewrite` into `out` (one value per cell, `[z][y][x]`): `eval` fills
/// each z-slab from the slab's cell centres, in parallel.
pub(super) fn write_slabs<T: Send>(
    domain: Domain,
    out: &mut [T],
    eval: impl Fn(&[Vec3], &mut [T]) + Sync,
) {
    let slab = domain.dims[0] * domain.dims[1];
    out.par_chunks_mut(slab)
        .enumerate()
        .for_each_init(Vec::new, |points, (k, out)| {
            domain.slab_centers(k, points);
            eval(points, out);
        });
}
