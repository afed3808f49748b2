//! Meshes and level sets: an OBJ sphere turned into a signed distance, and a
//! level set turned back into a mesh.

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use smokelab::domain::Domain;
use smokelab::field::ScalarField;
use smokelab::model::mesh::{icosphere, Mesh, MeshDistance};
use smokelab::model::{cache, shape};

const RADIUS: f32 = 0.6;

/// A meshed sphere read from OBJ and cached on 40³ cells is within half a
/// cell of the sphere's exact distance, at the cell centres and between them.
#[test]
fn obj_sphere_becomes_its_signed_distance() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sphere.obj");
    icosphere(Vec3::new(0.05, -0.03, 0.0), RADIUS, 3)
        .write_obj(&path)
        .unwrap();
    let mesh = Mesh::read_obj(&path).unwrap();
    assert_eq!(mesh.triangles.len(), 20 * 64);
    let dom = Domain::new(Vec3::splat(-1.0), 2.0 / 40.0, [40; 3]).unwrap();
    let level_set = cache(&MeshDistance::new(mesh), dom);
    let exact = shape::sphere(Vec3::new(0.05, -0.03, 0.0), RADIUS);
    let mut worst_centre = 0.0f32;
    for k in 0..40 {
        for j in 0..40 {
            for i in 0..40 {
                let p = dom.cell_center(i, j, k);
                worst_centre = worst_centre.max((level_set.eval(p) - exact.eval(p)).abs());
            }
        }
    }
    let mut rng = Pcg64::seed_from_u64(4);
    let mut worst_between = 0.0f32;
    for _ in 0..5000 {
        let p = Vec3::new(
            rng.random_range(-0.95..0.95),
            rng.random_range(-0.95..0.95),
            rng.random_range(-0.95..0.95),
        );
        // The distance has a kink at the centre that trilinear reads smooth.
        if exact.eval(p) < RADIUS - 2.0 * dom.cell {
            worst_between = worst_between.max((level_set.eval(p) - exact.eval(p)).abs());
        }
    }
    println!(
        "mesh distance error: {:.4} cells at centres, {:.4} between",
        worst_centre / dom.cell,
        worst_between / dom.cell
    );
    assert!(worst_centre <= 0.5 * dom.cell && worst_between <= 0.5 * dom.cell);
}

#[test]
fn bad_obj_files_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let missing = Mesh::read_obj(&dir.path().join("none.obj"))
        .unwrap_err()
        .to_string();
    assert!(missing.contains("none.obj"), "{missing}");
    let empty = dir.path().join("points.obj");
    std::fs::write(&empty, "v 0 0 0\nv 1 0 0\n").unwrap();
    let e = Mesh::read_obj(&empty).unwrap_err().to_string();
    assert!(e.contains("no faces"), "{e}");
}

/// Surface nets of a sphere's level set: every vertex within half a cell of
/// the sphere, and the OBJ round trip keeps every triangle.
#[test]
fn level_set_becomes_a_mesh() {
    let dom = Domain::new(Vec3::splat(-1.0), 2.0 / 32.0, [32; 3]).unwrap();
    let sphere = shape::sphere(Vec3::ZERO, RADIUS);
    let mesh = Mesh::from_level_set(&*sphere, dom);
    assert!(mesh.triangles.len() > 1000);
    let worst = mesh
        .vertices
        .iter()
        .map(|v| sphere.eval(*v).abs())
        .fold(0.0, f32::max);
    assert!(worst < 0.5 * dom.cell, "{} cells", worst / dom.cell);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("ball.obj");
    mesh.write_obj(&path).unwrap();
    let back = Mesh::read_obj(&path).unwrap();
    assert_eq!(back.triangles.len(), mesh.triangles.len());
    // Closed and consistently oriented: its own distance puts the centre inside.
    assert!(MeshDistance::new(back).eval(Vec3::ZERO) > 0.5);
}
