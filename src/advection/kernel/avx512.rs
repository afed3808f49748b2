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
    fn bits(m: M) -> u32 = u32::from(m);
    fn ule(a: I, b: I) -> M = _mm512_cmple_epu32_mask(a, b);
    /// Lane 0.
    fn first(v: I) -> i32 = _mm_cvtsi128_si32(_mm512_castsi512_si128(v));
    /// Lane `l`.
    fn lane(v: I, l: u32) -> i32 = _mm_cvtsi128_si32(_mm512_castsi512_si128(
        _mm512_permutexvar_epi32(isplat(l as i32), v),
    ));
    /// `v[o]` per lane from the 32 values `lo, hi`.
    fn permute(lo: F, hi: F, o: I) -> F = _mm512_permutex2var_ps(lo, o, hi);
    /// `m`'s lanes of `a`, the others of `b`.
    fn merge(m: M, a: F, b: F) -> F = _mm512_mask_mov_ps(b, m, a);
    /// `data[at]` in the lanes of `lanes`, `v` in the others.
    ///
    /// # Panics
    /// If a lane of `lanes` is outside `data`.
    fn gather(v: F, data: &[f32], at: I, lanes: M) -> F = {
        let last = isplat(data.len().min(i32::MAX as usize) as i32 - 1);
        assert!(lanes & !ule(at, last) == 0, "trilinear corner outside the data");
        _mm512_mask_i32gather_ps::<4>(v, lanes, at, data.as_ptr())
    };
}

/// Windows tried per stencil before the lanes left are gathered.
const WINDOWS: usize = 3;

/// Values before a lane's corner that its window starts at.
const SLACK: i32 = 8;

/// Every lane.
const FULL: u32 = 0xffff;

/// Whether consecutive corners are loaded as they are: on the AVX-512
/// machine measured, sixteen lanes through a window were as fast.
const CONTIGUOUS_LOADS: bool = false;

/// [`Plan::windows`] of a stencil whose lanes' corners are consecutive.
const CONTIGUOUS: u8 = 3;

/// Values of a window.
const WIDTH: usize = 32;

/// How a stencil's corners are fetched. When every lane's corner rows are
/// the first one's shifted by `shifts` and one window of the first row
/// (from `start[0]`) holds every lane's x0 and x1, or two do (the second
/// from `start[1]` holding the x0 of the lanes `second[0]` and the x1 of
/// `second[1]`: the lanes of a group fall in two lattice rows where the
/// flow's floor changes along it, and a lane's x0 and x1 lie at either
/// end of a row at a periodic seam), through them (`windows` 1 or 2);
/// otherwise (`windows` 0) [`fetch_split`].
#[derive(Clone, Copy)]
struct Plan {
    shifts: Option<[usize; 4]>,
    start: [usize; 2],
    second: [M; 2],
    windows: u8,
}

/// The windows of a stencil on a lattice of `len` values: from [`SLACK`]
/// before lane 0's x0, and if that does not hold every lane's corners,
/// from [`SLACK`] before the first corner it does not hold.
#[inline(always)]
fn plan(len: usize, rows: [I; 4], x: [I; 2], shifts: Option<[i32; 4]>) -> Plan {
    let shifts = shifts.map(|s| s.map(|s| s as usize));
    let mut plan = Plan {
        shifts,
        start: [0; 2],
        second: [0; 2],
        windows: 0,
    };
    let Some(rows_on) = shifts else {
        return plan;
    };
    let at = [iadd(rows[0], x[0]), iadd(rows[0], x[1])];
    // The usual case: lane l's x0 and x1 at lane 0's plus l (the lanes'
    // floors along x step with them), contiguous loads.
    let base = first(at[0]);
    let lane_ids = trunc(iota());
    let contiguous = and(
        ieq(isub(at[0], lane_ids), isplat(base)),
        ieq(isub(at[1], lane_ids), isplat(base + 1)),
    );
    if CONTIGUOUS_LOADS
        && bits(contiguous) == FULL
        && base >= 0
        && base as usize + rows_on[3] + W < len
    {
        (plan.start[0], plan.windows) = (base as usize, CONTIGUOUS);
        return plan;
    }
    let reach = rows_on[3] + WIDTH;
    if reach > len {
        return plan;
    }
    let last = (len - reach).min(i32::MAX as usize) as i32;
    let start = (base - SLACK).clamp(0, last);
    let one = held(at, start);
    plan.start[0] = start as usize;
    if one == [0xffff; 2] {
        plan.windows = 1;
        return plan;
    }
    let c = usize::from(one[0] == 0xffff);
    let second = (lane(at[c], (!one[c]).trailing_zeros()) - SLACK).clamp(0, last);
    let two = held(at, second);
    if (one[0] | two[0]) & (one[1] | two[1]) == 0xffff {
        (plan.start[1], plan.second, plan.windows) = (second as usize, [!one[0], !one[1]], 2);
    }
    plan
}

