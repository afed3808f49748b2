//! # smokelab-app
//!
//! The application on top of the `smokelab` library: the command line, the
//! run driver, the numbered experiments that reproduce the notes' figures,
//! their figures and the paper. It may use everything in the library; the
//! library uses none of it.
//!
//! The application lives in rooms, declared here from the bottom up: each
//! room uses only rooms declared above it (`tests/experiment_imports.rs`
//! keeps this true; `ARCHITECTURE.md` draws the map).

/// Figures and tables: plots, panels, CSV/Markdown tables, render
/// differences. Uses no other room.
pub mod figures;
/// The run driver: the step loop, saved frames and their VDB/ParaView
/// files, checkpoints, the output-folder rule, progress.
pub mod run;
/// Field scripts: the notes' FELT as Rhai (`smokelab script`).
pub mod script;
/// The numbered experiments: their kit, registry, shared helpers, one
/// file each.
pub mod experiment;
/// Publishing: the paper, its values and claims, the gallery.
pub mod publish;
/// The command line: one file per subcommand that has code of its own.
pub mod cli;
