//! The sphere-wall experiments (figs 7.3–7.10, 8.1–8.2) end to end at smoke
//! size (07-4 … 07-7: 24³ flow, 12 frames, 128×96 images; 07-8, 08-1: 16³,
//! 6 frames, 64×48): every picture shows its coloured rows in order, every
//! `data.csv` holds what its experiment says, and the figures of 07-4 … 07-7
//! show what the notes' captions say, measured (the cost studies 07-10 and
//! 08-2: `cost_studies.rs`).

mod common;
use common::{manifest, num, smoke_experiment as run, table};

use std::path::Path;

use image::RgbImage;

/// Bytes of one velocity grid of `res`³ cells (3 floats per cell).
fn velocity_grid(res: f64) -> f64 {
    res * res * res * 12.0
}

/// Of the pixels of `png` clearly dominated by red, by green and by blue:
/// how many, and their mean row (0 at the top).
fn dominant_colours(png: &Path) -> [(usize, f64); 3] {
    let img = image::open(png).unwrap().to_rgb8();
    let mut n = [(0, 0.0); 3];
    for (_, y, p) in img.enumerate_pixels() {
        let c = p.0.map(i32::from);
        for a in 0..3 {
            let (b, d) = ((a + 1) % 3, (a + 2) % 3);
            if c[a] > 60 && c[a] > c[b] + 30 && c[a] > c[d] + 30 {
                n[a].0 += 1;
                n[a].1 += y as f64;
            }
        }
    }
    n.map(|(k, y)| (k, y / k.max(1) as f64))
}

