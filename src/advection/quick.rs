//! QUICK advection: flux-form finite volumes with the quadratic upwind face
//! value (the notes' ch. 6 introduction: "conditionally stable, but has
//! minimal numerical viscosity").
//!
//! # Scheme
//! A quantity `q` at the cell centres changes by the fluxes through the six
//! faces of each cell, `∂q/∂t = −(1/Δx) Σ_axes (F_{+½} − F_{−½})`, with
//! `F = U_f q_f`:
//! - the **face velocity** `U_f` is the staggered velocity's own face value
//!   ([`FaceGrid`]): `U_{i+½} = u[i+1]`. Its finite-volume divergence *is*
//!   the compact divergence that [`crate::pressure`] annihilates, so after a
//!   projection the face fluxes are discretely divergence-free: a constant
//!   stays constant and `Σ q Δx³` is conserved to round-off;
//! - the **face value** is Leonard's QUICK quadratic through the two upwind
//!   cells and one downwind cell, `q_f = 6/8 q_C + 3/8 q_D − 1/8 q_U` (C the
//!   cell upwind of the face, D the one downwind, U the next one upwind).
//!
//! The advecting velocity is frozen at the start of the step (as the
//! semi-Lagrangian step traces all departures through `u(t)`), so the face
//! Courant numbers are computed once per step by [`Quick::prepare`] and shared
//! by every density. Each velocity component lives on its own lattice, the
//! cells shifted by half a cell along its axis; [`Quick::advect_faces`] moves
//! it through that lattice's control volumes, whose face velocities are the
//! means of the two cells' face velocities they straddle, so they are
//! divergence-free whenever the cells' are.
//!
//! # Time integration and stability
//! Time stepping is the three-stage strong-stability-preserving Runge–Kutta
//! method (SSP-RK3, Shu–Osher):
//! `q₁ = q + L(q)`, `q₂ = ¾q + ¼(q₁ + L(q₁))`, `q' = ⅓q + ⅔(q₂ + L(q₂))`.
//! For one Fourier mode QUICK's operator has a phase error `θ³/24` and a
//! damping `θ⁴/16` per cell (θ = kΔx), so on smooth data the scheme is second
//! order in space (third order in time); with SSP-RK3 a single mode is stable
//! up to a Courant number of 1.852 ([`STABILITY_LIMIT`]).
//!
//! The step's Courant number is the largest over cells of the total outflow
//! (or inflow) `Δt/Δx Σ |U_f|`. When it exceeds the configured maximum
//! (default [`DEFAULT_MAX_COURANT`] = 1, which the limiter's bounds need) the
//! step is split into equal sub-steps automatically; if sub-stepping is
//! forbidden the step is refused with a [`CflError`] instead — never a silent
//! blow-up.
//!
//! # Limiter
//! Without a limiter QUICK over- and undershoots at sharp edges. The optional
//! [`Limiter::Ultimate`] is Leonard's ULTIMATE universal limiter in its
//! multidimensional form (Thuburn, *J. Comput. Phys.* 123, 1996): every face
//! value is first held between its two neighbouring cells, then each cell
//! bounds the values on its *outflow* faces so that its forward-Euler update
//! stays within `[min, max]` of itself and its upwind neighbours. Every SSP-RK3
//! stage is a convex blend of such updates, so a limited density never leaves
//! its initial range (for a divergence-free velocity), and never goes negative
//! (for any velocity), as long as the Courant number is at most one.
//!
//! # Walls and obstacles
//! The box is periodic, like the FFT projection; closed boxes and other
//! obstacles are level sets ([`crate::boundary`]) whose cells are marked
//! solid with [`Quick::set_solid`]. Every face touching a solid cell is
//! *closed*: its face velocity is zero, so nothing is carried into or out of
//! an obstacle (the finite-volume no-penetration condition; the fluid piles
//! up against a wall instead of leaking through it). Where a QUICK stencil
//! would reach across a closed face for its far-upwind cell U, it uses the
//! mirror image of C instead (`U = C`, an even reflection at the wall), so
//! the face value next to a wall is `5/8 q_C + 3/8 q_D`.
//!
//! Densities are advected in flux form (mass is conserved; gas piles up
//! against a closed face). The velocity's components use the advective form
//! `−∇·(U q) + q ∇·U`, identical wherever the face velocities are
//! divergence-free, but without the spurious momentum source that the
//! convergence at a closed face would otherwise create.
//!
//! All scratch is allocated in [`Quick::new`]; every pass runs over z-slabs
//! with rayon.

