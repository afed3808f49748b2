//! Curl noise: the curl of a Perlin vector potential (`001_…`, `004_…`).
//!
//! With a potential `ψ = (ψ₁, ψ₂, ψ₃)` of three independent Perlin noises,
//!
//! ```text
//! V = ∇ × ψ = (∂_y ψ₃ − ∂_z ψ₂,  ∂_z ψ₁ − ∂_x ψ₃,  ∂_x ψ₂ − ∂_y ψ₁)      (001, "curl F")
//! ```
//!
//! and `∇·(∇×ψ) = 0` (`001_…`: "div(curl F) = 0"). In 2D the potential is one
//! scalar and `V = (∂_y N, −∂_x N)`.
//!
//! - [`Curl`] / [`Curl2`] take the partial derivatives from Perlin's analytic
//!   gradient ([`Perlin::value_gradient`]): exactly divergence-free (Perlin
//!   is C2, so `V` is C1), 3 gradient evaluations per point.
//! - [`CurlFd`] / [`CurlFd2`] take them by finite differences, as `001_…`
//!   does. `001_…` uses backward differences `(N(x) − N(x − h e))/h`
//!   ([`FdScheme::Backward`]); the divergence of the resulting field is then
//!   `h/2 (∂²_a ∂_b − ∂_a ∂²_b) N`-like terms, **first order** in h. Central
//!   differences ([`FdScheme::Central`]) make it second order. Either way the
//!   field is only approximately divergence-free; the tests measure the order.
//!
//! `001_…`'s 3D pseudo-code uses the same noise for all three components,
//! `F = (N, N, N)`; its curl `∇N × (1, 1, 1)` is always perpendicular to
//! `(1, 1, 1)`, a flat flow. The fields here use three independent potentials,
//! the same ones as [`Curl`], so the finite-difference field converges to the
//! analytic one. `001_…` also takes `h = 10⁻⁴`, below what f32 supports
//! away from the origin (the spacing of f32 near 10 is 10⁻⁶); the default
//! step here is [`CurlFd::DEFAULT_STEP`].

use glam::{Vec2, Vec3};

use super::perlin::{Perlin, Perlin2};
use crate::field::VectorField;

/// Analytic curl of three Perlin potentials.
#[derive(Clone, Copy, Debug)]
pub struct Curl {
    potential: [Perlin; 3],
}

impl Curl {
    /// Curl noise with potentials hashed by `keys`.
    pub fn new(keys: [u64; 3]) -> Self {
        Self {
            potential: keys.map(Perlin::new),
        }
    }

    #[inline(always)]
    fn sample(&self, p: Vec3) -> Vec3 {
        let g1 = self.potential[0].value_gradient(p).1;
        let g2 = self.potential[1].value_gradient(p).1;
        let g3 = self.potential[2].value_gradient(p).1;
        Vec3::new(g3.y - g2.z, g1.z - g3.x, g2.x - g1.y)
    }
}

impl VectorField for Curl {
    #[inline]
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample(p)
    }
}

/// Analytic 2D curl `(∂_y N, −∂_x N)` in the xy plane (z ignored, z component 0).
#[derive(Clone, Copy, Debug)]
pub struct Curl2 {
    potential: Perlin2,
}

impl Curl2 {
    /// 2D curl noise with potential hashed by `key`.
    pub fn new(key: u64) -> Self {
        Self {
            potential: Perlin2::new(key),
        }
    }

    #[inline(always)]
    fn sample(&self, p: Vec3) -> Vec3 {
        let g = self.potential.value_gradient(p.truncate()).1;
        Vec3::new(g.y, -g.x, 0.0)
    }
}

impl VectorField for Curl2 {
    #[inline]
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample(p)
    }
}

/// A finite-difference rule for `∂_a N`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum FdScheme {
    /// `(N(x) − N(x − h e_a)) / h`, as in `001_…`; O(h).
    Backward,
    /// `(N(x + h e_a) − N(x − h e_a)) / 2h`; O(h²).
    Central,
}

