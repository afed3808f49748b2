//! SELMA — semi-Lagrangian mapping (ch. 8, eqs 8.1–8.8), with continuous
//! injection at bounded memory.
//!
//! # The map
//!
//! Gridless advection is a remapping of the initial density (eqs 8.1–8.7):
//! `ρ_n = ρ₀ ∘ X_n`, with the backward map advected like any other quantity,
//!
//! ```text
//! X_n(x) = X_{n−1}(B_n(x))            (eq 8.8, B_n = the step's backtrace)
//! ```
//!
//! and sampled onto its own grid every step (the notes' `XmapCache`). The
//! map grid has `--map-res` cells along the longest axis — by default the
//! velocity grid's, finer for the notes' SELMA^fine. `X` is the identity
//! plus a displacement, and the identity is not periodic: the grid stores
//! the **displacement** `D = X − x`, which is, so interpolating across the
//! periodic seam is exact. `B_n` is [`crate::advection::departure_point`], the
//! backtrace of the gridded and gridless paths; when the map grid is the
//! velocity grid the step's shared departure points are used directly.
//!
//! # Continuous injection (the design chosen, after DESIGN.md "SELMA")
//!
//! With a source, the density since the last *re-anchoring* at step `r` is
//!
//! ```text
//! ρ_n(x) = ρ_r(X_n(x)) + Σ_{k=r+1…n} S(X_{n→k}(x)) Δt
//! ```
//!
//! where `X_n` now maps step `n` back to step `r` and `X_{n→k}` maps it back
//! to step `k`. Because `X_{n→k} = Y_k ∘ X_n`, with `Y_k = X_k⁻¹` the forward
//! map from reference coordinates to step `k`, the injected sum is a function
//! of the reference point alone:
//!
//! ```text
//! ρ_n(x) = R(X_n(x)),    R(ξ) = ρ_r(ξ) + Σ_k S(Y_k(ξ)) Δt
//! ```
//!
//! — DESIGN.md's design (a): the source is accumulated in reference
//! coordinates on the map lattice. `Y_k(ξ)` of every lattice node is tracked
//! forward by inverting the step's backtrace with a fixed-point iteration,
//! `y' ← y + (y' − B(y'))`, so the injected gas lands where the backtrace
//! says (to `(Δt|∇u|)³` relative). The source is averaged over the 2×2×2
//! sub-points of a map cell around `Y_k(ξ)`, so the injected mass equals the
//! source integral at twice the map resolution — the quadrature the run's
//! fine metrics use.
//!
//! A forward-tracked lattice deforms without bound, and with it the sampling
//! of the fresh source: reference neighbours drift apart in the flow's
//! stretching directions, and gas injected at one node is interpolated
//! toward nodes now far away (streaks, lost mass). So the map is
//! **re-anchored** (DESIGN.md's design (b)) when the lattice has deformed
//! too far: when some pair of neighbouring reference nodes has moved more
//! than `τ` map cells relative to each other
//! ([`Selma::lattice_deformation`]; `--selma-remap τ`, default
//! [`super::DEFAULT_SELMA_REMAP`]). Re-anchoring resamples `R` as the 2×2×2
//! box average of the current density over each map cell, resets `X` to
//! the identity and the lattice to rest. In the hot/cold flow at 32³ this
//! happens every ~30 steps while the flow is slow and every ~10 once the
//! plumes collide. `τ = 0` never re-anchors (pure design (a), the notes'
//! SELMA for a source-free `ρ₀`).
//!
//! Memory: 11 floats per map cell (`D` and its scratch, the tracked lattice
//! `Y`, `R` and its scratch), constant in the number of steps; a query is
//! one interpolation of `D` and one of `R`, also constant.
//!
//! # Error
//!
//! Against gridless on the same velocity history, with map cell `h`:
//! - the map's interpolation, `O(h²)` per step on smooth maps (the notes'
//!   SELMA; `tests/density.rs` measures order ≈ 2 without sources);
//! - the fresh source sampled on the deformed lattice and reconstructed
//!   trilinearly in reference coordinates: edges of the injected gas blurred
//!   over about one (deformed) map cell — grows with the time since the
//!   last re-anchoring;
//! - one density resampling per re-anchoring (box filter of width `h` plus
//!   trilinear reconstruction), instead of the gridded path's every step;
//!   mass is kept to the fine quadrature's accuracy;
//! - `ρ₀` is composed analytically until the first re-anchoring, then
//!   carried on the map grid.
//!
//! Every term vanishes as `h → 0` for any `τ`, so SELMA converges to the
//! gridless density as the map grid refines.

