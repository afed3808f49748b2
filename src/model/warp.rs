//! The nacelle warp (ch. 4): a map `X` with `L_O(x) = L_r(X(x))` (eq 4.1)
//! between a reference level set `L_r` and an object level set `L_O`, built
//! by the iteration of eqs 4.7–4.10 written with the field algebra exactly
//! as the notes' FELT script:
//!
//! ```text
//! B = compose(grad(L_r), X_n)             M = compose(grad(grad(L_r)), X_n)
//! Δ = (L_O − compose(L_r, X_n)) / (B·B)   (4.8)
//! Γ = (B·M·B) / (B·B)                     (4.9)
//! A = (−1 + (1 + 2ΔΓ)^½) / Γ              (4.7)
//! X_{n+1} = X_n + A B                     (4.10)
//! ```
//!
//! Eq 4.7 is evaluated in the equivalent form `A = 2Δ / (1 + (1 + 2ΔΓ)^½)`,
//! which is finite as `Γ → 0` (a signed-distance sphere has `B·M·B = 0`:
//! its Hessian annihilates the normal) and tends to the linear step `A = Δ`
//! there. Where `1 + 2ΔΓ < 0` the quadratic has no real root and the square
//! root is taken as 0 (the step `A = 2Δ` toward the extremum). Where `B = 0`
//! (`∇L_r` vanishes, e.g. a sphere's centre) `B·B` is floored at 10⁻¹²,
//! so the step is finite.
//!
//! Each `X_n` is wrapped in a [`memo`]: the four references to it in `X_{n+1}`
//! evaluate it once per batch, so `n` iterations cost `O(n)`, not `O(4ⁿ)`.
//! With a cache domain, `B·B` and `B·M·B` are sampled onto grids there and
//! read back (§4.2's faster variant).

use glam::Vec3;

use super::cache;
use crate::domain::Domain;
use crate::field::algebra::{
    abs, add, bilinear, compose, compose_matrix, compose_vector, div, dot, grad, hessian, max, mul,
    scalar_times_vector, sqrt, sub,
};
use crate::field::memo::memo;
use crate::field::ops::{constant, identity, scale, vector_sum};
use crate::field::{Scalar, Vector};

/// The two level sets of a warp and how to differentiate them.
#[derive(Clone)]
pub struct Nacelle {
    /// Reference shape `L_r` (e.g. a sphere carrying the attributes).
    pub reference: Scalar,
    /// Object shape `L_O`.
    pub object: Scalar,
    /// Central-difference step for `grad` / `grad(grad)` where `L_r` has no
    /// closed form (the Hessian is always differenced).
    pub h: f32,
    /// Where to cache `B·B` and `B·M·B` (`None`: purely procedural).
    pub cache: Option<Domain>,
}

impl Nacelle {
    /// One step of eqs 4.7–4.10: `X_{n+1}` from `X_n`.
    pub fn step(&self, xn: Vector) -> Vector {
        let xn = memo(xn);
        let b = compose_vector(grad(self.reference.clone(), self.h), xn.clone());
        let m = compose_matrix(hessian(self.reference.clone(), self.h), xn.clone());
        let mut bb = dot(b.clone(), b.clone());
        let mut bmb = bilinear(b.clone(), m, b.clone());
        if let Some(d) = self.cache {
            bb = cache(&*bb, d);
            bmb = cache(&*bmb, d);
        }
        let bb = max(bb, constant(1e-12));
        let delta = div(
            sub(
                self.object.clone(),
                compose(self.reference.clone(), xn.clone()),
            ),
            bb.clone(),
        );
        let gamma = div(bmb, bb);
        let disc = max(
            add(constant(1.0), scale(mul(delta.clone(), gamma), 2.0)),
            constant(0.0),
        );
        let a = div(scale(delta, 2.0), add(constant(1.0), sqrt(disc)));
        vector_sum(xn, scalar_times_vector(a, b))
    }

    /// `X_0 = x, X_1, …, X_iterations`.
    pub fn iterate(&self, iterations: usize) -> Vec<Vector> {
        let mut maps = vec![identity()];
        for _ in 0..iterations {
            let next = self.step(maps.last().expect("X_0").clone());
            maps.push(next);
        }
        maps
    }

    /// The residual of eq 4.1, `|L_O − L_r ∘ X|`.
    pub fn residual(&self, map: Vector) -> Scalar {
        abs(sub(
            self.object.clone(),
            compose(self.reference.clone(), map),
        ))
    }
}

/// Attribute transfer (eq 4.11): the points `x^M_i = X(x^O_i)` on the
/// reference surface at which the reference's attributes are read for the
/// object's vertices `x^O_i`.
pub fn transfer_points(map: &Vector, vertices: &[Vec3]) -> Vec<Vec3> {
    let mut out = vec![Vec3::ZERO; vertices.len()];
    map.eval_batch(vertices, &mut out);
    out
}

/// Texture coordinates on a reference sphere: longitude and latitude of
/// `p − center`, each in `[0, 1]`.
pub fn sphere_uv(center: Vec3, p: Vec3) -> [f32; 2] {
    let d = (p - center).normalize_or_zero();
    let u = 0.5 + d.z.atan2(d.x) / std::f32::consts::TAU;
    let v = 0.5 + d.y.clamp(-1.0, 1.0).asin() / std::f32::consts::PI;
    [u, v]
}
