//! Heartbeats: the GCS's own (1 Hz) and the liveness of every component we hear.
//!
//! * The GCS heartbeat is MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, MAV_STATE_ACTIVE, sent once
//!   per second as QGroundControl (`MAVLinkProtocol::_sendHeartbeats`) and MAVProxy
//!   (`mavproxy.py` `send_heartbeat`: `MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0, 0`) do.
//!   ArduPilot uses it for the GCS failsafe (`FS_GCS_ENABLE`), PX4 for data-link loss
//!   (`COM_DL_LOSS_T`).
//! * A component is *lost* after [`LivenessConfig::lost_after`] (3 s, QGroundControl's
//!   `_heartbeatMaxElpasedMSecs` is 3500 ms) without a heartbeat and *regained* on the next
//!   one. A reboot is detected when the component's boot clock (`time_boot_ms` of
//!   SYSTEM_TIME, ATTITUDE, GLOBAL_POSITION_INT …) goes back by more than a second (a late
//!   reordered frame cannot do that), or when a heartbeat reports MAV_STATE_BOOT after the
//!   component was active.
//! * Heartbeats are read leniently ([`Beat::from_payload`]): a MAV_TYPE or MAV_AUTOPILOT
//!   value newer than our dialect must not make a vehicle invisible.

use super::Endpoint;
use crate::time::Time;
use mavlink::dialects::ardupilotmega::{
    HEARTBEAT_DATA, MavAutopilot, MavMessage, MavModeFlag, MavState, MavType,
};
use std::collections::BTreeMap;
use std::time::Duration;

/// MAV_TYPE_GCS (6).
pub const MAV_TYPE_GCS: u8 = MavType::MAV_TYPE_GCS as u8;
/// MAV_AUTOPILOT_INVALID (8).
pub const MAV_AUTOPILOT_INVALID: u8 = MavAutopilot::MAV_AUTOPILOT_INVALID as u8;
/// MAV_STATE_BOOT.
const MAV_STATE_BOOT: u8 = MavState::MAV_STATE_BOOT as u8;
/// MAV_STATE_STANDBY and later (calibrating, active, critical …).
const MAV_STATE_STANDBY: u8 = MavState::MAV_STATE_STANDBY as u8;

/// The fields of a HEARTBEAT as raw numbers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Beat {
    /// Autopilot-specific mode.
    pub custom_mode: u32,
    /// MAV_TYPE.
    pub mav_type: u8,
    /// MAV_AUTOPILOT.
    pub autopilot: u8,
    /// MAV_MODE_FLAG bits.
    pub base_mode: u8,
    /// MAV_STATE.
    pub system_status: u8,
}

impl Beat {
    /// Read a HEARTBEAT payload without enum validation (MAVLink 2 trims trailing zeros).
    pub fn from_payload(payload: &[u8]) -> Beat {
        let mut p = [0u8; 9];
        let n = payload.len().min(9);
        p[..n].copy_from_slice(&payload[..n]);
        Beat {
            custom_mode: u32::from_le_bytes([p[0], p[1], p[2], p[3]]),
            mav_type: p[4],
            autopilot: p[5],
            base_mode: p[6],
            system_status: p[7],
        }
    }

    /// From a parsed HEARTBEAT.
    pub fn from_data(h: &HEARTBEAT_DATA) -> Beat {
        Beat {
            custom_mode: h.custom_mode,
            mav_type: h.mavtype as u8,
            autopilot: h.autopilot as u8,
            base_mode: h.base_mode.bits(),
            system_status: h.system_status as u8,
        }
    }

    /// MAV_MODE_FLAG_SAFETY_ARMED is set.
    pub fn armed(&self) -> bool {
        self.base_mode & 0x80 != 0
    }

    /// The sender is an autopilot (not a GCS, camera, gimbal …).
    pub fn is_autopilot(&self) -> bool {
        self.autopilot != MAV_AUTOPILOT_INVALID && self.mav_type != MAV_TYPE_GCS
    }
}

/// The GCS heartbeat message.
pub fn gcs_heartbeat() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_GCS,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: 3,
    })
}

/// Liveness timing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LivenessConfig {
    /// GCS heartbeat period (1 s).
    pub(crate) gcs_period: Duration,
    /// Silence after which a component is lost (3 s): no heartbeat and no other message.
    pub lost_after: Duration,
}

