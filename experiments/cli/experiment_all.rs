//! `smokelab experiment all`: every registered experiment in the notes'
//! order into one parent folder, going on past failures, with an estimate
//! of the time left from the last run's `experiments.csv` (the committed
//! `results/experiments.csv` for a new folder at the default size) and that
//! table written anew.

use anyhow::Result;
use serde::Serialize;

use crate::experiment::{kit, registry};
use crate::run::output_dir;
use smokelab::error::InputError;
use smokelab::io;

/// One row of `experiments.csv`.
#[derive(Serialize)]
struct ExperimentRow {
    id: &'static str,
    reproduces: &'static str,
    seconds: f64,
    output: String,
    status: String,
}

/// How `experiment all` runs: the size, progress, `--overwrite`, and the
/// Python that runs the peers of the experiments that have any (`--peers`).
pub(crate) struct AllOptions<'a> {
    pub size: kit::Size,
    pub progress: bool,
    pub overwrite: bool,
    pub peers: Option<&'a std::path::Path>,
}

/// The time left of `experiment all`, estimated from the seconds each
/// experiment took when `experiments.csv` was last written into the same
/// folder, scaled by this run's pace so far (its seconds over those
/// recorded, for the experiments done). `None` without a record.
struct AllEstimate {
    recorded: std::collections::HashMap<String, f64>,
    actual: f64,
    expected: f64,
}

impl AllEstimate {
    fn read(table: &std::path::Path) -> Self {
        let recorded = std::fs::read_to_string(table)
            .ok()
            .and_then(|text| {
                let mut r = csv::Reader::from_reader(text.as_bytes());
                let rows: Result<Vec<ExperimentRecord>, _> = r.deserialize().collect();
                rows.ok()
            })
            .map(|rows| rows.into_iter().map(|r| (r.id, r.seconds)).collect())
            .unwrap_or_default();
        Self {
            recorded,
            actual: 0.0,
            expected: 0.0,
        }
    }

    /// Book an experiment done in `seconds`.
    fn done(&mut self, id: &str, seconds: f64) {
        if let Some(&e) = self.recorded.get(id) {
            self.actual += seconds;
            self.expected += e;
        }
    }

    /// Seconds left for `remaining`, if every one of them has a record.
    fn left<'e>(&self, mut remaining: impl Iterator<Item = &'e str>) -> Option<f64> {
        let pace = if self.expected > 0.0 {
            self.actual / self.expected
        } else {
            1.0
        };
        remaining.try_fold(0.0, |sum, id| Some(sum + self.recorded.get(id)? * pace))
    }
}

/// The columns of `experiments.csv` the estimate reads.
#[derive(serde::Deserialize)]
struct ExperimentRecord {
    id: String,
    seconds: f64,
}

