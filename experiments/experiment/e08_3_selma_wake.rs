//! # 08-3 — SELMA applies a simulated wake to a modelled cloud (fig 8.3)
//!
//! Reproduces the notes' figure 8.3 (§8.3, *The A-Team*): "an aircraft
//! passing through cloud material leaves behind a wake disturbance in the
//! cloud. The velocity field is from a fluid simulation that does not
//! include the presence of the cloud. The cloud was modeled using the
//! methods in chapter 3, then displaced using SELMA."
//!
//! Set-up. The aircraft is a sphere of diameter `D = 0.6` flying at speed
//! `U = 1` through still air. Obstacles do not move in this code, so the
//! flow is simulated in the sphere's frame: a uniform stream past a fixed
//! sphere in a periodic `12 × 6 × 6` box, inviscid, exact obstacle with the
//! sticky rule at α = 0 (eq 6.7; the flow along the wall is held at zero,
//! so the surface sheds vorticity), warmed up for `5 D/U` so the wake
//! exists before the cloud arrives. The cloud is the three-layer billowed
//! cloud of 03-4 (ch. 3, eqs 3.5–3.8) scaled by 2.5, about 3.4 across the
//! path — 5.7 body diameters (`width`) — and 4 along it, placed upstream
//! with the flight path through its middle. The stream carries it through the sphere; its density is
//! `ρ₀ ∘ X` with `X` SELMA's backward map (eq 8.8) on a map grid twice as
//! fine as the velocity, never re-anchored (no sources: the cloud stays
//! procedural). Everything shown is in the still air's frame,
//! `f_lab(x, t) = f(x + U t x̂, t)`, where the cloud would stay put without
//! the sphere and the sphere flies from right to left through it.
//!
//! Measures (`data.csv`, one row per shown time `t`, in units of `D/U`):
//! - the **displacement** of the material now at lab point `x`,
//!   `d(x) = x − X(x + U t x̂)` — the lab position now minus the position it
//!   came from (the sphere and lab frames agree at `t = 0`), taken to the
//!   nearest periodic image of the box; a uniform stream alone gives
//!   `d = 0` exactly (SELMA's map of a uniform translation is exact);
//! - the **corridor**: the cylinder of radius `1.5 D` around the flight path
//!   (the line through the sphere's centre along x). `moved_outside` is the
//!   share of the cloud mass outside it (by current position) displaced by
//!   more than `D`; `moved_inside` the same share inside it;
//! - the cloud's **width** across the path at `t = 0` in body diameters
//!   (the extent in y of the cells with density above ½);
//! - the **vorticity** `ω = ∇ × u` (central differences of the face
//!   velocity, step one cell) over the fluid cells of the sphere frame: rms
//!   inside the corridor and outside it, and the peak, in units of `U/D`;
//!   the rms of the streamwise `ω_x` inside the corridor (the trailing
//!   vortices).
//!
//! The body carries lift, as an aircraft does: its reaction on the air is
//! a downward force per unit mass `LIFT · w(x)` on the fluid around the
//! sphere (a Gaussian of width `D/2` in x and y, spanning `2 D` across z,
//! [`LIFT`] = 2 in the code's units, `U = 1`, `D = 0.6`), added to the
//! y-velocity before every step; the projection turns the downwash into the
//! trailing vortex pair of a lifting body (streamwise vorticity `ω_x` of
//! opposite signs at the two ends of the span). Without it the wake of a
//! sphere on this grid is laminar, steady and axisymmetric (`ω_x` rms
//! 0.0005 U/D at smoke size): no vortical structure crosses the cloud.
//!
//! What it shows (`smokelab experiment 08-3`, default size): the sphere
//! cuts a channel through the middle of the cloud and draws cloud out
//! behind it into a tail that follows the body; across the path
//! (`section.png`, after the passage) the vortex pair has rolled the
//! cloud up around the path into hooks and a hole, and `ω_x` shows the two
//! counter-rotating vortices and nothing else (rms 0.27 U/D in the
//! corridor, peak |ω| 3.4 U/D). After the passage 36 % of the mass in the
//! corridor has moved more than `D`, 9.4 % of the mass outside it (mean
//! displacement 0.51 D, the vortices' induced flow reaching past the
//! corridor's edge). What does not show: turbulence. At 48 cells across
//! (5 per diameter) the semi-Lagrangian step's numerical viscosity keeps
//! the flow laminar; the wake is one smooth vortex pair, not the notes'
//! production-scale turbulence, and the render (`wake.png`) reads as a
//! channel and a tail, also with the near half cut away — the vortices
//! show in the sections.
//!
//! Run: `smokelab experiment 08-3` (about 2.5 min on 2 cores: 96 × 48 × 48
//! velocity cells, 256² renders; `--full` 192 × 96 × 96 and 512²; `--smoke`
//! 48 × 24 × 24 and 64², about 25 s).
//!
//! Writes `results/08-3/`: `wake.png` (renders before, while the sphere is
//! in the cloud and after it has passed, the sphere drawn in orange; top
//! row the whole cloud, bottom row its far half, cut at the vertical plane
//! through the flight path, which shows the channel inside),
//! `section.png` (after the passage, the cloud's density and `ω_x` on
//! three planes across the path),
//! `slice.png` (mid-plane slices through the path at the same times: the
//! cloud's density and the vorticity `ω_z`), `flow.png` (the stream in the
//! sphere's frame at the end of warm-up: x-velocity and `ω_z`), `data.csv`,
//! `manifest.json`.

