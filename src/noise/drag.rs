//! Drag coupling of particles to a noise field (`000_…` §3):
//!
//! ```text
//! F = α (V_F − V_p)
//! ```
//!
//! with `V_F` the field's velocity at the particle, `V_p` the particle's and α
//! the coupling coefficient. A small α "loosens the grip" of the noise: it
//! adds to other forces without overpowering them and hides the jumps of fast
//! simulation noise.

use glam::Vec3;

use crate::field::{Vector, VectorField};

/// A velocity field coupled to particles by linear drag.
#[derive(Clone)]
pub struct Drag {
    /// The field velocity `V_F`.
    pub field: Vector,
    /// Coupling coefficient α (per unit time, for unit mass).
    pub alpha: f32,
}

impl Drag {
    /// `F = α (V_F(p) − v)` for one particle at `p` moving with `v`.
    pub fn force(&self, p: Vec3, v: Vec3) -> Vec3 {
        self.alpha * (self.field.eval(p) - v)
    }

    /// Forces on many particles; the field is evaluated in one batch into
    /// `out`, which then holds the forces.
    ///
    /// # Panics
    /// If the slices differ in length.
    pub fn forces(&self, positions: &[Vec3], velocities: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(
            positions.len(),
            velocities.len(),
            "drag: slice lengths differ"
        );
        self.field.eval_batch(positions, out);
        for (f, &v) in out.iter_mut().zip(velocities) {
            *f = self.alpha * (*f - v);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops;

    #[test]
    fn drag_relaxes_towards_the_field() {
        let wind = Vec3::new(1.0, -2.0, 0.5);
        let drag = Drag {
            field: ops::constant_vector(wind),
            alpha: 0.5,
        };
        assert_eq!(drag.force(Vec3::ZERO, wind), Vec3::ZERO);
        assert_eq!(drag.force(Vec3::ONE, Vec3::ZERO), 0.5 * wind);
        // Forward Euler with unit mass: v ← v + F dt converges to the wind
        // geometrically with ratio (1 − α dt).
        let (mut v, dt) = (Vec3::ZERO, 0.1);
        let mut out = [Vec3::ZERO];
        for _ in 0..100 {
            drag.forces(&[Vec3::ZERO], &[v], &mut out);
            v += out[0] * dt;
        }
        let expect = (1.0f32 - 0.05).powi(100);
        assert!(((wind - v).length() / wind.length() - expect).abs() < 1e-5);
    }
}
