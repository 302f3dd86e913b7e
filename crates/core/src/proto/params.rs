//! Reading a few of a vehicle's parameters by name (the MAVLink parameter protocol's
//! PARAM_REQUEST_READ / PARAM_VALUE), retried with back-off over a lossy link.
//!
//! A ground station that downloads the whole list (PARAM_REQUEST_LIST: about 1,240 values
//! from ArduCopter 4.7 SITL, 1,370 from ArduRover, 37 bytes each on the wire) spends 45 kB on a
//! vehicle — more than 20 seconds of a 2 kB/s telemetry radio, all of it shared with the
//! telemetry. The fleet check needs about a dozen values, so it asks for each by name
//! (PARAM_REQUEST_READ with `param_index` −1): a few hundred bytes.
//!
//! How the reference implementations read one parameter, which this follows:
//! * pymavlink (`mavutil.py`, `param_fetch_one`) sends one PARAM_REQUEST_READ and leaves
//!   waiting and retrying to the caller;
//! * QGroundControl (`src/FactSystem/ParameterManager.h`, `_maxReadWriteRetry = 5`) sends a
//!   read again on its timer, up to five retries, then gives the parameter up.
//!
//! Here: at most [`ParamConfig::window`] names are asked at once (one on a radio, so the
//! answers never queue behind each other), each answer matched by its name (PARAM_VALUE
//! carries the name, not the request's index), a request not answered within its timeout is
//! sent again with the timeout doubled up to [`ParamConfig::max_timeout`], and after
//! [`ParamConfig::attempts`] sends the name is reported [`ParamEvent::Missing`]: the
//! autopilot does not have it (an older or other firmware: ArduPilot answers nothing for an
//! unknown name, PX4 1.16 a PARAM_ERROR or nothing) or the link lost every try.
//!
//! Sans-IO like the other machines ([`crate::proto`]): `handle_message`, `handle_timeout`,
//! `poll_transmit`, `poll_timeout`, `poll_event`.

use super::Endpoint;
use crate::time::Time;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::VecDeque;
use std::time::Duration;

/// How patiently parameters are read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamConfig {
    /// Names asked at once.
    pub window: usize,
    /// The first wait for an answer.
    pub timeout: Duration,
    /// The longest wait: each retry doubles the last, up to this.
    pub max_timeout: Duration,
    /// Sends of one request (the first and the retries) before the name is given up.
    pub attempts: u32,
}

impl ParamConfig {
    /// A link that carries whatever is sent (Wi-Fi, a cable, a simulator): the dozen names
    /// the fleet check reads all at once, a second's wait doubling to four, four sends (an
    /// autopilot that answers none of them is known in 11 s).
    pub const FAST: ParamConfig = ParamConfig {
        window: 16,
        timeout: Duration::from_secs(1),
        max_timeout: Duration::from_secs(4),
        attempts: 4,
    };
    /// A telemetry radio: one name at a time, waits from 1.5 s to 8 s (a radio's buffer
    /// holds seconds of telemetry ahead of the answer), six sends.
    pub const RADIO: ParamConfig = ParamConfig {
        window: 1,
        timeout: Duration::from_millis(1500),
        max_timeout: Duration::from_secs(8),
        attempts: 6,
    };
}

/// What the reader learnt.
#[derive(Clone, Debug, PartialEq)]
pub enum ParamEvent {
    /// The parameter's value (PARAM_VALUE.param_value: every type is carried as a float).
    Value {
        /// Its name.
        name: String,
        /// Its value.
        value: f32,
    },
    /// No answer after [`ParamConfig::attempts`] sends.
    Missing {
        /// Its name.
        name: String,
    },
}

/// One name being asked.
#[derive(Clone, Debug)]
struct Asked {
    name: String,
    sends: u32,
    wait: Duration,
    deadline: Time,
}

/// Reads a list of parameters of one component by name.
#[derive(Debug)]
pub struct ParamReader {
    target: Endpoint,
    cfg: ParamConfig,
    queued: VecDeque<String>,
    asked: Vec<Asked>,
    outbox: VecDeque<MavMessage>,
    events: VecDeque<ParamEvent>,
    sent: u32,
}

/// A parameter name as MAVLink carries it: at most 16 bytes, NUL-padded.
pub fn param_id(name: &str) -> mavlink::types::CharArray<16> {
    let mut b = [0u8; 16];
    for (d, s) in b.iter_mut().zip(name.bytes()) {
        *d = s;
    }
    b.into()
}

