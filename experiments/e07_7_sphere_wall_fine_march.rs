//! # 07-7 — the sphere wall, last ten frames gridless, fine march (fig 7.7)
//!
//! Reproduces the notes' figure 7.7 (§7.3): the holding of 07-6 (`F − k`
//! frames gridded, the last `k = F/6` gridless by eqs 7.1–7.4), rendered
//! with a march step of a tenth of a velocity cell: "the fine detail in the
//! density field is now resolved".
//!
//! Run: `smokelab experiment 07-7` (about 20 s on 2 cores: 32³, 30 frames
//! with the last 5 gridless, 320×240; `--full` 50³, 60 frames with 10
//! gridless, 640×480).
//!
//! Writes `results/07-7/`: `render.png`, `initial_final.png`, `data.csv`
//! (as 07-4) and `manifest.json`.

use anyhow::Result;

use crate::e07_6_sphere_wall_aliased::last_sixth;
use crate::registry::{Context, Experiment};
use crate::sphere_wall_series::{run_picture, Holding};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "07-7",
    folder: "07-7",
    reproduces: "fig 7.7",
    title: "sphere wall, last sixth of the frames gridless, march step = cell/10",
    cost: "~20 s",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    run_picture(
        ctx,
        Holding::Gridless {
            frames: last_sixth(ctx),
        },
        10.0,
    )
}
