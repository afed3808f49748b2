//! # 04-1 — the nacelle warp of a sphere into a cone and two linked tori (fig 4.1)
//!
//! Reproduces the notes' figure 4.1 (§4.1–4.3): the object `L_O` is the
//! union (max) of a cone and two linked tori, the reference `L_r` a sphere's
//! signed distance; the warp `X_n` solves `L_O = L_r(X)` (eq 4.1) by the
//! iteration of eqs 4.7–4.10, written with the field algebra as the notes'
//! FELT script. Panels: (a) the object, (b) the reference sphere, (c) the
//! warped reference `L_r(X_1)` after one iteration — the notes: "essentially
//! identical to the input object shape". The residual `|L_O − L_r(X_n)|` is
//! measured on the cells within 0.2 of the object's surface for n = 0…4,
//! for the purely procedural script and with `B·B`, `B·M·B` cached (§4.2).
//! With a signed-distance reference `B·B = 1` and `B·M·B = 0`, so the cached
//! variant matches the procedural one to round-off (the curves overlap).
//! The cone is a level set (slope 1 on its mantle, not a distance
//! everywhere), which the warp does not need.
//!
//! Run: `smokelab experiment 04-1` (about 2 s on 2 cores: 64³ residual grid
//! and meshes, 320² renders; `--full` 128³ and 640², `--smoke` 20³ and 80²).
//!
//! Writes `results/04-1/`: `warp.png` (a, b, c side by side), `residual.png`
//! and `.svg` (the worst and mean residual per iteration, log scale, drawn from
//! `data.csv`), `data.csv` (iteration, variant, worst and mean residual),
//! `object.obj`, `reference.obj`, `warped_1.obj` (surface-net meshes of
//! `L_O`, `L_r`, `L_r ∘ X_1`) and `manifest.json`.

use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::model_render::render_densities;
use crate::experiment::shared::warp_figures::{domain, object, reference};
use crate::figures::plot::{Plot, Series};
use crate::figures::table::write_rows;
use smokelab::field::{ops, ScalarField};
use smokelab::grid::ScalarGrid;
use smokelab::io;
use smokelab::model::mesh::Mesh;
use smokelab::model::warp::Nacelle;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "04-1",
    folder: "04-1",
    reproduces: "fig 4.1",
    title: "nacelle warp: sphere into a cone and two linked tori, residual per iteration",
    cost: "~2 s",
    run,
};

#[derive(Serialize)]
struct Config {
    iterations: usize,
    h: f32,
    grid: usize,
    pixels: u32,
    band: f32,
}

/// One row of `data.csv`.
#[derive(Serialize)]
struct Row {
    iteration: usize,
    variant: &'static str,
    worst: f32,
    mean: f64,
}

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let (grid, pixels) = ctx.size.pick((20, 80), (64, 320), (128, 640));
    let config = Config {
        iterations: 4,
        h: 1e-3,
        grid,
        pixels,
        band: 0.2,
    };
    io::create_output_dir(&ctx.out)?;
    let dom = domain(grid)?;
    let (object, reference) = (object()?, reference());
    let near = ScalarGrid::from_field(dom, &*object);
    let band: Vec<Vec3> = ndarray::indices(dom.shape())
        .into_iter()
        .filter(|&(k, j, i)| near.data()[[k, j, i]].abs() < config.band)
        .map(|(k, j, i)| dom.cell_center(i, j, k))
        .collect();

    let mut rows = Vec::new();
    let mut warped_1 = None;
    for (variant, cache) in [("procedural", None), ("cached", Some(dom))] {
        let warp = Nacelle {
            reference: reference.clone(),
            object: object.clone(),
            h: config.h,
            cache,
        };
        for (iteration, map) in warp.iterate(config.iterations).into_iter().enumerate() {
            let mut r = vec![0.0; band.len()];
            warp.residual(map.clone()).eval_batch(&band, &mut r);
            rows.push(Row {
                iteration,
                variant,
                worst: r.iter().fold(0.0, |m: f32, v| m.max(*v)),
                mean: r.iter().map(|&v| v as f64).sum::<f64>() / r.len().max(1) as f64,
            });
            if variant == "procedural" && iteration == 1 {
                warped_1 = Some(ops::compose(reference.clone(), map));
            }
        }
    }
    write_rows(&ctx.out.join("data.csv"), &rows)?;
    let mut plot = Plot::new(
        "nacelle residual |L_O − L_r(X_n)| near the object",
        "iteration n",
        "residual",
    )
    .log_y();
    for v in ["procedural", "cached"] {
        let of = |f: &dyn Fn(&Row) -> f64| {
            rows.iter()
                .filter(|r| r.variant == v)
                .map(|r| (r.iteration as f64, f(r).max(1e-9)))
                .collect()
        };
        plot = plot
            .series(Series::line(format!("{v}, worst"), of(&|r| r.worst as f64)))
            .series(Series::line(format!("{v}, mean"), of(&|r| r.mean)));
    }
    plot.write(&ctx.out.join("residual"))?;

    let warped_1 = warped_1.expect("iteration 1 is computed");
    let shapes = [
        ("object", &object),
        ("reference", &reference),
        ("warped_1", &warped_1),
    ];
    let mut images = Vec::new();
    for (name, level_set) in shapes {
        Mesh::from_level_set(&**level_set, dom).write_obj(&ctx.out.join(format!("{name}.obj")))?;
        let density = ops::mask(level_set.clone());
        images.push(render_densities(
            vec![(name.to_string(), density, Vec3::new(0.85, 0.8, 0.7))],
            dom,
            pixels,
            0.5,
            40.0,
        )?);
    }
    io::write_png(
        &ctx.out.join("warp.png"),
        &io::preview::side_by_side(&images, 6),
    )?;
    ctx.write_manifest(config, 0, start, serde_json::json!({}))
}
