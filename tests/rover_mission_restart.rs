//! A station's second mission (issue 25): ArduRover stays in AUTO after its mission is done
//! (MIS_DONE_BEHAVE 0), and there MAV_CMD_MISSION_START is accepted but starts nothing —
//! its handler only asks for AUTO (`GCS_MAVLINK_Rover::handle_command_int_packet`,
//! ArduPilot/ardupilot Rover/GCS_MAVLink_Rover.cpp) and `Rover::set_mode` returns at once for
//! the mode it is in, so `ModeAuto::_enter` / `mission.start_or_resume()` do not run. Seen on
//! ArduRover SITL V4.7.0-dev (90700977): after "Mission Complete" and MISSION_CURRENT seq 2
//! COMPLETE, a new upload, DO_SET_MISSION_CURRENT 1 (MISSION_CURRENT seq 2 NOT_STARTED) and
//! MISSION_START (ACCEPTED) were followed by nothing at all; HOLD, then MISSION_START, ran
//! the mission ("Mission: 1 ChangeSpeed", MISSION_ITEM_REACHED 1, ACTIVE, MISSION_ITEM_REACHED
//! 2, "Mission Complete", COMPLETE).
//!
//! * The simulated ArduRover does the same (a minimal GCS written here on the virtual clock).
//! * The fleet's `start_mission` starts a rover's second mission (HOLD first), as the bandit
//!   runner's stations need from the second sortie on.

#![allow(deprecated)]

use fleetmap::fleet::{self, FleetConfig};
use fleetmap::link::ConnSpec;
use fleetmap::link::transport::LinkOptions;
use fleetmap::mission::{MissionItem, MissionType};
use fleetmap::sim::harness::{Sim, SimConfig};
use fleetmap::sim::server::{self, ServeOptions};
use fleetmap::sim::{Flavour, Mode};
use fleetmap::time::Time;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use num_traits::FromPrimitive;
use std::time::Duration;

const HOME: (f64, f64) = (37.195135, -80.579943);

fn at(north: f64, east: f64) -> (f64, f64) {
    fleetmap::geo::local::offset(HOME.0, HOME.1, north, east)
}

/// A station mission as fleetmap builds it: DO_CHANGE_SPEED, then one waypoint.
fn station_mission(to: (f64, f64)) -> Vec<MissionItem> {
    vec![
        MissionItem::change_speed(1.0),
        MissionItem::waypoint(to.0, to.1, 0.0),
    ]
}

struct Gcs {
    sim: Sim,
    seq: u8,
    last_hb: Time,
}

