//! The default look of smoke renders: what a TD expects to see first.
//!
//! Colours are given as an *albedo*-like display colour `c` and scaled by κ,
//! `C^S = κ c` and `C^E = glow · κ c`, so that an opaque, fully lit region
//! renders at about `c` times the light colour whatever κ is (the march's
//! opaque limit is `C^T/κ`, eq A.22). A key light sits above, in front and to
//! the left of the box; with the isotropic phase function and exposure 1 the
//! lit side of dense smoke is near, not over, white-point, the shadowed side
//! shows the faint glow, and the background is dark.

use glam::Vec3;

use super::camera::Camera;
use super::lights::PointLight;
use super::Volume;
use crate::domain::Domain;
use crate::field::Scalar;

/// Default extinction per unit density.
pub const KAPPA: f32 = 1.5;

/// Default emission as a fraction of the scattering colour.
pub const GLOW: f32 = 0.12;

/// Display colour of the hot gas: a saturated red (sRGB ≈ 240, 70, 40).
pub const HOT: Vec3 = Vec3::new(0.88, 0.06, 0.02);
/// Display colour of the cold gas: a saturated blue (sRGB ≈ 50, 110, 245).
pub const COLD: Vec3 = Vec3::new(0.03, 0.15, 0.9);
/// Display colour of a buoyant gas in a box (fig 6.6).
pub const GREEN: Vec3 = Vec3::new(0.08, 0.7, 0.12);

/// Fraction of the image the box's corners fill in the default framing.
pub const FILL: f32 = 0.9;

/// The default camera: three-quarter view framing the whole box.
pub fn camera(bounds: &Domain, width: u32, height: u32) -> Camera {
    Camera::framing(bounds, width, height, FILL)
}

/// Default colours of the i-th volume when none is given: hot, cold, green,
/// then white.
pub fn default_color(i: usize) -> Vec3 {
    [HOT, COLD, GREEN].get(i).copied().unwrap_or(Vec3::ONE)
}

/// A smoke volume of display colour `color`: `C^S = κ color`, `C^E = glow κ color`.
pub fn smoke(
    name: impl Into<String>,
    density: Scalar,
    color: Vec3,
    kappa: f32,
    glow: f32,
) -> Volume {
    Volume {
        name: name.into(),
        density,
        emission: glow * kappa * color,
        scattering: kappa * color,
        kappa,
        occupancy: None,
    }
}

/// The key light of a box: white, above, in front (+z) and to the left, one
/// box diagonal from the centre.
pub fn key_light(bounds: &Domain) -> PointLight {
    let centre = bounds.origin + 0.5 * bounds.size();
    let diag = bounds.size().length();
    PointLight {
        position: centre + Vec3::new(-0.5, 0.8, 0.6).normalize() * diag,
        color: Vec3::splat(1.1),
    }
}
