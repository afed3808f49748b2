//! Bad input found by trying odd values on every subcommand after the
//! issue's list was fixed: each case used to run to exit 0 with a useless or
//! destructive result, or fail with a misleading message. Each now exits 2
//! with one line naming the value and what is valid, and writes nothing.

mod common;

use common::{assert_ok, Sandbox};

/// Run `args` in `sb` and check it exits 2 with one line holding every
/// needle.
fn assert_refused(sb: &Sandbox, args: &[&str], needles: &[&str]) {
    let err = sb.refused(args, needles);
    assert_eq!(
        err.lines().filter(|l| !l.trim().is_empty()).count(),
        1,
        "{args:?}: {err}"
    );
}

/// `render RUN_DIR --out RUN_DIR` replaced the run's manifest with the
/// render's (exit 0), after which `render` and `export` refused the folder
/// as not a run's; a render now names its manifest by frame
/// (`render_0004.json`) and leaves the run's alone. `noise --out RUN_DIR`,
/// which writes a `manifest.json`, is refused.
#[test]
fn writing_over_a_run_folder_manifest_is_refused() {
    let sb = Sandbox::new();
    sb.small_hot_cold_run("run", &["--save-every", "2"]);
    let manifest = std::fs::read(sb.join("run/manifest.json")).unwrap();
    let files = std::fs::read_dir(sb.join("run")).unwrap().count();
    assert_refused(
        &sb,
        &["noise", "value", "--res", "8", "--out", "run", "--quiet"],
        &["smokelab noise", "another --out"],
    );
    assert_eq!(
        std::fs::read(sb.join("run/manifest.json")).unwrap(),
        manifest
    );
    assert_eq!(std::fs::read_dir(sb.join("run")).unwrap().count(), files);
    let in_run = [
        "render", "run", "--image", "16x16", "--out", "run", "--quiet",
    ];
    assert_ok(&sb.run(&in_run), &in_run);
    assert_eq!(
        std::fs::read(sb.join("run/manifest.json")).unwrap(),
        manifest
    );
    assert!(sb.join("run/render_0004.json").is_file());
    let export = ["export", "vdb", "run", "--out", "vdb"];
    assert_ok(&sb.run(&export), &export);
    // A render's own folder may be rendered into again, with --overwrite.
    let render = |extra: &[&str]| {
        let mut args = vec!["render", "run", "--image", "16x16", "--out", "r", "--quiet"];
        args.extend_from_slice(extra);
        sb.run(&args)
    };
    assert!(render(&[]).status.success());
    assert_refused(
        &sb,
        &["render", "run", "--image", "16x16", "--out", "r", "--quiet"],
        &[
            "output folder r holds 3 files an earlier smokelab wrote",
            "--overwrite",
        ],
    );
    assert_ok(&render(&["--overwrite"]), &["render", "--overwrite"]);
}

