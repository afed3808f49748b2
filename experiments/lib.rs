//! # smokelab-app
//!
//! The application on top of the `smokelab` library: the command line, the
//! run driver, the numbered experiments that reproduce the notes' figures,
//! the convergence cases, plots and the paper builder. It may use everything
//! in the library; the library uses none of it (see `ARCHITECTURE.md`).

// Commands and the run driver.
pub mod cli;
mod resume;
mod experiment_all;
pub mod run;
pub mod checkpoint;
pub mod frames;
pub mod export;
pub mod render_command;
pub mod noise_command;
pub mod paper;
pub mod paper_values;
pub mod gallery;
pub mod claims;
pub mod progress;
pub mod output_dir;
pub mod memory;
pub mod script;
pub mod sweep;

// Figures and tables.
pub mod plot;
pub mod panels;
pub mod table;
pub mod growth;

// Numbered experiments: the registry, their shared pieces, one file each.
pub mod registry;
pub mod convergence_cases;
mod density_compare;
mod sphere_wall_series;
mod render_difference;
mod model_render;
mod cloud_figures;
mod warp_figures;
mod e03_3_cloud_layers;
mod e03_4_billow;
mod e03_7_cloud_advection;
mod e03_8_spatial_control;
mod e03_2_pyroclastic_spheres;
mod e04_1_nacelle_warp;
mod e04_2_texture_transfer;
mod e05_1_cut_sphere;
mod e06_1_hot_cold_gridded;
mod e06_3_hot_cold_gridless;
mod e06_5_density_modes;
mod s1_symmetry;
mod e06_6_slab_box;
mod e07_10_gridless_cost;
mod e07_2_gridless_noise_step;
mod e07_4_sphere_wall_gridded;
mod e07_5_sphere_wall_last_gridless;
mod e07_6_sphere_wall_aliased;
mod e07_7_sphere_wall_fine_march;
mod e07_8_sphere_wall_gridless;
mod e08_1_sphere_wall_selma;
mod e08_2_selma_cost;
mod e08_3_selma_wake;
mod ea_1_henyey_greenstein;
mod ea_2_fournier_forand;
mod ec_1_convergence;
mod ev_1_validation;
pub mod ep_1_perf;
mod en_3_simulation_noise_2d;
mod en_4_artist_spline;
