//! Divergence-free noise fields: velocity sources for gridless advection and
//! turbulence, each a [`VectorField`](crate::field::VectorField) usable
//! anywhere a velocity is.
//!
//! | kind | module | source | divergence-free? |
//! |---|---|---|---|
//! | value | [`value`] | `000_…` §3 (baseline) | no |
//! | perlin | [`perlin`] | notes eq 3.9 | no |
//! | fast simulation | [`simulation`] | `000_…` §3 | yes, normal flux continuous; tangential jumps |
//! | smooth simulation | [`simulation`] | `000_…` §4, appendix | yes, continuous |
//! | curl (analytic) | [`curl`] | `001_…`, `004_…` | yes, continuous |
//! | curl (finite differences) | [`curl`] | `001_…` | to O(h²) (O(h) with `001_…`'s backward rule) |
//! | bitangent | [`bitangent`] | `004_…` | yes, continuous |
//! | spectral | [`spectral`] | `003_…` (Stam–Fiume) | zero flux through every tile cube |
//!
//! Lattice noises live on the unit lattice (base frequency 1 per world unit),
//! hash their corners with a seeded key ([`lattice`]) and are not periodic.
//! 2D kinds live in the xy plane: they ignore `z` and return a zero z
//! component. [`fractal`] sums octaves of any kind; [`drag`] couples particles
//! to a field (`000_…` §3); [`artist`] steers simulation noise along splines
//! (`000_…` §5); [`lic`] draws a slice so the flow is visible.
//!
//! Build any kind from a [`NoiseSpec`]:
//!
//! ```
//! use glam::Vec3;
//! use smokelab::field::VectorField;
//! use smokelab::noise::{NoiseKind, NoiseSpec};
//! let spec = NoiseSpec { kind: NoiseKind::SmoothSim, seed: 7, ..Default::default() };
//! let v = spec.build().unwrap();
//! // Smooth simulation noise vanishes on lattice edges (Patel & Taylor §4, "dead spots").
//! assert_eq!(v.eval(Vec3::new(2.0, 3.0, 0.5)), Vec3::ZERO);
//! ```

pub mod artist;
pub mod bitangent;
pub mod curl;
pub mod drag;
pub mod fractal;
pub mod lattice;
pub mod lic;
pub mod perlin;
pub mod simulation;
pub mod spectral;
pub mod value;

use std::sync::Arc;

use serde::Serialize;

use crate::error::InputError;
use crate::field::Vector;
use bitangent::Bitangent;
use curl::{Curl, Curl2, CurlFd, CurlFd2, FdScheme};
use fractal::Fractal;
use lattice::{keys, AnimatedCorners, Corners, StaticCorners};
use perlin::{Perlin, PerlinVector};
use simulation::{Fast, SimulationNoise, SimulationNoise2, Smooth};
use spectral::{SpectralNoise, SpectralParams, SpectralTile};
use value::{ValueNoise, ValueNoise2};

/// Every noise smokelab can build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum NoiseKind {
    /// 3D value noise (trilinear random vectors; not divergence-free).
    Value,
    /// 2D value noise (not divergence-free).
    #[cfg_attr(feature = "clap", value(name = "value-2d"))]
    Value2d,
    /// Three offset Perlin noises (notes eq 3.9; not divergence-free).
    Perlin,
    /// Fast simulation noise (Patel & Taylor §3).
    FastSim,
    /// 2D fast simulation noise.
    #[cfg_attr(feature = "clap", value(name = "fast-sim-2d"))]
    FastSim2d,
    /// Smooth simulation noise (Patel & Taylor §4).
    SmoothSim,
    /// 2D smooth simulation noise.
    #[cfg_attr(feature = "clap", value(name = "smooth-sim-2d"))]
    SmoothSim2d,
    /// Analytic curl of three Perlin potentials.
    Curl,
    /// Analytic 2D curl of one Perlin potential.
    #[cfg_attr(feature = "clap", value(name = "curl-2d"))]
    Curl2d,
    /// Curl of three Perlin potentials by finite differences (i_dovelemon 2020).
    CurlFd,
    /// 2D curl by finite differences (i_dovelemon 2020).
    #[cfg_attr(feature = "clap", value(name = "curl-fd-2d"))]
    CurlFd2d,
    /// ∇A × ∇B of two Perlin noises (bitangent noise, "Simulation noise").
    Bitangent,
    /// Stam–Fiume FFT turbulence tile (Dunn, "Warping Implicit Surfaces").
    Spectral,
}

