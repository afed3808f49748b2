//! # 06-3 — hot/cold with gridless densities (figs 6.3 and 6.4)
//!
//! Reproduces §6.2: the hot/cold scenario of 06-1 with the densities never
//! sampled onto a grid — every query walks back through all stored velocity
//! grids (eq 7.4 with the source, [`smokelab::density::gridless`]). Fig
//! 6.3 is the frame sequence, fig 6.4 one frame larger. The same flow is
//! also run gridded and SELMA to put the gridless metrics in context (06-5
//! compares the pictures), and gridded once more with
//! MacCormack advection (`gridded-maccormack`, velocity and densities), the
//! stronger gridded baseline the claims table measures against too.
//!
//! Run: `smokelab experiment 06-3` (the notes' 50³, 100 steps; about 4
//! minutes on 2 free cores, most of it the gridless buoyancy queries, which
//! grow with the square of the step count; `--full` is 150 steps, about 10
//! minutes; `--smoke` is 16³ for tests). 06-5 runs the same comparison at
//! 40³.
//!
//! Writes `results/06-3/`: `sequence.png` (mid-plane slices of the gridless
//! fields at six frames, fig 6.3), `sequence_render.png` (the same frames
//! ray-marched), `frame.png` and `frame_render.png` (the last frame larger,
//! fig 6.4), `metrics_*.png/.svg` and `metrics.png` (mass retained,
//! symmetry, detail, sub-grid energy, time per step and memory of the four
//! runs over time), `summary.csv`, `manifest.json`, and one folder per
//! mode with its `metrics.csv` and `manifest.json` (volumes git-ignored).

use anyhow::Result;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::density_compare::{self as dc, ModeRun};
use smokelab::density::DensityMode;
use smokelab::io;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "06-3",
    folder: "06-3",
    reproduces: "figs 6.3, 6.4",
    title: "hot/cold with gridless densities, metrics against gridded and SELMA",
    cost: "~4 min",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    let start = std::time::Instant::now();
    let (config, look) = dc::hot_cold_size(ctx.size, None);
    let capture: Vec<usize> = (1..=6).map(|i| i * config.solver.frames / 6).collect();
    let modes = [
        ModeRun::new(&config, DensityMode::Gridless),
        ModeRun::new(&config, DensityMode::Gridded),
        ModeRun::new(&config, DensityMode::Selma),
        ModeRun::gridded_maccormack(&config),
    ];
    let results = dc::run_modes(ctx, &modes, &capture, look)?;
    let gridless = &results[0];
    let times = (capture.as_slice(), config.solver.dt);
    let res = config.solver.res;
    let title = format!("06-3 hot/cold, gridless density on a {res}³ velocity grid");
    dc::save_frames((&ctx.out, "sequence"), &title, &[gridless], times)?;
    io::write_png(
        &ctx.out.join("frame.png"),
        &dc::slice(&gridless.sim, 3 * look.slice),
    )?;
    io::write_png(
        &ctx.out.join("frame_render.png"),
        &dc::render_fine(&gridless.sim, 2 * look.render)?,
    )?;
    dc::plot_metrics(&ctx.out, &results, "hot/cold")?;
    let summary = dc::summarise(&ctx.out, &results)?;
    ctx.write_manifest(
        &config,
        config.solver.seed,
        start,
        serde_json::json!({ "captured_frames": capture, "summary": summary }),
    )
}
