//! Which telemetry the GCS asks a vehicle for, chosen to fit the vehicle's link
//! ([`LinkBudget`]), and the messages it asks the vehicle to stop.
//!
//! **On an unlimited link** the GCS asks for what it always asked: ArduPilot's
//! REQUEST_DATA_STREAM groups (QGroundControl `APMFirmwarePlugin::initializeStreamRates`,
//! MAVProxy `--streamrate`) — on a serial port ArduPilot streams only what its `MAVn_*`
//! (formerly `SRn_*`) parameters or such a request say — and MAV_CMD_SET_MESSAGE_INTERVAL for
//! the messages the GCS shows (QGroundControl `Vehicle::_setMessageInterval`, MAVSDK).
//!
//! **On a radio** a stream group costs what all its messages cost: ArduCopter's
//! EXTENDED_STATUS alone carries SYS_STATUS, POWER_STATUS, MEMINFO, MCU_STATUS,
//! NAV_CONTROLLER_OUTPUT, GPS_RAW_INT, GPS_RTK, MISSION_CURRENT, FENCE_STATUS and more
//! (ArduCopter `GCS_Mavlink.cpp`, `STREAM_EXTENDED_STATUS_msgs`), and with the groups the GCS
//! asked for an ArduCopter sends about 2 kB/s, a whole SiK radio. So the GCS stops every group
//! (REQUEST_DATA_STREAM for MAV_DATA_STREAM_ALL with `start_stop` 0, which ArduPilot's
//! `GCS_MAVLINK::handle_request_data_stream` applies to every group of the port it arrived on)
//! and asks for each message it uses by SET_MESSAGE_INTERVAL, at rates chosen so that the
//! telemetry fits [`LinkBudget::telemetry_bytes_per_s`]: every message first at the slowest
//! rate at which nothing the GCS shows goes stale, then, in the order of [`WANTED`], faster up
//! to what it is worth. PX4 has no groups; it streams its mode's defaults until told otherwise.
//! Whatever a vehicle on a radio still streams that the GCS did not ask for — a stop that was
//! lost, a PX4 default stream, a group a reboot restored — is stopped message by message
//! (SET_MESSAGE_INTERVAL with interval −1, which both autopilots take as "stop":
//! ArduPilot `GCS_MAVLINK::handle_command_set_message_interval`, PX4
//! `MavlinkReceiver::set_message_interval`) once it shows to be periodic ([`Unwanted`]).

// REQUEST_DATA_STREAM and its groups are deprecated in MAVLink, but they are what ArduPilot's
// stream-rate parameters obey (see the module documentation).
#![allow(deprecated)]

use super::flavour::Autopilot;
use crate::budget::LinkBudget;
use crate::time::Time;
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::{MavDataStream, TERRAIN_REPORT_DATA, TERRAIN_REQUEST_DATA};
use std::collections::{BTreeMap, BTreeSet};
use std::time::Duration;

/// A telemetry message the GCS uses, what it costs and how often it is worth having.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wanted {
    /// Message id.
    pub id: u32,
    /// Its name (reports).
    pub name: &'static str,
    /// Bytes one costs on the wire: MAVLink 2, its payload as the autopilots fill it after
    /// trailing zeros are trimmed, plus 12 bytes of header and checksum.
    pub wire_bytes: f64,
    /// The slowest rate at which what the GCS shows of it does not go stale, Hz.
    pub min_hz: f64,
    /// The rate beyond which it is worth nothing more, Hz.
    pub max_hz: f64,
    /// Only ArduPilot sends it (EKF_STATUS_REPORT is ArduPilot's dialect).
    pub ardupilot_only: bool,
}