use std::sync::Arc;
use std::time::Instant;

use anyhow::{bail, Result};
use glam::{Mat3, Vec3};
use image::RgbImage;
use rayon::prelude::*;
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::experiment::shared::cloud_figures::billowed;
use crate::experiment::shared::model_render::render_densities;
use crate::figures::panels;
use crate::figures::table::write_rows;
use smokelab::advection::Backtrace;
use smokelab::boundary::{
    Boundary, BoundaryOptions, BoundaryRule, Obstacle, ObstacleMethod, Sphere,
};
use smokelab::density::{BackwardMap, DensityMode, DensityModel, DensityOptions, SelmaField};
use smokelab::domain::Domain;
use smokelab::field::algebra::{bilinear, component, compose, dot, jacobian, zip, Binary};
use smokelab::field::ops::{self, constant, constant_vector, identity, vector_sum};
use smokelab::field::{Scalar, ScalarField, Vector};
use smokelab::grid::ScalarGrid;
use smokelab::io::{self, preview};
use smokelab::simulation::{Gas, MassBudget, Simulation, StepParams};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "08-3",
    folder: "08-3",
    reproduces: "fig 8.3",
    title: "SELMA applies a simulated sphere wake to a modelled cloud",
    cost: "~2.5 min",
    run,
};

/// Box edge across the flight path; the box is `2 L` long along it.
const L: f32 = 6.0;
/// Flight speed.
const U: f32 = 1.0;
/// The sphere: radius and centre (sphere frame), on the box's mid-line.
const RADIUS: f32 = 0.3;
const SPHERE: Vec3 = Vec3::new(5.7, 3.0, 3.0);
/// Body diameter, the unit of lengths in `data.csv`.
const D: f32 = 2.0 * RADIUS;
/// Radius of the wake's corridor around the flight path.
const CORRIDOR: f32 = 1.5 * D;
/// The cloud: 03-4's model (box `[−1.1, 1.1]³`) scaled by this, centred at
/// `CLOUD` at t = 0, upstream of the sphere.
const CLOUD_SCALE: f32 = 2.5;
const CLOUD: Vec3 = Vec3::new(3.1, 3.0, 3.0);
/// Half-width of the scaled modelling box.
const CLOUD_HALF: f32 = 1.1 * CLOUD_SCALE;
/// Time step, warm-up and flight times.
const DT: f32 = 0.05;
const WARM_UP: f32 = 5.0 * D / U;
const FLIGHT: f32 = 10.0 * D / U;
/// Shown times within the flight, in `D/U`: before, the sphere in the
/// cloud, after it has left.
const SHOWN: [f32; 3] = [0.0, 5.0, 10.0];
/// Vorticity of full colour in the slices, in `U/D`.
const VORTICITY_SCALE: f32 = 1.0;
/// The body's lift: the air it deflects downward per unit time, as a force
/// per unit mass `LIFT · w(x)` along −y on the fluid just behind it, with
/// `w` a Gaussian of widths [`CHORD`] along x and y centred at
/// [`LIFT_CENTER`], cut off smoothly beyond half the span [`SPAN`] across z.
const LIFT: f32 = 2.0;
const CHORD: f32 = 0.5 * D;
const SPAN: f32 = 2.0 * D;
/// Where the downwash is applied: 1.5 chords behind the sphere's trailing
/// point, on the fluid. Centred on the sphere, the middle of the Gaussian
/// fell on the body's closed faces and was lost, so the column of air that
/// passed the body carried less downwash than the air beside it: an
/// opposite-signed pair of `ω_x` the body's width apart inside the trailing
/// pair (the body's image in the downwash), which this placement removes.
const LIFT_CENTER: Vec3 = Vec3::new(SPHERE.x + RADIUS + 1.5 * CHORD, SPHERE.y, SPHERE.z);
/// Where the cross-sections of `section.png` cut the cloud after the
/// passage: lab x relative to the cloud's centre, in `D`.
const SECTIONS: [f32; 3] = [-2.0, 0.0, 2.0];