/// The name in a MAVLink parameter id (up to the first NUL; lossy on bad UTF-8).
pub fn param_name(id: &mavlink::types::CharArray<16>) -> String {
    let bytes: &[u8] = &id[..];
    let end = bytes.iter().position(|&c| c == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).into_owned()
}

impl ParamReader {
    /// Read `names` (duplicates asked once) from `target`, starting at `now`.
    pub fn new(target: Endpoint, names: &[&str], cfg: ParamConfig, now: Time) -> ParamReader {
        let mut queued: VecDeque<String> = VecDeque::new();
        for n in names {
            if !queued.iter().any(|q| q == n) {
                queued.push_back((*n).to_string());
            }
        }
        let mut r = ParamReader {
            target,
            cfg: ParamConfig {
                window: cfg.window.max(1),
                attempts: cfg.attempts.max(1),
                ..cfg
            },
            queued,
            asked: Vec::new(),
            outbox: VecDeque::new(),
            events: VecDeque::new(),
            sent: 0,
        };
        r.fill(now);
        r
    }

    /// PARAM_REQUEST_READ messages sent so far (first sends and retries).
    pub fn requests_sent(&self) -> u32 {
        self.sent
    }

    /// Whether every name was answered or given up.
    pub fn is_done(&self) -> bool {
        self.queued.is_empty() && self.asked.is_empty()
    }

    fn request(&mut self, name: &str) {
        self.sent += 1;
        self.outbox.push_back(MavMessage::PARAM_REQUEST_READ(
            mav::PARAM_REQUEST_READ_DATA {
                param_index: -1,
                target_system: self.target.sysid,
                target_component: self.target.compid,
                param_id: param_id(name),
            },
        ));
    }

    fn fill(&mut self, now: Time) {
        while self.asked.len() < self.cfg.window {
            let Some(name) = self.queued.pop_front() else {
                break;
            };
            self.request(&name);
            self.asked.push(Asked {
                name,
                sends: 1,
                wait: self.cfg.timeout,
                deadline: now + self.cfg.timeout,
            });
        }
    }

    /// A message from `from`: a PARAM_VALUE of the target answers the name it carries
    /// (whatever asked for it: an answer to another GCS's request counts too).
    pub fn handle_message(&mut self, from: Endpoint, msg: &MavMessage, now: Time) {
        let MavMessage::PARAM_VALUE(v) = msg else {
            return;
        };
        if from.sysid != self.target.sysid
            || (self.target.compid != 0 && from.compid != self.target.compid)
        {
            return;
        }
        let name = param_name(&v.param_id);
        if let Some(i) = self.asked.iter().position(|a| a.name == name) {
            self.asked.remove(i);
        } else if let Some(i) = self.queued.iter().position(|q| *q == name) {
            self.queued.remove(i);
        } else {
            return;
        }
        self.events.push_back(ParamEvent::Value {
            name,
            value: v.param_value,
        });
        self.fill(now);
    }

    /// Send again what timed out, give up what has used its attempts.
    pub fn handle_timeout(&mut self, now: Time) {
        let mut i = 0;
        while i < self.asked.len() {
            if self.asked[i].deadline > now {
                i += 1;
                continue;
            }
            if self.asked[i].sends >= self.cfg.attempts {
                let a = self.asked.remove(i);
                self.events.push_back(ParamEvent::Missing { name: a.name });
                continue;
            }
            let name = self.asked[i].name.clone();
            self.request(&name);
            let a = &mut self.asked[i];
            a.sends += 1;
            a.wait = (a.wait * 2).min(self.cfg.max_timeout);
            a.deadline = now + a.wait;
            i += 1;
        }
        self.fill(now);
    }

