//! The kernel in eight AVX2 lanes. The corners of a stencil come out of
//! windows of sixteen consecutive values of a lattice row (two loads for
//! x0 and two for x1, picked by `vpermps`), found once in the first corner
//! row and shifted to the others; the lanes no window holds, by gathers.

use std::arch::x86_64::*;

/// Lanes per vector.
const W: usize = 8;
/// Whether the grid sweeps take two groups at a time, their chains
/// interleaved.
const PAIRS: bool = true;
type F = __m256;
type I = __m256i;
/// All ones in the lanes set.
type M = __m256i;
/// An offset into a window and its upper-half blend mask ([`offset`]).
type Offset = (I, F);

prims! {
    fn splat(x: f32) -> F = _mm256_set1_ps(x);
    fn iota() -> F = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
    fn add(a: F, b: F) -> F = _mm256_add_ps(a, b);
    fn sub(a: F, b: F) -> F = _mm256_sub_ps(a, b);
    fn mul(a: F, b: F) -> F = _mm256_mul_ps(a, b);
    fn div(a: F, b: F) -> F = _mm256_div_ps(a, b);
    /// The first eight values of `s`.
    fn load(s: &[f32]) -> F = _mm256_loadu_ps(s[..W].as_ptr());
    fn store(s: &mut [f32], v: F) = _mm256_storeu_ps(s[..W].as_mut_ptr(), v);
    fn lt(a: F, b: F) -> M = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_LT_OQ>(a, b));
    fn gt(a: F, b: F) -> M = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(a, b));
    fn ge(a: F, b: F) -> M = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GE_OQ>(a, b));
    fn nan(a: F) -> M = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_UNORD_Q>(a, a));
    fn sel(m: M, a: F, b: F) -> F = _mm256_blendv_ps(b, a, _mm256_castsi256_ps(m));
    fn trunc(a: F) -> I = _mm256_cvttps_epi32(a);
    fn itof(a: I) -> F = _mm256_cvtepi32_ps(a);
    /// `⌊g⌋` and `g − ⌊g⌋` (rounded down exactly, then converted).
    fn floor(g: F) -> (I, F) = {
        let f = _mm256_round_ps::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(g);
        (_mm256_cvttps_epi32(f), _mm256_sub_ps(g, f))
    };
    fn isplat(x: i32) -> I = _mm256_set1_epi32(x);
    fn iadd(a: I, b: I) -> I = _mm256_add_epi32(a, b);
    fn isub(a: I, b: I) -> I = _mm256_sub_epi32(a, b);
    fn imul(a: I, b: I) -> I = _mm256_mullo_epi32(a, b);
    fn ilt(a: I, b: I) -> M = _mm256_cmpgt_epi32(b, a);
    fn igt(a: I, b: I) -> M = _mm256_cmpgt_epi32(a, b);
    fn ieq(a: I, b: I) -> M = _mm256_cmpeq_epi32(a, b);
    fn isel(m: M, a: I, b: I) -> I = _mm256_blendv_epi8(b, a, m);
    fn imin(a: I, b: I) -> I = _mm256_min_epi32(a, b);
    fn and(a: M, b: M) -> M = _mm256_and_si256(a, b);
    fn or(a: M, b: M) -> M = _mm256_or_si256(a, b);
    fn none() -> M = _mm256_setzero_si256();
    fn bits(m: M) -> u32 = _mm256_movemask_ps(_mm256_castsi256_ps(m)) as u32;
    fn ule(a: I, b: I) -> M = _mm256_cmpeq_epi32(_mm256_max_epu32(a, b), b);
    /// Lane 0.
    fn first(v: I) -> i32 = _mm256_cvtsi256_si32(v);
    /// Lane `l`.
    fn lane(v: I, l: u32) -> i32 = _mm256_cvtsi256_si32(_mm256_permutevar8x32_epi32(v, isplat(l as i32)));
    fn ior(a: I, b: I) -> I = _mm256_or_si256(a, b);
    /// Whether no lane has a bit of `mask`.
    fn none_of(v: I, mask: i32) -> bool = _mm256_testz_si256(v, isplat(mask)) == 1;
    /// Offsets `o` into a window with their upper halves (8–15: bit 3 in
    /// the sign bit).
    fn offset(o: I) -> Offset = (o, _mm256_castsi256_ps(_mm256_slli_epi32::<28>(o)));
    /// `v[o]` per lane, for offsets `o` of `0..16` into the sixteen values
    /// `lo, hi`, the upper half picked where the offset's is set.
    fn permute(lo: F, hi: F, o: Offset) -> F = _mm256_blendv_ps(
        _mm256_permutevar8x32_ps(lo, o.0),
        _mm256_permutevar8x32_ps(hi, o.0),
        o.1,
    );
    /// `m`'s lanes of `a`, the others of `b`.
    fn merge(m: M, a: F, b: F) -> F = _mm256_blendv_ps(b, a, _mm256_castsi256_ps(m));
    /// The lanes of `a` not in `b`.
    fn minus(a: M, b: M) -> M = _mm256_andnot_si256(b, a);
    fn all() -> M = _mm256_set1_epi32(-1);
    /// `data[at]` in the lanes of `lanes`, `v` in the others.
    ///
    /// # Panics
    /// If a lane of `lanes` is outside `data`.
    fn gather(v: F, data: &[f32], at: I, lanes: M) -> F = {
        let last = isplat(data.len().min(i32::MAX as usize) as i32 - 1);
        let outside = minus(lanes, ule(at, last));
        assert!(bits(outside) == 0, "trilinear corner outside the data");
        _mm256_mask_i32gather_ps::<4>(v, data.as_ptr(), at, _mm256_castsi256_ps(lanes))
    };
}

/// Values before a lane's corner that its window starts at: lanes up to
/// two values left of lane 0's x0, and up to thirteen right, share its
/// window.
const SLACK: i32 = 2;

/// Whether consecutive corners are loaded as they are.
const CONTIGUOUS_LOADS: bool = true;

/// Values of a window.
const WIDTH: usize = 16;

/// Eight values from `p`.
///
/// # Safety
/// `p .. p + 8` inside one allocation, on a CPU with AVX (the kernel's
/// entry points alone reach here, `prims!`).
#[inline(always)]
unsafe fn loadp(p: *const f32) -> F {
    _mm256_loadu_ps(p)
}

windows!(#[target_feature(enable = "avx2")]);
kernel!(#[target_feature(enable = "avx2")]);
