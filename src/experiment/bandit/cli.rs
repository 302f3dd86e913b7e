//! The spatial classification's studies on the command line: `fleetmap experiment bandit`
//! (the bandit paper's Monte Carlo study, §VI), `experiment merge` (the parts of a study run
//! with `--shard`) and `experiment fast-plain` (both IP models on the same epochs).

use super::fastplain::{self, FastPlainConfig};
use super::shard::{self, SHARD_FORMAT, Shard, ShardFile};
use super::{Preset, Sensing, Study, StudyConfig, TrialResult, VariantSummary, paper, plot, table};
use crate::experiment::Emit;
use crate::kinds::bandit::BoundArg;
use anyhow::Context;
use clap::{Args, Subcommand, ValueEnum};
use fleetmap_core::planner::bandit::{ConfidenceBound, LogBase};
use fleetmap_core::planner::baselines::GoalRule;
use fleetmap_io::files::atomic_write;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// The spatial classification's studies, subcommands of `fleetmap experiment`.
#[derive(Debug, Subcommand)]
pub enum Studies {
    /// The bandit paper's Monte Carlo study (Tables I–IV, Fig. 5, Fig. 6).
    Bandit(ExperimentBanditArgs),
    /// Join the parts of a bandit study run with `experiment bandit --shard K/N` (e.g. the
    /// tasks of a cluster's job array) into the study's CSV, summary, table and plot.
    Merge(MergeArgs),
    /// Fast = plain at the bandit paper's scale: both IP models on random
    /// Algorithm 1 epochs (10×10, 10 drones, 5 stations, Td = 8, Tc = 4, C = 1, 2, 3); exit
    /// status 1 on any difference.
    FastPlain(FastPlainArgs),
}

impl Studies {
    /// Run the study; `emit` prints a result on stdout.
    pub(crate) fn run(self, emit: Emit) -> anyhow::Result<ExitCode> {
        match self {
            Studies::Bandit(a) => run_experiment(a, emit),
            Studies::Merge(a) => run_merge(a, emit),
            Studies::FastPlain(a) => run_fast_plain(a),
        }
    }
}

/// The presets of `fleetmap experiment bandit`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum PresetArg {
    /// Table I and Fig. 5: worst-case sensor accuracy 0.6, 0.8, 1.0.
    Table1,
    /// Table II: epoch goals D = 5, 8, 10, 15.
    Table2,
    /// Table III: nine (Td, Tc) agility settings.
    Table3,
    /// Table IV: team sizes (Nd, Nc).
    Table4,
    /// Fig. 6: UCB against Random, GreedyCov, GreedyTrav (and the improved APT), D = 10.
    Fig6,
    /// The faithful UCB high level next to the improved APT one (Table I's default row).
    Compare,
}

impl PresetArg {
    fn preset(self) -> Preset {
        match self {
            PresetArg::Table1 => Preset::Table1,
            PresetArg::Table2 => Preset::Table2,
            PresetArg::Table3 => Preset::Table3,
            PresetArg::Table4 => Preset::Table4,
            PresetArg::Fig6 => Preset::Fig6,
            PresetArg::Compare => Preset::Compare,
        }
    }
}

/// A goal rule on the command line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum RuleArg {
    /// The paper's UCB rule (3).
    Ucb,
    /// The improved APT rule (most ambiguous cells).
    Apt,
    /// Baseline: random unclassified cells.
    Random,
    /// Baseline: least-sampled cells, spread out.
    GreedyCov,
    /// Baseline: cells nearest the team.
    GreedyTrav,
}

impl RuleArg {
    fn rule(self) -> GoalRule {
        match self {
            RuleArg::Ucb => GoalRule::Ucb,
            RuleArg::Apt => GoalRule::Apt,
            RuleArg::Random => GoalRule::Random,
            RuleArg::GreedyCov => GoalRule::GreedyCov,
            RuleArg::GreedyTrav => GoalRule::GreedyTrav,
        }
    }
}

/// What counts as a cell visit.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum SensingArg {
    /// Each arrival at a cell (hovering in place is one visit).
    Visits,
    /// Each time step on a cell.
    Steps,
}

/// The base of `log` in (3b).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum LogBaseArg {
    /// Natural logarithms (the paper as written).
    E,
    /// Base-10 logarithms.
    #[value(name = "10")]
    Ten,
}

