//! Analytic level sets, positive inside and negative outside (the notes'
//! convention, §3.2), each with its gradient in closed form: a sphere and a
//! torus as signed distances, the flat knife of eq 5.1, and an ellipsoid.

use std::sync::Arc;

use glam::Vec3;

use crate::error::{check_positive, InputError};
use crate::field::{Scalar, ScalarField};

/// Fill `out[i] = f(points[i])`, checking the lengths.
fn each<T>(points: &[Vec3], out: &mut [T], f: impl Fn(Vec3) -> T) {
    assert_eq!(points.len(), out.len(), "grad_batch: slice lengths differ");
    for (o, &p) in out.iter_mut().zip(points) {
        *o = f(p);
    }
}

/// Signed distance to a sphere, `R − |x − c|` (§3.3.2).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SphereDistance {
    /// Centre.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
}

impl ScalarField for SphereDistance {
    fn eval(&self, p: Vec3) -> f32 {
        self.radius - (p - self.center).length()
    }
    fn grad_batch(&self, points: &[Vec3], out: &mut [Vec3]) -> bool {
        each(points, out, |p| -(p - self.center).normalize_or_zero());
        true
    }
}

/// Signed distance to a torus of major radius `R` around `axis` and tube
/// radius `r`: `r − |(ρ − R, h)|`, with `h` the height along the axis and `ρ`
/// the distance from it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TorusDistance {
    /// Centre.
    pub center: Vec3,
    /// Unit axis of symmetry.
    pub axis: Vec3,
    /// Major radius R (centre to tube centre).
    pub major: f32,
    /// Tube radius r.
    pub minor: f32,
}

impl TorusDistance {
    /// `(ring offset w, |w|)`: the vector from the nearest point of the tube's
    /// centre circle to `p`.
    #[inline]
    fn offset(&self, p: Vec3) -> Vec3 {
        let q = p - self.center;
        let h = q.dot(self.axis);
        let radial = q - h * self.axis;
        let rho = radial.length();
        let out = if rho > 0.0 { radial / rho } else { Vec3::ZERO };
        (rho - self.major) * out + h * self.axis
    }
}

impl ScalarField for TorusDistance {
    fn eval(&self, p: Vec3) -> f32 {
        self.minor - self.offset(p).length()
    }
    fn grad_batch(&self, points: &[Vec3], out: &mut [Vec3]) -> bool {
        each(points, out, |p| -self.offset(p).normalize_or_zero());
        true
    }
}

/// The straight-edge knife of eq 5.1, `K(x) = (x − x_P) · n`: the signed
/// distance to the plane through `x_P` with unit normal `n`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plane {
    /// A point on the plane.
    pub point: Vec3,
    /// Unit normal (the positive side).
    pub normal: Vec3,
}

impl ScalarField for Plane {
    fn eval(&self, p: Vec3) -> f32 {
        (p - self.point).dot(self.normal)
    }
    fn grad_batch(&self, points: &[Vec3], out: &mut [Vec3]) -> bool {
        each(points, out, |_| self.normal);
        true
    }
}

/// An ellipsoid with semi-axes `radii` along x, y, z:
/// `m (1 − |(x − c) / radii|)` with `m` the smallest semi-axis, a level set
/// whose zero set is the ellipsoid and whose slope is 1 at the ends of its
/// shortest axis (not a signed distance elsewhere).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ellipsoid {
    /// Centre.
    pub center: Vec3,
    /// Semi-axes.
    pub radii: Vec3,
}

impl ScalarField for Ellipsoid {
    fn eval(&self, p: Vec3) -> f32 {
        self.radii.min_element() * (1.0 - ((p - self.center) / self.radii).length())
    }
    fn grad_batch(&self, points: &[Vec3], out: &mut [Vec3]) -> bool {
        let m = self.radii.min_element();
        each(points, out, |p| {
            let s = (p - self.center) / self.radii;
            -m * s.normalize_or_zero() / self.radii
        });
        true
    }
}

