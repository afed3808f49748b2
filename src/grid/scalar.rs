//! Scalar grid: one f32 per cell centre.

use glam::Vec3;
use ndarray::{Array3, Ix3};
use rayon::prelude::*;

use super::samples::{write_slabs, Grid};
use super::{Stencil, Wrap};
use crate::domain::Domain;
use crate::field::ScalarField;

/// Scalar samples on the cell centres of a [`Domain`], shape `(nz, ny, nx)`.
///
/// As a [`ScalarField`] it interpolates trilinearly (`cacheread`), periodic or
/// clamped according to its [`Wrap`].
pub type ScalarGrid = Grid<Ix3>;

impl Grid<Ix3> {
    /// A grid of zeros, periodic.
    pub fn zeros(domain: Domain) -> Self {
        Self {
            domain,
            wrap: Wrap::Periodic,
            data: Array3::zeros(domain.shape()),
        }
    }

    /// Wrap an array of shape `(nz, ny, nx)`.
    ///
    /// # Panics
    /// If the array's shape is not the domain's.
    pub fn from_array(domain: Domain, data: Array3<f32>) -> Self {
        let (nz, ny, nx) = domain.shape();
        Self::checked(domain, data, &[nz, ny, nx])
    }

    /// `cachewrite`: sample a field at every cell centre, in parallel batches
    /// of one z-slab.
    pub fn from_field(domain: Domain, field: &dyn ScalarField) -> Self {
        let mut grid = Self::zeros(domain);
        grid.write_field(field);
        grid
    }

    /// Overwrite the samples with `field` at every cell centre.
    pub fn write_field(&mut self, field: &dyn ScalarField) {
        let domain = self.domain;
        write_slabs(domain, self.as_slice_mut(), |p, out| {
            field.eval_batch(p, out)
        });
    }

    /// The trilinear interpolant (this grid's [`ScalarField`] query, with its
    /// [`Wrap`]) at every cell centre of `out`, whose domain is this one
    /// refined `r` times per axis ([`Domain::refined`]). Fine centre `f` lies
    /// at coarse grid coordinate `g = (f + ½)/r − ½` on each axis, so the
    /// weights are separable and the same on every row: one z-interpolated
    /// coarse slab per fine slab, then rows in y, then samples in x — the
    /// interpolant's value up to f32 rounding (a few ulps from the point
    /// query's, which rounds the fine centre's coordinates first), at a
    /// fraction of eight corners per sample.
    ///
    /// # Panics
    /// If `out`'s domain is not this one refined by an integer factor.
    pub fn sample_refined(&self, out: &mut ScalarGrid) {
        let [nx, ny, _] = self.domain.dims;
        let fine = *out.domain();
        let r = fine.dims[0] / nx;
        assert!(
            r >= 1 && fine == self.domain.refined(r),
            "sample_refined: {:?} is not {:?} refined",
            fine.dims,
            self.domain.dims
        );
        let axes: [Vec<(usize, usize, f32)>; 3] =
            std::array::from_fn(|a| refined_axis(self.domain.dims[a], r, self.wrap));
        let [ax, ay, az] = &axes;
        let coarse = self.as_slice();
        let fx = fine.dims[0];
        out.as_slice_mut()
            .par_chunks_mut(fx * fine.dims[1])
            .enumerate()
            .for_each_init(
                || (vec![0.0f32; nx * ny], vec![0.0f32; nx]),
                |(plane, row), (kf, slab)| {
                    let (k0, k1, tz) = az[kf];
                    let (a, b) = (
                        &coarse[k0 * nx * ny..][..nx * ny],
                        &coarse[k1 * nx * ny..][..nx * ny],
                    );
                    for (p, (a, b)) in plane.iter_mut().zip(a.iter().zip(b)) {
                        *p = (1.0 - tz) * a + tz * b;
                    }
                    for (out_row, &(j0, j1, ty)) in slab.chunks_exact_mut(fx).zip(ay) {
                        let (a, b) = (&plane[j0 * nx..][..nx], &plane[j1 * nx..][..nx]);
                        for (x, (a, b)) in row.iter_mut().zip(a.iter().zip(b)) {
                            *x = (1.0 - ty) * a + ty * b;
                        }
                        for (o, &(i0, i1, tx)) in out_row.iter_mut().zip(ax) {
                            *o = (1.0 - tx) * row[i0] + tx * row[i1];
                        }
                    }
                },
            );
    }

    /// Trilinear sample at continuous grid coordinates (cell centres at integers).
    #[inline]
    pub fn sample_grid_coords(&self, g: Vec3) -> f32 {
        Stencil::new(g, self.domain.dims, self.wrap).apply(self.as_slice())
    }