#[derive(Serialize)]
struct Config {
    cells: [usize; 3],
    map_cells: usize,
    dt: f32,
    speed: f32,
    sphere_center: Vec3,
    sphere_radius: f32,
    corridor_radius: f32,
    cloud_center: Vec3,
    cloud_scale: f32,
    warm_up: f32,
    flight: f32,
    boundary: &'static str,
    pixels: u32,
    shown_d_over_u: [f32; 3],
}

/// One row of `data.csv`: the cloud and the flow at one shown time.
#[derive(Serialize)]
struct Row {
    /// Flight time in `D/U`.
    time: f32,
    /// Cloud mass in the view box.
    mass: f64,
    /// Extent of the cloud across the path at t = 0, in `D`.
    width: f64,
    /// Share of the cloud mass outside the corridor.
    outside_share: f64,
    /// Share of the mass outside the corridor displaced more than `D`.
    moved_outside: f64,
    /// Share of the mass inside the corridor displaced more than `D`.
    moved_inside: f64,
    /// Mass-weighted mean `|d|` outside the corridor, in `D`.
    mean_displacement_outside: f64,
    /// Rms `|ω|` over the fluid cells inside / outside the corridor, `U/D`.
    vorticity_rms_corridor: f64,
    vorticity_rms_outside: f64,
    /// Peak `|ω|` over the fluid cells, `U/D`.
    vorticity_peak: f64,
    /// Rms of the streamwise vorticity `ω_x` over the fluid cells inside
    /// the corridor, `U/D`: the trailing vortices (an axisymmetric wake
    /// has none).
    streamwise_vorticity_rms_corridor: f64,
}

fn run(ctx: &Context) -> Result<()> {
    let (n, pixels) = ctx.size.pick((24, 64), (48, 256), (96, 512));
    let start = Instant::now();
    io::create_output_dir(&ctx.out)?;
    let cloud0 = scaled(ops::mask(billowed(1.0, 2 * n)?), CLOUD_SCALE, CLOUD);
    let view = view_box(n)?;
    let (mut sim, lift, flow) = warmed_up(n)?;
    sim.gases.push(cloud_gas(&sim, cloud0.clone(), 4 * n));
    if let Some(b) = &sim.boundary {
        let walls = Arc::new(b.wall_stop());
        sim.gases[0].model.set_walls(&walls);
    }
    let t0 = sim.time();
    let width = cloud_width(&ScalarGrid::from_field(view, &*cloud0), &view);
    if width < 5.0 {
        bail!("08-3: the cloud is {width:.2} body diameters across; the set-up needs at least 5");
    }
    let mut rows = vec![];
    let mut shown = Shown::default();
    for &t in &SHOWN {
        while sim.time() - t0 < t * D / U - 0.5 * DT {
            step_lifting(&mut sim, &lift);
        }
        let tau = sim.time() - t0;
        rows.push(row(&sim, t, tau, width, &view)?);
        shown.add(&sim, tau, &view, pixels)?;
    }
    save_sections(ctx, &sim, sim.time() - t0, &view, pixels)?;
    shown.save(ctx, n)?;
    io::write_png(&ctx.out.join("flow.png"), &flow)?;
    write_rows(&ctx.out.join("data.csv"), &rows)?;
    let config = Config {
        cells: [2 * n, n, n],
        map_cells: 4 * n,
        dt: DT,
        speed: U,
        sphere_center: SPHERE,
        sphere_radius: RADIUS,
        corridor_radius: CORRIDOR,
        cloud_center: CLOUD,
        cloud_scale: CLOUD_SCALE,
        warm_up: WARM_UP,
        flight: FLIGHT,
        boundary: "exact, sticky, alpha 0",
        pixels,
        shown_d_over_u: SHOWN,
    };
    ctx.write_manifest(config, 0xc10d, start, serde_json::json!({}))
}

