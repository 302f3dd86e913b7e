//! Scheduled faults: what goes wrong on a field day, at a given simulated time, on one vehicle
//! or on all of them — the link goes dark, the battery drops, the camera dies (and maybe comes
//! back) or slows down, a vehicle gets stuck.
//!
//! A schedule is written as text (`fleetmap sim --fault`, `fleetmap demo --fault`, a test's
//! [`crate::harness::SimConfig::faults`]):
//!
//! ```text
//! ENTRY[,ENTRY…]      ENTRY = TARGET:FAULT[@START[..END]]
//! TARGET = K (the K-th vehicle of the --vehicles spec, system id K) | all
//! FAULT  = outage | battery=PERCENT | camera=off | camera-rate=BYTES_PER_S
//!        | camera-interval=SECONDS | stuck
//! START, END = simulated time since the simulation started: 300, 300s, 5m, 1.5m, 2m30s
//! ```
//!
//! e.g. `2:battery=20@300s`, `1:camera=off@200s..400s`, `3:camera-rate=20000`,
//! `5:stuck@100s`, `all:outage@120s..420s`. Without `@START` the fault holds from the start;
//! without `..END` it never ends. A battery does not recharge by itself, so `battery=` takes no
//! end. What each fault does, and which real-autopilot behaviour it follows, is on [`Fault`]
//! and in docs/simulator.md ("Scheduled faults").
//!
//! The harness ([`crate::harness::Sim`]) applies a schedule as its clock passes each start and
//! end, at the first 20 Hz tick at or after it: the same schedule and seed give the same run.
//! An outage becomes a blackout window of the vehicle's link in both directions
//! ([`fleetmap_io::link::faults::LinkFaults::blackouts`]); the other faults act on the vehicle
//! (`FaultPlan`).

use fleetmap_core::time::Time;
use std::fmt;
use std::str::FromStr;
use std::time::Duration;
use thiserror::Error;

/// A fault spec that does not parse, or that names what the simulation does not have.
#[derive(Clone, Debug, Error, PartialEq)]
#[error("invalid fault {spec:?}: {reason}")]
pub struct FaultSpecError {
    /// The entry (or the whole spec, when it is empty).
    pub spec: String,
    /// What is wrong with it.
    pub reason: String,
}

/// Which vehicles a fault hits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FaultTarget {
    /// Every vehicle (camera faults: every vehicle with a camera).
    All,
    /// The K-th vehicle of the simulation, 1-based, in the order of the vehicle spec (the
    /// harness gives it system id K).
    Vehicle(usize),
}

/// What goes wrong.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fault {
    /// The vehicle's link carries nothing, either way, until the end: a radio out of range or
    /// a dead telemetry modem. The vehicle flies on and reacts as its autopilot does to a lost
    /// GCS (the simulated PX4's data-link-loss failsafe, NAV_DLL_ACT after COM_DL_LOSS_T; the
    /// simulated ArduPilot has FS_GCS_ENABLE 0, its default, and carries on).
    Outage,
    /// The battery's charge drops to this percentage of its capacity (0–100), at once: a
    /// failing cell, a pack that was not full, a cold battery. The autopilot's own battery
    /// failsafe then acts as it would at that level (ArduPilot: BATT_LOW_MAH → "Battery 1 is
    /// low" and RTL, BATT_CRT_MAH → land; PX4: "Critical battery level! Executing RTL").
    /// ArduPilot SITL does the same with SIM_BATT_VOLTAGE / SIM_BATT_CAP_AH, PX4 SITL with
    /// SIM_BAT_MIN_PCT changed in flight. A level above the charge left changes nothing.
    Battery {
        /// Charge left, percent of capacity.
        percent: f64,
    },
    /// The camera component (MAVLink component 100) stops: no heartbeat, no captures, no
    /// answers to commands, and what it was sending is lost. At the end it comes back as a
    /// camera that rebooted: a new boot, an empty queue, its heartbeat again. The autopilot
    /// keeps routing to it and says nothing (ArduPilot's AP_Camera_MAVLinkCamV2 looks for its
    /// camera only after boot and forwards camera commands to the component it found).
    CameraOff,
    /// The camera's image transmission is paced to this many bytes per second
    /// ([`fleetmap_camera::camera::CameraConfig::transfer_rate_bps`]); at the end, back to its
    /// configured pacing.
    CameraRate {
        /// Bytes per second of MAVLink 2 frames.
        bytes_per_s: f64,
    },
    /// The camera needs at least this long between two pictures
    /// ([`fleetmap_camera::camera::CameraConfig::min_interval_s`]): a camera slower than the samples
    /// the GCS asks for; asked faster, it takes them late, one per interval. At the end, back
    /// to its configured interval.
    CameraInterval {
        /// Minimum seconds between two captures.
        seconds: f64,
    },
    /// The vehicle makes no horizontal progress: wheels in mud, a rover hung up on a rock.
    /// It keeps its mode, its target and its telemetry, answers commands, and a copter can
    /// still climb and descend; its position stays where it is until the end. ArduRover's
    /// crash check (`Rover::crash_check`: blocked when slower than 0.08 m/s with throttle
    /// above 5 % for 2 s) is off by default (FS_CRASH_CHECK 0), so the real rover, like this
    /// one, keeps trying without a word.
    Stuck,
}

