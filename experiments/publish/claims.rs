//! The notes' claims against the committed results: each claim reads its
//! numbers from a file under `results/` and states whether it holds.
//!
//! `smokelab paper` writes [`table`] into the paper's `claims` block, so the
//! verdicts are recomputed whenever the results are regenerated; a test
//! checks that the committed paper and the committed results agree. A
//! verdict is a fixed rule on the numbers (stated in the "rule" column), not
//! a judgement made after seeing them.

use std::path::Path;

use anyhow::{anyhow, bail, Context, Result};

/// Whether a claim holds on our measurements.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Every part of the claim holds.
    Holds,
    /// Some parts hold and some do not.
    Partly,
    /// The measurement contradicts the claim.
    DoesNotHold,
}

impl Verdict {
    /// `Holds` if every part holds, `DoesNotHold` if none does, else `Partly`.
    pub fn of(parts: &[bool]) -> Self {
        match parts.iter().filter(|&&p| p).count() {
            n if n == parts.len() => Verdict::Holds,
            0 => Verdict::DoesNotHold,
            _ => Verdict::Partly,
        }
    }

    fn text(self) -> &'static str {
        match self {
            Verdict::Holds => "holds",
            Verdict::Partly => "partly",
            Verdict::DoesNotHold => "does not hold",
        }
    }
}

/// What one claim's measurement found.
pub struct Finding {
    /// Our numbers, as they go in the table.
    pub number: String,
    /// The verdict of the claim's rule on them.
    pub verdict: Verdict,
}

/// One claim of the notes and how it is measured.
pub struct Claim {
    /// The claim, with the section of the notes that makes it.
    pub claim: &'static str,
    /// The results file the numbers come from (relative to `results/`).
    pub source: &'static str,
    /// The rule that turns the numbers into a verdict.
    pub rule: &'static str,
    /// Reads the numbers from `results/` and applies the rule.
    pub measure: fn(&Path) -> Result<Finding>,
}

/// A CSV file read as text cells by column name.
struct Csv {
    path: String,
    columns: Vec<String>,
    rows: Vec<Vec<String>>,
}

impl Csv {
    fn read(results: &Path, file: &str) -> Result<Self> {
        let path = results.join(file);
        let mut r = csv::Reader::from_path(&path)
            .with_context(|| format!("cannot read {}", path.display()))?;
        let columns = r.headers()?.iter().map(String::from).collect();
        let rows = r
            .records()
            .map(|rec| Ok(rec?.iter().map(String::from).collect()))
            .collect::<Result<Vec<Vec<String>>>>()?;
        Ok(Self {
            path: path.display().to_string(),
            columns,
            rows,
        })
    }

    fn index(&self, column: &str) -> Result<usize> {
        self.columns
            .iter()
            .position(|c| c == column)
            .ok_or_else(|| anyhow!("{} has no column {column}", self.path))
    }

    /// The text of `column` in the first row matching every `(key, value)`.
    fn cell(&self, keys: &[(&str, &str)], column: &str) -> Result<String> {
        let at = keys
            .iter()
            .map(|&(k, v)| Ok((self.index(k)?, v)))
            .collect::<Result<Vec<_>>>()?;
        let c = self.index(column)?;
        let row = self
            .rows
            .iter()
            .find(|r| at.iter().all(|&(k, v)| r[k] == v))
            .ok_or_else(|| anyhow!("{} has no row with {keys:?}", self.path))?;
        Ok(row[c].clone())
    }

    /// [`Self::cell`] as a number.
    fn number(&self, keys: &[(&str, &str)], column: &str) -> Result<f64> {
        let text = self.cell(keys, column)?;
        text.parse()
            .with_context(|| format!("{}: {column} = {text} is not a number", self.path))
    }

    /// The value of `column` in the row whose `key` column is `value`.
    fn get(&self, key: &str, value: &str, column: &str) -> Result<f64> {
        self.number(&[(key, value)], column)
    }

