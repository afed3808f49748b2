//! The field algebra of the notes' modelling scripts (ch. 3–5): pointwise
//! arithmetic, vector and matrix fields, gradients, Hessians, composition,
//! and the level-set surface map (eq 3.3). Caches at any domain are
//! [`crate::model::cache`].
//!
//! Every combinator evaluates in batches: it asks each input for a whole
//! slice and combines the slices, so a long expression such as the nacelle
//! step (eqs 4.7–4.10) pays a few dynamic calls per batch, not per point.
//!
//! **Gradients.** [`grad`] uses a field's closed-form gradient when it has one
//! ([`ScalarField::grad_batch`]): constants, the implicit sphere, Perlin noise, the shapes of `model::shape`, and
//! every pointwise combinator here whose inputs have one (by the chain,
//! product and quotient rules). Otherwise it takes second-order central
//! differences with the caller's step `h`,
//! `∂f/∂x_a ≈ (f(x + h e_a) − f(x − h e_a)) / 2h` (error `O(h²)`); for a
//! cached field a step of one cell is the natural choice. Matrix fields
//! ([`jacobian`], [`hessian`]) always difference their vector field with the
//! same stencil, so `hessian(ℓ, h) = jacobian(grad(ℓ, h), h)` is the notes'
//! `grad(grad(ℓ))`, exact up to `O(h²)` when `grad ℓ` is analytic.
//!
//! ```
//! use std::sync::Arc;
//! use glam::Vec3;
//! use smokelab::field::{algebra as fa, Scalar, ScalarField};
//! // The unit sphere's signed distance, its gradient left to differences.
//! struct Ball;
//! impl ScalarField for Ball {
//!     fn eval(&self, p: Vec3) -> f32 {
//!         1.0 - p.length()
//!     }
//! }
//! let ball: Scalar = Arc::new(Ball);
//! // Eq 3.3 lands on the surface.
//! let surface = fa::levelset_surface(ball.clone(), 1e-3, 3);
//! let on = fa::compose(ball, surface);
//! assert!(on.eval(Vec3::new(0.2, 0.3, -0.4)).abs() < 1e-5);
//! ```

use std::sync::Arc;

use glam::{Mat3, Vec3};

use super::{ops, Scalar, ScalarField, Vector, VectorField};

/// A 3 × 3 matrix function of position (the notes' `matrixfield`).
pub trait MatrixField: Send + Sync {
    /// The value at world point `p`.
    fn eval(&self, p: Vec3) -> Mat3;

    /// Values at many points: `out[i] = eval(points[i])`.
    ///
    /// # Panics
    /// If the slices differ in length.
    fn eval_batch(&self, points: &[Vec3], out: &mut [Mat3]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        for (o, &p) in out.iter_mut().zip(points) {
            *o = self.eval(p);
        }
    }
}

/// A shared matrix field.
pub type Matrix = Arc<dyn MatrixField>;

/// A pointwise function of one scalar field.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Unary {
    /// `−f`.
    Neg,
    /// `|f|`.
    Abs,
    /// `√f` (NaN where `f < 0`).
    Sqrt,
    /// `clamp(f, lo, hi)`.
    Clamp(f32, f32),
    /// `f^e` for a constant `e` (NaN where `f < 0` and `e` is not whole).
    Pow(f32),
    /// `sin f`.
    Sin,
    /// `cos f`.
    Cos,
    /// `exp f`.
    Exp,
    /// `tanh f`.
    Tanh,
}

impl Unary {
    #[inline]
    fn apply(self, v: f32) -> f32 {
        match self {
            Unary::Neg => -v,
            Unary::Abs => v.abs(),
            Unary::Sqrt => v.sqrt(),
            Unary::Clamp(lo, hi) => v.clamp(lo, hi),
            Unary::Pow(e) => v.powf(e),
            Unary::Sin => v.sin(),
            Unary::Cos => v.cos(),
            Unary::Exp => v.exp(),
            Unary::Tanh => v.tanh(),
        }
    }

