//! Stam–Fiume spectral turbulence (`003_…`): a divergence-free random wind
//! synthesised in Fourier space, inverse-transformed once into a periodic tile
//! and sampled by interpolation.
//!
//! The synthesis follows `003_…`'s algorithm, per wave vector of the tile:
//!
//! 1. normalised frequency `(i, j, k) = (x/N, y/N, z/N)` folded into
//!    `[−½, ½)`, `d = √(i² + j² + k²)` (cycles per sample);
//! 2. three random phases `r_a ∈ [0, 2π)` and `v_a = S(d) e^{i r_a}` with the
//!    spectrum `S` ([`Spectrum`]: Gaussian with parameter B, or Kolmogorov);
//! 3. projection onto the plane normal to the wave vector,
//!    `u = v − k̂ (k̂·v)`;
//! 4. Hermitian symmetry `F(−k) = F(k)*`, imaginary parts of self-conjugate
//!    modes set to zero, so the inverse DFT is real;
//! 5. inverse DFT, then "normalize the resulting vector lengths in the range
//!    of [−1..+1]": the tile is scaled so that `max |u| = 1`.
//!
//! Where this differs from the pseudo-code, and why:
//! - **Projection direction.** The tile is read by trilinear interpolation.
//!   The flux of the trilinear interpolant through the faces of one lattice
//!   cube is `Σ_a (mean of u_a on the 4 corners of face a+) − (… of face a−)`,
//!   whose Fourier symbol is `2i e^{iπ(s_x+s_y+s_z)/N} k̃` with the real vector
//!   `k̃ = (sin πi cos πj cos πk, cos πi sin πj cos πk, cos πi cos πj sin πk)`.
//!   Projecting with `k̃` instead of `k` makes the sampled field's flux through
//!   every tile cube zero to round-off ([`SpectralTile::divergence`]); `k̃`
//!   is parallel to `k` to second order in `k`, so the low modes are
//!   unchanged. Modes where `k̃ = 0` (two or more Nyquist indices) carry no
//!   cube flux, can carry no divergence-free content on this stencil, and are
//!   set to zero. The zero mode (mean wind) is zero.
//! - **Time.** `003_…` computes `d` from the spatial frequencies only, so its
//!   4D spectrum is flat in temporal frequency and consecutive frames are
//!   uncorrelated. The 4D tile here multiplies by a Gaussian in temporal
//!   frequency `l` (cycles per frame), `exp(−l²/2B_t²)`, so the wind evolves
//!   smoothly; it is sampled trilinearly in space and linearly in time (the
//!   "quadrilinear interpolation" of `003_…`, 16 samples).
//! - **Transforms.** Only the half spectrum `k_x ≥ 0` is stored: complex
//!   inverse FFTs (rustfft) along t, z, y, then complex-to-real along x
//!   (realfft), each planned once per tile; the Hermitian symmetry of the
//!   `k_x = 0` and `k_x = N/2` planes is enforced explicitly (step 4), the rest
//!   is implied by the half-spectrum storage.
//!
//! Expected energy per mode after projection is `2 S(d)² T(l)²`: the
//! projector onto a plane has trace 2 and the three phases are independent.

use std::f32::consts::{PI, TAU};
use std::sync::Arc;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use rayon::prelude::*;
use realfft::num_complex::Complex32;
use realfft::RealFftPlanner;
use rustfft::{Fft, FftPlanner};
use serde::Serialize;

use crate::error::InputError;
use crate::field::VectorField;
use crate::grid::{Stencil, Wrap};

/// The spatial amplitude spectrum `S(d)`, `d` in cycles per sample.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub enum Spectrum {
    /// `S(d) = exp(−d² / 2B²)` (`003_…`'s "Gaussian fall-off" with parameter
    /// B): the energy spectrum `E(d) ∝ d² S²` peaks at `d = B`.
    Gaussian {
        /// Width B in cycles per sample.
        b: f32,
    },
    /// Kolmogorov: energy `E(d) ∝ d^{−5/3}`, i.e. `S(d) = d^{−11/6}`, for
    /// `d ≥ cutoff` (the energy-containing scale), zero below.
    Kolmogorov {
        /// Lowest frequency in cycles per sample.
        cutoff: f32,
    },
}

