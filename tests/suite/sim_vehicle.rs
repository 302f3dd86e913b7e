//! End-to-end tests of the simulated autopilots on the virtual clock: a minimal GCS (written
//! here from the MAVLink protocol descriptions, independent of the simulator's code) uploads
//! and downloads missions, arms, takes off and flies them in AUTO for every flavour and
//! vehicle type; the low-battery failsafe and battery swaps; determinism.

#![allow(deprecated)]

use fleetmap_core::mission::item::MissionItem;
use fleetmap_core::time::Time;
use fleetmap_sim::flavour::{SimFlavour, SimMode};
use fleetmap_sim::harness::{Sim, SimConfig};
use fleetmap_test_kit::at;
use fleetmap_test_kit::gcs::{Headers, command_long, heartbeat, status_text};
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use num_traits::FromPrimitive;
use std::time::Duration;

const HOME: (f64, f64) = (37.1965, -80.5785);
/// The simulated crew's battery turnaround in these tests, seconds after the disarm.
const CREW_SWAP_S: f64 = 5.0;

struct Gcs {
    sim: Sim,
    sysid: u8,
    headers: Headers,
    last_hb: Time,
    log: Vec<(Time, MavHeader, MavMessage)>,
}

impl Gcs {
    fn new(spec: &str, seed: u64) -> Gcs {
        Gcs::with(spec, seed, |_| {})
    }

    fn with(spec: &str, seed: u64, edit: impl FnOnce(&mut SimConfig)) -> Gcs {
        let mut cfg = SimConfig::from_spec(spec, None, Some(HOME), seed).unwrap();
        edit(&mut cfg);
        Gcs {
            sim: Sim::new(cfg, Time::ZERO).unwrap(),
            sysid: 1,
            headers: Headers::default(),
            last_hb: Time::ZERO,
            log: Vec::new(),
        }
    }

    fn send(&mut self, msg: MavMessage) {
        let h = self.headers.next_header();
        self.sim.send(self.sysid, &h, &msg);
    }

    fn heartbeat(&mut self) {
        self.send(heartbeat());
    }

    /// Step the simulation until `pred` accepts a received message or `secs` pass.
    fn wait<F: FnMut(&MavMessage) -> bool>(
        &mut self,
        secs: f64,
        mut pred: F,
    ) -> Option<MavMessage> {
        let end = self.sim.now() + Duration::from_secs_f64(secs);
        loop {
            while let Some((h, m)) = self.sim.recv(self.sysid) {
                self.log.push((self.sim.now(), h, m.clone()));
                if h.component_id == 1 && pred(&m) {
                    return Some(m);
                }
            }
            if self.sim.now() >= end {
                return None;
            }
            if self.sim.now().saturating_since(self.last_hb) >= Duration::from_secs(1) {
                self.last_hb = self.sim.now();
                self.heartbeat();
            }
            let t = self.sim.now() + Duration::from_millis(50);
            self.sim.advance_to(t);
        }
    }

    fn command(&mut self, cmd: u16, p: [f32; 7]) -> mav::MavResult {
        self.send(command_long((self.sysid, 1), cmd, p));
        match self.wait(
            3.0,
            |m| matches!(m, MavMessage::COMMAND_ACK(a) if a.command as u16 == cmd),
        ) {
            Some(MavMessage::COMMAND_ACK(a)) => a.result,
            other => panic!("no COMMAND_ACK for {cmd}: {other:?}"),
        }
    }

    fn set_mode(&mut self, flavour: SimFlavour, mode: SimMode) -> mav::MavResult {
        let c = flavour.custom_mode(mode).unwrap();
        if flavour.is_ardupilot() {
            self.command(176, [1.0, c as f32, 0.0, 0.0, 0.0, 0.0, 0.0])
        } else {
            self.command(
                176,
                [
                    1.0,
                    ((c >> 16) & 0xff) as f32,
                    (c >> 24) as f32,
                    0.0,
                    0.0,
                    0.0,
                    0.0,
                ],
            )
        }
    }

    fn upload(&mut self, items: &[MissionItem]) -> mav::MavMissionResult {
        self.upload_type(items, mav::MavMissionType::MAV_MISSION_TYPE_MISSION)
    }

    fn upload_type(
        &mut self,
        items: &[MissionItem],
        mission_type: mav::MavMissionType,
    ) -> mav::MavMissionResult {
        self.send(MavMessage::MISSION_COUNT(mav::MISSION_COUNT_DATA {
            count: items.len() as u16,
            target_system: self.sysid,
            target_component: 1,
            mission_type,
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
                .expect("vehicle stopped answering the upload");
            let seq = match m {
                MavMessage::MISSION_ACK(a) => return a.mavtype,
                MavMessage::MISSION_REQUEST(r) => r.seq,
                MavMessage::MISSION_REQUEST_INT(r) => r.seq,
                _ => unreachable!(),
            };
            let it = items[seq as usize];
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
                target_system: self.sysid,
                target_component: 1,
                frame: mav::MavFrame::from_u8(it.frame).unwrap(),
                current: 0,
                autocontinue: 1,
                mission_type,
            }));
        }
    }

    fn download(&mut self) -> Vec<MissionItem> {
        self.send(MavMessage::MISSION_REQUEST_LIST(
            mav::MISSION_REQUEST_LIST_DATA {
                target_system: self.sysid,
                target_component: 1,
                mission_type: mav::MavMissionType::MAV_MISSION_TYPE_MISSION,
            },
        ));
        let n = match self.wait(3.0, |m| matches!(m, MavMessage::MISSION_COUNT(_))) {
            Some(MavMessage::MISSION_COUNT(c)) => c.count,
            other => panic!("{other:?}"),
        };
        let mut out = Vec::new();
        for seq in 0..n {
            self.send(MavMessage::MISSION_REQUEST_INT(
                mav::MISSION_REQUEST_INT_DATA {
                    seq,
                    target_system: self.sysid,
                    target_component: 1,
                    mission_type: mav::MavMissionType::MAV_MISSION_TYPE_MISSION,
                },
            ));
            match self.wait(
                3.0,
                |m| matches!(m, MavMessage::MISSION_ITEM_INT(i) if i.seq == seq),
            ) {
                Some(MavMessage::MISSION_ITEM_INT(i)) => out.push(MissionItem {
                    frame: i.frame as u8,
                    command: i.command as u16,
                    current: i.current != 0,
                    autocontinue: i.autocontinue != 0,
                    param1: i.param1,
                    param2: i.param2,
                    param3: i.param3,
                    param4: i.param4,
                    x: i.x,
                    y: i.y,
                    z: i.z,
                }),
                other => panic!("{other:?}"),
            }
        }
        self.send(MavMessage::MISSION_ACK(mav::MISSION_ACK_DATA {
            target_system: self.sysid,
            target_component: 1,
            mavtype: mav::MavMissionResult::MAV_MISSION_ACCEPTED,
            mission_type: mav::MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        }));
        out
    }

    /// Arm and take off to `alt_m` above home in guided flight: ArduPilot in GUIDED with a
    /// relative takeoff altitude, PX4 with an AMSL one. Both commands must be accepted.
    fn arm_and_take_off(&mut self, flavour: SimFlavour, alt_m: f32) {
        if flavour.is_ardupilot() {
            assert_eq!(
                self.set_mode(flavour, SimMode::Guided),
                mav::MavResult::MAV_RESULT_ACCEPTED
            );
        }
        assert_eq!(
            self.command(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            mav::MavResult::MAV_RESULT_ACCEPTED
        );
        let takeoff = if flavour.is_ardupilot() {
            [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, alt_m]
        } else {
            let amsl = self.sim.vehicle(self.sysid).unwrap().home().unwrap().2 as f32 + alt_m;
            [0.0, 0.0, 0.0, f32::NAN, f32::NAN, f32::NAN, amsl]
        };
        assert_eq!(
            self.command(22, takeoff),
            mav::MavResult::MAV_RESULT_ACCEPTED
        );
    }

    fn texts(&self) -> Vec<String> {
        self.log
            .iter()
            .filter_map(|(_, _, m)| status_text(m))
            .collect()
    }
}

