//! Volume rendering by ray marching (the notes' appendix A).
//!
//! The renderer only *queries* densities (§1.1: "all that is needed of the
//! volumetric data is that it can be queried"): a [`Scene`] is a list of
//! [`Volume`]s — each a [`Scalar`] field with its emission colour `C^E`,
//! scattering colour `C^S` and extinction `κ` — lit by [`PointLight`]s, inside
//! a box the rays are clipped to. Gridded, gridless and SELMA densities all
//! render through the same code.
//!
//! - [`camera`] — pinhole camera, pixel rays (A.2);
//! - [`phase`] — isotropic, Henyey–Greenstein (A.8), Fournier–Forand (A.9–A.12);
//! - [`lights`] — point lights and their transmissivity grids (A.4–A.7);
//! - [`march`] — the ray march (A.22–A.29);
//! - [`output`] — EXR (linear, premultiplied) and sRGB PNG previews;
//! - [`look`] — the default look of smoke renders (colours, light, exposure).
//!
//! ```
//! use glam::Vec3;
//! use smokelab::domain::Domain;
//! use smokelab::field::ops;
//! use smokelab::render::{self, camera::Camera, RenderSettings, Scene, Volume};
//! let bounds = Domain::cube(16, 2.0).unwrap();
//! let scene = Scene {
//!     bounds,
//!     volumes: vec![Volume {
//!         name: "ball".into(),
//!         density: ops::mask(ops::sphere(Vec3::ONE, 0.5)),
//!         emission: Vec3::new(1.0, 0.3, 0.1),
//!         scattering: Vec3::ZERO,
//!         kappa: 4.0,
//!         occupancy: None,
//!     }],
//!     lights: vec![],
//!     phase: render::phase::Phase::Isotropic,
//! };
//! let settings = RenderSettings::new(Camera::framing(&bounds, 32, 32, 0.9));
//! let out = render::render(&scene, &settings).unwrap();
//! assert_eq!(out.image.alpha(0, 0), 0.0); // corner pixel misses the ball
//! assert!(out.image.alpha(16, 16) > 0.9); // centre pixel sees it
//! ```

pub mod camera;
pub mod lights;
pub mod look;
pub mod march;
pub mod output;
pub mod phase;

use std::time::Instant;

use std::sync::Arc;

use glam::Vec3;
use rayon::prelude::*;
use serde::Serialize;

use crate::density::occupancy::Occupancy;
use crate::domain::Domain;
use crate::error::InputError;
use crate::field::Scalar;
use camera::Camera;
use lights::{LitLight, PointLight};
use march::{Marcher, RowScratch};
use phase::Phase;

/// One density field and how it looks.
#[derive(Clone, Serialize)]
pub struct Volume {
    /// Name (for manifests).
    pub name: String,
    /// The density ρ, queried at sample points.
    #[serde(skip)]
    pub density: Scalar,
    /// Emission colour `C^E` per unit density (linear RGB).
    pub emission: Vec3,
    /// Scattering colour `C^S` per unit density (linear RGB).
    pub scattering: Vec3,
    /// Extinction coefficient κ per unit density.
    pub kappa: f32,
    /// Where the density may be positive (`None`: anywhere). When every
    /// volume has one, the march does not sample where all are clear.
    #[serde(skip)]
    pub occupancy: Option<Arc<Occupancy>>,
}

/// What is rendered: volumes, lights, phase function and the box rays are
/// clipped to.
#[derive(Clone, Serialize)]
pub struct Scene {
    /// The render box; its cell size is the default march step and its
    /// cells carry the light transmissivity grids.
    pub bounds: Domain,
    /// Density fields with their colours.
    pub volumes: Vec<Volume>,
    /// Point lights.
    pub lights: Vec<PointLight>,
    /// Phase function of every volume.
    pub phase: Phase,
}

/// How a scene is rendered.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct RenderSettings {
    /// Camera and image size.
    pub camera: Camera,
    /// March step Δs (`None`: the box's cell size; the notes' fine setting is cell/10).
    pub step: Option<f32>,
    /// Sub-steps `N_s` per march step (eq A.29).
    pub substeps: u32,
    /// Sample each sub-step at a random point instead of its midpoint.
    pub jitter: bool,
    /// Seed of the jitter.
    pub seed: u64,
}

impl RenderSettings {
    /// Defaults: Δs = cell, one jittered sub-step, seed 0.
    pub fn new(camera: Camera) -> Self {
        Self {
            camera,
            step: None,
            substeps: 1,
            jitter: true,
            seed: 0,
        }
    }
}

