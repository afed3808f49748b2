//! AVX2 kernels of the semi-Lagrangian sweeps (eqs 6.4–6.5): eight
//! consecutive faces of one x-row ([`super::semi_lagrangian::advect_faces`],
//! [`faces8`]) or eight cell centres ([`super::semi_lagrangian::advect_fused`],
//! [`cells8`]) traced back together (Euler or RK2), and interpolated at their
//! departure points ([`faces8`], [`sample8`]), the trilinear corners fetched
//! by gathers.
//!
//! Every lane does the scalar sweep's floating-point operations in the same
//! order (products and sums, no fused multiply-add), so its results are the
//! scalar path's to the bit. The callers keep the traced points away from
//! the box's edges; a group of eight with any stencil outside its lattice
//! returns `None`/`false` and the caller does those points one by one
//! through the wrapping scalar path.
//!
//! Arbitrary points (the gridless walk, SELMA's map: [`points8`], and
//! [`points16`] in sixteen AVX-512 lanes) wrap or clamp their stencils per
//! lane as the scalar `Stencil` does, so only points more than a period
//! outside the box (and NaN) are left to the scalar path.

use std::arch::x86_64::*;

use glam::Vec3;

use crate::grid::face::FaceSampler;
use crate::grid::Wrap;

use super::Backtrace;

/// The velocity lattices: component slices, lattice sizes `[mx, my, mz]`
/// and the domain's cell counts, as [`crate::grid::face::FaceSampler`] holds
/// them.
#[derive(Clone, Copy)]
pub(crate) struct Lattices<'a> {
    /// Components `[u, v, w]`, flat `[z][y][x]`.
    pub data: [&'a [f32]; 3],
    /// Lattice size of each component.
    pub dims: [[usize; 3]; 3],
}

/// The kernels' view of a velocity when this CPU has AVX2 and the lattices
/// fit them (gathers take 32-bit indices; a lane outside reads the first
/// corner's 2×2×2 block, so every lattice is at least 2 along each axis);
/// `None` otherwise (scalar paths only).
pub(crate) fn lattices(vel: FaceSampler) -> Option<Lattices> {
    let (data, dims) = vel.lattices();
    dims.iter()
        .all(|&d| fits(d))
        .then_some(Lattices { data, dims })
}

/// Whether this CPU has AVX2 and a lattice (or cell grid) of `dims` fits
/// the kernels: at least 2 along each axis, indices within `i32`.
pub(crate) fn fits(dims: [usize; 3]) -> bool {
    is_x86_feature_detected!("avx2")
        && dims.iter().all(|&m| m >= 2)
        && dims[0] * dims[1] * dims[2] < i32::MAX as usize / 2
}

/// `⌊g⌋` per lane (0 where it is outside) and `g − ⌊g⌋`, and the lanes
/// where `0 ≤ ⌊g⌋ ≤ n − 2` (all ones; the scalar `floor_inside`:
/// truncation plus a correction).
#[inline]
#[target_feature(enable = "avx2")]
fn floor_inside8(g: __m256, n: usize) -> (__m256i, __m256, __m256i) {
    let t = _mm256_cvttps_epi32(g);
    // −1 where the truncation rounded up (negative non-integers).
    let up = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_cvtepi32_ps(t), g));
    let f = _mm256_add_epi32(t, up);
    let frac = _mm256_sub_ps(g, _mm256_cvtepi32_ps(f));
    let low = _mm256_cmpgt_epi32(f, _mm256_set1_epi32(-1));
    let high = _mm256_cmpgt_epi32(_mm256_set1_epi32(n as i32 - 1), f);
    let ok = _mm256_and_si256(low, high);
    (_mm256_and_si256(f, ok), frac, ok)
}

/// Whether every lane of a mask is set.
#[inline]
#[target_feature(enable = "avx2")]
fn all(ok: __m256i) -> bool {
    _mm256_movemask_epi8(ok) == -1
}