use crate::density::BackwardMap;
use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;

use super::{wrap_world, Buffer, StepInput};
use crate::advection::departure_point;
use crate::boundary::WallStop;
use crate::domain::Domain;
use crate::field::{Scalar, ScalarField};
use crate::grid::{ScalarGrid, VectorGrid};

/// Corrector iterations of the forward (inverse-backtrace) step of the
/// tracked lattice, after the predictor.
const FORWARD_ITERATIONS: usize = 2;

/// Offsets of the 2×2×2 sub-points of a cell, in cells.
const SUB: [Vec3; 8] = [
    Vec3::new(-0.25, -0.25, -0.25),
    Vec3::new(0.25, -0.25, -0.25),
    Vec3::new(-0.25, 0.25, -0.25),
    Vec3::new(0.25, 0.25, -0.25),
    Vec3::new(-0.25, -0.25, 0.25),
    Vec3::new(0.25, -0.25, 0.25),
    Vec3::new(-0.25, 0.25, 0.25),
    Vec3::new(0.25, 0.25, 0.25),
];

/// The SELMA density as a field, `ρ(x) = ρ₀(X(x)) + R(X(x))` with
/// `X(x) = x + D(x)`. Cloning shares the grids (copy-on-write in the model),
/// so a clone is an immutable snapshot.
#[derive(Clone)]
pub struct SelmaField {
    /// `D = X − x` on the map lattice, world units.
    disp: Arc<VectorGrid>,
    /// `R(ξ)`: the density in reference coordinates.
    reference: Arc<ScalarGrid>,
    /// `ρ₀`, composed analytically until the first re-anchoring.
    initial: Option<Scalar>,
    /// Obstacles: map and lattice updates stop at their surface, the
    /// density is zero inside.
    walls: Option<Arc<WallStop>>,
}

impl BackwardMap for SelmaField {
    /// The map `X(x)` at world points (wrapped into the box).
    fn map_batch(&self, points: &[Vec3], out: &mut [Vec3]) {
        assert_eq!(points.len(), out.len(), "map_batch: slice lengths differ");
        let md = self.disp.domain();
        for (x, &p) in out.iter_mut().zip(points) {
            *x = wrap_world(md, p + self.disp.sample_grid_coords(md.grid_coords(p)));
        }
    }
}

impl ScalarField for SelmaField {
    fn eval(&self, p: Vec3) -> f32 {
        let mut out = [0.0];
        self.eval_batch(&[p], &mut out);
        out[0]
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        self.composed(points, out);
        if let Some(w) = &self.walls {
            for (o, &p) in out.iter_mut().zip(points) {
                if w.inside_world(p) {
                    *o = 0.0;
                }
            }
        }
    }
}

impl SelmaField {
    /// `ρ₀(X(x)) + R(X(x))` at every point, inside obstacles too (where the
    /// stopped map reads the density at their surface): what re-anchoring
    /// resamples, so that a reference cell straddling a wall keeps its gas.
    fn composed(&self, points: &[Vec3], out: &mut [f32]) {
        assert_eq!(points.len(), out.len(), "eval_batch: slice lengths differ");
        let mut xi = vec![Vec3::ZERO; points.len()];
        self.map_batch(points, &mut xi);
        self.reference.eval_batch(&xi, out);
        if let Some(initial) = &self.initial {
            let mut r0 = vec![0.0; points.len()];
            initial.eval_batch(&xi, &mut r0);
            for (o, r) in out.iter_mut().zip(r0) {
                *o += r;
            }
        }
    }
}

