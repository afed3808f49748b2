//! FFT divergence-free projection — the notes' `fftdivfree` (§6.1, step 3).
//!
//! Velocity lives at the cell centres of a periodic box (a *collocated*
//! grid). The divergence smokelab reports is the central difference
//! `∇·u ≈ Σ_a (u_a[i+1] − u_a[i−1]) / 2Δx`, whose Fourier symbol along axis a is
//! `i k̃_a` with the discrete wavenumber
//!
//! ```text
//! k̃ = sin(k Δx) / Δx,     k = 2π m / L,  m = −N/2 … N/2
//! ```
//!
//! Projecting each mode with that wavenumber, `û ← û − k̃ (k̃·û) / |k̃|²`, makes
//! the reported divergence vanish to round-off (Helmholtz–Hodge on the
//! discrete operator). Special modes:
//! - the zero mode (mean flow) has `k̃ = 0` and is left unchanged;
//! - for even N the Nyquist index m = N/2 has `k̃ = 0` as well: it is invisible
//!   to the central difference and would survive as a checkerboard, so every
//!   mode with a Nyquist index on any axis is set to zero.
//!
//! [`Operator::Spectral`] projects with the exact wavenumbers `k` instead:
//! spectrally accurate for band-limited data (the convergence suite uses it),
//! but then the central-difference divergence is only small, not zero.
//!
//! Optional viscosity is applied exactly per mode, `û ← û exp(−ν |k|² Δt)`
//! with the exact wavenumber, which solves `∂u/∂t = ν ∇²u` over Δt.
//!
//! Transforms: real-to-complex along x (realfft), complex along y and z
//! (rustfft), planned once in [`Projection::new`]; all spectra live in buffers
//! the projector owns. rustfft does not normalise: the inverse is scaled by
//! `1/(nx ny nz)`.

use std::f32::consts::PI;
use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;
use realfft::num_complex::Complex32;
use realfft::{ComplexToReal, RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};

use crate::domain::Domain;
use crate::grid::VectorGrid;

/// Which divergence operator the projector annihilates.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Operator {
    /// Central differences on the collocated grid, `k̃ = sin(kΔx)/Δx` (the
    /// divergence smokelab reports).
    #[default]
    CentralDifference,
    /// The exact derivative, `k̃ = k`.
    Spectral,
}

/// Planned transforms and scratch for projecting velocity grids on one domain.
#[derive(Clone)]
pub struct Projection {
    domain: Domain,
    /// Number of complex bins along x, `nx/2 + 1`.
    nxh: usize,
    r2c: Arc<dyn RealToComplex<f32>>,
    c2r: Arc<dyn ComplexToReal<f32>>,
    fft_y: Arc<dyn Fft<f32>>,
    ifft_y: Arc<dyn Fft<f32>>,
    fft_z: Arc<dyn Fft<f32>>,
    ifft_z: Arc<dyn Fft<f32>>,
    /// Per component, spectra after the x and y passes, layout `[z][y][kx]`.
    slabs: [Vec<Complex32>; 3],
    /// Per component, full 3D spectra, layout `[ky][kx][kz]`.
    columns: [Vec<Complex32>; 3],
    /// Wavenumbers of the divergence operator (`k̃ = sin(kΔx)/Δx` for central
    /// differences) per axis and index.
    k_discrete: [Vec<f32>; 3],
    /// Exact `k²` per axis and index, for viscosity.
    k_squared: [Vec<f32>; 3],
    /// Whether an index is the Nyquist index of its axis (even N only).
    nyquist: [Vec<bool>; 3],
}

/// Signed frequency index of FFT bin `m` on an axis of `n` points.
fn signed_index(m: usize, n: usize) -> i64 {
    if m <= n / 2 {
        m as i64
    } else {
        m as i64 - n as i64
    }
}

impl Projection {
    /// Plan the transforms and allocate the spectra for `domain`, projecting
    /// onto fields free of the central-difference divergence.
    pub fn new(domain: Domain) -> Self {
        Self::with_operator(domain, Operator::CentralDifference)
    }

