//! Runway mapping as a [`RunKind`]: what the commands, the TUI session and the demo need.

use super::report::{self, truth_coverage, truth_outlines};
use super::{KIND, MappingEvent, Operator, RunOptions};
use crate::app::blocking::run_blocking;
use crate::app::command::{Command, CommandError, Target};
use crate::app::error::RunError;
use crate::app::flight::Patience;
use crate::app::kind::{
    Attached, CommandReply, ExportFormat, Outcome, RunKind, RunSettings, png_bytes,
};
use crate::app::run::Progress;
use crate::app::team::heard;
use crate::fleet::FleetHandle;
use crate::panes::{KindLook, Panes, RunInfo, Sample};
use crate::store::RunDir;
use fleetmap_core::explore::mapping::{MappingState, RobotStatus};
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::world::World;
use std::path::Path;
use std::time::Duration;
use tokio::sync::mpsc;

/// Runway mapping (the runway paper): sweep, confirmation, the multi-robot DFS.
pub struct Runway;

impl RunKind for Runway {
    const KIND: &'static str = KIND;
    const LOOK: KindLook = super::panes::LOOK;
    const EXPORTS: [ExportFormat; 3] =
        [ExportFormat::Geojson, ExportFormat::Kml, ExportFormat::Png];
    type State = MappingState;
    type Options = RunOptions;
    type Event = MappingEvent;
    type Report = report::MappingReport;
    type Operator = Operator;

    fn mission(state: &MappingState) -> &str {
        &state.mission
    }

    fn is_finished(state: &MappingState) -> bool {
        state.is_finished()
    }

    fn sysids(state: &MappingState) -> Vec<u8> {
        state.robots.iter().map(|r| r.sysid).collect()
    }

    fn options(settings: &RunSettings) -> Result<RunOptions, RunError> {
        Ok(RunOptions {
            auto_resume: settings.auto_resume,
            patience: Patience {
                factor: settings.patience,
            },
            ..RunOptions::default()
        })
    }

    async fn new_state(
        fleet: &FleetHandle,
        def: &MissionDef,
        settings: &RunSettings,
        wait: Duration,
    ) -> Result<MappingState, RunError> {
        let mut state = super::new_mapping(fleet, def, settings.sharing, wait).await?;
        if state.params.motion().speed() > 0.0 {
            state.roi_epoch_unix_ms = settings.roi_epoch_unix_ms;
        }
        Ok(state)
    }

    fn summary_lines(def: &MissionDef) -> Vec<String> {
        super::summary::summary_lines(def)
    }

    fn started_line(dir: &Path, state: &MappingState) -> String {
        format!(
            "run directory {} — grid origin {:.7},{:.7}, {} m cells, {} drone(s)",
            dir.display(),
            state.grid.origin().lat,
            state.grid.origin().lon,
            state.grid.cell_size(),
            state.robots.len()
        )
    }

    async fn prepare_resume(
        fleet: &FleetHandle,
        state: &mut MappingState,
        settings: &RunSettings,
        wait: Duration,
    ) -> Result<String, RunError> {
        for r in &state.robots {
            heard(fleet, r.sysid, wait).await?;
        }
        if !settings.auto_resume {
            // Running `fleetmap resume` is the operator's "battery swapped" for every robot
            // that was waiting on the ground.
            let now = fleet.clock().now();
            for r in state.robots.clone() {
                if r.status == RobotStatus::AwaitingSwap {
                    state.on_swapped(r.sysid, now)?;
                }
            }
        }
        Ok(format!("{}, {} images so far", state.phase, state.images))
    }