/// The cloud's box in the lab, extended 2.5 D along the sphere's flight
/// (toward −x), where the wake carries cloud along, and 1 D the other
/// way, where the sphere starts; cells half the simulation's.
fn view_box(n: usize) -> Result<Domain> {
    let view_cell = 0.5 * L / n as f32;
    let view_lo = CLOUD - Vec3::new(CLOUD_HALF + 2.5 * D, CLOUD_HALF, CLOUD_HALF);
    let view_size = Vec3::new(
        2.0 * CLOUD_HALF + 3.5 * D,
        2.0 * CLOUD_HALF,
        2.0 * CLOUD_HALF,
    );
    Ok(Domain::new(
        view_lo,
        view_cell,
        (view_size / view_cell)
            .round()
            .to_array()
            .map(|c| c as usize),
    )?)
}

/// The row of `data.csv` at shown time `t` (`D/U`), `tau` after the
/// cloud was placed.
fn row(sim: &Simulation, t: f32, tau: f32, width: f64, view: &Domain) -> Result<Row> {
    let moved = displacement_shares(&selma_field(sim)?, view, tau, sim.domain());
    let vort = vorticity_stats(sim);
    Ok(Row {
        time: t,
        mass: moved.mass,
        width,
        outside_share: moved.outside_share,
        moved_outside: moved.outside,
        moved_inside: moved.inside,
        mean_displacement_outside: moved.mean_outside,
        vorticity_rms_corridor: vort[0],
        vorticity_rms_outside: vort[1],
        vorticity_peak: vort[2],
        streamwise_vorticity_rms_corridor: vort[3],
    })
}

/// The panels of `wake.png` and `slice.png`, one column per shown time.
#[derive(Default)]
struct Shown {
    renders: Vec<RgbImage>,
    cutaways: Vec<RgbImage>,
    density_slices: Vec<RgbImage>,
    vorticity_slices: Vec<RgbImage>,
}

impl Shown {
    /// The column of the state `sim` reached, `tau` after the cloud was
    /// placed: the cloud rendered whole and with its near half cut away,
    /// and the mid-plane density and vorticity `ω_z`.
    fn add(&mut self, sim: &Simulation, tau: f32, view: &Domain, pixels: u32) -> Result<()> {
        let density = lab(sim.gases[0].model.field(), tau);
        // The far half of the cloud, `z < CLOUD.z` (the camera looks from
        // +z): the near half cut away at the vertical plane through the
        // flight path.
        let far_half = ops::mask(ops::sum(
            constant(CLOUD.z),
            ops::scale(component(identity(), 2), -1.0),
        ));
        let body = ops::scale(
            ops::mask(ops::sphere(SPHERE - Vec3::X * U * tau, RADIUS)),
            20.0,
        );
        let cut = zip(density.clone(), far_half, Binary::Mul);
        for (shown, out) in [
            (density.clone(), &mut self.renders),
            (cut, &mut self.cutaways),
        ] {
            out.push(render_densities(
                vec![
                    ("cloud".into(), shown, Vec3::new(0.92, 0.93, 0.95)),
                    ("sphere".into(), body.clone(), Vec3::new(1.0, 0.55, 0.2)),
                ],
                *view,
                pixels,
                0.5,
                6.0,
            )?);
        }
        self.density_slices.push(preview::field_slice(
            &[
                preview::FieldLayer {
                    field: &*density,
                    color: [0.95, 0.95, 1.0],
                },
                preview::FieldLayer {
                    field: &*body,
                    color: [1.0, 0.55, 0.2],
                },
            ],
            view,
            pixels,
            3.0,
        ));
        self.vorticity_slices.push(vorticity_slice(
            &lab(vorticity_component(sim, 2), tau),
            view,
            pixels,
        ));
        Ok(())
    }

