//! The kinetic energy and the enstrophy of a periodic velocity per unit
//! volume, the integrals turbulence benchmarks are compared by (the
//! Taylor–Green vortex at Re = 1600, [`crate::scenario::taylor_green_3d`]):
//!
//! ```text
//! E = (1/V) ∫ ½ |u|² dV,        Ω = (1/V) ∫ ½ |ω|² dV
//! ```
//!
//! With periodic `u` and `∇·u = 0`, `∫|ω|² = ∫|∇u|²`, and the viscous term
//! takes energy at the rate `−dE/dt = 2νΩ`.
//!
//! `E` sums the faces: each face carries one cell's volume, so `E = ½ Σ_a
//! Σ_faces u_a² / cells` ([`FaceGrid::kinetic_energy`] over `V`).
//!
//! `Ω` is taken spectrally, `½ Σ_a Σ_b mean((∂_b u_a)²)` with each
//! derivative the Fourier derivative of the component on its own face
//! lattice (by Parseval, `Σ_m k_m² |û(m)|²` along each line, `k_m = 2π m /
//! L` for the signed index `m`, the Nyquist mode at `k = π / Δx`). It is
//! the enstrophy the solver's viscosity acts on: the exact heat kernel
//! ([`crate::pressure`]) damps each mode by `exp(−ν |k|² Δt)` with this
//! continuous `|k|`, so it removes energy at the rate `2νΩ` exactly. For a
//! field of resolved Fourier modes (the Taylor–Green vortex) `Ω` is the
//! continuum value to round-off, where the staggered differences would give
//! it times `(sin(kΔx/2) / (kΔx/2))²`.

use rayon::prelude::*;
use realfft::RealFftPlanner;

use crate::grid::{BoxKind, FaceGrid};

/// Kinetic energy and enstrophy per unit volume (module documentation).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Integrals {
    /// `E = (1/V) ∫ ½|u|² dV`.
    pub energy: f64,
    /// `Ω = (1/V) ∫ ½|ω|² dV`, spectral.
    pub enstrophy: f64,
}

/// `E` and `Ω` of a periodic `velocity`.
///
/// # Panics
/// If the box is closed (the Fourier derivative is periodic).
pub fn integrals(velocity: &FaceGrid) -> Integrals {
    assert_eq!(
        velocity.kind(),
        BoxKind::Periodic,
        "enstrophy: a periodic box only"
    );
    let d = *velocity.domain();
    let volume = d.cell_volume() as f64 * d.len() as f64;
    let mut gradient2 = 0.0;
    for a in 0..3 {
        for b in 0..3 {
            gradient2 += mean_derivative_squared(velocity.slice(a), d.dims, b, d.cell as f64);
        }
    }
    Integrals {
        energy: velocity.kinetic_energy() / volume,
        enstrophy: 0.5 * gradient2,
    }
}

/// `mean((∂_b f)²)` of the periodic lattice `f` (`[z][y][x]`, `dims`
/// cells of edge `h`) by Parseval along each line of axis `b`.
fn mean_derivative_squared(f: &[f32], dims: [usize; 3], b: usize, h: f64) -> f64 {
    let n = dims[b];
    let stride = [1, dims[0], dims[0] * dims[1]][b];
    // The other two axes' indices enumerate the lines.
    let (p, q) = match b {
        0 => (1, 2),
        1 => (0, 2),
        _ => (0, 1),
    };
    let strides = [1, dims[0], dims[0] * dims[1]];
    let fft = RealFftPlanner::<f64>::new().plan_fft_forward(n);
    let k = std::f64::consts::TAU / (n as f64 * h);
    // Parseval: Σ_x g² = (1/n) Σ_m |ĝ|²; the real transform holds m = 0 …
    // n/2, the others (the conjugates) counted by weight 2.
    let weight = |m: usize| if m == 0 || 2 * m == n { 1.0 } else { 2.0 };
    let total: f64 = (0..dims[p] * dims[q])
        .into_par_iter()
        .map_init(
            || {
                (
                    fft.make_input_vec(),
                    fft.make_output_vec(),
                    fft.make_scratch_vec(),
                )
            },
            |(line, spectrum, scratch), l| {
                let start = (l % dims[p]) * strides[p] + (l / dims[p]) * strides[q];
                for (i, x) in line.iter_mut().enumerate() {
                    *x = f[start + i * stride] as f64;
                }
                fft.process_with_scratch(line, spectrum, scratch)
                    .expect("buffers of the planned length");
                spectrum
                    .iter()
                    .enumerate()
                    .map(|(m, c)| weight(m) * (k * m as f64).powi(2) * c.norm_sqr())
                    .sum::<f64>()
            },
        )
        .sum();
    total / (n as f64 * n as f64) / (dims[p] * dims[q]) as f64
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::domain::Domain;
    use crate::field::VectorField;
    use glam::Vec3;

    /// One Fourier mode per component, `u = (sin(2y), 0, cos(3x + z))` in
    /// `[0, 2π]³`: `E = ½(½ + ½) = ½` and `½ mean|∇u|² = ½ (4·½ + (9 +
    /// 1)·½) = 3.5`, each to round-off.
    #[test]
    fn single_modes_give_their_closed_forms() {
        struct Modes;
        impl VectorField for Modes {
            fn eval(&self, p: Vec3) -> Vec3 {
                Vec3::new((2.0 * p.y).sin(), 0.0, (3.0 * p.x + p.z).cos())
            }
        }
        let n = 16;
        let d = Domain::new(Vec3::ZERO, std::f32::consts::TAU / n as f32, [n, n, n]).unwrap();
        let m = integrals(&FaceGrid::from_field(d, BoxKind::Periodic, &Modes));
        assert!((m.energy - 0.5).abs() < 1e-6, "{m:?}");
        assert!((m.enstrophy - 3.5).abs() < 1e-5, "{m:?}");
    }
}
