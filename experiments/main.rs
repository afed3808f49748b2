//! `smokelab`: see `smokelab --help` and the README.

use std::process::ExitCode;

use clap::Parser;
use smokelab::error::InputError;
use smokelab_app::cli::{execute, Cli};

fn main() -> ExitCode {
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