    /// `d op / dv` at `v` (one-sided conventions at kinks: `|·|′(0) = 0`,
    /// `clamp′ = 0` on the bounds).
    #[inline]
    fn derivative(self, v: f32) -> f32 {
        match self {
            Unary::Neg => -1.0,
            Unary::Abs => {
                if v > 0.0 {
                    1.0
                } else if v < 0.0 {
                    -1.0
                } else {
                    0.0
                }
            }
            Unary::Sqrt => 0.5 / v.sqrt(),
            Unary::Clamp(lo, hi) => {
                if v > lo && v < hi {
                    1.0
                } else {
                    0.0
                }
            }
            Unary::Pow(e) => e * v.powf(e - 1.0),
            Unary::Sin => v.cos(),
            Unary::Cos => -v.sin(),
            Unary::Exp => v.exp(),
            Unary::Tanh => {
                let t = v.tanh();
                1.0 - t * t
            }
        }
    }
}

/// `op(f)`.
pub struct Map(pub Scalar, pub Unary);

impl ScalarField for Map {
    fn eval(&self, p: Vec3) -> f32 {
        self.1.apply(self.0.eval(p))
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        self.0.eval_batch(points, out);
        for o in out.iter_mut() {
            *o = self.1.apply(*o);
        }
    }
    fn grad_batch(&self, points: &[Vec3], out: &mut [Vec3]) -> bool {
        if !self.0.grad_batch(points, out) {
            return false;
        }
        let mut v = vec![0.0; points.len()];
        self.0.eval_batch(points, &mut v);
        for (o, v) in out.iter_mut().zip(v) {
            *o *= self.1.derivative(v);
        }
        true
    }
}

/// A pointwise function of two scalar fields.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Binary {
    /// `a + b`.
    Add,
    /// `a − b`.
    Sub,
    /// `a · b`.
    Mul,
    /// `a / b`.
    Div,
    /// `min(a, b)` (a union of level sets that are negative inside, an
    /// intersection of ones positive inside).
    Min,
    /// `max(a, b)`.
    Max,
    /// `a^b` (NaN where `a < 0`).
    Pow,
}

impl Binary {
    #[inline]
    fn apply(self, a: f32, b: f32) -> f32 {
        match self {
            Binary::Add => a + b,
            Binary::Sub => a - b,
            Binary::Mul => a * b,
            Binary::Div => a / b,
            Binary::Min => a.min(b),
            Binary::Max => a.max(b),
            Binary::Pow => a.powf(b),
        }
    }

    /// `∇(a op b)` from the values and gradients of `a` and `b`.
    #[inline]
    fn gradient(self, a: f32, b: f32, ga: Vec3, gb: Vec3) -> Vec3 {
        match self {
            Binary::Add => ga + gb,
            Binary::Sub => ga - gb,
            Binary::Mul => b * ga + a * gb,
            Binary::Div => (b * ga - a * gb) / (b * b),
            Binary::Min => {
                if a <= b {
                    ga
                } else {
                    gb
                }
            }
            Binary::Max => {
                if a >= b {
                    ga
                } else {
                    gb
                }
            }
            Binary::Pow => {
                let ab = a.powf(b);
                // The ln a term vanishes when b is constant (gb = 0), also at a = 0.
                let log_term = if gb == Vec3::ZERO {
                    Vec3::ZERO
                } else {
                    ab * a.ln() * gb
                };
                b * a.powf(b - 1.0) * ga + log_term
            }
        }
    }
}

/// `a op b`.
pub struct Zip(pub Scalar, pub Scalar, pub Binary);

impl ScalarField for Zip {
    fn eval(&self, p: Vec3) -> f32 {
        self.2.apply(self.0.eval(p), self.1.eval(p))
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        self.0.eval_batch(points, out);
        let mut b = vec![0.0; points.len()];
        self.1.eval_batch(points, &mut b);
        for (o, b) in out.iter_mut().zip(b) {
            *o = self.2.apply(*o, b);
        }
    }
    fn grad_batch(&self, points: &[Vec3], out: &mut [Vec3]) -> bool {
        let mut gb = vec![Vec3::ZERO; points.len()];
        if !self.1.grad_batch(points, &mut gb) || !self.0.grad_batch(points, out) {
            return false;
        }
        let mut a = vec![0.0; points.len()];
        let mut b = vec![0.0; points.len()];
        self.0.eval_batch(points, &mut a);
        self.1.eval_batch(points, &mut b);
        for (i, o) in out.iter_mut().enumerate() {
            *o = self.2.gradient(a[i], b[i], *o, gb[i]);
        }
        true
    }
}

