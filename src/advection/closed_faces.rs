//! Divergence-free face velocities around obstacles.
//!
//! QUICK closes every face that touches an obstacle cell (zero face
//! velocity: nothing flows into or out of an obstacle). The collocated
//! velocity comes from the periodic FFT projection, which knows nothing of
//! obstacles, so next to an obstacle the averaged face velocities of the
//! open faces no longer balance: fluid would pile up against the wall
//! (mass is conserved and cannot leave through a closed face). This module
//! removes that imbalance with a pressure-like potential `p` on the graph of
//! open faces:
//!
//! ```text
//! Σ_{open faces f of i} (p_nb − p_i) = Σ_f ±U_f  (discrete Poisson, Neumann at closed faces)
//! U_f ← U_f − (p_D − p_C)                          on every open face
//! ```
//!
//! after which the finite-volume divergence of the face velocities vanishes in
//! every fluid cell (to the solver tolerance) and the closed faces carry
//! nothing: the advecting velocity is divergence-free *and* impermeable, so
//! flux-form QUICK conserves mass, keeps the limiter's bounds and never
//! leaks. The system is solved by conjugate gradients with a Jacobi
//! preconditioner, warm-started from the previous step's potential.

use rayon::prelude::*;

use super::lattice::Lattice;

/// Residual target: the largest cell divergence (in Courant units, i.e. the
/// fraction of a cell's volume gained per step) relative to the largest face
/// Courant number.
const TOLERANCE: f32 = 1e-5;

/// Conjugate-gradient state of the open-face Poisson problem.
pub(crate) struct FacePressure {
    /// Number of open faces of each cell (the Jacobi preconditioner).
    diag: Vec<f32>,
    /// The potential, kept between steps as the next initial guess.
    p: Vec<f32>,
    r: Vec<f32>,
    z: Vec<f32>,
    d: Vec<f32>,
    q: Vec<f32>,
    /// Iterations of the last solve.
    pub(crate) iterations: usize,
    /// Largest remaining cell divergence of the last solve, relative to the largest face value.
    pub(crate) residual: f32,
}

/// `(A x)_i = Σ_{open f} (x_i − x_nb)`: minus the open-face graph Laplacian.
fn apply(lat: &Lattice, open: &[Vec<bool>; 3], x: &[f32], out: &mut [f32]) {
    out.par_chunks_mut(lat.slab())
        .enumerate()
        .for_each(|(k, out)| {
            for j in 0..lat.ny {
                for i in 0..lat.nx {
                    let g = lat.idx(i, j, k);
                    let mut acc = 0.0f32;
                    for (a, (gm, gp)) in lat.around(i, j, k).into_iter().enumerate() {
                        if open[a][g] {
                            acc += x[g] - x[gp];
                        }
                        if open[a][gm] {
                            acc += x[g] - x[gm];
                        }
                    }
                    out[j * lat.nx + i] = acc;
                }
            }
        });
}

fn dot(a: &[f32], b: &[f32]) -> f64 {
    a.par_iter()
        .zip(b)
        .map(|(x, y)| *x as f64 * *y as f64)
        .sum()
}

fn max_abs(a: &[f32]) -> f32 {
    a.par_iter().map(|v| v.abs()).reduce(|| 0.0, f32::max)
}

impl FacePressure {
    /// Solver state for the open faces `open` (upper face of every cell, per axis).
    pub(crate) fn new(lat: &Lattice, open: &[Vec<bool>; 3]) -> Self {
        let n = lat.nx * lat.ny * lat.nz;
        let mut diag = vec![0.0f32; n];
        for (k, chunk) in diag.chunks_mut(lat.slab()).enumerate() {
            for j in 0..lat.ny {
                for i in 0..lat.nx {
                    let g = lat.idx(i, j, k);
                    let mut count = 0;
                    for (a, (gm, _)) in lat.around(i, j, k).into_iter().enumerate() {
                        count += open[a][g] as u32 + open[a][gm] as u32;
                    }
                    chunk[j * lat.nx + i] = count as f32;
                }
            }
        }
        let zeros = || vec![0.0f32; n];
        Self {
            diag,
            p: zeros(),
            r: zeros(),
            z: zeros(),
            d: zeros(),
            q: zeros(),
            iterations: 0,
            residual: 0.0,
        }
    }

