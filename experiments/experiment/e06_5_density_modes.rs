//! # 06-5 — gridded | gridless | SELMA side by side (fig 6.5, extended)
//!
//! Reproduces fig 6.5 — the hot/cold simulation with gridded (left) and
//! gridless (right) densities at the same frames — and adds a SELMA column
//! (ch. 8, with the continuous injection of `smokelab::density::selma`) and,
//! with `--full`, SELMA^fine (map grid twice as fine as the velocity). The
//! notes' claims under test: gridless keeps the hot/cold mirror symmetry
//! better, shows finer structure and keeps more density; SELMA should get
//! most of that at constant memory and cost per step. With `--full`,
//! `gridless-smooth-head-on` is gridless with injection spheres whose edge
//! is a smoothstep 0.4 wide instead of the notes' solid mask: the control
//! that shows why the solid mask breaks gridless symmetry (a path grazing
//! the sphere turns round-off into a whole `S Δt`).
//!
//! The first three rows run the scenario's default, sources offset by ±0.5
//! along x, so that the gases collide and pass each other as in the notes'
//! figures; three more, `gridded-head-on`, `gridless-head-on` and
//! `selma-head-on`, run the head-on variant (`offset = 0`), where the
//! problem is exactly mirror-symmetric and `mirror_error` measures how each
//! mode keeps that symmetry (in the offset rows it measures the offset;
//! experiment S-1 measures the half turn those keep). A fourth row,
//! `gridded-maccormack`, is the offset run gridded with MacCormack
//! advection of velocity and densities (Selle et al. 2008): the stronger
//! gridded baseline beside the notes' semi-Lagrangian one. `--full` adds the
//! symmetry control `gridless-smooth-head-on` and SELMA^fine.
//!
//! Run: `smokelab experiment 06-5` (40³, 100 steps; about 3 minutes on 2
//! free cores; `--full` is 50³ with 150 steps plus SELMA^fine, about 15
//! minutes; `--smoke` is 16³ for tests).
//!
//! Writes `results/06-5/`: `side_by_side.png` (one row per run, named in
//! the image — gridded, gridless, SELMA, gridded-maccormack, then the three
//! head-on[, then gridless-smooth-head-on, SELMA^fine] — mid-plane slices of the density
//! fields at four frames, each column headed by its frame and time),
//! `side_by_side_render.png` (the same, ray-marched),
//! `final.png` (the last frame of every mode, larger, left to right in the
//! same order), `metrics_*.png/.svg` and `metrics.png`, `summary.csv`,
//! `manifest.json`, and one folder per mode with its `metrics.csv`.

use anyhow::Result;

use crate::experiment::kit::{Context, Experiment, Size};
use crate::experiment::shared::density_compare::{self as dc, ModeRun};
use crate::figures::panels;
use smokelab::density::DensityMode;
use smokelab::scenario::hot_cold::HotColdConfig;

/// Edge width of the smooth-source control run (world units; the spheres
/// have radius 1).
const SMOOTH_EDGE: f32 = 0.4;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "06-5",
    folder: "06-5",
    reproduces: "fig 6.5 (+ SELMA)",
    title: "hot/cold: gridded | gridless | SELMA at the same frames, with metrics",
    cost: "~3 min",
    run,
};

fn run(ctx: &Context) -> Result<()> {
    let start = std::time::Instant::now();
    let (config, look) = dc::hot_cold_size(ctx.size, Some(40));
    let capture: Vec<usize> = (1..=4).map(|i| i * config.solver.frames / 4).collect();
    let head_on = HotColdConfig {
        offset: 0.0,
        ..config.clone()
    };
    let named = |m: ModeRun, suffix: &str| ModeRun {
        label: format!("{}{suffix}", m.label),
        config: m.config,
    };
    let mut modes: Vec<ModeRun> = DensityMode::ALL
        .iter()
        .map(|&m| ModeRun::new(&config, m))
        .chain(
            DensityMode::ALL
                .iter()
                .map(|&m| named(ModeRun::new(&head_on, m), "-head-on")),
        )
        .collect();
    modes.insert(3, ModeRun::gridded_maccormack(&config));
    if ctx.size == Size::Full {
        modes.push(named(
            ModeRun::gridless_smooth(&head_on, SMOOTH_EDGE),
            "-head-on",
        ));
        modes.push(ModeRun::selma_fine(&config, 2));
    }
    let results = dc::run_modes(ctx, &modes, &capture, look)?;
    let all: Vec<&dc::ModeResult> = results.iter().collect();
    let times = (capture.as_slice(), config.solver.dt);
    let res = config.solver.res;
    let title = format!("06-5 hot/cold by density mode, {res}³ velocity grid");
    dc::save_frames((&ctx.out, "side_by_side"), &title, &all, times)?;
    let finals: Vec<image::RgbImage> = results
        .iter()
        .map(|r| dc::slice(&r.sim, 2 * look.slice))
        .collect();
    let names: Vec<String> = results.iter().map(|r| r.label.clone()).collect();
    let last = panels::frame_heading(config.solver.frames, config.solver.dt);
    panels::save_row(
        &ctx.out.join("final.png"),
        &finals,
        6,
        &format!("06-5 the last frame by density mode ({last})"),
        &names,
    )?;
    dc::plot_metrics(&ctx.out, &results, "hot/cold")?;
    let summary = dc::summarise(&ctx.out, &results)?;
    ctx.write_manifest(
        &config,
        config.solver.seed,
        start,
        serde_json::json!({
            "modes": modes.iter().map(|m| &m.label).collect::<Vec<_>>(),
            "captured_frames": capture,
            "summary": summary,
        }),
    )
}
