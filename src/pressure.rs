//! Exact fast-Poisson pressure projection and exact viscosity on the MAC grid.
//!
//! # Projection
//!
//! With the compact operators of [`FaceGrid`] (`D` face → cell, `G` cell →
//! face, `L = D G` the 7-point Laplacian), [`PressureSolver::project`] solves
//!
//! ```text
//! L p = D u*,        u = u* − G p          ⇒   D u = D u* − L p = 0
//! ```
//!
//! exactly (up to round-off), by diagonalising `L` with a fast transform:
//!
//! - **periodic box** — `L` is circulant. With the DFT `p̂(m) = Σ_c p[c]
//!   e^{−2πi Σ_a m_a c_a / N_a}` (real-to-complex along x with realfft,
//!   complex along y and z with rustfft), its eigenvalues are
//!
//!   ```text
//!   λ(m) = −Σ_a (2 sin(π m_a / N_a) / Δx)²,     m_a = 0 … N_a − 1;
//!   ```
//!
//! - **closed box** (wall faces held at zero, so `L` has homogeneous Neumann
//!   conditions, mirror ghost `p[−1] = p[0]`) — with the DCT-II
//!   `p̂(m) = Σ_c p[c] Π_a cos(π m_a (2 c_a + 1) / 2N_a)` forward and the
//!   DCT-III back (rustdct), the eigenvalues are
//!
//!   ```text
//!   λ(m) = −Σ_a (2 sin(π m_a / 2N_a) / Δx)²,    m_a = 0 … N_a − 1.
//!   ```
//!
//! In both cases the only vanishing eigenvalue is the zero mode `m = 0` (the
//! mean of `p`), which is *pinned*: `p̂(0) = 0`, so the returned pressure has
//! zero mean. The zero mode of `D u*` is zero in exact arithmetic (periodic:
//! the sum telescopes; closed: the wall faces are zero), so nothing is lost.
//! There is no Nyquist special case: `sin(π m/N)` vanishes only at `m = 0`,
//! for even and odd `N` alike.
//!
//! One forward transform of the divergence and one inverse transform of the
//! pressure per projection — not a transform pair per velocity component.
//!
//! Normalisation: the transforms are unnormalised; the inverse is scaled by
//! `1 / (N_x N_y N_z)` (FFT) or `Π_a 2 / N_a` (DCT-II → DCT-III) at the end.
//!
//! # Viscosity
//!
//! [`PressureSolver::diffuse`] applies the heat kernel of the design notes
//! exactly, per mode and per component on its own face lattice:
//!
//! ```text
//! û_a(m) ← û_a(m) · exp(−ν |k(m)|² Δt),     k_a = 2π m_a / (N_a Δx)
//! ```
//!
//! with `m_a` the signed index (periodic; `k_a = π m_a / (N_a Δx)` for the
//! sine/cosine modes of the closed box). `|k|²` is the continuous wavenumber,
//! not the 7-point symbol `(2 sin(k Δx / 2) / Δx)² = k² (1 − k²Δx²/12 + …)`:
//! a resolved mode then decays exactly as in the continuum (the Taylor–Green
//! vortex to round-off), and the kernel is unconditionally stable. The gain
//! depends on the mode only, the same for all three components, and `D` is
//! diagonal in the same modes, so diffusion commutes with `D`: a
//! divergence-free field stays divergence-free.
//!
//! - Periodic box: every component lattice is the cell lattice shifted by
//!   half a cell, so the eigenvalues are those of the projection.
//! - Closed box (free-slip walls): along its own axis a component lives on
//!   faces whose wall values are zero (Dirichlet), transformed with the DST-I
//!   over the `N_a − 1` interior faces, `m_a = 1 … N_a − 1`; along the other
//!   two axes it lives at cell-centre positions with a mirror ghost (zero
//!   normal derivative of the tangential velocity: a free-slip, no-stress
//!   wall), transformed with DCT-II/III, `m_b = 0 … N_b − 1`. In both cases
//!   `λ = −(2 sin(π m / 2N)/Δx)²` per axis. This is the exact solution of the
//!   heat equation with free-slip walls; no-slip walls (tangential velocity
//!   zero on the wall, DST-II) are not offered — that Laplacian does not
//!   commute with `D`. There is no zero mode (the normal axis starts at m = 1).
//!
//! # Precision
//!
//! Velocities and the published [`PressureSolver::pressure`] are f32; the
//! divergence and the gradient are computed in f64 and the faces rounded
//! once. The transforms run in the [`PressurePrecision`] asked for
//! ([`PressureSolver::with_precision`]; [`PressureSolver::new`] is f64, a
//! simulation's default f32). In f32 the rounding of `D u*` to f32 and the
//! transforms' O(ε log N) survive the solve, leaving `max|D u| Δx / max|u|`
//! ≈ 1e-6 on random faces (`tests/mac_projection.rs`). On a hot/cold step
//! it grows about as `ε N` — the pressure's smooth part, `O(max|u| L)`, is
//! rounded to `ε` of itself and `L` amplifies that by `1/Δx²` — from 4e-7
//! at 32³ to 7.8e-6 at 256³, periodic and closed alike (experiment P-1's
//! `pressure_precision.csv`): below 1e-5 up to 256³, not beyond about
//! 320³, where f64 is the choice. In f64 what remains is the final rounding of the
//! faces, ≈ 1e-7. f64 costs twice the transform memory traffic. With
//! obstacles the same transforms precondition the f64 conjugate gradients.
//!
//! # Performance
//!
//! Plans and every buffer are made once in [`PressureSolver::new`]. Each
//! transform runs in three parallel passes (rayon): x and y lines of one
//! z-slab per task; z lines of one x-frequency per task, with the spectral
//! multiply fused between the forward and inverse z transforms; then the y
//! and x inverses of a few z-slabs per task. The periodic box's pair is
//! [`periodic_fft::PeriodicFft`] in the solver's precision (in f32 it is
//! also the FFT floor of experiment P-1 and, forward only, the metrics'
//! spectra). In a periodic box the projection has no pass
//! of its own: each task of the first pass computes the divergence of its
//! slab before transforming it, and each task of the last subtracts the
//! gradient of the slabs of `p` it has just made.

