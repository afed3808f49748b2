//! The modelling experiments (ch. 3–5, and 08-3) at smoke size: their tables say what
//! their headers promise.

mod common;
use common::smoke_experiment;

/// 05-1: `labels.npy` is int32 `(nz, ny, nx)`, one `pieces.csv` row per
/// label with its cell count, and the set counts add up to 2⁵.
#[test]
fn cut_sphere_writes_labels_and_pieces() {
    let dir = tempfile::tempdir().unwrap();
    let out = smoke_experiment(dir.path(), "05-1");
    let labels: ndarray::Array3<i32> = ndarray_npy::read_npy(out.join("labels.npy")).unwrap();
    assert_eq!(labels.dim(), (24, 24, 24));
    let mut rows = csv::Reader::from_path(out.join("pieces.csv")).unwrap();
    let pieces: Vec<csv::StringRecord> = rows.records().map(|r| r.unwrap()).collect();
    let max = *labels.iter().max().unwrap() as usize;
    assert_eq!(pieces.len(), max);
    for (i, p) in pieces.iter().enumerate() {
        let id: i32 = p[0].parse().unwrap();
        let cells: usize = p[2].parse().unwrap();
        assert_eq!(id as usize, i + 1);
        assert_eq!(labels.iter().filter(|&&l| l == id).count(), cells);
    }
    let mut data = csv::Reader::from_path(out.join("data.csv")).unwrap();
    let row = data.records().next().unwrap().unwrap();
    let (possible, non_empty, empty): (usize, usize, usize) = (
        row[0].parse().unwrap(),
        row[1].parse().unwrap(),
        row[2].parse().unwrap(),
    );
    assert_eq!((possible, non_empty + empty), (32, 32));
    assert!(out.join("exploded.png").is_file() && out.join("cut.png").is_file());
}

/// 04-1: the residual falls below 10⁻³ within three iterations, as the
/// notes say, at smoke size too.
#[test]
fn nacelle_residual_falls_within_three_iterations() {
    let dir = tempfile::tempdir().unwrap();
    let out = smoke_experiment(dir.path(), "04-1");
    let mut data = csv::Reader::from_path(out.join("data.csv")).unwrap();
    let worst: Vec<(usize, String, f64)> = data
        .records()
        .map(|r| {
            let r = r.unwrap();
            (
                r[0].parse().unwrap(),
                r[1].to_string(),
                r[2].parse().unwrap(),
            )
        })
        .collect();
    for variant in ["procedural", "cached"] {
        let r: Vec<f64> = worst
            .iter()
            .filter(|w| w.1 == variant)
            .map(|w| w.2)
            .collect();
        assert!(r[0] > 0.05, "{variant}: {r:?}");
        assert!(r[3] < 1e-3, "{variant}: {r:?}");
    }
    for f in ["object.obj", "reference.obj", "warped_1.obj", "warp.png"] {
        assert!(out.join(f).is_file(), "{f}");
    }
}

/// 08-3: a cloud at least five body diameters across, a wake cut through
/// it and the rest of it in place, and vorticity in the wake, the lifting
/// body's trailing vortices among it. Smoke size measured after the
/// passage (t = 10 D/U): width 6.5 D; 38 % of the mass in the corridor
/// (radius 1.5 D around the path) moved more than D, 10.2 % outside it
/// (mean displacement 0.52 D): asserted as under a third of the corridor's
/// share, which a wake dragging the whole cloud would fail; rms |ω| 0.30 U/D in the corridor against
/// 0.034 outside (the downwash reaches past the corridor's edge); rms
/// streamwise ω_x 0.21 U/D in the corridor (0.0005 without the lift).
#[test]
fn selma_wake_cuts_the_cloud_and_leaves_the_rest_in_place() {
    let dir = tempfile::tempdir().unwrap();
    let out = smoke_experiment(dir.path(), "08-3");
    let rows = common::table(&out.join("data.csv"));
    assert_eq!(rows.len(), 3);
    let at =
        |r: &std::collections::HashMap<String, String>, c: &str| -> f64 { r[c].parse().unwrap() };
    let before = &rows[0];
    let after = &rows[2];
    assert_eq!(at(before, "time"), 0.0);
    assert_eq!(at(after, "time"), 10.0);
    assert!(at(before, "width") >= 5.0, "width {}", at(before, "width"));
    // The rest of the cloud is in place, and it is a real share of the cloud.
    assert!(at(after, "outside_share") > 0.3, "{after:?}");
    assert!(
        at(after, "moved_outside") < at(after, "moved_inside") / 3.0,
        "{after:?}"
    );
    assert!(at(after, "mean_displacement_outside") < 0.6, "{after:?}");
    // The wake moved the cloud in the corridor, more with the passage.
    assert!(at(after, "moved_inside") > 0.2, "{after:?}");
    assert!(at(after, "moved_inside") > 3.0 * at(&rows[1], "moved_inside"));
    // Vorticity of order U/D lives in the wake, not outside it.
    assert!(at(after, "vorticity_rms_corridor") > 0.2, "{after:?}");
    assert!(at(after, "vorticity_peak") > 1.0, "{after:?}");
    assert!(
        at(after, "vorticity_rms_corridor") > 5.0 * at(after, "vorticity_rms_outside"),
        "{after:?}"
    );
    // The trailing vortices: streamwise vorticity, which the axisymmetric
    // wake of a sphere alone does not have.
    assert!(
        at(after, "streamwise_vorticity_rms_corridor") > 0.08,
        "{after:?}"
    );
    for f in [
        "wake.png",
        "slice.png",
        "section.png",
        "flow.png",
        "manifest.json",
    ] {
        assert!(out.join(f).is_file(), "no {f}");
    }
}

