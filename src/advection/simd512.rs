//! AVX-512 kernels of the semi-Lagrangian sweeps (eqs 6.4–6.5): the AVX2
//! kernels of [`super::simd`] in sixteen lanes, with the trilinear corners
//! fetched by row windows instead of gathers where the lanes allow.
//!
//! - The grid sweeps: sixteen consecutive faces of one x-row ([`faces16`])
//!   or sixteen cell centres ([`cells16`]) traced back together (Euler or
//!   RK2) and interpolated at their departure points ([`faces16`],
//!   [`sample16`]; several densities at the same points through shared
//!   corners, [`sample16_grids`]); the faces and the densities two groups
//!   at a time, their interpolations interleaved; stencils inside their
//!   lattice by [`trilinear16`], others wrapped or clamped by
//!   [`stencil16`].
//! - Arbitrary points: [`points16`], one backward step of the gridless walk
//!   and SELMA's map.
//!
//! Points traced back from neighbouring cells of one row mostly fall in one
//! or two lattice rows (the floors of their y and z differ only where the
//! flow changes sign along the row), and along x within a few cells of
//! their origin. A [`Window`] of 32 consecutive values of one lattice row,
//! fetched by two loads and picked by two permutes, then holds the x0 and
//! x1 corners of every lane in that row. [`trilinear16`] groups the lanes
//! by row, a window each (up to [`WINDOWS`]); lanes left over, and wrapped
//! stencils whose lanes span rows, take 64-bit pair gathers, except a
//! wrapped stencil's lanes at the x edge, whose two x-corners are not
//! adjacent: those are loaded one by one ([`x_corners16`]).
//!
//! Every lane does the scalar sweep's floating-point operations in the same
//! order (products and sums, no fused multiply-add): the results are the
//! scalar path's, and the AVX2 kernels', to the bit. Lanes the kernels
//! cannot do (stencils outside the lattice for the unwrapped kernels;
//! points more than a period outside, NaN) are reported to the caller,
//! which does them by the scalar path.

use std::arch::x86_64::*;

use glam::Vec3;

use super::simd::Lattices;
use super::Backtrace;
use crate::grid::Wrap;

/// How many lattice rows of a group of sixteen [`trilinear16`] fetches by
/// windows; the lanes of any further rows are gathered.
const WINDOWS: usize = 3;

/// Whether this CPU has AVX-512F; the callers fall back to the AVX2
/// kernels otherwise.
pub(crate) fn has_avx512() -> bool {
    is_x86_feature_detected!("avx512f")
}

/// `⌊g⌋` per lane (0 where it is outside) and `g − ⌊g⌋`, and the lanes
/// where `0 ≤ ⌊g⌋ ≤ n − 2` (`simd::floor_inside8` in sixteen lanes).
#[inline]
#[target_feature(enable = "avx512f")]
fn floor_inside16(g: __m512, n: usize) -> (__m512i, __m512, __mmask16) {
    let t = _mm512_cvttps_epi32(g);
    // −1 where the truncation rounded up (negative non-integers).
    let up = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(_mm512_cvtepi32_ps(t), g);
    let f = _mm512_mask_sub_epi32(t, up, t, _mm512_set1_epi32(1));
    let frac = _mm512_sub_ps(g, _mm512_cvtepi32_ps(f));
    let ok = _mm512_cmpge_epi32_mask(f, _mm512_setzero_si512())
        & _mm512_cmplt_epi32_mask(f, _mm512_set1_epi32(n as i32 - 1));
    (_mm512_maskz_mov_epi32(ok, f), frac, ok)
}

/// Lane 0 of `v`.
#[inline]
#[target_feature(enable = "avx512f")]
fn first(v: __m512i) -> i32 {
    _mm_cvtsi128_si32(_mm512_castsi512_si128(v))
}

/// The weights `(1 − t, t)` of the two corners along one axis.
#[inline]
#[target_feature(enable = "avx512f")]
fn weights(t: __m512) -> [__m512; 2] {
    [_mm512_sub_ps(_mm512_set1_ps(1.0), t), t]
}

/// `acc[n] + Σ_cx w_x[cx]·w_y·w_z·v[n][cx]` for each of `N` grids: one
/// corner row's two corners added to each grid's trilinear sum, in the
/// scalar order (weight product first), each weight product found once.
#[inline]
#[target_feature(enable = "avx512f")]
fn add_rows<const N: usize>(
    acc: [__m512; N],
    wx: [__m512; 2],
    wy: __m512,
    wz: __m512,
    v: [[__m512; 2]; N],
) -> [__m512; N] {
    let mut acc = acc;
    for (cx, wx) in wx.into_iter().enumerate() {
        let weight = _mm512_mul_ps(_mm512_mul_ps(wx, wy), wz);
        for (acc, v) in acc.iter_mut().zip(&v) {
            *acc = _mm512_add_ps(*acc, _mm512_mul_ps(weight, v[cx]));
        }
    }
    acc
}

/// The x0 and x1 corners `data[at]`, `data[at + 1]` of sixteen lanes (those
/// of `lanes`; the others zero): one 64-bit gather per eight lanes, split
/// by two permutes.
///
/// # Safety
/// Every lane of `lanes` has `0 ≤ at`, `at + 1 < data.len()`; the CPU has
/// AVX-512F.
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn x_pairs16(data: &[f32], at: __m512i, lanes: __mmask16) -> [__m512; 2] {
    let pairs = data.as_ptr().cast::<i64>();
    let zero = _mm512_setzero_si512();
    // SAFETY: as this function's; gathers need no alignment.
    let (low, high) = unsafe {
        (
            _mm512_mask_i32gather_epi64::<4>(zero, lanes as u8, _mm512_castsi512_si256(at), pairs),
            _mm512_mask_i32gather_epi64::<4>(
                zero,
                (lanes >> 8) as u8,
                _mm512_extracti64x4_epi64::<1>(at),
                pairs,
            ),
        )
    };
    let (low, high) = (_mm512_castsi512_ps(low), _mm512_castsi512_ps(high));
    let even = _mm512_setr_epi32(0, 2, 4, 6, 8, 10, 12, 14, 16, 18, 20, 22, 24, 26, 28, 30);
    let odd = _mm512_add_epi32(even, _mm512_set1_epi32(1));
    [
        _mm512_permutex2var_ps(low, even, high),
        _mm512_permutex2var_ps(low, odd, high),
    ]
}

