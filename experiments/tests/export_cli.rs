//! `smokelab export vdb|paraview RUN_DIR`: a finished run's saved frames as
//! the files `run --vdb/--paraview` writes.

mod common;

use std::path::Path;

use common::Sandbox;

/// Exporting a plain run gives the files a `--vdb --paraview` run of the
/// same configuration wrote: the `.vti` frames and `run.pvd` byte for byte,
/// the `.vdb` frames but for the 36 characters of each file's random UUID.
#[test]
fn export_writes_what_run_vdb_and_paraview_write() {
    let sb = Sandbox::new();
    sb.small_hot_cold_run("direct", &["--save-every", "2", "--vdb", "--paraview"]);
    sb.small_hot_cold_run("later", &["--save-every", "2"]);
    for format in ["vdb", "paraview"] {
        sb.ok(&["export", format, "later"]);
    }
    let (direct, later) = (sb.join("direct"), sb.join("later"));
    let read = |d: &Path, f: &str| std::fs::read(d.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    for f in ["frame_0001.vti", "frame_0002.vti", "run.pvd"] {
        assert!(read(&direct, f) == read(&later, f), "{f} differs");
    }
    for f in ["frame_0001.vdb", "frame_0002.vdb"] {
        let (a, b) = (read(&direct, f), read(&later, f));
        assert_eq!(a.len(), b.len(), "{f}: lengths differ");
        let differing: Vec<usize> = (0..a.len()).filter(|&i| a[i] != b[i]).collect();
        if let (Some(first), Some(last)) = (differing.first(), differing.last()) {
            assert!(
                last - first < 36,
                "{f}: bytes {first}..={last} differ, more than a UUID"
            );
        }
    }
}

/// A folder that is not a run's is refused with exit 2 and one line naming
/// it, and nothing is written into it.
#[test]
fn export_refuses_what_is_not_a_run_folder() {
    let sb = Sandbox::new();
    let d = sb.path();
    std::fs::write(d.join("file.txt"), "text").unwrap();
    std::fs::create_dir(d.join("empty")).unwrap();
    std::fs::create_dir(d.join("other")).unwrap();
    std::fs::write(d.join("other/manifest.json"), "{\"config\": {}}").unwrap();
    sb.small_hot_cold_run("unsaved", &["--save-every", "0"]);
    for (folder, needle) in [
        ("missing", "run folder missing cannot be read"),
        ("file.txt", "run folder file.txt is not a folder"),
        ("empty", "run folder empty has no manifest.json"),
        (
            "other",
            "run folder other has a manifest.json that is not a run's",
        ),
        ("unsaved", "run folder unsaved holds no saved frames"),
    ] {
        for format in ["vdb", "paraview"] {
            let err = sb.refused(
                &["export", format, folder],
                &[needle, "give a folder `smokelab run` wrote"],
            );
            assert_eq!(err.trim().lines().count(), 1, "{folder}: {err}");
        }
    }
    for folder in ["empty", "other", "unsaved"] {
        let written: Vec<_> = std::fs::read_dir(d.join(folder))
            .unwrap()
            .map(|e| e.unwrap().file_name().into_string().unwrap())
            .filter(|n| n.ends_with(".vdb") || n.ends_with(".vti") || n.ends_with(".pvd"))
            .collect();
        assert!(written.is_empty(), "{folder}: wrote {written:?}");
    }
}

/// The VDB frames a digital-content tool reads as they are: a `density`
/// grid (the gases' sum by default, or one gas), the obstacle as a level
/// set (class `level set`, φ = −`obstacle.npy`, negative inside, within
/// the narrow band), the step and time as file metadata, and names that
/// count 1, 2, 3… (steps 2, 4, 6).
#[test]
fn vdb_frames_carry_density_the_obstacle_level_set_and_a_sequence() {
    use vdb_rs::{MetadataValue, VdbReader};
    let sb = Sandbox::new();
    let d = sb.path();
    let run = [
        "run",
        "slab-box",
        "--res",
        "32",
        "--frames",
        "6",
        "--save-every",
        "2",
        "--vdb",
        "--quiet",
        "--out",
    ];
    sb.ok(&[&run[..], &["s"]].concat());
    let s = d.join("s");
    let names: Vec<String> = std::fs::read_dir(&s)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.ends_with(".vdb"))
        .collect();
    let mut names = names;
    names.sort();
    assert_eq!(
        names,
        ["frame_0001.vdb", "frame_0002.vdb", "frame_0003.vdb"]
    );
    let read = |p: &Path| {
        VdbReader::new(std::io::BufReader::new(std::fs::File::open(p).unwrap())).unwrap()
    };
    let mut r = read(&s.join("frame_0002.vdb"));
    let mut grids = r.available_grids();
    grids.sort();
    let manifest = sb.manifest("s");
    let gases: Vec<String> = manifest["extra"]["gases"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g.as_str().unwrap().to_string())
        .collect();
    let mut want: Vec<String> = gases.clone();
    // The slab-box's one gas is itself named `density`: no second grid.
    want.extend(["density".into(), "obstacle".into(), "vel".into()]);
    want.sort();
    want.dedup();
    assert_eq!(grids, want);
    let class = |r: &VdbReader<_>, g: &str| r.grid_descriptors[g].meta_data.0["class"].clone();
    assert_eq!(
        class(&r, "density"),
        MetadataValue::String("fog volume".into())
    );
    assert_eq!(
        class(&r, "obstacle"),
        MetadataValue::String("level set".into())
    );
    assert_eq!(r.header.meta_data.0["step"], MetadataValue::I64(4));
    // density = the sum of the gases, at every active voxel.
    let voxels = |r: &mut VdbReader<_>, g: &str| -> std::collections::HashMap<[i32; 3], f32> {
        r.read_grid::<f32>(g)
            .unwrap()
            .iter()
            .map(|(p, v, _)| ([p.x as i32, p.y as i32, p.z as i32], v))
            .collect()
    };
    let density = voxels(&mut r, "density");
    let sum = |p: &[i32; 3]| -> f32 {
        gases
            .iter()
            .map(|g| {
                let a: ndarray::Array3<f32> =
                    ndarray_npy::read_npy(s.join(format!("{g}_0004.npy"))).unwrap();
                a[[p[2] as usize, p[1] as usize, p[0] as usize]]
            })
            .sum()
    };
    assert!(density.values().any(|&v| v > 0.0));
    for (p, v) in density.iter().take(200) {
        assert!((v - sum(p)).abs() <= 1e-6 * v.abs().max(1.0), "{p:?}");
    }
    // The obstacle: φ = −O within the band, both signs present.
    let o: ndarray::Array3<f32> = ndarray_npy::read_npy(s.join("obstacle.npy")).unwrap();
    let cell = manifest["extra"]["grid"]["cell"].as_f64().unwrap() as f32;
    let level = voxels(&mut r, "obstacle");
    let (mut neg, mut pos) = (0, 0);
    for (p, &v) in &level {
        let want = -o[[p[2] as usize, p[1] as usize, p[0] as usize]];
        assert_eq!(v, want, "{p:?}");
        assert!(v.abs() < 3.0 * cell);
        if v < 0.0 {
            neg += 1
        } else {
            pos += 1
        }
    }
    assert!(neg > 0 && pos > 0, "{neg} inside, {pos} outside");
    // Deep inside the obstacle (O > 3Δx) nothing is active.
    let deep = o.indexed_iter().filter(|(_, &v)| v > 3.0 * cell).count();
    assert!(deep > 0);
    for ((k, j, i), &v) in o.indexed_iter() {
        if v > 3.0 * cell {
            assert!(!level.contains_key(&[i as i32, j as i32, k as i32]));
        }
    }

    // Hot/cold: `density` is the sum of hot and cold, or with
    // `--density-grid cold` the cold gas.
    let hc = [
        "run",
        "--res",
        "10",
        "--frames",
        "2",
        "--save-every",
        "1",
        "--vdb",
        "--quiet",
    ];
    for (out, extra) in [("sum", &[][..]), ("cold", &["--density-grid", "cold"][..])] {
        sb.ok(&[&hc[..], &["--out", out], extra].concat());
    }
    let mut sum = read(&d.join("sum/frame_0002.vdb"));
    let mut cold = read(&d.join("cold/frame_0002.vdb"));
    let (total, c) = (voxels(&mut sum, "density"), voxels(&mut cold, "density"));
    assert_eq!(c, voxels(&mut cold, "cold"));
    let (h, cs) = (voxels(&mut sum, "hot"), voxels(&mut sum, "cold"));
    assert!(h.values().any(|&v| v > 0.0) && cs.values().any(|&v| v > 0.0));
    for (p, v) in &total {
        let want = h.get(p).unwrap_or(&0.0) + cs.get(p).unwrap_or(&0.0);
        assert_eq!(*v, want, "{p:?}");
    }
}

