//! What the cloud experiments of chapter 3 (03-3 … 03-8) share: the base
//! shape, the displacement layers, `cumulo` with a cache per layer, and a
//! row of rendered, labelled panels written with their meshes and manifest,
//! and the billowed cloud of 03-4 (eq 3.8) that 03-7 and 08-3 advect.
//!
//! The base is the notes' Stanford bunny (`assets/bunny.obj`, see
//! `assets/README.md`): its signed distance (`model::mesh::MeshDistance`,
//! closest triangle with a winding-number sign) centred in the box, scaled
//! to [`BASE_WIDTH`] along its widest axis and cached on the base grid.
//! Layers follow the `NoiseLayers` script (eq 3.7): Perlin noise,
//! frequency 2, jump 2.2, roughness 0.5, first amplitude 0.2. Layer `i` is
//! cached on a box of `grid · (1 + i/2)` cells per axis (§3.3.3), each
//! finer than the last.

use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use image::RgbImage;
use serde::Serialize;

use crate::experiment::shared::model_render::render_framed;
use crate::figures::panels;
use smokelab::domain::Domain;
use smokelab::field::algebra::clamp;
use smokelab::field::ops::{self, constant};
use smokelab::field::Scalar;
use smokelab::grid::ScalarGrid;
use smokelab::model::cache;
use smokelab::model::cloud::{cumulo, measured_billow, noise_layers};
use smokelab::model::mesh::{Mesh, MeshDistance};
use smokelab::noise::perlin::Perlin;

/// Half-width of the modelling box `[−W, W]³`.
pub(crate) const W: f32 = 1.1;
/// Amplitude of the first layer.
pub(crate) const SCALE: f32 = 0.2;
/// Width of the base along its widest axis (that of the three-sphere
/// stand-in it replaced), leaving room in the box for the displacement.
pub(crate) const BASE_WIDTH: f32 = 1.4;
/// Steps of eq 3.3 per layer.
const ITERATIONS: usize = 3;
/// `Q_i` of eq 3.8 is this quantile of the previous cleared layer's
/// `|N_{i−1}^c|` over the base's surface: its maximum, as the notes'
/// `Q = 1` is for unit-amplitude noise, so the clamp never saturates and
/// `(|N_{i−1}^c| / Q_i)^billow` clears the valleys more the larger billow
/// is (a fixed `Q` of half the first layer's amplitude saturated almost
/// everywhere, so every billow looked alike; the 99th percentile left
/// billow 2 with 27 % of billow 0.33's cleared displacement, the maximum
/// 23 %).
pub(crate) const QUANTILE: f32 = 1.0;
/// The Stanford bunny as OBJ text.
static BUNNY: &[u8] = include_bytes!("../../assets/bunny.obj");

/// The base cloud: the bunny's signed distance, centred, scaled to
/// [`BASE_WIDTH`] and cached on `domain(grid)` (each query of the mesh
/// distance visits every triangle).
pub(crate) fn base(grid: usize) -> Result<Scalar> {
    let mut mesh = Mesh::parse_obj(BUNNY, "assets/bunny.obj")?;
    let (lo, hi) = mesh.vertices.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &v| (lo.min(v), hi.max(v)),
    );
    let (centre, scale) = (0.5 * (lo + hi), BASE_WIDTH / (hi - lo).max_element());
    for v in &mut mesh.vertices {
        *v = (*v - centre) * scale;
    }
    Ok(cache(&MeshDistance::new(mesh), domain(grid)?))
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

/// `cumulo` of `start` with `layers` (eq 3.5), where `start` already
/// carries the first `done` layers: the level set after layer `i` (counted
/// from the base) is cached on `grid · (1 + i/2)` cells (§3.3.3); the
/// gradient of each cached layer is differenced with half a base cell.
pub(crate) fn cloud(start: Scalar, layers: &[Scalar], done: usize, grid: usize) -> Result<Scalar> {
    let doms = (done..done + layers.len())
        .map(|i| domain(grid + grid * i / 2))
        .collect::<Result<Vec<_>>>()?;
    let h = 0.5 * domain(grid)?.cell;
    Ok(cumulo(start, layers, h, ITERATIONS, &doms)?)
}

