//! The runway's study on the command line: `fleetmap experiment runway`.

use crate::experiment::Emit;
use clap::Subcommand;
use std::process::ExitCode;

/// The runway's studies, subcommands of `fleetmap experiment`.
#[derive(Debug, Subcommand)]
pub enum Studies {
    /// The runway field test flown by teams of drones on the embedded simulator —
    /// time to the complete map and to the last landing, IoU and swaps per team size, and
    /// where each drone's time went (CSV, JSON summary, PNG in --out).
    Runway(super::RunwayArgs),
}

impl Studies {
    /// Run the study (its tables printed as they come: `emit` is not needed).
    pub(crate) fn run(self, _: Emit) -> anyhow::Result<ExitCode> {
        match self {
            Studies::Runway(a) => run_runway(a),
        }
    }
}

/// `fleetmap experiment runway`: fly every trial (a line on stderr as each ends), write the
/// outputs, print the tables (or the study as JSON with `--json`); exit status 1 when a trial
/// did not finish.
fn run_runway(args: super::RunwayArgs) -> anyhow::Result<ExitCode> {
    use crate::experiment::runway;
    runway::validate(&args)?;
    eprintln!(
        "runway study: {} trial(s) of {:?} drone(s), the simulator in {}",
        args.trials, args.drones, args.speedup
    );
    let study = runway::run(&args, &mut |t| {
        eprintln!("{}", runway::output::trial_line(t))
    })?;
    let files = runway::output::write_outputs(&study, &args.out)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&study)?);
    } else {
        print!("{}", runway::output::table(&study));
        for f in &files {
            println!("wrote {}", f.display());
        }
    }
    let unfinished = study.trials.iter().filter(|t| !t.finished).count();
    if unfinished == 0 {
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!(
            "fleetmap: {unfinished} of {} trial(s) did not finish (see runway_trials.csv)",
            study.trials.len()
        );
        Ok(ExitCode::FAILURE)
    }
}
