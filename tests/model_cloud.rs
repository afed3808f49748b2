//! Cloud modelling (ch. 3) and the level-set surface march (eq 3.3).

use std::sync::Arc;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use smokelab::domain::Domain;
use smokelab::field::algebra::{compose, levelset_surface};
use smokelab::field::ops::constant;
use smokelab::field::{Scalar, ScalarField};
use smokelab::model::cloud::{
    amplitude, billow, cumulo, displace, measured_billow, noise_layers, PyroclasticSphere,
};
use smokelab::model::{cache, shape};
use smokelab::noise::perlin::Perlin;

fn random_points(seed: u64, n: usize, half: f32) -> Vec<Vec3> {
    let mut rng = Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            Vec3::new(
                rng.random_range(-half..half),
                rng.random_range(-half..half),
                rng.random_range(-half..half),
            )
        })
        .collect()
}

/// A field with its closed-form gradient hidden, so `grad` differences it.
struct Hidden(Scalar);

impl ScalarField for Hidden {
    fn eval(&self, p: Vec3) -> f32 {
        self.0.eval(p)
    }
}

/// Eq 3.3 lands within 10⁻⁴ cells of the zero set in at most 5 steps, from
/// points up to 3 cells away: for a sphere and a torus given as signed
/// distances with differenced gradients, and as the same distances cached on
/// a 64³ grid (the march then lands on the cached surface).
#[test]
fn levelset_surface_lands_on_sphere_and_torus() {
    let dom = Domain::new(Vec3::splat(-1.0), 2.0 / 64.0, [64; 3]).unwrap();
    let cell = dom.cell;
    let sphere = shape::sphere(Vec3::new(0.1, 0.0, -0.1), 0.7);
    let torus = shape::torus(Vec3::ZERO, Vec3::new(0.0, 1.0, 0.3), 0.6, 0.25).unwrap();
    for (name, distance) in [("sphere", sphere), ("torus", torus)] {
        let cached = cache(&*distance, dom);
        let cases: [(&str, Scalar, f32); 2] = [
            ("differenced", Arc::new(Hidden(distance.clone())), 1e-3),
            ("cached", cached, 0.5 * cell),
        ];
        for (how, level_set, h) in cases {
            let band: Vec<Vec3> = random_points(3, 20_000, 0.95)
                .into_iter()
                .filter(|&p| level_set.eval(p).abs() < 3.0 * cell)
                .collect();
            assert!(
                band.len() > 200,
                "{name}: {} points in the band",
                band.len()
            );
            let mut worst = Vec::new();
            for iterations in 0..=5 {
                let on = compose(
                    level_set.clone(),
                    levelset_surface(level_set.clone(), h, iterations),
                );
                let mut d = vec![0.0; band.len()];
                on.eval_batch(&band, &mut d);
                worst.push(d.iter().fold(0.0f32, |m, v| m.max(v.abs())) / cell);
            }
            println!("{name}, {how}: worst |ℓ| after 0..5 steps, in cells: {worst:?}");
            assert!(
                worst[0] > 1.0,
                "{name}, {how}: the band starts off the surface"
            );
            assert!(
                worst[5] < 1e-4,
                "{name}, {how}: {} cells after 5 steps",
                worst[5]
            );
        }
    }
}

/// §3.3.1's closed form and eq 3.4 applied to the sphere's signed distance
/// give the same density at random points (ties on the surface excepted).
#[test]
fn pyroclastic_sphere_matches_the_closed_form() {
    let sphere = PyroclasticSphere {
        center: Vec3::new(0.05, -0.02, 0.0),
        radius: 0.5,
        amplitude: 0.2,
        frequency: 3.0,
        noise: Perlin::new(0x5eed),
    };
    let level_set = displace(
        shape::sphere(sphere.center, sphere.radius),
        sphere.surface_noise(),
        1e-3,
        1,
    );
    let (mut shell_in, mut shell_out, mut ties) = (0, 0, 0);
    let points = random_points(5, 20_000, 1.0);
    for &p in &points {
        let l = level_set.eval(p);
        if l.abs() < 1e-5 {
            ties += 1;
            continue;
        }
        let closed = sphere.eval(p);
        assert_eq!(closed, if l > 0.0 { 1.0 } else { 0.0 }, "at {p}: ℓ = {l}");
        let d = (p - sphere.center).length();
        if d > sphere.radius && d < sphere.radius + 0.4 {
            if closed > 0.0 {
                shell_in += 1;
            } else {
                shell_out += 1;
            }
        }
    }
    assert!(ties < 10, "{ties} ties");
    assert!(
        shell_in > 100 && shell_out > 100,
        "shell: {shell_in} in, {shell_out} out"
    );
}

fn layers(count: usize, rough: f32) -> Vec<Scalar> {
    noise_layers(
        count,
        Arc::new(Perlin::new(17)),
        constant(0.15),
        constant(3.0),
        constant(2.5),
        constant(rough),
    )
}

