//! The `fleetmap` binary: parses the command line and runs it (see `fleetmap --help`).

use clap::Parser;
use clap::error::ErrorKind;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = match fleetmap::cli::Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) => {
            if matches!(
                e.kind(),
                ErrorKind::DisplayHelp
                    | ErrorKind::DisplayVersion
                    | ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand
            ) {
                // Help and version are what the user asked for: print them whole.
                let _ = e.print();
                return if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand {
                    ExitCode::from(2)
                } else {
                    ExitCode::SUCCESS
                };
            }
            // A usage error: one line, the way every other error is reported.
            let rendered = e.render().to_string();
            // clap's message is the paragraph before "Usage:"; fold it onto one line.
            let message = rendered
                .lines()
                .take_while(|l| !l.starts_with("Usage:"))
                .map(str::trim)
                .filter(|l| !l.is_empty() && !l.starts_with("tip:"))
                .collect::<Vec<_>>()
                .join(" ");
            let message = message.trim_start_matches("error: ");
            eprintln!("fleetmap: {message} (see --help)");
            return ExitCode::from(2);
        }
    };
    match fleetmap::cli::run(cli) {
        Ok(code) => code,
        Err(e) => {
            // One line: the error and its causes, outermost first, each said once.
            eprintln!("fleetmap: {}", fleetmap::cli::error_line(&e));
            ExitCode::FAILURE
        }
    }
}
