//! The sweep file and its plan: what `smokelab sweep FILE.toml` reads, the
//! points it expands to, and `sweep.json`, the index every other sweep
//! command (`run-point`, `status`, `resubmit`, `gather`) reads back.
//!
//! A scenario sweep is the Cartesian product of its `[axes]`, in the order
//! the file lists them, the last axis varying fastest; every point is the
//! ordinary `smokelab run SCENARIO --set KEY=VALUE…` of its fixed `[keys]`
//! and its axis values, checked at planning exactly as `run --set` checks
//! them. An experiment sweep has one point per experiment id.

use std::path::{Path, PathBuf};

use anyhow::{Context as _, Result};
use clap::ValueEnum as _;
use serde::{Deserialize, Serialize};
use smokelab::error::InputError;
use smokelab::io;
use smokelab::scenario::{Scenario, ScenarioKind};

use super::layout::INDEX;
use super::slurm::SlurmOptions;
use crate::cli::run::RunArgs;
use crate::experiment::registry;

/// Checkpoint cadence of a scenario point when the file gives none.
const DEFAULT_CHECKPOINT_EVERY: usize = 10;

/// The top-level keys of a sweep file.
const FILE_KEYS: [&str; 7] = [
    "scenario",
    "experiment",
    "size",
    "checkpoint_every",
    "keys",
    "axes",
    "slurm",
];

/// What every point runs.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Target {
    /// `smokelab run SCENARIO` with the point's keys.
    Scenario(ScenarioKind),
    /// `smokelab experiment ID` at this size (`smoke`, `default`, `full`),
    /// one point per id.
    Experiment {
        /// The experiments, one point each.
        ids: Vec<String>,
        /// `smoke`, `default` or `full`.
        size: String,
    },
}

/// One axis: a configuration key and the values it takes.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Axis {
    /// The configuration key (`res`, `density`…); `experiment` for an
    /// experiment sweep.
    pub key: String,
    /// Its values, in the file's order.
    pub values: Vec<serde_json::Value>,
}

/// Where a point stands, read from its folder ([`super::gather::state`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum State {
    /// Not started: no folder yet.
    Pending,
    /// Started and not finished: running now, or killed (preempted, timed
    /// out) and waiting for `sweep resubmit`.
    Running,
    /// Every output written.
    Complete,
    /// Stopped on an error.
    Failed,
}

impl std::fmt::Display for State {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            State::Pending => "pending",
            State::Running => "running",
            State::Complete => "complete",
            State::Failed => "failed",
        })
    }
}

/// One point of the sweep.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Point {
    /// Its place in the sweep, `0..n` (the Slurm array task id).
    pub index: usize,
    /// Its value of every axis, in the axes' order.
    pub values: Vec<serde_json::Value>,
    /// Its folder, relative to the sweep's folder.
    pub folder: PathBuf,
    /// The `smokelab` arguments that run it, without `--out FOLDER`.
    pub args: Vec<String>,
    /// Its state when the index was last written.
    pub state: State,
}

/// `sweep.json`: the whole sweep.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct Plan {
    /// What every point runs.
    pub target: Target,
    /// The fixed keys (TOML values as JSON).
    pub keys: serde_json::Map<String, serde_json::Value>,
    /// The axes, in the file's order.
    pub axes: Vec<Axis>,
    /// Steps between a scenario point's checkpoints.
    pub checkpoint_every: usize,
    /// The Slurm job's resources from the file (flags override them).
    pub slurm: SlurmOptions,
    /// Every point, in order.
    pub points: Vec<Point>,
    /// Slurm jobs submitted for the sweep, oldest first.
    #[serde(default)]
    pub slurm_jobs: Vec<String>,
}