    /// Make the face values `faces` (upper face of every cell, per axis; zero
    /// on closed faces) divergence-free in every cell.
    pub(crate) fn project(
        &mut self,
        lat: &Lattice,
        open: &[Vec<bool>; 3],
        faces: &mut [Vec<f32>; 3],
    ) {
        let scale = faces.iter().map(|f| max_abs(f)).fold(0.0, f32::max);
        self.iterations = 0;
        self.residual = 0.0;
        if scale == 0.0 {
            self.p.fill(0.0);
            return;
        }
        // r = b − A p with b = −div U (A = −L).
        let div = &mut self.z;
        div.par_chunks_mut(lat.slab())
            .enumerate()
            .for_each(|(k, out)| {
                for j in 0..lat.ny {
                    for i in 0..lat.nx {
                        let g = lat.idx(i, j, k);
                        let mut acc = 0.0f32;
                        for (a, (gm, _)) in lat.around(i, j, k).into_iter().enumerate() {
                            acc += faces[a][g] - faces[a][gm];
                        }
                        out[j * lat.nx + i] = acc;
                    }
                }
            });
        apply(lat, open, &self.p, &mut self.q);
        self.r
            .par_iter_mut()
            .zip(self.z.par_iter().zip(&self.q))
            .for_each(|(r, (div, ap))| *r = -div - ap);
        let target = TOLERANCE * scale;
        let max_iter = 20 * (lat.nx + lat.ny + lat.nz);
        let precondition = |r: &[f32], diag: &[f32], z: &mut [f32]| {
            z.par_iter_mut()
                .zip(r.par_iter().zip(diag))
                .for_each(|(z, (r, d))| *z = if *d > 0.0 { r / d } else { 0.0 });
        };
        precondition(&self.r, &self.diag, &mut self.z);
        self.d.copy_from_slice(&self.z);
        let mut rz = dot(&self.r, &self.z);
        let mut res = max_abs(&self.r);
        while res > target && self.iterations < max_iter {
            apply(lat, open, &self.d, &mut self.q);
            let dq = dot(&self.d, &self.q);
            if dq <= 0.0 {
                break;
            }
            let alpha = (rz / dq) as f32;
            self.p
                .par_iter_mut()
                .zip(&self.d)
                .for_each(|(p, d)| *p += alpha * d);
            self.r
                .par_iter_mut()
                .zip(&self.q)
                .for_each(|(r, q)| *r -= alpha * q);
            precondition(&self.r, &self.diag, &mut self.z);
            let rz_new = dot(&self.r, &self.z);
            let beta = (rz_new / rz) as f32;
            rz = rz_new;
            self.d
                .par_iter_mut()
                .zip(&self.z)
                .for_each(|(d, z)| *d = z + beta * *d);
            res = max_abs(&self.r);
            self.iterations += 1;
        }
        self.residual = res / scale;
        // U_f ← U_f − (p_up − p_here) on open faces.
        let p = &self.p;
        for (a, (f, o)) in faces.iter_mut().zip(open).enumerate() {
            f.par_chunks_mut(lat.slab()).enumerate().for_each(|(k, f)| {
                for j in 0..lat.ny {
                    for i in 0..lat.nx {
                        let g = lat.idx(i, j, k);
                        if o[g] {
                            let gp = lat.around(i, j, k)[a].1;
                            f[j * lat.nx + i] -= p[gp] - p[g];
                        }
                    }
                }
            });
        }
    }
}