/// A SELMA density: the map, the tracked reference lattice, the source and
/// the cache at the velocity grid's cell centres.
#[derive(Clone)]
pub struct Selma {
    field: SelmaField,
    disp_scratch: VectorGrid,
    /// World positions `Y(ξ)` of the reference lattice nodes, wrapped.
    lattice: VectorGrid,
    /// Scratch for re-anchoring (absent when `remap == 0`).
    fresh: Option<ScalarGrid>,
    source: Option<Scalar>,
    remap: f32,
    restarts: usize,
    centres: ScalarGrid,
}

impl Selma {
    /// A density on the velocity grid `domain` with its map on `map`
    /// (which must tile the same box), starting at `initial`, injected at
    /// rate `source`, re-anchored when the lattice deformation exceeds
    /// `remap` map cells (0: never).
    ///
    /// # Panics
    /// If `map` is not the same box as `domain`.
    pub fn new(
        domain: Domain,
        map: Domain,
        initial: Option<Scalar>,
        source: Option<Scalar>,
        remap: f32,
    ) -> Self {
        assert!(
            (map.origin - domain.origin).abs().max_element() <= 1e-5 * domain.size().max_element()
                && (map.size() - domain.size()).abs().max_element()
                    <= 1e-4 * domain.size().max_element(),
            "selma: the map grid must tile the velocity grid's box"
        );
        let field = SelmaField {
            disp: Arc::new(VectorGrid::zeros(map)),
            reference: Arc::new(ScalarGrid::zeros(map)),
            initial,
            walls: None,
        };
        let centres = ScalarGrid::from_field(domain, &field);
        let mut lattice = VectorGrid::zeros(map);
        reset_lattice(&mut lattice);
        Self {
            field,
            disp_scratch: VectorGrid::zeros(map),
            lattice,
            fresh: (remap > 0.0).then(|| ScalarGrid::zeros(map)),
            source,
            remap,
            restarts: 0,
            centres,
        }
    }

    /// The map grid.
    pub fn map_domain(&self) -> &Domain {
        self.field.disp.domain()
    }

    /// Re-anchorings so far.
    pub fn restarts(&self) -> usize {
        self.restarts
    }

    /// How far the tracked lattice has deformed since the last
    /// re-anchoring: the largest `|Y(ξ + h e_a) − Y(ξ) − h e_a| / h` over
    /// nodes `ξ` and axes `a` — in map cells, how far some pair of
    /// neighbouring reference nodes has moved relative to each other.
    pub fn lattice_deformation(&self) -> f32 {
        let md = *self.map_domain();
        let [nx, ny, nz] = md.dims;
        let (size, h) = (md.size(), md.cell);
        let y = self.lattice.as_vec3();
        let unwrap = |d: Vec3| d - size * (d / size).round();
        (0..nz)
            .into_par_iter()
            .map(|k| {
                let mut m = 0.0f32;
                for j in 0..ny {
                    for i in 0..nx {
                        let p = y[md.index(i, j, k)];
                        let nb = [
                            (y[md.index((i + 1) % nx, j, k)], Vec3::X),
                            (y[md.index(i, (j + 1) % ny, k)], Vec3::Y),
                            (y[md.index(i, j, (k + 1) % nz)], Vec3::Z),
                        ];
                        for (q, e) in nb {
                            m = m.max((unwrap(q - p) - h * e).length());
                        }
                    }
                }
                m / h
            })
            .reduce(|| 0.0, f32::max)
    }

    /// Stop map and lattice updates at the surface of `walls`; zero density
    /// inside them ([`crate::boundary::wall_stop`]).
    pub fn set_walls(&mut self, walls: Arc<WallStop>) {
        self.field.walls = Some(walls);
    }

    /// Advect the map (eq 8.8), move the reference lattice forward, inject
    /// the source in reference coordinates, and re-anchor when the lattice
    /// has deformed by more than the threshold.
    pub fn step(&mut self, input: &StepInput<'_>) {
        self.advect_map(input);
        self.track_lattice(input);
        self.inject(input.dt);
        if self.remap > 0.0 && self.lattice_deformation() > self.remap {
            self.restart();
        }
    }

