//! The solver's step as a Python user takes it: `smokelab.Simulation`
//! (the extension in `python/`) stepped one `sim.step()` at a time in a
//! Python loop, timed by Python's own clock. Beside `Simulation::step`
//! timed in Rust on the same configuration, the ratio is what the Python
//! layer costs: the call, the GIL released and taken back, the Ctrl-C
//! check and the finite check of each step.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{bail, Context as _, Result};

/// The loop: hot/cold at `res` with every other key its default, `warm`
/// steps, then `timed` single steps; prints `median_ms,<ms>`.
const SCRIPT: &str = r#"
import statistics, sys, time
import smokelab
res, warm, timed = map(int, sys.argv[1:4])
sim = smokelab.Simulation("hot-cold", res=res)
sim.step(warm)
times = []
for _ in range(timed):
    start = time.perf_counter()
    sim.step()
    times.append(time.perf_counter() - start)
print(f"median_ms,{statistics.median(times) * 1e3}")
"#;

/// A Python that imports the solver.
pub struct PythonStep {
    pub python: PathBuf,
}

impl PythonStep {
    /// `python` if it imports `smokelab.Simulation`; otherwise why not
    /// (for the manifest: the measurement is then absent, not an error).
    pub fn probe(python: &Path) -> std::result::Result<Self, String> {
        let done = Command::new(python)
            .args(["-c", "import smokelab; smokelab.Simulation"])
            .output()
            .map_err(|e| format!("cannot run {}: {e}", python.display()))?;
        if !done.status.success() {
            let why = String::from_utf8_lossy(&done.stderr);
            return Err(format!(
                "{} cannot import smokelab's solver ({}); `pip install ./python` into it",
                python.display(),
                why.lines().last().unwrap_or("").trim()
            ));
        }
        Ok(Self {
            python: python.to_path_buf(),
        })
    }

    /// The median ms of one `sim.step()` at `res`³ after `warm` steps,
    /// over `timed` steps.
    pub fn median_ms(&self, res: usize, warm: usize, timed: usize) -> Result<f64> {
        let done = Command::new(&self.python)
            .args(["-c", SCRIPT])
            .args([res, warm, timed].map(|n| n.to_string()))
            .output()
            .with_context(|| format!("cannot run {}", self.python.display()))?;
        if !done.status.success() {
            bail!(
                "the Python step loop at {res}³ failed: {}",
                String::from_utf8_lossy(&done.stderr)
            );
        }
        String::from_utf8_lossy(&done.stdout)
            .lines()
            .find_map(|l| l.strip_prefix("median_ms,")?.trim().parse().ok())
            .with_context(|| format!("the Python step loop at {res}³ printed no median"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A Python that is not there, or that lacks the module, is no error
    /// but a reason for the manifest that says what to do.
    #[test]
    fn a_python_without_the_solver_gives_the_reason() {
        let why = PythonStep::probe(Path::new("/nonexistent/python3")).err();
        assert!(why.is_some_and(|w| w.contains("cannot run /nonexistent/python3")));
        let dir = tempfile::tempdir().unwrap();
        let python = dir.path().join("python");
        std::fs::write(
            &python,
            "#!/bin/sh\necho \"ModuleNotFoundError: No module named 'smokelab'\" >&2\nexit 1\n",
        )
        .unwrap();
        std::fs::set_permissions(&python, std::os::unix::fs::PermissionsExt::from_mode(0o755))
            .unwrap();
        let why = PythonStep::probe(&python).err().unwrap();
        assert!(
            why.contains("No module named 'smokelab'") && why.contains("pip install ./python"),
            "{why}"
        );
    }
}