/// Trilinear interpolation of `data` (lattice `d`) at lattice coordinates
/// `(gx, gy, gz)` in eight lanes, and the lanes whose stencil lies inside
/// the lattice (all ones); the others read the lattice's first corner
/// instead and must be redone by the wrapping scalar path. Corners, weights
/// and sum in `trilinear_inside`'s order.
///
/// # Safety
/// `data.len() ≥ mx·my·mz < 2³⁰`, every `m ≥ 2` ([`lattices`]), and the CPU has
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn trilinear8(data: &[f32], d: [usize; 3], g: [__m256; 3]) -> (__m256, __m256i) {
    let (x, tx, okx) = floor_inside8(g[0], d[0]);
    let (y, ty, oky) = floor_inside8(g[1], d[1]);
    let (z, tz, okz) = floor_inside8(g[2], d[2]);
    let ok = _mm256_and_si256(okx, _mm256_and_si256(oky, okz));
    let (nx, nxy) = (d[0] as i32, (d[0] * d[1]) as i32);
    let r = _mm256_add_epi32(
        _mm256_mullo_epi32(
            _mm256_add_epi32(_mm256_mullo_epi32(z, _mm256_set1_epi32(d[1] as i32)), y),
            _mm256_set1_epi32(nx),
        ),
        x,
    );
    let one = _mm256_set1_ps(1.0);
    let wx = [_mm256_sub_ps(one, tx), tx];
    let wy = [_mm256_sub_ps(one, ty), ty];
    let wz = [_mm256_sub_ps(one, tz), tz];
    let mut acc = _mm256_setzero_ps();
    // Corners c = cx + 2cy + 4cz in order; the two x-neighbours of a row
    // are adjacent in memory, so each (cy, cz) fetches both as one 64-bit
    // gather per four lanes (half the gathered elements of eight 32-bit
    // gathers) and splits them into the x0 and x1 values.
    for (cy, cz) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
        let at = _mm256_add_epi32(r, _mm256_set1_epi32(cy as i32 * nx + cz as i32 * nxy));
        // SAFETY: every lane has x ≤ mx − 2, y ≤ my − 2, z ≤ mz − 2 (lanes
        // outside read x = y = z = 0, and every m ≥ 2), so the pair at its
        // index ends at most at ((z + 1)·my + y + 1)·mx + x + 1
        // < mx·my·mz ≤ data.len(); indices are below 2³⁰ (no i32 overflow,
        // [`lattices`]).
        let v = unsafe { x_pairs8(data, at) };
        for (cx, v) in v.into_iter().enumerate() {
            let weight = _mm256_mul_ps(_mm256_mul_ps(wx[cx], wy[cy]), wz[cz]);
            acc = _mm256_add_ps(acc, _mm256_mul_ps(weight, v));
        }
    }
    (acc, ok)
}

/// The values at `at` and `at + 1` of `data` in eight lanes (the x0 and x1
/// corners of a trilinear stencil's row): one 64-bit gather per four lanes,
/// half the gathered elements of eight 32-bit gathers, split into the two
/// values in lane order.
///
/// # Safety
/// Every lane's `at + 1 < data.len()`, `at ≥ 0`; the CPU has AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn x_pairs8(data: &[f32], at: __m256i) -> [__m256; 2] {
    let pairs = data.as_ptr().cast::<i64>();
    // SAFETY: as this function's; gathers need no alignment.
    let (low, high) = unsafe {
        (
            _mm256_castsi256_ps(_mm256_i32gather_epi64::<4>(
                pairs,
                _mm256_castsi256_si128(at),
            )),
            _mm256_castsi256_ps(_mm256_i32gather_epi64::<4>(
                pairs,
                _mm256_extracti128_si256::<1>(at),
            )),
        )
    };
    // Lanes 0–3 in `low`, 4–7 in `high`, as (x0, x1) pairs: the even
    // elements are x0, the odd x1; the shuffle leaves them in lane order
    // 0 1 4 5 2 3 6 7, the permute restores 0…7.
    let split =
        |v: __m256| _mm256_castpd_ps(_mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_castps_pd(v)));
    [
        split(_mm256_shuffle_ps::<0b10_00_10_00>(low, high)),
        split(_mm256_shuffle_ps::<0b11_01_11_01>(low, high)),
    ]
}

/// Eight contiguous values of `data` from `at`.
///
/// # Panics
/// If `at + 8 > data.len()`.
#[inline]
#[target_feature(enable = "avx2")]
fn load8(data: &[f32], at: usize) -> __m256 {
    let s = &data[at..at + 8];
    // SAFETY: `s` holds eight f32.
    unsafe { _mm256_loadu_ps(s.as_ptr()) }
}