    /// Eq 8.8 on the displacement: `D_n(x) = (B_n(x) − x) + D_{n−1}(B_n(x))`.
    fn advect_map(&mut self, input: &StepInput<'_>) {
        let md = *self.map_domain();
        let vd = *input.velocity.domain();
        let old = &*self.field.disp;
        let [nx, ny, _] = md.dims;
        let out = self.disp_scratch.as_vec3_mut();
        let (u, dt_cells, bt) = (input.velocity, input.dt / vd.cell, input.backtrace);
        let walls = self.field.walls.as_deref();
        let departure = |g: Vec3| {
            let dep = departure_point(u, g, dt_cells, bt);
            walls.map_or(dep, |w| w.stop(dep))
        };
        if md == vd {
            // Map nodes are the velocity grid's cell centres: trace from the
            // integer lattice points, exactly as the gridded path does.
            out.par_chunks_mut(nx * ny)
                .enumerate()
                .for_each(|(k, out)| {
                    for j in 0..ny {
                        for i in 0..nx {
                            let c = Vec3::new(i as f32, j as f32, k as f32);
                            let dep = departure(c);
                            out[j * nx + i] = (dep - c) * md.cell + old.sample_grid_coords(dep);
                        }
                    }
                });
        } else {
            out.par_chunks_mut(nx * ny)
                .enumerate()
                .for_each(|(k, out)| {
                    for j in 0..ny {
                        for i in 0..nx {
                            let p = md.cell_center(i, j, k);
                            let d = vd.world_of(departure(vd.grid_coords(p)));
                            out[j * nx + i] = (d - p) + old.sample_grid_coords(md.grid_coords(d));
                        }
                    }
                });
        }
        std::mem::swap(Arc::make_mut(&mut self.field.disp), &mut self.disp_scratch);
    }

    /// Move every lattice node by the inverse of the step's backtrace:
    /// solve `B(y') = y` by `y' ← y + (y' − B(y'))` from the predictor
    /// `y' = y + (y − B(y))`.
    fn track_lattice(&mut self, input: &StepInput<'_>) {
        let vd = *input.velocity.domain();
        let (u, dt_cells, bt) = (input.velocity, input.dt / vd.cell, input.backtrace);
        let step = |g: Vec3| g - departure_point(u, g, dt_cells, bt);
        let walls = self.field.walls.as_deref();
        self.lattice
            .as_vec3_mut()
            .par_chunks_mut(4096)
            .for_each(|ys| {
                for y in ys {
                    let g0 = vd.grid_coords(*y);
                    let mut g = g0 + step(g0);
                    for _ in 0..FORWARD_ITERATIONS {
                        g = g0 + step(g);
                    }
                    if let Some(w) = walls {
                        g = w.stop(g);
                    }
                    *y = wrap_world(&vd, vd.world_of(g));
                }
            });
    }

    /// `R(ξ) += Δt · mean_{2×2×2} S(Y(ξ) + o)`.
    fn inject(&mut self, dt: f32) {
        let Some(source) = &self.source else {
            return;
        };
        let md = *self.map_domain();
        let slab = md.dims[0] * md.dims[1];
        let lattice = self.lattice.as_vec3();
        Arc::make_mut(&mut self.field.reference)
            .as_slice_mut()
            .par_chunks_mut(slab)
            .zip(lattice.par_chunks(slab))
            .for_each_init(
                || (Vec::new(), Vec::new()),
                |(points, values), (r, ys)| {
                    sub_points(&md, ys, points);
                    values.resize(points.len(), 0.0);
                    source.eval_batch(points, values);
                    for (r, v) in r.iter_mut().zip(values.chunks_exact(8)) {
                        *r += dt * (v.iter().sum::<f32>() * 0.125);
                    }
                },
            );
    }

