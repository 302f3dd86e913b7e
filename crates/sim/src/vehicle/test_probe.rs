//! A simulated vehicle driven by hand in unit tests: a GCS that heartbeats, sends messages and
//! commands, and keeps every frame the autopilot sent with its size on the wire (MAVLink 2,
//! trailing zeros cut, no signature).

use super::{Px4Link, SimVehicle, VehicleConfig};
use crate::flavour::SimFlavour;
use fleetmap_core::time::Time;
use mavlink::dialects::ardupilotmega::{self as mav, MavMessage};
use mavlink::{MavHeader, MavlinkVersion, Message};
use std::collections::BTreeMap;
use std::time::Duration;

const GCS: MavHeader = MavHeader {
    system_id: fleetmap_core::proto::GCS_SYSID as u32,
    component_id: fleetmap_core::proto::GCS_COMPID,
    sequence: 0,
};

/// A vehicle driven by hand, and every frame its autopilot sent: (time, id, bytes).
pub(crate) struct Probe {
    pub(crate) v: SimVehicle,
    pub(crate) now: Time,
    pub(crate) log: Vec<(Time, u32, usize)>,
    pub(crate) acks: Vec<(mav::MavCmd, mav::MavResult)>,
    pub(crate) texts: Vec<String>,
    pub(crate) intervals: Vec<(u16, i32)>,
    pub(crate) mission_requests: Vec<u16>,
    last_hb: Time,
}

impl Probe {
    pub(crate) fn new(flavour: SimFlavour, link: Option<Px4Link>) -> Probe {
        let mut cfg = VehicleConfig::new(1, flavour, (37.1965, -80.5785));
        cfg.camera = None;
        if let Some(l) = link {
            cfg.px4_link = l;
        }
        Probe {
            v: SimVehicle::new(cfg, None, Time::ZERO),
            now: Time::ZERO,
            log: Vec::new(),
            acks: Vec::new(),
            texts: Vec::new(),
            intervals: Vec::new(),
            mission_requests: Vec::new(),
            last_hb: Time::ZERO,
        }
    }

    pub(crate) fn drain(&mut self) {
        while let Some((h, m)) = self.v.poll_transmit() {
            if h.component_id != fleetmap_core::proto::AUTOPILOT_COMPID {
                continue;
            }
            let bytes =
                fleetmap_io::link::codec::encode_frame(&h, &m, MavlinkVersion::V2, None, 0).len();
            match &m {
                MavMessage::COMMAND_ACK(a) => self.acks.push((a.command, a.result)),
                MavMessage::STATUSTEXT(t) => self.texts.push(t.text.to_str().unwrap_or("").into()),
                MavMessage::MESSAGE_INTERVAL(i) => {
                    self.intervals.push((i.message_id, i.interval_us))
                }
                MavMessage::MISSION_REQUEST(r) => self.mission_requests.push(r.seq),
                MavMessage::MISSION_REQUEST_INT(r) => self.mission_requests.push(r.seq),
                _ => {}
            }
            self.log.push((self.now, m.message_id(), bytes));
        }
    }

    pub(crate) fn send(&mut self, msg: MavMessage) {
        self.v.handle_message(&GCS, &msg, self.now);
        self.drain();
    }