impl Fault {
    /// Whether the fault concerns the camera component.
    fn is_camera(&self) -> bool {
        matches!(
            self,
            Fault::CameraOff | Fault::CameraRate { .. } | Fault::CameraInterval { .. }
        )
    }
}

impl fmt::Display for Fault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Fault::Outage => write!(f, "outage"),
            Fault::Battery { percent } => write!(f, "battery={percent}"),
            Fault::CameraOff => write!(f, "camera=off"),
            Fault::CameraRate { bytes_per_s } => write!(f, "camera-rate={bytes_per_s}"),
            Fault::CameraInterval { seconds } => write!(f, "camera-interval={seconds}"),
            Fault::Stuck => write!(f, "stuck"),
        }
    }
}

/// One entry of a schedule: a fault on some vehicles from a time, maybe until a later one.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ScheduledFault {
    /// Which vehicles.
    pub target: FaultTarget,
    /// What.
    pub fault: Fault,
    /// When it starts, simulated time since the simulation started.
    pub from: Duration,
    /// When it ends (after `from`); `None`: never.
    pub until: Option<Duration>,
}

impl fmt::Display for ScheduledFault {
    /// The spec this entry parses from (times in seconds).
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.target {
            FaultTarget::All => write!(f, "all:")?,
            FaultTarget::Vehicle(k) => write!(f, "{k}:")?,
        }
        write!(f, "{}@{}s", self.fault, self.from.as_secs_f64())?;
        if let Some(u) = self.until {
            write!(f, "..{}s", u.as_secs_f64())?;
        }
        Ok(())
    }
}

impl FromStr for ScheduledFault {
    type Err = FaultSpecError;

    /// One entry: `TARGET:FAULT[@START[..END]]` (see the module documentation).
    fn from_str(s: &str) -> Result<ScheduledFault, FaultSpecError> {
        let entry = s.trim();
        let err = |reason: String| FaultSpecError {
            spec: entry.to_string(),
            reason,
        };
        let (target, rest) = entry
            .split_once(':')
            .ok_or_else(|| err("expected TARGET:FAULT, e.g. 2:battery=20@300s".into()))?;
        let target = match target.trim() {
            t if t.eq_ignore_ascii_case("all") => FaultTarget::All,
            t => match t.parse::<usize>() {
                Ok(k) if (1..=250).contains(&k) => FaultTarget::Vehicle(k),
                _ => {
                    return Err(err(format!(
                        "target {t:?}: expected a vehicle number 1–250 or `all`"
                    )));
                }
            },
        };
        let (fault, when) = match rest.split_once('@') {
            Some((f, w)) => (f.trim(), Some(w.trim())),
            None => (rest.trim(), None),
        };
        let fault = parse_fault(fault).map_err(err)?;
        let (from, until) = match when {
            None => (Duration::ZERO, None),
            Some(w) => match w.split_once("..") {
                Some((a, b)) => (
                    parse_time(a).map_err(&err)?,
                    Some(parse_time(b).map_err(&err)?),
                ),
                None => (parse_time(w).map_err(&err)?, None),
            },
        };
        if let Some(u) = until {
            if u <= from {
                return Err(err(format!(
                    "it ends ({}s) before it starts ({}s)",
                    u.as_secs_f64(),
                    from.as_secs_f64()
                )));
            }
            if matches!(fault, Fault::Battery { .. }) {
                return Err(err(
                    "a battery does not recharge by itself: battery= takes no end time".into(),
                ));
            }
        }
        Ok(ScheduledFault {
            target,
            fault,
            from,
            until,
        })
    }
}

