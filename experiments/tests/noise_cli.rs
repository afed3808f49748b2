//! The `smokelab` command line end to end (moved from `tests/noise.rs`).

use clap::Parser;
use smokelab::error::InputError;
use smokelab_app::cli::{execute, Cli};

fn noise_cmd(args: &[&str]) -> anyhow::Result<()> {
    let mut argv = vec!["smokelab", "noise"];
    argv.extend_from_slice(args);
    execute(Cli::try_parse_from(argv).expect("arguments parse"))
}

#[test]
fn noise_command_writes_volume_and_slice() {
    let dir = tempfile::tempdir().unwrap();
    for (kind, octaves) in [("smooth-sim", "2"), ("spectral", "1"), ("curl-fd-2d", "2")] {
        let out = dir.path().join(kind);
        let out_s = out.to_str().unwrap();
        noise_cmd(&[
            kind,
            "--res",
            "8",
            "--octaves",
            octaves,
            "--seed",
            "3",
            "--out",
            out_s,
        ])
        .unwrap();
        let vol: ndarray::Array4<f32> = ndarray_npy::read_npy(out.join("noise.npy")).unwrap();
        assert_eq!(vol.dim(), (8, 8, 8, 3));
        assert!(vol.iter().all(|v| v.is_finite()) && vol.iter().any(|&v| v != 0.0));
        let img = image::open(out.join("slice.png")).unwrap();
        assert_eq!((img.width(), img.height()), (512, 512));
        assert!(out.join("manifest.json").is_file());
    }
}

/// RMS divergence over RMS |∇u| of a written `(nz, ny, nx, 3)` grid over
/// its interior, by two discrete operators: `cube`, the flux of the grid's
/// trilinear interpolant through each cube between 8 samples (face means of
/// 4 corners, the operator the spectral tile is projected with); `central`,
/// central differences at each interior sample.
fn relative_divergence(vol: &ndarray::Array4<f32>) -> (f64, f64) {
    let (nz, ny, nx, _) = vol.dim();
    let at = |x: usize, y: usize, z: usize, c: usize| vol[[z, y, x, c]] as f64;
    // ∂u_c/∂x_a on the cube with lower corner (x, y, z): mean over the 4
    // edges along axis a.
    let cube_d = |x: usize, y: usize, z: usize, c: usize, a: usize| {
        let mut s = 0.0;
        for i in 0..2 {
            for j in 0..2 {
                let (lo, hi) = match a {
                    0 => ([x, y + i, z + j], [x + 1, y + i, z + j]),
                    1 => ([x + i, y, z + j], [x + i, y + 1, z + j]),
                    _ => ([x + i, y + j, z], [x + i, y + j, z + 1]),
                };
                s += at(hi[0], hi[1], hi[2], c) - at(lo[0], lo[1], lo[2], c);
            }
        }
        0.25 * s
    };
    let central_d = |x: usize, y: usize, z: usize, c: usize, a: usize| {
        let (lo, hi) = match a {
            0 => ([x - 1, y, z], [x + 1, y, z]),
            1 => ([x, y - 1, z], [x, y + 1, z]),
            _ => ([x, y, z - 1], [x, y, z + 1]),
        };
        0.5 * (at(hi[0], hi[1], hi[2], c) - at(lo[0], lo[1], lo[2], c))
    };
    let ratio = |d: &dyn Fn(usize, usize, usize, usize, usize) -> f64, from: usize, to: usize| {
        let (mut div, mut grad) = (0.0, 0.0);
        for z in from..nz - to {
            for y in from..ny - to {
                for x in from..nx - to {
                    div += (0..3).map(|a| d(x, y, z, a, a)).sum::<f64>().powi(2);
                    for c in 0..3 {
                        for a in 0..3 {
                            grad += d(x, y, z, c, a).powi(2);
                        }
                    }
                }
            }
        }
        (div / grad).sqrt()
    };
    (ratio(&cube_d, 0, 1), ratio(&central_d, 1, 1))
}

