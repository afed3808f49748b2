//! The Taylor–Green vortex: an exact solution of the full Navier–Stokes
//! equations in a periodic box, the check of the solver itself
//! (advection + viscosity + projection, no buoyancy) in the style of
//! Oceananigans' `validation/`.
//!
//! With `k = 2π/L` in a box of edge L,
//! ```text
//! u =  A sin(kx) cos(ky) F(t),   v = −A cos(kx) sin(ky) F(t),   w = 0,
//! F(t) = exp(−2νk²t)
//! ```
//! is divergence-free, its advection `u·∇u = −∇(A²F²(cos 2kx + cos 2ky)/4)`
//! is a pure gradient the pressure removes, and what is left is the viscous
//! decay: the kinetic energy falls as `F² = exp(−4νk²t)`.
//!
//! The run starts the solver from the exact field on the faces and lets it
//! step freely (no prescribed velocity, no gases): every difference from
//! the exact field at time `t` is the solver's error. The design choice: the
//! vortex is a *solver* check, not a prescribed flow for a density — a
//! prescribed Taylor–Green field decays without reversing, so no density
//! solution would be known at any later time without a reversal the
//! Navier–Stokes vortex does not have; LeVeque's deformation and Zalesak's
//! sphere ([`super::prescribed`]) already measure the densities.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use super::{Scenario, SolverConfig};
use crate::error::{check_positive, InputError};
use crate::grid::{BoxKind, FaceGrid};
use crate::simulation::{AtTime, PrescribedVelocity, Simulation};

use std::f32::consts::TAU;

/// The Taylor–Green field of amplitude `amplitude` in a box of edge `size`
/// with viscosity `nu`, at any time.
#[derive(Clone, Copy, Debug)]
pub struct TaylorGreen {
    /// Amplitude A at t = 0.
    pub amplitude: f32,
    /// Edge L of the periodic box; `k = 2π/L`.
    pub size: f32,
    /// Kinematic viscosity ν.
    pub nu: f32,
}

impl TaylorGreen {
    /// The wavenumber `k = 2π/L`.
    pub fn k(&self) -> f32 {
        TAU / self.size
    }

    /// The decay factor `F(t) = exp(−2νk²t)` of the velocity.
    pub fn decay(&self, t: f32) -> f64 {
        (-2.0 * self.nu as f64 * (self.k() as f64).powi(2) * t as f64).exp()
    }

    /// The exact field at time `t` on the faces of `like`'s grid.
    pub fn faces(&self, like: &FaceGrid, t: f32) -> FaceGrid {
        FaceGrid::from_field(*like.domain(), like.kind(), &AtTime(self, t))
    }

    /// The solver's `velocity` at time `t` against the exact field.
    pub fn measure(&self, velocity: &FaceGrid, t: f32) -> VelocityMeasures {
        let exact = self.faces(velocity, t);
        let (mut err2, mut norm2, mut linf, mut energy) = (0.0f64, 0.0f64, 0.0f64, 0.0f64);
        for a in 0..3 {
            for (&u, &e) in velocity.slice(a).iter().zip(exact.slice(a)) {
                let d = (u - e) as f64;
                err2 += d * d;
                norm2 += (e as f64).powi(2);
                linf = linf.max(d.abs());
                energy += (u as f64).powi(2);
            }
        }
        let at0 = self.faces(velocity, 0.0);
        let energy0: f64 = (0..3)
            .flat_map(|a| at0.slice(a).iter())
            .map(|&u| (u as f64).powi(2))
            .sum();
        VelocityMeasures {
            l2: (err2 / norm2).sqrt(),
            linf: linf / (self.amplitude as f64 * self.decay(t)),
            energy: energy / energy0,
            energy_exact: self.decay(t).powi(2),
        }
    }
}

impl PrescribedVelocity for TaylorGreen {
    fn at(&self, p: Vec3, t: f32) -> Vec3 {
        let (k, f) = (self.k(), self.decay(t) as f32);
        let (sx, cx) = (k * p.x).sin_cos();
        let (sy, cy) = (k * p.y).sin_cos();
        self.amplitude * f * Vec3::new(sx * cy, -cx * sy, 0.0)
    }
}

