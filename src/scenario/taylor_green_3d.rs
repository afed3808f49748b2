//! The Taylor–Green vortex at Re = 1600: case C3.5 of the International
//! Workshop on High-Order CFD Methods, a published turbulence benchmark.
//!
//! In the periodic box `[0, 2π]³` the flow starts from
//!
//! ```text
//! u = sin x cos y cos z,   v = −cos x sin y cos z,   w = 0
//! ```
//!
//! (unit velocity and length, so `Re = 1/ν = 1600`; the workshop's
//! incompressible limit of its Ma = 0.1 case) and runs to `t = 20`. The
//! vortex stretches, breaks down into turbulence and decays; the kinetic
//! energy `E(t)` (`E(0) = 1/8`), the dissipation `−dE/dt` (peak 0.01286 at
//! t ≈ 9) and the enstrophy ([`crate::metrics::enstrophy`]) are compared
//! with a spectral DNS at 512³. Nothing here is exact after t = 0: the
//! benchmark measures how much a scheme's numerical dissipation adds to
//! the viscous one, and when.
//!
//! At t = 0, `ω = (−cos x sin y sin z, −sin x cos y sin z, 2 sin x sin y
//! cos z)`, so `Ω(0) = ½ mean|ω|² = ½ (⅛ + ⅛ + ½) = 3/8` and the initial
//! dissipation is `2νΩ(0) = 3/(4·1600) = 4.6875e-4`.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::{Scenario, SolverConfig};
use crate::error::InputError;
use crate::field::VectorField;
use crate::grid::{BoxKind, FaceGrid};
use crate::simulation::Simulation;

use std::f32::consts::TAU;

/// The benchmark's Reynolds number, `Re = U L / ν` with `U = L = 1`.
pub const REYNOLDS: f32 = 1600.0;

/// The benchmark's final time.
pub const END_TIME: f32 = 20.0;

/// The initial field (module documentation).
#[derive(Clone, Copy, Debug)]
pub struct Initial;

impl VectorField for Initial {
    fn eval(&self, p: Vec3) -> Vec3 {
        let (sx, cx) = p.x.sin_cos();
        let (sy, cy) = p.y.sin_cos();
        let cz = p.z.cos();
        Vec3::new(sx * cy * cz, -cx * sy * cz, 0.0)
    }
}

/// `smokelab run taylor-green-3d`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TaylorGreen3dConfig {
    /// Resolution, time step, viscosity, advection scheme, confinement.
    #[serde(flatten)]
    pub solver: SolverConfig,
}

impl Default for TaylorGreen3dConfig {
    /// C3.5 at 32³: the box `[0, 2π]³`, ν = 1/1600, Δt = 0.1 (Courant
    /// number 0.51 at the initial peak speed 1), 200 steps to t = 20, a row
    /// of `energy.csv` every 2 steps.
    fn default() -> Self {
        Self {
            solver: SolverConfig {
                res: 32,
                size: TAU,
                nu: 1.0 / REYNOLDS,
                gravity: 0.0,
                dt: 0.1,
                frames: 200,
                save_every: 2,
                ..SolverConfig::default()
            },
        }
    }
}

impl TaylorGreen3dConfig {
    /// The configuration at `res`³ with the default's Courant number: Δt =
    /// `3.2 / res` (0.1 at 32³), to t = 20.
    pub fn at(res: usize) -> Self {
        let mut c = Self::default();
        c.solver.res = res;
        c.solver.frames = (END_TIME * res as f32 / 3.2).round() as usize;
        c.solver.dt = END_TIME / c.solver.frames as f32;
        c
    }
}

impl Scenario for TaylorGreen3dConfig {
    const NAME: &'static str = "taylor-green-3d";

    fn solver(&self) -> &SolverConfig {
        &self.solver
    }

    fn validate(&self) -> Result<(), InputError> {
        self.solver.validate()?;
        if self.solver.box_kind != BoxKind::Periodic {
            return Err(InputError::new(format!(
                "taylor-green-3d needs box periodic (box is {}): the benchmark is the periodic box [0, 2π]³",
                self.solver.box_kind.name()
            )));
        }
        Ok(())
    }

    fn logs_integrals(&self) -> bool {
        true
    }

    /// The solver at the initial field, with no gases. The field is
    /// `2π`-periodic whatever `size` is given, so it is set at the box's
    /// points scaled to `[0, 2π]³`.
    fn build(&self) -> Result<Simulation, InputError> {
        self.validate()?;
        let s = &self.solver;
        let mut sim = Simulation::new(s.domain()?, s.step_params(), vec![])
            .with_advection(&s.advection_options());
        struct Scaled(f32);
        impl VectorField for Scaled {
            fn eval(&self, p: Vec3) -> Vec3 {
                Initial.eval(p * self.0)
            }
        }
        let field = Scaled(TAU / s.size);
        sim.velocity = FaceGrid::from_field(*sim.domain(), BoxKind::Periodic, &field);
        Ok(sim)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::metrics::enstrophy::integrals;

    /// At 64³ the initial field has `E(0) = 1/8` and `2νΩ(0) = 4.6875e-4`
    /// (module documentation) to f32 round-off: the face samples of each
    /// sinusoid sum exactly over a period, and the spectral enstrophy
    /// differentiates resolved modes exactly.
    #[test]
    fn the_initial_energy_and_dissipation_are_the_closed_forms() {
        let sim = TaylorGreen3dConfig::at(64).build().unwrap();
        let m = integrals(&sim.velocity);
        let nu = 1.0 / REYNOLDS as f64;
        assert!(
            (m.energy - 0.125).abs() <= 1e-6 * 0.125,
            "E(0) = {}",
            m.energy
        );
        let dissipation = 2.0 * nu * m.enstrophy;
        assert!(
            (dissipation - 4.6875e-4).abs() <= 1e-6 * 4.6875e-4,
            "2νΩ(0) = {dissipation:e}"
        );
    }

    /// The default reaches t = 20; `at` keeps the Courant number.
    #[test]
    fn the_runs_reach_the_end_time() {
        for res in [32, 64, 128] {
            let s = TaylorGreen3dConfig::at(res).solver;
            assert!(
                (s.dt * s.frames as f32 - END_TIME).abs() < 1e-4,
                "{res}: {s:?}"
            );
            assert!(
                (s.dt * res as f32 / TAU - 0.51).abs() < 0.01,
                "{res}: Δt {}",
                s.dt
            );
        }
        assert_eq!(TaylorGreen3dConfig::at(32), TaylorGreen3dConfig::default());
    }

    /// A closed box is refused, naming it.
    #[test]
    fn a_closed_box_is_refused() {
        let mut c = TaylorGreen3dConfig::default();
        c.solver.box_kind = BoxKind::Closed;
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("box periodic"));
    }
}