impl Plan {
    /// Read and check the sweep file `path`, expanding it into its points.
    pub fn from_file(path: &Path) -> Result<Self, InputError> {
        let text = io::input::read_text(path, "sweep file")?;
        let shown = path.display();
        let mut file: toml::Table = toml::from_str(&text).map_err(|e| {
            InputError::new(format!(
                "sweep file {shown} is not valid TOML: {}",
                e.message()
            ))
        })?;
        if let Some(k) = file.keys().find(|k| !FILE_KEYS.contains(&k.as_str())) {
            return Err(InputError::new(format!(
                "sweep file {shown}: unknown key '{k}'; valid: {}",
                FILE_KEYS.join(", ")
            )));
        }
        let table = |file: &mut toml::Table, name: &str| match file.remove(name) {
            None => Ok(toml::Table::new()),
            Some(toml::Value::Table(t)) => Ok(t),
            Some(v) => Err(InputError::new(format!(
                "sweep file {shown}: '{name}' is {v}; give a table [{name}]"
            ))),
        };
        let keys = table(&mut file, "keys")?;
        let axes_table = table(&mut file, "axes")?;
        let slurm = SlurmOptions::from_table(table(&mut file, "slurm")?)
            .map_err(|e| InputError::new(format!("sweep file {shown}: {e}")))?;
        let checkpoint_every = match file.remove("checkpoint_every") {
            None => DEFAULT_CHECKPOINT_EVERY,
            Some(toml::Value::Integer(k)) if k >= 1 => k as usize,
            Some(v) => {
                return Err(InputError::new(format!(
                    "sweep file {shown}: checkpoint_every = {v}; give a whole number of steps ≥ 1"
                )))
            }
        };
        let mut axes = Vec::new();
        for (key, values) in ordered(axes_table, &text) {
            match values {
                toml::Value::Array(values) if !values.is_empty() => axes.push((key, values)),
                v => {
                    return Err(InputError::new(format!(
                        "sweep file {shown}: axis {key} = {v}; give a non-empty list of values, e.g. {key} = [32, 64]"
                    )))
                }
            }
        }
        if let Some((key, _)) = axes.iter().find(|(k, _)| keys.contains_key(k)) {
            return Err(InputError::new(format!(
                "sweep file {shown}: '{key}' is both a fixed key and an axis; keep one"
            )));
        }
        let target = target(&mut file, &shown.to_string())?;
        let points = match &target {
            Target::Scenario(kind) => scenario_points(*kind, &keys, &axes, checkpoint_every)?,
            Target::Experiment { ids, size } => {
                if let Some(k) = keys.keys().chain(axes.iter().map(|(k, _)| k)).next() {
                    return Err(InputError::new(format!(
                        "sweep file {shown}: an experiment takes no configuration keys ('{k}'); [keys] and [axes] are for a scenario sweep"
                    )));
                }
                experiment_points(ids, size)
            }
        };
        let axes = match &target {
            Target::Scenario(_) => axes
                .into_iter()
                .map(|(key, values)| Axis {
                    key,
                    values: values.iter().map(json).collect(),
                })
                .collect(),
            Target::Experiment { ids, .. } => vec![Axis {
                key: "experiment".into(),
                values: ids.iter().map(|id| id.as_str().into()).collect(),
            }],
        };
        Ok(Self {
            target,
            keys: keys.iter().map(|(k, v)| (k.clone(), json(v))).collect(),
            axes,
            checkpoint_every,
            slurm,
            points,
            slurm_jobs: Vec::new(),
        })
    }

    /// Read `DIR/sweep.json`.
    pub fn read(dir: &Path) -> Result<Self, InputError> {
        let path = dir.join(INDEX);
        let bytes = std::fs::read(&path).map_err(|e| {
            InputError::new(format!(
                "{} is not a sweep folder: cannot read {}: {e}",
                dir.display(),
                path.display()
            ))
        })?;
        serde_json::from_slice(&bytes).map_err(|e| {
            InputError::new(format!(
                "{} is not a sweep index this smokelab reads: {e}",
                path.display()
            ))
        })
    }

    /// Write `DIR/sweep.json` (atomically).
    pub fn write(&self, dir: &Path) -> Result<()> {
        let text = serde_json::to_string_pretty(self)? + "\n";
        io::write_atomic(&dir.join(INDEX), |w| {
            use std::io::Write as _;
            Ok(w.write_all(text.as_bytes())?)
        })
        .with_context(|| format!("cannot write {}", dir.join(INDEX).display()))
    }