    /// Every value of `column`, as numbers.
    fn numbers(&self, column: &str) -> Result<Vec<f64>> {
        let c = self.index(column)?;
        self.rows
            .iter()
            .map(|r| {
                r[c].parse()
                    .with_context(|| format!("{}: {column} = {} is not a number", self.path, r[c]))
            })
            .collect()
    }
}

/// Hot-gas measures per density mode from 06-3's summary.
fn modes(results: &Path) -> Result<Csv> {
    Csv::read(results, "06-3/summary.csv")
}

/// The gridded baselines of 06-3 a detail claim is measured against: the
/// notes' semi-Lagrangian advection and MacCormack (Selle et al. 2008), the
/// stronger gridded scheme; each row's mode and its name in the table.
const GRIDDED: [(&str, &str); 2] = [("gridded", "SL"), ("gridded-maccormack", "MacCormack")];

fn finer_structure(results: &Path) -> Result<Finding> {
    let t = modes(results)?;
    let (mut parts, mut text) = (vec![], vec![]);
    for (mode, name) in GRIDDED {
        let grad = t.get("mode", "gridless", "hot_grad")? / t.get("mode", mode, "hot_grad")?;
        let sub = t.get("mode", "gridless", "hot_subgrid")? / t.get("mode", mode, "hot_subgrid")?;
        parts.extend([grad > 1.0, sub > 1.0]);
        text.push(format!(
            "gridless/{name}: mean |∇ρ| ×{grad:.2}, sub-grid share ×{sub:.0}"
        ));
    }
    Ok(Finding {
        number: text.join("; "),
        verdict: Verdict::of(&parts),
    })
}

fn selma_between(results: &Path) -> Result<Finding> {
    let t = modes(results)?;
    let (mut parts, mut text) = (vec![], vec![]);
    for (column, measure) in [("hot_grad", "mean |∇ρ|"), ("hot_subgrid", "sub-grid share")] {
        let (b, c) = (
            t.get("mode", "selma", column)?,
            t.get("mode", "gridless", column)?,
        );
        let mut grids = vec![];
        for (mode, name) in GRIDDED {
            let a = t.get("mode", mode, column)?;
            parts.push(a < b && b < c);
            grids.push(format!("{name} {a:.4}"));
        }
        text.push(format!(
            "{measure} {} < SELMA {b:.4} < gridless {c:.4}",
            grids.join(", ")
        ));
    }
    Ok(Finding {
        number: format!("gridded < SELMA < gridless? {}", text.join("; ")),
        verdict: Verdict::of(&parts),
    })
}

fn keeps_peak(results: &Path) -> Result<Finding> {
    let t = modes(results)?;
    let less = t.get("mode", "gridless", "hot_max")?;
    let (mut parts, mut text) = (vec![], vec![format!("peak ρ gridless {less:.2}")]);
    for (mode, name) in GRIDDED {
        let grid = t.get("mode", mode, "hot_max")?;
        parts.push(less > grid);
        text.push(format!("gridded {name} {grid:.2}"));
    }
    Ok(Finding {
        number: text.join(", "),
        verdict: Verdict::of(&parts),
    })
}

fn keeps_mass(results: &Path) -> Result<Finding> {
    let t = modes(results)?;
    let kept = |m| -> Result<f64> {
        Ok(t.get("mode", m, "hot_mass_4x")? / t.get("mode", m, "hot_injected")?)
    };
    let less = kept("gridless")?;
    let mut parts = vec![];
    let mut text = vec![format!("mass / injected: gridless {:.1} %", 100.0 * less)];
    for (mode, name) in GRIDDED {
        let grid = kept(mode)?;
        parts.push((less - 1.0).abs() < (grid - 1.0).abs());
        text.push(format!("gridded {name} {:.1} %", 100.0 * grid));
    }
    Ok(Finding {
        number: text.join(", "),
        verdict: Verdict::of(&parts),
    })
}

/// The panel of the sphere-wall figures marched as the notes' figs 7.4–7.6.
const COARSE: &str = "fixed step cell";