/// The velocity at eight points `g` (cell-centre grid coordinates):
/// component `a` trilinear on its lattice at `g + ½e_a`
/// (`FaceSampler::at`), and the lanes whose stencils lie inside every
/// lattice (all ones).
///
/// # Safety
/// The CPU has AVX2 and `vel.dims` passes [`lattices`].
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn velocity8(vel: Lattices, g: [__m256; 3]) -> ([__m256; 3], __m256i) {
    let mut u = [_mm256_setzero_ps(); 3];
    let mut ok = _mm256_set1_epi32(-1);
    for (b, ub) in u.iter_mut().enumerate() {
        let mut p = g;
        p[b] = _mm256_add_ps(p[b], _mm256_set1_ps(0.5));
        // SAFETY: the lattice of b has vel.data[b]'s length (fits).
        let (v, inside) = unsafe { trilinear8(vel.data[b], vel.dims[b], p) };
        *ub = v;
        ok = _mm256_and_si256(ok, inside);
    }
    (u, ok)
}

/// The departure points of eight points `c` (grid coordinates) whose
/// velocities are `u0`, traced back through `vel` over `dt_cells = Δt/Δx`
/// (Euler or RK2) as the scalar `departure` does, and the lanes whose RK2
/// midpoint stencils lie inside the lattices (all ones; every lane for
/// Euler, none for RK3, which is left to the scalar path).
///
/// # Safety
/// The CPU has AVX2 and `vel.dims` passes [`lattices`].
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn trace8(
    vel: Lattices,
    c: [__m256; 3],
    u0: [__m256; 3],
    dt_cells: f32,
    backtrace: Backtrace,
) -> ([__m256; 3], __m256i) {
    let step = |u: [__m256; 3], s: f32| -> [__m256; 3] {
        std::array::from_fn(|a| _mm256_sub_ps(c[a], _mm256_mul_ps(_mm256_set1_ps(s), u[a])))
    };
    match backtrace {
        Backtrace::Euler => (step(u0, dt_cells), _mm256_set1_epi32(-1)),
        Backtrace::Rk2 => {
            // SAFETY: as this function's.
            let (u1, ok) = unsafe { velocity8(vel, step(u0, 0.5 * dt_cells)) };
            (step(u1, dt_cells), ok)
        }
        Backtrace::Rk3 => (c, _mm256_setzero_si256()),
    }
}

/// Faces `(i, j, k) … (i + 7, j, k)` of component `A`: `data` (laid out
/// like component `A`'s lattice) at each face's departure point through
/// `vel` over `dt_cells = Δt/Δx`, into `out`; `false` (nothing written) if
/// a stencil would wrap or clamp. Euler and RK2 only.
///
/// The caller keeps `1 ≤ i`, `i + 8 ≤ n_x − 1`, `1 ≤ j ≤ n_y − 2` and
/// `1 ≤ k ≤ n_z − 2` with `n` the cell counts, so the face velocities
/// (the four-face averages of `FaceSampler::at_face`) need no wrap.
///
/// # Safety
/// The CPU has AVX2 ([`lattices`]) and `vel.dims` passes [`lattices`]; `data`
/// has component `A`'s lattice length.
///
/// # Panics
/// If `out` is shorter than eight.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn faces8<const A: usize>(
    vel: Lattices,
    data: &[f32],
    f: [usize; 3],
    dt_cells: f32,
    backtrace: Backtrace,
    out: &mut [f32],
) -> bool {
    let lane = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
    let mut c = [
        _mm256_add_ps(_mm256_set1_ps(f[0] as f32), lane),
        _mm256_set1_ps(f[1] as f32),
        _mm256_set1_ps(f[2] as f32),
    ];
    c[A] = _mm256_sub_ps(c[A], _mm256_set1_ps(0.5));
    // The face velocity: its own value, the others four-face means.
    let u0: [__m256; 3] = std::array::from_fn(|b| {
        let d = vel.dims[b];
        let here = (f[2] * d[1] + f[1]) * d[0] + f[0];
        if b == A {
            return load8(vel.data[b], here);
        }
        let stride = |axis: usize| [1, d[0], d[0] * d[1]][axis];
        let (sa, sb) = (stride(A), stride(b));
        let mut sum = _mm256_setzero_ps();
        for p in [here - sa, here - sa + sb, here, here + sb] {
            sum = _mm256_add_ps(sum, load8(vel.data[b], p));
        }
        _mm256_mul_ps(_mm256_set1_ps(0.25), sum)
    });
    // SAFETY: as this function's.
    let (g, traced) = unsafe { trace8(vel, c, u0, dt_cells, backtrace) };
    if !all(traced) {
        return false;
    }
    let mut p = g;
    p[A] = _mm256_add_ps(p[A], _mm256_set1_ps(0.5));
    // SAFETY: `data` has component A's lattice length (caller).
    let (v, inside) = unsafe { trilinear8(data, vel.dims[A], p) };
    if all(inside) {
        store8(out, v);
    }
    all(inside)
}