#[test]
fn pictures_show_coloured_rows_and_record_their_holding() {
    let dir = tempfile::tempdir().unwrap();
    // id → (flow cells per axis, gridded frames, gridless frames, SELMA map
    // cells, march step in cells⁻¹). 07-4 … 07-7 move the wall in the
    // passing flow at 24³ (a ball's radius 0.42 is about a cell), 07-8 and
    // 08-1 at 16³. The first panel of each is its own figure.
    let cases = [
        ("07-4", 24.0, 12.0, 0.0, 0.0, 1.0),
        ("07-5", 24.0, 11.0, 1.0, 0.0, 1.0),
        ("07-6", 24.0, 10.0, 2.0, 0.0, 1.0),
        ("07-7", 24.0, 10.0, 2.0, 0.0, 10.0),
        ("07-8", 16.0, 0.0, 6.0, 0.0, 10.0),
        ("08-1", 16.0, 0.0, 0.0, 16.0, 10.0),
    ];
    // Per case its first row's (mass kept, peak kept, mass sampled, mass
    // advected), for the relations between cases asserted after the loop.
    let mut kept = std::collections::BTreeMap::new();
    let rows = 6.0;
    for (id, res, gridded, gridless, map, div) in cases {
        let cell = 10.0 / res;
        let out = run(dir.path(), id);
        for f in [
            "render.png",
            "figure.png",
            "initial_final.png",
            "manifest.json",
        ] {
            assert!(out.join(f).is_file(), "{id}: no {f}");
        }
        // The rows, top to bottom red, orange, yellow, green, blue, purple:
        // red-dominated pixels lie above green ones, green above blue ones
        // (measured mean image rows 15–16, 26, 30–31 of 48 at 64×48), and
        // each colour covers at least 40 pixels (measured 198–457 red,
        // 56–68 green, 85–180 blue of 3072).
        let [r, g, b] = dominant_colours(&out.join("render.png"));
        assert!(
            r.1 + 5.0 < g.1 && g.1 + 2.0 < b.1,
            "{id}: rows out of order: mean rows red {r:?}, green {g:?}, blue {b:?}"
        );
        assert!(
            r.0 >= 40 && g.0 >= 40 && b.0 >= 40,
            "{id}: rows not coloured: {r:?} red, {g:?} green, {b:?} blue pixels"
        );
        let t = table(&out.join("data.csv"));
        let row = &t[0];
        assert_eq!(num(row, "gridded_frames"), gridded, "{id}");
        assert_eq!(num(row, "gridless_frames"), gridless, "{id}");
        assert_eq!(num(row, "selma_map_res"), map, "{id}");
        assert!((num(row, "march_step") - cell / div).abs() < 1e-6, "{id}");
        let (sampled, advected) = (num(row, "mass_sampled"), num(row, "mass_advected"));
        if gridded > 0.0 {
            assert!(sampled.is_finite() && advected.is_finite(), "{id}");
        } else {
            assert!(sampled.is_nan() && advected.is_nan(), "{id}");
        }
        let (mass, peak) = (num(row, "mass_kept"), num(row, "peak_kept"));
        kept.insert(id, (mass, peak, sampled, advected));
        assert!(num(row, "render_seconds") > 0.0 && num(row, "samples") > 0.0);
        // Memory: the row grids while anything is gridded, plus one
        // velocity grid per gridless frame.
        let bytes = num(row, "density_bytes");
        if map == 0.0 {
            let grids = if gridded > 0.0 {
                rows * velocity_grid(res) / 3.0
            } else {
                0.0
            };
            assert_eq!(bytes, grids + gridless * velocity_grid(res), "{id}");
        } else {
            assert!(bytes > 0.0, "{id}");
        }
    }
    // What resampling does to the wall, as relations between the cases
    // (no measured values): the gridded frames are the only ones that
    // resample, so
    let k = |id: &str| kept[id];
    let (m4, p4, s4, a4) = k("07-4");
    let (m5, p5, s5, a5) = k("07-5");
    let (m6, p6, s6, a6) = k("07-6");
    // – every gridded holding samples the same wall on the same cells, and
    //   balls a cell across gain mass when sampled at the cell centres;
    assert!(
        s4 == s5 && s5 == s6 && s4 > 1.0,
        "mass sampled {s4} {s5} {s6}"
    );
    // – semi-Lagrangian resampling in this flow gains mass, and more of it
    //   the more frames are gridded (12, 11, 10), both in the grid's own
    //   sum and at 2× sampling;
    assert!(
        a4 > a5 && a5 > a6 && a6 > 1.0,
        "mass advected {a4} {a5} {a6}"
    );
    assert!(m4 > m5 && m5 > m6 && m6 > 1.0, "mass kept {m4} {m5} {m6}");
    // – and loses the peak: the all-gridded wall keeps less than half of
    //   it, each gridless last frame keeps more;
    assert!(p4 < 0.5 && p4 < p5 && p5 < p6, "peak kept {p4} {p5} {p6}");
    // – 07-7 holds the wall as 07-6 does (only the march differs);
    assert_eq!(k("07-7"), k("07-6"), "07-7 holds the wall as 07-6");
    // – the gridless walk and SELMA's map never resample the density: they
    //   keep its peak, and its mass to within 10 % over six frames (their
    //   backward maps follow the interpolated velocity, which is not
    //   exactly divergence-free, so mass is not exact either).
    for id in ["07-8", "08-1"] {
        let (mass, peak, _, _) = k(id);
        assert!(peak > 0.9 && peak > p6, "{id}: peak kept {peak}");
        assert!((mass - 1.0).abs() < 0.1, "{id}: mass kept {mass}");
    }
}

/// The difference rows of each of 07-4 … 07-7 (name → panel minus panel).
fn differences(id: &str) -> &'static [&'static str] {
    match id {
        "07-4" | "07-7" => &["fixed − cell/10"],
        "07-5" => &["07-5 − 07-4"],
        _ => &["fixed − cell/10", "jittered − cell/10"],
    }
}

