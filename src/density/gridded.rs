//! Gridded density — the notes' FELT script of §6.1.1 (eq 6.4):
//!
//! ```text
//! hot = advect(hot, velocity, dt) + inject(hotpoint, dt);
//! cachewrite(hotCache, hot);  hot = cacheread(hotCache);
//! ```
//!
//! The density lives on the velocity grid's cell centres; each step the
//! simulation's advector moves it (semi-Lagrangian: trilinear at the step's
//! departure points; or QUICK) and the source sampled at the cell centres is
//! added, `ρ ← ρ(x − uΔt) + S Δt`. Every step
//! resamples the density, which is what diffuses it (§6.1.1, fig 6.2).

use std::sync::Arc;

use super::Buffer;
use crate::domain::Domain;
use crate::field::Scalar;
use crate::grid::{ScalarGrid, Wrap};

/// A density grid and its advection scratch.
#[derive(Clone)]
pub struct Gridded {
    density: ScalarGrid,
    scratch: ScalarGrid,
    /// `density.total()` when [`Self::step`] found it (forgotten when the
    /// density is handed out to edit).
    total: Option<f64>,
}

impl Gridded {
    /// The initial density sampled at the cell centres of `domain` (zero if `None`).
    pub fn new(domain: Domain, initial: Option<&Scalar>) -> Self {
        let density = match initial {
            Some(f) => ScalarGrid::from_field(domain, &**f),
            None => ScalarGrid::zeros(domain),
        };
        Self {
            density,
            scratch: ScalarGrid::zeros(domain),
            total: None,
        }
    }

    /// How the density is read outside the box (periodic wrap, or clamped
    /// in a closed box).
    pub fn set_wrap(&mut self, wrap: Wrap) {
        self.density.set_wrap(wrap);
        self.scratch.set_wrap(wrap);
    }

    /// The density and the target its advection `ρ(x_d)` is written to.
    pub fn advection_pair(&mut self) -> (&ScalarGrid, &mut ScalarGrid) {
        (&self.density, &mut self.scratch)
    }

    /// Eq 6.4: `ρ ← ρ(x_d) + S Δt`, taking the advected density from the
    /// target of [`Self::advection_pair`] and adding the source `S` at the
    /// cell centres. Returns the advected density's total `Σ ρ(x_d) Δx³`
    /// ([`ScalarGrid::total`]), and keeps the new density's
    /// ([`Self::total`]): both found in the injection's pass.
    pub fn step(&mut self, source: &ScalarGrid, dt: f32) -> f64 {
        std::mem::swap(&mut self.density, &mut self.scratch);
        let (advected, total) = self.density.add_scaled_with_totals(source, dt);
        self.total = Some(total);
        advected
    }

    /// The density's total `Σ ρ Δx³` ([`ScalarGrid::total`]; kept from the
    /// last step when the density has not been edited since).
    pub fn total(&self) -> f64 {
        self.total.unwrap_or_else(|| self.density.total())
    }

    /// The density at the cell centres.
    pub fn density(&self) -> &ScalarGrid {
        &self.density
    }

    /// The density at the cell centres, to edit (ghost values at walls).
    pub fn density_mut(&mut self) -> &mut ScalarGrid {
        self.total = None;
        &mut self.density
    }

    /// Sample the trilinear interpolant at the cell centres of `grid` (a copy
    /// when `grid` is on the density's own domain).
    pub fn sample(&self, grid: &mut ScalarGrid) {
        let (fine, coarse) = (grid.domain(), self.density.domain());
        if fine == coarse {
            grid.as_slice_mut().copy_from_slice(self.density.as_slice());
        } else if fine.dims[0] % coarse.dims[0] == 0
            && *fine == coarse.refined(fine.dims[0] / coarse.dims[0])
        {
            self.density.sample_refined(grid);
        } else {
            grid.write_field(&self.density);
        }
    }

    /// The density as a shared field (a copy of the grid).
    pub fn field(&self) -> Scalar {
        Arc::new(self.density.clone())
    }

    pub(super) fn buffers(&self, out: &mut Vec<Buffer>) {
        out.push(Buffer::of_scalar(&self.density));
        out.push(Buffer::of_scalar(&self.scratch));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops;

    #[test]
    fn the_kept_total_is_the_grids_until_the_density_is_edited() {
        let d = Domain::cube(12, 1.0).unwrap();
        let mut g = Gridded::new(d, Some(&ops::constant(2.0)));
        let source = ScalarGrid::from_field(d, &*ops::constant(0.5));
        // The advection target holds the advected density (here: ones).
        let (_, target) = g.advection_pair();
        target.as_slice_mut().fill(1.0);
        let advected = g.step(&source, 0.1);
        let ones = ScalarGrid::from_field(d, &*ops::constant(1.0));
        assert_eq!(advected.to_bits(), ones.total().to_bits());
        assert_eq!(g.total().to_bits(), g.density().total().to_bits());
        g.density_mut().as_slice_mut()[7] = 100.0;
        assert_eq!(g.total().to_bits(), g.density().total().to_bits());
    }
}
