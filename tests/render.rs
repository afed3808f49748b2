//! The ray marcher against closed forms (appendix A), its convergence in the
//! march step, shadowing, reproducibility, and the `smokelab render` command's
//! handling of bad input.

use std::sync::Arc;

use glam::Vec3;
use smokelab::domain::Domain;
use smokelab::field::{ops, Scalar, ScalarField};
use smokelab::render::camera::Camera;
use smokelab::render::lights::{self, PointLight};
use smokelab::render::phase::Phase;
use smokelab::render::{render, Image, RenderSettings, Scene, Volume};

/// A camera looking straight down −z at the centre of `bounds`' front face.
fn head_on(bounds: &Domain, width: u32, height: u32, fov_deg: f32) -> Camera {
    let c = bounds.origin + 0.5 * bounds.size();
    Camera {
        position: Vec3::new(c.x, c.y, bounds.max_corner().z + 3.0),
        look_at: c,
        up: Vec3::Y,
        fov_deg,
        width,
        height,
    }
}

fn volume(density: Scalar, emission: Vec3, scattering: Vec3, kappa: f32) -> Volume {
    Volume {
        name: "v".into(),
        density,
        emission,
        scattering,
        kappa,
        occupancy: None,
    }
}

fn scene(bounds: Domain, volumes: Vec<Volume>, lights: Vec<PointLight>) -> Scene {
    Scene {
        bounds,
        volumes,
        lights,
        phase: Phase::Isotropic,
    }
}

/// A smooth blob: Gaussian of width `s` around `c`.
struct Gaussian {
    c: Vec3,
    s: f32,
    peak: f32,
}

impl ScalarField for Gaussian {
    fn eval(&self, p: Vec3) -> f32 {
        self.peak * (-(p - self.c).length_squared() / (2.0 * self.s * self.s)).exp()
    }
}

#[test]
fn uniform_slab_transmittance_is_exp_of_optical_depth() {
    // Slab 1.0 deep along z; steps that divide the depth and one that does not.
    let bounds = Domain::new(Vec3::ZERO, 0.1, [8, 8, 10]).unwrap();
    let (rho, kappa) = (0.7, 2.3);
    let s = scene(
        bounds,
        vec![volume(ops::constant(rho), Vec3::ZERO, Vec3::ZERO, kappa)],
        vec![],
    );
    for step in [None, Some(0.13), Some(0.01)] {
        let settings = RenderSettings {
            step,
            ..RenderSettings::new(head_on(&bounds, 1, 1, 10.0))
        };
        let img = render(&s, &settings).unwrap().image;
        let t = 1.0 - img.alpha(0, 0);
        let expect = (-kappa * rho * 1.0f32).exp();
        assert!(
            (t - expect).abs() < 1e-5,
            "step {step:?}: T = {t}, exp(−κρL) = {expect}"
        );
    }
}

#[test]
fn emission_only_cube_radiance_matches_closed_form() {
    let bounds = Domain::cube(12, 1.5).unwrap();
    let (rho, kappa) = (0.8f32, 1.7f32);
    let color = Vec3::new(0.9, 0.5, 0.2);
    let s = scene(
        bounds,
        vec![volume(ops::constant(rho), color, Vec3::ZERO, kappa)],
        vec![],
    );
    let img = render(&s, &RenderSettings::new(head_on(&bounds, 1, 1, 10.0)))
        .unwrap()
        .image;
    // Closed form of eq A.22 for constant density: C (1 − exp(−κρL))/κ.
    let expect = color * (1.0 - (-kappa * rho * 1.5).exp()) / kappa;
    let [r, g, b, _] = img.pixel(0, 0);
    let got = Vec3::new(r, g, b);
    assert!(
        (got - expect).abs().max_element() < 1e-4,
        "L = {got}, closed form {expect}"
    );
}

#[test]
fn two_equal_volumes_render_like_one_of_double_density() {
    let bounds = Domain::cube(16, 2.0).unwrap();
    let blob = |peak| -> Scalar {
        Arc::new(Gaussian {
            c: Vec3::ONE,
            s: 0.35,
            peak,
        })
    };
    let light = PointLight {
        position: Vec3::new(-2.0, 4.0, 3.0),
        color: Vec3::ONE,
    };
    let (e, sc) = (Vec3::new(0.2, 0.1, 0.0), Vec3::new(0.5, 0.6, 0.9));
    let settings = RenderSettings {
        jitter: false,
        ..RenderSettings::new(head_on(&bounds, 24, 24, 40.0))
    };
    let one = scene(bounds, vec![volume(blob(2.0), e, sc, 1.5)], vec![light]);
    let two = scene(
        bounds,
        vec![volume(blob(1.0), e, sc, 1.5), volume(blob(1.0), e, sc, 1.5)],
        vec![light],
    );
    let a = render(&one, &settings).unwrap().image;
    let b = render(&two, &settings).unwrap().image;
    let diff = a
        .rgba
        .iter()
        .zip(&b.rgba)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f32::max);
    assert!(diff < 1e-5, "max difference {diff}");
    assert!(a.alpha(12, 12) > 0.5, "the blob is visible");
}