    async fn fly(
        fleet: &FleetHandle,
        run_dir: RunDir,
        state: MappingState,
        mut options: RunOptions,
        progress: Option<mpsc::UnboundedSender<Progress>>,
    ) -> Result<(Outcome, MappingState), RunError> {
        if progress.is_some() {
            options.progress = progress;
        }
        let path = run_dir.path().to_path_buf();
        let hub = crate::app::images::spawn(fleet);
        let outcome = super::run(fleet.clone(), &hub, run_dir, state, options).await?;
        // The runner saved every step; read the last one back (file I/O: off the workers).
        let state = run_blocking(move || -> Result<MappingState, RunError> {
            RunDir::open(&path)?
                .load_state()?
                .ok_or(RunError::NothingSaved { path })
        })
        .await??;
        Ok((outcome, state))
    }

    async fn fly_attached(
        fleet: &FleetHandle,
        run_dir: RunDir,
        state: MappingState,
        options: RunOptions,
        attached: Attached<Self>,
    ) -> Result<(Outcome, MappingState), RunError> {
        let options = RunOptions {
            operator: Some(attached.operator),
            view: Some(attached.view),
            ..options
        };
        Self::fly(fleet, run_dir, state, options, Some(attached.progress)).await
    }

    fn command(
        command: Command,
        _target: Target,
        targets: &[u8],
        op: &mpsc::UnboundedSender<Operator>,
    ) -> Option<Result<CommandReply, CommandError>> {
        let send_each = |f: fn(u8) -> Operator| {
            for v in targets {
                let _ = op.send(f(*v));
            }
        };
        Some(Ok(match command {
            Command::Hold => {
                let _ = op.send(Operator::Pause);
                CommandReply::paused(true, "every vehicle holds (the mission is paused)")
            }
            Command::Resume => {
                let _ = op.send(Operator::Resume);
                CommandReply::paused(false, "mission resumed")
            }
            Command::Rtl => {
                send_each(Operator::Recall);
                CommandReply::text(format!(
                    "returning home: {targets:?} (their vertices are kept)"
                ))
            }
            Command::Land => {
                send_each(Operator::Land);
                CommandReply::text(format!("landing: {targets:?} (their vertices are kept)"))
            }
            Command::BatterySwapped => {
                send_each(Operator::BatterySwapped);
                CommandReply::text("the vehicle resumes from its vertex")
            }
            Command::Start | Command::Arm | Command::Disarm => return None,
        }))
    }

    fn panes(state: &MappingState, info: &RunInfo) -> Panes {
        super::panes::panes(state, info)
    }

    fn sample(vehicles: usize) -> Sample {
        super::sample::sample(vehicles)
    }

    fn report(state: &MappingState, world: Option<&World>) -> Result<Self::Report, RunError> {
        let cov = world
            .map(|w| truth_coverage(&state.grid, w, 0.0))
            .transpose()?;
        Ok(report::report(state, cov.as_ref()))
    }

    fn journal_figures(events: &[MappingEvent]) -> serde_json::Map<String, serde_json::Value> {
        let mut m = serde_json::Map::new();
        m.insert("journal_records".into(), events.len().into());
        m
    }