/// What a kind's construction guarantees about its divergence.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub enum Solenoidal {
    /// Not divergence-free.
    No,
    /// Zero net flux through any closed surface; the normal component is
    /// continuous across cell faces but the tangential ones jump.
    Discontinuous,
    /// Continuous and analytically divergence-free.
    Exact,
    /// Divergence O(h²) in the finite-difference step.
    Approximate,
    /// Zero net flux through every cube of the tile lattice.
    TileCubes,
}

impl NoiseKind {
    /// Every kind, for tests and listings.
    pub const ALL: &'static [NoiseKind] = &[
        NoiseKind::Value,
        NoiseKind::Value2d,
        NoiseKind::Perlin,
        NoiseKind::FastSim,
        NoiseKind::FastSim2d,
        NoiseKind::SmoothSim,
        NoiseKind::SmoothSim2d,
        NoiseKind::Curl,
        NoiseKind::Curl2d,
        NoiseKind::CurlFd,
        NoiseKind::CurlFd2d,
        NoiseKind::Bitangent,
        NoiseKind::Spectral,
    ];

    /// The command-line name.
    pub fn name(self) -> &'static str {
        match self {
            NoiseKind::Value => "value",
            NoiseKind::Value2d => "value-2d",
            NoiseKind::Perlin => "perlin",
            NoiseKind::FastSim => "fast-sim",
            NoiseKind::FastSim2d => "fast-sim-2d",
            NoiseKind::SmoothSim => "smooth-sim",
            NoiseKind::SmoothSim2d => "smooth-sim-2d",
            NoiseKind::Curl => "curl",
            NoiseKind::Curl2d => "curl-2d",
            NoiseKind::CurlFd => "curl-fd",
            NoiseKind::CurlFd2d => "curl-fd-2d",
            NoiseKind::Bitangent => "bitangent",
            NoiseKind::Spectral => "spectral",
        }
    }

    /// 2 for the planar kinds, 3 otherwise.
    pub fn dims(self) -> usize {
        match self {
            NoiseKind::Value2d
            | NoiseKind::FastSim2d
            | NoiseKind::SmoothSim2d
            | NoiseKind::Curl2d
            | NoiseKind::CurlFd2d => 2,
            _ => 3,
        }
    }

    /// The divergence guarantee of the construction.
    pub fn solenoidal(self) -> Solenoidal {
        match self {
            NoiseKind::Value | NoiseKind::Value2d | NoiseKind::Perlin => Solenoidal::No,
            NoiseKind::FastSim | NoiseKind::FastSim2d => Solenoidal::Discontinuous,
            NoiseKind::SmoothSim
            | NoiseKind::SmoothSim2d
            | NoiseKind::Curl
            | NoiseKind::Curl2d
            | NoiseKind::Bitangent => Solenoidal::Exact,
            NoiseKind::CurlFd | NoiseKind::CurlFd2d => Solenoidal::Approximate,
            NoiseKind::Spectral => Solenoidal::TileCubes,
        }
    }

    /// Whether the kind depends on time (value and simulation noises through
    /// their corner lookups, spectral through a 4D tile).
    pub fn time_varying(self) -> bool {
        matches!(
            self,
            NoiseKind::Value
                | NoiseKind::Value2d
                | NoiseKind::FastSim
                | NoiseKind::FastSim2d
                | NoiseKind::SmoothSim
                | NoiseKind::SmoothSim2d
                | NoiseKind::Spectral
        )
    }
}

/// Everything needed to build a noise field.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct NoiseSpec {
    /// Which noise.
    pub kind: NoiseKind,
    /// Random seed.
    pub seed: u64,
    /// Time for time-varying kinds (lattice time units; frames of a spectral
    /// tile); `None` is the static field.
    pub time: Option<f32>,
    /// Octaves (one octave is the basis alone).
    pub fractal: Fractal,
    /// Finite-difference step of the `curl-fd` kinds, lattice units.
    pub fd_step: f32,
    /// Finite-difference rule of the `curl-fd` kinds.
    pub fd_scheme: FdScheme,
    /// Tile parameters of the spectral kind.
    pub spectral: SpectralParams,
}

impl Default for NoiseSpec {
    fn default() -> Self {
        Self {
            kind: NoiseKind::SmoothSim,
            seed: 0,
            time: None,
            fractal: Fractal::default(),
            fd_step: CurlFd::DEFAULT_STEP,
            fd_scheme: FdScheme::Central,
            spectral: SpectralParams::default(),
        }
    }
}

