//! Runway mapping end to end on the embedded simulator: the GCS's runway run
//! (`fleetmap::kinds::runway`) flies simulated ArduPilot copters over the runway world through
//! the real fleet, link codec and image transfer, on tokio's paused clock — fully virtual
//! time, so a flight of an hour and more takes only the CPU time of its work.
//!
//! Every run's report is checked for its mission time against its journal: first
//! take-off ≤ DFS start ≤ complete map ≤ last landing, each drone's shares adding up to the
//! mission time, and the figures carried across a resume.

use fleetmap::app::images;
use fleetmap::app::kind::{OperatorTask, Outcome};
use fleetmap::kinds::runway::demo::{self, DemoConfig};
use fleetmap::kinds::runway::report::{MappingReport, report, truth_coverage};
use fleetmap::kinds::runway::{self, MappingEvent, RunOptions};
use fleetmap::store::{RunDir, RunMeta};
use fleetmap_core::explore::dfs::Sharing;
use fleetmap_core::explore::mapping::{MappingState, MilestoneKind, RobotStatus};
use fleetmap_core::geo::local;
use fleetmap_core::world::World;
use std::time::Duration;

use crate::common;

struct Finished {
    state: MappingState,
    report: fleetmap::kinds::runway::report::MappingReport,
    events: Vec<MappingEvent>,
    fleet: fleetmap::fleet::FleetHandle,
}

/// The report's mission time is consistent with the run's journal and with itself: the
/// milestones journalled once each, in the mission's order, with the report's values; the
/// complete map journalled with the last vertex's pictures and the last landing with the last
/// landing; every drone's flying, waiting and ground shares adding up to the mission time;
/// the airborne time of the position tracker (a separate measurement) close to flying +
/// waiting. `starts`: how many times a runner started on the run.
fn check_mission_time(r: &MappingReport, events: &[MappingEvent], starts: u32) {
    let m = &r.mission_time;
    eprintln!("mission time: {m:?}");
    let (dfs, map, last) = (
        m.to_dfs_start_s.expect("the DFS started"),
        m.to_map_complete_s.expect("the map was completed"),
        m.to_last_landing_s.expect("every drone landed"),
    );
    assert!(
        0.0 < dfs && dfs <= map && map <= last,
        "first take-off 0 < DFS start {dfs} <= map complete {map} <= last landing {last}"
    );
    assert_eq!(m.elapsed_s, last);
    assert_eq!(m.starts, starts);
    assert!(m.before_takeoff_s > 0.0);
    let milestones: Vec<(usize, MilestoneKind, f64)> = events
        .iter()
        .enumerate()
        .filter_map(|(i, e)| match e {
            MappingEvent::Milestone { what, mission_s } => Some((i, *what, *mission_s)),
            _ => None,
        })
        .collect();
    let kinds: Vec<MilestoneKind> = milestones.iter().map(|m| m.1).collect();
    assert_eq!(
        kinds,
        [
            MilestoneKind::FirstTakeoff,
            MilestoneKind::DfsStart,
            MilestoneKind::MapComplete,
            MilestoneKind::LastLanding
        ]
    );
    let at = |k: MilestoneKind| milestones.iter().find(|m| m.1 == k).unwrap();
    assert_eq!(at(MilestoneKind::DfsStart).2, dfs);
    assert_eq!(at(MilestoneKind::MapComplete).2, map);
    assert_eq!(at(MilestoneKind::LastLanding).2, last);
    let last_index = |f: &dyn Fn(&MappingEvent) -> bool| events.iter().rposition(f).unwrap();
    let first_index = |f: &dyn Fn(&MappingEvent) -> bool| events.iter().position(f).unwrap();
    // Nothing was imaged for the map after it was complete, no drone landed after the last
    // landing, the DFS started with the positive confirmation and no sweep picture was
    // classified before the first take-off.
    let observed = last_index(&|e| matches!(e, MappingEvent::Observed { .. }));
    assert_eq!(at(MilestoneKind::MapComplete).0, observed + 1);
    let landed = last_index(&|e| {
        matches!(
            e,
            MappingEvent::Landed { .. } | MappingEvent::LandedForSwap { .. }
        )
    });
    assert_eq!(at(MilestoneKind::LastLanding).0, landed + 1);
    let confirmed = first_index(&|e| matches!(e, MappingEvent::Confirmed { root: Some(_), .. }));
    assert_eq!(at(MilestoneKind::DfsStart).0, confirmed + 1);
    let swept = first_index(&|e| {
        matches!(
            e,
            MappingEvent::SweepImage { .. } | MappingEvent::Candidate { .. }
        )
    });
    assert!(at(MilestoneKind::FirstTakeoff).0 < swept);
    // Every drone is in exactly one share at every moment.
    for rb in &r.robots {
        let t = &rb.time;
        eprintln!(
            "vehicle {}: {:.0} m, {} images, {t:?}",
            rb.sysid, rb.distance_m, rb.images
        );
        let sum = t.flying_s + t.waiting_s + t.ground_s;
        assert!(
            (sum - last).abs() < 1e-6 && (t.elapsed_s - last).abs() < 1e-6,
            "vehicle {}: shares {sum} s of {last} s: {t:?}",
            rb.sysid
        );
        assert!((t.flying_share + t.waiting_share + t.ground_share - 1.0).abs() < 1e-9);
        assert!(t.imaging_s + t.homing_s <= t.flying_s + 1e-9);
        assert!(t.ground_before_s + t.ground_swap_s + t.ground_done_s <= t.ground_s + 1e-6);
        assert!(t.imaging_s > 0.0, "vehicle {} took no picture", rb.sysid);
        // The tracker's airborne time counts from each take-off on the runtime's clock, the
        // mission clock from the samples: the same flights within a few samples each.
        let air = t.flying_s + t.waiting_s;
        assert!(
            (air - rb.flight_time_s).abs() <= 0.02 * air + 10.0,
            "vehicle {}: {air} s flying and waiting, {} s airborne",
            rb.sysid,
            rb.flight_time_s
        );
    }
    let shares = m.flying_share + m.waiting_share + m.ground_share;
    assert!((shares - 1.0).abs() < 1e-9, "{shares}");
}

