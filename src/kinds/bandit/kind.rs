//! Spatial classification as a [`RunKind`]: what the commands, the TUI session and the demo
//! need.

use super::report::{self, ClassificationReport};
use super::{BanditEvent, KIND, RunOptions};
use crate::app::command::{Command, CommandError, Target};
use crate::app::error::{Check, RunError, RunnerError};
use crate::app::flight::Patience;
use crate::app::kind::{Attached, CommandReply, ExportFormat, Outcome, RunKind, RunSettings};
use crate::app::run::Progress;
use crate::app::team::heard;
use crate::fleet::FleetHandle;
use crate::panes::{KindLook, Panes, RunInfo, Sample};
use crate::store::RunDir;
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::planner::sortie::ClassificationState;
use fleetmap_core::world::World;
use fleetmap_io::watch;
use std::path::Path;
use std::time::Duration;
use tokio::sync::mpsc;

/// Spatial classification (the bandit paper): UCB epochs, integer-program sorties with
/// charging rovers.
pub struct Classification;

/// The size of the progress PNG (the bandit paper's Fig. 4), pixels.
const PROGRESS_PNG: (u32, u32) = (900, 560);

/// The operator's pause of a spatial-classification run (the TUI): while it is `true`, no
/// new sortie starts — the drones in the air finish theirs and land on their stations.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Pause(pub bool);

impl RunKind for Classification {
    const KIND: &'static str = KIND;
    const LOOK: KindLook = super::panes::LOOK;
    const EXPORTS: [ExportFormat; 3] =
        [ExportFormat::Png, ExportFormat::Geojson, ExportFormat::Kml];
    type State = ClassificationState;
    type Options = RunOptions;
    type Event = BanditEvent;
    type Report = ClassificationReport;
    type Operator = Pause;

    fn mission(state: &ClassificationState) -> &str {
        &state.mission
    }

    fn is_finished(state: &ClassificationState) -> bool {
        state.is_finished()
    }

    fn sysids(state: &ClassificationState) -> Vec<u8> {
        state.sysids()
    }

    fn options(settings: &RunSettings) -> Result<RunOptions, RunError> {
        if let Some(t) = settings.plan_time_limit_s
            && !(t.is_finite() && t > 0.0)
        {
            return Err(RunError::Option(
                "--plan-time-limit must be a positive number of seconds".into(),
            ));
        }
        Ok(RunOptions {
            patience: Patience {
                factor: settings.patience,
            },
            plan_time_limit_s: settings.plan_time_limit_s,
            auto_resume: settings.auto_resume,
            ..RunOptions::default()
        })
    }

    async fn new_state(
        fleet: &FleetHandle,
        def: &MissionDef,
        settings: &RunSettings,
        wait: Duration,
    ) -> Result<ClassificationState, RunError> {
        Ok(super::new_state(fleet, def, wait, settings.lock_step).await?)
    }

    fn summary_lines(def: &MissionDef) -> Vec<String> {
        super::summary::summary_lines(def)
    }

    fn started_line(dir: &Path, state: &ClassificationState) -> String {
        format!(
            "run directory {} — {}: {} candidate cells, {} drone(s), {} station(s), {:?} separation",
            dir.display(),
            state.mission,
            state.bandit.len(),
            state.drones.len(),
            state.stations.len(),
            state.params.separation
        )
    }

    async fn prepare_resume(
        fleet: &FleetHandle,
        state: &mut ClassificationState,
        _settings: &RunSettings,
        wait: Duration,
    ) -> Result<String, RunError> {
        for sysid in state.sysids() {
            heard(fleet, sysid, wait).await?;
            fleet
                .wait_until(sysid, wait, |v| v.position.is_some())
                .await
                .map_err(|_| RunnerError::from(Check::NoPosition { sysid }))?;
        }
        Ok(format!(
            "epoch {}, {} measurements so far, keep {}, reject {}, unclassified {}",
            state.bandit.epoch,
            state.measurements,
            state.bandit.keep().len(),
            state.bandit.reject().len(),
            state.bandit.unclassified().len()
        ))
    }

    async fn fly(
        fleet: &FleetHandle,
        run_dir: RunDir,
        state: ClassificationState,
        mut options: RunOptions,
        progress: Option<mpsc::UnboundedSender<Progress>>,
    ) -> Result<(Outcome, ClassificationState), RunError> {
        if progress.is_some() {
            options.progress = progress;
        }
        let hub = crate::app::images::image_hub(fleet);
        let state = super::run(fleet.clone(), &hub, run_dir, state, options).await?;
        Ok((Outcome::Finished, state))
    }

    async fn fly_attached(
        fleet: &FleetHandle,
        run_dir: RunDir,
        state: ClassificationState,
        options: RunOptions,
        attached: Attached<Self>,
    ) -> Result<(Outcome, ClassificationState), RunError> {
        // The runner reads the operator's pause as a `watch`.
        let (pause_tx, pause_rx) = watch::channel(false);
        let mut operator = attached.operator;
        // Ends with the flight (the operator's sender outlives it): dropping the set stops it,
        // also when the flight itself is dropped.
        let mut relay = tokio::task::JoinSet::new();
        relay.spawn(async move {
            while let Some(Pause(p)) = operator.recv().await {
                let _ = pause_tx.send(p);
            }
        });
        let options = RunOptions {
            view: Some(attached.view),
            pause: Some(pause_rx),
            ..options
        };
        let r = Self::fly(fleet, run_dir, state, options, Some(attached.progress)).await;
        relay.shutdown().await;
        r
    }