/// The x0 and x1 corners `data[row + x0]`, `data[row + x1]` of sixteen
/// lanes: pairs gathered for the lanes of `pairs` (those whose x1 is
/// x0 + 1, [`x_pairs16`]), the others — a stencil wrapped or clamped at
/// the x edge, a few lanes of a group — loaded one by one. (Two 32-bit
/// gathers of all sixteen lanes whenever one lane was at the edge had been
/// about half the wrapping stencil's time, which was 43 % of a gridless
/// run's profile at 40³.)
///
/// # Safety
/// Every lane has `0 ≤ row + x0, row + x1 < data.len()`, and those of
/// `pairs` also `row + x0 + 1 < data.len()`; the CPU has AVX-512F.
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn x_corners16(
    data: &[f32],
    row: __m512i,
    x: [__m512i; 2],
    pairs: __mmask16,
) -> [__m512; 2] {
    let at = x.map(|x| _mm512_add_epi32(row, x));
    // SAFETY: as this function's.
    let mut v = unsafe { x_pairs16(data, at[0], pairs) };
    let edge = !pairs;
    if edge == 0 {
        return v;
    }
    let mut index = [0i32; 32];
    // SAFETY: `index` holds two vectors of sixteen lanes.
    unsafe {
        _mm512_storeu_si512(index.as_mut_ptr().cast(), at[0]);
        _mm512_storeu_si512(index.as_mut_ptr().add(16).cast(), at[1]);
    }
    for l in (0..16).filter(|l| edge & (1 << l) != 0) {
        let lane = 1 << l;
        for (c, v) in v.iter_mut().enumerate() {
            let value = data[index[16 * c + l] as usize];
            *v = _mm512_mask_mov_ps(*v, lane, _mm512_set1_ps(value));
        }
    }
    v
}

/// 32 consecutive values of one lattice row that hold the x0 and x1
/// corners of some lanes (and, at fixed offsets, those of further corner
/// rows).
#[derive(Clone, Copy)]
struct Window {
    /// Lattice index of its first value.
    start: usize,
    /// The lanes it holds.
    lanes: __mmask16,
    /// Each lane's x0 and x1 as offsets into the window (meaningless for
    /// lanes it does not hold).
    offsets: [__m512i; 2],
}

impl Window {
    /// The window of lattice row `r` starting eight values before `x0` (at
    /// most at the row's start), holding the lanes of `candidates` whose
    /// row (of `rows`) is `r` and whose x0 and x1 (of `xs`) fall in it; or
    /// `None` if, `last_shift` values on, it would end beyond a lattice of
    /// `len` values.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn new(
        len: usize,
        (rows, xs): (__m512i, [__m512i; 2]),
        (r, x0): (i32, i32),
        candidates: __mmask16,
        last_shift: usize,
    ) -> Option<Self> {
        let base = (x0 - 8).max(0);
        let start = (r + base) as usize;
        if start + last_shift + 32 > len {
            return None;
        }
        let offsets = xs.map(|x| _mm512_sub_epi32(x, _mm512_set1_epi32(base)));
        let fits = |o: __m512i| _mm512_cmplt_epu32_mask(o, _mm512_set1_epi32(32));
        let lanes = candidates
            & _mm512_cmpeq_epi32_mask(rows, _mm512_set1_epi32(r))
            & fits(offsets[0])
            & fits(offsets[1]);
        Some(Self {
            start,
            lanes,
            offsets,
        })
    }

    /// The x0 and x1 values of its lanes in the row `shift` values on: two
    /// loads, two permutes.
    ///
    /// # Safety
    /// `shift` is at most the `last_shift` the window was made with, and
    /// `data` has the `len` it was made with; the CPU has AVX-512F.
    #[inline]
    #[target_feature(enable = "avx512f")]
    unsafe fn fetch(&self, data: &[f32], shift: usize) -> [__m512; 2] {
        // SAFETY: the 32 values from `start + shift` end inside (`new`).
        let (a, b) = unsafe {
            let p = data.as_ptr().add(self.start + shift);
            (_mm512_loadu_ps(p), _mm512_loadu_ps(p.add(16)))
        };
        self.offsets.map(|o| _mm512_permutex2var_ps(a, o, b))
    }
}

/// The stencil of sixteen lanes on a lattice `d`, as [`trilinear16`] finds
/// it: each lane's first corner row (the others are `shifts` on), its x0
/// and x1, the weights along each axis, and the lanes whose stencil lies
/// inside the lattice (the rest meaningless).
#[derive(Clone, Copy)]
struct Corners {
    ok: __mmask16,
    row: __m512i,
    xs: [__m512i; 2],
    shifts: [usize; 4],
    w: [[__m512; 2]; 3],
}

impl Corners {
    /// The stencil of lattice coordinates `g` on lattice `d`.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn new(d: [usize; 3], g: [__m512; 3]) -> Self {
        let (x, tx, okx) = floor_inside16(g[0], d[0]);
        let (y, ty, oky) = floor_inside16(g[1], d[1]);
        let (z, tz, okz) = floor_inside16(g[2], d[2]);
        let (nx, nxy) = (d[0] as i32, (d[0] * d[1]) as i32);
        let row = _mm512_mullo_epi32(
            _mm512_add_epi32(_mm512_mullo_epi32(z, _mm512_set1_epi32(d[1] as i32)), y),
            _mm512_set1_epi32(nx),
        );
        Self {
            ok: okx & oky & okz,
            row,
            xs: [x, _mm512_add_epi32(x, _mm512_set1_epi32(1))],
            shifts: [0, nx as usize, nxy as usize, (nx + nxy) as usize],
            w: [weights(tx), weights(ty), weights(tz)],
        }
    }

    /// The usual case: every lane inside, in lane 0's row and one
    /// [`Window`] of a lattice of `len` values.
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn one_window(&self, len: usize) -> Option<Window> {
        if self.ok != 0xffff {
            return None;
        }
        let at = (first(self.row), first(self.xs[0]));
        Window::new(len, (self.row, self.xs), at, 0xffff, self.shifts[3])
            .filter(|w| w.lanes == 0xffff)
    }

    /// `acc` plus corner row `c`'s two corners `v` ([`add_rows`]).
    #[inline]
    #[target_feature(enable = "avx512f")]
    fn add_row<const N: usize>(
        &self,
        acc: [__m512; N],
        c: usize,
        v: [[__m512; 2]; N],
    ) -> [__m512; N] {
        add_rows(acc, self.w[0], self.w[1][c & 1], self.w[2][c >> 1], v)
    }
}

