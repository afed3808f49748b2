//! Diagnostics computed on grids: divergence, mirror symmetry of densities
//! and velocity, the divergence tracers feel ([`interpolant`]) and where the
//! energy sits in wavenumber ([`spectrum`]).

pub mod interpolant;
pub mod spectrum;

use rayon::prelude::*;

pub use interpolant::{interpolant_divergence, probe_points};
pub use spectrum::SpectralShare;

use crate::grid::{FaceGrid, ScalarGrid};

/// Root-mean-square and maximum of a set of values.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct RmsMax {
    /// √(mean v²).
    pub rms: f32,
    /// max |v|.
    pub max: f32,
}

/// RMS and max of the compact divergence `D u` ([`FaceGrid::divergence`]),
/// the operator the pressure solve annihilates: round-off after a step.
pub fn divergence_stats(vel: &FaceGrid) -> RmsMax {
    let mut div = ScalarGrid::zeros(*vel.domain());
    vel.divergence(&mut div);
    rms_max(div.as_slice())
}

/// Share of a periodic staggered velocity's kinetic energy in the top octave
/// of wavenumbers (index beyond `N/4` on some axis): the three face
/// components together, each transformed on its own lattice (a cell-centred
/// average would hide exactly the alternating modes this looks for).
///
/// # Panics
/// If `vel` is in a closed box or `spectrum` was planned for other dims.
pub fn top_octave_share(spectrum: &mut SpectralShare, vel: &FaceGrid) -> f64 {
    assert_eq!(
        vel.kind(),
        crate::grid::BoxKind::Periodic,
        "top_octave_share: closed box"
    );
    spectrum.share_above(
        &[vel.slice(0), vel.slice(1), vel.slice(2)],
        vel.domain().dims.map(|n| n / 4),
    )
}

/// RMS and max |v| of a slice.
pub fn rms_max(values: &[f32]) -> RmsMax {
    let (sum, max) = values
        .par_iter()
        .map(|&v| (v as f64 * v as f64, v.abs()))
        .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)));
    RmsMax {
        rms: (sum / values.len().max(1) as f64).sqrt() as f32,
        max,
    }
}

/// Mirror-symmetry error between two gases that should be each other's image
/// through the mid-plane `y = L/2`:
/// `max |a(i,j,k) − b(i, ny−1−j, k)| / max(max|a|, max|b|)` (0 when both are empty).
///
/// # Panics
/// If the grids have different domains.
pub fn mirror_error(a: &ScalarGrid, b: &ScalarGrid) -> f32 {
    assert_eq!(a.domain(), b.domain(), "mirror_error: domains differ");
    let [nx, ny, _] = a.domain().dims;
    let (sa, sb) = (a.as_slice(), b.as_slice());
    let diff = sa
        .par_chunks(nx * ny)
        .zip(sb.par_chunks(nx * ny))
        .map(|(pa, pb)| {
            let mut m = 0.0f32;
            for j in 0..ny {
                let (ra, rb) = (
                    &pa[j * nx..(j + 1) * nx],
                    &pb[(ny - 1 - j) * nx..(ny - j) * nx],
                );
                for (x, y) in ra.iter().zip(rb) {
                    m = m.max((x - y).abs());
                }
            }
            m
        })
        .reduce(|| 0.0, f32::max);
    let scale = a.max_abs().max(b.max_abs());
    if scale == 0.0 {
        0.0
    } else {
        diff / scale
    }
}