/// The column `name` of a `data.csv` as numbers, row by row.
fn column(out: &std::path::Path, name: &str) -> Vec<f64> {
    common::table(&out.join("data.csv"))
        .iter()
        .map(|r| r[name].parse().unwrap())
        .collect()
}

/// The labels are in the pixels: a panel row of `pixels`-high renders
/// gains a title line and a heading line above the panels.
fn assert_labelled(png: &std::path::Path, pixels: u32) {
    let img = image::open(png).unwrap();
    assert!(
        img.height() > pixels + 2 * 14,
        "{}: {}",
        png.display(),
        img.height()
    );
}

/// 03-3: the base panel is the Stanford bunny's signed distance: its
/// volume on the 16³ smoke grid is within 6 % (a cell of 0.14 is a tenth of
/// the bunny's width) of the 0.548 the scaled mesh encloses (divergence
/// theorem over its 3674 triangles), and each layer adds volume.
#[test]
fn cloud_layers_stand_on_the_bunny() {
    let dir = tempfile::tempdir().unwrap();
    let out = smoke_experiment(dir.path(), "03-3");
    let volume = column(&out, "volume");
    assert!((volume[0] - 0.548).abs() < 0.06 * 0.548, "{volume:?}");
    assert!(volume.windows(2).all(|w| w[1] > w[0]), "{volume:?}");
    assert_labelled(&out.join("layers.png"), 64);
}

/// 03-4: with `Q` set against the previous layer's amplitude (eq 3.8),
/// billow 2 leaves the cleared layers at most a quarter of the mean
/// displacement billow 0.33 leaves (measured: 0.216 at smoke size, 0.229 at
/// the default), and the share of the surface they leave bare (raised by
/// less than 0.01, shown white in the figure's second row) rises with
/// billow to most of it (smoke 0.22 → 0.85, default 0.26 → 0.84). Both
/// figures have a second row of panels under the whole clouds.
#[test]
fn large_billow_clears_the_canyons() {
    let dir = tempfile::tempdir().unwrap();
    let out = smoke_experiment(dir.path(), "03-4");
    let billow = column(&out, "billow");
    let cleared = column(&out, "displacement_cleared");
    let bare = column(&out, "bare_share");
    assert_eq!(billow, [0.33, 0.5, 0.67, 1.0, 2.0]);
    assert!(cleared[4] <= 0.25 * cleared[0], "{cleared:?}");
    assert!(bare.windows(2).all(|w| w[1] > w[0]), "{bare:?}");
    assert!(bare[4] >= 0.75 && bare[0] <= 0.35, "{bare:?}");
    assert_labelled(&out.join("billow.png"), 2 * 64);
    let out = smoke_experiment(dir.path(), "03-5");
    assert_labelled(&out.join("billow.png"), 2 * 64);
}

/// 03-7: strong advection frays the cloud. Measured on the cell averages
/// at smoke size (16³): the unadvected cloud is one piece; the soft share
/// (mass in cells with `0.1 < ρ̄ < 0.9`) grows from none to medium to
/// strong (0.41, 0.54, 0.72). At 16³ the detached pieces are finer than
/// a cell and average away (every panel one piece), so detachment is
/// measured at the default size only.
#[test]
fn strong_advection_softens_cloud() {
    let dir = tempfile::tempdir().unwrap();
    let out = smoke_experiment(dir.path(), "03-7");
    let pieces = column(&out, "pieces");
    let soft = column(&out, "soft_share");
    assert_eq!(pieces[0], 1.0, "{pieces:?}");
    assert!(soft[0] < soft[1] && soft[1] < soft[2], "{soft:?}");
    assert_labelled(&out.join("advection.png"), 64);
    let out = smoke_experiment(dir.path(), "03-8");
    assert_labelled(&out.join("control.png"), 64);
}