/// A positive, finite number, or why not.
fn positive(what: &str, v: &str) -> Result<f64, String> {
    match v.trim().parse::<f64>() {
        Ok(x) if x.is_finite() && x > 0.0 => Ok(x),
        _ => Err(format!("{what} {v:?}: expected a positive number")),
    }
}

/// The FAULT part of an entry.
fn parse_fault(s: &str) -> Result<Fault, String> {
    let (name, value) = match s.split_once('=') {
        Some((n, v)) => (n.trim().to_ascii_lowercase(), Some(v.trim())),
        None => (s.trim().to_ascii_lowercase(), None),
    };
    let needs = |what: &str| format!("{name} needs a value: {name}={what}");
    match (name.as_str(), value) {
        ("outage", None) => Ok(Fault::Outage),
        ("stuck", None) => Ok(Fault::Stuck),
        ("outage" | "stuck", Some(_)) => Err(format!("{name} takes no value")),
        ("battery", Some(v)) => {
            let p = v.strip_suffix('%').unwrap_or(v).trim();
            match p.parse::<f64>() {
                Ok(p) if (0.0..100.0).contains(&p) => Ok(Fault::Battery { percent: p }),
                _ => Err(format!(
                    "battery {v:?}: expected the charge left, a percentage from 0 to below 100"
                )),
            }
        }
        ("battery", None) => Err(needs("PERCENT")),
        ("camera", Some(v)) if v.eq_ignore_ascii_case("off") => Ok(Fault::CameraOff),
        ("camera", _) => {
            Err("expected camera=off (with @START..END to bring it back, as after a reboot)".into())
        }
        ("camera-rate", Some(v)) => Ok(Fault::CameraRate {
            bytes_per_s: positive("camera-rate", v)?,
        }),
        ("camera-rate", None) => Err(needs("BYTES_PER_S")),
        ("camera-interval", Some(v)) => Ok(Fault::CameraInterval {
            seconds: positive("camera-interval", v.strip_suffix('s').unwrap_or(v))?,
        }),
        ("camera-interval", None) => Err(needs("SECONDS")),
        _ => Err(format!(
            "unknown fault {s:?}: expected outage, battery=PERCENT, camera=off, \
             camera-rate=BYTES_PER_S, camera-interval=SECONDS or stuck"
        )),
    }
}

/// Longest schedule time accepted, seconds (a year of simulated time).
const MAX_TIME_S: f64 = 365.0 * 24.0 * 3600.0;

/// A time since the start: seconds (`300`, `300s`, `2.5s`), minutes (`5m`, `1.5m`) or both
/// (`2m30s`).
fn parse_time(s: &str) -> Result<Duration, String> {
    let t = s.trim();
    let bad = || format!("time {t:?}: expected seconds or minutes, e.g. 300s, 5m or 2m30s");
    let num = |x: &str| -> Result<f64, String> {
        match x.parse::<f64>() {
            Ok(v) if v.is_finite() && v >= 0.0 => Ok(v),
            _ => Err(bad()),
        }
    };
    if t.is_empty() {
        return Err(bad());
    }
    let secs = if let Some((m, rest)) = t.split_once('m') {
        let s = rest.strip_suffix('s').unwrap_or(rest);
        let s = if s.is_empty() { 0.0 } else { num(s)? };
        if !rest.is_empty() && !rest.ends_with('s') {
            return Err(bad());
        }
        num(m)? * 60.0 + s
    } else {
        num(t.strip_suffix('s').unwrap_or(t))?
    };
    if secs > MAX_TIME_S {
        return Err(format!("time {t:?}: more than a year"));
    }
    // to the microsecond, the simulation's resolution
    Ok(Duration::from_micros((secs * 1e6).round() as u64))
}

