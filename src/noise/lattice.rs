//! The integer lattice under every lattice noise: cell location, seeded
//! hashing, and the *corner lookup* of `000_…` §3.
//!
//! A corner lookup maps an integer lattice point `(i, j, k)` to three random
//! numbers in `[−1, 1)`. Patel & Taylor (`000_…` §3) use them as the values of
//! the three edges leaving the corner in +x, +y, +z (fig 2); value noise uses
//! them as the corner's random vector; the 2D noises read the first one.
//!
//! - [`StaticCorners`] is a hash of the point and a seeded key ("for a static
//!   field, corner lookups would map to hashing functions").
//! - [`AnimatedCorners`] is 1D value noise in time per corner ("to make
//!   simulation noise time-varying, one could map corner lookups to 1D value
//!   noise functions, parameterized by time"): the lookups at the integer
//!   times `⌊t⌋` and `⌊t⌋ + 1`, interpolated linearly. Every corner of a cell is
//!   read at the same `t`, so any interpolation that is divergence-free for
//!   arbitrary corner data stays divergence-free at every instant.
//!
//! The hash is one 64-bit mix per lookup (three multiply-adds of the
//! coordinates into the key, then MurmurHash3's `fmix64`); its 64 bits are cut
//! into three 21-bit fields, one per value. The lattice is not periodic.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

const P_X: u64 = 0x9E37_79B9_7F4A_7C15;
const P_Y: u64 = 0xC2B2_AE3D_27D4_EB4F;
const P_Z: u64 = 0x1656_67B1_9E37_79F9;
const P_T: u64 = 0xD6E8_FEB8_6659_FD93;
const BITS: u32 = 21;
const MASK: u64 = (1 << BITS) - 1;
const TO_UNIT: f32 = 2.0 / (1u64 << BITS) as f32;

/// `n` independent 64-bit keys drawn from a PCG stream seeded with `seed`.
pub fn keys<const N: usize>(seed: u64) -> [u64; N] {
    let mut rng = Pcg64::seed_from_u64(seed);
    std::array::from_fn(|_| rng.random())
}

/// MurmurHash3's 64-bit finaliser (a bijection with full avalanche).
#[inline(always)]
pub fn fmix64(mut h: u64) -> u64 {
    h ^= h >> 33;
    h = h.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
    h ^= h >> 33;
    h = h.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
    h ^ (h >> 33)
}

/// The hash of lattice point `(i, j, k)` under `key`.
#[inline(always)]
pub fn hash3(key: u64, i: i32, j: i32, k: i32) -> u64 {
    fmix64(
        key.wrapping_add((i as i64 as u64).wrapping_mul(P_X))
            .wrapping_add((j as i64 as u64).wrapping_mul(P_Y))
            .wrapping_add((k as i64 as u64).wrapping_mul(P_Z)),
    )
}

/// Three uniform numbers in `[−1, 1)` from the three 21-bit fields of `h`.
#[inline(always)]
pub fn unit3(h: u64) -> Vec3 {
    let f = |s: u32| ((h >> s) & MASK) as f32 * TO_UNIT - 1.0;
    Vec3::new(f(0), f(BITS), f(2 * BITS))
}

/// Lower lattice index and fraction in `[0, 1]` of one coordinate
/// (`|x| < 2³¹`; the fraction is 1 only by rounding, for tiny negative x). Truncate and correct instead of `floor`, which is a libm
/// call on baseline x86-64 (no SSE4.1 `roundss`).
#[inline(always)]
pub fn cell(x: f32) -> (i32, f32) {
    let t = x as i32;
    let i = t - (x < t as f32) as i32;
    (i, x - i as f32)
}

/// A corner lookup: three random values per integer lattice point.
pub trait Corners: Clone + Send + Sync + 'static {
    /// The values `(e_x, e_y, e_z)` at lattice point `(i, j, k)`.
    fn corner(&self, i: i32, j: i32, k: i32) -> Vec3;
}

/// Static corners: a seeded hash of the lattice point.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct StaticCorners {
    key: u64,
}

impl StaticCorners {
    /// Corners keyed by `key` (see [`keys`]).
    pub fn new(key: u64) -> Self {
        Self { key }
    }
}

impl Corners for StaticCorners {
    #[inline(always)]
    fn corner(&self, i: i32, j: i32, k: i32) -> Vec3 {
        unit3(hash3(self.key, i, j, k))
    }
}

/// Time-varying corners at one instant: per corner, 1D value noise in time
/// with unit lattice spacing (`000_…` §3).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AnimatedCorners {
    key0: u64,
    key1: u64,
    frac: f32,
}

impl AnimatedCorners {
    /// The corners of `key` at time `t` (in lattice time units).
    pub fn new(key: u64, t: f32) -> Self {
        let t0 = t.floor();
        let slot = |n: i64| fmix64(key ^ (n as u64).wrapping_mul(P_T));
        Self {
            key0: slot(t0 as i64),
            key1: slot(t0 as i64 + 1),
            frac: t - t0,
        }
    }
}

impl Corners for AnimatedCorners {
    #[inline(always)]
    fn corner(&self, i: i32, j: i32, k: i32) -> Vec3 {
        let a = unit3(hash3(self.key0, i, j, k));
        let b = unit3(hash3(self.key1, i, j, k));
        a + (b - a) * self.frac
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn values_are_uniform_in_unit_interval() {
        let c = StaticCorners::new(keys::<1>(7)[0]);
        let (mut sum, mut sum2, mut n) = (0.0f64, 0.0f64, 0.0f64);
        for i in -20..20 {
            for j in -20..20 {
                let v = c.corner(i, j, 3);
                for x in v.to_array() {
                    assert!((-1.0..1.0).contains(&x));
                    sum += x as f64;
                    sum2 += (x * x) as f64;
                    n += 1.0;
                }
            }
        }
        // Uniform on [−1, 1): mean 0, variance 1/3; 4800 samples.
        assert!((sum / n).abs() < 0.03, "mean {}", sum / n);
        assert!((sum2 / n - 1.0 / 3.0).abs() < 0.02, "var {}", sum2 / n);
    }

    #[test]
    fn animated_corners_interpolate_between_integer_times() {
        let key = keys::<1>(3)[0];
        let at = |t: f32| AnimatedCorners::new(key, t).corner(1, -2, 5);
        let (a, b) = (at(4.0), at(5.0));
        assert!((at(4.25) - (a + 0.25 * (b - a))).length() < 1e-6);
        // Just below the next integer time it is continuous.
        assert!((at(4.999_99) - b).length() < 1e-4);
        assert_ne!(a, b);
    }

    #[test]
    fn cell_of_negative_coordinates() {
        assert_eq!(cell(-0.25), (-1, 0.75));
        assert_eq!(cell(-3.0), (-3, 0.0));
        assert_eq!(cell(2.0), (2, 0.0));
        assert_eq!(cell(2.75), (2, 0.75));
        // Rounding can give a fraction of exactly 1 for tiny negative x.
        assert_eq!(cell(-1e-8), (-1, 1.0));
    }
}
