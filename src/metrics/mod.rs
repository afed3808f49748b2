//! Diagnostics computed on grids: divergence, mirror symmetry of densities
//! and velocity, the divergence tracers feel ([`interpolant`]) and where the
//! energy sits in wavenumber ([`spectrum`]).

pub mod interpolant;
pub mod spectrum;

use rayon::prelude::*;

pub use interpolant::{face_interpolant_divergence, interpolant_divergence, probe_points};
pub use spectrum::SpectralShare;

use crate::grid::{FaceGrid, ScalarGrid};

/// Root-mean-square and maximum of a set of values.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct RmsMax {
    /// √(mean v²).
    pub rms: f32,
    /// max |v|.
    pub max: f32,
}

/// `Σ v²` (in f64) and `max |v|` of a slice, in eight independent lanes
/// (a fixed order, so the sum does not depend on how the caller splits its
/// work; one running sum or max would serialise on its latency).
#[inline(always)]
fn squares_and_max(values: &[f32]) -> (f64, f32) {
    let (mut sums, mut maxima) = ([0.0f64; 8], [0.0f32; 8]);
    let chunks = values.chunks_exact(8);
    let rest = chunks.remainder();
    for c in chunks {
        for l in 0..8 {
            sums[l] += c[l] as f64 * c[l] as f64;
            maxima[l] = larger(maxima[l], c[l].abs());
        }
    }
    let mut sum = sums.iter().sum::<f64>();
    let mut max = maxima.into_iter().fold(0.0, larger);
    for &v in rest {
        sum += v as f64 * v as f64;
        max = larger(max, v.abs());
    }
    (sum, max)
}

/// The maxima over paired rows `a`, `b` of each of the `M` non-negative
/// measures `f(a_i, b_i)`, in eight independent lanes (maxima are exact in
/// any order; a single running max would serialise on its latency).
#[inline(always)]
fn pair_maxima<const M: usize>(a: &[f32], b: &[f32], f: impl Fn(f32, f32) -> [f32; M]) -> [f32; M] {
    let mut lanes = [[0.0f32; 8]; M];
    let (ca, cb) = (a.chunks_exact(8), b.chunks_exact(8));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..8 {
            let v = f(x[l], y[l]);
            for m in 0..M {
                lanes[m][l] = larger(lanes[m][l], v[m]);
            }
        }
    }
    let mut out = lanes.map(|l| l.into_iter().fold(0.0, larger));
    for (&x, &y) in ra.iter().zip(rb) {
        let v = f(x, y);
        for m in 0..M {
            out[m] = larger(out[m], v[m]);
        }
    }
    out
}

/// The larger of `a` and `b`, `a` if `b` is NaN (as `f32::max` for the
/// non-negative, non-NaN `a` of a running maximum), in the form that
/// compiles to one `maxps`.
#[inline(always)]
fn larger(a: f32, b: f32) -> f32 {
    if b > a {
        b
    } else {
        a
    }
}

/// Share of a periodic staggered velocity's kinetic energy in the top octave
/// of wavenumbers (index beyond `N/4` on some axis): the three face
/// components together, each transformed on its own lattice (a cell-centred
/// average would hide exactly the alternating modes this looks for).
///
/// # Panics
/// If `vel` is in a closed box or `spectrum` was planned for other dims.
pub fn top_octave_share(spectrum: &mut SpectralShare, vel: &FaceGrid) -> f64 {
    assert_eq!(
        vel.kind(),
        crate::grid::BoxKind::Periodic,
        "top_octave_share: closed box"
    );
    spectrum.share_above(
        &[vel.slice(0), vel.slice(1), vel.slice(2)],
        vel.domain().dims.map(|n| n / 4),
    )
}

/// Values per task of the parallel reductions: the partial sums of fixed
/// chunks are added in chunk order, so a sum does not depend on the thread
/// count.
const CHUNK: usize = 1 << 14;