/// `render --size 1e30` (and 1e-30) was refused as "camera position and
/// look-at coincide": the squared distances overflowed (underflowed) f32.
#[test]
fn render_box_sizes_outside_f32_geometry_are_refused() {
    let sb = Sandbox::new();
    sb.small_hot_cold_run("run", &["--save-every", "2"]);
    for size in ["1e30", "1e-30", "1e10"] {
        assert_refused(
            &sb,
            &["render", "run", "--size", size, "--out", "o", "--quiet"],
            &["world units along its longest axis", "between 1e-3 and 1e9"],
        );
        assert!(!sb.join("o").exists());
    }
    // The ends of the range render.
    for size in ["1e-3", "1e9"] {
        let o = sb.run(&[
            "render",
            "run",
            "--size",
            size,
            "--image",
            "16x16",
            "--out",
            "o",
            "--quiet",
            "--overwrite",
        ]);
        assert!(
            o.status.success(),
            "{size}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
    }
}

/// `noise value --size 1e30` wrote an all-NaN volume and `--size 1e12`
/// speeds of 10³⁶, both with exit 0: f32 positions that far out hold no
/// fraction of a lattice cell.
#[test]
fn noise_sampled_beyond_f32_lattice_reach_is_refused() {
    let sb = Sandbox::new();
    for size in ["1e30", "1e12", "2e6"] {
        assert_refused(
            &sb,
            &[
                "noise", "value", "--res", "8", "--size", size, "--out", "o", "--quiet",
            ],
            &["samples the lattice out to", "at most 1e6"],
        );
    }
    // With octaves the last one's lattice counts: 4 × 2¹⁵ = 131072 is fine,
    // 40 × 2¹⁵ = 1.3e6 is not.
    assert_refused(
        &sb,
        &[
            "noise",
            "value",
            "--res",
            "8",
            "--size",
            "40",
            "--octaves",
            "16",
            "--out",
            "o",
            "--quiet",
        ],
        &["1.311e6 cells"],
    );
    assert!(!sb.join("o").exists());
    sb.ok(&[
        "noise",
        "value",
        "--res",
        "8",
        "--octaves",
        "16",
        "--out",
        "o",
        "--quiet",
    ]);
}

/// `experiment --list 03-2` listed and ignored the id (exit 0).
#[test]
fn experiment_list_with_an_id_is_refused() {
    let sb = Sandbox::new();
    for args in [
        &["experiment", "--list", "03-2"][..],
        &["experiment", "03-2", "--list"],
        &["experiment", "--list", "--out", "o"],
    ] {
        assert_refused(
            &sb,
            args,
            &["cannot be used with", "`smokelab experiment --help`"],
        );
    }
    assert!(!sb.join("o").exists());
}

/// clap's own errors (an unknown or misspelt option, a missing or
/// conflicting argument, an unknown subcommand) used to be 3–6 lines of
/// error, tips, usage and a pointer to `--help`; now one line with clap's
/// tip and the command whose `--help` lists the options. Help and the
/// version still print in full, with exit 0.
#[test]
fn clap_errors_are_one_line() {
    let sb = Sandbox::new();
    for (args, needles) in [
        (
            &["run", "--fram", "5"][..],
            &["'--fram'", "'--frames'", "`smokelab run --help`"][..],
        ),
        (
            &["experiment", "06-1", "--smoke", "--full"],
            &["--full", "--smoke", "`smokelab experiment --help`"],
        ),
        (&["rnu"], &["'rnu'", "`smokelab --help`"]),
        (
            &["render", "r"],
            &["not provided: --out <OUT>", "`smokelab render --help`"],
        ),
        (
            &["run", "--density", "grid"],
            &[
                "'grid'",
                "possible values: gridded, gridless, selma",
                "similar value exists: 'gridded'",
                "`smokelab run --help`",
            ],
        ),
        (
            &["sweep", "status"],
            &["not provided: <DIR>", "`smokelab sweep status --help`"],
        ),
    ] {
        assert_refused(&sb, args, needles);
    }
    for args in [&["--help"][..], &["run", "--help"], &["--version"]] {
        let o = sb.ok(args);
        assert!(!o.stdout.is_empty(), "{args:?}");
    }
    let help = String::from_utf8(sb.ok(&["--help"]).stdout).unwrap();
    assert!(
        help.contains("Without a command, `smokelab` runs hot/cold"),
        "{help}"
    );
    // No rustdoc link syntax (``[`name`]``) leaks from doc comments into
    // any command's help.
    let commands: Vec<String> = help
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| !l.trim().is_empty())
        .filter_map(|l| l.split_whitespace().next().map(str::to_string))
        .filter(|c| c != "help")
        .collect();
    assert!(commands.len() >= 5, "{help}");
    for command in std::iter::once(None).chain(commands.iter().map(Some)) {
        let args: Vec<&str> = command
            .map(String::as_str)
            .into_iter()
            .chain(["--help"])
            .collect();
        let text = String::from_utf8(sb.ok(&args).stdout).unwrap();
        assert!(
            !text.contains("[`"),
            "{args:?} shows rustdoc syntax:\n{text}"
        );
    }
    assert_eq!(std::fs::read_dir(sb.path()).unwrap().count(), 0);
}

