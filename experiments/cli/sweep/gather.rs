//! Where a sweep stands and what it measured: each point's state read from
//! its folder's manifest (so it works whichever executor ran it), and
//! `sweep.csv`, one row per point: its axis values, its state, then the
//! summary its run recorded (the manifest's wall time and peak memory, and
//! `metrics.csv`'s last row, the state the run ended in, without the
//! per-stage timing columns); and beside it the figures across the sweep
//! ([`super::figure`]).

use std::path::Path;

use anyhow::{Context as _, Result};
use smokelab::io;

use super::plan::{plain, Plan, Point, State};

/// The table `gather` writes into the sweep's folder.
pub const TABLE: &str = "sweep.csv";

/// The file `run-point` leaves in `logs/` when a point stops on an error
/// that its run's manifest cannot record (a bad folder, an experiment's
/// error), holding the error; removed when the point starts again.
pub fn failure_file(dir: &Path, point: &Point) -> std::path::PathBuf {
    let name = point
        .folder
        .file_name()
        .map_or_else(|| point.index.to_string(), |n| n.to_string_lossy().into());
    dir.join(super::layout::LOGS).join(format!("{name}.failed"))
}

/// The `status` of the manifest in `folder`, if it has a readable one.
fn manifest(folder: &Path) -> Option<serde_json::Value> {
    let bytes = std::fs::read(folder.join("manifest.json")).ok()?;
    serde_json::from_slice(&bytes).ok()
}

/// Where `point` of the sweep in `dir` stands: its manifest's status
/// (`running` until the run ends, so also a killed run's), `failed` if
/// `run-point` recorded an error, `running` for a folder without a
/// manifest yet (an experiment writes its manifest at the end), `pending`
/// without a folder.
pub fn state(dir: &Path, point: &Point) -> State {
    let folder = dir.join(&point.folder);
    let recorded = manifest(&folder)
        .and_then(|m| m["status"].as_str().map(String::from))
        .map(|s| match s.as_str() {
            "complete" => State::Complete,
            "failed" => State::Failed,
            _ => State::Running,
        });
    match recorded {
        Some(State::Complete) => State::Complete,
        _ if failure_file(dir, point).exists() => State::Failed,
        Some(state) => state,
        None if folder.is_dir() => State::Running,
        None => State::Pending,
    }
}

/// Every point's state read anew, recorded in `sweep.json`.
pub fn refresh(dir: &Path, plan: &mut Plan) -> Result<()> {
    for p in &mut plan.points {
        p.state = state(dir, p);
    }
    plan.write(dir)
}

/// `smokelab sweep status DIR`: one line per point and the counts.
pub fn status(dir: &Path) -> Result<()> {
    let mut plan = Plan::read(dir)?;
    refresh(dir, &mut plan)?;
    for p in &plan.points {
        println!(
            "{:>5}  {:<8}  {}  ({})",
            p.index,
            p.state.to_string(),
            plan.describe(p),
            p.folder.display()
        );
    }
    println!("{}", counts(&plan));
    Ok(())
}

/// `N points: a complete, b running, …`.
pub fn counts(plan: &Plan) -> String {
    let n = |s: State| plan.points.iter().filter(|p| p.state == s).count();
    format!(
        "{} points: {} complete, {} running, {} pending, {} failed",
        plan.points.len(),
        n(State::Complete),
        n(State::Running),
        n(State::Pending),
        n(State::Failed)
    )
}

/// The summary of one point's run: `(column, value)` pairs.
fn summary(folder: &Path) -> Result<Vec<(String, String)>> {
    let mut cells = Vec::new();
    if let Some(m) = manifest(folder) {
        for key in ["wall_seconds", "peak_memory_bytes"] {
            let value = match &m[key] {
                serde_json::Value::Null => String::new(),
                v => plain(v),
            };
            cells.push((key.to_string(), value));
        }
    }
    let metrics = folder.join("metrics.csv");
    if metrics.exists() {
        let mut reader = csv::Reader::from_path(&metrics)
            .with_context(|| format!("cannot read {}", metrics.display()))?;
        let header = reader.headers()?.clone();
        let last = reader
            .records()
            .last()
            .transpose()
            .with_context(|| format!("{} has a bad row", metrics.display()))?;
        if let Some(row) = last {
            for (name, value) in header.iter().zip(row.iter()) {
                if !name.starts_with("t_") {
                    cells.push((name.to_string(), value.to_string()));
                }
            }
        }
    }
    Ok(cells)
}

/// `smokelab sweep gather DIR`: write `DIR/sweep.csv`, a row per point
/// (incomplete ones with their state and no summary), columns in the
/// order the points first name them, then `DIR/sweep.png`
/// ([`super::figure::contact_sheet`]) and the wall-time plot
/// ([`super::figure::wall_time_plot`]).
pub fn gather(dir: &Path) -> Result<()> {
    let mut plan = Plan::read(dir)?;
    refresh(dir, &mut plan)?;
    let mut columns: Vec<String> = Vec::new();
    let mut rows = Vec::new();
    for p in &plan.points {
        let cells = match p.state {
            State::Complete => summary(&dir.join(&p.folder))?,
            _ => Vec::new(),
        };
        for (name, _) in &cells {
            if !columns.contains(name) {
                columns.push(name.clone());
            }
        }
        rows.push(cells);
    }
    let path = dir.join(TABLE);
    io::write_atomic(&path, |w| {
        let mut out = csv::Writer::from_writer(w);
        let mut header = vec!["point".to_string()];
        header.extend(plan.axes.iter().map(|a| a.key.clone()));
        header.push("state".into());
        header.extend(columns.iter().cloned());
        out.write_record(&header)?;
        for (p, cells) in plan.points.iter().zip(&rows) {
            let mut record = vec![p.index.to_string()];
            record.extend(p.values.iter().map(plain));
            record.push(p.state.to_string());
            for c in &columns {
                record.push(
                    cells
                        .iter()
                        .find(|(name, _)| name == c)
                        .map_or_else(String::new, |(_, v)| v.clone()),
                );
            }
            out.write_record(&record)?;
        }
        out.flush()?;
        Ok(())
    })
    .with_context(|| format!("cannot write {}", path.display()))?;
    let incomplete = plan
        .points
        .iter()
        .filter(|p| p.state != State::Complete)
        .count();
    println!("wrote {} ({})", path.display(), counts(&plan));
    if incomplete > 0 {
        eprintln!(
            "warning: {incomplete} points are not complete; their rows hold their state only (`smokelab sweep resubmit {}` finishes them)",
            dir.display()
        );
    }
    super::figure::contact_sheet(dir, &plan)?;
    let wall: Vec<Option<f64>> = rows
        .iter()
        .map(|cells| {
            let (_, seconds) = cells.iter().find(|(name, _)| name == "wall_seconds")?;
            seconds.parse().ok()
        })
        .collect();
    super::figure::wall_time_plot(dir, &plan, &wall)
}
