//! Scheduled faults in flight: the harness applies each at its time, and the vehicle does what
//! the real autopilot would with it. A small GCS, written here from the MAVLink message
//! definitions, heartbeats every vehicle once a second and keeps everything it receives.

#![allow(deprecated)]

use super::parse_faults;
use crate::flavour::{SimFlavour, SimMode};
use crate::harness::{Sim, SimConfig};
use crate::vehicle::VehicleEvent;
use fleetmap_core::time::Time;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::time::Duration;

const HOME: (f64, f64) = (37.1965, -80.5785);
const AUTOPILOT: u8 = fleetmap_core::proto::AUTOPILOT_COMPID;
const CAMERA: u8 = fleetmap_core::proto::CAMERA_COMPID;

/// What the GCS received: (when, from system, header, message).
type Received = (Time, u8, MavHeader, MavMessage);

struct Gcs {
    sim: Sim,
    seq: u8,
    last_hb: Option<Time>,
    got: Vec<Received>,
    images: Vec<(u8, Time)>,
    events: Vec<(Time, u8, VehicleEvent)>,
}

impl Gcs {
    fn new(spec: &str, faults: &str, edit: impl FnOnce(&mut SimConfig)) -> Gcs {
        let mut cfg = SimConfig::from_spec(spec, None, Some(HOME), 3)
            .unwrap()
            .with_scheduled_faults(parse_faults(faults).unwrap());
        edit(&mut cfg);
        Gcs {
            sim: Sim::new(cfg, Time::ZERO).unwrap(),
            seq: 0,
            last_hb: None,
            got: Vec::new(),
            images: Vec::new(),
            events: Vec::new(),
        }
    }

    fn send(&mut self, sysid: u8, msg: MavMessage) {
        let h = MavHeader {
            system_id: fleetmap_core::proto::GCS_SYSID as u32,
            component_id: fleetmap_core::proto::GCS_COMPID,
            sequence: self.seq,
        };
        self.seq = self.seq.wrapping_add(1);
        self.sim.send(sysid, &h, &msg);
    }

    /// Run in 50 ms steps to `secs` of simulated time.
    fn run_to(&mut self, secs: f64) {
        let end = Time::from_secs_f64(secs);
        while self.sim.now() < end {
            let now = self.sim.now();
            if self
                .last_hb
                .is_none_or(|t| now.saturating_since(t) >= Duration::from_secs(1))
            {
                self.last_hb = Some(now);
                for s in self.sim.sysids() {
                    self.send(s, gcs_heartbeat());
                }
            }
            self.sim.advance_to(now + Duration::from_millis(50));
            self.collect();
        }
    }

    fn collect(&mut self) {
        let now = self.sim.now();
        for s in self.sim.sysids() {
            while let Some((h, m)) = self.sim.recv(s) {
                self.got.push((now, s, h, m));
            }
        }
        while let Some((s, _)) = self.sim.poll_image() {
            self.images.push((s, now));
        }
        while let Some((s, e)) = self.sim.poll_event() {
            self.events.push((now, s, e));
        }
    }

