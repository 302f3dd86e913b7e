//! `fleetmap plan --scenario FILE.json [--json]`: solve one epoch of the bandit paper's
//! low-level planner (the IP (11), Algorithm 2) for a scenario file (docs/ip-scenario.md).

use super::ModelArg;
use anyhow::Context;
use clap::Args;
use fleetmap_core::planner::ip::{PlanOptions, PlanOutcome, PlanStatus, solve_instance};
use fleetmap_core::planner::scenario::Scenario;
use fleetmap_core::planner::scenario::ScenarioError;
use std::fmt::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

/// Arguments of `fleetmap plan`.
#[derive(Debug, Args)]
pub struct PlanArgs {
    /// The scenario file (JSON, docs/ip-scenario.md).
    #[arg(long, value_name = "FILE.json")]
    pub scenario: PathBuf,
    /// Print the result as JSON (the spec's output object) instead of text.
    #[arg(long)]
    pub json: bool,
    /// The IP formulation.
    #[arg(long, value_enum, default_value_t = ModelArg::Fast)]
    pub model: ModelArg,
    /// HiGHS threads.
    #[arg(long, default_value_t = 1)]
    pub threads: u32,
    /// Give up after this many seconds (status "time_limit").
    #[arg(long, value_name = "SECONDS")]
    pub time_limit: Option<f64>,
    /// Skip the linear-assignment re-pairing of §III-C.
    #[arg(long)]
    pub(crate) no_repair: bool,
}

/// Run `fleetmap plan`. Exit status 0 for "optimal", "infeasible" and "time_limit" (the answer
/// is in the output), 1 for a malformed scenario or a solver error.
pub fn run(args: PlanArgs) -> anyhow::Result<ExitCode> {
    let text = std::fs::read_to_string(&args.scenario)
        .with_context(|| format!("cannot read scenario {}", args.scenario.display()))?;
    let scenario = Scenario::from_json(&text)
        .with_context(|| format!("scenario {}", args.scenario.display()))?;
    // A well-formed scenario that no plan can satisfy whatever K is the answer "infeasible"
    // (docs/ip-scenario.md lists what is malformed); only malformed input is an error.
    // `Err(ScenarioError::Infeasible(reason))`: no plan can exist whatever K.
    let inst = match scenario.instance() {
        Ok(inst) => Ok(inst),
        Err(e @ ScenarioError::Infeasible(_)) => Err(e),
        Err(e) => {
            return Err(anyhow::Error::new(e))
                .with_context(|| format!("scenario {}", args.scenario.display()));
        }
    };
    if let Some(t) = args.time_limit
        && !(t > 0.0 && t.is_finite())
    {
        anyhow::bail!("--time-limit must be a positive number of seconds, got {t}");
    }
    let opts = PlanOptions {
        model: args.model.into(),
        threads: args.threads.max(1),
        time_limit: args.time_limit,
        repair: !args.no_repair,
        ..PlanOptions::default()
    };
    let outcome = match &inst {
        Ok(inst) => solve_instance(inst, &opts, &fleetmap_io::clock::stopwatch()),
        Err(ScenarioError::Infeasible(reason)) => PlanOutcome::never(reason.clone()),
        Err(other) => PlanOutcome::never(other.to_string()),
    };
    let mut out = String::new();
    if args.json {
        out.push_str(&serde_json::to_string(&outcome.output())?);
        out.push('\n');
    } else {
        let name = if scenario.name.is_empty() {
            args.scenario.display().to_string()
        } else {
            scenario.name.clone()
        };
        writeln!(out, "scenario: {name}")?;
        writeln!(
            out,
            "status: {}   cycles: {}   solve: {:.3} s   variables: {}   constraints: {}",
            outcome.status.as_str(),
            outcome.plan.as_ref().map_or(0, |p| p.cycles),
            outcome.solve_seconds,
            outcome.variables,
            outcome.constraints
        )?;
        for a in &outcome.attempts {
            writeln!(
                out,
                "  model with {} cycle(s): {}{} in {:.3} s ({} variables, {} constraints)",
                a.cycles,
                a.status.as_str(),
                if a.presolved { " by reachability" } else { "" },
                a.seconds,
                a.variables,
                a.constraints
            )?;
        }
        if outcome.status == PlanStatus::Infeasible && inst.is_ok() {
            writeln!(
                out,
                "no plan visits every goal within K = {} cycles",
                scenario.k
            )?;
        }
        if !outcome.message.is_empty() {
            let who = if inst.is_ok() {
                "solver"
            } else {
                "no plan can exist whatever K"
            };
            writeln!(out, "{who}: {}", outcome.message)?;
        }
        if let Some(plan) = &outcome.plan {
            let fmt = |cells: &[fleetmap_core::geo::Cell]| {
                cells
                    .iter()
                    .map(|c| format!("[{},{}]", c.row, c.col))
                    .collect::<Vec<_>>()
                    .join(" ")
            };
            for (i, cycles) in plan.drones.iter().enumerate() {
                for (k, steps) in cycles.iter().enumerate() {
                    writeln!(out, "drone {i} cycle {k}: {}", fmt(steps))?;
                }
            }
            for (a, cycles) in plan.stations.iter().enumerate() {
                for (k, steps) in cycles.iter().enumerate() {
                    writeln!(out, "station {a} cycle {k}: {}", fmt(steps))?;
                }
            }
        }
    }
    crate::kinds::emit(&out)?;
    Ok(if outcome.status == PlanStatus::Error {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

