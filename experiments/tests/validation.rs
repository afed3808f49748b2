//! Experiment V-1 at smoke size (16³ and 24³; Taylor–Green 16 and 32): what
//! its table must show, each bound from the measured value with a margin
//! that a broken scheme or representation would not keep.

mod common;

use std::collections::HashMap;

use common::{num, smoke_experiment, table};

type Row = HashMap<String, String>;

/// The row of `case`, `representation`, `scheme` at `res`.
fn row<'a>(rows: &'a [Row], case: &str, rep: &str, scheme: &str, res: usize) -> &'a Row {
    rows.iter()
        .find(|r| {
            r["case"] == case
                && r["representation"] == rep
                && r["scheme"] == scheme
                && num(r, "res") == res as f64
        })
        .unwrap_or_else(|| panic!("no row {case} {rep} {scheme} {res}"))
}

/// The observed order of `(case, method)` in `orders.csv`.
fn order(orders: &[Row], case: &str, method: &str) -> f64 {
    let r = orders
        .iter()
        .find(|r| r["case"] == case && r["method"] == method)
        .unwrap_or_else(|| panic!("no order for {case} {method}"));
    num(r, "order")
}

#[test]
fn v1_smoke_table_orders_and_published_values() {
    let dir = tempfile::tempdir().unwrap();
    let out = smoke_experiment(dir.path(), "V-1");
    let rows = table(&out.join("data.csv"));
    let orders = table(&out.join("orders.csv"));
    // Two cases × (4 gridded schemes + gridless + SELMA twice) × 2
    // resolutions, Taylor–Green's 4 schemes × 2, and the Re 1600
    // benchmark's 4 schemes without and with confinement.
    assert_eq!(rows.len(), 2 * 7 * 2 + 4 * 2 + 4 * 2, "rows of data.csv");
    for r in &rows {
        assert!(r["seconds"] == "NaN" || num(r, "seconds") >= 0.0);
    }

    for case in ["deformation", "zalesak"] {
        let at = |rep, scheme| row(&rows, case, rep, scheme, 24);
        // Gridless walks the exact velocities back: its only error is the
        // RK2 backtrace's. Measured L1 at 24³: deformation 2.0e-3,
        // zalesak 3.0e-2; every gridded scheme's is above 0.6.
        let gl = num(at("gridless", "-"), "l1");
        let bound = if case == "deformation" { 5e-3 } else { 6e-2 };
        assert!(gl < bound, "{case}: gridless L1 {gl}");
        for scheme in ["sl", "quick", "maccormack", "bfecc"] {
            let g = num(at("gridded", scheme), "l1");
            assert!(g > 10.0 * gl, "{case} {scheme}: L1 {g} vs gridless {gl}");
        }
        // QUICK's flux form conserves mass to f32 rounding (measured
        // ≤ 3e-6); SL, MacCormack and BFECC change it by per cents.
        let q = num(at("gridded", "quick"), "mass_change").abs();
        assert!(q < 2e-5, "{case}: QUICK mass change {q}");
        for scheme in ["sl", "maccormack", "bfecc"] {
            let m = num(at("gridded", scheme), "mass_change").abs();
            assert!(m > 100.0 * q, "{case} {scheme}: mass change {m}");
        }
        // MacCormack keeps sharper values than SL: a lower L∞ error and a
        // higher peak (deformation: L∞ 0.77 vs 0.96, peak 0.43 vs 0.10).
        let (mc, sl) = (at("gridded", "maccormack"), at("gridded", "sl"));
        assert!(num(mc, "linf") < num(sl, "linf"), "{case}: L∞");
        assert!(num(mc, "peak") > 1.2 * num(sl, "peak"), "{case}: peak");
        // SELMA with one map composes the initial field with its map, so it
        // keeps the peak (measured 1.000 in both cases) however wrong the
        // map; re-anchored, the resampling smears it (0.44 and 0.16).
        let (one, again) = (at("selma", "one-map"), at("selma", "re-anchored"));
        assert!(num(one, "peak") > 0.95, "{case}: SELMA one map peak");
        assert!(num(again, "peak") < 0.6, "{case}: SELMA re-anchored peak");
    }
    // In rigid rotation MacCormack's L1 is below SL's (measured 0.93 vs
    // 1.23); in the deformation, where it gains a third of the mass, it
    // is not (1.47 vs 1.47).
    let z = |scheme| num(row(&rows, "zalesak", "gridded", scheme, 24), "l1");
    assert!(z("maccormack") < 0.85 * z("sl"), "zalesak L1");

    // Observed orders from 16³ to 24³. The gridless return error falls as
    // the RK2 backtrace's over a reversed period (C-1: order 3 in Δt at
    // 32³; measured 2.5 here, where the cell samples also refine).
    let gl = order(&orders, "deformation", "gridless");
    assert!((2.0..3.2).contains(&gl), "deformation gridless order {gl}");
    // Taylor–Green: every scheme's step is first order (C-1), measured
    // 0.86–0.93 from 16 to 32.
    for m in [
        "gridded sl",
        "gridded quick",
        "gridded maccormack",
        "gridded bfecc",
    ] {
        let o = order(&orders, "taylor-green", m);
        assert!((0.75..1.1).contains(&o), "taylor-green {m} order {o}");
    }

    // published.csv: every entry names its source and gives a number or
    // says "not found"; our value beside it is a number.
    let mut csv = csv::Reader::from_path(out.join("published.csv")).unwrap();
    let mut n = 0;
    for rec in csv.deserialize::<HashMap<String, String>>() {
        let rec = rec.unwrap();
        n += 1;
        assert!(!rec["source"].is_empty());
        assert!(
            rec["published"] == "not found" || rec["published"].parse::<f64>().is_ok(),
            "{rec:?}"
        );
        assert!(rec["ours"].parse::<f64>().unwrap().is_finite(), "{rec:?}");
        assert!(!rec["status"].is_empty(), "{rec:?}");
    }
    assert!(n >= 3, "{n} published entries");
    // The manifest says where the published values were searched for.
    let manifest: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("manifest.json")).unwrap()).unwrap();
    let searched = manifest["config"]["published_searched"].as_array();
    assert!(
        searched.is_some_and(|s| !s.is_empty()),
        "manifest has no published_searched: {manifest}"
    );
    for f in [
        "table.md",
        "manifest.json",
        "error_deformation.png",
        "error_zalesak.svg",
        "error_taylor_green.png",
    ] {
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // The legend carries the observed order.
    let svg = std::fs::read_to_string(out.join("error_deformation.svg")).unwrap();
    assert!(
        svg.contains("gridless (order 2."),
        "legend without the order"
    );
}
