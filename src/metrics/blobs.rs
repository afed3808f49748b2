//! Isolated blobs: how much of a density's mass lies in specks.
//!
//! A density aliased onto a grid (a gridless filament thinner than a cell,
//! point-sampled) shows as beads: small clumps of cells above the level of
//! the gas around them. The measure is the share of the mass in such
//! clumps,
//!
//! ```text
//! share = Σ_{C : |C| < N} Σ_{c ∈ C} ρ_c  /  Σ_c ρ_c ,
//! ```
//!
//! over the 26-connected components `C` of the cells with
//! `ρ_c > level · max ρ` ([`BLOB_LEVEL`] = 5 %), counting those with fewer
//! than `N` cells ([`BLOB_CELLS`] = 8, a 2×2×2 block). Cells are neighbours
//! across the box's faces too (the box is periodic for every field).

use crate::grid::ScalarGrid;

/// The level, relative to the maximum, above which a cell belongs to a blob.
pub const BLOB_LEVEL: f32 = 0.05;

/// Components with fewer cells than this are isolated blobs.
pub const BLOB_CELLS: usize = 8;

/// The share of the total mass `Σ ρ` of `grid` in 26-connected components
/// of the cells above `level · max ρ` that have fewer than `min_cells`
/// cells (module documentation); 0 for a grid without positive mass.
pub fn isolated_mass_share(grid: &ScalarGrid, level: f32, min_cells: usize) -> f64 {
    let rho = grid.as_slice();
    let total: f64 = rho.iter().map(|&r| r as f64).sum();
    let max = rho.iter().copied().fold(0.0f32, f32::max);
    if !(total > 0.0 && max > 0.0) {
        return 0.0;
    }
    let threshold = level * max;
    let d = grid.domain();
    let [nx, ny, _] = d.dims;
    let mut seen: Vec<bool> = rho.iter().map(|&r| r <= threshold).collect();
    let (mut stack, mut component) = (Vec::new(), Vec::new());
    let mut isolated = 0.0f64;
    for start in 0..rho.len() {
        if seen[start] {
            continue;
        }
        seen[start] = true;
        stack.push(start);
        component.clear();
        while let Some(n) = stack.pop() {
            component.push(n);
            for m in d.block([n % nx, (n / nx) % ny, n / (nx * ny)]) {
                if !seen[m] {
                    seen[m] = true;
                    stack.push(m);
                }
            }
        }
        if component.len() < min_cells {
            isolated += component.iter().map(|&n| rho[n] as f64).sum::<f64>();
        }
    }
    isolated / total
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Domain;

    /// A hand-made 10³ grid: a 3×3×3 block of 2 (27 cells, mass 54), a
    /// diagonal pair of 4 (26-connected, 2 cells, mass 8), a lone cell of
    /// 6 on the box's face whose neighbour across the face is a cell of 1
    /// (one component of 2 cells, mass 7), and a faint cell below the
    /// level (0.1 < 5 % of 6, mass 0.1, in no component). Isolated:
    /// (8 + 7) / (54 + 8 + 7 + 0.1).
    #[test]
    fn isolated_share_counts_small_components() {
        let d = Domain::cube(10, 10.0).unwrap();
        let mut g = ScalarGrid::zeros(d);
        let mut set = |[i, j, k]: [usize; 3], v: f32| g.as_slice_mut()[(k * 10 + j) * 10 + i] = v;
        for k in 1..4 {
            for j in 1..4 {
                for i in 1..4 {
                    set([i, j, k], 2.0);
                }
            }
        }
        set([6, 6, 6], 4.0);
        set([7, 7, 7], 4.0);
        set([0, 5, 8], 6.0);
        set([9, 5, 8], 1.0);
        set([5, 1, 1], 0.1);
        // Every sum is exact in f64 (whole numbers and one f32), so the
        // shares are the exact quotients, rounded once.
        let (total, faint) = (69.0 + 0.1f32 as f64, 0.1f32 as f64);
        assert_eq!(
            isolated_mass_share(&g, BLOB_LEVEL, BLOB_CELLS),
            15.0 / total
        );
        // Everything above the level is a blob once blobs may be larger.
        assert_eq!(
            isolated_mass_share(&g, BLOB_LEVEL, 28),
            (total - faint) / total
        );
        assert_eq!(
            isolated_mass_share(&ScalarGrid::zeros(d), BLOB_LEVEL, BLOB_CELLS),
            0.0
        );
    }
}