    /// Plan for `domain` with the given divergence operator.
    pub fn with_operator(domain: Domain, operator: Operator) -> Self {
        let [nx, ny, nz] = domain.dims;
        let nxh = nx / 2 + 1;
        let mut real = RealFftPlanner::<f32>::new();
        let mut complex = FftPlanner::<f32>::new();
        let dx = domain.cell;
        let bins = [nxh, ny, nz];
        let k_of = |axis: usize, m: usize| {
            let n = domain.dims[axis];
            2.0 * PI * signed_index(m, n) as f32 / (n as f32 * dx)
        };
        let per_axis = |f: &dyn Fn(usize, usize) -> f32| -> [Vec<f32>; 3] {
            std::array::from_fn(|a| (0..bins[a]).map(|m| f(a, m)).collect())
        };
        let k_discrete = match operator {
            Operator::CentralDifference => per_axis(&|a, m| (k_of(a, m) * dx).sin() / dx),
            Operator::Spectral => per_axis(&k_of),
        };
        let k_squared = per_axis(&|a, m| k_of(a, m).powi(2));
        let nyquist = std::array::from_fn(|a| {
            let n = domain.dims[a];
            (0..bins[a]).map(|m| n % 2 == 0 && m == n / 2).collect()
        });
        let len = nz * ny * nxh;
        Self {
            domain,
            nxh,
            r2c: real.plan_fft_forward(nx),
            c2r: real.plan_fft_inverse(nx),
            fft_y: complex.plan_fft_forward(ny),
            ifft_y: complex.plan_fft_inverse(ny),
            fft_z: complex.plan_fft_forward(nz),
            ifft_z: complex.plan_fft_inverse(nz),
            slabs: std::array::from_fn(|_| vec![Complex32::default(); len]),
            columns: std::array::from_fn(|_| vec![Complex32::default(); len]),
            k_discrete,
            k_squared,
            nyquist,
        }
    }

    /// The domain this projector was planned for.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// Make `vel` divergence-free (in the central-difference sense), then, if
    /// `viscosity > 0`, diffuse it exactly over `dt`.
    ///
    /// # Panics
    /// If `vel` is not on the planned domain.
    pub fn project(&mut self, vel: &mut VectorGrid, viscosity: f32, dt: f32) {
        assert_eq!(
            vel.domain(),
            &self.domain,
            "projection planned for another domain"
        );
        for c in 0..3 {
            self.forward(vel, c);
        }
        self.apply_projector(viscosity * dt);
        for c in 0..3 {
            self.inverse(vel, c);
        }
    }

    /// Component `c` of `vel` → `columns[c]` (full 3D spectrum).
    fn forward(&mut self, vel: &VectorGrid, c: usize) {
        let [nx, ny, nz] = self.domain.dims;
        let nxh = self.nxh;
        let (r2c, fft_y) = (&self.r2c, &self.fft_y);
        let src = vel.as_slice();
        // x (real-to-complex) and y passes, one z-slab per task.
        self.slabs[c]
            .par_chunks_mut(ny * nxh)
            .enumerate()
            .for_each_init(
                || {
                    SlabScratch::new(
                        nx,
                        ny * nxh,
                        r2c.get_scratch_len(),
                        fft_y.get_inplace_scratch_len(),
                    )
                },
                |s, (k, slab)| {
                    for j in 0..ny {
                        let row = &src[3 * (k * ny + j) * nx..3 * (k * ny + j + 1) * nx];
                        for (r, v) in s.real.iter_mut().zip(row.chunks_exact(3)) {
                            *r = v[c];
                        }
                        r2c.process_with_scratch(
                            &mut s.real,
                            &mut slab[j * nxh..(j + 1) * nxh],
                            &mut s.r2c,
                        )
                        .expect("r2c buffer sizes are planned");
                    }
                    transpose(slab, &mut s.lines, ny, nxh);
                    fft_y.process_with_scratch(&mut s.lines, &mut s.fft);
                    transpose(&s.lines, slab, nxh, ny);
                },
            );
        // z pass, one ky per task, gathering into [ky][kx][kz].
        let (slab_data, fft_z) = (&self.slabs[c], &self.fft_z);
        self.columns[c]
            .par_chunks_mut(nxh * nz)
            .enumerate()
            .for_each_init(
                || vec![Complex32::default(); fft_z.get_inplace_scratch_len()],
                |scratch, (j, col)| {
                    for k in 0..nz {
                        let row = &slab_data[(k * ny + j) * nxh..(k * ny + j + 1) * nxh];
                        for (i, &v) in row.iter().enumerate() {
                            col[i * nz + k] = v;
                        }
                    }
                    fft_z.process_with_scratch(col, scratch);
                },
            );
    }

