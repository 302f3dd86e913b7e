//! Runway mapping with a drone that cannot take off: two ArduCopter drones over the small
//! strip world ([`common::WORLD`]) on the embedded simulator, in virtual time, drone 2
//! refusing to arm (the simulator's compass fault, "PreArm: Compass not calibrated") for its
//! first two and a half minutes. Drone 2 leaves the tree as for a battery swap (journal `grounded`,
//! the operator told why and what to fix) while drone 1 goes on; the run is stopped in the
//! middle and resumed, and the resumed run knows drone 2 is grounded and why; once its check
//! passes (a person fixed it) drone 2 rejoins by itself (auto-resume) and flies; the run
//! finishes with the strip mapped. A lone drone whose check never passes waits for its fix
//! (ten minutes with auto-resume), then the run ends saying what a person must fix.

use fleetmap::app::kind::{OperatorTask, Outcome};
use fleetmap::fleet::FleetHandle;
use fleetmap::kinds::runway::MappingEvent;
use fleetmap::kinds::runway::report::{report, truth_coverage};
use fleetmap::store::RunDir;
use fleetmap_core::explore::mapping::MappingState;
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::time::Time;
use fleetmap_core::world::World;
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_sim::server::SimTask;
use std::time::Duration;

use crate::common;

/// Simulated seconds until drone 2's pre-arm check passes.
const FIXED_AT_S: f64 = 150.0;

/// `drones` ArduCopters over `world`, vehicle `sysid` of `compass` failing its pre-arm check
/// until the given simulated time.
fn team(world: &World, drones: usize, compass: (u8, f64)) -> (FleetHandle, SimTask) {
    let spec = format!("{drones}xcopter:ardupilot");
    let mut sc = SimConfig::from_spec(&spec, Some(world.clone()), None, 5).unwrap();
    for v in &mut sc.vehicles {
        v.swap_after_s = Some(30.0);
        if v.sysid == compass.0 {
            v.compass_fault_until_s = Some(compass.1);
        }
    }
    let sim = Sim::new(sc, Time::ZERO).unwrap();
    fleetmap::launch::sim_fleet::serve_virtual(sim, None)
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_drone_that_cannot_take_off_leaves_the_tree_and_rejoins_when_fixed() {
    let world = World::from_toml(common::WORLD).unwrap();
    let text = format!(
        "{}\n[[vehicles]]\nsysid = 2\nrole = \"drone\"\nname = \"uav2\"\n",
        common::strip_mission()
    );
    let def = MissionDef::parse(&text, "strip, two drones").unwrap();
    let (fleet, sim) = team(&world, 2, (2, FIXED_AT_S));
    let (state, _, dir, _tmp) = common::runway::new_run(&fleet, &def, &text).await;
    // Stopped at drone 1's next step after drone 2 was grounded.
    let mut grounded = false;
    let (lines, ended) = common::runway::run_until(&fleet, &dir, state, |l| {
        if l.contains("vehicle 2 cannot go on") {
            grounded = true;
            return false;
        }
        grounded && l.contains("vehicle 1")
    })
    .await;
    assert!(ended.is_none(), "the run ended before drone 2 was grounded");
    let told = lines
        .iter()
        .find(|l| l.contains("vehicle 2 cannot go on"))
        .unwrap();
    assert!(
        told.contains("Compass not calibrated")
            && told.contains("leaves the tree")
            && told.contains("a person must fix it"),
        "{told}"
    );
    let saved: MappingState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
    let g = saved
        .robot(2)
        .unwrap()
        .grounded
        .clone()
        .expect("grounded in the saved state");
    assert!(g.reason.contains("Compass not calibrated"), "{g:?}");
    assert!(g.fix.is_some(), "{g:?}");
    assert_eq!(saved.robot(2).unwrap().battery_swaps, 0);
    // Resumed: drone 2 is still grounded until its check passes, then rejoins by itself.
    let (lines, ended) = common::runway::run_until(&fleet, &dir, saved, |_| false).await;
    assert_eq!(ended, Some(Outcome::Finished));
    assert!(
        lines
            .iter()
            .any(|l| l.contains("vehicle 2 is ready again: taking off to rejoin")),
        "{lines:#?}"
    );
    let done: MappingState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
    assert!(done.is_finished());
    let r2 = done.robot(2).unwrap();
    assert!(r2.grounded.is_none());
    assert!(r2.flight_s > 10.0, "drone 2 never flew after it rejoined");
    assert_eq!(r2.battery_swaps, 0, "a grounding is not a battery swap");
    let events = common::journal::<MappingEvent>(&dir);
    let out = events
        .iter()
        .position(|e| {
            matches!(
                e,
                MappingEvent::Grounded {
                    sysid: 2,
                    fix: Some(_),
                    ..
                }
            )
        })
        .expect("journalled");
    let back = events
        .iter()
        .position(|e| matches!(e, MappingEvent::ReadyAgain { sysid: 2, by } if by == "auto"))
        .expect("journalled");
    assert!(out < back);
    assert!(
        !events
            .iter()
            .any(|e| matches!(e, MappingEvent::Grounded { sysid: 1, .. }))
    );
    let cov = truth_coverage(&done.grid, &world, 0.0).unwrap();
    let rep = report(&done, Some(&cov));
    let t = rep.truth.as_ref().unwrap();
    assert!(
        t.iou >= t.iou_best_possible - 0.05,
        "IoU {:.3}, best possible {:.3}",
        t.iou,
        t.iou_best_possible
    );
    let _ = sim.stop().await;
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_lone_drone_that_is_never_fixed_ends_the_run_saying_what_to_fix() {
    let world = World::from_toml(common::WORLD).unwrap();
    let text = common::strip_mission();
    let def = MissionDef::parse(&text, "strip").unwrap();
    let (fleet, sim) = team(&world, 1, (1, f64::INFINITY));
    let (state, _, dir, _tmp) = common::runway::new_run(&fleet, &def, &text).await;
    let t0 = tokio::time::Instant::now();
    let (lines, ended) = common::runway::run_until(&fleet, &dir, state, |_| false).await;
    match &ended {
        Some(Outcome::WaitingForOperator { waiting }) => {
            assert_eq!(waiting.len(), 1, "{waiting:?}");
            assert_eq!(waiting[0].0, 1);
            // what a person must fix, not a battery swap
            assert!(matches!(waiting[0].1, OperatorTask::Fix(_)), "{waiting:?}");
        }
        other => panic!("expected vehicle 1 to wait for a fix, got {other:?}"),
    }
    let waited = t0.elapsed();
    assert!(
        waited >= Duration::from_secs(600) && waited < Duration::from_secs(900),
        "{waited:?}"
    );
    let last = lines.last().expect("progress");
    assert!(
        last.contains("vehicle 1 waits for a person")
            && last.contains("Compass not calibrated")
            && last.contains("fleetmap resume"),
        "{last}"
    );
    let saved: MappingState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
    assert!(saved.robot(1).unwrap().grounded.is_some());
    assert_eq!(saved.robot(1).unwrap().flight_s, 0.0);
    let _ = sim.stop().await;
}