fn mission(copter: bool) -> Vec<MissionItem> {
    let (a, b, c) = (
        at(HOME, 20.0, 0.0),
        at(HOME, 20.0, 20.0),
        at(HOME, 0.0, 20.0),
    );
    let mut v = Vec::new();
    if copter {
        // At the launch position: PX4 flies a take-off item as a waypoint to its position.
        v.push(MissionItem::takeoff_at(HOME.0, HOME.1, 10.0));
    }
    v.push(MissionItem::change_speed(4.0));
    v.push(MissionItem::waypoint(a.0, a.1, 10.0));
    v.push(MissionItem::image_start_capture(0.0, 1));
    v.push(MissionItem::waypoint(b.0, b.1, 10.0));
    v.push(MissionItem::waypoint(c.0, c.1, 10.0));
    // once more around the last two waypoints (jump targets in the autopilot's numbering;
    // `fly` shifts them for ArduPilot's home slot)
    v.push(MissionItem::jump(v.len() as u16 - 2, 1));
    v.push(MissionItem::return_to_launch());
    v
}

fn fly(flavour: SimFlavour) {
    let spec = format!("1x{flavour}");
    let mut g = Gcs::new(&spec, 7);
    let copter = flavour.is_copter();
    let ap = flavour.is_ardupilot();
    // arming before the position estimate is refused with the autopilot's result
    let early = g.command(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]);
    assert_eq!(
        early,
        if ap {
            mav::MavResult::MAV_RESULT_FAILED
        } else {
            mav::MavResult::MAV_RESULT_TEMPORARILY_REJECTED
        },
        "{flavour}"
    );
    assert!(
        g.texts()
            .iter()
            .any(|t| t.starts_with("PreArm") || t.starts_with("Preflight Fail")),
        "{:?}",
        g.texts()
    );
    // position estimate, home
    g.wait(25.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
        .expect("home");
    // ArduPilot streams on request
    g.send(MavMessage::REQUEST_DATA_STREAM(
        mav::REQUEST_DATA_STREAM_DATA {
            req_message_rate: 4,
            target_system: 1,
            target_component: 1,
            req_stream_id: mav::MavDataStream::MAV_DATA_STREAM_ALL,
            start_stop: 1,
        },
    ));
    g.wait(3.0, |m| matches!(m, MavMessage::GLOBAL_POSITION_INT(_)))
        .expect("position stream");

    let mut items = mission(copter);
    if ap {
        items.insert(0, MissionItem::waypoint(HOME.0, HOME.1, 0.0));
        for it in &mut items {
            if it.command == 177 {
                it.param1 += 1.0;
            }
        }
    }
    assert_eq!(
        g.upload(&items),
        mav::MavMissionResult::MAV_MISSION_ACCEPTED
    );
    let back = g.download();
    assert_eq!(back.len(), items.len());
    for (i, (a, b)) in items.iter().zip(&back).enumerate().skip(usize::from(ap)) {
        assert_eq!(a.command, b.command, "item {i}");
        assert_eq!((a.x, a.y), (b.x, b.y), "item {i}");
    }

    // arm and fly
    if copter {
        if ap {
            assert_eq!(
                g.set_mode(flavour, SimMode::Guided),
                mav::MavResult::MAV_RESULT_ACCEPTED
            );
            assert_eq!(
                g.command(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                mav::MavResult::MAV_RESULT_ACCEPTED
            );
            assert_eq!(
                g.command(22, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 10.0]),
                mav::MavResult::MAV_RESULT_ACCEPTED
            );
            g.wait(
                20.0,
                |m| matches!(m, MavMessage::GLOBAL_POSITION_INT(p) if p.relative_alt > 9_500),
            )
            .expect("takeoff");
            assert_eq!(
                g.set_mode(flavour, SimMode::Auto),
                mav::MavResult::MAV_RESULT_ACCEPTED
            );
        } else {
            assert_eq!(
                g.command(300, [0.0; 7]),
                mav::MavResult::MAV_RESULT_ACCEPTED,
                "PX4 MISSION_START arms"
            );
        }
    } else {
        assert_eq!(
            g.set_mode(flavour, SimMode::Auto),
            mav::MavResult::MAV_RESULT_ACCEPTED
        );
        assert_eq!(
            g.command(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            mav::MavResult::MAV_RESULT_ACCEPTED
        );
        if ap {
            // ArduRover starts the mission when armed in AUTO
        }
    }
    let first = usize::from(ap);
    let mut reached = std::collections::BTreeSet::new();
    let last = (items.len() - 1) as u16;
    g.wait(240.0, |m| {
        if let MavMessage::MISSION_ITEM_REACHED(r) = m {
            reached.insert(r.seq);
            return r.seq == last;
        }
        false
    })
    .unwrap_or_else(|| panic!("{flavour}: mission not finished, reached {reached:?}"));
    // the jump flew the last two waypoints twice
    let jump_at = items.iter().position(|it| it.command == 177).unwrap();
    let twice = g
        .log
        .iter()
        .filter(|(_, _, m)| matches!(m, MavMessage::MISSION_ITEM_REACHED(r) if usize::from(r.seq) == jump_at - 1))
        .count();
    assert!(
        twice >= 2,
        "{flavour}: waypoint before the jump reached {twice} times"
    );
    // every navigation item was reported (ArduPilot: not the camera do-item)
    for (i, it) in items.iter().enumerate().skip(first) {
        let expect = if ap {
            it.command <= 95 || it.command == 178
        } else {
            it.command != 177
        };
        let expect = expect && (copter || it.command != 22);
        assert_eq!(
            reached.contains(&(i as u16)),
            expect,
            "{flavour} item {i} ({}) reached {reached:?}",
            it.command
        );
    }
    if copter {
        // RTL ends on the ground at home, disarmed
        let hb = g.wait(30.0, |m| matches!(m, MavMessage::HEARTBEAT(h) if !h.base_mode.contains(mav::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED)));
        assert!(hb.is_some(), "{flavour}: not disarmed after RTL");
        let v = g.sim.vehicle(1).unwrap();
        assert!(v.landed());
        let (lat, lon, _) = v.true_position();
        let d = fleetmap_core::geo::local::distance(lat, lon, HOME.0, HOME.1);
        assert!(d < 2.0, "{flavour}: landed {d} m from home");
        // a camera image was taken at the second waypoint
        let (_, img) = g.sim.poll_image().expect("an image");
        let (a, b) = at(HOME, 20.0, 0.0);
        let d = fleetmap_core::geo::local::distance(img.true_pose.lat, img.true_pose.lon, a, b);
        // PX4 reaches a waypoint — and takes the picture that follows — as soon as its estimate
        // is within NAV_ACC_RAD (2 m), still flying; the GPS error (0.4 m per axis) comes on top.
        let tol = if flavour.is_ardupilot() {
            2.0
        } else {
            2.0 + 1.5
        };
        assert!(d < tol, "{flavour}: image {d} m from the waypoint");
        assert!(image::load_from_memory(&img.jpeg).is_ok());
    }
}

#[test]
fn ardupilot_copter_flies_a_mission() {
    fly(SimFlavour::ARDU_COPTER);
}

#[test]
fn px4_copter_flies_a_mission() {
    fly(SimFlavour::PX4_COPTER);
}

#[test]
fn ardupilot_rover_drives_a_mission() {
    fly(SimFlavour::ARDU_ROVER);
}

#[test]
fn px4_rover_drives_a_mission() {
    fly(SimFlavour::PX4_ROVER);
}

#[test]
fn low_battery_failsafe_lands_at_home_and_a_swap_reboots() {
    for flavour in [SimFlavour::ARDU_COPTER, SimFlavour::PX4_COPTER] {
        // the configured levels: RTL at 25 %, land at 8 % (ArduPilot BATT_LOW_MAH /
        // BATT_CRT_MAH, PX4 BAT_CRIT_THR / BAT_EMERGEN_THR)
        let mut g = Gcs::with(&format!("1x{flavour}"), 3, |c| {
            c.vehicles[0].failsafe = fleetmap_sim::vehicle::BatteryFailsafe {
                rtl_pct: 25.0,
                land_pct: 8.0,
            };
            c.vehicles[0].swap_after_s = Some(CREW_SWAP_S);
        });
        g.wait(25.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
            .unwrap();
        let items = if flavour.is_ardupilot() {
            vec![
                MissionItem::waypoint(HOME.0, HOME.1, 0.0),
                MissionItem::takeoff(10.0),
            ]
        } else {
            vec![MissionItem::takeoff(10.0)]
        };
        assert_eq!(
            g.upload(&items),
            mav::MavMissionResult::MAV_MISSION_ACCEPTED
        );
        g.send(MavMessage::REQUEST_DATA_STREAM(
            mav::REQUEST_DATA_STREAM_DATA {
                req_message_rate: 2,
                target_system: 1,
                target_component: 1,
                req_stream_id: mav::MavDataStream::MAV_DATA_STREAM_ALL,
                start_stop: 1,
            },
        ));
        // hover 20 m east of home
        g.arm_and_take_off(flavour, 10.0);
        g.wait(
            20.0,
            |m| matches!(m, MavMessage::GLOBAL_POSITION_INT(p) if p.relative_alt > 9_000),
        )
        .unwrap_or_else(|| panic!("{flavour}: not airborne: {:?}", g.texts()));
        let (lat, lon) = at(HOME, 0.0, 20.0);
        let r = g.command(
            192,
            [
                -1.0,
                1.0,
                0.0,
                f32::NAN,
                lat as f32,
                lon as f32,
                g.sim.vehicle(1).unwrap().home().unwrap().2 as f32 + 10.0,
            ],
        );
        assert_eq!(r, mav::MavResult::MAV_RESULT_ACCEPTED, "{flavour}");
        // hover until the failsafe (12 minutes of battery)
        let rtl = flavour.custom_mode(SimMode::Rtl).unwrap();
        let hb = g.wait(
            900.0,
            |m| matches!(m, MavMessage::HEARTBEAT(h) if h.custom_mode == rtl),
        );
        assert!(hb.is_some(), "{flavour}: no RTL");
        let pct = g.sim.vehicle(1).unwrap().battery().fraction() * 100.0;
        assert!((pct - 25.0).abs() < 0.5, "{flavour}: failsafe at {pct} %");
        // ... lands at home and disarms
        g.wait(120.0, |m| matches!(m, MavMessage::HEARTBEAT(h) if !h.base_mode.contains(mav::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED)))
            .unwrap_or_else(|| panic!("{flavour}: not disarmed after landing: {:?} {:?}", g.texts(), g.sim.vehicle(1).unwrap().true_position()));
        // (disarmed within the last second: the heartbeat is 1 Hz)
        let disarmed_at = g.sim.now();
        let v = g.sim.vehicle(1).unwrap();
        let (lat, lon, u) = v.true_position();
        assert!(u < 0.01);
        let d = fleetmap_core::geo::local::distance(lat, lon, HOME.0, HOME.1);
        assert!(
            d < 2.0,
            "{flavour}: landed {d} m from home: {:?}",
            g.texts()
        );
        let boot_ms = |g: &mut Gcs| match g.wait(3.0, |m| {
            matches!(
                m,
                MavMessage::SYS_STATUS(_)
                    | MavMessage::ATTITUDE(_)
                    | MavMessage::GLOBAL_POSITION_INT(_)
            )
        }) {
            Some(MavMessage::GLOBAL_POSITION_INT(p)) => p.time_boot_ms,
            Some(MavMessage::ATTITUDE(a)) => a.time_boot_ms,
            _ => 0,
        };
        let _ = boot_ms;
        // No GCS command swaps a battery: MAV_CMD_USER_1 (which the simulator once took for
        // "swapped") is unsupported, as ArduPilot answers it, and changes nothing.
        assert_eq!(
            g.command(31010, [0.0; 7]),
            mav::MavResult::MAV_RESULT_UNSUPPORTED
        );
        assert_eq!(g.sim.vehicle(1).unwrap().boots(), 1, "{flavour}");
        // The crew swaps the battery CREW_SWAP_S after the disarm (which the 1 Hz heartbeat
        // reported up to a second late): until then the vehicle stays on with its used
        // battery, then it powers off, then boots again.
        let before = disarmed_at + Duration::from_secs_f64(CREW_SWAP_S - 1.5);
        g.wait(before.saturating_since(g.sim.now()).as_secs_f64(), |_| {
            false
        });
        let v = g.sim.vehicle(1).unwrap();
        assert!(
            v.powered() && v.boots() == 1,
            "{flavour}: swapped before the crew came"
        );
        assert!(v.battery().percent() < 95, "{flavour}");
        while g.sim.vehicle(1).unwrap().powered() {
            assert!(
                g.sim.now().saturating_since(disarmed_at)
                    < Duration::from_secs_f64(CREW_SWAP_S + 1.0),
                "{flavour}: the crew never swapped the battery"
            );
            g.wait(0.05, |_| false);
        }
        let off_at = g.sim.now();
        assert!(
            off_at.saturating_since(disarmed_at) >= Duration::from_secs_f64(CREW_SWAP_S - 1.5),
            "{flavour}: swapped before the crew's turnaround"
        );
        let hb = g.wait(10.0, |m| matches!(m, MavMessage::HEARTBEAT(_)));
        assert!(hb.is_some());
        assert!(
            g.sim.now().saturating_since(off_at) >= Duration::from_secs(2),
            "power off"
        );
        let last = g.log.last().unwrap();
        assert!(
            last.1.sequence < 5,
            "sequence numbers restart: {}",
            last.1.sequence
        );
        let v = g.sim.vehicle(1).unwrap();
        assert_eq!(v.boots(), 2);
        assert_eq!(v.battery().percent(), 100);
        // the mission survived the power cycle, the current item went back to the start
        assert_eq!(
            v.mission()
                .items(fleetmap_core::mission::item::MissionType::Mission)
                .len(),
            items.len()
        );
        assert_eq!(
            v.mission().current(),
            if flavour.is_ardupilot() { 1 } else { 0 }
        );
        // and the position estimate takes time again
        assert_ne!(
            g.command(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            mav::MavResult::MAV_RESULT_ACCEPTED
        );
    }
}

#[test]
fn same_seed_same_stream() {
    let run = |seed: u64| {
        let mut g = Gcs::new("1xcopter:ardupilot,1xrover:px4", seed);
        g.wait(30.0, |_| false);
        g.sim.sysids();
        let mut bytes = Vec::new();
        for (t, h, m) in &g.log {
            bytes.push(format!("{t} {} {} {m:?}", h.component_id, h.sequence));
        }
        bytes
    };
    assert_eq!(run(5), run(5));
}

#[test]
fn a_copter_landed_on_a_rover_rides_with_it_and_charges() {
    let mut g = Gcs::new("1xcopter:ardupilot,1xrover:ardupilot", 9);
    // the rover starts 3 m east of the copter (from_spec with --home)
    g.wait(25.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
        .unwrap();
    g.send(MavMessage::REQUEST_DATA_STREAM(
        mav::REQUEST_DATA_STREAM_DATA {
            req_message_rate: 2,
            target_system: 1,
            target_component: 1,
            req_stream_id: mav::MavDataStream::MAV_DATA_STREAM_ALL,
            start_stop: 1,
        },
    ));
    let f = SimFlavour::ARDU_COPTER;
    assert_eq!(
        g.set_mode(f, SimMode::Guided),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    assert_eq!(
        g.command(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    assert_eq!(
        g.command(22, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 5.0]),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    g.wait(
        15.0,
        |m| matches!(m, MavMessage::GLOBAL_POSITION_INT(p) if p.relative_alt > 4_500),
    )
    .expect("airborne");
    // fly over the rover and land on it
    let (rlat, rlon, _) = g.sim.vehicle(2).unwrap().reported_position();
    let amsl = g.sim.vehicle(1).unwrap().home().unwrap().2 as f32 + 5.0;
    assert_eq!(
        g.command(
            192,
            [-1.0, 1.0, 0.0, f32::NAN, rlat as f32, rlon as f32, amsl]
        ),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    g.wait(20.0, |_| false);
    assert_eq!(g.command(21, [0.0; 7]), mav::MavResult::MAV_RESULT_ACCEPTED);
    g.wait(30.0, |m| matches!(m, MavMessage::HEARTBEAT(h) if !h.base_mode.contains(mav::MavModeFlag::MAV_MODE_FLAG_SAFETY_ARMED)))
        .expect("landed and disarmed on the rover");
    let before = g.sim.vehicle(1).unwrap().battery().fraction();
    let (lat0, lon0, _) = g.sim.vehicle(1).unwrap().true_position();
    // the rover drives 20 m north (GUIDED via DO_REPOSITION)
    g.sysid = 2;
    let (tlat, tlon) = fleetmap_core::geo::local::offset(rlat, rlon, 20.0, 0.0);
    assert_eq!(
        g.set_mode(SimFlavour::ARDU_ROVER, SimMode::Guided),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    assert_eq!(
        g.command(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    assert_eq!(
        g.command(
            192,
            [-1.0, 1.0, 0.0, f32::NAN, tlat as f32, tlon as f32, 0.0]
        ),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    g.wait(60.0, |_| false);
    let (lat1, lon1, u) = g.sim.vehicle(1).unwrap().true_position();
    let (rlat1, rlon1, _) = g.sim.vehicle(2).unwrap().true_position();
    let moved = fleetmap_core::geo::local::distance(lat0, lon0, lat1, lon1);
    assert!((moved - 20.0).abs() < 2.0, "the copter rode {moved} m");
    assert!(fleetmap_core::geo::local::distance(lat1, lon1, rlat1, rlon1) < 1.5);
    assert_eq!(u, 0.0);
    let after = g.sim.vehicle(1).unwrap().battery().fraction();
    assert!(after > before, "charging: {before} → {after}");
}

#[test]
fn worlds_match_the_fixture_sheet() {
    use fleetmap_core::world::Surface;
    let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/worlds/");
    let w =
        fleetmap_io::files::load_world(std::path::Path::new(&format!("{dir}runway.toml"))).unwrap();
    let c = (37.196800, -80.578100);
    // homes: offset(C, −32 m, −18 m + 3 m·(k−1)), about 7 m from the runway's long side
    for k in 1..=4 {
        let h = w.default_home(k).unwrap();
        let want = fleetmap_core::geo::local::offset(c.0, c.1, -32.0, -18.0 + 3.0 * (k - 1) as f64);
        assert!(fleetmap_core::geo::local::distance(h.0, h.1, want.0, want.1) < 1e-6);
        assert_eq!(w.surface_at(h.0, h.1, 0.0), Surface::Grass);
    }
    let h = w.default_home(1).unwrap();
    let (he, hn) = w.to_local(h.0, h.1);
    let mut nearest = f64::MAX;
    for i in -200..200 {
        for j in -200..200 {
            let (e, n) = (he + f64::from(i) * 0.1, hn + f64::from(j) * 0.1);
            if w.surface_at_local(e, n, 0.0).0 == Surface::Asphalt {
                nearest = nearest.min((e - he).hypot(n - hn));
            }
        }
    }
    assert!(
        (nearest - 7.0).abs() < 1.0,
        "nearest runway point {nearest} m"
    );
    let poly = &w.polygons_of(Surface::Asphalt, 0.0)[0];
    let area = {
        let pts: Vec<(f64, f64)> = poly.iter().map(|p| w.to_local(p.0, p.1)).collect();
        let mut a = 0.0;
        for i in 0..pts.len() {
            let (x0, y0) = pts[i];
            let (x1, y1) = pts[(i + 1) % pts.len()];
            a += x0 * y1 - x1 * y0;
        }
        a.abs() / 2.0
    };
    assert!((area - 92.0 * 21.0).abs() < 0.5, "runway area {area}");

    // the moving plume world loads and moves
    let p =
        fleetmap_io::files::load_world(std::path::Path::new(&format!("{dir}plume.toml"))).unwrap();
    let a = &p.polygons_of(Surface::Plume, 0.0)[0][0];
    let b = &p.polygons_of(Surface::Plume, 100.0)[0][0];
    let (dn, de) = fleetmap_core::geo::local::delta(a.0, a.1, b.0, b.1);
    assert!(dn.abs() < 1e-6 && (de - 30.0).abs() < 1e-3, "{dn} {de}");

    let w =
        fleetmap_io::files::load_world(std::path::Path::new(&format!("{dir}hardware-6x6.toml")))
            .unwrap();
    assert_eq!(w.cells_of(Surface::Obstacle).len(), 11);
    assert_eq!(
        w.cells_of(Surface::GreenTile),
        vec![(5, 0), (4, 4), (2, 5), (1, 2)]
    );
    assert_eq!(w.cells_of(Surface::GreyTile).len(), 10);
    assert_eq!(w.cells_of(Surface::Road).len(), 11);
    let rows = ["GRO.O.", "OR.OGO", "RRRRRR", ".RO.OG", "ORGO..", ".RO.O."];
    for (i, row) in rows.iter().enumerate() {
        let r = 5 - i as i32;
        for (c, ch) in row.chars().enumerate() {
            let (lat, lon) =
                fleetmap_core::world::grid_cell_center((37.195, -80.58), 5.0, r, c as i32);
            let want = match ch {
                'G' => Surface::GreenTile,
                'R' => Surface::Road,
                'O' => Surface::Obstacle,
                _ => Surface::GreyTile,
            };
            assert_eq!(w.surface_at(lat, lon, 0.0), want, "cell ({r},{c})");
        }
    }
    // drones 1, 2 and station 5 on (3,1); drones 3, 4 and station 6 on (3,4)
    for (k, cell) in [
        (1, (3, 1)),
        (2, (3, 1)),
        (3, (3, 4)),
        (4, (3, 4)),
        (5, (3, 1)),
        (6, (3, 4)),
    ] {
        let h = w.default_home(k).unwrap();
        let want = fleetmap_core::world::grid_cell_center((37.195, -80.58), 5.0, cell.0, cell.1);
        assert!(fleetmap_core::geo::local::distance(h.0, h.1, want.0, want.1) < 1e-6);
    }
}

#[test]
fn ardupilot_needs_a_takeoff_item_to_start_auto_on_the_ground_and_message_intervals_work() {
    let mut g = Gcs::new("1xcopter:ardupilot", 2);
    g.wait(25.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
        .unwrap();
    // no stream before asking (ArduCopter), then GLOBAL_POSITION_INT at 5 Hz on request
    assert!(
        !g.log
            .iter()
            .any(|(_, _, m)| matches!(m, MavMessage::GLOBAL_POSITION_INT(_)))
    );
    assert_eq!(
        g.command(511, [33.0, 200_000.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    let n0 = g.log.len();
    g.wait(10.0, |_| false);
    let n = g.log[n0..]
        .iter()
        .filter(|(_, _, m)| matches!(m, MavMessage::GLOBAL_POSITION_INT(_)))
        .count();
    assert!((48..=52).contains(&n), "{n} positions in 10 s at 5 Hz");
    let wp = at(HOME, 10.0, 0.0);
    let items = vec![
        MissionItem::waypoint(HOME.0, HOME.1, 0.0),
        MissionItem::waypoint(wp.0, wp.1, 10.0),
    ];
    assert_eq!(
        g.upload(&items),
        mav::MavMissionResult::MAV_MISSION_ACCEPTED
    );
    assert_eq!(
        g.set_mode(SimFlavour::ARDU_COPTER, SimMode::Guided),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    assert_eq!(
        g.command(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    assert_eq!(
        g.set_mode(SimFlavour::ARDU_COPTER, SimMode::Auto),
        mav::MavResult::MAV_RESULT_FAILED
    );
    assert!(
        g.texts().iter().any(|t| t == "Auto: Missing Takeoff Cmd"),
        "{:?}",
        g.texts()
    );
    // a takeoff with the wrong frame is DENIED, in flight a second takeoff FAILS
    g.send(MavMessage::COMMAND_INT(mav::COMMAND_INT_DATA {
        command: mav::MavCmd::MAV_CMD_NAV_TAKEOFF,
        target_system: 1,
        target_component: 1,
        frame: mav::MavFrame::MAV_FRAME_GLOBAL,
        z: 10.0,
        ..mav::COMMAND_INT_DATA::default()
    }));
    let ack = g.wait(2.0, |m| matches!(m, MavMessage::COMMAND_ACK(_)));
    assert!(
        matches!(ack, Some(MavMessage::COMMAND_ACK(a)) if a.result == mav::MavResult::MAV_RESULT_DENIED)
    );
    assert_eq!(
        g.command(22, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 10.0]),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    g.wait(2.0, |_| false);
    assert_eq!(
        g.command(22, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 10.0]),
        mav::MavResult::MAV_RESULT_FAILED
    );
    // disarming in flight is refused
    assert_eq!(g.command(400, [0.0; 7]), mav::MavResult::MAV_RESULT_FAILED);
    // unknown commands are unsupported
    assert_eq!(
        g.command(31011, [0.0; 7]),
        mav::MavResult::MAV_RESULT_UNSUPPORTED
    );
}

#[test]
fn armed_copter_on_the_ground_disarms_itself() {
    for f in [SimFlavour::ARDU_COPTER, SimFlavour::PX4_COPTER] {
        let mut g = Gcs::new(&format!("1x{f}"), 4);
        g.wait(25.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
            .unwrap();
        if f.is_ardupilot() {
            assert_eq!(
                g.set_mode(f, SimMode::Guided),
                mav::MavResult::MAV_RESULT_ACCEPTED
            );
        }
        assert_eq!(
            g.command(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
            mav::MavResult::MAV_RESULT_ACCEPTED
        );
        let t0 = g.sim.now();
        g.wait(15.0, |_| false);
        assert!(!g.sim.vehicle(1).unwrap().armed(), "{f}: still armed");
        let t = g
            .log
            .iter()
            .find(|(t, _, m)| *t > t0 && matches!(m, MavMessage::STATUSTEXT(s) if s.text.to_str().unwrap_or("").starts_with("Disarm")))
            .map(|(t, _, _)| t.saturating_since(t0).as_secs_f64())
            .unwrap();
        assert!((9.5..=11.0).contains(&t), "{f}: disarmed after {t} s");
    }
}

#[test]
fn the_vehicles_run_their_mission_protocol_timers() {
    // An upload the GCS stops answering: ArduPilot re-requests the item once a second and
    // cancels after 8 s without one; PX4 re-requests every 250 ms and gives up after 5 s.
    for (spec, every_s, gives_up_s) in [
        ("1xcopter:ardupilot", 1.0, 8.0),
        ("1xcopter:px4", 0.25, 5.0),
    ] {
        let mut g = Gcs::new(spec, 6);
        g.wait(2.0, |_| false);
        g.send(MavMessage::MISSION_COUNT(mav::MISSION_COUNT_DATA {
            count: 3,
            target_system: 1,
            target_component: 1,
            mission_type: mav::MavMissionType::MAV_MISSION_TYPE_MISSION,
            opaque_id: 0,
        }));
        let t0 = g.sim.now();
        g.wait(gives_up_s + 2.0, |_| false);
        let requests: Vec<f64> = g
            .log
            .iter()
            .filter(|(t, _, m)| {
                let first = match m {
                    MavMessage::MISSION_REQUEST(r) => r.seq == 0,
                    MavMessage::MISSION_REQUEST_INT(r) => r.seq == 0,
                    _ => false,
                };
                *t >= t0 && first
            })
            .map(|(t, _, _)| t.saturating_since(t0).as_secs_f64())
            .collect();
        assert!(requests.len() >= 3, "{spec}: requests at {requests:?}");
        for w in requests.windows(2) {
            let gap = w[1] - w[0];
            assert!(
                (every_s - 0.01..=every_s + 0.11).contains(&gap),
                "{spec}: re-requests {gap} s apart: {requests:?}"
            );
        }
        let last = requests.last().copied().unwrap_or_default();
        assert!(
            (gives_up_s - every_s - 0.11..=gives_up_s + 0.11).contains(&last),
            "{spec}: last request at {last} s"
        );
        let ended = g.log.iter().any(|(t, _, m)| {
            *t >= t0
                && match m {
                    MavMessage::MISSION_ACK(a) => {
                        a.mavtype == mav::MavMissionResult::MAV_MISSION_OPERATION_CANCELLED
                    }
                    MavMessage::STATUSTEXT(s) => {
                        s.text.to_str().unwrap_or("").contains("Operation timeout")
                    }
                    _ => false,
                }
        });
        assert!(ended, "{spec}: the upload was not abandoned");
    }
}

#[test]
fn px4_judges_the_gcs_link_over_com_dl_loss_t_of_the_gcs_clock() {
    // (GCS time scale, simulated seconds since the last GCS heartbeat, arming accepted):
    // PX4 refuses to arm once COM_DL_LOSS_T (10 s) has passed without a GCS heartbeat; a
    // GCS on the wall clock facing a simulator ten times faster heartbeats only every 10
    // simulated seconds, so there the limit is 100 simulated seconds.
    let arm = [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
    for (scale, silence_s, ok) in [
        (1.0, 7, true),
        (1.0, 12, false),
        (10.0, 12, true),
        (10.0, 95, true),
        (10.0, 105, false),
    ] {
        let mut g = Gcs::with("1xcopter:px4", 5, |c| {
            c.vehicles[0].gcs_time_scale = scale;
        });
        // position estimate and home (8 s after boot), then one heartbeat and silence
        g.sim.advance_to(Time::from_secs(20));
        g.heartbeat();
        g.sim.advance(Duration::from_secs(silence_s));
        while g.sim.recv(1).is_some() {}
        g.last_hb = g.sim.now(); // no heartbeat while waiting for the ACK
        let r = g.command(400, arm);
        let want = if ok {
            mav::MavResult::MAV_RESULT_ACCEPTED
        } else {
            mav::MavResult::MAV_RESULT_TEMPORARILY_REJECTED
        };
        assert_eq!(r, want, "scale {scale}, {silence_s} s without a heartbeat");
        let gcs_refusal = g.log.iter().any(|(_, _, m)| {
            matches!(m, MavMessage::STATUSTEXT(t)
                if t.text.to_str().unwrap_or("").contains("No connection to the GCS"))
        });
        assert_eq!(gcs_refusal, !ok, "scale {scale}, {silence_s} s");
    }
}

#[test]
fn signed_vehicles_ignore_unsigned_commands_and_setup_signing_installs_a_key() {
    use fleetmap_io::link::codec::{Codec, encode_frame};
    use fleetmap_io::link::signing::{Signing, SigningKey};
    let key = SigningKey::from_passphrase("field-team");
    let mut cfg =
        SimConfig::from_spec("1xcopter:ardupilot,1xcopter:ardupilot", None, Some(HOME), 1).unwrap();
    cfg.signing_key = Some(key.clone());
    let epoch = cfg.unix_epoch_us;
    let mut sim = Sim::new(cfg, Time::ZERO).unwrap();
    sim.advance_to(Time::from_secs(2));
    let h = MavHeader {
        system_id: 255,
        component_id: 190,
        sequence: 0,
    };
    let arm = MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
        param1: 1.0,
        command: mav::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        target_system: 1,
        target_component: 1,
        ..mav::COMMAND_LONG_DATA::default()
    });
    let acks = |sim: &mut Sim, sysid: u8, codec: &mut Codec| -> usize {
        let mut n = 0;
        while let Some(d) = sim.recv_bytes(sysid) {
            for f in codec.decode(&d, epoch + sim.now().as_micros()) {
                assert!(
                    f.signature.is_some(),
                    "every frame from a signed vehicle is signed"
                );
                if matches!(f.message, Ok(MavMessage::COMMAND_ACK(_))) {
                    n += 1;
                }
            }
        }
        n
    };
    let mut gcs = Codec::with_signing(Signing::new(key.clone(), 7));
    // an unsigned command is ignored
    sim.send(1, &h, &arm);
    sim.advance(Duration::from_millis(200));
    assert_eq!(acks(&mut sim, 1, &mut gcs), 0);
    // a signed one is answered
    let signed = gcs.encode_with_header(
        &h,
        &arm,
        mavlink::MavlinkVersion::V2,
        epoch + sim.now().as_micros(),
    );
    sim.send_bytes(1, &signed);
    sim.advance(Duration::from_millis(200));
    assert_eq!(acks(&mut sim, 1, &mut gcs), 1);
    // SETUP_SIGNING with zeros (signed with the current key) turns signing off on vehicle 2
    let setup = MavMessage::SETUP_SIGNING(mav::SETUP_SIGNING_DATA {
        initial_timestamp: 0,
        target_system: 2,
        target_component: 1,
        secret_key: [0; 32],
    });
    let f = gcs.encode_with_header(
        &h,
        &setup,
        mavlink::MavlinkVersion::V2,
        epoch + sim.now().as_micros(),
    );
    sim.send_bytes(2, &f);
    sim.advance(Duration::from_millis(200));
    while sim.recv_bytes(2).is_some() {}
    let arm2 = MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
        param1: 1.0,
        command: mav::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        target_system: 2,
        target_component: 1,
        ..mav::COMMAND_LONG_DATA::default()
    });
    let plain = encode_frame(&h, &arm2, mavlink::MavlinkVersion::V2, None, 0);
    sim.send_bytes(2, &plain);
    sim.advance(Duration::from_millis(200));
    let mut any = Codec::new();
    let mut got = false;
    while let Some(d) = sim.recv_bytes(2) {
        for f in any.decode(&d, 0) {
            assert!(f.signature.is_none());
            got |= matches!(f.message, Ok(MavMessage::COMMAND_ACK(_)));
        }
    }
    assert!(
        got,
        "vehicle 2 answers unsigned commands once signing is off"
    );
}

fn exclusion_square(north: f64, east: f64, half: f64) -> Vec<MissionItem> {
    [(-half, -half), (-half, half), (half, half), (half, -half)]
        .iter()
        .map(|(dn, de)| {
            let (lat, lon) = at(HOME, north + dn, east + de);
            MissionItem {
                param1: 4.0,
                ..MissionItem::at(5002, lat, lon, 0.0)
            }
        })
        .collect()
}

#[test]
fn geofences_are_enforced() {
    // PX4: a mission through an exclusion zone is not valid (mission feasibility check)
    let mut g = Gcs::new("1xcopter:px4", 5);
    g.wait(12.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
        .unwrap();
    let fence = exclusion_square(20.0, 0.0, 3.0);
    assert_eq!(
        g.upload_type(&fence, mav::MavMissionType::MAV_MISSION_TYPE_FENCE),
        mav::MavMissionResult::MAV_MISSION_ACCEPTED
    );
    let (a, b) = (at(HOME, 20.0, 0.0), at(HOME, 20.0, 20.0));
    let items = vec![
        MissionItem::takeoff(10.0),
        MissionItem::waypoint(a.0, a.1, 10.0),
        MissionItem::waypoint(b.0, b.1, 10.0),
    ];
    assert_eq!(
        g.upload(&items),
        mav::MavMissionResult::MAV_MISSION_ACCEPTED
    );
    assert!(
        g.texts()
            .iter()
            .any(|t| t == "Geofence violation for waypoint 2"),
        "{:?}",
        g.texts()
    );
    assert_eq!(g.command(300, [0.0; 7]), mav::MavResult::MAV_RESULT_DENIED);
    assert!(!g.sim.vehicle(1).unwrap().armed());

    // ArduCopter with the fence enabled: flying into the zone triggers RTL
    let mut g = Gcs::new("1xcopter:ardupilot", 5);
    g.wait(25.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
        .unwrap();
    assert_eq!(
        g.upload_type(&fence, mav::MavMissionType::MAV_MISSION_TYPE_FENCE),
        mav::MavMissionResult::MAV_MISSION_ACCEPTED
    );
    assert_eq!(
        g.command(207, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    let f = SimFlavour::ARDU_COPTER;
    assert_eq!(
        g.set_mode(f, SimMode::Guided),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    assert_eq!(
        g.command(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    assert_eq!(
        g.command(22, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 10.0]),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    g.wait(10.0, |_| false);
    let amsl = g.sim.vehicle(1).unwrap().home().unwrap().2 as f32 + 10.0;
    assert_eq!(
        g.command(
            192,
            [-1.0, 1.0, 0.0, f32::NAN, a.0 as f32, a.1 as f32, amsl]
        ),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    let rtl = f.custom_mode(SimMode::Rtl).unwrap();
    g.wait(
        30.0,
        |m| matches!(m, MavMessage::HEARTBEAT(h) if h.custom_mode == rtl),
    )
    .expect("fence breach → RTL");
    assert!(g.texts().iter().any(|t| t == "Fence Breached"));
    let (lat, lon, _) = g.sim.vehicle(1).unwrap().reported_position();
    let (n, _) = fleetmap_core::geo::local::delta(HOME.0, HOME.1, lat, lon);
    assert!(n < 18.0, "stopped near the fence, {n} m north");
}

/// Turning to a heading in guided flight, as each autopilot does it: ArduCopter with
/// MAV_CMD_CONDITION_YAW (absolute or relative; an angle outside 0..360 FAILED), PX4 with the
/// yaw of DO_REPOSITION (param4, radians; it has no CONDITION_YAW outside missions).
#[test]
fn guided_yaw_by_condition_yaw_or_reposition() {
    let hdg = |g: &mut Gcs, want: f64| {
        g.wait(30.0, |m| {
            matches!(m, MavMessage::GLOBAL_POSITION_INT(p)
                if p.hdg != u16::MAX
                    && ((f64::from(p.hdg) / 100.0 - want).rem_euclid(360.0) < 1.0
                        || (want - f64::from(p.hdg) / 100.0).rem_euclid(360.0) < 1.0))
        })
        .is_some()
    };
    for flavour in [SimFlavour::ARDU_COPTER, SimFlavour::PX4_COPTER] {
        let mut g = Gcs::new(&format!("1x{flavour}"), 5);
        g.wait(25.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
            .unwrap();
        g.send(MavMessage::REQUEST_DATA_STREAM(
            mav::REQUEST_DATA_STREAM_DATA {
                req_message_rate: 4,
                target_system: 1,
                target_component: 1,
                req_stream_id: mav::MavDataStream::MAV_DATA_STREAM_ALL,
                start_stop: 1,
            },
        ));
        let amsl = g.sim.vehicle(1).unwrap().home().unwrap().2 as f32 + 10.0;
        g.arm_and_take_off(flavour, 10.0);
        g.wait(
            20.0,
            |m| matches!(m, MavMessage::GLOBAL_POSITION_INT(p) if p.relative_alt > 9_000),
        )
        .unwrap_or_else(|| panic!("{flavour}: not airborne: {:?}", g.texts()));
        // 20 m north-east: the copter faces its direction of travel (45°)
        let (lat, lon) = at(HOME, 20.0, 20.0);
        assert_eq!(
            g.command(
                192,
                [-1.0, 1.0, 0.0, f32::NAN, lat as f32, lon as f32, amsl]
            ),
            mav::MavResult::MAV_RESULT_ACCEPTED,
            "{flavour}"
        );
        assert!(hdg(&mut g, 45.0), "{flavour}: not facing its travel");
        g.wait(30.0, |m| {
            matches!(m, MavMessage::GLOBAL_POSITION_INT(p)
                if fleetmap_core::geo::local::distance(
                    f64::from(p.lat) / 1e7, f64::from(p.lon) / 1e7, lat, lon) < 0.5)
        })
        .unwrap_or_else(|| panic!("{flavour}: did not arrive"));
        if flavour.is_ardupilot() {
            assert_eq!(
                g.command(115, [400.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                mav::MavResult::MAV_RESULT_FAILED
            );
            assert_eq!(
                g.command(115, [90.0, 0.0, 0.0, 2.0, 0.0, 0.0, 0.0]),
                mav::MavResult::MAV_RESULT_FAILED
            );
            assert_eq!(
                g.command(115, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                mav::MavResult::MAV_RESULT_ACCEPTED
            );
            assert!(hdg(&mut g, 0.0), "{flavour}: did not turn north");
            // relative: 90° counter-clockwise of north = west
            assert_eq!(
                g.command(115, [90.0, 0.0, -1.0, 1.0, 0.0, 0.0, 0.0]),
                mav::MavResult::MAV_RESULT_ACCEPTED
            );
            assert!(hdg(&mut g, 270.0), "{flavour}: did not turn west");
        } else {
            assert_eq!(
                g.command(115, [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
                mav::MavResult::MAV_RESULT_UNSUPPORTED
            );
            let (lat, lon) = at(HOME, 20.0, 20.0);
            assert_eq!(
                g.command(
                    192,
                    [
                        -1.0,
                        1.0,
                        0.0,
                        std::f32::consts::PI,
                        lat as f32,
                        lon as f32,
                        amsl
                    ]
                ),
                mav::MavResult::MAV_RESULT_ACCEPTED
            );
            assert!(hdg(&mut g, 180.0), "{flavour}: did not turn south");
        }
        // it stays where it was sent
        let (la, lo, _) = g.sim.vehicle(1).unwrap().true_position();
        let d = fleetmap_core::geo::local::distance(la, lo, lat, lon);
        assert!(d < 1.5, "{flavour}: {d} m from its target");
    }
}

/// A copter hovering in calm air holds itself level: its position estimate drifts with the
/// GPS error, but smoothly, so the attitude (and a nadir camera's footprint) stays steady.
/// At 12 m, 1° of tilt moves the footprint by 0.21 m.
#[test]
fn a_copter_hovering_in_calm_air_stays_level() {
    for flavour in [SimFlavour::ARDU_COPTER, SimFlavour::PX4_COPTER] {
        let mut g = Gcs::new(&format!("1x{flavour}"), 11);
        g.wait(25.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
            .unwrap();
        g.send(MavMessage::REQUEST_DATA_STREAM(
            mav::REQUEST_DATA_STREAM_DATA {
                req_message_rate: 10,
                target_system: 1,
                target_component: 1,
                req_stream_id: mav::MavDataStream::MAV_DATA_STREAM_ALL,
                start_stop: 1,
            },
        ));
        g.arm_and_take_off(flavour, 12.0);
        g.wait(
            30.0,
            |m| matches!(m, MavMessage::GLOBAL_POSITION_INT(p) if p.relative_alt > 11_500),
        )
        .unwrap_or_else(|| panic!("{flavour}: not airborne: {:?}", g.texts()));
        // Settle, then watch the attitude for two minutes of hovering.
        g.wait(15.0, |_| false);
        let (mut samples, mut worst) = (0u32, 0.0f64);
        g.wait(120.0, |m| {
            if let MavMessage::ATTITUDE(a) = m {
                samples += 1;
                let tilt = f64::from(a.roll)
                    .abs()
                    .max(f64::from(a.pitch).abs())
                    .to_degrees();
                worst = worst.max(tilt);
            }
            false
        });
        assert!(samples > 100, "{flavour}: {samples} ATTITUDE messages");
        assert!(
            worst < 1.0,
            "{flavour}: tilted by {worst:.2}° while hovering in calm air"
        );
    }
}

/// ArduPilot does not change its signing key while armed (`GCS_MAVLINK::handle_setup_signing`:
/// "ERROR: Won't setup signing when armed"), as ArduRover SITL showed after a mission left it
/// armed at home; PX4 1.16 has no MAVLink signing at all and ignores SETUP_SIGNING. In both
/// cases the vehicle goes on answering unsigned commands.
#[test]
fn setup_signing_is_refused_while_armed_and_ignored_by_px4() {
    let setup = MavMessage::SETUP_SIGNING(mav::SETUP_SIGNING_DATA {
        initial_timestamp: 1,
        target_system: 1,
        target_component: 1,
        secret_key: [7; 32],
    });
    let mut g = Gcs::new("1xcopter:ardupilot", 4);
    g.wait(20.0, |_| false);
    g.arm_and_take_off(SimFlavour::ARDU_COPTER, 5.0);
    g.send(setup.clone());
    g.wait(1.0, |_| false);
    assert!(
        g.texts()
            .iter()
            .any(|t| t == "ERROR: Won't setup signing when armed"),
        "{:?}",
        g.texts()
    );
    // Still unsigned: an unsigned command is answered.
    assert_eq!(
        g.command(511, [33.0, 200_000.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
    let mut p = Gcs::new("1xcopter:px4", 4);
    p.wait(5.0, |_| false);
    p.send(setup);
    p.wait(1.0, |_| false);
    assert_eq!(
        p.command(511, [33.0, 200_000.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        mav::MavResult::MAV_RESULT_ACCEPTED
    );
}

/// PX4 flies a mission's take-off item as a waypoint to the item's own position
/// (navigator/mission.cpp); an item without one (latitude/longitude 0, 0) is never reached:
/// against PX4 1.16 SITL the copter climbed and hovered at the take-off altitude with the
/// mission stuck at item 0. The same mission with the take-off at the launch position flies.
#[test]
fn px4_never_reaches_a_take_off_item_without_a_position() {
    for (takeoff, flies) in [
        (MissionItem::takeoff(10.0), false),
        (MissionItem::takeoff_at(HOME.0, HOME.1, 10.0), true),
    ] {
        let mut g = Gcs::new("1xcopter:px4", 3);
        g.wait(25.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
            .expect("home");
        let a = at(HOME, 20.0, 0.0);
        let items = vec![takeoff, MissionItem::waypoint(a.0, a.1, 10.0)];
        assert_eq!(
            g.upload(&items),
            mav::MavMissionResult::MAV_MISSION_ACCEPTED
        );
        assert_eq!(
            g.command(300, [0.0; 7]),
            mav::MavResult::MAV_RESULT_ACCEPTED,
            "PX4 MISSION_START arms"
        );
        let reached = g.wait(
            60.0,
            |m| matches!(m, MavMessage::MISSION_ITEM_REACHED(r) if r.seq == 1),
        );
        assert_eq!(reached.is_some(), flies, "take-off item {:?}", items[0]);
        let alt = g.sim.vehicle(1).unwrap().true_local().2;
        assert!(alt > 9.0, "airborne either way, at {alt:.1} m");
    }
}

/// A finished mission leaves ArduRover in AUTO (MIS_DONE_BEHAVE 0), and there
/// MAV_CMD_MISSION_START is accepted but starts nothing: its handler only asks for AUTO
/// (`GCS_MAVLINK_Rover::handle_command_int_packet`, Rover/GCS_MAVLink_Rover.cpp) and
/// `Rover::set_mode` returns at once for the mode it is in (seen on ArduRover SITL V4.7.0-dev
/// 90700977). Leaving AUTO first (HOLD) lets MISSION_START run the mission again.
#[test]
fn ardurover_in_auto_ignores_mission_start_until_it_leaves_auto() {
    const MISSION_START: u16 = 300;
    const SET_CURRENT: u16 = 224;
    let mut g = Gcs::new("1xrover:ardupilot", 5);
    g.wait(25.0, |m| matches!(m, MavMessage::HOME_POSITION(_)))
        .expect("home");
    let ok = mav::MavResult::MAV_RESULT_ACCEPTED;
    // a station mission as fleetmap builds it, behind ArduPilot's home slot
    let station = |to: (f64, f64)| {
        vec![
            MissionItem::waypoint(HOME.0, HOME.1, 0.0),
            MissionItem::change_speed(1.0),
            MissionItem::waypoint(to.0, to.1, 0.0),
        ]
    };
    let reached_last = |g: &mut Gcs| {
        g.wait(
            60.0,
            |m| matches!(m, MavMessage::MISSION_ITEM_REACHED(r) if r.seq == 2),
        )
        .is_some()
    };
    // First sortie: one cell (5 m) east, started as fleetmap starts a station.
    let accepted = mav::MavMissionResult::MAV_MISSION_ACCEPTED;
    assert_eq!(g.upload(&station(at(HOME, 0.0, 5.0))), accepted);
    assert_eq!(
        g.command(SET_CURRENT, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        ok
    );
    // ArduRover arms in MANUAL without RC; the simulated rover arms in any mode
    assert_eq!(g.command(400, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]), ok);
    assert_eq!(g.command(MISSION_START, [0.0; 7]), ok);
    assert!(
        reached_last(&mut g),
        "the first mission is driven to its end"
    );
    let auto = SimFlavour::ARDU_ROVER.custom_mode(SimMode::Auto).unwrap();
    let in_auto = g.wait(
        3.0,
        |m| matches!(m, MavMessage::HEARTBEAT(h) if h.custom_mode == auto),
    );
    assert!(
        in_auto.is_some(),
        "a finished mission leaves ArduRover in AUTO"
    );

    // Second sortie: back to the start cell.
    assert_eq!(g.upload(&station(at(HOME, 0.0, 0.0))), accepted);
    assert_eq!(
        g.command(SET_CURRENT, [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]),
        ok
    );
    assert_eq!(
        g.command(MISSION_START, [0.0; 7]),
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
    assert_eq!(g.set_mode(SimFlavour::ARDU_ROVER, SimMode::Hold), ok);
    assert_eq!(g.command(MISSION_START, [0.0; 7]), ok);
    assert!(
        reached_last(&mut g),
        "from HOLD the mission runs to its end"
    );
}