/// The departure points of cell centres `(i, j, k) … (i + 7, j, k)` traced
/// back through `vel` over `dt_cells = Δt/Δx` (Euler or RK2), written to
/// `out = [x, y, z]` (eight lanes each); `false` (nothing written) if an RK2
/// midpoint's stencil would wrap or clamp. The cell velocity is the mean of
/// the cell's two faces per component, `FaceSampler::at_cell`'s sum in the
/// same order, and the trace is the scalar `departure`'s.
///
/// The caller keeps every cell's upper face inside its lattice (`i + 8 <
/// mx` of `u`, `j + 1 < my` of `v`, `k + 1 < mz` of `w`), so no face wraps.
///
/// # Safety
/// The CPU has AVX2 ([`lattices`]) and `vel.dims` passes [`lattices`].
///
/// # Panics
/// If an `out` slice is shorter than eight.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn cells8(
    vel: Lattices,
    f: [usize; 3],
    dt_cells: f32,
    backtrace: Backtrace,
    out: [&mut [f32]; 3],
) -> bool {
    let lane = _mm256_setr_ps(0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0);
    let c = [
        _mm256_add_ps(_mm256_set1_ps(f[0] as f32), lane),
        _mm256_set1_ps(f[1] as f32),
        _mm256_set1_ps(f[2] as f32),
    ];
    let u0: [__m256; 3] = std::array::from_fn(|a| {
        let d = vel.dims[a];
        let here = (f[2] * d[1] + f[1]) * d[0] + f[0];
        let up = here + [1, d[0], d[0] * d[1]][a];
        let sum = _mm256_add_ps(load8(vel.data[a], here), load8(vel.data[a], up));
        _mm256_mul_ps(_mm256_set1_ps(0.5), sum)
    });
    // SAFETY: as this function's.
    let (g, traced) = unsafe { trace8(vel, c, u0, dt_cells, backtrace) };
    if !all(traced) {
        return false;
    }
    for (o, v) in out.into_iter().zip(g) {
        store8(o, v);
    }
    true
}

/// `data` (a cell-centred grid of `dims` cells) interpolated at the eight
/// grid-coordinate points `g = [x, y, z]` (eight lanes each), into `out`;
/// `false` (nothing written) if a stencil would wrap or clamp.
///
/// # Safety
/// The CPU has AVX2; `dims` passes [`lattices`] as a lattice.
///
/// # Panics
/// If `data` is shorter than `dims`, or a slice of `g` or `out` shorter
/// than eight.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn sample8(
    data: &[f32],
    dims: [usize; 3],
    g: [&[f32]; 3],
    out: &mut [f32],
) -> bool {
    assert!(
        data.len() >= dims.iter().product::<usize>(),
        "sample8: data"
    );
    let g = g.map(|x| load8(x, 0));
    // SAFETY: data covers the lattice (asserted), which fits (caller).
    let (v, inside) = unsafe { trilinear8(data, dims, g) };
    if all(inside) {
        store8(out, v);
    }
    all(inside)
}

/// Store eight lanes at the start of `out`.
///
/// # Panics
/// If `out` is shorter than eight.
#[inline]
#[target_feature(enable = "avx2")]
fn store8(out: &mut [f32], v: __m256) {
    let s = &mut out[..8];
    // SAFETY: `s` holds eight f32.
    unsafe { _mm256_storeu_ps(s.as_mut_ptr(), v) };
}

