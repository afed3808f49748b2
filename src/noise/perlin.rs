//! Perlin gradient noise (Perlin 2002, "Improving Noise") with its analytic
//! gradient — the scalar potential behind curl noise (`001_…`, `004_…`) and
//! bitangent noise (`004_…`), and the notes' own noisy velocity (eq 3.9).
//!
//! On the unit lattice, with fraction `f = p − ⌊p⌋`, corner offsets
//! `o ∈ {0,1}³`, pseudo-random gradients `g_o` (Perlin's 12 edge directions)
//! and the quintic fade `s(t) = 6t⁵ − 15t⁴ + 10t³`:
//!
//! ```text
//! N(p)  = Σ_o w_o(f) g_o·(f − o),           w_o = Π_a (o_a ? s(f_a) : 1 − s(f_a))
//! ∇N(p) = Σ_o w_o g_o + Σ_o (g_o·(f − o)) ∇w_o
//! ```
//!
//! Both sums are evaluated as the trilinear blend written as a polynomial in
//! the faded coordinates `(u, v, w)`, whose `u`, `v`, `w` derivatives times
//! `s'` give the second sum.
//!
//! Inside a cell `N` is a polynomial of degree 6 per axis; across cells it is
//! C2 (the fade has vanishing first and second derivatives at 0 and 1), so
//! its gradient is C1 and the curl and bitangent fields built from it are
//! continuous and exactly divergence-free.

use glam::{Vec2, Vec3};

use super::lattice::{cell, hash3};
use crate::field::{ScalarField, VectorField};

/// Perlin's 12 cube-edge gradients, padded to 16 (2002, §3).
const GRAD3: [Vec3; 16] = [
    Vec3::new(1.0, 1.0, 0.0),
    Vec3::new(-1.0, 1.0, 0.0),
    Vec3::new(1.0, -1.0, 0.0),
    Vec3::new(-1.0, -1.0, 0.0),
    Vec3::new(1.0, 0.0, 1.0),
    Vec3::new(-1.0, 0.0, 1.0),
    Vec3::new(1.0, 0.0, -1.0),
    Vec3::new(-1.0, 0.0, -1.0),
    Vec3::new(0.0, 1.0, 1.0),
    Vec3::new(0.0, -1.0, 1.0),
    Vec3::new(0.0, 1.0, -1.0),
    Vec3::new(0.0, -1.0, -1.0),
    Vec3::new(1.0, 1.0, 0.0),
    Vec3::new(-1.0, 1.0, 0.0),
    Vec3::new(0.0, -1.0, 1.0),
    Vec3::new(0.0, -1.0, -1.0),
];

/// Eight 2D gradients: the axes and the diagonals.
const GRAD2: [Vec2; 8] = [
    Vec2::new(1.0, 0.0),
    Vec2::new(-1.0, 0.0),
    Vec2::new(0.0, 1.0),
    Vec2::new(0.0, -1.0),
    Vec2::new(1.0, 1.0),
    Vec2::new(-1.0, 1.0),
    Vec2::new(1.0, -1.0),
    Vec2::new(-1.0, -1.0),
];

/// The quintic fade `s(t) = 6t⁵ − 15t⁴ + 10t³` (the `step` of `000_…` §4).
#[inline(always)]
pub fn fade(t: f32) -> f32 {
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

/// `s'(t) = 30 t² (1 − t)²`.
#[inline(always)]
fn fade_derivative(t: f32) -> f32 {
    let a = t * (1.0 - t);
    30.0 * a * a
}

/// 3D Perlin noise on the unit lattice.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Perlin {
    key: u64,
}

impl Perlin {
    /// Noise whose lattice gradients are hashed with `key` (see
    /// [`super::lattice::keys`]).
    pub fn new(key: u64) -> Self {
        Self { key }
    }

    #[inline(always)]
    fn gradient_at(&self, i: i32, j: i32, k: i32) -> Vec3 {
        GRAD3[(hash3(self.key, i, j, k) >> 60) as usize]
    }

    /// `N(p)`.
    #[inline(always)]
    pub fn value(&self, p: Vec3) -> f32 {
        let (i, fx) = cell(p.x);
        let (j, fy) = cell(p.y);
        let (k, fz) = cell(p.z);
        let n = |a: i32, b: i32, c: i32| {
            let r = Vec3::new(fx - a as f32, fy - b as f32, fz - c as f32);
            self.gradient_at(i + a, j + b, k + c).dot(r)
        };
        let lerp = |a: f32, b: f32, t: f32| a + (b - a) * t;
        let (u, v, w) = (fade(fx), fade(fy), fade(fz));
        let x00 = lerp(n(0, 0, 0), n(1, 0, 0), u);
        let x10 = lerp(n(0, 1, 0), n(1, 1, 0), u);
        let x01 = lerp(n(0, 0, 1), n(1, 0, 1), u);
        let x11 = lerp(n(0, 1, 1), n(1, 1, 1), u);
        lerp(lerp(x00, x10, v), lerp(x01, x11, v), w)
    }

