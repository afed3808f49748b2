//! Cloud modelling by layered pyroclastic displacement (ch. 3).
//!
//! - [`PyroclasticSphere`]: the closed-form density of a displaced sphere
//!   (§3.3.1, eq 3.2);
//! - [`displace`]: any level set displaced by a noise sampled on its surface
//!   (eq 3.4), through `levelsetsurface` (eq 3.3);
//! - [`cumulo`]: layers of displacement, each on the surface left by the
//!   previous ones (eq 3.5), optionally cached per layer on its own domain
//!   (§3.3.3, "Selectively sampling the levelset into grids");
//! - [`fractal_sum`] and [`noise_layers`]: fractal layers whose frequency,
//!   jump, roughness and scale are fields (eqs 3.6–3.7, the `NoiseLayers`
//!   script), which is the spatial control of §3.6;
//! - [`billow`]: clearing the canyons (eq 3.8);
//! - [`NoisyVelocity`] and [`advected`]: the noisy velocity of eq 3.9 and
//!   gridless advection of the cloud by it (§3.5, eq 7.4 without sources).
//!
//! Level sets are positive inside; the density of a level set is
//! `mask(ℓ)` (eq 3.1).

use std::sync::Arc;

use glam::Vec3;

use super::cache;
use crate::domain::Domain;
use crate::error::InputError;
use crate::field::algebra::{
    abs, clamp, compose, levelset_surface, mul, pow_field, scalar_times_vector,
};
use crate::field::ops::{self, constant, identity};
use crate::field::{Scalar, ScalarField, Vector, VectorField};
use crate::noise::perlin::Perlin;

/// A bound on `|Perlin(x)|`: the noise is a convex blend of the corner terms
/// `g·(f − o)`, each at most `|r_a| + |r_b| ≤ 2` for Perlin's edge gradients.
pub const PERLIN_BOUND: f32 = 2.0;

/// The pyroclastic sphere of §3.3.1: density 1 inside `|x − c| < R + r(n)`,
/// 0 outside, with the displacement `r(n) = a |Perlin(f n)|` sampled at the
/// direction `n = (x − c)/|x − c|` (eq 3.2 and steps 1–3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PyroclasticSphere {
    /// Centre `x_sphere`.
    pub center: Vec3,
    /// Radius `R`.
    pub radius: f32,
    /// Displacement amplitude `a`.
    pub amplitude: f32,
    /// Frequency `f` of the noise on the unit sphere.
    pub frequency: f32,
    /// The noise.
    pub noise: Perlin,
}

impl PyroclasticSphere {
    /// The displacement noise as a field of surface points, `a Perlin(f (y − c)/R)`:
    /// on the sphere's surface it is `r(n)` without the absolute value, so
    /// `displace(sphere distance, this)` is the same shape (eq 3.4).
    pub fn surface_noise(&self) -> Scalar {
        let map = ops::vector_sum(
            ops::vector_scale(identity(), self.frequency / self.radius),
            ops::constant_vector(-self.center * (self.frequency / self.radius)),
        );
        ops::scale(compose(Arc::new(self.noise), map), self.amplitude)
    }
}

impl ScalarField for PyroclasticSphere {
    fn eval(&self, p: Vec3) -> f32 {
        // Step 1, eq 3.2.
        let d = (p - self.center).length();
        // Step 2: the early outs.
        if d < self.radius {
            return 1.0;
        }
        if d - self.radius > self.amplitude * PERLIN_BOUND {
            return 0.0;
        }
        // Step 3.
        let n = (p - self.center) / d;
        let r = self.amplitude * self.noise.value(self.frequency * n).abs();
        if d - self.radius < r {
            1.0
        } else {
            0.0
        }
    }
}

/// Eq 3.4: `ℓ_N(x) = ℓ(x) + |N(x_ℓ(x))|`, where `x_ℓ` is `levelsetsurface(ℓ,
/// iterations)` (eq 3.3, gradient differenced with step `h` where `ℓ` has no
/// closed form).
pub fn displace(level_set: Scalar, noise: Scalar, h: f32, iterations: usize) -> Scalar {
    let surface = levelset_surface(level_set.clone(), h, iterations);
    crate::field::algebra::add(level_set, compose(abs(noise), surface))
}

