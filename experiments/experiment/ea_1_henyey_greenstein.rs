//! # the Henyey–Greenstein phase function (fig A.1)
//!
//! Reproduces fig A.1 of the notes: `P_HG(θ)` of eq A.8 for
//! g = 0.99, 0.5, −0.5, −0.99 against the scattering angle θ between the
//! view ray and the direction to the light (θ = 0: looking into the light),
//! on a logarithmic axis — the four curves span seven decades. Positive g
//! peaks forward, negative g backward, and each curve is the mirror image of
//! its −g partner.
//!
//! Run: `smokelab experiment A-1` (well under a second).
//!
//! Writes `results/A-1/`: `data.csv` (θ in degrees, cos θ, one column per
//! g), `henyey_greenstein.png`/`.svg`, and `manifest.json` with
//! `∫ P dΩ` of every curve (1 up to quadrature error).

use anyhow::Result;
use serde::Serialize;

use crate::experiment::kit::{Context, Experiment};
use crate::figures::plot::{Annotation, LegendPosition, Plot, Series};
use crate::figures::table::write_columns;
use smokelab::io;
use smokelab::render::phase::Phase;

/// Registry entry.
pub const EXPERIMENT: Experiment = Experiment {
    id: "A-1",
    folder: "A-1",
    reproduces: "fig A.1",
    title: "Henyey–Greenstein phase function, g = ±0.5, ±0.99",
    cost: "<1 s",
    run,
};

/// The notes' asymmetry parameters.
const G: [f32; 4] = [0.99, 0.5, -0.5, -0.99];
/// Angle samples from 0° to 180°.
const SAMPLES: usize = 721;

#[derive(Serialize)]
struct Config {
    g: [f32; 4],
    samples: usize,
}

#[derive(Serialize)]
struct Normalisation {
    g: f32,
    sphere_integral: f64,
}

fn run(ctx: &Context) -> Result<()> {
    let start = std::time::Instant::now();
    let phases: Vec<Phase> = G
        .iter()
        .map(|&g| Phase::henyey_greenstein(g))
        .collect::<Result<_, _>>()?;
    io::create_output_dir(&ctx.out)?;
    let mut cols = vec!["theta_deg".to_string(), "cos_theta".to_string()];
    cols.extend(G.iter().map(|g| format!("hg_g{g}")));
    let mut rows = Vec::new();
    let mut series: Vec<Vec<(f64, f64)>> = vec![vec![]; G.len()];
    for i in 0..SAMPLES {
        let deg = 180.0 * i as f64 / (SAMPLES - 1) as f64;
        let c = deg.to_radians().cos();
        let mut row = vec![deg, c];
        for (p, s) in phases.iter().zip(&mut series) {
            let v = p.eval_f64(c);
            row.push(v);
            s.push((deg, v));
        }
        rows.push(row);
    }
    write_columns(&ctx.out.join("data.csv"), &cols, &rows)?;
    let mut plot = Plot::new(
        "Henyey–Greenstein phase function (eq A.8)",
        "scattering angle θ between view ray and light direction [degrees]",
        "P_HG(θ) [1/sr]",
    )
    .log_y()
    .x_range(0.0, 180.0)
    .legend(LegendPosition::UpperMiddle)
    .annotate(Annotation::at_fraction(
        0.3,
        0.3,
        "each curve integrates to 1 over the sphere",
    ));
    for (g, pts) in G.iter().zip(series) {
        plot = plot.series(Series::line(format!("g = {g}"), pts));
    }
    plot.write(&ctx.out.join("henyey_greenstein"))?;
    let norms: Vec<Normalisation> = G
        .iter()
        .zip(&phases)
        .map(|(&g, p)| Normalisation {
            g,
            sphere_integral: p.sphere_integral(20_000),
        })
        .collect();
    let config = Config {
        g: G,
        samples: SAMPLES,
    };
    ctx.write_manifest(
        &config,
        0,
        start,
        serde_json::json!({ "normalisation": norms }),
    )
}
