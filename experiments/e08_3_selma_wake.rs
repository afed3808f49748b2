//! # 08-3 — SELMA applies a simulated wake to a modelled cloud (fig 8.3)
//!
//! Reproduces the idea of the notes' figure 8.3 (§8.3, *The A-Team*): "an
//! aircraft passing through cloud material leaves behind a wake disturbance
//! in the cloud. The velocity field is from a fluid simulation that does not
//! include the presence of the cloud. The cloud was modeled using the
//! methods in chapter 3, then displaced using SELMA."
//!
//! Here the aircraft is a sphere (radius 0.4) flying through still air at
//! speed U = 1. The simulation runs in the sphere's frame — a uniform stream
//! past a fixed obstacle in a periodic 10 × 4 × 4 box, inviscid, exact
//! obstacles with the reflecting rule (free slip) — and is warmed up for 2
//! time units so the wake exists before the cloud arrives. The
//! cloud is a three-layer billowed cloud of ch. 3 on three merged spheres
//! (billow 1, `Q` = 0.1 for every layer; `shot_cloud`), placed upstream;
//! its density is `ρ₀ ∘ X` with `X` SELMA's backward map on a map grid twice
//! as fine as the velocity, never re-anchored (no sources, so the cloud
//! stays procedural: eq 8.3). Renders are in the still air's frame
//! (`ρ_lab(x, t) = ρ(x + U t, t)`), so the cloud stays put and the sphere's
//! path crosses it from right to left.
//!
//! The same run without the sphere (a uniform stream) leaves the cloud
//! exactly translated; the disturbance `∫|ρ_lab(t) − ρ₀| / ∫ρ₀` therefore
//! measures the wake alone. `data.csv` reports it inside and outside a tube
//! of two sphere radii around the flight path, with the cloud's mass in the
//! view box (the cloud's box, extended 1.5 along the flight).
//!
//! What it shows (default size): the sphere bores a tunnel through the
//! cloud and drags two sheets of cloud along its path — Darwin's drift: air
//! near the stagnation streamline travels with the body; the disturbance
//! within two radii of the path is about 100× that outside (`data.csv`).
//! At 32 cells across, the wake is laminar: the notes' picture shows a
//! turbulent wake from a production-scale simulation, which this grid does
//! not resolve; the sticky rule at α = 0 gave the same picture with more
//! of the cloud dragged out of view.
//!
//! Run: `smokelab experiment 08-3` (about 30 s on 2 cores: 80 × 32 × 32
//! velocity cells, 256² renders; `--full` 160 × 64 × 64 and 512²; `--smoke`
//! 40 × 16 × 16 and 64²).
//!
//! Writes `results/08-3/`: `wake.png` (renders at t = 0, when the sphere is
//! in the cloud, and after it has passed), `slice.png` (mid-plane slices of
//! the cloud at the same times), `flow.png` (the stream's x-velocity in the
//! mid-plane at the end of warm-up: the wake's deficit), `data.csv`,
//! `manifest.json`.

use std::sync::Arc;
use std::time::Instant;

use anyhow::Result;
use glam::Vec3;
use image::RgbImage;
use serde::Serialize;

use crate::cloud_figures::{cloud, layers, SCALE};
use crate::model_render::{by_size, render_densities};
use crate::registry::{Context, Experiment};
use crate::table::write_rows;
use smokelab::advection::Backtrace;
use smokelab::boundary::{
    Boundary, BoundaryOptions, BoundaryRule, Obstacle, ObstacleMethod, Sphere,
};
use smokelab::density::{DensityMode, DensityModel, DensityOptions};
use smokelab::domain::Domain;
use smokelab::field::algebra::{compose, dot, max};
use smokelab::field::ops::{self, constant, constant_vector, identity, vector_sum};
use smokelab::field::{Scalar, Vector};
use smokelab::grid::ScalarGrid;
use smokelab::io::{self, manifest::Manifest, preview};
use smokelab::model::cloud::billow;
use smokelab::model::shape;
use smokelab::simulation::{Gas, MassBudget, Simulation, StepParams};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "08-3",
    folder: "08-3",
    reproduces: "fig 8.3",
    title: "SELMA applies a simulated sphere wake to a modelled cloud",
    cost: "~30 s",
    run,
};

