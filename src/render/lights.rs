//! Point lights and their transmissivity grids (eqs A.4–A.7).
//!
//! The light reaching a sample, `C^I(x) = Σᵢ C^L_i T^L_i(x) P(n·nᴸᵢ)` (A.7),
//! needs the transmissivity toward each light,
//! `T^L(x) = exp(−∫₀^D κρ(x + s nᴸ) ds)` (A.5). Marching that integral for
//! every sample of every camera ray would cost a second march per sample;
//! instead, once per frame, the total extinction `σ = Σ κⱼ ρⱼ` is sampled on
//! a grid over the render box (one batch query of each density per cell),
//! `T^L` is marched through that grid from every cell centre toward each
//! light, and the camera march interpolates `T^L` trilinearly.

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use super::{ray_box, Volume};
use crate::domain::Domain;
use crate::error::InputError;
use crate::field::ScalarField;
use crate::grid::{ScalarGrid, Wrap};

/// A point light: colour `C^L` at position `xᴸ`. As in the notes there is
/// no inverse-square fall-off; the colour is the light that reaches an
/// unshadowed sample.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct PointLight {
    /// Position xᴸ.
    pub position: Vec3,
    /// Colour C^L (linear RGB, may exceed 1).
    pub color: Vec3,
}

impl PointLight {
    /// Check that position and colour are finite and the colour non-negative.
    pub fn validate(&self) -> Result<(), InputError> {
        if !self.position.is_finite() {
            return Err(InputError::new(format!(
                "light position is {}; it must be finite",
                self.position
            )));
        }
        if !(self.color.is_finite() && self.color.min_element() >= 0.0) {
            return Err(InputError::new(format!(
                "light colour is {}; it must be finite and non-negative",
                self.color
            )));
        }
        Ok(())
    }
}

/// March step through the extinction grid, in cells (midpoint rule on the
/// trilinear interpolant of σ).
pub const SHADOW_STEP_CELLS: f32 = 1.0;

/// Optical depth past which the march toward a light stops: `T < 10⁻⁵`.
pub const SHADOW_MAX_DEPTH: f32 = 11.5;

/// One light with its transmissivity `T^L` sampled on the render grid.
pub struct LitLight {
    /// The light.
    pub light: PointLight,
    /// `T^L` at the cell centres, read back with clamped trilinear interpolation.
    pub transmissivity: ScalarGrid,
}

impl LitLight {
    /// `T^L(x)` interpolated from the grid.
    #[inline]
    pub fn transmissivity_at(&self, x: Vec3) -> f32 {
        self.transmissivity.eval(x)
    }
}

/// Total extinction `σ(x) = Σⱼ κⱼ max(ρⱼ(x), 0)` at the cell centres of `grid`.
///
/// Returns the grid and the number of density queries made.
pub fn extinction_grid(grid: &Domain, volumes: &[Volume]) -> (ScalarGrid, u64) {
    let mut sigma = ScalarGrid::zeros(*grid).with_wrap(Wrap::Clamped);
    let slab = grid.dims[0] * grid.dims[1];
    sigma
        .as_slice_mut()
        .par_chunks_mut(slab)
        .enumerate()
        .for_each_init(
            || (Vec::new(), vec![0.0; slab]),
            |(points, rho), (k, out)| {
                grid.slab_centers(k, points);
                out.fill(0.0);
                for v in volumes {
                    v.density.eval_batch(points, rho);
                    for (o, r) in out.iter_mut().zip(rho.iter()) {
                        *o += v.kappa * r.max(0.0);
                    }
                }
            },
        );
    (sigma, (grid.len() * volumes.len()) as u64)
}

/// Edge of an occupancy brick, in cells.
const BRICK: usize = 4;

/// Which bricks of `BRICK³` cells the trilinear interpolant of σ is
/// negligible in: the shadow march jumps over those. Negligible means
/// `σ ≤ 10⁻⁵ / D` with D the box diagonal, so a skipped stretch of any path
/// through the box holds optical depth below 10⁻⁵ and `T^L` changes by less
/// than 10⁻⁵ relative. (Exact zeros alone would not do: semi-Lagrangian
/// advection leaves tiny positive densities almost everywhere.)
struct Occupancy {
    domain: Domain,
    dims: [usize; 3],
    empty: Vec<bool>,
}

