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
    for kind in ["smooth-sim", "spectral", "curl-fd-2d"] {
        let out = dir.path().join(kind);
        let out_s = out.to_str().unwrap();
        noise_cmd(&[
            kind,
            "--res",
            "8",
            "--octaves",
            "2",
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
        let exp = smokelab_app::registry::find(id).unwrap();
        let out = dir.path().join(id);
        let ctx = smokelab_app::registry::Context {
            out: out.clone(),
            size: smokelab_app::registry::Size::Smoke,
            progress: false,
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
    // Value noise diverges; smooth simulation noise does not (to O(h²)).
    assert!(
        ratio("value-2d") > 0.1 && ratio("smooth-sim-2d") < 1e-3,
        "{csv}"
    );
}