/// A linear, premultiplied RGBA image, row 0 at the top.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `4 × width × height` floats, RGBA per pixel, rows top to bottom.
    pub rgba: Vec<f32>,
}

impl Image {
    /// RGBA of pixel `(x, y)`.
    pub fn pixel(&self, x: u32, y: u32) -> [f32; 4] {
        let o = 4 * (y as usize * self.width as usize + x as usize);
        [
            self.rgba[o],
            self.rgba[o + 1],
            self.rgba[o + 2],
            self.rgba[o + 3],
        ]
    }

    /// Alpha `1 − T` of pixel `(x, y)`.
    pub fn alpha(&self, x: u32, y: u32) -> f32 {
        self.pixel(x, y)[3]
    }
}

/// What a render cost, for manifests and benchmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct RenderStats {
    /// Image width.
    pub width: u32,
    /// Image height.
    pub height: u32,
    /// March step Δs used.
    pub step: f32,
    /// Sub-steps per march step.
    pub substeps: u32,
    /// Rays that hit the render box.
    pub rays: u64,
    /// Camera-ray sample points (each queries every volume once).
    pub samples: u64,
    /// Camera-ray sub-steps not sampled: every volume's [`Occupancy`] is
    /// clear there (`samples + skipped` is what the march takes without).
    pub skipped: u64,
    /// Density queries made for the light grids.
    pub light_grid_queries: u64,
    /// Seconds building the light grids.
    pub light_seconds: f64,
    /// Seconds of the whole render.
    pub seconds: f64,
    /// `samples / seconds`.
    pub samples_per_second: f64,
    /// `(samples + skipped) / seconds`: sub-steps marched per second.
    pub substeps_per_second: f64,
}

/// An image and its statistics.
#[derive(Clone, Debug)]
pub struct Rendered {
    /// The image.
    pub image: Image,
    /// What it cost.
    pub stats: RenderStats,
}

/// Check a scene and settings; the error names the bad value.
pub fn validate(scene: &Scene, settings: &RenderSettings) -> Result<(), InputError> {
    settings.camera.validate()?;
    if scene.volumes.is_empty() {
        return Err(InputError::new(
            "nothing to render: give at least one volume",
        ));
    }
    for v in &scene.volumes {
        if !(v.kappa.is_finite() && v.kappa >= 0.0) {
            return Err(InputError::new(format!(
                "kappa of '{}' is {}; it must be a finite number ≥ 0",
                v.name, v.kappa
            )));
        }
        for (what, c) in [("emission", v.emission), ("scattering", v.scattering)] {
            if !(c.is_finite() && c.min_element() >= 0.0) {
                return Err(InputError::new(format!(
                    "{what} colour of '{}' is {c}; it must be finite and non-negative",
                    v.name
                )));
            }
        }
    }
    for l in &scene.lights {
        l.validate()?;
    }
    if let Some(step) = settings.step {
        check_step(step, &scene.bounds)?;
    }
    if !(1..=64).contains(&settings.substeps) {
        return Err(InputError::new(format!(
            "sub-steps is {}; it must be between 1 and 64",
            settings.substeps
        )));
    }
    Ok(())
}

/// Check a march step against the render box: positive, at most the box
/// size, and not so small that a ray would take more than 10⁶ steps.
pub fn check_step(step: f32, bounds: &Domain) -> Result<(), InputError> {
    let size = bounds.size().max_element();
    if !(step.is_finite() && step > 0.0 && step <= size && size / step <= 1e6) {
        return Err(InputError::new(format!(
            "march step is {step}; it must lie between {} and the box size {size}",
            size / 1e6
        )));
    }
    Ok(())
}

