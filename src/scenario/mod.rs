//! Scenarios: initial state, sources, forces and parameters with defaults.

pub mod config;
pub mod hot_cold;
pub mod prescribed;
pub mod slab_box;
pub mod sphere_wall;
pub mod taylor_green;
pub mod taylor_green_3d;

use serde::{Deserialize, Serialize};

#[cfg(feature = "clap")]
pub use config::SolverFlags;
pub use config::{Scenario, SolverConfig};

/// The scenarios `smokelab run` knows.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "kebab-case")]
pub enum ScenarioKind {
    /// Hot gas rising from below, cold gas sinking from above (§6.1.1, figs 6.1–6.2).
    #[default]
    HotCold,
    /// Buoyant gas in a closed box flowing around a slab (§6.3, fig 6.6).
    SlabBox,
    /// A sphere in LeVeque's 3D deformation field, returning at one period
    /// (prescribed velocity).
    Deformation,
    /// Zalesak's slotted sphere in rigid rotation (prescribed velocity).
    Zalesak,
    /// The Taylor–Green vortex decaying under the full Navier–Stokes step,
    /// measured against its exact solution.
    TaylorGreen,
    /// The Taylor–Green vortex at Re = 1600 breaking down into turbulence
    /// (the high-order CFD workshop's case C3.5, module `taylor_green_3d`).
    #[serde(rename = "taylor-green-3d")]
    #[cfg_attr(feature = "clap", value(name = "taylor-green-3d"))]
    TaylorGreen3d,
}

impl ScenarioKind {
    /// Every scenario.
    pub const ALL: [ScenarioKind; 6] = [
        ScenarioKind::HotCold,
        ScenarioKind::SlabBox,
        ScenarioKind::Deformation,
        ScenarioKind::Zalesak,
        ScenarioKind::TaylorGreen,
        ScenarioKind::TaylorGreen3d,
    ];
}

/// `$body` with the type alias `$C` bound to the configuration type of
/// scenario `$kind` (a [`ScenarioKind`]): `with_scenario!(kind, C =>
/// run::<C>(args))`.
///
/// This is the one place besides [`ScenarioKind`] (and its `ALL`) that a
/// new scenario is added to: every dispatch on a scenario — `smokelab run`,
/// `--resume`, the sweep's planning, the scenario keys, the Python module —
/// goes through it, and the compiler names a missing arm here.
#[macro_export]
macro_rules! with_scenario {
    ($kind:expr, $C:ident => $body:expr) => {
        match $kind {
            $crate::scenario::ScenarioKind::HotCold => {
                type $C = $crate::scenario::hot_cold::HotColdConfig;
                $body
            }
            $crate::scenario::ScenarioKind::SlabBox => {
                type $C = $crate::scenario::slab_box::SlabBoxConfig;
                $body
            }
            $crate::scenario::ScenarioKind::Deformation => {
                type $C = $crate::scenario::prescribed::DeformationConfig;
                $body
            }
            $crate::scenario::ScenarioKind::Zalesak => {
                type $C = $crate::scenario::prescribed::ZalesakConfig;
                $body
            }
            $crate::scenario::ScenarioKind::TaylorGreen => {
                type $C = $crate::scenario::taylor_green::TaylorGreenConfig;
                $body
            }
            $crate::scenario::ScenarioKind::TaylorGreen3d => {
                type $C = $crate::scenario::taylor_green_3d::TaylorGreen3dConfig;
                $body
            }
        }
    };
}
