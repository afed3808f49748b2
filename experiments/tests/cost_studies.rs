//! The cost studies 07-10 (fig 7.10) and 08-2 (fig 8.2) at smoke size (16³
//! flow, 6 frames, 64×48 images): memory is *measured* (heap high-water
//! mark, `smokelab_app::experiment::shared::memory`) and must grow by about one velocity grid
//! per gridless frame and stay flat for SELMA; render work must grow with
//! the gridless chain (the walk steps counted) and not with SELMA's frames.
//! Render times are asserted on the committed default-size studies
//! (`results_provenance.rs`, the data gate), not here.
//!
//! One test in this binary: the measurements are process-wide, so nothing
//! else may run beside them.

mod common;
use common::{num, smoke_experiment, table};

use std::collections::HashMap;
use std::path::Path;

use smokelab_app::experiment::shared::growth::{classify, Criteria, Growth, Trend};

/// `(frames, column)` of one series, by frames.
fn series(t: &[HashMap<String, String>], name: &str, col: &str) -> Vec<(f64, f64)> {
    let mut s: Vec<(f64, f64)> = t
        .iter()
        .filter(|r| r["series"] == name)
        .map(|r| (num(r, "frames"), num(r, col)))
        .collect();
    s.sort_by(|a, b| a.0.total_cmp(&b.0));
    s
}

/// Bytes of one velocity grid at smoke size as the counted bytes hold it
/// (16³ × 3 floats); the faces array is 17 × 16 × 16 per component, 6 %
/// more.
const VELOCITY_GRID: f64 = 16.0 * 16.0 * 16.0 * 12.0;

/// Linear: grows by ≥ 20 % of its mean over the frames, r² ≥ 0.95; flat:
/// within ±15 % (SELMA's measured heap: −7.9 %, its unadvected point 14 %
/// above the rest).
const C: Criteria = Criteria {
    min_growth: 0.2,
    min_r2: 0.95,
    max_flat: 0.15,
};

fn growth(points: &[(f64, f64)], what: &str) -> Growth {
    classify(points, &C).unwrap_or_else(|| panic!("{what}: no fit of {points:?}"))
}

fn run(dir: &Path, id: &str) -> Vec<HashMap<String, String>> {
    let out = smoke_experiment(dir, id);
    for f in [
        "time.png",
        "memory.png",
        "rss.png",
        "costs.png",
        "summary.csv",
    ] {
        assert!(out.join(f).is_file(), "{id}: no {f}");
    }
    table(&out.join("data.csv"))
}