/// `s · v`: a scalar field times a vector field.
pub struct ScalarTimesVector(pub Scalar, pub Vector);

impl VectorField for ScalarTimesVector {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.0.eval(p) * self.1.eval(p)
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.1.eval_batch(points, out);
        let mut s = vec![0.0; points.len()];
        self.0.eval_batch(points, &mut s);
        for (o, s) in out.iter_mut().zip(s) {
            *o *= s;
        }
    }
}

/// `a − b` for vector fields.
pub struct VectorDifference(pub Vector, pub Vector);

impl VectorField for VectorDifference {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.0.eval(p) - self.1.eval(p)
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.0.eval_batch(points, out);
        let mut b = vec![Vec3::ZERO; points.len()];
        self.1.eval_batch(points, &mut b);
        for (o, b) in out.iter_mut().zip(b) {
            *o -= b;
        }
    }
}

/// `a · b`: the dot product of two vector fields.
pub struct Dot(pub Vector, pub Vector);

impl ScalarField for Dot {
    fn eval(&self, p: Vec3) -> f32 {
        self.0.eval(p).dot(self.1.eval(p))
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        let mut a = vec![Vec3::ZERO; points.len()];
        let mut b = vec![Vec3::ZERO; points.len()];
        self.0.eval_batch(points, &mut a);
        self.1.eval_batch(points, &mut b);
        for ((o, a), b) in out.iter_mut().zip(a).zip(b) {
            *o = a.dot(b);
        }
    }
}

/// Component `a` (0, 1, 2: x, y, z) of a vector field.
pub struct Component(pub Vector, pub usize);

impl ScalarField for Component {
    fn eval(&self, p: Vec3) -> f32 {
        self.0.eval(p)[self.1]
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        let mut v = vec![Vec3::ZERO; points.len()];
        self.0.eval_batch(points, &mut v);
        for (o, v) in out.iter_mut().zip(v) {
            *o = v[self.1];
        }
    }
}

/// `v / |v|`, zero where `v` is zero.
pub struct Normalize(pub Vector);

impl VectorField for Normalize {
    fn eval(&self, p: Vec3) -> Vec3 {
        self.0.eval(p).normalize_or_zero()
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        self.0.eval_batch(points, out);
        for o in out.iter_mut() {
            *o = o.normalize_or_zero();
        }
    }
}

/// `a · M · b`: a bilinear form of two vector fields through a matrix field
/// (eq 4.9's `B·M·B`).
pub struct Bilinear(pub Vector, pub Matrix, pub Vector);

impl ScalarField for Bilinear {
    fn eval(&self, p: Vec3) -> f32 {
        self.0.eval(p).dot(self.1.eval(p) * self.2.eval(p))
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        let n = points.len();
        let (mut a, mut b, mut m) = (
            vec![Vec3::ZERO; n],
            vec![Vec3::ZERO; n],
            vec![Mat3::ZERO; n],
        );
        self.0.eval_batch(points, &mut a);
        self.1.eval_batch(points, &mut m);
        self.2.eval_batch(points, &mut b);
        for (i, o) in out.iter_mut().enumerate() {
            *o = a[i].dot(m[i] * b[i]);
        }
    }
}

/// The gradient of a scalar field: closed form when the field has one,
/// central differences with step `h` otherwise (module docs).
pub struct Gradient {
    /// The differentiated field.
    pub field: Scalar,
    /// Central-difference step.
    pub h: f32,
}

/// Central differences of a field of `T` at every point: `eval` fills values
/// at the six points `p ± h e_a`, and `build` turns the three differences
/// `(f(p + h e_a) − f(p − h e_a)) / 2h` into `out[i]`.
fn differences<T, O>(
    points: &[Vec3],
    h: f32,
    zero: T,
    out: &mut [O],
    eval: impl FnOnce(&[Vec3], &mut [T]),
    build: impl Fn([T; 3]) -> O,
) where
    T: Copy + std::ops::Sub<Output = T> + std::ops::Mul<f32, Output = T>,
{
    assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
    let axes = [Vec3::X * h, Vec3::Y * h, Vec3::Z * h];
    let around: Vec<Vec3> = points
        .iter()
        .flat_map(|&p| axes.iter().flat_map(move |&e| [p + e, p - e]))
        .collect();
    let mut v = vec![zero; around.len()];
    eval(&around, &mut v);
    let inv = 0.5 / h;
    for (o, v) in out.iter_mut().zip(v.chunks_exact(6)) {
        *o = build([
            (v[0] - v[1]) * inv,
            (v[2] - v[3]) * inv,
            (v[4] - v[5]) * inv,
        ]);
    }
}