/// Lower and upper lattice index and the fraction between them along one
/// axis of a lattice of `n`, per lane, as the scalar stencil's `axis` finds
/// them (periodic wrap, or clamp to `[0, n − 1]`), and the lanes it leaves
/// to the scalar path (all ones: periodic points more than a period
/// outside, clamped NaN); those lanes read indices 0 and 1.
#[inline]
#[target_feature(enable = "avx2")]
fn axis8(g: __m256, n: usize, wrap: Wrap) -> (__m256i, __m256i, __m256, __m256i) {
    let ni = n as i32;
    let (f, frac, i0, i1, bad) = match wrap {
        Wrap::Periodic => {
            let t = _mm256_cvttps_epi32(g);
            // −1 where the truncation rounded up (negative non-integers).
            let up = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_cvtepi32_ps(t), g));
            let f = _mm256_add_epi32(t, up);
            let n8 = _mm256_set1_epi32(ni);
            let below = _mm256_cmpgt_epi32(_mm256_setzero_si256(), f);
            let above = _mm256_cmpgt_epi32(f, _mm256_set1_epi32(ni - 1));
            let i0 = _mm256_sub_epi32(
                _mm256_add_epi32(f, _mm256_and_si256(below, n8)),
                _mm256_and_si256(above, n8),
            );
            let i1 = _mm256_add_epi32(i0, _mm256_set1_epi32(1));
            let i1 = _mm256_andnot_si256(_mm256_cmpeq_epi32(i1, n8), i1);
            let bad = _mm256_or_si256(
                _mm256_cmpgt_epi32(_mm256_set1_epi32(-ni), f),
                _mm256_cmpgt_epi32(f, _mm256_set1_epi32(2 * ni - 1)),
            );
            (f, g, i0, i1, bad)
        }
        Wrap::Clamped => {
            // `g.clamp(0, n − 1)`: `max(a, b)` is `a > b ? a : b`, so −0 and
            // NaN pass through as in `f32::clamp`.
            let zero = _mm256_setzero_ps();
            let c = _mm256_min_ps(_mm256_set1_ps((n - 1) as f32), _mm256_max_ps(zero, g));
            let f = _mm256_cvttps_epi32(c);
            let i1 = _mm256_min_epi32(
                _mm256_add_epi32(f, _mm256_set1_epi32(1)),
                _mm256_set1_epi32(ni - 1),
            );
            let bad = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_UNORD_Q>(g, g));
            (f, c, f, i1, bad)
        }
    };
    let frac = _mm256_sub_ps(frac, _mm256_cvtepi32_ps(f));
    let i0 = _mm256_andnot_si256(bad, i0);
    let i1 = _mm256_blendv_epi8(i1, _mm256_set1_epi32(1), bad);
    (i0, i1, frac, bad)
}