/// One panel of a figure.
pub(crate) struct Panel {
    /// Label (file names, table).
    pub label: String,
    /// Heading drawn over the panel ("billow = 0.33").
    pub heading: String,
    /// The level set; its density is `mask(ℓ)` (eq 3.1).
    pub level_set: Scalar,
    /// A density to render instead of `mask(ℓ)` (advected clouds).
    pub density: Option<Scalar>,
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

impl Look {
    /// Extinction per unit density.
    pub(crate) fn kappa(self) -> f32 {
        match self {
            Look::Geometry => 60.0,
            Look::Volume => 6.0,
        }
    }
}

/// Display colour of a cloud.
pub(crate) const CLOUD_COLOR: Vec3 = Vec3::new(0.92, 0.93, 0.95);

/// What [`write_panels`] measured of one panel.
pub(crate) struct Shown {
    /// `∫ρ` on the base grid.
    pub volume: f64,
    /// The surface-net mesh of the level set on the base grid.
    pub mesh: Mesh,
}

/// Render `panels` side by side into `<out>/<image>` with `look`, each
/// headed by its `heading` and the figure by `title`, as [`render_panels`].
/// Returns what was measured per panel, for the experiment's `data.csv`.
pub(crate) fn write_panels(
    ctx: &crate::experiment::kit::Context,
    panels: Vec<Panel>,
    sizes: (usize, u32),
    look: Look,
    (title, image): (&str, &str),
) -> Result<Vec<Shown>> {
    let headings: Vec<String> = panels.iter().map(|p| p.heading.clone()).collect();
    let rendered = render_panels(ctx, panels, sizes, look)?;
    panels::save_row(&ctx.out.join(image), &rendered.images, 6, title, &headings)?;
    Ok(rendered.shown)
}

/// What [`render_panels`] made of a row of panels.
pub(crate) struct Rendered {
    /// What was measured per panel.
    pub shown: Vec<Shown>,
    /// One render per panel.
    pub images: Vec<RgbImage>,
    /// The box the camera framed: whole cells of the base grid holding
    /// every panel's density.
    pub frame: Domain,
}

/// Render each of `panels` with `look`, all framed by one camera on the
/// box that holds every panel's density, on the base grid of `grid` cells
/// at `pixels` square; write each panel's mesh as `<label>.obj` for the
/// geometry look.
pub(crate) fn render_panels(
    ctx: &crate::experiment::kit::Context,
    panels: Vec<Panel>,
    (grid, pixels): (usize, u32),
    look: Look,
) -> Result<Rendered> {
    let kappa = look.kappa();
    let dom = domain(grid)?;
    let densities: Vec<Scalar> = panels
        .iter()
        .map(|p| {
            p.density
                .clone()
                .unwrap_or_else(|| ops::mask(p.level_set.clone()))
        })
        .collect();
    let grids: Vec<ScalarGrid> = densities
        .iter()
        .map(|d| ScalarGrid::from_field(dom, &**d))
        .collect();
    let frame = occupied(&grids, dom)?;
    let mut images = Vec::new();
    let mut shown = Vec::new();
    for ((p, density), g) in panels.iter().zip(densities).zip(&grids) {
        let mesh = Mesh::from_level_set(&*p.level_set, dom);
        if look == Look::Geometry {
            mesh.write_obj(&ctx.out.join(format!("{}.obj", p.label)))?;
        }
        shown.push(Shown {
            volume: g.total(),
            mesh,
        });
        images.push(render_framed(
            vec![(p.label.clone(), density, CLOUD_COLOR)],
            (dom, frame),
            pixels,
            0.5,
            kappa,
        )?);
    }
    Ok(Rendered {
        shown,
        images,
        frame,
    })
}

/// The smallest box of whole cells of `dom` holding every positive cell of
/// `grids`.
///
/// # Errors
/// If every grid is empty (nothing to frame).
fn occupied(grids: &[ScalarGrid], dom: Domain) -> Result<Domain> {
    let (mut lo, mut hi) = ([usize::MAX; 3], [0usize; 3]);
    for g in grids {
        for ((k, j, i), &v) in g.data().indexed_iter() {
            if v > 0.0 {
                for (a, c) in [i, j, k].into_iter().enumerate() {
                    lo[a] = lo[a].min(c);
                    hi[a] = hi[a].max(c + 1);
                }
            }
        }
    }
    anyhow::ensure!(lo[0] < hi[0], "nothing to frame: every panel is empty");
    let origin = dom.origin + dom.cell * Vec3::new(lo[0] as f32, lo[1] as f32, lo[2] as f32);
    Ok(Domain::new(
        origin,
        dom.cell,
        [0, 1, 2].map(|a| hi[a] - lo[a]),
    )?)
}

/// The `data.csv` row of a panel that measures only what every panel has.
#[derive(Serialize)]
pub(crate) struct PanelRow {
    panel: String,
    volume: f64,
    triangles: usize,
}

/// One [`PanelRow`] per panel, from its `label` and what was `shown`.
pub(crate) fn panel_rows(labels: Vec<String>, shown: Vec<Shown>) -> Vec<PanelRow> {
    labels
        .into_iter()
        .zip(shown)
        .map(|(panel, s)| PanelRow {
            panel,
            volume: s.volume,
            triangles: s.mesh.triangles.len(),
        })
        .collect()
}

/// Write `rows` as `<out>/data.csv` and the manifest with `config`, for a
/// run started at `start`.
pub(crate) fn write_table(
    ctx: &crate::experiment::kit::Context,
    config: impl Serialize,
    rows: &[impl Serialize],
    start: Instant,
) -> Result<()> {
    crate::figures::table::write_rows(&ctx.out.join("data.csv"), rows)?;
    ctx.write_manifest(config, 0xc10d, start, serde_json::json!({}))
}

/// What every billow value shares: the bunny, the cloud after the first
/// layer (eq 3.8 leaves `N_0` as it is), the raw layers, and the points
/// of the bunny's surface on which `Q` is measured.
pub(crate) struct Wedge {
    /// The cloud after the first layer.
    pub(crate) first: Scalar,
    layers: Vec<Scalar>,
    surface: Vec<Vec3>,
    grid: usize,
}

impl Wedge {
    /// The shared parts at `grid` cells per axis.
    pub(crate) fn new(grid: usize) -> Result<Self> {
        let base = base(grid)?;
        let layers = layers(3, constant(SCALE));
        let first = cloud(base.clone(), &layers[..1], 0, grid)?;
        let surface = Mesh::from_level_set(&*base, domain(grid)?).vertices;
        Ok(Self {
            first,
            layers,
            surface,
            grid,
        })
    }

