//! Reach-aware flights for a moving region, end to end on the embedded
//! simulator in virtual time (tokio's paused clock, as `tests/suite/runway.rs`): the GCS's runway run
//! flies simulated ArduPilot copters through the real fleet, links and image transfer over a
//! world whose region drifts.
//!
//! * A region drifting away from home at 0.8 m/s, faster than a team at 1 m/s can map it: the
//!   drone maps while its battery covers the way back from where the next cell will be, and
//!   when not even a full battery from home could reach the region and return, the run ends
//!   with its own finish reason, "beyond reach" — in bounded time, every drone home, and no cell
//!   labelled for giving up (every decision in the book is a 3-of-5 vote).
//! * A region drifting slowly (0.2 m/s) is still mapped to the end as before.

use fleetmap::app::images;
use fleetmap::app::kind::Outcome;
use fleetmap::app::kind::RunKind;
use fleetmap::kinds::runway::demo::{self, DemoConfig};
use fleetmap::kinds::runway::report::{MappingReport, report, truth_coverage};
use fleetmap::kinds::runway::{self, MappingEvent};
use fleetmap::store::{RunDir, RunMeta};
use fleetmap_core::explore::dfs::Sharing;
use fleetmap_core::explore::mapping::{FinishReason, GaveUp, MappingState, Phase, RobotStatus};
use fleetmap_core::explore::reach::Unreachable;
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::world::World;
use std::time::Duration;

use crate::common;

/// Grass with one asphalt band 200 m east-west by 24 m, its centre 10 m north of the first
/// home, drifting east (away from home) at `ve` m/s: wide enough that the sweep box stays over
/// it for the first two minutes.
fn band_world(ve: f64) -> String {
    format!(
        r#"
name = "drifting-band"
description = "A 200 m x 24 m asphalt band drifting east at {ve} m/s (test world)"
background = "grass"
ground_alt_amsl_m = 600.0

[[region]]
name = "band"
surface = "asphalt"
rectangle = {{ center = [37.196890, -80.578100], length_m = 200.0, width_m = 24.0, heading_deg = 90.0 }}
markings = false
velocity_ne_mps = [0.0, {ve}]

[homes]
reference = [37.196800, -80.578100]
first_north_m = 0.0
first_east_m = 0.0
step_north_m = 0.0
step_east_m = 3.0
"#
    )
}

/// The field-test mission (1 m/s, 4 m cells at 12 m, five pictures a cell) with `drones`
/// drones, batteries of `minutes`, and the region's velocity `[0, ve]` as its forecast.
fn mission(base: &str, drones: u8, minutes: f64, ve: f64) -> String {
    assert!(
        base.contains("flight_time_min = 12.0"),
        "the field-test mission's battery line moved"
    );
    let mut text = base.replacen(
        "flight_time_min = 12.0",
        &format!("flight_time_min = {minutes:.1}"),
        1,
    );
    let runway = "\n[runway]";
    let at = text.find(runway).expect("a [runway] table");
    text.insert_str(
        at + runway.len(),
        &format!("\nroi_velocity_ne_mps = [0.0, {ve}]"),
    );
    for k in 2..=drones {
        let vehicle = format!("\n[[vehicles]]\nsysid = {k}\nrole = \"drone\"\n");
        let at = text.find("\n[area]").expect("an [area] table");
        text.insert_str(at, &vehicle);
    }
    text
}

/// Seconds from a drone's disarming on landing to the crew's battery swap (a power cycle).
/// 1 s keeps the flights these tests were tuned on: the runner used to ask the simulator for
/// the swap itself (MAV_CMD_USER_1), which it received 0.85 s after the disarm.
const CREW_SWAP_S: f64 = 1.0;

struct Ran {
    outcome: Outcome,
    state: MappingState,
    report: MappingReport,
    events: Vec<MappingEvent>,
    world: World,
    /// Seconds of the fleet clock from the runner's start to its end.
    run_s: f64,
}

