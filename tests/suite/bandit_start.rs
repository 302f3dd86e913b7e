//! Starting a spatial-classification sortie when a vehicle cannot start: the bandit paper's
//! 6×6 hardware mission (4 ArduCopter drones, 2 ArduRover stations) on the embedded
//! simulator, in virtual time (in-process links, tokio's clock paused: minutes of flight in
//! seconds of CPU, the same run every time).
//!
//! * A drone whose pre-arm check keeps failing (the simulator's compass fault, "PreArm:
//!   Compass not calibrated") is out of the run before anything takes off; the journal and
//!   the operator are told which and why and what a person must fix; the three others
//!   classify every cell with its station held, and a run stopped in the middle and resumed
//!   knows it is out and why.
//! * When no drone can start, the run stops at once (even with auto-resume), saying which
//!   vehicles a person must fix and what, then `fleetmap resume`.
//! * A drone whose link goes dark at the moment it is told to arm — the others already
//!   taking off — is out for now: the others hover over their stations while the sortie is
//!   planned again without it, then fly; once its link is back it rejoins and flies, and the
//!   run classifies every cell.

use crate::common;

use fleetmap::fleet::{self, FleetConfig, FleetHandle};
use fleetmap::kinds::bandit::sim::{self as bandit_sim, SimSetup};
use fleetmap::kinds::bandit::{self, BanditEvent, RunOptions};
use fleetmap::store::RunDir;
use fleetmap_core::mission::definition::Role;
use fleetmap_core::planner::sortie::ClassificationState;
use fleetmap_core::time::Time;
use fleetmap_core::world::World;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::transport::{LinkOptions, MemoryPort, open_memory_link};
use fleetmap_sim::harness::Sim;
use fleetmap_sim::server::{SimTask, spawn_memory};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;
use tokio::sync::mpsc;

/// MAV_CMD_COMPONENT_ARM_DISARM.
const ARM: u16 = 400;

struct Team {
    fleet: FleetHandle,
    sim: SimTask,
    /// Set once the switched link has gone dark.
    went_dark: Arc<AtomicBool>,
}

/// Whether a MAVLink 2 frame is a COMMAND_LONG carrying `command` (its `command` field, the
/// two bytes after the seven float params; a trimmed payload never ends before it here).
fn is_command_long(frame: &[u8], command: u16) -> bool {
    frame.len() >= 40
        && frame[0] == 0xFD
        && u32::from_le_bytes([frame[7], frame[8], frame[9], 0]) == 76
        && u16::from_le_bytes([frame[38], frame[39]]) == command
}