/// What the GCS uses, in the order it is worth raising on a radio: the position first (the
/// runners' arrival and steadiness checks and the map read it), then state, battery and
/// progress. The wire sizes are what ArduCopter 4.7 and PX4 1.16 SITL send
/// (docs/results/links.md); the minimum rates keep every field of the fleet pane fresh
/// within the 5 s after which the GCS counts telemetry as missing ([`STREAMS_STALE`]), the
/// position within the arming check's 5 s and the runners' 1 s.
pub const WANTED: &[Wanted] = &[
    Wanted {
        id: 33,
        name: "GLOBAL_POSITION_INT",
        wire_bytes: 40.0,
        min_hz: 1.0,
        max_hz: 5.0,
        ardupilot_only: false,
    },
    Wanted {
        id: 0xF5, // 245
        name: "EXTENDED_SYS_STATE",
        wire_bytes: 14.0,
        min_hz: 0.5,
        max_hz: 1.0,
        ardupilot_only: false,
    },
    Wanted {
        id: 1,
        name: "SYS_STATUS",
        wire_bytes: 55.0,
        min_hz: 0.5,
        max_hz: 1.0,
        ardupilot_only: false,
    },
    Wanted {
        id: 42,
        name: "MISSION_CURRENT",
        wire_bytes: 30.0,
        min_hz: 0.5,
        max_hz: 1.0,
        ardupilot_only: false,
    },
    Wanted {
        id: 193,
        name: "EKF_STATUS_REPORT",
        wire_bytes: 38.0,
        min_hz: 0.2,
        max_hz: 1.0,
        ardupilot_only: true,
    },
    Wanted {
        id: 24,
        name: "GPS_RAW_INT",
        wire_bytes: 64.0,
        min_hz: 0.2,
        max_hz: 1.0,
        ardupilot_only: false,
    },
    Wanted {
        id: 147,
        name: "BATTERY_STATUS",
        wire_bytes: 54.0,
        min_hz: 0.2,
        max_hz: 0.5,
        ardupilot_only: false,
    },
    Wanted {
        id: 242,
        name: "HOME_POSITION",
        wire_bytes: 72.0,
        min_hz: 0.05,
        max_hz: 0.2,
        ardupilot_only: false,
    },
];

/// Bytes per second a vehicle on a radio sends whatever the GCS asks: its autopilot's and
/// its camera's HEARTBEAT (21 bytes at 1 Hz each).
pub const HEARTBEATS_BYTES_PER_S: f64 = 42.0;

/// TERRAIN_REQUEST's message id. ArduPilot sends it from its EXTRA3 group or when asked by
/// SET_MESSAGE_INTERVAL (`ap_message` MSG_TERRAIN_REQUEST), at most every 2 s, and only while
/// it lacks terrain (`AP_Terrain::send_request`, `TerrainGCS.cpp`).
pub const TERRAIN_REQUEST: u32 = <TERRAIN_REQUEST_DATA as MessageData>::ID;
/// TERRAIN_REPORT's message id: how many squares the vehicle waits for and has. A message of
/// its own (MSG_TERRAIN_REPORT): ArduCopter 4.7 SITL asked for TERRAIN_REQUEST alone sent
/// no TERRAIN_REPORT (docs/results/conformance.md, "Terrain served from tiles").
pub const TERRAIN_REPORT: u32 = <TERRAIN_REPORT_DATA as MessageData>::ID;
/// How often a vehicle served terrain on a radio is asked for both, Hz.
pub const TERRAIN_HZ: f64 = 1.0;
/// What they cost on the wire at [`TERRAIN_HZ`], bytes per second: a TERRAIN_REPORT
/// (22-byte payload, 34 bytes) each time, and a TERRAIN_REQUEST (18-byte payload, 30 bytes)
/// at most every 2 s while the vehicle lacks terrain.
pub const TERRAIN_BYTES_PER_S: f64 = 34.0 * TERRAIN_HZ + 30.0 / 2.0;

/// Telemetry the GCS asked for and has not heard for this long counts as missing: it asks
/// again.
pub const STREAMS_STALE: Duration = Duration::from_secs(5);

/// The requests that set a vehicle's telemetry.
#[derive(Clone, Debug, PartialEq)]
pub struct StreamPlan {
    /// ArduPilot's REQUEST_DATA_STREAM, in order: (group, rate Hz; 0 stops it). Empty for
    /// PX4.
    pub data_streams: Vec<(MavDataStream, u16)>,
    /// MAV_CMD_SET_MESSAGE_INTERVAL, sent after the groups: (message id, interval µs; −1
    /// stops the message).
    pub intervals: Vec<(u32, f32)>,
    /// On a radio: what the messages asked for cost, heartbeats included, bytes per second
    /// (`None` on an unlimited link, where the groups' cost is the autopilot's affair).
    pub expected_bytes_per_s: Option<f64>,
}

impl StreamPlan {
    /// The plan for a vehicle of `autopilot` on a link of `budget`.
    pub fn for_link(autopilot: Autopilot, budget: LinkBudget) -> StreamPlan {
        Self::for_link_terrain(autopilot, budget, false)
    }