impl Default for LivenessConfig {
    fn default() -> Self {
        LivenessConfig {
            gcs_period: Duration::from_secs(1),
            lost_after: Duration::from_secs(3),
        }
    }
}

/// What the liveness tracker reports.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LivenessEvent {
    /// First heartbeat from a component.
    Discovered {
        /// The component.
        who: Endpoint,
        /// Its heartbeat.
        beat: Beat,
    },
    /// Nothing heard (heartbeat or other message) for `lost_after`.
    Lost {
        /// The component.
        who: Endpoint,
    },
    /// Heard again after being lost.
    Regained {
        /// The component.
        who: Endpoint,
    },
    /// The component rebooted (boot clock went back, or it reports MAV_STATE_BOOT again).
    Rebooted {
        /// The component.
        who: Endpoint,
    },
}

#[derive(Clone, Debug)]
struct Peer {
    last_beat: Time,
    /// The last frame of any kind: a component that answers mission items or streams
    /// telemetry is alive even when its 1 Hz heartbeats are lost on a poor link.
    last_heard: Time,
    lost: bool,
    boot_ms: Option<u32>,
    was_active: bool,
}

/// The GCS heartbeat generator and the liveness of every component heard.
#[derive(Debug)]
pub struct Liveness {
    cfg: LivenessConfig,
    own: Endpoint,
    next_beat: Time,
    peers: BTreeMap<Endpoint, Peer>,
    out: Vec<MavMessage>,
    events: std::collections::VecDeque<LivenessEvent>,
}

impl Liveness {
    /// A tracker for the GCS `own` (its own heartbeats are ignored); the first GCS
    /// heartbeat is due at `now`.
    pub fn new(own: Endpoint, cfg: LivenessConfig, now: Time) -> Liveness {
        Liveness {
            cfg,
            own,
            next_beat: now,
            peers: BTreeMap::new(),
            out: Vec::new(),
            events: Default::default(),
        }
    }

    /// Whether `who` is currently alive (heard within `lost_after`).
    pub fn is_alive(&self, who: Endpoint) -> bool {
        self.peers.get(&who).is_some_and(|p| !p.lost)
    }

    /// Time of the last heartbeat from `who`.
    pub fn last_heartbeat(&self, who: Endpoint) -> Option<Time> {
        self.peers.get(&who).map(|p| p.last_beat)
    }

    /// A heartbeat from `who`.
    pub fn handle_heartbeat(&mut self, who: Endpoint, beat: &Beat, now: Time) {
        if who == self.own {
            return;
        }
        match self.peers.get_mut(&who) {
            None => {
                self.peers.insert(
                    who,
                    Peer {
                        last_beat: now,
                        last_heard: now,
                        lost: false,
                        boot_ms: None,
                        was_active: beat.system_status >= MAV_STATE_STANDBY,
                    },
                );
                self.events
                    .push_back(LivenessEvent::Discovered { who, beat: *beat });
            }
            Some(p) => {
                p.last_beat = now;
                p.last_heard = now;
                if p.lost {
                    p.lost = false;
                    self.events.push_back(LivenessEvent::Regained { who });
                }
                if beat.system_status == MAV_STATE_BOOT && p.was_active {
                    p.was_active = false;
                    p.boot_ms = None;
                    self.events.push_back(LivenessEvent::Rebooted { who });
                } else if beat.system_status >= MAV_STATE_STANDBY {
                    p.was_active = true;
                }
            }
        }
    }

    /// Any other message from `who`: it is alive; watches its boot clock.
    pub fn handle_message(&mut self, who: Endpoint, msg: &MavMessage, now: Time) {
        if let Some(p) = self.peers.get_mut(&who) {
            p.last_heard = now;
            if p.lost {
                p.lost = false;
                self.events.push_back(LivenessEvent::Regained { who });
            }
        }
        let boot = match msg {
            MavMessage::SYSTEM_TIME(m) => m.time_boot_ms,
            MavMessage::ATTITUDE(m) => m.time_boot_ms,
            MavMessage::GLOBAL_POSITION_INT(m) => m.time_boot_ms,
            MavMessage::LOCAL_POSITION_NED(m) => m.time_boot_ms,
            _ => return,
        };
        let Some(p) = self.peers.get_mut(&who) else {
            return;
        };
        match p.boot_ms {
            Some(last) if boot.saturating_add(1000) < last => {
                p.boot_ms = Some(boot);
                self.events.push_back(LivenessEvent::Rebooted { who });
            }
            Some(last) if boot <= last => {}
            _ => p.boot_ms = Some(boot),
        }
    }

