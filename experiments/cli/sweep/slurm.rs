//! The Slurm executor: `sweep.sbatch`, one job array whose task
//! `SLURM_ARRAY_TASK_ID` runs point of that index with `smokelab sweep
//! run-point DIR INDEX`, submitted with `sbatch` (the whole array, or the
//! listed points on `resubmit`).

use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context as _, Result};
use serde::{Deserialize, Serialize};
use smokelab::error::InputError;

/// The script in the sweep's folder.
pub const SCRIPT: &str = "sweep.sbatch";

/// The job's resources: `#SBATCH` lines of the script.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize, clap::Args)]
pub struct SlurmOptions {
    /// Slurm partition (`#SBATCH --partition`).
    #[arg(long)]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub partition: Option<String>,
    /// Time limit of each array task, e.g. `02:00:00` (`#SBATCH --time`).
    #[arg(long)]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub time: Option<String>,
    /// CPUs of each array task (`#SBATCH --cpus-per-task`; the run uses that many threads).
    #[arg(long)]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cpus_per_task: Option<u32>,
    /// Memory of each array task, e.g. `8G` (`#SBATCH --mem`).
    #[arg(long)]
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mem: Option<String>,
    /// Another `#SBATCH` line, e.g. `--sbatch=--account=abc` (repeatable; after the file's).
    #[arg(long = "sbatch", value_name = "OPTION", allow_hyphen_values = true)]
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub extra: Vec<String>,
}

impl SlurmOptions {
    /// The sweep file's `[slurm]` table (`partition`, `time`,
    /// `cpus_per_task`, `mem`, `extra = ["--account=abc", …]`).
    pub fn from_table(table: toml::Table) -> Result<Self, String> {
        const KEYS: [&str; 5] = ["partition", "time", "cpus_per_task", "mem", "extra"];
        if let Some(k) = table.keys().find(|k| !KEYS.contains(&k.as_str())) {
            return Err(format!(
                "unknown key '{k}' in [slurm]; valid: {}",
                KEYS.join(", ")
            ));
        }
        let options: Self = toml::Value::Table(table).try_into().map_err(|e| {
            let e = e.to_string().split_whitespace().collect::<Vec<_>>().join(" ");
            format!("[slurm] is not valid: {e}; e.g. partition = \"cpu\", time = \"01:00:00\", cpus_per_task = 4, mem = \"8G\", extra = [\"--account=abc\"]")
        })?;
        options.check().map_err(|e| e.to_string())?;
        Ok(options)
    }

    /// These options, overridden by the ones `flags` gives (their extra
    /// lines added after these).
    pub fn with(&self, flags: &SlurmOptions) -> Result<Self, InputError> {
        let mut extra = self.extra.clone();
        extra.extend(flags.extra.iter().cloned());
        let options = Self {
            partition: flags.partition.clone().or_else(|| self.partition.clone()),
            time: flags.time.clone().or_else(|| self.time.clone()),
            cpus_per_task: flags.cpus_per_task.or(self.cpus_per_task),
            mem: flags.mem.clone().or_else(|| self.mem.clone()),
            extra,
        };
        options.check()?;
        Ok(options)
    }

    /// Values the script can hold: one line each, options of `sbatch`.
    fn check(&self) -> Result<(), InputError> {
        if self.cpus_per_task == Some(0) {
            return Err(InputError::new(
                "cpus_per_task is 0; an array task needs at least 1 CPU",
            ));
        }
        let texts = [&self.partition, &self.time, &self.mem]
            .into_iter()
            .flatten()
            .chain(&self.extra);
        for t in texts {
            if t.is_empty() || t.contains(['\n', '\r']) {
                return Err(InputError::new(format!(
                    "Slurm option {t:?} must be one non-empty line"
                )));
            }
        }
        if let Some(e) = self.extra.iter().find(|e| !e.starts_with('-')) {
            return Err(InputError::new(format!(
                "extra #SBATCH line {e:?} is not an sbatch option; give it as `--name=value`"
            )));
        }
        Ok(())
    }
}

