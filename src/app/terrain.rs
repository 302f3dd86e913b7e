//! Terrain served from a folder of SRTM tiles (`--terrain DIR`): the async shell of
//! [`fleetmap_core::terrain::serve`].
//!
//! One task per fleet listens to every frame (`FleetHandle::subscribe`). A TERRAIN_REQUEST
//! from a vehicle is answered square by square with TERRAIN_DATA, sent to that vehicle only
//! and, on a radio, queued behind its commands and mission transfers (`FleetHandle::send_to`).
//! The tiles a request needs are read when first needed (`fleetmap_io::files::terrain`, off
//! the reactor) and kept; a tile the folder lacks is looked for again at most every
//! [`RETRY_MISSING`], so one copied in during a session is found. A vehicle's TERRAIN_REPORT
//! (how many squares it still waits for and has) and what it waits for that no tile has are
//! published in [`TerrainStatus`] for the commands to show before take-off.
//!
//! On a radio the fleet asks ArduPilot vehicles for TERRAIN_REQUEST and never stops it
//! ([`crate::fleet::FleetConfig::terrain`]); the squares go out at most
//! [`Server::blocks_per_s`] a second, fewer on a radio so that one round of a vehicle's
//! requests fits in the GCS's share of the uplink before the vehicle asks again.

use crate::fleet::{FleetHandle, Incoming};
use fleetmap_core::budget::LinkBudget;
use fleetmap_core::terrain::grid::Request;
use fleetmap_core::terrain::hgt::TileId;
use fleetmap_core::terrain::serve::{Missing, Out, Server};
use fleetmap_core::terrain::{Tiles, tiles_for};
use fleetmap_core::time::Time;
use mavlink::dialects::ardupilotmega::{MavMessage, TERRAIN_DATA_DATA};
use std::collections::BTreeMap;
use std::path::PathBuf;
use std::time::Duration;
use tokio::sync::{broadcast, watch};

/// A tile the folder lacked is looked for again after this long.
pub(crate) const RETRY_MISSING: Duration = Duration::from_secs(10);

/// Squares a second on an unlimited link (Mission Planner sends 12, MAVProxy 5).
pub(crate) const BLOCKS_PER_S: f64 = 12.0;

/// Bytes of one TERRAIN_DATA on the wire (43-byte payload, MAVLink 2 framing).
pub(crate) const TERRAIN_DATA_BYTES: f64 = 55.0;

/// What one vehicle's terrain looks like from the GCS.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct VehicleTerrain {
    /// TERRAIN_REQUESTs heard.
    pub(crate) requests: u64,
    /// Squares sent.
    pub(crate) squares_sent: u64,
    /// The vehicle's last TERRAIN_REPORT: (squares pending, squares loaded).
    pub(crate) report: Option<(u16, u16)>,
    /// What it waits for that no tile has, as a sentence.
    pub(crate) waiting: Option<String>,
}

/// Every vehicle's terrain.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct TerrainStatus {
    /// By system id.
    pub(crate) vehicles: BTreeMap<u8, VehicleTerrain>,
}

/// The running terrain server.
pub(crate) struct TerrainService {
    status: watch::Receiver<TerrainStatus>,
    task: tokio::task::JoinHandle<()>,
    dir: PathBuf,
}

impl TerrainService {
    /// What the vehicles have and wait for, now and as it changes.
    pub(crate) fn watch(&self) -> watch::Receiver<TerrainStatus> {
        self.status.clone()
    }

    /// The folder served.
    pub(crate) fn dir(&self) -> &std::path::Path {
        &self.dir
    }

    /// Stop serving.
    pub(crate) fn stop(&self) {
        self.task.abort();
    }
}

impl Drop for TerrainService {
    fn drop(&mut self) {
        self.task.abort();
    }
}

/// The sentence for a vehicle that waits: "vehicle 2 waits for terrain at lat,lon: no tile
/// N47E008.hgt in DIR".
pub(crate) fn waiting_sentence(sysid: u8, at: (f64, f64), missing: Missing, dir: &str) -> String {
    let why = match missing {
        Missing::NoTile(id) => format!("no tile {} (nor .hgt.zip) in {dir}", id.file_name()),
        Missing::Void(id) => format!("tile {} has no height there (a void)", id.file_name()),
    };
    format!(
        "vehicle {sysid} waits for terrain at {:.6},{:.6}: {why}",
        at.0, at.1
    )
}

/// Serve terrain from `dir` to every vehicle of `fleet`.
pub(crate) fn spawn(fleet: &FleetHandle, dir: PathBuf) -> TerrainService {
    let (tx, status) = watch::channel(TerrainStatus::default());
    let frames = fleet.subscribe();
    let task = tokio::spawn(serve(fleet.clone(), dir.clone(), frames, tx));
    TerrainService { status, task, dir }
}

