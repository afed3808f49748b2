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
use crate::grid::FaceGrid;

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

/// Probe points per task: the partial sums of fixed chunks are added in
/// chunk order, so the measure does not depend on the thread count.
const CHUNK: usize = 256;

/// `∇·u` of `vel`'s point query at `points`, rms and max |·|, both divided by
/// the rms over the same points of `|∇u|` (zero for a uniform flow).
pub fn interpolant_divergence(vel: &dyn VectorField, domain: &Domain, points: &[Vec3]) -> RmsMax {
    relative_divergence(domain, points, |q, u| {
        for (o, &p) in u.iter_mut().zip(q) {
            *o = vel.eval(p);
        }
    })
}

/// [`interpolant_divergence`] of a staggered velocity, its point query
/// batched ([`crate::advection::sample_face_points`]): the same value to the bit, for
/// the measures taken after every step.
pub fn face_interpolant_divergence(vel: &FaceGrid, points: &[Vec3]) -> RmsMax {
    relative_divergence(vel.domain(), points, |q, u| {
        crate::advection::sample_face_points(vel, q, u)
    })
}

/// The divergence of a staggered velocity's interpolant
/// ([`crate::grid::Interpolant`]) at `points` (world), differentiated
/// exactly ([`crate::grid::face::FaceSampler::divergence_at`]), rms and
/// max |·| relative to `max|u| / Δx` (`max|u|` the largest face value; zero
/// for a velocity at rest). Trilinear: zero at the cell centres of a
/// projected velocity, not between; RT0: each point's cell's compact
/// divergence, zero to round-off after the projection.
pub fn face_pointwise_divergence(vel: &FaceGrid, points: &[Vec3]) -> RmsMax {
    let scale = vel.max_norm();
    if scale == 0.0 || points.is_empty() {
        return RmsMax::default();
    }
    let (d, s) = (vel.domain(), vel.sampler());
    let chunks: Vec<(f64, f32)> = points
        .par_chunks(CHUNK)
        .map(|chunk| {
            chunk.iter().fold((0.0f64, 0.0f32), |(sum, max), &p| {
                let div = s.divergence_at(d.grid_coords(p));
                (sum + (div as f64).powi(2), max.max(div.abs()))
            })
        })
        .collect();
    let (sum, max) = chunks
        .iter()
        .fold((0.0, 0.0f32), |a, b| (a.0 + b.0, a.1.max(b.1)));
    RmsMax {
        rms: ((sum / points.len() as f64).sqrt() / scale as f64) as f32,
        max: max / scale,
    }
}

/// [`interpolant_divergence`] with the point query `query(points, out)`:
/// per chunk of points the six points `p ± h e_a` of each, queried at once,
/// then the central differences `(u(p + h e_a) − u(p − h e_a)) / 2h`.
fn relative_divergence(
    domain: &Domain,
    points: &[Vec3],
    query: impl Fn(&[Vec3], &mut [Vec3]) + Sync,
) -> RmsMax {
    let h = STEP_CELLS * domain.cell;
    let chunks: Vec<(f64, f64, f32)> = points
        .par_chunks(CHUNK)
        .map_init(
            || (Vec::new(), Vec::new()),
            |(at, u): &mut (Vec<Vec3>, Vec<Vec3>), chunk| {
                at.clear();
                for &p in chunk {
                    for e in Vec3::AXES.map(|e| e * h) {
                        at.extend([p + e, p - e]);
                    }
                }
                u.resize(at.len(), Vec3::ZERO);
                query(at, u);
                let (mut div2, mut grad2, mut max) = (0.0f64, 0.0f64, 0.0f32);
                for v in u.chunks_exact(6) {
                    let mut div = 0.0f32;
                    for a in 0..3 {
                        let d = (v[2 * a] - v[2 * a + 1]) / (2.0 * h);
                        div += d[a];
                        grad2 += d.length_squared() as f64;
                    }
                    div2 += (div as f64).powi(2);
                    max = max.max(div.abs());
                }
                (div2, grad2, max)
            },
        )
        .collect();
    let (div2, grad2, max) = chunks.iter().fold((0.0, 0.0, 0.0f32), |a, b| {
        (a.0 + b.0, a.1 + b.1, a.2.max(b.2))
    });
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

    /// A smooth periodic flow with some divergence: `u_a` a product of sines.
    struct Waves;
    impl VectorField for Waves {
        fn eval(&self, p: Vec3) -> Vec3 {
            let s = |x: f32, k: f32| (std::f32::consts::TAU * k * x / 4.0).sin();
            Vec3::new(
                s(p.x, 1.0) * s(p.y, 2.0),
                s(p.y, 1.0) + 0.5 * s(p.z, 3.0),
                s(p.z, 2.0) * s(p.x, 1.0),
            )
        }
    }

    #[test]
    fn the_batched_face_query_gives_the_same_bits_at_any_thread_count() {
        use crate::grid::BoxKind;
        let d = Domain::cube(16, 4.0).unwrap();
        // 4100 points: sixteen full chunks, one partial, a partial group of eight.
        let pts = probe_points(&d, 4100, 3);
        let on = |n: usize, f: &(dyn Fn() -> RmsMax + Sync)| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap();
            pool.install(f)
        };
        let bits = |r: RmsMax| [r.rms.to_bits(), r.max.to_bits()];
        for kind in BoxKind::ALL {
            let vel = FaceGrid::from_field(d, kind, &Waves);
            let fast = on(1, &|| face_interpolant_divergence(&vel, &pts));
            // Measured rms ≈ 0.2 in both boxes: a real, non-zero measure.
            assert!(fast.rms > 0.05 && fast.max > fast.rms, "{kind}: {fast:?}");
            assert_eq!(
                bits(fast),
                bits(on(3, &|| face_interpolant_divergence(&vel, &pts)))
            );
            let generic = on(3, &|| interpolant_divergence(&vel, &d, &pts));
            assert_eq!(
                bits(fast),
                bits(generic),
                "{kind}: {fast:?} against {generic:?}"
            );
            // And the point query one point at a time.
            let mut batch = vec![Vec3::ZERO; pts.len()];
            crate::advection::sample_face_points(&vel, &pts, &mut batch);
            assert!(pts.iter().zip(&batch).all(|(&p, &u)| vel.sample(p) == u));
        }
    }
}
