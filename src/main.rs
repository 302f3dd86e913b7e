//! The `fleetmap` binary: parses the command line and runs it (see `fleetmap --help`).

use clap::Parser;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = fleetmap::cli::Cli::parse();
    match fleetmap::cli::run(cli) {
        Ok(code) => code,
        Err(e) => {
            // One line: the error and its causes, outermost first.
            let msg = e
                .chain()
                .map(|c| c.to_string())
                .collect::<Vec<_>>()
                .join(": ");
            eprintln!("fleetmap: {msg}");
            ExitCode::FAILURE
        }
    }
}