    /// Send a command to `(sysid, compid)` and run for up to 3 s waiting for its ACK.
    fn command(
        &mut self,
        sysid: u8,
        compid: u8,
        cmd: mav::MavCmd,
        p: [f32; 7],
    ) -> Option<mav::MavResult> {
        self.send(
            sysid,
            MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
                param1: p[0],
                param2: p[1],
                param3: p[2],
                param4: p[3],
                param5: p[4],
                param6: p[5],
                param7: p[6],
                command: cmd,
                target_system: sysid,
                target_component: compid,
                confirmation: 0,
            }),
        );
        let from = self.got.len();
        let end = self.sim.now().as_secs_f64() + 3.0;
        loop {
            let ack = self.got[from..].iter().find_map(|(_, s, h, m)| match m {
                MavMessage::COMMAND_ACK(a)
                    if *s == sysid && h.component_id == compid && a.command == cmd =>
                {
                    Some(a.result)
                }
                _ => None,
            });
            if ack.is_some() || self.sim.now().as_secs_f64() >= end {
                return ack;
            }
            let t = self.sim.now().as_secs_f64() + 0.05;
            self.run_to(t);
        }
    }

    fn accepted(&mut self, sysid: u8, cmd: mav::MavCmd, p: [f32; 7]) {
        assert_eq!(
            self.command(sysid, AUTOPILOT, cmd, p),
            Some(mav::MavResult::MAV_RESULT_ACCEPTED),
            "{cmd:?} to vehicle {sysid}"
        );
    }

    /// Arm in GUIDED (ArduPilot) and, for a copter, take off to `alt` m.
    fn arm_and_take_off(&mut self, sysid: u8, flavour: SimFlavour, alt: f32) {
        if flavour.is_ardupilot() {
            let c = flavour.custom_mode(SimMode::Guided).unwrap() as f32;
            self.accepted(
                sysid,
                mav::MavCmd::MAV_CMD_DO_SET_MODE,
                [1.0, c, 0.0, 0.0, 0.0, 0.0, 0.0],
            );
        }
        self.accepted(
            sysid,
            mav::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        if flavour.is_copter() {
            // ArduPilot: relative altitude; PX4: AMSL, at the current position
            let p = if flavour.is_ardupilot() {
                [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, alt]
            } else {
                let amsl = self.sim.vehicle(sysid).unwrap().home().unwrap().2 as f32 + alt;
                [0.0, 0.0, 0.0, f32::NAN, f32::NAN, f32::NAN, amsl]
            };
            self.accepted(sysid, mav::MavCmd::MAV_CMD_NAV_TAKEOFF, p);
        }
    }

    /// Go to `north`, `east` metres from home at `alt` m (DO_REPOSITION in GUIDED).
    fn go_to(&mut self, sysid: u8, north: f64, east: f64, alt: f32) {
        let (lat, lon) = fleetmap_core::geo::local::offset(HOME.0, HOME.1, north, east);
        self.send(
            sysid,
            MavMessage::COMMAND_INT(mav::COMMAND_INT_DATA {
                param1: -1.0,
                param2: 1.0,
                param3: 0.0,
                param4: f32::NAN,
                x: (lat * 1e7) as i32,
                y: (lon * 1e7) as i32,
                z: alt,
                command: mav::MavCmd::MAV_CMD_DO_REPOSITION,
                target_system: sysid,
                target_component: AUTOPILOT,
                frame: mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
                current: 0,
                autocontinue: 0,
            }),
        );
    }

    /// One picture asked of vehicle `sysid`'s camera component: its ACK, if any.
    fn take_picture(&mut self, sysid: u8, seq: f32) -> Option<mav::MavResult> {
        self.command(
            sysid,
            CAMERA,
            mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
            [0.0, 0.0, 1.0, seq, 0.0, 0.0, 0.0],
        )
    }

    /// The times vehicle `sysid`'s `compid` was heard in [a, b) seconds.
    fn heard(&self, sysid: u8, compid: Option<u8>, a: f64, b: f64) -> Vec<Time> {
        self.got
            .iter()
            .filter(|(t, s, h, _)| {
                *s == sysid
                    && compid.is_none_or(|c| h.component_id == c)
                    && *t >= Time::from_secs_f64(a)
                    && *t < Time::from_secs_f64(b)
            })
            .map(|(t, ..)| *t)
            .collect()
    }

    fn texts(&self, sysid: u8) -> Vec<(Time, String)> {
        self.got
            .iter()
            .filter(|(_, s, ..)| *s == sysid)
            .filter_map(|(t, _, _, m)| match m {
                MavMessage::STATUSTEXT(x) => Some((*t, x.text.to_str().unwrap_or("").to_string())),
                _ => None,
            })
            .collect()
    }

    fn local(&self, sysid: u8) -> (f64, f64, f64) {
        self.sim.vehicle(sysid).unwrap().true_local()
    }
}

fn gcs_heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: mav::MavType::MAV_TYPE_GCS,
        autopilot: mav::MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: mav::MavModeFlag::empty(),
        system_status: mav::MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    })
}

