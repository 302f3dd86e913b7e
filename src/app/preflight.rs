//! The fleet check before take-off, on a connected fleet: read what
//! [`fleetmap_core::preflight`] needs from every vehicle of the mission (heartbeat, the
//! sysid watch's verdict, a camera's heartbeat, home, link, a few parameters by name through
//! [`fleetmap_core::proto::params`]), run the pure check, and gate a run's start on it.
//!
//! Every door that starts or resumes a run goes through [`crate::launch::prepare`],
//! which calls [`gate`]: the findings are logged, and a blocker stops the start unless the
//! operator said `--ignore-check`. `fleetmap check --connect` prints them ([`run_check`]).
//! In the terminal UI with a run the operator starts, the findings are in the log pane and
//! a blocker waits for START instead, which checks the fleet again ([`StartCheck`]): the
//! operator fixes what it says while looking at the fleet, and starts when nothing blocks.

use crate::app::error::RunError;
use crate::fleet::FleetHandle;
use fleetmap_core::mission::definition::{MissionDef, Role};
use fleetmap_core::preflight::{self, Finding, Severity, VehicleReport, names};
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::flavour::{Autopilot, Flavour};
use fleetmap_core::proto::params::{ParamConfig, ParamEvent, ParamReader};
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::BTreeMap;
use std::time::Duration;

/// How long the check waits, after a vehicle is heard, for the sysid watch's verdict and a
/// drone's camera heartbeat (the camera protocol's 1 Hz, relayed by the autopilot).
pub(crate) const SETTLE: Duration = Duration::from_secs(6);

/// Read `names` from `target` (an autopilot whose values are byte-wise integers when
/// `bytewise`): values, and the names not answered.
async fn read_params(
    fleet: &FleetHandle,
    target: Endpoint,
    names: &[&str],
    cfg: ParamConfig,
    bytewise: bool,
) -> (BTreeMap<String, f32>, Vec<String>) {
    let mut rx = fleet.subscribe();
    let clock = fleet.clock().clone();
    let mut reader = ParamReader::new(target, names, cfg, clock.now());
    let mut values = BTreeMap::new();
    let mut missing = Vec::new();
    loop {
        while let Some(m) = reader.poll_transmit() {
            // a send that fails (the fleet stopping, a conflict) is one more lost request
            let _ = fleet.send(m).await;
        }
        while let Some(e) = reader.poll_event() {
            match e {
                ParamEvent::Value { name, value } => {
                    values.insert(name, value);
                }
                ParamEvent::Missing { name } => missing.push(name),
            }
        }
        if reader.is_done() {
            break;
        }
        let wait = reader
            .poll_timeout()
            .map_or(Duration::from_millis(100), |t| clock.wall_until(t));
        tokio::select! {
            biased;
            got = rx.recv() => match got {
                Ok(inc) => {
                    if let Ok(msg) = &inc.frame.message {
                        let from = Endpoint::of(&inc.frame.header);
                        if let MavMessage::PARAM_VALUE(v) = msg
                            && bytewise
                            && !matches!(
                                v.param_type,
                                mavlink::dialects::ardupilotmega::MavParamType::MAV_PARAM_TYPE_REAL32
                                    | mavlink::dialects::ardupilotmega::MavParamType::MAV_PARAM_TYPE_REAL64
                            )
                        {
                            let mut v = v.clone();
                            v.param_value = v.param_value.to_bits() as i32 as f32;
                            reader.handle_message(from, &MavMessage::PARAM_VALUE(v), clock.now());
                        } else {
                            reader.handle_message(from, msg, clock.now());
                        }
                    }
                }
                Err(tokio::sync::broadcast::error::RecvError::Lagged(_)) => {}
                Err(_) => break,
            },
            _ = tokio::time::sleep(wait) => reader.handle_timeout(clock.now()),
        }
    }
    (values, missing)
}