/// Trilinear interpolation of `N` grids laid out like one lattice `d`
/// (`datas`, of one length) at lattice coordinates `g` in sixteen lanes,
/// and the lanes whose stencil lies inside the lattice; if any lane's does
/// not, the values are meaningless (the caller redoes the group by the
/// wrapping path). Corners, weights and sum in `simd::trilinear8`'s order
/// (the scalar `trilinear_inside`'s) for each grid; the floors, windows
/// and weights are found once for all of them ([`Corners`]).
///
/// # Safety
/// Every `data.len() ≥ mx·my·mz < 2³⁰` and equal, every `m ≥ 2`
/// (`simd::lattices`), and the CPU has AVX-512F.
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn trilinear16<const N: usize>(
    datas: [&[f32]; N],
    d: [usize; 3],
    g: [__m512; 3],
) -> ([__m512; N], __mmask16) {
    let k = Corners::new(d, g);
    let ok = k.ok;
    let mut acc = [_mm512_setzero_ps(); N];
    if ok != 0xffff {
        return (acc, ok);
    }
    let len = datas[0].len();
    let (row, xs, shifts) = (k.row, k.xs, k.shifts);
    let x = xs[0];
    if let Some(w) = k.one_window(len) {
        for (c, &shift) in shifts.iter().enumerate() {
            // SAFETY: `shift ≤ shifts[3]`, the window's `last_shift`; every
            // grid has its length.
            // Loops, not `datas.map(..)`: a closure is not inlined here
            // (it was 14 % of a gridless render's profile, called per grid).
            let mut v = [[_mm512_setzero_ps(); 2]; N];
            for (v, data) in v.iter_mut().zip(datas) {
                *v = unsafe { w.fetch(data, shift) };
            }
            acc = k.add_row(acc, c, v);
        }
        return (acc, ok);
    }
    // Otherwise a window for each of the first `WINDOWS` rows the lanes
    // fall in, and gathers for any lanes left.
    let (mut rows, mut x0s) = ([0i32; 16], [0i32; 16]);
    // SAFETY: each array holds sixteen i32.
    unsafe {
        _mm512_storeu_si512(rows.as_mut_ptr().cast(), row);
        _mm512_storeu_si512(x0s.as_mut_ptr().cast(), x);
    }
    let mut windows = [None; WINDOWS];
    let mut left = 0xffffu16;
    for w in &mut windows {
        let l = left.trailing_zeros() as usize;
        // Lane `l` is always in its own window (its x0 is at offset ≤ 8).
        *w = Window::new(len, (row, xs), (rows[l], x0s[l]), left, shifts[3]);
        left &= !w.map_or(0, |w| w.lanes);
        if w.is_none() || left == 0 {
            break;
        }
    }
    for (c, &shift) in shifts.iter().enumerate() {
        let mut v = [[_mm512_setzero_ps(); 2]; N];
        for (v, data) in v.iter_mut().zip(datas) {
            for w in windows.iter().flatten() {
                // SAFETY: `shift ≤ shifts[3]`, the window's `last_shift`.
                let [v0, v1] = unsafe { w.fetch(data, shift) };
                *v = [
                    _mm512_mask_mov_ps(v[0], w.lanes, v0),
                    _mm512_mask_mov_ps(v[1], w.lanes, v1),
                ];
            }
            if left != 0 {
                let at =
                    _mm512_add_epi32(_mm512_add_epi32(row, x), _mm512_set1_epi32(shift as i32));
                // SAFETY: every lane is inside (`ok`): x ≤ mx − 2, y ≤ my − 2,
                // z ≤ mz − 2, so the pair at its index in any corner row ends
                // inside `data`; indices are below 2³⁰.
                let [v0, v1] = unsafe { x_pairs16(data, at, left) };
                *v = [
                    _mm512_mask_mov_ps(v[0], left, v0),
                    _mm512_mask_mov_ps(v[1], left, v1),
                ];
            }
        }
        acc = k.add_row(acc, c, v);
    }
    (acc, ok)
}

/// `simd::axis8` in sixteen lanes (AVX-512), the lanes left to the scalar path
/// as a mask.
#[inline]
#[target_feature(enable = "avx512f")]
fn axis16(g: __m512, n: usize, wrap: Wrap) -> (__m512i, __m512i, __m512, __mmask16) {
    let ni = n as i32;
    let one = _mm512_set1_epi32(1);
    let (f, frac, i0, i1, bad) = match wrap {
        Wrap::Periodic => {
            let t = _mm512_cvttps_epi32(g);
            // −1 where the truncation rounded up (negative non-integers).
            let up = _mm512_cmp_ps_mask::<_CMP_GT_OQ>(_mm512_cvtepi32_ps(t), g);
            let f = _mm512_mask_sub_epi32(t, up, t, one);
            let n16 = _mm512_set1_epi32(ni);
            let below = _mm512_cmplt_epi32_mask(f, _mm512_setzero_si512());
            let above = _mm512_cmpgt_epi32_mask(f, _mm512_set1_epi32(ni - 1));
            let i0 = _mm512_mask_add_epi32(f, below, f, n16);
            let i0 = _mm512_mask_sub_epi32(i0, above, i0, n16);
            let i1 = _mm512_add_epi32(i0, one);
            let i1 =
                _mm512_mask_mov_epi32(i1, _mm512_cmpeq_epi32_mask(i1, n16), _mm512_setzero_si512());
            let bad = _mm512_cmplt_epi32_mask(f, _mm512_set1_epi32(-ni))
                | _mm512_cmpgt_epi32_mask(f, _mm512_set1_epi32(2 * ni - 1));
            (f, g, i0, i1, bad)
        }
        Wrap::Clamped => {
            // As `axis8`: `max(a, b)` is `a > b ? a : b`.
            let zero = _mm512_setzero_ps();
            let c = _mm512_min_ps(_mm512_set1_ps((n - 1) as f32), _mm512_max_ps(zero, g));
            let f = _mm512_cvttps_epi32(c);
            let i1 = _mm512_min_epi32(_mm512_add_epi32(f, one), _mm512_set1_epi32(ni - 1));
            (f, c, f, i1, _mm512_cmp_ps_mask::<_CMP_UNORD_Q>(g, g))
        }
    };
    let frac = _mm512_sub_ps(frac, _mm512_cvtepi32_ps(f));
    let i0 = _mm512_maskz_mov_epi32(!bad, i0);
    let i1 = _mm512_mask_mov_epi32(i1, bad, one);
    (i0, i1, frac, bad)
}

