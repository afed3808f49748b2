//! Field combinators used by the notes' FELT scripts (ch. 2, §6.1.1).
//!
//! Each combinator is a small struct holding shared handles to its inputs and
//! implementing [`ScalarField`] or [`VectorField`], with a batch evaluation
//! that forwards whole slices. The free functions build them:
//!
//! ```
//! use glam::Vec3;
//! use smokelab::field::{ops, ScalarField};
//! // The notes' inject(): mask(1 − |x − c|²) · dt, a solid unit sphere.
//! let inject = ops::scale(ops::mask(ops::sphere(Vec3::splat(2.0), 1.0)), 0.1);
//! assert_eq!(inject.eval(Vec3::splat(2.0)), 0.1);
//! assert_eq!(inject.eval(Vec3::ZERO), 0.0);
//! ```

use std::sync::Arc;

use glam::Vec3;

use super::{Bounds, Scalar, ScalarField, Vector, VectorField};

/// A constant scalar.
pub struct Constant(pub f32);

impl ScalarField for Constant {
    fn eval(&self, _: Vec3) -> f32 {
        self.0
    }
    fn eval_batch(&self, _: &[Vec3], out: &mut [f32]) {
        out.fill(self.0);
    }
    fn grad_batch(&self, _: &[Vec3], out: &mut [Vec3]) -> bool {
        out.fill(Vec3::ZERO);
        true
    }
}

/// A constant vector.
pub struct ConstantVector(pub Vec3);

impl VectorField for ConstantVector {
    fn eval(&self, _: Vec3) -> Vec3 {
        self.0
    }
    fn eval_batch(&self, _: &[Vec3], out: &mut [Vec3]) {
        out.fill(self.0);
    }
}

/// The identity map `x ↦ x`, the notes' `identity()`.
pub struct Identity;

impl VectorField for Identity {
    fn eval(&self, p: Vec3) -> Vec3 {
        p
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        out.copy_from_slice(points);
    }
}

/// Implicit sphere `r² − |x − c|²`: positive inside, zero on the surface.
///
/// With `r = 1` this is the notes' `scalarfield(1.0) − spherecenter*spherecenter`.
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
}

impl ScalarField for Sphere {
    fn eval(&self, p: Vec3) -> f32 {
        self.radius * self.radius - (p - self.center).length_squared()
    }
    fn positive_bounds(&self) -> Option<Bounds> {
        Some(Bounds::ball(self.center, self.radius))
    }
    fn grad_batch(&self, points: &[Vec3], out: &mut [Vec3]) -> bool {
        assert_eq!(points.len(), out.len(), "grad_batch: slice lengths differ");
        for (o, &p) in out.iter_mut().zip(points) {
            *o = -2.0 * (p - self.center);
        }
        true
    }
}

/// `mask(f)`: 1 where `f > 0`, 0 elsewhere (the notes' `mask()`).
pub struct Mask(pub Scalar);

impl ScalarField for Mask {
    fn eval(&self, p: Vec3) -> f32 {
        if self.0.eval(p) > 0.0 {
            1.0
        } else {
            0.0
        }
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        self.0.eval_batch(points, out);
        for v in out.iter_mut() {
            *v = if *v > 0.0 { 1.0 } else { 0.0 };
        }
    }
    fn support(&self) -> Option<Bounds> {
        self.0.positive_bounds()
    }
}

/// A ball with a smooth edge: 1 inside `radius − edge/2`, 0 outside
/// `radius + edge/2`, a smoothstep between (so about the volume of the solid
/// ball of `radius`). A continuous alternative to `mask(sphere)`.
pub struct SmoothBall {
    /// Centre.
    pub center: Vec3,
    /// Radius of the middle of the edge.
    pub radius: f32,
    /// Width of the edge (> 0).
    pub edge: f32,
}