/// Mirror-symmetry error of a velocity through the mid-plane `y = L/2`: the
/// mirror image of `(u, v, w)` is `(u, −v, w)` reflected, so `u` and `w` at
/// row `j` compare with row `ny − 1 − j`, and `v` on the y-face `j` with
/// minus the y-face `ny − j` (wrapped in a periodic box);
/// `max |difference| / max |u_a|` over all faces (0 for a fluid at rest).
pub fn velocity_mirror_error(vel: &FaceGrid) -> f32 {
    let ny = vel.domain().dims[1];
    let (mut diff, mut scale) = (0.0f32, 0.0f32);
    for a in 0..3 {
        let [mx, my, _] = vel.face_dims(a);
        let (sign, mirror): (f32, Box<dyn Fn(usize) -> usize + Sync>) = if a == 1 {
            (-1.0, Box::new(move |j| (my + ny - j) % my))
        } else {
            (1.0, Box::new(move |j| my - 1 - j))
        };
        let (d, s) = vel
            .slice(a)
            .par_chunks(mx * my)
            .map(|slab| {
                let (mut d, mut s) = (0.0f32, 0.0f32);
                for j in 0..my {
                    let (x, y) = (&slab[j * mx..][..mx], &slab[mirror(j) * mx..][..mx]);
                    for (x, y) in x.iter().zip(y) {
                        d = d.max((x - sign * y).abs());
                        s = s.max(x.abs());
                    }
                }
                (d, s)
            })
            .reduce(|| (0.0, 0.0), |p, q| (p.0.max(q.0), p.1.max(q.1)));
        diff = diff.max(d);
        scale = scale.max(s);
    }
    if scale == 0.0 {
        0.0
    } else {
        diff / scale
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Domain;
    use crate::field::ops;
    use crate::grid::BoxKind;
    use glam::Vec3;

    #[test]
    fn compact_divergence_of_shear_is_zero_and_of_a_wave_is_exact() {
        let d = Domain::cube(8, 8.0).unwrap();
        let kind = BoxKind::Periodic;
        let shear = FaceGrid::from_field(d, kind, &*ops::constant_vector(Vec3::X));
        assert_eq!(divergence_stats(&shear).max, 0.0);
        // u = sin(kx) x̂ with k = 2π/8, Δx = 1, sampled on the x-faces
        // x = i: the compact difference at the centre x = i + ½ is
        // 2 sin(k/2) cos(k(i + ½)), largest where |cos| = cos(π/8).
        struct Wave;
        impl crate::field::VectorField for Wave {
            fn eval(&self, p: Vec3) -> Vec3 {
                Vec3::new((std::f32::consts::TAU * p.x / 8.0).sin(), 0.0, 0.0)
            }
        }
        let w = FaceGrid::from_field(d, kind, &Wave);
        let expect = 2.0 * (std::f32::consts::PI / 8.0).sin() * (std::f32::consts::PI / 8.0).cos();
        assert!((divergence_stats(&w).max - expect).abs() < 1e-5);
    }

    #[test]
    fn mirror_error_sees_flips() {
        let d = Domain::cube(8, 8.0).unwrap();
        let a = ScalarGrid::from_field(d, &*ops::mask(ops::sphere(Vec3::new(4.0, 2.0, 4.0), 1.5)));
        let b = ScalarGrid::from_field(d, &*ops::mask(ops::sphere(Vec3::new(4.0, 6.0, 4.0), 1.5)));
        assert_eq!(mirror_error(&a, &b), 0.0);
        assert_eq!(mirror_error(&a, &a), 1.0);
    }

    #[test]
    fn velocity_mirror_error_sees_asymmetric_flow() {
        let d = Domain::cube(8, 8.0).unwrap();
        // A vertical jet through the mid-plane is symmetric: v(y) = v(L − y)
        // mirrors to −v, so use a periodic v odd about the mid-plane.
        struct Odd;
        impl crate::field::VectorField for Odd {
            fn eval(&self, p: Vec3) -> Vec3 {
                Vec3::new(
                    1.0,
                    0.3 * (std::f32::consts::TAU * (p.y - 4.0) / 8.0).sin(),
                    0.5,
                )
            }
        }
        let kind = BoxKind::Periodic;
        let sym = FaceGrid::from_field(d, kind, &Odd);
        assert!(velocity_mirror_error(&sym) < 1e-6);
        let up = FaceGrid::from_field(d, kind, &*ops::constant_vector(Vec3::Y));
        assert_eq!(velocity_mirror_error(&up), 2.0);
    }
}
