//! Ray-march throughput on a hot/cold frame (issue 3): the 50³ default
//! scenario stepped 100 times, rendered at 256×256 with the march step equal
//! to the cell size and to a tenth of it (the notes' coarse and fine
//! settings, figs 7.10 and 8.2). Criterion reports elements/s = camera-ray
//! density samples per second (light-grid construction included in the time).
//!
//! `render_gridless_wall` is fig 7.10's worst point (07-10 at `--full`:
//! the 50³ sphere wall's frame-0 row grids composed with all 60 gridless
//! frames, march step cell/10) at 64×48 instead of 640×480, with the
//! empty-space bound (`skip`) and without (`no_skip`): elements/s = march
//! sub-steps per second (the samples without the bound; with it only a
//! share of them is evaluated). The setup prints the sub-step count of the
//! full 640×480 render (taken from the unadvected wall without the bound,
//! which marches the same rays), so the full render's time is extrapolated
//! as that count over the measured rate, and the samples evaluated with and
//! without the bound and the time to build it.
//!
//! Run: `cargo bench --bench render` (a few minutes on 2 cores);
//! `-- render_gridless_wall` for the fig 7.10 point alone.

use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use glam::Vec3;
use smokelab::domain::Domain;
use smokelab::render::camera::Camera;
use smokelab::render::phase::Phase;
use smokelab::render::{look, render, RenderSettings, Scene, Volume};
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::sphere_wall::{
    AdvectedWall, FlowHistory, GriddedWall, SphereWallConfig, Wall,
};
use smokelab_app::run::frames::simulation_scene;

fn bench_render(c: &mut Criterion) {
    let config = HotColdConfig {
        solver: SolverConfig {
            frames: 100,
            ..SolverConfig::default()
        },
        ..Default::default()
    };
    let mut sim = config.build().expect("default config is valid");
    for _ in 0..config.solver.frames {
        sim.step();
    }
    let scene = simulation_scene(&sim);
    let cell = sim.domain().cell;
    let mut group = c.benchmark_group("render_hot_cold_50_256x256");
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(2));
    for (name, step) in [("step_cell", cell), ("step_cell_over_10", cell / 10.0)] {
        let settings = RenderSettings {
            step: Some(step),
            ..RenderSettings::new(look::camera(sim.domain(), 256, 256))
        };
        let probe = render(&scene, &settings).expect("valid render");
        group.throughput(Throughput::Elements(probe.stats.samples));
        group.measurement_time(Duration::from_secs_f64(
            (12.0 * probe.stats.seconds).clamp(3.0, 40.0),
        ));
        group.bench_function(name, |b| {
            b.iter(|| black_box(render(&scene, &settings).expect("valid render")))
        });
    }
    group.finish();
}

/// The sphere wall's rows as 07-10 renders them (experiments'
/// `sphere_wall_series::render_wall`: κ = 4, the key light, the framed
/// slab around the wall), march step `cell / 10`, `width × height`; with
/// the wall's empty-space bound if `skip`.
fn wall_render(
    state: &AdvectedWall,
    d: Domain,
    (width, height): (u32, u32),
    skip: bool,
) -> (Scene, RenderSettings) {
    let volumes = state
        .rows
        .iter()
        .enumerate()
        .map(|(i, r)| Volume {
            occupancy: state.occupancy.clone().filter(|_| skip),
            ..look::smoke(format!("row{i}"), r.clone(), Vec3::ONE, 4.0, look::GLOW)
        })
        .collect();
    let scene = Scene {
        bounds: d,
        volumes,
        lights: vec![look::key_light(&d)],
        phase: Phase::Isotropic,
    };
    let size = d.size();
    let view = Domain::new(
        d.origin + size * Vec3::new(0.05, 0.05, 0.35),
        0.05 * size.x,
        [18, 18, 6],
    )
    .expect("valid view");
    let settings = RenderSettings {
        step: Some(d.cell / 10.0),
        ..RenderSettings::new(Camera::framing(&view, width, height, 0.95))
    };
    (scene, settings)
}

fn bench_gridless_wall(c: &mut Criterion) {
    let config = SphereWallConfig::default();
    let flow = FlowHistory::record(&config).expect("valid config");
    let wall = Wall::new(&config);
    let d = flow.domain;
    let base = GriddedWall::new(&wall, d);
    let plain = AdvectedWall::gridded(&base);
    let (scene, settings) = wall_render(&plain, d, (640, 480), false);
    let full = render(&scene, &settings).expect("valid render").stats;
    eprintln!(
        "render_gridless_wall: 640x480 has {} sub-steps",
        full.samples
    );
    let start = std::time::Instant::now();
    let state = AdvectedWall::gridless(&wall, Some(&base), &flow, config.frames).expect("k = F");
    eprintln!(
        "render_gridless_wall: chain and bound built in {:.2} s, {:.3} of the box flagged",
        start.elapsed().as_secs_f64(),
        state.occupancy.as_ref().map_or(1.0, |o| o.fraction())
    );
    let mut group = c.benchmark_group("render_gridless_wall");
    group.sample_size(10);
    group.warm_up_time(Duration::from_secs(1));
    for (name, skip) in [
        ("k60_cell_over_10_64x48_skip", true),
        ("k60_cell_over_10_64x48_no_skip", false),
    ] {
        let (scene, settings) = wall_render(&state, d, (64, 48), skip);
        let probe = render(&scene, &settings).expect("valid render").stats;
        eprintln!(
            "render_gridless_wall {name}: {} samples, {} skipped, one render {:.2} s",
            probe.samples, probe.skipped, probe.seconds
        );
        group.throughput(Throughput::Elements(probe.samples + probe.skipped));
        group.measurement_time(Duration::from_secs_f64(
            (12.0 * probe.seconds).clamp(3.0, 60.0),
        ));
        group.bench_function(name, |b| {
            b.iter(|| black_box(render(&scene, &settings).expect("valid render")))
        });
    }
    group.finish();
}

criterion_group!(benches, bench_render, bench_gridless_wall);
criterion_main!(benches);
