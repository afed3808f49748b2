//! Numbered experiments, one file each, named after the figure of the notes
//! they reproduce (`06_1_…` → figs 6.1–6.2). Each file opens with what it
//! reproduces, how to run it, what it costs and what it writes.
//!
//! Run one with `smokelab experiment <id>`; list them with
//! `smokelab experiment --list`. Every experiment writes its images,
//! `data.csv` or `metrics.csv`, and `manifest.json` into a new folder under
//! `runs/`, or with `--publish` into the committed `results/<id>/`.

use anyhow::Result;

use smokelab::error::InputError;

use crate::experiment::kit::Experiment;

/// Every experiment, in the notes' order.
pub const ALL: &[Experiment] = &[
    crate::experiment::e03_2_pyroclastic_spheres::EXPERIMENT,
    crate::experiment::e03_3_cloud_layers::EXPERIMENT,
    crate::experiment::e03_4_billow::GEOMETRY,
    crate::experiment::e03_4_billow::RENDERS,
    crate::experiment::e03_7_cloud_advection::EXPERIMENT,
    crate::experiment::e03_8_spatial_control::EXPERIMENT,
    crate::experiment::e04_1_nacelle_warp::EXPERIMENT,
    crate::experiment::e04_2_texture_transfer::EXPERIMENT,
    crate::experiment::e05_1_cut_sphere::EXPERIMENT,
    crate::experiment::e06_1_hot_cold_gridded::EXPERIMENT,
    crate::experiment::e06_3_hot_cold_gridless::EXPERIMENT,
    crate::experiment::e06_5_density_modes::EXPERIMENT,
    crate::experiment::s1_symmetry::EXPERIMENT,
    crate::experiment::e06_6_slab_box::EXPERIMENT,
    crate::experiment::e07_2_gridless_noise_step::EXPERIMENT,
    crate::experiment::e07_4_sphere_wall_gridded::EXPERIMENT,
    crate::experiment::e07_5_sphere_wall_last_gridless::EXPERIMENT,
    crate::experiment::e07_6_sphere_wall_aliased::EXPERIMENT,
    crate::experiment::e07_7_sphere_wall_fine_march::EXPERIMENT,
    crate::experiment::e07_8_sphere_wall_gridless::EXPERIMENT,
    crate::experiment::e07_10_gridless_cost::EXPERIMENT,
    crate::experiment::e08_1_sphere_wall_selma::EXPERIMENT,
    crate::experiment::e08_2_selma_cost::EXPERIMENT,
    crate::experiment::e08_3_selma_wake::EXPERIMENT,
    crate::experiment::ea_1_henyey_greenstein::EXPERIMENT,
    crate::experiment::ea_2_fournier_forand::EXPERIMENT,
    crate::experiment::en_3_simulation_noise_2d::EXPERIMENT,
    crate::experiment::en_4_artist_spline::EXPERIMENT,
    crate::experiment::ec_1_convergence::EXPERIMENT,
    crate::experiment::ep_1_perf::EXPERIMENT,
    crate::experiment::ev_1_validation::EXPERIMENT,
];

/// The experiments that run peer programs with `--peers PYTHON`
/// ([`crate::experiment::kit::Context::peers`]).
pub const WITH_PEERS: &[&str] = &[crate::experiment::ep_1_perf::EXPERIMENT.id];

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