/// Parse a schedule: entries separated by commas (see the module documentation). An empty
/// spec is an error.
pub fn parse_faults(spec: &str) -> Result<Vec<ScheduledFault>, FaultSpecError> {
    let entries: Vec<&str> = spec
        .split(',')
        .map(str::trim)
        .filter(|e| !e.is_empty())
        .collect();
    if entries.is_empty() {
        return Err(FaultSpecError {
            spec: spec.to_string(),
            reason: "no fault given".into(),
        });
    }
    entries.into_iter().map(str::parse).collect()
}

/// What the harness does to one vehicle when the schedule says so (the harness applies it:
/// `harness::apply_fault`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Action {
    /// Drop the battery to this percentage.
    Battery(f64),
    /// Camera failed (true) or back (false).
    CameraFailed(bool),
    /// Pace the camera's transfers to this rate (`None`: its configured pacing).
    CameraRate(Option<f64>),
    /// The camera's minimum interval (`None`: its configured one).
    CameraInterval(Option<f64>),
    /// Stuck (true) or free (false).
    Stuck(bool),
}

/// A fault of the schedule started (`started`) or ended on a vehicle: what the harness
/// announces.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Transition {
    /// The fault.
    pub(crate) fault: Fault,
    /// Whether it started (else it ended).
    pub(crate) started: bool,
}

/// One entry resolved to one vehicle (its index in the simulation) on the simulation's
/// timeline.
#[derive(Clone, Debug)]
struct Resolved {
    vehicle: usize,
    fault: Fault,
    from: Time,
    until: Option<Time>,
}

impl Resolved {
    fn active(&self, t: Time) -> bool {
        self.from <= t && self.until.is_none_or(|u| t < u)
    }
}

/// The state the schedule last put a vehicle in.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
struct Applied {
    camera_failed: bool,
    stuck: bool,
    rate: Option<f64>,
    interval: Option<f64>,
}

/// What passing some starts and ends brings: the actions on the vehicles and the transitions
/// to announce, each with its vehicle's index.
pub(crate) type Step = (Vec<(usize, Action)>, Vec<(usize, Transition)>);

/// A schedule resolved against a simulation's vehicles: which vehicle changes how at which
/// time. Overlapping windows combine: the camera is off, or the vehicle stuck, while any
/// window says so; of several camera-rate (or camera-interval) windows the one that started
/// last holds.
#[derive(Clone, Debug, Default)]
pub(crate) struct FaultPlan {
    entries: Vec<Resolved>,
    /// Every start and end, sorted, without repeats.
    times: Vec<Time>,
    /// The first of `times` not yet passed.
    next: usize,
    applied: Vec<Applied>,
}

impl FaultPlan {
    /// Resolve `schedule` for vehicles whose cameras are `has_camera` (one per vehicle, in
    /// order) on a simulation that starts at `start`.
    pub(crate) fn new(
        schedule: &[ScheduledFault],
        has_camera: &[bool],
        start: Time,
    ) -> Result<FaultPlan, FaultSpecError> {
        let n = has_camera.len();
        let mut entries = Vec::new();
        for s in schedule {
            let err = |reason: String| FaultSpecError {
                spec: s.to_string(),
                reason,
            };
            let vehicles: Vec<usize> = match s.target {
                FaultTarget::Vehicle(k) if k == 0 || k > n => {
                    return Err(err(format!(
                        "there is no vehicle {k}: the simulation has {n}"
                    )));
                }
                FaultTarget::Vehicle(k) => {
                    if s.fault.is_camera() && !has_camera[k - 1] {
                        return Err(err(format!("vehicle {k} has no camera")));
                    }
                    vec![k - 1]
                }
                FaultTarget::All => {
                    let all: Vec<usize> = (0..n)
                        .filter(|&i| !s.fault.is_camera() || has_camera[i])
                        .collect();
                    if all.is_empty() {
                        return Err(err("no vehicle has a camera".into()));
                    }
                    all
                }
            };
            for vehicle in vehicles {
                entries.push(Resolved {
                    vehicle,
                    fault: s.fault,
                    from: start + s.from,
                    until: s.until.map(|u| start + u),
                });
            }
        }
        let mut times: Vec<Time> = entries
            .iter()
            .flat_map(|e| std::iter::once(e.from).chain(e.until))
            .collect();
        times.sort();
        times.dedup();
        Ok(FaultPlan {
            entries,
            times,
            next: 0,
            applied: vec![Applied::default(); n],
        })
    }