impl Occupancy {
    /// Brick `b` spans grid coordinates `[bB − ½, (b+1)B − ½)` per axis, and
    /// trilinear samples there read nodes `bB − 1 ..= (b+1)B`: the brick is
    /// empty when all of those are negligible.
    fn new(sigma: &ScalarGrid) -> Self {
        let domain = *sigma.domain();
        let n = domain.dims;
        let dims = n.map(|c| c.div_ceil(BRICK));
        let data = sigma.as_slice();
        let negligible = 1e-5 / domain.size().length();
        let range =
            |b: usize, a: usize| (b * BRICK).saturating_sub(1)..=((b + 1) * BRICK).min(n[a] - 1);
        let mut empty = vec![true; dims.iter().product()];
        for bz in 0..dims[2] {
            for by in 0..dims[1] {
                for bx in 0..dims[0] {
                    let occupied = range(bz, 2).any(|k| {
                        range(by, 1)
                            .any(|j| range(bx, 0).any(|i| data[domain.index(i, j, k)] > negligible))
                    });
                    empty[(bz * dims[1] + by) * dims[0] + bx] = !occupied;
                }
            }
        }
        Self {
            domain,
            dims,
            empty,
        }
    }

    /// If `p` lies in an empty brick, the distance along `dir` to its exit.
    #[inline]
    fn skip(&self, p: Vec3, dir: Vec3) -> Option<f32> {
        let size = BRICK as f32 * self.domain.cell;
        let b = ((p - self.domain.origin) / size).floor();
        let idx = [0, 1, 2].map(|a| (b[a].max(0.0) as usize).min(self.dims[a] - 1));
        if !self.empty[(idx[2] * self.dims[1] + idx[1]) * self.dims[0] + idx[0]] {
            return None;
        }
        let lo = self.domain.origin + Vec3::new(idx[0] as f32, idx[1] as f32, idx[2] as f32) * size;
        Some(ray_box(p, dir, lo, lo + Vec3::splat(size)).map_or(0.0, |(_, t1)| t1.max(0.0)))
    }
}

