//! What the whole process shares: the worker threads, the run being
//! written (for the interrupt message), the default run folder.

use std::path::PathBuf;

use smokelab::error::InputError;

/// The run folder being written and whether it writes checkpoints, for
/// the interrupt message ([`interrupt_hint`]).
static RUNNING: std::sync::Mutex<Option<(PathBuf, bool)>> = std::sync::Mutex::new(None);

pub(crate) fn set_running(dir: &std::path::Path, checkpoints: bool) {
    *RUNNING.lock().unwrap_or_else(|e| e.into_inner()) = Some((dir.to_path_buf(), checkpoints));
}

/// What the interrupt (Ctrl-C) message tells about going on: `run
/// --resume RUN_DIR` for a run that writes checkpoints, how to make one
/// that does otherwise.
pub fn interrupt_hint() -> String {
    match RUNNING.lock().unwrap_or_else(|e| e.into_inner()).as_ref() {
        Some((dir, true)) => format!(
            "Continue the run from its last checkpoint with `smokelab run --resume {}`",
            dir.display()
        ),
        Some((dir, false)) => format!(
            "The run in {} wrote no checkpoint; run with --checkpoint-every K to be able to continue it with `smokelab run --resume RUN_DIR`",
            dir.display()
        ),
        None => "A run with --checkpoint-every K continues with `smokelab run --resume RUN_DIR`"
            .to_string(),
    }
}

/// Set the number of rayon worker threads (once per process).
pub fn init_threads(threads: Option<usize>) -> Result<(), InputError> {
    if let Some(n) = threads {
        smokelab::timing::check_threads(n)?;
        // A second call (e.g. in tests) keeps the first pool; that is fine.
        let _ = rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build_global();
    }
    Ok(())
}

pub fn default_run_dir(name: &str) -> PathBuf {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    PathBuf::from("runs").join(format!("{name}-{secs}"))
}