/// The squares a second that fit the slowest radio among the vehicles: half the GCS's uplink
/// share, so the answers to one request have gone out before the vehicle asks again.
fn pace(fleet: &FleetHandle) -> f64 {
    let snap = fleet.snapshot();
    snap.vehicles
        .values()
        .filter_map(|v| match v.link_quality.budget {
            LinkBudget::Unlimited => None,
            b => b.uplink_bytes_per_s(),
        })
        .map(|b| (b / 2.0 / TERRAIN_DATA_BYTES).max(0.5))
        .fold(BLOCKS_PER_S, f64::min)
}

async fn serve(
    fleet: FleetHandle,
    dir: PathBuf,
    mut frames: broadcast::Receiver<Incoming>,
    status: watch::Sender<TerrainStatus>,
) {
    let clock = fleet.clock().clone();
    let mut server = Server::new(BLOCKS_PER_S);
    let mut tiles = Tiles::new();
    let mut absent: BTreeMap<TileId, Time> = BTreeMap::new();
    let dir_text = dir.display().to_string();
    loop {
        let wait = server
            .poll_timeout()
            .map(|t| clock.wall_until(t))
            .unwrap_or(Duration::from_secs(1));
        tokio::select! {
            biased;
            r = frames.recv() => match r {
                Ok(Incoming { frame, .. }) => {
                    let Ok(msg) = &frame.message else { continue };
                    let sysid = frame.sysid();
                    match msg {
                        MavMessage::TERRAIN_REQUEST(r) => {
                            let request = Request {
                                lat_e7: r.lat,
                                lon_e7: r.lon,
                                spacing_m: r.grid_spacing,
                                mask: r.mask,
                            };
                            let now = clock.now();
                            for id in tiles_for(&request) {
                                if tiles.contains(id)
                                    || absent.get(&id).is_some_and(|t| now.saturating_since(*t) < RETRY_MISSING)
                                {
                                    continue;
                                }
                                let d = dir.clone();
                                let read = tokio::task::spawn_blocking(move || {
                                    fleetmap_io::files::terrain::read_tile(&d, id)
                                })
                                .await;
                                match read {
                                    Ok(Ok(Some(tile))) => {
                                        tracing::info!("terrain: read {} from {}", id.file_name(), dir_text);
                                        tiles.insert(tile);
                                        absent.remove(&id);
                                    }
                                    Ok(Ok(None)) => {
                                        absent.insert(id, now);
                                    }
                                    Ok(Err(e)) => {
                                        tracing::warn!("terrain: {e}");
                                        absent.insert(id, now);
                                    }
                                    Err(e) => tracing::warn!("terrain: reading {id} failed: {e}"),
                                }
                            }
                            server.handle_request(sysid, request, now);
                            status.send_modify(|s| {
                                s.vehicles.entry(sysid).or_default().requests += 1;
                            });
                        }
                        MavMessage::TERRAIN_REPORT(r) => {
                            status.send_if_modified(|s| {
                                let v = s.vehicles.entry(sysid).or_default();
                                let new = Some((r.pending, r.loaded));
                                let changed = v.report != new;
                                v.report = new;
                                changed
                            });
                        }
                        _ => {}
                    }
                }
                Err(broadcast::error::RecvError::Lagged(_)) => {}
                Err(broadcast::error::RecvError::Closed) => return,
            },
            _ = tokio::time::sleep(wait) => {}
        }
        // send what is due
        server.set_blocks_per_s(pace(&fleet));
        let now = clock.now();
        while let Some(out) = server.poll(now, |lat, lon| tiles.height(lat, lon)) {
            match out {
                Out::Data {
                    sysid,
                    request,
                    square,
                } => {
                    let msg = MavMessage::TERRAIN_DATA(TERRAIN_DATA_DATA {
                        lat: request.lat_e7,
                        lon: request.lon_e7,
                        grid_spacing: request.spacing_m,
                        data: square.heights,
                        gridbit: square.gridbit,
                    });
                    if let Err(e) = fleet.send_to(sysid, msg).await {
                        tracing::debug!("terrain: vehicle {sysid}: {e}");
                    }
                    status.send_modify(|s| {
                        let v = s.vehicles.entry(sysid).or_default();
                        v.squares_sent += 1;
                        v.waiting = None;
                    });
                }
                Out::Waiting { sysid, at, missing } => {
                    let line = waiting_sentence(sysid, at, missing, &dir_text);
                    tracing::warn!("{line}");
                    status.send_modify(|s| {
                        s.vehicles.entry(sysid).or_default().waiting = Some(line);
                    });
                }
            }
        }
    }
}