/// The exported spectral noise is divergence-free on the grid it is written
/// to (its tile is that grid); value noise, the control, is not.
#[test]
fn exported_spectral_noise_is_divergence_free_on_its_grid() {
    let dir = tempfile::tempdir().unwrap();
    let export = |args: &[&str]| {
        let out = dir.path().join(args.join("_"));
        let mut argv = args.to_vec();
        argv.extend_from_slice(&["--quiet", "--out", out.to_str().unwrap()]);
        noise_cmd(&argv).unwrap();
        let vol: ndarray::Array4<f32> = ndarray_npy::read_npy(out.join("noise.npy")).unwrap();
        relative_divergence(&vol)
    };
    let mut central_all = vec![];
    // The case (48³ from a 32-sample reference tile), a finer grid
    // over a smaller cube, a Kolmogorov spectrum, and a time between frames.
    for args in [
        &["spectral", "--res", "48"][..],
        &["spectral", "--res", "48", "--size", "3"],
        &[
            "spectral",
            "--res",
            "40",
            "--spectrum",
            "kolmogorov",
            "--b",
            "0.05",
        ],
        &["spectral", "--res", "32", "--time", "2.5", "--frames", "4"],
    ] {
        let (cube, central) = export(args);
        println!("{args:?}: cube flux {cube:.2e}, central {central:.2e} of |∇u|");
        // Measured: 1.6e-7 … 4.2e-7 (f32 round-off). Before, the 48³ grid
        // resampled from the 32³ tile: 4.1e-2.
        assert!(cube < 1e-5, "{args:?}: cube-flux divergence {cube:e}");
        central_all.push(central);
    }
    // Central differences are not the operator the tile is projected with:
    // their symbol differs from the cube's at second order in k, so they
    // measure 1.7e-2 on the case (3.3e-2 before) and 8.8e-2 on the
    // Kolmogorov spectrum, whose energy sits at high k.
    assert!(central_all[0] < 0.025, "central {central_all:?}");
    // Control: value noise is divergent under both operators.
    let (cube, central) = export(&["value", "--res", "32"]);
    assert!(
        cube > 0.1 && central > 0.1,
        "value noise: {cube}, {central}"
    );
}

#[test]
fn noise_command_rejects_bad_input_and_writes_nothing() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("never");
    let out_s = out.to_str().unwrap();
    let cases: &[&[&str]] = &[
        &["value", "--res", "2"],
        &["value", "--size", "-1"],
        &["value", "--octaves", "0"],
        &["value", "--lacunarity", "1"],
        &["value", "--gain", "-0.5"],
        &["value", "--dimension", "nan"],
        &["curl", "--time", "1.0"],
        &["spectral", "--time", "1.0", "--frames", "1"],
        &["spectral", "--tile", "7"],
        &["spectral", "--res", "45"],
        &["spectral", "--res", "48", "--size", "5"],
        &["spectral", "--octaves", "2"],
        &["spectral", "--b", "0.7"],
        &["curl-fd", "--fd-step", "0"],
    ];
    for args in cases {
        let mut argv = args.to_vec();
        argv.extend_from_slice(&["--out", out_s]);
        let err = noise_cmd(&argv).expect_err("bad input accepted");
        let msg = err.to_string();
        assert!(
            err.downcast_ref::<InputError>().is_some(),
            "{args:?}: {msg}"
        );
        assert!(!out.exists(), "{args:?} wrote {out_s}");
        println!("{args:?}: {msg}");
    }
}

/// The noise experiments run end to end at smoke size.
#[test]
fn noise_experiments_run_at_smoke_size() {
    let dir = tempfile::tempdir().unwrap();
    for id in ["N-3", "N-4", "07-2"] {
        let exp = smokelab_app::experiment::registry::find(id).unwrap();
        let out = dir.path().join(id);
        let ctx = smokelab_app::experiment::kit::Context {
            out: out.clone(),
            size: smokelab_app::experiment::kit::Size::Smoke,
            progress: false,
            peers: None,
        };
        (exp.run)(&ctx).unwrap();
        for file in ["data.csv", "manifest.json"] {
            assert!(out.join(file).is_file(), "{id}: no {file}");
        }
    }
    let csv = std::fs::read_to_string(dir.path().join("N-3/data.csv")).unwrap();
    let ratio = |kind: &str| -> f64 {
        let line = csv
            .lines()
            .find(|l| l.starts_with(&format!("{kind},")))
            .unwrap();
        line.rsplit(',').next().unwrap().parse().unwrap()
    };
    // The cost of one evaluation (costs.csv: kind, ns, ratio to fast) is a
    // timing, so it is only checked for being one: every kind present with
    // a positive, finite time. (Its ratios — measured at default size:
    // value 1.60–1.64× fast in 3D, 1.93–1.94× in 2D, smooth 1.03–1.06× —
    // fell to 1.15× for value-2d on a machine loaded 3× over its cores, so
    // they are reported by the experiment, not asserted here.)
    let costs = std::fs::read_to_string(dir.path().join("N-3/costs.csv")).unwrap();
    for kind in [
        "fast-sim",
        "value",
        "smooth-sim",
        "fast-sim-2d",
        "value-2d",
        "smooth-sim-2d",
    ] {
        let line = costs.lines().find(|l| l.starts_with(&format!("{kind},")));
        let ns: f64 = line
            .unwrap_or_else(|| panic!("no {kind} in {costs}"))
            .split(',')
            .nth(1)
            .unwrap()
            .parse()
            .unwrap();
        assert!(ns.is_finite() && ns > 0.0, "{costs}");
    }
    // Value noise diverges; smooth simulation noise does not (to O(h²)).
    assert!(
        ratio("value-2d") > 0.1 && ratio("smooth-sim-2d") < 1e-3,
        "{csv}"
    );
}
