//! Numbered experiments, one file each, named after the figure of the notes
//! they reproduce (`06_1_…` → figs 6.1–6.2). Each file opens with what it
//! reproduces, how to run it, what it costs and what it writes.
//!
//! Run one with `smokelab experiment <id>`; list them with
//! `smokelab experiment --list`. Every experiment writes into `results/<id>/`
//! by default: images, `data.csv` or `metrics.csv`, and `manifest.json`.

use std::path::PathBuf;

use anyhow::Result;

use smokelab::error::InputError;

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
    crate::e03_2_pyroclastic_spheres::EXPERIMENT,
    crate::e03_3_cloud_layers::EXPERIMENT,
    crate::e03_4_billow::GEOMETRY,
    crate::e03_4_billow::RENDERS,
    crate::e03_7_cloud_advection::EXPERIMENT,
    crate::e03_8_spatial_control::EXPERIMENT,
    crate::e04_1_nacelle_warp::EXPERIMENT,
    crate::e04_2_texture_transfer::EXPERIMENT,
    crate::e05_1_cut_sphere::EXPERIMENT,
    crate::e06_1_hot_cold_gridded::EXPERIMENT,
    crate::e06_3_hot_cold_gridless::EXPERIMENT,
    crate::e06_5_density_modes::EXPERIMENT,
    crate::s1_symmetry::EXPERIMENT,
    crate::e06_6_slab_box::EXPERIMENT,
    crate::e07_2_gridless_noise_step::EXPERIMENT,
    crate::e07_4_sphere_wall_gridded::EXPERIMENT,
    crate::e07_5_sphere_wall_last_gridless::EXPERIMENT,
    crate::e07_6_sphere_wall_aliased::EXPERIMENT,
    crate::e07_7_sphere_wall_fine_march::EXPERIMENT,
    crate::e07_8_sphere_wall_gridless::EXPERIMENT,
    crate::e07_10_gridless_cost::EXPERIMENT,
    crate::e08_1_sphere_wall_selma::EXPERIMENT,
    crate::e08_2_selma_cost::EXPERIMENT,
    crate::e08_3_selma_wake::EXPERIMENT,
    crate::ea_1_henyey_greenstein::EXPERIMENT,
    crate::ea_2_fournier_forand::EXPERIMENT,
    crate::en_3_simulation_noise_2d::EXPERIMENT,
    crate::en_4_artist_spline::EXPERIMENT,
    crate::ec_1_convergence::EXPERIMENT,
    crate::ep_1_perf::EXPERIMENT,
    crate::ev_1_validation::EXPERIMENT,
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
