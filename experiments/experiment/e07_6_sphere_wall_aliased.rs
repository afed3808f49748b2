//! # 07-6 — the sphere wall, last ten frames gridless, coarse march (fig 7.6)
//!
//! Reproduces the notes' figure 7.6 (§7.3): the wall gridded for the first
//! `F − k` frames, then `k` frames of gridless advection (eqs 7.1–7.4: the
//! grid of frame `F − k` composed with the backward map through the last
//! `k` recorded velocities), rendered with the notes' coarse march, a fixed
//! step of one velocity cell with every sub-step sampled at its midpoint:
//! "the detail is finer than the raymarch stepping, causing significant
//! aliasing in the render". Beside it the same march jittered (eq A.29),
//! which turns a pattern into noise, and the fine fixed march of 07-7, the
//! reference of both. The notes' 50 + 10 of 60 frames is `k = F/6`: 10 by
//! default, 2 of 12 at `--smoke`.
//!
//! The aliasing is measured apart from noise by how the error against the
//! fine march is spread (`coherent_error`, module doc of
//! [`smokelab::metrics::picture`]). The flow is the passing hot/cold run
//! with Δt 0.1 per frame ([`crate::experiment::shared::sphere_wall_series::figure_config`]);
//! with the former head-on flow at Δt 0.05 the ten gridless frames added
//! only 12 % coherent error over 07-4's gridded wall (0.35 against 0.32
//! grey levels): they did not compress the detail below the march step.
//! Measured now at 50³ × 60 frames (`smokelab experiment 07-4`, `07-6`):
//! the fixed march's error is 0.57
//! grey levels rms, 82 % of its energy coherent (0.52 coherent), 2.3×
//! the gridded 07-4's 0.22 under the same march and 2.4× the jittered
//! march's 0.22 (its error noise). The aliasing is measured clearly but is
//! still small in grey levels: in the renders it shows as faint streaks
//! along the filaments of the crops, not as the notes' "significant"
//! aliasing. The figure therefore adds each march's error against the
//! fine one, amplified (×50 fixed, ×20 jittered at the default size): the
//! fixed step's is bands, orange and blue stripes across the folded
//! filaments; the jittered step's is grain spread over the whole wall. The
//! crops are taken where the fixed step's coherent error is largest.
//!
//! Size: the notes' set-up by default and at `--full` — a 50³ hot/cold
//! flow with the gases passing each other, 60 frames of Δt 0.1 (two solver
//! steps each) after 4.5 s of warm-up, 640×480 renders
//! ([`crate::experiment::shared::sphere_wall_series::figure_config`] says why this flow); 07-4,
//! 07-5, 07-6 took 29, 14, 83 s on 2 cores at a load of 2.
//! `--smoke`: 24³, 12 frames, 128×96 ([`crate::experiment::shared::sphere_wall_series::figure_config`]).
//!
//! Run: `smokelab experiment 07-6` (83 s; most of it the fine march).
//!
//! Writes `results/07-6/`: `figure.png` (rows: fixed step cell, the figure;
//! jittered step cell; fixed step cell/10; the first two minus the third,
//! amplified; full frames beside the 2× crop where the fixed step's
//! coherent error is largest, labelled), `render.png` (the first alone), `initial_final.png`,
//! `data.csv` (bytes include the `k` stored velocity grids) and
//! `manifest.json`.
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
    id: "07-6",
    folder: "07-6",
    reproduces: "fig 7.6",
    title: "sphere wall, last sixth of the frames gridless, march step = cell (aliasing)",
    cost: "~3.5 min",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    let marches = [March::CELL, March::jittered(1.0), March::FINE];
    run_picture(ctx, last_sixth_picture(ctx, "07-6 (fig 7.6)", &marches))
}
