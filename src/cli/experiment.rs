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

/// The studies.
#[derive(Debug, Subcommand)]
pub enum ExperimentCommand {
    /// Runway paper §6, Fig. 7: Algorithm 1 on random grid ROIs against Lemma 1, Lemma 2 and
    /// the lawnmower baseline (CSV, JSON summary, PNG plots in --out).
    Dfs(crate::experiment::dfs::DfsArgs),
    /// The bandit paper's Monte Carlo study (Tables I–IV, Fig. 5, Fig. 6).
    Bandit(super::bandit::ExperimentBanditArgs),
    /// Join the parts of a bandit study run with `experiment bandit --shard K/N` (e.g. the
    /// tasks of a cluster's job array) into the study's CSV, summary, table and plot.
    Merge(super::bandit::MergeArgs),
    /// Fast = plain at the bandit paper's scale: both IP models on random
    /// Algorithm 1 epochs (10×10, 10 drones, 5 stations, Td = 8, Tc = 4, C = 1, 2, 3); exit
    /// status 1 on any difference.
    FastPlain(FastPlainArgs),
    /// The runway field test flown by teams of drones on the embedded simulator —
    /// time to the complete map and to the last landing, IoU and swaps per team size, and
    /// where each drone's time went (CSV, JSON summary, PNG in --out).
    Runway(crate::experiment::runway::RunwayArgs),
}

/// Arguments of `fleetmap experiment fast-plain` (defaults: the paper's §VI setting).
#[derive(Debug, Args)]
pub struct FastPlainArgs {
    /// Instances per capacity.
    #[arg(long, default_value_t = 50)]
    pub instances: usize,
    /// Charger capacities C of eq. (10), comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1,2,3")]
    pub capacity: Vec<usize>,
    /// Seed of the worlds, epochs and measurements.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// HiGHS time limit per solve, seconds (a time-limited solve counts as unknown, not as a
    /// difference).
    #[arg(long, default_value_t = 120.0)]
    pub time_limit: f64,
    /// Grid side (cells).
    #[arg(long, default_value_t = 10)]
    pub size: usize,
    /// Obstacles per world.
    #[arg(long, default_value_t = 16)]
    pub obstacles: usize,
    /// Drones N_d (cut to C·N_c when fewer fit on the chargers).
    #[arg(long, default_value_t = 10)]
    pub drones: usize,
    /// Stations N_c.
    #[arg(long, default_value_t = 5)]
    pub stations: usize,
    /// Goals per epoch, D.
    #[arg(long, default_value_t = 8)]
    pub goals: usize,
    /// Drone steps per sensing cycle, T_d.
    #[arg(long, default_value_t = 8)]
    pub td: usize,
    /// Station steps per sensing cycle, T_c.
    #[arg(long, default_value_t = 4)]
    pub tc: usize,
    /// Bounds K on the cycles, comma-separated; instance n uses the (n mod len)-th.
    #[arg(long, value_delimiter = ',', default_value = "1,2,3")]
    pub cycles: Vec<usize>,
    /// Instance n's team comes from Algorithm 1's epoch p, drawn from 0 ..= this.
    #[arg(long, default_value_t = 12)]
    pub max_epoch: usize,
    /// Print the whole study as JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
    /// Directory for fast_plain.csv, fast_plain.json and the scenario file of every difference
    /// and every unknown instance (created if missing).
    #[arg(long, value_name = "DIR", default_value = "experiment-fast-plain")]
    pub out: std::path::PathBuf,
}

/// Run a study.
pub fn run(args: ExperimentArgs) -> anyhow::Result<ExitCode> {
    match args.which {
        ExperimentCommand::Dfs(a) => run_dfs(a),
        ExperimentCommand::Bandit(a) => super::bandit::run_experiment(a),
        ExperimentCommand::Merge(a) => super::bandit::run_merge(a),
        ExperimentCommand::FastPlain(a) => run_fast_plain(a),
        ExperimentCommand::Runway(a) => run_runway(a),
    }
}

/// `fleetmap experiment runway`: fly every trial (a line on stderr as each ends), write the
/// outputs, print the tables (or the study as JSON with `--json`); exit status 1 when a trial
/// did not finish.
fn run_runway(args: crate::experiment::runway::RunwayArgs) -> anyhow::Result<ExitCode> {
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

/// `fleetmap experiment fast-plain`: print each instance as it is decided (stdout, or stderr
/// with `--json`), write the CSV, the JSON study and one scenario file per difference
/// atomically into `--out`, print the summary, and exit with status 1 on any difference.
fn run_fast_plain(args: FastPlainArgs) -> anyhow::Result<ExitCode> {
    use crate::experiment::fastplain::{self, FastPlainConfig};
    use anyhow::Context;
    let cfg = FastPlainConfig {
        instances: args.instances,
        capacities: args.capacity,
        seed: args.seed,
        time_limit: Some(args.time_limit),
        size: args.size,
        obstacles: args.obstacles,
        drones: args.drones,
        stations: args.stations,
        goals: args.goals,
        td: args.td,
        tc: args.tc,
        cycles: args.cycles,
        max_epoch: args.max_epoch,
    };
    fastplain::validate(&cfg)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let json = args.json;
    let line = |s: String| {
        if json {
            eprintln!("{s}");
        } else {
            println!("{s}");
        }
    };
    line(fastplain::header());
    let clock = fleetmap_io::clock::stopwatch();
    let study = fastplain::run(&cfg, &clock, &mut |r| line(fastplain::row_line(r)))?;
    let write = |name: &str, bytes: &[u8]| -> anyhow::Result<std::path::PathBuf> {
        let path = args.out.join(name);
        fleetmap_io::files::atomic_write(&path, bytes)
            .with_context(|| format!("cannot write {}", path.display()))?;
        Ok(path)
    };
    let mut files = vec![
        write("fast_plain.csv", fastplain::rows_csv(&study).as_bytes())?,
        write(
            "fast_plain.json",
            serde_json::to_string_pretty(&study)?.as_bytes(),
        )?,
    ];
    for r in &study.rows {
        if let Some(scen) = &r.scenario {
            let kind = match r.verdict {
                fastplain::Verdict::Difference(_) => "difference",
                _ => "unknown",
            };
            files.push(write(
                &format!("{kind}-C{}-{}.json", r.capacity, r.index),
                scen.as_bytes(),
            )?);
        }
    }
    if json {
        println!("{}", serde_json::to_string_pretty(&study)?);
        eprint!("{}", fastplain::summary_lines(&study));
    } else {
        print!("{}", fastplain::summary_lines(&study));
        for f in &files {
            println!("wrote {}", f.display());
        }
    }
    if study.summary.differences == 0 {
        Ok(ExitCode::SUCCESS)
    } else {
        for r in &study.rows {
            if let fastplain::Verdict::Difference(why) = &r.verdict {
                eprintln!(
                    "fleetmap: DIFFERENCE at C = {}, instance {} (world seed {}, K = {}): {why}",
                    r.capacity, r.index, r.world_seed, r.k_max
                );
            }
        }
        Ok(ExitCode::FAILURE)
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