    /// `(N(p), ∇N(p))`, the gradient analytic (module docs).
    #[inline(always)]
    pub fn value_gradient(&self, p: Vec3) -> (f32, Vec3) {
        let (i, fx) = cell(p.x);
        let (j, fy) = cell(p.y);
        let (k, fz) = cell(p.z);
        let g = |a: i32, b: i32, c: i32| self.gradient_at(i + a, j + b, k + c);
        let (g000, g100, g010, g110) = (g(0, 0, 0), g(1, 0, 0), g(0, 1, 0), g(1, 1, 0));
        let (g001, g101, g011, g111) = (g(0, 0, 1), g(1, 0, 1), g(0, 1, 1), g(1, 1, 1));
        let (x1, y1, z1) = (fx - 1.0, fy - 1.0, fz - 1.0);
        let n = |g: Vec3, x: f32, y: f32, z: f32| g.x * x + g.y * y + g.z * z;
        let (n000, n100) = (n(g000, fx, fy, fz), n(g100, x1, fy, fz));
        let (n010, n110) = (n(g010, fx, y1, fz), n(g110, x1, y1, fz));
        let (n001, n101) = (n(g001, fx, fy, z1), n(g101, x1, fy, z1));
        let (n011, n111) = (n(g011, fx, y1, z1), n(g111, x1, y1, z1));
        // The trilinear blend in fade coordinates as a polynomial in
        // (u, v, w): c0 + c1 u + c2 v + c3 w + c4 uv + c5 vw + c6 wu + c7 uvw.
        let (u, v, w) = (fade(fx), fade(fy), fade(fz));
        let (du, dv, dw) = (
            fade_derivative(fx),
            fade_derivative(fy),
            fade_derivative(fz),
        );
        let k1 = n100 - n000;
        let k2 = n010 - n000;
        let k3 = n001 - n000;
        let k4 = n110 - n010 - k1;
        let k5 = n011 - n001 - k2;
        let k6 = n101 - n001 - k1;
        let k7 = (n111 - n011) - (n101 - n001) - k4;
        let value =
            n000 + u * k1 + v * k2 + w * k3 + u * v * k4 + v * w * k5 + w * u * k6 + u * v * w * k7;
        let h1 = g100 - g000;
        let h2 = g010 - g000;
        let h3 = g001 - g000;
        let h4 = g110 - g010 - h1;
        let h5 = g011 - g001 - h2;
        let h6 = g101 - g001 - h1;
        let h7 = (g111 - g011) - (g101 - g001) - h4;
        let blended = g000
            + u * h1
            + v * h2
            + w * h3
            + (u * v) * h4
            + (v * w) * h5
            + (w * u) * h6
            + (u * v * w) * h7;
        let chain = Vec3::new(
            du * (k1 + v * k4 + w * k6 + v * w * k7),
            dv * (k2 + w * k5 + u * k4 + w * u * k7),
            dw * (k3 + u * k6 + v * k5 + u * v * k7),
        );
        (value, blended + chain)
    }
}

impl ScalarField for Perlin {
    fn eval(&self, p: Vec3) -> f32 {
        self.value(p)
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        for (o, &p) in out.iter_mut().zip(points) {
            *o = self.value(p);
        }
    }
    fn grad_batch(&self, points: &[Vec3], out: &mut [Vec3]) -> bool {
        assert_eq!(points.len(), out.len(), "grad_batch: slice lengths differ");
        for (o, &p) in out.iter_mut().zip(points) {
            *o = self.value_gradient(p).1;
        }
        true
    }
}

/// 2D Perlin noise in the xy plane (z ignored).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Perlin2 {
    key: u64,
}

impl Perlin2 {
    /// Noise whose lattice gradients are hashed with `key`.
    pub fn new(key: u64) -> Self {
        Self { key }
    }

    #[inline(always)]
    fn gradient_at(&self, i: i32, j: i32) -> Vec2 {
        GRAD2[(hash3(self.key, i, j, 0) >> 61) as usize]
    }

    /// `N(x, y)`.
    #[inline(always)]
    pub fn value(&self, p: Vec2) -> f32 {
        self.value_gradient(p).0
    }

