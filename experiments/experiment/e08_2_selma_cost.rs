//! # 08-2 — gridless vs SELMA: render time and memory against frames (fig 8.2)
//!
//! Reproduces the notes' figure 8.2 (§8): the sphere wall after `n` frames,
//! `n = 0, F/6, …, F`, held three ways — gridless (the analytic wall
//! composed with the chain through `n` stored velocities, eqs 7.1–7.4),
//! SELMA (the map resampled on the velocity grid every frame, eq 8.8) and
//! SELMA^fine (the map on a grid twice as fine per axis) — each rendered
//! with a march step of a tenth of a velocity cell. For each: the render's
//! wall time and the bytes held by the density representation — gridless:
//! the `n` stored velocity grids; SELMA: the model's grids (map and its
//! scratch, tracked lattice, reference density on the map grid, and the
//! cell-centre cache on the velocity grid), each allocation once. The
//! notes expect gridless to grow linearly in both and SELMA to stay flat,
//! SELMA^fine higher in memory.
//!
//! Memory is also *measured* per point (`memory::measure`), over building
//! the holding and rendering it: the gridless chain from its own copies of
//! the `n` velocity grids (shared with the recorded flow otherwise), SELMA
//! advanced from the identity through `n` frames (its advection scratch
//! counts). Columns `heap_peak_bytes` and `rss_peak_bytes`, as in 07-10.
//!
//! `data.csv` is written first; `time`, `memory` (counted solid, heap
//! dashed) and `rss` (all three on `costs.png`) are drawn from it, with
//! each series' least-squares slope printed on the plot; `summary.csv` and
//! `manifest.json` (`fits`) hold the slopes (seconds and MiB per frame),
//! relative growth, r² and verdict linear / flat / unclear. Render times
//! are wall times on a shared machine, the fastest of five renders of each
//! point (three in a row, then one in each of [`TIMING_PASSES`] later
//! passes over all points): relative measures.
//!
//! Measured (default size, a loaded machine): gridless memory grows 0.375
//! MiB per frame counted, 0.376 heap, 0.378 RSS (r² ≥ 0.9997); SELMA's heap
//! is flat (−2.8 % over the frames; SELMA^fine 0.01 %), at 1.4 and 10.1 MiB.
//! SELMA's RSS changes by +14 %; SELMA^fine's unadvected point is 3 MiB
//! against 9–10 MiB for the advected ones, the advection's scratch.
//!
//! Run: `smokelab experiment 08-2` (about 20 s on 2 cores: 32³, 30
//! frames, 7 values of `n`, 160×120; `--full` 50³, 60 frames, 640×480 —
//! hours; `--smoke` 16³, 6 frames, 64×48).

use std::time::Instant;

use anyhow::Result;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::sphere_wall_series::{
    owned_frames, plot_costs, warm_up, CostRow, Setup, TIMING_PASSES,
};
use crate::figures::table::write_rows;
use smokelab::scenario::sphere_wall::{AdvectedWall, SelmaWall};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "08-2",
    folder: "08-2",
    reproduces: "fig 8.2",
    title: "render time and memory vs frames: gridless, SELMA, SELMA-fine",
    cost: "~40 s",
    run,
};

/// The march step, in velocity cells.
const MARCH_DIV: f32 = 10.0;

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let (Setup { config, flow, wall }, (w, h)) = Setup::warmed_study(ctx)?;
    let f = flow.frames();
    let unadvected = SelmaWall::new(&flow, None)?;
    warm_up(&AdvectedWall::selma(&wall, &unadvected), &flow, (w, h))?;
    type Build<'a> = Box<dyn Fn() -> Result<AdvectedWall> + 'a>;
    let mut points: Vec<(&str, usize, Build)> = vec![];
    for i in 0..=6 {
        let n = i * f / 6;
        let (wall, flow) = (&wall, &flow);
        points.push((
            "gridless",
            n,
            Box::new(move || {
                Ok(AdvectedWall::gridless(
                    wall,
                    None,
                    &owned_frames(flow, 0..n),
                    n,
                )?)
            }),
        ));
        for (name, map) in [("selma", None), ("selma-fine", Some(2 * config.res))] {
            points.push((
                name,
                n,
                Box::new(move || {
                    let mut s = SelmaWall::new(flow, map)?;
                    while s.frame() < n {
                        s.advance(flow);
                    }
                    Ok(AdvectedWall::selma(wall, &s))
                }),
            ));
        }
    }
    let mut rows = vec![];
    for (series, n, build) in &points {
        let (row, _) = CostRow::measure(series, *n, build, &flow, MARCH_DIV, (w, h))?;
        rows.push(row);
    }
    // Each later pass renders every point once more, a pass apart.
    for _ in 0..TIMING_PASSES {
        for ((_, _, build), row) in points.iter().zip(&mut rows) {
            row.time_again(&build()?, &flow, MARCH_DIV, (w, h))?;
        }
    }
    write_rows(&ctx.out.join("data.csv"), &rows)?;
    let fits = plot_costs(&ctx.out, "sphere wall", "advected frames n")?;
    let extra = serde_json::json!({
        "frames": f,
        "dt": flow.dt,
        "image": [w, h],
        "march_step": flow.domain.cell / MARCH_DIV,
        "fits": fits,
        "slope_units": "render_seconds: s per frame; *_mib: MiB per frame",
    });
    ctx.write_manifest(config, 0, start, extra)
}