/// What the check needs from vehicle `sysid`: waits up to `wait` for it to be heard and
/// for the sysid watch's verdict (as a run's start does: `app::team::one_autopilot`), reads its
/// parameters, then waits up to [`SETTLE`] for a drone's camera and up to `home_wait` for
/// a copter's home (not for an autopilot that answered nothing: it obeys nobody here).
async fn report(
    fleet: &FleetHandle,
    sysid: u8,
    drone: bool,
    wait: Duration,
    home_wait: Duration,
) -> VehicleReport {
    let mut r = VehicleReport {
        sysid,
        ..VehicleReport::default()
    };
    if fleet.wait_vehicle(sysid, wait).await.is_err() {
        return r;
    }
    let _ = fleet
        .wait_until(sysid, wait, |v| {
            v.sysid_checked || v.sysid_conflict.is_some()
        })
        .await;
    let Some(v) = fleet.vehicle(sysid) else {
        return r;
    };
    r.heard = true;
    r.flavour = Some(v.flavour);
    r.conflict = v.sysid_conflict.as_ref().map(|c| c.evidence.clone());
    if r.conflict.is_some() {
        // nothing is sent to a system two autopilots answer as
        return r;
    }
    read_all(fleet, &mut r, &v).await;
    if drone {
        let _ = fleet
            .wait_until(sysid, SETTLE, |v| v.camera_compid.is_some())
            .await;
    }
    if !r.params.is_empty() {
        let _ = fleet
            .wait_until(sysid, home_wait, |v| v.home.is_some() || !v.flavour.flies())
            .await;
    }
    let Some(v) = fleet.vehicle(sysid) else {
        return r;
    };
    r.conflict = v.sysid_conflict.as_ref().map(|c| c.evidence.clone());
    r.camera = v.camera_compid.is_some();
    r.home = v.home.map(|h| (h.lat, h.lon));
    r.budget = v.link_quality.budget;
    r.down_bytes_per_s = Some(v.link_quality.down_bytes_per_s);
    r
}

/// Read the parameters the check needs from `v` into `r` (values and names not answered).
async fn read_all(fleet: &FleetHandle, r: &mut VehicleReport, v: &crate::fleet::VehicleSnapshot) {
    let cfg = if v.link_quality.budget.is_limited() {
        ParamConfig::RADIO
    } else {
        ParamConfig::FAST
    };
    let flavour: Flavour = v.flavour;
    let bytewise = flavour.autopilot == Autopilot::Px4;
    let target = Endpoint::new(v.sysid, v.compid);
    let mut ask = names::first_read(flavour);
    while !ask.is_empty() {
        let (values, missing) = read_params(fleet, target, &ask, cfg, bytewise).await;
        r.params.extend(values);
        r.unread.extend(missing);
        ask = if r.params.is_empty() {
            // it answered nothing: asking more would only wait longer
            Vec::new()
        } else {
            names::next_read(flavour, &r.params, &r.unread, fleet.config().gcs.sysid)
        };
    }
    // names of older or newer firmware that were only tried: not a finding when the
    // autopilot answered their counterparts
    let fallback = [
        names::SYSID_MYGCS,
        names::SYSID_ENFORCE,
        names::MAV_GCS_SYSID_HI,
    ];
    if r.params.contains_key(names::MAV_GCS_SYSID) {
        r.unread.retain(|n| !fallback.contains(&n.as_str()));
    } else if r.params.contains_key(names::SYSID_MYGCS) {
        r.unread.retain(|n| n != names::MAV_GCS_SYSID);
    }
}

/// Read every vehicle of `def` (in parallel) and check them: findings, blockers first.
/// `wait` bounds the wait for each vehicle's first heartbeat and for the sysid watch,
/// `home_wait` the wait for a copter's home.
pub(crate) async fn run_check(
    fleet: &FleetHandle,
    def: &MissionDef,
    wait: Duration,
    home_wait: Duration,
) -> Vec<Finding> {
    let tasks: Vec<_> = def
        .vehicles
        .iter()
        .map(|v| {
            let (fleet, sysid, drone) = (fleet.clone(), v.sysid, v.role == Role::Drone);
            tokio::spawn(async move { report(&fleet, sysid, drone, wait, home_wait).await })
        })
        .collect();
    let mut reports = Vec::new();
    for (t, v) in tasks.into_iter().zip(&def.vehicles) {
        reports.push(t.await.unwrap_or_else(|_| VehicleReport {
            sysid: v.sysid,
            ..VehicleReport::default()
        }));
    }
    preflight::check(def, &reports, fleet.config().gcs.sysid)
}