/// RMS and max |v| of a slice ([`squares_and_max`] of fixed chunks, added
/// in order: the same bits at any thread count).
pub fn rms_max(values: &[f32]) -> RmsMax {
    let chunks: Vec<(f64, f32)> = values.par_chunks(CHUNK).map(squares_and_max_fast).collect();
    let (sum, max) = chunks
        .iter()
        .fold((0.0, 0.0f32), |(s, m), &(cs, cm)| (s + cs, larger(m, cm)));
    RmsMax {
        rms: (sum / values.len().max(1) as f64).sqrt() as f32,
        max,
    }
}

/// `fn $name(args) -> T`: `$kernel(args)`, compiled with AVX2 where the CPU
/// has it — the same operations in the same order (no fused multiply-add;
/// the reductions' lanes are explicit), so the same bits, in four or eight
/// lanes per instruction instead of SSE2's two or four. `$kernel` and what
/// it calls are `#[inline(always)]`, to be compiled into the AVX2 copy.
macro_rules! with_avx2 {
    ($(#[$doc:meta])* fn $name:ident = $kernel:ident($($arg:ident: $ty:ty),*) -> $ret:ty) => {
        $(#[$doc])*
        fn $name($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2")]
                fn avx2($($arg: $ty),*) -> $ret {
                    $kernel($($arg),*)
                }
                if is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has AVX2 (just detected).
                    return unsafe { avx2($($arg),*) };
                }
            }
            $kernel($($arg),*)
        }
    };
}

with_avx2! {
    /// [`squares_and_max`], with AVX2.
    fn squares_and_max_fast = squares_and_max(values: &[f32]) -> (f64, f32)
}

with_avx2! {
    /// [`mirror_slab_pair`], with AVX2.
    fn mirror_slab_pair_fast = mirror_slab_pair(a: &[f32], b: &[f32], nx: usize) -> [f32; 2]
}

with_avx2! {
    /// [`velocity_slab`], with AVX2.
    fn velocity_slab_fast = velocity_slab(vel: &FaceGrid, k: usize, div: &mut [f32]) -> (f64, f32, [f32; 2])
}

/// Mirror-symmetry error between two gases that should be each other's image
/// through the mid-plane `y = L/2`:
/// `max |a(i,j,k) − b(i, ny−1−j, k)| / max(max|a|, max|b|)` (0 when both are
/// empty). One pass over both grids.
///
/// # Panics
/// If the grids have different domains.
pub fn mirror_error(a: &ScalarGrid, b: &ScalarGrid) -> f32 {
    assert_eq!(a.domain(), b.domain(), "mirror_error: domains differ");
    let [nx, ny, _] = a.domain().dims;
    let (sa, sb) = (a.as_slice(), b.as_slice());
    let [diff, scale] = sa
        .par_chunks(nx * ny)
        .zip(sb.par_chunks(nx * ny))
        .map(|(pa, pb)| mirror_slab_pair_fast(pa, pb, nx))
        .reduce(|| [0.0; 2], larger2);
    if scale == 0.0 {
        0.0
    } else {
        diff / scale
    }
}

/// Of z-slabs `a` and `b` of two gases (rows of `nx`): `max |a − b
/// mirrored|` and `max(max |a|, max |b|)` ([`mirror_error`]).
#[inline(always)]
fn mirror_slab_pair(a: &[f32], b: &[f32], nx: usize) -> [f32; 2] {
    let ny = a.len() / nx;
    (0..ny).fold([0.0; 2], |acc, j| {
        let (ra, rb) = (&a[j * nx..][..nx], &b[(ny - 1 - j) * nx..][..nx]);
        larger2(
            acc,
            pair_maxima(ra, rb, |x, y| [(x - y).abs(), larger(x.abs(), y.abs())]),
        )
    })
}

/// A velocity's mirror-symmetry error and its largest face value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityMirror {
    /// `max |difference| / max |u_a|` ([`velocity_stats`]; 0 for a fluid at rest).
    pub error: f32,
    /// `max_a max_faces |u_a|`, [`FaceGrid::max_norm`].
    pub max_norm: f32,
}

/// What is measured of a velocity after every step, in one pass over its
/// faces ([`velocity_stats`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VelocityStats {
    /// RMS and max of the compact divergence `D u` ([`FaceGrid::divergence`]),
    /// the operator the pressure solve annihilates: round-off after a step.
    pub divergence: RmsMax,
    /// Mirror-symmetry error through the mid-plane `y = L/2`, and `max |u_a|`.
    pub mirror: VelocityMirror,
}

