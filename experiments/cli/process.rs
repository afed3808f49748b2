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

/// The one-line message for a flag given a bad value, or `None` for any
/// other command-line error (clap prints those, usage and all).
///
/// A whole-number flag given something outside its type (`--frames -5`,
/// `--seed 99999999999999999999`), of which clap says only "invalid digit
/// found in string" or "number too large to fit in target type", is told
/// its range, found from the flag's type in `cmd`'s definition: "expected
/// a whole number from 0 to 18446744073709551615". Other bad values keep
/// the first line of clap's message.
pub fn bad_value_message(e: &clap::Error, cmd: &clap::Command) -> Option<String> {
    use clap::error::{ContextKind, ContextValue, ErrorKind};
    if e.kind() != ErrorKind::ValueValidation {
        return None;
    }
    let context = |kind| match e.get(kind) {
        Some(ContextValue::String(s)) => Some(s.as_str()),
        _ => None,
    };
    let (arg, value) = (
        context(ContextKind::InvalidArg),
        context(ContextKind::InvalidValue),
    );
    let not_a_number =
        std::error::Error::source(e).is_some_and(|s| s.is::<std::num::ParseIntError>());
    if let (true, Some(arg), Some(value)) = (not_a_number, arg, value) {
        if let Some((lo, hi)) = integer_range(cmd, arg) {
            return Some(format!(
                "invalid value '{value}' for '{arg}': expected a whole number from {lo} to {hi}"
            ));
        }
    }
    let rendered = e.render().to_string();
    let first = rendered.lines().next()?;
    Some(first.strip_prefix("error: ").unwrap_or(first).to_string())
}

/// The range of the whole-number flag `arg` (as clap's message names it,
/// `--frames <FRAMES>`) in `cmd` or its subcommands, if every flag of that
/// long name has the same integer type.
fn integer_range(cmd: &clap::Command, arg: &str) -> Option<(i128, i128)> {
    fn of(parser: &clap::builder::ValueParser) -> Option<(i128, i128)> {
        use std::any::TypeId;
        let id = parser.type_id();
        macro_rules! ranges {
            ($($t:ty),*) => {
                $(if id == TypeId::of::<$t>() {
                    return Some((<$t>::MIN as i128, <$t>::MAX as i128));
                })*
            };
        }
        ranges!(u8, u16, u32, u64, usize, i8, i16, i32, i64, isize);
        None
    }
    // `--frames <FRAMES>`: the flag's long name.
    let long = arg.split_whitespace().next()?.strip_prefix("--")?;
    fn walk(cmd: &clap::Command, long: &str, found: &mut Vec<Option<(i128, i128)>>) {
        for a in cmd.get_arguments() {
            if a.get_long() == Some(long) {
                found.push(of(a.get_value_parser()));
            }
        }
        for sub in cmd.get_subcommands() {
            walk(sub, long, found);
        }
    }
    let mut found = Vec::new();
    walk(cmd, long, &mut found);
    let first = *found.first()?;
    found.iter().all(|r| *r == first).then_some(first)?
}
