//! The numbered experiments, one file each, named after the figure of the
//! notes they reproduce (`e06_1_…` → figs 6.1–6.2), with the kit they are
//! written with ([`kit`]), the registry that lists them ([`registry`]) and
//! the helpers several of them share ([`shared`]). An experiment file is
//! private to this room: the rest of the application reaches it only
//! through the registry, and no experiment imports another.

pub mod kit;
pub mod registry;
pub mod shared;

mod e03_2_pyroclastic_spheres;
mod e03_3_cloud_layers;
mod e03_4_billow;
mod e03_7_cloud_advection;
mod e03_8_spatial_control;
mod e04_1_nacelle_warp;
mod e04_2_texture_transfer;
mod e05_1_cut_sphere;
mod e06_1_hot_cold_gridded;
mod e06_3_hot_cold_gridless;
mod e06_5_density_modes;
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
mod en_3_simulation_noise_2d;
mod en_4_artist_spline;
mod ep_1_perf;
mod ev_1_validation;
mod s1_symmetry;