impl VectorField for Gradient {
    fn eval(&self, p: Vec3) -> Vec3 {
        let mut out = [Vec3::ZERO];
        self.eval_batch(&[p], &mut out);
        out[0]
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        if self.field.grad_batch(points, out) {
            return;
        }
        differences(
            points,
            self.h,
            0.0,
            out,
            |p, v| self.field.eval_batch(p, v),
            Vec3::from_array,
        );
    }
}

/// The Jacobian `J_ij = ∂v_i/∂x_j` of a vector field by central differences
/// with step `h` (column `j` is `∂v/∂x_j`).
pub struct Jacobian {
    /// The differentiated field.
    pub field: Vector,
    /// Central-difference step.
    pub h: f32,
}

impl MatrixField for Jacobian {
    fn eval(&self, p: Vec3) -> Mat3 {
        let mut out = [Mat3::ZERO];
        self.eval_batch(&[p], &mut out);
        out[0]
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Mat3]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        differences(
            points,
            self.h,
            Vec3::ZERO,
            out,
            |p, v| self.field.eval_batch(p, v),
            |d| Mat3::from_cols(d[0], d[1], d[2]),
        );
    }
}

/// `M ∘ X`: a matrix field evaluated at the image of a map.
pub struct ComposeMatrix(pub Matrix, pub Vector);

impl MatrixField for ComposeMatrix {
    fn eval(&self, p: Vec3) -> Mat3 {
        self.0.eval(self.1.eval(p))
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Mat3]) {
        let mut mapped = vec![Vec3::ZERO; points.len()];
        self.1.eval_batch(points, &mut mapped);
        self.0.eval_batch(&mapped, out);
    }
}

/// The notes' `levelsetsurface(ℓ, iterations)`: the map `x ↦ x_ℓ(x)` onto
/// the zero set of `ℓ` by the march of eq 3.3,
/// `x ← x − ℓ(x) ∇ℓ(x) / |∇ℓ(x)|`, `iterations` times. The step moves by `ℓ`
/// itself, so it assumes a signed distance (`|∇ℓ| = 1`, §3.2): then one step
/// lands on the surface up to the gradient's error, and a cached distance
/// takes 3–5 (the notes' count). For a level set of slope `s ≠ 1` the march
/// converges only linearly, with ratio `|1 − s|`. Where `∇ℓ = 0` the point
/// stays where it is.
pub struct LevelSetSurface {
    /// The level set ℓ.
    pub level_set: Scalar,
    /// `∇ℓ` (analytic or differenced, see [`grad`]).
    pub gradient: Vector,
    /// Number of steps of eq 3.3.
    pub iterations: usize,
}

impl VectorField for LevelSetSurface {
    fn eval(&self, p: Vec3) -> Vec3 {
        let mut out = [Vec3::ZERO];
        self.eval_batch(&[p], &mut out);
        out[0]
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        out.copy_from_slice(points);
        let mut value = vec![0.0; points.len()];
        let mut g = vec![Vec3::ZERO; points.len()];
        for _ in 0..self.iterations {
            self.level_set.eval_batch(out, &mut value);
            self.gradient.eval_batch(out, &mut g);
            for ((x, &l), g) in out.iter_mut().zip(&value).zip(&g) {
                *x -= l * g.normalize_or_zero();
            }
        }
    }
}

/// `op(f)`.
pub fn map(f: Scalar, op: Unary) -> Scalar {
    Arc::new(Map(f, op))
}

/// `a op b`.
pub fn zip(a: Scalar, b: Scalar, op: Binary) -> Scalar {
    Arc::new(Zip(a, b, op))
}

/// The named binary and unary operations, one constructor each.
macro_rules! constructors {
    ($(binary $name:ident = $op:ident, $doc:literal;)* $(unary $uname:ident = $uop:ident, $udoc:literal;)*) => {
        $(
            #[doc = $doc]
            pub fn $name(a: Scalar, b: Scalar) -> Scalar {
                zip(a, b, Binary::$op)
            }
        )*
        $(
            #[doc = $udoc]
            pub fn $uname(f: Scalar) -> Scalar {
                map(f, Unary::$uop)
            }
        )*
    };
}

