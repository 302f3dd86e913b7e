//! The fleet check before take-off: what field teams most often get wrong about a fleet,
//! told from what was read from each vehicle, each finding with the one line that fixes it.
//!
//! Ground stations leave these to the operator (QGroundControl merges two autopilots left at
//! one system id into one vehicle, mavlink/qgroundcontrol#14808 and #2630; ArduPilot pull
//! requests #30210 and #20272 are about which ground station id an autopilot obeys). A
//! fleet adds its own: every vehicle returning at the same altitude to the same home.
//!
//! A **blocker** is what makes the run fail for certain, and stops its start unless the
//! operator overrides the check:
//! * two autopilots answering as one system id ([`Check::DuplicateSysid`]),
//! * a mission vehicle not heard at all ([`Check::NotHeard`]),
//! * an autopilot that accepts MAVLink only from a ground station id that is not fleetmap's
//!   255 ([`Check::GcsId`]),
//! * a drone with no camera component answering ([`Check::Camera`]).
//!
//! A **warning** is a setting the operator should know about but fleetmap can fly with:
//! failsafes off (ArduCopter SITL's defaults: `FS_GCS_ENABLE` 0, `BATT_FS_LOW_ACT` and
//! `BATT_FS_CRT_ACT` 0; fleetmap plans batteries itself — swaps on the runway, sorties from
//! charge — so a missing battery failsafe is a missing second line of defence), drones that
//! share a home and a return altitude, a geofence off or only reporting, telemetry that
//! does not fit the radio, parameters that could not be read.
//!
//! Pure: [`VehicleReport`]s and the mission in, [`Finding`]s out. The parameter names and
//! where they are defined: [`names`].

pub mod names;

use crate::budget::LinkBudget;
use crate::geo::local;
use crate::mission::definition::{MissionDef, Role};
use crate::proto::flavour::{Autopilot, Flavour, VehicleClass};
use names::*;
use std::collections::BTreeMap;
use std::fmt;

/// How bad a finding is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Severity {
    /// The run would fail: its start is stopped unless the operator overrides the check.
    Blocker,
    /// Worth fixing; the run may start.
    Warning,
}

impl fmt::Display for Severity {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Severity::Blocker => "BLOCKER",
            Severity::Warning => "warning",
        })
    }
}

/// Which check found it (`docs/fleet-check.md` has one section per check).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Check {
    /// Two autopilots answer as one system id.
    DuplicateSysid,
    /// A vehicle of the mission was not heard.
    NotHeard,
    /// The autopilot's ground-station id is not fleetmap's.
    GcsId,
    /// The GCS-loss failsafe is off.
    GcsFailsafe,
    /// The battery failsafe is off.
    BatteryFailsafe,
    /// Drones that share a home return at the same altitude.
    RtlAltitude,
    /// The geofence is off or only reports.
    Geofence,
    /// A drone has no camera component answering.
    Camera,
    /// The telemetry heard does not fit the link's budget.
    StreamRates,
    /// Parameters the check needs were not answered.
    Unread,
}

impl Check {
    /// The check's name, as printed and in JSON.
    pub fn name(self) -> &'static str {
        match self {
            Check::DuplicateSysid => "duplicate-sysid",
            Check::NotHeard => "not-heard",
            Check::GcsId => "gcs-id",
            Check::GcsFailsafe => "gcs-failsafe",
            Check::BatteryFailsafe => "battery-failsafe",
            Check::RtlAltitude => "rtl-altitude",
            Check::Geofence => "geofence",
            Check::Camera => "camera",
            Check::StreamRates => "stream-rates",
            Check::Unread => "unread",
        }
    }
}

/// One thing found, about one vehicle.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Finding {
    /// Blocker or warning.
    pub severity: Severity,
    /// Which check.
    pub check: Check,
    /// The vehicle's system id.
    pub sysid: u8,
    /// What is wrong, one line.
    pub what: String,
    /// What to do about it, one line (a `param set NAME VALUE` where a parameter fixes it).
    pub fix: String,
}

impl fmt::Display for Finding {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{} vehicle {} {}: {}\n    fix: {}",
            self.severity,
            self.sysid,
            self.check.name(),
            self.what,
            self.fix
        )
    }
}

