//! Measures of a density at twice the velocity grid's resolution: mass,
//! mean gradient, and the share of spectral energy finer than the velocity
//! grid can hold.
//!
//! Every density representation is sampled the same way — at the cell
//! centres of the velocity grid refined twice per axis — so the measures
//! compare representations on equal terms:
//!
//! - **mass** `Σ ρ (Δx/2)³`: for a gridded density this equals the grid's
//!   own `Σ ρ Δx³` (the trilinear weights of the refined centres sum to 8 per
//!   coarse node on a periodic grid);
//! - **peak** `max ρ` — what diffusion erodes first (the notes' "loss of
//!   density", fig 7.4);
//! - **mean |∇ρ|** by central differences on the fine grid — the notes' measure
//!   of filaments and sheets (§7.1, eqs 7.5–7.7);
//! - **sub-grid fraction**: of the density's spectral energy
//!   `Σ_{k≠0} |ρ̂(k)|²`, the part with a wavenumber index beyond the velocity
//!   grid's Nyquist index `N/2` on some axis — detail the velocity grid cannot
//!   represent. Trilinear interpolation itself leaks a little energy there,
//!   so a gridded density's value is the baseline, not zero.
//!
//! The transforms (real-to-complex along x, complex along y and z) are
//! planned once in [`DensityProbe::new`] and every buffer is reused.

use std::sync::Arc;

use rayon::prelude::*;
use realfft::num_complex::Complex32;
use realfft::{RealFftPlanner, RealToComplex};
use rustfft::{Fft, FftPlanner};
use serde::Serialize;

use super::DensityModel;
use crate::domain::Domain;
use crate::field::ScalarField;
use crate::grid::ScalarGrid;

/// Refinement of the measuring grid over the velocity grid, per axis.
pub const REFINE: usize = 2;

/// The measures of one density at one step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct DensityMeasures {
    /// `∫ρ` by the fine sampling.
    pub mass: f64,
    /// Largest sample of the fine sampling: the peak density, which
    /// numerical diffusion lowers even where it keeps the mass.
    pub max: f64,
    /// Mean of |∇ρ| over the box, central differences on the fine grid.
    pub mean_gradient: f64,
    /// Share of the non-mean spectral energy beyond the velocity grid's Nyquist index.
    pub subgrid_fraction: f64,
}

/// Planned transforms and buffers for measuring densities of one velocity grid.
pub struct DensityProbe {
    coarse: Domain,
    fine: ScalarGrid,
    nxh: usize,
    r2c: Arc<dyn RealToComplex<f32>>,
    fft_y: Arc<dyn Fft<f32>>,
    fft_z: Arc<dyn Fft<f32>>,
    /// Spectrum after the x and y passes, `[z][y][kx]`.
    slabs: Vec<Complex32>,
    /// Full spectrum, `[ky][kx][kz]`.
    columns: Vec<Complex32>,
}

impl DensityProbe {
    /// Plan for densities on the velocity grid `coarse`.
    pub fn new(coarse: Domain) -> Self {
        let fine = coarse.refined(REFINE);
        let [nx, ny, nz] = fine.dims;
        let nxh = nx / 2 + 1;
        let len = nxh * ny * nz;
        let mut complex = FftPlanner::<f32>::new();
        Self {
            coarse,
            fine: ScalarGrid::zeros(fine),
            nxh,
            r2c: RealFftPlanner::<f32>::new().plan_fft_forward(nx),
            fft_y: complex.plan_fft_forward(ny),
            fft_z: complex.plan_fft_forward(nz),
            slabs: vec![Complex32::default(); len],
            columns: vec![Complex32::default(); len],
        }
    }

    /// The measuring grid.
    pub fn fine_domain(&self) -> &Domain {
        self.fine.domain()
    }

    /// The last fine sampling.
    pub fn fine(&self) -> &ScalarGrid {
        &self.fine
    }

