//! Value noise: linear interpolation of random corner vectors — the baseline
//! of `000_…` §3 ("the lattice-based noise that linearly interpolates
//! corners that contain random vectors").
//!
//! Trilinear (3D) or bilinear (2D) in each lattice cell, C0 across cells, and
//! **not** divergence-free: its divergence is the sum of the slopes of three
//! independent random interpolants. Cost per 3D evaluation: 8 corner lookups,
//! 7 mixes per component = 42 FP add/subtracts and 21 multiplies (`000_…` §3).

use glam::Vec3;

use super::lattice::{cell, Corners};
use crate::field::VectorField;

/// `a + (b − a) t` per component: 2 add/subtracts and 1 multiply each, the
/// form `000_…` counts.
#[inline(always)]
fn mix(a: Vec3, b: Vec3, t: f32) -> Vec3 {
    a + (b - a) * t
}

/// 3D value noise on the unit lattice.
#[derive(Clone, Copy, Debug)]
pub struct ValueNoise<C> {
    corners: C,
}

impl<C: Corners> ValueNoise<C> {
    /// Value noise reading its corner vectors from `corners`.
    pub fn new(corners: C) -> Self {
        Self { corners }
    }

    #[inline(always)]
    fn sample(&self, p: Vec3) -> Vec3 {
        let (i, fx) = cell(p.x);
        let (j, fy) = cell(p.y);
        let (k, fz) = cell(p.z);
        let c = |a, b, d| self.corners.corner(i + a, j + b, k + d);
        let x00 = mix(c(0, 0, 0), c(1, 0, 0), fx);
        let x10 = mix(c(0, 1, 0), c(1, 1, 0), fx);
        let x01 = mix(c(0, 0, 1), c(1, 0, 1), fx);
        let x11 = mix(c(0, 1, 1), c(1, 1, 1), fx);
        mix(mix(x00, x10, fy), mix(x01, x11, fy), fz)
    }
}

impl<C: Corners> VectorField for ValueNoise<C> {
    #[inline]
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample(p)
    }
}

/// 2D value noise in the xy plane: random 2-vectors at the corners, bilinear.
/// `z` is ignored and the z component is zero.
#[derive(Clone, Copy, Debug)]
pub struct ValueNoise2<C> {
    corners: C,
}

impl<C: Corners> ValueNoise2<C> {
    /// 2D value noise reading the first two values of each corner lookup.
    pub fn new(corners: C) -> Self {
        Self { corners }
    }

    #[inline(always)]
    fn sample(&self, p: Vec3) -> Vec3 {
        let (i, fx) = cell(p.x);
        let (j, fy) = cell(p.y);
        let c = |a, b| self.corners.corner(i + a, j + b, 0);
        let v = mix(mix(c(0, 0), c(1, 0), fx), mix(c(0, 1), c(1, 1), fx), fy);
        v.truncate().extend(0.0)
    }
}

impl<C: Corners> VectorField for ValueNoise2<C> {
    #[inline]
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::noise::lattice::{keys, StaticCorners};

    #[test]
    fn interpolates_the_corner_vectors() {
        let corners = StaticCorners::new(keys::<1>(1)[0]);
        let n = ValueNoise::new(corners);
        assert_eq!(n.eval(Vec3::new(2.0, -1.0, 3.0)), corners.corner(2, -1, 3));
        let mid = n.eval(Vec3::new(2.5, -1.0, 3.0));
        let expect = 0.5 * (corners.corner(2, -1, 3) + corners.corner(3, -1, 3));
        assert!((mid - expect).length() < 1e-6);
        let n2 = ValueNoise2::new(corners);
        let v = n2.eval(Vec3::new(4.0, 5.0, 9.0));
        assert_eq!(v, corners.corner(4, 5, 0).truncate().extend(0.0));
    }
}
