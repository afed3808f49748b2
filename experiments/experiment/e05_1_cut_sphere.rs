//! # 05-1 — a sphere cut by 5 random flat blades (fig 5.1)
//!
//! Reproduces the notes' figure 5.1 (§5.3): the signed distance of a sphere
//! (radius 0.8 in `[−1, 1]³`) is cut by 5 knives, each the plane of eq 5.1
//! through a random point of `[−0.35, 0.35]³` with a random normal (seed 5).
//! Every cut splits each level set into `cutInside` and `cutOutside` (§5.2);
//! level sets with no positive sample on the grid are discarded as soon as
//! they appear, so of the 2⁵ = 32 possible sets only the non-empty ones are
//! built (the notes found 22 for their blades). The pieces are the
//! 26-connected components of each set's positive cells.
//!
//! Run: `smokelab experiment 05-1` (about 6 s on 2 cores: 64³ grid, 384²
//! renders; `--full` 160³ and 768², `--smoke` 24³ and 96²).
//!
//! Writes `results/05-1/`: `cut.png` (the sphere, each piece its colour, so
//! the cuts show), `exploded.png` (each piece moved out from the centre along
//! its centroid; both drawn from the labelled cells), `labels.npy` (int32 `(nz, ny, nx)`: the piece id of each
//! cell, 0 outside), `pieces.csv` (id, level set, cells, volume, centroid),
//! `data.csv` (the counts: possible, non-empty and empty sets, pieces, the
//! pieces' volume against the sphere's) and `manifest.json`.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::model_render::{palette, render_densities};
use crate::figures::table::write_rows;
use smokelab::domain::Domain;
use smokelab::field::{ops, Scalar};
use smokelab::grid::{ScalarGrid, Wrap};
use smokelab::io;
use smokelab::model::cut::{cut_all, label_pieces};
use smokelab::model::shape;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "05-1",
    folder: "05-1",
    reproduces: "fig 5.1",
    title: "a sphere cut by 5 random blades into pieces",
    cost: "~6 s",
    run,
};

#[derive(Serialize)]
struct Config {
    radius: f32,
    knives: usize,
    seed: u64,
    grid: usize,
    pixels: u32,
    explode: f32,
}

/// One row of `pieces.csv`.
#[derive(Serialize)]
struct PieceRow {
    id: i32,
    level_set: usize,
    cells: usize,
    volume: f64,
    cx: f32,
    cy: f32,
    cz: f32,
}

/// The one row of `data.csv`.
#[derive(Serialize)]
struct Counts {
    possible_sets: usize,
    non_empty_sets: usize,
    empty_sets: usize,
    pieces: usize,
    pieces_volume: f64,
    sphere_volume: f64,
    volume_error_relative: f64,
}

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let (grid, pixels) = ctx.size.pick((24, 96), (64, 384), (160, 768));
    let config = Config {
        radius: 0.8,
        knives: 5,
        seed: 5,
        grid,
        pixels,
        explode: 1.0,
    };
    let mut rng = Pcg64::seed_from_u64(config.seed);
    let mut random = |s: f32| Vec3::from_array(std::array::from_fn(|_| rng.random_range(-s..s)));
    let knives: Vec<Scalar> = (0..config.knives)
        .map(|_| shape::plane(random(0.35), random(1.0)))
        .collect::<Result<_, _>>()?;
    let domain = Domain::new(Vec3::splat(-1.0), 2.0 / grid as f32, [grid; 3])?;
    io::create_output_dir(&ctx.out)?;

    let cuts = cut_all(shape::sphere(Vec3::ZERO, config.radius), &knives, domain);
    let labels = label_pieces(&cuts.sets, domain);
    ndarray_npy::write_npy(ctx.out.join("labels.npy"), &labels.ids)?;
    let rows: Vec<PieceRow> = labels
        .pieces
        .iter()
        .map(|p| PieceRow {
            id: p.id,
            level_set: p.set,
            cells: p.cells,
            volume: p.volume,
            cx: p.centroid.x,
            cy: p.centroid.y,
            cz: p.centroid.z,
        })
        .collect();
    write_rows(&ctx.out.join("pieces.csv"), &rows)?;
    let pieces_volume: f64 = labels.pieces.iter().map(|p| p.volume).sum();
    let sphere_volume = 4.0 / 3.0 * std::f64::consts::PI * (config.radius as f64).powi(3);
    let counts = Counts {
        possible_sets: 1 << config.knives,
        non_empty_sets: cuts.sets.len(),
        empty_sets: cuts.empty,
        pieces: labels.pieces.len(),
        pieces_volume,
        sphere_volume,
        volume_error_relative: pieces_volume / sphere_volume - 1.0,
    };
    write_rows(&ctx.out.join("data.csv"), std::slice::from_ref(&counts))?;

    // Renders: every level set its colour, in place and moved out along the
    // centroid of its cells. Each set is drawn from its cells (an indicator
    // grid read trilinearly), so a render query is one grid lookup.
    let mut sets = vec![(Vec3::ZERO, 0usize, ScalarGrid::zeros(domain)); cuts.sets.len()];
    let set_of: Vec<usize> = labels.pieces.iter().map(|p| p.set).collect();
    for p in &labels.pieces {
        let s = &mut sets[p.set];
        s.0 += p.centroid * p.cells as f32;
        s.1 += p.cells;
    }
    for (cell, &id) in labels.ids.iter().enumerate() {
        if id > 0 {
            sets[set_of[id as usize - 1]].2.as_slice_mut()[cell] = 1.0;
        }
    }
    let sets: Vec<(Vec3, Scalar)> = sets
        .into_iter()
        .map(|(sum, cells, g)| {
            let density: Scalar = Arc::new(g.with_wrap(Wrap::Clamped));
            (sum / cells.max(1) as f32, density)
        })
        .collect();
    let view = |explode: f32| {
        sets.iter()
            .enumerate()
            .map(|(i, (centroid, density))| {
                let offset = explode * *centroid;
                let moved = ops::compose(
                    density.clone(),
                    ops::vector_sum(ops::identity(), ops::constant_vector(-offset)),
                );
                (format!("set{i}"), moved, palette(i))
            })
            .collect::<Vec<_>>()
    };
    let bounds = Domain::new(Vec3::splat(-1.3), 2.6 / grid as f32, [grid; 3])?;
    let whole = render_densities(view(0.0), bounds, pixels, 0.5, 40.0)?;
    io::write_png(&ctx.out.join("cut.png"), &whole)?;
    let exploded = render_densities(view(config.explode), bounds, pixels, 0.5, 40.0)?;
    io::write_png(&ctx.out.join("exploded.png"), &exploded)?;

    let extra = serde_json::to_value(&counts)?;
    let seed = config.seed;
    ctx.write_manifest(config, seed, start, extra)
}
