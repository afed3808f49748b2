//! `smokelab sweep`: the sweep file expanded into points (the Cartesian
//! product of the axes, last fastest), each point the ordinary run of its
//! keys (its volumes equal a direct `smokelab run`'s), `run-point`,
//! `status`, `resubmit` and `gather` (its table and its contact sheet of the
//! points' previews), the Slurm script, and bad sweep files
//! refused with one line and exit 2 before anything is written. The real
//! Slurm is exercised by `.ci/slurm`.

mod common;

use std::path::Path;

use common::{table, Sandbox};

/// The issue's (and the book's) first example.
const FIRST_EXAMPLE: &str = r#"scenario = "hot-cold"
[keys]
frames = 4
save_every = 4
[axes]
res = [12, 16]
density = ["gridded", "gridless"]
"#;

/// `sb/name` holding `text`; its name.
fn file<'a>(sb: &Sandbox, name: &'a str, text: &str) -> &'a str {
    std::fs::write(sb.join(name), text).unwrap();
    name
}

/// `DIR/sweep.json`.
fn index(dir: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(dir.join("sweep.json")).unwrap()).unwrap()
}

/// The size of the largest last preview among the `points` of the sweep in
/// `dir` that have one: the size of each panel of its `sweep.png`.
fn panel_size(dir: &Path, points: &[serde_json::Value]) -> (u32, u32) {
    let sizes: Vec<(u32, u32)> = points
        .iter()
        .filter_map(|p| {
            let folder = dir.join(p["folder"].as_str().unwrap());
            let last = std::fs::read_dir(folder)
                .ok()?
                .map(|e| e.unwrap().path())
                .filter(|p| p.to_string_lossy().contains("preview_"))
                .max()?;
            Some(image::image_dimensions(last).unwrap())
        })
        .collect();
    let w = sizes.iter().map(|s| s.0).max().unwrap();
    let h = sizes.iter().map(|s| s.1).max().unwrap();
    (w, h)
}

/// `DIR/figures.json`'s caption of `sweep.png`.
fn sheet_caption(dir: &Path) -> String {
    let captions: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("figures.json")).unwrap()).unwrap();
    captions["sweep.png"].as_str().unwrap().to_string()
}

/// Run `args`, check exit 2 with one line naming every needle, and that
/// the sweep folder `out` was not created.
fn refused(sb: &Sandbox, args: &[&str], needles: &[&str], out: &str) {
    let err = sb.refused(args, needles);
    assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    assert!(!sb.join(out).exists(), "{args:?} created {out}");
}

