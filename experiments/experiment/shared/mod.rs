//! What several experiments share: figure builders for a family of
//! experiments (clouds, warps, the sphere-wall series, density modes),
//! the convergence cases, the Taylor–Green Re 1600 benchmark, and measuring
//! tools (growth fits, memory, the Python module's step).

pub(super) mod cloud_figures;
pub mod convergence_cases;
pub(super) mod density_compare;
pub mod growth;
pub mod memory;
pub(super) mod model_render;
pub(super) mod python_step;
pub(super) mod sphere_wall_series;
pub(super) mod turbulence_benchmark;
pub(super) mod warp_figures;