    /// [`StreamPlan::for_link`], for a GCS that serves terrain (`terrain`): an ArduPilot
    /// vehicle on a radio is also asked for [`TERRAIN_REQUEST`] and [`TERRAIN_REPORT`] at
    /// [`TERRAIN_HZ`] — the group they would otherwise come in is stopped there, so neither
    /// is ever stopped — and their cost, [`TERRAIN_BYTES_PER_S`], comes out of the
    /// telemetry's share first. On an unlimited link they come with EXTRA3 as before.
    pub fn for_link_terrain(autopilot: Autopilot, budget: LinkBudget, terrain: bool) -> StreamPlan {
        let terrain = terrain && autopilot == Autopilot::ArduPilot;
        match budget.telemetry_bytes_per_s() {
            None => Self::unlimited(autopilot),
            Some(share) if terrain => {
                let mut plan = Self::within(autopilot, share - TERRAIN_BYTES_PER_S);
                let us = (1e6 / TERRAIN_HZ).round() as f32;
                plan.intervals.push((TERRAIN_REQUEST, us));
                plan.intervals.push((TERRAIN_REPORT, us));
                plan.expected_bytes_per_s =
                    plan.expected_bytes_per_s.map(|b| b + TERRAIN_BYTES_PER_S);
                plan
            }
            Some(share) => Self::within(autopilot, share),
        }
    }

    /// The whole telemetry (an unlimited link).
    fn unlimited(autopilot: Autopilot) -> StreamPlan {
        let data_streams = if autopilot == Autopilot::ArduPilot {
            vec![
                (MavDataStream::MAV_DATA_STREAM_EXTENDED_STATUS, 2),
                (MavDataStream::MAV_DATA_STREAM_POSITION, 5),
                (MavDataStream::MAV_DATA_STREAM_EXTRA1, 4),
                (MavDataStream::MAV_DATA_STREAM_EXTRA2, 4),
                (MavDataStream::MAV_DATA_STREAM_EXTRA3, 2),
            ]
        } else {
            Vec::new()
        };
        let hz = |id: u32, hz: f32| (id, 1e6 / hz);
        StreamPlan {
            data_streams,
            intervals: vec![
                hz(33, 5.0),  // GLOBAL_POSITION_INT
                hz(24, 2.0),  // GPS_RAW_INT
                hz(1, 1.0),   // SYS_STATUS
                hz(42, 1.0),  // MISSION_CURRENT
                hz(245, 1.0), // EXTENDED_SYS_STATE
                hz(242, 0.5), // HOME_POSITION
                hz(147, 1.0), // BATTERY_STATUS
                hz(74, 2.0),  // VFR_HUD
            ],
            expected_bytes_per_s: None,
        }
    }

    /// Only what [`WANTED`] lists, within `share` bytes per second.
    fn within(autopilot: Autopilot, share: f64) -> StreamPlan {
        let wanted: Vec<&Wanted> = WANTED
            .iter()
            .filter(|w| !w.ardupilot_only || autopilot == Autopilot::ArduPilot)
            .collect();
        let rates = share_out(&wanted, share - HEARTBEATS_BYTES_PER_S);
        let cost: f64 = wanted
            .iter()
            .zip(&rates)
            .map(|(w, hz)| w.wire_bytes * hz)
            .sum();
        StreamPlan {
            data_streams: if autopilot == Autopilot::ArduPilot {
                vec![(MavDataStream::MAV_DATA_STREAM_ALL, 0)]
            } else {
                Vec::new()
            },
            intervals: wanted
                .iter()
                .zip(&rates)
                .map(|(w, hz)| (w.id, (1e6 / hz).round() as f32))
                .collect(),
            expected_bytes_per_s: Some(cost + HEARTBEATS_BYTES_PER_S),
        }
    }

    /// The message ids the plan asks for by interval (and not to stop).
    pub fn asked(&self) -> BTreeSet<u32> {
        self.intervals
            .iter()
            .filter(|(_, us)| *us > 0.0)
            .map(|(id, _)| *id)
            .collect()
    }
}

