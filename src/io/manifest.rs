//! `manifest.json`: what ran, where, with what, and what it cost.

use serde::Serialize;

/// Facts about the machine and build a result came from.
#[derive(Clone, Debug, Serialize)]
pub struct Machine {
    /// CPU model string from `/proc/cpuinfo`.
    pub cpu: String,
    /// Logical cores visible to the process.
    pub cores: usize,
    /// Rayon worker threads used.
    pub threads: usize,
    /// Operating system.
    pub os: String,
    /// The instruction set the semi-Lagrangian kernel ran on
    /// ([`crate::simd::Isa::selected`]: `scalar`, `neon`, `avx2` or
    /// `avx512`; `SMOKELAB_SIMD` overrides the widest).
    pub simd: crate::simd::Isa,
}

impl Machine {
    /// Read the current machine.
    pub fn current() -> Self {
        let cpu = std::fs::read_to_string("/proc/cpuinfo")
            .ok()
            .and_then(|s| {
                s.lines()
                    .find(|l| l.starts_with("model name"))
                    .and_then(|l| l.split(':').nth(1))
                    .map(|m| m.trim().to_string())
            })
            .unwrap_or_else(|| "unknown".into());
        Self {
            cpu,
            cores: std::thread::available_parallelism().map_or(1, |n| n.get()),
            threads: rayon::current_num_threads(),
            os: std::env::consts::OS.into(),
            simd: crate::simd::Isa::selected(),
        }
    }
}

/// The git commit this library was built from, with `-dirty` when tracked
/// files differed from it (recorded by `build.rs`; `unknown` outside a git
/// checkout). Unlike asking git at run time, this names the code that ran,
/// wherever the run is started.
pub const BUILD_COMMIT: &str = env!("SMOKELAB_COMMIT");

/// Whether the work a manifest describes has finished: a run writes its
/// manifest `running` at the start and `complete` at the end, or `failed`
/// (with the error in `extra.error`) when it stops on an error, so a
/// manifest that still says `running` belongs to a run that was killed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Status {
    /// Started, not finished (yet).
    Running,
    /// Finished; every output is written.
    Complete,
    /// Stopped on an error; the outputs written before it stay.
    Failed,
}

/// The manifest written beside every run's outputs.
#[derive(Clone, Debug, Serialize)]
pub struct Manifest<C: Serialize> {
    /// Whether the work has finished.
    pub status: Status,
    /// smokelab version.
    pub version: &'static str,
    /// git commit of the build (see [`BUILD_COMMIT`]).
    pub commit: String,
    /// Command line that produced the run.
    pub command: String,
    /// The resolved configuration.
    pub config: C,
    /// Random seed.
    pub seed: u64,
    /// Machine facts.
    pub machine: Machine,
    /// Wall time of the whole run in seconds.
    pub wall_seconds: f64,
    /// Peak resident memory in bytes (`VmHWM`), if known.
    pub peak_memory_bytes: Option<u64>,
    /// Anything else the run wants to record (per-stage totals, render stats…).
    pub extra: serde_json::Value,
}

impl<C: Serialize> Manifest<C> {
    /// The manifest of finished work on `config`, filled with the current
    /// machine and commit.
    pub fn new(config: C, seed: u64, wall_seconds: f64, extra: serde_json::Value) -> Self {
        Self {
            status: Status::Complete,
            version: env!("CARGO_PKG_VERSION"),
            commit: BUILD_COMMIT.to_string(),
            command: std::env::args().collect::<Vec<_>>().join(" "),
            config,
            seed,
            machine: Machine::current(),
            wall_seconds,
            peak_memory_bytes: crate::timing::peak_rss_bytes(),
            extra,
        }
    }

    /// The manifest of work on `config` that stopped after `wall_seconds`
    /// on `error`, recorded as `extra.error`.
    pub fn failed(config: C, seed: u64, wall_seconds: f64, error: String) -> Self {
        Self {
            status: Status::Failed,
            ..Self::new(
                config,
                seed,
                wall_seconds,
                serde_json::json!({ "error": error }),
            )
        }
    }

    /// The manifest of work on `config` that has just started.
    pub fn running(config: C, seed: u64, extra: serde_json::Value) -> Self {
        Self {
            status: Status::Running,
            ..Self::new(config, seed, 0.0, extra)
        }
    }
}