use std::f64::consts::PI;
use std::fmt;
use std::ops::MulAssign;
use std::sync::Arc;

use rayon::prelude::*;
use realfft::num_traits::NumAssign;
use rustdct::{DctNum, DctPlanner, Dst1, TransformType2And3};
use serde::{Deserialize, Serialize};

use crate::domain::Domain;
use crate::error::InputError;
use crate::grid::face::{subtract_difference, BoxKind, FaceGrid, Real};
use crate::grid::ScalarGrid;

pub mod obstacles;
pub mod periodic_fft;

use periodic_fft::PeriodicFft;

/// The arithmetic of the pressure solve's transforms (the divergence, the
/// gradient and the published pressure are f64 either way).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum PressurePrecision {
    /// Transforms in f32: half the memory traffic; after the projection
    /// `max|D u| Δx / max|u|` stays below 1e-5 up to 256³ (it grows about
    /// as `ε N`; experiment P-1's `pressure_precision.csv`, module
    /// documentation "Precision").
    #[default]
    F32,
    /// Transforms in f64: `max|D u|` at the rounding of the faces.
    F64,
}

impl PressurePrecision {
    /// Every precision, in a fixed order (for tests and sweeps).
    pub const ALL: [PressurePrecision; 2] = [PressurePrecision::F32, PressurePrecision::F64];

    /// Lower-case name, as serialised.
    pub fn name(self) -> &'static str {
        match self {
            PressurePrecision::F32 => "f32",
            PressurePrecision::F64 => "f64",
        }
    }
}

impl fmt::Display for PressurePrecision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A precision the transforms can run in: f32 or f64.
trait Float: Real + DctNum + NumAssign {}

impl<T: Real + DctNum + NumAssign> Float for T {}

/// What to multiply each mode by between the forward and inverse transform.
#[derive(Clone, Copy, Debug)]
enum Filter {
    /// `1/λ`, zero mode pinned to 0: solves `L p = f`.
    InverseLaplacian,
    /// `exp(λ ν Δt)`: exact heat step.
    Heat { nu_dt: f64 },
}

/// Eigenvalue `−(2 sin(π m / period) / Δx)²` of one axis of the 7-point
/// Laplacian (`period = N` periodic, `2N` Neumann or Dirichlet), in f64.
fn eigenvalue(m: usize, period: usize, dx: f32) -> f64 {
    let s = 2.0 * (PI * m as f64 / period as f64).sin() / dx as f64;
    -s * s
}