/// The compact divergence's rms and max, and the mirror-symmetry error of a
/// velocity through the mid-plane `y = L/2` — the mirror image of `(u, v,
/// w)` is `(u, −v, w)` reflected, so `u` and `w` at row `j` compare with row
/// `ny − 1 − j`, and `v` on the y-face `j` with minus the y-face `ny − j`
/// (wrapped in a periodic box); `max |difference| / max |u_a|` over all
/// faces (0 for a fluid at rest) — with the `max |u_a|` it divides by.
///
/// One z-slab at a time: the divergence of slab `k` (no grid is allocated)
/// and the mirror of every component's slab `k` while it is in cache; the
/// per-slab sums are added in slab order, so the result does not depend on
/// the thread count.
pub fn velocity_stats(vel: &FaceGrid) -> VelocityStats {
    let [nx, ny, nz] = vel.domain().dims;
    let slabs: Vec<(f64, f32, [f32; 2])> = (0..nz)
        .into_par_iter()
        .map_init(
            || vec![0.0f32; nx * ny],
            |div, k| velocity_slab_fast(vel, k, div),
        )
        .collect();
    // A closed box's top wall of w-faces, beyond the cells' slabs.
    let wall = (nz..vel.face_dims(2)[2])
        .map(|k| mirror_slab(vel, 2, k))
        .fold([0.0; 2], larger2);
    let (sum, max, [diff, scale]) = slabs
        .iter()
        .fold((0.0, 0.0f32, wall), |(s, m, r), &(ds, dm, dr)| {
            (s + ds, larger(m, dm), larger2(r, dr))
        });
    VelocityStats {
        divergence: RmsMax {
            rms: (sum / vel.domain().len() as f64).sqrt() as f32,
            max,
        },
        mirror: VelocityMirror {
            error: if scale == 0.0 { 0.0 } else { diff / scale },
            max_norm: scale,
        },
    }
}

/// [`velocity_stats`] of z-slab `k`: `Σ (D u)²` and `max |D u|` of its
/// cells (the divergence written to `div`), and [`mirror_slab`] of each
/// component's slab `k`.
#[inline(always)]
fn velocity_slab(vel: &FaceGrid, k: usize, div: &mut [f32]) -> (f64, f32, [f32; 2]) {
    vel.divergence_slab(k, div);
    let (squares, max) = squares_and_max(div);
    let mirror = (0..3)
        .map(|a| mirror_slab(vel, a, k))
        .fold([0.0; 2], larger2);
    (squares, max, mirror)
}

/// Of component `a`'s z-slab `k` of faces: `max |u_a − mirror image|` and
/// `max |u_a|` ([`velocity_stats`]).
#[inline(always)]
fn mirror_slab(vel: &FaceGrid, a: usize, k: usize) -> [f32; 2] {
    let ny = vel.domain().dims[1];
    let [mx, my, _] = vel.face_dims(a);
    let slab = &vel.slice(a)[k * mx * my..][..mx * my];
    let sign = if a == 1 { -1.0 } else { 1.0 };
    let mirror = |j: usize| {
        if a == 1 {
            (my + ny - j) % my
        } else {
            my - 1 - j
        }
    };
    (0..my).fold([0.0; 2], |acc, j| {
        let (x, y) = (&slab[j * mx..][..mx], &slab[mirror(j) * mx..][..mx]);
        larger2(
            acc,
            pair_maxima(x, y, |x, y| [(x - sign * y).abs(), x.abs()]),
        )
    })
}