/// The panels of 07-4 holding the wall gridded, each with its name in the
/// table: the notes' semi-Lagrangian (the figure) and MacCormack.
const WALL_GRIDDED: [(&str, &str); 2] =
    [(COARSE, "SL"), ("MacCormack fixed step cell", "MacCormack")];

fn sphere_wall_loss(results: &Path) -> Result<Finding> {
    let t = Csv::read(results, "07-4/data.csv")?;
    let (mut parts, mut text) = (vec![], vec![]);
    for (panel, name) in WALL_GRIDDED {
        let mass = t.get("panel", panel, "mass_kept")?;
        let peak = t.get("panel", panel, "peak_kept")?;
        parts.extend([mass < 0.95, peak < 0.95]);
        text.push(format!(
            "{name} keeps {:.1} % of its mass, {:.1} % of its peak",
            100.0 * mass,
            100.0 * peak
        ));
    }
    Ok(Finding {
        number: format!("gridded wall: {}", text.join("; ")),
        verdict: Verdict::of(&parts),
    })
}

/// The sharpness (gradient energy) of the first panel of a sphere-wall
/// picture experiment: its own figure.
fn figure_sharpness(results: &Path, id: &str) -> Result<f64> {
    let t = Csv::read(results, &format!("{id}/data.csv"))?;
    t.numbers("sharpness")?
        .first()
        .copied()
        .ok_or_else(|| anyhow!("{id}/data.csv has no rows"))
}

fn gridless_sharpens(results: &Path) -> Result<Finding> {
    let [a, b, c] = ["07-4", "07-5", "07-7"].map(|id| figure_sharpness(results, id));
    let (a, b, c) = (a?, b?, c?);
    Ok(Finding {
        number: format!("gradient energy 07-4 {a:.2} < 07-5 {b:.2} < 07-7 {c:.2} grey levels²"),
        verdict: Verdict::of(&[a < b, b < c]),
    })
}

fn coarse_march_aliases(results: &Path) -> Result<Finding> {
    let coherent = |id: &str| {
        Csv::read(results, &format!("{id}/data.csv"))?.get("panel", COARSE, "coherent_error")
    };
    let (gridded, gridless) = (coherent("07-4")?, coherent("07-6")?);
    Ok(Finding {
        number: format!(
            "coherent error of the cell march: 10 gridless frames {gridless:.2}, all gridded {gridded:.2} grey levels (×{:.2})",
            gridless / gridded
        ),
        verdict: Verdict::of(&[gridless > 2.0 * gridded]),
    })
}

fn gridless_cost_grows(results: &Path) -> Result<Finding> {
    let t = Csv::read(results, "08-2/summary.csv")?;
    let trend = |series: &str, quantity: &str| {
        t.cell(&[("series", series), ("quantity", quantity)], "trend")
    };
    let mut parts = vec![];
    let mut text = vec![];
    for (series, want) in [("gridless", "linear"), ("selma", "flat")] {
        let mut found = vec![];
        for (quantity, name) in [
            ("render_seconds", "time"),
            ("heap_mib", "heap"),
            ("rss_mib", "RSS"),
        ] {
            let got = trend(series, quantity)?;
            parts.push(got == want);
            found.push(format!("{name} {got}"));
        }
        text.push(format!("{series}: {}", found.join(", ")));
    }
    let slope = t.number(&[("series", "gridless"), ("quantity", "rss_mib")], "slope")?;
    Ok(Finding {
        number: format!(
            "{} (gridless RSS +{slope:.3} MiB per frame)",
            text.join("; ")
        ),
        verdict: Verdict::of(&parts),
    })
}