/// Multiply the z-lines of one column block, `col[j·nz + k]` for the x-index
/// `i`, by the filter gain of mode `(i, j, k)`.
///
/// `tables` holds per-axis eigenvalues (inverse Laplacian) or per-axis heat
/// factors `exp(λ_a ν Δt)` (heat step: the product of the three is
/// `exp(λ ν Δt)`).
#[inline]
fn apply_gain<T: Float, C: MulAssign<T>>(
    col: &mut [C],
    i: usize,
    nz: usize,
    filter: Filter,
    tables: &[Vec<f64>; 3],
) {
    let [tx, ty, tz] = tables;
    for (j, line) in col.chunks_exact_mut(nz).enumerate() {
        match filter {
            Filter::InverseLaplacian => {
                let lxy = tx[i] + ty[j];
                for (c, &lz) in line.iter_mut().zip(tz) {
                    let l = lxy + lz;
                    // Every eigenvalue is < 0 except the zero mode's, exactly 0.
                    *c *= <T as Real>::from_f64(if l < 0.0 { 1.0 / l } else { 0.0 });
                }
            }
            Filter::Heat { .. } => {
                let hxy = tx[i] * ty[j];
                for (c, &hz) in line.iter_mut().zip(tz) {
                    *c *= <T as Real>::from_f64(hxy * hz);
                }
            }
        }
    }
}

/// Per-axis tables for [`apply_gain`]: the eigenvalues, or the heat factors
/// `exp(−ν k_a² Δt)` with the continuous wavenumber `k_a` recovered from the
/// eigenvalue `λ = −(2 sin(k_a Δx/2)/Δx)²` (`k_a Δx ∈ [0, π]`).
fn gain_tables(eig: &[Vec<f64>; 3], filter: Filter, dx: f32) -> [Vec<f64>; 3] {
    let dx = dx as f64;
    match filter {
        Filter::InverseLaplacian => eig.clone(),
        Filter::Heat { nu_dt } => std::array::from_fn(|a| {
            eig[a]
                .iter()
                .map(|&l| {
                    let k = 2.0 / dx * (0.5 * dx * (-l).sqrt()).min(1.0).asin();
                    (-nu_dt * k * k).exp()
                })
                .collect()
        }),
    }
}

/// z-slabs per task in the inverse x/y pass: gathering kz for consecutive
/// slabs reads whole cache lines of the columns.
const SLAB_BLOCK: usize = 8;

/// Periodic box: the real FFT pair ([`PeriodicFft`]) in precision `T` and
/// its eigenvalues.
#[derive(Clone)]
struct PeriodicPlan<T: Float> {
    fft: PeriodicFft<T>,
    /// `λ_a(m)` per axis and bin.
    eig: [Vec<f64>; 3],
    /// Cell size Δx.
    dx: f32,
}

impl<T: Float> PeriodicPlan<T> {
    fn new(domain: &Domain) -> Self {
        let [nx, ny, nz] = domain.dims;
        let bins = [nx / 2 + 1, ny, nz];
        let eig = std::array::from_fn(|a| {
            (0..bins[a])
                .map(|m| eigenvalue(m, domain.dims[a], domain.cell))
                .collect()
        });
        Self {
            fft: PeriodicFft::new(domain.dims),
            eig,
            dx: domain.cell,
        }
    }

    /// Pass 1: `src` (`[z][y][x]`) transformed along x and y.
    fn forward<S: Real>(&mut self, src: &[S]) {
        self.fft.forward(src, |v| <T as Real>::from_f64(v.to_f64()));
    }

    /// Passes 2 and 3: z transform, gain, inverse z; then inverse y and x
    /// into `dst`, scaled by `1/(nx ny nz)`.
    fn finish<S: Real>(&mut self, filter: Filter, dst: &mut [S]) {
        let [nx, ny, nz] = self.fft.dims();
        let tables = gain_tables(&self.eig, filter, self.dx);
        let scale = 1.0 / (nx * ny * nz) as f64;
        self.fft.inverse(
            |i, col| apply_gain::<T, _>(col, i, nz, filter, &tables),
            dst,
            |r| S::from_f64(r.to_f64() * scale),
        );
    }

    /// [`PressureSolver::project`] in a periodic box, in the transform's
    /// passes: pass 1 transforms `D u*` (made in f64, [`FaceGrid::divergence_slab`],
    /// rounded to `T`) as each task makes its slab; pass 3 hands each slab of `p` (f64, into
    /// `p`) to [`subtract_gradient_slab`] while it is in cache — all of `u`
    /// and `v`, and `w` where the slab below is in the same block. The first
    /// slab of each block takes its `w` afterwards, from `p`.
    fn project(&mut self, u: &mut FaceGrid, p: &mut [f64]) {
        let [nx, ny, nz] = self.fft.dims();
        let slab = nx * ny;
        self.fft.forward_slabs(|k, out| u.divergence_slab(k, out));
        let tables = gain_tables(&self.eig, Filter::InverseLaplacian, self.dx);
        let scale = 1.0 / (nx * ny * nz) as f64;
        let s = 1.0 / self.dx as f64;
        let block = SLAB_BLOCK * slab;
        let [us, vs, ws] = u.slices_mut();
        let blocks = p
            .par_chunks_mut(block)
            .zip(us.par_chunks_mut(block))
            .zip(vs.par_chunks_mut(block))
            .zip(ws.par_chunks_mut(block));
        self.fft.inverse_blocks(
            |i, col| apply_gain::<T, _>(col, i, nz, Filter::InverseLaplacian, &tables),
            blocks,
            |(((p, u), v), w), d, real| {
                let (below, p) = p.split_at_mut(d * slab);
                let p = &mut p[..slab];
                for (o, &r) in p.iter_mut().zip(real) {
                    *o = r.to_f64() * scale;
                }
                let below = d.checked_sub(1).map(|_| &below[(d - 1) * slab..]);
                let [u, v, w] = [&mut **u, &mut **v, &mut **w].map(|c| &mut c[d * slab..][..slab]);
                subtract_gradient_slab([nx, ny], s, p, below, [u, v, w]);
            },
        );
        let p = &*p;
        ws.par_chunks_mut(block).enumerate().for_each(|(b, w)| {
            let k = b * SLAB_BLOCK;
            let kl = (k + nz - 1) % nz;
            subtract_difference(
                &mut w[..slab],
                &p[k * slab..][..slab],
                &p[kl * slab..][..slab],
                s,
            );
        });
    }
}

