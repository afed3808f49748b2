//! Pinhole camera: the ray of each pixel, `x(s) = x_C + s n_P` (eq A.2).

use glam::Vec3;
use serde::Serialize;

use crate::domain::Domain;
use crate::error::InputError;

/// Largest image side accepted, in pixels.
pub const MAX_IMAGE_SIDE: u32 = 16_384;

/// A pinhole camera with a vertical field of view.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Camera {
    /// Eye position x_C.
    pub position: Vec3,
    /// Point the optical axis passes through.
    pub look_at: Vec3,
    /// Approximate up direction (made orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub fov_deg: f32,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
}

/// The camera's orthonormal frame and image-plane scale, ready to make rays.
#[derive(Clone, Copy, Debug)]
pub struct RayGen {
    origin: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    /// Half-height of the image plane at unit distance, `tan(fov/2)`.
    half_h: f32,
    width: u32,
    height: u32,
}

/// Default viewing direction (from the box centre towards the eye): in
/// front of the box (+z), a little to the right and above, so a TD sees the
/// volume in three-quarter view with its top face foreshortened.
const DEFAULT_VIEW: Vec3 = Vec3::new(0.35, 0.3, 1.0);

impl Camera {
    /// A camera that frames `domain`: looking at the box centre from
    /// [`DEFAULT_VIEW`] with a 30° vertical fov, at the distance where the
    /// box's eight corners fill `fill` (0..1] of the image's half-width or
    /// half-height, whichever binds.
    pub fn framing(domain: &Domain, width: u32, height: u32, fill: f32) -> Self {
        let fov_deg: f32 = 30.0;
        let centre = domain.origin + 0.5 * domain.size();
        let back = DEFAULT_VIEW.normalize();
        let right = (-back).cross(Vec3::Y).normalize();
        let up = right.cross(-back);
        let ky = fill * (0.5 * fov_deg).to_radians().tan();
        let kx = ky * width as f32 / height.max(1) as f32;
        // A corner c (relative to the centre) at eye distance d has depth
        // d − c·back; it projects inside when |c·right| ≤ kx·depth and
        // |c·up| ≤ ky·depth.
        let mut dist: f32 = 0.0;
        for i in 0..8 {
            let c = (Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32) - 0.5)
                * domain.size();
            let need = c.dot(back) + (c.dot(right).abs() / kx).max(c.dot(up).abs() / ky);
            dist = dist.max(need);
        }
        Self {
            position: centre + back * dist,
            look_at: centre,
            up: Vec3::Y,
            fov_deg,
            width,
            height,
        }
    }

    /// Check the camera: finite vectors, distinct eye and target, an up
    /// vector not parallel to the view, 0 < fov < 180, image sides in
    /// `1..=MAX_IMAGE_SIDE`.
    pub fn validate(&self) -> Result<(), InputError> {
        for (name, v) in [
            ("camera position", self.position),
            ("camera look-at", self.look_at),
            ("camera up", self.up),
        ] {
            if !v.is_finite() {
                return Err(InputError::new(format!("{name} is {v}; it must be finite")));
            }
        }
        let dir = self.look_at - self.position;
        if dir.length() <= 1e-6 * (1.0 + self.position.length()) {
            return Err(InputError::new(format!(
                "camera position and look-at coincide at {}; they must differ",
                self.position
            )));
        }
        if dir.normalize().cross(self.up).length() < 1e-4 {
            return Err(InputError::new(format!(
                "camera up {} is parallel to the view direction; choose another up",
                self.up
            )));
        }
        if !(self.fov_deg.is_finite() && self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return Err(InputError::new(format!(
                "field of view is {}°; it must lie strictly between 0 and 180",
                self.fov_deg
            )));
        }
        check_image_size(self.width, self.height)
    }

    /// The ray generator (call after [`Camera::validate`]).
    pub fn rays(&self) -> RayGen {
        let forward = (self.look_at - self.position).normalize();
        let right = forward.cross(self.up).normalize();
        let up = right.cross(forward);
        RayGen {
            origin: self.position,
            forward,
            right,
            up,
            half_h: (0.5 * self.fov_deg).to_radians().tan(),
            width: self.width,
            height: self.height,
        }
    }
}

impl RayGen {
    /// Eye position.
    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    /// Unit direction n_P through the centre of pixel `(px, py)`, `py = 0`
    /// at the top of the image.
    #[inline]
    pub fn direction(&self, px: u32, py: u32) -> Vec3 {
        let aspect = self.width as f32 / self.height as f32;
        let u = (2.0 * (px as f32 + 0.5) / self.width as f32 - 1.0) * self.half_h * aspect;
        let v = (1.0 - 2.0 * (py as f32 + 0.5) / self.height as f32) * self.half_h;
        (self.forward + u * self.right + v * self.up).normalize()
    }
}

