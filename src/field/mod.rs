//! Fields: anything that can be asked for its value at a world point.
//!
//! This is the notes' resolution independence (§1.2, ch. 2): a field may be
//! procedural (a sphere's implicit function, a noise), a grid read through
//! interpolation (`cacheread`), or an expression built from other fields with
//! the combinators in [`ops`] — `advect(field, velocity, dt)` among them. The
//! renderer and the density models only ever *query* fields.
//!
//! Hot paths evaluate in **batches**: [`ScalarField::eval_batch`] takes a
//! slice of points and fills a slice of values, so a chain of fields pays one
//! dynamic call per batch, not per point. Fields are `Send + Sync` and shared
//! through [`Arc`], so building a chain never copies a grid.

pub mod algebra;
pub mod memo;
pub mod ops;

use std::sync::Arc;

use glam::Vec3;

/// A scalar function of position.
pub trait ScalarField: Send + Sync {
    /// The value at world point `p`.
    fn eval(&self, p: Vec3) -> f32;

    /// Values at many points: `out[i] = eval(points[i])`.
    ///
    /// The default is compiled for each implementation, calling its `eval`
    /// statically (inlined where `eval` is small), so an implementation
    /// overrides it only to do better than one point at a time.
    ///
    /// # Panics
    /// If the slices differ in length.
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        for (o, &p) in out.iter_mut().zip(points) {
            *o = self.eval(p);
        }
    }

    /// Gradients at many points, when the field knows its own in closed form.
    ///
    /// Returns `false` — before doing any work, and leaving `out`
    /// unspecified — when it does not; [`algebra::grad`] then takes central
    /// differences.
    ///
    /// # Panics
    /// If the slices differ in length (implementations that return `true`).
    fn grad_batch(&self, _points: &[Vec3], _out: &mut [Vec3]) -> bool {
        false
    }
}

/// A vector function of position.
pub trait VectorField: Send + Sync {
    /// The value at world point `p`.
    fn eval(&self, p: Vec3) -> Vec3;

    /// Values at many points: `out[i] = eval(points[i])`.
    ///
    /// # Panics
    /// If the slices differ in length.
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        for (o, &p) in out.iter_mut().zip(points) {
            *o = self.eval(p);
        }
    }
}

/// A shared scalar field.
pub type Scalar = Arc<dyn ScalarField>;
/// A shared vector field.
pub type Vector = Arc<dyn VectorField>;

impl<F: ScalarField + ?Sized> ScalarField for Arc<F> {
    fn eval(&self, p: Vec3) -> f32 {
        (**self).eval(p)
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        (**self).eval_batch(points, out)
    }
    fn grad_batch(&self, points: &[Vec3], out: &mut [Vec3]) -> bool {
        (**self).grad_batch(points, out)
    }
}

impl<F: VectorField + ?Sized> VectorField for Arc<F> {
    fn eval(&self, p: Vec3) -> Vec3 {
        (**self).eval(p)
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        (**self).eval_batch(points, out)
    }
}