#[test]
fn a_battery_fault_triggers_the_autopilots_own_failsafe_and_the_copter_comes_home() {
    // ArduCopter: BATT_LOW_MAH (20 %) → RTL. PX4: BAT_CRIT_THR → RTL, set to 25 % here as
    // an operator would: at its default 7 %, 2 % above BAT_EMERGEN_THR (5 %) do not last
    // PX4's climb to RTL_RETURN_ALT, and it lands where it is (also what the real one does).
    for (flavour, percent, text) in [
        (SimFlavour::ARDU_COPTER, 15, "Battery 1 is low"),
        (
            SimFlavour::PX4_COPTER,
            20,
            "Critical battery level! Executing RTL",
        ),
    ] {
        let mut g = Gcs::new(
            &format!("1x{flavour}"),
            &format!("1:battery={percent}@45s"),
            |c| {
                if !flavour.is_ardupilot() {
                    c.vehicles[0].failsafe.rtl_pct = 25.0;
                }
            },
        );
        g.run_to(20.0);
        g.arm_and_take_off(1, flavour, 10.0);
        g.run_to(30.0);
        g.go_to(1, 40.0, 0.0, 10.0);
        g.run_to(44.9);
        let v = g.sim.vehicle(1).unwrap();
        assert!(
            v.battery().percent() > 90,
            "{flavour}: {}",
            v.battery().percent()
        );
        assert!(
            !g.texts(1).iter().any(|(_, t)| t.starts_with(text)),
            "{flavour}: too early"
        );
        assert_ne!(v.mode(), SimMode::Rtl);
        let away = g.local(1);
        assert!(
            away.1 > 20.0,
            "{flavour}: it should be on its way north: {away:?}"
        );
        g.run_to(45.2);
        let v = g.sim.vehicle(1).unwrap();
        assert!(
            v.battery().percent() <= percent as i8,
            "{flavour}: {}",
            v.battery().percent()
        );
        assert_eq!(
            v.mode(),
            SimMode::Rtl,
            "{flavour}: the autopilot returns by itself"
        );
        let said = g.texts(1);
        let (t, _) = said
            .iter()
            .find(|(_, t)| t.starts_with(text))
            .unwrap_or_else(|| panic!("{flavour}: no failsafe text in {said:?}"));
        assert!(*t >= Time::from_secs(45), "{flavour}: said at {t:?}");
        assert!(g.events.iter().any(|(_, s, e)| *s == 1
            && *e
                == VehicleEvent::FaultStarted(super::Fault::Battery {
                    percent: f64::from(percent)
                })));
        assert!(
            g.events
                .iter()
                .any(|(_, s, e)| *s == 1 && *e == VehicleEvent::BatteryFailsafe(SimMode::Rtl))
        );
        // home, landed
        g.run_to(140.0);
        let v = g.sim.vehicle(1).unwrap();
        let (e, n, u) = g.local(1);
        assert!(
            v.landed() && u < 0.1,
            "{flavour}: landed {} at {u} m",
            v.landed()
        );
        assert!(
            e.hypot(n) < 3.0,
            "{flavour}: landed {e:.1}, {n:.1} from home"
        );
    }
}

