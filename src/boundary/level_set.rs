//! Obstacles as level sets `O(x)`, positive inside (the notes' §6.3).
//!
//! Every shape here is a signed distance in world units (exact for the
//! sphere, slab and boxes), so `O` sampled at the cell centres says how deep
//! a cell lies inside an obstacle. Gradients are analytic where the shape has
//! one; [`FieldLevelSet`] wraps any scalar field and differentiates it by
//! central differences. Where a gradient is undefined (the centre of a
//! sphere) it is zero, and the boundary rules leave such a point alone.

use std::sync::Arc;

use glam::Vec3;

use crate::field::{ops, Scalar, ScalarField, VectorField};

/// A level set `O(x)`: positive inside the obstacle, negative outside.
pub trait LevelSet: Send + Sync {
    /// `O(p)`, world units.
    fn value(&self, p: Vec3) -> f32;
    /// `∇O(p)`: points into the obstacle (the outward normal is `−∇O`).
    fn gradient(&self, p: Vec3) -> Vec3;
}

/// A shared level set.
pub type Obstacle = Arc<dyn LevelSet>;

/// Solid ball: `O = r − |x − c|`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
}

impl LevelSet for Sphere {
    fn value(&self, p: Vec3) -> f32 {
        self.radius - (p - self.center).length()
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        -(p - self.center).normalize_or_zero()
    }
}

/// Solid axis-aligned box `[min, max]`, signed distance positive inside.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cuboid {
    /// Lower corner.
    pub min: Vec3,
    /// Upper corner.
    pub max: Vec3,
}

impl Cuboid {
    /// Per axis: offset from the centre and `|offset| − half-size` (positive outside the slab of that axis).
    fn excess(&self, p: Vec3) -> (Vec3, Vec3) {
        let c = 0.5 * (self.min + self.max);
        let h = 0.5 * (self.max - self.min);
        let r = p - c;
        (r, r.abs() - h)
    }
}

impl LevelSet for Cuboid {
    fn value(&self, p: Vec3) -> f32 {
        let (_, q) = self.excess(p);
        let outside = q.max(Vec3::ZERO).length();
        if outside > 0.0 {
            -outside
        } else {
            -q.max_element()
        }
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        let (r, q) = self.excess(p);
        let out = q.max(Vec3::ZERO);
        if out != Vec3::ZERO {
            // Toward the nearest point of the box.
            -(r.signum() * out).normalize()
        } else {
            // Inside: the inward normal of the nearest face.
            let a = if q.x >= q.y && q.x >= q.z {
                0
            } else if q.y >= q.z {
                1
            } else {
                2
            };
            let mut g = Vec3::ZERO;
            g[a] = -r[a].signum();
            g
        }
    }
}

/// Infinite planar slab `|n·(x − c)| ≤ t/2`: `O = t/2 − |n·(x − c)|`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slab {
    /// Unit normal of the slab's faces.
    pub normal: Vec3,
    /// A point on the mid-plane.
    pub center: Vec3,
    /// Thickness t.
    pub thickness: f32,
}

impl LevelSet for Slab {
    fn value(&self, p: Vec3) -> f32 {
        0.5 * self.thickness - self.normal.dot(p - self.center).abs()
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        -self.normal.dot(p - self.center).signum() * self.normal
    }
}

/// The walls of a closed box: solid everywhere outside the interior `[min, max]`,
/// `O = −(box signed distance)`, positive outside the interior.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Walls {
    /// The fluid's box.
    pub interior: Cuboid,
}