async fn fly(drones: usize, seed: u64) -> Finished {
    let world = World::from_toml(demo::RUNWAY_WORLD).unwrap();
    let cfg = DemoConfig {
        drones,
        seed,
        ..DemoConfig::default()
    };
    let (text, def) = demo::runway_mission(&cfg).unwrap();
    let spec = format!("{drones}xcopter:ardupilot");
    let (fleet, sim) = demo::start_virtual(&spec, world.clone(), &cfg)
        .await
        .unwrap();
    let (state, run_dir, path, _tmp) = common::runway::new_run(&fleet, &def, &text).await;
    let hub = images::spawn(&fleet);
    let (opts, printer) = common::runway::printed_options();
    let outcome = runway::run(fleet.clone(), &hub, run_dir, state, opts)
        .await
        .unwrap();
    assert_eq!(outcome, Outcome::Finished);
    let _ = printer.await;
    // What was saved is what the report reads.
    let state: MappingState = RunDir::open(&path).unwrap().load_state().unwrap().unwrap();
    let cov = truth_coverage(&state.grid, &world, 0.0).unwrap();
    let r = report(&state, Some(&cov));
    let _ = sim.stop().await;
    Finished {
        state,
        report: r,
        events: common::journal::<MappingEvent>(&path),
        fleet,
    }
}

fn print(r: &MappingReport) {
    let t = r.truth.as_ref().unwrap();
    eprintln!(
        "runway: {} cells mapped, tree {} vertices, {} images, {} decisions ({} FP, {} FN), \
         IoU {:.3} (best possible {:.3}, paper {:.3}), {:.0} s airborne, {} battery swaps",
        r.cells_mapped,
        r.tree_vertices,
        r.images,
        r.detections,
        t.false_positives,
        t.false_negatives,
        t.iou,
        t.iou_best_possible,
        t.paper_iou,
        r.flight_time_s,
        r.battery_swaps
    );
}

/// The runway paper's field test (§7): one UAV, 12-minute batteries, 4 m cells at 12 m,
/// 1 m/s, five images per cell. It must finish with battery swaps, and its map must be
/// within 5 points of IoU of the best any labelling of this grid can reach (the paper's own
/// map reached 75.7 %).
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn one_robot_maps_the_runway_with_battery_swaps() {
    let f = fly(1, 1).await;
    print(&f.report);
    check_mission_time(&f.report, &f.events, 1);
    let t = f.report.truth.as_ref().unwrap();
    assert!(f.report.finished);
    assert!(
        f.report.battery_swaps >= 1,
        "no battery swap: {:?}",
        f.report
    );
    assert!(
        t.iou >= t.iou_best_possible - 0.05,
        "IoU {:.3} is more than 5 points below the best possible {:.3}",
        t.iou,
        t.iou_best_possible
    );
    assert!(f.report.tree_vertices >= 100, "{}", f.report.tree_vertices);
}

