//! Trilinear interpolation stencils in continuous grid coordinates.

use glam::Vec3;
use serde::{Deserialize, Serialize};

/// What happens to a sample point outside the grid.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Wrap {
    /// The grid tiles space (the FFT projection's periodic box).
    #[default]
    Periodic,
    /// Points are clamped to the outermost cell centres (closed boxes).
    Clamped,
}

/// The eight corners and weights of a trilinear sample.
///
/// Built from continuous grid coordinates (cell centres at integers); the
/// indices are linear `[z][y][x]` offsets into a grid with `dims`, every one
/// below `cells = nx·ny·nz` by construction, so applying the stencil checks
/// the data's length once instead of each corner.
#[derive(Clone, Copy, Debug)]
pub struct Stencil {
    /// Linear indices of the corners, in the order
    /// `(x0,y0,z0), (x1,y0,z0), (x0,y1,z0), (x1,y1,z0), (x0,y0,z1), …`.
    index: [usize; 8],
    /// Trilinear weights, summing to one.
    weight: [f32; 8],
    /// Cells of the grid the indices point into.
    cells: usize,
}

/// `⌊g⌋` as an integer and the fraction `g − ⌊g⌋`.
///
/// Truncation plus a correction: `f32::floor` is a libm call on baseline
/// x86-64, and this runs three times per trilinear sample.
#[inline(always)]
fn floor_frac(g: f32) -> (i32, f32) {
    let t = g as i32;
    let f = if (t as f32) > g { t - 1 } else { t };
    (f, g - f as f32)
}

/// Lower and upper lattice index and the fraction between them along one axis.
#[inline(always)]
fn axis(g: f32, n: usize, wrap: Wrap) -> (usize, usize, f32) {
    let ni = n as i32;
    match wrap {
        Wrap::Periodic => {
            let (f, t) = floor_frac(g);
            // Departure points are rarely more than one period away: avoid the
            // integer division of `rem_euclid` on the common path.
            let i0 = if (0..ni).contains(&f) {
                f
            } else if (-ni..0).contains(&f) {
                f + ni
            } else {
                f.rem_euclid(ni)
            } as usize;
            let i1 = if i0 + 1 == n { 0 } else { i0 + 1 };
            (i0, i1, t)
        }
        Wrap::Clamped => {
            let (f, t) = floor_frac(g.clamp(0.0, (n - 1) as f32));
            let i0 = f as usize;
            let i1 = (i0 + 1).min(n - 1);
            (i0, i1, t)
        }
    }
}

impl Stencil {
    /// The stencil of continuous grid coordinates `g` on a grid of `dims = [nx, ny, nz]`.
    #[inline(always)]
    pub fn new(g: Vec3, dims: [usize; 3], wrap: Wrap) -> Self {
        Self::weighted(g, dims, wrap, None)
    }

    /// The stencil of `∂q/∂g_axis`, the derivative of the trilinear
    /// interpolant at `g` along `axis` (per grid spacing): [`Self::new`]'s
    /// corners with the weights `(1 − t, t)` along `axis` replaced by
    /// `(−1, 1)` — or `(0, 0)` where a clamped coordinate lies outside the
    /// grid, where the clamped interpolant is constant. On a face plane
    /// between two cells it is the upper cell's.
    #[inline(always)]
    pub fn derivative(g: Vec3, dims: [usize; 3], wrap: Wrap, axis: usize) -> Self {
        Self::weighted(g, dims, wrap, Some(axis))
    }

    /// [`Self::new`], or [`Self::derivative`] along `derivative`.
    #[inline(always)]
    fn weighted(g: Vec3, dims: [usize; 3], wrap: Wrap, derivative: Option<usize>) -> Self {
        let (x0, x1, tx) = axis(g.x, dims[0], wrap);
        let (y0, y1, ty) = axis(g.y, dims[1], wrap);
        let (z0, z1, tz) = axis(g.z, dims[2], wrap);
        let (mut sx, mut sy, mut sz) = (1.0 - tx, 1.0 - ty, 1.0 - tz);
        let (mut tx, mut ty, mut tz) = (tx, ty, tz);
        if let Some(a) = derivative {
            let outside = wrap == Wrap::Clamped && !(0.0..=(dims[a] - 1) as f32).contains(&g[a]);
            let (s, t) = if outside { (0.0, 0.0) } else { (-1.0, 1.0) };
            match a {
                0 => (sx, tx) = (s, t),
                1 => (sy, ty) = (s, t),
                _ => (sz, tz) = (s, t),
            }
        }
        let (nx, ny) = (dims[0], dims[1]);
        let row = |y: usize, z: usize| (z * ny + y) * nx;
        let (r00, r10, r01, r11) = (row(y0, z0), row(y1, z0), row(y0, z1), row(y1, z1));
        Self {
            cells: nx * ny * dims[2],
            index: [
                r00 + x0,
                r00 + x1,
                r10 + x0,
                r10 + x1,
                r01 + x0,
                r01 + x1,
                r11 + x0,
                r11 + x1,
            ],
            weight: [
                sx * sy * sz,
                tx * sy * sz,
                sx * ty * sz,
                tx * ty * sz,
                sx * sy * tz,
                tx * sy * tz,
                sx * ty * tz,
                tx * ty * tz,
            ],
        }
    }