impl Spectrum {
    /// `S(d)`.
    pub fn amplitude(&self, d: f32) -> f32 {
        match *self {
            Spectrum::Gaussian { b } => (-d * d / (2.0 * b * b)).exp(),
            Spectrum::Kolmogorov { cutoff } => {
                if d < cutoff {
                    0.0
                } else {
                    d.powf(-11.0 / 6.0)
                }
            }
        }
    }

    fn validate(&self) -> Result<(), InputError> {
        let (name, v) = match *self {
            Spectrum::Gaussian { b } => ("Gaussian width B", b),
            Spectrum::Kolmogorov { cutoff } => ("Kolmogorov cutoff", cutoff),
        };
        if !(v.is_finite() && v > 0.0 && v < 0.5) {
            return Err(InputError::new(format!(
                "{name} is {v}; it must lie in (0, 0.5) cycles per sample"
            )));
        }
        Ok(())
    }
}

/// How to synthesise a tile.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SpectralParams {
    /// Samples per axis N (even, 8…256).
    pub res: usize,
    /// Frames in time; 1 is a static 3D tile, more a 4D tile periodic in time.
    pub frames: usize,
    /// Spatial spectrum.
    pub spectrum: Spectrum,
    /// Temporal Gaussian width `B_t` in cycles per frame (4D tiles only).
    pub temporal_b: f32,
    /// Side of the tile in world units (its spatial period).
    pub period: f32,
}

impl Default for SpectralParams {
    fn default() -> Self {
        Self {
            res: 32,
            frames: 1,
            spectrum: Spectrum::Gaussian { b: 0.1 },
            temporal_b: 0.1,
            period: 4.0,
        }
    }
}

impl SpectralParams {
    /// Check the parameters, naming the bad value.
    pub fn validate(&self) -> Result<(), InputError> {
        if !(8..=256).contains(&self.res) || !self.res.is_multiple_of(2) {
            return Err(InputError::new(format!(
                "spectral tile resolution is {}; it must be even and in 8..=256",
                self.res
            )));
        }
        if !(1..=256).contains(&self.frames) {
            return Err(InputError::new(format!(
                "spectral tile frames is {}; it must be in 1..=256",
                self.frames
            )));
        }
        if self.frames > 1 && !(self.temporal_b.is_finite() && self.temporal_b > 0.0) {
            return Err(InputError::new(format!(
                "temporal width B_t is {}; it must be positive",
                self.temporal_b
            )));
        }
        if !(self.period.is_finite() && self.period > 0.0) {
            return Err(InputError::new(format!(
                "spectral tile period is {}; it must be a positive number of world units",
                self.period
            )));
        }
        self.spectrum.validate()
    }
}

/// Signed frequency index of FFT bin `m` on an axis of `n` points.
fn signed(m: usize, n: usize) -> i64 {
    if m <= n / 2 {
        m as i64
    } else {
        m as i64 - n as i64
    }
}

/// Step 1–4: the projected, Hermitian half spectrum of each component, layout
/// `[l][k_z][k_y][k_x]` with `k_x ∈ 0..=N/2`.
fn spectrum(p: &SpectralParams, seed: u64) -> [Vec<Complex32>; 3] {
    let (n, nt) = (p.res, p.frames);
    let nh = n / 2 + 1;
    let len = nt * n * n * nh;
    let mut out: [Vec<Complex32>; 3] = std::array::from_fn(|_| vec![Complex32::default(); len]);
    let mut rng = Pcg64::seed_from_u64(seed);
    let half_angle: Vec<(f32, f32)> = (0..n)
        .map(|m| (PI * signed(m, n) as f32 / n as f32).sin_cos())
        .collect();
    let mut idx = 0;
    for l in 0..nt {
        let tl = signed(l, nt) as f32 / nt as f32;
        let temporal = if nt == 1 {
            1.0
        } else {
            (-tl * tl / (2.0 * p.temporal_b * p.temporal_b)).exp()
        };
        for kz in 0..n {
            let k = signed(kz, n) as f32 / n as f32;
            for ky in 0..n {
                let j = signed(ky, n) as f32 / n as f32;
                for kx in 0..nh {
                    let i = kx as f32 / n as f32;
                    // Phases are drawn for every mode so the stream does not
                    // depend on which modes end up zero.
                    let r: [f32; 3] = std::array::from_fn(|_| rng.random_range(0.0..TAU));
                    let d = (i * i + j * j + k * k).sqrt();
                    let (sx, cx) = half_angle[kx];
                    let (sy, cy) = half_angle[ky];
                    let (sz, cz) = half_angle[kz];
                    let kt = Vec3::new(sx * cy * cz, cx * sy * cz, cx * cy * sz);
                    let k2 = kt.length_squared();
                    if d > 0.0 && k2 > 1e-12 {
                        let s = p.spectrum.amplitude(d) * temporal;
                        let v = r.map(|a| Complex32::from_polar(s, a));
                        let kv = v[0] * kt.x + v[1] * kt.y + v[2] * kt.z;
                        for c in 0..3 {
                            out[c][idx] = v[c] - kv * (kt[c] / k2);
                        }
                    }
                    idx += 1;
                }
            }
        }
    }
    // Step 4 on the self-paired planes k_x = 0 and k_x = N/2.
    for kx in [0, n / 2] {
        for l in 0..nt {
            for kz in 0..n {
                for ky in 0..n {
                    let at = |l: usize, kz: usize, ky: usize| ((l * n + kz) * n + ky) * nh + kx;
                    let here = at(l, kz, ky);
                    let mirror = at((nt - l) % nt, (n - kz) % n, (n - ky) % n);
                    for comp in out.iter_mut() {
                        if mirror < here {
                            comp[here] = comp[mirror].conj();
                        } else if mirror == here {
                            comp[here].im = 0.0;
                        }
                    }
                }
            }
        }
    }
    out
}

