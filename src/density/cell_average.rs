//! Cell averages by supersampling: what a procedural density (gridless,
//! SELMA) puts on a grid.
//!
//! A gridless or SELMA density `ρ(x) = ρ₀(X(x))` holds structure finer than
//! a cell — filaments stretched by the flow. Its value at a cell centre is a
//! point sample, which aliases a filament thinner than a cell into isolated
//! specks (06-6: 15 % of the gridless gas in blobs under 8 cells at 32³),
//! and the specks then drive the buoyancy. The band-limited sample of the
//! field on a grid is its **cell average**
//!
//! ```text
//! ρ̄_c = (1/|c|) ∫_c ρ(X(x)) dx  ≈  (1/8) Σ_{s=1…8} ρ(X(x_c + δ_s Δx)),
//!         δ_s ∈ {−¼, +¼}³
//! ```
//!
//! — the midpoint rule on the 2×2×2 sub-cells, exact for a field linear in
//! each coordinate (trilinear) and with error `Δx²/96 · ∇²ρ` for a smooth
//! one; each sub-cell point is walked back through the history on its own
//! (gridless) or read through the map (SELMA). [`CellSamples`] selects it
//! or the point sample at the centre (one walk per cell instead of eight).
//!
//! The default is the average for gridless and the centre for SELMA
//! ([`CellSamples::default_for`]): SELMA's reference `R` is itself a grid of
//! 2×2×2 cell averages (its injection and its re-anchoring), composed with
//! a map sampled on the velocity grid's lattice, so its centre values are
//! already band-limited at the grid's spacing (0 % of its mass in isolated
//! blobs on the slab box, either way); averaging them again blurs `R` once
//! more and costs eight map reads per cell.
//!
//! The points are laid out offset by offset ([`sub_points`]): sub-point `s`
//! of centre `m` at `s·n + m`, so that a run of lanes of the vector kernels
//! holds one offset of consecutive centres — points of one lattice row.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::{BoxWrap, DensityMode};
use crate::domain::Domain;
use crate::error::InputError;

/// Offsets of the 2×2×2 sub-points of a cell, in cells (`δ_s`).
pub(crate) const SUB: [Vec3; 8] = [
    Vec3::new(-0.25, -0.25, -0.25),
    Vec3::new(0.25, -0.25, -0.25),
    Vec3::new(-0.25, 0.25, -0.25),
    Vec3::new(0.25, 0.25, -0.25),
    Vec3::new(-0.25, -0.25, 0.25),
    Vec3::new(0.25, -0.25, 0.25),
    Vec3::new(-0.25, 0.25, 0.25),
    Vec3::new(0.25, 0.25, 0.25),
];

/// How a gridless or SELMA density is sampled onto the velocity grid for
/// the buoyancy force and the saved volumes: the number of points per cell.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "usize", into = "usize")]
pub enum CellSamples {
    /// `1`: the point sample at the cell centre (aliases sub-cell filaments
    /// into specks).
    Centre,
    /// `8`: the cell average over the 2×2×2 sub-cell points (module
    /// documentation); eight walks per cell.
    Average,
}

impl CellSamples {
    /// The default of a density mode (module documentation): the average
    /// for gridless, the centre for SELMA (and for gridded, which has no
    /// field finer than its grid).
    pub fn default_for(mode: DensityMode) -> Self {
        match mode {
            DensityMode::Gridless => CellSamples::Average,
            DensityMode::Gridded | DensityMode::Selma => CellSamples::Centre,
        }
    }

    /// Points per cell: 1 or 8.
    pub fn count(self) -> usize {
        match self {
            CellSamples::Centre => 1,
            CellSamples::Average => SUB.len(),
        }
    }
}

impl TryFrom<usize> for CellSamples {
    type Error = InputError;

    fn try_from(n: usize) -> Result<Self, InputError> {
        match n {
            1 => Ok(CellSamples::Centre),
            8 => Ok(CellSamples::Average),
            _ => Err(InputError::new(format!(
                "cell_samples is {n}; it must be 1 (the cell centre) or 8 (the 2×2×2 cell average)"
            ))),
        }
    }
}

impl From<CellSamples> for usize {
    fn from(s: CellSamples) -> usize {
        s.count()
    }
}