use rayon::prelude::*;
use serde::{Deserialize, Serialize};

use super::closed_faces::FacePressure;
use super::lattice::Lattice;
use crate::domain::Domain;
use crate::grid::{BoxKind, FaceGrid, ScalarGrid};

/// Largest Courant number at which SSP-RK3 keeps every Fourier mode of the
/// QUICK operator bounded (1.8521…, found numerically from the amplification
/// factor `R(−c g(θ))`, `R(z) = 1 + z + z²/2 + z³/6`).
pub const STABILITY_LIMIT: f32 = 1.85;

/// Default largest Courant number of one sub-step: the limiter's bounds hold
/// up to 1, and this leaves room below [`STABILITY_LIMIT`] for varying velocity.
pub const DEFAULT_MAX_COURANT: f32 = 1.0;

/// Most sub-steps one step may be split into before it is refused.
pub const MAX_SUBSTEPS: usize = 1000;

/// Face-value limiter for QUICK.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum Limiter {
    /// Plain QUICK (over- and undershoots near sharp edges).
    None,
    /// Leonard's ULTIMATE universal limiter, multidimensional form: bounded
    /// and non-negative.
    #[default]
    Ultimate,
}

impl Limiter {
    /// Every variant, for tests and listings.
    pub const ALL: [Limiter; 2] = [Limiter::None, Limiter::Ultimate];
}

/// Why a QUICK step was refused.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CflError {
    /// The step needs sub-steps but they are forbidden.
    #[error(
        "QUICK step refused: Courant number {courant:.3} exceeds the maximum {max_courant} \
         and sub-stepping is disabled; allow sub-steps or use dt ≤ {dt_max:.4e}"
    )]
    SubstepsForbidden {
        /// Courant number of the whole step.
        courant: f32,
        /// Largest Courant number allowed per (sub-)step.
        max_courant: f32,
        /// Largest time step that would have been accepted.
        dt_max: f32,
    },
    /// The step would need more than [`MAX_SUBSTEPS`] sub-steps.
    #[error(
        "QUICK step refused: Courant number {courant:.3e} would need {needed} sub-steps \
         (at most {MAX_SUBSTEPS}); reduce dt"
    )]
    TooManySubsteps {
        /// Courant number of the whole step.
        courant: f32,
        /// Sub-steps it would need.
        needed: f64,
    },
    /// The advecting velocity holds NaN or infinity.
    #[error("QUICK step refused: the advecting velocity is not finite")]
    NonFinite,
}

/// Sub-stepping policy and limits of a [`Quick`] advector.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct QuickOptions {
    /// Largest Courant number of one sub-step, in `(0, STABILITY_LIMIT]`.
    pub max_courant: f32,
    /// Split a step that exceeds `max_courant` into sub-steps (otherwise refuse it).
    pub substeps: bool,
}

impl Default for QuickOptions {
    fn default() -> Self {
        Self {
            max_courant: DEFAULT_MAX_COURANT,
            substeps: true,
        }
    }
}

/// QUICK face value for a face with signed Courant number `c`, given the four
/// cells `q(m−1), q(m), q(m+1), q(m+2)` around the face `m+½` and whether the
/// faces `m−½` and `m+3/2` are open (a far-upwind cell behind a closed face
/// is replaced by the mirror image of the upwind cell).
#[inline(always)]
fn face_value(c: f32, q: [f32; 4], open: [bool; 2], limited: bool) -> f32 {
    let [qm1, q0, qp1, qp2] = q;
    let (u, cc, d) = if c >= 0.0 {
        (if open[0] { qm1 } else { q0 }, q0, qp1)
    } else {
        (if open[1] { qp2 } else { qp1 }, qp1, q0)
    };
    let v = 0.75 * cc + 0.375 * d - 0.125 * u;
    if limited {
        v.max(cc.min(d)).min(cc.max(d))
    } else {
        v
    }
}

/// Which form of the advection operator a stage evaluates.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Form {
    /// `−∇·(U q)`: conserves `Σ q` (densities).
    Conservative,
    /// `−∇·(U q) + q ∇·U = −U·∇q`: keeps constants constant even where the
    /// face velocities diverge, e.g. at closed faces (the velocity's own components).
    Advective,
}