/// Rates for `wanted` within `bytes_per_s`: each at its minimum, then each in turn raised to
/// its maximum while the bytes last (the last one raised part of the way). When even the
/// minimums do not fit, all are scaled down together (the link is too slow for the GCS to
/// show everything fresh; it shows what it can).
fn share_out(wanted: &[&Wanted], bytes_per_s: f64) -> Vec<f64> {
    let floor: f64 = wanted.iter().map(|w| w.wire_bytes * w.min_hz).sum();
    let budget = bytes_per_s.max(0.0);
    if floor >= budget {
        let k = if floor > 0.0 { budget / floor } else { 0.0 };
        return wanted.iter().map(|w| (w.min_hz * k).max(0.01)).collect();
    }
    let mut left = budget - floor;
    wanted
        .iter()
        .map(|w| {
            let extra = (w.max_hz - w.min_hz) * w.wire_bytes;
            let take = extra.min(left);
            left -= take;
            w.min_hz + take / w.wire_bytes
        })
        .collect()
}

/// Messages that are answers or events, never periodic streams: a vehicle on a radio is
/// never asked to stop them (the protocols, the camera and the operator's texts need them).
const EVENTS: &[u32] = &[
    0,   // HEARTBEAT
    4,   // PING
    20,  // PARAM_REQUEST_READ
    22,  // PARAM_VALUE
    37,  // MISSION_REQUEST_PARTIAL_LIST
    39,  // MISSION_ITEM
    40,  // MISSION_REQUEST
    43,  // MISSION_REQUEST_LIST
    44,  // MISSION_COUNT
    45,  // MISSION_CLEAR_ALL
    46,  // MISSION_ITEM_REACHED
    47,  // MISSION_ACK
    51,  // MISSION_REQUEST_INT
    73,  // MISSION_ITEM_INT
    75,  // COMMAND_INT
    76,  // COMMAND_LONG
    77,  // COMMAND_ACK
    110, // FILE_TRANSFER_PROTOCOL
    111, // TIMESYNC
    112, // CAMERA_TRIGGER (PX4 sends one per picture)
    130, // DATA_TRANSMISSION_HANDSHAKE
    131, // ENCAPSULATED_DATA
    148, // AUTOPILOT_VERSION
    180, // CAMERA_FEEDBACK (ArduPilot sends one per picture)
    244, // MESSAGE_INTERVAL
    253, // STATUSTEXT
    259, // CAMERA_INFORMATION
    262, // CAMERA_CAPTURE_STATUS
    263, // CAMERA_IMAGE_CAPTURED
    300, // PROTOCOL_VERSION
    350, // DEBUG_FLOAT_ARRAY
];

/// How many arrivals within [`Unwanted::WINDOW`] make a message periodic.
const PERIODIC_ARRIVALS: usize = 3;

/// The messages a vehicle on a radio streams without being asked, and the requests to stop
/// them: one MAV_CMD_SET_MESSAGE_INTERVAL(id, −1) per message once it arrived
/// `PERIODIC_ARRIVALS` times within [`Unwanted::WINDOW`], again at most every
/// [`Unwanted::RETRY`] while it keeps coming, and no more after [`Unwanted::MAX_ASKS`] (a
/// vehicle that will not stop a message is left alone). Pure: fed with what the autopilot
/// sends and the time.
#[derive(Clone, Debug, Default)]
pub struct Unwanted {
    /// The ids the GCS asked for (never stopped).
    asked: BTreeSet<u32>,
    /// Recent arrivals of each other id.
    seen: BTreeMap<u32, Vec<Time>>,
    /// Stop requests sent: (when the last was, how many).
    asks: BTreeMap<u32, (Time, u32)>,
    /// Stop requests to send.
    out: Vec<u32>,
}

impl Unwanted {
    /// Arrivals of a message are counted over this long.
    pub const WINDOW: Duration = Duration::from_secs(10);
    /// A message still arriving this long after the GCS asked to stop it is asked again.
    pub const RETRY: Duration = Duration::from_secs(15);
    /// Stop requests per message before the GCS gives up on it.
    pub const MAX_ASKS: u32 = 3;

    /// Watch a vehicle whose plan asks for `asked`.
    pub fn new(asked: BTreeSet<u32>) -> Unwanted {
        Unwanted {
            asked,
            ..Unwanted::default()
        }
    }

    /// A new plan: the ids it asks for are wanted from now on, and every stop request
    /// starts again from zero (a reboot restores the vehicle's defaults).
    pub fn replan(&mut self, asked: BTreeSet<u32>) {
        *self = Unwanted::new(asked);
    }