/// `u_a −= s (p[f] − p[f − e_a])` on one periodic z-slab ([`FaceGrid::subtract_gradient_f64`]
/// with `s = 1/Δx`, the same operations): `u` and `v` from the slab's `p`
/// (the lower cell wraps within the slab), `w` if the slab below, `below`,
/// is given.
fn subtract_gradient_slab(
    [nx, ny]: [usize; 2],
    s: f64,
    p: &[f64],
    below: Option<&[f64]>,
    [u, v, w]: [&mut [f32]; 3],
) {
    for (ur, pr) in u.chunks_exact_mut(nx).zip(p.chunks_exact(nx)) {
        subtract_difference(&mut ur[..1], &pr[..1], &pr[nx - 1..], s);
        subtract_difference(&mut ur[1..], &pr[1..], pr, s);
    }
    for j in 0..ny {
        let jl = if j == 0 { ny - 1 } else { j - 1 };
        subtract_difference(
            &mut v[j * nx..][..nx],
            &p[j * nx..][..nx],
            &p[jl * nx..][..nx],
            s,
        );
    }
    if let Some(below) = below {
        subtract_difference(w, p, below, s);
    }
}

/// The DST-I `y_k = Σ_j x_j sin(π (j + 1)(k + 1) / (n + 1))` of one line,
/// from a zeroed `scratch`.
///
/// rustdct 0.7's DST-I for lengths from 25 (`Dst1ConvertToFft`) builds the
/// odd extension `[0, x, 0, −x reversed]` of length `2(n + 1)` in the
/// scratch but writes only the `x` entries: the two zeros are whatever the
/// scratch held. After another transform on the same scratch (the cosine
/// axes of the same lattice) they are that transform's leftovers, and the
/// DST-I returns the line plus a multiple of `sin(π (k + 1)/2)`-like
/// garbage. Zeroing the scratch first makes every call the one rustdct
/// tests, from fresh scratch.
fn dst1<T: Float>(t: &dyn Dst1<T>, line: &mut [T], scratch: &mut [T]) {
    scratch.fill(T::zero());
    t.process_dst1_with_scratch(line, scratch);
}

/// A real-to-real transform along one axis.
#[derive(Clone)]
enum R2r<T: Float> {
    /// DCT-II forward, DCT-III back: cell-centred samples, mirror ghosts.
    Cosine(Arc<dyn TransformType2And3<T>>),
    /// DST-I both ways: the interior faces of a lattice with zero walls.
    Sine(Arc<dyn Dst1<T>>),
}

impl<T: Float> R2r<T> {
    fn scratch_len(&self) -> usize {
        match self {
            R2r::Cosine(t) => t.get_scratch_len(),
            R2r::Sine(t) => t.get_scratch_len(),
        }
    }

    /// Forward transform of every length-`n` line of `lines`.
    fn forward(&self, lines: &mut [T], n: usize, scratch: &mut [T]) {
        for l in lines.chunks_exact_mut(n) {
            match self {
                R2r::Cosine(t) => t.process_dct2_with_scratch(l, scratch),
                R2r::Sine(t) => dst1(t.as_ref(), l, scratch),
            }
        }
    }

    /// Inverse (unnormalised) transform of every length-`n` line.
    fn inverse(&self, lines: &mut [T], n: usize, scratch: &mut [T]) {
        for l in lines.chunks_exact_mut(n) {
            match self {
                R2r::Cosine(t) => t.process_dct3_with_scratch(l, scratch),
                R2r::Sine(t) => dst1(t.as_ref(), l, scratch),
            }
        }
    }

