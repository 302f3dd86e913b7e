//! The runs (async shell): what a mission kind is, how a run starts, flies, is saved and
//! resumes, and the two kinds this build flies — runway mapping and spatial classification.
//!
//! | module | what |
//! |---|---|
//! | [`kind`] | one mission kind ([`kind::RunKind`]): its state, report, exports, resume, how it flies headless or in the TUI, the operator's commands and the panes' view |
//! | [`kinds`] | the registry of kinds: one `registry!` line per kind; work for any kind is a `KindVisitor` |
//! | `launch` | the one way to start or resume a run (`prepare`, then `Ready::fly`), for `run`, `resume`, `tui --mission` and `demo` |
//! | `preflight` | the fleet check on a connected fleet, and the gate it puts before every start |
//! | [`run`] | the run core both runners share: state lock, durable commits through the store task, progress, view, tracker |
//! | `session` | the live terminal session on a real fleet, with or without a run attached (any kind) |
//! | [`runway`] | the runway-mapping run (sweep, confirmation, DFS, battery swaps, resume): events, pilot, intake, sweep, runner; its report and GeoJSON / KML / PNG exports, IoU against a simulated world |
//! | [`bandit`] | the spatial-classification run (epochs, sorties with charging rovers, measurements, resume): events, runner, sortie, pilot, intake, upload; its report (keep / reject / errors, per-epoch figures) and the progress PNG (Fig. 4) |
//! | [`images`] | every image the fleet takes as one stream (MAVLink image transmission, file URLs), and the run's image hub |
//! | [`flight`] | flight steps with timeouts: take off, fly to a point and settle, capture, land |
//! | `terrain` | terrain served from a folder of SRTM tiles: every vehicle's TERRAIN_REQUEST answered, what each waits for |
//! | [`error`] | the layer's typed errors ([`error::RunError`]): what failed, on which file or vehicle, with its cause |
//! | [`demo`] | (feature `sim`) `fleetmap demo`: the embedded simulator and the station in one process |
//! | [`bandit_sim`] | (feature `sim`) the embedded simulator with drones and charging rovers (`fleetmap demo --bandit`, tests) |

pub mod bandit;
#[cfg(feature = "sim")]
pub mod bandit_sim;
#[cfg(feature = "sim")]
pub mod demo;
pub mod error;
pub mod flight;
pub mod images;
pub mod kind;
pub mod kinds;
pub(crate) mod launch;
pub(crate) mod preflight;
pub mod run;
pub mod runway;
pub(crate) mod session;
pub(crate) mod terrain;

use crate::app::error::RunError;
use crate::fleet::FleetHandle;
use fleetmap_core::explore::dfs::Sharing;
use fleetmap_core::explore::mapping::MappingState;
use fleetmap_core::geo::{Grid, LatLon};
use fleetmap_core::mission::definition::{MissionDef, Origin};
use std::time::Duration;

/// Wait until every drone and station of `def` has been heard, each long enough to tell it
/// is one autopilot ([`one_autopilot`]: two behind one system id refuse the run).
pub(crate) async fn wait_for_team(
    fleet: &FleetHandle,
    def: &MissionDef,
    wait: Duration,
) -> Result<(), RunError> {
    for v in &def.vehicles {
        fleet
            .wait_vehicle(v.sysid, wait)
            .await
            .map_err(|source| RunError::TeamVehicle {
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
) -> Result<(), RunError> {
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

/// [`RunError::SysidConflict`] for the first of `sysids` behind which two autopilots answer.
pub(crate) fn refuse_conflicts(
    fleet: &FleetHandle,
    sysids: impl IntoIterator<Item = u8>,
) -> Result<(), RunError> {
    for sysid in sysids {
        if let Some(c) = fleet.vehicle(sysid).and_then(|v| v.sysid_conflict) {
            tracing::error!(
                "vehicle {sysid}: two or more autopilots answer as system id {sysid}: the run is \
                 refused"
            );
            return Err(RunError::SysidConflict {
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
) -> Result<Grid, RunError> {
    let origin = match def.grid.origin {
        Origin::Coordinates(p) => LatLon {
            lat: p.lat,
            lon: p.lon,
        },
        Origin::Vehicle => {
            let first = def.vehicles.first().ok_or(RunError::NoVehicles)?.sysid;
            let v = fleet
                .wait_until(first, wait, |v| v.home.is_some())
                .await
                .map_err(|_| RunError::NoHome {
                    sysid: first,
                    wait_s: wait.as_secs_f64(),
                })?;
            let h = v.home.ok_or(RunError::NoHome {
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

/// A new runway-mapping state for `def` once the team is connected.
pub async fn new_mapping(
    fleet: &FleetHandle,
    def: &MissionDef,
    sharing: Sharing,
    wait: Duration,
) -> Result<MappingState, RunError> {
    wait_for_team(fleet, def, wait).await?;
    let grid = mission_grid(fleet, def, wait).await?;
    Ok(MappingState::new(def, grid, sharing)?)
}
