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

use std::arch::x86_64::*;

use glam::Vec3;

use crate::grid::face::FaceSampler;

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
        let pairs = data.as_ptr().cast::<i64>();
        // SAFETY: every lane has x ≤ mx − 2, y ≤ my − 2, z ≤ mz − 2 (lanes
        // outside read x = y = z = 0, and every m ≥ 2), so the pair at its
        // index ends at most at ((z + 1)·my + y + 1)·mx + x + 1
        // < mx·my·mz ≤ data.len(); indices are below 2³⁰ (no i32 overflow,
        // [`lattices`]); gathers need no alignment.
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
        let split = |v: __m256| {
            _mm256_castpd_ps(_mm256_permute4x64_pd::<0b11_01_10_00>(_mm256_castps_pd(v)))
        };
        let v = [
            split(_mm256_shuffle_ps::<0b10_00_10_00>(low, high)),
            split(_mm256_shuffle_ps::<0b11_01_11_01>(low, high)),
        ];
        for (cx, v) in v.into_iter().enumerate() {
            let weight = _mm256_mul_ps(_mm256_mul_ps(wx[cx], wy[cy]), wz[cz]);
            acc = _mm256_add_ps(acc, _mm256_mul_ps(weight, v));
        }
    }
    (acc, ok)
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
/// `vel` over `dt_cells = Δt/Δx`, or `None` (nothing written) if a stencil
/// would wrap or clamp. Euler and RK2 only.
///
/// The caller keeps `1 ≤ i`, `i + 8 ≤ n_x − 1`, `1 ≤ j ≤ n_y − 2` and
/// `1 ≤ k ≤ n_z − 2` with `n` the cell counts, so the face velocities
/// (the four-face averages of `FaceSampler::at_face`) need no wrap.
///
/// # Safety
/// The CPU has AVX2 ([`lattices`]) and `vel.dims` passes [`lattices`]; `data`
/// has component `A`'s lattice length.
#[target_feature(enable = "avx2")]
pub(super) unsafe fn faces8<const A: usize>(
    vel: Lattices,
    data: &[f32],
    f: [usize; 3],
    dt_cells: f32,
    backtrace: Backtrace,
) -> Option<[f32; 8]> {
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
        return None;
    }
    let mut p = g;
    p[A] = _mm256_add_ps(p[A], _mm256_set1_ps(0.5));
    // SAFETY: `data` has component A's lattice length (caller).
    let (v, inside) = unsafe { trilinear8(data, vel.dims[A], p) };
    if !all(inside) {
        return None;
    }
    let mut out = [0.0; 8];
    store8(&mut out, v);
    Some(out)
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

/// The departure points of eight arbitrary points `g` (cell-centre grid
/// coordinates, unwrapped) traced back through `vel` over `dt_cells =
/// Δt/Δx` (Euler or RK2) as `semi_lagrangian::departure_point` does, and a
/// bit mask of the lanes (bit `l` for lane `l`) where a stencil would wrap
/// or clamp: their points are not the scalar path's and must be redone by
/// it. The gridless walk's kernel (eq 7.4's `B_k`).
///
/// # Safety
/// The CPU has AVX2 ([`lattices`]) and `vel.dims` passes [`lattices`].
#[target_feature(enable = "avx2")]
pub(crate) unsafe fn points8(
    vel: Lattices,
    g: &[Vec3; 8],
    dt_cells: f32,
    backtrace: Backtrace,
) -> ([Vec3; 8], u32) {
    let c: [__m256; 3] = std::array::from_fn(|a| {
        let lanes: [f32; 8] = std::array::from_fn(|l| g[l][a]);
        load8(&lanes, 0)
    });
    // SAFETY (both): as this function's.
    let (u0, ok0) = unsafe { velocity8(vel, c) };
    let (p, ok1) = unsafe { trace8(vel, c, u0, dt_cells, backtrace) };
    let mut lanes = [[0.0f32; 8]; 3];
    for (l, pa) in lanes.iter_mut().zip(p) {
        store8(l, pa);
    }
    let ok = _mm256_and_si256(ok0, ok1);
    let outside = !_mm256_movemask_ps(_mm256_castsi256_ps(ok)) as u32 & 0xff;
    let points = std::array::from_fn(|l| Vec3::new(lanes[0][l], lanes[1][l], lanes[2][l]));
    (points, outside)
}
