//! Volume renders of modelled shapes (ch. 3–5 experiments): each density
//! is a field, rendered with the appendix-A marcher under the default look
//! (one key light, isotropic phase), its own display colour per volume.

use anyhow::Result;
use glam::Vec3;
use image::RgbImage;

use smokelab::domain::Domain;
use smokelab::field::Scalar;
use smokelab::render::output::{self, Display};
use smokelab::render::phase::Phase;
use smokelab::render::{camera::Camera, look, render, RenderSettings, Scene};

/// Display colours for many pieces: hues around the wheel, light enough to
/// read under the key light.
pub(crate) fn palette(i: usize) -> Vec3 {
    let h = (i as f32 * 0.618_034).fract() * 6.0;
    let x = 1.0 - (h % 2.0 - 1.0).abs();
    let (r, g, b) = match h as u32 {
        0 => (1.0, x, 0.0),
        1 => (x, 1.0, 0.0),
        2 => (0.0, 1.0, x),
        3 => (0.0, x, 1.0),
        4 => (x, 0.0, 1.0),
        _ => (1.0, 0.0, x),
    };
    Vec3::new(r, g, b) * 0.75 + Vec3::splat(0.2)
}

/// A square render of `densities` (name, density, colour) inside `bounds`,
/// marched at `step` cells per step, with extinction `kappa` per unit
/// density.
pub(crate) fn render_densities(
    densities: Vec<(String, Scalar, Vec3)>,
    bounds: Domain,
    side: u32,
    step: f32,
    kappa: f32,
) -> Result<RgbImage> {
    render_framed(densities, (bounds, bounds), side, step, kappa)
}

/// [`render_densities`] with the camera framing `frame` (a box inside
/// `bounds` that holds the densities) instead of the whole of `bounds`, so
/// the shape fills the image.
pub(crate) fn render_framed(
    densities: Vec<(String, Scalar, Vec3)>,
    (bounds, frame): (Domain, Domain),
    side: u32,
    step: f32,
    kappa: f32,
) -> Result<RgbImage> {
    let volumes = densities
        .into_iter()
        .map(|(name, density, color)| look::smoke(name, density, color, kappa, look::GLOW))
        .collect();
    let scene = Scene {
        bounds,
        volumes,
        lights: vec![look::key_light(&bounds)],
        phase: Phase::Isotropic,
    };
    let settings = RenderSettings {
        step: Some(step * bounds.cell),
        ..RenderSettings::new(Camera::framing(&frame, side, side, look::FILL))
    };
    let r = render(&scene, &settings)?;
    Ok(output::preview(&r.image, &Display::default()))
}
