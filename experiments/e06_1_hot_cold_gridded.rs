//! # 06-1 — hot/cold, all gridded (figs 6.1 and 6.2)
//!
//! Reproduces the notes' hot/cold sequence (§6.1.1): red hot gas injected low
//! rises, blue cold gas injected high sinks, they collide in the middle and
//! flow around each other. Semi-Lagrangian advection, FFT projection, 50³ as
//! in the notes.
//!
//! Two runs: the default problem, both sources on one vertical axis (the
//! gases meet head-on and spread into a disc; exactly mirror-symmetric, so
//! `metrics.csv`'s `mirror_error` tests the whole step), and the same with
//! `offset = 0.5` (hot source 0.5 to +x, cold 0.5 to −x), where the gases
//! pass each other as in the notes' figures; that run keeps the half-turn
//! symmetry instead of the mirror (experiment S-1 measures it), so its
//! `mirror_error` column measures the offset, not an error.
//!
//! Run: `smokelab experiment 06-1` (about 30 s on 2 cores; `--full` is the
//! same 50³ runs with twice the frames; `--smoke` is 16³ for tests).
//!
//! Writes `results/06-1/`: `sequence.png` (volume renders of the frame
//! sequence side by side, fig 6.1), `render_NNNN.png`/`.exr` per saved frame
//! (fig 6.2 is the last), `slices.png` and `preview_NNNN.png` (mid-plane
//! slices, a diagnostic), `metrics.csv`, `manifest.json`, and the volumes
//! `*_NNNN.npy` (git-ignored); the offset run writes the same into
//! `offset/`, and its strips as `sequence_offset.png` and `slices_offset.png`.

use anyhow::Result;
use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;

use crate::frames::FrameRender;
use crate::registry::{Context, Experiment, Size};
use crate::run::{self, RunOptions, SaveFrames};
use smokelab::io;
use smokelab::scenario::hot_cold::HotColdConfig;

/// Horizontal source offset of the second run (world units; the spheres
/// have radius 1).
const OFFSET: f32 = 0.5;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "06-1",
    folder: "06-1",
    reproduces: "figs 6.1, 6.2",
    title: "hot/cold buoyant gases, all gridded, 50³",
    cost: "~30 s",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    let base = HotColdConfig::default();
    let config = match ctx.size {
        Size::Smoke => HotColdConfig {
            solver: SolverConfig {
                res: 16,
                frames: 12,
                ..base.solver.clone()
            },
            ..base
        },
        Size::Default => base,
        Size::Full => HotColdConfig {
            solver: SolverConfig {
                frames: 2 * base.solver.frames,
                ..base.solver.clone()
            },
            ..base
        },
    };
    run_one(ctx, &config, &ctx.out, "")?;
    let offset = HotColdConfig {
        offset: OFFSET,
        ..config.clone()
    };
    run_one(ctx, &offset, &ctx.out.join("offset"), "_offset")
}

/// One run of `config` into `out`, its strips written to `ctx.out` with
/// `suffix` (`sequence{suffix}.png`, `slices{suffix}.png`).
fn run_one(
    ctx: &Context,
    config: &HotColdConfig,
    out: &std::path::Path,
    suffix: &str,
) -> Result<()> {
    let frames: Vec<usize> = (1..=6).map(|i| i * config.solver.frames / 6).collect();
    let render = FrameRender::new(
        SaveFrames::List(frames.clone()),
        (256, 256),
        None,
        &config.solver.domain()?,
    )?;
    let mut sim = config.build()?;
    io::create_output_dir(out)?;
    let opts = RunOptions {
        out: out.to_path_buf(),
        frames: config.solver.frames,
        save: SaveFrames::List(frames),
        progress: ctx.progress,
        metrics_every: config.solver.metrics_every,
        sample_res: config.solver.sample_res,
        render: Some(render),
        vdb: false,
        paraview: false,
    };
    let summary = run::run(&mut sim, &opts, config, config.solver.seed)?;
    let strip = |paths: &mut dyn Iterator<Item = &std::path::PathBuf>| {
        let images = paths
            .map(|p| Ok(image::open(p)?.to_rgb8()))
            .collect::<Result<Vec<_>>>()?;
        anyhow::Ok(io::preview::side_by_side(&images, 4))
    };
    io::write_png(
        &ctx.out.join(format!("sequence{suffix}.png")),
        &strip(&mut summary.renders.iter().map(|r| &r.png))?,
    )?;
    io::write_png(
        &ctx.out.join(format!("slices{suffix}.png")),
        &strip(&mut summary.previews.iter())?,
    )
}