    /// `wake.png` (the renders) and `slice.png` (the mid-plane slices).
    fn save(self, ctx: &Context, n: usize) -> Result<()> {
        let headings: Vec<String> = SHOWN.iter().map(|t| format!("t = {t} D/U")).collect();
        panels::save(
            &ctx.out.join("wake.png"),
            &[self.renders, self.cutaways],
            6,
            &panels::Labels {
                title: &format!(
                    "render, still-air frame: sphere (orange) flies right to left; {:.1} cells per D",
                    D * n as f32 / L
                ),
                rows: &[
                    "whole cloud".into(),
                    "near half cut away at the path".into(),
                ],
                columns: &headings,
            },
        )?;
        panels::save(
            &ctx.out.join("slice.png"),
            &[self.density_slices, self.vorticity_slices],
            6,
            &panels::Labels {
                title: "mid-plane through the flight path, still-air frame",
                rows: &["density".into(), "vorticity ω_z".into()],
                columns: &headings,
            },
        )
    }
}

/// `section.png`: density and streamwise vorticity `ω_x` across the path
/// at [`SECTIONS`] behind the cloud's centre, at the last shown time.
fn save_sections(
    ctx: &Context,
    sim: &Simulation,
    tau: f32,
    view: &Domain,
    pixels: u32,
) -> Result<()> {
    let density = lab(sim.gases[0].model.field(), tau);
    let omega_x = lab(vorticity_component(sim, 0), tau);
    let behind: Vec<String> = SECTIONS
        .iter()
        .map(|&s| {
            let x = CLOUD.x + s * D;
            format!("{:.1} D behind", (x - (SPHERE.x - U * tau)) / D)
        })
        .collect();
    let (section_density, section_vorticity): (Vec<_>, Vec<_>) = SECTIONS
        .iter()
        .map(|&s| {
            let x = CLOUD.x + s * D;
            let across = Domain::new(
                Vec3::new(CLOUD.z - CLOUD_HALF, CLOUD.y - CLOUD_HALF, 0.0),
                view.cell,
                [view.dims[2], view.dims[1], 4],
            )?;
            let d = cross_section(density.clone(), x);
            let w = cross_section(omega_x.clone(), x);
            Ok((
                preview::field_slice(
                    &[preview::FieldLayer {
                        field: &*d,
                        color: [0.95, 0.95, 1.0],
                    }],
                    &across,
                    pixels,
                    3.0,
                ),
                vorticity_slice(&w, &across, pixels),
            ))
        })
        .collect::<Result<Vec<_>>>()?
        .into_iter()
        .unzip();
    panels::save(
        &ctx.out.join("section.png"),
        &[section_density, section_vorticity],
        6,
        &panels::Labels {
            title: &format!("across the path, t = {} D/U (z right, y up)", SHOWN[2]),
            rows: &["density".into(), "vorticity ω_x".into()],
            columns: &behind,
        },
    )
}

/// `f` scaled by `s` about the origin and moved to `center`:
/// `f((x − center) / s)`.
fn scaled(f: Scalar, s: f32, center: Vec3) -> Scalar {
    let map = ops::vector_scale(vector_sum(identity(), constant_vector(-center)), 1.0 / s);
    compose(f, map)
}