/// How a stage's result `t = s + L(s)` is written.
#[derive(Clone, Copy)]
enum Blend<'a> {
    /// `out = t`.
    Replace,
    /// `out = a q + (1 − a) t`.
    With(&'a [f32], f32),
    /// `out = a out + (1 − a) t` (out holds q).
    InPlace(f32),
}

/// Per-step scratch of the finite-volume passes.
#[derive(Clone)]
struct Passes {
    /// QUICK face values on the upper faces `i+½, j+½, k+½` of every cell.
    face: [Vec<f32>; 3],
    /// Limiter bounds on the outflow face values of every cell.
    lo: Vec<f32>,
    hi: Vec<f32>,
}

/// A QUICK advector for one domain: the step's face Courant numbers, its
/// sub-step count and all scratch.
#[derive(Clone)]
pub struct Quick {
    domain: Domain,
    lattice: Lattice,
    options: QuickOptions,
    /// Face Courant numbers of one sub-step, `U_f Δt / (Δx n_sub)`, on the
    /// upper faces of every cell, per axis.
    courant_faces: [Vec<f32>; 3],
    /// Whether the upper face of every cell is open (no solid cell either side), per axis.
    open: [Vec<bool>; 3],
    /// Makes the open faces divergence-free when there are obstacles.
    pressure: Option<FacePressure>,
    substeps: usize,
    courant: f32,
    passes: Passes,
    stage1: Vec<f32>,
    stage2: Vec<f32>,
    /// Face Courant numbers and open faces of one velocity component's
    /// lattice ([`Quick::advect_faces`]).
    staggered_faces: [Vec<f32>; 3],
    staggered_open: [Vec<bool>; 3],
}

impl Quick {
    /// Buffers for advecting on `domain`.
    ///
    /// # Panics
    /// If `options.max_courant` is not in `(0, STABILITY_LIMIT]`.
    pub fn new(domain: Domain, options: QuickOptions) -> Self {
        assert!(
            options.max_courant > 0.0 && options.max_courant <= STABILITY_LIMIT,
            "QUICK max_courant is {}; it must be in (0, {STABILITY_LIMIT}]",
            options.max_courant
        );
        let n = domain.len();
        let zeros = || vec![0.0f32; n];
        Self {
            domain,
            lattice: Lattice::new(&domain),
            options,
            courant_faces: std::array::from_fn(|_| zeros()),
            open: std::array::from_fn(|_| vec![true; n]),
            pressure: None,
            substeps: 1,
            courant: 0.0,
            passes: Passes {
                face: std::array::from_fn(|_| zeros()),
                lo: zeros(),
                hi: zeros(),
            },
            stage1: zeros(),
            stage2: zeros(),
            staggered_faces: std::array::from_fn(|_| zeros()),
            staggered_open: std::array::from_fn(|_| vec![true; n]),
        }
    }

    /// The domain this advector works on.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// Mark obstacle cells (`solid[n]`, `[z][y][x]` order): every face
    /// touching one is closed from the next [`Self::prepare`] on.
    ///
    /// # Panics
    /// If `solid` does not have one entry per cell.
    pub fn set_solid(&mut self, solid: &[bool]) {
        assert_eq!(
            solid.len(),
            self.domain.len(),
            "QUICK: solid mask of another size"
        );
        let lat = &self.lattice;
        let [ox, oy, oz] = &mut self.open;
        ox.par_chunks_mut(lat.slab())
            .zip(oy.par_chunks_mut(lat.slab()))
            .zip(oz.par_chunks_mut(lat.slab()))
            .enumerate()
            .for_each(|(k, ((ox, oy), oz))| {
                for j in 0..lat.ny {
                    for i in 0..lat.nx {
                        let (n, g) = (j * lat.nx + i, lat.idx(i, j, k));
                        let here = !solid[g];
                        ox[n] = here && !solid[lat.idx(lat.x.at(i, 1), j, k)];
                        oy[n] = here && !solid[lat.idx(i, lat.y.at(j, 1), k)];
                        oz[n] = here && !solid[lat.idx(i, j, lat.z.at(k, 1))];
                    }
                }
            });
        self.pressure = solid
            .iter()
            .any(|&s| s)
            .then(|| FacePressure::new(&self.lattice, &self.open));
    }

    /// The open-face projection's warm start, the last step's potential
    /// (`None` without obstacles).
    pub fn warm_start(&self) -> Option<&[f32]> {
        self.pressure.as_ref().map(|p| p.potential())
    }

