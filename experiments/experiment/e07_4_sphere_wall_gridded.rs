//! # 07-4 — the sphere wall advected and resampled every frame (figs 7.3–7.4)
//!
//! Reproduces the notes' figures 7.3 and 7.4 (§7.3): a wall of small balls
//! of density, one colour per row ([`smokelab::scenario::sphere_wall`]), moved
//! by the recorded velocity of a hot/cold run that does not know about it,
//! "advected and sampled to a grid every time step" — eq 6.4 without a
//! source, `ρ ← ρ(x − uΔt)` trilinear on the velocity grid, every frame —
//! and rendered with the notes' coarse march, a fixed step of one velocity
//! cell (eqs A.24–A.26, sub-steps at their midpoints), beside the fine
//! march of a tenth of a cell. The notes: "a substantial loss of density due
//! to numerical dissipation", and the wall "looks soft or diffused". Measured
//! at 50³ × 60 frames: the wall is soft
//! everywhere (sharpness 5.00 grey levels², the least of 07-4, 07-5, 07-7)
//! and the mean row peak keeps 56 % — the notes' loss of density, as a loss
//! of peak; the mass is gained, not lost (`mass_kept` 1.24: resampling is
//! not conservative). For the gridded density the cell march is close to
//! the fine one (coherent error 0.22 grey levels): the baseline of 07-6's
//! aliasing.
//!
//! Beside the notes' figure, the same wall advected every frame by
//! MacCormack (Selle et al. 2008, [`Holding::MacCormack`]) instead of
//! semi-Lagrangian, marched by the cell: the stronger gridded baseline the
//! gridless figures 07-5 … 07-7 are also to be judged against. Measured at
//! 50³ × 60 frames: sharper (5.00 → 7.10 grey levels²) and the mean row
//! peak keeps 84 % instead of 56 %, and it is sharper than 07-7's ten
//! gridless frames after fifty SL ones (5.99); but the mass grows ×1.86
//! (×1.84 from the advection alone, SL's ×1.23): neither scheme conserves
//! mass on these balls a few cells across.
//!
//! Size: the notes' set-up by default and at `--full` — a 50³ hot/cold
//! flow with the gases passing each other, 60 frames of Δt 0.1 (two solver
//! steps each) after 4.5 s of warm-up, 640×480 renders
//! ([`crate::experiment::shared::sphere_wall_series::figure_config`] says why this flow); 07-4,
//! 07-5, 07-6 took 29, 14, 83 s on 2 cores at a load of 2.
//! `--smoke`: 24³, 12 frames, 128×96 ([`crate::experiment::shared::sphere_wall_series::figure_config`]).
//!
//! Run: `smokelab experiment 07-4` (29 s; most of it the fine march).
//!
//! Writes `results/07-4/`: `figure.png` (rows: fixed step cell, the
//! figure; fixed step cell/10; MacCormack fixed step cell; the first's
//! difference from the cell/10 march amplified; each full frame beside the
//! 2× crop where that difference's coherent part is largest, labelled with
//! the frame, its time, the march and the scheme), `render.png` (the
//! first alone), `initial_final.png` (fig 7.3, the unadvected wall, beside
//! it, labelled), `data.csv` and `manifest.json`.
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
    figure_config, figure_size, run_picture, Holding, March, Panel, Picture,
};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "07-4",
    folder: "07-4",
    reproduces: "figs 7.3, 7.4",
    title: "sphere wall, every frame advected and resampled on the grid",
    cost: "~80 s",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    let config = figure_config(ctx.size);
    let gridded = Holding::Gridless { frames: 0 };
    run_picture(
        ctx,
        Picture {
            title: format!("07-4 (fig 7.4): {} frames gridded", config.frames),
            config,
            size: figure_size(ctx.size),
            panels: vec![
                Panel::marched(gridded, March::CELL),
                Panel::marched(gridded, March::FINE),
                Panel {
                    name: format!("MacCormack {}", March::CELL.label()),
                    holding: Holding::MacCormack,
                    march: March::CELL,
                },
            ],
        },
    )
}
