//! What the cloud experiments of chapter 3 (03-3 … 03-8) share: the base
//! shape, the displacement layers, `cumulo` with a cache per layer, and a
//! row of rendered panels written with its meshes, table and manifest.
//!
//! The base is a signed-distance cloud of three overlapping spheres (their
//! union, `max`), standing in for the notes' bunny; a user's own shape
//! enters the same way through `model::mesh::MeshDistance`. Layers follow
//! the `NoiseLayers` script (eq 3.7): Perlin noise, frequency 2, jump 2.2,
//! roughness 0.5, first amplitude 0.2. Layer `i` is cached on a box of
//! `grid · (1 + i/2)` cells per axis (§3.3.3), each finer than the last.

use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use serde::Serialize;

use crate::model_render::render_densities;
use crate::registry::Context;
use crate::table::write_rows;
use smokelab::domain::Domain;
use smokelab::field::algebra::max;
use smokelab::field::ops::{self, constant};
use smokelab::field::Scalar;
use smokelab::io::{self, manifest::Manifest};
use smokelab::model::cloud::{cumulo, noise_layers};
use smokelab::model::mesh::Mesh;
use smokelab::model::shape;
use smokelab::noise::perlin::Perlin;

/// Half-width of the modelling box `[−W, W]³`.
pub(crate) const W: f32 = 1.1;
/// Amplitude of the first layer.
pub(crate) const SCALE: f32 = 0.2;
/// Steps of eq 3.3 per layer.
const ITERATIONS: usize = 3;

/// The base cloud: the union of three spheres' signed distances.
pub(crate) fn base() -> Scalar {
    let a = shape::sphere(Vec3::new(-0.3, -0.1, 0.0), 0.45);
    let b = shape::sphere(Vec3::new(0.25, -0.15, 0.1), 0.4);
    let c = shape::sphere(Vec3::new(0.0, 0.25, -0.05), 0.38);
    max(max(a, b), c)
}

/// `count` layers of the `NoiseLayers` script with constant parameters,
/// except the amplitude field `scale`.
pub(crate) fn layers(count: usize, scale: Scalar) -> Vec<Scalar> {
    noise_layers(
        count,
        std::sync::Arc::new(Perlin::new(0xc10d)),
        scale,
        constant(2.0),
        constant(2.2),
        constant(0.5),
    )
}

/// The modelling box with `res` cells per axis.
pub(crate) fn domain(res: usize) -> Result<Domain> {
    Ok(Domain::new(
        Vec3::splat(-W),
        2.0 * W / res as f32,
        [res; 3],
    )?)
}

/// `cumulo` of the base with `layers`, the level set after layer `i` cached
/// on `grid · (1 + i/2)` cells (eq 3.5, §3.3.3); the gradient of each
/// cached layer is differenced with half a cell of the previous cache.
pub(crate) fn cloud(layers: &[Scalar], grid: usize) -> Result<Scalar> {
    let doms = (0..layers.len())
        .map(|i| domain(grid + grid * i / 2))
        .collect::<Result<Vec<_>>>()?;
    let h = 0.5 * domain(grid)?.cell;
    Ok(cumulo(base(), layers, h, ITERATIONS, &doms)?)
}

/// One panel of a figure.
pub(crate) struct Panel {
    /// Label (file names, table).
    pub label: String,
    /// The level set; its density is `mask(ℓ)` (eq 3.1).
    pub level_set: Scalar,
    /// A density to render instead of `mask(ℓ)` (advected clouds).
    pub density: Option<Scalar>,
}

/// One row of `data.csv`.
#[derive(Serialize)]
struct Row {
    panel: String,
    volume: f64,
    triangles: usize,
}

/// How panels are shown.
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Look {
    /// The notes' geometry figures: a hard surface (extinction 60 per unit
    /// density) and each panel's surface-net mesh written as `<label>.obj`.
    Geometry,
    /// A soft volume (extinction 6), no meshes.
    Volume,
}

/// Render `panels` side by side into `<out>/<image>` with `look`, write the
/// volume and triangle count per panel in `data.csv`, and the manifest with
/// `config`.
pub(crate) fn write_panels(
    ctx: &Context,
    config: impl Serialize,
    panels: Vec<Panel>,
    (grid, pixels): (usize, u32),
    look: Look,
    image: &str,
) -> Result<()> {
    let (kappa, meshes) = match look {
        Look::Geometry => (60.0, true),
        Look::Volume => (6.0, false),
    };
    let start = Instant::now();
    let dom = domain(grid)?;
    let mut images = Vec::new();
    let mut rows = Vec::new();
    for p in panels {
        let density = p.density.unwrap_or_else(|| ops::mask(p.level_set.clone()));
        let volume = smokelab::grid::ScalarGrid::from_field(dom, &*density).total();
        let triangles = if meshes {
            let mesh = Mesh::from_level_set(&*p.level_set, dom);
            mesh.write_obj(&ctx.out.join(format!("{}.obj", p.label)))?;
            mesh.triangles.len()
        } else {
            0
        };
        rows.push(Row {
            panel: p.label.clone(),
            volume,
            triangles,
        });
        let color = Vec3::new(0.92, 0.93, 0.95);
        images.push(render_densities(
            vec![(p.label, density, color)],
            dom,
            pixels,
            0.5,
            kappa,
        )?);
    }
    io::write_png(&ctx.out.join(image), &io::preview::side_by_side(&images, 6))?;
    write_rows(&ctx.out.join("data.csv"), &rows)?;
    io::write_json(
        &ctx.out.join("manifest.json"),
        &Manifest::new(
            config,
            0xc10d,
            start.elapsed().as_secs_f64(),
            serde_json::json!({}),
        ),
    )
}
