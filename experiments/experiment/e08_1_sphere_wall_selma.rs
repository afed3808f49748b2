//! # 08-1 — the sphere wall advected by SELMA (fig 8.1)
//!
//! Reproduces the notes' figure 8.1 (§8): the backward map `X` advected and
//! resampled on the velocity grid every frame, eq 8.8
//! `X_n(x) = X_{n−1}(B_n(x))` (the notes' `XmapCache`; no source, no
//! re-anchoring), and the analytic wall composed with it,
//! `ρ_F = ρ₀ ∘ X_F`, rendered with a march step of a tenth of a velocity
//! cell. The notes: "the highly detailed result", at constant memory and
//! query cost.
//!
//! Run: `smokelab experiment 08-1` (about 7 s on 2 cores: 32³, 30 frames,
//! 320×240; `--full` 50³, 60 frames, 640×480).
//!
//! Writes `results/08-1/`: `render.png`, `figure.png` (the render beside its middle half 2×,
//! labelled), `initial_final.png`, `data.csv`
//! (as 07-4; the bytes are the SELMA model's grids: map, scratch, tracked
//! lattice, reference density and cell-centre cache) and `manifest.json`.

use anyhow::Result;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::sphere_wall_series::{fine_picture, run_picture, Holding};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "08-1",
    folder: "08-1",
    reproduces: "fig 8.1",
    title: "sphere wall, every frame SELMA, march step = cell/10",
    cost: "~7 s",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    let title = |f| format!("08-1 (fig 8.1): {f} frames SELMA");
    run_picture(ctx, fine_picture(ctx, title, Holding::Selma { factor: 1 }))
}