/// `figure.png` of a picture experiment shows what its caption and
/// manifest say: a row per panel and per difference, the differences'
/// amplifications as recorded, and in the first row the crop window
/// recorded in the manifest, zoomed 2× from `render.png`.
fn shows_its_crop_and_differences(id: &str, out: &Path, fig: &RgbImage, render: &RgbImage) {
    let extra = &manifest(out)["extra"];
    let panels = extra["panels"].as_array().unwrap().len();
    let gains: Vec<u64> = extra["difference_gains"]
        .as_array()
        .unwrap()
        .iter()
        .map(|g| g.as_u64().unwrap())
        .collect();
    let names = differences(id);
    assert_eq!(gains.len(), names.len(), "{id}: gains {gains:?}");
    // Every row is as high as a render, 6 px apart, under a title and a
    // line of headings.
    let rows = (panels + names.len()) as u32;
    let panel_rows = rows * render.height() + 6 * (rows - 1);
    assert!(
        fig.height() > panel_rows && fig.height() < panel_rows + 60,
        "{id}: figure {} px high for {rows} rows",
        fig.height()
    );
    let captions: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("figures.json")).unwrap()).unwrap();
    let caption = captions["figure.png"].as_str().unwrap();
    let crop: Vec<u32> = extra["crop"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as u32)
        .collect();
    let [x0, y0, w, h] = crop[..] else {
        panic!("{id}: crop {crop:?}")
    };
    assert_eq!((w, h), (render.width() / 2, render.height() / 2), "{id}");
    for (name, k) in names.iter().zip(&gains) {
        assert!(
            caption.contains(&format!("{name}, ×{k}")),
            "{id}: caption {caption:?} lacks {name}, ×{k}"
        );
    }
    assert!(
        caption.contains(&format!("crop 2×: x {x0}–{}, y {y0}–{}", x0 + w, y0 + h)),
        "{id}: caption {caption:?} does not place the crop at {crop:?}"
    );
    // The crop in the first row's second column is that window of the
    // render, each pixel doubled.
    let zoomed = RgbImage::from_fn(2 * w, 2 * h, |x, y| {
        *render.get_pixel(x0 + x / 2, y0 + y / 2)
    });
    let top = fig.height() - panel_rows;
    let found = (0..=fig.width() - zoomed.width()).any(|x| {
        (0..zoomed.height()).all(|y| {
            (0..zoomed.width()).all(|cx| fig.get_pixel(x + cx, top + y) == zoomed.get_pixel(cx, y))
        })
    });
    assert!(
        found,
        "{id}: the first row's crop is not the render at {crop:?}"
    );
}