    /// The autopilot sent message `id` at `now`.
    pub fn handle_message(&mut self, id: u32, now: Time) {
        if self.asked.contains(&id) || EVENTS.contains(&id) {
            return;
        }
        let seen = self.seen.entry(id).or_default();
        seen.retain(|t| now.saturating_since(*t) <= Self::WINDOW);
        seen.push(now);
        if seen.len() < PERIODIC_ARRIVALS {
            return;
        }
        let due = match self.asks.get(&id) {
            None => true,
            Some((at, n)) => *n < Self::MAX_ASKS && now.saturating_since(*at) >= Self::RETRY,
        };
        if due {
            let n = self.asks.get(&id).map_or(0, |(_, n)| *n);
            self.asks.insert(id, (now, n + 1));
            self.out.push(id);
        }
    }

    /// The next message to ask the vehicle to stop.
    pub fn poll_stop(&mut self) -> Option<u32> {
        if self.out.is_empty() {
            None
        } else {
            Some(self.out.remove(0))
        }
    }

    /// The messages asked to stop so far, with how many times.
    pub fn stopped(&self) -> impl Iterator<Item = (u32, u32)> + '_ {
        self.asks.iter().map(|(id, (_, n))| (*id, *n))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cost(plan: &StreamPlan) -> f64 {
        plan.expected_bytes_per_s.unwrap()
    }

    #[test]
    fn unlimited_links_keep_the_full_telemetry() {
        let ap = StreamPlan::for_link(Autopilot::ArduPilot, LinkBudget::Unlimited);
        assert_eq!(ap.data_streams.len(), 5);
        assert!(ap.data_streams.iter().all(|(_, hz)| *hz > 0));
        assert!(ap.asked().contains(&74), "VFR_HUD");
        assert_eq!(ap.expected_bytes_per_s, None);
        let px4 = StreamPlan::for_link(Autopilot::Px4, LinkBudget::Unlimited);
        assert!(px4.data_streams.is_empty());
        assert_eq!(px4.intervals, ap.intervals);
    }

    #[test]
    fn a_2000_byte_radio_gets_every_message_at_its_best_rate_within_800_bytes() {
        let plan = StreamPlan::for_link(Autopilot::ArduPilot, LinkBudget::radio());
        assert_eq!(
            plan.data_streams,
            vec![(MavDataStream::MAV_DATA_STREAM_ALL, 0)]
        );
        assert!(cost(&plan) <= 800.0, "{}", cost(&plan));
        for w in WANTED {
            let (_, us) = plan.intervals.iter().find(|(id, _)| *id == w.id).unwrap();
            assert!((1e6 / f64::from(*us) - w.max_hz).abs() < 1e-3, "{}", w.name);
        }
        assert!(!plan.asked().contains(&74), "no VFR_HUD on a radio");
        let px4 = StreamPlan::for_link(Autopilot::Px4, LinkBudget::radio());
        assert!(px4.data_streams.is_empty());
        assert!(
            !px4.asked().contains(&193),
            "EKF_STATUS_REPORT is ArduPilot's"
        );
    }

    #[test]
    fn slower_radios_raise_the_position_first_and_never_exceed_the_share() {
        for bytes_per_s in [LinkBudget::MIN_RADIO, 500, 800, 1000, 1500, 2000, 5000] {
            let budget = LinkBudget::Radio { bytes_per_s };
            let plan = StreamPlan::for_link(Autopilot::ArduPilot, budget);
            let share = budget.telemetry_bytes_per_s().unwrap();
            let floor: f64 = WANTED.iter().map(|w| w.wire_bytes * w.min_hz).sum::<f64>()
                + HEARTBEATS_BYTES_PER_S;
            assert!(
                cost(&plan) <= share.max(HEARTBEATS_BYTES_PER_S) + 1e-6 || floor > share,
                "{bytes_per_s}: {} > {share}",
                cost(&plan)
            );
            let hz = |id: u32| {
                let (_, us) = plan.intervals.iter().find(|(i, _)| *i == id).unwrap();
                1e6 / f64::from(*us)
            };
            // The position is raised before anything else is.
            if hz(1) > WANTED[2].min_hz + 1e-9 {
                assert!((hz(33) - 5.0).abs() < 1e-3, "{bytes_per_s}");
            }
        }
        // 1000 B/s: 400 B/s of telemetry; the minimums fit, the position gets its 5 Hz.
        let plan = StreamPlan::for_link(
            Autopilot::ArduPilot,
            LinkBudget::Radio { bytes_per_s: 1000 },
        );
        assert!((cost(&plan) - 400.0).abs() < 1.0, "{}", cost(&plan));
    }