impl LevelSet for Walls {
    fn value(&self, p: Vec3) -> f32 {
        -self.interior.value(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        -self.interior.gradient(p)
    }
}

/// Union of obstacles: `O = max_i O_i`, with the gradient of the largest.
#[derive(Clone)]
pub struct Union(pub Vec<Obstacle>);

impl Union {
    fn top(&self, p: Vec3) -> Option<&Obstacle> {
        self.0
            .iter()
            .max_by(|a, b| a.value(p).total_cmp(&b.value(p)))
    }
}

impl LevelSet for Union {
    fn value(&self, p: Vec3) -> f32 {
        self.0
            .iter()
            .map(|o| o.value(p))
            .fold(f32::NEG_INFINITY, f32::max)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.top(p).map_or(Vec3::ZERO, |o| o.gradient(p))
    }
}

/// Any scalar field as a level set, differentiated by central differences.
pub struct FieldLevelSet {
    field: Scalar,
    gradient: ops::Gradient,
}

impl FieldLevelSet {
    /// The level set `O = field`, with gradient step `h` (world units).
    ///
    /// # Panics
    /// If `h` is not positive and finite.
    pub fn new(field: Scalar, h: f32) -> Self {
        assert!(
            h.is_finite() && h > 0.0,
            "finite-difference step is {h}; it must be positive"
        );
        Self {
            gradient: ops::Gradient {
                field: field.clone(),
                h,
            },
            field,
        }
    }
}

impl LevelSet for FieldLevelSet {
    fn value(&self, p: Vec3) -> f32 {
        self.field.eval(p)
    }
    fn gradient(&self, p: Vec3) -> Vec3 {
        self.gradient.eval(p)
    }
}

/// The level set as a scalar field (for sampling and previews).
pub struct AsField(pub Obstacle);

impl ScalarField for AsField {
    fn eval(&self, p: Vec3) -> f32 {
        self.0.value(p)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Central differences of `value`, to check analytic gradients.
    fn fd(o: &dyn LevelSet, p: Vec3) -> Vec3 {
        let h = 1e-3;
        let d = |e: Vec3| (o.value(p + e * h) - o.value(p - e * h)) / (2.0 * h);
        Vec3::new(d(Vec3::X), d(Vec3::Y), d(Vec3::Z))
    }

    #[test]
    fn analytic_gradients_match_differences() {
        let shapes: Vec<(Obstacle, &str)> = vec![
            (
                Arc::new(Sphere {
                    center: Vec3::splat(1.0),
                    radius: 0.7,
                }),
                "sphere",
            ),
            (
                Arc::new(Cuboid {
                    min: Vec3::new(0.2, 0.5, 0.0),
                    max: Vec3::new(1.3, 0.9, 2.0),
                }),
                "cuboid",
            ),
            (
                Arc::new(Slab {
                    normal: Vec3::new(0.6, 0.8, 0.0),
                    center: Vec3::splat(1.0),
                    thickness: 0.3,
                }),
                "slab",
            ),
            (
                Arc::new(Walls {
                    interior: Cuboid {
                        min: Vec3::splat(0.25),
                        max: Vec3::splat(1.75),
                    },
                }),
                "walls",
            ),
        ];
        // Points off every crease (ties between faces, centres).
        let points = [
            Vec3::new(0.31, 0.77, 0.43),
            Vec3::new(1.62, 1.13, 1.91),
            Vec3::new(1.02, 0.21, 0.61),
            Vec3::new(0.05, 1.95, 0.13),
            Vec3::new(1.21, 0.71, 1.05),
        ];
        for (o, name) in &shapes {
            for p in points {
                let (g, f) = (o.gradient(p), fd(&**o, p));
                assert!((g - f).length() < 2e-2, "{name} at {p}: {g} vs {f}");
            }
        }
        let u = Union(shapes.into_iter().map(|(o, _)| o).collect());
        for p in points {
            assert!((u.gradient(p) - fd(&u, p)).length() < 2e-2, "union at {p}");
        }
    }

    #[test]
    fn signs_and_depths() {
        let b = Cuboid {
            min: Vec3::ZERO,
            max: Vec3::new(2.0, 1.0, 4.0),
        };
        assert_eq!(b.value(Vec3::new(1.0, 0.25, 2.0)), 0.25);
        assert_eq!(b.value(Vec3::new(3.0, 0.5, 2.0)), -1.0);
        let w = Walls { interior: b };
        assert_eq!(w.value(Vec3::new(1.0, 0.25, 2.0)), -0.25);
        assert_eq!(w.gradient(Vec3::new(1.0, 1.5, 2.0)), Vec3::Y);
        let s = Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        };
        assert_eq!(s.value(Vec3::new(0.0, 0.5, 0.0)), 0.5);
        assert_eq!(s.gradient(Vec3::ZERO), Vec3::ZERO);
        let f = FieldLevelSet::new(ops::sphere(Vec3::ZERO, 1.0), 1e-2);
        let g = f.gradient(Vec3::new(0.5, 0.0, 0.0));
        assert!((g - Vec3::new(-1.0, 0.0, 0.0)).length() < 1e-3, "{g}");
    }
}