    fn report_lines(r: &Self::Report) -> Vec<String> {
        let mut lines = vec![
            format!(
                "  {} ({}); DFS allocation {}, {} sharing",
                r.phase,
                if r.finished {
                    "every robot landed"
                } else {
                    "not finished"
                },
                r.allocation,
                r.sharing
            ),
            format!(
                "  map: {} runway cells, {} non-runway; tree {} vertices ({} explored, {} unexplored)",
                r.cells_mapped,
                r.negative_cells,
                r.tree_vertices,
                r.explored_vertices,
                r.unexplored_vertices
            ),
            format!(
                "  images: {} at cell centres ({} decisions), {} in the sweep, {} lost",
                r.images, r.detections, r.sweep_images, r.image_failures
            ),
            format!(
                "  flight: {:.0} s airborne, {:.0} m, {} battery swap(s)",
                r.flight_time_s, r.distance_m, r.battery_swaps
            ),
            mission_time_line(&r.mission_time),
        ];
        let o = &r.onboard;
        if o.cell_pictures + o.sweep_pictures + o.audits > 0 {
            lines.push(format!(
                "  classified on board: {} cell pictures, {} sweep pictures; {} audited ({} agreed, \
                 {} disagreed, {} without a picture)",
                o.cell_pictures,
                o.sweep_pictures,
                o.audits,
                o.audits_agreed,
                o.audits_disagreed,
                o.audits_lost
            ));
        }
        if let Some([n, e]) = r.roi_velocity_ne_mps {
            lines.push(format!(
                "  region moving at {:.2} m/s (north {n:.2}, east {e:.2}): the map is in its frame \
                 at the run's epoch",
                n.hypot(e)
            ));
        }
        for rb in &r.robots {
            let t = &rb.time;
            lines.push(format!(
                "  vehicle {} at {:.1} m: {}, {:.0} s, {:.0} m, {} swap(s), {} images; \
                 of {:.0} s: flying {:.0} % ({:.0} s imaging, {:.0} s back to the start, \
                 {:.0} s home), waiting {:.0} % \
                 ({:.0} s confirmation, {:.0} s DFS start, {:.0} s vertex, {:.0} s sweep), \
                 ground {:.0} % ({:.0} s swaps, {:.0} s done)",
                rb.sysid,
                rb.altitude_m,
                rb.status,
                rb.flight_time_s,
                rb.distance_m,
                rb.battery_swaps,
                rb.images,
                t.elapsed_s,
                100.0 * t.flying_share,
                t.imaging_s,
                t.returning_s,
                t.homing_s,
                100.0 * t.waiting_share,
                t.waiting.confirmation_s,
                t.waiting.dfs_start_s,
                t.waiting.vertex_s,
                t.waiting.sweep_s + t.waiting.pictures_s,
                100.0 * t.ground_share,
                t.ground_swap_s,
                t.ground_done_s
            ));
        }
        if let Some(t) = &r.truth {
            lines.push(format!(
                "  vs ground truth: IoU {:.1} % (best possible on this grid {:.1} %, paper {:.1} %); \
                 {} of {} region cells mapped; decisions: {} false positive(s), {} false negative(s) of {}",
                100.0 * t.iou,
                100.0 * t.iou_best_possible,
                100.0 * t.paper_iou,
                t.region_cells_mapped,
                t.region_cells,
                t.false_positives,
                t.false_negatives,
                r.detections
            ));
        }
        lines
    }

    fn export(
        state: &MappingState,
        world: Option<&World>,
        format: ExportFormat,
    ) -> Result<(&'static str, Vec<u8>), RunError> {
        let outlines = world.map(|w| truth_outlines(w, 0.0)).unwrap_or_default();
        Ok(match format {
            ExportFormat::Geojson => (
                "map.geojson",
                serde_json::to_vec_pretty(&report::geojson(state, &outlines))?,
            ),
            ExportFormat::Kml => ("map.kml", report::kml(state, &outlines).into_bytes()),
            ExportFormat::Png => ("map.png", png_bytes(&report::png(state, &outlines))?),
        })
    }
}

/// The report's mission-time line: first take-off to the DFS's start, the complete map and the
/// last landing (fleet-clock seconds), and the team's shares.
pub(crate) fn mission_time_line(m: &report::MissionTime) -> String {
    let at = |t: Option<f64>| t.map_or_else(|| "—".to_string(), |t| format!("{t:.0} s"));
    format!(
        "  mission time (vehicles' clock, from the first take-off): DFS start {}, map complete {}, \
         last landing {}{}; team {:.0} % flying, {:.0} % waiting, {:.0} % on the ground",
        at(m.to_dfs_start_s),
        at(m.to_map_complete_s),
        at(m.to_last_landing_s),
        if m.starts > 1 {
            format!(
                " ({} starts: the time between a stop and its resume is not counted)",
                m.starts
            )
        } else {
            String::new()
        },
        100.0 * m.flying_share,
        100.0 * m.waiting_share,
        100.0 * m.ground_share
    )
}