impl Gcs {
    fn send(&mut self, msg: MavMessage) {
        let h = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: self.seq,
        };
        self.seq = self.seq.wrapping_add(1);
        self.sim.send(1, &h, &msg);
    }

    /// Step the simulation until `pred` accepts a message from the autopilot or `secs` pass.
    fn wait<F: FnMut(&MavMessage) -> bool>(
        &mut self,
        secs: f64,
        mut pred: F,
    ) -> Option<MavMessage> {
        let end = self.sim.now() + Duration::from_secs_f64(secs);
        loop {
            while let Some((h, m)) = self.sim.recv(1) {
                if h.component_id == 1 && pred(&m) {
                    return Some(m);
                }
            }
            if self.sim.now() >= end {
                return None;
            }
            if self.sim.now().saturating_since(self.last_hb) >= Duration::from_secs(1) {
                self.last_hb = self.sim.now();
                self.send(MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
                    custom_mode: 0,
                    mavtype: mav::MavType::MAV_TYPE_GCS,
                    autopilot: mav::MavAutopilot::MAV_AUTOPILOT_INVALID,
                    base_mode: mav::MavModeFlag::empty(),
                    system_status: mav::MavState::MAV_STATE_ACTIVE,
                    mavlink_version: 3,
                }));
            }
            let t = self.sim.now() + Duration::from_millis(50);
            self.sim.advance_to(t);
        }
    }

    fn command(&mut self, cmd: u16, p: [f32; 7]) -> mav::MavResult {
        self.send(MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
            param1: p[0],
            param2: p[1],
            param3: p[2],
            param4: p[3],
            param5: p[4],
            param6: p[5],
            param7: p[6],
            command: mav::MavCmd::from_u16(cmd).unwrap(),
            target_system: 1,
            target_component: 1,
            confirmation: 0,
        }));
        match self.wait(
            3.0,
            |m| matches!(m, MavMessage::COMMAND_ACK(a) if a.command as u16 == cmd),
        ) {
            Some(MavMessage::COMMAND_ACK(a)) => a.result,
            other => panic!("no COMMAND_ACK for {cmd}: {other:?}"),
        }
    }

    /// Upload `items` behind ArduPilot's home slot (seq 0).
    fn upload(&mut self, items: &[MissionItem]) {
        let mut all = vec![MissionItem::waypoint(HOME.0, HOME.1, 0.0)];
        all.extend_from_slice(items);
        let ty = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
        self.send(MavMessage::MISSION_COUNT(mav::MISSION_COUNT_DATA {
            count: all.len() as u16,
            target_system: 1,
            target_component: 1,
            mission_type: ty,
            opaque_id: 0,
        }));
        loop {
            let m = self
                .wait(5.0, |m| {
                    matches!(
                        m,
                        MavMessage::MISSION_REQUEST(_)
                            | MavMessage::MISSION_REQUEST_INT(_)
                            | MavMessage::MISSION_ACK(_)
                    )
                })
                .expect("the upload is answered");
            let seq = match m {
                MavMessage::MISSION_ACK(a) => {
                    assert_eq!(a.mavtype, mav::MavMissionResult::MAV_MISSION_ACCEPTED);
                    return;
                }
                MavMessage::MISSION_REQUEST(r) => r.seq,
                MavMessage::MISSION_REQUEST_INT(r) => r.seq,
                _ => unreachable!(),
            };
            let it = all[seq as usize];
            self.send(MavMessage::MISSION_ITEM_INT(mav::MISSION_ITEM_INT_DATA {
                param1: it.param1,
                param2: it.param2,
                param3: it.param3,
                param4: it.param4,
                x: it.x,
                y: it.y,
                z: it.z,
                seq,
                command: mav::MavCmd::from_u16(it.command).unwrap(),
                target_system: 1,
                target_component: 1,
                frame: mav::MavFrame::from_u8(it.frame).unwrap(),
                current: 0,
                autocontinue: 1,
                mission_type: ty,
            }));
        }
    }

    /// Wait for MISSION_ITEM_REACHED of wire seq `seq`.
    fn reached(&mut self, secs: f64, seq: u16) -> bool {
        self.wait(
            secs,
            |m| matches!(m, MavMessage::MISSION_ITEM_REACHED(r) if r.seq == seq),
        )
        .is_some()
    }
}

const AUTO_START: u16 = 300; // MAV_CMD_MISSION_START
const SET_CURRENT: u16 = 224; // MAV_CMD_DO_SET_MISSION_CURRENT
const ARM: u16 = 400;
const SET_MODE: u16 = 176;