    /// Put back a [`Self::warm_start`]; `false` (nothing changed) if there
    /// are no obstacles or its length differs.
    pub fn set_warm_start(&mut self, p: &[f32]) -> bool {
        self.pressure.as_mut().is_some_and(|f| f.set_potential(p))
    }

    /// Conjugate-gradient iterations and relative residual of the last
    /// open-face projection (`None` without obstacles).
    pub fn face_projection_stats(&self) -> Option<(usize, f32)> {
        self.pressure.as_ref().map(|p| (p.iterations, p.residual))
    }

    /// Sub-steps of the prepared step.
    pub fn substeps(&self) -> usize {
        self.substeps
    }

    /// Courant number of the prepared (whole) step: the largest total outflow
    /// or inflow `Δt/Δx Σ|U_f|` of any cell.
    pub fn courant(&self) -> f32 {
        self.courant
    }

    /// Freeze the advecting velocity `vel` for a step of `dt`: its face
    /// values as Courant numbers, the step's Courant number, and the number
    /// of sub-steps.
    ///
    /// # Errors
    /// [`CflError`] if the step needs sub-steps and they are forbidden, needs
    /// more than [`MAX_SUBSTEPS`], or the velocity is not finite. The advector
    /// then holds no usable step.
    ///
    /// # Panics
    /// If `vel` is on another domain or in a closed box (QUICK's lattice is
    /// periodic; walls are obstacles, [`Quick::set_solid`]).
    pub fn prepare(&mut self, vel: &FaceGrid, dt: f32) -> Result<usize, CflError> {
        assert_eq!(
            vel.domain(),
            &self.domain,
            "QUICK: velocity on another domain"
        );
        assert_eq!(vel.kind(), BoxKind::Periodic, "QUICK: closed box");
        let lat = &self.lattice;
        let scale = dt / self.domain.cell;
        let (u, v, w) = (vel.slice(0), vel.slice(1), vel.slice(2));
        let [cx, cy, cz] = &mut self.courant_faces;
        let open = &self.open;
        cx.par_chunks_mut(lat.slab())
            .zip(cy.par_chunks_mut(lat.slab()))
            .zip(cz.par_chunks_mut(lat.slab()))
            .enumerate()
            .for_each(|(k, ((fx, fy), fz))| {
                let kp = lat.z.at(k, 1);
                for j in 0..lat.ny {
                    let jp = lat.y.at(j, 1);
                    for i in 0..lat.nx {
                        let n = j * lat.nx + i;
                        let g = lat.idx(i, j, k);
                        let f = |open: bool, v: f32| if open { scale * v } else { 0.0 };
                        fx[n] = f(open[0][g], u[lat.idx(lat.x.at(i, 1), j, k)]);
                        fy[n] = f(open[1][g], v[lat.idx(i, jp, k)]);
                        fz[n] = f(open[2][g], w[lat.idx(i, j, kp)]);
                    }
                }
            });
        if let Some(pressure) = &mut self.pressure {
            pressure.project(&self.lattice, &self.open, &mut self.courant_faces);
        }
        let courant = self.max_cell_courant();
        self.courant = courant;
        if !courant.is_finite() {
            self.substeps = 0;
            return Err(CflError::NonFinite);
        }
        let needed = (courant as f64 / self.options.max_courant as f64)
            .ceil()
            .max(1.0);
        if needed > 1.0 && !self.options.substeps {
            self.substeps = 0;
            return Err(CflError::SubstepsForbidden {
                courant,
                max_courant: self.options.max_courant,
                dt_max: dt * self.options.max_courant / courant,
            });
        }
        if needed > MAX_SUBSTEPS as f64 {
            self.substeps = 0;
            return Err(CflError::TooManySubsteps { courant, needed });
        }
        self.substeps = needed as usize;
        if self.substeps > 1 {
            let f = 1.0 / self.substeps as f32;
            for c in &mut self.courant_faces {
                c.par_iter_mut().for_each(|v| *v *= f);
            }
        }
        Ok(self.substeps)
    }