/// `simd::stencil8` in sixteen lanes: trilinear interpolation of `data`
/// (lattice `d`) at lattice coordinates `g`, wrapped or clamped as the
/// scalar [`crate::grid::Stencil`] with `wrap` (its corners, weights and
/// sum in its order), and the lanes left to the scalar path
/// ([`axis16`]). A corner row whose lanes all lie in one [`Window`] is
/// fetched by it, any other by gathers.
///
/// # Safety
/// As `simd::stencil8`, with AVX-512F.
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn stencil16(
    data: &[f32],
    d: [usize; 3],
    wrap: Wrap,
    g: [__m512; 3],
) -> (__m512, __mmask16) {
    let (x0, x1, tx, bx) = axis16(g[0], d[0], wrap);
    let (y0, y1, ty, by) = axis16(g[1], d[1], wrap);
    let (z0, z1, tz, bz) = axis16(g[2], d[2], wrap);
    let (mx, my) = (
        _mm512_set1_epi32(d[0] as i32),
        _mm512_set1_epi32(d[1] as i32),
    );
    let (y, z) = (
        [y0, y1],
        [_mm512_mullo_epi32(z0, my), _mm512_mullo_epi32(z1, my)],
    );
    let (wx, wy, wz) = (weights(tx), weights(ty), weights(tz));
    // Where a lane's x1 is x0 + 1 its two x-corners are adjacent in memory
    // (a pair); at a wrapped or clamped x edge they are not.
    let pairs = _mm512_cmpeq_epi32_mask(x1, _mm512_add_epi32(x0, _mm512_set1_epi32(1)));
    let mut acc = _mm512_setzero_ps();
    for c in 0..4 {
        let (cy, cz) = (c & 1, c >> 1);
        let row = _mm512_mullo_epi32(_mm512_add_epi32(z[cz], y[cy]), mx);
        let window = Window::new(data.len(), (row, [x0, x1]), (first(row), first(x0)), !0, 0);
        // SAFETY: every index is a lattice index (`axis16`: 0 ≤ x0, x1 < mx,
        // and so on; indices below 2³⁰, `simd::lattices`), so it and, for
        // the lanes of `pairs`, the next one (x0 ≤ mx − 2) are inside
        // `data`; a window ends inside (`Window::new`, shift 0).
        let v = unsafe {
            match window.filter(|w| w.lanes == 0xffff) {
                Some(w) => w.fetch(data, 0),
                None => x_corners16(data, row, [x0, x1], pairs),
            }
        };
        [acc] = add_rows([acc], wx, wy[cy], wz[cz], [v]);
    }
    (acc, bx | by | bz)
}

/// The velocity at sixteen points `g` (cell-centre grid coordinates):
/// component `a` trilinear on its lattice at `g + ½e_a`
/// (`FaceSampler::at`) — each component by [`interpolate16`]: through
/// [`trilinear16`] if every lane's stencil is inside its lattice, else
/// through [`stencil16`], wrapped or clamped by `wrap` — and the lanes it
/// computed (those [`stencil16`] leaves to the scalar path are not).
///
/// # Safety
/// The CPU has AVX-512F and `vel.dims` passes `simd::lattices`.
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn velocity16(vel: Lattices, wrap: Wrap, g: [__m512; 3]) -> ([__m512; 3], __mmask16) {
    let mut u = [_mm512_setzero_ps(); 3];
    let mut done = 0xffff;
    for (b, ub) in u.iter_mut().enumerate() {
        let mut p = g;
        p[b] = _mm512_add_ps(p[b], _mm512_set1_ps(0.5));
        // SAFETY: the lattice of b has vel.data[b]'s length (fits).
        let (v, lanes) = unsafe { interpolate16(vel.data[b], vel.dims[b], wrap, p) };
        *ub = v;
        done &= lanes as __mmask16;
    }
    (u, done)
}

/// [`velocity16`] at the RK2 midpoints of the grid sweeps' rows: the
/// components whose stencils all lie in one [`Window`]
/// ([`Corners::one_window`]; nine in ten on a 128³ sweep) interpolated
/// together, corner row by corner row, so that their three independent
/// chains of loads, permutes and sums overlap (one component after
/// another, a 128³ RK2 step's advection took about 10 % longer); the
/// others by [`interpolate16`]. The same operations per component. At
/// scattered points, where fewer stencils fit one window, the stencils
/// found for nothing cost more than the overlap gains (a gridless render
/// 16 % slower, the gridless walk at 40³ 5 %): they take [`velocity16`].
///
/// # Safety
/// As [`velocity16`].
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn velocity16_rows(vel: Lattices, wrap: Wrap, g: [__m512; 3]) -> ([__m512; 3], __mmask16) {
    // Plain loops and literals: closures do not take the target feature
    // (`array::from_fn`'s were not inlined here). A component left over
    // finds its stencil again in `interpolate16`: handing it these by
    // reference kept all three on the stack, and was slower.
    let mut points = [g; 3];
    for (b, p) in points.iter_mut().enumerate() {
        p[b] = _mm512_add_ps(p[b], _mm512_set1_ps(0.5));
    }
    let corners = [
        Corners::new(vel.dims[0], points[0]),
        Corners::new(vel.dims[1], points[1]),
        Corners::new(vel.dims[2], points[2]),
    ];
    let windows = [
        corners[0].one_window(vel.data[0].len()),
        corners[1].one_window(vel.data[1].len()),
        corners[2].one_window(vel.data[2].len()),
    ];
    let mut u = [_mm512_setzero_ps(); 3];
    for c in 0..4 {
        for b in 0..3 {
            if let Some(w) = &windows[b] {
                // SAFETY: `shifts[c] ≤ shifts[3]`, the window's
                // `last_shift`, on the lattice of b's length.
                let v = unsafe { w.fetch(vel.data[b], corners[b].shifts[c]) };
                [u[b]] = corners[b].add_row([u[b]], c, [v]);
            }
        }
    }
    let mut done = 0xffff;
    for b in 0..3 {
        if windows[b].is_none() {
            // SAFETY: the lattice of b has vel.data[b]'s length (fits).
            let (v, lanes) = unsafe { interpolate16(vel.data[b], vel.dims[b], wrap, points[b]) };
            u[b] = v;
            done &= lanes as __mmask16;
        }
    }
    (u, done)
}