/// Trilinear interpolation of `data` (lattice `d`) at lattice coordinates
/// `g` in eight lanes, wrapped or clamped as the scalar
/// [`crate::grid::Stencil`] with `wrap` (its corners, weights and sum in
/// its order: the same bits), and the lanes left to the scalar path
/// ([`axis8`]; they read valid but meaningless corners).
///
/// # Safety
/// `data.len() ≥ mx·my·mz < 2³⁰`, every `m ≥ 2` ([`lattices`]), and the CPU has
/// AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn stencil8(data: &[f32], d: [usize; 3], wrap: Wrap, g: [__m256; 3]) -> (__m256, __m256i) {
    let (x0, x1, tx, bx) = axis8(g[0], d[0], wrap);
    let (y0, y1, ty, by) = axis8(g[1], d[1], wrap);
    let (z0, z1, tz, bz) = axis8(g[2], d[2], wrap);
    let bad = _mm256_or_si256(bx, _mm256_or_si256(by, bz));
    let (mx, my) = (
        _mm256_set1_epi32(d[0] as i32),
        _mm256_set1_epi32(d[1] as i32),
    );
    let (y, z) = (
        [y0, y1],
        [_mm256_mullo_epi32(z0, my), _mm256_mullo_epi32(z1, my)],
    );
    let one = _mm256_set1_ps(1.0);
    let wx = [_mm256_sub_ps(one, tx), tx];
    let wy = [_mm256_sub_ps(one, ty), ty];
    let wz = [_mm256_sub_ps(one, tz), tz];
    // Where every lane's x1 is x0 + 1 the two x-corners are adjacent in
    // memory: one 64-bit gather per four lanes fetches both (as
    // `trilinear8`); at a wrapped or clamped x edge, two 32-bit gathers.
    let adjacent = all(_mm256_cmpeq_epi32(
        x1,
        _mm256_add_epi32(x0, _mm256_set1_epi32(1)),
    ));
    let mut acc = _mm256_setzero_ps();
    for (cy, cz) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
        let row = _mm256_mullo_epi32(_mm256_add_epi32(z[cz], y[cy]), mx);
        let at = _mm256_add_epi32(row, x0);
        // SAFETY: every index is a lattice index (`axis8`: 0 ≤ x0, x1 < mx,
        // and so on; indices below 2³⁰, [`lattices`]), so it and, where
        // `adjacent`, the next one (x0 ≤ mx − 2) are inside `data`; gathers
        // need no alignment.
        let v = unsafe {
            if adjacent {
                x_pairs8(data, at)
            } else {
                let at1 = _mm256_add_epi32(row, x1);
                [
                    _mm256_i32gather_ps::<4>(data.as_ptr(), at),
                    _mm256_i32gather_ps::<4>(data.as_ptr(), at1),
                ]
            }
        };
        for (cx, v) in v.into_iter().enumerate() {
            let weight = _mm256_mul_ps(_mm256_mul_ps(wx[cx], wy[cy]), wz[cz]);
            acc = _mm256_add_ps(acc, _mm256_mul_ps(weight, v));
        }
    }
    (acc, bad)
}

/// The velocity at eight points `g` (cell-centre grid coordinates) as
/// `FaceSampler::at` finds it anywhere (component `a` on its lattice at
/// `g + ½e_a`, wrapped or clamped by `wrap`), and the lanes left to the
/// scalar path (all ones).
///
/// # Safety
/// The CPU has AVX2 and `vel.dims` passes [`lattices`].
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn velocity8_wrapped(vel: Lattices, wrap: Wrap, g: [__m256; 3]) -> ([__m256; 3], __m256i) {
    let mut u = [_mm256_setzero_ps(); 3];
    let mut bad = _mm256_setzero_si256();
    for (b, ub) in u.iter_mut().enumerate() {
        let mut p = g;
        p[b] = _mm256_add_ps(p[b], _mm256_set1_ps(0.5));
        // SAFETY: the lattice of b has vel.data[b]'s length (fits).
        let (v, lanes) = unsafe { stencil8(vel.data[b], vel.dims[b], wrap, p) };
        *ub = v;
        bad = _mm256_or_si256(bad, lanes);
    }
    (u, bad)
}

/// `x` wrapped into `[−½, n − ½)` as the density's scalar `wrap1` does for
/// points less than a period outside (one add or subtract of `n`), and
/// the lanes further out (all ones), which need its remainder.
#[inline]
#[target_feature(enable = "avx2")]
fn wrap8(x: __m256, n: usize) -> (__m256, __m256i) {
    let (lo, len) = (_mm256_set1_ps(-0.5), _mm256_set1_ps(n as f32));
    let hi = _mm256_set1_ps(-0.5 + n as f32);
    let below = _mm256_cmp_ps::<_CMP_LT_OQ>(x, lo);
    let above = _mm256_cmp_ps::<_CMP_GE_OQ>(x, hi);
    let (up, down) = (_mm256_add_ps(x, len), _mm256_sub_ps(x, len));
    let far = _mm256_or_ps(
        _mm256_andnot_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(up, lo), below),
        _mm256_andnot_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(down, hi), above),
    );
    let y = _mm256_blendv_ps(_mm256_blendv_ps(x, up, below), down, above);
    (y, _mm256_castps_si256(far))
}

