//! One solver configuration for every scenario, and how a scenario's
//! configuration is resolved from its defaults, a TOML file and overrides.
//!
//! [`SolverConfig`] holds what every scenario shares — resolution, box, time
//! step, viscosity, gravity, advection, density mode, output cadence, seed,
//! threads. Each key is defined once (`solver_keys!`), which gives both the
//! configuration field and its command-line flag ([`SolverFlags`], with the
//! `clap` feature), with one doc. A scenario's configuration flattens it
//! (`#[serde(flatten)]`), so its TOML keys and its command-line flags are the
//! same flat names in every scenario. [`resolve`] layers defaults ← file ←
//! overrides key by key and refuses any key the scenario does not have,
//! naming the scenario that has it.

use std::path::Path;

use glam::Vec3;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use toml::Table;

use crate::advection::{AdvectionOptions, Backtrace, Limiter, QuickOptions, Scheme};
use crate::density::{CellSamples, DensityMode, DensityOptions, DEFAULT_SELMA_REMAP};
use crate::domain::{Domain, MIN_CELLS};
use crate::error::{check_non_negative, check_positive, InputError};
use crate::grid::{BoxKind, Interpolant};
use crate::pressure::PressurePrecision;
use crate::simulation::{Gas, Simulation, StepParams};

/// One definition of every solver key: its doc, name, type and default, and
/// its command-line flag. Expands to [`SolverConfig`] (serde: the TOML
/// keys), its `Default`, and, with the `clap` feature, [`SolverFlags`] with
/// the same doc per flag and [`SolverFlags::overrides`].
///
/// A key reads `name: Type = default;` then `flag name: FlagType [clap
/// attributes] => to_key;`, where `to_key` maps the parsed flag to the key's
/// override ([`given`] for an `Option` flag, [`switch`] for a bool flag that
/// sets the key to a fixed value).
macro_rules! solver_keys {
    ($(
        $(#[doc = $doc:literal])+
        $(#[serde(rename = $key:literal)])?
        $field:ident: $ty:ty = $default:expr;
        flag $flag:ident: $flag_ty:ty [$($arg:meta),*] => $to_key:expr;
    )+) => {
        /// Parameters of the solver, shared by every scenario (flattened into
        /// each scenario's configuration: the TOML keys are these field names).
        #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
        pub struct SolverConfig {
            $(
                $(#[doc = $doc])+
                $(#[serde(rename = $key)])?
                pub $field: $ty,
            )+
        }

        impl Default for SolverConfig {
            /// The hot/cold defaults of §6.1.1: 50³ in a cube of edge 10, Δt
            /// 0.05, 150 frames, inviscid, g = 1, RK2 semi-Lagrangian, gridded
            /// densities.
            fn default() -> Self {
                Self { $($field: $default,)+ }
            }
        }

        /// The command-line flags of the [`SolverConfig`] keys (same name, `-`
        /// for `_`, and the same doc); each given flag overrides its key.
        #[cfg(feature = "clap")]
        #[derive(Debug, Default, clap::Args)]
        pub struct SolverFlags {
            $(
                $(#[doc = $doc])+
                #[arg(long $(, $arg)*)]
                pub $flag: $flag_ty,
            )+
        }

        #[cfg(feature = "clap")]
        impl SolverFlags {
            /// The keys the given flags set, and their values (a layer for
            /// [`resolve`]).
            pub fn overrides(&self) -> Table {
                let mut table = Table::new();
                $(
                    if let Some(value) = ($to_key)(&self.$flag) {
                        table.insert(key_name!($field $(, $key)?).into(), value);
                    }
                )+
                table
            }
        }
    };
}

/// A key's TOML name: its `serde(rename)`, else its field name.
#[cfg(feature = "clap")]
macro_rules! key_name {
    ($field:ident) => {
        stringify!($field)
    };
    ($field:ident, $key:literal) => {
        $key
    };
}

/// The override of a value flag: its value, if given.
#[cfg(feature = "clap")]
fn given<T: Serialize>(flag: &Option<T>) -> Option<toml::Value> {
    flag.as_ref()
        .map(|v| toml::Value::try_from(v).expect("a flag's value is a TOML value"))
}

/// The override of a switch: `value`, if the switch is given.
#[cfg(feature = "clap")]
fn switch(value: bool) -> impl Fn(&bool) -> Option<toml::Value> {
    move |on| on.then_some(toml::Value::Boolean(value))
}

/// `--cell-samples`: 1 or 8 (the message says what each means).
#[cfg(feature = "clap")]
fn parse_cell_samples(text: &str) -> Result<CellSamples, String> {
    let n: usize = text.parse().map_err(|e| format!("{e}"))?;
    CellSamples::try_from(n).map_err(|e| e.to_string())
}

solver_keys! {
    /// Cells per axis of the cubic box (the notes use 50).
    res: usize = 50;
    flag res: Option<usize> [allow_negative_numbers = true] => given;

    /// Edge length L of the cubic box, world units.
    size: f32 = 10.0;
    flag size: Option<f32> [allow_negative_numbers = true] => given;

    /// The box's faces: `periodic` (the notes' FFT box) or `closed` (six
    /// walls with no normal flow; SL, MacCormack or BFECC advection and
    /// gridded densities only).
    #[serde(rename = "box")]
    box_kind: BoxKind = BoxKind::Periodic;
    flag box_kind: Option<BoxKind> [long = "box", value_enum] => given;

    /// Number of time steps (one step per frame).
    frames: usize = 150;
    flag frames: Option<usize> [allow_negative_numbers = true] => given;

    /// Time step Δt.
    dt: f32 = 0.05;
    flag dt: Option<f32> [allow_negative_numbers = true] => given;

    /// Kinematic viscosity ν (0: inviscid, as the notes' eq 6.2).
    nu: f32 = 0.0;
    flag nu: Option<f32> [allow_negative_numbers = true] => given;

    /// Magnitude g of gravity; g⃗ = (0, −g, 0).
    gravity: f32 = 1.0;
    flag gravity: Option<f32> [allow_negative_numbers = true] => given;

    /// Vorticity confinement ε ≥ 0 (Fedkiw, Stam & Jensen 2001, eqs 9–11):
    /// the force `ε Δx (N × ω)`, `N = ∇|ω| / |∇|ω||`, added with the
    /// buoyancy every step to put back rotation the advection's numerical
    /// dissipation removes (0: off; any scheme and density mode; no force
    /// on the faces obstacles close).
    confinement: f32 = 0.0;
    flag confinement: Option<f32> [allow_negative_numbers = true] => given;

    /// Semi-Lagrangian backtrace: `euler`, `rk2`, `rk3`, or `exact` (the
    /// exact path through the RT0 velocity; needs `interpolant = rt0`).
    backtrace: Backtrace = Backtrace::Rk2;
    flag backtrace: Option<Backtrace> [value_enum] => given;

    /// How every trace that follows the velocity (semi-Lagrangian,
    /// MacCormack and BFECC backtraces, gridless walks, SELMA maps) reads it
    /// between the faces: `trilinear` (each component trilinear on its own
    /// faces) or `rt0` (alias `pollock`: the lowest-order Raviart–Thomas
    /// interpolant, each component linear along its own axis inside a cell
    /// and constant across, so divergence-free at every point; first order).
    interpolant: Interpolant = Interpolant::Trilinear;
    flag interpolant: Option<Interpolant> [value_enum] => given;

    /// Advection scheme for velocity and gridded densities: `sl`, `quick`,
    /// `maccormack` or `bfecc` (gridless and SELMA densities always trace
    /// semi-Lagrangian departure points; the scheme then moves the velocity).
    advection: Scheme = Scheme::Sl;
    flag advection: Option<Scheme> [value_enum] => given;

    /// QUICK: steps beyond the CFL bound are split into sub-steps (key
    /// `substeps = true`, the default) or refused (`substeps = false`, flag
    /// `--no-substeps`).
    substeps: bool = true;
    flag no_substeps: bool [] => switch(false);

    /// QUICK: limiter for the densities, `ultimate` or `none`.
    limiter: Limiter = Limiter::Ultimate;
    flag limiter: Option<Limiter> [value_enum] => given;

    /// How the densities are held: `gridded` (eq 6.4), `gridless` (eq 7.4) or
    /// `selma` (eq 8.8).
    density: DensityMode = DensityMode::Gridded;
    flag density: Option<DensityMode> [value_enum] => given;

    /// SELMA map grid cells along the longest axis (default: `res`; finer is
    /// SELMA^fine).
    map_res: Option<usize> = None;
    flag map_res: Option<usize> [allow_negative_numbers = true] => given;

    /// SELMA: re-anchor the map when its tracked lattice has deformed by more
    /// than this many map cells (0: never).
    selma_remap: f32 = DEFAULT_SELMA_REMAP;
    flag selma_remap: Option<f32> [allow_negative_numbers = true] => given;

    /// Gridless and SELMA: points per cell when the density is put on the
    /// grid for the buoyancy force and the saved volumes — `8`, the cell
    /// average over 2×2×2 sub-cell points (band-limited; the gridless
    /// default; adaptive: eight walks only in cells where the gas varies), or
    /// `1`, the point sample at the cell centre (the SELMA default, whose
    /// reference is already cell averages; for gridless it aliases sub-cell
    /// filaments into specks).
    cell_samples: Option<CellSamples> = None;
    flag cell_samples: Option<CellSamples>
        [allow_negative_numbers = true, value_parser = parse_cell_samples] => given;

    /// Also write the densities sampled at this resolution
    /// (`<gas>_fine_NNNN.npy`).
    sample_res: Option<usize> = None;
    flag sample_res: Option<usize> [allow_negative_numbers = true] => given;

    /// Write volumes and a preview every this many frames (0: metrics only).
    save_every: usize = 10;
    flag save_every: Option<usize> [allow_negative_numbers = true] => given;

    /// Compute the fine metrics (densities sampled at 2×, spectra, the
    /// interpolant's divergence) every this many steps (≥ 1) and at the last.
    /// Each costs about 1.5 steps at 128³ hot/cold (experiment P-1), so the
    /// default 100 adds about 1.5 % to a run.
    metrics_every: usize = 100;
    flag metrics_every: Option<usize> [allow_negative_numbers = true] => given;

    /// Compute the step diagnostics (max|u| and the CFL number, the compact
    /// divergence, the gases' and the velocity's mirror errors) every this
    /// many steps (≥ 1) and at the last, `NaN` between; the CFL warning is
    /// checked on these steps. One pass over the faces and the gases costs
    /// about 5 % of a 128³ hot/cold step (experiment P-1), so the default 10
    /// adds about 0.5 %; 1 measures every step.
    diagnostics_every: usize = 10;
    flag diagnostics_every: Option<usize> [allow_negative_numbers = true] => given;

    /// Arithmetic of the pressure solve's transforms: `f32` (default; after
    /// the projection `max|D u| Δx / max|u|` ≤ 1e-5 up to 256³, growing
    /// about as `ε N`; experiment P-1's `pressure_precision.csv`) or `f64`
    /// (`max|D u|` at the faces' rounding; for finer grids, and the
    /// convergence suite's).
    pressure_precision: PressurePrecision = PressurePrecision::F32;
    flag pressure_precision: Option<PressurePrecision> [value_enum] => given;

    /// Run even if the memory estimate exceeds the available memory.
    force: bool = false;
    flag force: bool [] => switch(true);

    /// Random seed (recorded; the scenarios themselves are deterministic).
    seed: u64 = 0;
    flag seed: Option<u64> [allow_negative_numbers = true] => given;

    /// Worker threads (default: all cores).
    threads: Option<usize> = None;
    flag threads: Option<usize> [allow_negative_numbers = true] => given;
}

impl SolverConfig {
    /// The cubic domain `[0, size]³` with `res` cells per axis.
    pub fn domain(&self) -> Result<Domain, InputError> {
        Domain::cube(self.res, self.size)
    }

    /// The density options of the run.
    pub fn density_options(&self) -> DensityOptions {
        DensityOptions {
            mode: self.density,
            map_res: self.map_res,
            selma_remap: self.selma_remap,
            cell_samples: self.cell_samples,
        }
    }

    /// The advection options these parameters select.
    pub fn advection_options(&self) -> AdvectionOptions {
        AdvectionOptions {
            scheme: self.advection,
            quick: QuickOptions {
                substeps: self.substeps,
                ..Default::default()
            },
            density_limiter: self.limiter,
        }
    }

    /// Δt, ν, g⃗ = (0, −g, 0), the backtrace, the interpolant and the confinement ε.
    pub fn step_params(&self) -> StepParams {
        StepParams {
            dt: self.dt,
            viscosity: self.nu,
            gravity: Vec3::new(0.0, -self.gravity, 0.0),
            backtrace: self.backtrace,
            interpolant: self.interpolant,
            confinement: self.confinement,
        }
    }

    /// Check every parameter; the message names the bad value and what is valid.
    pub fn validate(&self) -> Result<(), InputError> {
        if self.res < MIN_CELLS {
            return Err(InputError::new(format!(
                "resolution {} is too small; it must be at least {MIN_CELLS}",
                self.res
            )));
        }
        check_positive("dt", self.dt)?;
        check_positive("size", self.size)?;
        check_non_negative("nu", self.nu)?;
        check_non_negative("confinement", self.confinement)?;
        if !self.gravity.is_finite() {
            return Err(InputError::new(format!(
                "gravity is {}; it must be finite",
                self.gravity
            )));
        }
        if self.metrics_every == 0 {
            return Err(InputError::new(
                "metrics_every is 0; it must be at least 1 (fine metrics every K steps)",
            ));
        }
        if self.diagnostics_every == 0 {
            return Err(InputError::new(
                "diagnostics_every is 0; it must be at least 1 (step diagnostics every K steps)",
            ));
        }
        if let Some(r) = self.sample_res {
            if r < MIN_CELLS {
                return Err(InputError::new(format!(
                    "sample_res {r} is too small; it must be at least {MIN_CELLS}"
                )));
            }
        }
        if let Some(r) = self.map_res {
            if self.density != DensityMode::Selma {
                return Err(InputError::new(format!(
                    "map_res {r} is only used by --density selma (density is {})",
                    self.density
                )));
            }
        }
        // Like map_res: a SELMA-only key given to another mode is a mistake
        // (the default is what every mode's configuration prints).
        if self.selma_remap != DEFAULT_SELMA_REMAP && self.density != DensityMode::Selma {
            return Err(InputError::new(format!(
                "selma_remap {} is only used by --density selma (density is {})",
                self.selma_remap, self.density
            )));
        }
        if self.backtrace == Backtrace::Exact && self.interpolant != Interpolant::Rt0 {
            return Err(InputError::new(format!(
                "backtrace exact follows the RT0 velocity; it needs interpolant rt0 (interpolant is {})",
                self.interpolant
            )));
        }
        if self.box_kind == BoxKind::Closed {
            if self.advection == Scheme::Quick {
                return Err(InputError::new(
                    "box closed needs advection sl, maccormack or bfecc (QUICK's lattice is periodic; advection is quick)",
                ));
            }
            if self.density != DensityMode::Gridded {
                return Err(InputError::new(format!(
                    "box closed needs density gridded (the {} walk is periodic)",
                    self.density
                )));
            }
        }
        if let Some(n) = self.threads {
            crate::timing::check_threads(n)?;
        }
        self.density_options().validate(&self.domain()?)
    }
}

/// Refuse gases whose source covers no cell centre: such a run would
/// inject nothing and move nothing (a radius below half a cell, say).
pub fn check_sources(gases: &[Gas], solver: &SolverConfig) -> Result<(), InputError> {
    for gas in gases {
        if gas.source.total() <= 0.0 {
            return Err(InputError::new(format!(
                "the {} source covers no cell centre at res {} (cell {:.4}); use a larger radius or a finer res",
                gas.name,
                solver.res,
                solver.size / solver.res as f32
            )));
        }
    }
    Ok(())
}

/// A scenario: initial state, sources, obstacles and forces, with defaults.
/// Its configuration flattens a [`SolverConfig`]; adding a scenario is one
/// file implementing this trait and one line in the application's registry.
pub trait Scenario: Clone + Default + Serialize + DeserializeOwned {
    /// The name on the command line and in messages, e.g. `hot-cold`.
    const NAME: &'static str;

    /// The solver parameters.
    fn solver(&self) -> &SolverConfig;

    /// Check every parameter (the solver's too); the message names the bad
    /// value and what is valid.
    fn validate(&self) -> Result<(), InputError>;

    /// The simulation at rest with sources and obstacles in place.
    fn build(&self) -> Result<Simulation, InputError>;

    /// The exact solution a run of `sim` (just built) is measured against,
    /// where the scenario knows one (the prescribed flows).
    fn exact(&self, _sim: &Simulation) -> Option<super::prescribed::Exact> {
        None
    }

    /// The exact velocity a run's solver is measured against, where the
    /// scenario knows one (the Taylor–Green vortex).
    fn exact_velocity(&self) -> Option<super::taylor_green::TaylorGreen> {
        None
    }

    /// Whether a run logs the kinetic energy and enstrophy per unit volume
    /// ([`crate::metrics::enstrophy`]) at every saved frame, `energy.csv`
    /// (the turbulence benchmark, [`super::taylor_green_3d`]).
    fn logs_integrals(&self) -> bool {
        false
    }
}

/// Every key a scenario's configuration has (the solver's included).
pub fn keys<C: Scenario>() -> Vec<String> {
    // JSON keeps `None` fields as `null`, so optional keys are listed too.
    match serde_json::to_value(C::default()) {
        Ok(serde_json::Value::Object(map)) => map.keys().cloned().collect(),
        _ => unreachable!("a scenario configuration serializes to a map"),
    }
}

/// Read a TOML configuration file as a table of keys.
pub fn read_toml(path: &Path) -> Result<Table, InputError> {
    let text = crate::io::input::read_text(path, "config")?;
    toml::from_str(&text).map_err(|e| {
        InputError::new(format!(
            "config {} is not valid TOML: {}",
            path.display(),
            e.message()
        ))
    })
}

/// The configuration of scenario `C`: its defaults, then each key of
/// `layers` in turn (each a source, e.g. `config run.toml` or `flags`, and
/// its keys), checked.
///
/// A key `C` does not have is an error naming it, and the scenarios in
/// `others` (each a name and its keys) that do have it; a value of the wrong
/// type is an error naming its key and source.
pub fn resolve<C: Scenario>(
    layers: &[(String, Table)],
    others: &[(&str, Vec<String>)],
) -> Result<C, InputError> {
    let own = keys::<C>();
    let defaults = Table::try_from(C::default()).expect("a scenario configuration is a table");
    let mut merged = defaults.clone();
    let mut origin = Vec::new();
    for (source, layer) in layers {
        for (key, value) in layer {
            if !own.contains(key) {
                let owners: Vec<&str> = others
                    .iter()
                    .filter(|(_, k)| k.contains(key))
                    .map(|(name, _)| *name)
                    .collect();
                return Err(InputError::new(if owners.is_empty() {
                    format!(
                        "unknown key '{key}' in {source}; {} has the keys {}",
                        C::NAME,
                        own.join(", ")
                    )
                } else {
                    format!(
                        "'{key}' ({source}) applies to {} only; {} has no such parameter",
                        owners.join(", "),
                        C::NAME
                    )
                }));
            }
            merged.insert(key.clone(), value.clone());
            origin.push((key, value, source));
        }
    }
    let config: C = parse(merged).map_err(|e| {
        // Name the first key whose value alone does not fit.
        let culprit = origin.iter().find(|(key, value, _)| {
            let mut one = defaults.clone();
            one.insert((*key).clone(), (*value).clone());
            parse::<C>(one).is_err()
        });
        InputError::new(match culprit {
            Some((key, value, source)) => format!(
                "{key} = {value} ({source}) is not a valid {} value: {}",
                C::NAME,
                e.message()
            ),
            None => format!("not a valid {} configuration: {}", C::NAME, e.message()),
        })
    })?;
    config.validate()?;
    Ok(config)
}

fn parse<C: Scenario>(table: Table) -> Result<C, toml::de::Error> {
    toml::Value::Table(table).try_into()
}
