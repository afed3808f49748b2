//! # 07-5 — the sphere wall, gridded but for one last gridless frame (fig 7.5)
//!
//! Reproduces the notes' figure 7.5 (§7.3): the wall of 07-4 advected and
//! resampled on the grid for all frames but the last, which is one step of
//! gridless advection, eq 7.1, `ρ_F(x) = ρ_{F−1}(x − u(x)Δt)` — the grid
//! of frame `F − 1` composed with the last recorded velocity's backtrace
//! and never resampled. The notes: "the edges of filaments have been subtly
//! sharpened".
//!
//! Run: `smokelab experiment 07-5` (about 3 s on 2 cores; sizes as 07-4:
//! 32³, 30 frames, 320×240 by default, `--full` 50³ and 60 frames at
//! 640×480). March step: one velocity cell.
//!
//! Writes `results/07-5/`: `render.png`, `initial_final.png`, `data.csv`
//! (as 07-4; the bytes now include the one stored velocity grid) and
//! `manifest.json`.

use anyhow::Result;

use crate::registry::{Context, Experiment};
use crate::sphere_wall_series::{run_picture, Holding};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "07-5",
    folder: "07-5",
    reproduces: "fig 7.5",
    title: "sphere wall, all frames gridded but the last, which is gridless",
    cost: "~3 s",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    run_picture(ctx, Holding::Gridless { frames: 1 }, 1.0)
}