    fn command(
        command: Command,
        target: Target,
        _targets: &[u8],
        op: &mpsc::UnboundedSender<Pause>,
    ) -> Option<Result<CommandReply, CommandError>> {
        match command {
            Command::Hold if target == Target::All => {
                let _ = op.send(Pause(true));
                Some(Ok(CommandReply::paused(
                    true,
                    "paused: no new sortie starts (drones in the air finish theirs and land on \
                     their stations)",
                )))
            }
            Command::Resume => {
                let _ = op.send(Pause(false));
                Some(Ok(CommandReply::paused(false, "mission resumed")))
            }
            Command::BatterySwapped => Some(Err(CommandError::NotForThisMission(
                "the drones of a spatial-classification run charge on their stations: there is \
                 no battery swap to confirm",
            ))),
            // RTL, LAND, ARM, DISARM and a vehicle's HOLD go straight to the vehicle (the run
            // then stops at the next rendezvous it misses; `fleetmap resume` re-plans from
            // where the team is).
            _ => None,
        }
    }

    fn panes(state: &ClassificationState, info: &RunInfo) -> Panes {
        super::panes::panes(state, info)
    }

    fn sample(vehicles: usize) -> Sample {
        super::sample::sample(vehicles)
    }

    fn report(
        state: &ClassificationState,
        world: Option<&World>,
    ) -> Result<ClassificationReport, RunError> {
        let truth = world.map(World::green_cells);
        Ok(report::report(state, truth.as_deref()))
    }

    fn journal_figures(events: &[BanditEvent]) -> serde_json::Map<String, serde_json::Value> {
        let counted = events
            .iter()
            .filter(|e| matches!(e, BanditEvent::Measurement(m) if m.counted))
            .count();
        let mut m = serde_json::Map::new();
        m.insert("journal_records".into(), events.len().into());
        m.insert("journal_measurements".into(), counted.into());
        m
    }

    fn report_lines(r: &ClassificationReport) -> Vec<String> {
        let cells = |v: &[[i32; 2]]| -> String {
            if v.is_empty() {
                "none".into()
            } else {
                v.iter()
                    .map(|c| format!("({}, {})", c[0], c[1]))
                    .collect::<Vec<_>>()
                    .join(" ")
            }
        };
        let mut lines = vec![
            format!(
                "  {}: {} epoch(s), {} measurements, {:.0} s of drone flight, {:.0} s of sorties",
                if r.finished {
                    "every cell classified"
                } else {
                    "not finished"
                },
                r.epochs,
                r.measurements,
                r.flight_time_s,
                r.sortie_time_s
            ),
            format!("  keep ({}): {}", r.keep.len(), cells(&r.keep)),
            format!("  reject ({}): {}", r.reject.len(), cells(&r.reject)),
        ];
        for (sysid, o) in &r.out {
            lines.push(format!(
                "  {} {sysid} out of the run since epoch {}: {}{}",
                o.role,
                o.epoch,
                o.reason,
                o.fix
                    .as_ref()
                    .map(|f| format!(" — to fix: {f}"))
                    .unwrap_or_default()
            ));
        }
        if !r.unclassified.is_empty() {
            lines.push(format!(
                "  unclassified ({}): {}",
                r.unclassified.len(),
                cells(&r.unclassified)
            ));
        }
        if let (Some(t), Some(e)) = (&r.interesting_truth, &r.errors) {
            lines.push(format!(
                "  vs ground truth: interesting {}; {} labelling error(s){}",
                cells(t),
                e.len(),
                if e.is_empty() {
                    String::new()
                } else {
                    format!(": {}", cells(e))
                }
            ));
        }
        for e in &r.per_epoch {
            lines.push(format!(
                "  epoch {:>2}: {} cycle(s), planner {:.2} s, sorties {:.0} s, {} measurements, \
                 keep {} reject {} unclassified {}",
                e.epoch,
                e.cycles,
                e.planner_s,
                e.flight_s,
                e.measurements,
                e.keep,
                e.reject,
                e.unclassified
            ));
        }
        lines
    }

    fn export(
        state: &ClassificationState,
        world: Option<&World>,
        format: ExportFormat,
    ) -> Result<(&'static str, Vec<u8>), RunError> {
        Ok(match format {
            ExportFormat::Png => {
                let truth = world.map(World::green_cells);
                let (w, h) = PROGRESS_PNG;
                (
                    "progress.png",
                    report::progress_png(state, truth.as_deref(), w, h)?,
                )
            }
            ExportFormat::Geojson => (
                "cells.geojson",
                serde_json::to_vec_pretty(&report::geojson(state))?,
            ),
            ExportFormat::Kml => ("cells.kml", report::kml(state).into_bytes()),
        })
    }
}
