//! # 07-5 — the sphere wall, gridded but for one last gridless frame (fig 7.5)
//!
//! Reproduces the notes' figure 7.5 (§7.3): the wall of 07-4 advected and
//! resampled on the grid for all frames but the last, which is one step of
//! gridless advection, eq 7.1, `ρ_F(x) = ρ_{F−1}(x − u(x)Δt)` — the grid
//! of frame `F − 1` composed with the last recorded velocity's backtrace
//! and never resampled — shown above 07-4's wall, both with the fixed cell
//! march. The notes: "the edges of filaments have been subtly sharpened".
//! Measured at 50³ × 60 frames: sharpness 5.07 against 07-4's 5.00 grey
//! levels² (+1.3 %) — sharper by the measure, subtly, as captioned; too
//! subtly to see side by side, even in the 2× crops. So the figure adds
//! their difference, 07-5 − 07-4 in luma amplified ×100 (orange brighter,
//! blue darker): one or two grey levels, in streaks along the filaments'
//! edges, and the crops are taken where it is largest.
//!
//! Size: the notes' set-up by default and at `--full` — a 50³ hot/cold
//! flow with the gases passing each other, 60 frames of Δt 0.1 (two solver
//! steps each) after 4.5 s of warm-up, 640×480 renders
//! ([`crate::experiment::shared::sphere_wall_series::figure_config`] says why this flow); 07-4,
//! 07-5, 07-6 took 29, 14, 83 s on 2 cores at a load of 2.
//! `--smoke`: 24³, 12 frames, 128×96 ([`crate::experiment::shared::sphere_wall_series::figure_config`]).
//!
//! Run: `smokelab experiment 07-5` (14 s).
//!
//! Writes `results/07-5/`: `figure.png` (rows: 59 gridded + 1 gridless,
//! the figure; 60 gridded, 07-4's; their difference amplified; full frames
//! beside the 2× crop where the difference is largest, labelled), `render.png` (the first alone), `initial_final.png`,
//! `data.csv` (the bytes include the one stored velocity grid; no fine
//! march, so no error columns) and `manifest.json`.
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
use crate::experiment::shared::sphere_wall_series::{
    figure_config, figure_size, run_compared, Difference, Holding, March, Panel, Picture,
};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "07-5",
    folder: "07-5",
    reproduces: "fig 7.5",
    title: "sphere wall, all frames gridded but the last, which is gridless",
    cost: "~45 s",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    let config = figure_config(ctx.size);
    let f = config.frames;
    let panel = |name: String, frames| Panel {
        name,
        holding: Holding::Gridless { frames },
        march: March::CELL,
    };
    run_compared(
        ctx,
        Picture {
            title: format!(
                "07-5 (fig 7.5) above 07-4 (fig 7.4) · {}",
                March::CELL.label()
            ),
            config,
            size: figure_size(ctx.size),
            panels: vec![
                panel(format!("{} gridded + 1 gridless", f - 1), 1),
                panel(format!("{f} gridded (07-4)"), 0),
            ],
        },
        vec![Difference {
            name: "07-5 − 07-4".into(),
            of: 0,
            minus: 1,
        }],
    )
}