#[test]
fn the_first_example_runs_every_point_as_the_ordinary_run_and_gathers_one_table() {
    let sb = Sandbox::new();
    let f = file(&sb, "sweep.toml", FIRST_EXAMPLE);
    sb.ok(&["sweep", f, "--out", "sw", "--jobs", "2"]);
    let plan = index(&sb.join("sw"));
    let points = plan["points"].as_array().unwrap();
    // res outer, density inner: the file's axis order, the last fastest.
    let expected = [
        (12, "gridded"),
        (12, "gridless"),
        (16, "gridded"),
        (16, "gridless"),
    ];
    assert_eq!(points.len(), 4);
    for (i, (p, (res, density))) in points.iter().zip(expected).enumerate() {
        assert_eq!(p["index"], i);
        assert_eq!(p["values"], serde_json::json!([res, density]));
        assert_eq!(p["state"], "complete");
        let folder = sb.join("sw").join(p["folder"].as_str().unwrap());
        let m = common::manifest(&folder);
        assert_eq!(m["status"], "complete");
        assert_eq!(m["config"]["res"], res);
        assert_eq!(m["config"]["density"], density);
        assert_eq!(m["config"]["frames"], 4);
        assert!(folder.join("checkpoint.bin").exists());
    }
    // Point 3 is bitwise `smokelab run` of its keys.
    sb.ok(&[
        "run",
        "hot-cold",
        "--res",
        "16",
        "--density",
        "gridless",
        "--frames",
        "4",
        "--save-every",
        "4",
        "--quiet",
        "--out",
        "direct",
    ]);
    let p3 = sb.join("sw").join(points[3]["folder"].as_str().unwrap());
    for name in ["hot_0004.npy", "cold_0004.npy", "vel_0004.npy"] {
        assert_eq!(
            std::fs::read(p3.join(name)).unwrap(),
            std::fs::read(sb.join("direct").join(name)).unwrap(),
            "{name}"
        );
    }

    let status = sb.ok(&["sweep", "status", "sw"]);
    let status = String::from_utf8_lossy(&status.stdout);
    assert!(
        status.contains("4 points: 4 complete, 0 running, 0 pending, 0 failed"),
        "{status}"
    );

    let o = sb.ok(&["sweep", "gather", "sw"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("wrote sw/sweep.png"), "{stdout}");
    assert!(!stdout.contains("grey panel"), "{stdout}");
    // The contact sheet: a 2 × 2 grid of the previews, all scaled to the
    // largest, with the headings in margins left and above.
    let sheet = image::open(sb.join("sw/sweep.png")).unwrap().to_rgb8();
    let (w, h) = panel_size(&sb.join("sw"), points);
    assert!(
        sheet.width() > 2 * w + 6 && sheet.width() < 3 * w,
        "{}×{} for panels {w}×{h}",
        sheet.width(),
        sheet.height()
    );
    assert!(
        sheet.height() > 2 * h + 6 && sheet.height() < 3 * h,
        "{}×{} for panels {w}×{h}",
        sheet.width(),
        sheet.height()
    );
    assert_eq!(
        sheet_caption(&sb.join("sw")),
        "hot-cold sweep sw. Rows, top to bottom: res = 12; res = 16. \
         Columns, left to right: density = gridded; density = gridless."
    );
    // The wall time against res, a line per density.
    let svg = std::fs::read_to_string(sb.join("sw/sweep_wall_seconds.svg")).unwrap();
    for name in ["density = gridded", "density = gridless", "wall time (s)"] {
        assert!(svg.contains(name), "{name}");
    }
    assert!(sb.join("sw/sweep_wall_seconds.png").is_file());
    let rows = table(&sb.join("sw/sweep.csv"));
    let header = std::fs::read_to_string(sb.join("sw/sweep.csv")).unwrap();
    assert!(
        header.starts_with("point,res,density,state,wall_seconds,peak_memory_bytes,step,time,"),
        "{header}"
    );
    // The per-stage timing columns are left out.
    let columns: Vec<&str> = header.lines().next().unwrap().split(',').collect();
    assert!(columns.contains(&"hot_advection"), "{columns:?}");
    assert!(!columns.iter().any(|c| c.starts_with("t_")), "{columns:?}");
    assert_eq!(rows.len(), 4);
    for (row, (res, density)) in rows.iter().zip(expected) {
        assert_eq!(row["res"], res.to_string());
        assert_eq!(row["density"], density);
        assert_eq!(row["state"], "complete");
        assert_eq!(row["step"], "4");
    }
    // The summary is the run's last metrics row.
    let direct = table(&sb.join("direct/metrics.csv"));
    assert_eq!(rows[3]["hot_mass"], direct[3]["hot_mass"]);
    assert_eq!(rows[3]["max_u"], direct[3]["max_u"]);
    assert_ne!(rows[2]["hot_mass"], rows[3]["hot_mass"]);

    // Nothing left to do.
    let o = sb.ok(&["sweep", "resubmit", "sw"]);
    assert!(String::from_utf8_lossy(&o.stdout).contains("all 4 points are complete"));
}

#[test]
fn the_slurm_script_maps_each_array_task_to_a_point_and_takes_the_options() {
    let sb = Sandbox::new();
    let text = format!(
        "{FIRST_EXAMPLE}[slurm]\npartition = \"short\"\nmem = \"2G\"\nextra = [\"--account=lab\"]\n"
    );
    let f = file(&sb, "sweep.toml", &text);
    let o = sb.ok(&[
        "sweep",
        f,
        "--out",
        "sw",
        "--slurm",
        "--dry-run",
        "--partition",
        "long",
        "--time",
        "01:30:00",
        "--cpus-per-task",
        "2",
        "--sbatch=--qos=low",
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    let script = std::fs::read_to_string(sb.join("sw/sweep.sbatch")).unwrap();
    assert!(stdout.contains(&script), "{stdout}");
    let dir = std::path::absolute(sb.join("sw")).unwrap();
    let directives: Vec<&str> = script
        .lines()
        .filter(|l| l.starts_with("#SBATCH"))
        .collect();
    assert_eq!(
        directives,
        [
            "#SBATCH --job-name=smokelab-sweep",
            "#SBATCH --array=0-3",
            &format!("#SBATCH --output={}/logs/slurm-%A_%a.log", dir.display()),
            "#SBATCH --open-mode=append",
            "#SBATCH --partition=long",
            "#SBATCH --time=01:30:00",
            "#SBATCH --cpus-per-task=2",
            "#SBATCH --mem=2G",
            "#SBATCH --account=lab",
            "#SBATCH --qos=low",
        ]
    );
    let exe = std::path::absolute(env!("CARGO_BIN_EXE_smokelab")).unwrap();
    assert!(
        script.ends_with(&format!(
            "exec {} sweep run-point {} \"$SLURM_ARRAY_TASK_ID\"\n",
            exe.display(),
            dir.display()
        )),
        "{script}"
    );
    assert!(stdout.contains("not submitted (--dry-run)"));

    // Nothing ran; one array task's command runs its point alone.
    let status = sb.ok(&["sweep", "status", "sw"]);
    assert!(String::from_utf8_lossy(&status.stdout)
        .contains("4 points: 0 complete, 0 running, 4 pending"));
    sb.ok(&["sweep", "run-point", "sw", "2"]);
    let status = sb.ok(&["sweep", "status", "sw"]);
    assert!(String::from_utf8_lossy(&status.stdout)
        .contains("4 points: 1 complete, 0 running, 3 pending"));
    let p2 = index(&sb.join("sw"))["points"][2]["folder"]
        .as_str()
        .unwrap()
        .to_string();
    assert_eq!(
        common::manifest(&sb.join("sw").join(&p2))["config"]["res"],
        16
    );
    sb.refused(
        &["sweep", "run-point", "sw", "4"],
        &["point 4 is not in the sweep", "0 to 3"],
    );

    // A resubmission with the Slurm options changed lists the unfinished points only.
    let o = sb.ok(&[
        "sweep",
        "resubmit",
        "sw",
        "--slurm",
        "--dry-run",
        "--time",
        "02:00:00",
    ]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("resubmitting 3 of 4 points: 0,1,3"),
        "{stdout}"
    );
    assert!(stdout.contains("sbatch --array=0,1,3 "), "{stdout}");
    assert!(stdout.contains("#SBATCH --time=02:00:00"), "{stdout}");
    // … and runs them here with --local.
    sb.ok(&["sweep", "resubmit", "sw", "--local", "--jobs", "2"]);
    let plan = index(&sb.join("sw"));
    assert!(plan["points"]
        .as_array()
        .unwrap()
        .iter()
        .all(|p| p["state"] == "complete"));
}

/// An unfinished sweep's contact sheet keeps its grid: a grey panel for
/// each point not complete, named on the terminal; with no point complete
/// there is no figure, and a line says so.
#[test]
fn gather_shows_unfinished_points_as_grey_panels() {
    let sb = Sandbox::new();
    let f = file(&sb, "sweep.toml", FIRST_EXAMPLE);
    sb.ok(&["sweep", f, "--out", "sw", "--slurm", "--dry-run"]);
    let o = sb.ok(&["sweep", "gather", "sw"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("wrote no sweep.png: no point has an image to show"),
        "{stdout}"
    );
    assert!(!sb.join("sw/sweep.png").exists());

    sb.ok(&["sweep", "run-point", "sw", "1"]);
    let o = sb.ok(&["sweep", "gather", "sw"]);
    let stdout = String::from_utf8_lossy(&o.stdout);
    for (i, at) in [
        (0, "res=12, density=gridded"),
        (2, "res=16, density=gridded"),
    ] {
        assert!(
            stdout.contains(&format!(
                "sweep.png: point {i} ({at}) is a grey panel: it is pending"
            )),
            "{stdout}"
        );
    }
    assert!(!stdout.contains("point 1 ("), "{stdout}");
    assert!(stdout.contains("wrote sw/sweep.png"), "{stdout}");
    let plan = index(&sb.join("sw"));
    let points = plan["points"].as_array().unwrap();
    let (w, h) = panel_size(&sb.join("sw"), points);
    let sheet = image::open(sb.join("sw/sweep.png")).unwrap().to_rgb8();
    // The panels fill the bottom right; the headings the margins.
    let (left, top) = (sheet.width() - 2 * w - 6, sheet.height() - 2 * h - 6);
    let grey = |row: u32, col: u32| {
        let (x0, y0) = (left + col * (w + 6), top + row * (h + 6));
        (y0..y0 + h)
            .flat_map(|y| (x0..x0 + w).map(move |x| (x, y)))
            .all(|(x, y)| *sheet.get_pixel(x, y) == image::Rgb([128, 128, 128]))
    };
    assert!(grey(0, 0) && grey(1, 0) && grey(1, 1));
    assert!(!grey(0, 1), "point 1's preview is missing");
}

#[test]
fn an_experiment_sweep_has_a_point_per_id() {
    let sb = Sandbox::new();
    let f = file(&sb, "all.toml", "experiment = \"all\"\nsize = \"smoke\"\n");
    let o = sb.ok(&["sweep", f, "--out", "all", "--slurm", "--dry-run"]);
    let ids = smokelab_app::experiment::registry::ids();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains(&format!("#SBATCH --array=0-{}\n", ids.len() - 1)),
        "{stdout}"
    );
    let plan = index(&sb.join("all"));
    let points = plan["points"].as_array().unwrap();
    assert_eq!(points.len(), ids.len());
    for (p, id) in points.iter().zip(&ids) {
        assert_eq!(p["values"], serde_json::json!([id]));
        assert_eq!(
            p["args"],
            serde_json::json!(["experiment", id, "--quiet", "--smoke"])
        );
    }
    let f = file(&sb, "two.toml", "experiment = [\"06-1\", \"06-3\"]\n");
    sb.ok(&["sweep", f, "--out", "two", "--slurm", "--dry-run"]);
    assert_eq!(
        index(&sb.join("two"))["points"].as_array().unwrap().len(),
        2
    );
}

#[test]
fn bad_sweep_files_and_flags_are_refused_before_anything_is_written() {
    let sb = Sandbox::new();
    let cases: [(&str, &[&str]); 13] = [
        (
            "scenario = \"hot-cold\"\n[keys]\nwal = 1.2\n[axes]\nres = [12]\n",
            &["wal"],
        ),
        (
            "scenario = \"hot-cold\"\n[axes]\ndensity = [\"gridded\", \"griddled\"]\n",
            &["griddled", "gridless", "at point density=\"griddled\""],
        ),
        (
            "scenario = \"hot-cold\"\n[axes]\nres = [12, -4]\n",
            &["res", "-4", "at point res=-4"],
        ),
        (
            "scenario = \"hot-cold\"\n[keys]\nselma_remap = 2.0\n",
            &["selma_remap", "density is gridded"],
        ),
        (
            "scenario = \"hot-cod\"\n",
            &["unknown scenario 'hot-cod'", "hot-cold"],
        ),
        (
            "scenario = \"hot-cold\"\nsweep = 1\n",
            &["unknown key 'sweep'", "axes"],
        ),
        (
            "scenario = \"hot-cold\"\n[axes]\nres = []\n",
            &["axis res", "non-empty list"],
        ),
        (
            "scenario = \"hot-cold\"\n[keys]\nres = 12\n[axes]\nres = [12, 16]\n",
            &["'res' is both a fixed key and an axis"],
        ),
        ("[axes]\nres = [12]\n", &["say what to sweep"]),
        (
            "experiment = [\"06-1\", \"99-9\"]\n",
            &["unknown experiment id '99-9'"],
        ),
        (
            "experiment = \"06-1\"\n[axes]\nres = [12]\n",
            &["an experiment takes no configuration keys ('res')"],
        ),
        (
            "scenario = \"hot-cold\"\n[slurm]\nqueue = \"x\"\n",
            &["unknown key 'queue' in [slurm]"],
        ),
        (
            "scenario = \"hot-cold\"\n[slurm]\ncpus_per_task = \"x\"\n",
            &["[slurm] is not valid", "cpus_per_task"],
        ),
    ];
    for (i, (text, needles)) in cases.iter().enumerate() {
        let name = format!("bad{i}.toml");
        file(&sb, &name, text);
        refused(&sb, &["sweep", &name, "--out", "sw"], needles, "sw");
    }
    let f = file(&sb, "good.toml", FIRST_EXAMPLE);
    refused(
        &sb,
        &["sweep", f, "--out", "sw", "--partition", "x"],
        &["add --slurm"],
        "sw",
    );
    refused(
        &sb,
        &["sweep", f, "--out", "sw", "--jobs", "0"],
        &["--jobs is 0"],
        "sw",
    );
    refused(
        &sb,
        &["sweep", "missing.toml", "--out", "sw"],
        &["missing.toml"],
        "sw",
    );
    refused(
        &sb,
        &["sweep", "status", "nowhere"],
        &["nowhere is not a sweep folder"],
        "nowhere",
    );
    // A folder with files in it is not a sweep's to take.
    std::fs::create_dir(sb.join("full")).unwrap();
    std::fs::write(sb.join("full/notes.txt"), "mine").unwrap();
    sb.refused(
        &["sweep", f, "--out", "full"],
        &["sweep folder full is not empty"],
    );
    assert_eq!(std::fs::read_dir(sb.join("full")).unwrap().count(), 1);
}
