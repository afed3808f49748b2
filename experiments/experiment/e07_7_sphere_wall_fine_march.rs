//! # 07-7 — the sphere wall, last ten frames gridless, fine march (fig 7.7)
//!
//! Reproduces the notes' figure 7.7 (§7.3): the holding of 07-6 (`F − k`
//! frames gridded, the last `k = F/6` gridless by eqs 7.1–7.4), rendered
//! with a fixed march step of a tenth of a velocity cell, above 07-6's
//! march of one cell: "the fine detail in the density field is now
//! resolved". Measured at 50³ × 60 frames: sharpness 5.86 grey levels²,
//! 17 % above 07-4's 5.00 and 16 % above 07-5's 5.07; the cell march of the
//! same holding differs from it by 0.57 grey levels rms (see 07-6).
//!
//! Size: the notes' set-up by default and at `--full` — a 50³ hot/cold
//! flow with the gases passing each other, 60 frames of Δt 0.1 (two solver
//! steps each) after 4.5 s of warm-up, 640×480 renders
//! ([`crate::experiment::shared::sphere_wall_series::figure_config`] says why this flow); 07-4,
//! 07-5, 07-6 took 29, 14, 83 s on 2 cores at a load of 2.
//! `--smoke`: 24³, 12 frames, 128×96 ([`crate::experiment::shared::sphere_wall_series::figure_config`]).
//!
//! Run: `smokelab experiment 07-7` (about 70 s; most of it the fine march).
//!
//! Writes `results/07-7/`: `figure.png` (rows: fixed step cell/10, the
//! figure; fixed step cell; the second minus the first, amplified ×50: the
//! detail the cell march aliases; full frames beside the 2× crop where
//! that difference's coherent part is largest, labelled), `render.png` (the first alone), `initial_final.png`,
//! `data.csv` and `manifest.json`.
//! `data.csv` has a row per panel (`panel` names it): frames gridded and
//! gridless, march step and jitter, render seconds and samples, density
//! bytes, mass and mean row peak kept at 2× sampling, the gridded part's
//! mass factors, `sharpness` (the gradient energy of the picture, mean
//! squared luma difference of neighbouring pixels, grey levels²,
//! [`smokelab::metrics::picture`]), and against the fine fixed march of the
//! same holding where the experiment renders one: `error_rms`,
//! `coherent_error` (the rms of the part of the error coherent between
//! neighbouring pixels, √ of its lag-1 autocovariance: a pattern such as
//! banding keeps it, per-pixel noise such as the jitter's does not) and
//! `coherent_share`.

use anyhow::Result;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::sphere_wall_series::{last_sixth_picture, run_picture, March};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "07-7",
    folder: "07-7",
    reproduces: "fig 7.7",
    title: "sphere wall, last sixth of the frames gridless, march step = cell/10",
    cost: "~2.5 min",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    let marches = [March::FINE, March::CELL];
    run_picture(ctx, last_sixth_picture(ctx, "07-7 (fig 7.7)", &marches))
}