    /// Factor making `inverse ∘ forward` the identity on length-`n` lines:
    /// DCT-III·DCT-II = n/2, DST-I·DST-I = (n+1)/2.
    fn norm(&self, n: usize) -> f64 {
        match self {
            R2r::Cosine(_) => 2.0 / n as f64,
            R2r::Sine(_) => 2.0 / (n + 1) as f64,
        }
    }
}

/// One lattice of the closed box and its transforms.
#[derive(Clone)]
struct RealConfig<T: Float> {
    /// Array size `[mx, my, mz]`.
    lattice: [usize; 3],
    /// First transformed index per axis (1 past a wall face, else 0).
    offset: [usize; 3],
    /// Transform length per axis.
    len: [usize; 3],
    axes: [R2r<T>; 3],
    /// `λ_a(m)` per axis and transform index.
    eig: [Vec<f64>; 3],
    /// Product of the per-axis normalisations.
    norm: f64,
}

/// Closed box: DCT-II/III (and DST-I for wall-normal face components).
#[derive(Clone)]
struct ClosedPlan<T: Float> {
    /// Index 0: cell centres (pressure); `1 + a`: face component `a`.
    configs: [RealConfig<T>; 4],
    /// Cell size Δx.
    dx: f32,
    /// Layout `[z][x][y]` over the transform lengths.
    slabs: Vec<T>,
    /// Layout `[x][y][z]` over the transform lengths.
    columns: Vec<T>,
}

impl<T: Float> ClosedPlan<T> {
    fn new(domain: &Domain) -> Self {
        let mut planner = DctPlanner::<T>::new();
        let configs = std::array::from_fn(|c| {
            let normal = c.checked_sub(1);
            let mut lattice = [0; 3];
            let mut offset = [0; 3];
            let mut len = [0; 3];
            let mut eig: [Vec<f64>; 3] = Default::default();
            let axes = std::array::from_fn(|a| {
                let n = domain.dims[a];
                if normal == Some(a) {
                    (lattice[a], offset[a], len[a]) = (n + 1, 1, n - 1);
                    eig[a] = (1..n).map(|m| eigenvalue(m, 2 * n, domain.cell)).collect();
                    R2r::Sine(planner.plan_dst1(n - 1))
                } else {
                    (lattice[a], offset[a], len[a]) = (n, 0, n);
                    eig[a] = (0..n).map(|m| eigenvalue(m, 2 * n, domain.cell)).collect();
                    R2r::Cosine(planner.plan_dct2(n))
                }
            });
            let norm = (0..3).map(|a| R2r::norm(&axes[a], len[a])).product();
            RealConfig {
                lattice,
                offset,
                len,
                axes,
                eig,
                norm,
            }
        });
        let cells = domain.len();
        Self {
            configs,
            dx: domain.cell,
            slabs: vec![T::zero(); cells],
            columns: vec![T::zero(); cells],
        }
    }

    /// Pass 1: the transformed part of `src` (lattice `config`) → `slabs`,
    /// transformed along x and y.
    fn forward<S: Real>(&mut self, config: usize, src: &[S]) {
        let cfg = &self.configs[config];
        let [lx, ly, lz] = cfg.len;
        let [mx, my, mz] = cfg.lattice;
        let [ox, oy, oz] = cfg.offset;
        assert_eq!(src.len(), mx * my * mz, "forward: lattice size");
        let [ax, ay, _] = &cfg.axes;
        let scratch = ax.scratch_len().max(ay.scratch_len());
        let src = &src[oz * mx * my..(oz + lz) * mx * my];
        self.slabs[..lx * ly * lz]
            .par_chunks_mut(lx * ly)
            .zip(src.par_chunks(mx * my))
            .for_each_init(
                || (vec![T::zero(); lx], vec![T::zero(); scratch]),
                |(line, scratch), (slab, s)| {
                    for j in 0..ly {
                        for (l, &v) in line.iter_mut().zip(&s[(j + oy) * mx + ox..][..lx]) {
                            *l = <T as Real>::from_f64(v.to_f64());
                        }
                        ax.forward(line, lx, scratch);
                        for (i, &v) in line.iter().enumerate() {
                            slab[i * ly + j] = v;
                        }
                    }
                    ay.forward(slab, ly, scratch);
                },
            );
    }

