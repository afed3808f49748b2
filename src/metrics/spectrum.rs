//! Where the energy of periodic samples sits in wavenumber.
//!
//! [`SpectralShare::share_above`] returns, of the non-mean spectral energy
//! `Σ_{k≠0} |q̂(k)|²` of one or more periodic arrays (e.g. the three velocity
//! components), the part with `|k_a| > cut_a` on some axis `a` — a shell in
//! the ∞-norm of the wavenumber index. With `cut = N/4` that shell is the top
//! octave below the Nyquist index `N/2`: grid-scale content such as a
//! cell-to-cell alternating velocity; with the Nyquist index of a coarser grid
//! it is the detail that grid cannot hold.
//!
//! The transform is the pressure solver's periodic FFT in f32
//! ([`PeriodicFft`]: real-to-complex along x, complex along y and z, planned
//! once in [`SpectralShare::new`], every buffer reused), taken forward only
//! ([`PeriodicFft::spectra`]).

use realfft::num_complex::Complex32;

use crate::pressure::periodic_fft::PeriodicFft;

/// A planned transform for arrays of one shape `[nx, ny, nz]`.
pub struct SpectralShare {
    fft: PeriodicFft<f32>,
}

impl SpectralShare {
    /// Plans for arrays of `dims = [nx, ny, nz]` (`[z][y][x]` order in memory).
    pub fn new(dims: [usize; 3]) -> Self {
        Self {
            fft: PeriodicFft::new(dims),
        }
    }

    /// Bytes of the buffers.
    pub fn bytes(&self) -> usize {
        self.fft.bytes()
    }

    /// Share of the summed non-mean energy of `arrays` with `|k_a| > cut[a]`
    /// on some axis (0 when every array is constant).
    ///
    /// # Panics
    /// If an array does not hold `nx·ny·nz` values.
    pub fn share_above(&mut self, arrays: &[&[f32]], cut: [usize; 3]) -> f64 {
        let dims = self.fft.dims();
        let signed = |m: usize, n: usize| if m <= n / 2 { m } else { n - m };
        let weights: [Vec<AxisWeight>; 3] = std::array::from_fn(|a| {
            (0..dims[a])
                .map(|m| AxisWeight {
                    total: 1.0,
                    below: if signed(m, dims[a]) > cut[a] {
                        0.0
                    } else {
                        1.0
                    },
                })
                .collect()
        });
        let (mut total, mut above) = (0.0, 0.0);
        for a in arrays {
            let (t, h) = self.energy(a, &weights);
            total += t;
            above += h;
        }
        share(total, above)
    }

    /// [`Self::share_above`] of the array whose spectrum is this array's
    /// times a separable gain: the energy of bin `m` weighted by
    /// `Π_a weights[a][m_a].total` in the total and by
    /// `Π_a total − Π_a below` in the part above — e.g. a finer grid's
    /// samples of this array's interpolant, each bin standing for the fine
    /// bins it aliases to (`density::probe`). Each table holds one entry
    /// per index along its axis, even in `m` ↔ `N − m` (a real array's
    /// spectrum is, and x holds only bins `0 … nx/2`); bin 0 is left out.
    ///
    /// # Panics
    /// If `src` does not hold `nx·ny·nz` values or a table is not its axis long.
    pub fn weighted_share(&mut self, src: &[f32], weights: &[Vec<AxisWeight>; 3]) -> f64 {
        let (total, above) = self.energy(src, weights);
        share(total, above)
    }

    /// Weighted non-mean energy of `src` (bin 0 left out), and its part
    /// above ([`Self::weighted_share`]); bins `kx = 1 … nx/2 − 1` stand for
    /// `±kx` and count twice.
    fn energy(&mut self, src: &[f32], weights: &[Vec<AxisWeight>; 3]) -> (f64, f64) {
        let [nx, ny, nz] = self.fft.dims();
        assert_eq!(src.len(), nx * ny * nz, "spectrum: array of another size");
        assert!(
            weights.iter().zip([nx, ny, nz]).all(|(w, n)| w.len() == n),
            "spectrum: a weight table of another length"
        );
        let [wx, wy, wz] = weights;
        self.fft.forward(src, |v| v);
        let columns = self.fft.spectra(|i, col: &[Complex32]| {
            let w = if i == 0 || (nx % 2 == 0 && i == nx / 2) {
                1.0
            } else {
                2.0
            };
            let (mut total, mut above) = (0.0f64, 0.0f64);
            for (j, line) in col.chunks_exact(nz).enumerate() {
                let (t, b) = (wx[i].total * wy[j].total, wx[i].below * wy[j].below);
                for (k, c) in line.iter().enumerate() {
                    if i == 0 && j == 0 && k == 0 {
                        continue;
                    }
                    let e = w * c.norm_sqr() as f64;
                    let t = t * wz[k].total;
                    total += e * t;
                    above += e * (t - b * wz[k].below);
                }
            }
            (total, above)
        });
        // Added in x-frequency order: the same bits at any thread count.
        columns
            .into_iter()
            .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1))
    }
}

/// The gain on one index of one axis in [`SpectralShare::weighted_share`]:
/// on the energy counted in the total, and on the energy counted below the
/// cut (the part above is the difference of the products).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AxisWeight {
    /// Gain in the total.
    pub total: f64,
    /// Gain of the part below the cut.
    pub below: f64,
}

/// `above / total`, 0 when there is no energy.
fn share(total: f64, above: f64) -> f64 {
    if total > 0.0 {
        above / total
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separates_modes_at_the_cut_and_ignores_the_mean() {
        let dims = [8, 6, 10];
        let wave = |m: [usize; 3]| -> Vec<f32> {
            let mut v = Vec::with_capacity(480);
            for k in 0..10 {
                for j in 0..6 {
                    for i in 0..8 {
                        let ph = std::f32::consts::TAU * (m[0] * i) as f32 / 8.0
                            + std::f32::consts::TAU * (m[1] * j) as f32 / 6.0
                            + std::f32::consts::TAU * (m[2] * k) as f32 / 10.0;
                        v.push(3.0 + ph.cos());
                    }
                }
            }
            v
        };
        let mut s = SpectralShare::new(dims);
        let (low, high) = (wave([1, 1, 2]), wave([0, 0, 3]));
        assert!(s.share_above(&[&low], [2, 1, 2]) < 1e-10);
        assert!((s.share_above(&[&high], [2, 1, 2]) - 1.0).abs() < 1e-6);
        // Equal amplitudes: half the energy above.
        let both = s.share_above(&[&low, &high], [2, 1, 2]);
        assert!((both - 0.5).abs() < 1e-5, "{both}");
    }

    /// The per-column energies are added in x-frequency order, so the share has
    /// the same bits on 1 and 3 threads (a rayon `reduce` did not: its tree
    /// follows the work stealing). Measured share: 0.966.
    #[test]
    fn the_share_is_the_same_at_any_thread_count() {
        let dims = [32, 24, 40];
        let field: Vec<f32> = (0..32 * 24 * 40)
            .map(|i| ((i * 7919) % 1009) as f32 / 1009.0 - 0.5)
            .collect();
        let share = |threads: usize| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("a thread pool");
            pool.install(|| SpectralShare::new(dims).share_above(&[&field], [8, 6, 10]))
        };
        let one = share(1);
        assert!(
            one > 0.05 && one < 0.99,
            "energy on both sides of the cut: {one}"
        );
        for _ in 0..4 {
            assert_eq!(share(3).to_bits(), one.to_bits());
        }
    }
}
