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
//!   coarse node on a periodic grid); a gridless density with the solid
//!   sources is a lattice count of the sources' sharp images, off by ±1–2 %
//!   at 2× (32³ hot/cold, step 20: 0.9911 of the injected at 2×, 1.0010
//!   at 4×, 0.9992 at 8×) — sampling, not lost mass;
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
//! A gridded density in a periodic box needs no fine transform for its
//! sub-grid fraction: its fine samples are the grid's trilinear interpolant,
//! whose spectrum along each axis is the grid's own times the
//! interpolation's gain. With fine samples `f[2i] = ¾ρ_i + ¼ρ_{i−1}`,
//! `f[2i+1] = ¾ρ_i + ¼ρ_{i+1}` on `2N` points,
//!
//! ```text
//! f̂(k) = H(k) ρ̂(k mod N),   |H(k)|² = (½ cos(3ω/2) + 3/2 cos(ω/2))²,   ω = πk/N,
//! ```
//!
//! so each coarse bin `q` stands for the fine bins `q` and `q + N` per axis,
//! weighted by `|H|²` ([`refined_weights`]); the share comes from one
//! transform of the coarse grid (eight times fewer values) with the fine
//! one's value to rounding. A clamped (closed-box) density's fine samples
//! differ at the walls, and are transformed at 2×.
//!
//! The transforms (real-to-complex along x, complex along y and z) are
//! planned once in [`DensityProbe::new`] and every buffer is reused.

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use super::{DensityMode, DensityModel};
use crate::domain::Domain;
use crate::field::{eval_supported, ScalarField};
use crate::grid::{ScalarGrid, Wrap};
use crate::metrics::spectrum::AxisWeight;
use crate::metrics::SpectralShare;

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
    fine: ScalarGrid,
    /// Further fine grids for [`Self::measure_all`], made when first needed.
    more: Vec<ScalarGrid>,
    spectra: Spectra,
}

/// The transforms of the sub-grid fraction: of the fine samples, and of a
/// periodic gridded density's own grid with the gains of its 2×
/// interpolant (module documentation).
struct Spectra {
    coarse: Domain,
    fine: SpectralShare,
    grid: SpectralShare,
    gains: [Vec<AxisWeight>; 3],
}

