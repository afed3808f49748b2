//! Which faces of the periodic MAC grid are open to the fluid: obstacles
//! voxelized on the cells.
//!
//! A cell is *wet* when its centre lies in the fluid, `O < 0`, and a face is
//! *open* (`A = 1`) when both cells it separates are wet, *closed* (`A = 0`)
//! otherwise — the flag-grid obstacles of mantaflow and Bridson's *Fluid
//! Simulation* (§5.3), the same cells QUICK closes. The pressure solve
//! ([`crate::pressure::obstacles`]) runs over the wet cells and balances the
//! fluxes `A u` through their faces:
//!
//! ```text
//! (D_A u)[c] = Σ_a (A u)_a[c + e_a] − (A u)_a[c]) / Δx
//! ```
//!
//! # Why not fractional faces
//! Cut cells with fractional `A ∈ [0, 1]` from the level set (Batty,
//! Bertails & Bridson 2007; Ng, Min & Gibou 2009) were built first and
//! measured: with the fractions the projection balances `D_A u`, but the
//! semi-Lagrangian advection reads the plain velocity, whose divergence in a
//! cut cell is of the order of the velocity's tangential gradient. In
//! `run slab-box --res 32 --advection sl` the gas mass grew to 243 % of what
//! was injected by step 200; with whole faces (open where the face's centre
//! is in the fluid) it ended at 108 %, both with the ghost densities
//! described below (QUICK: 100.000 %); the final form keeps 103 %. The
//! difference matters, in favour of whole faces; a conservative advection of
//! cut-cell volumes would be needed first.
//!
//! # Closed faces
//! A closed face beside a wet cell (a *surface* face) holds the velocity 0:
//! no flow through it, whatever the advection reads there. Closed faces
//! between two dry cells hold an extension of the fluid's velocity, for the
//! interpolation near the wall: [`OpenFaces::extend`] gives each, layer by
//! layer from the surface ([`EXTENSION_LAYERS`] deep, zero beyond), the mean
//! of its neighbours of the same component that are open or already
//! extended, times the retained fraction α of the boundary rule. Such faces
//! carry the tangential velocity inside the wall: α = 1 (reflect) is free
//! slip, α = 0 a wall that holds the tangential velocity at zero half a cell
//! inside it.
//!
//! # Dry cells hold no gas
//! After each step a gridded density is zeroed in the dry cells
//! ([`OpenFaces::clear_dry`]); a backtrace that ends near a wall reads
//! those zeros. Ghost values (the mean of the wet neighbours, layer by
//! layer) were tried in their place and measured worse: 140 % of the
//! injected mass at step 200 of `run slab-box --res 32 --advection sl`,
//! against 103 % with zeros — near a wall where the flow leaves it, the
//! ghost acts as an inflow of the wall cell's own density.

use rayon::prelude::*;

use crate::domain::Domain;
use crate::grid::{BoxKind, FaceGrid, ScalarGrid};

/// Layers of closed faces, counted from the fluid, that receive an extension
/// of the velocity (enough for backtraces of a few cells into a wall).
pub const EXTENSION_LAYERS: usize = 3;

/// A closed face that receives the mean of some neighbours' values.
#[derive(Clone, Debug)]
struct Extended {
    /// Index into its component's array.
    at: usize,
    /// Neighbouring faces of the same component it averages.
    from: Vec<usize>,
}

/// The open faces of one periodic domain, and what follows from them
/// (surface faces, the extension plans).
#[derive(Clone, Debug)]
pub struct OpenFaces {
    domain: Domain,
    /// `A` (0 or 1) per face, in the [`FaceGrid`] layout of each component.
    open: [Vec<f32>; 3],
    /// Per cell, whether it holds fluid: `O < 0` and an open face.
    wet: Vec<bool>,
    /// Per component, closed faces beside a wet cell.
    surface: [Vec<usize>; 3],
    /// Per component, the extension plan in layer order.
    extended: [Vec<Extended>; 3],
}

impl OpenFaces {
    /// The open faces of `level`'s domain (periodic), `level` the obstacle
    /// level set at the cell centres.
    pub fn new(level: &ScalarGrid) -> Self {
        let domain = *level.domain();
        let o = level.as_slice();
        let open: [Vec<f32>; 3] = std::array::from_fn(|a| {
            let mut open = vec![0.0; domain.len()];
            domain.par_for_each_cell(&mut open, |n, c, x| {
                let both = o[n] < 0.0 && o[domain.neighbour(c, a, -1)] < 0.0;
                *x = if both { 1.0 } else { 0.0 };
            });
            open
        });
        let mut wet = vec![false; domain.len()];
        domain.par_for_each_cell(&mut wet, |n, c, w| {
            *w = (0..3).any(|a| open[a][n] > 0.0 || open[a][domain.neighbour(c, a, 1)] > 0.0);
        });
        // Closed faces beside a wet cell are the surface; closed faces
        // between two dry cells take the extension.
        let below = |a: usize, f: usize| domain.neighbour(coords(&domain, f), a, -1);
        let surface = std::array::from_fn(|a| {
            (0..domain.len())
                .filter(|&f| open[a][f] == 0.0 && (wet[f] || wet[below(a, f)]))
                .collect()
        });
        let extended = std::array::from_fn(|a| {
            let known = open[a].iter().map(|&x| x > 0.0).collect();
            extension_plan(&domain, known, |f| !wet[f] && !wet[below(a, f)])
        });
        Self {
            domain,
            open,
            wet,
            surface,
            extended,
        }
    }

