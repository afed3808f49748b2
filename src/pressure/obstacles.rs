//! The pressure solve around obstacles: conjugate gradients over the wet
//! cells, preconditioned by the obstacle-free fast solver.
//!
//! With the open faces `A` (1 open, 0 closed) of [`OpenFaces`], the
//! projection makes the fluxes through the faces of every wet cell balance:
//!
//! ```text
//! D(A G p) = D(A u*),        u = u* − G p   on open faces (A > 0)
//! ```
//!
//! so `D_A u = 0` in every wet cell and nothing flows through a closed face
//! (those are set by [`OpenFaces::extend`]). `K = −D A G` is symmetric and
//! positive semi-definite on the wet cells (its null space: a constant per
//! connected region of fluid, which the right-hand side never excites — its
//! sum over a region telescopes to zero). It is solved by preconditioned
//! conjugate gradients (Saad, *Iterative Methods*, alg. 9.1) with
//!
//! - the preconditioner `z = −L⁻¹ r` restricted to the wet cells, `L` the
//!   obstacle-free 7-point Laplacian solved by one FFT pair
//!   ([`PressureSolver`]) — the approach Oceananigans takes for immersed
//!   boundaries: away from obstacles `K = −L` and the preconditioned
//!   operator is the identity;
//! - a warm start from the last step's pressure;
//! - the stopping rule `‖b − K p‖₂ ≤ tol ‖b‖₂`, `b = −D(A u*)`, tolerance
//!   [`TOLERANCE`] by default, every vector and reduction in f64; partial
//!   sums over fixed chunks, so the result does not depend on the thread
//!   count.

use rayon::prelude::*;

use super::PressureSolver;
use crate::domain::Domain;
use crate::grid::OpenFaces;
use crate::grid::{BoxKind, FaceGrid};

/// Relative residual at which the conjugate gradients stop.
pub const TOLERANCE: f64 = 1e-6;

/// Iterations after which the conjugate gradients give up (the last
/// residual is reported, not hidden).
pub const MAX_ITERATIONS: usize = 400;

/// Chunk of the deterministic parallel reductions.
const CHUNK: usize = 4096;

/// How the last solve went.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct CgReport {
    /// Iterations taken (0 when the warm start already met the tolerance).
    pub iterations: usize,
    /// Final `‖b − K p‖₂ / ‖b‖₂` (0 when `b = 0`).
    pub residual: f64,
}

/// Buffers and the warm-start pressure of the obstacle-aware projection.
#[derive(Clone)]
pub struct ObstacleProjection {
    domain: Domain,
    /// The pressure, kept between steps (zero at dry cells).
    p: Vec<f64>,
    r: Vec<f64>,
    z: Vec<f64>,
    d: Vec<f64>,
    q: Vec<f64>,
    tolerance: f64,
    report: CgReport,
}

impl ObstacleProjection {
    /// Buffers for the open faces `faces` (periodic box), stopping at the
    /// relative residual `tolerance`; [`Self::project`] takes the same faces.
    ///
    /// # Panics
    /// If `tolerance` is not in `(0, 1)`.
    pub fn new(faces: &OpenFaces, tolerance: f64) -> Self {
        assert!(tolerance > 0.0 && tolerance < 1.0, "tolerance {tolerance}");
        let domain = *faces.domain();
        let zeros = vec![0.0; domain.len()];
        Self {
            domain,
            p: zeros.clone(),
            r: zeros.clone(),
            z: zeros.clone(),
            d: zeros.clone(),
            q: zeros,
            tolerance,
            report: CgReport::default(),
        }
    }

    /// Iterations and residual of the last [`Self::project`].
    pub fn report(&self) -> CgReport {
        self.report
    }

    /// The pressure of the last projection (f64, zero at dry cells, defined
    /// up to a constant per fluid region).
    pub fn pressure(&self) -> &[f64] {
        &self.p
    }

    /// Put back a [`Self::pressure`] as the next solve's warm start (a
    /// checkpoint's). `false` (nothing changed) if its length differs.
    pub fn set_pressure(&mut self, p: &[f64]) -> bool {
        let fits = p.len() == self.p.len();
        if fits {
            self.p.copy_from_slice(p);
        }
        fits
    }