/// Check that both image sides lie in `1..=MAX_IMAGE_SIDE`.
pub fn check_image_size(width: u32, height: u32) -> Result<(), InputError> {
    for (name, n) in [("width", width), ("height", height)] {
        if n == 0 || n > MAX_IMAGE_SIDE {
            return Err(InputError::new(format!(
                "image {name} is {n}; it must be between 1 and {MAX_IMAGE_SIDE} pixels"
            )));
        }
    }
    Ok(())
}

/// Parse `WxH` (e.g. `256x256`) into an image size within `1..=MAX_IMAGE_SIDE`.
pub fn parse_image_size(s: &str) -> Result<(u32, u32), InputError> {
    let bad = || {
        InputError::new(format!(
            "image size '{s}' is not valid; use WxH with sides from 1 to {MAX_IMAGE_SIDE}, e.g. 256x256"
        ))
    };
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(bad)?;
    let w: u32 = w.trim().parse().map_err(|_| bad())?;
    let h: u32 = h.trim().parse().map_err(|_| bad())?;
    if w == 0 || h == 0 || w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE {
        return Err(bad());
    }
    Ok((w, h))
}

/// Parse `X,Y,Z` into a finite vector; `what` names the option in errors.
pub fn parse_vec3(s: &str, what: &str) -> Result<Vec3, InputError> {
    let bad = || {
        InputError::new(format!(
            "{what} '{s}' is not valid; give three finite numbers X,Y,Z"
        ))
    };
    let v: Vec<f32> = s
        .split(',')
        .map(|t| t.trim().parse::<f32>().map_err(|_| bad()))
        .collect::<Result<_, _>>()?;
    match v.as_slice() {
        &[x, y, z] if x.is_finite() && y.is_finite() && z.is_finite() => Ok(Vec3::new(x, y, z)),
        _ => Err(bad()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_pixel_looks_at_target_and_corners_span_the_fov() {
        let cam = Camera {
            position: Vec3::new(0.0, 0.0, 10.0),
            look_at: Vec3::ZERO,
            up: Vec3::Y,
            fov_deg: 90.0,
            width: 3,
            height: 3,
        };
        cam.validate().unwrap();
        let r = cam.rays();
        assert!((r.direction(1, 1) - Vec3::NEG_Z).length() < 1e-6);
        // Top row looks up, right column looks right; pixel centres sit at ±2/3 of tan(45°).
        let top = r.direction(1, 0);
        assert!((top.y / -top.z - 2.0 / 3.0).abs() < 1e-6);
        let right = r.direction(2, 1);
        assert!((right.x / -right.z - 2.0 / 3.0).abs() < 1e-6);
    }

    #[test]
    fn framing_keeps_the_box_in_view() {
        let d = Domain::cube(10, 10.0).unwrap();
        for (w, h) in [(256, 256), (400, 200), (200, 400)] {
            let cam = Camera::framing(&d, w, h, 0.9);
            cam.validate().unwrap();
            let r = cam.rays();
            let fwd = (cam.look_at - cam.position).normalize();
            // Every corner of the box projects inside the image, and one
            // touches 90 % of a side.
            let mut extent: f32 = 0.0;
            for c in 0..8 {
                let corner = Vec3::new(
                    (c & 1) as f32 * 10.0,
                    ((c >> 1) & 1) as f32 * 10.0,
                    ((c >> 2) & 1) as f32 * 10.0,
                );
                let v = corner - cam.position;
                let z = v.dot(fwd);
                let x = v.dot(r.right) / z / r.half_h / (w as f32 / h as f32);
                let y = v.dot(r.up) / z / r.half_h;
                assert!(
                    x.abs() < 0.9001 && y.abs() < 0.9001,
                    "corner {corner} at ({x}, {y})"
                );
                extent = extent.max(x.abs()).max(y.abs());
            }
            assert!(extent > 0.899, "loosest corner at {extent}");
        }
    }

    #[test]
    fn rejects_bad_cameras_and_sizes() {
        let d = Domain::cube(8, 1.0).unwrap();
        let good = Camera::framing(&d, 16, 16, 0.9);
        let mut c = good;
        c.position.x = f32::NAN;
        assert!(c.validate().is_err());
        let mut c = good;
        c.width = 0;
        assert!(c.validate().is_err());
        let mut c = good;
        c.up = c.look_at - c.position;
        assert!(c.validate().is_err());
        assert_eq!(parse_image_size("320x200").unwrap(), (320, 200));
        for bad in ["0x10", "10x0", "100000x10", "10", "axb", "-5x5"] {
            assert!(parse_image_size(bad).is_err(), "{bad}");
        }
        assert_eq!(parse_vec3("1,2,3", "x").unwrap(), Vec3::new(1.0, 2.0, 3.0));
        assert!(parse_vec3("1,2", "x").is_err());
        assert!(parse_vec3("1,inf,2", "x").is_err());
    }
}