/// The findings as printed: one block per finding, then a summary line.
pub(crate) fn render(findings: &[Finding]) -> String {
    let mut s = String::new();
    for f in findings {
        s.push_str(&f.to_string());
        s.push('\n');
    }
    s.push_str(&summary(findings));
    s.push('\n');
    s
}

/// What a blocker found before a run starts does.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OnBlocker {
    /// Stop the start (`fleetmap run`, `resume`, the demo, a UI that starts by itself).
    #[default]
    Stop,
    /// Start anyway (`--ignore-check`).
    Ignore,
    /// Let the UI open and stop at the operator's START, which checks again
    /// ([`StartCheck::at_start`]).
    AtStart,
}

impl OnBlocker {
    /// [`OnBlocker::Ignore`] when the operator said `--ignore-check`, otherwise `otherwise`.
    pub(crate) fn unless_ignored(ignore_check: bool, otherwise: OnBlocker) -> OnBlocker {
        if ignore_check {
            OnBlocker::Ignore
        } else {
            otherwise
        }
    }
}

/// The check at a run's start: log every finding; with a blocker, stop unless `on_blocker`
/// says otherwise.
pub(crate) async fn gate(
    fleet: &FleetHandle,
    def: &MissionDef,
    wait: Duration,
    on_blocker: OnBlocker,
) -> Result<StartCheck, RunError> {
    let findings = run_check(fleet, def, wait, wait).await;
    for f in &findings {
        match f.severity {
            Severity::Blocker => tracing::error!("fleet check: {}", one_line(f)),
            Severity::Warning => tracing::warn!("fleet check: {}", one_line(f)),
        }
    }
    let blockers = preflight::blockers(&findings);
    if blockers > 0 {
        match on_blocker {
            OnBlocker::Ignore => tracing::warn!(
                "fleet check: {blockers} blocker(s) ignored (--ignore-check): starting anyway"
            ),
            OnBlocker::AtStart => tracing::warn!(
                "fleet check: {blockers} blocker(s): the run waits for START, which checks again"
            ),
            OnBlocker::Stop => {
                return Err(RunError::CheckFailed {
                    blockers,
                    report: render(&findings),
                });
            }
        }
    }
    Ok(StartCheck {
        def: def.clone(),
        findings,
        ignore: on_blocker == OnBlocker::Ignore,
    })
}

/// How long the check at the operator's START waits for a vehicle not heard: the fleet
/// was heard when the UI opened, so this only bounds a vehicle that has gone since.
const AT_START_WAIT: Duration = Duration::from_secs(10);

/// The fleet check of a run that is about to start: what it found before the UI opened,
/// and what to check again at the operator's START.
#[derive(Clone, Debug)]
pub(crate) struct StartCheck {
    /// The mission checked.
    def: MissionDef,
    /// What the check before the UI found, blockers first.
    pub findings: Vec<Finding>,
    /// The operator said `--ignore-check`: blockers do not stop the start.
    ignore: bool,
}

impl StartCheck {
    /// Check the fleet again at the operator's START: the findings (blockers first) and
    /// whether the run may start (no blocker, or `--ignore-check`).
    pub(crate) async fn at_start(&self, fleet: &FleetHandle) -> (Vec<Finding>, bool) {
        let findings = run_check(fleet, &self.def, AT_START_WAIT, AT_START_WAIT).await;
        let go = self.ignore || preflight::blockers(&findings) == 0;
        (findings, go)
    }
}

/// The summary line under the findings: `fleet check: 1 blocker, 3 warnings`.
pub(crate) fn summary(findings: &[Finding]) -> String {
    let b = preflight::blockers(findings);
    let w = findings.len() - b;
    format!(
        "fleet check: {b} blocker{}, {w} warning{}",
        if b == 1 { "" } else { "s" },
        if w == 1 { "" } else { "s" }
    )
}

/// A finding on one line (logs).
pub(crate) fn one_line(f: &Finding) -> String {
    format!(
        "{} vehicle {} {}: {} (fix: {})",
        f.severity,
        f.sysid,
        f.check.name(),
        f.what,
        f.fix
    )
}
