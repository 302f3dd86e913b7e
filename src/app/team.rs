//! Connecting to a run's team (async shell over [`FleetHandle`]): every vehicle of the
//! mission heard, one autopilot behind each system id, the grid's origin known. Both mission
//! kinds start and resume through these.

use crate::app::error::{RunnerError, RunnerResult};
use crate::fleet::FleetHandle;
use fleetmap_core::geo::{Grid, LatLon};
use fleetmap_core::mission::definition::{MissionDef, Origin};
use std::time::Duration;

/// Wait until every drone and station of `def` has been heard, each long enough to tell it
/// is one autopilot ([`one_autopilot`]: two behind one system id refuse the run).
pub(crate) async fn wait_for_team(
    fleet: &FleetHandle,
    def: &MissionDef,
    wait: Duration,
) -> RunnerResult<()> {
    for v in &def.vehicles {
        fleet
            .wait_vehicle(v.sysid, wait)
            .await
            .map_err(|source| RunnerError::TeamVehicle {
                sysid: v.sysid,
                role: format!("{:?}", v.role),
                source,
            })?;
    }
    for v in &def.vehicles {
        one_autopilot(fleet, v.sysid, wait).await?;
    }
    Ok(())
}

/// Wait (up to `wait`) until vehicle `sysid` has been heard long enough to tell whether a
/// second autopilot shares its system id ([`crate::fleet::VehicleSnapshot::sysid_checked`],
/// a few seconds of its telemetry), then refuse it if one does. A vehicle that sends too
/// little to tell within `wait` is let through with a warning (the fleet keeps watching:
/// a conflict found later stops every command to it).
pub(crate) async fn one_autopilot(
    fleet: &FleetHandle,
    sysid: u8,
    wait: Duration,
) -> RunnerResult<()> {
    if fleet
        .wait_until(sysid, wait, |v| {
            v.sysid_checked || v.sysid_conflict.is_some()
        })
        .await
        .is_err()
    {
        tracing::warn!(
            "vehicle {sysid}: too little traffic in {:.0} s to tell whether another autopilot \
             shares its system id; going on, still watching",
            wait.as_secs_f64()
        );
    }
    refuse_conflicts(fleet, [sysid])
}

/// [`RunnerError::SysidConflict`] for the first of `sysids` behind which two autopilots answer.
pub(crate) fn refuse_conflicts(
    fleet: &FleetHandle,
    sysids: impl IntoIterator<Item = u8>,
) -> RunnerResult<()> {
    for sysid in sysids {
        if let Some(c) = fleet.vehicle(sysid).and_then(|v| v.sysid_conflict) {
            tracing::error!(
                "vehicle {sysid}: two or more autopilots answer as system id {sysid}: the run is \
                 refused"
            );
            return Err(RunnerError::SysidConflict {
                sysid,
                evidence: c.evidence,
            });
        }
    }
    Ok(())
}

/// The mission grid: the file's origin, or the first vehicle's home (waits for its
/// HOME_POSITION up to `wait`).
pub(crate) async fn mission_grid(
    fleet: &FleetHandle,
    def: &MissionDef,
    wait: Duration,
) -> RunnerResult<Grid> {
    let origin = match def.grid.origin {
        Origin::Coordinates(p) => LatLon {
            lat: p.lat,
            lon: p.lon,
        },
        Origin::Vehicle => {
            let first = def.vehicles.first().ok_or(RunnerError::NoVehicles)?.sysid;
            let v = fleet
                .wait_until(first, wait, |v| v.home.is_some())
                .await
                .map_err(|_| RunnerError::NoHome {
                    sysid: first,
                    wait_s: wait.as_secs_f64(),
                })?;
            let h = v.home.ok_or(RunnerError::NoHome {
                sysid: first,
                wait_s: wait.as_secs_f64(),
            })?;
            LatLon {
                lat: h.lat,
                lon: h.lon,
            }
        }
    };
    Ok(Grid::new(origin, def.grid.cell_size_m)?)
}

/// Wait up to `wait` for vehicle `sysid`'s heartbeat (a clear error when it stays silent),
/// then refuse it if a second autopilot shares its system id ([`one_autopilot`]).
pub(crate) async fn heard(fleet: &FleetHandle, sysid: u8, wait: Duration) -> RunnerResult<()> {
    fleet
        .wait_vehicle(sysid, wait)
        .await
        .map_err(|source| RunnerError::NotHeard {
            sysid,
            wait_s: wait.as_secs_f64(),
            source,
        })?;
    one_autopilot(fleet, sysid, wait).await
}
