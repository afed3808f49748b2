//! # smokelab
//!
//! Navier–Stokes smoke after Tessendorf & Kowalski, *Resolution Independent
//! Volumes*: a field is anything that can be queried at a point, a grid is a
//! field through interpolation, and the solver's step reads like the notes'
//! FELT script (advect, force, project).
//!
//! The library holds the science only; the `smokelab` command line, the run
//! driver, the numbered experiments, plots and the paper live in the
//! application crate under `experiments/` (see `ARCHITECTURE.md`).
//!
//! The modules below are declared in dependency order: each uses only those
//! above it.
//!
//! ```
//! use smokelab::scenario::hot_cold::HotColdConfig;
//! use smokelab::scenario::{Scenario, SolverConfig};
//! let solver = SolverConfig { res: 16, frames: 3, ..Default::default() };
//! let config = HotColdConfig { solver, ..Default::default() };
//! let mut sim = config.build().unwrap();
//! for _ in 0..config.solver.frames {
//!     sim.step();
//! }
//! let div = smokelab::metrics::velocity_stats(&sim.velocity).divergence;
//! assert!(div.max <= 1e-4 * sim.velocity.max_norm() / sim.domain().cell);
//! ```

pub mod error;
pub mod domain;
pub mod field;
pub mod grid;
pub mod fit;
pub mod timing;
pub mod simd;
pub mod io;
pub mod pressure;
pub mod advection;
pub mod forces;
pub mod confinement;
pub mod metrics;
pub mod boundary;
pub mod density;
pub mod noise;
pub mod model;
pub mod simulation;
pub mod scenario;
pub mod render;
