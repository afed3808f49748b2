//! The sphere-wall experiments (figs 7.3–7.10, 8.1–8.2) end to end at smoke
//! size (16³ flow, 6 frames, 64×48 images): every picture shows coloured
//! rows and every `data.csv` holds what its experiment says (the cost
//! studies 07-10 and 08-2: `cost_studies.rs`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use smokelab_app::registry::{find, Context, Size};

fn run(dir: &Path, id: &str) -> PathBuf {
    let out = dir.join(id);
    let ctx = Context {
        out: out.clone(),
        size: Size::Smoke,
        progress: false,
    };
    (find(id).unwrap().run)(&ctx).unwrap_or_else(|e| panic!("{id}: {e:#}"));
    out
}

/// `data.csv` as rows of column → value.
fn table(path: &Path) -> Vec<HashMap<String, String>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    let cols: Vec<&str> = lines.next().unwrap().split(',').collect();
    lines
        .map(|l| {
            cols.iter()
                .zip(l.split(','))
                .map(|(c, v)| (c.to_string(), v.to_string()))
                .collect()
        })
        .collect()
}

fn num(row: &HashMap<String, String>, col: &str) -> f64 {
    row[col].parse().unwrap()
}

/// Bytes of one velocity grid at smoke size (16³ × 3 floats).
const VELOCITY_GRID: f64 = 16.0 * 16.0 * 16.0 * 12.0;

/// Pixels of `png` whose colour is clearly dominated by red, by green and by blue.
fn dominant_colours(png: &Path) -> [usize; 3] {
    let img = image::open(png).unwrap().to_rgb8();
    let mut n = [0; 3];
    for p in img.pixels() {
        let c = p.0.map(i32::from);
        for a in 0..3 {
            let (b, d) = ((a + 1) % 3, (a + 2) % 3);
            if c[a] > 60 && c[a] > c[b] + 30 && c[a] > c[d] + 30 {
                n[a] += 1;
            }
        }
    }
    n
}

#[test]
fn pictures_show_coloured_rows_and_record_their_holding() {
    let dir = tempfile::tempdir().unwrap();
    // id → (gridded frames, gridless frames, SELMA map cells, march step in cells⁻¹)
    let cases = [
        ("07-4", 6.0, 0.0, 0.0, 1.0),
        ("07-5", 5.0, 1.0, 0.0, 1.0),
        ("07-6", 5.0, 1.0, 0.0, 1.0),
        ("07-7", 5.0, 1.0, 0.0, 10.0),
        ("07-8", 0.0, 6.0, 0.0, 10.0),
        ("08-1", 0.0, 0.0, 16.0, 10.0),
    ];
    let cell = 10.0 / 16.0;
    let rows = 6.0;
    for (id, gridded, gridless, map, div) in cases {
        let out = run(dir.path(), id);
        for f in ["render.png", "initial_final.png", "manifest.json"] {
            assert!(out.join(f).is_file(), "{id}: no {f}");
        }
        let [r, g, b] = dominant_colours(&out.join("render.png"));
        assert!(
            r > 5 && g > 5 && b > 5,
            "{id}: rows not coloured: {r} red, {g} green, {b} blue pixels"
        );
        let t = table(&out.join("data.csv"));
        assert_eq!(t.len(), 1, "{id}: one data row");
        let row = &t[0];
        assert_eq!(num(row, "gridded_frames"), gridded, "{id}");
        assert_eq!(num(row, "gridless_frames"), gridless, "{id}");
        assert_eq!(num(row, "selma_map_res"), map, "{id}");
        assert!((num(row, "march_step") - cell / div).abs() < 1e-6, "{id}");
        let mass = num(row, "mass_kept");
        assert!((0.8..1.2).contains(&mass), "{id}: mass kept {mass}");
        assert!(num(row, "render_seconds") > 0.0 && num(row, "samples") > 0.0);
        // Memory: the row grids while anything is gridded, plus one
        // velocity grid per gridless frame.
        let bytes = num(row, "density_bytes");
        if map == 0.0 {
            let grids = if gridded > 0.0 {
                rows * VELOCITY_GRID / 3.0
            } else {
                0.0
            };
            assert_eq!(bytes, grids + gridless * VELOCITY_GRID, "{id}");
        } else {
            assert!(bytes > 0.0, "{id}");
        }
    }
}