/// The paper's tables and figure, as `--table` names them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum TableArg {
    /// Table I and Fig. 5 (worst-case sensor accuracy).
    #[value(name = "I")]
    I,
    /// Table II (epoch goals D).
    #[value(name = "II")]
    Ii,
    /// Table III (agility Td, Tc).
    #[value(name = "III")]
    Iii,
    /// Table IV (team size Nd, Nc).
    #[value(name = "IV")]
    Iv,
    /// Fig. 6 (Algorithm 1 against the baselines).
    #[value(name = "fig6")]
    Fig6,
}

impl TableArg {
    fn preset(self) -> Preset {
        match self {
            TableArg::I => Preset::Table1,
            TableArg::Ii => Preset::Table2,
            TableArg::Iii => Preset::Table3,
            TableArg::Iv => Preset::Table4,
            TableArg::Fig6 => Preset::Fig6,
        }
    }
}

/// Arguments of `fleetmap experiment bandit`.
#[derive(Debug, Args)]
pub struct ExperimentBanditArgs {
    /// The paper's table or figure to reproduce, with the paper's number of trials; the
    /// printed table puts the paper's row under ours.
    #[arg(long, value_enum, ignore_case = true, conflicts_with = "preset")]
    pub table: Option<TableArg>,
    /// The same studies by preset name, and `compare` (Algorithm 1 beside its improvements).
    #[arg(long, value_enum, default_value_t = PresetArg::Table1)]
    pub preset: PresetArg,
    /// Monte Carlo trials per variant (default: the paper's, 100 for Table I, 50 for the others).
    #[arg(long)]
    pub trials: Option<usize>,
    /// Study seed (trial t uses the same world in every variant).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Run only part K of N of the trials (those with trial mod N = K − 1) and write them to
    /// shard-K-of-N.json in --out; `fleetmap experiment merge` joins the N parts.
    #[arg(long, value_name = "K/N")]
    pub shard: Option<Shard>,
    /// Output directory for trials.csv, epochs.csv, table.csv, table.txt, summary.json and
    /// progress.png (default results/bandit-PRESET).
    #[arg(long, value_name = "DIR")]
    pub out: Option<PathBuf>,
    /// Only the variants whose label contains this text (e.g. `mu_worst=0.8`).
    #[arg(long, value_name = "TEXT")]
    pub only: Option<String>,
    /// Choose epoch goals with this rule in every variant (not for fig6/compare).
    #[arg(long, value_enum)]
    pub rule: Option<RuleArg>,
    /// Stop a trial after this many epochs (reported as censored).
    #[arg(long, default_value_t = 1000)]
    pub max_epochs: usize,
    /// Trials run in parallel (default: the number of CPU cores). HiGHS uses one thread each.
    #[arg(long)]
    pub(crate) jobs: Option<usize>,
    /// δ, the labelling error probability (the paper's Fig. 2 value by default).
    #[arg(long, default_value_t = 1e-4)]
    pub delta: f64,
    /// ε, the labelling tolerance (the paper's Fig. 2 value by default).
    #[arg(long, default_value_t = 0.05)]
    pub epsilon: f64,
    /// What counts as a cell visit giving B measurements (sensitivity option).
    #[arg(long, value_enum, default_value_t = SensingArg::Visits)]
    pub sensing: SensingArg,
    /// Base of `log` in (3b): e as written in the paper, or 10 (sensitivity option).
    #[arg(long, value_enum, default_value_t = LogBaseArg::E)]
    pub log_base: LogBaseArg,
    /// The confidence interval of (3) and (4): the paper's (3b) (default, to reproduce its
    /// tables) or the KL bound.
    #[arg(long, value_enum, default_value_t = BoundArg::Paper)]
    pub bound: BoundArg,
    /// Print the summary as JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
}

/// Arguments of `fleetmap experiment merge`.
#[derive(Debug, Args)]
pub struct MergeArgs {
    /// The parts: shard-K-of-N.json files, or directories holding them.
    #[arg(required = true, value_name = "PART")]
    pub parts: Vec<PathBuf>,
    /// Where to write the joined study's trials.csv, epochs.csv, table.csv, table.txt,
    /// summary.json and progress.png.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Print the summary as JSON on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
}

