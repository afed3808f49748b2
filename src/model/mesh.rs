//! Triangle meshes in and out of level sets: a user's OBJ becomes a signed
//! distance (§3.2, "simple polygonal geometry … turned into a scalarfield
//! known as a levelset"), and a level set becomes a mesh again (the notes'
//! `ls2shape`, ch. 5) by naive surface nets, written as OBJ.
//!
//! [`MeshDistance`] is a procedural field: the distance to the nearest
//! triangle (Ericson's closest point on a triangle), positive inside where
//! the generalised winding number (Van Oosterom & Strackee's solid angle
//! per triangle, summed over `4π`) exceeds ½. Each query visits every
//! triangle, so cache it ([`super::cache`]) before rendering or displacing.

use std::io::Write;
use std::path::Path;

use fast_surface_nets::ndshape::RuntimeShape;
use fast_surface_nets::{surface_nets, SurfaceNetsBuffer};
use glam::Vec3;

use crate::domain::Domain;
use crate::error::InputError;
use crate::field::ScalarField;
use crate::grid::ScalarGrid;

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Mesh {
    /// Vertex positions.
    pub vertices: Vec<Vec3>,
    /// Triangles as vertex indices, counter-clockwise seen from outside.
    pub triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// Read the faces of every object in an OBJ file (polygons are fanned
    /// into triangles); materials are ignored.
    pub fn read_obj(path: &Path) -> Result<Self, InputError> {
        let text = std::fs::read(path)
            .map_err(|e| InputError::new(format!("cannot read OBJ {}: {e}", path.display())))?;
        Self::parse_obj(&text, &path.display().to_string())
    }

    /// [`Mesh::read_obj`] of OBJ text already in memory (an embedded
    /// asset), `name` naming it in errors.
    pub fn parse_obj(text: &[u8], name: &str) -> Result<Self, InputError> {
        let options = tobj::LoadOptions {
            triangulate: true,
            single_index: true,
            ..Default::default()
        };
        let (models, _materials) =
            tobj::load_obj_buf(&mut &text[..], &options, |_| Ok(Default::default()))
                .map_err(|e| InputError::new(format!("cannot read OBJ {name}: {e}")))?;
        let mut mesh = Mesh::default();
        for m in models {
            let base = mesh.vertices.len() as u32;
            mesh.vertices.extend(
                m.mesh
                    .positions
                    .chunks_exact(3)
                    .map(|p| Vec3::new(p[0], p[1], p[2])),
            );
            mesh.triangles.extend(
                m.mesh
                    .indices
                    .chunks_exact(3)
                    .map(|t| [base + t[0], base + t[1], base + t[2]]),
            );
        }
        if mesh.triangles.is_empty() {
            crate::input_bail!("OBJ {name} has no faces");
        }
        if let Some(v) = mesh.vertices.iter().find(|v| !v.is_finite()) {
            crate::input_bail!("OBJ {name} has a vertex at {v}");
        }
        Ok(mesh)
    }

    /// Write as OBJ (1-based indices), atomically ([`crate::io::write_atomic`]).
    pub fn write_obj(&self, path: &Path) -> anyhow::Result<()> {
        crate::io::write_atomic(path, |w| self.write_obj_to(w))
    }

    fn write_obj_to(&self, w: &mut impl Write) -> anyhow::Result<()> {
        writeln!(
            w,
            "# smokelab mesh: {} vertices, {} triangles",
            self.vertices.len(),
            self.triangles.len()
        )?;
        for v in &self.vertices {
            writeln!(w, "v {} {} {}", v.x, v.y, v.z)?;
        }
        for t in &self.triangles {
            writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
        }
        Ok(())
    }

    /// The triangles' corner positions.
    fn corners(&self, t: [u32; 3]) -> [Vec3; 3] {
        t.map(|i| self.vertices[i as usize])
    }

    /// The zero set of `level_set` sampled on `domain`, as a mesh (naive
    /// surface nets; vertices in world coordinates). Cells on the domain's
    /// upper faces close no quads, so keep the shape a cell inside the box.
    pub fn from_level_set(level_set: &dyn ScalarField, domain: Domain) -> Self {
        let grid = ScalarGrid::from_field(domain, level_set);
        // The crate takes negative inside; ours is positive inside.
        let sdf: Vec<f32> = grid.as_slice().iter().map(|v| -v).collect();
        let [nx, ny, nz] = domain.dims.map(|n| n as u32);
        let shape = RuntimeShape::<u32, 3>::new([nx, ny, nz]);
        let mut buffer = SurfaceNetsBuffer::default();
        surface_nets(&sdf, &shape, [0; 3], [nx - 1, ny - 1, nz - 1], &mut buffer);
        Mesh {
            vertices: buffer
                .positions
                .iter()
                .map(|&p| domain.world_of(Vec3::from_array(p)))
                .collect(),
            triangles: buffer
                .indices
                .chunks_exact(3)
                .map(|t| [t[0], t[1], t[2]])
                .collect(),
        }
    }
}