/// The stream past the sphere in the sphere's frame after the warm-up, and
/// the figure of its mid-plane: x-velocity (white = U, black = at rest or
/// reversed) and vorticity `ω_z`.
fn warmed_up(n: usize) -> Result<(Simulation, LiftFaces, RgbImage)> {
    let domain = Domain::new(Vec3::ZERO, L / n as f32, [2 * n, n, n])?;
    let params = StepParams {
        dt: DT,
        viscosity: 0.0,
        gravity: Vec3::ZERO,
        backtrace: Backtrace::Rk2,
        interpolant: Default::default(),
        confinement: 0.0,
    };
    let sphere: Obstacle = Arc::new(Sphere {
        center: SPHERE,
        radius: RADIUS,
    });
    let options = BoundaryOptions {
        method: ObstacleMethod::Exact,
        rule: BoundaryRule::Sticky,
        alpha: 0.0,
        passes: 1,
    };
    let mut sim = Simulation::new(domain, params, vec![])
        .with_boundary(Boundary::new(domain, &sphere, options)?);
    let lift = lift_weights(&sim);
    sim.velocity.slice_mut(0).fill(U);
    sim.project()?;
    sim.apply_boundary();
    while sim.time() < WARM_UP - 0.5 * DT {
        step_lifting(&mut sim, &lift);
    }
    let u: Vector = Arc::new(sim.velocity.clone());
    let speed = dot(u, constant_vector(Vec3::X));
    let width = 640;
    let velocity_image = preview::field_slice(
        &[preview::FieldLayer {
            field: &*speed,
            color: [1.0, 1.0, 1.0],
        }],
        &domain,
        width,
        2.0,
    );
    let image = panels::row(
        &[
            velocity_image,
            vorticity_slice(&vorticity_component(&sim, 2), &domain, width),
        ],
        6,
        "sphere frame, mid-plane, t = 0 D/U (end of warm-up)",
        &[
            "x-velocity (white = U)".into(),
            "vorticity ω_z (red +, blue −)".into(),
        ],
    )?;
    Ok((sim, lift, image))
}