    /// Largest total outflow or inflow Courant number of any cell.
    fn max_cell_courant(&self) -> f32 {
        let lat = &self.lattice;
        let [cx, cy, cz] = &self.courant_faces;
        (0..lat.nz)
            .into_par_iter()
            .map(|k| {
                let km = lat.z.at(k, -1);
                let mut worst = 0.0f32;
                for j in 0..lat.ny {
                    let jm = lat.y.at(j, -1);
                    for i in 0..lat.nx {
                        let n = lat.idx(i, j, k);
                        let up = [cx[n], cy[n], cz[n]];
                        let down = [
                            cx[lat.idx(lat.x.at(i, -1), j, k)],
                            cy[lat.idx(i, jm, k)],
                            cz[lat.idx(i, j, km)],
                        ];
                        let (mut out, mut inn, mut all) = (0.0f32, 0.0f32, 0.0f32);
                        for a in 0..3 {
                            out += up[a].max(0.0) + (-down[a]).max(0.0);
                            inn += (-up[a]).max(0.0) + down[a].max(0.0);
                            all += up[a].abs() + down[a].abs();
                        }
                        // `max` drops NaN; the plain sum keeps it.
                        if !all.is_finite() {
                            return f32::NAN;
                        }
                        worst = worst.max(out).max(inn);
                    }
                }
                worst
            })
            .reduce(
                || 0.0,
                |a, b| {
                    if a.is_nan() || b.is_nan() {
                        f32::NAN
                    } else {
                        a.max(b)
                    }
                },
            )
    }

    /// Advect a scalar grid through the prepared step: `dst = q(t + Δt)`.
    ///
    /// # Panics
    /// If no step is prepared (or the last [`Self::prepare`] failed), or the
    /// grids are on another domain.
    pub fn advect_scalar(&mut self, src: &ScalarGrid, dst: &mut ScalarGrid, limiter: Limiter) {
        assert_eq!(
            src.domain(),
            &self.domain,
            "QUICK: source on another domain"
        );
        assert_eq!(
            dst.domain(),
            &self.domain,
            "QUICK: target on another domain"
        );
        let out = dst.as_slice_mut();
        out.copy_from_slice(src.as_slice());
        self.advance(out, limiter, Form::Conservative);
    }

    /// Advect every component of a staggered field through the prepared
    /// step (eq 6.5's `advect(velocity, velocity, dt)` when `src` is the
    /// velocity), in advective form and unlimited. Component `a` lives on
    /// the cells shifted by `−½e_a`; the faces of its control volume around
    /// face `f` straddle the cells `f − e_a` and `f`, and carry the mean of
    /// their two face Courant numbers (open only if both are).
    ///
    /// # Panics
    /// As [`Self::advect_scalar`].
    pub fn advect_faces(&mut self, src: &FaceGrid, dst: &mut FaceGrid) {
        assert_eq!(
            src.domain(),
            &self.domain,
            "QUICK: source on another domain"
        );
        assert_eq!(
            dst.domain(),
            &self.domain,
            "QUICK: target on another domain"
        );
        for a in 0..3 {
            self.stagger(a);
            std::mem::swap(&mut self.courant_faces, &mut self.staggered_faces);
            std::mem::swap(&mut self.open, &mut self.staggered_open);
            let q = dst.slice_mut(a);
            q.copy_from_slice(src.slice(a));
            self.advance(q, Limiter::None, Form::Advective);
            std::mem::swap(&mut self.courant_faces, &mut self.staggered_faces);
            std::mem::swap(&mut self.open, &mut self.staggered_open);
        }
    }

    /// Face Courant numbers and open faces of component `a`'s lattice.
    fn stagger(&mut self, a: usize) {
        let lat = &self.lattice;
        let (cf, open) = (&self.courant_faces, &self.open);
        for b in 0..3 {
            self.staggered_faces[b]
                .par_chunks_mut(lat.slab())
                .zip(self.staggered_open[b].par_chunks_mut(lat.slab()))
                .enumerate()
                .for_each(|(k, (fs, os))| {
                    for j in 0..lat.ny {
                        for i in 0..lat.nx {
                            let n = lat.idx(i, j, k);
                            let mut below = [i, j, k];
                            below[a] = [&lat.x, &lat.y, &lat.z][a].at(below[a], -1);
                            let m = lat.idx(below[0], below[1], below[2]);
                            fs[j * lat.nx + i] = 0.5 * (cf[b][n] + cf[b][m]);
                            os[j * lat.nx + i] = open[b][n] && open[b][m];
                        }
                    }
                });
        }
    }

    /// All sub-steps of the prepared step on `q`, in place.
    fn advance(&mut self, q: &mut [f32], limiter: Limiter, form: Form) {
        assert!(
            self.substeps > 0,
            "QUICK: advect called without a successfully prepared step"
        );
        let limited = limiter == Limiter::Ultimate;
        let mut s1 = std::mem::take(&mut self.stage1);
        let mut s2 = std::mem::take(&mut self.stage2);
        for _ in 0..self.substeps {
            // SSP-RK3 (Shu–Osher).
            self.stage(q, Blend::Replace, &mut s1, limited, form);
            self.stage(&s1, Blend::With(q, 0.75), &mut s2, limited, form);
            self.stage(&s2, Blend::InPlace(1.0 / 3.0), q, limited, form);
        }
        self.stage1 = s1;
        self.stage2 = s2;
    }