impl NoiseSpec {
    /// Check the parameters, naming the bad value and what is valid.
    pub fn validate(&self) -> Result<(), InputError> {
        self.fractal.validate()?;
        if let Some(t) = self.time {
            if !self.kind.time_varying() {
                let kinds: Vec<_> = NoiseKind::ALL
                    .iter()
                    .filter(|k| k.time_varying())
                    .map(|k| k.name())
                    .collect();
                return Err(InputError::new(format!(
                    "noise kind '{}' does not depend on time; --time applies to {}",
                    self.kind.name(),
                    kinds.join(", ")
                )));
            }
            if !t.is_finite() || t.abs() > 1e6 {
                return Err(InputError::new(format!(
                    "time is {t}; it must be a finite number of magnitude at most 1e6"
                )));
            }
            if self.kind == NoiseKind::Spectral && self.spectral.frames < 2 {
                return Err(InputError::new(format!(
                    "a time-varying spectral noise needs a 4D tile; frames is {}, it must be at least 2",
                    self.spectral.frames
                )));
            }
        }
        if matches!(self.kind, NoiseKind::CurlFd | NoiseKind::CurlFd2d)
            && !(self.fd_step.is_finite() && self.fd_step > 0.0 && self.fd_step <= 0.5)
        {
            return Err(InputError::new(format!(
                "finite-difference step is {}; it must lie in (0, 0.5] lattice units",
                self.fd_step
            )));
        }
        if self.kind == NoiseKind::Spectral {
            self.spectral.validate()?;
        }
        Ok(())
    }

    /// Build the field: the fractal sum of the seeded basis kind.
    pub fn build(&self) -> Result<Vector, InputError> {
        self.validate()?;
        self.fractal.build(self.seed, |seed| self.basis(seed))
    }

    /// One octave of the kind, seeded with `seed`.
    fn basis(&self, seed: u64) -> Result<Vector, InputError> {
        let key = keys::<1>(seed)[0];
        Ok(match self.kind {
            NoiseKind::Value
            | NoiseKind::Value2d
            | NoiseKind::FastSim
            | NoiseKind::FastSim2d
            | NoiseKind::SmoothSim
            | NoiseKind::SmoothSim2d => match self.time {
                None => lattice_noise(self.kind, StaticCorners::new(key)),
                Some(t) => lattice_noise(self.kind, AnimatedCorners::new(key, t)),
            },
            NoiseKind::Perlin => Arc::new(PerlinVector::new(Perlin::new(key))),
            NoiseKind::Curl => Arc::new(Curl::new(keys::<3>(seed))),
            NoiseKind::Curl2d => Arc::new(Curl2::new(key)),
            NoiseKind::CurlFd => {
                Arc::new(CurlFd::new(keys::<3>(seed), self.fd_step, self.fd_scheme))
            }
            NoiseKind::CurlFd2d => Arc::new(CurlFd2::new(key, self.fd_step, self.fd_scheme)),
            NoiseKind::Bitangent => Arc::new(Bitangent::new(keys::<2>(seed))),
            NoiseKind::Spectral => {
                let tile = Arc::new(SpectralTile::new(self.spectral, seed)?);
                Arc::new(SpectralNoise::new(tile, self.time.unwrap_or(0.0)))
            }
        })
    }
}

/// The corner-lookup kinds on the corners `c`.
fn lattice_noise<C: Corners>(kind: NoiseKind, c: C) -> Vector {
    match kind {
        NoiseKind::Value => Arc::new(ValueNoise::new(c)),
        NoiseKind::Value2d => Arc::new(ValueNoise2::new(c)),
        NoiseKind::FastSim => Arc::new(SimulationNoise::<C, Fast>::new(c)),
        NoiseKind::FastSim2d => Arc::new(SimulationNoise2::<C, Fast>::new(c)),
        NoiseKind::SmoothSim => Arc::new(SimulationNoise::<C, Smooth>::new(c)),
        NoiseKind::SmoothSim2d => Arc::new(SimulationNoise2::<C, Smooth>::new(c)),
        _ => unreachable!("{kind:?} does not read corner lookups"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;

    #[test]
    fn two_d_kinds_are_planar() {
        for &kind in NoiseKind::ALL.iter().filter(|k| k.dims() == 2) {
            let v = NoiseSpec {
                kind,
                seed: 3,
                ..Default::default()
            }
            .build()
            .unwrap();
            let p = Vec3::new(0.3, 1.9, 0.0);
            let a = v.eval(p);
            assert_eq!(a.z, 0.0);
            assert_eq!(a, v.eval(p + Vec3::Z * 5.7), "{kind:?} depends on z");
        }
    }

    #[test]
    fn time_is_rejected_for_static_kinds() {
        for &kind in NoiseKind::ALL {
            let spec = NoiseSpec {
                kind,
                time: Some(0.5),
                spectral: SpectralParams {
                    frames: 4,
                    res: 8,
                    ..Default::default()
                },
                ..Default::default()
            };
            assert_eq!(spec.build().is_ok(), kind.time_varying(), "{kind:?}");
        }
    }
}