    /// The point `index`, or an error naming the valid range.
    pub fn point(&self, index: usize) -> Result<&Point, InputError> {
        self.points.get(index).ok_or_else(|| {
            InputError::new(format!(
                "point {index} is not in the sweep; it has points 0 to {}",
                self.points.len().saturating_sub(1)
            ))
        })
    }

    /// `key=value` for each axis of `point`, for messages.
    pub fn describe(&self, point: &Point) -> String {
        self.axes
            .iter()
            .zip(&point.values)
            .map(|(a, v)| format!("{}={}", a.key, plain(v)))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// The axes of the table `[axes]` in the order the file `text` lists them
/// (a parsed table keeps its keys sorted; their places in the text do not).
fn ordered(axes: toml::Table, text: &str) -> Vec<(String, toml::Value)> {
    #[derive(Deserialize)]
    struct Places {
        #[serde(default)]
        axes: std::collections::BTreeMap<String, toml::Spanned<toml::Value>>,
    }
    let places = toml::from_str::<Places>(text).map_or_else(|_| Default::default(), |p| p.axes);
    let mut axes: Vec<(String, toml::Value)> = axes.into_iter().collect();
    axes.sort_by_key(|(key, _)| places.get(key).map_or(0, |s| s.span().start));
    axes
}

/// The file's `scenario` or `experiment` (and `size`).
fn target(file: &mut toml::Table, shown: &str) -> Result<Target, InputError> {
    let scenarios = || {
        ScenarioKind::value_variants()
            .iter()
            .filter_map(|k| k.to_possible_value().map(|v| v.get_name().to_string()))
            .collect::<Vec<_>>()
            .join(", ")
    };
    let size = file.remove("size");
    match (file.remove("scenario"), file.remove("experiment")) {
        (Some(toml::Value::String(name)), None) => {
            if size.is_some() {
                return Err(InputError::new(format!(
                    "sweep file {shown}: 'size' is for an experiment sweep; a scenario's size is its key res"
                )));
            }
            ScenarioKind::from_str(&name, false)
                .map(Target::Scenario)
                .map_err(|_| {
                    InputError::new(format!(
                        "sweep file {shown}: unknown scenario '{name}'; valid: {}",
                        scenarios()
                    ))
                })
        }
        (None, Some(experiment)) => {
            let ids: Vec<String> = match experiment {
                toml::Value::String(id) if id == "all" => {
                    registry::ids().into_iter().map(String::from).collect()
                }
                toml::Value::String(id) => vec![id],
                toml::Value::Array(list) if !list.is_empty() => list
                    .into_iter()
                    .map(|v| match v {
                        toml::Value::String(id) => Ok(id),
                        v => Err(InputError::new(format!(
                            "sweep file {shown}: experiment id {v} is not a string like \"06-1\""
                        ))),
                    })
                    .collect::<Result<_, _>>()?,
                v => {
                    return Err(InputError::new(format!(
                        "sweep file {shown}: experiment = {v}; give an id, a list of ids or \"all\""
                    )))
                }
            };
            for id in &ids {
                registry::find(id)?;
            }
            let size = match size {
                None => "default".to_string(),
                Some(toml::Value::String(s)) if ["smoke", "default", "full"].contains(&s.as_str()) => s,
                Some(v) => {
                    return Err(InputError::new(format!(
                        "sweep file {shown}: size = {v}; valid: \"smoke\", \"default\", \"full\""
                    )))
                }
            };
            Ok(Target::Experiment { ids, size })
        }
        (Some(_), Some(_)) => Err(InputError::new(format!(
            "sweep file {shown}: give one of 'scenario' and 'experiment', not both"
        ))),
        (Some(v), None) => Err(InputError::new(format!(
            "sweep file {shown}: scenario = {v}; give a name, one of {}",
            scenarios()
        ))),
        (None, None) => Err(InputError::new(format!(
            "sweep file {shown}: say what to sweep: scenario = \"hot-cold\" (one of {}) or experiment = \"06-1\" (an id, a list of ids or \"all\")",
            scenarios()
        ))),
    }
}

/// Every point of a scenario sweep, each checked as `run --set` checks it.
fn scenario_points(
    kind: ScenarioKind,
    keys: &toml::Table,
    axes: &[(String, Vec<toml::Value>)],
    checkpoint_every: usize,
) -> Result<Vec<Point>, InputError> {
    let count: usize = axes.iter().map(|(_, v)| v.len()).product();
    let name = kind
        .to_possible_value()
        .expect("every scenario has a name")
        .get_name()
        .to_string();
    let width = index_width(count);
    let mut points = Vec::with_capacity(count);
    for index in 0..count {
        // The last axis varies fastest.
        let mut rest = index;
        let mut values = vec![toml::Value::Boolean(false); axes.len()];
        for (slot, (_, axis)) in values.iter_mut().zip(axes).rev() {
            *slot = axis[rest % axis.len()].clone();
            rest /= axis.len();
        }
        let set: Vec<String> = keys
            .iter()
            .chain(axes.iter().map(|(k, _)| k).zip(&values))
            .map(|(k, v)| format!("{k}={v}"))
            .collect();
        let run = RunArgs {
            scenario: kind,
            set: set.clone(),
            ..RunArgs::default()
        };
        check(&run).map_err(|e| {
            let at: Vec<String> = axes
                .iter()
                .zip(&values)
                .map(|((k, _), v)| format!("{k}={v}"))
                .collect();
            match at.is_empty() {
                true => e,
                false => InputError::new(format!("{e} (at point {})", at.join(", "))),
            }
        })?;
        let mut folder = format!("{index:0width$}");
        for ((k, _), v) in axes.iter().zip(&values) {
            folder += &format!("-{k}={}", folder_text(v));
        }
        let mut args = vec!["run".to_string(), name.clone()];
        for pair in set {
            args.extend(["--set".to_string(), pair]);
        }
        args.extend([
            "--checkpoint-every".into(),
            checkpoint_every.to_string(),
            "--quiet".into(),
        ]);
        points.push(Point {
            index,
            values: values.iter().map(json).collect(),
            folder: PathBuf::from("points").join(folder),
            args,
            state: State::Pending,
        });
    }
    Ok(points)
}

/// The configuration of the run `args` describes, resolved and checked as
/// `run` checks it before starting.
fn check(args: &RunArgs) -> Result<(), InputError> {
    let solver = smokelab::with_scenario!(args.scenario, C => {
        args.resolve::<C>()?.solver().clone()
    });
    args.check_selma_remap(&solver)
}

/// One point per experiment id.
fn experiment_points(ids: &[String], size: &str) -> Vec<Point> {
    let width = index_width(ids.len());
    ids.iter()
        .enumerate()
        .map(|(index, id)| {
            let mut args = vec!["experiment".to_string(), id.clone(), "--quiet".into()];
            if size != "default" {
                args.push(format!("--{size}"));
            }
            Point {
                index,
                values: vec![id.as_str().into()],
                folder: PathBuf::from("points").join(format!("{index:0width$}-{id}")),
                args,
                state: State::Pending,
            }
        })
        .collect()
}

/// Digits of the folders' index: four, or more for a larger sweep.
fn index_width(count: usize) -> usize {
    count.saturating_sub(1).to_string().len().max(4)
}

/// A TOML value as JSON (a date as its text).
fn json(v: &toml::Value) -> serde_json::Value {
    serde_json::to_value(v).unwrap_or_else(|_| v.to_string().into())
}

/// A value as a table cell: a string bare, anything else as TOML writes it.
pub fn plain(v: &serde_json::Value) -> String {
    match v {
        serde_json::Value::String(s) => s.clone(),
        v => v.to_string(),
    }
}

/// A value as part of a folder name: letters, digits, `.`, `+` and `-`
/// kept, anything else `_`, at most 32 characters.
fn folder_text(v: &toml::Value) -> String {
    let text = match v {
        toml::Value::String(s) => s.clone(),
        v => v.to_string(),
    };
    text.chars()
        .map(|c| match c {
            c if c.is_ascii_alphanumeric() || ".+-".contains(c) => c,
            _ => '_',
        })
        .take(32)
        .collect()
}