/// Mean absolute difference of two images (all channels).
fn mean_diff(a: &Image, b: &Image) -> f64 {
    a.rgba
        .iter()
        .zip(&b.rgba)
        .map(|(x, y)| (x - y).abs() as f64)
        .sum::<f64>()
        / a.rgba.len() as f64
}

#[test]
fn halving_the_march_step_converges_at_second_order() {
    // Smooth density, lit and emitting, sampled at sub-step midpoints: the
    // march is a midpoint rule, so each halving of Δs should shrink the
    // change in the image about fourfold.
    let bounds = Domain::cube(16, 2.0).unwrap();
    let density: Scalar = Arc::new(Gaussian {
        c: Vec3::new(1.0, 1.1, 0.9),
        s: 0.4,
        peak: 3.0,
    });
    let s = scene(
        bounds,
        vec![volume(
            density,
            Vec3::new(0.3, 0.1, 0.05),
            Vec3::new(0.8, 0.7, 0.6),
            2.0,
        )],
        vec![PointLight {
            position: Vec3::new(-1.0, 4.0, 3.0),
            color: Vec3::ONE,
        }],
    );
    let images: Vec<Image> = [1.0, 0.5, 0.25]
        .iter()
        .map(|f| {
            let settings = RenderSettings {
                step: Some(f * bounds.cell),
                jitter: false,
                ..RenderSettings::new(Camera::framing(&bounds, 48, 48, 0.9))
            };
            render(&s, &settings).unwrap().image
        })
        .collect();
    let diffs: Vec<f64> = images.windows(2).map(|w| mean_diff(&w[0], &w[1])).collect();
    let orders: Vec<f64> = diffs.windows(2).map(|d| (d[0] / d[1]).log2()).collect();
    println!("changes per halving {diffs:?}, observed orders {orders:?}");
    for w in diffs.windows(2) {
        assert!(
            w[1] < w[0],
            "halving changed the image more than before: {diffs:?}"
        );
    }
    for p in &orders {
        assert!(
            (1.8..2.2).contains(p),
            "observed order {p} is not 2: {orders:?}"
        );
    }
}

#[test]
fn empty_volume_is_exactly_transparent_and_dense_volume_opaque() {
    let bounds = Domain::cube(8, 1.0).unwrap();
    let cam = Camera::framing(&bounds, 16, 16, 0.9);
    let empty = scene(
        bounds,
        vec![volume(ops::constant(0.0), Vec3::ONE, Vec3::ONE, 3.0)],
        vec![PointLight {
            position: Vec3::splat(3.0),
            color: Vec3::ONE,
        }],
    );
    let img = render(&empty, &RenderSettings::new(cam)).unwrap().image;
    assert!(
        img.rgba.iter().all(|&v| v == 0.0),
        "empty render is not all zero"
    );

    let dense = scene(
        bounds,
        vec![volume(ops::constant(50.0), Vec3::ONE, Vec3::ZERO, 10.0)],
        vec![],
    );
    let r = render(&dense, &RenderSettings::new(head_on(&bounds, 8, 8, 20.0))).unwrap();
    for y in 0..8 {
        for x in 0..8 {
            assert!(
                r.image.alpha(x, y) >= 0.9999,
                "pixel ({x},{y}) alpha {}",
                r.image.alpha(x, y)
            );
        }
    }
    // Early exit: optical depth 50 per cell stops each ray after a few steps.
    assert!(
        r.stats.samples <= r.stats.rays * march_chunk(),
        "{:?}",
        r.stats
    );
}

fn march_chunk() -> u64 {
    smokelab::render::march::CHUNK as u64
}

