//! Simulation noise (Patel & Taylor, `000_…` §3–4 and appendix): random
//! values on lattice *edges*, summed into face *fluxes*, interpolated between
//! opposite faces.
//!
//! **Corners → edges → faces.** A corner lookup at `C_ijk` gives the values of
//! the three edges leaving it in +x, +y, +z (fig 2), so the 12 edges of a cell
//! come from 7 corners (corner `n` at offset `(n & 1, n>>1 & 1, n>>2 & 1)`;
//! the far corner `(1,1,1)` carries no edge of the cell). The six face fluxes
//! are the appendix's:
//!
//! ```text
//! f[0] (x−) = (c4.y − c0.y) + (c0.z − c2.z)     f[1] (x+) = (c5.y − c1.y) + (c1.z − c3.z)
//! f[2] (y−) = (c4.x − c0.x) + (c1.z − c0.z)     f[3] (y+) = (c6.x − c2.x) + (c3.z − c2.z)
//! f[4] (z−) = (c0.y − c1.y) + (c0.x − c2.x)     f[5] (z+) = (c4.y − c5.y) + (c4.x − c6.x)
//! ```
//!
//! Each edge enters two faces of the cell with opposite signs, so
//! `(f1 − f0) + (f3 − f2) + (f5 − f4) = 0` identically (the divergence theorem
//! of §3); it is Stokes' theorem for the lattice curl of the edge potential
//! `(e_x, −e_y, −e_z)`. A face shared by two cells gets the same value from
//! both, bit for bit.
//!
//! **Fast** (§3): `V_x = f_x− + P_x (f_x+ − f_x−)`, likewise y and z — linear
//! flux interpolation. The normal component is continuous across faces, so the
//! field is divergence-free everywhere (zero net flux through any closed
//! surface), but the tangential components jump across cell faces.
//! 7 lookups, 24 FP add/subtracts, 3 multiplies.
//!
//! **Smooth** (§4): with `step(x) = 6x⁵ − 15x⁴ + 10x³`,
//! `bell(x) = 16x⁴ − 32x³ + 16x² = 16 (x(1−x))²` and `mix(a,b,x) = a + (b−a)x`,
//! `V_x = bell(P_y) bell(P_z) mix(f_x−, f_x+, step(P_x))` and cyclically.
//! Since `step' = (30/16) bell`, `∇·V = (30/16) bell·bell·bell · Σ(f+ − f−) = 0`.
//! Tangential components carry `bell` of the normal coordinate and vanish on
//! every face, so the field is continuous (C1; the paper says C2, but `bell''`
//! is 32 at both ends and the neighbouring cells' fluxes differ) and zero on
//! every lattice edge ("dead spots").
//!
//! **2D** (§4, fig 3): one random scalar per corner; each side's flux is the
//! difference of its two corners; `V_x` interpolates the fluxes of the two
//! x-sides, `V_y` those of the two y-sides — the lattice curl of a stream
//! function.

use std::marker::PhantomData;

use glam::{Vec2, Vec3};

use super::lattice::{cell, Corners};
use crate::field::VectorField;

/// How fluxes are interpolated inside a cell.
pub trait Interpolation: Copy + Send + Sync + 'static {
    /// Weight of the upper face along the flux direction.
    fn along(t: f32) -> f32;
    /// Factor from a transverse coordinate.
    fn across(t: f32) -> f32;
}

/// Linear flux interpolation (fast simulation noise, §3).
#[derive(Clone, Copy, Debug)]
pub struct Fast;

impl Interpolation for Fast {
    #[inline(always)]
    fn along(t: f32) -> f32 {
        t
    }
    #[inline(always)]
    fn across(_: f32) -> f32 {
        1.0
    }
}

/// Step/bell interpolation (smooth simulation noise, §4).
#[derive(Clone, Copy, Debug)]
pub struct Smooth;

impl Interpolation for Smooth {
    #[inline(always)]
    fn along(t: f32) -> f32 {
        super::perlin::fade(t)
    }
    #[inline(always)]
    fn across(t: f32) -> f32 {
        let a = t * (1.0 - t);
        16.0 * a * a
    }
}

/// The six face fluxes of cell `(i, j, k)` from 7 corner lookups (appendix).
#[inline(always)]
pub fn faces<C: Corners>(corners: &C, i: i32, j: i32, k: i32) -> [f32; 6] {
    let c0 = corners.corner(i, j, k);
    let c1 = corners.corner(i + 1, j, k);
    let c2 = corners.corner(i, j + 1, k);
    let c3 = corners.corner(i + 1, j + 1, k);
    let c4 = corners.corner(i, j, k + 1);
    let c5 = corners.corner(i + 1, j, k + 1);
    let c6 = corners.corner(i, j + 1, k + 1);
    [
        (c4.y - c0.y) + (c0.z - c2.z),
        (c5.y - c1.y) + (c1.z - c3.z),
        (c4.x - c0.x) + (c1.z - c0.z),
        (c6.x - c2.x) + (c3.z - c2.z),
        (c0.y - c1.y) + (c0.x - c2.x),
        (c4.y - c5.y) + (c4.x - c6.x),
    ]
}