/// `--selma-remap` is SELMA's, as `--map-res` is: given to another density
/// mode it is refused (it used to be accepted silently), naming the mode.
#[test]
fn selma_remap_without_selma_is_refused() {
    let sb = Sandbox::new();
    for (mode, remap) in [
        ("gridded", ["--selma-remap", "2"]),
        ("gridless", ["--selma-remap", "0.5"]),
        ("gridded", ["--set", "selma_remap=3"]),
    ] {
        let args = [
            &[
                "run",
                "--res",
                "10",
                "--frames",
                "1",
                "--density",
                mode,
                "--out",
                "o",
            ][..],
            &remap[..],
        ]
        .concat();
        let value = remap[1].trim_start_matches("selma_remap=");
        let needle = format!("selma_remap {value} is only used by --density selma");
        assert_refused(&sb, &args, &[needle.as_str(), mode]);
    }
    assert!(!sb.join("o").exists());
    sb.ok(&[
        "run",
        "--res",
        "10",
        "--frames",
        "1",
        "--density",
        "selma",
        "--selma-remap",
        "2",
        "--quiet",
        "--out",
        "o",
    ]);
}

/// `--initial` holding NaN or ∞ ran to a "complete" run of NaN, and an
/// f64 `.npy` whose header claims 40 GB aborted (exit 134) allocating it:
/// both are refused with exit 2 naming the file (and the first bad index),
/// before anything is written.
#[test]
fn initial_volumes_that_are_not_finite_or_not_whole_are_refused() {
    let sb = Sandbox::new();
    let mut bad = ndarray::Array3::<f64>::from_elem((8, 8, 8), 0.5);
    bad[[2, 3, 4]] = f64::NAN;
    ndarray_npy::write_npy(sb.join("nan.npy"), &bad).unwrap();
    bad[[2, 3, 4]] = 0.5;
    bad[[7, 0, 1]] = f64::INFINITY;
    ndarray_npy::write_npy(sb.join("inf.npy"), &bad.mapv(|v| v as f32)).unwrap();
    let mut dict =
        "{'descr': '<f8', 'fortran_order': False, 'shape': (2000, 2000, 1250), }".to_string();
    while !(11 + dict.len()).is_multiple_of(64) {
        dict.push(' ');
    }
    dict.push('\n');
    let mut big = b"\x93NUMPY\x01\x00".to_vec();
    big.extend((dict.len() as u16).to_le_bytes());
    big.extend(dict.bytes());
    big.extend([0u8; 64]);
    std::fs::write(sb.join("big.npy"), &big).unwrap();
    let run = |file: &'static str| {
        [
            "run",
            "deformation",
            "--res",
            "8",
            "--frames",
            "1",
            "--initial",
            file,
            "--quiet",
            "--out",
            "o",
        ]
    };
    assert_refused(
        &sb,
        &run("nan.npy"),
        &[
            "initial nan.npy holds NaN at (z, y, x) = (2, 3, 4)",
            "finite",
        ],
    );
    assert_refused(
        &sb,
        &run("inf.npy"),
        &["initial inf.npy holds inf at (z, y, x) = (7, 0, 1)"],
    );
    assert_refused(
        &sb,
        &run("big.npy"),
        &[
            "big.npy",
            "declares shape [2000, 2000, 1250] (40000000000 bytes of data)",
        ],
    );
    assert!(!sb.join("o").exists());
}

/// A whole-number flag given a value outside its type said "invalid digit
/// found in string" (`--frames -5`) or panicked (`--seed
/// 99999999999999999999`), over several lines: now one line naming the
/// flag, the value and the range, exit 2.
#[test]
fn whole_number_flags_out_of_range_name_their_range() {
    let sb = Sandbox::new();
    let u64_range = "expected a whole number from 0 to 18446744073709551615";
    let cases: [(&[&str], String); 4] = [
        (
            &["run", "hot-cold", "--seed", "99999999999999999999"],
            format!("invalid value '99999999999999999999' for '--seed <SEED>': {u64_range}"),
        ),
        (
            &["run", "hot-cold", "--frames", "-5"],
            format!("invalid value '-5' for '--frames <FRAMES>': {u64_range}"),
        ),
        (
            &["noise", "value", "--seed", "18446744073709551616"],
            format!("'18446744073709551616' for '--seed <SEED>': {u64_range}"),
        ),
        (
            &["script", "x.rhai", "--max-operations", "0"],
            "'0' for '--max-operations <N>'".to_string(),
        ),
    ];
    for (args, needle) in cases {
        let err = sb.refused(args, &[&needle]);
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(
            !err.contains("invalid digit") && !err.contains("usize"),
            "{err}"
        );
    }
    assert!(!sb.join("runs").exists());
}