/// The lanes whose x0 and whose x1 (`at`) the window from `start` holds.
#[inline(always)]
fn held(at: [I; 2], start: i32) -> [M; 2] {
    let (from, last) = (isplat(start), isplat(WIDTH as i32 - 1));
    [ule(isub(at[0], from), last), ule(isub(at[1], from), last)]
}

/// The offsets from `start` of the stencil's x0 and x1 in its first row.
#[inline(always)]
fn offsets(row: I, x: [I; 2], start: usize) -> [I; 2] {
    let at = isub(row, isplat(start as i32));
    [iadd(at, x[0]), iadd(at, x[1])]
}

/// The corners `data[rows[r] + x[c]]` of a stencil's four rows: through
/// `plan`'s windows in the usual case (two loads and two permutes a row
/// and window), else [`fetch_split`].
///
/// # Panics
/// If a window or a gathered lane lies outside `data`.
#[inline(always)]
fn fetch(data: &[f32], plan: Plan, rows: [I; 4], x: [I; 2]) -> [[F; 2]; 4] {
    let Some(shifts) = plan.shifts.filter(|_| plan.windows > 0) else {
        // (With `shifts`, only the first row is read.)
        let rows = match plan.shifts {
            Some(_) => [rows[0]; 4],
            None => rows,
        };
        // SAFETY: reached only from the kernel's AVX-512 entry points (see
        // `prims!`).
        return unsafe { fetch_split(data, plan.shifts, rows, x) };
    };
    let [first, second] = plan.start;
    if plan.windows == CONTIGUOUS {
        assert!(
            first + shifts[3] + W < data.len(),
            "trilinear corners outside the data"
        );
        let mut v = [[splat(0.0); 2]; 4];
        for (v, s) in v.iter_mut().zip(shifts) {
            // SAFETY: the rows' W + 1 values from `first` end inside
            // (asserted), and the kernel's AVX-512 entry points alone
            // reach here (`prims!`).
            *v = unsafe {
                let p = data.as_ptr().add(first + s);
                [_mm512_loadu_ps(p), _mm512_loadu_ps(p.add(1))]
            };
        }
        return v;
    }
    let reach = first.max(second) + shifts[3] + WIDTH;
    assert!(reach <= data.len(), "trilinear window outside the data");
    let window = |start: usize, o: [I; 2]| {
        // SAFETY: every window of the plan ends by `reach` (asserted), and
        // the kernel's AVX-512 entry points alone reach here (`prims!`).
        let (lo, hi) = unsafe {
            let p = data.as_ptr().add(start);
            (_mm512_loadu_ps(p), _mm512_loadu_ps(p.add(16)))
        };
        [permute(lo, hi, o[0]), permute(lo, hi, o[1])]
    };
    let mut v = [[splat(0.0); 2]; 4];
    let o = offsets(rows[0], x, first);
    if plan.windows == 1 {
        for (v, s) in v.iter_mut().zip(shifts) {
            *v = window(first + s, o);
        }
    } else {
        let o2 = offsets(rows[0], x, second);
        for (v, s) in v.iter_mut().zip(shifts) {
            let [a, b] = window(first + s, o);
            let [c, d] = window(second + s, o2);
            *v = [merge(plan.second[0], c, a), merge(plan.second[1], d, b)];
        }
    }
    v
}