    /// Make the fluxes `A u` divergence-free in every wet cell of `faces`:
    /// solve `K p = −D(A u*)` and set `u −= G p` on the open faces. Closed
    /// faces are left alone (see [`OpenFaces::extend`]). `fast` must be the
    /// obstacle-free solver of the same domain, the preconditioner.
    ///
    /// # Panics
    /// If `u`, `faces` or `fast` is not on this domain's periodic grid.
    pub fn project(
        &mut self,
        u: &mut FaceGrid,
        faces: &OpenFaces,
        fast: &mut PressureSolver,
    ) -> CgReport {
        assert_eq!(u.domain(), &self.domain, "obstacles: another domain");
        assert_eq!(u.kind(), BoxKind::Periodic, "obstacles: closed box");
        assert_eq!(faces.domain(), &self.domain, "open faces: another domain");
        assert_eq!(
            fast.domain(),
            &self.domain,
            "preconditioner: another domain"
        );
        assert_eq!(fast.kind(), BoxKind::Periodic, "preconditioner: closed box");
        // b = −D(A u*), kept in z while the residual is formed.
        faces.flux_divergence(u, &mut self.z);
        self.z.par_iter_mut().for_each(|b| *b = -*b);
        let b_norm = dot(&self.z, &self.z).sqrt();
        // r = b − K p (warm start).
        apply(faces, &self.p, &mut self.q);
        self.r
            .par_iter_mut()
            .zip(self.z.par_iter().zip(self.q.par_iter()))
            .for_each(|(r, (&b, &kp))| *r = b - kp);
        let mut report = CgReport {
            iterations: 0,
            residual: if b_norm > 0.0 {
                dot(&self.r, &self.r).sqrt() / b_norm
            } else {
                0.0
            },
        };
        if report.residual > self.tolerance {
            self.precondition(faces, fast);
            self.d.copy_from_slice(&self.z);
            let mut rz = dot(&self.r, &self.z);
            while report.iterations < MAX_ITERATIONS && report.residual > self.tolerance {
                apply(faces, &self.d, &mut self.q);
                let dq = dot(&self.d, &self.q);
                if dq <= 0.0 {
                    break;
                }
                let step = rz / dq;
                self.p
                    .par_iter_mut()
                    .zip(self.r.par_iter_mut())
                    .zip(self.d.par_iter().zip(self.q.par_iter()))
                    .for_each(|((p, r), (&d, &q))| {
                        *p += step * d;
                        *r -= step * q;
                    });
                report.iterations += 1;
                report.residual = dot(&self.r, &self.r).sqrt() / b_norm;
                self.precondition(faces, fast);
                let rz_next = dot(&self.r, &self.z);
                let beta = rz_next / rz;
                rz = rz_next;
                self.d
                    .par_iter_mut()
                    .zip(self.z.par_iter())
                    .for_each(|(d, &z)| *d = z + beta * *d);
            }
        }
        subtract_open_gradient(u, faces, &self.p);
        self.report = report;
        report
    }

    /// `z = −L⁻¹ r` on the wet cells, zero on the dry ones.
    fn precondition(&mut self, faces: &OpenFaces, fast: &mut PressureSolver) {
        fast.solve_poisson_f64(&self.r, &mut self.z);
        self.z
            .par_iter_mut()
            .zip(faces.wet().par_iter())
            .for_each(|(z, &w)| *z = if w { -*z } else { 0.0 });
    }
}

/// `out = K x = −D(A G x)` on the wet cells, zero on the dry ones:
/// `(K x)[c] = Σ_a A[c](x[c] − x[c − e_a]) − A[c + e_a](x[c + e_a] − x[c])`,
/// over Δx².
fn apply(faces: &OpenFaces, x: &[f64], out: &mut [f64]) {
    let d = *faces.domain();
    let inv_h2 = 1.0 / (d.cell as f64 * d.cell as f64);
    let wet = faces.wet();
    d.par_for_each_cell(out, |n, c, o| {
        *o = if wet[n] {
            (0..3)
                .map(|a| {
                    let (up, lo) = (d.neighbour(c, a, 1), d.neighbour(c, a, -1));
                    let open = faces.open(a);
                    open[n] as f64 * (x[n] - x[lo]) - open[up] as f64 * (x[up] - x[n])
                })
                .sum::<f64>()
                * inv_h2
        } else {
            0.0
        };
    });
}

/// `u_a[f] −= (p[f] − p[f − e_a]) / Δx` on every open face.
fn subtract_open_gradient(u: &mut FaceGrid, faces: &OpenFaces, p: &[f64]) {
    let d = *u.domain();
    let inv = 1.0 / d.cell as f64;
    for a in 0..3 {
        let open = faces.open(a);
        d.par_for_each_cell(u.slice_mut(a), |n, c, v| {
            if open[n] > 0.0 {
                *v = (*v as f64 - (p[n] - p[d.neighbour(c, a, -1)]) * inv) as f32;
            }
        });
    }
}

/// `x · y`, summed in fixed chunks (the same result for any thread count).
fn dot(x: &[f64], y: &[f64]) -> f64 {
    let partial: Vec<f64> = x
        .par_chunks(CHUNK)
        .zip(y.par_chunks(CHUNK))
        .map(|(x, y)| x.iter().zip(y).map(|(a, b)| a * b).sum())
        .collect();
    partial.iter().sum()
}
