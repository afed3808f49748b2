//! Trilinear interpolation stencils in continuous grid coordinates.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// What happens to a sample point outside the grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Wrap {
    /// The grid tiles space (the FFT projection's periodic box).
    #[default]
    Periodic,
    /// Points are clamped to the outermost cell centres (closed boxes).
    Clamped,
}

/// The eight corners and weights of a trilinear sample.
///
/// Built from continuous grid coordinates (cell centres at integers); the
/// indices are linear `[z][y][x]` offsets into a grid with `dims`.
#[derive(Clone, Copy, Debug)]
pub struct Stencil {
    /// Linear indices of the corners, in the order
    /// `(x0,y0,z0), (x1,y0,z0), (x0,y1,z0), (x1,y1,z0), (x0,y0,z1), …`.
    pub index: [usize; 8],
    /// Trilinear weights, summing to one.
    pub weight: [f32; 8],
}

/// `g.floor()` without the libm call: baseline x86-64 has no SSE4.1 `roundss`,
/// so `f32::floor` is a function call that costs as much as the rest of a
/// trilinear stencil. Exact for every finite `g` (floats of magnitude ≥ 2²³
/// are integers already).
#[inline(always)]
fn floor(g: f32) -> f32 {
    if g.abs() < 8_388_608.0 {
        let t = g as i32 as f32;
        if t > g {
            t - 1.0
        } else {
            t
        }
    } else {
        g
    }
}

/// Lower and upper lattice index and the fraction between them along one axis.
#[inline(always)]
fn axis(g: f32, n: usize, wrap: Wrap) -> (usize, usize, f32) {
    match wrap {
        Wrap::Periodic => {
            let f = floor(g);
            let t = g - f;
            let (fi, ni) = (f as i64, n as i64);
            // Departure points are rarely more than one period away: avoid the
            // integer division of `rem_euclid` on the common path.
            let i0 = if (0..ni).contains(&fi) {
                fi
            } else if (-ni..0).contains(&fi) {
                fi + ni
            } else {
                fi.rem_euclid(ni)
            } as usize;
            let i1 = if i0 + 1 == n { 0 } else { i0 + 1 };
            (i0, i1, t)
        }
        Wrap::Clamped => {
            let g = g.clamp(0.0, (n - 1) as f32);
            let f = floor(g);
            let i0 = f as usize;
            let i1 = (i0 + 1).min(n - 1);
            (i0, i1, g - f)
        }
    }
}

impl Stencil {
    /// The stencil of continuous grid coordinates `g` on a grid of `dims = [nx, ny, nz]`.
    #[inline(always)]
    pub fn new(g: Vec3, dims: [usize; 3], wrap: Wrap) -> Self {
        let (x0, x1, tx) = axis(g.x, dims[0], wrap);
        let (y0, y1, ty) = axis(g.y, dims[1], wrap);
        let (z0, z1, tz) = axis(g.z, dims[2], wrap);
        let (nx, ny) = (dims[0], dims[1]);
        let row = |y: usize, z: usize| (z * ny + y) * nx;
        let (r00, r10, r01, r11) = (row(y0, z0), row(y1, z0), row(y0, z1), row(y1, z1));
        let (sx, sy, sz) = (1.0 - tx, 1.0 - ty, 1.0 - tz);
        Self {
            index: [
                r00 + x0,
                r00 + x1,
                r10 + x0,
                r10 + x1,
                r01 + x0,
                r01 + x1,
                r11 + x0,
                r11 + x1,
            ],
            weight: [
                sx * sy * sz,
                tx * sy * sz,
                sx * ty * sz,
                tx * ty * sz,
                sx * sy * tz,
                tx * sy * tz,
                sx * ty * tz,
                tx * ty * tz,
            ],
        }
    }

    /// Interpolate a scalar array laid out like the grid.
    #[inline(always)]
    pub fn apply(&self, data: &[f32]) -> f32 {
        let mut acc = 0.0;
        for c in 0..8 {
            acc += self.weight[c] * data[self.index[c]];
        }
        acc
    }

    /// Interpolate an interleaved 3-component array laid out like the grid.
    #[inline(always)]
    pub fn apply_vec3(&self, data: &[f32]) -> Vec3 {
        let mut acc = Vec3::ZERO;
        for c in 0..8 {
            let o = 3 * self.index[c];
            acc += self.weight[c] * Vec3::new(data[o], data[o + 1], data[o + 2]);
        }
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one_and_wrap() {
        let s = Stencil::new(Vec3::new(-0.25, 3.5, 7.9), [4, 4, 8], Wrap::Periodic);
        let sum: f32 = s.weight.iter().sum();
        assert!((sum - 1.0).abs() < 1e-6);
        // x = -0.25 lies between cell 3 (wrapped) and cell 0.
        assert_eq!(s.index[0] % 4, 3);
        assert_eq!(s.index[1] % 4, 0);
    }

    #[test]
    fn fast_floor_is_floor() {
        for g in [
            -3.5f32, -3.0, -2.9999998, -0.0, 0.0, 1e-30, -1e-30, 0.5, 7.0, 7.9999995, 1e7, -1e9,
            3e38,
        ] {
            assert_eq!(floor(g), g.floor(), "{g}");
        }
        assert!(floor(f32::NAN).is_nan());
    }

    #[test]
    fn clamped_stays_inside() {
        let s = Stencil::new(Vec3::new(-5.0, 10.0, 1.5), [4, 4, 4], Wrap::Clamped);
        assert!(s.index.iter().all(|&i| i < 64));
        let sum: f32 = s.weight.iter().sum();
        assert!((sum - 1.0).abs() < 1e-6);
    }
}