    /// Serving terrain on a radio: MSG_TERRAIN is asked for, paid for out of the same share,
    /// and neither of its messages is ever stopped; elsewhere nothing changes.
    #[test]
    fn terrain_served_on_a_radio_is_asked_for_counted_and_never_stopped() {
        let budget = LinkBudget::radio();
        let share = budget.telemetry_bytes_per_s().unwrap();
        let plan = StreamPlan::for_link_terrain(Autopilot::ArduPilot, budget, true);
        assert!(plan.intervals.contains(&(TERRAIN_REQUEST, 1e6)));
        assert!(plan.intervals.contains(&(TERRAIN_REPORT, 1e6)));
        assert!(cost(&plan) <= share + 1e-6, "{}", cost(&plan));
        let without = StreamPlan::for_link(Autopilot::ArduPilot, budget);
        assert!(!without.asked().contains(&TERRAIN_REQUEST));
        // on a slow radio the telemetry gives way to it
        let slow = LinkBudget::Radio { bytes_per_s: 1000 };
        let plan_slow = StreamPlan::for_link_terrain(Autopilot::ArduPilot, slow, true);
        assert!(
            (cost(&plan_slow) - 400.0).abs() < 1.0,
            "{}",
            cost(&plan_slow)
        );
        let mut u = Unwanted::new(plan.asked());
        let t = |ms: u64| Time::from_millis(ms);
        for k in 0..30 {
            u.handle_message(TERRAIN_REPORT, t(k * 1000));
            u.handle_message(TERRAIN_REQUEST, t(k * 2000));
        }
        assert_eq!(u.poll_stop(), None);
        // without terrain, a TERRAIN_REPORT streaming on a radio is stopped as before
        let mut u = Unwanted::new(without.asked());
        for k in 0..3 {
            u.handle_message(TERRAIN_REPORT, t(k * 1000));
        }
        assert_eq!(u.poll_stop(), Some(TERRAIN_REPORT));
        // PX4 and unlimited links are untouched
        assert_eq!(
            StreamPlan::for_link_terrain(Autopilot::Px4, budget, true),
            StreamPlan::for_link(Autopilot::Px4, budget)
        );
        assert_eq!(
            StreamPlan::for_link_terrain(Autopilot::ArduPilot, LinkBudget::Unlimited, true),
            StreamPlan::for_link(Autopilot::ArduPilot, LinkBudget::Unlimited)
        );
    }

    #[test]
    fn unasked_periodic_messages_are_stopped_once_then_retried_then_left() {
        let plan = StreamPlan::for_link(Autopilot::Px4, LinkBudget::radio());
        let mut u = Unwanted::new(plan.asked());
        let t = |ms: u64| Time::from_millis(ms);
        // ATTITUDE at 10 Hz: stopped at its third arrival.
        for k in 0..3 {
            u.handle_message(30, t(k * 100));
        }
        assert_eq!(u.poll_stop(), Some(30));
        assert_eq!(u.poll_stop(), None);
        // Asked-for, event and rare messages are left alone.
        for k in 0..20 {
            u.handle_message(33, t(k * 100));
            u.handle_message(253, t(k * 100));
            u.handle_message(77, t(k * 100));
        }
        u.handle_message(31, t(0));
        u.handle_message(31, t(11_000));
        u.handle_message(31, t(22_000));
        assert_eq!(u.poll_stop(), None);
        // Still coming: asked again after RETRY, at most MAX_ASKS times.
        let mut asked = 1;
        for k in 3..2000u64 {
            u.handle_message(30, t(k * 100));
            while u.poll_stop().is_some() {
                asked += 1;
            }
        }
        assert_eq!(asked, Unwanted::MAX_ASKS);
        // A new plan (a reboot) starts over.
        u.replan(plan.asked());
        for k in 0..3 {
            u.handle_message(30, t(300_000 + k * 100));
        }
        assert_eq!(u.poll_stop(), Some(30));
    }
}
