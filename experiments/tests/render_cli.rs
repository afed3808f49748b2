//! The `smokelab` command line end to end (moved from `tests/render.rs`).

mod common;

use common::Sandbox;
use ndarray::Array3;
use std::path::Path;

fn write_volume(path: &Path, shape: (usize, usize, usize)) {
    let a = Array3::<f32>::from_shape_fn(shape, |(k, j, i)| ((i + j + k) % 3) as f32 * 0.2);
    ndarray_npy::write_npy(path, &a).unwrap();
}

/// Density files named after a frame (`hot_0100.npy`) name the render
/// after it: `render_0100.exr`, `.png` and its manifest `render_0100.json`.
#[test]
fn render_command_writes_exr_png_and_manifest() {
    let sb = Sandbox::new();
    let (hot, cold) = (sb.join("hot_0100.npy"), sb.join("cold_0100.npy"));
    write_volume(&hot, (8, 8, 8));
    write_volume(&cold, (8, 8, 8));
    let out = sb.join("out");
    sb.ok(&[
        "render",
        "--density",
        hot.to_str().unwrap(),
        "--density",
        cold.to_str().unwrap(),
        "--image",
        "32x24",
        "--camera",
        "-5,12,20",
        "--out",
        out.to_str().unwrap(),
    ]);
    let png = image::open(out.join("render_0100.png")).unwrap();
    assert_eq!((png.width(), png.height()), (32, 24));
    assert!(out.join("render_0100.exr").is_file());
    let m = common::manifest_file(&out.join("render_0100.json"));
    assert_eq!(m["config"]["frame"], 100);
    assert!(m["extra"]["samples"].as_u64().unwrap() > 0);
    assert_eq!(m["config"]["scene"]["volumes"].as_array().unwrap().len(), 2);
}

#[test]
fn render_command_rejects_bad_input_with_exit_2_and_writes_nothing() {
    let sb = Sandbox::new();
    let p = |n: &str| sb.join(n).to_str().unwrap().to_string();
    write_volume(Path::new(&p("a.npy")), (8, 8, 8));
    write_volume(Path::new(&p("b.npy")), (8, 8, 6));
    std::fs::write(p("junk.npy"), b"not a numpy file").unwrap();
    let out = p("out");
    let a = p("a.npy");
    let cases: Vec<(&str, Vec<&str>)> = vec![
        ("zero image", vec!["--density", &a, "--image", "0x64"]),
        (
            "absurd image",
            vec!["--density", &a, "--image", "100000x100000"],
        ),
        ("malformed image", vec!["--density", &a, "--image", "big"]),
        (
            "non-finite camera",
            vec!["--density", &a, "--camera", "nan,1,2"],
        ),
        (
            "infinite camera",
            vec!["--density", &a, "--camera", "inf,1,2"],
        ),
        ("non-finite kappa", vec!["--density", &a, "--kappa", "nan"]),
        ("infinite kappa", vec!["--density", &a, "--kappa", "inf"]),
        ("negative kappa", vec!["--density", &a, "--kappa", "-1"]),
        ("missing volume", vec!["--density", "/nonexistent/x.npy"]),
        ("unreadable volume", vec!["--density", "JUNK"]),
        ("different shapes", vec!["--density", &a, "--density", "B"]),
        (
            "zero march step",
            vec!["--density", &a, "--march-step", "0"],
        ),
        ("bad phase", vec!["--density", &a, "--phase", "hg:1.5"]),
    ];
    let junk = p("junk.npy");
    let b = p("b.npy");
    for (what, args) in cases {
        let mut full = vec!["render", "--out", &out];
        full.extend(args.iter().map(|s| match *s {
            "JUNK" => junk.as_str(),
            "B" => b.as_str(),
            s => s,
        }));
        let err = sb.fails(&full, 2);
        assert_eq!(err.trim().lines().count(), 1, "{what}: not one line: {err}");
        assert!(err.starts_with("error:"), "{what}: {err}");
        assert!(!Path::new(&out).exists(), "{what}: wrote {out}");
    }
}

