//! The field language's pointwise functions, components and cache scaling,
//! checked at points against their closed forms.

use glam::Vec3;
use rhai::{Engine, FLOAT};
use smokelab::field::VectorField;
use smokelab::pressure::PressurePrecision;

use super::types::{ScalarF, VectorCache};
use super::{functions, types};

fn engine() -> Engine {
    let mut e = Engine::new();
    types::register(&mut e);
    functions::register(&mut e, PressurePrecision::default());
    e
}

fn points() -> Vec<Vec3> {
    (0..50)
        .map(|i| {
            let t = i as f32;
            Vec3::new(
                0.9 * (0.37 * t).sin(),
                0.8 * (0.71 * t + 1.0).cos(),
                0.7 * (0.13 * t).sin(),
            )
        })
        .collect()
}

/// The script `expr` (a scalarfield of `p = identity()`) against `exact`.
fn check(expr: &str, exact: impl Fn(f64, f64, f64) -> f64) {
    let f: ScalarF = engine()
        .eval(&format!("let p = identity(); {expr}"))
        .unwrap_or_else(|e| panic!("{expr}: {e}"));
    for p in points() {
        let (x, y, z) = (p.x as f64, p.y as f64, p.z as f64);
        let (got, want) = (f.field.eval(p) as f64, exact(x, y, z));
        assert!(
            (got - want).abs() <= 1e-6 * (1.0 + want.abs()),
            "{expr} at {p}: {got} vs {want}"
        );
    }
}

#[test]
fn pointwise_functions_of_fields_match_their_closed_forms() {
    check("sin(p.x)", |x, _, _| x.sin());
    check("cos(2.0 * p.y)", |_, y, _| (2.0 * y).cos());
    check("exp(p.z)", |_, _, z| z.exp());
    check("tanh(3 * (p.x - p.y))", |x, y, _| (3.0 * (x - y)).tanh());
    check("abs(p.y)", |_, y, _| y.abs());
    check("min(p.x, 0.3)", |x, _, _| x.min(0.3));
    check("min(0, p.y)", |_, y, _| y.min(0.0));
    check("max(p.x, p.z)", |x, _, z| x.max(z));
    check("max(-0.2, p.z)", |_, _, z| z.max(-0.2));
    check("component(p, 1) + p.z", |_, y, z| y + z);
    // LeVeque's deformation component, the field the script wrote by Taylor series.
    check(
        "let pi = 3.141592653589793; 2.0 * sin(pi * p.x) ** 2 * sin(2.0 * pi * p.y) * sin(2.0 * pi * p.z)",
        |x, y, z| {
            use std::f64::consts::PI;
            2.0 * (PI * x).sin().powi(2) * (2.0 * PI * y).sin() * (2.0 * PI * z).sin()
        },
    );
}

#[test]
fn the_same_functions_of_numbers_are_numbers() {
    let e = engine();
    let num = |s: &str| {
        e.eval::<FLOAT>(s)
            .unwrap_or_else(|err| panic!("{s}: {err}"))
    };
    assert_eq!(num("sin(0.5)"), 0.5f64.sin());
    assert_eq!(num("sin(1)"), 1f64.sin());
    assert_eq!(num("cos(2)"), 2f64.cos());
    assert_eq!(num("exp(1)"), 1f64.exp());
    assert_eq!(num("tanh(0.25)"), 0.25f64.tanh());
    assert_eq!(num("abs(-2.5)"), 2.5);
    assert_eq!(num("min(2.0, 3.5)"), 2.0);
    assert_eq!(num("max(-1.0, -3.0)"), -1.0);
    assert_eq!(num("vector(1.0, 2.0, 3.0).y"), 2.0);
}

#[test]
fn vectorcache_times_a_number_scales_every_face_and_components_read_the_cache() {
    let e = engine();
    let (u, v): (VectorCache, VectorCache) = {
        let arr: rhai::Array = e
            .eval(
                "let r = domain(8, 1.0); let u = vectorcache(r);
                 let p = identity();
                 cachewrite(u, vector(1.0, 0.0, 0.0) * sin(6.283185307179586 * p.y)
                     + vector(0.0, 0.0, 1.0) * cos(6.283185307179586 * p.x));
                 [u, 2.5 * u / 2 * 2]",
            )
            .unwrap();
        (arr[0].clone().cast(), arr[1].clone().cast())
    };
    for axis in 0..3 {
        for (a, b) in u.0.slice(axis).iter().zip(v.0.slice(axis)) {
            assert_eq!(*b, *a * 2.5 / 2.0 * 2.0);
        }
    }
    // The z-faces hold cos(2πx) at their centres; `u.z` is the cache's point query.
    let f: ScalarF = e
        .eval(
            "let r = domain(8, 1.0); let u = vectorcache(r);
             cachewrite(u, vector(0.0, 0.0, 1.0) * cos(6.283185307179586 * identity().x));
             u.z",
        )
        .unwrap();
    let g: ScalarF = e
        .eval(
            "let r = domain(8, 1.0); let u = vectorcache(r);
             cachewrite(u, vector(0.0, 0.0, 1.0) * cos(6.283185307179586 * identity().x));
             component(u, 2)",
        )
        .unwrap();
    for p in points() {
        let q = p.abs();
        assert_eq!(f.field.eval(q), g.field.eval(q));
        assert_eq!(f.field.eval(q), VectorField::eval(&*u.0, q).z);
    }
    // At a z-face centre ((i + ½)Δx, (j + ½)Δx, kΔx) the query is the face's value.
    let face = Vec3::new(0.0625, 0.3125, 0.5);
    let want = (std::f64::consts::TAU * 0.0625).cos();
    assert!((f.field.eval(face) as f64 - want).abs() < 1e-6);
}

/// `fftdivfree` in a `domain` solves in the engine's precision: projecting
/// the periodic field `u = (sin 2πx + sin 2πy, 0, 0)` (its solenoidal
/// part `sin 2πy` survives) at 32³, f64 leaves a relative divergence
/// `max|D u| Δx / max|u|` at least 8 times below f32's: f64's residual is
/// only the rounding of the result to f32 faces (~ε₃₂ = 6e-8), f32's is the
/// transforms' round-off, growing as ε₃₂·N (about 20 times that at 32³).
/// Were the precision not passed to the solver, the two would be equal.
#[test]
fn fftdivfree_solves_in_the_engines_precision() {
    let residual = |precision: PressurePrecision| {
        let mut e = Engine::new();
        types::register(&mut e);
        functions::register(&mut e, precision);
        let u: VectorCache = e
            .eval(
                "let r = domain(32, 1.0); let u = vectorcache(r);
                 let p = 6.283185307179586 * identity();
                 cachewrite(u, vector(1.0, 0.0, 0.0) * (sin(p.x) + sin(p.y)));
                 fftdivfree(u, r)",
            )
            .unwrap();
        let mut div = vec![0.0; 32 * 32 * 32];
        u.0.divergence_f64(&mut div);
        let max_div = div.iter().fold(0.0f64, |m, d| m.max(d.abs()));
        let max_u = (0..3)
            .flat_map(|a| u.0.slice(a).iter())
            .fold(0.0f64, |m, x| m.max(x.abs() as f64));
        max_div / 32.0 / max_u
    };
    let (r32, r64) = (
        residual(PressurePrecision::F32),
        residual(PressurePrecision::F64),
    );
    assert!(r32 < 1e-5, "f32 projection residual {r32}");
    assert!(r64 < r32 / 8.0, "f64 residual {r64}, f32 {r32}");
}