#[inline(always)]
fn mix(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// 3D simulation noise on the unit lattice; `I` is [`Fast`] or [`Smooth`].
#[derive(Clone, Copy, Debug)]
pub struct SimulationNoise<C, I> {
    corners: C,
    interpolation: PhantomData<I>,
}

impl<C: Corners, I: Interpolation> SimulationNoise<C, I> {
    /// Simulation noise on the edge values of `corners`.
    pub fn new(corners: C) -> Self {
        Self {
            corners,
            interpolation: PhantomData,
        }
    }

    #[inline(always)]
    fn sample(&self, p: Vec3) -> Vec3 {
        let (i, fx) = cell(p.x);
        let (j, fy) = cell(p.y);
        let (k, fz) = cell(p.z);
        let f = faces(&self.corners, i, j, k);
        let (bx, by, bz) = (I::across(fx), I::across(fy), I::across(fz));
        Vec3::new(
            by * bz * mix(f[0], f[1], I::along(fx)),
            bx * bz * mix(f[2], f[3], I::along(fy)),
            bx * by * mix(f[4], f[5], I::along(fz)),
        )
    }
}

impl<C: Corners, I: Interpolation> VectorField for SimulationNoise<C, I> {
    #[inline]
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample(p)
    }
}

/// 2D simulation noise in the xy plane (§4, fig 3): the first value of each
/// corner lookup is a stream function; `z` is ignored, the z component is 0.
#[derive(Clone, Copy, Debug)]
pub struct SimulationNoise2<C, I> {
    corners: C,
    interpolation: PhantomData<I>,
}

impl<C: Corners, I: Interpolation> SimulationNoise2<C, I> {
    /// 2D simulation noise on the corner values of `corners`.
    pub fn new(corners: C) -> Self {
        Self {
            corners,
            interpolation: PhantomData,
        }
    }

    #[inline(always)]
    fn sample(&self, p: Vec3) -> Vec3 {
        let (i, fx) = cell(p.x);
        let (j, fy) = cell(p.y);
        let psi = |a, b| self.corners.corner(i + a, j + b, 0).x;
        let (p00, p10, p01, p11) = (psi(0, 0), psi(1, 0), psi(0, 1), psi(1, 1));
        // Side fluxes: x-sides run along y, y-sides along x (outward sign
        // chosen so that (fx1 − fx0) + (fy1 − fy0) = 0).
        let (fx0, fx1) = (p01 - p00, p11 - p10);
        let (fy0, fy1) = (p00 - p10, p01 - p11);
        let v = Vec2::new(
            I::across(fy) * mix(fx0, fx1, I::along(fx)),
            I::across(fx) * mix(fy0, fy1, I::along(fy)),
        );
        v.extend(0.0)
    }
}

impl<C: Corners, I: Interpolation> VectorField for SimulationNoise2<C, I> {
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
    fn face_fluxes_cancel_and_are_shared() {
        let c = StaticCorners::new(keys::<1>(9)[0]);
        for (i, j, k) in [(0, 0, 0), (-3, 5, 2), (7, -1, -8)] {
            let f = faces(&c, i, j, k);
            let net = (f[1] - f[0]) + (f[3] - f[2]) + (f[5] - f[4]);
            assert!(net.abs() < 1e-6, "net flux {net}");
            // Upper faces equal the neighbours' lower faces exactly.
            assert_eq!(f[1], faces(&c, i + 1, j, k)[0]);
            assert_eq!(f[3], faces(&c, i, j + 1, k)[2]);
            assert_eq!(f[5], faces(&c, i, j, k + 1)[4]);
        }
    }

    #[test]
    fn smooth_noise_is_the_appendix_formula() {
        let c = StaticCorners::new(keys::<1>(2)[0]);
        let n = SimulationNoise::<_, Smooth>::new(c);
        let p = Vec3::new(1.3, -0.6, 2.9);
        let f = faces(&c, 1, -1, 2);
        let (t, b) = (Vec3::new(0.3, 0.4, 0.9), |x: f32| {
            16.0 * x.powi(4) - 32.0 * x.powi(3) + 16.0 * x * x
        });
        let step = |x: f32| 6.0 * x.powi(5) - 15.0 * x.powi(4) + 10.0 * x.powi(3);
        let expect = Vec3::new(
            b(t.y) * b(t.z) * mix(f[0], f[1], step(t.x)),
            b(t.x) * b(t.z) * mix(f[2], f[3], step(t.y)),
            b(t.x) * b(t.y) * mix(f[4], f[5], step(t.z)),
        );
        assert!((n.eval(p) - expect).length() < 1e-5);
        // Dead spot on a lattice edge.
        assert_eq!(n.eval(Vec3::new(1.5, 2.0, 3.0)), Vec3::ZERO);
    }

    /// Bell(1/2)² = 1, so at a cell centre the smooth noise is the mean of the
    /// opposite fluxes, exactly like the fast noise.
    #[test]
    fn fast_and_smooth_agree_at_cell_centres() {
        let c = StaticCorners::new(keys::<1>(4)[0]);
        let fast = SimulationNoise::<_, Fast>::new(c);
        let smooth = SimulationNoise::<_, Smooth>::new(c);
        let p = Vec3::new(3.5, -1.5, 0.5);
        assert!((fast.eval(p) - smooth.eval(p)).length() < 1e-6);
        let (f2, s2) = (
            SimulationNoise2::<_, Fast>::new(c),
            SimulationNoise2::<_, Smooth>::new(c),
        );
        assert!((f2.eval(p) - s2.eval(p)).length() < 1e-6);
    }
}
