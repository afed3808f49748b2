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

    /// A box outside which every value is exactly `+0.0`, when the field
    /// knows one; callers may skip evaluating points outside it. `None`
    /// (the default): no bound is known.
    fn support(&self) -> Option<Bounds> {
        None
    }

    /// A box outside which every value is `≤ 0`, when the field knows one
    /// (an implicit surface's inside; [`ops::Mask`]'s support). The
    /// default is [`Self::support`].
    fn positive_bounds(&self) -> Option<Bounds> {
        self.support()
    }
}

/// Points per chunk of [`eval_supported`]: neighbouring cells' points,
/// which mostly lie together inside or outside a small source.
const SUPPORT_CHUNK: usize = 32;

/// [`ScalarField::eval_batch`] of `field` that skips the chunks of
/// [`SUPPORT_CHUNK`] points whose bounding box misses `support` (the
/// field's [`ScalarField::support`], found once by the caller): their
/// values are `+0.0`, which the field gives there, so every value is the
/// same as without skipping.
///
/// # Panics
/// If the slices differ in length.
pub fn eval_supported(
    field: &dyn ScalarField,
    support: Option<Bounds>,
    points: &[Vec3],
    out: &mut [f32],
) {
    let Some(bounds) = support else {
        return field.eval_batch(points, out);
    };
    assert_eq!(
        points.len(),
        out.len(),
        "eval_supported: slice lengths differ"
    );
    for (p, o) in points
        .chunks(SUPPORT_CHUNK)
        .zip(out.chunks_mut(SUPPORT_CHUNK))
    {
        if bounds.meets(p) {
            field.eval_batch(p, o);
        } else {
            o.fill(0.0);
        }
    }
}

/// A closed axis-aligned box `[min, max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    /// The lowest corner.
    pub min: Vec3,
    /// The highest corner.
    pub max: Vec3,
}

impl Bounds {
    /// The box of the ball `|p − center| ≤ radius`, widened by 10⁻⁵ of
    /// `|center| + radius`: more than the f32 rounding of a field's
    /// `|p − c|` or `|p − c|²`, so a point outside the box is outside the
    /// ball as the field computes it.
    pub fn ball(center: Vec3, radius: f32) -> Self {
        let r = radius + 1e-5 * (center.abs().max_element() + radius);
        Self {
            min: center - Vec3::splat(r),
            max: center + Vec3::splat(r),
        }
    }

    /// The bounding box of `points`, `None` if there are none.
    pub fn of(points: &[Vec3]) -> Option<Self> {
        let &first = points.first()?;
        let (min, max) = points
            .iter()
            .fold((first, first), |(lo, hi), &p| (lo.min(p), hi.max(p)));
        Some(Self { min, max })
    }

    /// Whether the two boxes share a point.
    pub fn overlaps(&self, other: &Self) -> bool {
        other.min.cmple(self.max).all() && other.max.cmpge(self.min).all()
    }

    /// Whether the box meets the bounding box of `points` (false if empty).
    pub fn meets(&self, points: &[Vec3]) -> bool {
        Self::of(points).is_some_and(|b| self.overlaps(&b))
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
    fn support(&self) -> Option<Bounds> {
        (**self).support()
    }
    fn positive_bounds(&self) -> Option<Bounds> {
        (**self).positive_bounds()
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
