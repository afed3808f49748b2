//! # C-1 — convergence suite (observed orders of accuracy)
//!
//! Runs every study of `smokelab::convergence::cases` against its exact
//! solution, refining at a fixed CFL number, and fits the observed order by
//! least squares — the report behind "how accurate is it?". The CI runs the
//! same studies at smaller sizes (`tests/convergence.rs`).
//!
//! Run: `smokelab experiment C-1` (about a minute on 2 cores; `--full` adds a
//! finer level to every study; `--smoke` is the coarse subset).
//!
//! Writes `results/convergence/`: `<study>.csv` (h, error, rate), a log-log
//! plot per study with a slope guide of the expected order (`<study>.png`,
//! `.svg`), `orders.md` (the table for `paper/`), `manifest.json`.

use anyhow::Result;

use super::{Context, Experiment, Size};
use crate::advection::Backtrace;
use crate::convergence::cases::{self, Study};
use crate::io::{self, manifest::Manifest, CsvLog};
use crate::plot::{Annotation, Plot, Series, Style};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "C-1",
    folder: "convergence",
    reproduces: "orders of accuracy",
    title: "convergence suite: observed orders vs exact solutions, fixed CFL",
    cost: "~1 min",
    run,
};

/// Half-width of the band an observed order must fall in to pass.
const BAND: f64 = 0.25;

/// Resolutions per study family for a run size: `(advection 1D, rotation and
/// Taylor–Green, projection)`.
fn levels(size: Size) -> (Vec<usize>, Vec<usize>, Vec<usize>) {
    match size {
        Size::Smoke => (vec![32, 64, 128], vec![16, 32, 64], vec![16, 32]),
        Size::Default => (vec![32, 64, 128, 256, 512], vec![32, 64, 128, 256], vec![16, 32, 64, 128]),
        Size::Full => (
            vec![32, 64, 128, 256, 512, 1024],
            vec![32, 64, 128, 256, 512],
            vec![16, 32, 64, 128, 192],
        ),
    }
}

fn run(ctx: &Context) -> Result<()> {
    let start = std::time::Instant::now();
    let (line, plane, cube) = levels(ctx.size);
    io::create_output_dir(&ctx.out)?;
    let mut studies: Vec<Study> = vec![];
    for bt in Backtrace::ALL {
        studies.push(cases::sl_uniform(bt, &line));
        studies.push(cases::sl_rotation(bt, &plane));
    }
    studies.push(cases::taylor_green_sl(&plane));
    studies.push(cases::projection_discrete(&cube));
    let mut table = String::from(
        "| study | expected order | observed order | pairwise rates | within ±0.25 |\n|---|---|---|---|---|\n",
    );
    let mut summary = vec![];
    for s in &studies {
        let fit = s.fit();
        let mut csv = CsvLog::new(ctx.out.join(format!("{}.csv", s.name)), &["h", "error", "rate"]);
        for i in 0..s.h.len() {
            let rate = if i == 0 { f64::NAN } else { fit.rates[i - 1] };
            csv.push(&[s.h[i], s.error[i], rate]);
        }
        csv.flush()?;
        plot_study(ctx, s, fit.order)?;
        let ok = (fit.order - s.expected).abs() <= BAND;
        let rates: Vec<String> = fit.rates.iter().map(|r| format!("{r:.2}")).collect();
        table.push_str(&format!(
            "| {} | {} | {:.3} | {} | {} |\n",
            s.name,
            s.expected,
            fit.order,
            rates.join(", "),
            if ok { "yes" } else { "**no**" }
        ));
        summary.push(serde_json::json!({"study": s.name, "expected": s.expected, "observed": fit.order, "pass": ok}));
        if ctx.progress {
            eprintln!("{}: observed order {:.3} (expected {})", s.name, fit.order, s.expected);
        }
    }
    io::write_atomic(&ctx.out.join("orders.md"), |w| {
        use std::io::Write;
        Ok(w.write_all(table.as_bytes())?)
    })?;
    let config = serde_json::json!({"size": format!("{:?}", ctx.size), "band": BAND});
    io::write_json(
        &ctx.out.join("manifest.json"),
        &Manifest::new(config, 0, start.elapsed().as_secs_f64(), serde_json::json!(summary)),
    )
}

/// Log-log plot of error against h with a slope guide through the finest point.
fn plot_study(ctx: &Context, s: &Study, observed: f64) -> Result<()> {
    let points: Vec<(f64, f64)> = s.h.iter().copied().zip(s.error.iter().copied()).collect();
    let (h_fine, e_fine) = *points.last().expect("studies have levels");
    let guide: Vec<(f64, f64)> = s.h.iter().map(|&h| (h, e_fine * (h / h_fine).powf(s.expected))).collect();
    Plot::new(s.name.clone(), "h", "rms error")
        .log_x()
        .log_y()
        .series(Series::line("measured", points).styled(Style::LineMarkers))
        .series(Series::line(format!("slope {}", s.expected), guide).styled(Style::Dashed))
        .annotate(Annotation::at_fraction(0.05, 0.92, format!("observed order {observed:.2}")))
        .write(&ctx.out.join(&s.name))?;
    Ok(())
}