#[test]
fn measured_memory_grows_one_grid_per_gridless_frame_and_is_flat_for_selma() {
    let dir = tempfile::tempdir().unwrap();

    // 07-10: gridded for F − k frames, gridless for k.
    let t = run(dir.path(), "07-10");
    assert_eq!(t.len(), 14, "two marches × k = 0…6");
    for name in ["march=cell", "march=cell/10"] {
        let counted = growth(&series(&t, name, "density_bytes"), name);
        assert_eq!(counted.fit.slope, VELOCITY_GRID, "{name}: counted");
        let heap = growth(&series(&t, name, "heap_peak_bytes"), name);
        // Measured: 1.10 and 1.15 grids per frame (the faces array is 1.06
        // grids, plus the chain's per-frame state), r² 0.990 and 0.995 —
        // but 0.972 in one CI run: at 16³ a grid is 48 KiB, near the noise
        // of the render's per-task buffers. The fit's r² is asserted on the
        // committed default-size study (`results_provenance.rs`, the data gate), as the RSS is.
        let per_frame = heap.fit.slope / VELOCITY_GRID;
        assert_eq!(heap.trend, Trend::Linear, "{name}: heap {heap:?}");
        assert!(
            (1.0..1.3).contains(&per_frame),
            "{name}: heap grows {per_frame} grids per frame, r² {}",
            heap.r2
        );
    }
    // RSS is not asserted at smoke size: a 16³ grid is 12 pages, below the
    // noise of the allocator's arenas (measured 1.3–1.5 grids per frame,
    // r² 0.91–0.98, in most runs, but 0.39 and r² 0.36 in one CI run); it is
    // asserted on the committed default-size study (`results_provenance.rs`, the data gate).
    // The render work: the same samples at every k, ten times as many with
    // the tenfold finer march; what grows with the chain is counted, the
    // backward steps walked (`walk_steps`, points mapped × k). The render
    // time is fitted and reported by the experiment (`summary.csv`), not
    // asserted here: wall time on a shared machine.
    let samples = series(&t, "march=cell", "samples");
    assert!(samples.iter().all(|s| s.1 == samples[0].1), "{samples:?}");
    let fine = series(&t, "march=cell/10", "samples")[0].1;
    let ratio = fine / samples[0].1;
    assert!((8.0..12.0).contains(&ratio), "fine/coarse samples {ratio}");
    // Measured: 34 118 steps per gridless frame on the coarse march (30 022
    // samples), 292 754 on the fine (288 658): the samples plus the 4096
    // points of the light grid, each walked once for all rows (the memo),
    // the same count at every k (exactly k × the k = 1 count, r² = 1).
    let mut excess = vec![];
    for (name, n) in [("march=cell", samples[0].1), ("march=cell/10", fine)] {
        let walk = series(&t, name, "walk_steps");
        let per_frame = walk[1].1;
        for &(k, steps) in &walk {
            assert_eq!(steps, k * per_frame, "{name}: walk steps {walk:?}");
        }
        let g = growth(&walk, name);
        assert!(
            g.trend == Trend::Linear && g.fit.slope > 0.0 && g.r2 > 0.9999,
            "{name}: walk steps {walk:?}: {g:?}"
        );
        let per_sample = g.fit.slope / n;
        assert!(
            (1.0..1.2).contains(&per_sample),
            "{name}: {per_sample} walks per sample and gridless frame"
        );
        excess.push(per_frame - n);
    }
    assert_eq!(excess[0], excess[1], "walks beyond the samples: {excess:?}");

    // 08-2: gridless through n frames, SELMA and SELMA^fine after n.
    let t = run(dir.path(), "08-2");
    assert_eq!(t.len(), 21, "three holdings × n = 0…6");
    let heap = growth(&series(&t, "gridless", "heap_peak_bytes"), "gridless");
    let per_frame = heap.fit.slope / VELOCITY_GRID;
    // Measured: 1.12 grids per frame, r² 0.991.
    assert!(
        heap.trend == Trend::Linear && (1.0..1.3).contains(&per_frame) && heap.r2 > 0.98,
        "gridless heap {per_frame} grids per frame: {heap:?}"
    );
    for name in ["selma", "selma-fine"] {
        let points = series(&t, name, "heap_peak_bytes");
        let heap = growth(&points, name);
        // Measured: −7.9 % (SELMA) and 0.03 % (SELMA^fine) over the frames.
        assert_eq!(
            heap.trend,
            Trend::Flat,
            "{name}: heap {heap:?} of {points:?}"
        );
    }
    let at = |name: &str, col: &str| series(&t, name, col)[6].1;
    // SELMA^fine holds a map eight times as large: measured 5.5× the heap.
    let fine_over = at("selma-fine", "heap_peak_bytes") / at("selma", "heap_peak_bytes");
    assert!(fine_over > 4.0, "selma-fine/selma heap {fine_over}");
    // The render work, counted (time is wall time on a shared machine: a
    // CI run under load measured SELMA's last render at 2.4× its first; the
    // time fits are asserted on the committed default-size study,
    // `results_provenance.rs`, the data gate): the gridless chain walks k steps per point mapped,
    // exactly k × the one-frame count; SELMA walks none at any k.
    let walk = series(&t, "gridless", "walk_steps");
    assert!(walk[1].1 > 0.0, "gridless walks: {walk:?}");
    for &(k, steps) in &walk {
        assert_eq!(steps, k * walk[1].1, "gridless walk steps {walk:?}");
    }
    for name in ["selma", "selma-fine"] {
        let s = series(&t, name, "walk_steps");
        assert!(s.iter().all(|p| p.1 == 0.0), "{name} walks: {s:?}");
    }
}
