//! # 06-5 — gridded | gridless | SELMA side by side (fig 6.5, extended)
//!
//! Reproduces fig 6.5 — the hot/cold simulation with gridded (left) and
//! gridless (right) densities at the same frames — and adds a SELMA column
//! (ch. 8, with the continuous injection of `smokelab::density::selma`) and,
//! with `--full`, SELMA^fine (map grid twice as fine as the velocity). The
//! notes' claims under test: gridless keeps the hot/cold mirror symmetry
//! better, shows finer structure and keeps more density; SELMA should get
//! most of that at constant memory and cost per step. A fourth run,
//! `gridless-smooth`, is gridless with injection spheres whose edge is a
//! smoothstep 0.4 wide instead of the notes' solid mask: the control that
//! shows why the solid mask breaks gridless symmetry (a path grazing the
//! sphere turns round-off into a whole `S Δt`).
//!
//! Two more rows, `gridded-offset` and `selma-offset`, run with the
//! scenario's `offset = 0.5` (hot source 0.5 to +x, cold 0.5 to −x), so the
//! gases pass each other as in the notes' figs 6.1–6.5 instead of meeting
//! head-on. Their `mirror_error` measures the offset (the problem keeps the
//! half turn, not the mirror; experiment S-1 measures that symmetry). A
//! gridless offset row would add the cost of another gridless run (about
//! 50 s of the 150); `--full` adds it.
//!
//! Run: `smokelab experiment 06-5` (40³, 100 steps; about 3 minutes on 2
//! free cores; `--full` is 50³ with 150 steps plus SELMA^fine, about 15
//! minutes; `--smoke` is 16³ for tests).
//!
//! Writes `results/06-5/`: `side_by_side.png` (one row per run — gridded,
//! gridless, SELMA, gridless-smooth, gridded-offset, selma-offset[,
//! gridless-offset, SELMA^fine] — mid-plane slices of the density fields at
//! four frames), `side_by_side_render.png` (the same, ray-marched),
//! `final.png` (the last frame of every mode, larger, left to right in the
//! same order), `metrics_*.png/.svg` and `metrics.png`, `summary.csv`,
//! `manifest.json`, and one folder per mode with its `metrics.csv`.

use anyhow::Result;
use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;

use crate::density_compare::{self as dc, Look, ModeRun};
use crate::registry::{Context, Experiment, Size};
use smokelab::density::DensityMode;
use smokelab::io::{self, manifest::Manifest, preview};
use smokelab::scenario::hot_cold::HotColdConfig;

/// Edge width of the smooth-source control run (world units; the spheres
/// have radius 1).
const SMOOTH_EDGE: f32 = 0.4;

/// Horizontal source offset of the offset rows (world units).
const OFFSET: f32 = 0.5;

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
    let base = HotColdConfig::default();
    let (config, look) = match ctx.size {
        Size::Smoke => (
            HotColdConfig {
                solver: SolverConfig {
                    res: 16,
                    frames: 12,
                    metrics_every: 4,
                    ..base.solver.clone()
                },
                ..base
            },
            Look {
                slice: 128,
                render: 64,
            },
        ),
        Size::Default => (
            HotColdConfig {
                solver: SolverConfig {
                    res: 40,
                    frames: 100,
                    metrics_every: 10,
                    ..base.solver.clone()
                },
                ..base
            },
            Look {
                slice: 320,
                render: 256,
            },
        ),
        Size::Full => (
            HotColdConfig {
                solver: SolverConfig {
                    metrics_every: 10,
                    ..base.solver.clone()
                },
                ..base
            },
            Look {
                slice: 400,
                render: 320,
            },
        ),
    };
    let capture: Vec<usize> = (1..=4).map(|i| i * config.solver.frames / 4).collect();
    let mut modes: Vec<ModeRun> = DensityMode::ALL
        .iter()
        .map(|&m| ModeRun::new(&config, m))
        .collect();
    modes.push(ModeRun::gridless_smooth(&config, SMOOTH_EDGE));
    let offset = HotColdConfig {
        offset: OFFSET,
        ..config.clone()
    };
    let mut offset_modes = vec![DensityMode::Gridded, DensityMode::Selma];
    if ctx.size == Size::Full {
        offset_modes.insert(1, DensityMode::Gridless);
    }
    for mode in offset_modes {
        let m = ModeRun::new(&offset, mode);
        modes.push(ModeRun {
            label: format!("{}-offset", m.label),
            config: m.config,
        });
    }
    if ctx.size == Size::Full {
        modes.push(ModeRun::selma_fine(&config, 2));
    }
    for m in &modes {
        m.config.validate()?;
    }
    let results = modes
        .iter()
        .map(|m| dc::run_mode(ctx, m, &capture, look))
        .collect::<Result<Vec<_>>>()?;
    let rows = |pick: fn(&dc::Captured) -> image::RgbImage| -> Vec<Vec<image::RgbImage>> {
        results
            .iter()
            .map(|r| r.frames.iter().map(pick).collect())
            .collect()
    };
    io::write_png(
        &ctx.out.join("side_by_side.png"),
        &dc::grid(&rows(|f| f.slice.clone()), 4),
    )?;
    io::write_png(
        &ctx.out.join("side_by_side_render.png"),
        &dc::grid(&rows(|f| f.render.clone()), 4),
    )?;
    let finals: Vec<image::RgbImage> = results
        .iter()
        .map(|r| dc::slice(&r.sim, 2 * look.slice))
        .collect();
    io::write_png(
        &ctx.out.join("final.png"),
        &preview::side_by_side(&finals, 6),
    )?;
    let runs: Vec<(String, std::path::PathBuf)> = results
        .iter()
        .map(|r| (r.label.clone(), r.dir.clone()))
        .collect();
    dc::plot_metrics(&ctx.out, &runs, "hot/cold")?;
    let summary = dc::summarise(&ctx.out, &results)?;
    io::write_json(
        &ctx.out.join("manifest.json"),
        &Manifest::new(
            &config,
            config.solver.seed,
            start.elapsed().as_secs_f64(),
            serde_json::json!({
                "modes": modes.iter().map(|m| &m.label).collect::<Vec<_>>(),
                "captured_frames": capture,
                "summary": summary,
            }),
        ),
    )
}