/// `T^L` (eq A.5) at every cell centre of `sigma`'s grid: the optical depth
/// toward the light is integrated with the midpoint rule in steps of
/// [`SHADOW_STEP_CELLS`] cells, up to the light or the edge of the box,
/// whichever comes first (outside the box there is no density), or until
/// it exceeds [`SHADOW_MAX_DEPTH`]. Steps inside bricks where σ is
/// negligible are skipped (see `Occupancy`).
pub fn light_transmissivity(light: &PointLight, sigma: &ScalarGrid) -> ScalarGrid {
    let d = *sigma.domain();
    let (lo, hi) = (d.origin, d.max_corner());
    let h_max = SHADOW_STEP_CELLS * d.cell;
    let occupancy = Occupancy::new(sigma);
    let mut trans = ScalarGrid::zeros(d).with_wrap(Wrap::Clamped);
    let slab = d.dims[0] * d.dims[1];
    trans
        .as_slice_mut()
        .par_chunks_mut(slab)
        .enumerate()
        .for_each(|(k, out)| {
            for j in 0..d.dims[1] {
                for i in 0..d.dims[0] {
                    let x = d.cell_center(i, j, k);
                    let to_light = light.position - x;
                    let dist = to_light.length();
                    let tau = if dist > 0.0 {
                        let dir = to_light / dist;
                        let t_exit = ray_box(x, dir, lo, hi).map_or(0.0, |(_, t1)| t1);
                        let len = dist.min(t_exit);
                        let n = (len / h_max).ceil().max(1.0) as usize;
                        let h = len / n as f32;
                        let mut tau = 0.0;
                        let mut s = 0;
                        while s < n {
                            let t = (s as f32 + 0.5) * h;
                            let p = x + t * dir;
                            if let Some(gap) = occupancy.skip(p, dir) {
                                // Next midpoint at or past the brick's exit.
                                let next = ((t + gap) / h - 0.5).ceil() as usize;
                                s = next.max(s + 1);
                                continue;
                            }
                            tau += h * sigma.eval(p);
                            if tau > SHADOW_MAX_DEPTH {
                                break;
                            }
                            s += 1;
                        }
                        tau
                    } else {
                        0.0
                    };
                    out[j * d.dims[0] + i] = (-tau).exp();
                }
            }
        });
    trans
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops;

    /// The same optical depths without brick skipping.
    fn brute_force(light: &PointLight, sigma: &ScalarGrid) -> ScalarGrid {
        let d = *sigma.domain();
        let mut t = ScalarGrid::zeros(d);
        for k in 0..d.dims[2] {
            for j in 0..d.dims[1] {
                for i in 0..d.dims[0] {
                    let x = d.cell_center(i, j, k);
                    let dir = (light.position - x).normalize();
                    let len = (light.position - x)
                        .length()
                        .min(ray_box(x, dir, d.origin, d.max_corner()).unwrap().1);
                    let n = (len / d.cell).ceil().max(1.0) as usize;
                    let h = len / n as f32;
                    let tau: f32 = (0..n)
                        .map(|s| h * sigma.eval(x + (s as f32 + 0.5) * h * dir))
                        .sum();
                    t.data_mut()[[k, j, i]] = (-tau.min(SHADOW_MAX_DEPTH + 1.0)).exp();
                }
            }
        }
        t
    }

    #[test]
    fn skipping_empty_bricks_changes_transmissivity_below_1e_5() {
        // Two small blobs in a mostly empty, non-multiple-of-brick box.
        let d = Domain::new(Vec3::ZERO, 0.1, [19, 14, 11]).unwrap();
        // A faint haze everywhere, just below the skipping threshold.
        let haze = ops::constant(0.9e-5 / (4.0 * d.size().length()));
        let blobs = ops::sum(
            ops::sum(
                ops::mask(ops::sphere(Vec3::new(0.5, 0.7, 0.5), 0.2)),
                ops::scale(ops::mask(ops::sphere(Vec3::new(1.4, 0.4, 0.6), 0.15)), 3.0),
            ),
            haze,
        );
        let vol = Volume {
            name: "blobs".into(),
            density: blobs,
            emission: Vec3::ZERO,
            scattering: Vec3::ONE,
            kappa: 4.0,
            occupancy: None,
        };
        let (sigma, _) = extinction_grid(&d, &[vol]);
        for position in [Vec3::new(3.0, 2.5, -1.0), Vec3::new(1.0, 0.6, 0.5)] {
            let light = PointLight {
                position,
                color: Vec3::ONE,
            };
            let fast = light_transmissivity(&light, &sigma);
            let slow = brute_force(&light, &sigma);
            let diff = fast
                .as_slice()
                .iter()
                .zip(slow.as_slice())
                .map(|(a, b)| (a - b).abs())
                .fold(0.0, f32::max);
            assert!(diff < 1e-5, "light at {position}: max difference {diff}");
            assert!(
                fast.as_slice().iter().any(|&t| t < 0.5),
                "something is shadowed"
            );
        }
    }

    #[test]
    fn uniform_medium_attenuates_as_exp_of_path_to_the_box_edge() {
        let d = Domain::cube(20, 2.0).unwrap();
        let vol = Volume {
            name: "fog".into(),
            density: ops::constant(0.5),
            emission: Vec3::ZERO,
            scattering: Vec3::ONE,
            kappa: 2.0,
            occupancy: None,
        };
        let (sigma, queries) = extinction_grid(&d, &[vol]);
        assert_eq!(queries, 8000);
        // Light straight above, far away: path length to the top face.
        let light = PointLight {
            position: Vec3::new(1.0, 100.0, 1.0),
            color: Vec3::ONE,
        };
        let t = light_transmissivity(&light, &sigma);
        for j in [0, 7, 19] {
            let x = d.cell_center(9, j, 9);
            let expect = (x.y - 2.0).exp(); // σ = κρ = 1
            let got = t.data()[[9, j, 9]];
            assert!((got - expect).abs() < 1e-5, "j={j}: {got} vs {expect}");
        }
        // A light inside the box only attenuates up to its position.
        let inside = PointLight {
            position: Vec3::new(1.0, 1.5, 1.0),
            color: Vec3::ONE,
        };
        let t = light_transmissivity(&inside, &sigma);
        let x = d.cell_center(9, 2, 9);
        let expect = (-(inside.position - x).length()).exp();
        assert!((t.data()[[9, 2, 9]] - expect).abs() < 1e-5);
    }
}
