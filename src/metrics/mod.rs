//! Diagnostics computed on grids: divergence, mirror symmetry of densities
//! and velocity, the divergence tracers feel ([`interpolant`]) and where the
//! energy sits in wavenumber ([`spectrum`]).

pub mod interpolant;
pub mod spectrum;

use rayon::prelude::*;

pub use interpolant::{interpolant_divergence, probe_points};
pub use spectrum::SpectralShare;

use crate::grid::{ScalarGrid, VectorGrid};

/// Root-mean-square and maximum of a set of values.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct RmsMax {
    /// √(mean v²).
    pub rms: f32,
    /// max |v|.
    pub max: f32,
}

/// The central-difference divergence on the periodic collocated grid,
/// `Σ_a (u_a[i+1] − u_a[i−1]) / 2Δx` — the operator [`crate::projection`]
/// annihilates. Returns one value per cell, `[z][y][x]`.
pub fn divergence(vel: &VectorGrid) -> ScalarGrid {
    let d = *vel.domain();
    let [nx, ny, nz] = d.dims;
    let u = vel.as_vec3();
    let inv = 1.0 / (2.0 * d.cell);
    let mut out = ScalarGrid::zeros(d);
    out.as_slice_mut()
        .par_chunks_mut(nx * ny)
        .enumerate()
        .for_each(|(k, slab)| {
            let (kp, km) = ((k + 1) % nz, (k + nz - 1) % nz);
            for j in 0..ny {
                let (jp, jm) = ((j + 1) % ny, (j + ny - 1) % ny);
                for i in 0..nx {
                    let (ip, im) = ((i + 1) % nx, (i + nx - 1) % nx);
                    let at = |i, j, k| u[(k * ny + j) * nx + i];
                    slab[j * nx + i] = (at(ip, j, k).x - at(im, j, k).x + at(i, jp, k).y
                        - at(i, jm, k).y
                        + at(i, j, kp).z
                        - at(i, j, km).z)
                        * inv;
                }
            }
        });
    out
}

/// RMS and max of the central-difference divergence.
pub fn divergence_stats(vel: &VectorGrid) -> RmsMax {
    rms_max(divergence(vel).as_slice())
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
/// mirror image of `u` is `(u, −v, w)` at `(i, ny−1−j, k)`, so
/// `max |u(i,j,k) − M u(i, ny−1−j, k)| / max |u|` (0 for a fluid at rest).
pub fn velocity_mirror_error(vel: &VectorGrid) -> f32 {
    let [nx, ny, _] = vel.domain().dims;
    let u = vel.as_vec3();
    let flip = glam::Vec3::new(1.0, -1.0, 1.0);
    let diff = u
        .par_chunks(nx * ny)
        .map(|slab| {
            let mut m = 0.0f32;
            for j in 0..ny {
                let (a, b) = (
                    &slab[j * nx..(j + 1) * nx],
                    &slab[(ny - 1 - j) * nx..(ny - j) * nx],
                );
                for (x, y) in a.iter().zip(b) {
                    m = m.max((*x - flip * *y).length());
                }
            }
            m
        })
        .reduce(|| 0.0, f32::max);
    let scale = vel.max_norm();
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
    use glam::Vec3;

    #[test]
    fn divergence_of_linear_shear_is_zero_and_of_expansion_is_not() {
        let d = Domain::cube(8, 8.0).unwrap();
        let shear = VectorGrid::from_field(d, &*ops::constant_vector(Vec3::X));
        assert_eq!(divergence_stats(&shear).max, 0.0);
        // u = sin(kx) x̂ with k = 2π/8, Δx = 1: the central difference is
        // cos(kx) sin(kΔx)/Δx, largest at the cell centres nearest x = 0,
        // where |cos(k/2)| = cos(π/8).
        struct Wave;
        impl crate::field::VectorField for Wave {
            fn eval(&self, p: Vec3) -> Vec3 {
                Vec3::new((std::f32::consts::TAU * p.x / 8.0).sin(), 0.0, 0.0)
            }
        }
        let w = VectorGrid::from_field(d, &Wave);
        let expect = (std::f32::consts::PI / 4.0).sin() * (std::f32::consts::PI / 8.0).cos();
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
        // mirrors to −v, so use v odd about the mid-plane.
        struct Odd;
        impl crate::field::VectorField for Odd {
            fn eval(&self, p: Vec3) -> Vec3 {
                Vec3::new(1.0, (p.y - 4.0) * 0.1, 0.5)
            }
        }
        let sym = VectorGrid::from_field(d, &Odd);
        assert!(velocity_mirror_error(&sym) < 1e-6);
        let up = VectorGrid::from_field(d, &*ops::constant_vector(Vec3::Y));
        assert_eq!(velocity_mirror_error(&up), 2.0);
    }
}
