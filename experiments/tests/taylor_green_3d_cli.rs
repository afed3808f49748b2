//! `smokelab run taylor-green-3d`: the Re = 1600 benchmark's defaults and
//! its `energy.csv`, with and without `--confinement`, and the refusals.

mod common;

use common::{num, table, Sandbox};

/// A short run at 16³ writes `energy.csv` at every saved frame: the
/// energy below E(0) = 1/8 and falling without confinement, the viscous
/// dissipation 2νΩ with ν defaulting to 1/1600; confinement keeps more of
/// the energy; a negative
/// confinement and a closed box are refused with exit 2 naming the value.
#[test]
fn the_benchmark_logs_its_energy_and_enstrophy() {
    let sb = Sandbox::new();
    let d = sb.path();
    let energy_at_end = |eps: &str, out: &str| {
        sb.ok(&[
            "run",
            "taylor-green-3d",
            "--res",
            "16",
            "--dt",
            "0.2",
            "--frames",
            "10",
            "--save-every",
            "5",
            "--confinement",
            eps,
            "--quiet",
            "--out",
            out,
        ]);
        let rows = table(&d.join(out).join("energy.csv"));
        assert_eq!(rows.len(), 2, "rows at frames 5 and 10");
        if eps == "0" {
            // Confinement adds energy (at ε = 0.5, 16³: 0.134 → 0.138).
            assert!(num(&rows[1], "energy") < num(&rows[0], "energy"));
        }
        for r in &rows {
            let ratio = num(r, "viscous_dissipation") / num(r, "enstrophy");
            assert!((ratio - 2.0 / 1600.0).abs() < 1e-9, "2ν: {ratio}");
        }
        num(&rows[1], "energy")
    };
    let plain = energy_at_end("0", "plain");
    let confined = energy_at_end("0.5", "confined");
    assert!(plain < 0.125 && confined > plain, "{plain} {confined}");
    let printed =
        String::from_utf8(sb.ok(&["run", "taylor-green-3d", "--print-config"]).stdout).unwrap();
    assert!(printed.contains("nu = 0.000625"), "{printed}");
    assert!(printed.contains("confinement = 0.0"), "{printed}");
    for (flag, value, named) in [
        ("--box", "closed", "box periodic"),
        ("--confinement", "-1", "confinement is -1"),
    ] {
        let err = sb.fails(
            &[
                "run",
                "taylor-green-3d",
                flag,
                value,
                "--quiet",
                "--out",
                "bad",
            ],
            2,
        );
        assert!(err.contains(named), "{flag} {value}: {err}");
    }
}