/// Every experiment in the notes' order into `parent/<folder>/`, going on
/// past failures, then a table of what ran, how long and where it wrote —
/// printed and saved as `parent/experiments.csv`. Every folder is checked
/// first ([`output_dir::EXPERIMENT`]): one holding earlier outputs refuses
/// the whole run unless `overwrite`, and then each experiment's folder is
/// locked and its earlier outputs removed right before it runs.
pub(crate) fn run(parent: &std::path::Path, options: &AllOptions) -> Result<()> {
    let &AllOptions {
        size,
        progress,
        overwrite,
        peers,
    } = options;
    io::check_output_dir(parent)?;
    let table = parent.join("experiments.csv");
    // A new folder has no record of its own: at the default size, the
    // committed results' times stand in.
    let committed = std::path::Path::new("results/experiments.csv");
    let mut estimate = AllEstimate::read(match size {
        kit::Size::Default if !table.is_file() => committed,
        _ => &table,
    });
    for exp in registry::ALL {
        output_dir::check(&parent.join(exp.folder), &output_dir::EXPERIMENT, overwrite)?;
    }
    if table.is_file() && !overwrite {
        return Err(InputError::new(format!(
            "output folder {} holds {} of an earlier `experiment all`; give another --out, or --overwrite to replace it",
            parent.display(),
            table.display()
        ))
        .into());
    }
    let mut rows = Vec::new();
    let count = registry::ALL.len();
    for (n, exp) in registry::ALL.iter().enumerate() {
        let out = parent.join(exp.folder);
        let folder = output_dir::open(&out, &output_dir::EXPERIMENT, overwrite)?;
        // One bar per experiment, titled with its place in the whole; its
        // runs are its named stages.
        let bar =
            crate::run::progress::experiment(&format!("{}/{count} {}", n + 1, exp.id), progress);
        let left = estimate
            .left(registry::ALL[n..].iter().map(|e| e.id))
            .map(|s| format!(" · about {:.0} min left in all", (s / 60.0).ceil()))
            .unwrap_or_default();
        bar.suspend(|| println!("== experiment {} ({}){left}", exp.id, exp.reproduces));
        let ctx = kit::Context {
            out: out.clone(),
            size,
            progress,
            peers: peers.map(std::path::Path::to_path_buf),
        };
        let start = std::time::Instant::now();
        let result = (exp.run)(&ctx);
        let status = match result {
            Ok(()) => "ok".to_string(),
            Err(e) => {
                bar.suspend(|| eprintln!("experiment {} failed: {e:#}", exp.id));
                format!("failed: {e}")
            }
        };
        drop(folder);
        let seconds = start.elapsed().as_secs_f64();
        estimate.done(exp.id, seconds);
        rows.push((exp, seconds, out, status));
    }
    let mut table = format!(
        "{:<7} {:<22} {:>9}  {:<28} {}\n",
        "id", "reproduces", "seconds", "output", "status"
    );
    let mut csv = Vec::new();
    for (exp, secs, out, status) in &rows {
        table.push_str(&format!(
            "{:<7} {:<22} {:>9.1}  {:<28} {}\n",
            exp.id,
            exp.reproduces,
            secs,
            out.display(),
            status
        ));
        csv.push(ExperimentRow {
            id: exp.id,
            reproduces: exp.reproduces,
            seconds: (secs * 10.0).round() / 10.0,
            output: out.display().to_string(),
            status: status.clone(),
        });
    }
    print!("{table}");
    io::create_output_dir(parent)?;
    crate::figures::table::write_rows(&parent.join("experiments.csv"), &csv)?;
    let failed: Vec<_> = rows
        .iter()
        .filter(|r| r.3 != "ok")
        .map(|r| r.0.id)
        .collect();
    if !failed.is_empty() {
        anyhow::bail!("experiments failed: {}", failed.join(", "));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::AllEstimate;

    #[test]
    fn all_estimate_scales_the_recorded_seconds_by_the_pace_so_far() {
        let dir = tempfile::tempdir().unwrap();
        let table = dir.path().join("experiments.csv");
        std::fs::write(
            &table,
            "id,reproduces,seconds,output,status\n\
             03-2,fig 3.2,10.0,results/03-2,ok\n\
             06-1,fig 6.1,20.0,results/06-1,ok\n\
             06-5,fig 6.5,30.0,results/06-5,ok\n",
        )
        .unwrap();
        let mut e = AllEstimate::read(&table);
        // Before anything ran: the record as it stands.
        assert_eq!(e.left(["06-1", "06-5"].into_iter()), Some(50.0));
        // 03-2 took twice its record: the rest is expected twice as long.
        e.done("03-2", 20.0);
        assert_eq!(e.left(["06-1", "06-5"].into_iter()), Some(100.0));
        // An experiment without a record: no estimate rather than a low one.
        assert_eq!(e.left(["06-5", "V-1"].into_iter()), None);
        // No record at all: no estimate.
        let none = AllEstimate::read(&dir.path().join("missing.csv"));
        assert_eq!(none.left(["03-2"].into_iter()), None);
    }
}
