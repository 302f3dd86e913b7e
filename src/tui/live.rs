//! The live adapter's pure half: fleet snapshots and the panes a run's kind draws from its
//! state ([`Panes`], `RunKind::panes`) become the UI's [`Model`] (the async half, which feeds it and carries out the operator's commands, is
//! `crate::tui::session`).
//!
//! Nothing here reads a clock or touches the network: [`LiveLog`] keeps the messages (the
//! vehicles' STATUSTEXT and the runner's progress lines) with the times it is given, and
//! [`build_model`] is a function of its arguments.

use crate::fleet::{FleetSnapshot, VehicleSnapshot};
use crate::panes::{
    Battery, CameraHealth, Gps, GpsFix, LinkState, LogEntry, MapModel, MissionModel,
    MissionProgress, Model, Panes, Role, VehicleRow,
};
use fleetmap_core::geo::{Grid, LatLon};
use fleetmap_core::proto::flavour::VehicleClass;
use fleetmap_core::proto::severity::Severity;
use fleetmap_core::time::Time;
use std::collections::HashMap;

/// Most messages kept.
pub(crate) const LOG_CAPACITY: usize = 500;

/// The messages shown in the log pane.
#[derive(Clone, Debug, Default)]
pub struct LiveLog {
    /// Oldest first.
    pub(crate) entries: Vec<LogEntry>,
    /// The last STATUSTEXT taken from each vehicle (its arrival time).
    seen: HashMap<u8, Time>,
}

impl LiveLog {
    /// Add a line.
    pub fn push(
        &mut self,
        time: Time,
        severity: Severity,
        sysid: Option<u8>,
        text: impl Into<String>,
    ) {
        self.entries.push(LogEntry {
            time,
            severity,
            sysid,
            text: text.into(),
        });
        if self.entries.len() > LOG_CAPACITY {
            let excess = self.entries.len() - LOG_CAPACITY;
            self.entries.drain(..excess);
        }
    }

    /// Take the vehicles' new STATUSTEXTs from a snapshot.
    pub fn absorb(&mut self, fleet: &FleetSnapshot) {
        for v in fleet.vehicles.values() {
            if let Some(t) = &v.last_text
                && self.seen.get(&v.sysid) != Some(&t.at)
            {
                self.seen.insert(v.sysid, t.at);
                self.push(t.at, t.severity, Some(v.sysid), t.text.clone());
            }
        }
    }
}

fn gps_fix(fix: Option<u8>) -> GpsFix {
    match fix {
        None | Some(0) => GpsFix::NoGps,
        Some(1) => GpsFix::NoFix,
        Some(2) => GpsFix::Fix2d,
        Some(3) => GpsFix::Fix3d,
        Some(4) => GpsFix::Dgps,
        Some(5) => GpsFix::RtkFloat,
        Some(_) => GpsFix::RtkFixed,
    }
}

/// One fleet-table row.
pub(crate) fn vehicle_row(
    v: &VehicleSnapshot,
    role: Role,
    grid: Option<&Grid>,
    activity: Option<String>,
) -> VehicleRow {
    let cell = match (grid, v.position) {
        (Some(g), Some(p)) => g
            .cell_of(LatLon {
                lat: p.lat,
                lon: p.lon,
            })
            .ok(),
        _ => None,
    };
    VehicleRow {
        sysid: v.sysid,
        role,
        autopilot: v.flavour.autopilot,
        vehicle_type: v.flavour.class,
        mode: if v.sysid_conflict.is_some() {
            "ID CONFLICT".into()
        } else {
            v.mode.clone()
        },
        armed: v.armed,
        battery: Battery {
            remaining_pct: v.battery_pct.and_then(|p| u8::try_from(p).ok()),
            voltage_v: v.battery_v,
            cells: None,
        },
        gps: Gps {
            fix: gps_fix(v.gps_fix),
            satellites: v.satellites,
        },
        alt_m: v.alt_rel,
        speed_mps: v.groundspeed,
        mission: match (v.mission_current, v.mission_total) {
            (Some(c), Some(t)) if t > 0 => Some(MissionProgress {
                current: c.saturating_add(1).min(t),
                total: t,
            }),
            _ => None,
        },
        link: LinkState {
            quality_pct: Some((100.0 - v.link_quality.loss_pct).clamp(0.0, 100.0).round() as u8),
            lost: !v.alive,
            last_heard_s: Some(v.heartbeat_age_s as f32),
            bytes_per_s: Some(
                (v.link_quality.down_bytes_per_s + v.link_quality.up_bytes_per_s) as f32,
            ),
            budget_bytes_per_s: v.link_quality.budget.bytes_per_s(),
            rssi: v
                .link_quality
                .radio
                .map(|r| (r.status.rssi, r.status.remrssi)),
        },
        cell,
        camera: v.camera_age_s.map(|age| CameraHealth {
            heard_s: age as f32,
            silent: v.camera_silent(),
            pictures: v.camera_pictures,
            measurements: v.camera_measurements,
        }),
        // Said where the operator looks first, over whatever the runner had it doing.
        activity: match &v.sysid_conflict {
            Some(_) => Some(format!(
                "TWO AUTOPILOTS AS ID {}: not commanded; {}",
                v.sysid,
                crate::fleet::SysidConflict::FIX
            )),
            None => activity,
        },
    }
}

/// The whole UI model: the fleet's vehicles (mission robots first, in mission order), the
/// mission's map and progress when a run is attached (its kind's [`Panes`]), and the log.
pub fn build_model(fleet: &FleetSnapshot, mission: Option<Panes>, log: &LiveLog) -> Model {
    let grid = mission.as_ref().map(|p| &p.grid);
    let mut order: Vec<u8> = mission
        .as_ref()
        .map(|p| p.order.clone())
        .unwrap_or_default();
    for id in fleet.vehicles.keys() {
        if !order.contains(id) {
            order.push(*id);
        }
    }
    let vehicles = order
        .iter()
        .filter_map(|id| fleet.vehicles.get(id))
        .map(|v| {
            let role = if v.flavour.class == VehicleClass::Rover {
                Role::Station
            } else {
                Role::Drone
            };
            let act = mission
                .as_ref()
                .and_then(|p| p.activity.get(&v.sysid).cloned());
            vehicle_row(v, role, grid, act)
        })
        .collect();
    let (map, mission_model) = match mission {
        Some(p) => (p.map, p.mission),
        None => (MapModel::default(), MissionModel::default()),
    };
    Model {
        time: fleet.time,
        vehicles,
        map,
        mission: mission_model,
        log: log.entries.clone(),
        sim_speed: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fleet::StatusText;

    #[test]
    fn log_takes_each_statustext_once() {
        let mut log = LiveLog::default();
        let mut f = FleetSnapshot::default();
        let mut v = VehicleSnapshot::test_copter(3);
        v.last_text = Some(StatusText {
            severity: fleetmap_core::proto::severity::Severity::Warning,
            text: "PreArm: Need Position Estimate".into(),
            at: Time::from_secs(2),
        });
        f.vehicles.insert(3, v);
        log.absorb(&f);
        log.absorb(&f);
        assert_eq!(log.entries.len(), 1);
        assert_eq!(log.entries[0].severity, Severity::Warning);
        assert_eq!(log.entries[0].sysid, Some(3));
    }
}