    /// Emit the GCS heartbeat when due and mark silent components lost.
    pub fn handle_timeout(&mut self, now: Time) {
        if now >= self.next_beat {
            self.out.push(gcs_heartbeat());
            // Keep the 1 Hz grid; skip missed beats instead of bursting.
            while self.next_beat <= now {
                self.next_beat += self.cfg.gcs_period;
            }
        }
        for (who, p) in self.peers.iter_mut() {
            if !p.lost && now.saturating_since(p.last_heard) >= self.cfg.lost_after {
                p.lost = true;
                self.events.push_back(LivenessEvent::Lost { who: *who });
            }
        }
    }

    /// The next message to send (the GCS heartbeat).
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.out.pop()
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<LivenessEvent> {
        self.events.pop_front()
    }

    /// When [`Liveness::handle_timeout`] must be called next.
    pub fn poll_timeout(&self) -> Option<Time> {
        let lost = self
            .peers
            .values()
            .filter(|p| !p.lost)
            .map(|p| p.last_heard + self.cfg.lost_after)
            .min();
        Some(lost.map_or(self.next_beat, |l| l.min(self.next_beat)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::SYSTEM_TIME_DATA;

    fn beat(status: u8) -> Beat {
        Beat {
            custom_mode: 0,
            mav_type: MavType::MAV_TYPE_QUADROTOR as u8,
            autopilot: 3,
            base_mode: 0,
            system_status: status,
        }
    }

    #[test]
    fn gcs_heartbeat_at_1hz_and_lost_after_3s_then_regained() {
        let v = Endpoint::new(1, crate::proto::AUTOPILOT_COMPID);
        let mut l = Liveness::new(Endpoint::gcs(), LivenessConfig::default(), Time::ZERO);
        let mut beats = 0;
        let mut events = Vec::new();
        l.handle_heartbeat(v, &beat(3), Time::ZERO);
        let mut now = Time::ZERO;
        while l.poll_timeout().unwrap() < Time::from_millis(5500) {
            now = l.poll_timeout().unwrap();
            l.handle_timeout(now);
            while l.poll_transmit().is_some() {
                beats += 1;
            }
            while let Some(e) = l.poll_event() {
                events.push((now, e));
            }
        }
        assert_eq!(beats, 6); // t = 0, 1, 2, 3, 4, 5
        assert!(events.contains(&(Time::from_secs(3), LivenessEvent::Lost { who: v })));
        assert!(!l.is_alive(v));
        l.handle_heartbeat(v, &beat(3), now);
        assert_eq!(l.poll_event(), Some(LivenessEvent::Regained { who: v }));
        assert!(l.is_alive(v));
    }

    #[test]
    fn reboot_detected_by_boot_clock_and_boot_state() {
        let v = Endpoint::new(1, crate::proto::AUTOPILOT_COMPID);
        let mut l = Liveness::new(Endpoint::gcs(), LivenessConfig::default(), Time::ZERO);
        l.handle_heartbeat(v, &beat(4), Time::ZERO);
        let _ = l.poll_event();
        let st = |ms| {
            MavMessage::SYSTEM_TIME(SYSTEM_TIME_DATA {
                time_unix_usec: 0,
                time_boot_ms: ms,
            })
        };
        l.handle_message(v, &st(60_000), Time::ZERO);
        l.handle_message(v, &st(59_500), Time::ZERO); // reordered: not a reboot
        assert_eq!(l.poll_event(), None);
        l.handle_message(v, &st(2_000), Time::ZERO);
        assert_eq!(l.poll_event(), Some(LivenessEvent::Rebooted { who: v }));
        l.handle_heartbeat(v, &beat(MAV_STATE_BOOT), Time::ZERO);
        assert_eq!(l.poll_event(), Some(LivenessEvent::Rebooted { who: v }));
    }

    #[test]
    fn lenient_heartbeat_keeps_unknown_numbers() {
        let b = Beat::from_payload(&[4, 0, 0, 0, 250, 3, 0x81]);
        assert_eq!(b.custom_mode, 4);
        assert_eq!(b.mav_type, 250);
        assert!(b.armed());
        assert_eq!(b.system_status, 0);
    }
}