/// In-place complex FFT of every line along one axis (`len` points, `stride`
/// apart) of a row-major array, lines gathered into contiguous scratch.
fn fft_axis(data: &mut [Complex32], len: usize, stride: usize, fft: &Arc<dyn Fft<f32>>) {
    let block = len * stride;
    data.par_chunks_mut(block).for_each_init(
        || {
            (
                vec![Complex32::default(); block],
                vec![Complex32::default(); fft.get_inplace_scratch_len()],
            )
        },
        |(lines, scratch), chunk| {
            for m in 0..len {
                for s in 0..stride {
                    lines[s * len + m] = chunk[m * stride + s];
                }
            }
            fft.process_with_scratch(lines, scratch);
            for m in 0..len {
                for s in 0..stride {
                    chunk[m * stride + s] = lines[s * len + m];
                }
            }
        },
    );
}

/// Step 5 without the normalisation: the real components, layout `[t][z][y][x]`.
fn inverse(p: &SpectralParams, mut spec: [Vec<Complex32>; 3]) -> [Vec<f32>; 3] {
    let (n, nt) = (p.res, p.frames);
    let nh = n / 2 + 1;
    let mut complex = FftPlanner::<f32>::new();
    let ifft_n = complex.plan_fft_inverse(n);
    let ifft_t = complex.plan_fft_inverse(nt);
    let c2r = RealFftPlanner::<f32>::new().plan_fft_inverse(n);
    let mut out: [Vec<f32>; 3] = std::array::from_fn(|_| vec![0.0; nt * n * n * n]);
    spec.par_iter_mut()
        .zip(out.par_iter_mut())
        .for_each(|(s, real)| {
            if nt > 1 {
                fft_axis(s, nt, n * n * nh, &ifft_t);
            }
            fft_axis(s, n, n * nh, &ifft_n);
            fft_axis(s, n, nh, &ifft_n);
            s.par_chunks_mut(nh)
                .zip(real.par_chunks_mut(n))
                .for_each_init(
                    || c2r.make_scratch_vec(),
                    |scratch, (row, line)| {
                        // Real up to round-off after the symmetric passes.
                        row[0].im = 0.0;
                        row[nh - 1].im = 0.0;
                        c2r.process_with_scratch(row, line, scratch)
                            .expect("c2r buffer sizes are planned");
                    },
                );
        });
    out
}

/// Flux of the trilinearly sampled tile through the faces of its lattice cubes.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct TileDivergence {
    /// Largest |net flux| over all cubes (and frames).
    pub max_net: f32,
    /// Mean over cubes of Σ |face flux| (6 faces, unit face area).
    pub mean_abs: f32,
    /// `max_net / mean_abs`.
    pub relative: f32,
}