impl FdScheme {
    /// Every rule.
    pub const ALL: [FdScheme; 2] = [FdScheme::Backward, FdScheme::Central];

    /// `∂_e n` at `p` with step `h`.
    #[inline(always)]
    fn derivative(self, n: impl Fn(Vec3) -> f32, p: Vec3, e: Vec3, h: f32) -> f32 {
        match self {
            FdScheme::Backward => (n(p) - n(p - e * h)) / h,
            FdScheme::Central => (n(p + e * h) - n(p - e * h)) / (2.0 * h),
        }
    }
}

/// Curl of three Perlin potentials by finite differences (`001_…`).
#[derive(Clone, Copy, Debug)]
pub struct CurlFd {
    potential: [Perlin; 3],
    step: f32,
    scheme: FdScheme,
}

impl CurlFd {
    /// Default step in lattice units: balances the O(h²) truncation of
    /// central differences against f32 round-off `~ε|N|/h`.
    pub const DEFAULT_STEP: f32 = 1e-2;

    /// Finite-difference curl noise with the potentials of [`Curl::new`].
    ///
    /// # Panics
    /// If `step` is not positive and finite.
    pub fn new(keys: [u64; 3], step: f32, scheme: FdScheme) -> Self {
        assert!(
            step.is_finite() && step > 0.0,
            "finite-difference step {step} must be positive"
        );
        Self {
            potential: keys.map(Perlin::new),
            step,
            scheme,
        }
    }

    #[inline(always)]
    fn sample(&self, p: Vec3) -> Vec3 {
        let [a, b, c] = self.potential;
        let d = |n: Perlin, e: Vec3| self.scheme.derivative(|q| n.value(q), p, e, self.step);
        Vec3::new(
            d(c, Vec3::Y) - d(b, Vec3::Z),
            d(a, Vec3::Z) - d(c, Vec3::X),
            d(b, Vec3::X) - d(a, Vec3::Y),
        )
    }
}

impl CurlFd {
    /// The exact divergence of this finite-difference field at `p` — what
    /// [`FdScheme`] leaves of `∇·(∇×ψ) = 0` (`001_…`). With `D_a` the
    /// finite-difference operator along axis `a`, which commutes with `∂_b`,
    ///
    /// ```text
    /// ∇·V = (D_y ∂_x − D_x ∂_y) ψ₃ + (D_z ∂_y − D_y ∂_z) ψ₁ + (D_x ∂_z − D_z ∂_x) ψ₂
    /// ```
    ///
    /// each `∂_b ψ` taken from Perlin's analytic gradient, so no second
    /// finite difference blurs the measurement: the result is the scheme's
    /// truncation error, O(h²) central and O(h) backward (bounded third
    /// derivatives: Perlin is C²).
    pub fn divergence(&self, p: Vec3) -> f32 {
        let [a, b, c] = self.potential;
        // D_e ∂_g ψ: the scheme's difference along e of the analytic ∂ψ/∂x_g.
        let d = |n: Perlin, e: Vec3, g: usize| {
            self.scheme
                .derivative(|q| n.value_gradient(q).1[g], p, e, self.step)
        };
        let (x, y, z) = (0, 1, 2);
        (d(c, Vec3::Y, x) - d(c, Vec3::X, y))
            + (d(a, Vec3::Z, y) - d(a, Vec3::Y, z))
            + (d(b, Vec3::X, z) - d(b, Vec3::Z, x))
    }
}

impl VectorField for CurlFd {
    #[inline]
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample(p)
    }
}

/// 2D curl `(∂_y N, −∂_x N)` by finite differences (`001_…`'s `computeCurl`).
#[derive(Clone, Copy, Debug)]
pub struct CurlFd2 {
    potential: Perlin2,
    step: f32,
    scheme: FdScheme,
}

