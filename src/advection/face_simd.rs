//! AVX2 kernel of the semi-Lagrangian face sweep
//! ([`super::semi_lagrangian::advect_faces`], eq 6.5): eight consecutive
//! faces of one x-row traced back together (Euler or RK2) and interpolated
//! at their departure points, the trilinear corners fetched by gathers.
//!
//! Every lane does the scalar sweep's floating-point operations in the same
//! order (products and sums, no fused multiply-add), so its results are the
//! scalar path's to the bit. It covers faces at least one face from every
//! edge of the box whose whole stencils lie inside the lattices; a group of
//! eight with any lane outside returns `None` and the caller does those
//! faces one by one through the wrapping scalar path.

use std::arch::x86_64::*;

use super::Backtrace;

/// The velocity lattices: component slices, lattice sizes `[mx, my, mz]`
/// and the domain's cell counts, as [`crate::grid::face::FaceSampler`] holds
/// them.
#[derive(Clone, Copy)]
pub(super) struct Lattices<'a> {
    /// Components `[u, v, w]`, flat `[z][y][x]`.
    pub data: [&'a [f32]; 3],
    /// Lattice size of each component.
    pub dims: [[usize; 3]; 3],
}

/// Whether this CPU runs [`faces8`].
pub(super) fn available() -> bool {
    is_x86_feature_detected!("avx2")
}

/// Whether the AVX2 kernel can index lattices of these sizes (gathers take
/// 32-bit indices).
pub(super) fn fits(dims: &[[usize; 3]; 3]) -> bool {
    dims.iter()
        .all(|d| d[0] * d[1] * d[2] < i32::MAX as usize / 2)
}

/// `⌊g⌋` per lane and `g − ⌊g⌋`, and whether `0 ≤ ⌊g⌋ ≤ n − 2` in every
/// lane (the scalar `floor_inside`: truncation plus a correction).
#[inline]
#[target_feature(enable = "avx2")]
fn floor_inside8(g: __m256, n: usize) -> (__m256i, __m256, bool) {
    let t = _mm256_cvttps_epi32(g);
    // −1 where the truncation rounded up (negative non-integers).
    let up = _mm256_castps_si256(_mm256_cmp_ps::<_CMP_GT_OQ>(_mm256_cvtepi32_ps(t), g));
    let f = _mm256_add_epi32(t, up);
    let frac = _mm256_sub_ps(g, _mm256_cvtepi32_ps(f));
    let low = _mm256_cmpgt_epi32(f, _mm256_set1_epi32(-1));
    let high = _mm256_cmpgt_epi32(_mm256_set1_epi32(n as i32 - 1), f);
    let ok = _mm256_movemask_epi8(_mm256_and_si256(low, high)) == -1;
    (f, frac, ok)
}

/// Trilinear interpolation of `data` (lattice `d`) at lattice coordinates
/// `(gx, gy, gz)` in eight lanes, or `None` if a stencil leaves the lattice.
///
/// # Safety
/// `data.len() ≥ mx·my·mz < 2³⁰` ([`fits`]) and the CPU has AVX2.
#[inline]
#[target_feature(enable = "avx2")]
unsafe fn trilinear8(data: &[f32], d: [usize; 3], g: [__m256; 3]) -> Option<__m256> {
    let (x, tx, okx) = floor_inside8(g[0], d[0]);
    let (y, ty, oky) = floor_inside8(g[1], d[1]);
    let (z, tz, okz) = floor_inside8(g[2], d[2]);
    if !(okx && oky && okz) {
        return None;
    }
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
    for c in 0..8 {
        let (cx, cy, cz) = (c & 1, c >> 1 & 1, c >> 2);
        let weight = _mm256_mul_ps(_mm256_mul_ps(wx[cx], wy[cy]), wz[cz]);
        let at = _mm256_add_epi32(
            r,
            _mm256_set1_epi32(cx as i32 + cy as i32 * nx + cz as i32 * nxy),
        );
        // SAFETY: every lane has x ≤ mx − 2, y ≤ my − 2, z ≤ mz − 2, so its
        // index is at most ((z + 1)·my + y + 1)·mx + x + 1 < mx·my·mz ≤
        // data.len(), and below 2³⁰ (no i32 overflow, [`fits`]).
        let v = unsafe { _mm256_i32gather_ps::<4>(data.as_ptr(), at) };
        acc = _mm256_add_ps(acc, _mm256_mul_ps(weight, v));
    }
    Some(acc)
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
/// The CPU has AVX2 ([`available`]) and `vel.dims` passes [`fits`]; `data`
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
    let step = |u: [__m256; 3], s: f32| -> [__m256; 3] {
        std::array::from_fn(|a| _mm256_sub_ps(c[a], _mm256_mul_ps(_mm256_set1_ps(s), u[a])))
    };
    let g = match backtrace {
        Backtrace::Euler => step(u0, dt_cells),
        Backtrace::Rk2 => {
            let mid = step(u0, 0.5 * dt_cells);
            let mut u1 = [_mm256_setzero_ps(); 3];
            for (b, u) in u1.iter_mut().enumerate() {
                let mut p = mid;
                p[b] = _mm256_add_ps(p[b], _mm256_set1_ps(0.5));
                // SAFETY: the lattice of b has vel.data[b]'s length (fits).
                *u = unsafe { trilinear8(vel.data[b], vel.dims[b], p) }?;
            }
            step(u1, dt_cells)
        }
        Backtrace::Rk3 => return None,
    };
    let mut p = g;
    p[A] = _mm256_add_ps(p[A], _mm256_set1_ps(0.5));
    // SAFETY: `data` has component A's lattice length (caller).
    let v = unsafe { trilinear8(data, vel.dims[A], p) }?;
    let mut out = [0.0; 8];
    // SAFETY: `out` holds eight f32.
    unsafe { _mm256_storeu_ps(out.as_mut_ptr(), v) };
    Some(out)
}
