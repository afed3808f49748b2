//! The nacelle warp (ch. 4, eqs 4.1–4.10).

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use smokelab::domain::Domain;
use smokelab::field::{Scalar, ScalarField, VectorField};
use smokelab::model::shape;
use smokelab::model::warp::Nacelle;

fn random_points(seed: u64, n: usize) -> Vec<Vec3> {
    let mut rng = Pcg64::seed_from_u64(seed);
    (0..n)
        .map(|_| {
            Vec3::new(
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
                rng.random_range(-1.0..1.0),
            )
        })
        .collect()
}

#[test]
fn identical_level_sets_give_the_identity() {
    let l = shape::torus(Vec3::new(0.1, 0.0, 0.0), Vec3::new(0.2, 1.0, 0.0), 0.5, 0.2).unwrap();
    let warp = Nacelle {
        reference: l.clone(),
        object: l,
        h: 1e-3,
        cache: None,
    };
    let maps = warp.iterate(3);
    for p in random_points(1, 500) {
        assert!(
            (maps[3].eval(p) - p).length() < 1e-6,
            "at {p}: {}",
            maps[3].eval(p)
        );
    }
}

/// Worst residual `|L_O − L_r(X_n)|` at points in a band around the object,
/// for n = 0..=3.
fn residuals(warp: &Nacelle, object: &Scalar) -> Vec<f32> {
    let band: Vec<Vec3> = random_points(2, 20_000)
        .into_iter()
        .filter(|&p| object.eval(p).abs() < 0.2)
        .collect();
    assert!(band.len() > 1000);
    warp.iterate(3)
        .into_iter()
        .map(|x| {
            let r = warp.residual(x);
            let mut v = vec![0.0; band.len()];
            r.eval_batch(&band, &mut v);
            v.into_iter().fold(0.0, f32::max)
        })
        .collect()
}

/// A sphere warped into an ellipsoid: residual below 10⁻³ within 3
/// iterations, for a signed-distance reference (Γ = 0), a quadratic one
/// (Γ ≠ 0) and with `B·B`, `B·M·B` cached on a 32³ grid.
#[test]
fn sphere_to_ellipsoid_converges_within_three_iterations() {
    let object = shape::ellipsoid(Vec3::ZERO, Vec3::new(0.35, 0.5, 0.65)).unwrap();
    // R² − |x|² = (R² − |x|²) / 2R for R = ½: slope 1 on the sphere, Hessian −I/R.
    let quadratic = smokelab::field::ops::sphere(Vec3::ZERO, 0.5);
    let grid = Domain::new(Vec3::splat(-1.0), 2.0 / 32.0, [32; 3]).unwrap();
    let cases: [(&str, Scalar, Option<Domain>); 3] = [
        ("distance", shape::sphere(Vec3::ZERO, 0.5), None),
        ("quadratic", quadratic, None),
        (
            "distance, cached",
            shape::sphere(Vec3::ZERO, 0.5),
            Some(grid),
        ),
    ];
    for (name, reference, cache) in cases {
        let warp = Nacelle {
            reference,
            object: object.clone(),
            h: 1e-3,
            cache,
        };
        let r = residuals(&warp, &object);
        println!("{name}: worst residual per iteration {r:?}");
        assert!(r[0] > 0.05, "{name}: X_0 should be far off");
        assert!(r[3] < 1e-3, "{name}: residuals {r:?}");
    }
}