#[test]
fn ardurover_in_auto_ignores_mission_start_until_it_leaves_auto() {
    let cfg = SimConfig::from_spec("1xrover:ardupilot", None, Some(HOME), 5).unwrap();
    let mut g = Gcs {
        sim: Sim::new(cfg, Time::ZERO).unwrap(),
        seq: 0,
        last_hb: Time::ZERO,
    };
    g.wait(25.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
        .expect("home");
    let ok = mav::MavResult::MAV_RESULT_ACCEPTED;
    // First sortie: one cell (5 m) east, started as fleetmap starts a station.
    g.upload(&station_mission(at(0.0, 5.0)));
    assert_eq!(
        g.command(SET_CURRENT, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        ok
    );
    // ArduRover arms in MANUAL without RC; the sim's rover arms in any mode
    assert_eq!(g.command(ARM, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]), ok);
    assert_eq!(g.command(AUTO_START, [0.0; 7]), ok);
    assert!(g.reached(60.0, 2), "the first mission is driven to its end");
    let auto = Flavour::ARDU_ROVER.custom_mode(Mode::Auto).unwrap();
    let in_auto = g.wait(
        3.0,
        |m| matches!(m, MavMessage::HEARTBEAT(h) if h.custom_mode == auto),
    );
    assert!(
        in_auto.is_some(),
        "a finished mission leaves ArduRover in AUTO"
    );

    // Second sortie: back to the start cell.
    g.upload(&station_mission(at(0.0, 0.0)));
    assert_eq!(
        g.command(SET_CURRENT, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        ok
    );
    assert_eq!(
        g.command(AUTO_START, [0.0; 7]),
        ok,
        "accepted, as ArduRover does"
    );
    let mut states = Vec::new();
    let anything = g.wait(15.0, |m| match m {
        MavMessage::MISSION_ITEM_REACHED(_) => true,
        MavMessage::MISSION_CURRENT(c) => {
            states.push(c.mission_state);
            c.mission_state == mav::MissionState::MISSION_STATE_ACTIVE
        }
        _ => false,
    });
    assert!(
        anything.is_none(),
        "MISSION_START in AUTO must start nothing: {anything:?}"
    );
    assert!(
        states
            .iter()
            .all(|s| *s == mav::MissionState::MISSION_STATE_NOT_STARTED),
        "{states:?}"
    );

    // Leaving AUTO first: HOLD, then MISSION_START runs the mission.
    let hold = Flavour::ARDU_ROVER.custom_mode(Mode::Hold).unwrap();
    assert_eq!(
        g.command(SET_MODE, [1.0, hold as f32, 0.0, 0.0, 0.0, 0.0, 0.0]),
        ok
    );
    assert_eq!(g.command(AUTO_START, [0.0; 7]), ok);
    assert!(g.reached(60.0, 2), "from HOLD the mission runs to its end");
}

/// The fleet starts a rover's mission a second time although the first left it in AUTO.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_fleet_starts_a_rovers_second_mission() {
    let listen: ConnSpec = "udpin:127.0.0.1:0".parse().unwrap();
    let f = fleet::start(&[listen], &LinkOptions::default(), FleetConfig::default())
        .await
        .unwrap();
    let gcs = f.links()[0].local.expect("the port the GCS listens on");
    let sim = Sim::new(
        SimConfig::from_spec("1xrover:ardupilot", None, Some(HOME), 5).unwrap(),
        Time::ZERO,
    )
    .unwrap();
    let _served = server::spawn(
        sim,
        ServeOptions {
            endpoints: vec![server::Endpoint::parse(&format!("udpout:{gcs}")).unwrap()],
            speed: fleetmap::sim::pace::Speed::Times(5.0),
            gcs: server::GcsClock::Wall,
            image_dir: None,
            duration_s: None,
        },
    )
    .await
    .unwrap();
    let wait = Duration::from_secs(60);
    f.wait_until(1, wait, |v| v.home.is_some())
        .await
        .expect("the rover and its home");
    let last = 1u16; // user numbering: DO_CHANGE_SPEED 0, the waypoint 1
    for (k, to) in [at(0.0, 5.0), at(0.0, 0.0)].into_iter().enumerate() {
        f.upload_mission(1, MissionType::Mission, station_mission(to))
            .await
            .unwrap();
        f.set_mission_current(1, 0).await.unwrap();
        f.arm(1).await.unwrap();
        f.start_mission(1).await.unwrap();
        // The snapshot shows the fleet's reset of the progress (it is published a few times a
        // second): only a MISSION_ITEM_REACHED after it counts.
        f.wait_until(1, Duration::from_secs(5), |v| v.reached.is_empty())
            .await
            .expect("the progress is reset on start");
        f.wait_until(1, wait, |v| v.reached.contains(&last))
            .await
            .unwrap_or_else(|v| {
                panic!(
                    "mission {k}: the rover never reached its waypoint: reached {:?}, current \
                     {:?}, state {:?}",
                    v.as_ref().map(|v| v.reached.clone()),
                    v.as_ref().and_then(|v| v.mission_current),
                    v.as_ref().and_then(|v| v.mission_state),
                )
            });
    }
}
