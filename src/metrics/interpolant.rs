//! What tracers feel: the divergence of the velocity *as it is queried*.
//!
//! Backtraces, gridless walks and SELMA maps never see the grid's own
//! difference operators; they follow the velocity field's point query (the
//! trilinear interpolant). [`interpolant_divergence`] measures `∇·u` of that
//! query at a fixed set of points ([`probe_points`]) by central differences
//! with a step of [`STEP_CELLS`] cells, and reports it relative to the rms
//! of the full velocity gradient `|∇u|` (Frobenius norm) at the same points —
//! the scale any divergence must be small against. A discretely
//! divergence-free field can still score high here if its interpolant is not
//! (a cell-to-cell alternating mode under the collocated central difference);
//! for the staggered grid's per-component trilinear query the divergence
//! vanishes at cell centres and stays small in between.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;

use super::RmsMax;
use crate::domain::Domain;
use crate::field::VectorField;

/// Central-difference step of the derivatives, in cells: small enough that a
/// difference rarely straddles a kink of the piecewise-trilinear query (it
/// does with probability ≈ 2 %), large enough for f32 values.
pub const STEP_CELLS: f32 = 1e-2;

/// `count` points uniformly in the box of `domain`, from `seed` (the same
/// points every call, so metrics compare step to step and run to run).
pub fn probe_points(domain: &Domain, count: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let (lo, size) = (domain.origin, domain.size());
    (0..count)
        .map(|_| lo + size * Vec3::new(rng.random(), rng.random(), rng.random()))
        .collect()
}

/// `∇·u` of `vel`'s point query at `points`, rms and max |·|, both divided by
/// the rms over the same points of `|∇u|` (zero for a uniform flow).
pub fn interpolant_divergence(vel: &dyn VectorField, domain: &Domain, points: &[Vec3]) -> RmsMax {
    let h = STEP_CELLS * domain.cell;
    let (div2, grad2, max) = points
        .par_chunks(256)
        .map(|chunk| {
            let (mut div2, mut grad2, mut max) = (0.0f64, 0.0f64, 0.0f32);
            for &p in chunk {
                let mut div = 0.0f32;
                for a in 0..3 {
                    let e = Vec3::AXES[a] * h;
                    let d = (vel.eval(p + e) - vel.eval(p - e)) / (2.0 * h);
                    div += d[a];
                    grad2 += d.length_squared() as f64;
                }
                div2 += (div as f64).powi(2);
                max = max.max(div.abs());
            }
            (div2, grad2, max)
        })
        .reduce(
            || (0.0, 0.0, 0.0),
            |a, b| (a.0 + b.0, a.1 + b.1, a.2.max(b.2)),
        );
    let grad_rms = (grad2 / points.len().max(1) as f64).sqrt();
    if grad_rms == 0.0 {
        return RmsMax::default();
    }
    RmsMax {
        rms: ((div2 / points.len() as f64).sqrt() / grad_rms) as f32,
        max: (max as f64 / grad_rms) as f32,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops;

    struct Expansion;
    impl VectorField for Expansion {
        fn eval(&self, p: Vec3) -> Vec3 {
            p
        }
    }

    struct Rotation;
    impl VectorField for Rotation {
        fn eval(&self, p: Vec3) -> Vec3 {
            Vec3::new(-p.y, p.x, 0.0)
        }
    }

    #[test]
    fn sees_expansion_not_rotation_or_uniform_flow() {
        let d = Domain::cube(16, 4.0).unwrap();
        let pts = probe_points(&d, 500, 7);
        assert!(pts.iter().all(|&p| d.contains(p)));
        // ∇·(x) = 3 and |∇u| = √3 everywhere: relative divergence √3.
        let e = interpolant_divergence(&Expansion, &d, &pts);
        assert!((e.rms - 3f32.sqrt()).abs() < 1e-2, "{e:?}");
        let r = interpolant_divergence(&Rotation, &d, &pts);
        assert!(r.max < 1e-3, "{r:?}");
        let c = interpolant_divergence(&*ops::constant_vector(Vec3::ONE), &d, &pts);
        assert_eq!(c, RmsMax::default());
    }
}