    /// Passes 2 and 3: z transform, gain, inverse z; inverse y and x into
    /// `dst` (lattice `config`), normalised; wall faces set to zero.
    fn finish<S: Real>(&mut self, config: usize, filter: Filter, dst: &mut [S]) {
        let Self {
            configs,
            dx,
            slabs,
            columns,
        } = self;
        let cfg = &configs[config];
        let [lx, ly, lz] = cfg.len;
        let [mx, my, mz] = cfg.lattice;
        let [ox, oy, oz] = cfg.offset;
        assert_eq!(dst.len(), mx * my * mz, "finish: lattice size");
        let [ax, ay, az] = &cfg.axes;
        let scratch = ax.scratch_len().max(ay.scratch_len()).max(az.scratch_len());
        let n = lx * ly * lz;
        let tables = gain_tables(&cfg.eig, filter, *dx);
        {
            let slabs = &slabs[..n];
            columns[..n]
                .par_chunks_mut(ly * lz)
                .enumerate()
                .for_each_init(
                    || vec![T::zero(); scratch],
                    |scratch, (i, col)| {
                        for k in 0..lz {
                            let src = &slabs[(k * lx + i) * ly..][..ly];
                            for (j, &v) in src.iter().enumerate() {
                                col[j * lz + k] = v;
                            }
                        }
                        az.forward(col, lz, scratch);
                        apply_gain::<T, _>(col, i, lz, filter, &tables);
                        az.inverse(col, lz, scratch);
                    },
                );
        }
        let cols = &columns[..n];
        let norm = cfg.norm;
        let (lo, rest) = dst.split_at_mut(oz * mx * my);
        let (mid, hi) = rest.split_at_mut(lz * mx * my);
        lo.fill(S::from_f64(0.0));
        hi.fill(S::from_f64(0.0));
        slabs[..n]
            .par_chunks_mut(SLAB_BLOCK * lx * ly)
            .zip(mid.par_chunks_mut(SLAB_BLOCK * mx * my))
            .enumerate()
            .for_each_init(
                || (vec![T::zero(); lx], vec![T::zero(); scratch]),
                |(line, scratch), (block, (slabs, out))| {
                    let k0 = block * SLAB_BLOCK;
                    let depth = slabs.len() / (lx * ly);
                    for (idx, col) in cols.chunks_exact(lz).enumerate() {
                        for (d, &v) in col[k0..k0 + depth].iter().enumerate() {
                            slabs[d * lx * ly + idx] = v;
                        }
                    }
                    for (slab, o) in slabs
                        .chunks_exact_mut(lx * ly)
                        .zip(out.chunks_exact_mut(mx * my))
                    {
                        ay.inverse(slab, ly, scratch);
                        o[..oy * mx].fill(S::from_f64(0.0));
                        o[(oy + ly) * mx..].fill(S::from_f64(0.0));
                        for j in 0..ly {
                            for (i, l) in line.iter_mut().enumerate() {
                                *l = slab[i * ly + j];
                            }
                            ax.inverse(line, lx, scratch);
                            let row = &mut o[(j + oy) * mx..][..mx];
                            row[..ox].fill(S::from_f64(0.0));
                            row[ox + lx..].fill(S::from_f64(0.0));
                            for (r, &v) in row[ox..ox + lx].iter_mut().zip(line.iter()) {
                                *r = S::from_f64(v.to_f64() * norm);
                            }
                        }
                    }
                },
            );
    }
}

/// The transforms of one box kind, in precision `T`.
#[derive(Clone)]
enum Engine<T: Float> {
    Periodic(Box<PeriodicPlan<T>>),
    Closed(Box<ClosedPlan<T>>),
}

impl<T: Float> Engine<T> {
    fn new(domain: &Domain, kind: BoxKind) -> Self {
        match kind {
            BoxKind::Periodic => Engine::Periodic(Box::new(PeriodicPlan::new(domain))),
            BoxKind::Closed => Engine::Closed(Box::new(ClosedPlan::new(domain))),
        }
    }

    /// Forward-transform `src` on lattice `config` (0: cells, `1 + a`: face
    /// component `a`; the periodic lattices all have the cell shape).
    fn forward<S: Real>(&mut self, config: usize, src: &[S]) {
        match self {
            Engine::Periodic(p) => p.forward(src),
            Engine::Closed(c) => c.forward(config, src),
        }
    }

    /// Multiply by the filter's gain and transform back into `dst`.
    fn finish<S: Real>(&mut self, config: usize, filter: Filter, dst: &mut [S]) {
        match self {
            Engine::Periodic(p) => p.finish(filter, dst),
            Engine::Closed(c) => c.finish(config, filter, dst),
        }
    }

    /// [`PressureSolver::project`]: `p` receives the pressure, `rhs` is the
    /// closed box's scratch for `D u*`.
    fn project(&mut self, u: &mut FaceGrid, p: &mut [f64], rhs: &mut [f64]) {
        match self {
            Engine::Periodic(plan) => plan.project(u, p),
            Engine::Closed(_) => {
                u.zero_walls();
                u.divergence_f64(rhs);
                self.forward(0, rhs);
                self.finish(0, Filter::InverseLaplacian, p);
                u.subtract_gradient_f64(p, 1.0);
            }
        }
    }