/// The `NoiseLayers` script with constant fields is eq 3.7 with one octave:
/// layer i is `scale · rough^i · P(x · freq · fjump^i)`.
#[test]
fn noise_layers_follow_the_fractal_scaling() {
    let ls = layers(3, 0.5);
    let p = Perlin::new(17);
    for x in random_points(9, 50, 1.0) {
        for (i, l) in ls.iter().enumerate() {
            let expect = 0.15 * 0.5f32.powi(i as i32) * p.value(x * 3.0 * 2.5f32.powi(i as i32));
            assert!(
                (l.eval(x) - expect).abs() < 1e-6 * (1.0 + expect.abs()),
                "layer {i} at {x}"
            );
        }
    }
}

/// Eq 3.8: a cleared layer vanishes where the previous cleared layer does,
/// equals the raw layer where the previous one exceeds Q, and a larger
/// billow clears more.
#[test]
fn billow_clears_the_canyons() {
    let raw = layers(2, 0.6);
    let q = 0.05;
    let soft = billow(&raw, &[q], constant(0.5)).unwrap();
    let hard = billow(&raw, &[q], constant(2.0)).unwrap();
    let (mut saturated, mut canyon) = (0, 0);
    for x in random_points(13, 4000, 1.0) {
        let prev = raw[0].eval(x).abs();
        let n1 = raw[1].eval(x);
        let (s, h) = (soft[1].eval(x), hard[1].eval(x));
        assert_eq!(soft[0].eval(x), raw[0].eval(x));
        assert!(
            h.abs() <= s.abs() + 1e-7 && s.abs() <= n1.abs() + 1e-7,
            "at {x}"
        );
        if prev >= q {
            saturated += 1;
            assert_eq!(s, n1);
        }
        if prev < 1e-3 * q {
            canyon += 1;
            assert!(h.abs() <= 1e-6 * n1.abs() + 1e-9, "at {x}: {h}");
        }
    }
    assert!(
        saturated > 100 && canyon > 0,
        "saturated {saturated}, canyon {canyon}"
    );
}

/// Eq 3.8 with measured `Q`: each `Q_i` is the quantile of the previous
/// cleared layer over the points (the 9th of 10 sorted values for 0.9, the
/// largest for 1), so the gate saturates on the previous layer's peaks
/// only; a wrong count of `Q`, a bad quantile or no points are refused.
#[test]
fn measured_billow_sets_q_against_the_previous_layer() {
    let raw = layers(3, 0.6);
    let points = random_points(17, 10, 1.0);
    let (cleared, q) = measured_billow(&raw, constant(1.0), &points, 0.9).unwrap();
    assert_eq!((cleared.len(), q.len()), (3, 2));
    for i in 1..3 {
        let mut v: Vec<f32> = points
            .iter()
            .map(|&x| cleared[i - 1].eval(x).abs())
            .collect();
        v.sort_by(f32::total_cmp);
        assert_eq!(q[i - 1], v[8], "Q_{i}");
        assert_eq!(amplitude(&*cleared[i - 1], &points, 1.0).unwrap(), v[9]);
        let x = points
            .iter()
            .copied()
            .find(|&x| cleared[i - 1].eval(x).abs() >= q[i - 1])
            .unwrap();
        assert_eq!(cleared[i].eval(x), raw[i].eval(x), "saturated at {x}");
    }
    assert!(billow(&raw, &[0.1], constant(1.0)).is_err());
    assert!(billow(&raw, &[0.1, 0.0], constant(1.0)).is_err());
    assert!(amplitude(&*raw[0], &points, 0.0).is_err());
    assert!(amplitude(&*raw[0], &[], 0.5).is_err());
}

/// `cumulo` with a cache per layer (§3.3.3) stays within a cell of the
/// procedural chain near the surface, and refuses a wrong number of domains.
#[test]
fn cached_cumulo_follows_the_procedural_one() {
    let base = shape::sphere(Vec3::ZERO, 0.5);
    let ls = layers(2, 0.5);
    let exact = cumulo(base.clone(), &ls, 1e-3, 3, &[]).unwrap();
    let doms = [
        Domain::new(Vec3::splat(-1.0), 2.0 / 48.0, [48; 3]).unwrap(),
        Domain::new(Vec3::splat(-1.0), 2.0 / 96.0, [96; 3]).unwrap(),
    ];
    let cached = cumulo(base.clone(), &ls, 1e-3, 3, &doms).unwrap();
    let pts: Vec<Vec3> = random_points(21, 20_000, 0.9)
        .into_iter()
        .filter(|&p| exact.eval(p).abs() < 0.1)
        .collect();
    let mean = pts
        .iter()
        .map(|&p| (exact.eval(p) - cached.eval(p)).abs())
        .sum::<f32>()
        / pts.len() as f32;
    println!(
        "cached vs procedural cumulo: mean |Δℓ| {mean:.5} over {} points",
        pts.len()
    );
    assert!(pts.len() > 500);
    assert!(mean < doms[1].cell, "mean |Δℓ| {mean}");
    let e = cumulo(base, &ls, 1e-3, 3, &doms[..1])
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("1 cache domains for 2 layers"), "{e}");
}