impl DensityProbe {
    /// Plan for densities on the velocity grid `coarse`.
    pub fn new(coarse: Domain) -> Self {
        let fine = coarse.refined(REFINE);
        Self {
            fine: ScalarGrid::zeros(fine),
            more: Vec::new(),
            spectra: Spectra {
                coarse,
                fine: SpectralShare::new(fine.dims),
                grid: SpectralShare::new(coarse.dims),
                gains: coarse.dims.map(refined_weights),
            },
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
        let grids = std::iter::once(&self.fine).chain(&self.more);
        grids
            .map(|g| std::mem::size_of_val(g.as_slice()))
            .sum::<usize>()
            + self.spectra.fine.bytes()
            + self.spectra.grid.bytes()
    }

    /// Sample `model` on the fine grid and measure it.
    pub fn measure(&mut self, model: &DensityModel) -> DensityMeasures {
        model.sample(&mut self.fine);
        measure_sampled(&self.fine, Some(model), &mut self.spectra)
    }

    /// [`Self::measure`] of every model, sampled together
    /// ([`DensityModel::sample_all`]: gridless gases that share their
    /// velocity history walk back once), so with one fine grid per model
    /// when more than one is gridless; the same values as one by one.
    pub fn measure_all(&mut self, models: &[&DensityModel]) -> Vec<DensityMeasures> {
        let gridless = models
            .iter()
            .filter(|m| m.mode() == DensityMode::Gridless)
            .count();
        if gridless < 2 {
            return models.iter().map(|m| self.measure(m)).collect();
        }
        let domain = *self.fine.domain();
        self.more
            .resize_with(models.len() - 1, || ScalarGrid::zeros(domain));
        let mut grids: Vec<&mut ScalarGrid> = std::iter::once(&mut self.fine)
            .chain(&mut self.more)
            .collect();
        DensityModel::sample_all(models, &mut grids);
        let spectra = &mut self.spectra;
        std::iter::once(&self.fine)
            .chain(&self.more)
            .zip(models)
            .map(|(g, m)| measure_sampled(g, Some(m), spectra))
            .collect()
    }

    /// Sample any field on the fine grid and measure it.
    pub fn measure_field(&mut self, field: &dyn ScalarField) -> DensityMeasures {
        self.fine.write_field(field);
        measure_sampled(&self.fine, None, &mut self.spectra)
    }
}

/// The measures of a density sampled on `fine`, the velocity grid refined
/// [`REFINE`] times: of `model` when it is the density sampled (a periodic
/// gridded one's sub-grid fraction from its own grid), else of a field.
fn measure_sampled(
    fine: &ScalarGrid,
    model: Option<&DensityModel>,
    spectra: &mut Spectra,
) -> DensityMeasures {
    let cut = spectra.coarse.dims.map(|n| n / 2);
    let own_grid = model
        .filter(|m| m.mode() == DensityMode::Gridded)
        .map(DensityModel::density)
        .filter(|grid| grid.wrap() == Wrap::Periodic);
    let subgrid_fraction = match own_grid {
        Some(grid) => spectra.grid.weighted_share(grid.as_slice(), &spectra.gains),
        None => spectra.fine.share_above(&[fine.as_slice()], cut),
    };
    DensityMeasures {
        mass: fine.total(),
        max: fine.max_abs() as f64,
        mean_gradient: mean_gradient(fine),
        subgrid_fraction,
    }
}

/// The gains of the bins `q = 0 … n − 1` of an axis of `n` cells on the
/// spectrum of its trilinear samples at [`REFINE`] = 2 (module
/// documentation): in the total `|H(q)|² + |H(q + n)|²`, below the cut
/// those of the two fine bins whose signed index is at most `n/2`.
fn refined_weights(n: usize) -> Vec<AxisWeight> {
    let gain = |k: usize| {
        let w = std::f64::consts::PI * k as f64 / n as f64;
        let h = 0.5 * (1.5 * w).cos() + 1.5 * (0.5 * w).cos();
        h * h
    };
    let below = |k: usize| k.min(2 * n - k) <= n / 2;
    (0..n)
        .map(|q| {
            let fine = [q, q + n];
            AxisWeight {
                total: fine.iter().map(|&k| gain(k)).sum(),
                below: fine.iter().filter(|&&k| below(k)).map(|&k| gain(k)).sum(),
            }
        })
        .collect()
}

/// `∫ f dV` over the box of `domain` by the midpoint rule on the grid
/// refined `refine` times per axis, one z-slab at a time (no grid is
/// allocated). For the injection budget: the notes' sources are solid
/// spheres, whose volume this approximates to a fraction of a percent at
/// `refine = 4` and 32³ or more.
pub fn integral(f: &dyn ScalarField, domain: &Domain, refine: usize) -> f64 {
    let fine = domain.refined(refine);
    let support = f.support();
    let sum: f64 = (0..fine.dims[2])
        .into_par_iter()
        .map_init(
            || (Vec::new(), Vec::new()),
            |(points, values), k| {
                fine.slab_centers(k, points);
                values.resize(points.len(), 0.0);
                eval_supported(f, support, points, values);
                values.iter().map(|&v| v as f64).sum::<f64>()
            },
        )
        // Added in slab order: the same bits at any thread count.
        .collect::<Vec<_>>()
        .into_iter()
        .sum();
    sum * fine.cell_volume() as f64
}

/// The cell averages of `f` on `domain` by the midpoint rule on the
/// `refine`³ sub-cells of each cell: `f̄_c = Σ_{sub-cells} f / refine³`. The
/// sub-cell centres are those of [`integral`] at the same `refine`, so
/// `Σ_c f̄_c Δx³` is that quadrature of `∫f dV` (to f32 rounding of the
/// averages). The gridded injection rate, so that a gridded gas injects what
/// gridless and SELMA do (`crate::simulation::Gas`).
pub fn cell_averages(f: &dyn ScalarField, domain: &Domain, refine: usize) -> ScalarGrid {
    let fine = domain.refined(refine);
    let [nx, ny, _] = domain.dims;
    let mut grid = ScalarGrid::zeros(*domain);
    let weight = 1.0 / (refine * refine * refine) as f64;
    let nf = fine.dims[0];
    let support = f.support();
    grid.as_slice_mut()
        .par_chunks_mut(nx * ny)
        .enumerate()
        .for_each_init(
            || {
                (
                    vec![Vec3::ZERO; nf],
                    vec![0.0f32; nf],
                    vec![0.0f64; nx * ny],
                )
            },
            |(points, values, sums), (k, out)| {
                sums.iter_mut().for_each(|s| *s = 0.0);
                // One fine row at a time (its points stay in the L1 cache),
                // each adding `refine` samples in a row to each of its
                // coarse cells, in the samples' order.
                for kf in k * refine..(k + 1) * refine {
                    for jf in 0..fine.dims[1] {
                        // A row outside the support adds only `+0.0`s.
                        let ends = [
                            fine.cell_center(0, jf, kf),
                            fine.cell_center(nf - 1, jf, kf),
                        ];
                        if support.is_some_and(|b| !b.meets(&ends)) {
                            continue;
                        }
                        for (i, p) in points.iter_mut().enumerate() {
                            *p = fine.cell_center(i, jf, kf);
                        }
                        eval_supported(f, support, points, values);
                        let cells = &mut sums[(jf / refine) * nx..][..nx];
                        for (s, sub) in cells.iter_mut().zip(values.chunks_exact(refine)) {
                            for &v in sub {
                                *s += v as f64;
                            }
                        }
                    }
                }
                for (o, s) in out.iter_mut().zip(sums.iter()) {
                    *o = (s * weight) as f32;
                }
            },
        );
    grid
}

/// Mean of `|∇ρ|` over a periodic grid, by central differences. Row by row:
/// the x-neighbours wrap only at a row's two ends, and the sum of each
/// z-slab runs in eight fixed lanes (independent of the thread count).
pub fn mean_gradient(g: &ScalarGrid) -> f64 {
    let d = g.domain();
    let [nx, ny, nz] = d.dims;
    let r = g.as_slice();
    let inv = 1.0 / (2.0 * d.cell);
    let row = |j: usize, k: usize| &r[(k * ny + j) * nx..][..nx];
    let slabs: Vec<f64> = (0..nz)
        .into_par_iter()
        .map_init(
            || vec![0.0f32; nx],
            |gx: &mut Vec<f32>, k| {
                let (kp, km) = ((k + 1) % nz, (k + nz - 1) % nz);
                let mut lanes = [0.0f64; 8];
                for j in 0..ny {
                    let (jp, jm) = ((j + 1) % ny, (j + ny - 1) % ny);
                    let c = row(j, k);
                    gx[0] = c[1 % nx] - c[nx - 1];
                    for i in 1..nx.saturating_sub(1) {
                        gx[i] = c[i + 1] - c[i - 1];
                    }
                    if nx > 1 {
                        gx[nx - 1] = c[0] - c[nx - 2];
                    }
                    let (yp, ym, zp, zm) = (row(jp, k), row(jm, k), row(j, kp), row(j, km));
                    // |∇ρ| in place of the x-difference, then summed by lane.
                    for (i, g) in gx.iter_mut().enumerate() {
                        let (gy, gz) = (yp[i] - ym[i], zp[i] - zm[i]);
                        *g = (*g * *g + gy * gy + gz * gz).sqrt() * inv;
                    }
                    for (n, &v) in gx.iter().enumerate() {
                        lanes[n % 8] += v as f64;
                    }
                }
                lanes.iter().sum::<f64>()
            },
        )
        .collect();
    slabs.iter().sum::<f64>() / d.len() as f64
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

    /// A periodic gridded density's sub-grid fraction, from its own grid
    /// and the interpolation's gains, is the one of its 2× samples'
    /// transform (here 0.0199 on 12 × 10 × 8 cells of noise; without the
    /// gains it would be 0, the coarse grid holding nothing beyond its
    /// Nyquist index). Measured difference: 7e-8 relative (f32 transforms
    /// of different sizes).
    #[test]
    fn a_periodic_gridded_share_is_its_fine_samples_share() {
        let d = Domain::new(Vec3::new(0.5, -1.0, 2.0), 0.5, [12, 10, 8]).unwrap();
        let mut model = DensityModel::new(&Default::default(), d, None, None);
        let DensityModel::Gridded(g) = &mut model else {
            panic!("the default density is gridded")
        };
        for (i, v) in g.density_mut().as_slice_mut().iter_mut().enumerate() {
            *v = ((i * 7919) % 1009) as f32 / 1009.0;
        }
        let mut probe = DensityProbe::new(d);
        let from_grid = probe.measure(&model);
        let from_samples = probe.measure_field(model.density());
        let (a, b) = (from_grid.subgrid_fraction, from_samples.subgrid_fraction);
        assert!(b > 5e-3 && b < 0.5, "energy on both sides of the cut: {b}");
        assert!((a - b).abs() < 1e-5 * b, "{a} vs {b}");
        assert!((from_grid.mass - from_samples.mass).abs() < 1e-5 * from_grid.mass);
    }

    #[test]
    fn cell_averages_total_the_quadrature() {
        let d = Domain::cube(12, 6.0).unwrap();
        let s = ops::mask(ops::sphere(Vec3::new(2.9, 3.1, 3.3), 1.2));
        let exact = integral(&*s, &d, 4);
        let averaged = cell_averages(&*s, &d, 4).total();
        // Measured: 7.23046875 both (equal here; f32 rounding of the
        // averages could differ by ~1e-7); the point samples at the centres
        // give 6.875, −4.9 %.
        assert!(
            (averaged - exact).abs() < 1e-6 * exact,
            "{averaged} vs {exact}"
        );
        let point = ScalarGrid::from_field(d, &*s).total();
        assert!((point - exact).abs() > 1e-2 * exact, "{point} vs {exact}");
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
