//! Divergence-free face velocities around obstacles.
//!
//! QUICK closes every face that touches an obstacle cell (zero face
//! velocity: nothing flows into or out of an obstacle). The staggered
//! velocity comes from the periodic pressure solve, which knows nothing of
//! obstacles, so next to an obstacle the face velocities of the open faces
//! no longer balance once the closed ones are zeroed: fluid would pile up against the wall
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
const TOLERANCE: f32 = 1e-4;

/// Bits of [`FacePressure::mask`]: which of a cell's six faces are open.
const PX: u8 = 1;
const MX: u8 = 2;
const PY: u8 = 4;
const MY: u8 = 8;
const PZ: u8 = 16;
const MZ: u8 = 32;

/// Conjugate-gradient state of the open-face Poisson problem.
#[derive(Clone)]
pub(crate) struct FacePressure {
    /// Open faces of every cell, as bits `PX … MZ`.
    mask: Vec<u8>,
    /// Inverse number of open faces of each cell (the Jacobi preconditioner; 0 if none).
    inv_diag: Vec<f32>,
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

/// `Σ_{open f} (x_i − x_nb)` for cell `g` with open-face bits `m` and
/// neighbours `nb` (below, above per axis).
#[inline(always)]
fn minus_laplacian(m: u8, x: &[f32], g: usize, nb: [(usize, usize); 3]) -> f32 {
    if m == 0 {
        return 0.0;
    }
    let xi = x[g];
    let mut acc = 0.0f32;
    for (a, (gm, gp)) in nb.into_iter().enumerate() {
        let (up, down) = [(PX, MX), (PY, MY), (PZ, MZ)][a];
        if m & up != 0 {
            acc += xi - x[gp];
        }
        if m & down != 0 {
            acc += xi - x[gm];
        }
    }
    acc
}

/// `out = A x` with `A = −L`, the negated open-face graph Laplacian; returns `x·out`.
fn apply(lat: &Lattice, mask: &[u8], x: &[f32], out: &mut [f32]) -> f64 {
    out.par_chunks_mut(lat.slab())
        .enumerate()
        .map(|(k, out)| {
            let mut dot = 0.0f64;
            for j in 0..lat.ny {
                let row = lat.row(j, k);
                for i in 0..lat.nx {
                    let g = row.base + i;
                    let v = minus_laplacian(mask[g], x, g, row.around(lat, i));
                    out[j * lat.nx + i] = v;
                    dot += (v * x[g]) as f64;
                }
            }
            dot
        })
        // Added in slab order: the same bits at any thread count.
        .collect::<Vec<f64>>()
        .into_iter()
        .sum()
}

fn max_abs(a: &[f32]) -> f32 {
    a.par_iter().map(|v| v.abs()).reduce(|| 0.0, f32::max)
}

impl FacePressure {
    /// The potential kept as the next solve's warm start.
    pub(crate) fn potential(&self) -> &[f32] {
        &self.p
    }

    /// Put back a [`Self::potential`]; `false` (nothing changed) if its
    /// length differs.
    pub(crate) fn set_potential(&mut self, p: &[f32]) -> bool {
        let fits = p.len() == self.p.len();
        if fits {
            self.p.copy_from_slice(p);
        }
        fits
    }

    /// Solver state for the open faces `open` (upper face of every cell, per axis).
    pub(crate) fn new(lat: &Lattice, open: &[Vec<bool>; 3]) -> Self {
        let n = lat.nx * lat.ny * lat.nz;
        let mut mask = vec![0u8; n];
        for k in 0..lat.nz {
            for j in 0..lat.ny {
                for i in 0..lat.nx {
                    let g = lat.idx(i, j, k);
                    let mut m = 0;
                    for (a, (gm, _)) in lat.around(i, j, k).into_iter().enumerate() {
                        let (up, down) = [(PX, MX), (PY, MY), (PZ, MZ)][a];
                        if open[a][g] {
                            m |= up;
                        }
                        if open[a][gm] {
                            m |= down;
                        }
                    }
                    mask[g] = m;
                }
            }
        }
        let inv_diag = mask
            .iter()
            .map(|m| match m.count_ones() {
                0 => 0.0,
                c => 1.0 / c as f32,
            })
            .collect();
        let zeros = || vec![0.0f32; n];
        Self {
            mask,
            inv_diag,
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
        if !(scale > 0.0 && scale.is_finite()) {
            self.p.fill(0.0);
            return;
        }
        // r = b − A p with b = −div U.
        apply(lat, &self.mask, &self.p, &mut self.q);
        self.r
            .par_chunks_mut(lat.slab())
            .zip(self.q.par_chunks(lat.slab()))
            .enumerate()
            .for_each(|(k, (r, ap))| {
                for j in 0..lat.ny {
                    for i in 0..lat.nx {
                        let g = lat.idx(i, j, k);
                        let mut div = 0.0f32;
                        for (a, (gm, _)) in lat.around(i, j, k).into_iter().enumerate() {
                            div += faces[a][g] - faces[a][gm];
                        }
                        let n = j * lat.nx + i;
                        r[n] = -div - ap[n];
                    }
                }
            });
        let target = TOLERANCE * scale;
        let max_iter = 20 * (lat.nx + lat.ny + lat.nz);
        // z = M⁻¹ r; returns (r·z, max|r|).
        let precondition = |r: &[f32], inv_diag: &[f32], z: &mut [f32]| -> (f64, f32) {
            z.par_chunks_mut(4096)
                .zip(r.par_chunks(4096).zip(inv_diag.par_chunks(4096)))
                .map(|(z, (r, w))| {
                    let (mut rz, mut rmax) = (0.0f64, 0.0f32);
                    for ((z, r), w) in z.iter_mut().zip(r).zip(w) {
                        *z = r * w;
                        rz += (*r * *z) as f64;
                        rmax = rmax.max(r.abs());
                    }
                    (rz, rmax)
                })
                // Added in chunk order: the same bits at any thread count.
                .collect::<Vec<_>>()
                .into_iter()
                .fold((0.0, 0.0), |a, b| (a.0 + b.0, a.1.max(b.1)))
        };
        let (mut rz, mut res) = precondition(&self.r, &self.inv_diag, &mut self.z);
        self.d.copy_from_slice(&self.z);
        while res > target && self.iterations < max_iter {
            let dq = apply(lat, &self.mask, &self.d, &mut self.q);
            if dq <= 0.0 {
                break;
            }
            let alpha = (rz / dq) as f32;
            self.p
                .par_chunks_mut(4096)
                .zip(self.r.par_chunks_mut(4096))
                .zip(self.d.par_chunks(4096).zip(self.q.par_chunks(4096)))
                .for_each(|((p, r), (d, q))| {
                    for (((p, r), d), q) in p.iter_mut().zip(r.iter_mut()).zip(d).zip(q) {
                        *p += alpha * d;
                        *r -= alpha * q;
                    }
                });
            let (rz_new, rmax) = precondition(&self.r, &self.inv_diag, &mut self.z);
            let beta = (rz_new / rz) as f32;
            rz = rz_new;
            res = rmax;
            self.d
                .par_iter_mut()
                .zip(&self.z)
                .for_each(|(d, z)| *d = z + beta * *d);
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