    /// `columns[c]` → component `c` of `vel`, scaled by `1/(nx ny nz)`.
    fn inverse(&mut self, vel: &mut VectorGrid, c: usize) {
        let [nx, ny, nz] = self.domain.dims;
        let nxh = self.nxh;
        let ifft_z = &self.ifft_z;
        self.columns[c].par_chunks_mut(nxh * nz).for_each_init(
            || vec![Complex32::default(); ifft_z.get_inplace_scratch_len()],
            |scratch, col| ifft_z.process_with_scratch(col, scratch),
        );
        let (cols, c2r, ifft_y) = (&self.columns[c], &self.c2r, &self.ifft_y);
        let scale = 1.0 / self.domain.len() as f32;
        let even_x = nx % 2 == 0;
        // x and y passes, a few z-slabs per task: gathering kz for a block of
        // consecutive slabs reads whole cache lines of the columns.
        self.slabs[c]
            .par_chunks_mut(SLAB_BLOCK * ny * nxh)
            .zip(vel.as_slice_mut().par_chunks_mut(SLAB_BLOCK * 3 * nx * ny))
            .enumerate()
            .for_each_init(
                || {
                    SlabScratch::new(
                        nx,
                        SLAB_BLOCK * ny * nxh,
                        c2r.get_scratch_len(),
                        ifft_y.get_inplace_scratch_len(),
                    )
                },
                |s, (block, (slabs, out))| {
                    let k0 = block * SLAB_BLOCK;
                    let depth = slabs.len() / (ny * nxh);
                    // Scatter kz back: lines[b][kx][y] for z = k0 + b.
                    for j in 0..ny {
                        for i in 0..nxh {
                            let col = &cols[(j * nxh + i) * nz + k0..][..depth];
                            for (b, &v) in col.iter().enumerate() {
                                s.lines[(b * nxh + i) * ny + j] = v;
                            }
                        }
                    }
                    for b in 0..depth {
                        let lines = &mut s.lines[b * nxh * ny..(b + 1) * nxh * ny];
                        let slab = &mut slabs[b * ny * nxh..(b + 1) * ny * nxh];
                        let out = &mut out[b * 3 * nx * ny..(b + 1) * 3 * nx * ny];
                        ifft_y.process_with_scratch(lines, &mut s.fft);
                        transpose(lines, slab, nxh, ny);
                        for j in 0..ny {
                            let line = &mut slab[j * nxh..(j + 1) * nxh];
                            // A real signal has real DC and (even nx) Nyquist bins;
                            // drop the round-off imaginary parts realfft would reject.
                            line[0].im = 0.0;
                            if even_x {
                                line[nxh - 1].im = 0.0;
                            }
                            c2r.process_with_scratch(line, &mut s.real, &mut s.r2c)
                                .expect("c2r buffer sizes are planned");
                            for (v, &r) in out[3 * j * nx..3 * (j + 1) * nx]
                                .chunks_exact_mut(3)
                                .zip(&s.real)
                            {
                                v[c] = r * scale;
                            }
                        }
                    }
                },
            );
    }

    /// `û ← (û − k̃ (k̃·û)/|k̃|²) · exp(−ν|k|²Δt)` on every mode; Nyquist modes zeroed.
    fn apply_projector(&mut self, nu_dt: f32) {
        let [_, _, nz] = self.domain.dims;
        let nxh = self.nxh;
        let [kdx, kdy, kdz] = &self.k_discrete;
        let [k2x, k2y, k2z] = &self.k_squared;
        let [nqx, nqy, nqz] = &self.nyquist;
        let [cx, cy, cz] = &mut self.columns;
        cx.par_chunks_mut(nxh * nz)
            .zip(cy.par_chunks_mut(nxh * nz))
            .zip(cz.par_chunks_mut(nxh * nz))
            .enumerate()
            .for_each(|(j, ((ux, uy), uz))| {
                for i in 0..nxh {
                    for k in 0..nz {
                        let n = i * nz + k;
                        if nqx[i] || nqy[j] || nqz[k] {
                            ux[n] = Complex32::default();
                            uy[n] = Complex32::default();
                            uz[n] = Complex32::default();
                            continue;
                        }
                        let kt = Vec3::new(kdx[i], kdy[j], kdz[k]);
                        let kk = kt.length_squared();
                        if kk > 0.0 {
                            let dot = ux[n] * kt.x + uy[n] * kt.y + uz[n] * kt.z;
                            let d = dot / kk;
                            ux[n] -= d * kt.x;
                            uy[n] -= d * kt.y;
                            uz[n] -= d * kt.z;
                        }
                        if nu_dt > 0.0 {
                            let f = (-nu_dt * (k2x[i] + k2y[j] + k2z[k])).exp();
                            ux[n] *= f;
                            uy[n] *= f;
                            uz[n] *= f;
                        }
                    }
                }
            });
    }
}

/// z-slabs per task of the inverse x/y pass: 4 complex f32 = one 32-byte
/// run of a kz column per gather.
const SLAB_BLOCK: usize = 4;

/// Per-task scratch for the x and y passes of one slab (or block of slabs).
struct SlabScratch {
    real: Vec<f32>,
    lines: Vec<Complex32>,
    r2c: Vec<Complex32>,
    fft: Vec<Complex32>,
}

impl SlabScratch {
    fn new(nx: usize, slab: usize, real_scratch: usize, fft_scratch: usize) -> Self {
        Self {
            real: vec![0.0; nx],
            lines: vec![Complex32::default(); slab],
            r2c: vec![Complex32::default(); real_scratch],
            fft: vec![Complex32::default(); fft_scratch],
        }
    }
}

/// `dst[c][r] = src[r][c]` for a `rows × cols` row-major `src`.
fn transpose(src: &[Complex32], dst: &mut [Complex32], rows: usize, cols: usize) {
    for r in 0..rows {
        for c in 0..cols {
            dst[c * rows + r] = src[r * cols + c];
        }
    }
}
