//! # 07-10 — render time and memory against gridless frames (fig 7.10)
//!
//! Reproduces the notes' figure 7.10 (§7.3): the sphere wall held gridded
//! for `F − k` frames and gridless for the last `k` (eqs 7.1–7.4), for
//! `k = 0, F/6, …, F`, rendered with a march step of one velocity cell and
//! of a tenth of one. For each: the render's wall time, its counted work
//! (`walk_steps`: the backward steps the gridless chain walks, points
//! mapped × `k`) and the bytes held by the density representation when it
//! is rendered — the row grids (one per row, velocity resolution) plus the
//! `k` stored velocity grids of the gridless chain, each allocation once.
//! (Here `k = F` composes the frame-0 grids, so every point holds the same
//! row grids; 07-8 composes the analytic wall.) The notes expect both to
//! grow linearly in `k`, time ten times faster with the ten-times finer
//! march.
//!
//! Measured (smoke size, 16³, F = 6): the walk steps are exactly `k` times
//! 34 118 (march = cell, 30 022 samples) and 292 754 (cell/10, 288 658
//! samples) — each sample and each of the light grid's 4096 points walked
//! once for all rows (they share one memoised map); the wall time grows
//! with them plus the march's fixed costs (fine march 0.027 s at `k = 0`,
//! 0.053–0.055 s at `k = 6`).
//!
//! Memory is also *measured* per point (`memory::measure`): the holding is
//! built — from its own copies of the `k` velocity grids, which a
//! simulation keeps only for its gridless gases (here they would be shared
//! with the recorded flow) — and rendered inside the measurement:
//! `heap_peak_bytes` (the heap's high-water mark) and `rss_peak_bytes` (the
//! resident set's, after `malloc_trim`). One unmeasured render first starts
//! the worker threads.
//!
//! `data.csv` is written first; `time`, `memory` (counted solid, heap
//! dashed) and `rss` (`.png`, `.svg`; all three on `costs.png`) are drawn
//! from it, each series with its least-squares slope printed on the plot;
//! `summary.csv` holds per series and quantity the slope (seconds or MiB per
//! gridless frame), the growth relative to the mean, r² and the verdict
//! linear / flat / unclear (`growth`); `manifest.json` the same (`fits`).
//! `strip.png` shows the fine-march renders from `k = 0` to `k = F`. Render
//! times are wall times on a shared machine (the fastest of five renders
//! of each point: three in a row, then one in each of [`TIMING_PASSES`]
//! later passes over all points): relative measures, as the
//! notes say of theirs.
//!
//! The series evaluate every sample, as the notes' renderer does (their
//! wall's bound is dropped). The worst point (`k = F`, fine march) is then
//! rendered once more with empty-space skipping (`density::occupancy`: the
//! bound of the gridless chain over the frame-0 row grids); the manifest's
//! `empty_space` holds the bound's build time and flagged share of the
//! box, both renders' seconds, samples and samples/s, the samples ratio
//! (load-independent), the speedup and whether the picture is the same.
//!
//! Measured (default size, a loaded machine): memory grows 0.375 MiB per
//! frame counted, 0.378 heap and 0.368–0.370 RSS (r² ≥ 0.9995): one 32³
//! velocity grid per gridless frame, as the notes expect.
//!
//! Measured (default size, load ≈ 6): the worst point 7.63 s evaluating
//! every sample, 1.32 s with skipping (0.215 of the samples), the same
//! picture; at `--full` size the worst point alone takes 290 s and 33 s
//! (README, "Empty-space skipping").
//!
//! Run: `smokelab experiment 07-10` (about 20 s on 2 cores: 32³, 30
//! frames, 7 values of `k`, 160×120; `--full` 50³, 60 frames, 640×480 —
//! about 3.5 unskipped worst points, tens of minutes; `--smoke` 16³, 6
//! frames, 64×48).

use std::time::Instant;

use anyhow::Result;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::sphere_wall_series::{
    fastest_render, owned_frames, plot_costs, CostRow, Setup, TIMING_PASSES,
};
use crate::figures::table::write_rows;
use image::RgbImage;
use smokelab::io::{self, preview};
use smokelab::scenario::sphere_wall::{AdvectedWall, FlowHistory, GriddedWall, Wall};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "07-10",
    folder: "07-10",
    reproduces: "fig 7.10",
    title: "render time and memory vs gridless frames, march step cell and cell/10",
    cost: "~50 s",
    run,
};

