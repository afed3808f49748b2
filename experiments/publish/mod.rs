//! Publishing: `smokelab paper` (the paper refreshed from `results/`, its
//! values and claims) and `smokelab gallery` (`results/index.html`).

pub mod claims;
pub mod gallery;
pub mod paper;
pub mod paper_values;
