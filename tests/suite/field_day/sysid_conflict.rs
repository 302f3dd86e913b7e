//! Two autopilots left at the same system id on one link, on the embedded simulator in
//! virtual time: two simulated ArduCopters both answering as system id 1
//! share the fleet's link 0 — as two SITLs sending to one GCS UDP port do — and what the GCS
//! sends on it reaches both. Both missions refuse to start with the error that names the id
//! and says what to do, before any upload, arming or mode change (checked on every frame the
//! GCS sent); a fleet where every autopilot has its own id is not flagged and starts.

use fleetmap::app::error::RunnerError;
use fleetmap::fleet::{self, FleetConfig, FleetHandle};
use fleetmap::kinds::bandit;
use fleetmap::kinds::bandit::sim::{self as bandit_sim, SimSetup};
use fleetmap_core::explore::dfs::Sharing;
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::time::Time;
use fleetmap_core::world::World;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::transport::{LinkOptions, MemoryPort, open_memory_link};
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_sim::server::{SimTask, spawn_memory};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tokio::sync::mpsc;

use crate::common;

/// Every frame the GCS sent, on any link.
type Sent = Arc<Mutex<Vec<Vec<u8>>>>;

/// The fleet on one in-process link per system id (in order of first appearance in the
/// simulator), the vehicles that share an id on the same link; what the GCS sends on a link
/// reaches every vehicle on it.
fn wire(sim: Sim) -> (FleetHandle, SimTask, Sent) {
    let sysids = sim.sysids();
    let mut order: Vec<u8> = Vec::new();
    for s in &sysids {
        if !order.contains(s) {
            order.push(*s);
        }
    }
    let (ev_tx, ev_rx) = mpsc::channel(4096);
    let sent: Sent = Arc::default();
    let mut links = Vec::new();
    let mut ports: Vec<Option<MemoryPort>> = sysids.iter().map(|_| None).collect();
    for (i, id) in order.iter().enumerate() {
        let (h, fleet_end) = open_memory_link(
            i,
            &format!("link-{id}"),
            &LinkOptions::default(),
            ev_tx.clone(),
        );
        links.push(h);
        let MemoryPort {
            mut from_gcs,
            to_gcs,
        } = fleet_end;
        let mut fan = Vec::new();
        for (k, s) in sysids.iter().enumerate() {
            if s == id {
                let (tx, rx) = mpsc::unbounded_channel();
                fan.push(tx);
                ports[k] = Some(MemoryPort {
                    from_gcs: rx,
                    to_gcs: to_gcs.clone(),
                });
            }
        }
        let log = sent.clone();
        tokio::spawn(async move {
            while let Some(frame) = from_gcs.recv().await {
                if let Ok(mut l) = log.lock() {
                    l.push(frame.clone());
                }
                for f in &fan {
                    let _ = f.send(frame.clone());
                }
            }
        });
    }
    drop(ev_tx);
    let ports = ports.into_iter().map(|p| p.expect("a port")).collect();
    let sim = spawn_memory(sim, ports);
    let fleet = fleet::spawn(links, ev_rx, FleetConfig::default(), MonotonicClock::new());
    (fleet, sim, sent)
}

/// A MAVLink 2 frame's message id.
fn msg_id(f: &[u8]) -> Option<u32> {
    (f.len() >= 10 && f[0] == 0xFD).then(|| u32::from_le_bytes([f[7], f[8], f[9], 0]))
}

/// What in `sent` would have uploaded, armed or switched a mode: MISSION_COUNT (44),
/// SET_MODE (11), MISSION_ITEM_INT (73), or a COMMAND_LONG / COMMAND_INT carrying
/// COMPONENT_ARM_DISARM (400), DO_SET_MODE (176) or NAV_TAKEOFF (22).
fn commanding(sent: &Sent) -> Vec<String> {
    let frames = sent.lock().map(|l| l.clone()).unwrap_or_default();
    frames
        .iter()
        .filter_map(|f| {
            let id = msg_id(f)?;
            let cmd = |at: usize| f.get(at..at + 2).map(|b| u16::from_le_bytes([b[0], b[1]]));
            match id {
                11 | 44 | 73 => Some(format!("message {id}")),
                76 => cmd(38)
                    .filter(|c| [400, 176, 22].contains(c))
                    .map(|c| format!("COMMAND_LONG {c}")),
                75 => cmd(38)
                    .filter(|c| [400, 176, 22].contains(c))
                    .map(|c| format!("COMMAND_INT {c}")),
                _ => None,
            }
        })
        .collect()
}

fn assert_refused(r: Result<(), RunnerError>, sent: &Sent) {
    let e = r.expect_err("the run started with two autopilots on system id 1");
    assert!(
        matches!(e, RunnerError::SysidConflict { sysid: 1, .. }),
        "{e:?}"
    );
    let text = e.to_string();
    for needed in [
        "REFUSED",
        "system id 1",
        "SYSID_THISMAV",
        "MAV_SYS_ID",
        "restart",
    ] {
        assert!(text.contains(needed), "{needed:?} missing from: {text}");
    }
    let bad = commanding(sent);
    assert!(bad.is_empty(), "sent before refusing: {bad:?}");
    assert!(
        !sent.lock().unwrap().is_empty(),
        "the GCS sent nothing at all: the check proves nothing"
    );
}

