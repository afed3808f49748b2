//! What the warp experiments of chapter 4 (04-1, 04-2) share: the box,
//! the object of fig 4.1 (a cone and two linked tori) and the reference
//! the nacelle warp maps onto it (a sphere).

use std::sync::Arc;

use anyhow::Result;
use glam::Vec3;

use smokelab::domain::Domain;
use smokelab::field::algebra::max;
use smokelab::field::{Scalar, ScalarField};
use smokelab::model::shape;

/// The box `[−1, 1]³` at `grid` cells per axis.
pub(crate) fn domain(grid: usize) -> Result<Domain> {
    Ok(Domain::new(
        Vec3::splat(-1.0),
        2.0 / grid as f32,
        [grid; 3],
    )?)
}

/// A cone along −y from `apex`, half-angle `angle`, cut at `height`:
/// `min((h sin α − ρ cos α), height − h)` with `h` the depth below the apex
/// and `ρ` the distance from the axis — positive inside, slope 1 on the mantle.
struct Cone {
    apex: Vec3,
    angle: f32,
    height: f32,
}

impl ScalarField for Cone {
    fn eval(&self, p: Vec3) -> f32 {
        let q = p - self.apex;
        let h = -q.y;
        let rho = (q.x * q.x + q.z * q.z).sqrt();
        let mantle = h * self.angle.sin() - rho * self.angle.cos();
        mantle.min(self.height - h)
    }
}

/// The object of fig 4.1: a cone and two linked tori, the cone through one
/// torus.
pub(crate) fn object() -> Result<Scalar> {
    let a = shape::torus(Vec3::new(-0.2, 0.15, 0.0), Vec3::Y, 0.38, 0.1)?;
    let b = shape::torus(Vec3::new(0.18, 0.15, 0.0), Vec3::Z, 0.38, 0.1)?;
    let cone: Scalar = Arc::new(Cone {
        apex: Vec3::new(-0.25, 0.55, 0.0),
        angle: 0.35,
        height: 1.2,
    });
    Ok(max(max(a, b), cone))
}

/// The reference of fig 4.1: a sphere's signed distance.
pub(crate) fn reference() -> Scalar {
    shape::sphere(Vec3::ZERO, 0.5)
}