/// Departure points of sixteen points `c` (grid coordinates) whose
/// velocities are `u0`, traced back through `vel` over `dt_cells = Δt/Δx`
/// (Euler or RK2) as the scalar `departure` does (its RK2 midpoint through
/// [`velocity16_rows`] for points of a grid row, `ROWS`, else
/// [`velocity16`]; stencils wrapped or clamped by `wrap`), and the lanes
/// it computed (none for RK3, which is left to the scalar path).
///
/// # Safety
/// The CPU has AVX-512F and `vel.dims` passes `simd::lattices`.
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn trace16<const ROWS: bool>(
    vel: Lattices,
    wrap: Wrap,
    c: [__m512; 3],
    u0: [__m512; 3],
    dt_cells: f32,
    backtrace: Backtrace,
) -> ([__m512; 3], __mmask16) {
    match backtrace {
        Backtrace::Euler => (back16(c, u0, dt_cells), 0xffff),
        Backtrace::Rk2 => {
            let mid = back16(c, u0, 0.5 * dt_cells);
            // SAFETY: as this function's.
            let (u1, done) = unsafe {
                match ROWS {
                    true => velocity16_rows(vel, wrap, mid),
                    false => velocity16(vel, wrap, mid),
                }
            };
            (back16(c, u1, dt_cells), done)
        }
        Backtrace::Rk3 => (c, 0),
    }
}

/// `c − s·u` per lane and component: a backtrace's step from `c` with
/// velocity `u` over `s` cells (the scalar `departure`'s operations).
#[inline]
#[target_feature(enable = "avx512f")]
fn back16(c: [__m512; 3], u: [__m512; 3], s: f32) -> [__m512; 3] {
    let s = _mm512_set1_ps(s);
    [
        _mm512_sub_ps(c[0], _mm512_mul_ps(s, u[0])),
        _mm512_sub_ps(c[1], _mm512_mul_ps(s, u[1])),
        _mm512_sub_ps(c[2], _mm512_mul_ps(s, u[2])),
    ]
}

/// `data` (lattice `d`) at lattice coordinates `g` in sixteen lanes:
/// [`trilinear16`] where every stencil is inside, else [`stencil16`]
/// wrapped or clamped by `wrap`; and the lanes it computed.
///
/// # Safety
/// As [`trilinear16`].
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn interpolate16(data: &[f32], d: [usize; 3], wrap: Wrap, g: [__m512; 3]) -> (__m512, u32) {
    // SAFETY (both): as this function's.
    let ([v], inside) = unsafe { trilinear16([data], d, g) };
    if inside == 0xffff {
        return (v, 0xffff);
    }
    let (v, bad) = unsafe { stencil16(data, d, wrap, g) };
    (v, u32::from(!bad))
}

/// [`interpolate16`] of one grid at `N` groups of points `g`: the groups
/// whose stencils all lie in one [`Window`] ([`Corners::one_window`])
/// interpolated together, corner row by corner row, so that their
/// independent chains of loads, permutes and sums overlap (as
/// [`velocity16_rows`] does for the velocity's components); the others by
/// [`interpolate16`]. The same operations per group, so the same bits.
///
/// # Safety
/// As [`trilinear16`].
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn interpolate16_groups<const N: usize>(
    data: &[f32],
    d: [usize; 3],
    wrap: Wrap,
    g: [[__m512; 3]; N],
) -> ([__m512; N], [u32; N]) {
    let mut corners = [Corners::new(d, g[0]); N];
    let mut windows = [None; N];
    for n in 0..N {
        corners[n] = Corners::new(d, g[n]);
        windows[n] = corners[n].one_window(data.len());
    }
    let mut v = [_mm512_setzero_ps(); N];
    for c in 0..4 {
        for n in 0..N {
            if let Some(w) = &windows[n] {
                // SAFETY: `shifts[c] ≤ shifts[3]`, the window's
                // `last_shift`, on the lattice of `data`'s length.
                let x = unsafe { w.fetch(data, corners[n].shifts[c]) };
                [v[n]] = corners[n].add_row([v[n]], c, [x]);
            }
        }
    }
    let mut done = [0xffff; N];
    for n in 0..N {
        if windows[n].is_none() {
            // SAFETY: as this function's.
            (v[n], done[n]) = unsafe { interpolate16(data, d, wrap, g[n]) };
        }
    }
    (v, done)
}

/// Sixteen values as a vector.
#[inline]
#[target_feature(enable = "avx512f")]
fn load16(v: &[f32; 16]) -> __m512 {
    // SAFETY: `v` holds sixteen f32.
    unsafe { _mm512_loadu_ps(v.as_ptr()) }
}

/// Sixteen contiguous values of `data` from `at`.
///
/// # Panics
/// If `at + 16 > data.len()`.
#[inline]
#[target_feature(enable = "avx512f")]
fn load16_at(data: &[f32], at: usize) -> __m512 {
    load16(data[at..at + 16].try_into().expect("sixteen values"))
}

/// A vector's sixteen lanes.
#[inline]
#[target_feature(enable = "avx512f")]
fn lanes16(v: __m512) -> [f32; 16] {
    let mut out = [0.0; 16];
    // SAFETY: `out` holds sixteen f32.
    unsafe { _mm512_storeu_ps(out.as_mut_ptr(), v) };
    out
}

/// The grid coordinates of sixteen consecutive points of one x-row from
/// `f`: cell centres, or with `face = Some(a)` the faces of component `a`
/// (shifted by −½ along `a`).
#[inline]
#[target_feature(enable = "avx512f")]
fn row_points(f: [usize; 3], face: Option<usize>) -> [__m512; 3] {
    let lane = _mm512_setr_ps(
        0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 10.0, 11.0, 12.0, 13.0, 14.0, 15.0,
    );
    let mut c = [
        _mm512_add_ps(_mm512_set1_ps(f[0] as f32), lane),
        _mm512_set1_ps(f[1] as f32),
        _mm512_set1_ps(f[2] as f32),
    ];
    if let Some(a) = face {
        c[a] = _mm512_sub_ps(c[a], _mm512_set1_ps(0.5));
    }
    c
}

/// The velocity at the sixteen faces `(i, j, k) … (i + 15, j, k)` of
/// component `A` as `FaceSampler::at_face` finds it: its own value, each
/// other component `b` the mean of four faces, read in its order from
/// `around[b]` plus `shift`, the linear indices of lane 0's four faces
/// (`FaceSampler::face_neighbours` of a face `shift` before it along x,
/// wrapped or clamped there), lane `l`'s `l` values on.
///
/// The caller keeps `1 ≤ i` and `i + 16 ≤ n_x − 1` (`n_x` the cells along
/// x), where no lane's faces wrap or clamp along x, so each lane's are
/// lane 0's shifted by its offset; otherwise the values are not the faces'
/// (or, past the lattice, it panics).
#[inline]
#[target_feature(enable = "avx512f")]
fn face_velocities16<const A: usize>(
    vel: Lattices,
    f: [usize; 3],
    around: &[[usize; 4]; 3],
    shift: usize,
) -> [__m512; 3] {
    let mut u = [_mm512_setzero_ps(); 3];
    for (b, ub) in u.iter_mut().enumerate() {
        if b == A {
            let d = vel.dims[b];
            *ub = load16_at(vel.data[b], (f[2] * d[1] + f[1]) * d[0] + f[0]);
            continue;
        }
        let mut sum = _mm512_setzero_ps();
        for p in around[b] {
            sum = _mm512_add_ps(sum, load16_at(vel.data[b], p + shift));
        }
        *ub = _mm512_mul_ps(_mm512_set1_ps(0.25), sum);
    }
    u
}