    /// One forward-Euler stage `t = s + L(s)`, blended into `out`.
    fn stage(&mut self, s: &[f32], blend: Blend, out: &mut [f32], limited: bool, form: Form) {
        let advective = form == Form::Advective;
        let lat = &self.lattice;
        let cf = &self.courant_faces;
        let open = &self.open;
        let p = &mut self.passes;
        // Pass A: QUICK values on the upper faces of every cell.
        {
            let [fx, fy, fz] = &mut p.face;
            fx.par_chunks_mut(lat.slab())
                .zip(fy.par_chunks_mut(lat.slab()))
                .zip(fz.par_chunks_mut(lat.slab()))
                .enumerate()
                .for_each(|(k, ((fx, fy), fz))| {
                    let ks = [-1, 0, 1, 2].map(|d| lat.z.at(k, d));
                    for j in 0..lat.ny {
                        let js = [-1, 0, 1, 2].map(|d| lat.y.at(j, d));
                        let row = lat.idx(0, j, k);
                        for i in 0..lat.nx {
                            let n = j * lat.nx + i;
                            let g = row + i;
                            let xi = [-1, 0, 1, 2].map(|d| row + lat.x.at(i, d));
                            let yi = js.map(|jj| lat.idx(i, jj, k));
                            let zi = ks.map(|kk| lat.idx(i, j, kk));
                            for (a, (ix, f)) in
                                [(xi, &mut fx[n]), (yi, &mut fy[n]), (zi, &mut fz[n])]
                                    .into_iter()
                                    .enumerate()
                            {
                                let q = ix.map(|m| s[m]);
                                let o = [open[a][ix[0]], open[a][ix[2]]];
                                *f = face_value(cf[a][g], q, o, limited);
                            }
                        }
                    }
                });
        }
        // Pass B: each cell's bounds on its outflow face values.
        if limited {
            let face = &p.face;
            p.lo.par_chunks_mut(lat.slab())
                .zip(p.hi.par_chunks_mut(lat.slab()))
                .enumerate()
                .for_each(|(k, (lo, hi))| {
                    for j in 0..lat.ny {
                        let row = lat.row(j, k);
                        for i in 0..lat.nx {
                            let g = row.base + i;
                            let (l, h) = outflow_bounds(cf, face, s, g, row.around(lat, i));
                            lo[j * lat.nx + i] = l;
                            hi[j * lat.nx + i] = h;
                        }
                    }
                });
        }
        // Pass C: the flux through every upper face, each computed once
        // (limited values clamped by the face's upwind cell).
        {
            let (lo, hi) = (&p.lo, &p.hi);
            let [fx, fy, fz] = &mut p.face;
            fx.par_chunks_mut(lat.slab())
                .zip(fy.par_chunks_mut(lat.slab()))
                .zip(fz.par_chunks_mut(lat.slab()))
                .enumerate()
                .for_each(|(k, ((fx, fy), fz))| {
                    for j in 0..lat.ny {
                        let row = lat.row(j, k);
                        for i in 0..lat.nx {
                            let (n, g) = (j * lat.nx + i, row.base + i);
                            let around = row.around(lat, i);
                            for (a, f) in
                                [&mut fx[n], &mut fy[n], &mut fz[n]].into_iter().enumerate()
                            {
                                let c = cf[a][g];
                                let v = if limited {
                                    let up = if c > 0.0 { g } else { around[a].1 };
                                    f.max(lo[up]).min(hi[up])
                                } else {
                                    *f
                                };
                                *f = c * v;
                            }
                        }
                    }
                });
        }
        // Pass D: flux divergence and the blend.
        let flux = &p.face;
        let slab = lat.slab();
        let update = |k: usize, out: &mut [f32], q: Option<&[f32]>, a: f32| {
            for j in 0..lat.ny {
                let row = lat.row(j, k);
                for i in 0..lat.nx {
                    let g = row.base + i;
                    let (mut div, mut net) = (0.0f32, 0.0f32);
                    for (ax, (gm, _)) in row.around(lat, i).into_iter().enumerate() {
                        div += flux[ax][g] - flux[ax][gm];
                        if advective {
                            net += cf[ax][g] - cf[ax][gm];
                        }
                    }
                    let t = if advective {
                        s[g] - div + s[g] * net
                    } else {
                        s[g] - div
                    };
                    let n = j * lat.nx + i;
                    out[n] = match q {
                        Some(q) => a * q[n] + (1.0 - a) * t,
                        None if a == 0.0 => t,
                        None => a * out[n] + (1.0 - a) * t,
                    };
                }
            }
        };
        match blend {
            Blend::Replace => out
                .par_chunks_mut(slab)
                .enumerate()
                .for_each(|(k, o)| update(k, o, None, 0.0)),
            Blend::With(q, a) => out
                .par_chunks_mut(slab)
                .zip(q.par_chunks(slab))
                .enumerate()
                .for_each(|(k, (o, q))| update(k, o, Some(q), a)),
            Blend::InPlace(a) => out
                .par_chunks_mut(slab)
                .enumerate()
                .for_each(|(k, o)| update(k, o, None, a)),
        }
    }
}

