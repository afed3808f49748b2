//! Bitangent noise (`004_…`): the cross product of the gradients of two
//! scalar noises, `V = ∇A × ∇B`.
//!
//! From `∇·(a × b) = b·(∇×a) − a·(∇×b)` and `∇×∇A = 0`, `∇·(∇A × ∇B) = 0`
//! ("divergence free vector field by construction only calling two noise
//! functions"). `V` is tangent to the level sets of both `A` and `B`. With
//! Perlin `A` and `B` (C2), `V` is C1 and exactly divergence-free; cost is two
//! gradient evaluations, against three for [`super::curl::Curl`].

use glam::Vec3;

use super::perlin::Perlin;
use crate::field::VectorField;

/// `∇A × ∇B` for two independent Perlin noises.
#[derive(Clone, Copy, Debug)]
pub struct Bitangent {
    a: Perlin,
    b: Perlin,
}

impl Bitangent {
    /// Bitangent noise with the two scalar noises hashed by `keys`.
    pub fn new(keys: [u64; 2]) -> Self {
        Self {
            a: Perlin::new(keys[0]),
            b: Perlin::new(keys[1]),
        }
    }

    #[inline(always)]
    fn sample(&self, p: Vec3) -> Vec3 {
        let ga = self.a.value_gradient(p).1;
        let gb = self.b.value_gradient(p).1;
        ga.cross(gb)
    }
}

impl VectorField for Bitangent {
    #[inline]
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::lattice::keys;

    #[test]
    fn tangent_to_both_level_sets() {
        let k = keys::<2>(8);
        let n = Bitangent::new(k);
        let (a, b) = (Perlin::new(k[0]), Perlin::new(k[1]));
        for s in 0..50 {
            let p = Vec3::new(s as f32 * 0.173, (s as f32).sin(), 0.5 - s as f32 * 0.07);
            let v = n.eval(p);
            let (ga, gb) = (a.value_gradient(p).1, b.value_gradient(p).1);
            let scale = ga.length() * gb.length() * v.length().max(1e-6);
            assert!(v.dot(ga).abs() <= 1e-5 * scale.max(1e-6));
            assert!(v.dot(gb).abs() <= 1e-5 * scale.max(1e-6));
        }
    }
}