    /// Integral over the box, `Σ ρ Δx³`, accumulated in f64: the sums of
    /// fixed chunks ([`lane_sum`]) added in chunk order, so the same bits at
    /// any thread count.
    pub fn total(&self) -> f64 {
        let sums: Vec<f64> = self
            .as_slice()
            .par_chunks(TOTAL_CHUNK)
            .map(lane_sum)
            .collect();
        sums.iter().sum::<f64>() * self.domain.cell_volume() as f64
    }

    /// `v += s·a` for every value `v` and the value `a` of `add` at the
    /// same cell (f32), returning [`Self::total`] before and after, the
    /// same bits, found in the same pass: each chunk summed, updated and
    /// summed again while it is in cache. One read and one write of the
    /// grid where the update and two totals would read it three times.
    ///
    /// # Panics
    /// If `add` is on another domain.
    pub fn add_scaled_with_totals(&mut self, add: &ScalarGrid, s: f32) -> (f64, f64) {
        assert_eq!(
            self.domain, add.domain,
            "add_scaled_with_totals: another domain"
        );
        let sums: Vec<(f64, f64)> = (self.as_slice_mut().par_chunks_mut(TOTAL_CHUNK))
            .zip(add.as_slice().par_chunks(TOTAL_CHUNK))
            .map(|(values, add)| {
                let before = lane_sum(values);
                for (v, a) in values.iter_mut().zip(add) {
                    *v += a * s;
                }
                (before, lane_sum(values))
            })
            .collect();
        let volume = self.domain.cell_volume() as f64;
        let before = sums.iter().map(|s| s.0).sum::<f64>() * volume;
        let after = sums.iter().map(|s| s.1).sum::<f64>() * volume;
        (before, after)
    }

    /// Largest absolute sample.
    pub fn max_abs(&self) -> f32 {
        self.as_slice()
            .par_iter()
            .map(|v| v.abs())
            .reduce(|| 0.0, f32::max)
    }

    /// Centre of mass `Σ ρ x / Σ ρ` (undefined for an empty grid: returns the box centre).
    pub fn center_of_mass(&self) -> Vec3 {
        let d = self.domain;
        let (mut m, mut c) = (0.0f64, [0.0f64; 3]);
        for ((k, j, i), &v) in self.data.indexed_iter() {
            let p = d.cell_center(i, j, k);
            m += v as f64;
            c[0] += v as f64 * p.x as f64;
            c[1] += v as f64 * p.y as f64;
            c[2] += v as f64 * p.z as f64;
        }
        if m == 0.0 {
            return d.origin + 0.5 * d.size();
        }
        Vec3::new((c[0] / m) as f32, (c[1] / m) as f32, (c[2] / m) as f32)
    }
}

impl ScalarField for ScalarGrid {
    fn eval(&self, p: Vec3) -> f32 {
        self.sample_grid_coords(self.domain.grid_coords(p))
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        let data = self.as_slice();
        for (o, &p) in out.iter_mut().zip(points) {
            *o = Stencil::new(self.domain.grid_coords(p), self.domain.dims, self.wrap).apply(data);
        }
    }
}

/// Per fine index along an axis of `n` coarse cells refined `r` times: the
/// two coarse neighbours of its centre and the weight of the upper one
/// (`g = (f + ½)/r − ½`; periodic indices wrap, clamped coordinates stop at
/// the outermost centres, as [`Stencil`] does).
fn refined_axis(n: usize, r: usize, wrap: Wrap) -> Vec<(usize, usize, f32)> {
    (0..n * r)
        .map(|f| {
            let g = (f as f64 + 0.5) / r as f64 - 0.5;
            match wrap {
                Wrap::Periodic => {
                    let lo = g.floor();
                    let i = (lo as i64).rem_euclid(n as i64) as usize;
                    (i, (i + 1) % n, (g - lo) as f32)
                }
                Wrap::Clamped => {
                    let g = g.clamp(0.0, (n - 1) as f64);
                    let i = (g.floor() as usize).min(n.saturating_sub(2));
                    (i, (i + 1).min(n - 1), (g - i as f64) as f32)
                }
            }
        })
        .collect()
}

/// The values [`ScalarGrid::total`] sums per chunk, in chunk order.
const TOTAL_CHUNK: usize = 1 << 14;