impl ScalarField for SmoothBall {
    fn eval(&self, p: Vec3) -> f32 {
        let t = ((self.radius + 0.5 * self.edge - (p - self.center).length()) / self.edge)
            .clamp(0.0, 1.0);
        t * t * (3.0 - 2.0 * t)
    }
    fn support(&self) -> Option<Bounds> {
        Some(Bounds::ball(self.center, self.radius + 0.5 * self.edge))
    }
}

/// `a + b`.
pub struct Sum(pub Scalar, pub Scalar);

impl ScalarField for Sum {
    fn eval(&self, p: Vec3) -> f32 {
        self.0.eval(p) + self.1.eval(p)
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        self.0.eval_batch(points, out);
        let mut tmp = vec![0.0; points.len()];
        self.1.eval_batch(points, &mut tmp);
        for (o, t) in out.iter_mut().zip(tmp) {
            *o += t;
        }
    }
}

/// `s · f` for a constant `s`.
pub struct Scale(pub Scalar, pub f32);

impl ScalarField for Scale {
    fn eval(&self, p: Vec3) -> f32 {
        self.1 * self.0.eval(p)
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        self.0.eval_batch(points, out);
        for o in out.iter_mut() {
            *o *= self.1;
        }
    }
    fn support(&self) -> Option<Bounds> {
        // `s · (+0.0)` is `+0.0` only for `s ≥ 0`.
        (self.1 >= 0.0).then(|| self.0.support()).flatten()
    }
}

/// `a + b` for vector fields.
pub struct VectorSum(pub Vector, pub Vector);

impl VectorField for VectorSum {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.0.eval(p) + self.1.eval(p)
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.0.eval_batch(points, out);
        let mut tmp = vec![Vec3::ZERO; points.len()];
        self.1.eval_batch(points, &mut tmp);
        for (o, t) in out.iter_mut().zip(tmp) {
            *o += t;
        }
    }
}

/// `s · v` for a constant `s`.
pub struct VectorScale(pub Vector, pub f32);

impl VectorField for VectorScale {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.1 * self.0.eval(p)
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.0.eval_batch(points, out);
        for o in out.iter_mut() {
            *o *= self.1;
        }
    }
}

/// `f ∘ X`: the scalar field evaluated at the image of a map, `f(X(x))`.
pub struct Compose(pub Scalar, pub Vector);

impl ScalarField for Compose {
    fn eval(&self, p: Vec3) -> f32 {
        self.0.eval(self.1.eval(p))
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        let mut mapped = vec![Vec3::ZERO; points.len()];
        self.1.eval_batch(points, &mut mapped);
        self.0.eval_batch(&mapped, out);
    }
}

/// `v ∘ X` for a vector field.
pub struct ComposeVector(pub Vector, pub Vector);

impl VectorField for ComposeVector {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.0.eval(self.1.eval(p))
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        let mut mapped = vec![Vec3::ZERO; points.len()];
        self.1.eval_batch(points, &mut mapped);
        self.0.eval_batch(&mapped, out);
    }
}

/// The semi-Lagrangian backtrace map `x ↦ x − u(x) Δt` (eq 6.4's argument).
pub struct Backtrace {
    /// Velocity u.
    pub velocity: Vector,
    /// Time step Δt.
    pub dt: f32,
}

impl VectorField for Backtrace {
    fn eval(&self, p: Vec3) -> Vec3 {
        p - self.dt * self.velocity.eval(p)
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.velocity.eval_batch(points, out);
        for (o, &p) in out.iter_mut().zip(points) {
            *o = p - self.dt * *o;
        }
    }
}

/// Central-difference gradient of a scalar field with step `h`.
pub struct Gradient {
    /// The differentiated field.
    pub field: Scalar,
    /// Finite-difference step.
    pub h: f32,
}

