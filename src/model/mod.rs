//! Modelling with fields (the notes' ch. 3–5): analytic shapes, triangle
//! meshes in and out of level sets, clouds by layered pyroclastic
//! displacement, the nacelle warp, and cutting with level-set knives. Everything here is built from the field algebra
//! ([`crate::field::algebra`]) and so is resolution independent: a lattice
//! appears only where a cache or a piece count asks for one.

pub mod cloud;
pub mod cut;
pub mod mesh;
pub mod shape;
pub mod warp;

use std::sync::Arc;

use crate::domain::Domain;
use crate::field::{Scalar, ScalarField, Vector, VectorField};
use crate::grid::{ScalarGrid, VectorGrid, Wrap};

/// The notes' `cacheread(cachewrite(scalarcache(domain), f))`: `f` sampled at
/// the cell centres of `domain` (any box, any resolution) and read back by
/// trilinear interpolation, clamped outside the box.
pub fn cache(f: &dyn ScalarField, domain: Domain) -> Scalar {
    Arc::new(ScalarGrid::from_field(domain, f).with_wrap(Wrap::Clamped))
}

/// [`cache`] for a vector field.
pub fn cache_vector(v: &dyn VectorField, domain: Domain) -> Vector {
    Arc::new(VectorGrid::from_field(domain, v).with_wrap(Wrap::Clamped))
}