/// The march steps compared: series name and cell divisor.
const MARCHES: [(&str, f32); 2] = [("march=cell", 1.0), ("march=cell/10", 10.0)];

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let (Setup { config, flow, wall }, (w, h)) = Setup::warmed_study(ctx)?;
    let f = flow.frames();
    let mut gridded = GriddedWall::new(&wall, flow.domain);
    let mut rows = vec![];
    let mut strip = vec![];
    // The gridded part at each k, for the timing passes.
    let mut snapshots = vec![];
    // k from F down to 0: the gridded part grows one frame at a time.
    for i in (0..=6).rev() {
        let k = i * f / 6;
        while gridded.frame() < f - k {
            gridded.advance(&flow);
        }
        for (series, div) in MARCHES {
            let build = || unskipped(&wall, &gridded, &flow, k);
            let (row, img) = CostRow::measure(series, k, build, &flow, div, (w, h))?;
            rows.push(row);
            if div > 1.0 {
                strip.push(img);
            }
        }
        snapshots.push((k, gridded.clone()));
    }
    // Each later pass renders every point once more, a pass apart.
    for _ in 0..TIMING_PASSES {
        for ((k, gridded), pair) in snapshots.iter().zip(rows.chunks_mut(MARCHES.len())) {
            for ((_, div), row) in MARCHES.iter().zip(pair) {
                row.time_again(&unskipped(&wall, gridded, &flow, *k)?, &flow, *div, (w, h))?;
            }
        }
    }
    let skipping = empty_space(&wall, &flow, &rows, &strip[0], (w, h))?;
    rows.sort_by(|a, b| (&a.series, a.frames).cmp(&(&b.series, b.frames)));

    strip.reverse();
    io::write_png(
        &ctx.out.join("strip.png"),
        &preview::side_by_side(&strip, 4),
    )?;
    write_rows(&ctx.out.join("data.csv"), &rows)?;
    let fits = plot_costs(&ctx.out, "sphere wall", "gridless frames k (of F)")?;
    let extra = serde_json::json!({
        "frames": f,
        "dt": flow.dt,
        "image": [w, h],
        "fits": fits,
        "empty_space": skipping,
        "slope_units": "render_seconds: s per gridless frame; *_mib: MiB per gridless frame",
    });
    ctx.write_manifest(config, 0, start, extra)
}

/// The wall with its last `k` frames gridless after `gridded`'s, every
/// sample evaluated (no occupancy bound): the notes' measurement.
fn unskipped(
    wall: &Wall,
    gridded: &GriddedWall,
    flow: &FlowHistory,
    k: usize,
) -> Result<AdvectedWall> {
    let f = flow.frames();
    let own = owned_frames(flow, f - k..f);
    let mut state = AdvectedWall::gridless(wall, Some(gridded), &own, k)?;
    state.occupancy = None;
    Ok(state)
}

/// The worst point (`k = F`, fine march) once more with empty-space
/// skipping (`density::occupancy`): the bound's build time and flagged
/// share, the render's time, samples and skipped sub-steps beside the
/// unskipped point's (`rows`), and whether the picture is the same as the
/// unskipped `picture`.
fn empty_space(
    wall: &Wall,
    flow: &FlowHistory,
    rows: &[CostRow],
    picture: &RgbImage,
    size: (u32, u32),
) -> Result<serde_json::Value> {
    let f = flow.frames();
    let plain = rows
        .iter()
        .find(|r| r.series == MARCHES[1].0 && r.frames == f)
        .expect("the k = F fine-march point");
    let start = Instant::now();
    let state = AdvectedWall::gridless(wall, Some(&GriddedWall::new(wall, flow.domain)), flow, f)?;
    let bound_seconds = start.elapsed().as_secs_f64();
    let (img, stats, walk_steps) = fastest_render(&state, flow, MARCHES[1].1, size)?;
    let rate = |samples: u64, seconds: f64| samples as f64 / seconds;
    Ok(serde_json::json!({
        "gridless_frames": f,
        "march": MARCHES[1].0,
        "bound_seconds": bound_seconds,
        "flagged_fraction": state.occupancy.as_ref().map(|o| o.fraction()),
        "same_picture": img == *picture,
        "unskipped": {
            "render_seconds": plain.render_seconds,
            "samples": plain.samples,
            "walk_steps": plain.walk_steps,
            "samples_per_second": rate(plain.samples, plain.render_seconds),
        },
        "skipped": {
            "render_seconds": stats.seconds,
            "samples": stats.samples,
            "skipped": stats.skipped,
            "walk_steps": walk_steps,
            "samples_per_second": stats.samples_per_second,
            "substeps_per_second": stats.substeps_per_second,
        },
        "samples_ratio": stats.samples as f64 / plain.samples as f64,
        "speedup": plain.render_seconds / stats.seconds,
    }))
}
