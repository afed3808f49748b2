//! Ray-march throughput on a hot/cold frame (issue 3): the 50³ default
//! scenario stepped 100 times, rendered at 256×256 with the march step equal
//! to the cell size and to a tenth of it (the notes' coarse and fine
//! settings, figs 7.10 and 8.2). Criterion reports elements/s = camera-ray
//! density samples per second (light-grid construction included in the time).
//!
//! Run: `cargo bench --bench render` (about a minute on 2 cores).

use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;
use std::hint::black_box;
use std::time::Duration;

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use smokelab::render::{look, render, RenderSettings};
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab_app::frames::simulation_scene;

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

criterion_group!(benches, bench_render);
criterion_main!(benches);