impl CurlFd2 {
    /// 2D finite-difference curl noise with the potential of [`Curl2::new`].
    ///
    /// # Panics
    /// If `step` is not positive and finite.
    pub fn new(key: u64, step: f32, scheme: FdScheme) -> Self {
        assert!(
            step.is_finite() && step > 0.0,
            "finite-difference step {step} must be positive"
        );
        Self {
            potential: Perlin2::new(key),
            step,
            scheme,
        }
    }

    #[inline(always)]
    fn sample(&self, p: Vec3) -> Vec3 {
        let n = |q: Vec3| self.potential.value(q.truncate());
        let p = p.truncate().extend(0.0);
        let dx = self.scheme.derivative(n, p, Vec3::X, self.step);
        let dy = self.scheme.derivative(n, p, Vec3::Y, self.step);
        Vec2::new(dy, -dx).extend(0.0)
    }
}

impl VectorField for CurlFd2 {
    #[inline]
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::lattice::keys;

    /// `CurlFd::divergence` is the divergence of the field itself: it
    /// matches a central difference of the sampled field with a step ten
    /// times finer than the field's own (a wrong sign or term would miss by
    /// the size of the divergence itself, ~0.1–1 at h = 0.2).
    #[test]
    fn divergence_is_that_of_the_finite_difference_field() {
        let k = keys::<3>(5);
        for scheme in [FdScheme::Backward, FdScheme::Central] {
            let curl = CurlFd::new(k, 0.2, scheme);
            for s in 0..32 {
                let p = Vec3::new(
                    0.3 + 0.41 * s as f32,
                    1.7 - 0.23 * s as f32,
                    0.11 * s as f32,
                );
                let delta = 0.02;
                let numeric: f32 = [Vec3::X, Vec3::Y, Vec3::Z]
                    .iter()
                    .map(|&e| (curl.eval(p + delta * e) - curl.eval(p - delta * e)).dot(e))
                    .sum::<f32>()
                    / (2.0 * delta);
                let exact = curl.divergence(p);
                assert!(
                    (numeric - exact).abs() < 2e-2 * (1.0 + exact.abs()),
                    "{scheme:?} at {p}: divergence {exact}, numerically {numeric}"
                );
            }
        }
    }

    /// The finite-difference fields converge to the analytic curl at the
    /// scheme's order.
    #[test]
    fn finite_differences_converge_to_the_analytic_curl() {
        let k = keys::<3>(21);
        let exact = Curl::new(k);
        let exact2 = Curl2::new(k[0]);
        let points: Vec<Vec3> = (0..64)
            .map(|s| {
                Vec3::new(
                    (s as f32 * 0.37).sin() * 2.0,
                    (s as f32 * 0.91).cos() * 2.0,
                    s as f32 * 0.031,
                )
            })
            .collect();
        let error = |f: &dyn VectorField, g: &dyn VectorField| {
            points
                .iter()
                .map(|&p| (f.eval(p) - g.eval(p)).length())
                .sum::<f32>()
                / points.len() as f32
        };
        for (scheme, order) in [(FdScheme::Backward, 1.0), (FdScheme::Central, 2.0)] {
            let (h1, h2) = (0.04, 0.02);
            let e1 = error(&CurlFd::new(k, h1, scheme), &exact);
            let e2 = error(&CurlFd::new(k, h2, scheme), &exact);
            let observed = (e1 / e2).log2();
            assert!(
                (observed - order).abs() < 0.3,
                "{scheme:?}: {e1} → {e2}, order {observed}"
            );
            let e1 = error(&CurlFd2::new(k[0], h1, scheme), &exact2);
            let e2 = error(&CurlFd2::new(k[0], h2, scheme), &exact2);
            let observed = (e1 / e2).log2();
            assert!(
                (observed - order).abs() < 0.3,
                "2D {scheme:?}: {e1} → {e2}, order {observed}"
            );
        }
    }
}
