//! Grids — the notes' *caches* (§1.2, ch. 2): samples on the cell centres of a
//! [`Domain`](crate::domain::Domain), stored `[z][y][x]` in f32.
//!
//! A grid is itself a field through trilinear interpolation (`cacheread`), and
//! any field can be sampled onto a grid in parallel (`cachewrite`, see
//! [`ScalarGrid::from_field`] and [`VectorGrid::from_field`]).

pub mod face;
pub mod interpolant;
mod interpolate;
pub mod open_faces;
mod samples;
mod scalar;
mod vector;

pub use face::{BoxKind, FaceGrid};
pub use interpolant::Interpolant;
pub use interpolate::{Stencil, Wrap};
pub use open_faces::OpenFaces;
pub use samples::Grid;
pub use scalar::ScalarGrid;
pub use vector::VectorGrid;