/// The velocity at the sixteen cell centres `(i, j, k) … (i + 15, j, k)` as
/// `FaceSampler::at_cell` finds it: per component `a` the mean of the
/// cell's two faces, read in its order from `faces[a]`, the linear indices
/// of lane 0's (`FaceSampler::cell_faces`, the upper wrapped there), lane
/// `l`'s `l` values on.
///
/// The caller keeps every cell's upper x-face inside `u`'s lattice (`i + 16
/// < mx`), where no lane's wraps; otherwise the values are not the cells'
/// (or, past the lattice, it panics).
#[inline]
#[target_feature(enable = "avx512f")]
fn cell_velocities16(vel: Lattices, faces: &[[usize; 2]; 3]) -> [__m512; 3] {
    let mut u = [_mm512_setzero_ps(); 3];
    for (a, ua) in u.iter_mut().enumerate() {
        let [lo, hi] = faces[a];
        let sum = _mm512_add_ps(load16_at(vel.data[a], lo), load16_at(vel.data[a], hi));
        *ua = _mm512_mul_ps(_mm512_set1_ps(0.5), sum);
    }
    u
}

/// The faces `(i, j, k) … (i + 15, j, k)` of component `A` for each of
/// `N` group starts `i` of one row (`starts`, `j`, `k`), whose velocities
/// [`face_velocities16`] finds from `first`, face `(1, j, k)`'s neighbours
/// (the caller keeps its bounds on each `i`): `data` (laid out like
/// component `A`'s lattice) at each face's departure point through `vel`
/// over `dt_cells = Δt/Δx` (stencils wrapped or clamped by `wrap`), into
/// `row[i..i + 16]`. The groups' interpolations interleaved
/// ([`interpolate16_groups`]). Returns per group the lanes left to the
/// scalar path (bit `l` for lane `l`; those values are meaningless). Euler
/// and RK2 only.
///
/// # Safety
/// The CPU has AVX-512F ([`has_avx512`]), `vel.dims` passes
/// `simd::lattices`, and `data` has component `A`'s lattice length.
///
/// # Panics
/// If `row` is shorter than a start plus sixteen.
pub(super) unsafe fn faces16<const A: usize, const N: usize>(
    vel: Lattices,
    wrap: Wrap,
    dst: (&[f32], &mut [f32]),
    at: ([usize; N], usize, usize),
    first: &[[usize; 4]; 3],
    trace: (f32, Backtrace),
) -> [u32; N] {
    // SAFETY (both): as this function's.
    unsafe {
        match trace.1 {
            Backtrace::Euler => faces16_traced::<A, N, true>(vel, wrap, dst, at, first, trace),
            _ => faces16_traced::<A, N, false>(vel, wrap, dst, at, first, trace),
        }
    }
}

/// [`faces16`] compiled for the Euler trace (`EULER`: the trace inline,
/// no midpoint code) or for the others: one function per backtrace, each
/// laid out alone (with both in one, a 128³ Euler step's advection took
/// 10–15 % longer).
///
/// # Safety
/// As [`faces16`], and `EULER` is whether `trace` is Euler's.
#[inline(never)]
#[target_feature(enable = "avx512f")]
unsafe fn faces16_traced<const A: usize, const N: usize, const EULER: bool>(
    vel: Lattices,
    wrap: Wrap,
    (data, row): (&[f32], &mut [f32]),
    (starts, j, k): ([usize; N], usize, usize),
    first: &[[usize; 4]; 3],
    trace: (f32, Backtrace),
) -> [u32; N] {
    let mut c = [[_mm512_setzero_ps(); 3]; N];
    let mut u0 = c;
    for n in 0..N {
        let f = [starts[n], j, k];
        c[n] = row_points(f, Some(A));
        u0[n] = face_velocities16::<A>(vel, f, first, starts[n] - 1);
    }
    // SAFETY: as this function's.
    let (v, left) = unsafe { face_values16::<A, N, EULER>(vel, wrap, data, (c, u0), trace) };
    for n in 0..N {
        row[starts[n]..starts[n] + 16].copy_from_slice(&lanes16(v[n]));
    }
    left
}

/// [`faces16`] for any sixteen faces of component `A` — the row ends of a
/// slab, whose neighbours wrap or clamp along x — from their grid
/// coordinates `c` and velocities `u0` (`[x, y, z]` lanes, as
/// `FaceSampler::at_face` finds them): the same trace and interpolation,
/// so the same bits. Returns the lanes left to the scalar path.
///
/// # Safety
/// As [`faces16`].
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn face_points16<const A: usize>(
    vel: Lattices,
    wrap: Wrap,
    (data, out): (&[f32], &mut [f32; 16]),
    (c, u0): (&[[f32; 16]; 3], &[[f32; 16]; 3]),
    trace: (f32, Backtrace),
) -> u32 {
    let (mut cv, mut uv) = ([_mm512_setzero_ps(); 3], [_mm512_setzero_ps(); 3]);
    for a in 0..3 {
        (cv[a], uv[a]) = (load16(&c[a]), load16(&u0[a]));
    }
    // SAFETY: as this function's.
    let ([v], [left]) =
        unsafe { face_values16::<A, 1, false>(vel, wrap, data, ([cv], [uv]), trace) };
    *out = lanes16(v);
    left
}