    /// The linear indices of the eight corners (the order of the `index`
    /// doc above): the values a sample at this point is a weighted mean of,
    /// whose minimum and maximum bound it (MacCormack's clamp).
    #[inline(always)]
    pub fn corners(&self) -> [usize; 8] {
        self.index
    }

    /// Interpolate a scalar array laid out like the grid.
    ///
    /// # Panics
    /// If `data` is too short for the stencil's grid.
    #[inline(always)]
    pub fn apply(&self, data: &[f32]) -> f32 {
        assert!(data.len() >= self.cells, "stencil outside the data");
        let mut acc = 0.0;
        for c in 0..8 {
            // SAFETY: every index is below `cells ≤ data.len()` (Self::new).
            acc += self.weight[c] * unsafe { *data.get_unchecked(self.index[c]) };
        }
        acc
    }

    /// Interpolate an interleaved 3-component array laid out like the grid.
    ///
    /// # Panics
    /// If `data` is too short for the stencil's grid.
    #[inline(always)]
    pub fn apply_vec3(&self, data: &[f32]) -> Vec3 {
        assert!(data.len() >= 3 * self.cells, "stencil outside the data");
        let mut acc = Vec3::ZERO;
        for c in 0..8 {
            let o = 3 * self.index[c];
            // SAFETY: `index < cells`, so `o + 2 < 3 cells ≤ data.len()`.
            let v = unsafe {
                Vec3::new(
                    *data.get_unchecked(o),
                    *data.get_unchecked(o + 1),
                    *data.get_unchecked(o + 2),
                )
            };
            acc += self.weight[c] * v;
        }
        acc
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weights_sum_to_one_and_wrap() {
        let s = Stencil::new(Vec3::new(-0.25, 3.5, 7.9), [4, 4, 8], Wrap::Periodic);
        let sum: f32 = s.weight.iter().sum();
        assert!((sum - 1.0).abs() < 1e-6);
        // x = -0.25 lies between cell 3 (wrapped) and cell 0.
        assert_eq!(s.index[0] % 4, 3);
        assert_eq!(s.index[1] % 4, 0);
    }

    #[test]
    fn fast_floor_is_floor() {
        for g in [
            -3.5f32, -3.0, -2.9999998, -0.0, 0.0, 1e-30, -1e-30, 0.5, 7.0, 7.9999995, 1e7, -1e9,
        ] {
            let (f, t) = floor_frac(g);
            assert_eq!(f as f32, g.floor(), "{g}");
            assert_eq!(t, g - g.floor(), "{g}");
        }
    }

    #[test]
    fn indices_stay_inside_for_any_point() {
        // The unchecked loads of `apply` rely on this invariant.
        for v in [
            f32::NAN,
            f32::INFINITY,
            -f32::INFINITY,
            1e30,
            -1e30,
            -1e-30,
            4.0,
            -4.0,
        ] {
            for wrap in [Wrap::Periodic, Wrap::Clamped] {
                let s = Stencil::new(Vec3::new(v, -v, 0.5 * v), [4, 3, 5], wrap);
                assert!(s.index.iter().all(|&i| i < s.cells), "{v} {wrap:?}");
            }
        }
    }

    #[test]
    fn clamped_stays_inside() {
        let s = Stencil::new(Vec3::new(-5.0, 10.0, 1.5), [4, 4, 4], Wrap::Clamped);
        assert!(s.index.iter().all(|&i| i < 64));
        let sum: f32 = s.weight.iter().sum();
        assert!((sum - 1.0).abs() < 1e-6);
    }
}
