//! The command line: bad input exits 2 with a clear line and writes nothing.

mod common;

use clap::ValueEnum;
use common::Sandbox;
use smokelab::scenario::ScenarioKind;

fn assert_rejected(args: &[&str], needle: &str) {
    let sb = Sandbox::new();
    std::fs::write(sb.join("bad.toml"), "res = \"fifty\"\n").unwrap();
    std::fs::write(sb.join("unknown.toml"), "res = 8\nresolution = 8\n").unwrap();
    let mut full: Vec<&str> = args.to_vec();
    full.extend(["--out", "out"]);
    let err = sb.fails(&full, 2);
    assert!(
        err.contains(needle),
        "{args:?}: stderr {err:?} does not mention {needle:?}"
    );
    assert_eq!(
        err.lines().filter(|l| !l.trim().is_empty()).count(),
        1,
        "{args:?}: not one line: {err}"
    );
    assert!(
        !sb.join("out").exists(),
        "{args:?}: output folder was created"
    );
    assert!(
        !sb.join("runs").exists(),
        "{args:?}: a run folder was created"
    );
}

#[test]
fn bad_inputs_exit_2_and_write_nothing() {
    assert_rejected(&["run", "hot-cold", "--res", "3"], "resolution 3");
    assert_rejected(&["run", "hot-cold", "--res", "5000"], "GiB");
    assert_rejected(&["run", "hot-cold", "--dt", "0"], "dt is 0");
    assert_rejected(&["run", "hot-cold", "--dt", "-0.1"], "dt is -0.1");
    assert_rejected(&["run", "hot-cold", "--dt", "nan"], "dt is NaN");
    assert_rejected(&["run", "hot-cold", "--dt", "inf"], "dt is inf");
    assert_rejected(&["run", "hot-cold", "--frames", "-3"], "-3");
    assert_rejected(&["run", "warm-tepid"], "warm-tepid");
    assert_rejected(
        &["run", "hot-cold", "--config", "missing.toml"],
        "missing.toml",
    );
    assert_rejected(&["run", "hot-cold", "--config", "bad.toml"], "bad.toml");
    assert_rejected(
        &["run", "hot-cold", "--config", "unknown.toml"],
        "resolution",
    );
    assert_rejected(&["experiment", "99-9"], "99-9");
    // Found by trying bad input on every subcommand (each used to hang,
    // panic, exit 1 or run silently):
    assert_rejected(
        &["run", "hot-cold", "--threads", "100000"],
        "threads is 100000",
    );
    assert_rejected(
        &["run", "slab-box", "--res", "2097152"],
        "2097152 × 2097152",
    );
    assert_rejected(
        &["run", "hot-cold", "--res", "8", "--radius", "0.01"],
        "covers no cell",
    );
    assert_rejected(&["run", "hot-cold", "--config", "."], "not a regular file");
    assert_rejected(
        &["run", "hot-cold", "--set", "wall=1"],
        "'wall' (--set) applies to slab-box only",
    );
    assert_rejected(&["run", "hot-cold", "--set", "res"], "KEY=VALUE");
    assert_rejected(
        &["run", "hot-cold", "--pressure-precision", "f16"],
        "f32, f64",
    );
    assert_rejected(
        &["run", "hot-cold", "--set", "pressure_precision=half"],
        "half",
    );
    assert_rejected(
        &["noise", "value", "--octaves", "16", "--lacunarity", "1000"],
        "frequency",
    );
}

/// An output path that is a file, or inside one, is refused with exit 2
/// (it used to fail with exit 1 after the run had started).
#[test]
fn output_paths_inside_files_are_refused() {
    for out in ["/dev/null", "/dev/null/run"] {
        let sb = Sandbox::new();
        let err = sb.fails(&["run", "hot-cold", "--res", "8", "--out", out], 2);
        assert!(err.contains("give a folder"), "{out}: {err}");
    }
}