/// Limiter pass for cell `g` with `neighbours` (below, above per axis): bounds `[lo, hi]` on the values of its
/// outflow faces such that its forward-Euler update stays within the range of
/// itself and its upwind neighbours, whatever the neighbours do to its inflow
/// faces (a face value only ever moves toward its upwind cell).
///
/// With `C_out` the total outflow Courant number and inflow face values
/// `v_f` (between `q_f` of the upwind neighbour and the face's QUICK value),
/// `q' = B − Σ_out c_f (v_f − q)` where `B = q(1 − C_out) + Σ_in c_f v_f`.
/// Requiring `q_min ≤ q' ≤ q_max` for the extreme `B` gives
/// `Σ_out c_f (v_f − q) ∈ [B_max − q_max, B_min − q_min]`, enforced face by face
/// with the interval widened to contain 0 (first-order upwind is always
/// allowed; it is non-negative for any velocity at `C_out ≤ 1`).
#[inline(always)]
fn outflow_bounds(
    cf: &[Vec<f32>; 3],
    face: &[Vec<f32>; 3],
    s: &[f32],
    g: usize,
    neighbours: [(usize, usize); 3],
) -> (f32, f32) {
    let q = s[g];
    let (mut qmin, mut qmax) = (q, q);
    let (mut c_out, mut in_min, mut in_max) = (0.0f32, 0.0f32, 0.0f32);
    let mut inflow = |c: f32, v: f32, nb: f32| {
        in_min += c * v.min(nb);
        in_max += c * v.max(nb);
        qmin = qmin.min(nb);
        qmax = qmax.max(nb);
    };
    for (a, &(gm, gp)) in neighbours.iter().enumerate() {
        let cu = cf[a][g];
        if cu > 0.0 {
            c_out += cu;
        } else if cu < 0.0 {
            inflow(-cu, face[a][g], s[gp]);
        }
        let cl = cf[a][gm];
        if cl < 0.0 {
            c_out -= cl;
        } else if cl > 0.0 {
            inflow(cl, face[a][gm], s[gm]);
        }
    }
    if c_out <= 0.0 {
        return (q, q);
    }
    let keep = q * (1.0 - c_out);
    let lo = (keep + in_max - qmax).min(0.0);
    let hi = (keep + in_min - qmin).max(0.0);
    (q + lo / c_out, q + hi / c_out)
}

