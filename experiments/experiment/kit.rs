//! The kit every experiment is written with: how big a run to make
//! ([`Size`]), where and how it runs ([`Context`]), and the entry it
//! registers ([`Experiment`]). The registry
//! ([`crate::experiment::registry`]) lists the entries; an experiment file
//! imports this kit and never the registry, so neither imports the other.

use std::path::PathBuf;
use std::time::Instant;

use anyhow::Result;
use serde::Serialize;
use smokelab::io::{self, manifest::Manifest};

/// How big a run to make.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Size {
    /// Tiny, seconds: for the test suite.
    Smoke,
    /// Cheap default: a couple of minutes at most on 2 cores.
    Default,
    /// The notes' sizes.
    Full,
}

impl Size {
    /// The one of `smoke`, `default` and `full` that belongs to this size:
    /// how every experiment picks its grid, frames and pixels.
    pub fn pick<T>(self, smoke: T, default: T, full: T) -> T {
        match self {
            Size::Smoke => smoke,
            Size::Default => default,
            Size::Full => full,
        }
    }
}

/// Where and how an experiment runs.
#[derive(Clone, Debug)]
pub struct Context {
    /// Output folder (created by the experiment after validating its input).
    pub out: PathBuf,
    /// Run size.
    pub size: Size,
    /// Show progress bars.
    pub progress: bool,
    /// The Python that runs the peer programs an experiment measures
    /// itself against (`--peers PYTHON`; [`crate::experiment::registry::WITH_PEERS`]
    /// lists the experiments that have any, the others ignore it).
    pub peers: Option<PathBuf>,
}

impl Context {
    /// Write the experiment's `manifest.json` into its output folder: the
    /// configuration, the seed, the seconds since `start` and anything
    /// else it records (`extra`), with the machine and commit
    /// ([`Manifest::new`]).
    ///
    /// # Errors
    /// A failed write.
    pub fn write_manifest(
        &self,
        config: impl Serialize,
        seed: u64,
        start: Instant,
        extra: serde_json::Value,
    ) -> Result<()> {
        let seconds = start.elapsed().as_secs_f64();
        io::write_json(
            &self.out.join("manifest.json"),
            &Manifest::new(config, seed, seconds, extra),
        )
    }
}

/// A registered experiment.
pub struct Experiment {
    /// Id used on the command line, e.g. `06-1`.
    pub id: &'static str,
    /// Folder under `results/` it writes to by default (usually the id).
    pub folder: &'static str,
    /// The figures of the notes it reproduces.
    pub reproduces: &'static str,
    /// One line on what it shows.
    pub title: &'static str,
    /// Expected cost of the default run.
    pub cost: &'static str,
    /// Entry point.
    pub run: fn(&Context) -> Result<()>,
}
