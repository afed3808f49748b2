//! `smokelab`: see `smokelab --help` and the README.

use std::process::ExitCode;

use clap::Parser;
use smokelab::error::InputError;
use smokelab_app::cli::{execute, Cli};

fn main() -> ExitCode {
    // Die quietly on a closed pipe (`smokelab experiment --list | head`)
    // like other command-line tools, instead of panicking in `println!`.
    #[cfg(unix)]
    // SAFETY: restoring the default action of one signal before any thread
    // starts has no preconditions.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    let cli = Cli::try_parse().unwrap_or_else(|e| e.exit());
    match execute(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) if e.downcast_ref::<InputError>().is_some() => {
            eprintln!("error: {e}");
            ExitCode::from(2)
        }
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