#[test]
fn run_with_render_writes_render_frames_and_rejects_bad_render_flags() {
    let sb = Sandbox::new();
    let out = sb.join("run");
    sb.ok(&[
        "run",
        "hot-cold",
        // 10³: the default sources cover cell centres (at 8³ they cover
        // none, and the run is refused).
        "--res",
        "10",
        "--frames",
        "4",
        "--save-every",
        "2",
        "--render",
        "--render-every",
        "4",
        "--image",
        "24x16",
        "--quiet",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(out.join("render_0004.png").is_file() && out.join("render_0004.exr").is_file());
    assert!(
        !out.join("render_0002.png").exists(),
        "only every 4th frame is rendered"
    );
    let png = image::open(out.join("render_0004.png")).unwrap();
    assert_eq!((png.width(), png.height()), (24, 16));
    let m = common::manifest(&out);
    assert_eq!(m["extra"]["renders"][0]["frame"], 4);

    let bad = sb.join("bad");
    for args in [
        vec!["--render", "--image", "0x16"],
        vec!["--render", "--march-step", "-1"],
        vec!["--render", "--save-every", "0"],
    ] {
        let mut full = vec!["run", "hot-cold", "--res", "10", "--frames", "2", "--quiet"];
        full.extend(args.iter().copied());
        full.extend(["--out", bad.to_str().unwrap()]);
        let err = sb.fails(&full, 2);
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(!bad.exists(), "{args:?} wrote {}", bad.display());
    }
}

/// `render RUN_DIR` (or `--from RUN_DIR`) renders the run's gases at its
/// last saved frame (or `--frame`) in the run's box, as `--density` with
/// the run's `--size` would; an explicit `--size` overrides the run's.
#[test]
fn render_takes_the_box_and_the_gases_from_a_run_folder() {
    let sb = Sandbox::new();
    let d = sb.path();
    // A box of edge 5, not the default 10: the run's geometry must be used.
    sb.small_hot_cold_run("r", &["--size", "5", "--save-every", "2"]);
    let render = |name: &str, args: &[&str]| {
        let mut full = vec!["render", "--image", "16x12", "--out", name];
        full.extend_from_slice(args);
        sb.ok(&full);
        let exr: Vec<_> = std::fs::read_dir(d.join(name))
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|e| e == "exr"))
            .collect();
        assert_eq!(exr.len(), 1, "{exr:?}");
        std::fs::read(&exr[0]).unwrap()
    };
    let files = |frame: &str| ["hot", "cold"].map(|g| format!("r/{g}_{frame}.npy"));
    let [hot4, cold4] = files("0004");
    let from_run = render("a", &["r"]);
    assert_eq!(from_run, render("b", &["--from", "r", "--frame", "4"]));
    let explicit = ["--density", &hot4, "--density", &cold4];
    let sized = |size: &'static str| {
        let mut a = explicit.to_vec();
        a.extend(["--size", size]);
        a
    };
    assert_eq!(from_run, render("c", &sized("5")));
    let default_box = render("d", &explicit);
    assert_ne!(from_run, default_box, "the run's box made no difference");
    assert_eq!(default_box, render("e", &["r", "--size", "10"]));
    let [hot2, cold2] = files("0002");
    let mut frame2 = vec!["--density", &hot2, "--density", &cold2];
    frame2.extend(["--size", "5"]);
    assert_eq!(render("f", &["r", "--frame", "2"]), render("g", &frame2));
    let m = common::manifest_file(&sb.join("a/render_0004.json"));
    assert_eq!(
        m["config"]["scene"]["bounds"]["cell"],
        serde_json::json!(0.5)
    );
    assert_eq!(
        m["config"]["densities"],
        serde_json::json!(["r/hot_0004.npy", "r/cold_0004.npy"])
    );
}

/// Bad run folders and frames: exit 2, one line naming the value, nothing written.
#[test]
fn render_from_a_run_rejects_bad_folders_and_frames() {
    let sb = Sandbox::new();
    let d = sb.path();
    sb.small_hot_cold_run("r", &["--save-every", "2"]);
    for (args, needle) in [
        (&["r", "--frame", "3"][..], "its saved frames are 2, 4"),
        (&["missing"][..], "run folder missing cannot be read"),
        (&["r", "--from", "r"][..], "two run folders"),
        (
            &["--frame", "2", "--density", "r/hot_0002.npy"][..],
            "--frame 2 needs a run folder",
        ),
        (
            &["r", "--frame", "2", "--density", "r/hot_0002.npy"][..],
            "give one of them",
        ),
        (&[][..], "nothing to render"),
    ] {
        let mut full = vec!["render", "--out", "out"];
        full.extend_from_slice(args);
        let err = sb.fails(&full, 2);
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!d.join("out").exists(), "{args:?} wrote out");
    }
}

/// A run that is not complete (killed: its manifest still says `running`)
/// used to be rendered as if whole; now it is refused unless `--partial`.
#[test]
fn render_of_a_partial_run_needs_partial() {
    let sb = Sandbox::new();
    sb.small_hot_cold_run("r", &["--save-every", "2"]);
    let mut m = sb.manifest("r");
    m["status"] = serde_json::json!("running");
    std::fs::write(sb.join("r/manifest.json"), m.to_string()).unwrap();
    let args = ["render", "r", "--image", "16x12", "--quiet", "--out", "out"];
    sb.refused(
        &args,
        &["run folder r is not complete", "running", "--partial"],
    );
    assert!(!sb.join("out").exists());
    sb.ok(&[&args[..], &["--partial"]].concat());
    assert!(sb.join("out/render_0004.exr").is_file());
}

/// The frames of a run go into one folder, each named by its frame; a
/// frame rendered again is refused unless `--overwrite`, which replaces
/// that frame's files only.
#[test]
fn render_names_its_files_by_frame_so_frames_share_a_folder() {
    let sb = Sandbox::new();
    sb.small_hot_cold_run("r", &["--save-every", "2"]);
    let render = |frame: &str, extra: &[&str]| {
        let mut args = vec!["render", "r", "--frame", frame, "--image", "16x12"];
        args.extend_from_slice(&["--quiet", "--out", "render"]);
        args.extend_from_slice(extra);
        args.into_iter().map(String::from).collect::<Vec<_>>()
    };
    let ok = |args: Vec<String>| {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        String::from_utf8(sb.ok(&args).stdout).unwrap()
    };
    let printed = ok(render("2", &[]));
    assert!(
        printed.contains("wrote render/render_0002.exr and render/render_0002.png"),
        "{printed}"
    );
    ok(render("4", &[]));
    let mut names: Vec<String> = std::fs::read_dir(sb.join("render"))
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| !n.starts_with('.'))
        .collect();
    names.sort();
    assert_eq!(
        names,
        [
            "render_0002.exr",
            "render_0002.json",
            "render_0002.png",
            "render_0004.exr",
            "render_0004.json",
            "render_0004.png"
        ]
    );
    let again = render("4", &[]);
    let again: Vec<&str> = again.iter().map(String::as_str).collect();
    sb.refused(&again, &["render_0004", "--overwrite"]);
    let frame2 = std::fs::read(sb.join("render/render_0002.exr")).unwrap();
    ok(render("4", &["--overwrite"]));
    assert_eq!(
        std::fs::read(sb.join("render/render_0002.exr")).unwrap(),
        frame2
    );
    assert!(sb.join("render/render_0004.exr").is_file());
}
