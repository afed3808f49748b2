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

use rayon::prelude::*;

use super::Buffer;
use crate::domain::Domain;
use crate::field::Scalar;
use crate::grid::{ScalarGrid, Wrap};

/// A density grid and its advection scratch.
#[derive(Clone)]
pub struct Gridded {
    density: ScalarGrid,
    scratch: ScalarGrid,
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
    /// cell centres.
    pub fn step(&mut self, source: &ScalarGrid, dt: f32) {
        std::mem::swap(&mut self.density, &mut self.scratch);
        self.density
            .as_slice_mut()
            .par_iter_mut()
            .zip(source.as_slice().par_iter())
            .for_each(|(rho, s)| *rho += s * dt);
    }

    /// The density at the cell centres.
    pub fn density(&self) -> &ScalarGrid {
        &self.density
    }

    /// The density at the cell centres, to edit (ghost values at walls).
    pub fn density_mut(&mut self) -> &mut ScalarGrid {
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