    /// The next message to send.
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.outbox.pop_front()
    }

    /// When [`ParamReader::handle_timeout`] is next due.
    pub fn poll_timeout(&self) -> Option<Time> {
        self.asked.iter().map(|a| a.deadline).min()
    }

    /// The next value or give-up.
    pub fn poll_event(&mut self) -> Option<ParamEvent> {
        self.events.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn value(name: &str, v: f32) -> MavMessage {
        MavMessage::PARAM_VALUE(mav::PARAM_VALUE_DATA {
            param_value: v,
            param_count: 1,
            param_index: 0,
            param_id: param_id(name),
            param_type: mav::MavParamType::MAV_PARAM_TYPE_REAL32,
        })
    }

    fn asked(m: &MavMessage) -> String {
        match m {
            MavMessage::PARAM_REQUEST_READ(r) => {
                assert_eq!(r.param_index, -1);
                param_name(&r.param_id)
            }
            other => panic!("not a read: {other:?}"),
        }
    }

    #[test]
    fn names_round_trip_through_the_sixteen_bytes() {
        assert_eq!(param_name(&param_id("FS_GCS_ENABLE")), "FS_GCS_ENABLE");
        // exactly 16 characters: no terminating NUL on the wire
        assert_eq!(
            param_name(&param_id("ABCDEFGHIJKLMNOP")),
            "ABCDEFGHIJKLMNOP"
        );
    }

    #[test]
    fn asks_a_window_at_a_time_and_reports_each_answer() {
        let ap = Endpoint::new(3, crate::proto::AUTOPILOT_COMPID);
        let cfg = ParamConfig {
            window: 2,
            ..ParamConfig::FAST
        };
        let t0 = Time::from_secs(10);
        let mut r = ParamReader::new(ap, &["A", "B", "C", "A"], cfg, t0);
        let first: Vec<String> = std::iter::from_fn(|| r.poll_transmit())
            .map(|m| asked(&m))
            .collect();
        assert_eq!(first, ["A", "B"]);
        // another system's answer, and an answer to nothing asked, are ignored
        r.handle_message(
            Endpoint::new(4, crate::proto::AUTOPILOT_COMPID),
            &value("A", 1.0),
            t0,
        );
        r.handle_message(ap, &value("Z", 1.0), t0);
        assert!(r.poll_event().is_none());
        r.handle_message(ap, &value("B", 2.0), t0);
        assert_eq!(
            r.poll_event(),
            Some(ParamEvent::Value {
                name: "B".into(),
                value: 2.0
            })
        );
        assert_eq!(r.poll_transmit().map(|m| asked(&m)).as_deref(), Some("C"));
        r.handle_message(ap, &value("A", 1.0), t0);
        r.handle_message(ap, &value("C", 3.0), t0);
        assert!(r.is_done());
        assert_eq!(r.requests_sent(), 3);
    }

    #[test]
    fn retries_with_doubling_waits_then_gives_up() {
        let ap = Endpoint::new(1, crate::proto::AUTOPILOT_COMPID);
        let cfg = ParamConfig {
            window: 1,
            timeout: Duration::from_secs(1),
            max_timeout: Duration::from_secs(3),
            attempts: 4,
        };
        let mut now = Time::from_secs(0);
        let mut r = ParamReader::new(ap, &["X"], cfg, now);
        let mut sends = Vec::new();
        while !r.is_done() {
            while let Some(m) = r.poll_transmit() {
                assert_eq!(asked(&m), "X");
                sends.push(now.as_secs_f64());
            }
            now = r.poll_timeout().expect("a timer while asking");
            r.handle_timeout(now);
        }
        // waits 1, 2, 3 (capped), 3: sends at 0, 1, 3, 6 and the give-up at 9
        assert_eq!(sends, [0.0, 1.0, 3.0, 6.0]);
        assert_eq!(now, Time::from_secs(9));
        assert_eq!(
            r.poll_event(),
            Some(ParamEvent::Missing { name: "X".into() })
        );
    }

    #[test]
    fn reads_everything_over_a_link_that_loses_most_frames() {
        // a deterministic 60 % loss each way: every name is still read within its attempts
        let ap = Endpoint::new(2, crate::proto::AUTOPILOT_COMPID);
        let names = [
            "FS_GCS_ENABLE",
            "RTL_ALT",
            "FENCE_ENABLE",
            "BATT_FS_LOW_ACT",
        ];
        let mut r = ParamReader::new(ap, &names, ParamConfig::RADIO, Time::from_secs(0));
        let mut now = Time::from_secs(0);
        let mut k = 0u32;
        let mut lossy = move || {
            k += 1;
            k % 5 < 3
        };
        let mut got = Vec::new();
        for _ in 0..1000 {
            while let Some(m) = r.poll_transmit() {
                let name = asked(&m);
                if !lossy() && !lossy() {
                    r.handle_message(ap, &value(&name, 1.0), now);
                }
            }
            while let Some(e) = r.poll_event() {
                got.push(e);
            }
            if r.is_done() {
                break;
            }
            now = r.poll_timeout().unwrap_or(now);
            r.handle_timeout(now);
        }
        assert_eq!(got.len(), names.len());
        assert!(got.iter().all(|e| matches!(e, ParamEvent::Value { .. })));
    }
}