/// A sphere's signed distance.
///
/// # Panics
/// If the radius is not positive (use [`try_sphere`] for user input).
pub fn sphere(center: Vec3, radius: f32) -> Scalar {
    try_sphere(center, radius).expect("sphere radius")
}

/// A sphere's signed distance, refusing a radius that is not positive.
pub fn try_sphere(center: Vec3, radius: f32) -> Result<Scalar, InputError> {
    check_positive("sphere radius", radius)?;
    Ok(Arc::new(SphereDistance { center, radius }))
}

/// A torus's signed distance; refuses a non-positive radius or a zero axis.
pub fn torus(center: Vec3, axis: Vec3, major: f32, minor: f32) -> Result<Scalar, InputError> {
    check_positive("torus major radius", major)?;
    check_positive("torus tube radius", minor)?;
    let axis = axis.try_normalize().ok_or_else(|| {
        InputError::new(format!(
            "torus axis is {axis}; it must be a non-zero finite vector"
        ))
    })?;
    Ok(Arc::new(TorusDistance {
        center,
        axis,
        major,
        minor,
    }))
}

/// The knife of eq 5.1 through `point` with normal `normal` (normalised);
/// refuses a zero normal.
pub fn plane(point: Vec3, normal: Vec3) -> Result<Scalar, InputError> {
    let normal = normal.try_normalize().ok_or_else(|| {
        InputError::new(format!(
            "plane normal is {normal}; it must be a non-zero finite vector"
        ))
    })?;
    Ok(Arc::new(Plane { point, normal }))
}

/// An ellipsoid's level set; refuses a semi-axis that is not positive.
pub fn ellipsoid(center: Vec3, radii: Vec3) -> Result<Scalar, InputError> {
    for (a, r) in ["x", "y", "z"].iter().zip(radii.to_array()) {
        check_positive(&format!("ellipsoid semi-axis {a}"), r)?;
    }
    Ok(Arc::new(Ellipsoid { center, radii }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::algebra::grad;

    /// Each closed-form gradient against central differences, and each
    /// signed distance has unit slope.
    #[test]
    fn closed_form_gradients_match_differences() {
        struct Hidden(Scalar);
        impl ScalarField for Hidden {
            fn eval(&self, p: Vec3) -> f32 {
                self.0.eval(p)
            }
        }
        let shapes = [
            (sphere(Vec3::new(0.1, 0.2, 0.0), 0.7), true),
            (
                torus(Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), 0.6, 0.2).unwrap(),
                true,
            ),
            (plane(Vec3::ONE, Vec3::new(1.0, -2.0, 0.5)).unwrap(), true),
            (
                ellipsoid(Vec3::ZERO, Vec3::new(0.5, 0.8, 1.1)).unwrap(),
                false,
            ),
        ];
        for (s, distance) in shapes {
            let fd = grad(Arc::new(Hidden(s.clone())), 1e-3);
            for i in 0..30 {
                let t = i as f32;
                let p = Vec3::new((1.3 * t).sin(), (0.7 * t).cos(), (0.4 * t + 0.2).sin());
                let mut g = [Vec3::ZERO];
                assert!(s.grad_batch(&[p], &mut g));
                assert!(
                    (g[0] - fd.eval(p)).length() < 1e-2,
                    "{p}: {} vs {}",
                    g[0],
                    fd.eval(p)
                );
                if distance {
                    assert!((g[0].length() - 1.0).abs() < 1e-5);
                }
            }
        }
    }

    #[test]
    fn bad_shapes_are_refused_with_the_value() {
        let e = try_sphere(Vec3::ZERO, -1.0).err().unwrap().to_string();
        assert!(e.contains("-1"), "{e}");
        assert!(torus(Vec3::ZERO, Vec3::ZERO, 1.0, 0.1).is_err());
        assert!(plane(Vec3::ZERO, Vec3::ZERO).is_err());
        assert!(ellipsoid(Vec3::ZERO, Vec3::new(1.0, 0.0, 1.0)).is_err());
    }
}