/// What was read from one vehicle before the check.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct VehicleReport {
    /// System id.
    pub sysid: u8,
    /// Whether its autopilot was heard (a heartbeat).
    pub heard: bool,
    /// Autopilot and class from its heartbeat.
    pub flavour: Option<Flavour>,
    /// Two autopilots answer as this id: what showed it
    /// ([`crate::proto::sysid_conflict`]).
    pub conflict: Option<String>,
    /// Parameters read, by name.
    pub params: BTreeMap<String, f32>,
    /// Parameters asked for and not answered.
    pub unread: Vec<String>,
    /// A camera component of this system was heard.
    pub camera: bool,
    /// Home (latitude, longitude in degrees), if the vehicle reported one.
    pub home: Option<(f64, f64)>,
    /// What its link carries.
    pub budget: LinkBudget,
    /// Bytes per second received from it lately (vehicles' time), if measured.
    pub down_bytes_per_s: Option<f64>,
}

/// Drones whose homes are closer than this share a home, metres: their returns meet over
/// it (a take-off field is tens of metres across; rally points are not read).
pub const SHARED_HOME_M: f64 = 50.0;
/// Return altitudes closer than this are the same, metres.
pub const MIN_RTL_SEPARATION_M: f64 = 3.0;
/// Telemetry heard above this multiple of the link's telemetry share
/// ([`LinkBudget::telemetry_bytes_per_s`]) does not fit.
pub const STREAM_MARGIN: f64 = 1.25;

/// Whether ArduPilot's GCS-id settings (`values`) accept MAVLink from fleetmap's system id
/// `gcs`, and what the GCS id is: (enforced, accepts `gcs`, GCS id, parameter to set).
/// `None` when neither the 4.7 nor the older names were read.
fn ardupilot_gcs(
    values: &BTreeMap<String, f32>,
    gcs: u8,
) -> Option<(bool, bool, i64, &'static str)> {
    let us = i64::from(gcs);
    if let Some(&g) = values.get(MAV_GCS_SYSID) {
        let g = g.round() as i64;
        let hi = values.get(MAV_GCS_SYSID_HI).map_or(0, |h| h.round() as i64);
        let accepts = g == us || (hi >= g && (g..=hi).contains(&us));
        let enforced = values
            .get(MAV_OPTIONS)
            .is_some_and(|o| (o.round() as i64) & 1 == 1);
        return Some((enforced, accepts, g, MAV_GCS_SYSID));
    }
    let g = values.get(SYSID_MYGCS)?.round() as i64;
    let enforced = values
        .get(SYSID_ENFORCE)
        .is_some_and(|e| e.round() as i64 == 1);
    Some((enforced, g == us, g, SYSID_MYGCS))
}

/// The return altitude of a copter, metres above home: ArduCopter `RTL_ALT` (cm; 0 returns
/// at the current altitude: `None`), PX4 `RTL_RETURN_ALT`.
fn rtl_alt_m(r: &VehicleReport) -> Option<f64> {
    let f = r.flavour?;
    if f.class != VehicleClass::Copter {
        return None;
    }
    match f.autopilot {
        Autopilot::ArduPilot => r
            .params
            .get(RTL_ALT)
            .map(|&cm| f64::from(cm) / 100.0)
            .filter(|&m| m > 0.0),
        Autopilot::Px4 => r.params.get(RTL_RETURN_ALT).map(|&m| f64::from(m)),
        Autopilot::Other(_) => None,
    }
}

fn is(v: Option<&f32>, x: i64) -> bool {
    v.is_some_and(|v| v.round() as i64 == x)
}