/// `N` groups of faces of component `A` at grid coordinates `c` with
/// velocities `u0`: `data` at their departure points (the tail of
/// [`faces16`] and [`face_points16`]), and per group the lanes left to the
/// scalar path.
///
/// # Safety
/// As [`faces16`].
#[inline]
#[target_feature(enable = "avx512f")]
unsafe fn face_values16<const A: usize, const N: usize, const EULER: bool>(
    vel: Lattices,
    wrap: Wrap,
    data: &[f32],
    (c, u0): ([[__m512; 3]; N], [[__m512; 3]; N]),
    (dt_cells, backtrace): (f32, Backtrace),
) -> ([__m512; N], [u32; N]) {
    let mut g = c;
    let mut traced = [0xffff; N];
    for n in 0..N {
        (g[n], traced[n]) = match EULER {
            true => (back16(c[n], u0[n], dt_cells), 0xffff),
            // SAFETY: as this function's.
            false => unsafe { trace16::<true>(vel, wrap, c[n], u0[n], dt_cells, backtrace) },
        };
        g[n][A] = _mm512_add_ps(g[n][A], _mm512_set1_ps(0.5));
    }
    // SAFETY: `data` has component A's lattice length (caller).
    let (v, mut left) = unsafe { interpolate16_groups(data, vel.dims[A], wrap, g) };
    for n in 0..N {
        left[n] = !(u32::from(traced[n]) & left[n]) & 0xffff;
    }
    (v, left)
}

/// The departure points of the cell centres `(i, j, k) … (i + 15, j, k)`,
/// whose velocities [`cell_velocities16`] finds from `faces` (the caller
/// keeps its bound on `i`), traced back through `vel` over `dt_cells =
/// Δt/Δx` (Euler or RK2; stencils wrapped or clamped by `wrap`), into
/// `out = [x, y, z]` (sixteen each). Returns the lanes left to the scalar
/// path (their points meaningless).
///
/// # Safety
/// The CPU has AVX-512F ([`has_avx512`]) and `vel.dims` passes
/// `simd::lattices`.
///
/// # Panics
/// If an `out` slice is shorter than sixteen.
pub(super) unsafe fn cells16(
    vel: Lattices,
    wrap: Wrap,
    f: [usize; 3],
    faces: &[[usize; 2]; 3],
    trace: (f32, Backtrace),
    out: [&mut [f32]; 3],
) -> u32 {
    // SAFETY (both): as this function's.
    unsafe {
        match trace.1 {
            Backtrace::Euler => cells16_traced::<true>(vel, wrap, f, faces, trace, out),
            _ => cells16_traced::<false>(vel, wrap, f, faces, trace, out),
        }
    }
}

/// [`cells16`] compiled for the Euler trace (`EULER`) or for the others,
/// as [`faces16_traced`].
///
/// # Safety
/// As [`cells16`], and `EULER` is whether `trace` is Euler's.
#[inline(never)]
#[target_feature(enable = "avx512f")]
unsafe fn cells16_traced<const EULER: bool>(
    vel: Lattices,
    wrap: Wrap,
    f: [usize; 3],
    faces: &[[usize; 2]; 3],
    (dt_cells, backtrace): (f32, Backtrace),
    out: [&mut [f32]; 3],
) -> u32 {
    let c = row_points(f, None);
    let u0 = cell_velocities16(vel, faces);
    let (g, done) = match EULER {
        true => (back16(c, u0, dt_cells), 0xffff),
        // SAFETY: as this function's.
        false => unsafe { trace16::<true>(vel, wrap, c, u0, dt_cells, backtrace) },
    };
    for (o, v) in out.into_iter().zip(g) {
        o[..16].copy_from_slice(&lanes16(v));
    }
    !u32::from(done) & 0xffff
}

/// `data` (a cell-centred grid of `dims` cells, wrapped or clamped by
/// `wrap`) at the sixteen grid-coordinate points `g = [x, y, z]`, into
/// `out`. Returns the lanes left to the scalar path (their values
/// meaningless).
///
/// # Safety
/// The CPU has AVX-512F; `dims` passes `simd::lattices` as a lattice.
///
/// # Panics
/// If `data` is shorter than `dims`, or a slice of `g` or `out` shorter
/// than sixteen.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn sample16(
    data: &[f32],
    (dims, wrap): ([usize; 3], Wrap),
    g: [&[f32]; 3],
    out: &mut [f32],
) -> u32 {
    assert!(
        data.len() >= dims.iter().product::<usize>(),
        "sample16: data"
    );
    let g = g.map(|x| load16(x[..16].try_into().expect("sixteen points")));
    // SAFETY: data covers the lattice (asserted), which fits (caller).
    let (v, done) = unsafe { interpolate16(data, dims, wrap, g) };
    out[..16].copy_from_slice(&lanes16(v));
    !done & 0xffff
}

/// [`sample16`] for `N` grids of one layout (`datas`, each of `dims` cells
/// and the same length) at `G` groups of sixteen points, group `n` at
/// `points[a][starts[n]..]`, into `outs[m][at + starts[n]..][..16]`: each
/// group's corners found once for all grids ([`Corners`]), and the groups
/// whose stencils lie in one [`Window`] interpolated together, corner row
/// by corner row, so that their chains overlap (as [`interpolate16_groups`]);
/// the others by [`trilinear16`]. The same operations per grid as
/// [`sample16`]'s, so the same bits. Returns per group whether it wrote
/// it: only when every lane's stencil lies inside the grid (the caller
/// samples the grids one by one otherwise).
///
/// # Safety
/// The CPU has AVX-512F; `dims` passes `simd::lattices` as a lattice.
///
/// # Panics
/// If the grids' lengths differ or are shorter than `dims`, or a slice of
/// `points` (of `outs` past `at`) is shorter than a start plus sixteen.
#[target_feature(enable = "avx512f")]
pub(super) unsafe fn sample16_grids<const N: usize, const G: usize>(
    datas: [&[f32]; N],
    dims: [usize; 3],
    (points, starts): ([&[f32]; 3], [usize; G]),
    (mut outs, at): ([&mut [f32]; N], usize),
) -> [bool; G] {
    let len = datas.first().map_or(0, |d| d.len());
    assert!(
        len >= dims.iter().product::<usize>() && datas.iter().all(|d| d.len() == len),
        "sample16_grids: data"
    );
    let mut g = [[_mm512_setzero_ps(); 3]; G];
    let mut corners = [Corners::new(dims, g[0]); G];
    let mut windows = [None; G];
    for n in 0..G {
        for a in 0..3 {
            let at = starts[n];
            g[n][a] = load16(points[a][at..at + 16].try_into().expect("sixteen points"));
        }
        corners[n] = Corners::new(dims, g[n]);
        windows[n] = corners[n].one_window(len);
    }
    let mut acc = [[_mm512_setzero_ps(); N]; G];
    for c in 0..4 {
        for n in 0..G {
            if let Some(w) = &windows[n] {
                let mut v = [[_mm512_setzero_ps(); 2]; N];
                for (v, data) in v.iter_mut().zip(datas) {
                    // SAFETY: `shifts[c] ≤ shifts[3]`, the window's
                    // `last_shift`; every grid has its length.
                    *v = unsafe { w.fetch(data, corners[n].shifts[c]) };
                }
                acc[n] = corners[n].add_row(acc[n], c, v);
            }
        }
    }
    let mut wrote = [true; G];
    for n in 0..G {
        if windows[n].is_none() {
            // SAFETY: every grid covers the lattice with one length
            // (asserted), which fits (caller).
            let (v, inside) = unsafe { trilinear16(datas, dims, g[n]) };
            if inside != 0xffff {
                wrote[n] = false;
                continue;
            }
            acc[n] = v;
        }
        for (out, v) in outs.iter_mut().zip(acc[n]) {
            out[at + starts[n]..][..16].copy_from_slice(&lanes16(v));
        }
    }
    wrote
}

