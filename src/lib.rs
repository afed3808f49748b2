//! # smokelab
//!
//! Navier–Stokes smoke after Tessendorf & Kowalski, *Resolution Independent
//! Volumes*: a field is anything that can be queried at a point, a grid is a
//! field through interpolation, and the solver's step reads like the notes'
//! FELT script (advect, force, project).
//!
//! Modules in dependency order:
//! - [`error`] — user-facing input errors (exit code 2);
//! - [`domain`] — the box, cell size and index ↔ world conventions;
//! - [`field`] — scalar and vector fields, batch evaluation, combinators;
//! - [`grid`] — caches: trilinear `cacheread`, parallel `cachewrite`;
//! - [`advection`] — semi-Lagrangian (eqs 6.4–6.5) and QUICK;
//! - [`projection`] — FFT divergence-free projection with exact viscosity;
//! - [`metrics`] — divergence, mirror symmetry;
//! - [`boundary`] — level-set obstacles, reflecting and sticky rules (eqs 6.6–6.7);
//! - [`convergence`] — observed order of accuracy for convergence tests;
//! - [`density`] — gridded, gridless and SELMA densities (§6.2, ch. 7–8);
//! - [`noise`] — divergence-free noise velocities (simulation, curl, bitangent, spectral);
//! - [`timing`] — stage timers, peak memory;
//! - [`fit`] — least-squares straight lines (cost per frame);
//! - [`plot`] — line plots (PNG + SVG) for the experiments;
//! - [`simulation`] — the time step;
//! - [`scenario`] — hot/cold (§6.1.1), slab in a box (§6.3, fig 6.6);
//! - [`io`] — atomic `.npy`/PNG/JSON/CSV writers, manifests, previews;
//! - [`render`] — the volume ray marcher (appendix A), EXR/PNG output;
//! - [`run`] — driving a simulation through its frames;
//! - [`experiments`] — numbered reproductions of the notes' figures;
//! - [`paper`] — `paper/paper.md` refreshed from `results/`, built to HTML;
//! - [`cli`] — the `smokelab` command line.
//!
//! ```
//! use smokelab::scenario::hot_cold::HotColdConfig;
//! let config = HotColdConfig { res: 16, frames: 3, ..Default::default() };
//! let mut sim = config.build().unwrap();
//! for _ in 0..config.frames {
//!     sim.step();
//! }
//! let div = smokelab::metrics::divergence_stats(&sim.velocity);
//! assert!(div.max <= 1e-4 * sim.velocity.max_norm() / sim.domain().cell);
//! ```

pub mod advection;
pub mod boundary;
pub mod cli;
pub mod convergence;
pub mod density;
pub mod domain;
pub mod error;
#[path = "../experiments/mod.rs"]
pub mod experiments;
pub mod field;
pub mod fit;
pub mod grid;
pub mod io;
pub mod metrics;
pub mod noise;
pub mod paper;
pub mod plot;
pub mod pressure;
pub mod projection;
pub mod render;
pub mod run;
pub mod scenario;
pub mod simulation;
pub mod timing;