    /// `(N, ∇N)` at `(x, y)`, the 2D form of [`Perlin::value_gradient`].
    #[inline(always)]
    pub fn value_gradient(&self, p: Vec2) -> (f32, Vec2) {
        let (i, fx) = cell(p.x);
        let (j, fy) = cell(p.y);
        let (g00, g10) = (self.gradient_at(i, j), self.gradient_at(i + 1, j));
        let (g01, g11) = (self.gradient_at(i, j + 1), self.gradient_at(i + 1, j + 1));
        let (x1, y1) = (fx - 1.0, fy - 1.0);
        let n00 = g00.x * fx + g00.y * fy;
        let n10 = g10.x * x1 + g10.y * fy;
        let n01 = g01.x * fx + g01.y * y1;
        let n11 = g11.x * x1 + g11.y * y1;
        let (u, v) = (fade(fx), fade(fy));
        let (du, dv) = (fade_derivative(fx), fade_derivative(fy));
        let (k1, k2) = (n10 - n00, n01 - n00);
        let k3 = n11 - n01 - k1;
        let value = n00 + u * k1 + v * k2 + u * v * k3;
        let (h1, h2) = (g10 - g00, g01 - g00);
        let h3 = g11 - g01 - h1;
        let blended = g00 + u * h1 + v * h2 + (u * v) * h3;
        let chain = Vec2::new(du * (k1 + v * k3), dv * (k2 + u * k3));
        (value, blended + chain)
    }
}

/// The notes' noisy velocity (eq 3.9): one Perlin noise read at three offset
/// positions, `(N(x), N(x + Δx₁), N(x + Δx₂))`. Not divergence-free (§3.3:
/// "this velocity field is not incompressible").
#[derive(Clone, Copy, Debug)]
pub struct PerlinVector {
    noise: Perlin,
}

impl PerlinVector {
    /// The offsets `Δx₁, Δx₂` ("chosen for effect"): far apart in lattice
    /// units so the three components are uncorrelated.
    pub const OFFSETS: [Vec3; 2] = [Vec3::new(31.7, -12.3, 7.9), Vec3::new(-5.1, 43.3, -19.6)];

    /// Eq 3.9 on the noise `noise`.
    pub fn new(noise: Perlin) -> Self {
        Self { noise }
    }

    #[inline(always)]
    fn sample(&self, p: Vec3) -> Vec3 {
        Vec3::new(
            self.noise.value(p),
            self.noise.value(p + Self::OFFSETS[0]),
            self.noise.value(p + Self::OFFSETS[1]),
        )
    }
}

impl VectorField for PerlinVector {
    #[inline]
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::lattice::keys;

    /// Central differences in f64 steps agree with the analytic gradient.
    #[test]
    fn analytic_gradient_matches_finite_differences() {
        let n = Perlin::new(keys::<1>(11)[0]);
        let h = 1e-3;
        let mut worst = 0.0f32;
        for s in 0..200 {
            let p = Vec3::new(
                (s as f32 * 0.731).sin() * 3.0,
                (s as f32 * 1.37).cos() * 3.0,
                s as f32 * 0.0137,
            );
            let (v, g) = n.value_gradient(p);
            assert!((v - n.value(p)).abs() < 1e-6);
            let fd = Vec3::new(
                n.value(p + Vec3::X * h) - n.value(p - Vec3::X * h),
                n.value(p + Vec3::Y * h) - n.value(p - Vec3::Y * h),
                n.value(p + Vec3::Z * h) - n.value(p - Vec3::Z * h),
            ) / (2.0 * h);
            worst = worst.max((fd - g).length());
        }
        // Truncation h²/6·|N'''| ≲ 1e-5 plus f32 round-off ~ 1e-7/h.
        assert!(worst < 2e-3, "worst gradient error {worst}");
    }

    #[test]
    fn analytic_gradient_2d_matches_finite_differences() {
        let n = Perlin2::new(keys::<1>(12)[0]);
        let h = 1e-3;
        for s in 0..200 {
            let p = Vec2::new((s as f32 * 0.41).sin() * 4.0, s as f32 * 0.023 - 2.0);
            let (_, g) = n.value_gradient(p);
            let fd = Vec2::new(
                n.value(p + Vec2::X * h) - n.value(p - Vec2::X * h),
                n.value(p + Vec2::Y * h) - n.value(p - Vec2::Y * h),
            ) / (2.0 * h);
            assert!((fd - g).length() < 2e-3, "at {p}: {fd} vs {g}");
        }
    }

    #[test]
    fn vanishes_on_the_lattice() {
        let n = Perlin::new(5);
        assert_eq!(n.value(Vec3::new(3.0, -2.0, 7.0)), 0.0);
    }
}
