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

/// March step through the extinction grid, in cells: half a cell keeps the
/// trilinear interpolant resolved.
const SHADOW_STEP_CELLS: f32 = 0.5;

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

/// `T^L` (eq A.5) at every cell centre of `sigma`'s grid: the optical depth
/// toward the light is integrated with the midpoint rule in steps of
/// [`SHADOW_STEP_CELLS`] cells, up to the light or the edge of the box,
/// whichever comes first (outside the box there is no density).
pub fn light_transmissivity(light: &PointLight, sigma: &ScalarGrid) -> ScalarGrid {
    let d = *sigma.domain();
    let (lo, hi) = (d.origin, d.max_corner());
    let h_max = SHADOW_STEP_CELLS * d.cell;
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
                        let mut acc = 0.0;
                        for s in 0..n {
                            acc += sigma.eval(x + (s as f32 + 0.5) * h * dir);
                        }
                        acc * h
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

    #[test]
    fn uniform_medium_attenuates_as_exp_of_path_to_the_box_edge() {
        let d = Domain::cube(20, 2.0).unwrap();
        let vol = Volume {
            name: "fog".into(),
            density: ops::constant(0.5),
            emission: Vec3::ZERO,
            scattering: Vec3::ONE,
            kappa: 2.0,
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
