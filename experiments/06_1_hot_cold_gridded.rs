//! # 06-1 — hot/cold, all gridded (figs 6.1 and 6.2)
//!
//! Reproduces the notes' hot/cold sequence (§6.1.1): red hot gas injected low
//! rises, blue cold gas injected high sinks, they collide in the middle and
//! flow around each other. Semi-Lagrangian advection, FFT projection, 50³ as
//! in the notes.
//!
//! Run: `smokelab experiment 06-1` (about 10 s on 2 cores; `--full` is the
//! same 50³ run with twice the frames; `--smoke` is 16³ for tests).
//!
//! Writes `results/06-1/`: `sequence.png` (the frame sequence side by side,
//! fig 6.1), `preview_NNNN.png` per saved frame (fig 6.2 is the last),
//! `metrics.csv`, `manifest.json`, and the volumes `*_NNNN.npy` (git-ignored).

use anyhow::Result;

use super::{Context, Experiment, Size};
use crate::io;
use crate::run::{self, RunOptions, SaveFrames};
use crate::scenario::hot_cold::HotColdConfig;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "06-1",
    reproduces: "figs 6.1, 6.2",
    title: "hot/cold buoyant gases, all gridded, 50³",
    cost: "~10 s",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    let base = HotColdConfig::default();
    let config = match ctx.size {
        Size::Smoke => HotColdConfig {
            res: 16,
            frames: 12,
            ..base
        },
        Size::Default => base,
        Size::Full => HotColdConfig {
            frames: 2 * base.frames,
            ..base
        },
    };
    let frames: Vec<usize> = (1..=6).map(|i| i * config.frames / 6).collect();
    let mut sim = config.build()?;
    io::create_output_dir(&ctx.out)?;
    let opts = RunOptions {
        out: ctx.out.clone(),
        frames: config.frames,
        save: SaveFrames::List(frames),
        progress: ctx.progress,
        metrics_every: config.metrics_every,
        sample_res: config.sample_res,
    };
    let summary = run::run(&mut sim, &opts, &config, config.seed)?;
    let images = summary
        .previews
        .iter()
        .map(|p| Ok(image::open(p)?.to_rgb8()))
        .collect::<Result<Vec<_>>>()?;
    io::write_png(
        &ctx.out.join("sequence.png"),
        &io::preview::side_by_side(&images, 4),
    )
}