/// Every finding about the fleet `vehicles` flying `def` from a ground station of system id
/// `gcs` (255 unless the operator chose another), blockers first, then by vehicle.
pub fn check(def: &MissionDef, vehicles: &[VehicleReport], gcs: u8) -> Vec<Finding> {
    let mut out = Vec::new();
    let mut add = |severity, check, sysid, what: String, fix: String| {
        out.push(Finding {
            severity,
            check,
            sysid,
            what,
            fix,
        })
    };
    let role = |sysid: u8| {
        def.vehicles
            .iter()
            .find(|v| v.sysid == sysid)
            .map(|v| v.role)
    };
    for r in vehicles {
        let id = r.sysid;
        if !r.heard {
            add(
                Severity::Blocker,
                Check::NotHeard,
                id,
                format!("no heartbeat from system id {id}"),
                format!(
                    "power it and check its link; its system id must be {id} (ArduPilot \
                     MAV_SYSID, PX4 MAV_SYS_ID)"
                ),
            );
            continue;
        }
        if let Some(e) = &r.conflict {
            add(
                Severity::Blocker,
                Check::DuplicateSysid,
                id,
                format!("two autopilots answer as system id {id} ({e})"),
                "give each autopilot its own id: param set MAV_SYSID N on ArduPilot \
                 (SYSID_THISMAV before 4.7), MAV_SYS_ID N on PX4; reboot it"
                    .into(),
            );
        }
        let Some(f) = r.flavour else { continue };
        let v = &r.params;
        // nothing answered: ArduPilot with its GCS id enforced drops whatever fleetmap
        // sends (`GCS_MAVLINK::accept_packet`), and so does a link whose uplink is dead
        let deaf = v.is_empty() && !r.unread.is_empty();
        if role(id) == Some(Role::Drone) && !r.camera {
            add(
                Severity::Blocker,
                Check::Camera,
                id,
                "no camera component answers (no heartbeat from a MAVLink camera of this \
                 system)"
                    .into(),
                "power and connect the drone's camera (component 100, e.g. `fleetmap camera` \
                 on the autopilot's camera port) and check that the autopilot forwards it"
                    .into(),
            );
        }
        match f.autopilot {
            Autopilot::ArduPilot => {
                match ardupilot_gcs(v, gcs) {
                    Some((true, false, g, p)) => add(
                        Severity::Blocker,
                        Check::GcsId,
                        id,
                        format!(
                            "accepts MAVLink only from ground station id {g} ({p} {g} with \
                             the only-from-GCS option on); fleetmap is {gcs}"
                        ),
                        format!("param set {p} {gcs}"),
                    ),
                    Some((false, false, g, p)) => add(
                        Severity::Warning,
                        Check::GcsId,
                        id,
                        format!(
                            "takes ground station id {g} for its GCS ({p}); fleetmap's \
                             heartbeats ({gcs}) do not count for its GCS failsafe"
                        ),
                        format!("param set {p} {gcs}"),
                    ),
                    None if deaf => add(
                        Severity::Blocker,
                        Check::GcsId,
                        id,
                        format!(
                            "answers none of fleetmap's parameter reads ({}): it accepts \
                             MAVLink only from another ground station id (MAV_OPTIONS bit 0 \
                             with MAV_GCS_SYSID not {gcs}), or nothing reaches it",
                            r.unread.len()
                        ),
                        format!(
                            "from a GCS it accepts (e.g. MAVProxy --source-system=ITS_GCS_ID): \
                             param set {MAV_GCS_SYSID} {gcs}; or check the link's uplink"
                        ),
                    ),
                    _ => {}
                }
                if is(v.get(FS_GCS_ENABLE), 0) {
                    add(
                        Severity::Warning,
                        Check::GcsFailsafe,
                        id,
                        "GCS-loss failsafe off (FS_GCS_ENABLE 0): a drone that loses the \
                         link flies on"
                            .into(),
                        format!("param set {FS_GCS_ENABLE} 1"),
                    );
                }
                if is(v.get(BATT_FS_LOW_ACT), 0) && is(v.get(BATT_FS_CRT_ACT), 0) {
                    let rtl = if f.class == VehicleClass::Copter {
                        2
                    } else {
                        1
                    };
                    add(
                        Severity::Warning,
                        Check::BatteryFailsafe,
                        id,
                        "battery failsafe off (BATT_FS_LOW_ACT 0, BATT_FS_CRT_ACT 0): only \
                         fleetmap's own planning brings it home on a low battery"
                            .into(),
                        format!("param set {BATT_FS_LOW_ACT} {rtl}"),
                    );
                }
                if is(v.get(FENCE_ENABLE), 0) {
                    add(
                        Severity::Warning,
                        Check::Geofence,
                        id,
                        "geofence off (FENCE_ENABLE 0)".into(),
                        format!("param set {FENCE_ENABLE} 1"),
                    );
                } else if is(v.get(FENCE_ACTION), 0) {
                    add(
                        Severity::Warning,
                        Check::Geofence,
                        id,
                        "a fence breach is only reported (FENCE_ACTION 0)".into(),
                        format!("param set {FENCE_ACTION} 1"),
                    );
                }
            }
            Autopilot::Px4 => {
                if is(v.get(NAV_DLL_ACT), 0) {
                    add(
                        Severity::Warning,
                        Check::GcsFailsafe,
                        id,
                        "GCS-loss failsafe off (NAV_DLL_ACT 0)".into(),
                        format!("param set {NAV_DLL_ACT} 2"),
                    );
                }
                if is(v.get(COM_LOW_BAT_ACT), 0) {
                    add(
                        Severity::Warning,
                        Check::BatteryFailsafe,
                        id,
                        "battery failsafe only warns (COM_LOW_BAT_ACT 0)".into(),
                        format!("param set {COM_LOW_BAT_ACT} 3"),
                    );
                }
                if v.get(GF_ACTION).is_some_and(|a| a.round() as i64 <= 1) {
                    add(
                        Severity::Warning,
                        Check::Geofence,
                        id,
                        "a geofence breach is not acted on (GF_ACTION 0 or 1)".into(),
                        format!("param set {GF_ACTION} 3"),
                    );
                }
            }
            Autopilot::Other(_) => {}
        }
        if let (Some(cap), Some(got)) = (r.budget.telemetry_bytes_per_s(), r.down_bytes_per_s)
            && got > cap * STREAM_MARGIN
        {
            let fix = match f.autopilot {
                Autopilot::Px4 => "lower the radio port's MAVLink rate (param set MAV_1_RATE …)",
                _ => "lower the stream rates of the radio's port (the MAVn_… / SRn_… parameters)",
            };
            add(
                Severity::Warning,
                Check::StreamRates,
                id,
                format!(
                    "sends {got:.0} B/s on a {} link whose telemetry share is {cap:.0} B/s",
                    r.budget
                ),
                fix.into(),
            );
        }
        if deaf && f.autopilot != Autopilot::ArduPilot {
            add(
                Severity::Blocker,
                Check::Unread,
                id,
                format!(
                    "answers none of fleetmap's parameter reads ({}): nothing fleetmap sends \
                     reaches it",
                    r.unread.len()
                ),
                "check the link's uplink (the radio's or network's direction to the vehicle)"
                    .into(),
            );
        } else if !r.unread.is_empty() && !deaf {
            add(
                Severity::Warning,
                Check::Unread,
                id,
                format!("no answer for {}", r.unread.join(", ")),
                "check the link (or the firmware: these are ArduPilot 4.7 / PX4 1.16 names), \
                 then run the check again"
                    .into(),
            );
        }
    }
    rtl_findings(def, vehicles, &mut out);
    out.sort_by_key(|f| (f.severity, f.sysid, f.check));
    out
}