fn symmetry_better(results: &Path) -> Result<Finding> {
    let t = Csv::read(results, "S-1/summary.csv")?;
    let ratio = |scheme: &str, column: &str| {
        let keys = [
            ("case", "quarter-cell"),
            ("scheme", scheme),
            ("mode", "gridless"),
        ];
        t.number(&keys, column)
    };
    let mut parts = vec![];
    let mut text = vec![];
    // Gridless against gridded with the same scheme, and gridless SL
    // against gridded MacCormack (as the 06-3 claims, both gridded
    // baselines).
    for (scheme, to, name) in [
        ("sl", "gridded", "SL"),
        ("quick", "gridded", "QUICK"),
        ("sl", "maccormack", "MacCormack"),
    ] {
        let (err, drift) = (
            ratio(scheme, &format!("ratio_to_{to}"))?,
            ratio(scheme, &format!("drift_ratio_to_{to}"))?,
        );
        parts.extend([err < 1.0, drift < 1.0]);
        text.push(format!("{name}: error ×{err:.2}, drift ×{drift:.2}"));
    }
    Ok(Finding {
        number: format!(
            "gridless/gridded, sources ¼ cell off the mirror: {}",
            text.join("; ")
        ),
        verdict: Verdict::of(&parts),
    })
}

fn noise_costs(results: &Path) -> Result<Finding> {
    let t = Csv::read(results, "N-3/costs.csv")?;
    let [fast, value, smooth] =
        ["fast-sim", "value", "smooth-sim"].map(|k| t.get("kind", k, "ns_per_eval"));
    let (fast, value, smooth) = (fast?, value?, smooth?);
    Ok(Finding {
        number: format!(
            "ns per evaluation (3D): fast {fast:.1}, value {value:.1}, smooth {smooth:.1}"
        ),
        verdict: Verdict::of(&[fast < value, value < smooth]),
    })
}

fn obstacles_hold(results: &Path) -> Result<Finding> {
    let t = Csv::read(results, "06-6/data.csv")?;
    let notes = t.get("case", "sl-gridded-reflect-notes", "max_obstacle_fraction")?;
    let (case, column) = (t.index("case")?, t.index("max_obstacle_fraction")?);
    let exact = t
        .rows
        .iter()
        .filter(|r| !r[case].ends_with("-notes"))
        .map(|r| r[column].parse::<f64>())
        .try_fold(0.0_f64, |m, v| v.map(|v| m.max(v)))?;
    Ok(Finding {
        number: format!(
            "gas inside obstacles: notes' rule {:.1e}, exact projection {exact:.1e}",
            notes
        ),
        verdict: Verdict::of(&[notes < 1e-3]),
    })
}

fn simulation_noise_divergence_free(results: &Path) -> Result<Finding> {
    let t = Csv::read(results, "N-3/data.csv")?;
    let [value, fast, smooth] = ["value-2d", "fast-sim-2d", "smooth-sim-2d"]
        .map(|k| t.get("kind", k, "relative_divergence"));
    let (value, fast, smooth) = (value?, fast?, smooth?);
    Ok(Finding {
        number: format!("|∇·u|/|∇u|: value {value:.2}, fast {fast:.1e}, smooth {smooth:.1e}"),
        verdict: Verdict::of(&[fast < 1e-2, smooth < 1e-2, value > 0.1]),
    })
}

fn orders_as_designed(results: &Path) -> Result<Finding> {
    let text = std::fs::read_to_string(results.join("convergence/orders.md"))
        .context("cannot read results/convergence/orders.md")?;
    let rows: Vec<&str> = text
        .lines()
        .skip(2)
        .filter(|l| l.starts_with('|'))
        .collect();
    let within = rows
        .iter()
        .filter(|l| l.trim_end().ends_with("| yes |"))
        .count();
    if rows.is_empty() {
        bail!("results/convergence/orders.md has no rows");
    }
    Ok(Finding {
        number: format!(
            "{within} of {} studies within ±0.25 of the expected order",
            rows.len()
        ),
        verdict: Verdict::of(&[within == rows.len()]),
    })
}