    /// The domain measured on.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// `A` (1 open, 0 closed) of component `a`'s faces, in the [`FaceGrid`] layout.
    pub fn open(&self, a: usize) -> &[f32] {
        &self.open[a]
    }

    /// Whether each cell holds fluid (`O < 0` and an open face), `[z][y][x]` order.
    pub fn wet(&self) -> &[bool] {
        &self.wet
    }

    /// Close every surface face (velocity 0) and give the closed faces
    /// behind them the α-scaled extension of the fluid velocity (module
    /// documentation); open faces are untouched.
    ///
    /// # Panics
    /// If `vel` is not on this domain's periodic grid.
    pub fn extend(&self, vel: &mut FaceGrid, alpha: f32) {
        assert_eq!(vel.domain(), &self.domain, "open faces: another domain");
        assert_eq!(vel.kind(), BoxKind::Periodic, "open faces: closed box");
        for a in 0..3 {
            let u = vel.slice_mut(a);
            for &f in &self.surface[a] {
                u[f] = 0.0;
            }
            for e in &self.extended[a] {
                let mean = e.from.iter().map(|&g| u[g]).sum::<f32>() / e.from.len() as f32;
                // The first layer averages open faces and applies α once;
                // deeper layers average faces that already carry it.
                let first = e.from.iter().any(|&g| self.open[a][g] > 0.0);
                u[e.at] = if first { alpha * mean } else { mean };
            }
        }
    }

    /// Set the density of every dry cell to zero (the obstacles hold no gas).
    ///
    /// # Panics
    /// If `rho` does not have one value per cell.
    pub fn clear_dry(&self, rho: &mut [f32]) {
        assert_eq!(rho.len(), self.domain.len(), "one value per cell");
        rho.par_iter_mut()
            .zip(self.wet.par_iter())
            .filter(|(_, &w)| !w)
            .for_each(|(r, _)| *r = 0.0);
    }

    /// The flux divergence `D_A u` (module documentation) at the wet cells,
    /// in cell order, in f32 (for its statistics).
    pub fn wet_flux_divergence(&self, vel: &FaceGrid) -> Vec<f32> {
        let mut out = vec![0.0f64; self.domain.len()];
        self.flux_divergence(vel, &mut out);
        out.iter()
            .zip(&self.wet)
            .filter(|(_, &w)| w)
            .map(|(&d, _)| d as f32)
            .collect()
    }

    /// `D_A u` at every cell into `out` (zero at dry cells), in f64.
    ///
    /// # Panics
    /// If `out` does not have one value per cell.
    pub fn flux_divergence(&self, vel: &FaceGrid, out: &mut [f64]) {
        let d = self.domain;
        let inv = 1.0 / d.cell as f64;
        d.par_for_each_cell(out, |n, c, o| {
            *o = if self.wet[n] {
                let flux = |a: usize, f: usize| self.open[a][f] as f64 * vel.slice(a)[f] as f64;
                (0..3)
                    .map(|a| flux(a, d.neighbour(c, a, 1)) - flux(a, n))
                    .sum::<f64>()
                    * inv
            } else {
                0.0
            };
        });
    }

    /// Largest `|u|` on a surface face: the flow through the obstacles'
    /// closed faces (exactly zero after the exact projection).
    pub fn closed_flux_max(&self, vel: &FaceGrid) -> f32 {
        (0..3)
            .flat_map(|a| self.surface[a].iter().map(move |&f| vel.slice(a)[f].abs()))
            .fold(0.0, f32::max)
    }

    /// Mass `Σ ρ Δx³` in the dry cells (inside obstacles), at any depth.
    ///
    /// Fixed chunks summed in parallel, their sums added in order: the
    /// same bits at any thread count (a parallel `sum` adds in the order
    /// its work was split, which moved the last bits between runs).
    pub fn mass_inside(&self, rho: &[f32]) -> f64 {
        let sums: Vec<f64> = (rho.par_chunks(1 << 14))
            .zip(self.wet.par_chunks(1 << 14))
            .map(|(rho, wet)| {
                let dry = rho.iter().zip(wet).filter(|(_, &w)| !w);
                dry.map(|(&r, _)| r as f64).sum::<f64>()
            })
            .collect();
        sums.iter().sum::<f64>() * self.domain.cell_volume() as f64
    }
}

/// `[i, j, k]` of linear cell (or periodic face) index `n`.
fn coords(d: &Domain, n: usize) -> [usize; 3] {
    let [nx, ny, _] = d.dims;
    [n % nx, (n / nx) % ny, n / (nx * ny)]
}

/// The faces of one component that are not `known` (open), satisfy
/// `takes`, and lie within [`EXTENSION_LAYERS`] steps of a known one, in
/// layer order, each with the known or earlier-layer neighbours (of its six)
/// it averages.
fn extension_plan(
    d: &Domain,
    known: Vec<bool>,
    takes: impl Fn(usize) -> bool + Sync,
) -> Vec<Extended> {
    let mut known = known;
    let mut plan = Vec::new();
    for _ in 0..EXTENSION_LAYERS {
        let layer: Vec<Extended> = (0..d.len())
            .into_par_iter()
            .filter(|&f| !known[f] && takes(f))
            .filter_map(|f| {
                let c = coords(d, f);
                let from: Vec<usize> = (0..3)
                    .flat_map(|b| [-1, 1].map(|s| d.neighbour(c, b, s)))
                    .filter(|&g| known[g])
                    .collect();
                (!from.is_empty()).then_some(Extended { at: f, from })
            })
            .collect();
        for e in &layer {
            known[e.at] = true;
        }
        plan.extend(layer);
    }
    plan
}