/// The text of `sweep.sbatch` for `points` points in the sweep folder
/// `dir` (absolute), run by the `smokelab` binary `exe` (absolute).
pub fn script(dir: &Path, exe: &Path, points: usize, options: &SlurmOptions) -> String {
    let q = |p: &Path| shell_quote(&p.display().to_string());
    let mut s = format!(
        "#!/bin/bash\n\
         # smokelab sweep: array task i runs point i of {index}\n\
         # (`smokelab sweep status` tells where each stands; `smokelab sweep resubmit`\n\
         # submits the unfinished ones again and they resume from their checkpoints).\n\
         #SBATCH --job-name=smokelab-sweep\n\
         #SBATCH --array=0-{last}\n\
         #SBATCH --output={logs}/slurm-%A_%a.log\n\
         #SBATCH --open-mode=append\n",
        index = dir.join(super::layout::INDEX).display(),
        last = points.saturating_sub(1),
        logs = dir.join(super::layout::LOGS).display(),
    );
    let lines = [
        options
            .partition
            .as_ref()
            .map(|p| format!("--partition={p}")),
        options.time.as_ref().map(|t| format!("--time={t}")),
        options
            .cpus_per_task
            .map(|c| format!("--cpus-per-task={c}")),
        options.mem.as_ref().map(|m| format!("--mem={m}")),
    ];
    for line in lines
        .into_iter()
        .flatten()
        .chain(options.extra.iter().cloned())
    {
        s += &format!("#SBATCH {line}\n");
    }
    s += &format!(
        "\n# One worker thread per CPU Slurm gives the task.\n\
         if [ -n \"${{SLURM_CPUS_PER_TASK:-}}\" ]; then export RAYON_NUM_THREADS=\"$SLURM_CPUS_PER_TASK\"; fi\n\
         exec {exe} sweep run-point {dir} \"$SLURM_ARRAY_TASK_ID\"\n",
        exe = q(exe),
        dir = q(dir),
    );
    s
}

/// `sbatch --parsable [--array=LIST] SCRIPT`: submit the array (only the
/// points `only`, if given); the job id.
pub fn submit(script: &Path, only: Option<&[usize]>) -> Result<String> {
    let mut cmd = Command::new("sbatch");
    cmd.arg("--parsable");
    if let Some(only) = only {
        cmd.arg(format!("--array={}", array_list(only)));
    }
    cmd.arg(script);
    let out = cmd.output().map_err(|e| {
        InputError::new(format!(
            "cannot run sbatch ({e}); run on a Slurm login node, or write the script only with --dry-run"
        ))
    })?;
    if !out.status.success() {
        bail!(
            "sbatch {} failed ({}): {}",
            script.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let text = String::from_utf8(out.stdout).context("sbatch printed a job id that is not text")?;
    // `--parsable` prints `JOBID` or `JOBID;CLUSTER`.
    Ok(text.trim().split(';').next().unwrap_or("").to_string())
}

/// The `--array` list of `indices`: `1,3,5`.
pub fn array_list(indices: &[usize]) -> String {
    indices
        .iter()
        .map(usize::to_string)
        .collect::<Vec<_>>()
        .join(",")
}

/// `text` quoted for the shell: bare when it is made of safe characters,
/// else in single quotes.
fn shell_quote(text: &str) -> String {
    let safe = |c: char| c.is_ascii_alphanumeric() || "/._-+=:,@".contains(c);
    if !text.is_empty() && text.chars().all(safe) {
        text.to_string()
    } else {
        format!("'{}'", text.replace('\'', r"'\''"))
    }
}

/// Refuse `--slurm` where there is no `sbatch`, before anything is written.
pub fn check_sbatch() -> Result<(), InputError> {
    match Command::new("sbatch").arg("--version").output() {
        Ok(o) if o.status.success() => Ok(()),
        _ => Err(InputError::new(
            "--slurm: no working sbatch on PATH; run on a Slurm login node, or write the script only with --dry-run",
        )),
    }
}