/// The notes' `cumulo` (eq 3.5): each layer displaces the level set left by
/// the previous ones. With `domains` non-empty (one per layer), the level set
/// after layer `i` is cached on `domains[i]` and read back from there, so the
/// next layers query a grid instead of the whole chain (§3.3.3).
pub fn cumulo(
    base: Scalar,
    layers: &[Scalar],
    h: f32,
    iterations: usize,
    domains: &[Domain],
) -> Result<Scalar, InputError> {
    if !domains.is_empty() && domains.len() != layers.len() {
        crate::input_bail!(
            "cumulo: {} cache domains for {} layers; give one per layer or none",
            domains.len(),
            layers.len()
        );
    }
    let mut out = base;
    for (i, layer) in layers.iter().enumerate() {
        out = displace(out, layer.clone(), h, iterations);
        if let Some(&d) = domains.get(i) {
            out = cache(&*out, d);
        }
    }
    Ok(out)
}

/// Eq 3.6: `FS(x) = Σ_{i<octaves} r^i PN(x f_jump^i)`.
pub fn fractal_sum(noise: Scalar, octaves: usize, jump: f32, roughness: f32) -> Scalar {
    let mut sum = constant(0.0);
    for i in 0..octaves {
        let octave = compose(
            noise.clone(),
            ops::vector_scale(identity(), jump.powi(i as i32)),
        );
        sum = ops::sum(sum, ops::scale(octave, roughness.powi(i as i32)));
    }
    sum
}

/// The `NoiseLayers` script (eq 3.7 with fields for parameters):
/// layer `i` is `scale · rough^i · noise(x · freq · fjump^i)`, where `scale`,
/// `freq`, `fjump` and `rough` are fields, so the character of the
/// displacement can change from place to place (§3.6).
pub fn noise_layers(
    count: usize,
    noise: Scalar,
    scale: Scalar,
    freq: Scalar,
    fjump: Scalar,
    rough: Scalar,
) -> Vec<Scalar> {
    let mut freq_scale = freq;
    let mut amp_scale = scale;
    let mut layers = Vec::with_capacity(count);
    for _ in 0..count {
        let at = scalar_times_vector(freq_scale.clone(), identity());
        layers.push(mul(compose(noise.clone(), at), amp_scale.clone()));
        freq_scale = mul(freq_scale, fjump.clone());
        amp_scale = mul(amp_scale, rough.clone());
    }
    layers
}

/// Eq 3.8, canyon clearing: `N_i^c = N_i · clamp(|N_{i−1}^c| / Q_i, 0, 1)^billow`
/// with `N_0^c = N_0` and `q[i − 1] = Q_i` for each layer after the first.
/// The previous layer enters through its absolute value, the displacement
/// it actually made (eq 3.4), so every layer after the first vanishes where
/// the previous one did: in its canyons. The notes' `Q = 1` is for
/// unit-amplitude noise; [`measured_billow`] sets each `Q_i` against the
/// previous layer's own amplitude.
///
/// # Errors
/// If `q` does not hold one finite positive value per layer after the
/// first.
pub fn billow(layers: &[Scalar], q: &[f32], billow: Scalar) -> Result<Vec<Scalar>, InputError> {
    if q.len() + 1 != layers.len().max(1) {
        crate::input_bail!(
            "billow: {} values of Q for {} layers; give one per layer after the first",
            q.len(),
            layers.len()
        );
    }
    if let Some(bad) = q.iter().find(|q| !(q.is_finite() && **q > 0.0)) {
        crate::input_bail!("billow: Q = {bad}; it must be finite and positive");
    }
    let mut cleared: Vec<Scalar> = layers.iter().take(1).cloned().collect();
    for (layer, &qi) in layers.iter().skip(1).zip(q) {
        let prev = cleared.last().expect("the first layer is in").clone();
        cleared.push(clear(layer, prev, qi, &billow));
    }
    Ok(cleared)
}