    /// Run for `secs`, heartbeating as a GCS does.
    pub(crate) fn run(&mut self, secs: f64) {
        let end = self.now + Duration::from_secs_f64(secs);
        while self.now < end {
            self.now += Duration::from_millis(50);
            if self.now.saturating_since(self.last_hb) >= Duration::from_secs(1) {
                self.last_hb = self.now;
                self.send(MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
                    mavtype: mav::MavType::MAV_TYPE_GCS,
                    autopilot: mav::MavAutopilot::MAV_AUTOPILOT_INVALID,
                    ..mav::HEARTBEAT_DATA::default()
                }));
            }
            self.v.step(self.now);
            self.drain();
        }
    }

    pub(crate) fn command(&mut self, command: mav::MavCmd, p: [f32; 7]) -> Option<mav::MavResult> {
        self.acks.clear();
        self.send(MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
            param1: p[0],
            param2: p[1],
            param3: p[2],
            param4: p[3],
            param5: p[4],
            param6: p[5],
            param7: p[6],
            command,
            target_system: 1,
            target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
            confirmation: 0,
        }));
        self.acks.iter().find(|a| a.0 == command).map(|a| a.1)
    }

    pub(crate) fn interval(&mut self, id: u32, us: f32) -> Option<mav::MavResult> {
        self.command(
            mav::MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
            [id as f32, us, 0.0, 0.0, 0.0, 0.0, 0.0],
        )
    }

    pub(crate) fn stream(&mut self, stream: mav::MavDataStream, hz: u16, start_stop: u8) {
        self.send(MavMessage::REQUEST_DATA_STREAM(
            mav::REQUEST_DATA_STREAM_DATA {
                req_message_rate: hz,
                target_system: 1,
                target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
                req_stream_id: stream,
                start_stop,
            },
        ));
    }

    /// fleetmap's requests today (`src/fleet/actor.rs`, `request_streams`).
    pub(crate) fn fleetmap_requests(&mut self) {
        use mav::MavDataStream as S;
        if self.v.config().flavour.is_ardupilot() {
            for (s, hz) in [
                (S::MAV_DATA_STREAM_EXTENDED_STATUS, 2),
                (S::MAV_DATA_STREAM_POSITION, 5),
                (S::MAV_DATA_STREAM_EXTRA1, 4),
                (S::MAV_DATA_STREAM_EXTRA2, 4),
                (S::MAV_DATA_STREAM_EXTRA3, 2),
            ] {
                self.stream(s, hz, 1);
            }
        }
        for (id, us) in FLEETMAP_INTERVALS {
            self.interval(id, us);
        }
    }

    /// Per message id over the last `secs`: (Hz, mean bytes).
    pub(crate) fn table(&self, secs: f64) -> BTreeMap<u32, (f64, f64)> {
        let from = self.now - Duration::from_secs_f64(secs);
        let mut per: BTreeMap<u32, (usize, usize)> = BTreeMap::new();
        for &(t, id, b) in &self.log {
            if t > from {
                let e = per.entry(id).or_default();
                e.0 += 1;
                e.1 += b;
            }
        }
        per.into_iter()
            .map(|(id, (n, b))| (id, (n as f64 / secs, b as f64 / n as f64)))
            .collect()
    }

    /// Messages `id` per second between `from` and `to` seconds of simulated time.
    pub(crate) fn hz_between(&self, id: u32, from: f64, to: f64) -> f64 {
        let (a, b) = (Time::from_secs_f64(from), Time::from_secs_f64(to));
        let n = self
            .log
            .iter()
            .filter(|&&(t, i, _)| i == id && t > a && t <= b)
            .count();
        n as f64 / (to - from)
    }

    /// Bytes per second between `from` and `to` seconds of simulated time.
    pub(crate) fn bps_between(&self, from: f64, to: f64) -> f64 {
        let (a, b) = (Time::from_secs_f64(from), Time::from_secs_f64(to));
        let n: usize = self
            .log
            .iter()
            .filter(|&&(t, _, _)| t > a && t <= b)
            .map(|&(_, _, s)| s)
            .sum();
        n as f64 / (to - from)
    }

    /// Seconds of simulated time now.
    pub(crate) fn secs(&self) -> f64 {
        self.now.saturating_since(Time::ZERO).as_secs_f64()
    }

    /// Bytes per second over the last `secs`.
    pub(crate) fn bps(&self, secs: f64) -> f64 {
        self.table(secs).values().map(|(hz, b)| hz * b).sum()
    }
}

/// fleetmap's SET_MESSAGE_INTERVAL requests today (`src/fleet/actor.rs`, `request_streams`).
pub(crate) const FLEETMAP_INTERVALS: [(u32, f32); 8] = [
    (33, 200_000.0),
    (24, 500_000.0),
    (1, 1_000_000.0),
    (42, 1_000_000.0),
    (245, 1_000_000.0),
    (242, 2_000_000.0),
    (147, 1_000_000.0),
    (74, 500_000.0),
];