/// Box edge across the flight path; the box is `2.5 L` long along it.
const L: f32 = 4.0;
/// Flight speed.
const U: f32 = 1.0;
/// The sphere: radius and centre (sphere frame).
const RADIUS: f32 = 0.4;
const SPHERE: Vec3 = Vec3::new(6.0, 2.15, 2.0);
/// The cloud's centre at t = 0 (the modelling box `[−1.1, 1.1]³` moved here).
const CLOUD: Vec3 = Vec3::new(2.5, 2.0, 2.0);
/// Time step, warm-up and flight times.
const DT: f32 = 0.05;
const WARM_UP: f32 = 2.0;
const FLIGHT: f32 = 6.0;
/// Render times within the flight: before, sphere in the cloud, after.
const SHOWN: [f32; 3] = [0.0, 3.5, 6.0];

#[derive(Serialize)]
struct Config {
    cells: [usize; 3],
    map_cells: usize,
    dt: f32,
    speed: f32,
    sphere_center: Vec3,
    sphere_radius: f32,
    cloud_center: Vec3,
    warm_up: f32,
    flight: f32,
    boundary: &'static str,
    pixels: u32,
    shown: [f32; 3],
}

/// One row of `data.csv`: the cloud at one shown time.
#[derive(Serialize)]
struct Row {
    case: &'static str,
    time: f32,
    mass: f64,
    /// `∫|ρ_lab − ρ₀| / ∫ρ₀` inside the tube of two radii around the path.
    disturbance_near: f64,
    /// The same outside the tube.
    disturbance_far: f64,
}

/// The cloud of this shot on `grid` cells: three merged spheres (their
/// signed distances' `max`) under the three layers of ch. 3 cleared by eq
/// 3.8 with billow 1 and a fixed `Q` of half the first layer's amplitude.
fn shot_cloud(grid: usize) -> Result<Scalar> {
    let a = shape::sphere(Vec3::new(-0.3, -0.1, 0.0), 0.45);
    let b = shape::sphere(Vec3::new(0.25, -0.15, 0.1), 0.4);
    let c = shape::sphere(Vec3::new(0.0, 0.25, -0.05), 0.38);
    let q = [0.5 * SCALE; 2];
    let cleared = billow(&layers(3, constant(SCALE)), &q, constant(1.0))?;
    cloud(max(max(a, b), c), &cleared, 0, grid)
}

fn run(ctx: &Context) -> Result<()> {
    let (n, pixels) = by_size(ctx.size, [(16, 64), (32, 256), (64, 512)]);
    let start = Instant::now();
    io::create_output_dir(&ctx.out)?;
    let cloud0 = translated(ops::mask(shot_cloud(2 * n)?), CLOUD);
    // The cloud's box, extended 1.5 along the flight so the gas dragged
    // along the path stays in view.
    let view = Domain::new(
        CLOUD - Vec3::new(3.0, 1.5, 1.5),
        1.5 / n as f32,
        [3 * n, 2 * n, 2 * n],
    )?;
    let mut rows = vec![];
    let mut renders: Vec<RgbImage> = vec![];
    let mut slices: Vec<RgbImage> = vec![];
    let mut flow = None;
    for case in ["sphere", "no-sphere"] {
        let (mut sim, flow_image) = warmed_up(n, case == "sphere")?;
        flow = flow.or(flow_image);
        sim.gases.push(cloud_gas(&sim, cloud0.clone(), 5 * n));
        if let Some(b) = &sim.boundary {
            let walls = Arc::new(b.wall_stop());
            sim.gases[0].model.set_walls(&walls);
        }
        let t0 = sim.time();
        let reference = lab_density(&sim, t0);
        let reference_grid = ScalarGrid::from_field(view, &*reference);
        for &t in &SHOWN {
            while sim.time() - t0 < t - 0.5 * DT {
                sim.step();
            }
            let density = lab_density(&sim, t0);
            let grid = ScalarGrid::from_field(view, &*density);
            let (near, far) = disturbance(&grid, &reference_grid, &view);
            rows.push(Row {
                case,
                time: t,
                mass: grid.total(),
                disturbance_near: near,
                disturbance_far: far,
            });
            if case == "sphere" {
                let color = Vec3::new(0.92, 0.93, 0.95);
                renders.push(render_densities(
                    vec![("cloud".into(), density.clone(), color)],
                    view,
                    pixels,
                    0.5,
                    6.0,
                )?);
                slices.push(preview::field_slice(
                    &[preview::FieldLayer {
                        field: &*density,
                        color: [0.95, 0.95, 1.0],
                    }],
                    &view,
                    pixels,
                    3.0,
                ));
            }
        }
    }
    io::write_png(
        &ctx.out.join("wake.png"),
        &preview::side_by_side(&renders, 6),
    )?;
    io::write_png(
        &ctx.out.join("slice.png"),
        &preview::side_by_side(&slices, 6),
    )?;
    if let Some(f) = flow {
        io::write_png(&ctx.out.join("flow.png"), &f)?;
    }
    write_rows(&ctx.out.join("data.csv"), &rows)?;
    let config = Config {
        cells: [5 * n / 2, n, n],
        map_cells: 5 * n,
        dt: DT,
        speed: U,
        sphere_center: SPHERE,
        sphere_radius: RADIUS,
        cloud_center: CLOUD,
        warm_up: WARM_UP,
        flight: FLIGHT,
        boundary: "exact, reflect (free slip)",
        pixels,
        shown: SHOWN,
    };
    io::write_json(
        &ctx.out.join("manifest.json"),
        &Manifest::new(
            config,
            0xc10d,
            start.elapsed().as_secs_f64(),
            serde_json::json!({}),
        ),
    )
}

