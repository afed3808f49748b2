//! # the Fournier–Forand phase function (fig A.2)
//!
//! Reproduces fig A.2 of the notes: `P_FF(θ)` of eqs A.9–A.12 with
//! refractive index n = 1.05 for four Junge slopes μ, on log–log axes (θ from
//! 0.1° to 180°), the usual presentation of ocean-water phase functions.
//!
//! The caption prints μ = 0.35, 0.4, 0.45, 0.5. With those values
//! ν = (3 − μ)/2 > 1 and eq A.9 is negative at every angle (and its
//! integral over the sphere is of order −10²⁵), so they cannot be what the
//! figure shows; the Fournier–Forand literature (Mobley et al. 2002, the
//! Ocean Optics Web Book the notes cite) uses 3 < μ ≤ 5, and μ = 3.5, 4.0,
//! 4.5, 5.0 — the caption's values times ten — gives the familiar family of
//! forward-peaked curves. Those are plotted; the manifest records the
//! literal caption values' range as evidence. Petzold's measured curves of
//! the notes' figure are not reproduced: no data in the repository, and no
//! package found ships a published Petzold table (the crates.io, PyPI and
//! npm package lists and Debian's `apt-cache search` were searched for
//! "petzold", "volume scattering" and "phase function", Nov 2026).
//!
//! Run: `smokelab experiment A-2` (well under a second).
//!
//! Writes `results/A-2/`: `data.csv` (θ in degrees, one column per μ),
//! `fournier_forand.png`/`.svg`, and `manifest.json` with `∫ P dΩ` of every
//! curve and the check of the caption's literal μ values.

use anyhow::Result;
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::figures::plot::{Annotation, LegendPosition, Plot, Series};
use crate::figures::table::write_columns;
use smokelab::io;
use smokelab::render::phase::{self, Phase};

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "A-2",
    folder: "A-2",
    reproduces: "fig A.2",
    title: "Fournier–Forand phase function, n = 1.05, μ = 3.5…5",
    cost: "<1 s",
    run,
};

/// Relative refractive index of the notes' figure.
const N: f32 = 1.05;
/// Junge slopes plotted (the caption's 0.35…0.5 times ten, see the header).
const MU: [f32; 4] = [3.5, 4.0, 4.5, 5.0];
/// The caption's literal values.
const CAPTION_MU: [f64; 4] = [0.35, 0.4, 0.45, 0.5];
/// Angle samples, log-spaced from 0.1° to 180°.
const SAMPLES: usize = 400;
const THETA_MIN_DEG: f64 = 0.1;

#[derive(Serialize)]
struct Config {
    n: f32,
    mu: [f32; 4],
    samples: usize,
    theta_min_deg: f64,
}

#[derive(Serialize)]
struct Normalisation {
    mu: f32,
    sphere_integral: f64,
}

/// What eq A.9 gives for one of the caption's literal μ values.
#[derive(Serialize)]
struct CaptionCheck {
    mu: f64,
    nu: f64,
    min_over_angles: f64,
    max_over_angles: f64,
}

fn run(ctx: &Context) -> Result<()> {
    let start = std::time::Instant::now();
    let phases: Vec<Phase> = MU
        .iter()
        .map(|&mu| Phase::fournier_forand(N, mu))
        .collect::<Result<_, _>>()?;
    io::create_output_dir(&ctx.out)?;
    let mut cols = vec!["theta_deg".to_string()];
    cols.extend(MU.iter().map(|mu| format!("ff_mu{mu}")));
    let mut rows = Vec::new();
    let mut series: Vec<Vec<(f64, f64)>> = vec![vec![]; MU.len()];
    let angles: Vec<f64> = (0..SAMPLES)
        .map(|i| THETA_MIN_DEG * (180.0 / THETA_MIN_DEG).powf(i as f64 / (SAMPLES - 1) as f64))
        .collect();
    for &deg in &angles {
        let mut row = vec![deg];
        for (p, s) in phases.iter().zip(&mut series) {
            let v = p.eval_angle_f64(deg.to_radians());
            row.push(v);
            s.push((deg, v));
        }
        rows.push(row);
    }
    write_columns(&ctx.out.join("data.csv"), &cols, &rows)?;
    let mut plot = Plot::new(
        "Fournier–Forand phase function (eqs A.9–A.12), n = 1.05",
        "scattering angle θ [degrees]",
        "P_FF(θ) [1/sr]",
    )
    .log_x()
    .log_y()
    .x_range(THETA_MIN_DEG, 180.0)
    .annotate(Annotation::at_fraction(
        0.03,
        0.93,
        "μ = caption's 0.35…0.5 × 10 (the literal values make eq A.9 negative)",
    ));
    for (mu, pts) in MU.iter().zip(series) {
        plot = plot.series(Series::line(format!("μ = {mu}"), pts));
    }
    plot = plot.legend(LegendPosition::UpperRight);
    plot.write(&ctx.out.join("fournier_forand"))?;
    let norms: Vec<Normalisation> = MU
        .iter()
        .zip(&phases)
        .map(|(&mu, p)| Normalisation {
            mu,
            sphere_integral: p.sphere_integral(20_000),
        })
        .collect();
    let caption: Vec<CaptionCheck> = CAPTION_MU
        .iter()
        .map(|&mu| {
            let vals = angles
                .iter()
                .map(|d| phase::fournier_forand(N as f64, mu, d.to_radians()));
            CaptionCheck {
                mu,
                nu: (3.0 - mu) / 2.0,
                min_over_angles: vals.clone().fold(f64::INFINITY, f64::min),
                max_over_angles: vals.fold(f64::NEG_INFINITY, f64::max),
            }
        })
        .collect();
    let config = Config {
        n: N,
        mu: MU,
        samples: SAMPLES,
        theta_min_deg: THETA_MIN_DEG,
    };
    ctx.write_manifest(
        &config,
        0,
        start,
        serde_json::json!({ "normalisation": norms, "caption_mu_check": caption }),
    )
}
