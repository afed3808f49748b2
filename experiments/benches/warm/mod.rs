//! The state the solver and metrics benchmarks time: a hot/cold simulation
//! stepped until the gases move.

use smokelab::advection::Backtrace;
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::{Scenario, SolverConfig};
use smokelab::simulation::Simulation;

/// A hot/cold simulation at `res`³ with the `backtrace`, after 40 steps.
pub fn hot_cold(res: usize, backtrace: Backtrace) -> Simulation {
    let config = HotColdConfig {
        solver: SolverConfig {
            res,
            backtrace,
            ..SolverConfig::default()
        },
        ..Default::default()
    };
    let mut sim = config.build().expect("valid config");
    for _ in 0..40 {
        sim.step();
    }
    sim
}
