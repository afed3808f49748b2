//! # 07-6 — the sphere wall, last ten frames gridless, coarse march (fig 7.6)
//!
//! Reproduces the notes' figure 7.6 (§7.3): the wall gridded for the first
//! `F − k` frames, then `k` frames of gridless advection (eqs 7.1–7.4: the
//! grid of frame `F − k` composed with the backward map through the last
//! `k` recorded velocities), rendered with a march step of one velocity
//! cell. The gridless frames sharpen the density below the march step, and
//! the render aliases: "the detail is finer than the raymarch stepping".
//! The notes' 50 + 10 of 60 frames is `k = F/6`: 10 at `--full`, 5 of 30 by
//! default, 1 of 6 at `--smoke`.
//!
//! Run: `smokelab experiment 07-6` (about 5 s on 2 cores: 32³, 30 frames,
//! 320×240; `--full` 50³, 60 frames, 640×480).
//!
//! Writes `results/07-6/`: `render.png`, `initial_final.png`, `data.csv`
//! (as 07-4; bytes include the `k` stored velocity grids) and
//! `manifest.json`.

use anyhow::Result;

use crate::registry::{Context, Experiment};
use crate::sphere_wall_series::{config, run_picture, Holding};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "07-6",
    folder: "07-6",
    reproduces: "fig 7.6",
    title: "sphere wall, last sixth of the frames gridless, march step = cell (aliasing)",
    cost: "~5 s",
    run,
};

/// Gridless frames at the end of the run: the notes' 10 of 60.
pub(crate) fn last_sixth(ctx: &Context) -> usize {
    (config(ctx.size).frames / 6).max(1)
}

fn run(ctx: &Context) -> Result<()> {
    run_picture(
        ctx,
        Holding::Gridless {
            frames: last_sixth(ctx),
        },
        1.0,
    )
}