/// A killed or failed run used to be exported as if whole; now it is
/// refused unless `--partial`, and a gas name in its manifest that is not a
/// plain file name (`../x`) is refused before it becomes a path.
#[test]
fn export_refuses_partial_runs_and_gas_names_that_are_paths() {
    let sb = Sandbox::new();
    sb.small_hot_cold_run("r", &["--save-every", "2"]);
    let edit = |f: &dyn Fn(&mut serde_json::Value)| {
        let mut m = sb.manifest("r");
        f(&mut m);
        std::fs::write(sb.join("r/manifest.json"), m.to_string()).unwrap();
    };
    for status in ["running", "failed"] {
        edit(&|m| m["status"] = serde_json::json!(status));
        for format in ["vdb", "paraview"] {
            sb.refused(
                &["export", format, "r"],
                &["run folder r is not complete", status, "--partial"],
            );
        }
    }
    assert!(!sb.join("r/run.pvd").exists() && !sb.join("r/frame_0001.vdb").exists());
    sb.ok(&["export", "paraview", "r", "--partial"]);
    assert!(sb.join("r/run.pvd").is_file());
    edit(&|m| m["status"] = serde_json::json!("complete"));
    for bad in ["../hot", "/etc/hot", ".hidden", "a/b"] {
        edit(&|m| m["extra"]["gases"][0] = serde_json::json!(bad));
        sb.refused(
            &["export", "vdb", "r", "--out", "x"],
            &["not a plain file name"],
        );
    }
    assert!(!sb.join("x").exists());
}
