//! The kernel in sixteen AVX-512F lanes. The corners of a stencil come
//! out of windows of 32 consecutive values of a lattice row (two loads,
//! one two-source permute per corner and row): the first from eight
//! before lane 0's x0, further ones from the first lane not yet held (the
//! lanes of a group fall in one or two lattice rows, split where the
//! flow's floor changes along the row), found once in the first corner
//! row and shifted to the others; the rest by masked gathers.

use std::arch::x86_64::*;

/// Lanes per vector.
const W: usize = 16;
/// Whether the grid sweeps take two groups at a time, their chains
/// interleaved.
const PAIRS: bool = false;
type F = __m512;
type I = __m512i;
type M = __mmask16;
/// An offset into a window ([`offset`]).
type Offset = I;

prims! {
    fn splat(x: f32) -> F = _mm512_set1_ps(x);
    fn iota() -> F = _mm512_setr_ps(
        0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0, 15.0,
    );
    fn add(a: F, b: F) -> F = _mm512_add_ps(a, b);
    fn sub(a: F, b: F) -> F = _mm512_sub_ps(a, b);
    fn mul(a: F, b: F) -> F = _mm512_mul_ps(a, b);
    fn div(a: F, b: F) -> F = _mm512_div_ps(a, b);
    /// The first sixteen values of `s`.
    fn load(s: &[f32]) -> F = _mm512_loadu_ps(s[..W].as_ptr());
    fn store(s: &mut [f32], v: F) = _mm512_storeu_ps(s[..W].as_mut_ptr(), v);
    fn lt(a: F, b: F) -> M = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(a, b);
    fn gt(a: F, b: F) -> M = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(a, b);
    fn ge(a: F, b: F) -> M = _mm512_cmp_ps_mask::<_CMP_GE_OQ>(a, b);
    fn nan(a: F) -> M = _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(a, a);
    fn sel(m: M, a: F, b: F) -> F = _mm512_mask_blend_ps(m, b, a);
    fn trunc(a: F) -> I = _mm512_cvttps_epi32(a);
    fn itof(a: I) -> F = _mm512_cvtepi32_ps(a);
    /// `⌊g⌋` and `g − ⌊g⌋` (rounded down exactly, then converted).
    fn floor(g: F) -> (I, F) = {
        let f = _mm512_roundscale_ps::<{ _MM_FROUND_TO_NEG_INF | _MM_FROUND_NO_EXC }>(g);
        (_mm512_cvttps_epi32(f), _mm512_sub_ps(g, f))
    };
    fn isplat(x: i32) -> I = _mm512_set1_epi32(x);
    fn iadd(a: I, b: I) -> I = _mm512_add_epi32(a, b);
    fn isub(a: I, b: I) -> I = _mm512_sub_epi32(a, b);
    fn imul(a: I, b: I) -> I = _mm512_mullo_epi32(a, b);
    fn ilt(a: I, b: I) -> M = _mm512_cmplt_epi32_mask(a, b);
    fn igt(a: I, b: I) -> M = _mm512_cmpgt_epi32_mask(a, b);
    fn ieq(a: I, b: I) -> M = _mm512_cmpeq_epi32_mask(a, b);
    fn isel(m: M, a: I, b: I) -> I = _mm512_mask_blend_epi32(m, b, a);
    fn imin(a: I, b: I) -> I = _mm512_min_epi32(a, b);
    fn and(a: M, b: M) -> M = a & b;
    fn or(a: M, b: M) -> M = a | b;
    fn none() -> M = 0;
    fn all() -> M = 0xffff;
    /// The lanes of `a` not in `b`.
    fn minus(a: M, b: M) -> M = a & !b;
    fn bits(m: M) -> u32 = u32::from(m);
    fn ule(a: I, b: I) -> M = _mm512_cmple_epu32_mask(a, b);
    /// Lane 0.
    fn first(v: I) -> i32 = _mm_cvtsi128_si32(_mm512_castsi512_si128(v));
    /// Lane `l`.
    fn lane(v: I, l: u32) -> i32 = _mm_cvtsi128_si32(_mm512_castsi512_si128(
        _mm512_permutexvar_epi32(isplat(l as i32), v),
    ));
    fn ior(a: I, b: I) -> I = _mm512_or_si512(a, b);
    /// Whether no lane has a bit of `mask`.
    fn none_of(v: I, mask: i32) -> bool = _mm512_test_epi32_mask(v, isplat(mask)) == 0;
    /// Offsets into a window, as they are.
    fn offset(o: I) -> Offset = o;
    /// `v[o]` per lane from the 32 values `lo, hi`.
    fn permute(lo: F, hi: F, o: Offset) -> F = _mm512_permutex2var_ps(lo, o, hi);
    /// `m`'s lanes of `a`, the others of `b`.
    fn merge(m: M, a: F, b: F) -> F = _mm512_mask_mov_ps(b, m, a);
    /// `data[at]` in the lanes of `lanes`, `v` in the others.
    ///
    /// # Panics
    /// If a lane of `lanes` is outside `data`.
    fn gather(v: F, data: &[f32], at: I, lanes: M) -> F = {
        let last = isplat(data.len().min(i32::MAX as usize) as i32 - 1);
        assert!(minus(lanes, ule(at, last)) == 0, "trilinear corner outside the data");
        _mm512_mask_i32gather_ps::<4>(v, lanes, at, data.as_ptr())
    };
}

/// Values before a lane's corner that its window starts at.
const SLACK: i32 = 8;

/// Whether consecutive corners are loaded as they are: on the AVX-512
/// machine measured, sixteen lanes through a window were as fast.
const CONTIGUOUS_LOADS: bool = false;

/// Values of a window.
const WIDTH: usize = 32;

/// Sixteen values from `p`.
///
/// # Safety
/// `p .. p + 16` inside one allocation, on a CPU with AVX-512F (the
/// kernel's entry points alone reach here, `prims!`).
#[inline(always)]
unsafe fn loadp(p: *const f32) -> F {
    _mm512_loadu_ps(p)
}

windows!(#[target_feature(enable = "avx512f")]);
kernel!(#[target_feature(enable = "avx512f")]);