constructors! {
    binary add = Add, "`a + b`.";
    binary sub = Sub, "`a − b`.";
    binary mul = Mul, "`a · b`.";
    binary div = Div, "`a / b`.";
    binary min = Min, "`min(a, b)`.";
    binary max = Max, "`max(a, b)`.";
    binary pow_field = Pow, "`a^b` with a field exponent.";
    unary neg = Neg, "`−f`.";
    unary abs = Abs, "`|f|`.";
    unary sqrt = Sqrt, "`√f`.";
    unary sin = Sin, "`sin f`.";
    unary cos = Cos, "`cos f`.";
    unary exp = Exp, "`exp f`.";
    unary tanh = Tanh, "`tanh f`.";
}

/// Component `axis` (0 = x, 1 = y, 2 = z) of `v`.
///
/// # Panics
/// If `axis > 2`.
pub fn component(v: Vector, axis: usize) -> Scalar {
    assert!(axis < 3, "component: axis {axis} is not 0, 1 or 2");
    Arc::new(Component(v, axis))
}

/// `f^e` with a constant exponent.
pub fn pow(f: Scalar, e: f32) -> Scalar {
    map(f, Unary::Pow(e))
}

/// `clamp(f, lo, hi)`.
pub fn clamp(f: Scalar, lo: f32, hi: f32) -> Scalar {
    map(f, Unary::Clamp(lo, hi))
}

/// `s · v` for a scalar field `s`.
pub fn scalar_times_vector(s: Scalar, v: Vector) -> Vector {
    Arc::new(ScalarTimesVector(s, v))
}

/// `a − b` for vector fields.
pub fn vector_sub(a: Vector, b: Vector) -> Vector {
    Arc::new(VectorDifference(a, b))
}

/// `a · b`.
pub fn dot(a: Vector, b: Vector) -> Scalar {
    Arc::new(Dot(a, b))
}

/// `v / |v|`.
pub fn normalize(v: Vector) -> Vector {
    Arc::new(Normalize(v))
}

/// `a · M · b`.
pub fn bilinear(a: Vector, m: Matrix, b: Vector) -> Scalar {
    Arc::new(Bilinear(a, m, b))
}

/// `grad(f)`: closed form where `f` has one, central differences with step
/// `h` otherwise.
pub fn grad(f: Scalar, h: f32) -> Vector {
    Arc::new(Gradient { field: f, h })
}

/// The Jacobian of `v` by central differences with step `h`.
pub fn jacobian(v: Vector, h: f32) -> Matrix {
    Arc::new(Jacobian { field: v, h })
}

/// `grad(grad(f))`: the Hessian `M_ij = ∂²f/∂x_i∂x_j` (eq 4.4).
pub fn hessian(f: Scalar, h: f32) -> Matrix {
    jacobian(grad(f, h), h)
}

/// `f ∘ X`.
pub fn compose(f: Scalar, map: Vector) -> Scalar {
    ops::compose(f, map)
}

/// `v ∘ X`.
pub fn compose_vector(v: Vector, map: Vector) -> Vector {
    ops::compose_vector(v, map)
}

/// `M ∘ X`.
pub fn compose_matrix(m: Matrix, map: Vector) -> Matrix {
    Arc::new(ComposeMatrix(m, map))
}