    /// [`PressureSolver::solve_poisson`] on any cell data.
    fn solve_poisson<S: Real>(&mut self, f: &[S], p: &mut [S]) {
        self.forward(0, f);
        self.finish(0, Filter::InverseLaplacian, p);
    }

    /// [`PressureSolver::diffuse`] after its checks, `nu_dt > 0`.
    fn diffuse(&mut self, u: &mut FaceGrid, nu_dt: f64) {
        for a in 0..3 {
            self.forward(1 + a, u.slice(a));
            self.finish(1 + a, Filter::Heat { nu_dt }, u.slice_mut(a));
        }
    }
}

/// The engine in the precision asked for.
#[derive(Clone)]
enum Engines {
    F32(Engine<f32>),
    F64(Engine<f64>),
}

/// `engines.f(args…)` on whichever precision `engines` holds.
macro_rules! with_engine {
    ($engines:expr, $e:ident => $body:expr) => {
        match $engines {
            Engines::F32($e) => $body,
            Engines::F64($e) => $body,
        }
    };
}

/// Exact MAC pressure projection and viscosity for one domain and box kind.
///
/// Plans every transform and owns every buffer once ([`PressureSolver::new`]);
/// [`PressureSolver::project`] and [`PressureSolver::diffuse`] then allocate
/// only a few per-axis tables and per-task line buffers. See the
/// [module documentation](self) for the equations.
#[derive(Clone)]
pub struct PressureSolver {
    domain: Domain,
    kind: BoxKind,
    /// `D u*`, f64, the closed box's transform input (empty for a periodic
    /// box, whose divergence is made slab by slab in the transform).
    rhs: Vec<f64>,
    /// `p` of the last projection (zero mean), f64.
    p64: Vec<f64>,
    engine: Engines,
}

impl PressureSolver {
    /// Plan the transforms in f64 and allocate the buffers for `domain` and
    /// `kind` ([`Self::with_precision`] for f32).
    pub fn new(domain: Domain, kind: BoxKind) -> Self {
        Self::with_precision(domain, kind, PressurePrecision::F64)
    }

    /// Plan the transforms in `precision` and allocate the buffers for
    /// `domain` and `kind`.
    pub fn with_precision(domain: Domain, kind: BoxKind, precision: PressurePrecision) -> Self {
        let engine = match precision {
            PressurePrecision::F32 => Engines::F32(Engine::new(&domain, kind)),
            PressurePrecision::F64 => Engines::F64(Engine::new(&domain, kind)),
        };
        let rhs = match kind {
            BoxKind::Periodic => vec![],
            BoxKind::Closed => vec![0.0; domain.len()],
        };
        Self {
            domain,
            kind,
            rhs,
            p64: vec![0.0; domain.len()],
            engine,
        }
    }

    /// The domain planned for.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// The box kind planned for.
    pub fn kind(&self) -> BoxKind {
        self.kind
    }

    /// The precision of the transforms.
    pub fn precision(&self) -> PressurePrecision {
        match self.engine {
            Engines::F32(_) => PressurePrecision::F32,
            Engines::F64(_) => PressurePrecision::F64,
        }
    }

    /// The pressure `p` of the last [`PressureSolver::project`] (zeros before
    /// the first), rounded to f32 into a new grid: `L p = D u*` with zero
    /// mean. In physical units it is the kinematic pressure impulse
    /// `p_phys Δt / ρ`.
    pub fn pressure(&self) -> ScalarGrid {
        let mut p = ScalarGrid::zeros(self.domain).with_wrap(self.kind.wrap());
        for (d, &s) in p.as_slice_mut().iter_mut().zip(&self.p64) {
            *d = s as f32;
        }
        p
    }

    /// Make `u` exactly discretely divergence-free: solve `L p = D u*`
    /// (zero mode pinned), then `u = u* − G p`. Closed box: the wall faces are
    /// first set to zero (no flow through a wall).
    ///
    /// Periodic box: `D u*` is made slab by slab inside the forward
    /// transform and `G p` subtracted slab by slab inside the inverse
    /// ([`PeriodicPlan::project`]), so neither is a pass of its own; the
    /// values are those of [`FaceGrid::divergence_f64`] and
    /// [`FaceGrid::subtract_gradient_f64`].
    ///
    /// # Panics
    /// If `u` is not on the planned domain and box kind.
    pub fn project(&mut self, u: &mut FaceGrid) {
        assert_eq!(u.domain(), &self.domain, "pressure solver: another domain");
        assert_eq!(u.kind(), self.kind, "pressure solver: another box kind");
        let (p, rhs) = (&mut self.p64, &mut self.rhs);
        with_engine!(&mut self.engine, e => e.project(u, p, rhs));
    }