/// A synthesised periodic tile of divergence-free wind.
#[derive(Clone, Debug)]
pub struct SpectralTile {
    params: SpectralParams,
    /// Interleaved samples, layout `[t][z][y][x][3]`, max |u| = 1.
    data: Vec<f32>,
    /// The factor applied by the normalisation.
    scale: f32,
}

impl SpectralTile {
    /// Synthesise a tile (module docs, steps 1–5).
    pub fn new(params: SpectralParams, seed: u64) -> Result<Self, InputError> {
        params.validate()?;
        let real = inverse(&params, spectrum(&params, seed));
        let cells = real[0].len();
        let mut data = vec![0.0f32; 3 * cells];
        data.par_chunks_mut(3).enumerate().for_each(|(i, v)| {
            for c in 0..3 {
                v[c] = real[c][i];
            }
        });
        let max = data
            .par_chunks(3)
            .map(|v| Vec3::from_slice(v).length())
            .reduce(|| 0.0, f32::max);
        let scale = if max > 0.0 { 1.0 / max } else { 1.0 };
        data.par_iter_mut().for_each(|x| *x *= scale);
        Ok(Self {
            params,
            data,
            scale,
        })
    }

    /// The parameters the tile was built with.
    pub fn params(&self) -> &SpectralParams {
        &self.params
    }

    /// The normalisation factor `1 / max |u|` applied to the inverse DFT
    /// (rustfft's unnormalised convention).
    pub fn scale(&self) -> f32 {
        self.scale
    }

    /// Interleaved samples of frame `t`, layout `[z][y][x][3]`.
    ///
    /// # Panics
    /// If `t` is not a frame of the tile.
    pub fn frame(&self, t: usize) -> &[f32] {
        let len = 3 * self.params.res.pow(3);
        &self.data[t * len..(t + 1) * len]
    }

    /// The net flux of the trilinearly interpolated tile through every
    /// lattice cube, relative to the typical face flux.
    pub fn divergence(&self) -> TileDivergence {
        let n = self.params.res;
        let (net, abs) = (0..self.params.frames * n)
            .into_par_iter()
            .map(|fz| {
                let (f, k) = (fz / n, fz % n);
                let u = self.frame(f);
                let at = |i: usize, j: usize, k: usize, c: usize| {
                    u[3 * (((k % n) * n + j % n) * n + i % n) + c]
                };
                let mut max_net = 0.0f32;
                let mut sum_abs = 0.0f64;
                for j in 0..n {
                    for i in 0..n {
                        let face = |c: usize, side: usize| {
                            let mut s = 0.0;
                            for a in 0..2 {
                                for b in 0..2 {
                                    s += match c {
                                        0 => at(i + side, j + a, k + b, 0),
                                        1 => at(i + a, j + side, k + b, 1),
                                        _ => at(i + a, j + b, k + side, 2),
                                    };
                                }
                            }
                            0.25 * s
                        };
                        let mut net = 0.0;
                        for c in 0..3 {
                            let (lo, hi) = (face(c, 0), face(c, 1));
                            net += hi - lo;
                            sum_abs += (lo.abs() + hi.abs()) as f64;
                        }
                        max_net = max_net.max(net.abs());
                    }
                }
                (max_net, sum_abs)
            })
            // Added in order: the same bits at any thread count.
            .collect::<Vec<_>>()
            .into_iter()
            .fold((0.0f32, 0.0f64), |a, b| (a.0.max(b.0), a.1 + b.1));
        let mean_abs = (abs / (self.params.frames * n * n * n) as f64) as f32;
        TileDivergence {
            max_net: net,
            mean_abs,
            relative: net / mean_abs,
        }
    }
}

/// The tile as a velocity field at one time: trilinear in space (periodic,
/// sample `m` at world `m · period/N`), linear between frames.
#[derive(Clone, Debug)]
pub struct SpectralNoise {
    tile: Arc<SpectralTile>,
    inv_spacing: f32,
    frames: [usize; 2],
    frac: f32,
}

impl SpectralNoise {
    /// The field of `tile` at time `t` in frames (periodic in `frames`).
    pub fn new(tile: Arc<SpectralTile>, t: f32) -> Self {
        let p = *tile.params();
        let t0 = t.floor();
        let f0 = (t0 as i64).rem_euclid(p.frames as i64) as usize;
        Self {
            inv_spacing: p.res as f32 / p.period,
            frames: [f0, (f0 + 1) % p.frames],
            frac: t - t0,
            tile,
        }
    }