    /// Re-anchor: `R ←` the 2×2×2 box average of the current density over
    /// each map cell, `X ←` identity, lattice at rest, `ρ₀` dropped.
    fn restart(&mut self) {
        let md = *self.map_domain();
        let slab = md.dims[0] * md.dims[1];
        let fresh = self
            .fresh
            .as_mut()
            .expect("re-anchoring needs its scratch grid");
        let field = &self.field;
        fresh
            .as_slice_mut()
            .par_chunks_mut(slab)
            .enumerate()
            .for_each_init(
                || (Vec::new(), Vec::new(), Vec::new()),
                |(centres, points, values), (k, out)| {
                    md.slab_centers(k, centres);
                    sub_points(&md, centres, points);
                    values.resize(points.len(), 0.0);
                    field.composed(points, values);
                    for (o, v) in out.iter_mut().zip(values.chunks_exact(8)) {
                        *o = v.iter().sum::<f32>() * 0.125;
                    }
                },
            );
        std::mem::swap(Arc::make_mut(&mut self.field.reference), fresh);
        self.field.initial = None;
        Arc::make_mut(&mut self.field.disp).as_slice_mut().fill(0.0);
        reset_lattice(&mut self.lattice);
        self.restarts += 1;
    }

    /// Evaluate `ρ₀∘X + R∘X` at every velocity cell centre (the buoyancy input).
    pub fn evaluate_centres(&mut self) {
        self.centres.write_field(&self.field);
    }

    /// The density at the velocity cell centres as of the last [`Self::evaluate_centres`].
    pub fn density(&self) -> &ScalarGrid {
        &self.centres
    }

    /// The density as a field.
    pub fn field(&self) -> &SelmaField {
        &self.field
    }

    /// Every buffer held (see [`super::DensityModel::buffers`]).
    pub fn buffers(&self, out: &mut Vec<Buffer>) {
        out.push(Buffer::of_scalar(&self.centres));
        out.push(Buffer::of_vector(&self.field.disp));
        out.push(Buffer::of_scalar(&self.field.reference));
        out.push(Buffer::of_vector(&self.disp_scratch));
        out.push(Buffer::of_vector(&self.lattice));
        out.extend(self.fresh.iter().map(Buffer::of_scalar));
    }
    /// What changes as the density steps, for a checkpoint (the scratch
    /// grids are overwritten before they are read; `ρ₀`, the source and the
    /// walls come from the configuration).
    pub fn state(&self) -> SelmaState {
        SelmaState {
            disp: (*self.field.disp).clone(),
            reference: (*self.field.reference).clone(),
            lattice: self.lattice.clone(),
            composes_initial: self.field.initial.is_some(),
            restarts: self.restarts,
            centres: self.centres.clone(),
        }
    }

    /// Put back what [`Self::state`] returned.
    ///
    /// # Panics
    /// If a grid is on another domain than this density's.
    pub fn restore(&mut self, state: SelmaState) {
        let md = *self.map_domain();
        assert!(
            *state.disp.domain() == md
                && *state.reference.domain() == md
                && *state.lattice.domain() == md
                && state.centres.domain() == self.centres.domain(),
            "selma: checkpoint grids on another domain"
        );
        self.field.disp = Arc::new(state.disp);
        self.field.reference = Arc::new(state.reference);
        if !state.composes_initial {
            self.field.initial = None;
        }
        self.lattice = state.lattice;
        self.restarts = state.restarts;
        self.centres = state.centres;
    }
}

/// The evolving part of a [`Selma`] density ([`Selma::state`]).
#[derive(Clone, Debug)]
pub struct SelmaState {
    /// The map's displacement `D = X − x`.
    pub disp: VectorGrid,
    /// `R(ξ)`, the density in reference coordinates.
    pub reference: ScalarGrid,
    /// The tracked lattice `Y(ξ)`.
    pub lattice: VectorGrid,
    /// Whether `ρ₀` is still composed (no re-anchoring yet).
    pub composes_initial: bool,
    /// Re-anchorings so far.
    pub restarts: usize,
    /// The density at the velocity grid's cell centres.
    pub centres: ScalarGrid,
}

/// The 2×2×2 sub-points of a map cell around each of `centres`, wrapped
/// into the box, eight per centre.
fn sub_points(md: &Domain, centres: &[Vec3], out: &mut Vec<Vec3>) {
    out.clear();
    for &c in centres {
        for o in SUB {
            out.push(wrap_world(md, c + o * md.cell));
        }
    }
}