    /// The outage windows of vehicle `i`: the blackouts of its link, both ways.
    pub(crate) fn outages(&self, i: usize) -> Vec<(Time, Time)> {
        self.entries
            .iter()
            .filter(|e| e.vehicle == i && e.fault == Fault::Outage)
            .map(|e| (e.from, e.until.unwrap_or(Time::from_micros(u64::MAX))))
            .collect()
    }

    /// Whether a start or an end has come by `t`.
    pub(crate) fn due(&self, t: Time) -> bool {
        self.times.get(self.next).is_some_and(|&b| b <= t)
    }

    /// The starts and ends passed by `t` (all of them since the last call): the actions on
    /// the vehicles, by index, and the transitions to announce (a fault started or ended).
    pub(crate) fn step(&mut self, t: Time) -> Step {
        let since = self.next;
        while self.times.get(self.next).is_some_and(|&b| b <= t) {
            self.next += 1;
        }
        let passed_times = self.times.get(since..self.next).unwrap_or_default();
        let (Some(&lo), Some(&hi)) = (passed_times.first(), passed_times.last()) else {
            return (Vec::new(), Vec::new());
        };
        let passed = |x: Time| lo <= x && x <= hi;
        let mut events = Vec::new();
        let mut actions = Vec::new();
        for e in &self.entries {
            if passed(e.from) {
                events.push((
                    e.vehicle,
                    Transition {
                        fault: e.fault,
                        started: true,
                    },
                ));
                if let Fault::Battery { percent } = e.fault {
                    actions.push((e.vehicle, Action::Battery(percent)));
                }
            }
            if e.until.is_some_and(passed) {
                events.push((
                    e.vehicle,
                    Transition {
                        fault: e.fault,
                        started: false,
                    },
                ));
            }
        }
        for (i, applied) in self.applied.iter_mut().enumerate() {
            let active = || {
                self.entries
                    .iter()
                    .filter(|e| e.vehicle == i && e.active(t))
            };
            // of overlapping windows, the one that started last (then the later entry)
            let latest = |pick: fn(&Fault) -> Option<f64>| {
                active()
                    .filter_map(|e| pick(&e.fault).map(|v| (e.from, v)))
                    .fold(None, |best: Option<(Time, f64)>, c| match best {
                        Some(b) if b.0 > c.0 => Some(b),
                        _ => Some(c),
                    })
                    .map(|(_, v)| v)
            };
            let now = Applied {
                camera_failed: active().any(|e| e.fault == Fault::CameraOff),
                stuck: active().any(|e| e.fault == Fault::Stuck),
                rate: latest(|f| match f {
                    Fault::CameraRate { bytes_per_s } => Some(*bytes_per_s),
                    _ => None,
                }),
                interval: latest(|f| match f {
                    Fault::CameraInterval { seconds } => Some(*seconds),
                    _ => None,
                }),
            };
            if now.camera_failed != applied.camera_failed {
                actions.push((i, Action::CameraFailed(now.camera_failed)));
            }
            if now.stuck != applied.stuck {
                actions.push((i, Action::Stuck(now.stuck)));
            }
            if now.rate != applied.rate {
                actions.push((i, Action::CameraRate(now.rate)));
            }
            if now.interval != applied.interval {
                actions.push((i, Action::CameraInterval(now.interval)));
            }
            *applied = now;
        }
        (actions, events)
    }
}

#[cfg(test)]
mod flights;
#[cfg(test)]
mod tests;
