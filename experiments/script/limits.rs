//! The bounds a script runs within, so that no script — a mistake or a
//! hostile file — can hang, exhaust memory or read outside its folders.
//!
//! - **The file** is a regular file (not `/dev/zero`, a FIFO or a folder) of
//!   at most [`MAX_SCRIPT_BYTES`] ([`read_script`]); so is every module it
//!   imports ([`super::modules`]).
//! - **The interpreter** runs under Rhai's safety limits (the Rhai book,
//!   "Safety and Protection"; [`apply`]): at most `--max-operations`
//!   operations (default [`DEFAULT_MAX_OPERATIONS`]), [`MAX_CALL_LEVELS`]
//!   nested function calls, expressions [`MAX_EXPR_DEPTH`] deep, strings of
//!   [`MAX_STRING_BYTES`], arrays of [`MAX_ARRAY_LEN`] elements, object maps
//!   of [`MAX_MAP_LEN`] entries, [`MAX_MODULES`] imported modules. A script
//!   builds field graphs and calls native verbs — the interpreter never runs
//!   per point — so the shipped scripts use about a hundred operations a
//!   step (measured at 8³: `hot_cold.rhai` 76, `selma.rhai` 123; the
//!   manifest records the count); `loop { }` stops within a second.
//!
//! Hitting a limit stops the script with one line naming the limit and,
//! for the operation count, the flag that raises it ([`describe`]; exit 2).

use std::cell::Cell;
use std::io::Read;
use std::path::Path;
use std::rc::Rc;

use rhai::{Engine, EvalAltResult};
use smokelab::error::InputError;

/// The default of `smokelab script --max-operations`: Rhai operations
/// (statements, expressions, calls; a native verb such as `advect` counts
/// once whatever its grid). Reached by `loop { }` in well under a second.
pub const DEFAULT_MAX_OPERATIONS: u64 = 10_000_000;

/// Nested script function calls (recursion depth).
pub const MAX_CALL_LEVELS: usize = 64;

/// Nesting depth of an expression, at the top level and inside functions.
pub const MAX_EXPR_DEPTH: (usize, usize) = (64, 32);

/// Length of one string, in bytes.
pub const MAX_STRING_BYTES: usize = 1 << 20;

/// Elements of one array. Rhai sizes an array by walking it at every
/// growth, so filling one to `n` costs `n²/2`: ten thousand stops
/// `loop { a.push(1) }` within a second (a million took hours); a
/// script's arrays are its gases and a few displacements.
pub const MAX_ARRAY_LEN: usize = 10_000;

/// Entries of one object map (sized as arrays are, by a walk).
pub const MAX_MAP_LEN: usize = 10_000;

/// Modules imported, all told.
pub const MAX_MODULES: usize = 64;

/// Size of a script or module file.
pub const MAX_SCRIPT_BYTES: u64 = 1 << 20;

/// Read a script or module: a regular file of at most
/// [`MAX_SCRIPT_BYTES`], as UTF-8 text.
pub fn read_script(path: &Path, what: &str) -> Result<String, InputError> {
    let file = smokelab::io::input::open_regular(path, what)?;
    let mut bytes = Vec::new();
    file.take(MAX_SCRIPT_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(|e| InputError::new(format!("cannot read {what} {}: {e}", path.display())))?;
    if bytes.len() as u64 > MAX_SCRIPT_BYTES {
        return Err(InputError::new(format!(
            "{what} {} is larger than {MAX_SCRIPT_BYTES} bytes, the limit for a script",
            path.display()
        )));
    }
    String::from_utf8(bytes).map_err(|_| {
        InputError::new(format!(
            "{what} {} is not UTF-8 text; a script is a text file",
            path.display()
        ))
    })
}

/// Set every limit on `engine`, the operation count at `max_operations`;
/// the operations used so far are counted into `used` (for the manifest).
pub fn apply(engine: &mut Engine, max_operations: u64, used: &Rc<Cell<u64>>) {
    engine
        .set_max_operations(max_operations)
        .set_max_call_levels(MAX_CALL_LEVELS)
        .set_max_expr_depths(MAX_EXPR_DEPTH.0, MAX_EXPR_DEPTH.1)
        .set_max_string_size(MAX_STRING_BYTES)
        .set_max_array_size(MAX_ARRAY_LEN)
        .set_max_map_size(MAX_MAP_LEN)
        .set_max_modules(MAX_MODULES);
    let used = used.clone();
    engine.on_progress(move |n| {
        used.set(n);
        None
    });
}

/// The message for an error that is a limit being hit (looking through
/// function calls and modules), or `None` for any other error.
pub fn describe(err: &EvalAltResult, max_operations: u64) -> Option<String> {
    Some(match err.unwrap_inner() {
        EvalAltResult::ErrorTooManyOperations(..) => format!(
            "the script ran {max_operations} operations, the limit; \
             a script that needs more can raise it with --max-operations N"
        ),
        EvalAltResult::ErrorStackOverflow(..) => format!(
            "function calls nested deeper than {MAX_CALL_LEVELS} levels, the limit \
             (a recursion without end?)"
        ),
        EvalAltResult::ErrorDataTooLarge(what, ..) => {
            let limit = match what.as_str() {
                s if s.contains("string") => format!("{MAX_STRING_BYTES} bytes"),
                s if s.contains("map") => format!("{MAX_MAP_LEN} entries"),
                _ => format!("{MAX_ARRAY_LEN} elements"),
            };
            format!("{what} over the limit of {limit}")
        }
        EvalAltResult::ErrorTooManyModules(..) => {
            format!("more than {MAX_MODULES} modules imported, the limit")
        }
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limited(max_operations: u64) -> Engine {
        let mut e = Engine::new();
        apply(&mut e, max_operations, &Rc::new(Cell::new(0)));
        e
    }

    /// Each limit stops its runaway script, and the message names it.
    #[test]
    fn runaway_scripts_stop_at_their_limit() {
        let cases = [
            ("loop { }", "1000 operations, the limit"),
            ("fn f(n) { f(n + 1) } f(0)", "deeper than 64 levels"),
            (
                "let s = \"x\"; loop { s += s; }",
                "over the limit of 1048576 bytes",
            ),
            (
                "let a = []; loop { a.push(1); }",
                "over the limit of 10000 elements",
            ),
        ];
        for (script, needle) in cases {
            let ops = if script == "loop { }" {
                1000
            } else {
                100_000_000
            };
            let err = limited(ops).run(script).unwrap_err();
            let message = describe(&err, ops).unwrap_or_else(|| panic!("{script}: {err}"));
            assert!(message.contains(needle), "{script}: {message}");
        }
        // Not a limit.
        let err = limited(1000).run("let x = 1 / 0;").unwrap_err();
        assert!(describe(&err, 1000).is_none(), "{err}");
    }
}