/// Every claim, in the order of the notes.
pub fn claims() -> Vec<Claim> {
    vec![
        Claim {
            claim: "gridless density holds finer structure than gridded (§6.2)",
            source: "06-3/summary.csv",
            rule: "all four ratios > 1 (against SL and MacCormack)",
            measure: finer_structure,
        },
        Claim {
            claim: "SELMA's detail lies between gridded and gridless (ch. 8)",
            source: "06-3/summary.csv",
            rule: "each ordering strict, with SL and with MacCormack gridded",
            measure: selma_between,
        },
        Claim {
            claim: "gridless keeps more density: peaks (§6.2)",
            source: "06-3/summary.csv",
            rule: "gridless peak > gridded SL and MacCormack",
            measure: keeps_peak,
        },
        Claim {
            claim: "gridless keeps more density: mass (§6.2)",
            source: "06-3/summary.csv",
            rule: "gridless closer to 100 % than SL and than MacCormack (4× sampling)",
            measure: keeps_mass,
        },
        Claim {
            claim: "gridless preserves the hot/cold symmetry better than gridded (§6.2)",
            source: "S-1/summary.csv",
            rule: "both ratios < 1 with each scheme and against MacCormack",
            measure: symmetry_better,
        },
        Claim {
            claim: "the reflecting rule keeps gas out of obstacles (§6.3)",
            source: "06-6/data.csv",
            rule: "notes' rule leaves < 0.1 % inside",
            measure: obstacles_hold,
        },
        Claim {
            claim: "gridded advection of the sphere wall loses substantial density (fig 7.4)",
            source: "07-4/data.csv",
            rule: "mass and peak kept < 95 %, with SL and with MacCormack",
            measure: sphere_wall_loss,
        },
        Claim {
            claim: "gridless frames sharpen the wall: subtly after one, more after ten (figs 7.5, 7.7)",
            source: "07-7/data.csv",
            rule: "gradient energy of the render 07-4 < 07-5 < 07-7",
            measure: gridless_sharpens,
        },
        Claim {
            claim: "ten gridless frames make detail finer than a cell march resolves: significant aliasing (fig 7.6)",
            source: "07-6/data.csv",
            rule: "coherent error of the cell march > 2× that of the gridded wall",
            measure: coarse_march_aliases,
        },
        Claim {
            claim: "gridless render time and memory grow linearly with frames, SELMA's stay flat (figs 7.10, 8.2)",
            source: "08-2/summary.csv",
            rule: "each fitted trend as claimed (`growth::classify`)",
            measure: gridless_cost_grows,
        },
        Claim {
            claim: "simulation noise is divergence-free, value noise is not (Patel & Taylor)",
            source: "N-3/data.csv",
            rule: "sim < 10⁻², value > 0.1",
            measure: simulation_noise_divergence_free,
        },
        Claim {
            claim: "simulation noise costs: fast < value < smooth (Patel & Taylor §3–4)",
            source: "N-3/costs.csv",
            rule: "each inequality",
            measure: noise_costs,
        },
        Claim {
            claim: "each scheme converges at its designed order",
            source: "convergence/orders.md",
            rule: "every study within ±0.25",
            measure: orders_as_designed,
        },
    ]
}

/// The claims table in Markdown, measured from `results`.
///
/// # Errors
/// A missing results file, column or row.
pub fn table(results: &Path) -> Result<String> {
    let mut out = String::from(
        "| claim of the notes | our number | rule | verdict | source |\n|---|---|---|---|---|\n",
    );
    for c in claims() {
        let f = (c.measure)(results).with_context(|| format!("claim \"{}\"", c.claim))?;
        // A `|` inside a cell would end it.
        out.push_str(&format!(
            "| {} | {} | {} | **{}** | [{}](../results/{}) |\n",
            c.claim,
            f.number.replace('|', "\\|"),
            c.rule,
            f.verdict.text(),
            c.source,
            c.source
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn verdict_of_parts() {
        assert_eq!(Verdict::of(&[true, true]), Verdict::Holds);
        assert_eq!(Verdict::of(&[true, false]), Verdict::Partly);
        assert_eq!(Verdict::of(&[false, false]), Verdict::DoesNotHold);
    }
}