/// `simd::wrap8` in sixteen lanes (AVX-512).
#[inline]
#[target_feature(enable = "avx512f")]
fn wrap16(x: __m512, n: usize) -> (__m512, __mmask16) {
    let (lo, len) = (_mm512_set1_ps(-0.5), _mm512_set1_ps(n as f32));
    let hi = _mm512_set1_ps(-0.5 + n as f32);
    let below = _mm512_cmp_ps_mask::<_CMP_LT_OQ>(x, lo);
    let above = _mm512_cmp_ps_mask::<_CMP_GE_OQ>(x, hi);
    let (up, down) = (_mm512_add_ps(x, len), _mm512_sub_ps(x, len));
    let far = (below & !_mm512_cmp_ps_mask::<_CMP_GE_OQ>(up, lo))
        | (above & !_mm512_cmp_ps_mask::<_CMP_LT_OQ>(down, hi));
    let y = _mm512_mask_mov_ps(_mm512_mask_mov_ps(x, below, up), above, down);
    (y, far)
}

/// `simd::points8` for sixteen points: the same operations in the same
/// order per lane, so the same bits. Returns the lanes left to the scalar
/// path (not written).
///
/// # Safety
/// The CPU has AVX-512F ([`has_avx512`]) and `vel.dims` passes
/// `simd::lattices`.
#[target_feature(enable = "avx512f")]
pub(crate) unsafe fn points16(
    vel: Lattices,
    wrap: Wrap,
    g: &mut [Vec3; 16],
    dt_cells: f32,
    backtrace: Backtrace,
    into_box: Option<[usize; 3]>,
) -> u32 {
    if backtrace == Backtrace::Rk3 {
        return 0xffff;
    }
    let c = coordinates16(g);
    // SAFETY (both): as this function's.
    let (u0, first) = unsafe { velocity16(vel, wrap, c) };
    let (mut p, done) = unsafe { trace16::<false>(vel, wrap, c, u0, dt_cells, backtrace) };
    let mut bad = !(first & done);
    if let Some(n) = into_box {
        for (pa, n) in p.iter_mut().zip(n) {
            let (y, far) = wrap16(*pa, n);
            *pa = y;
            bad |= far;
        }
    }
    // The lanes left keep their points.
    let p: [__m512; 3] = std::array::from_fn(|a| _mm512_mask_mov_ps(p[a], bad, c[a]));
    set_points16(g, p);
    u32::from(bad)
}

/// Sixteen `Vec3`s are 48 consecutive f32, x y z interleaved.
const _: () = assert!(std::mem::size_of::<[Vec3; 16]>() == 48 * 4);

/// The permutes that take 48 interleaved floats (vectors `a`, `b`, `c`)
/// to component `comp`'s sixteen lanes: `(a, b)` by the first, then that
/// and `c` by the second. Lane `l` is float `3l + comp`.
const fn deinterleave(comp: usize) -> [[i32; 16]; 2] {
    let mut idx = [[0; 16]; 2];
    let mut l = 0;
    while l < 16 {
        let e = 3 * l + comp;
        idx[0][l] = (e % 32) as i32;
        idx[1][l] = if e < 32 { l } else { e - 16 } as i32;
        l += 1;
    }
    idx
}

/// The permutes that take x, y, z lanes to the sixteen floats `16q … 16q
/// + 15` of their interleaving: `(x, y)` by the first, then that and `z`
/// by the second ([`deinterleave`]'s inverse).
const fn interleave(q: usize) -> [[i32; 16]; 2] {
    let mut idx = [[0; 16]; 2];
    let mut i = 0;
    while i < 16 {
        let e = 16 * q + i;
        let (comp, l) = (e % 3, e / 3);
        idx[0][i] = match comp {
            0 => l,
            1 => 16 + l,
            _ => 0,
        } as i32;
        idx[1][i] = if comp == 2 { 16 + l } else { i } as i32;
        i += 1;
    }
    idx
}

/// An index vector.
#[inline]
#[target_feature(enable = "avx512f")]
fn index16(idx: &[i32; 16]) -> __m512i {
    // SAFETY: `idx` holds sixteen i32.
    unsafe { _mm512_loadu_si512(idx.as_ptr().cast()) }
}

/// The x, y and z lanes of sixteen points: three loads and six permutes
/// (element by element through the stack, they had cost 5–8 % of a
/// gridless walk).
#[inline]
#[target_feature(enable = "avx512f")]
fn coordinates16(g: &[Vec3; 16]) -> [__m512; 3] {
    let p = g.as_ptr().cast::<f32>();
    // SAFETY: `g` is 48 consecutive f32 (asserted above).
    let [a, b, c] = [0, 16, 32].map(|o| unsafe { _mm512_loadu_ps(p.add(o)) });
    const IDX: [[[i32; 16]; 2]; 3] = [deinterleave(0), deinterleave(1), deinterleave(2)];
    IDX.map(|[first, second]| {
        let ab = _mm512_permutex2var_ps(a, index16(&first), b);
        _mm512_permutex2var_ps(ab, index16(&second), c)
    })
}

/// [`coordinates16`]'s inverse: the points of x, y and z lanes `p` into `g`.
#[inline]
#[target_feature(enable = "avx512f")]
fn set_points16(g: &mut [Vec3; 16], [x, y, z]: [__m512; 3]) {
    let out = g.as_mut_ptr().cast::<f32>();
    const IDX: [[[i32; 16]; 2]; 3] = [interleave(0), interleave(1), interleave(2)];
    for (q, [first, second]) in IDX.iter().enumerate() {
        let xy = _mm512_permutex2var_ps(x, index16(first), y);
        let v = _mm512_permutex2var_ps(xy, index16(second), z);
        // SAFETY: `g` is 48 consecutive f32 (asserted above).
        unsafe { _mm512_storeu_ps(out.add(16 * q), v) };
    }
}