/// `levelsetsurface(ℓ, iterations)` (eq 3.3), differencing `ℓ` with step `h`
/// where it has no closed-form gradient.
pub fn levelset_surface(level_set: Scalar, h: f32, iterations: usize) -> Vector {
    Arc::new(LevelSetSurface {
        gradient: grad(level_set.clone(), h),
        level_set,
        iterations,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops::{constant, identity, sphere};

    fn points() -> Vec<Vec3> {
        (0..40)
            .map(|i| {
                let t = i as f32;
                Vec3::new(
                    (0.37 * t).sin(),
                    (0.71 * t + 1.0).cos(),
                    (0.13 * t).sin() * 0.8,
                )
            })
            .collect()
    }

    /// `x · y + z`, with its gradient in closed form.
    struct Bilin;
    impl ScalarField for Bilin {
        fn eval(&self, p: Vec3) -> f32 {
            p.x * p.y + p.z
        }
        fn grad_batch(&self, points: &[Vec3], out: &mut [Vec3]) -> bool {
            for (o, p) in out.iter_mut().zip(points) {
                *o = Vec3::new(p.y, p.x, 1.0);
            }
            true
        }
    }

    #[test]
    fn batches_match_points_for_every_operation() {
        let a: Scalar = Arc::new(Bilin);
        let b = add(sphere(Vec3::ZERO, 2.0), constant(0.5));
        let v = scalar_times_vector(a.clone(), identity());
        let m = hessian(a.clone(), 1e-2);
        let scalars = [
            neg(a.clone()),
            abs(a.clone()),
            sqrt(b.clone()),
            clamp(a.clone(), -0.1, 0.2),
            pow(b.clone(), 1.5),
            sub(a.clone(), b.clone()),
            mul(a.clone(), b.clone()),
            div(a.clone(), b.clone()),
            min(a.clone(), b.clone()),
            max(a.clone(), b.clone()),
            pow_field(b.clone(), a.clone()),
            dot(v.clone(), identity()),
            bilinear(v.clone(), m, identity()),
            sin(a.clone()),
            cos(a.clone()),
            exp(a.clone()),
            tanh(a.clone()),
            component(v.clone(), 0),
            component(v.clone(), 2),
        ];
        let pts = points();
        for f in scalars {
            let mut out = vec![0.0; pts.len()];
            f.eval_batch(&pts, &mut out);
            for (p, o) in pts.iter().zip(&out) {
                assert_eq!(*o, f.eval(*p), "at {p}");
            }
        }
        for v in [normalize(v.clone()), vector_sub(v, identity())] {
            let mut out = vec![Vec3::ZERO; pts.len()];
            v.eval_batch(&pts, &mut out);
            for (p, o) in pts.iter().zip(&out) {
                assert_eq!(*o, v.eval(*p));
            }
        }
    }

    /// The chain, product and quotient rules against central differences of
    /// the same expression with the closed forms hidden.
    #[test]
    fn analytic_gradients_match_differences() {
        struct Hidden(Scalar);
        impl ScalarField for Hidden {
            fn eval(&self, p: Vec3) -> f32 {
                self.0.eval(p)
            }
        }
        let a: Scalar = Arc::new(Bilin);
        let b = add(sphere(Vec3::ZERO, 2.0), constant(0.5));
        let exprs = [
            mul(a.clone(), b.clone()),
            div(a.clone(), b.clone()),
            pow(b.clone(), 1.5),
            sqrt(b.clone()),
            pow_field(b.clone(), a.clone()),
            min(
                clamp(b.clone(), 0.0, 4.4),
                mul(neg(a.clone()), constant(3.0)),
            ),
            abs(add(a.clone(), constant(2.0))),
            sin(a.clone()),
            cos(b.clone()),
            exp(a.clone()),
            tanh(mul(a.clone(), constant(2.0))),
        ];
        let pts = points();
        for e in exprs {
            let mut exact = vec![Vec3::ZERO; pts.len()];
            assert!(e.grad_batch(&pts, &mut exact));
            let fd = grad(Arc::new(Hidden(e.clone())), 1e-3);
            for (p, g) in pts.iter().zip(&exact) {
                let d = fd.eval(*p);
                assert!(
                    (d - *g).length() < 2e-2 * (1.0 + g.length()),
                    "at {p}: {g} vs {d}"
                );
            }
        }
        // A field without a closed form is differenced.
        let hidden: Scalar = Arc::new(Hidden(a));
        assert!(!add(hidden, b).grad_batch(&pts, &mut vec![Vec3::ZERO; pts.len()]));
    }

    #[test]
    fn hessian_of_a_quadratic_is_its_constant_matrix() {
        // r² − |x|² has Hessian −2 I.
        let m = hessian(sphere(Vec3::new(0.3, 0.0, -0.2), 1.0), 1e-2);
        for p in points() {
            let h = m.eval(p);
            assert!(
                (h - Mat3::from_diagonal(Vec3::splat(-2.0))).abs_diff_eq(Mat3::ZERO, 1e-2),
                "{h}"
            );
        }
    }
}