/// `Σ v` in f64, in eight independent lanes added at the end (a fixed
/// order; one running sum would serialise on its latency).
fn lane_sum(values: &[f32]) -> f64 {
    let mut lanes = [0.0f64; 8];
    let chunks = values.chunks_exact(8);
    let rest = chunks.remainder().iter().map(|&v| v as f64).sum::<f64>();
    for c in chunks {
        for (s, &v) in lanes.iter_mut().zip(c) {
            *s += v as f64;
        }
    }
    lanes.iter().sum::<f64>() + rest
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops;

    /// A smooth positive field whose samples use every bit of an f32.
    struct Bumpy;
    impl ScalarField for Bumpy {
        fn eval(&self, p: Vec3) -> f32 {
            1.0 + (1.3 * p.x).sin() * (0.7 * p.y).cos() + 0.1 * p.z
        }
    }

    #[test]
    fn cachewrite_then_cacheread_reproduces_linear_fields() {
        let d = Domain::new(Vec3::ZERO, 0.5, [6, 5, 4]).unwrap();
        struct Linear;
        impl ScalarField for Linear {
            fn eval(&self, p: Vec3) -> f32 {
                1.0 + 2.0 * p.x - p.y + 0.5 * p.z
            }
        }
        let g = ScalarGrid::from_field(d, &Linear).with_wrap(Wrap::Clamped);
        // Inside the hull of the cell centres trilinear interpolation is exact for linear data.
        for p in [Vec3::new(0.4, 0.8, 0.3), Vec3::new(2.6, 2.2, 1.7)] {
            assert!((g.eval(p) - Linear.eval(p)).abs() < 1e-5);
        }
        assert_eq!(g.data()[[1, 2, 3]], Linear.eval(d.cell_center(3, 2, 1)));
    }

    #[test]
    fn total_of_constant_is_volume() {
        let d = Domain::cube(8, 2.0).unwrap();
        let g = ScalarGrid::from_field(d, &*ops::constant(3.0));
        assert!((g.total() - 24.0).abs() < 1e-9);
    }

    #[test]
    fn total_is_the_same_at_any_thread_count() {
        // 64³ cells: sixteen chunks, split differently by one and three threads.
        let d = Domain::cube(64, 6.0).unwrap();
        let g = ScalarGrid::from_field(d, &Bumpy);
        let on = |n| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(n)
                .build()
                .unwrap();
            pool.install(|| g.total())
        };
        let one = on(1);
        assert_eq!(one.to_bits(), on(3).to_bits());
        // And it is the sum: a running f64 sum differs by rounding only
        // (measured 2e-16 relative); a lost or doubled chunk by ≳ 1/16.
        let plain = g.as_slice().iter().map(|&v| v as f64).sum::<f64>() * d.cell_volume() as f64;
        assert!(
            (one - plain).abs() <= 1e-12 * plain,
            "{one} against {plain}"
        );
    }
    #[test]
    fn add_scaled_with_totals_is_the_update_and_both_totals_to_the_bit() {
        // 40³ cells: four chunks and a short last one.
        let d = Domain::cube(40, 6.0).unwrap();
        let g = ScalarGrid::from_field(d, &Bumpy);
        let add = ScalarGrid::from_field(d, &*ops::constant(0.3));
        let mut updated = g.clone();
        let (before, after) = updated.add_scaled_with_totals(&add, 0.05);
        assert_eq!(before.to_bits(), g.total().to_bits());
        assert_eq!(after.to_bits(), updated.total().to_bits());
        for (u, &v) in updated.as_slice().iter().zip(g.as_slice()) {
            assert_eq!(u.to_bits(), (v + 0.3 * 0.05f32).to_bits());
        }
        assert!(after > before, "{after} after {before}");
    }

    #[test]
    fn sample_refined_is_the_point_query_at_the_fine_centres() {
        struct Bumpy;
        impl ScalarField for Bumpy {
            fn eval(&self, p: Vec3) -> f32 {
                (1.3 * p.x).sin() * (0.7 * p.y).cos() + 0.4 * p.z
            }
        }
        let d = Domain::new(Vec3::new(-1.0, 0.5, 2.0), 0.5, [7, 5, 4]).unwrap();
        for wrap in [Wrap::Periodic, Wrap::Clamped] {
            let coarse = ScalarGrid::from_field(d, &Bumpy).with_wrap(wrap);
            for r in [1, 2, 3] {
                let mut fast = ScalarGrid::zeros(d.refined(r));
                coarse.sample_refined(&mut fast);
                let slow = ScalarGrid::from_field(d.refined(r), &coarse);
                // Measured: ≤ 4.8e-7 (rounding of the fine centres'
                // coordinates in the point query); a wrong neighbour or
                // weight is off by ≳ 1e-2 on this field.
                let worst = fast
                    .as_slice()
                    .iter()
                    .zip(slow.as_slice())
                    .map(|(a, b)| (a - b).abs())
                    .fold(0.0f32, f32::max);
                assert!(worst < 2e-6, "{wrap:?} r = {r}: {worst}");
            }
        }
    }
}