/// Fly `text` over `world_text` with `drones` simulated copters of `minutes` batteries, the
/// region's frame tied to the simulator's start (as the demo does), until the runner returns or
/// two hours of virtual time pass. The simulated crew swaps a landed drone's battery
/// [`CREW_SWAP_S`] after it disarms; the runner resumes by itself on the fresh battery.
async fn fly(world_text: &str, text: &str, drones: u8, minutes: f64, seed: u64) -> Ran {
    let world = World::from_toml(world_text).unwrap();
    let def = MissionDef::parse(text, "reach.toml").unwrap();
    let cfg = DemoConfig {
        drones: usize::from(drones),
        seed,
        battery_minutes: minutes,
        swap_after_s: CREW_SWAP_S,
        ..DemoConfig::default()
    };
    let (fleet, sim) =
        demo::start_virtual(&format!("{drones}xcopter:ardupilot"), world.clone(), &cfg)
            .await
            .unwrap();
    let mut state =
        fleetmap::kinds::runway::new_mapping(&fleet, &def, Sharing::Gcs, Duration::from_secs(60))
            .await
            .unwrap();
    // The simulator and the fleet clock started together: the region's epoch (its world time
    // 0) is the fleet clock's zero, that many wall milliseconds ago on the runner's reading.
    let fleet_ms = fleet.clock().now().as_millis();
    state.roi_epoch_unix_ms = Some(fleetmap_io::clock::unix_ms().saturating_sub(fleet_ms));
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("run");
    let run_dir = RunDir::create(&path, RunMeta::new(runway::KIND, 0), Some(text)).unwrap();
    let hub = images::spawn(&fleet);
    let (opts, printer) = common::runway::printed_options();
    let t0 = fleet.clock().now();
    let outcome = tokio::time::timeout(
        Duration::from_secs(2 * 3600),
        runway::run(fleet.clone(), &hub, run_dir, state, opts),
    )
    .await
    .expect("the run ended within two hours of virtual time")
    .unwrap();
    let run_s = fleet.clock().now().as_secs_f64() - t0.as_secs_f64();
    let _ = printer.await;
    let state: MappingState = RunDir::open(&path).unwrap().load_state().unwrap().unwrap();
    let cov = truth_coverage(&state.grid, &world, 0.0).unwrap();
    let report = report(&state, Some(&cov));
    let events = common::journal::<MappingEvent>(&path);
    let _ = sim.stop().await;
    Ran {
        outcome,
        state,
        report,
        events,
        world,
        run_s,
    }
}

/// Every decision in the book was made by the votes of a visit's pictures (3 of 5 one way or
/// the other), none by a visit closed short.
fn every_decision_is_a_vote(state: &MappingState) {
    let p = state.params.votes;
    let against = p.images_per_visit - p.positive_votes + 1;
    for d in state.book.decisions() {
        let voted = if d.positive {
            d.votes_for >= p.positive_votes
        } else {
            d.votes_against >= against
        };
        assert!(voted, "a decision not made by its votes: {d:?}");
    }
}