/// The solver's velocity against the exact Taylor–Green field at one time.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct VelocityMeasures {
    /// `‖u − u_exact‖₂ / ‖u_exact‖₂` over every face.
    pub l2: f64,
    /// `max |u − u_exact|` over the exact amplitude `A F(t)`.
    pub linf: f64,
    /// Kinetic energy `Σ u²` over the exact field's at t = 0.
    pub energy: f64,
    /// The exact energy ratio `F(t)² = exp(−4νk²t)`.
    pub energy_exact: f64,
}

/// `smokelab run taylor-green`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TaylorGreenConfig {
    /// Resolution, time step, viscosity, advection scheme, cadence.
    #[serde(flatten)]
    pub solver: SolverConfig,
    /// Amplitude A of the vortex at t = 0.
    pub amplitude: f32,
}

impl Default for TaylorGreenConfig {
    /// The C-1 set-up in a cube: the box `[0, 2π]³` (k = 1) at 32³, A = 1,
    /// ν = 0.05, Δt = Δx/2 (Courant number ½), 32 steps to t = π, a row of
    /// `exact.csv` every 2 steps.
    fn default() -> Self {
        let (res, size) = (32, TAU);
        Self {
            solver: SolverConfig {
                res,
                size,
                nu: 0.05,
                gravity: 0.0,
                dt: 0.5 * size / res as f32,
                frames: 32,
                save_every: 2,
                ..SolverConfig::default()
            },
            amplitude: 1.0,
        }
    }
}

impl TaylorGreenConfig {
    /// The exact field of this run.
    pub fn flow(&self) -> TaylorGreen {
        TaylorGreen {
            amplitude: self.amplitude,
            size: self.solver.size,
            nu: self.solver.nu,
        }
    }
}

impl Scenario for TaylorGreenConfig {
    const NAME: &'static str = "taylor-green";

    fn solver(&self) -> &SolverConfig {
        &self.solver
    }

    fn validate(&self) -> Result<(), InputError> {
        self.solver.validate()?;
        check_positive("amplitude", self.amplitude)?;
        if self.solver.box_kind != BoxKind::Periodic {
            return Err(InputError::new(format!(
                "taylor-green needs box periodic (box is {}): the vortex is the periodic box's exact solution",
                self.solver.box_kind.name()
            )));
        }
        Ok(())
    }

    fn exact_velocity(&self) -> Option<TaylorGreen> {
        Some(self.flow())
    }

    /// The solver at the exact field of t = 0, with no gases.
    fn build(&self) -> Result<Simulation, InputError> {
        self.validate()?;
        let s = &self.solver;
        let mut sim = Simulation::new(s.domain()?, s.step_params(), vec![])
            .with_advection(&s.advection_options());
        sim.velocity = self.flow().faces(&sim.velocity, 0.0);
        Ok(sim)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The exact field on the faces is the analytic one at each face centre,
    /// bit for bit, and decays by `F(t)`.
    #[test]
    fn the_exact_field_on_the_faces_is_the_analytic_one() {
        let mut c = TaylorGreenConfig::default();
        c.solver.res = 8;
        let sim = c.build().unwrap();
        let flow = c.flow();
        let t = 0.7;
        let faces = flow.faces(&sim.velocity, t);
        let f = (-2.0f64 * 0.05 * t as f64).exp() as f32;
        for a in 0..3 {
            let dims = faces.face_dims(a);
            for k in 0..dims[2] {
                for j in 0..dims[1] {
                    for i in 0..dims[0] {
                        let p = faces.face_position(a, i, j, k);
                        let analytic = f * [p.x.sin() * p.y.cos(), -p.x.cos() * p.y.sin(), 0.0][a];
                        let got = faces.component(a)[[k, j, i]];
                        assert_eq!(got, flow.at(p, t)[a], "component {a} at {p}");
                        assert!(
                            (got - analytic).abs() <= 2e-6,
                            "component {a} at {p}: {got} vs {analytic}"
                        );
                    }
                }
            }
        }
    }

    /// A closed box and a non-positive amplitude are refused, naming the value.
    #[test]
    fn bad_options_are_refused() {
        let mut c = TaylorGreenConfig::default();
        c.solver.box_kind = BoxKind::Closed;
        assert!(c
            .validate()
            .unwrap_err()
            .to_string()
            .contains("box periodic"));
        let c = TaylorGreenConfig {
            amplitude: 0.0,
            ..TaylorGreenConfig::default()
        };
        assert!(c.validate().unwrap_err().to_string().contains("amplitude"));
    }
}
