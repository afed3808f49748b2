//! Cutting with level-set knives (ch. 5): the pieces of a sphere cut by
//! random flat blades fill the sphere, and the order of the knives does not
//! change them (§5.3).

use std::collections::HashMap;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use smokelab::domain::Domain;
use smokelab::field::{Scalar, ScalarField};
use smokelab::model::cut::{cut_all, cut_inside, cut_outside, label_pieces};
use smokelab::model::shape;

const RADIUS: f32 = 0.8;

/// `n` blades through random points of the cube `[−0.35, 0.35]³` with random normals.
fn blades(seed: u64, n: usize) -> Vec<Scalar> {
    let mut rng = Pcg64::seed_from_u64(seed);
    let mut v = |s: f32| {
        Vec3::new(
            rng.random_range(-s..s),
            rng.random_range(-s..s),
            rng.random_range(-s..s),
        )
    };
    (0..n)
        .map(|_| {
            let point = v(0.35);
            let normal = v(1.0);
            shape::plane(point, normal).unwrap()
        })
        .collect()
}

fn domain(res: usize) -> Domain {
    Domain::new(Vec3::splat(-1.0), 2.0 / res as f32, [res; 3]).unwrap()
}

#[test]
fn a_single_cut_splits_the_inside_by_the_knife_sign() {
    let ball = shape::sphere(Vec3::ZERO, RADIUS);
    let knife = shape::plane(Vec3::new(0.1, 0.0, 0.0), Vec3::X).unwrap();
    let (a, b) = (
        cut_inside(ball.clone(), knife.clone()),
        cut_outside(ball.clone(), knife.clone()),
    );
    for p in [
        Vec3::new(0.3, 0.1, 0.0),
        Vec3::new(-0.2, 0.3, 0.1),
        Vec3::new(0.95, 0.0, 0.0),
        Vec3::new(-0.5, -0.7, 0.3),
    ] {
        let inside = ball.eval(p) > 0.0;
        assert_eq!(a.eval(p) > 0.0, inside && knife.eval(p) > 0.0, "{p}");
        assert_eq!(b.eval(p) > 0.0, inside && knife.eval(p) < 0.0, "{p}");
        if !inside {
            assert_eq!(a.eval(p), ball.eval(p));
        }
    }
}

#[test]
fn pieces_of_five_blades_fill_the_sphere() {
    let d = domain(64);
    let ball = shape::sphere(Vec3::ZERO, RADIUS);
    let cuts = cut_all(ball, &blades(7, 5), d);
    assert_eq!(cuts.sets.len() + cuts.empty, 32);
    assert!(
        cuts.sets.len() >= 6,
        "5 blades through the core leave {} sets",
        cuts.sets.len()
    );
    let labels = label_pieces(&cuts.sets, d);
    let total: f64 = labels.pieces.iter().map(|p| p.volume).sum();
    let exact = 4.0 / 3.0 * std::f64::consts::PI * (RADIUS as f64).powi(3);
    let err = (total - exact).abs() / exact;
    println!(
        "sets {} (empty {}), pieces {}, volume {total:.5} vs {exact:.5} ({:.3} %)",
        cuts.sets.len(),
        cuts.empty,
        labels.pieces.len(),
        100.0 * err
    );
    assert!(err < 0.01, "piece volumes sum to {total}, sphere {exact}");
    // Planes cut a ball into convex parts: one piece per non-empty set.
    assert_eq!(labels.pieces.len(), cuts.sets.len());
    // Every piece lies on the side of each knife its set says.
    let knives = blades(7, 5);
    for p in &labels.pieces {
        let sides = &cuts.sets[p.set].sides;
        let cell = labels
            .ids
            .indexed_iter()
            .find(|(_, &id)| id == p.id)
            .map(|((k, j, i), _)| d.cell_center(i, j, k))
            .unwrap();
        for (knife, &positive) in knives.iter().zip(sides) {
            assert_eq!(knife.eval(cell) > 0.0, positive);
        }
    }
}

/// The same cells are grouped together whatever the knives' order.
#[test]
fn knife_order_does_not_change_the_pieces() {
    let d = domain(40);
    let ball = shape::sphere(Vec3::ZERO, RADIUS);
    let knives = blades(11, 4);
    let reference = label_pieces(&cut_all(ball.clone(), &knives, d).sets, d);
    for order in [[3, 2, 1, 0], [1, 3, 0, 2], [2, 0, 3, 1]] {
        let permuted: Vec<Scalar> = order.iter().map(|&i| knives[i].clone()).collect();
        let other = label_pieces(&cut_all(ball.clone(), &permuted, d).sets, d);
        assert_eq!(other.pieces.len(), reference.pieces.len());
        // The labelings are the same partition: a bijection between ids.
        let (mut ab, mut ba) = (HashMap::new(), HashMap::new());
        for (&a, &b) in reference.ids.iter().zip(other.ids.iter()) {
            assert_eq!(*ab.entry(a).or_insert(b), b, "order {order:?}");
            assert_eq!(*ba.entry(b).or_insert(a), a, "order {order:?}");
        }
    }
}
