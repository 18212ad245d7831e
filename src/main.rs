//! The `lightbooth` command line. Each subcommand lives in its own module
//! under `cli/`; this file only parses arguments, sets up logging and maps
//! errors to an exit status.

mod cli;

use std::process::ExitCode;

use clap::Parser;

/// The daemon's default log filter: state changes and jobs at info, and every
/// command sent to the instrument and its reply, whichever model's driver
/// sends it (the shared link session logs the wire traffic at debug, `→ PR-650
/// command`, `← PR-670 reply`, and the serial port its discarded input; each
/// driver logs its own details at debug).
const DAEMON_LOG: &str = "info,lightbooth_instrument::pr650=debug,lightbooth_instrument::pr655=debug,\
                          lightbooth_instrument::link=debug";

fn main() -> ExitCode {
    let args = cli::Cli::parse();
    // A one-shot command piped into `head` ends quietly when its reader
    // goes, as every Unix tool does: Rust ignores SIGPIPE, so the next
    // `println!` panicked ("failed printing to stdout: Broken pipe"). Not
    // the daemons (`serve`, `worker`), whose sockets and clients come and go.
    if !args.is_daemon() {
        // SAFETY: restoring a signal's default action before any thread is
        // started touches no memory of this program.
        unsafe {
            libc::signal(libc::SIGPIPE, libc::SIG_DFL);
        }
    }
    // Logs go to stderr, so `--json` output on stdout stays machine-readable.
    // The daemon logs every instrument command, state change and job (info);
    // one-shot commands only warnings. `LIGHTBOOTH_LOG=debug` (or any tracing
    // filter) overrides both.
    // Colour codes only on a terminal: a log file or journal gets plain text.
    let ansi = std::io::IsTerminal::is_terminal(&std::io::stderr());
    tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(ansi)
        .with_env_filter(
            tracing_subscriber::EnvFilter::try_from_env("LIGHTBOOTH_LOG").unwrap_or_else(|_| {
                tracing_subscriber::EnvFilter::new(if args.is_daemon() { DAEMON_LOG } else { "warn" })
            }),
        )
        .init();
    match cli::run(args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