/// `smokelab run <scenario> --print-config`, for every scenario, prints a
/// TOML file that, given back as `--config`, resolves to the same
/// configuration.
#[test]
fn print_config_round_trips() {
    let sb = Sandbox::new();
    for kind in ScenarioKind::ALL {
        let name = kind.to_possible_value().expect("not hidden");
        let scenario = name.get_name();
        let mut args = vec!["run", scenario, "--res", "24"];
        // A key of one scenario only, so that the file holds it too.
        if kind == ScenarioKind::SlabBox {
            args.extend(["--set", "wall=0.9"]);
        }
        args.push("--print-config");
        let o = sb.ok(&args);
        let printed = String::from_utf8(o.stdout).unwrap();
        assert!(printed.contains("res = 24"), "{printed}");
        // Every key shows, the unset ones (threads…) as comments.
        let listed =
            String::from_utf8(sb.run(&["run", scenario, "--set", "nokey=1"]).stderr).unwrap();
        let keys = listed.split(" has the keys ").nth(1).unwrap().trim();
        let lines = format!("\n{printed}");
        for key in keys.split(", ") {
            assert!(
                lines.contains(&format!("\n{key} = ")) || lines.contains(&format!("\n# {key} =\n")),
                "{scenario}: {key} missing from\n{printed}"
            );
        }
        assert!(printed.contains("\n# threads =\n"), "{printed}");
        std::fs::write(sb.join("c.toml"), &printed).unwrap();
        let again = sb.run(&["run", scenario, "--config", "c.toml", "--print-config"]);
        assert_eq!(
            String::from_utf8(again.stdout).unwrap(),
            printed,
            "{scenario}"
        );
    }
}

/// The configuration `smokelab run hot-cold --config c.toml ARGS
/// --print-config` resolves to, in `sb`.
fn printed_config(sb: &Sandbox, args: &[&str]) -> toml::Table {
    let mut full = vec!["run", "hot-cold", "--config", "c.toml"];
    full.extend_from_slice(args);
    full.push("--print-config");
    let o = sb.ok(&full);
    toml::from_str(&String::from_utf8(o.stdout).unwrap()).unwrap()
}

/// Each solver flag overrides its key over a `--config` file and changes
/// nothing else, one flag per kind of value (usize, u64, f32, enum, a
/// renamed key, an optional key, both switches); a switch not given leaves
/// the file's value.
#[test]
fn solver_flags_override_their_keys_and_only_them() {
    use toml::Value::{Boolean, Float, Integer, String as Text};
    let sb = Sandbox::new();
    let file = "res = 30\ndt = 0.1\nadvection = \"maccormack\"\nseed = 3\n";
    std::fs::write(sb.join("c.toml"), file).unwrap();
    let base = printed_config(&sb, &[]);
    assert_eq!(base["res"], Integer(30), "the file's keys are read");
    let cases: [(&[&str], &str, toml::Value); 9] = [
        (&["--res", "24"], "res", Integer(24)),
        (&["--seed", "7"], "seed", Integer(7)),
        (&["--dt", "0.025"], "dt", Float(0.025)),
        (&["--advection", "bfecc"], "advection", Text("bfecc".into())),
        (&["--box", "closed"], "box", Text("closed".into())),
        (&["--cell-samples", "8"], "cell_samples", Integer(8)),
        (
            &["--diagnostics-every", "1"],
            "diagnostics_every",
            Integer(1),
        ),
        (&["--no-substeps"], "substeps", Boolean(false)),
        (&["--force"], "force", Boolean(true)),
    ];
    for (args, key, value) in cases {
        let mut expected = base.clone();
        assert_ne!(expected.insert(key.into(), value.clone()), Some(value));
        assert_eq!(printed_config(&sb, args), expected, "{args:?}");
    }
    std::fs::write(sb.join("c.toml"), "substeps = false\nforce = true\n").unwrap();
    let switched = printed_config(&sb, &[]);
    assert_eq!(
        (&switched["substeps"], &switched["force"]),
        (&Boolean(false), &Boolean(true))
    );
}

