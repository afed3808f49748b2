//! Experiment P-1 (the performance table) at smoke size, and its
//! `--peers` flag's input errors. Timings are not asserted (the machine is
//! shared); what is asserted is what the run must produce whatever the load:
//! every resolution measured, the 1- and 2-thread fields bitwise equal (the
//! experiment fails otherwise, at 32³ among others), the peer columns absent
//! without `--peers`, and the plots and manifest written.

mod common;

use common::{num, smoke_experiment, table, Sandbox};

#[test]
fn p1_smoke_measures_every_resolution_and_threads_agree_bitwise() {
    let sb = Sandbox::new();
    let out = smoke_experiment(sb.path(), "P-1");
    let rows = table(&out.join("data.csv"));
    let res: Vec<f64> = rows.iter().map(|r| num(r, "res")).collect();
    assert_eq!(res, [16.0, 32.0]);
    for r in &rows {
        assert_eq!(num(r, "bitwise_equal"), 1.0);
        assert_eq!(num(r, "cells"), num(r, "res").powi(3));
        for col in [
            "step_ms",
            "step_1thread_ms",
            "step_euler_ms",
            "advect_ms",
            "inject_ms",
            "project_ms",
        ] {
            assert!(num(r, col) > 0.0, "{col} = {}", num(r, col));
        }
        // The floor and the ratio are what the columns say they are.
        let floor = num(r, "fft_pair_f32_ms").min(num(r, "fft_pair_solver_f64_ms"))
            + num(r, "bandwidth_ms");
        assert!((num(r, "floor_ms") - floor).abs() <= 1e-9 * floor);
        let ratio = num(r, "step_ms") / floor;
        assert!((num(r, "step_over_floor") - ratio).abs() <= 1e-9 * ratio);
        assert!(!r.contains_key("peer_ms"), "peer columns without --peers");
    }
    for f in ["time", "threads", "stages"] {
        for ext in ["png", "svg"] {
            let p = out.join(format!("{f}.{ext}"));
            assert!(
                std::fs::metadata(&p).unwrap().len() > 1000,
                "{}",
                p.display()
            );
        }
    }
    let m = common::manifest(&out);
    assert_eq!(m["extra"]["bitwise_equal_1_vs_2_threads"], true);
    assert!(m["extra"]["peers"].as_str().unwrap().starts_with("absent"));
    assert!(m["extra"]["load_before"].is_string() && m["extra"]["load_after"].is_string());
    let md = std::fs::read_to_string(out.join("table.md")).unwrap();
    assert!(md.contains("| 16³ |") && md.contains("| 32³ |"), "{md}");
    // Every kernel width this CPU has, at every size, the default among
    // them; the widths' fields agreed to the bit (or the run failed).
    let isas: Vec<String> = smokelab::simd::Isa::available()
        .iter()
        .map(|i| i.to_string())
        .collect();
    let widths = table(&out.join("widths.csv"));
    assert_eq!(widths.len(), 2 * isas.len());
    for (w, (res, isa)) in widths.iter().zip(
        [16.0, 32.0]
            .iter()
            .flat_map(|r| isas.iter().map(move |i| (r, i))),
    ) {
        assert_eq!((num(w, "res"), &w["kernel"]), (*res, isa));
        for col in ["step_ms", "advect_ms", "step_euler_ms", "advect_euler_ms"] {
            assert!(num(w, col) > 0.0, "{isa} {col}");
        }
        assert!(md.contains(&format!("| {res}³ | {isa} |")), "{md}");
    }
    assert_eq!(m["extra"]["simd"]["bitwise_equal_across_widths"], true);
    assert_eq!(m["extra"]["simd"]["default"], m["machine"]["simd"]);
    assert!(isas.contains(&m["machine"]["simd"].as_str().unwrap().to_string()));
}

#[test]
fn p1_refuses_a_bad_peers_python_with_exit_2_and_writes_nothing() {
    let sb = Sandbox::new();
    for (id, python) in [
        ("P-1", "/nonexistent/python"),
        // A program that runs but is not a Python with the peers' modules.
        ("P-1", "/bin/false"),
        // --peers belongs to P-1 only.
        ("C-1", "/bin/false"),
    ] {
        let args = ["experiment", id, "--smoke", "--quiet", "--out", "o"];
        sb.refused(&[&args[..], &["--peers", python]].concat(), &["--peers"]);
        assert!(!sb.join("o").exists());
    }
}