/// The closest point to `p` on triangle `abc` (Ericson, *Real-Time Collision
/// Detection*, §5.1.5).
fn closest_on_triangle(p: Vec3, [a, b, c]: [Vec3; 3]) -> Vec3 {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return a;
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(bp), ac.dot(bp));
    if d3 >= 0.0 && d4 <= d3 {
        return b;
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        return a + ab * (d1 / (d1 - d3));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(cp), ac.dot(cp));
    if d6 >= 0.0 && d5 <= d6 {
        return c;
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        return a + ac * (d2 / (d2 - d6));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        return b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)));
    }
    let denom = 1.0 / (va + vb + vc);
    a + ab * (vb * denom) + ac * (vc * denom)
}

/// The solid angle of triangle `abc` seen from `p`, signed by orientation
/// (Van Oosterom & Strackee 1983).
fn solid_angle(p: Vec3, [a, b, c]: [Vec3; 3]) -> f32 {
    let (a, b, c) = (a - p, b - p, c - p);
    let (la, lb, lc) = (a.length(), b.length(), c.length());
    let num = a.dot(b.cross(c));
    let den = la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb;
    2.0 * num.atan2(den)
}

/// The signed distance to a closed triangle mesh, positive inside.
pub struct MeshDistance {
    mesh: Mesh,
}

impl MeshDistance {
    /// The signed distance of `mesh` (which should be closed and oriented
    /// consistently; the inside is where the winding number exceeds ½).
    pub fn new(mesh: Mesh) -> Self {
        Self { mesh }
    }
}

impl ScalarField for MeshDistance {
    fn eval(&self, p: Vec3) -> f32 {
        let (mut d2, mut winding) = (f32::INFINITY, 0.0f32);
        for &t in &self.mesh.triangles {
            let tri = self.mesh.corners(t);
            d2 = d2.min((closest_on_triangle(p, tri) - p).length_squared());
            winding += solid_angle(p, tri);
        }
        let inside = (winding / (4.0 * std::f32::consts::PI)).abs() > 0.5;
        if inside {
            d2.sqrt()
        } else {
            -d2.sqrt()
        }
    }
}

/// A unit-radius icosphere refined `subdivisions` times, scaled to `radius`
/// about `center` (20·4ⁿ triangles, outward counter-clockwise).
pub fn icosphere(center: Vec3, radius: f32, subdivisions: usize) -> Mesh {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let mut vertices: Vec<Vec3> = [
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ]
    .iter()
    .map(|&v| Vec3::from_array(v).normalize())
    .collect();
    let mut triangles: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..subdivisions {
        let mut midpoints = std::collections::HashMap::new();
        let mut mid = |a: u32, b: u32, vertices: &mut Vec<Vec3>| {
            *midpoints.entry((a.min(b), a.max(b))).or_insert_with(|| {
                vertices.push((vertices[a as usize] + vertices[b as usize]).normalize());
                vertices.len() as u32 - 1
            })
        };
        triangles = triangles
            .iter()
            .flat_map(|&[a, b, c]| {
                let (ab, bc, ca) = (
                    mid(a, b, &mut vertices),
                    mid(b, c, &mut vertices),
                    mid(c, a, &mut vertices),
                );
                [[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]
            })
            .collect();
    }
    Mesh {
        vertices: vertices.into_iter().map(|v| center + radius * v).collect(),
        triangles,
    }
}