/// The study the arguments describe (preset, variants with the options applied, trials).
fn study_of(args: &ExperimentBanditArgs) -> anyhow::Result<Study> {
    let preset = args.table.map_or(args.preset.preset(), TableArg::preset);
    // Each row keeps its position in the whole table as its sensing stream.
    let (mut streams, mut variants): (Vec<usize>, Vec<StudyConfig>) =
        preset.variants().into_iter().enumerate().unzip();
    if let Some(only) = &args.only {
        (streams, variants) = streams
            .into_iter()
            .zip(variants)
            .filter(|(_, v)| v.label.contains(only.as_str()))
            .unzip();
        if variants.is_empty() {
            anyhow::bail!(
                "--only {only:?} matches no variant of {} (labels: {})",
                preset.name(),
                preset
                    .variants()
                    .iter()
                    .map(|v| v.label.clone())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
    }
    if let Some(rule) = args.rule {
        if matches!(preset, Preset::Fig6 | Preset::Compare) {
            anyhow::bail!(
                "--rule cannot be combined with --preset {} (it compares rules)",
                preset.name()
            );
        }
        for v in &mut variants {
            v.rule = rule.rule();
            v.label = format!("{} [{}]", v.label, rule.rule().name());
        }
    }
    if args.max_epochs == 0 {
        anyhow::bail!("--max-epochs must be at least 1");
    }
    if !(args.delta > 0.0 && args.delta < 1.0) {
        anyhow::bail!("--delta must be in (0, 1), got {}", args.delta);
    }
    if !(args.epsilon > 0.0 && args.epsilon < 1.0) {
        anyhow::bail!("--epsilon must be in (0, 1), got {}", args.epsilon);
    }
    for v in &mut variants {
        v.max_epochs = args.max_epochs;
        v.delta = args.delta;
        v.epsilon = args.epsilon;
        v.sensing = match args.sensing {
            SensingArg::Visits => Sensing::Visits,
            SensingArg::Steps => Sensing::Steps,
        };
        v.log_base = match args.log_base {
            LogBaseArg::E => LogBase::Natural,
            LogBaseArg::Ten => LogBase::Ten,
        };
        v.bound = args.bound.bound();
        if v.bound != ConfidenceBound::Paper {
            v.label = format!("{} [bound {}]", v.label, v.bound);
        }
    }
    let trials = args.trials.unwrap_or(paper::trials(preset));
    if trials == 0 {
        anyhow::bail!("--trials must be at least 1");
    }
    Ok(Study {
        preset,
        seed: args.seed,
        trials,
        variants,
        streams,
    })
}

/// The command line that is running, for the summary (how the results were made).
fn command_line() -> String {
    let mut words = vec!["fleetmap".to_string()];
    words.extend(std::env::args().skip(1).map(|a| {
        if a.is_empty() || a.contains(char::is_whitespace) {
            format!("{a:?}")
        } else {
            a
        }
    }));
    words.join(" ")
}

/// Run `fleetmap experiment bandit`: the whole study (outputs in --out, the table on stdout),
/// or one part of it (`--shard`: a shard file in --out).
fn run_experiment(args: ExperimentBanditArgs, emit: Emit) -> anyhow::Result<ExitCode> {
    let study = study_of(&args)?;
    let shard = args.shard.unwrap_or(Shard::WHOLE);
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from(format!("results/bandit-{}", study.preset.name())));
    std::fs::create_dir_all(&out_dir)
        .with_context(|| format!("cannot create output directory {}", out_dir.display()))?;
    let jobs = args
        .jobs
        .unwrap_or_else(|| std::thread::available_parallelism().map_or(1, |n| n.get()))
        .max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(jobs)
        .build()
        .context("cannot start the worker threads")?;
    let tasks = study.tasks(shard);
    let bar = if args.quiet {
        ProgressBar::hidden()
    } else {
        let b =
            ProgressBar::with_draw_target(Some(tasks.len() as u64), ProgressDrawTarget::stderr());
        b.set_style(
            ProgressStyle::with_template(
                "{prefix} [{elapsed_precise}] {wide_bar} {pos}/{len} trials (eta {eta})",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        b.set_prefix(format!("bandit {} {shard}", study.preset.name()));
        b
    };
    let results: Vec<TrialResult> = pool.install(|| {
        tasks
            .par_iter()
            .map(|&(v, t)| {
                let r = study.run(v, t);
                bar.inc(1);
                r
            })
            .collect()
    });
    bar.finish_and_clear();
    if shard != Shard::WHOLE {
        let file = ShardFile {
            format: SHARD_FORMAT,
            study,
            shard,
            results,
        };
        let path = out_dir.join(shard.file_name());
        let json = serde_json::to_vec(&file)?;
        atomic_write(&path, &json).with_context(|| format!("cannot write {}", path.display()))?;
        emit(&format!(
            "part {shard} of the study: {} trials in {}; join the {} parts with `fleetmap experiment merge PART... --out DIR`\n",
            file.results.len(),
            path.display(),
            shard.count
        ))?;
        return Ok(ExitCode::SUCCESS);
    }
    write_study(&study, &results, &out_dir, &command_line(), args.json, emit)?;
    Ok(ExitCode::SUCCESS)
}

/// The shard files a merge argument names: the file itself, or a directory's
/// `shard-*.json` files.
fn shard_files(p: &Path) -> anyhow::Result<Vec<PathBuf>> {
    if !p.is_dir() {
        return Ok(vec![p.to_path_buf()]);
    }
    let mut found: Vec<PathBuf> = std::fs::read_dir(p)
        .with_context(|| format!("cannot list {}", p.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|f| {
            f.file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.starts_with("shard-") && n.ends_with(".json"))
        })
        .collect();
    if found.is_empty() {
        anyhow::bail!("{} holds no shard-K-of-N.json file", p.display());
    }
    found.sort();
    Ok(found)
}

/// Run `fleetmap experiment merge`: join the parts of a study and write what the undivided
/// run would have written.
fn run_merge(args: MergeArgs, emit: Emit) -> anyhow::Result<ExitCode> {
    let mut parts = Vec::new();
    for p in &args.parts {
        for f in shard_files(p)? {
            let bytes =
                std::fs::read(&f).with_context(|| format!("cannot read {}", f.display()))?;
            let part: ShardFile = serde_json::from_slice(&bytes)
                .with_context(|| format!("{} is not a part of a study", f.display()))?;
            parts.push((f.display().to_string(), part));
        }
    }
    let (study, results) = shard::merge(parts)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create output directory {}", args.out.display()))?;
    write_study(
        &study,
        &results,
        &args.out,
        &command_line(),
        args.json,
        emit,
    )?;
    Ok(ExitCode::SUCCESS)
}

/// Write a whole study's outputs to `out_dir` and print its table (or its summary JSON).
fn write_study(
    study: &Study,
    results: &[TrialResult],
    out_dir: &Path,
    command: &str,
    json: bool,
    emit: Emit,
) -> anyhow::Result<()> {
    let summaries: Vec<VariantSummary> = study.summarise(results);
    let write = |name: &str, bytes: &[u8]| -> anyhow::Result<()> {
        let p = out_dir.join(name);
        atomic_write(&p, bytes).with_context(|| format!("cannot write {}", p.display()))
    };
    write("trials.csv", table::trials_csv(results).as_bytes())?;
    write("epochs.csv", table::epochs_csv(results).as_bytes())?;
    write("table.csv", table::table_csv(&summaries).as_bytes())?;
    let printed = table::printed(study, &summaries, &out_dir.display().to_string());
    write("table.txt", printed.as_bytes())?;
    let summary = table::StudySummary::new(study, command, &summaries);
    let summary_json = serde_json::to_string_pretty(&summary)?;
    write("summary.json", summary_json.as_bytes())?;
    let title = match study.preset {
        Preset::Table1 => {
            "Classification progress vs worst-case sensor accuracy (Fig. 5)".to_string()
        }
        Preset::Fig6 => "Classification progress: Algorithm 1 vs baselines (Fig. 6)".to_string(),
        p => format!("Classification progress, {}", table::title(p)),
    };
    let png = plot::progress_png(
        &title,
        &summaries,
        study.preset == Preset::Table1,
        1100,
        700,
    )?;
    write("progress.png", &png)?;
    emit(&if json { summary_json + "\n" } else { printed })
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

/// `fleetmap experiment fast-plain`: print each instance as it is decided (stdout, or stderr
/// with `--json`), write the CSV, the JSON study and one scenario file per difference
/// atomically into `--out`, print the summary, and exit with status 1 on any difference.
fn run_fast_plain(args: FastPlainArgs) -> anyhow::Result<ExitCode> {
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
