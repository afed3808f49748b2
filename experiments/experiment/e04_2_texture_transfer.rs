//! # 04-2 — texture coordinates transferred onto the warped object (fig 4.2)
//!
//! Reproduces the notes' figure 4.2 (§4.3, eq 4.11): the reference sphere of
//! experiment 04-1 carries longitude–latitude texture coordinates; the warp
//! `X_1` of 04-1 maps every point of the object (cone and two linked tori)
//! to a point `x^M = X(x^O)` of the reference, where the coordinates are
//! read. The render splits the object's density into the white and the
//! dark squares of a 12 × 6 checker in those coordinates; the object's
//! surface-net mesh is written with the transferred coordinates as `vt`.
//!
//! Run: `smokelab experiment 04-2` (about 2 s on 2 cores: 64³ mesh grid,
//! 384² render; `--full` 128³ and 768², `--smoke` 20³ and 80²).
//!
//! Writes `results/04-2/`: `texture.png`, `object_uv.obj` (vertices,
//! transferred texture coordinates, faces), `data.csv` (vertex count and the
//! worst `|L_r(x^M)|`, how far the transferred points are from the
//! reference surface) and `manifest.json`.

use std::io::Write;
use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::model_render::render_densities;
use crate::experiment::shared::warp_figures::{domain, object, reference};
use crate::figures::table::write_rows;
use smokelab::field::algebra::mul;
use smokelab::field::{ops, ScalarField, Vector};
use smokelab::io;
use smokelab::model::mesh::Mesh;
use smokelab::model::warp::{sphere_uv, transfer_points, Nacelle};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "04-2",
    folder: "04-2",
    reproduces: "fig 4.2",
    title: "texture coordinates transferred from a sphere by the nacelle warp",
    cost: "~2 s",
    run,
};

/// Squares of the checker along u and v.
const SQUARES: [f32; 2] = [12.0, 6.0];

/// 1 on the squares of one parity of the checker in the reference's
/// coordinates at `X(x)`, 0 on the others.
struct Checker {
    map: Vector,
    parity: u32,
}

impl Checker {
    fn square(&self, m: Vec3) -> f32 {
        let [u, v] = sphere_uv(Vec3::ZERO, m);
        let s = (u * SQUARES[0]).floor() as i64 + (v * SQUARES[1]).floor() as i64;
        if s.rem_euclid(2) as u32 == self.parity {
            1.0
        } else {
            0.0
        }
    }
}

impl ScalarField for Checker {
    fn eval(&self, p: Vec3) -> f32 {
        self.square(self.map.eval(p))
    }
    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        let mut m = vec![Vec3::ZERO; points.len()];
        self.map.eval_batch(points, &mut m);
        for (o, m) in out.iter_mut().zip(m) {
            *o = self.square(m);
        }
    }
}

#[derive(Serialize)]
struct Config {
    iterations: usize,
    squares: [f32; 2],
    grid: usize,
    pixels: u32,
}

/// The one row of `data.csv`.
#[derive(Serialize)]
struct Row {
    vertices: usize,
    worst_reference_level: f32,
}

fn run(ctx: &Context) -> Result<()> {
    let start = Instant::now();
    let (grid, pixels) = ctx.size.pick((20, 80), (64, 384), (128, 768));
    let config = Config {
        iterations: 1,
        squares: SQUARES,
        grid,
        pixels,
    };
    io::create_output_dir(&ctx.out)?;
    let dom = domain(grid)?;
    let warp = Nacelle {
        reference: reference(),
        object: object()?,
        h: 1e-3,
        cache: None,
    };
    let map = warp.iterate(config.iterations).pop().expect("X_1");

    // Eq 4.11 on the object's mesh: x^M = X(x^O), then the sphere's (u, v).
    let mesh = Mesh::from_level_set(&*warp.object, dom);
    let mapped = transfer_points(&map, &mesh.vertices);
    let worst = mapped
        .iter()
        .map(|&m| warp.reference.eval(m).abs())
        .fold(0.0, f32::max);
    io::write_atomic(&ctx.out.join("object_uv.obj"), |w| {
        for v in &mesh.vertices {
            writeln!(w, "v {} {} {}", v.x, v.y, v.z)?;
        }
        for &m in &mapped {
            let [u, v] = sphere_uv(Vec3::ZERO, m);
            writeln!(w, "vt {u} {v}")?;
        }
        for t in &mesh.triangles {
            let [a, b, c] = t.map(|i| i + 1);
            writeln!(w, "f {a}/{a} {b}/{b} {c}/{c}")?;
        }
        Ok(())
    })?;
    write_rows(
        &ctx.out.join("data.csv"),
        &[Row {
            vertices: mesh.vertices.len(),
            worst_reference_level: worst,
        }],
    )?;

    let inside = ops::mask(warp.object.clone());
    let colors = [Vec3::new(0.95, 0.92, 0.85), Vec3::new(0.75, 0.2, 0.12)];
    let densities = (0..2)
        .map(|parity| {
            let checker = Arc::new(Checker {
                map: map.clone(),
                parity,
            });
            (
                format!("squares{parity}"),
                mul(inside.clone(), checker),
                colors[parity as usize],
            )
        })
        .collect();
    let image = render_densities(densities, dom, pixels, 0.5, 40.0)?;
    io::write_png(&ctx.out.join("texture.png"), &image)?;
    ctx.write_manifest(config, 0, start, serde_json::json!({}))
}