/// Render `scene` as seen by `settings.camera`.
///
/// Builds the light transmissivity grids once, then marches every pixel in
/// parallel over image rows.
pub fn render(scene: &Scene, settings: &RenderSettings) -> Result<Rendered, InputError> {
    validate(scene, settings)?;
    let start = Instant::now();
    let bounds = scene.bounds;
    let (lit, light_grid_queries) = light_grids(scene);
    let light_seconds = start.elapsed().as_secs_f64();
    let cam = settings.camera;
    let step = settings.step.unwrap_or(bounds.cell);
    let occupancy = empty_space(&scene.volumes);
    let marcher = Marcher {
        rays: cam.rays(),
        lo: bounds.origin,
        hi: bounds.max_corner(),
        volumes: &scene.volumes,
        lights: &lit,
        phase: scene.phase,
        substep: step / settings.substeps as f32,
        jitter: settings.jitter,
        seed: settings.seed,
        width: cam.width,
        occupancy: &occupancy,
    };
    let mut rgba = vec![0.0f32; 4 * cam.width as usize * cam.height as usize];
    let counts: Vec<march::RowCounts> = rgba
        .par_chunks_mut(4 * cam.width as usize)
        .enumerate()
        .map_init(RowScratch::default, |scratch, (py, row)| {
            marcher.row(py as u32, row, scratch)
        })
        .collect();
    let seconds = start.elapsed().as_secs_f64();
    let rays = counts.iter().map(|c| c.rays).sum();
    let samples = counts.iter().map(|c| c.samples).sum::<u64>();
    let skipped = counts.iter().map(|c| c.skipped).sum::<u64>();
    Ok(Rendered {
        image: Image {
            width: cam.width,
            height: cam.height,
            rgba,
        },
        stats: RenderStats {
            width: cam.width,
            height: cam.height,
            step,
            substeps: settings.substeps,
            rays,
            samples,
            skipped,
            light_grid_queries,
            light_seconds,
            seconds,
            samples_per_second: samples as f64 / seconds.max(1e-12),
            substeps_per_second: (samples + skipped) as f64 / seconds.max(1e-12),
        },
    })
}

/// The bounds the march may skip by: every volume's occupancy, each
/// shared one once; none if some volume has none.
fn empty_space(volumes: &[Volume]) -> Vec<&Occupancy> {
    let mut out: Vec<&Occupancy> = vec![];
    for v in volumes {
        match &v.occupancy {
            None => return vec![],
            Some(o) => {
                if !out.iter().any(|&p| std::ptr::eq(p, &**o)) {
                    out.push(o);
                }
            }
        }
    }
    out
}

/// The transmissivity grid of every light (none when nothing scatters).
fn light_grids(scene: &Scene) -> (Vec<LitLight>, u64) {
    let scatters = scene.volumes.iter().any(|v| v.scattering != Vec3::ZERO);
    if scene.lights.is_empty() || !scatters {
        return (vec![], 0);
    }
    let (sigma, queries) = lights::extinction_grid(&scene.bounds, &scene.volumes);
    let lit = scene
        .lights
        .iter()
        .map(|l| LitLight {
            light: *l,
            transmissivity: lights::light_transmissivity(l, &sigma),
        })
        .collect();
    (lit, queries)
}

/// Entry and exit distances `(t0, t1)` of the ray `o + t d` through the box
/// `[lo, hi]` (slab method), or `None` if it misses or the box is behind.
/// `t0` may be negative when `o` is inside.
#[inline]
pub fn ray_box(o: Vec3, d: Vec3, lo: Vec3, hi: Vec3) -> Option<(f32, f32)> {
    let (mut t0, mut t1) = (f32::NEG_INFINITY, f32::INFINITY);
    for a in 0..3 {
        if d[a] == 0.0 {
            if o[a] < lo[a] || o[a] > hi[a] {
                return None;
            }
            continue;
        }
        let inv = 1.0 / d[a];
        let (mut ta, mut tb) = ((lo[a] - o[a]) * inv, (hi[a] - o[a]) * inv);
        if ta > tb {
            std::mem::swap(&mut ta, &mut tb);
        }
        t0 = t0.max(ta);
        t1 = t1.min(tb);
    }
    (t1 >= t0 && t1 > 0.0).then_some((t0, t1))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ray_box_hits_misses_and_starts_inside() {
        let (lo, hi) = (Vec3::ZERO, Vec3::ONE);
        let (t0, t1) = ray_box(Vec3::new(0.5, 0.5, -1.0), Vec3::Z, lo, hi).unwrap();
        assert_eq!((t0, t1), (1.0, 2.0));
        assert!(ray_box(Vec3::new(2.0, 0.5, -1.0), Vec3::Z, lo, hi).is_none());
        assert!(ray_box(Vec3::new(0.5, 0.5, 2.0), Vec3::Z, lo, hi).is_none());
        let (t0, t1) = ray_box(Vec3::splat(0.5), Vec3::X, lo, hi).unwrap();
        assert_eq!((t0, t1), (-0.5, 0.5));
        let d = Vec3::ONE.normalize();
        let (t0, t1) = ray_box(Vec3::splat(-1.0), d, lo, hi).unwrap();
        assert!((t1 - t0 - 3f32.sqrt()).abs() < 1e-5);
    }
}