impl VectorField for Gradient {
    fn eval(&self, p: Vec3) -> Vec3 {
        let d = |e: Vec3| self.field.eval(p + e * self.h) - self.field.eval(p - e * self.h);
        Vec3::new(d(Vec3::X), d(Vec3::Y), d(Vec3::Z)) / (2.0 * self.h)
    }
}

/// A constant scalar field.
pub fn constant(value: f32) -> Scalar {
    Arc::new(Constant(value))
}

/// A constant vector field.
pub fn constant_vector(value: Vec3) -> Vector {
    Arc::new(ConstantVector(value))
}

/// The identity map.
pub fn identity() -> Vector {
    Arc::new(Identity)
}

/// Implicit sphere `r² − |x − c|²`.
pub fn sphere(center: Vec3, radius: f32) -> Scalar {
    Arc::new(Sphere { center, radius })
}

/// `mask(f)`: 1 inside (`f > 0`), 0 outside.
pub fn mask(f: Scalar) -> Scalar {
    Arc::new(Mask(f))
}

/// A ball of `radius` with a smoothstep edge of width `edge` (> 0).
pub fn smooth_ball(center: Vec3, radius: f32, edge: f32) -> Scalar {
    Arc::new(SmoothBall {
        center,
        radius,
        edge,
    })
}

/// `a + b`.
pub fn sum(a: Scalar, b: Scalar) -> Scalar {
    Arc::new(Sum(a, b))
}

/// `s · f`.
pub fn scale(f: Scalar, s: f32) -> Scalar {
    Arc::new(Scale(f, s))
}

/// `a + b` for vectors.
pub fn vector_sum(a: Vector, b: Vector) -> Vector {
    Arc::new(VectorSum(a, b))
}

/// `s · v`.
pub fn vector_scale(v: Vector, s: f32) -> Vector {
    Arc::new(VectorScale(v, s))
}

/// `f ∘ X`.
pub fn compose(f: Scalar, map: Vector) -> Scalar {
    Arc::new(Compose(f, map))
}

/// `v ∘ X`.
pub fn compose_vector(v: Vector, map: Vector) -> Vector {
    Arc::new(ComposeVector(v, map))
}

/// The notes' `advect(f, u, Δt)`: `f(x − u(x) Δt)` (eq 6.4 without the source).
pub fn advect(f: Scalar, velocity: Vector, dt: f32) -> Scalar {
    compose(f, Arc::new(Backtrace { velocity, dt }))
}

/// `advect` for a vector field: `v(x − u(x) Δt)` (eq 6.5 without the force).
pub fn advect_vector(v: Vector, velocity: Vector, dt: f32) -> Vector {
    compose_vector(v, Arc::new(Backtrace { velocity, dt }))
}

/// Central-difference gradient with step `h`.
pub fn grad(f: Scalar, h: f32) -> Vector {
    Arc::new(Gradient { field: f, h })
}

