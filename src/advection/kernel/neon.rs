//! The kernel in four NEON lanes (every aarch64 CPU); the corners loaded
//! one by one.

use std::arch::aarch64::*;

/// Lanes per vector.
const W: usize = 4;
/// Whether the grid sweeps take two groups at a time, their chains
/// interleaved.
const PAIRS: bool = true;
type F = float32x4_t;
type I = int32x4_t;
/// All ones in the lanes set.
type M = uint32x4_t;

prims! {
    fn splat(x: f32) -> F = vdupq_n_f32(x);
    fn iota() -> F = load(&[0.0, 1.0, 2.0, 3.0]);
    fn add(a: F, b: F) -> F = vaddq_f32(a, b);
    fn sub(a: F, b: F) -> F = vsubq_f32(a, b);
    fn mul(a: F, b: F) -> F = vmulq_f32(a, b);
    fn div(a: F, b: F) -> F = vdivq_f32(a, b);
    /// The first four values of `s`.
    fn load(s: &[f32]) -> F = vld1q_f32(s[..W].as_ptr());
    fn store(s: &mut [f32], v: F) = vst1q_f32(s[..W].as_mut_ptr(), v);
    fn lt(a: F, b: F) -> M = vcltq_f32(a, b);
    fn gt(a: F, b: F) -> M = vcgtq_f32(a, b);
    fn ge(a: F, b: F) -> M = vcgeq_f32(a, b);
    fn nan(a: F) -> M = vmvnq_u32(vceqq_f32(a, a));
    fn sel(m: M, a: F, b: F) -> F = vbslq_f32(m, a, b);
    fn trunc(a: F) -> I = vcvtq_s32_f32(a);
    fn itof(a: I) -> F = vcvtq_f32_s32(a);
    /// `⌊g⌋` and `g − ⌊g⌋` (rounded down exactly, then converted).
    fn floor(g: F) -> (I, F) = {
        let f = vrndmq_f32(g);
        (vcvtq_s32_f32(f), vsubq_f32(g, f))
    };
    fn isplat(x: i32) -> I = vdupq_n_s32(x);
    fn iadd(a: I, b: I) -> I = vaddq_s32(a, b);
    fn isub(a: I, b: I) -> I = vsubq_s32(a, b);
    fn imul(a: I, b: I) -> I = vmulq_s32(a, b);
    fn ilt(a: I, b: I) -> M = vcltq_s32(a, b);
    fn igt(a: I, b: I) -> M = vcgtq_s32(a, b);
    fn ieq(a: I, b: I) -> M = vceqq_s32(a, b);
    fn isel(m: M, a: I, b: I) -> I = vbslq_s32(m, a, b);
    fn imin(a: I, b: I) -> I = vminq_s32(a, b);
    fn ule(a: I, b: I) -> M = vcleq_u32(vreinterpretq_u32_s32(a), vreinterpretq_u32_s32(b));
    fn and(a: M, b: M) -> M = vandq_u32(a, b);
    fn or(a: M, b: M) -> M = vorrq_u32(a, b);
    fn none() -> M = vdupq_n_u32(0);
    fn bits(m: M) -> u32 = (vgetq_lane_u32::<0>(m) & 1)
        | (vgetq_lane_u32::<1>(m) & 2)
        | (vgetq_lane_u32::<2>(m) & 4)
        | (vgetq_lane_u32::<3>(m) & 8);
    /// The four lanes.
    fn lanes(v: I) -> [i32; 4] = [
        vgetq_lane_s32::<0>(v),
        vgetq_lane_s32::<1>(v),
        vgetq_lane_s32::<2>(v),
        vgetq_lane_s32::<3>(v),
    ];
}

/// Nothing to plan: every corner is loaded.
type Plan = ();

#[inline(always)]
fn plan(_: usize, _: [I; 4], _: [I; 2], _: Option<[i32; 4]>) -> Plan {}

/// The corners `data[rows[r] + x[c]]`, by plain (checked) loads.
#[inline(always)]
fn fetch(data: &[f32], _: Plan, rows: [I; 4], x: [I; 2]) -> [[F; 2]; 4] {
    rows.map(|r| {
        x.map(|x| {
            let at = lanes(iadd(r, x));
            load(&at.map(|i| data[i as usize]))
        })
    })
}

kernel!();