/// The hardware team on the simulator behind in-process links and a fleet on them, in
/// virtual time. `compass` get a pre-arm failure that never clears; the link of `dark`
/// carries nothing, either way, for `dark_for` from the first ARM the fleet sends it.
async fn team(compass: &[u8], dark: Option<u8>, dark_for: Duration) -> Team {
    let _ = tracing_subscriber::fmt()
        .with_test_writer()
        .with_env_filter("warn,highs=error")
        .try_init();
    let world = World::from_toml(bandit_sim::HARDWARE_WORLD).unwrap();
    let setup = SimSetup {
        seed: 3,
        camera_px: 160,
        charge_minutes: 6.0,
        ..SimSetup::default()
    };
    let mut sc = bandit_sim::sim_config(bandit_sim::HARDWARE_TEAM, &world, &setup).unwrap();
    for v in &mut sc.vehicles {
        if compass.contains(&v.sysid) {
            v.compass_fault_until_s = Some(f64::INFINITY);
        }
    }
    let sim = Sim::new(sc, Time::ZERO).unwrap();
    let (ev_tx, ev_rx) = mpsc::channel(4096);
    let went_dark = Arc::new(AtomicBool::new(false));
    let mut links = Vec::new();
    let mut ports = Vec::new();
    for (i, sysid) in sim.sysids().into_iter().enumerate() {
        let (h, fleet_end) = open_memory_link(
            i,
            &format!("sim-{sysid}"),
            &LinkOptions::default(),
            ev_tx.clone(),
        );
        links.push(h);
        if Some(sysid) != dark {
            ports.push(fleet_end);
            continue;
        }
        // A link that goes dark, both ways, from the first ARM to this vehicle.
        let (to_sim, from_gcs) = mpsc::unbounded_channel();
        let (to_gcs, mut from_sim) = mpsc::unbounded_channel::<Vec<u8>>();
        ports.push(MemoryPort { from_gcs, to_gcs });
        let MemoryPort {
            from_gcs: mut gcs_rx,
            to_gcs: gcs_tx,
        } = fleet_end;
        let until = Arc::new(std::sync::Mutex::new(None::<tokio::time::Instant>));
        let dark_now = {
            let until = until.clone();
            move || {
                until
                    .lock()
                    .map(|u| u.is_some_and(|t| tokio::time::Instant::now() < t))
                    .unwrap_or(false)
            }
        };
        let flag = went_dark.clone();
        let up_dark = dark_now.clone();
        tokio::spawn(async move {
            while let Some(frame) = gcs_rx.recv().await {
                if !flag.load(Ordering::SeqCst) && is_command_long(&frame, ARM) {
                    flag.store(true, Ordering::SeqCst);
                    if let Ok(mut u) = until.lock() {
                        *u = Some(tokio::time::Instant::now() + dark_for);
                    }
                }
                if !up_dark() && to_sim.send(frame).is_err() {
                    return;
                }
            }
        });
        tokio::spawn(async move {
            while let Some(bytes) = from_sim.recv().await {
                if !dark_now() && gcs_tx.send(bytes).is_err() {
                    return;
                }
            }
        });
    }
    drop(ev_tx);
    let sim = spawn_memory(sim, ports);
    let fleet = fleet::spawn(links, ev_rx, FleetConfig::default(), MonotonicClock::new());
    Team {
        fleet,
        sim,
        went_dark,
    }
}

