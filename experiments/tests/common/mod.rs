//! Helpers every application test shares.

use std::path::Path;
use std::process::{Command, Output};

/// Run the `smokelab` binary with `args` in the folder `cwd`.
pub fn smokelab(args: &[&str], cwd: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_smokelab"))
        .args(args)
        .current_dir(cwd)
        .output()
        .expect("run smokelab")
}