/// Drones that share a home (within [`SHARED_HOME_M`]) and return at the same altitude
/// (within [`MIN_RTL_SEPARATION_M`]): a warning on each later one, with an altitude above
/// every other's.
fn rtl_findings(def: &MissionDef, vehicles: &[VehicleReport], out: &mut Vec<Finding>) {
    let sep = if def.flight.altitude_separation_m >= MIN_RTL_SEPARATION_M {
        def.flight.altitude_separation_m
    } else {
        5.0
    };
    let fliers: Vec<(&VehicleReport, (f64, f64), f64)> = vehicles
        .iter()
        .filter(|r| r.heard)
        .filter_map(|r| Some((r, r.home?, rtl_alt_m(r)?)))
        .collect();
    let top = fliers.iter().map(|x| x.2).fold(0.0, f64::max);
    let mut next = top + sep;
    for (i, (r, home, alt)) in fliers.iter().enumerate() {
        let clash = fliers[..i].iter().find(|(_, h, a)| {
            local::distance(home.0, home.1, h.0, h.1) < SHARED_HOME_M
                && (a - alt).abs() < MIN_RTL_SEPARATION_M
        });
        let Some((other, h, _)) = clash else { continue };
        let apart = local::distance(home.0, home.1, h.0, h.1);
        let fix = match r.flavour.map(|f| f.autopilot) {
            Some(Autopilot::Px4) => format!("param set {RTL_RETURN_ALT} {next:.0}"),
            _ => format!("param set {RTL_ALT} {:.0}", next * 100.0),
        };
        next += sep;
        out.push(Finding {
            severity: Severity::Warning,
            check: Check::RtlAltitude,
            sysid: r.sysid,
            what: format!(
                "returns at {alt:.0} m like vehicle {}, whose home is {apart:.0} m away: \
                 both descend on one spot at one height",
                other.sysid
            ),
            fix,
        });
    }
}

/// How many findings are blockers.
pub fn blockers(findings: &[Finding]) -> usize {
    findings
        .iter()
        .filter(|f| f.severity == Severity::Blocker)
        .count()
}

#[cfg(test)]
mod tests;
