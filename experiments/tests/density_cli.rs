//! The `smokelab` command line end to end (moved from `tests/density.rs`).

mod common;

use common::Sandbox;
use smokelab::density::DensityMode;
use smokelab::scenario::hot_cold::HotColdConfig;
use smokelab::scenario::Scenario;
use smokelab::scenario::SolverConfig;

#[test]
fn a_gridless_run_too_big_for_memory_is_refused_with_its_estimate() {
    let sb = Sandbox::new();
    // 64³ × 10⁶ steps: 12 MB per stored velocity grid, about 11 TiB in all.
    let err = sb.refused(
        &[
            "run",
            "hot-cold",
            "--density",
            "gridless",
            "--res",
            "64",
            "--frames",
            "1000000",
            "--out",
            "out",
        ],
        &["--force"],
    );
    assert!(
        err.contains("GiB") && err.contains("one velocity grid per step"),
        "{err}"
    );
    assert!(!sb.join("out").exists());
    // The same run gridded fits.
    let cfg = HotColdConfig {
        solver: SolverConfig {
            res: 64,
            frames: 1_000_000,
            ..SolverConfig::default()
        },
        ..Default::default()
    };
    assert!(cfg.validate().is_ok());
    // Options that make no sense are refused too.
    for (args, needle) in [
        (
            &["run", "hot-cold", "--density", "gridded", "--map-res", "32"][..],
            "map_res 32",
        ),
        (
            &["run", "hot-cold", "--density", "selma", "--map-res", "2"][..],
            "map-res 2",
        ),
        (
            &["run", "hot-cold", "--metrics-every", "0"][..],
            "metrics_every is 0",
        ),
        (
            &["run", "hot-cold", "--diagnostics-every", "0"][..],
            "diagnostics_every is 0",
        ),
        (
            &[
                "run",
                "hot-cold",
                "--density",
                "selma",
                "--selma-remap",
                "-1",
            ][..],
            "selma_remap is -1",
        ),
        (&["run", "hot-cold", "--density", "fluffy"][..], "fluffy"),
    ] {
        let mut a = args.to_vec();
        a.extend(["--out", "out"]);
        sb.refused(&a, &[needle]);
        assert!(!sb.join("out").exists());
    }
}

#[test]
fn density_experiments_run_at_smoke_size_and_write_their_figures() {
    let sb = Sandbox::new();
    for (id, figures) in [
        (
            "06-3",
            &["sequence.png", "frame.png", "frame_render.png"][..],
        ),
        (
            "06-5",
            &["side_by_side.png", "side_by_side_render.png", "final.png"][..],
        ),
    ] {
        let out = sb.join(id);
        sb.ok(&["experiment", id, "--smoke", "--quiet", "--out", id]);
        let common = [
            "metrics.png",
            "metrics_mass.svg",
            "metrics_symmetry.png",
            "metrics_memory.svg",
            "summary.csv",
            "manifest.json",
            "gridless/metrics.csv",
        ];
        for f in figures.iter().chain(&common) {
            assert!(out.join(f).is_file(), "{id}: no {f}");
        }
        let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
        for mode in DensityMode::ALL.map(DensityMode::name) {
            assert!(
                summary.lines().any(|l| l.starts_with(mode)),
                "{id}: {summary}"
            );
        }
        // The MacCormack gridded baseline has its row, every number finite,
        // and gridless's sub-grid share dwarfs both gridded schemes' (at
        // smoke size ×50 over each; ×10 asserted).
        let header: Vec<&str> = summary.lines().next().unwrap().split(',').collect();
        let row = |mode: &str| -> Vec<f64> {
            let line = summary
                .lines()
                .find(|l| l.split(',').next() == Some(mode))
                .unwrap_or_else(|| panic!("{id}: no {mode} row in {summary}"));
            line.split(',')
                .skip(1)
                .map(|v| v.parse().unwrap())
                .collect()
        };
        let subgrid = header.iter().position(|&c| c == "hot_subgrid").unwrap() - 1;
        let mc = row("gridded-maccormack");
        assert!(mc.iter().all(|v| v.is_finite()), "{id}: {summary}");
        let gridless = row("gridless")[subgrid];
        for mode in ["gridded", "gridded-maccormack"] {
            assert!(
                gridless > 10.0 * row(mode)[subgrid],
                "{id}: sub-grid share gridless {gridless} against {mode}: {summary}"
            );
        }
    }
}