#[test]
fn a_sample_behind_a_dense_blob_is_shadowed() {
    let bounds = Domain::cube(24, 3.0).unwrap();
    let blob: Scalar = ops::scale(ops::mask(ops::sphere(Vec3::new(1.5, 1.5, 1.5), 0.5)), 5.0);
    let light = PointLight {
        position: Vec3::new(1.5, 10.0, 1.5),
        color: Vec3::ONE,
    };
    let vols = vec![volume(blob, Vec3::ZERO, Vec3::ONE, 2.0)];
    let (sigma, _) = lights::extinction_grid(&bounds, &vols);
    let lit = smokelab::render::lights::LitLight {
        light,
        transmissivity: lights::light_transmissivity(&light, &sigma),
    };
    let in_front = lit.transmissivity_at(Vec3::new(1.5, 2.5, 1.5));
    let behind = lit.transmissivity_at(Vec3::new(1.5, 0.5, 1.5));
    let beside = lit.transmissivity_at(Vec3::new(0.4, 0.5, 1.5));
    // Through the blob the optical depth is ≈ κρ·2r = 10.
    assert!(in_front > 0.99, "in front: {in_front}");
    assert!(beside > 0.99, "beside: {beside}");
    assert!(behind < 1e-3, "behind: {behind}");
}

#[test]
fn same_seed_gives_bit_identical_images_on_one_and_two_threads() {
    let bounds = Domain::cube(16, 2.0).unwrap();
    let density: Scalar = Arc::new(Gaussian {
        c: Vec3::ONE,
        s: 0.5,
        peak: 2.0,
    });
    let s = scene(
        bounds,
        vec![volume(
            density,
            Vec3::new(0.2, 0.1, 0.1),
            Vec3::new(0.6, 0.6, 0.9),
            1.5,
        )],
        vec![PointLight {
            position: Vec3::new(-2.0, 4.0, 3.0),
            color: Vec3::ONE,
        }],
    );
    let settings = RenderSettings {
        substeps: 3,
        seed: 7,
        ..RenderSettings::new(Camera::framing(&bounds, 40, 30, 0.9))
    };
    let on = |threads: usize, settings: RenderSettings| {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap()
            .install(|| render(&s, &settings).unwrap().image)
    };
    let one = on(1, settings);
    let two = on(2, settings);
    assert!(one.rgba.iter().any(|&v| v > 0.0));
    assert!(
        one.rgba
            .iter()
            .zip(&two.rgba)
            .all(|(a, b)| a.to_bits() == b.to_bits()),
        "images differ between 1 and 2 threads"
    );
    // The jitter is live: another seed moves the samples.
    let other = on(
        2,
        RenderSettings {
            seed: 8,
            ..settings
        },
    );
    assert_ne!(one.rgba, other.rgba);
}

// ---- `smokelab render` ----------------------------------------------------

/// The renderer queries a gridless density as the procedural field it is:
/// with a resting velocity history the chain is the identity, so the render
/// equals the analytic field's bit for bit, and differs from the render of
/// the same field cached on the velocity grid (what a gridded density is).
#[test]
fn gridless_density_renders_as_its_field_not_a_grid() {
    use smokelab::advection::Backtrace;
    use smokelab::density::GridlessField;
    use smokelab::grid::{BoxKind, FaceGrid, ScalarGrid};

    let bounds = Domain::cube(8, 2.0).unwrap();
    let blob: Scalar = Arc::new(Gaussian {
        c: Vec3::ONE,
        s: 0.3,
        peak: 2.0,
    });
    let mut chain = GridlessField::new(bounds, Some(blob.clone()), None);
    let rest = Arc::new(FaceGrid::zeros(bounds, BoxKind::Periodic));
    for _ in 0..3 {
        chain.push(rest.clone(), 0.1, Backtrace::Rk2);
    }
    let cached: Scalar = Arc::new(ScalarGrid::from_field(bounds, &*blob));
    let settings = RenderSettings {
        jitter: false,
        step: Some(bounds.cell / 4.0),
        ..RenderSettings::new(head_on(&bounds, 24, 24, 40.0))
    };
    let light = PointLight {
        position: Vec3::new(-2.0, 4.0, 3.0),
        color: Vec3::ONE,
    };
    let (e, sc) = (Vec3::new(0.2, 0.1, 0.0), Vec3::new(0.5, 0.6, 0.9));
    let image = |density: Scalar| {
        let s = scene(bounds, vec![volume(density, e, sc, 1.5)], vec![light]);
        render(&s, &settings).unwrap().image
    };
    let (gridless, analytic, gridded) = (image(Arc::new(chain)), image(blob), image(cached));
    assert_eq!(gridless.rgba, analytic.rgba, "gridless render ≠ analytic");
    let diff = mean_diff(&gridless, &gridded);
    assert!(diff > 1e-3, "the 8³ cache renders the same ({diff})");
}