/// The figures 07-4 … 07-7 show what the notes' captions say, measured at
/// smoke size (24³ passing flow, 12 frames of Δt 0.5, the last 2 gridless
/// in 07-6/07-7, 128×96 renders; 16³ with 6 frames cannot tell 07-6's
/// holding from 07-5's, both one gridless frame):
/// - fig 7.5 "subtly sharpened", fig 7.7 "resolved": the gradient energy
///   of each figure (its first panel) orders 07-4 < 07-5 < 07-7 (measured
///   71.02, 75.12, 80.25 grey levels²: +5.8 %, +6.8 %; 07-7 13 % above
///   07-4);
/// - fig 7.6, the fixed-step march's error against the fine march is a
///   pattern (coherent share measured 0.64);
/// - the gridless frames make that pattern: 07-6's coherent error 0.758
///   grey levels against the gridded 07-4's 0.481 under the same march
///   (×1.58) and the jittered march's 0.525 (×1.44, its error noise).
#[test]
fn chapter_7_figures_sharpen_and_alias_as_captioned() {
    let dir = tempfile::tempdir().unwrap();
    let first = |id: &str| {
        let out = run(dir.path(), id);
        // The figure is labelled: a margin left of the panels for the row
        // names, a line over them for the headings and title.
        let fig = image::open(out.join("figure.png")).unwrap().to_rgb8();
        let render = image::open(out.join("render.png")).unwrap().to_rgb8();
        assert!(
            fig.width() > 2 * render.width() + 40 && fig.height() > render.height() + 20,
            "{id}: figure {:?} has no room for labels beside renders {:?}",
            fig.dimensions(),
            render.dimensions()
        );
        shows_its_crop_and_differences(id, &out, &fig, &render);
        table(&out.join("data.csv"))
    };
    let (t4, t5, t6, t7) = (first("07-4"), first("07-5"), first("07-6"), first("07-7"));
    let sharp = |t: &[std::collections::HashMap<String, String>]| num(&t[0], "sharpness");
    let (s4, s5, s7) = (sharp(&t4), sharp(&t5), sharp(&t7));
    assert!(
        1.03 * s4 < s5 && 1.03 * s5 < s7 && 1.1 * s4 < s7,
        "sharpness 07-4 {s4}, 07-5 {s5}, 07-7 {s7}: not increasing by 3 % each, 10 % in all"
    );
    // 07-6: fixed step cell, jittered step cell, fixed step cell/10.
    let (fixed, jittered) = (&t6[0], &t6[1]);
    assert_eq!(
        (fixed["jitter"].as_str(), jittered["jitter"].as_str()),
        ("false", "true")
    );
    let share = |r: &std::collections::HashMap<String, String>| num(r, "coherent_share");
    assert!(
        share(fixed) > 0.55,
        "fixed march error not coherent: {}",
        share(fixed)
    );
    assert!(
        share(jittered) < 0.15,
        "jittered march error coherent: {}",
        share(jittered)
    );
    assert!(num(jittered, "error_rms") > 3.0 * num(fixed, "error_rms"));
    let (c4, c6) = (num(&t4[0], "coherent_error"), num(fixed, "coherent_error"));
    let cj = num(jittered, "coherent_error");
    assert!(c6 > 1.3 * c4, "coherent error 07-6 {c6} vs 07-4 {c4}");
    assert!(c6 > 1.2 * cj, "coherent error 07-6 {c6} vs jittered {cj}");
}

/// 07-4 sets the wall advected by MacCormack beside the notes'
/// semi-Lagrangian figure: its own row of `data.csv`, gridded every frame,
/// its numbers finite, and — as at the default 50³ (peak 84 % against
/// 56 %, sharpness 7.10 against 5.00) — sharper than SL with more of the
/// rows' peaks kept. Measured at smoke size: peak kept 0.477 against
/// 0.236, sharpness 83.6 against 71.0 grey levels²; the mass is not kept
/// by either (advection ×1.62 against ×1.19).
#[test]
fn sphere_wall_07_4_has_a_maccormack_row_sharper_than_sl() {
    let dir = tempfile::tempdir().unwrap();
    let t = table(&run(dir.path(), "07-4").join("data.csv"));
    let names: Vec<&str> = t.iter().map(|r| r["panel"].as_str()).collect();
    assert_eq!(
        names,
        [
            "fixed step cell",
            "fixed step cell/10",
            "MacCormack fixed step cell"
        ]
    );
    let (sl, mac) = (&t[0], &t[2]);
    assert_eq!(num(mac, "gridded_frames"), 12.0);
    assert_eq!(num(mac, "gridless_frames"), 0.0);
    for col in [
        "mass_kept",
        "peak_kept",
        "mass_sampled",
        "mass_advected",
        "sharpness",
    ] {
        assert!(num(mac, col).is_finite(), "MacCormack {col} = {}", mac[col]);
    }
    // Both sample the same wall at frame 0.
    assert_eq!(mac["mass_sampled"], sl["mass_sampled"]);
    let (p_sl, p_mac) = (num(sl, "peak_kept"), num(mac, "peak_kept"));
    assert!(p_mac > p_sl, "peak kept: MacCormack {p_mac}, SL {p_sl}");
    let (s_sl, s_mac) = (num(sl, "sharpness"), num(mac, "sharpness"));
    assert!(s_mac > s_sl, "sharpness: MacCormack {s_mac}, SL {s_sl}");
}