/// One step of eq 3.8: `layer · clamp(|prev| / q, 0, 1)^billow`.
fn clear(layer: &Scalar, prev: Scalar, q: f32, billow: &Scalar) -> Scalar {
    let gate = clamp(ops::scale(abs(prev), 1.0 / q), 0.0, 1.0);
    mul(layer.clone(), pow_field(gate, billow.clone()))
}

/// The amplitude of a displacement layer on a surface: the `quantile`
/// (in `(0, 1]`; 1 is the maximum) of `|N(x)|` over the surface points
/// `surface`.
///
/// # Errors
/// If `surface` is empty or `quantile` is outside `(0, 1]`.
pub fn amplitude(
    layer: &dyn ScalarField,
    surface: &[Vec3],
    quantile: f32,
) -> Result<f32, InputError> {
    if surface.is_empty() {
        crate::input_bail!("amplitude: no surface points");
    }
    if !(quantile > 0.0 && quantile <= 1.0) {
        crate::input_bail!("amplitude: quantile {quantile} is outside (0, 1]");
    }
    let mut values: Vec<f32> = surface.iter().map(|&x| layer.eval(x).abs()).collect();
    let rank = ((quantile * values.len() as f32).ceil() as usize).clamp(1, values.len()) - 1;
    let (_, &mut v, _) = values.select_nth_unstable_by(rank, f32::total_cmp);
    Ok(v)
}

/// Eq 3.8 with each `Q_i` measured: the `quantile` of the previous cleared
/// layer's `|N_{i−1}^c|` over the points `surface` ([`amplitude`]), so the
/// clamp saturates only on that layer's peaks, as the notes' `Q = 1` does
/// for unit-amplitude noise, whatever the layers' amplitudes. `Q_i` is
/// measured after layer `i − 1` is cleared, so it depends on `billow`.
/// Returns the cleared layers and the `Q_i`.
///
/// # Errors
/// As [`amplitude`], or if a previous layer vanishes on the whole surface
/// (`Q_i = 0`, nothing to clear against).
pub fn measured_billow(
    layers: &[Scalar],
    billow_exponent: Scalar,
    surface: &[Vec3],
    quantile: f32,
) -> Result<(Vec<Scalar>, Vec<f32>), InputError> {
    let mut q = Vec::new();
    let mut cleared: Vec<Scalar> = layers.iter().take(1).cloned().collect();
    for (i, layer) in layers.iter().enumerate().skip(1) {
        let prev = cleared[i - 1].clone();
        let qi = amplitude(&*prev, surface, quantile)?;
        if qi <= 0.0 {
            crate::input_bail!(
                "billow: layer {} vanishes on the surface; Q would be 0",
                i - 1
            );
        }
        q.push(qi);
        cleared.push(clear(layer, prev, qi, &billow_exponent));
    }
    Ok((cleared, q))
}

/// Eq 3.9: `u(x) = a (P(s x), P(s x + Δ₁), P(s x + Δ₂))`, Perlin noise at
/// three offset points — not divergence-free, enough to feather a cloud.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NoisyVelocity {
    /// The noise `P`.
    pub noise: Perlin,
    /// Amplitude `a`.
    pub amplitude: f32,
    /// Spatial frequency `s`.
    pub frequency: f32,
    /// The offsets `Δ₁`, `Δ₂` (in noise coordinates).
    pub offsets: [Vec3; 2],
}

impl VectorField for NoisyVelocity {
    fn eval(&self, p: Vec3) -> Vec3 {
        let q = self.frequency * p;
        self.amplitude
            * Vec3::new(
                self.noise.value(q),
                self.noise.value(q + self.offsets[0]),
                self.noise.value(q + self.offsets[1]),
            )
    }
}

/// Gridless advection of a density by a steady velocity for `steps` steps of
/// `dt`: `ρ(x) = ρ₀(X(x))` with `X` the backtrace `x ← x − u(x) Δt` applied
/// `steps` times (eq 7.4 without sources).
pub fn advected(density: Scalar, velocity: Vector, dt: f32, steps: usize) -> Scalar {
    (0..steps).fold(density, |rho, _| ops::advect(rho, velocity.clone(), dt))
}
