//! `smokelab`: see `smokelab --help` and the README.

use std::process::ExitCode;

use clap::{CommandFactory, Parser};
use smokelab::error::InputError;
use smokelab_app::cli::{execute, process, Cli};

fn main() -> ExitCode {
    // Die quietly on a closed pipe (`smokelab experiment --list | head`)
    // like other command-line tools, instead of panicking in `println!`.
    #[cfg(unix)]
    // SAFETY: restoring the default action of one signal before any thread
    // starts has no preconditions.
    unsafe {
        libc::signal(libc::SIGPIPE, libc::SIG_DFL);
    }
    // Ctrl-C (and SIGTERM, SIGHUP): remove the files being written, so only
    // whole files remain, and stop with the shell's code for an interrupt.
    ctrlc::set_handler(|| {
        let removed = smokelab::io::remove_temporary_files();
        eprintln!(
            "interrupted; removed {removed} partly written files. {}",
            smokelab_app::cli::process::interrupt_hint()
        );
        std::process::exit(130);
    })
    .expect("no other interrupt handler is installed");
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        // Help and version print as clap lays them out.
        Err(e)
            if !e.use_stderr()
                || e.kind() == clap::error::ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand =>
        {
            e.exit()
        }
        // A bad value: one line, naming the flag, the value and what is
        // valid; any other parse error in one line too.
        Err(e) => {
            let message = match process::bad_value_message(&e, &Cli::command()) {
                Some(message) => format!("error: {message}"),
                None => {
                    let args: Vec<String> = std::env::args().collect();
                    smokelab_app::cli::one_line_error(&e, &args)
                }
            };
            eprintln!("{message}");
            return ExitCode::from(2);
        }
    };
    // An unknown or unavailable `SMOKELAB_SIMD` stops before any work.
    if let Err(e) = smokelab::simd::Isa::from_env() {
        eprintln!("error: {e}");
        return ExitCode::from(2);
    }
    match execute(cli) {
        Ok(()) => ExitCode::SUCCESS,
        // The interrupt handler removed the file being written, so its write
        // failed; the handler ends the process (exit 130), not this error.
        Err(_) if smokelab::io::interrupted() => loop {
            std::thread::park();
        },
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