/// Put every lattice node at its own cell centre.
fn reset_lattice(lattice: &mut VectorGrid) {
    let md = *lattice.domain();
    let slab = md.dims[0] * md.dims[1];
    lattice
        .as_vec3_mut()
        .par_chunks_mut(slab)
        .enumerate()
        .for_each_init(Vec::new, |centres, (k, out)| {
            md.slab_centers(k, centres);
            out.copy_from_slice(centres);
        });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::advection::{Backtrace, Departures};
    use crate::grid::{BoxKind, FaceGrid};

    /// A shear-and-swirl velocity on a 16³ box of edge 8.
    fn velocity() -> FaceGrid {
        struct Swirl;
        impl crate::field::VectorField for Swirl {
            fn eval(&self, p: Vec3) -> Vec3 {
                let k = std::f32::consts::TAU / 8.0;
                Vec3::new((k * p.y).sin(), (k * p.z).cos(), 0.5 * (k * p.x).sin())
            }
        }
        FaceGrid::from_field(Domain::cube(16, 8.0).unwrap(), BoxKind::Periodic, &Swirl)
    }

    #[test]
    fn the_tracked_lattice_inverts_the_backtrace() {
        let u = velocity();
        let d = *u.domain();
        let (dt, bt) = (0.4, Backtrace::Rk2);
        let mut dep = Departures::new(d);
        dep.trace(&u, dt, bt);
        let mut s = Selma::new(d, d, None, None, 0.0);
        let input = StepInput {
            velocity: &u,
            snapshot: None,
            dt,
            backtrace: bt,
        };
        s.step(&input);
        // B(Y(ξ)) = ξ: moving forward then back returns every node home.
        let mut worst = 0.0f32;
        for (n, y) in s.lattice.as_vec3().iter().enumerate() {
            let (i, j, k) = (n % 16, (n / 16) % 16, n / 256);
            let back = departure_point(&u, d.grid_coords(*y), dt / d.cell, bt);
            let home = Vec3::new(i as f32, j as f32, k as f32);
            let miss = back - home;
            let miss = miss - 16.0 * (miss / 16.0).round();
            worst = worst.max(miss.length());
        }
        // Displacement ≤ 0.9 cells and Δt|∇u| ≤ 0.4·(2π/8) ≈ 0.31: after the
        // predictor and two corrections the residual is ≤ 0.31³ · 0.9 ≈ 0.027.
        assert!(
            worst < 0.02,
            "lattice misses its backtrace by {worst} cells"
        );
        // And the map X(x) = x + D(x) at the nodes is the backtrace itself.
        let x0 = s.field.disp.as_vec3()[0] / d.cell;
        assert!((x0 - (dep.points()[0] - Vec3::ZERO)).length() < 1e-5);
    }

    #[test]
    fn re_anchoring_resets_the_map_and_keeps_the_density() {
        let u = velocity();
        let d = *u.domain();
        let (dt, bt) = (0.4, Backtrace::Rk2);
        let mut dep = Departures::new(d);
        dep.trace(&u, dt, bt);
        let source: Scalar =
            crate::field::ops::mask(crate::field::ops::sphere(Vec3::splat(4.0), 1.5));
        let mut s = Selma::new(d, d, None, Some(source), 1e-3);
        let input = StepInput {
            velocity: &u,
            snapshot: None,
            dt,
            backtrace: bt,
        };
        s.step(&input);
        s.step(&input);
        assert_eq!(s.restarts(), 2);
        assert!(s.field.disp.as_slice().iter().all(|&v| v == 0.0));
        assert_eq!(s.lattice_deformation(), 0.0);
        // Two steps of a 1.5-radius sphere at rate 1: mass ≈ 2 Δt (4/3)π 1.5³.
        let mass = s.field.reference.total();
        let expect = 2.0 * 0.4 * 4.0 / 3.0 * std::f64::consts::PI * 1.5f64.powi(3);
        assert!((mass - expect).abs() < 0.03 * expect, "{mass} vs {expect}");
    }
}
