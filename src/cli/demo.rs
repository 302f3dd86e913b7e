//! `fleetmap demo [--headless] [--run-dir DIR]`: the embedded default — a mission kind's
//! built-in demo on the simulator in-process, flown to the end. Which kind flies, its world,
//! mission, team and report are the kind's (`crate::launch::demo::DemoKind`, chosen by its
//! flags through the registry); this file starts and flies it, written once for every kind.

use crate::app::kind::RunSettings;
use crate::cli::vehicles::block_on;
use crate::launch::demo::{DemoFlagList, DemoInputs, DemoKind, DemoOptions, DemoVisitor};
use crate::launch::{NewRun, Start, finish_exports, prepare};
use anyhow::bail;
use clap::Args;
use fleetmap_io::clock::unix_ms;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

pub(crate) use crate::launch::demo::{RadioArgs, fault_schedule};

/// Arguments of `fleetmap demo`: the flags every demo shares, and each kind's own (in the
/// registry's order; one of them chooses the kind's demo instead of the first kind's).
#[derive(Debug, Args)]
pub struct DemoArgs {
    /// The flags every demo shares.
    #[command(flatten)]
    pub options: DemoOptions,
    /// Each kind's own flags, in the registry's order.
    #[command(flatten)]
    pub(crate) kinds: crate::kinds::DemoFlags,
    /// Every vehicle behind its own simulated telemetry radio. On a radio the runway
    /// cameras classify their pictures on board, as the spatial-classification cameras
    /// always do.
    #[command(flatten)]
    pub radio: RadioArgs,
    /// A scheduled fault in the simulator, `TARGET:FAULT[@START[..END]]` (repeatable): e.g.
    /// `2:battery=20@300s`, `1:camera=off@200s..400s`, `all:outage@120s..420s`, `5:stuck@100s`
    /// (as `fleetmap sim --fault`; docs/simulator.md, "Scheduled faults").
    #[arg(long = "fault", value_name = "SPEC")]
    pub faults: Vec<String>,
}

/// Run `fleetmap demo`: the demo the flags choose.
pub fn run(args: DemoArgs) -> anyhow::Result<ExitCode> {
    args.kinds.visit(Fly(&args))
}

/// Fly the chosen kind's demo with the command line's arguments.
struct Fly<'a>(&'a DemoArgs);

impl DemoVisitor for Fly<'_> {
    type Output = anyhow::Result<ExitCode>;
    fn visit<K: DemoKind>(self, flags: &K::Flags) -> anyhow::Result<ExitCode> {
        let args = self.0;
        if let Some(why) = args.kinds.misplaced(K::KIND) {
            bail!("{why}");
        }
        let inputs = DemoInputs {
            options: &args.options,
            radio: &args.radio,
            faults: &args.faults,
        };
        let plan = K::plan(&inputs, flags)?;
        let tui = !args.options.headless && crate::cli::tui::interactive();
        let dir = args.options.run_dir.clone().unwrap_or_else(|| {
            PathBuf::from("runs").join(format!("{}-{}", K::RUN_DIR_PREFIX, unix_ms() / 1000))
        });
        block_on(async move {
            let team = K::start(plan.team).await?;
            if !tui {
                println!("{}", plan.intro);
            }
            let settings = K::settings(&inputs, &team);
            let demo = Demo {
                new: NewRun {
                    run_dir: Some(dir),
                    ..plan.new
                },
                tui,
                auto_start: plan.auto_start,
                json: args.options.json,
                label: plan.label,
            };
            demo.fly::<K>(team.fleet, team.sim, &settings).await
        })?
    }
}

/// What the demos share once their simulator is up and their state is made: the run
/// directory (with the world beside the state, so `fleetmap report DIR` scores it later),
/// then the run in the terminal UI or headless with the report.
struct Demo {
    /// The run to start (with the world, so `fleetmap report DIR` scores it later).
    new: NewRun,
    tui: bool,
    auto_start: bool,
    json: bool,
    label: String,
}

impl Demo {
    /// Start the run on the simulated fleet ([`crate::launch`], as `fleetmap run` does)
    /// and fly it to its end. Headless, the report's summary lines (or its JSON) are
    /// printed, and [`DemoKind::succeeded`] says whether the exit status is 0.
    async fn fly<K: DemoKind>(
        self,
        fleet: crate::fleet::FleetHandle,
        sim: fleetmap_sim::server::SimHandle,
        settings: &RunSettings,
    ) -> anyhow::Result<ExitCode> {
        let connections: Vec<String> = sim
            .bound
            .iter()
            .map(|b| format!("udpout:{}", b.local))
            .collect();
        let wait = Duration::from_secs(60);
        let ready = prepare::<K>(
            &fleet,
            &connections,
            Start::New(Box::new(self.new)),
            settings,
            wait,
        )
        .await;
        let ready = match ready {
            Ok(r) => r,
            Err(e) => {
                fleet.shutdown().await;
                let _ = sim.stop().await;
                return Err(e.into());
            }
        };
        let path = ready.run_dir.path().to_path_buf();
        if self.tui {
            let config = crate::cli::run::flow::ui_session(crate::tui::Source::new(
                crate::tui::SourceKind::Demo,
                self.label,
            ));
            let end = crate::tui::session::fly(ready, &fleet, config, self.auto_start).await;
            fleet.shutdown().await;
            let _ = sim.stop().await;
            let finished = end?;
            println!(
                "demo {}: run directory {} (`fleetmap report {}`)",
                if finished {
                    "finished"
                } else {
                    "stopped before the end"
                },
                path.display(),
                path.display()
            );
            return Ok(ExitCode::SUCCESS);
        }
        println!("demo: run directory {}", path.display());
        let (tx, printer) = crate::cli::run::flow::print_progress();
        let result = ready.fly_headless(&fleet, Some(tx)).await;
        let _ = tokio::time::timeout(Duration::from_secs(1), printer).await;
        fleet.shutdown().await;
        let _ = sim.stop().await;
        let (outcome, state) = result?;
        let (exports, r) = finish_exports::<K>(&path, &state).await?;
        if self.json {
            println!("{}", serde_json::to_string_pretty(&r)?);
        } else {
            for l in K::summary(&r) {
                println!("{l}");
            }
            for e in &exports {
                println!("  wrote {}", e.display());
            }
            println!(
                "  `fleetmap report {}` and `fleetmap export {} --format {}` work on this run",
                path.display(),
                path.display(),
                match K::EXPORTS[0] {
                    crate::app::kind::ExportFormat::Png => "png",
                    _ => "kml",
                }
            );
        }
        Ok(if K::succeeded(&outcome, &r) {
            ExitCode::SUCCESS
        } else {
            ExitCode::FAILURE
        })
    }
}