/// The points at which the cells around `centres` (cells of `d`) are
/// sampled, into `out` (resized): the centres themselves, or their 2×2×2
/// sub-points laid out offset by offset (sub-point `s` of centre `m` at
/// `out[s·n + m]`, `n` centres), wrapped into the box.
pub(crate) fn cell_points(d: &Domain, samples: CellSamples, centres: &[Vec3], out: &mut Vec<Vec3>) {
    out.clear();
    match samples {
        CellSamples::Centre => out.extend_from_slice(centres),
        CellSamples::Average => {
            out.resize(SUB.len() * centres.len(), Vec3::ZERO);
            sub_points(d, centres, out);
        }
    }
}

/// The 2×2×2 sub-points of a cell of `d` around each of `centres`, wrapped
/// into the box, eight per centre, offset by offset: sub-point `s` of
/// centre `m` at `out[s·n + m]` (`n` centres).
///
/// # Panics
/// If `out` does not hold eight points per centre.
pub(crate) fn sub_points(d: &Domain, centres: &[Vec3], out: &mut [Vec3]) {
    let n = centres.len();
    assert_eq!(out.len(), SUB.len() * n, "sub_points: eight per centre");
    let into_box = BoxWrap::new(d);
    let offsets = SUB.map(|s| s * d.cell);
    let (low, high) = (offsets[0], offsets[7]);
    for (m, &c) in centres.iter().enumerate() {
        // Every sub-point's coordinates are the lowest's or the highest's:
        // when those two are inside the box, all eight are.
        let inside = into_box.inside(c + low) && into_box.inside(c + high);
        for (s, &o) in offsets.iter().enumerate() {
            out[s * n + m] = if inside { c + o } else { into_box.wrap(c + o) };
        }
    }
}

/// The sum of centre `m`'s eight sub-point values, laid out as
/// [`sub_points`] lays out the points, in the offsets' order.
#[inline(always)]
pub(crate) fn sub_sum(values: &[f32], m: usize) -> f32 {
    let n = values.len() / SUB.len();
    (0..SUB.len()).map(|s| values[s * n + m]).sum::<f32>()
}

/// `out[m]` = the value of cell `m` from `values` at its
/// [`cell_points`]: the value itself, or the mean of its eight sub-points
/// (a cell is wet or dry as a whole, and a dry cell's values are cleared
/// afterwards, [`crate::boundary::WallStop::dry_world`]).
///
/// # Panics
/// If `values` does not hold `samples.count()` entries per cell of `out`.
pub(crate) fn cell_values(samples: CellSamples, values: &[f32], out: &mut [f32]) {
    let n = out.len();
    assert!(
        values.len() == samples.count() * n,
        "cell_values: one value per sample point"
    );
    match samples {
        CellSamples::Centre => out.copy_from_slice(values),
        CellSamples::Average => {
            for (m, o) in out.iter_mut().enumerate() {
                *o = sub_sum(values, m) * 0.125;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The eight sub-points of a cell are its sub-cell centres, and the
    /// mean of a linear ramp over them is the ramp at the centre (exactly:
    /// the box of edge 2 in 4 cells makes every number dyadic).
    #[test]
    fn sub_points_are_the_sub_cell_centres() {
        let d = Domain::cube(4, 2.0).unwrap();
        let centres = [d.cell_center(1, 2, 3), d.cell_center(0, 0, 0)];
        let mut points = Vec::new();
        cell_points(&d, CellSamples::Average, &centres, &mut points);
        assert_eq!(points.len(), 16);
        for (s, o) in SUB.iter().enumerate() {
            for (m, &c) in centres.iter().enumerate() {
                assert_eq!(points[s * 2 + m], c + *o * d.cell);
            }
        }
        let ramp = |p: Vec3| 1.0 + p.x - 2.0 * p.y + 0.5 * p.z;
        let values: Vec<f32> = points.iter().map(|&p| ramp(p)).collect();
        let mut cells = [0.0; 2];
        cell_values(CellSamples::Average, &values, &mut cells);
        // Dyadic centres, offsets and slopes: every value and sum is exact.
        for (&c, &p) in cells.iter().zip(&centres) {
            assert_eq!(c, ramp(p));
        }
    }

    #[test]
    fn samples_are_one_or_eight() {
        assert_eq!(CellSamples::try_from(1).unwrap(), CellSamples::Centre);
        assert_eq!(CellSamples::try_from(8).unwrap().count(), 8);
        assert!(CellSamples::try_from(4).is_err());
        assert_eq!(
            CellSamples::default_for(DensityMode::Gridless),
            CellSamples::Average
        );
        assert_eq!(
            CellSamples::default_for(DensityMode::Selma),
            CellSamples::Centre
        );
    }
}
