//! Numbered experiments, one file each, named after the figure of the notes
//! they reproduce (`06_1_…` → figs 6.1–6.2). Each file opens with what it
//! reproduces, how to run it, what it costs and what it writes.
//!
//! Run one with `smokelab experiment <id>`; list them with
//! `smokelab experiment --list`. Every experiment writes into `results/<id>/`
//! by default: images, `data.csv` or `metrics.csv`, and `manifest.json`.

#[path = "N_4_artist_spline.rs"]
mod artist_spline;
#[path = "C_1_convergence.rs"]
mod convergence;
#[path = "density_compare.rs"]
mod density_compare;
#[path = "06_5_density_modes.rs"]
mod density_modes;
#[path = "A_2_fournier_forand.rs"]
mod fournier_forand;
#[path = "07_10_gridless_cost.rs"]
mod gridless_cost;
#[path = "07_2_gridless_noise_step.rs"]
mod gridless_noise_step;
#[path = "A_1_henyey_greenstein.rs"]
mod henyey_greenstein;
#[path = "06_1_hot_cold_gridded.rs"]
mod hot_cold_gridded;
#[path = "06_3_hot_cold_gridless.rs"]
mod hot_cold_gridless;
#[path = "08_2_selma_cost.rs"]
mod selma_cost;
#[path = "N_3_simulation_noise_2d.rs"]
mod simulation_noise_2d;
#[path = "06_6_slab_box.rs"]
mod slab_box;
#[path = "07_6_sphere_wall_aliased.rs"]
mod sphere_wall_aliased;
#[path = "07_7_sphere_wall_fine_march.rs"]
mod sphere_wall_fine_march;
#[path = "07_4_sphere_wall_gridded.rs"]
mod sphere_wall_gridded;
#[path = "07_8_sphere_wall_gridless.rs"]
mod sphere_wall_gridless;
#[path = "07_5_sphere_wall_last_gridless.rs"]
mod sphere_wall_last_gridless;
#[path = "08_1_sphere_wall_selma.rs"]
mod sphere_wall_selma;
#[path = "sphere_wall_series.rs"]
mod sphere_wall_series;

use std::path::PathBuf;

use anyhow::Result;

use crate::error::InputError;

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

/// Where and how an experiment runs.
#[derive(Clone, Debug)]
pub struct Context {
    /// Output folder (created by the experiment after validating its input).
    pub out: PathBuf,
    /// Run size.
    pub size: Size,
    /// Show progress bars.
    pub progress: bool,
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

/// Every experiment, in the notes' order.
pub const ALL: &[Experiment] = &[
    hot_cold_gridded::EXPERIMENT,
    hot_cold_gridless::EXPERIMENT,
    density_modes::EXPERIMENT,
    slab_box::EXPERIMENT,
    gridless_noise_step::EXPERIMENT,
    sphere_wall_gridded::EXPERIMENT,
    sphere_wall_last_gridless::EXPERIMENT,
    sphere_wall_aliased::EXPERIMENT,
    sphere_wall_fine_march::EXPERIMENT,
    sphere_wall_gridless::EXPERIMENT,
    gridless_cost::EXPERIMENT,
    sphere_wall_selma::EXPERIMENT,
    selma_cost::EXPERIMENT,
    henyey_greenstein::EXPERIMENT,
    fournier_forand::EXPERIMENT,
    simulation_noise_2d::EXPERIMENT,
    artist_spline::EXPERIMENT,
    convergence::EXPERIMENT,
];

/// The ids of all experiments.
pub fn ids() -> Vec<&'static str> {
    ALL.iter().map(|e| e.id).collect()
}

/// The experiment with this id.
pub fn find(id: &str) -> Result<&'static Experiment, InputError> {
    ALL.iter().find(|e| e.id == id).ok_or_else(|| {
        InputError::new(format!(
            "unknown experiment id '{id}'; known ids: {}",
            ids().join(", ")
        ))
    })
}

/// A table of the experiments for `--list`, columns as wide as their entries.
pub fn listing() -> String {
    let w_rep = ALL
        .iter()
        .map(|e| e.reproduces.chars().count())
        .max()
        .unwrap_or(0)
        .max(10);
    let w_cost = ALL
        .iter()
        .map(|e| e.cost.chars().count())
        .max()
        .unwrap_or(0)
        .max(4);
    let mut s = format!(
        "{:<7} {:<w_rep$} {:<w_cost$} {}\n",
        "id", "reproduces", "cost", "what"
    );
    for e in ALL {
        s.push_str(&format!(
            "{:<7} {:<w_rep$} {:<w_cost$} {}\n",
            e.id, e.reproduces, e.cost, e.title
        ));
    }
    s
}