/// `dst = src` advected by `vel` over `dt` with QUICK (allocates an advector;
/// time steps that move several quantities keep one [`Quick`]).
///
/// # Errors
/// As [`Quick::prepare`].
pub fn advect_scalar(
    src: &ScalarGrid,
    vel: &FaceGrid,
    dt: f32,
    options: QuickOptions,
    limiter: Limiter,
    dst: &mut ScalarGrid,
) -> Result<usize, CflError> {
    let mut q = Quick::new(*vel.domain(), options);
    let n = q.prepare(vel, dt)?;
    q.advect_scalar(src, dst, limiter);
    Ok(n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::ops;
    use glam::Vec3;

    fn uniform(d: Domain, u: Vec3) -> FaceGrid {
        FaceGrid::from_field(d, BoxKind::Periodic, &*ops::constant_vector(u))
    }

    #[test]
    fn face_value_is_the_upwind_quadratic() {
        // Quadratic data q(m) = m² is reproduced exactly at the face m = ½.
        let q = [-1.0f32, 0.0, 1.0, 2.0].map(|m| m * m);
        assert_eq!(face_value(1.0, q, [true; 2], false), 0.25);
        assert_eq!(face_value(-1.0, q, [true; 2], false), 0.25);
        // Behind a closed face the far-upwind cell mirrors the upwind one.
        assert_eq!(face_value(1.0, q, [false, true], false), 0.375);
        assert_eq!(face_value(-1.0, q, [true, false], false), 0.625);
        // The limited value stays between the face's two cells.
        assert_eq!(face_value(1.0, [1.0, 0.0, 0.0, 0.0], [true; 2], true), 0.0);
    }

    #[test]
    fn half_cell_shift_is_exact_for_linear_data() {
        // QUICK and SSP-RK3 are exact for a linear ramp: it moves by u Δt
        // wherever the periodic jump (reach: two cells upwind and one
        // downwind per stage) has not arrived.
        let d = Domain::new(Vec3::ZERO, 1.0, [16, 4, 4]).unwrap();
        let vel = uniform(d, Vec3::X);
        let mut src = ScalarGrid::zeros(d);
        for ((_, _, i), v) in src.data_mut().indexed_iter_mut() {
            *v = i as f32;
        }
        let mut dst = ScalarGrid::zeros(d);
        let n = advect_scalar(
            &src,
            &vel,
            0.5,
            QuickOptions::default(),
            Limiter::None,
            &mut dst,
        )
        .unwrap();
        assert_eq!(n, 1);
        for i in 7..13 {
            let v = dst.data()[[1, 2, i]];
            assert!((v - (i as f32 - 0.5)).abs() < 1e-5, "cell {i}: {v}");
        }
    }

    #[test]
    fn constants_and_mass_survive_a_swirl() {
        let d = Domain::cube(12, std::f32::consts::TAU).unwrap();
        struct Swirl;
        impl crate::field::VectorField for Swirl {
            fn eval(&self, p: Vec3) -> Vec3 {
                Vec3::new(
                    p.y.sin() + p.z.cos(),
                    p.z.sin() + 0.3 * p.x.cos(),
                    p.x.sin(),
                )
            }
        }
        let mut vel = FaceGrid::from_field(d, BoxKind::Periodic, &Swirl);
        crate::pressure::PressureSolver::new(d, BoxKind::Periodic).project(&mut vel);
        let src = ScalarGrid::from_field(d, &*ops::constant(2.5));
        let mut dst = ScalarGrid::zeros(d);
        for limiter in Limiter::ALL {
            advect_scalar(&src, &vel, 0.4, QuickOptions::default(), limiter, &mut dst).unwrap();
            let err = dst
                .as_slice()
                .iter()
                .map(|v| (v - 2.5).abs())
                .fold(0.0, f32::max);
            assert!(err < 2e-5, "{limiter:?}: constant changed by {err}");
        }
        let blob = ScalarGrid::from_field(d, &*ops::mask(ops::sphere(Vec3::splat(3.0), 1.5)));
        advect_scalar(
            &blob,
            &vel,
            0.4,
            QuickOptions::default(),
            Limiter::Ultimate,
            &mut dst,
        )
        .unwrap();
        let rel = (dst.total() - blob.total()).abs() / blob.total();
        assert!(rel < 1e-5, "mass changed by {rel}");
    }

    #[test]
    fn refuses_forbidden_substeps_and_non_finite_velocity() {
        let d = Domain::cube(8, 8.0).unwrap();
        let mut q = Quick::new(
            d,
            QuickOptions {
                substeps: false,
                ..Default::default()
            },
        );
        assert_eq!(q.prepare(&uniform(d, Vec3::X), 0.5), Ok(1));
        let e = q.prepare(&uniform(d, Vec3::X), 3.0).unwrap_err();
        assert!(matches!(e, CflError::SubstepsForbidden { .. }));
        assert!(e.to_string().contains("dt ≤ 1.0000e0"), "{e}");
        let mut q = Quick::new(d, QuickOptions::default());
        assert_eq!(q.prepare(&uniform(d, Vec3::X), 3.0), Ok(3));
        assert_eq!(
            q.prepare(&uniform(d, Vec3::splat(f32::NAN)), 0.1),
            Err(CflError::NonFinite)
        );
        assert!(matches!(
            q.prepare(&uniform(d, Vec3::X), 1e5),
            Err(CflError::TooManySubsteps { .. })
        ));
    }
}