/// A region drifting away from home at 0.8 m/s with drones at 1 m/s and 6-minute batteries:
/// each flight east gains 0.2 m/s on the region, and the region is soon farther out than a
/// full battery can fly to and back. The run ends beyond reach, in bounded time.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_region_drifting_away_faster_than_the_team_maps_ends_beyond_reach() {
    let ve = 0.8;
    let text = mission(demo::RUNWAY_MISSION, 2, 6.0, ve);
    let r = fly(&band_world(ve), &text, 2, 6.0, 5).await;
    let rep = &r.report;
    eprintln!(
        "beyond reach: {} after {:.0} s of the fleet clock; {} cells mapped, {} decisions, \
         {} swaps, mission time {:?}",
        rep.phase, r.run_s, rep.cells_mapped, rep.detections, rep.battery_swaps, rep.mission_time
    );
    assert_eq!(r.outcome, Outcome::Finished);
    assert!(r.state.is_finished());
    assert_eq!(
        r.state.phase.finish_reason(),
        Some(FinishReason::BeyondReach)
    );
    assert_eq!(rep.finish_reason, Some(FinishReason::BeyondReach));
    assert!(
        rep.phase.starts_with("finished: beyond reach"),
        "{}",
        rep.phase
    );
    // Why: out of range (the region is slower than the drones), with its figures.
    let Phase::Finished {
        gave_up: Some(GaveUp::BeyondReach { why, cell, sysid }),
        ..
    } = r.state.phase
    else {
        panic!("{:?}", r.state.phase)
    };
    let Unreachable::OutOfRange {
        distance_m,
        needed_pct,
        full_pct,
    } = why
    else {
        panic!("{why:?}")
    };
    assert!(needed_pct > full_pct - 1.0, "{why:?}");
    assert!(distance_m > 30.0, "{why:?}");
    let b = rep.beyond_reach.as_ref().expect("the report says why");
    assert_eq!((b.sysid, b.cell), (sysid, [cell.row, cell.col]));
    // The report's JSON says it too.
    let json = serde_json::to_value(rep).unwrap();
    assert_eq!(json["finish_reason"], "beyond_reach", "{json}");
    assert_eq!(json["beyond_reach"]["why"], "out_of_range", "{json}");
    let lines = runway::Runway::report_lines(rep).join("\n");
    assert!(lines.contains("beyond reach"), "{lines}");
    // It mapped what it could reach first: the DFS started, and some cells are region.
    assert!(rep.found && rep.cells_mapped > 0, "{rep:?}");
    // Bounded: well within one drone's battery or two of flying; no endless sorties.
    assert!(r.run_s < 1800.0, "{} s", r.run_s);
    assert!(rep.battery_swaps <= 2, "{} swaps", rep.battery_swaps);
    // Every drone home and landed; the map not complete.
    assert!(
        r.state
            .robots
            .iter()
            .all(|x| x.status == RobotStatus::Landed)
    );
    assert_eq!(rep.mission_time.to_map_complete_s, None);
    assert!(rep.mission_time.to_last_landing_s.is_some());
    // Nothing labelled for giving up: no open visit left, every decision a vote, and no image
    // journalled after the give-up changed a cell.
    every_decision_is_a_vote(&r.state);
    for x in &r.state.robots {
        assert!(r.state.book.open_visit(x.sysid).is_none());
        assert_eq!(x.visit, None);
    }
    let gave_up = r
        .events
        .iter()
        .position(|e| matches!(e, MappingEvent::BeyondReach { .. }))
        .expect("the give-up is journalled");
    assert_eq!(
        r.events
            .iter()
            .filter(|e| matches!(e, MappingEvent::BeyondReach { .. }))
            .count(),
        1
    );
    for e in &r.events[gave_up..] {
        if let MappingEvent::Image { changed, .. } = e {
            assert!(
                changed.is_empty(),
                "a cell changed after the give-up: {e:?}"
            );
        }
        assert!(
            !matches!(
                e,
                MappingEvent::Observed { .. } | MappingEvent::Confirmed { .. }
            ),
            "{e:?}"
        );
    }
    assert!(matches!(
        r.events.last(),
        Some(MappingEvent::Finished {
            reason: Some(FinishReason::BeyondReach),
            ..
        })
    ));
}

/// The moving-plume demo (`assets/worlds/plume.toml`, `missions/plume.toml`: three drones at
/// 2 m/s, a 44 m × 26 m plume drifting east at 0.3 m/s) in virtual time: within reach, so
/// mapped to the end as before the reach rule, scored in the plume's own frame.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_region_drifting_within_reach_is_still_mapped() {
    let world_text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/assets/worlds/plume.toml"
    ))
    .unwrap();
    let world = World::from_toml(&world_text).unwrap();
    let (text, def, _) = demo::mission_for(&world, &DemoConfig::default()).unwrap();
    assert_eq!(def.name, "plume");
    let r = fly(&world_text, &text, 3, 12.0, 1).await;
    let rep = &r.report;
    let t = rep.truth.as_ref().unwrap();
    eprintln!(
        "within reach: {} after {:.0} s; {} cells mapped, IoU {:.3} (best {:.3}), {} swaps",
        rep.phase, r.run_s, rep.cells_mapped, t.iou, t.iou_best_possible, rep.battery_swaps
    );
    assert_eq!(r.outcome, Outcome::Finished);
    assert_eq!(rep.finish_reason, Some(FinishReason::Mapped));
    assert!(rep.beyond_reach.is_none());
    assert!(
        !r.events
            .iter()
            .any(|e| matches!(e, MappingEvent::BeyondReach { .. }))
    );
    assert!(rep.mission_time.to_map_complete_s.is_some());
    every_decision_is_a_vote(&r.state);
    assert!(
        t.iou >= t.iou_best_possible - 0.05,
        "IoU {:.3} against a best possible {:.3}",
        t.iou,
        t.iou_best_possible
    );
    // The map is where the plume was at the epoch, not where it is at the end.
    let end_s = r.state.clock.elapsed_s + r.state.clock.before_takeoff_s;
    let at_end = fleetmap::kinds::runway::report::iou(
        &r.state.book.positive_cells().into_iter().collect(),
        &truth_coverage(&r.state.grid, &r.world, end_s).unwrap(),
    );
    assert!(
        at_end < t.iou - 0.2,
        "IoU {at_end:.3} with the plume at the end"
    );
}