/// Eight arbitrary points `g` (cell-centre grid coordinates), in place:
/// their departure points through `vel` over `dt_cells = Δt/Δx` (Euler or
/// RK2) as `semi_lagrangian::departure_point` finds them — the stencils
/// wrapped or clamped by `wrap` as the scalar `Stencil` does — and, with
/// `into_box = Some(n)`, wrapped into the periodic box of `n` cells as the
/// density's `wrap_grid`. Returns a bit mask (bit `l` for lane `l`) of the
/// lanes it leaves to the scalar path (RK3, points more than a period
/// outside, NaN): those points are not written. The gridless walk's and
/// SELMA's kernel (eq 7.4's `B_k`).
///
/// # Safety
/// The CPU has AVX2 ([`lattices`]) and `vel.dims` passes [`lattices`].
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn points8(
    vel: Lattices,
    wrap: Wrap,
    g: &mut [Vec3; 8],
    dt_cells: f32,
    backtrace: Backtrace,
    into_box: Option<[usize; 3]>,
) -> u32 {
    if backtrace == Backtrace::Rk3 {
        return 0xff;
    }
    let c: [__m256; 3] = std::array::from_fn(|a| {
        let lanes: [f32; 8] = std::array::from_fn(|l| g[l][a]);
        load8(&lanes, 0)
    });
    let step = |u: [__m256; 3], s: f32| -> [__m256; 3] {
        std::array::from_fn(|a| _mm256_sub_ps(c[a], _mm256_mul_ps(_mm256_set1_ps(s), u[a])))
    };
    // SAFETY (both): as this function's.
    let (u0, mut bad) = unsafe { velocity8_wrapped(vel, wrap, c) };
    let mut p = if backtrace == Backtrace::Rk2 {
        let (u1, bad1) = unsafe { velocity8_wrapped(vel, wrap, step(u0, 0.5 * dt_cells)) };
        bad = _mm256_or_si256(bad, bad1);
        step(u1, dt_cells)
    } else {
        step(u0, dt_cells)
    };
    if let Some(n) = into_box {
        for (pa, n) in p.iter_mut().zip(n) {
            let (y, far) = wrap8(*pa, n);
            *pa = y;
            bad = _mm256_or_si256(bad, far);
        }
    }
    let bad = _mm256_movemask_ps(_mm256_castsi256_ps(bad)) as u32;
    let mut lanes = [[0.0f32; 8]; 3];
    for (l, pa) in lanes.iter_mut().zip(p) {
        store8(l, pa);
    }
    for (l, gl) in g.iter_mut().enumerate() {
        if bad & (1 << l) == 0 {
            *gl = Vec3::new(lanes[0][l], lanes[1][l], lanes[2][l]);
        }
    }
    bad
}

/// The velocity at eight points `g` (cell-centre grid coordinates) as
/// `FaceSampler::at` finds them, into `out`; returns a bit mask (bit `l` for
/// lane `l`) of the lanes left to the scalar path (points more than a period
/// outside, NaN), whose `out` is not written. The batched point query,
/// [`crate::grid::FaceGrid::sample_points`].
///
/// # Safety
/// The CPU has AVX2 and `vel.dims` passes [`lattices`].
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn velocities8(
    vel: Lattices,
    wrap: Wrap,
    g: &[Vec3; 8],
    out: &mut [Vec3; 8],
) -> u32 {
    let c: [__m256; 3] = std::array::from_fn(|a| {
        let lanes: [f32; 8] = std::array::from_fn(|l| g[l][a]);
        load8(&lanes, 0)
    });
    // SAFETY: as this function's.
    let (u, bad) = unsafe { velocity8_wrapped(vel, wrap, c) };
    let bad = _mm256_movemask_ps(_mm256_castsi256_ps(bad)) as u32;
    let mut lanes = [[0.0f32; 8]; 3];
    for (l, ua) in lanes.iter_mut().zip(u) {
        store8(l, ua);
    }
    for (l, o) in out.iter_mut().enumerate() {
        if bad & (1 << l) == 0 {
            *o = Vec3::new(lanes[0][l], lanes[1][l], lanes[2][l]);
        }
    }
    bad
}

#[cfg(test)]
mod tests {
    use super::super::simd512::{has_avx512, points16};
    use super::*;
    use crate::advection::departure_point;
    use crate::domain::Domain;
    use crate::field::VectorField;
    use crate::grid::face::BoxKind;
    use crate::grid::FaceGrid;