    /// The three-layer cloud with canyon clearing `b` (eq 3.8, `Q_i`
    /// measured, [`QUANTILE`]), its cleared layers and the `Q_i`.
    pub(crate) fn cloud(&self, b: f32) -> Result<Billowed> {
        let (cleared, q) = measured_billow(&self.layers, constant(b), &self.surface, QUANTILE)?;
        let level_set = cloud(self.first.clone(), &cleared[1..], 1, self.grid)?;
        Ok(Billowed {
            level_set,
            cleared,
            q,
        })
    }

    /// Mean over the bunny's surface points of `Σ |N_i^c|` over `layers`.
    pub(crate) fn displacement(&self, layers: &[Scalar]) -> f64 {
        mean(&self.displacements(layers))
    }

    /// `Σ |N_i^c|` over `layers` at each of the bunny's surface points.
    pub(crate) fn displacements(&self, layers: &[Scalar]) -> Vec<f64> {
        self.surface
            .iter()
            .map(|&x| {
                layers
                    .iter()
                    .map(|l| f64::from(l.eval(x).abs()))
                    .sum::<f64>()
            })
            .collect()
    }

    /// The material the cleared layers add to the first layer's cloud:
    /// `mask(ℓ) − mask(ℓ_1)` for the full level set `ℓ` (eq 3.4 only adds
    /// `|N_i^c|`, so it holds the first layer's cloud), clamped to `[0, 1]`.
    pub(crate) fn added(&self, level_set: &Scalar) -> Scalar {
        clamp(
            ops::sum(
                ops::mask(level_set.clone()),
                ops::scale(ops::mask(self.first.clone()), -1.0),
            ),
            0.0,
            1.0,
        )
    }
}

/// A billowed cloud.
pub(crate) struct Billowed {
    /// Its level set.
    pub level_set: Scalar,
    /// The cleared layers `N_i^c`.
    pub(crate) cleared: Vec<Scalar>,
    /// `Q_i` for the layers after the first.
    pub(crate) q: Vec<f32>,
}

/// The three-layer cloud with canyon clearing `b` (eq 3.8).
pub(crate) fn billowed(b: f32, grid: usize) -> Result<Scalar> {
    Ok(Wedge::new(grid)?.cloud(b)?.level_set)
}

/// The mean of `values`.
pub(crate) fn mean(values: &[f64]) -> f64 {
    values.iter().sum::<f64>() / values.len() as f64
}