fn check_finished(s: &ClassificationState, world: &World) {
    assert!(s.is_finished());
    assert_eq!(s.bandit.keep(), world.green_cells(), "keep set");
    assert!(s.bandit.unclassified().is_empty());
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_drone_that_cannot_arm_is_left_out_and_the_others_finish_across_a_resume() {
    let (world, _) = common::bandit::hardware();
    let team = team(&[4], None, Duration::ZERO).await;
    let (state, _, dir, _tmp) = common::bandit::new_run(&team.fleet).await;
    // Stopped at the end of the first sortie flown without drone 4.
    let (lines, stopped) = common::bandit::run_until(&team.fleet, &dir, state, |l| {
        l.contains("every drone on its station")
    })
    .await;
    assert!(stopped, "the run ended before a sortie was flown");
    let told: Vec<&String> = lines
        .iter()
        .filter(|l| l.contains("drone 4 cannot start"))
        .collect();
    assert_eq!(told.len(), 1, "{lines:#?}");
    assert!(
        told[0].contains("Compass not calibrated") && told[0].contains("a person must fix"),
        "{}",
        told[0]
    );
    // What the saved state says, as a resume reads it.
    let saved: ClassificationState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
    let out = saved
        .out
        .get(&4)
        .expect("drone 4 is out in the saved state");
    assert_eq!(out.role, Role::Drone);
    assert!(
        out.reason.contains("Compass not calibrated"),
        "{}",
        out.reason
    );
    assert!(
        out.fix.as_deref().is_some_and(|f| f.contains("pre-arm")),
        "{out:?}"
    );
    assert_eq!(saved.out.len(), 1);
    // Resumed: still out (its check still fails), and the three others finish.
    let (lines, stopped) = common::bandit::run_until(&team.fleet, &dir, saved, |_| false).await;
    assert!(!stopped);
    let done: ClassificationState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
    check_finished(&done, &world);
    assert_eq!(done.out.get(&4).map(|o| o.role), Some(Role::Drone));
    assert_eq!(
        done.airborne_s.get(&4).copied(),
        Some(0.0),
        "drone 4 never flew"
    );
    assert!(
        done.airborne_s
            .iter()
            .filter(|(s, _)| **s != 4)
            .all(|(_, t)| *t > 60.0)
    );
    assert!(
        !lines.iter().any(|l| l.contains("drone 4 cannot start")),
        "a member out is not sent off again while it is not ready: {lines:#?}"
    );
    let events = common::journal::<BanditEvent>(&dir);
    let outs: Vec<&BanditEvent> = events
        .iter()
        .filter(|e| matches!(e, BanditEvent::VehicleOut { sysid: 4, .. }))
        .collect();
    assert_eq!(outs.len(), 1, "{outs:?}");
    assert!(
        events
            .iter()
            .any(|e| matches!(e, BanditEvent::SortieDropped { .. }))
    );
    assert!(
        events
            .iter()
            .any(|e| matches!(e, BanditEvent::Started { resumed: true }))
    );
    assert!(matches!(events.last(), Some(BanditEvent::Finished { .. })));
    // Station 6 held drone 4 on its charger: neither had a mission while drone 4 was out.
    let first_out = events
        .iter()
        .position(|e| matches!(e, BanditEvent::VehicleOut { .. }))
        .unwrap();
    for e in &events[first_out..] {
        if let BanditEvent::SortiePrepared { missions, .. } = e {
            assert!(
                missions.iter().all(|(s, _)| *s != 4 && *s != 6),
                "{missions:?}"
            );
        }
    }
    let _ = team.sim.stop().await;
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn a_drone_whose_link_goes_dark_at_take_off_is_out_then_rejoins() {
    let (world, _) = common::bandit::hardware();
    let team = team(&[], Some(4), Duration::from_secs(120)).await;
    let (state, _, dir, _tmp) = common::bandit::new_run(&team.fleet).await;
    let (lines, _) = common::bandit::run_until(&team.fleet, &dir, state, |_| false).await;
    assert!(team.went_dark.load(Ordering::SeqCst));
    let done: ClassificationState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
    check_finished(&done, &world);
    assert!(done.out.is_empty(), "{:?}", done.out);
    let told = lines
        .iter()
        .find(|l| l.contains("drone 4 cannot start"))
        .expect("the operator is told");
    assert!(told.contains("tried again"), "{told}");
    let events = common::journal::<BanditEvent>(&dir);
    let out = events
        .iter()
        .position(|e| {
            matches!(
                e,
                BanditEvent::VehicleOut {
                    sysid: 4,
                    fix: None,
                    ..
                }
            )
        })
        .expect("drone 4 went out, for a reason a retry may fix");
    let back = events
        .iter()
        .position(|e| matches!(e, BanditEvent::VehicleBack { sysid: 4, .. }))
        .expect("drone 4 rejoined");
    assert!(out < back);
    // The others were in the air when drone 4 went out: they hovered, then flew the sortie
    // planned without it; drone 4 flew after it rejoined.
    assert!(
        done.airborne_s.values().all(|&t| t > 30.0),
        "{:?}",
        done.airborne_s
    );
    let _ = team.sim.stop().await;
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn no_drone_that_can_start_stops_the_run_saying_what_to_fix() {
    let team = team(&[1, 2, 3, 4], None, Duration::ZERO).await;
    let (state, run, dir, _tmp) = common::bandit::new_run(&team.fleet).await;
    let hub = fleetmap::app::images::image_hub(&team.fleet);
    let (tx, mut rx) = mpsc::unbounded_channel();
    let opts = RunOptions {
        progress: Some(tx),
        auto_resume: true,
        ..RunOptions::default()
    };
    let e = bandit::run(team.fleet.clone(), &hub, run, state, opts)
        .await
        .expect_err("no drone can fly");
    let msg = fleetmap::app::error::chain(&e);
    assert!(msg.contains("no drone can fly"), "{msg}");
    for d in 1..=4 {
        assert!(msg.contains(&format!("drone {d}: ")), "{msg}");
    }
    assert!(msg.contains("Compass not calibrated"), "{msg}");
    let mut lines = Vec::new();
    while let Ok(l) = rx.try_recv() {
        lines.push(l.to_string());
    }
    assert!(
        lines
            .iter()
            .any(|l| l.starts_with("the run stops:") && l.contains("fleetmap resume")),
        "{lines:#?}"
    );
    assert!(!lines.iter().any(|l| l.contains("carrying on by itself")));
    let saved: ClassificationState = RunDir::open(&dir).unwrap().load_state().unwrap().unwrap();
    assert_eq!(saved.out.len(), 4);
    assert!(saved.airborne_s.values().all(|&t| t == 0.0));
    let _ = team.sim.stop().await;
}