/// Two ArduCopters over the strip world plus, with `twin`, a third at system id 1 beside
/// the first.
fn strip_sim(twin: bool) -> Sim {
    let world = World::from_toml(common::WORLD).unwrap();
    let mut sc = SimConfig::from_spec("2xcopter:ardupilot", Some(world), None, 5).unwrap();
    if twin {
        let mut v = sc.vehicles[0].clone();
        v.start = fleetmap_core::geo::local::offset(v.start.0, v.start.1, 0.0, 6.0);
        v.seed ^= 0xD0_0B1E;
        sc.vehicles.push(v);
        sc = sc.with_sysid(3, 1).unwrap();
    }
    Sim::new(sc, Time::ZERO).unwrap()
}

fn two_drones() -> MissionDef {
    let text = format!(
        "{}\n[[vehicles]]\nsysid = 2\nrole = \"drone\"\nname = \"uav2\"\n",
        common::strip_mission()
    );
    MissionDef::parse(&text, "strip, two drones").unwrap()
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn runway_run_refuses_two_autopilots_on_one_system_id() {
    let (fleet, _sim, sent) = wire(strip_sim(true));
    let t0 = tokio::time::Instant::now();
    let r = fleetmap::kinds::runway::new_mapping(
        &fleet,
        &two_drones(),
        Sharing::Gcs,
        Duration::from_secs(60),
    )
    .await
    .map(|_| ());
    assert_refused(r, &sent);
    let v = fleet.vehicle(1).unwrap();
    let c = v.sysid_conflict.expect("vehicle 1 marked");
    assert!(c.detect_s < 5.0, "found after {} s", c.detect_s);
    assert!(t0.elapsed() < Duration::from_secs(10), "{:?}", t0.elapsed());
    assert!(fleet.vehicle(2).unwrap().sysid_conflict.is_none());
    // The fleet itself refuses to command it.
    let e = fleet.arm(1).await.expect_err("armed a conflicted id");
    assert!(e.to_string().contains("two or more autopilots"), "{e}");
    assert!(commanding(&sent).is_empty());
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn runway_run_starts_on_a_clean_fleet() {
    let (fleet, _sim, _sent) = wire(strip_sim(false));
    let state = fleetmap::kinds::runway::new_mapping(
        &fleet,
        &two_drones(),
        Sharing::Gcs,
        Duration::from_secs(60),
    )
    .await
    .expect("a clean fleet starts");
    assert_eq!(state.robots.len(), 2);
    for s in [1, 2] {
        let v = fleet.vehicle(s).unwrap();
        assert!(v.sysid_checked, "vehicle {s} not checked");
        assert!(v.sysid_conflict.is_none(), "vehicle {s} flagged");
    }
}

/// The bandit paper's hardware team (4 drones, 2 stations) and, with `twin`, a seventh
/// vehicle: another drone left at system id 1.
fn hardware_sim(twin: bool) -> Sim {
    let world = World::from_toml(bandit_sim::HARDWARE_WORLD).unwrap();
    let setup = SimSetup {
        seed: 3,
        camera_px: 160,
        ..SimSetup::default()
    };
    let mut sc = bandit_sim::sim_config(bandit_sim::HARDWARE_TEAM, &world, &setup).unwrap();
    if twin {
        let mut v = sc.vehicles[0].clone();
        v.start = fleetmap_core::geo::local::offset(v.start.0, v.start.1, 0.0, 5.0);
        v.seed ^= 0xD0_0B1E;
        sc.vehicles.push(v);
        let n = sc.vehicles.len();
        sc = sc.with_sysid(n, 1).unwrap();
    }
    Sim::new(sc, Time::ZERO).unwrap()
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn bandit_run_refuses_two_autopilots_on_one_system_id() {
    let (fleet, _sim, sent) = wire(hardware_sim(true));
    let def = MissionDef::parse(bandit_sim::HARDWARE_MISSION, "hardware-6x6.toml").unwrap();
    let r = bandit::new_state(&fleet, &def, Duration::from_secs(60), None)
        .await
        .map(|_| ());
    let e = r.expect_err("the bandit run started with two autopilots on system id 1");
    let text = format!("{e}");
    assert!(
        text.contains("REFUSED") && text.contains("system id 1"),
        "{text}"
    );
    assert!(text.contains("SYSID_THISMAV"), "{text}");
    let bad = commanding(&sent);
    assert!(bad.is_empty(), "sent before refusing: {bad:?}");
    assert!(fleet.vehicle(1).unwrap().sysid_conflict.is_some());
    for s in 2..=6 {
        assert!(fleet.vehicle(s).unwrap().sysid_conflict.is_none(), "{s}");
    }
}

#[tokio::test(flavor = "current_thread", start_paused = true)]
async fn bandit_run_starts_on_a_clean_fleet() {
    let (fleet, _sim, _sent) = wire(hardware_sim(false));
    let def = MissionDef::parse(bandit_sim::HARDWARE_MISSION, "hardware-6x6.toml").unwrap();
    bandit::new_state(&fleet, &def, Duration::from_secs(60), None)
        .await
        .expect("a clean fleet starts");
    for s in 1..=6 {
        let v = fleet.vehicle(s).unwrap();
        assert!(v.sysid_checked && v.sysid_conflict.is_none(), "{s}");
    }
}