/// The cloud as a SELMA gas (no source, no lift, never re-anchored) on a map
/// of `map_cells` along the box's length.
fn cloud_gas(sim: &Simulation, cloud: Scalar, map_cells: usize) -> Gas {
    let domain = *sim.domain();
    let options = DensityOptions {
        map_res: Some(map_cells),
        selma_remap: 0.0,
        ..DensityOptions::mode(DensityMode::Selma)
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

/// The cloud's SELMA field (density and backward map).
fn selma_field(sim: &Simulation) -> Result<SelmaField> {
    match &sim.gases[0].model {
        DensityModel::Selma(s) => Ok(s.field().clone()),
        _ => bail!("08-3: the cloud is not a SELMA gas"),
    }
}

/// A sphere-frame field `f` in the still air's frame at flight time `tau`:
/// `f(x + U τ x̂)`.
fn lab(f: Scalar, tau: f32) -> Scalar {
    compose(
        f,
        vector_sum(identity(), constant_vector(Vec3::X * U * tau)),
    )
}

/// The vorticity's component `axis` of the simulation's velocity (`ω_x =
/// ∂w/∂y − ∂v/∂z`, `ω_z = ∂v/∂x − ∂u/∂y`, …; central differences, step one
/// cell), a field in the sphere's frame.
fn vorticity_component(sim: &Simulation, axis: usize) -> Scalar {
    let u: Vector = Arc::new(sim.velocity.clone());
    let j = jacobian(u, sim.domain().cell);
    let e = |a: usize| constant_vector(Vec3::AXES[a % 3]);
    // ω_a = ∂u_{a+2}/∂x_{a+1} − ∂u_{a+1}/∂x_{a+2}; J's column j is ∂u/∂x_j.
    let (b, c) = (axis + 1, axis + 2);
    ops::sum(
        bilinear(e(c), j.clone(), e(b)),
        ops::scale(bilinear(e(b), j, e(c)), -1.0),
    )
}

/// `f` on the plane `x = x0`, seen along the flight path: the value at
/// `(a, b, ·)` is `f(x0, b, a)`, so a [`preview::field_slice`] of it shows
/// z to the right and y up.
fn cross_section(f: Scalar, x0: f32) -> Scalar {
    Arc::new(CrossSection { f, x0 })
}

struct CrossSection {
    f: Scalar,
    x0: f32,
}

impl ScalarField for CrossSection {
    fn eval(&self, p: Vec3) -> f32 {
        self.f.eval(Vec3::new(self.x0, p.y, p.x))
    }

    fn eval_batch(&self, points: &[Vec3], out: &mut [f32]) {
        let across: Vec<Vec3> = points
            .iter()
            .map(|p| Vec3::new(self.x0, p.y, p.x))
            .collect();
        self.f.eval_batch(&across, out);
    }
}

/// Indices into the y-velocity's faces, each with the weight of the lift
/// there.
type LiftFaces = Vec<(usize, f32)>;

/// The faces of the y-velocity the body's lift acts on, with their weights
/// `w(x)`: a Gaussian of width [`CHORD`] in x and y about
/// [`LIFT_CENTER`], times a smooth cut-off `½(1 − tanh((|z − z_c| − SPAN/2)/CHORD·2))`
/// across the span, over the faces where it exceeds 10⁻³.
fn lift_weights(sim: &Simulation) -> LiftFaces {
    let dims = sim.velocity.face_dims(1);
    let mut out = vec![];
    let mut idx = 0;
    for k in 0..dims[2] {
        for j in 0..dims[1] {
            for i in 0..dims[0] {
                let p = sim.velocity.face_position(1, i, j, k) - LIFT_CENTER;
                let g = (-(p.x * p.x + p.y * p.y) / (CHORD * CHORD)).exp();
                let cut = 0.5 * (1.0 - ((p.z.abs() - 0.5 * SPAN) * 2.0 / CHORD).tanh());
                let w = g * cut;
                if w > 1e-3 {
                    out.push((idx, w));
                }
                idx += 1;
            }
        }
    }
    out
}

/// One step with the body's lift: the y-velocity at `lift`'s faces gains
/// `−Δt · LIFT · w` (its reaction on the air, a downwash between the wing
/// tips), then the step (advect, project, boundary) makes it a
/// divergence-free flow: the trailing vortex pair of a lifting body.
fn step_lifting(sim: &mut Simulation, lift: &[(usize, f32)]) {
    let dv = sim.params.dt * LIFT;
    let v = sim.velocity.slice_mut(1);
    for &(i, w) in lift {
        v[i] -= dv * w;
    }
    sim.step();
}

/// Mid-plane slice of `ω_z` over `domain`: red where positive, blue where
/// negative, full colour at [`VORTICITY_SCALE`] `U/D`.
fn vorticity_slice(omega_z: &Scalar, domain: &Domain, width: u32) -> RgbImage {
    let negative = ops::scale(omega_z.clone(), -1.0);
    preview::field_slice(
        &[
            preview::FieldLayer {
                field: &**omega_z,
                color: [1.0, 0.3, 0.2],
            },
            preview::FieldLayer {
                field: &*negative,
                color: [0.25, 0.5, 1.0],
            },
        ],
        domain,
        width,
        2.0 * D / (U * VORTICITY_SCALE),
    )
}

/// `ω = ∇ × u` from the Jacobian `J` whose column `j` is `∂u/∂x_j`.
fn curl(j: Mat3) -> Vec3 {
    Vec3::new(
        j.y_axis.z - j.z_axis.y,
        j.z_axis.x - j.x_axis.z,
        j.x_axis.y - j.y_axis.x,
    )
}

/// Distance of `p` from the flight path (the line through the sphere's
/// centre along x).
fn off_path(p: Vec3) -> f32 {
    Vec3::new(0.0, p.y - SPHERE.y, p.z - SPHERE.z).length()
}

/// Rms `|ω|` over the fluid cells (centres outside the sphere) of the
/// sphere frame inside the corridor and outside it, and the peak `|ω|`, all
/// in `U/D`.
fn vorticity_stats(sim: &Simulation) -> [f64; 4] {
    let domain = *sim.domain();
    let u: Vector = Arc::new(sim.velocity.clone());
    let j = jacobian(u, domain.cell);
    // [|ω|² and cells inside, the same outside, peak, ω_x² inside]
    let total = fold_slabs(
        &domain,
        |points| {
            let mut m = vec![Mat3::ZERO; points.len()];
            j.eval_batch(points, &mut m);
            let mut acc = [0.0; 6];
            for (p, m) in points.iter().zip(&m) {
                if p.distance(SPHERE) < RADIUS {
                    continue;
                }
                let omega = curl(*m) * D / U;
                let w = f64::from(omega.length());
                let c = if off_path(*p) < CORRIDOR { 0 } else { 2 };
                acc[c] += w * w;
                acc[c + 1] += 1.0;
                acc[4] = acc[4].max(w);
                if c == 0 {
                    acc[5] += f64::from(omega.x * omega.x);
                }
            }
            acc
        },
        |total, slab| {
            for c in [0, 1, 2, 3, 5] {
                total[c] += slab[c];
            }
            total[4] = total[4].max(slab[4]);
        },
    );
    [
        (total[0] / total[1]).sqrt(),
        (total[2] / total[3]).sqrt(),
        total[4],
        (total[5] / total[1]).sqrt(),
    ]
}

/// Where the cloud went, measured over the cells of the lab-frame `view`.
struct Displaced {
    /// Cloud mass in the view.
    mass: f64,
    /// Share of the mass outside the corridor.
    outside_share: f64,
    /// Share of the mass outside (inside) the corridor displaced more than `D`.
    outside: f64,
    inside: f64,
    /// Mass-weighted mean `|d|` outside the corridor, in `D`.
    mean_outside: f64,
}

/// The displacement `d(x) = x − X(x + U τ x̂)` of the cloud at flight time
/// `tau` over the cells of `view` (lab frame), each component taken to the
/// nearest periodic image of `sim_box`, and the mass shares it moved more
/// than `D` outside and inside the corridor (by current position).
fn displacement_shares(field: &SelmaField, view: &Domain, tau: f32, sim_box: &Domain) -> Displaced {
    let size = sim_box.size();
    let shift = Vec3::X * U * tau;
    let t = fold_slabs(
        view,
        |lab| {
            let body: Vec<Vec3> = lab.iter().map(|&p| p + shift).collect();
            let mut rho = vec![0.0; body.len()];
            let mut from = vec![Vec3::ZERO; body.len()];
            smokelab::field::ScalarField::eval_batch(field, &body, &mut rho);
            field.map_batch(&body, &mut from);
            // [mass outside, moved outside, mass inside, moved inside,
            // mass × |d| outside]
            let mut acc = [0.0; 5];
            for ((p, x), &r) in lab.iter().zip(&from).zip(&rho) {
                let d = *p - *x;
                let d = d - size * (d / size).round();
                let c = if off_path(*p) < CORRIDOR { 2 } else { 0 };
                acc[c] += f64::from(r);
                if d.length() > D {
                    acc[c + 1] += f64::from(r);
                }
                if c == 0 {
                    acc[4] += f64::from(r * d.length() / D);
                }
            }
            acc
        },
        |total, slab| {
            for (t, s) in total.iter_mut().zip(slab) {
                *t += s;
            }
        },
    );
    let mass = t[0] + t[2];
    Displaced {
        mass: mass * f64::from(view.cell_volume()),
        outside_share: t[0] / mass,
        outside: t[1] / t[0],
        inside: t[3] / t[2],
        mean_outside: t[4] / t[0],
    }
}

/// `slab(centres)` for every z-slab of `domain`'s cells, in parallel,
/// folded in slab order by `combine` from zeros (the same bits at any
/// thread count).
fn fold_slabs<const N: usize>(
    domain: &Domain,
    slab: impl Fn(&[Vec3]) -> [f64; N] + Sync,
    combine: impl Fn(&mut [f64; N], &[f64; N]),
) -> [f64; N] {
    let per_slab: Vec<[f64; N]> = (0..domain.dims[2])
        .into_par_iter()
        .map(|k| {
            let mut centres = vec![];
            domain.slab_centers(k, &mut centres);
            slab(&centres)
        })
        .collect();
    let mut total = [0.0; N];
    for s in &per_slab {
        combine(&mut total, s);
    }
    total
}

/// The cloud's extent across the flight path (along y) in body diameters:
/// the span of the cells of `grid` with density above ½.
fn cloud_width(grid: &ScalarGrid, view: &Domain) -> f64 {
    let [nx, ny, nz] = view.dims;
    let rows: Vec<usize> = (0..ny)
        .filter(|&j| (0..nz).any(|k| (0..nx).any(|i| grid.data()[[k, j, i]] > 0.5)))
        .collect();
    match (rows.first(), rows.last()) {
        (Some(a), Some(b)) => f64::from((b - a + 1) as f32 * view.cell / D),
        _ => 0.0,
    }
}