/// [`larger`] of each of two pairs.
#[inline(always)]
fn larger2(a: [f32; 2], b: [f32; 2]) -> [f32; 2] {
    [larger(a[0], b[0]), larger(a[1], b[1])]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Domain;
    use crate::field::ops;
    use crate::grid::BoxKind;
    use glam::Vec3;

    #[test]
    fn compact_divergence_of_shear_is_zero_and_of_a_wave_is_exact() {
        let d = Domain::cube(8, 8.0).unwrap();
        let kind = BoxKind::Periodic;
        let shear = FaceGrid::from_field(d, kind, &*ops::constant_vector(Vec3::X));
        assert_eq!(velocity_stats(&shear).divergence.max, 0.0);
        // u = sin(kx) x̂ with k = 2π/8, Δx = 1, sampled on the x-faces
        // x = i: the compact difference at the centre x = i + ½ is
        // 2 sin(k/2) cos(k(i + ½)), largest where |cos| = cos(π/8).
        struct Wave;
        impl crate::field::VectorField for Wave {
            fn eval(&self, p: Vec3) -> Vec3 {
                Vec3::new((std::f32::consts::TAU * p.x / 8.0).sin(), 0.0, 0.0)
            }
        }
        let w = FaceGrid::from_field(d, kind, &Wave);
        let expect = 2.0 * (std::f32::consts::PI / 8.0).sin() * (std::f32::consts::PI / 8.0).cos();
        let stats = velocity_stats(&w);
        assert!((stats.divergence.max - expect).abs() < 1e-5);
        // The slab-by-slab pass agrees with the whole-grid operator.
        let mut div = ScalarGrid::zeros(d);
        w.divergence(&mut div);
        let whole = rms_max(div.as_slice());
        assert_eq!(stats.divergence.max, whole.max);
        assert!((stats.divergence.rms - whole.rms).abs() <= 1e-6 * whole.rms);
        assert_eq!(stats.mirror.max_norm, w.max_norm());
    }

    #[test]
    fn rms_max_is_the_same_at_any_thread_count() {
        // 300 007 values: eighteen full chunks and a partial one.
        let values: Vec<f32> = (0..300_007u32)
            .map(|i| ((i.wrapping_mul(2_654_435_761) >> 8) as f32 / 16_777_216.0 - 0.5) * 3.0)
            .collect();
        let on = |n| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap();
            pool.install(|| rms_max(&values))
        };
        let one = on(1);
        let three = on(3);
        assert_eq!(
            [one.rms.to_bits(), one.max.to_bits()],
            [three.rms.to_bits(), three.max.to_bits()]
        );
        // The values are uniform on [−1.5, 1.5): rms √0.75 = 0.866 (measured
        // 0.8661), max just below 1.5.
        let plain =
            (values.iter().map(|&v| v as f64 * v as f64).sum::<f64>() / values.len() as f64).sqrt();
        assert!(
            (one.rms as f64 - plain).abs() <= 1e-6 * plain,
            "{one:?} against {plain}"
        );
        assert_eq!(one.max, values.iter().fold(0.0f32, |m, v| m.max(v.abs())));
    }

    #[test]
    fn mirror_error_sees_flips() {
        let d = Domain::cube(8, 8.0).unwrap();
        let a = ScalarGrid::from_field(d, &*ops::mask(ops::sphere(Vec3::new(4.0, 2.0, 4.0), 1.5)));
        let b = ScalarGrid::from_field(d, &*ops::mask(ops::sphere(Vec3::new(4.0, 6.0, 4.0), 1.5)));
        assert_eq!(mirror_error(&a, &b), 0.0);
        assert_eq!(mirror_error(&a, &a), 1.0);
    }

    #[test]
    fn velocity_mirror_error_sees_asymmetric_flow() {
        let d = Domain::cube(8, 8.0).unwrap();
        // A vertical jet through the mid-plane is symmetric: v(y) = v(L − y)
        // mirrors to −v, so use a periodic v odd about the mid-plane.
        struct Odd;
        impl crate::field::VectorField for Odd {
            fn eval(&self, p: Vec3) -> Vec3 {
                Vec3::new(
                    1.0,
                    0.3 * (std::f32::consts::TAU * (p.y - 4.0) / 8.0).sin(),
                    0.5,
                )
            }
        }
        let kind = BoxKind::Periodic;
        let sym = FaceGrid::from_field(d, kind, &Odd);
        let m = velocity_stats(&sym).mirror;
        assert!(m.error < 1e-6);
        assert_eq!(m.max_norm, sym.max_norm());
        let up = FaceGrid::from_field(d, kind, &*ops::constant_vector(Vec3::Y));
        assert_eq!(velocity_stats(&up).mirror.error, 2.0);
    }
}
