//! `fleetmap experiment …`: the papers' Monte Carlo studies (CSV, JSON summary, PNG plots).

use clap::{Args, Subcommand};
use std::process::ExitCode;

/// Arguments of `fleetmap experiment`.
#[derive(Debug, Args)]
pub struct ExperimentArgs {
    /// Which study.
    #[command(subcommand)]
    pub which: ExperimentCommand,
}

/// The studies: the DFS study here, every mission kind's from its folder.
#[derive(Debug, Subcommand)]
pub enum ExperimentCommand {
    /// Runway paper §6, Fig. 7: Algorithm 1 on random grid ROIs against Lemma 1, Lemma 2 and
    /// the lawnmower baseline (CSV, JSON summary, PNG plots in --out).
    Dfs(crate::experiment::dfs::DfsArgs),
    #[command(flatten)]
    #[allow(missing_docs)]
    Kind(crate::experiment::KindStudies),
}

/// Run a study.
pub fn run(args: ExperimentArgs) -> anyhow::Result<ExitCode> {
    match args.which {
        ExperimentCommand::Dfs(a) => run_dfs(a),
        ExperimentCommand::Kind(s) => s.run(crate::kinds::emit),
    }
}

/// `fleetmap experiment dfs`: run, write the outputs, print the table (or the JSON summary
/// with `--json`), and fail loudly if any trial exceeded Lemma 1.
fn run_dfs(args: crate::experiment::dfs::DfsArgs) -> anyhow::Result<ExitCode> {
    use crate::experiment::dfs;
    use anyhow::Context;
    let total = (dfs::configurations(&args).len() * args.trials) as u64;
    let bar = indicatif::ProgressBar::with_draw_target(
        Some(total),
        indicatif::ProgressDrawTarget::stderr(),
    );
    bar.set_style(
        indicatif::ProgressStyle::with_template(
            "dfs study {bar:40} {pos}/{len} trials [{elapsed_precise}, eta {eta}]",
        )
        .context("progress bar template")?,
    );
    let study = dfs::run(&args, &|| bar.inc(1)).context("dfs study")?;
    bar.finish_and_clear();
    let files = dfs::write_outputs(&study, &args.out).context("dfs study outputs")?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&study)?);
    } else {
        print!("{}", dfs::table(&study));
        for f in &files {
            println!("wrote {}", f.display());
        }
    }
    let lines = dfs::violation_lines(&study);
    if lines.is_empty() {
        eprintln!(
            "fleetmap: every one of the {} trials stayed within the Lemma 1 upper bound",
            study.records.len()
        );
        Ok(ExitCode::SUCCESS)
    } else {
        eprintln!(
            "fleetmap: LEMMA 1 VIOLATED in {} of {} trials:",
            lines.len(),
            study.records.len()
        );
        for l in lines.iter().take(20) {
            eprintln!("  {l}");
        }
        if lines.len() > 20 {
            eprintln!("  … and {} more (see dfs_trials.csv)", lines.len() - 20);
        }
        Ok(ExitCode::FAILURE)
    }
}