/// A solver flag's bad value exits 2 naming the value (and, where the flag
/// knows them, the valid ones), one flag per kind of value.
#[test]
fn bad_solver_flag_values_exit_2_naming_the_value() {
    let cases: [(&[&str], &[&str]); 7] = [
        (&["--res", "many"], &["'many'", "--res"]),
        (&["--seed", "-1"], &["'-1'", "--seed"]),
        (&["--size", "wide"], &["'wide'", "--size"]),
        (&["--advection", "upwind"], &["'upwind'", "sl, quick"]),
        (&["--box", "open"], &["'open'", "periodic, closed"]),
        (
            &["--cell-samples", "3"],
            &["'3'", "1 (the cell centre) or 8"],
        ),
        (&["--no-substeps=yes"], &["'yes'", "--no-substeps"]),
    ];
    let sb = Sandbox::new();
    for (flag, needles) in cases {
        let mut args = vec!["run", "hot-cold", "--out", "out"];
        args.extend_from_slice(flag);
        sb.refused(&args, needles);
        assert!(!sb.join("out").exists(), "{args:?} created its folder");
    }
}

#[test]
fn experiment_list_names_06_1() {
    let sb = Sandbox::new();
    let o = sb.ok(&["experiment", "--list"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(out.contains("06-1") && out.contains("fig"), "{out}");
}

#[test]
fn small_run_writes_whole_outputs() {
    let sb = Sandbox::new();
    sb.ok(&[
        "run",
        "hot-cold",
        "--res",
        "12",
        "--frames",
        "4",
        "--save-every",
        "2",
        "--out",
        "r",
        "--quiet",
    ]);
    let r = sb.join("r");
    for f in [
        "hot_0002.npy",
        "cold_0004.npy",
        "vel_0004.npy",
        "preview_0004.png",
        "metrics.csv",
        "manifest.json",
    ] {
        assert!(r.join(f).is_file(), "missing {f}");
    }
    let vel: ndarray::Array4<f32> = ndarray_npy::read_npy(r.join("vel_0004.npy")).unwrap();
    assert_eq!(vel.dim(), (12, 12, 12, 3));
    // The solver's own faces; their mean over each cell is `vel`.
    let faces: Vec<ndarray::Array3<f32>> = ["u", "v", "w"]
        .iter()
        .map(|c| ndarray_npy::read_npy(r.join(format!("{c}_0004.npy"))).unwrap())
        .collect();
    for (a, f) in faces.iter().enumerate() {
        assert_eq!(f.dim(), (12, 12, 12));
        for ((k, j, i), &centre) in vel.index_axis(ndarray::Axis(3), a).indexed_iter() {
            let mut up = [k, j, i];
            up[2 - a] = (up[2 - a] + 1) % 12;
            let mean = 0.5 * (f[[k, j, i]] + f[up]);
            assert!(
                (mean - centre).abs() <= 1e-6,
                "component {a} at ({i},{j},{k})"
            );
        }
    }
    let csv = std::fs::read_to_string(r.join("metrics.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "header + one row per step");
    let manifest = common::manifest(&r);
    assert_eq!(manifest["config"]["res"], 12);
    assert!(std::fs::read_dir(&r).unwrap().all(|e| !e
        .unwrap()
        .path()
        .to_string_lossy()
        .ends_with(smokelab::io::TEMPORARY_SUFFIX)));
}

#[test]
fn experiment_06_1_smoke_gases_pass_each_other_unless_head_on() {
    let sb = Sandbox::new();
    sb.ok(&["experiment", "06-1", "--smoke", "--quiet", "--out", "e"]);
    let e = sb.join("e");
    for f in [
        "sequence.png",
        "metrics.csv",
        "manifest.json",
        "head_on/metrics.csv",
    ] {
        assert!(e.join(f).is_file(), "missing {f}");
    }
    let rows = |f: &str| -> Vec<std::collections::HashMap<String, String>> {
        csv::Reader::from_path(e.join(f))
            .unwrap()
            .deserialize()
            .map(|r| r.unwrap())
            .collect()
    };
    let num = |r: &std::collections::HashMap<String, String>, c: &str| -> f64 {
        r[c].parse().unwrap_or_else(|_| panic!("{c} = {:?}", r[c]))
    };
    // At the last frame the default (offset) gases have passed each other,
    // the head-on ones have not (measured at 16³: 42 % against 2.4 %).
    let data = rows("data.csv");
    let last = |offset: f64| {
        data.iter()
            .filter(|r| num(r, "offset") == offset)
            .max_by_key(|r| num(r, "frame") as usize)
            .unwrap()
    };
    let (passing, head_on) = (last(0.5), last(0.0));
    assert!(num(passing, "hot_past_mid") > 0.3, "{passing:?}");
    assert!(num(head_on, "hot_past_mid") < 0.1, "{head_on:?}");
    // The mass reported is metrics.csv's last row.
    for (row, metrics) in [(passing, "metrics.csv"), (head_on, "head_on/metrics.csv")] {
        let m = rows(metrics).pop().unwrap();
        let ratio = num(&m, "hot_mass") / num(&m, "hot_injected");
        let reported = num(row, "hot_mass_over_injected");
        assert!(
            (reported / ratio - 1.0).abs() < 1e-6,
            "{reported} against {ratio}"
        );
    }
    // The study: the larger the offset, the more gas has passed at the end.
    let study = rows("offset_study.csv");
    let frames = study
        .iter()
        .map(|r| num(r, "frame") as usize)
        .max()
        .unwrap();
    let passed: Vec<f64> = study
        .iter()
        .filter(|r| num(r, "frame") as usize == frames)
        .map(|r| num(r, "hot_past_mid"))
        .collect();
    assert_eq!(passed.len(), 5, "{study:?}");
    assert!(passed.windows(2).all(|w| w[0] < w[1]), "{passed:?}");
}

#[test]
fn experiment_all_smoke_runs_every_experiment_and_tabulates() {
    let sb = Sandbox::new();
    // Without --out: a new folder of its own under runs/.
    sb.ok(&["experiment", "all", "--smoke", "--quiet"]);
    let runs: Vec<_> = std::fs::read_dir(sb.join("runs"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    assert!(
        runs.len() == 1
            && runs[0]
                .file_name()
                .unwrap()
                .to_string_lossy()
                .starts_with("all-smoke-"),
        "{runs:?}"
    );
    let table = std::fs::read_to_string(runs[0].join("experiments.csv")).unwrap();
    let list = String::from_utf8(sb.run(&["experiment", "--list"]).stdout).unwrap();
    // One row per experiment of the listing (header excluded), each "ok",
    // each output folder written.
    let ids: Vec<&str> = list
        .lines()
        .skip(1)
        .filter_map(|l| l.split_whitespace().next())
        .collect();
    assert!(ids.len() >= 10, "listing: {list}");
    let mut reader = csv::Reader::from_reader(table.as_bytes());
    let rows: Vec<csv::StringRecord> = reader.records().map(|r| r.unwrap()).collect();
    assert_eq!(rows.len(), ids.len(), "{table}");
    assert_eq!(
        reader.headers().unwrap(),
        vec!["id", "reproduces", "seconds", "output", "status"]
    );
    for (row, id) in rows.iter().zip(&ids) {
        assert_eq!(&row[0], *id, "{row:?}");
        assert_eq!(&row[4], "ok", "{row:?}");
        let folder = sb.join(&row[3]);
        assert!(
            std::fs::read_dir(&folder).is_ok_and(|mut d| d.next().is_some()),
            "{id} wrote nothing in {}",
            folder.display()
        );
    }
}

/// `--vdb` and `--paraview` write every saved frame for Houdini/Blender and
/// ParaView, and the manifest records where the grid sits in the world.
#[test]
fn a_run_writes_vdb_and_paraview_frames_and_its_grid() {
    let sb = Sandbox::new();
    sb.ok(&[
        "run",
        "hot-cold",
        "--res",
        "10",
        "--frames",
        "4",
        "--save-every",
        "2",
        "--vdb",
        "--paraview",
        "--quiet",
        "--out",
        "out",
    ]);
    let out = sb.join("out");
    // Numbered 1, 2 in the order saved (steps 2 and 4), as a sequence.
    for f in [
        "frame_0001.vdb",
        "frame_0002.vdb",
        "frame_0001.vti",
        "frame_0002.vti",
    ] {
        assert!(out.join(f).is_file(), "no {f}");
    }
    assert!(!out.join("frame_0004.vdb").exists());
    let pvd = std::fs::read_to_string(out.join("run.pvd")).unwrap();
    assert!(
        pvd.contains("timestep=\"0.2\" group=\"\" part=\"0\" file=\"frame_0002.vti\""),
        "{pvd}"
    );
    let manifest = common::manifest(&out);
    let grid = &manifest["extra"]["grid"];
    assert_eq!(grid["dims"], serde_json::json!([10, 10, 10]));
    assert_eq!(grid["cell"], serde_json::json!(1.0));
    assert_eq!(grid["origin"], serde_json::json!([0.0, 0.0, 0.0]));
}

/// A rerun into a folder that holds an earlier run is refused (a 5-frame
/// rerun into a 164-frame folder used to leave 657 files mixing both); with
/// `--overwrite` the earlier outputs are replaced and none of its frames stay.
#[test]
fn a_rerun_into_a_used_folder_is_refused_unless_overwrite() {
    let sb = Sandbox::new();
    let args = |frames: &'static str, extra: &[&'static str]| {
        let mut args = vec![
            "run",
            "hot-cold",
            "--res",
            "10",
            "--frames",
            frames,
            "--save-every",
            "2",
            "--quiet",
            "--out",
            "out",
        ];
        args.extend_from_slice(extra);
        args
    };
    sb.ok(&args("6", &[]));
    let out = sb.join("out");
    std::fs::write(out.join("notes.txt"), "mine").unwrap();
    sb.refused(&args("2", &[]), &["--overwrite"]);
    assert!(
        out.join("hot_0006.npy").is_file(),
        "the refused rerun removed files"
    );
    sb.ok(&args("2", &["--overwrite"]));
    assert!(out.join("hot_0002.npy").is_file());
    for stale in [
        "hot_0004.npy",
        "hot_0006.npy",
        "preview_0006.png",
        "vel_0006.npy",
    ] {
        assert!(
            !out.join(stale).exists(),
            "{stale} of the earlier run is still there"
        );
    }
    assert!(
        out.join("notes.txt").is_file(),
        "a file the run does not write was removed"
    );
}

/// `--box closed`: the normal components have one more face along their
/// axis, the wall faces are exactly zero, and the manifest says so.
#[test]
fn a_closed_box_run_writes_wall_faces() {
    let sb = Sandbox::new();
    let args = [
        "run",
        "hot-cold",
        "--box",
        "closed",
        "--res",
        "12",
        "--frames",
        "3",
        "--save-every",
        "3",
        "--out",
        "c",
        "--quiet",
    ];
    sb.ok(&args);
    let c = sb.join("c");
    let read = |n: &str| -> ndarray::Array3<f32> {
        ndarray_npy::read_npy(c.join(format!("{n}_0003.npy"))).unwrap()
    };
    let (u, v, w) = (read("u"), read("v"), read("w"));
    assert_eq!(
        (u.dim(), v.dim(), w.dim()),
        ((12, 12, 13), (12, 13, 12), (13, 12, 12))
    );
    use ndarray::s;
    let walls = [
        u.slice(s![.., .., 0]),
        u.slice(s![.., .., 12]),
        v.slice(s![.., 0, ..]),
        v.slice(s![.., 12, ..]),
        w.slice(s![0, .., ..]),
        w.slice(s![12, .., ..]),
    ];
    assert!(walls.iter().all(|wall| wall.iter().all(|&x| x == 0.0)));
    assert!(v.iter().any(|&x| x != 0.0), "the gases did not move");
    let manifest = common::manifest(&c);
    assert_eq!(manifest["extra"]["grid"]["boundary"], "closed");
}

/// A CFL number far beyond any resolved flow gets one warning with the number.
/// The step diagnostics come on their cadence: with `--diagnostics-every
/// 3` over 7 steps, rows 3, 6 and 7 (the last) hold exactly what a run
/// diagnosing every step writes there, the rows between `NaN`; the other
/// columns (budgets, fine measures) are the same in every row; the
/// default cadence is 10.
#[test]
fn step_diagnostics_come_on_their_cadence() {
    const DIAGNOSTICS: [&str; 6] = [
        "max_u",
        "cfl",
        "div_rms",
        "div_max",
        "mirror_error",
        "vel_mirror_error",
    ];
    let sb = Sandbox::new();
    let run = |out: &str, every: &str| {
        let mut args = vec!["run", "hot-cold", "--res", "10", "--frames", "7"];
        args.extend(["--save-every", "0", "--quiet", "--out", out]);
        sb.ok(&[&args[..], &["--diagnostics-every", every]].concat());
        common::table(&sb.join(out).join("metrics.csv"))
    };
    let (every, third) = (run("every", "1"), run("third", "3"));
    assert_eq!((every.len(), third.len()), (7, 7));
    for (step, (a, b)) in (1..).zip(every.iter().zip(&third)) {
        for (col, value) in a {
            if col.starts_with("t_") {
                continue;
            }
            let diagnosed = step % 3 == 0 || step == 7;
            if DIAGNOSTICS.contains(&col.as_str()) {
                assert_ne!(value, "NaN", "step {step}, {col}");
                if !diagnosed {
                    assert_eq!(b[col], "NaN", "step {step}, {col}");
                    continue;
                }
            }
            assert_eq!(&b[col], value, "step {step}, {col}");
        }
    }
    for col in DIAGNOSTICS {
        assert!(every[0].contains_key(col), "{col}");
    }
    std::fs::write(sb.join("c.toml"), "").unwrap();
    let config = printed_config(&sb, &[]);
    assert_eq!(config["diagnostics_every"], toml::Value::Integer(10));
}

#[test]
fn a_huge_cfl_number_is_warned_about() {
    let sb = Sandbox::new();
    let args = [
        "run",
        "hot-cold",
        "--res",
        "12",
        "--frames",
        "3",
        "--gravity",
        "1e9",
        "--save-every",
        "0",
        "--out",
        "g",
        "--quiet",
    ];
    let o = sb.ok(&args);
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(err.matches("warning: CFL number").count(), 1, "{err}");
    assert!(err.contains("lower --dt or --gravity"), "{err}");
}

/// `--version` names the package version and the commit the binary was
/// built from, so a bug report says which code ran.
#[test]
fn version_prints_the_version_and_the_commit() {
    let sb = Sandbox::new();
    let o = sb.ok(&["--version"]);
    let out = String::from_utf8_lossy(&o.stdout);
    let expected = format!("smokelab {} (", env!("CARGO_PKG_VERSION"));
    assert!(out.starts_with(&expected), "{out:?}");
    let commit = out
        .trim()
        .trim_start_matches(&expected)
        .trim_end_matches(')');
    let hash = commit.trim_end_matches("-dirty");
    assert!(
        commit == "unknown" || (hash.len() == 40 && hash.chars().all(|c| c.is_ascii_hexdigit())),
        "{out:?} names no commit"
    );
}