    /// A smooth swirl of speed up to about 3 cells per unit time on a box of 12 cells.
    struct Swirl;

    impl VectorField for Swirl {
        fn eval(&self, p: Vec3) -> Vec3 {
            3.0 * Vec3::new((2.0 * p.y).sin(), (1.5 * p.z).cos(), (p.x + p.y).sin())
        }
    }

    /// Points spread over the box and half a cell beyond each face (where the
    /// stencils wrap or clamp), the box's edges themselves, and −0.
    fn points(n: usize) -> Vec<Vec3> {
        let mut s = 7u32;
        let mut next = || {
            s = s.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            (s >> 8) as f32 / (1 << 24) as f32
        };
        let span = n as f32 + 1.0;
        let mut p: Vec<Vec3> = (0..4000)
            .map(|_| Vec3::new(next(), next(), next()) * span - 1.0)
            .collect();
        let edges = [-0.5, -0.0, 0.0, n as f32 - 1.0, n as f32 - 0.5];
        for (i, &x) in edges.iter().enumerate() {
            for &y in &edges {
                p.push(Vec3::new(x, y, edges[(i + 2) % edges.len()]));
            }
        }
        p
    }

    #[test]
    fn kernels_do_every_lane_and_match_the_scalar_backtrace_to_the_bit() {
        let n = 12;
        let domain = Domain::cube(n, 1.0).unwrap();
        for kind in [BoxKind::Periodic, BoxKind::Closed] {
            let vel = FaceGrid::from_field(domain, kind, &Swirl);
            let lat = lattices(vel.sampler()).expect("the test needs AVX2");
            let pts = points(n);
            for bt in [Backtrace::Euler, Backtrace::Rk2] {
                let dt_cells = 0.4;
                let want: Vec<Vec3> = pts
                    .iter()
                    .map(|&p| departure_point(&vel, p, dt_cells, bt))
                    .collect();
                let same = |got: &[Vec3], want: &[Vec3]| {
                    got.iter()
                        .zip(want)
                        .all(|(g, w)| (0..3).all(|a| g[a].to_bits() == w[a].to_bits()))
                };
                for (group, want) in pts.chunks_exact(8).zip(want.chunks_exact(8)) {
                    let mut g: [Vec3; 8] = group.try_into().unwrap();
                    // SAFETY: `lattices` checked AVX2.
                    let left = unsafe { points8(lat, kind.wrap(), &mut g, dt_cells, bt, None) };
                    assert_eq!(left, 0, "{kind} {bt:?}: lanes left at {group:?}");
                    assert!(same(&g, want), "{kind} {bt:?}: {g:?} != {want:?}");
                }
                if !has_avx512() {
                    continue;
                }
                for (group, want) in pts.chunks_exact(16).zip(want.chunks_exact(16)) {
                    let mut g: [Vec3; 16] = group.try_into().unwrap();
                    // SAFETY: `has_avx512`, `lattices`.
                    let left = unsafe { points16(lat, kind.wrap(), &mut g, dt_cells, bt, None) };
                    assert_eq!(left, 0, "{kind} {bt:?}: lanes left at {group:?}");
                    assert!(same(&g, want), "{kind} {bt:?}: {g:?} != {want:?}");
                }
            }
        }
    }

    #[test]
    fn kernels_leave_points_beyond_a_period_and_nan_to_the_scalar_path() {
        let n = 12;
        let vel = FaceGrid::from_field(Domain::cube(n, 1.0).unwrap(), BoxKind::Periodic, &Swirl);
        let lat = lattices(vel.sampler()).expect("the test needs AVX2");
        let mut g = [Vec3::splat(5.0); 8];
        g[1].x = -20.0; // more than a period below: the stencil's remainder
        g[3].y = 30.0;
        g[6].z = f32::NAN;
        let before = g;
        // SAFETY: `lattices` checked AVX2.
        let left = unsafe { points8(lat, Wrap::Periodic, &mut g, 0.4, Backtrace::Rk2, None) };
        assert_eq!(left, 0b0100_1010);
        assert_eq!(g[1], before[1], "left lanes are not written");
        assert_eq!(g[0], departure_point(&vel, before[0], 0.4, Backtrace::Rk2));
    }
}