    #[inline(always)]
    fn sample(&self, p: Vec3) -> Vec3 {
        let n = self.tile.params.res;
        let st = Stencil::new(p * self.inv_spacing, [n; 3], Wrap::Periodic);
        let a = st.apply_vec3(self.tile.frame(self.frames[0]));
        if self.frac == 0.0 {
            a
        } else {
            a.lerp(st.apply_vec3(self.tile.frame(self.frames[1])), self.frac)
        }
    }
}

impl VectorField for SpectralNoise {
    #[inline]
    fn eval(&self, p: Vec3) -> Vec3 {
        self.sample(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn small(frames: usize) -> SpectralParams {
        SpectralParams {
            res: 8,
            frames,
            spectrum: Spectrum::Gaussian { b: 0.2 },
            temporal_b: 0.3,
            period: 1.0,
        }
    }

    /// A naive forward DFT of the synthesised real tile gives back the
    /// constructed half spectrum (times the number of samples): nothing was
    /// lost to a missing Hermitian partner, so the inverse really was real.
    #[test]
    fn tile_transforms_back_to_its_spectrum() {
        for frames in [1, 4] {
            let p = small(frames);
            let spec = spectrum(&p, 5);
            let real = inverse(&p, spec.clone());
            let (n, nt, nh) = (p.res, frames, p.res / 2 + 1);
            let total = (n * n * n * nt) as f32;
            let mut worst = 0.0f32;
            let mut peak = 0.0f32;
            for l in 0..nt {
                for kz in 0..n {
                    for ky in 0..n {
                        for kx in 0..nh {
                            let mut acc = [Complex32::default(); 3];
                            for t in 0..nt {
                                for z in 0..n {
                                    for y in 0..n {
                                        for x in 0..n {
                                            let ph = -TAU
                                                * ((l * t) as f32 / nt as f32
                                                    + ((kz * z + ky * y + kx * x) as f32)
                                                        / n as f32);
                                            let e = Complex32::from_polar(1.0, ph);
                                            let i = ((t * n + z) * n + y) * n + x;
                                            for c in 0..3 {
                                                acc[c] += e * real[c][i];
                                            }
                                        }
                                    }
                                }
                            }
                            let i = ((l * n + kz) * n + ky) * nh + kx;
                            for c in 0..3 {
                                worst = worst.max((acc[c] / total - spec[c][i]).norm());
                                peak = peak.max(spec[c][i].norm());
                            }
                        }
                    }
                }
            }
            assert!(
                worst < 1e-5 * peak,
                "frames {frames}: {worst} vs peak {peak}"
            );
        }
    }

    #[test]
    fn tile_is_normalised_periodic_and_cube_flux_free() {
        let tile = Arc::new(SpectralTile::new(small(3), 1).unwrap());
        let noise = SpectralNoise::new(tile.clone(), 0.0);
        let max = tile
            .frame(0)
            .chunks(3)
            .map(|v| Vec3::from_slice(v).length())
            .fold(0.0f32, f32::max);
        assert!(max <= 1.0 + 1e-6);
        let p = Vec3::new(0.3, 0.71, 0.05);
        assert!((noise.eval(p) - noise.eval(p + Vec3::X)).length() < 1e-5);
        // Time-periodic: t and t + frames agree.
        let (a, b) = (
            SpectralNoise::new(tile.clone(), 0.4),
            SpectralNoise::new(tile.clone(), 3.4),
        );
        assert!((a.eval(p) - b.eval(p)).length() < 1e-6);
        assert!(tile.divergence().relative < 1e-5);
    }

    #[test]
    fn rejects_bad_parameters() {
        let bad = [
            SpectralParams { res: 7, ..small(1) },
            SpectralParams {
                res: 512,
                ..small(1)
            },
            SpectralParams {
                frames: 0,
                ..small(1)
            },
            SpectralParams {
                period: -1.0,
                ..small(1)
            },
            SpectralParams {
                spectrum: Spectrum::Gaussian { b: 0.0 },
                ..small(1)
            },
            SpectralParams {
                spectrum: Spectrum::Kolmogorov { cutoff: f32::NAN },
                ..small(1)
            },
        ];
        for p in bad {
            assert!(SpectralTile::new(p, 0).is_err(), "{p:?} accepted");
        }
    }
}