    /// Bytes of the probe's buffers.
    pub fn bytes(&self) -> usize {
        std::mem::size_of_val(self.fine.as_slice())
            + std::mem::size_of_val(&self.slabs[..])
            + std::mem::size_of_val(&self.columns[..])
    }

    /// Sample `model` on the fine grid and measure it.
    pub fn measure(&mut self, model: &DensityModel) -> DensityMeasures {
        model.sample(&mut self.fine);
        self.measure_sampled()
    }

    /// Sample any field on the fine grid and measure it.
    pub fn measure_field(&mut self, field: &dyn ScalarField) -> DensityMeasures {
        self.fine.write_field(field);
        self.measure_sampled()
    }

    fn measure_sampled(&mut self) -> DensityMeasures {
        DensityMeasures {
            mass: self.fine.total(),
            max: self.fine.max_abs() as f64,
            mean_gradient: mean_gradient(&self.fine),
            subgrid_fraction: self.subgrid_fraction(),
        }
    }

    /// Share of `Σ_{k≠0} |ρ̂|²` with `|m_a| > N_a/2` on some axis `a`.
    fn subgrid_fraction(&mut self) -> f64 {
        let [nx, ny, nz] = self.fine.domain().dims;
        let nxh = self.nxh;
        let cut = self.coarse.dims.map(|n| (n / 2) as i64);
        let (r2c, fft_y, src) = (&self.r2c, &self.fft_y, self.fine.as_slice());
        self.slabs
            .par_chunks_mut(ny * nxh)
            .enumerate()
            .for_each_init(
                || {
                    (
                        vec![0.0f32; nx],
                        vec![Complex32::default(); r2c.get_scratch_len()],
                        vec![Complex32::default(); ny],
                        vec![Complex32::default(); fft_y.get_inplace_scratch_len()],
                    )
                },
                |(real, rs, line, ys), (k, slab)| {
                    for j in 0..ny {
                        real.copy_from_slice(&src[(k * ny + j) * nx..(k * ny + j + 1) * nx]);
                        r2c.process_with_scratch(real, &mut slab[j * nxh..(j + 1) * nxh], rs)
                            .expect("r2c buffer sizes are planned");
                    }
                    for i in 0..nxh {
                        for j in 0..ny {
                            line[j] = slab[j * nxh + i];
                        }
                        fft_y.process_with_scratch(line, ys);
                        for j in 0..ny {
                            slab[j * nxh + i] = line[j];
                        }
                    }
                },
            );
        let (slabs, fft_z) = (&self.slabs, &self.fft_z);
        let signed = |m: usize, n: usize| {
            if m <= n / 2 {
                m as i64
            } else {
                m as i64 - n as i64
            }
        };
        let (total, above) = self
            .columns
            .par_chunks_mut(nxh * nz)
            .enumerate()
            .map_init(
                || vec![Complex32::default(); fft_z.get_inplace_scratch_len()],
                |scratch, (j, col)| {
                    for k in 0..nz {
                        let row = &slabs[(k * ny + j) * nxh..(k * ny + j + 1) * nxh];
                        for (i, &v) in row.iter().enumerate() {
                            col[i * nz + k] = v;
                        }
                    }
                    fft_z.process_with_scratch(col, scratch);
                    let sy = signed(j, ny).abs();
                    let (mut total, mut above) = (0.0f64, 0.0f64);
                    for i in 0..nxh {
                        // Bins 1 … nx/2−1 stand for ±kx: count them twice.
                        let w = if i == 0 || (nx % 2 == 0 && i == nx / 2) {
                            1.0
                        } else {
                            2.0
                        };
                        for k in 0..nz {
                            if i == 0 && j == 0 && k == 0 {
                                continue;
                            }
                            let e = w * col[i * nz + k].norm_sqr() as f64;
                            total += e;
                            let sz = signed(k, nz).abs();
                            if i as i64 > cut[0] || sy > cut[1] || sz > cut[2] {
                                above += e;
                            }
                        }
                    }
                    (total, above)
                },
            )
            .reduce(|| (0.0, 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
        if total > 0.0 {
            above / total
        } else {
            0.0
        }
    }
}

/// `∫ f dV` over the box of `domain` by the midpoint rule on the grid
/// refined `refine` times per axis, one z-slab at a time (no grid is
/// allocated). For the injection budget: the notes' sources are solid
/// spheres, whose volume this approximates to a fraction of a percent at
/// `refine = 4` and 32³ or more.
pub fn integral(f: &dyn ScalarField, domain: &Domain, refine: usize) -> f64 {
    let fine = domain.refined(refine);
    let sum: f64 = (0..fine.dims[2])
        .into_par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(points, values), k| {
                fine.slab_centers(k, points);
                values.resize(points.len(), 0.0);
                f.eval_batch(points, values);
                values.iter().map(|&v| v as f64).sum::<f64>()
            },
        )
        .sum();
    sum * fine.cell_volume() as f64
}

/// Mean of `|∇ρ|` over a periodic grid, by central differences.
pub fn mean_gradient(g: &ScalarGrid) -> f64 {
    let d = g.domain();
    let [nx, ny, nz] = d.dims;
    let r = g.as_slice();
    let inv = 1.0 / (2.0 * d.cell);
    let sum: f64 = (0..nz)
        .into_par_iter()
        .map(|k| {
            let (kp, km) = ((k + 1) % nz, (k + nz - 1) % nz);
            let mut s = 0.0f64;
            for j in 0..ny {
                let (jp, jm) = ((j + 1) % ny, (j + ny - 1) % ny);
                for i in 0..nx {
                    let (ip, im) = ((i + 1) % nx, (i + nx - 1) % nx);
                    let at = |i, j, k| r[(k * ny + j) * nx + i];
                    let gx = at(ip, j, k) - at(im, j, k);
                    let gy = at(i, jp, k) - at(i, jm, k);
                    let gz = at(i, j, kp) - at(i, j, km);
                    s += ((gx * gx + gy * gy + gz * gz).sqrt() * inv) as f64;
                }
            }
            s
        })
        .sum();
    sum / d.len() as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops;
    use glam::Vec3;

    /// `sin(2π m x / L)` along x.
    struct Wave(f32);
    impl ScalarField for Wave {
        fn eval(&self, p: Vec3) -> f32 {
            1.0 + (std::f32::consts::TAU * self.0 * p.x / 8.0).sin()
        }
    }

    #[test]
    fn spectral_fraction_separates_modes_at_the_coarse_nyquist() {
        let coarse = Domain::cube(8, 8.0).unwrap();
        let mut probe = DensityProbe::new(coarse);
        // Mode 3 fits the 8-cell grid (Nyquist index 4); mode 6 does not.
        let low = probe.measure_field(&Wave(3.0));
        assert!(low.subgrid_fraction < 1e-8, "{low:?}");
        let high = probe.measure_field(&Wave(6.0));
        assert!((high.subgrid_fraction - 1.0).abs() < 1e-6, "{high:?}");
        assert!((low.mass - 512.0).abs() < 1e-3);
        // mean |d/dx sin(kx)| = k · 2/π with k = 2π·3/8; the central
        // difference at h = 1/2 scales it by sin(kh)/(kh).
        let k = std::f64::consts::TAU * 3.0 / 8.0;
        let expect = k * 2.0 / std::f64::consts::PI * (k * 0.5).sin() / (k * 0.5);
        assert!(
            (low.mean_gradient - expect).abs() < 2e-2 * expect,
            "{low:?}"
        );
    }

    #[test]
    fn gridded_mass_is_the_grid_total() {
        let d = Domain::cube(8, 8.0).unwrap();
        let s = ops::mask(ops::sphere(Vec3::new(3.0, 4.0, 4.5), 2.0));
        let model = DensityModel::new(&Default::default(), d, Some(s), None);
        let mut probe = DensityProbe::new(d);
        let m = probe.measure(&model);
        let grid = model.density().total();
        assert!((m.mass - grid).abs() < 1e-5 * grid, "{} vs {grid}", m.mass);
    }
}