    /// Solve `L p = f` for cell-centred `f` with the zero mode pinned
    /// (`p̂(0) = 0`; the mean of `f` is ignored). The fast solver the design
    /// notes use to precondition the cut-cell conjugate gradients.
    ///
    /// # Panics
    /// If a grid is not on the planned domain.
    pub fn solve_poisson(&mut self, f: &ScalarGrid, p: &mut ScalarGrid) {
        assert_eq!(f.domain(), &self.domain, "solve_poisson: another domain");
        assert_eq!(p.domain(), &self.domain, "solve_poisson: another domain");
        let (f, p) = (f.as_slice(), p.as_slice_mut());
        with_engine!(&mut self.engine, e => e.solve_poisson(f, p));
    }

    /// [`Self::solve_poisson`] on f64 `[z][y][x]` cell arrays (the cut-cell
    /// preconditioner; with f32 transforms, an f32 preconditioner of the
    /// f64 conjugate gradients).
    ///
    /// # Panics
    /// If an array does not have one value per cell.
    pub fn solve_poisson_f64(&mut self, f: &[f64], p: &mut [f64]) {
        assert_eq!(
            f.len(),
            self.domain.len(),
            "solve_poisson: one value per cell"
        );
        assert_eq!(
            p.len(),
            self.domain.len(),
            "solve_poisson: one value per cell"
        );
        with_engine!(&mut self.engine, e => e.solve_poisson(f, p));
    }

    /// Exact viscous step: each component `û_a ← û_a exp(λ_a ν Δt)` on its
    /// own lattice (module documentation, "Viscosity"). Periodic box: exact
    /// for the periodic 7-point Laplacian; closed box: free-slip walls, the
    /// wall faces stay zero. Three transform pairs, one per component.
    ///
    /// Fails if `nu` or `dt` is negative or not finite.
    ///
    /// # Panics
    /// If `u` is not on the planned domain and box kind.
    pub fn diffuse(&mut self, u: &mut FaceGrid, nu: f32, dt: f32) -> Result<(), InputError> {
        assert_eq!(u.domain(), &self.domain, "pressure solver: another domain");
        assert_eq!(u.kind(), self.kind, "pressure solver: another box kind");
        if !(nu.is_finite() && nu >= 0.0) {
            crate::input_bail!("viscosity is {nu}; it must be a finite number ≥ 0");
        }
        if !(dt.is_finite() && dt >= 0.0) {
            crate::input_bail!("time step is {dt}; it must be a finite number ≥ 0");
        }
        let nu_dt = nu as f64 * dt as f64;
        if nu_dt == 0.0 {
            return Ok(());
        }
        with_engine!(&mut self.engine, e => e.diffuse(u, nu_dt));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The DST-I of each line equals its definition however dirty the
    /// scratch left by another transform, at the lengths of both rustdct
    /// algorithms (naive below 25, FFT from 25): with the scratch as a
    /// DCT-II left it, the FFT lengths were off by O(the DCT's output).
    #[test]
    fn sine_lines_match_the_definition_after_another_transform() {
        let mut planner = DctPlanner::<f64>::new();
        for n in (1..=70).chain([127, 255]) {
            let sine = R2r::Sine(planner.plan_dst1(n));
            let cosine = R2r::Cosine(planner.plan_dct2(n + 1));
            let mut scratch = vec![0.0; sine.scratch_len().max(cosine.scratch_len())];
            let lines: Vec<f64> = (0..3 * n)
                .map(|i| ((i * 37 % 11) as f64 - 5.0) / 3.0)
                .collect();
            let mut other: Vec<f64> = (0..n + 1).map(|i| 1e3 * (i as f64 + 0.5)).collect();
            cosine.forward(&mut other, n + 1, &mut scratch);
            let mut out = lines.clone();
            sine.forward(&mut out, n, &mut scratch);
            for (x, y) in lines.chunks_exact(n).zip(out.chunks_exact(n)) {
                for (k, &yk) in y.iter().enumerate() {
                    let exact: f64 = x
                        .iter()
                        .enumerate()
                        .map(|(j, &xj)| {
                            xj * (PI * ((j + 1) * (k + 1)) as f64 / (n + 1) as f64).sin()
                        })
                        .sum();
                    assert!(
                        (yk - exact).abs() <= 1e-12 * n as f64,
                        "n = {n}, k = {k}: {yk} vs {exact}"
                    );
                }
            }
        }
    }
}