/// Three robots: every cell of the runway explored, and once the map is complete every
/// robot flies straight home from where it is (no new step of the DFS after the complete
/// map) and lands.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn three_robots_explore_every_runway_cell_and_come_back() {
    let f = fly(3, 2).await;
    print(&f.report);
    check_mission_time(&f.report, &f.events, 1);
    let complete = f
        .events
        .iter()
        .position(|e| {
            matches!(
                e,
                MappingEvent::Milestone {
                    what: MilestoneKind::MapComplete,
                    ..
                }
            )
        })
        .expect("the map complete milestone");
    // At most the flight each drone was on when the last vertex was imaged ends after it
    // (a move is not broken off); no drone takes a second step of the DFS.
    for id in 1..=3u8 {
        let after = f.events[complete..]
            .iter()
            .filter(|e| matches!(e, MappingEvent::Arrived { sysid, .. } if *sysid == id))
            .count();
        assert!(
            after <= 1,
            "vehicle {id}: {after} DFS moves after the complete map"
        );
    }
    let s = &f.state;
    let ex = s.explorer.as_ref().unwrap();
    assert!(ex.is_finished());
    assert_eq!(f.report.unexplored_vertices, 0);
    assert_eq!(f.report.explored_vertices, f.report.tree_vertices);
    // Every cell mostly on the runway is in the map and was visited by the DFS.
    let t = f.report.truth.as_ref().unwrap();
    assert!(
        t.region_cells_mapped * 100 >= t.region_cells * 95,
        "{} of {} runway cells mapped",
        t.region_cells_mapped,
        t.region_cells
    );
    for r in &s.robots {
        assert_eq!(r.status, RobotStatus::Landed, "vehicle {}", r.sysid);
        // landed at home, its tour over
        let v = f.fleet.vehicle(r.sysid).unwrap();
        let (p, h) = (v.position.unwrap(), v.home.unwrap());
        assert!(
            local::distance(p.lat, p.lon, h.lat, h.lon) < 3.0,
            "vehicle {} is not home",
            r.sysid
        );
        assert!(!v.armed);
        assert_eq!(
            ex.robot(fleetmap_core::explore::dfs::RobotId(r.sysid))
                .unwrap()
                .phase,
            fleetmap_core::explore::dfs::Phase::Done
        );
    }
    assert!(f.report.robots.iter().all(|r| r.images > 0));
}

/// A run stopped at a battery swap and resumed (`fleetmap resume`'s path: the operator swaps
/// the battery, the state is read back from the run directory, a new runner carries on) keeps
/// its mission time: the figures saved before the stop go on growing from where they were,
/// the milestones are journalled once each, and the report is consistent with the journal.
/// One drone over the small strip world ([`common::WORLD`]) with 4-minute batteries.
#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn the_mission_time_survives_a_resume() {
    use fleetmap::app::kind::{RunKind, RunSettings};
    let world = World::from_toml(common::WORLD).unwrap();
    let cfg = DemoConfig {
        drones: 1,
        seed: 3,
        battery_minutes: 4.0,
        swap_after_s: 20.0,
        ..DemoConfig::default()
    };
    let text =
        common::strip_mission().replacen("flight_time_min = 12.0", "flight_time_min = 4.0", 1);
    let def = fleetmap_core::mission::definition::MissionDef::parse(&text, "strip").unwrap();
    let (fleet, sim) = demo::start_virtual("1xcopter:ardupilot", world.clone(), &cfg)
        .await
        .unwrap();
    let mut state =
        fleetmap::kinds::runway::new_mapping(&fleet, &def, Sharing::Gcs, Duration::from_secs(60))
            .await
            .unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let path = tmp.path().join("run");
    let mut run_dir = RunDir::create(&path, RunMeta::new(runway::KIND, 0), Some(&text)).unwrap();
    let hub = images::spawn(&fleet);
    let mut starts = 0;
    let mut before: Option<fleetmap_core::explore::mapping::MissionClock> = None;
    loop {
        starts += 1;
        // Not auto-resuming and headless: the runner stops when the drone lands for a swap.
        let outcome = runway::run(fleet.clone(), &hub, run_dir, state, RunOptions::default())
            .await
            .unwrap();
        state = RunDir::open(&path).unwrap().load_state().unwrap().unwrap();
        let clock = state.clock.clone();
        assert_eq!(clock.starts, starts);
        if let Some(b) = &before {
            // Carried on from the saved figures.
            assert!(clock.elapsed_s > b.elapsed_s, "{clock:?} after {b:?}");
            assert_eq!(clock.before_takeoff_s, b.before_takeoff_s);
            assert!(b.dfs_start_s.is_none_or(|t| clock.dfs_start_s == Some(t)));
            let t = &state.robots[0].times;
            assert!((t.accounted_s() - clock.elapsed_s).abs() < 1.0, "{t:?}");
        }
        before = Some(clock);
        match outcome {
            Outcome::Finished => break,
            Outcome::WaitingForOperator { waiting } => {
                assert_eq!(waiting, vec![(1, OperatorTask::BatterySwap)]);
                assert!(starts < 6, "more swaps than the strip needs");
                // The crew swaps the battery (the simulator does it 20 s after landing).
                tokio::time::sleep(Duration::from_secs(30)).await;
                let settings = RunSettings::default();
                runway::Runway::prepare_resume(
                    &fleet,
                    &mut state,
                    &settings,
                    Duration::from_secs(60),
                )
                .await
                .unwrap();
                run_dir = RunDir::open(&path).unwrap();
            }
        }
    }
    assert!(starts >= 2, "the run never stopped for a swap");
    let cov = truth_coverage(&state.grid, &world, 0.0).unwrap();
    let r = report(&state, Some(&cov));
    print(&r);
    check_mission_time(&r, &common::journal::<MappingEvent>(&path), starts);
    assert!(r.robots[0].time.ground_swap_s > 0.0);
    assert!(r.robots[0].time.homing_s > 0.0);
    let _ = sim.stop().await;
}