/// Windows of a row and the lanes they hold: `count` windows, window `n`
/// from `start[n]` holding the x0 and x1 of the lanes `lanes[n]`; the
/// lanes `left` are gathered.
struct Windows {
    start: [usize; WINDOWS],
    lanes: [[M; 2]; WINDOWS],
    count: usize,
    left: [M; 2],
}

impl Windows {
    /// Windows for the corners `at`, each from [`SLACK`] before the first
    /// corner not yet held (an x0, then an x1: a lane's two corners lie in
    /// different windows at a periodic seam), up to [`WINDOWS`], none
    /// starting after `last`.
    #[inline(always)]
    fn find(at: [I; 2], last: Option<i32>) -> Self {
        let mut w = Self {
            start: [0; WINDOWS],
            lanes: [[0; 2]; WINDOWS],
            count: 0,
            left: [0xffff; 2],
        };
        let Some(last) = last else {
            return w;
        };
        while w.count < WINDOWS && (w.left[0] | w.left[1]) != 0 {
            let c = usize::from(w.left[0] == 0);
            let first = lane(at[c], w.left[c].trailing_zeros());
            let start = (first - SLACK).clamp(0, last);
            let from = isplat(start);
            let held = [
                w.left[0] & ule(isub(at[0], from), isplat(31)),
                w.left[1] & ule(isub(at[1], from), isplat(31)),
            ];
            if held == [0, 0] {
                break;
            }
            w.start[w.count] = start as usize;
            w.lanes[w.count] = held;
            w.count += 1;
            w.left = [w.left[0] & !held[0], w.left[1] & !held[1]];
        }
        w
    }

    /// The corners `at` (of the row the windows were found in) of the row
    /// `shift` on.
    ///
    /// # Panics
    /// If a window or a gathered lane lies outside `data`.
    #[inline(always)]
    fn fetch(&self, data: &[f32], shift: usize, at: [I; 2]) -> [F; 2] {
        let mut v = [splat(0.0); 2];
        for n in 0..self.count {
            let start = self.start[n];
            let d = &data[start + shift..start + shift + WIDTH];
            let (lo, hi) = (load(d), load(&d[16..]));
            let from = isplat(start as i32);
            v[0] = merge(self.lanes[n][0], permute(lo, hi, isub(at[0], from)), v[0]);
            v[1] = merge(self.lanes[n][1], permute(lo, hi, isub(at[1], from)), v[1]);
        }
        for c in 0..2 {
            if self.left[c] != 0 {
                let a = iadd(at[c], isplat(shift as i32));
                v[c] = gather(v[c], data, a, self.left[c]);
            }
        }
        v
    }
}

/// [`fetch`] for stencils that one window does not hold: windows found in
/// the first row and shifted to the others by `shifts`, or, when the rows
/// differ across lanes (`shifts` `None`: wrapped or clamped along y or z),
/// each row's own; gathers for the rest ([`Windows`]).
#[inline(never)]
#[target_feature(enable = "avx512f")]
fn fetch_split(data: &[f32], shifts: Option<[usize; 4]>, rows: [I; 4], x: [I; 2]) -> [[F; 2]; 4] {
    let mut v = [[splat(0.0); 2]; 4];
    let last = |reach: usize| {
        (data.len() >= reach).then(|| (data.len() - reach).min(i32::MAX as usize) as i32)
    };
    match shifts {
        Some(shifts) => {
            let at = [iadd(rows[0], x[0]), iadd(rows[0], x[1])];
            let w = Windows::find(at, last(shifts[3] + WIDTH));
            for (v, s) in v.iter_mut().zip(shifts) {
                *v = w.fetch(data, s, at);
            }
        }
        None => {
            for (v, r) in v.iter_mut().zip(rows) {
                let at = [iadd(r, x[0]), iadd(r, x[1])];
                *v = Windows::find(at, last(WIDTH)).fetch(data, 0, at);
            }
        }
    }
    v
}

kernel!(#[target_feature(enable = "avx512f")]);