/// The notes' `inject(center, dt)`: a solid sphere of density, `mask(r² − |x−c|²) · Δt`.
pub fn inject(center: Vec3, radius: f32, dt: f32) -> Scalar {
    scale(mask(sphere(center, radius)), dt)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::eval_supported;
    use approx::assert_relative_eq;

    #[test]
    fn advect_translates_by_uniform_velocity() {
        let f = sphere(Vec3::ZERO, 1.0);
        let moved = advect(f.clone(), constant_vector(Vec3::new(1.0, 0.0, 0.0)), 0.5);
        // After advecting, the sphere's centre is at x = 0.5.
        assert_relative_eq!(moved.eval(Vec3::new(0.5, 0.0, 0.0)), 1.0);
        let pts = [Vec3::new(0.5, 0.0, 0.0), Vec3::new(1.5, 0.0, 0.0)];
        let mut out = [0.0; 2];
        moved.eval_batch(&pts, &mut out);
        assert_eq!(out, [moved.eval(pts[0]), moved.eval(pts[1])]);
    }

    #[test]
    fn batch_matches_pointwise_for_every_combinator() {
        let a = sphere(Vec3::new(0.1, 0.2, 0.3), 0.7);
        let b = scale(mask(a.clone()), 2.0);
        let c = sum(a.clone(), b.clone());
        let v = vector_sum(identity(), constant_vector(Vec3::ONE));
        let d = compose(c.clone(), vector_scale(v, 0.5));
        let pts: Vec<Vec3> = (0..50)
            .map(|i| Vec3::new(i as f32 * 0.03, -0.2 + i as f32 * 0.01, 0.4))
            .collect();
        for f in [a, b, c, d] {
            let mut out = vec![0.0; pts.len()];
            f.eval_batch(&pts, &mut out);
            for (p, o) in pts.iter().zip(&out) {
                assert_eq!(*o, f.eval(*p));
            }
        }
    }

    /// Outside its support a field is `+0.0` to the bit, also one ulp
    /// past the box's faces and corners and around a far-off centre (where
    /// `|p − c|` rounds most); a negative scale has no support (it gives
    /// `−0.0`); and [`eval_supported`] gives `eval_batch`'s bits while it
    /// skips the chunks outside.
    #[test]
    fn support_is_exact_where_it_skips() {
        let c = Vec3::new(37.3, -12.9, 50.1);
        let fields = [
            mask(sphere(c, 1.7)),
            smooth_ball(c, 1.7, 0.3),
            scale(mask(sphere(c, 1.7)), 2.0),
        ];
        for f in &fields {
            let b = f.support().expect("a bounded source");
            let mut outside = vec![];
            for corner in 0..27 {
                // Each axis below, inside or above the box, the outside
                // ones one ulp past its faces; all but the centre outside.
                let pick = |a: usize, min: f32, max: f32, mid: f32| match corner
                    / 3usize.pow(a as u32)
                    % 3
                {
                    0 => min.next_down(),
                    1 => mid,
                    _ => max.next_up(),
                };
                if corner == 13 {
                    continue;
                }
                outside.push(Vec3::new(
                    pick(0, b.min.x, b.max.x, c.x),
                    pick(1, b.min.y, b.max.y, c.y),
                    pick(2, b.min.z, b.max.z, c.z),
                ));
            }
            for p in &outside {
                assert_eq!(f.eval(*p).to_bits(), 0.0f32.to_bits(), "{p}");
            }
            let pts: Vec<Vec3> = (0..4000)
                .map(|i| {
                    c + Vec3::new((i % 20) as f32, (i / 20 % 20) as f32, (i / 400) as f32) * 0.25
                        - 2.4
                })
                .collect();
            let (mut all, mut skipped) = (vec![0.0; pts.len()], vec![1.0; pts.len()]);
            f.eval_batch(&pts, &mut all);
            eval_supported(&**f, Some(b), &pts, &mut skipped);
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&all), bits(&skipped));
            assert!(all.iter().any(|&v| v > 0.0) && !b.meets(&pts[..20]));
        }
        assert!(scale(mask(sphere(c, 1.7)), -1.0).support().is_none());
        assert!(sphere(c, 1.7).support().is_none());
    }

    #[test]
    fn smooth_ball_spans_its_edge() {
        let b = smooth_ball(Vec3::ZERO, 1.0, 0.4);
        assert_eq!(b.eval(Vec3::new(0.79, 0.0, 0.0)), 1.0);
        assert_eq!(b.eval(Vec3::new(0.0, 1.21, 0.0)), 0.0);
        assert_relative_eq!(b.eval(Vec3::new(0.0, 0.0, 1.0)), 0.5, epsilon = 1e-6);
    }

    #[test]
    fn gradient_of_sphere_is_minus_two_r() {
        let g = grad(sphere(Vec3::ZERO, 1.0), 1e-2);
        let p = Vec3::new(0.3, -0.2, 0.5);
        assert!((g.eval(p) - (-2.0 * p)).length() < 1e-3);
    }
}