/// `f` moved by `offset`: `f(x − offset)`.
fn translated(f: Scalar, offset: Vec3) -> Scalar {
    compose(f, vector_sum(identity(), constant_vector(-offset)))
}

/// The stream past the sphere (or without it) in the sphere's frame, after
/// the warm-up; with the sphere also an image of the mid-plane x-velocity
/// (white = U, black = at rest or reversed).
fn warmed_up(n: usize, with_sphere: bool) -> Result<(Simulation, Option<RgbImage>)> {
    let domain = Domain::new(Vec3::ZERO, L / n as f32, [5 * n / 2, n, n])?;
    let params = StepParams {
        dt: DT,
        viscosity: 0.0,
        gravity: Vec3::ZERO,
        backtrace: Backtrace::Rk2,
    };
    let mut sim = Simulation::new(domain, params, vec![]);
    if with_sphere {
        let sphere: Obstacle = Arc::new(Sphere {
            center: SPHERE,
            radius: RADIUS,
        });
        let options = BoundaryOptions {
            method: ObstacleMethod::Exact,
            rule: BoundaryRule::Reflect,
            alpha: 1.0,
            passes: 1,
        };
        sim = sim.with_boundary(Boundary::new(domain, &sphere, options)?);
    }
    sim.velocity.slice_mut(0).fill(U);
    sim.project();
    sim.apply_boundary();
    while sim.time() < WARM_UP - 0.5 * DT {
        sim.step();
    }
    let image = with_sphere.then(|| {
        let u: Vector = Arc::new(sim.velocity.clone());
        let speed = dot(u, constant_vector(Vec3::X));
        preview::field_slice(
            &[preview::FieldLayer {
                field: &*speed,
                color: [1.0, 1.0, 1.0],
            }],
            &domain,
            640,
            2.0,
        )
    });
    Ok((sim, image))
}

/// The cloud as a SELMA gas (no source, no lift, never re-anchored) on a map
/// of `map_cells` along the box's length.
fn cloud_gas(sim: &Simulation, cloud: Scalar, map_cells: usize) -> Gas {
    let domain = *sim.domain();
    let options = DensityOptions {
        mode: DensityMode::Selma,
        map_res: Some(map_cells),
        selma_remap: 0.0,
    };
    Gas {
        name: "cloud".into(),
        model: DensityModel::new(&options, domain, Some(cloud), None),
        source: ScalarGrid::zeros(domain),
        source_field: constant(0.0),
        lift: 0.0,
        budget: MassBudget::default(),
    }
}

/// The cloud in the still air's frame at flight time `t − t0`:
/// `ρ(x + U t)` in sphere-frame coordinates.
fn lab_density(sim: &Simulation, t0: f32) -> Scalar {
    let shift = Vec3::X * U * (sim.time() - t0);
    translated(sim.gases[0].model.field(), -shift)
}

/// `∫|ρ − ρ₀| / ∫ρ₀` over the cells of `view` within two sphere radii of the
/// flight path (the line through the sphere's centre along x), and outside.
fn disturbance(rho: &ScalarGrid, rho0: &ScalarGrid, view: &Domain) -> (f64, f64) {
    let total: f64 = rho0.data().iter().map(|&v| v as f64).sum();
    let (mut near, mut far) = (0.0, 0.0);
    let [nx, ny, nz] = view.dims;
    for k in 0..nz {
        for j in 0..ny {
            for i in 0..nx {
                let p = view.cell_center(i, j, k);
                let off = Vec3::new(0.0, p.y - SPHERE.y, p.z - SPHERE.z).length();
                let d = (rho.data()[[k, j, i]] - rho0.data()[[k, j, i]]).abs() as f64;
                if off < 2.0 * RADIUS {
                    near += d;
                } else {
                    far += d;
                }
            }
        }
    }
    (near / total, far / total)
}