#[test]
fn a_camera_that_dies_is_silent_and_comes_back_rebooted() {
    let mut g = Gcs::new("1xcopter:ardupilot", "1:camera=off@30s..60s", |_| {});
    g.run_to(25.0);
    assert_eq!(
        g.take_picture(1, 1.0),
        Some(mav::MavResult::MAV_RESULT_ACCEPTED)
    );
    g.run_to(29.0);
    assert_eq!(g.images.len(), 1, "a working camera takes the picture");
    assert!(!g.heard(1, Some(CAMERA), 20.0, 30.0).is_empty());
    g.run_to(40.0);
    // dead: no heartbeat, no answer, no picture — also when the autopilot triggers it
    assert_eq!(g.take_picture(1, 2.0), None);
    g.accepted(
        1,
        mav::MavCmd::MAV_CMD_DO_DIGICAM_CONTROL,
        [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
    );
    g.run_to(59.9);
    assert!(g.sim.vehicle(1).unwrap().camera_failed());
    assert_eq!(g.heard(1, Some(CAMERA), 30.0, 60.0), Vec::<Time>::new());
    assert_eq!(g.images.len(), 1, "a dead camera takes no picture");
    // the autopilot goes on as before
    assert!(g.heard(1, Some(AUTOPILOT), 50.0, 60.0).len() > 5);
    g.run_to(63.0);
    let back = g.heard(1, Some(CAMERA), 60.0, 63.0);
    assert!(!back.is_empty(), "its heartbeat is back");
    // rebooted: its messages count from 0 again
    let first = g
        .got
        .iter()
        .find(|(t, s, h, _)| *s == 1 && h.component_id == CAMERA && *t >= Time::from_secs(60))
        .map(|(_, _, h, _)| h.sequence);
    assert_eq!(first, Some(0));
    assert_eq!(
        g.take_picture(1, 3.0),
        Some(mav::MavResult::MAV_RESULT_ACCEPTED)
    );
    g.run_to(68.0);
    assert_eq!(g.images.len(), 2, "it takes pictures again");
    let ev: Vec<_> = g
        .events
        .iter()
        .filter(|(_, _, e)| {
            matches!(
                e,
                VehicleEvent::FaultStarted(_) | VehicleEvent::FaultEnded(_)
            )
        })
        .map(|(t, _, e)| (t.as_secs_f64().round(), e.clone()))
        .collect();
    assert_eq!(
        ev,
        vec![
            (30.0, VehicleEvent::FaultStarted(super::Fault::CameraOff)),
            (60.0, VehicleEvent::FaultEnded(super::Fault::CameraOff)),
        ]
    );
}

/// The seconds from each picture's DATA_TRANSMISSION_HANDSHAKE to its last packet.
fn transfer_spans(g: &Gcs) -> Vec<f64> {
    let mut spans = Vec::new();
    let mut open: Option<(Time, u16, u16)> = None; // start, packets, seen
    for (t, _, h, m) in &g.got {
        if h.component_id != CAMERA {
            continue;
        }
        match m {
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(d) => open = Some((*t, d.packets, 0)),
            MavMessage::ENCAPSULATED_DATA(_) => {
                if let Some((start, n, seen)) = open.as_mut() {
                    *seen += 1;
                    if *seen == *n {
                        spans.push(t.saturating_since(*start).as_secs_f64());
                        open = None;
                    }
                }
            }
            _ => {}
        }
    }
    spans
}

#[test]
fn a_slowed_camera_sends_slower_and_takes_pictures_late_then_recovers() {
    let mut g = Gcs::new(
        "1xcopter:ardupilot",
        "1:camera-rate=4000@30s..90s,1:camera-interval=5@30s..90s",
        |_| {},
    );
    g.run_to(25.0);
    g.take_picture(1, 1.0);
    g.run_to(29.0);
    let fast = transfer_spans(&g);
    assert_eq!(fast.len(), 1);
    assert!(
        fast[0] < 0.1,
        "unpaced, the picture leaves at once: {fast:?}"
    );
    // slowed: three pictures asked at once come 5 s apart, each paced at 4000 B/s
    g.run_to(31.0);
    let asked = g.sim.now();
    for k in 0..3 {
        assert_eq!(
            g.take_picture(1, 2.0 + k as f32),
            Some(mav::MavResult::MAV_RESULT_ACCEPTED)
        );
    }
    g.run_to(70.0);
    let taken: Vec<f64> = g.images[1..]
        .iter()
        .map(|(_, t)| t.saturating_since(asked).as_secs_f64())
        .collect();
    assert_eq!(taken.len(), 3, "{taken:?}");
    assert!(
        taken[1] - taken[0] >= 4.9 && taken[2] - taken[1] >= 4.9,
        "{taken:?}"
    );
    let spans = transfer_spans(&g);
    assert_eq!(spans.len(), 4);
    let packets = g
        .got
        .iter()
        .rev()
        .find_map(|(_, _, _, m)| match m {
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(d) => Some(d.packets),
            _ => None,
        })
        .unwrap();
    let expected = f64::from(packets - 1) * 267.0 / 4000.0;
    assert!(spans[3] >= 0.9 * expected, "{spans:?}, {packets} packets");
    // after the window: the configured camera again
    g.run_to(95.0);
    let asked = g.sim.now();
    for k in 0..2 {
        g.take_picture(1, 10.0 + k as f32);
    }
    g.run_to(100.0);
    let taken: Vec<f64> = g.images[4..]
        .iter()
        .map(|(_, t)| t.saturating_since(asked).as_secs_f64())
        .collect();
    assert_eq!(taken.len(), 2, "{taken:?}");
    assert!(taken[1] - taken[0] < 1.0, "{taken:?}");
    assert!(transfer_spans(&g).last().unwrap() < &0.1);
}

#[test]
fn a_stuck_rover_keeps_its_mode_and_answers_but_makes_no_progress() {
    let mut g = Gcs::new("1xrover:ardupilot", "1:stuck@40s..70s", |_| {});
    g.run_to(20.0);
    g.arm_and_take_off(1, SimFlavour::ARDU_ROVER, 0.0);
    g.go_to(1, 200.0, 0.0, 0.0);
    g.run_to(40.0);
    let moving = g.local(1);
    assert!(moving.1 > 10.0, "driving north before: {moving:?}");
    g.run_to(55.0);
    // it answers commands
    g.accepted(
        1,
        mav::MavCmd::MAV_CMD_DO_CHANGE_SPEED,
        [1.0, 1.5, -1.0, 0.0, 0.0, 0.0, 0.0],
    );
    g.run_to(69.9);
    let v = g.sim.vehicle(1).unwrap();
    assert!(v.stuck());
    assert_eq!(v.mode(), SimMode::Guided, "it keeps its mode");
    assert!(v.armed());
    let stuck = g.local(1);
    // at most the step of the tick the fault came in
    assert!(
        (stuck.0 - moving.0).hypot(stuck.1 - moving.1) < 0.2,
        "{moving:?} → {stuck:?}"
    );
    // and still reports where it is
    let positions = g
        .got
        .iter()
        .filter(|(t, _, _, m)| {
            *t > Time::from_secs(45) && matches!(m, MavMessage::GLOBAL_POSITION_INT(_))
        })
        .count();
    assert!(positions > 10, "{positions} positions while stuck");
    g.run_to(85.0);
    let free = g.local(1);
    assert!(
        free.1 - stuck.1 > 10.0,
        "free again it goes on: {stuck:?} → {free:?}"
    );
}

#[test]
fn an_outage_carries_nothing_either_way_on_that_vehicles_link_only() {
    let mut g = Gcs::new("2xcopter:ardupilot", "1:outage@30s..60s", |_| {});
    g.run_to(40.0);
    // a command into the dark is neither answered nor executed
    let loiter = SimFlavour::ARDU_COPTER.custom_mode(SimMode::Hold).unwrap() as f32;
    assert_eq!(
        g.command(
            1,
            AUTOPILOT,
            mav::MavCmd::MAV_CMD_DO_SET_MODE,
            [1.0, loiter, 0.0, 0.0, 0.0, 0.0, 0.0]
        ),
        None
    );
    assert_ne!(g.sim.vehicle(1).unwrap().mode(), SimMode::Hold);
    g.run_to(62.0);
    assert_eq!(g.heard(1, None, 30.0, 60.0), Vec::<Time>::new());
    assert!(!g.heard(1, None, 25.0, 30.0).is_empty());
    assert!(!g.heard(1, None, 60.0, 62.0).is_empty());
    // the other vehicle's link is untouched
    assert!(g.heard(2, None, 30.0, 60.0).len() > 30);
    assert_eq!(
        g.command(
            1,
            AUTOPILOT,
            mav::MavCmd::MAV_CMD_DO_SET_MODE,
            [1.0, loiter, 0.0, 0.0, 0.0, 0.0, 0.0]
        ),
        Some(mav::MavResult::MAV_RESULT_ACCEPTED)
    );

    // every vehicle, open-ended
    let mut g = Gcs::new("2xcopter:ardupilot", "all:outage@30s", |_| {});
    g.run_to(100.0);
    for s in [1, 2] {
        assert!(!g.heard(s, None, 20.0, 30.0).is_empty());
        assert_eq!(g.heard(s, None, 30.0, 100.0), Vec::<Time>::new());
    }
}

#[test]
fn a_px4_copter_in_an_outage_takes_its_data_link_failsafe() {
    // NAV_DLL_ACT: the real PX4 returns after COM_DL_LOSS_T without the GCS
    let mut g = Gcs::new("1xcopter:px4", "1:outage@40s..100s", |_| {});
    g.run_to(12.0);
    g.accepted(
        1,
        mav::MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    );
    let amsl = g.sim.vehicle(1).unwrap().home().unwrap().2 as f32 + 10.0;
    g.accepted(
        1,
        mav::MavCmd::MAV_CMD_NAV_TAKEOFF,
        [0.0, 0.0, 0.0, f32::NAN, f32::NAN, f32::NAN, amsl],
    );
    g.run_to(45.0);
    assert_ne!(g.sim.vehicle(1).unwrap().mode(), SimMode::Rtl);
    g.run_to(60.0);
    assert_eq!(g.sim.vehicle(1).unwrap().mode(), SimMode::Rtl);
}

#[test]
fn faults_on_missing_vehicles_or_cameras_are_refused() {
    let cfg = |f: &str| {
        SimConfig::from_spec("1xcopter:ardupilot,1xrover:ardupilot", None, Some(HOME), 1)
            .unwrap()
            .with_scheduled_faults(parse_faults(f).unwrap())
    };
    let e = Sim::new(cfg("3:stuck@10s"), Time::ZERO).unwrap_err();
    assert!(e.to_string().contains("no vehicle 3"), "{e}");
    let e = Sim::new(cfg("2:camera=off@10s"), Time::ZERO).unwrap_err();
    assert!(e.to_string().contains("vehicle 2 has no camera"), "{e}");
    assert!(Sim::new(cfg("all:camera=off@10s,2:stuck"), Time::ZERO).is_ok());
}
