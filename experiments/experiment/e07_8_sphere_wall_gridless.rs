//! # 07-8 — the sphere wall, every frame gridless (fig 7.8)
//!
//! Reproduces the notes' figure 7.8 (§7.3): the analytic wall composed with
//! the gridless backward map through all `F` recorded velocities,
//! `ρ_F = ρ₀ ∘ B_1 ∘ … ∘ B_F` (eqs 7.1–7.4), never sampled on a grid, and
//! rendered with a march step of a tenth of a velocity cell. The notes:
//! gridless advection "generates structures in the volume that have more
//! spatial detail than the original density distribution or velocity
//! field", without changing the gross motion.
//!
//! Run: `smokelab experiment 07-8` (about 70 s on 2 cores: a 30-step chain
//! at every march sample of a 320×240 image, 32³ flow; `--full` 50³, 60
//! frames, 640×480 — tens of minutes).
//!
//! Writes `results/07-8/`: `render.png`, `figure.png` (the render beside its middle half 2×,
//! labelled), `initial_final.png`, `data.csv`
//! (as 07-4; the bytes are the `F` stored velocity grids) and
//! `manifest.json`.

use anyhow::Result;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::sphere_wall_series::{fine_picture, run_picture, Holding};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "07-8",
    folder: "07-8",
    reproduces: "fig 7.8",
    title: "sphere wall, every frame gridless, march step = cell/10",
    cost: "~70 s",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    let title = |f| format!("07-8 (fig 7.8): {f} frames gridless");
    run_picture(
        ctx,
        fine_picture(ctx, title, Holding::Gridless { frames: usize::MAX }),
    )
}
