//! The spatial-classification run (bandit paper Algorithm 1, §V) on real or simulated
//! vehicles: the async shell around [`ClassificationState`].
//!
//! One loop asks the state what to do next ([`ClassificationState::next`]) and does it:
//!
//! * **Epoch** (Algorithm 1, steps 3–6): the goals (3) are chosen between sorties, while the
//!   drones charge on their stations; the IP (11) runs on a blocking thread
//!   ([`crate::planner::ip::solve_instance`], K doubled when infeasible).
//! * **Sortie** (one sensing cycle): the cycle's missions ([`crate::planner::sortie::missions`])
//!   are checked against the no-fly cells, uploaded to every vehicle that moves, read back and
//!   compared item by item, and checked again as read back — only then, and once every drone
//!   has the charge the sortie needs, are all vehicles started: drones take off from their
//!   station and fly their cells, capturing B images at each unclassified cell; once they are
//!   in the air, rovers drive their road cells at v_c = v_d·T_c/T_d (a rover never drives off
//!   with a drone taking off from it). A vehicle that refuses its mission stops the sortie
//!   before anything takes off.
//! * **Following**: one task per drone follows its mission; at the end of its cells it hovers
//!   until the station it lands on has arrived (a station that falls behind holds its drones at
//!   the rendezvous, and the next sortie waits for everyone), then lands on the station's
//!   reported position (its charger slot). With lock-step separation (7e) a coordinator holds
//!   every drone that is a step ahead (GUIDED hold) until the others have reached its step.
//! * **Images** → green-pixel measurement of the part of the image over the cell
//!   ([`crate::vision::green`]) → H → (4); the state is saved (atomically) and the measurement
//!   journalled after every image.
//! * **Geofence**: at the start of a run every vehicle gets the no-fly cells as a fence
//!   (MAV_MISSION_TYPE_FENCE, inclusion + exclusion polygons), read back and enabled
//!   (ArduPilot DO_FENCE_ENABLE; PX4 enforces an uploaded fence).
//!
//! **Resume** (`fleetmap resume`): a sortie that was flying is followed to its end — the
//! vehicles fly their uploaded missions on their own, and drones left hovering at their last
//! cell are landed — then the rest of the epoch is planned again from where telemetry puts the
//! vehicles. A sortie that had not started is dropped and re-planned. Every measurement the
//! dead GCS had acknowledged is in the state; images taken while no GCS listened are lost, as
//! they would be with any ground station.

use crate::app::flight::{self, Patience};
use crate::app::images::{ImageHub, ReceivedImage};
use crate::fleet::{FleetHandle, VehicleSnapshot};
use crate::geo::{Cell, LatLon, local};
use crate::mission::{MissionItem, MissionType};
use crate::planner::bandit::Label;
use crate::planner::ip::{PlanOptions, PlanStatus, solve_instance};
use crate::planner::sortie::missions::{self, AreaRules};
use crate::planner::sortie::{
    CaptureKey, ClassificationState, CycleEnd, CyclePhase, EpochStats, MAX_K, Measurement, Next,
    Separation, TeamConfig,
};
use crate::proto::Endpoint;
use crate::proto::command::Command;
use crate::store::RunDir;
use crate::vision::camera::CameraModel;
use crate::vision::geometry;
use crate::vision::green::{GreenParams, green_fraction};
use crate::vision::load::{LoadLimits, load_image_bytes};
use crate::vision::sanity::{self, CaptureClaim, CaptureLimits, check_capture};
use anyhow::Context as _;
use image::RgbImage;
use mavlink::dialects::ardupilotmega::MavCmd;
use nalgebra::UnitQuaternion;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::{Mutex, broadcast, mpsc, watch};

pub use crate::planner::sortie::KIND;

/// A journal record of the run (`events.jsonl`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "event", rename_all = "snake_case")]
pub enum BanditEvent {
    /// The runner started (or resumed).
    Started {
        /// Whether this continues an earlier start.
        resumed: bool,
    },
    /// A vehicle holds the geofence (uploaded, read back, enabled).
    Fence {
        /// Vehicle.
        sysid: u8,
        /// Fence items.
        items: usize,
    },
    /// Epoch p began with these goals (3).
    EpochStarted {
        /// Epoch p.
        epoch: u64,
        /// E_p.
        goals: Vec<Cell>,
    },
    /// The IP planned the rest of the epoch.
    Planned {
        /// Epoch p.
        epoch: u64,
        /// Sensing cycles.
        cycles: usize,
        /// Goals planned for.
        goals: usize,
        /// Solver wall time, seconds.
        seconds: f64,
        /// A re-plan (resume, or the team ended elsewhere than planned).
        replan: bool,
    },
    /// The missions of a sortie were built and checked.
    SortiePrepared {
        /// Epoch p.
        epoch: u64,
        /// Cycle index.
        cycle: usize,
        /// Vehicles that move, with their item counts.
        missions: Vec<(u8, usize)>,
    },
    /// Every mission of the sortie is on its vehicle, read back identical.
    SortieVerified {
        /// Epoch p.
        epoch: u64,
        /// Cycle index.
        cycle: usize,
    },
    /// A vehicle refused its mission: the sortie stopped before take-off.
    SortieRejected {
        /// Vehicle.
        sysid: u8,
        /// Why.
        reason: String,
    },
    /// The sortie's vehicles were started.
    SortieStarted {
        /// Epoch p.
        epoch: u64,
        /// Cycle index.
        cycle: usize,
    },
    /// One image measurement (counted or not).
    Measurement(Measurement),
    /// An image that does not count (why).
    ImageIgnored {
        /// Vehicle.
        sysid: u8,
        /// Why.
        reason: String,
    },
    /// An image could not be read.
    ImageFailed {
        /// Vehicle.
        sysid: u8,
        /// Why.
        reason: String,
    },
    /// A cell was classified by (4).
    Classified {
        /// The cell.
        cell: Cell,
        /// Keep or reject.
        label: Label,
        /// |H_l|.
        samples: u64,
        /// μ̂_l.
        mean: f64,
    },
    /// A drone landed on its station at the rendezvous.
    Landed {
        /// Vehicle.
        sysid: u8,
        /// The cell.
        cell: Cell,
        /// Distance to the station, metres.
        from_station_m: f64,
    },
    /// The sortie ended with the team at `config`.
    SortieDone {
        /// Epoch p.
        epoch: u64,
        /// Cycle index.
        cycle: usize,
        /// Seconds flown.
        seconds: f64,
        /// The team configuration.
        config: TeamConfig,
    },
    /// Lock-step (7e): a drone a step ahead of the others holds where it is.
    Held {
        /// Vehicle.
        sysid: u8,
        /// The step it has arrived at.
        step: usize,
    },
    /// A prepared sortie was dropped on resume (nothing had started).
    SortieDropped {
        /// Epoch p.
        epoch: u64,
    },
    /// The epoch ended.
    EpochDone(EpochStats),
    /// Every cell is classified.
    Finished {
        /// K.
        keep: Vec<Cell>,
        /// R.
        reject: Vec<Cell>,
    },
}

/// Options of a run.
#[derive(Default)]
pub struct RunOptions {
    /// Progress lines (headless stdout, the TUI's log).
    pub progress: Option<mpsc::UnboundedSender<String>>,
    /// The state after every change (the TUI's panes).
    pub view: Option<watch::Sender<Arc<ClassificationState>>>,
    /// Timeout scaling.
    pub patience: Patience,
    /// HiGHS time limit per solve, seconds (`None`: none).
    pub plan_time_limit_s: Option<f64>,
    /// Send drones off only with at least this charge, percent (`None`: the reserve plus
    /// 1.5 × the sortie's estimated need).
    pub min_takeoff_pct: Option<f64>,
    /// The operator's pause (the TUI): while it reads `true`, no new sortie starts — the
    /// drones in the air finish theirs and land on their stations, which is where a
    /// spatial-classification team waits (charging) between sorties anyway.
    pub pause: Option<watch::Receiver<bool>>,
}

/// Why a sortie stopped before take-off.
#[derive(Debug, thiserror::Error)]
#[error(
    "the sortie of epoch {epoch}, cycle {cycle} stopped before take-off: vehicle {sysid} \
     rejected its mission: {reason}"
)]
pub struct SortieRejected {
    /// Epoch p.
    pub epoch: u64,
    /// Cycle.
    pub cycle: usize,
    /// The vehicle.
    pub sysid: u8,
    /// Why.
    pub reason: String,
}

struct Core {
    state: ClassificationState,
    run: RunDir,
}

struct Shared {
    core: Mutex<Core>,
    changed: watch::Sender<u64>,
    progress: Option<mpsc::UnboundedSender<String>>,
    view: Option<watch::Sender<Arc<ClassificationState>>>,
    fleet: FleetHandle,
    patience: Patience,
    /// Drones whose autopilot has reported charging at least once (BATTERY_STATUS
    /// charge_state): only for those is "not charging" evidence of a missed charger.
    reports_charging: std::sync::Mutex<BTreeSet<u8>>,
}

impl Shared {
    fn say(&self, line: String) {
        tracing::info!("{line}");
        if let Some(p) = &self.progress {
            let _ = p.send(line);
        }
    }

    /// Mutate the state, save it, then journal `events`; notify everyone.
    async fn commit<T>(
        &self,
        f: impl FnOnce(&mut ClassificationState) -> anyhow::Result<(T, Vec<BanditEvent>)>,
    ) -> anyhow::Result<T> {
        let mut core = self.core.lock().await;
        let (out, events) = f(&mut core.state)?;
        let Core { state, run } = &mut *core;
        run.save_state(state).context("saving the run state")?;
        for ev in &events {
            run.append_event(ev).context("writing the run journal")?;
        }
        if let Some(v) = &self.view {
            let _ = v.send(Arc::new(core.state.clone()));
        }
        drop(core);
        self.changed.send_modify(|n| *n += 1);
        Ok(out)
    }

    async fn read<T>(&self, f: impl FnOnce(&ClassificationState) -> T) -> T {
        f(&self.core.lock().await.state)
    }

    async fn wait_change(&self, timeout: Duration) {
        let mut rx = self.changed.subscribe();
        rx.borrow_and_update();
        let _ = tokio::time::timeout(timeout, rx.changed()).await;
    }
}

/// The measured part of an image taken at `altitude_m`: a centred square covering
/// `fraction` of a `cell_m` cell on the ground (the whole image when the footprint is
/// smaller than that).
pub fn crop_to_cell(
    img: &RgbImage,
    camera: &CameraModel,
    altitude_m: f64,
    cell_m: f64,
    fraction: f64,
) -> RgbImage {
    let (fw, fh) = camera.footprint(altitude_m.max(0.1));
    let want = cell_m * fraction.clamp(0.05, 1.0);
    let (w, h) = img.dimensions();
    let side = |f: f64, n: u32| -> u32 {
        if f.is_finite() && f > want {
            ((f64::from(n) * want / f).round() as u32).clamp(1, n)
        } else {
            n
        }
    };
    let (cw, ch) = (side(fw, w), side(fh, h));
    image::imageops::crop_imm(img, (w - cw) / 2, (h - ch) / 2, cw, ch).to_image()
}

/// The measurement of one received image (blocking work: decode, crop, count green
/// pixels): the green share and the Bernoulli realisation.
pub fn measure_image(
    bytes: &[u8],
    green: &GreenParams,
    camera: &CameraModel,
    altitude_m: f64,
    cell_m: f64,
    fraction: f64,
) -> Result<(f64, bool), String> {
    let img = load_image_bytes(bytes, &LoadLimits::default()).map_err(|e| e.to_string())?;
    let img = crop_to_cell(&img, camera, altitude_m, cell_m, fraction);
    let f = green_fraction(&img, green);
    Ok((f, img.width() > 0 && f >= green.min_fraction))
}

fn is_complete(v: &VehicleSnapshot, items: &[MissionItem], seen_active: bool) -> bool {
    let Some(last) = items.len().checked_sub(1) else {
        return true;
    };
    let last = last as u16;
    v.reached.contains(&last)
        || (seen_active && v.mission_state == Some(5) && v.mission_current == Some(last))
}

/// The items a vehicle is known to have done: those reported reached since the mission
/// started and, after a restart of the GCS (`resumed`: the reports sent meanwhile are gone),
/// every item before the current one. (MISSION_CURRENT is not used otherwise: the fleet
/// keeps the previous sortie's value until the vehicle reports the new one.)
fn done_items(
    v: &VehicleSnapshot,
    items: &[MissionItem],
    complete: bool,
    resumed: bool,
) -> Vec<u16> {
    if complete {
        return (0..items.len() as u16).collect();
    }
    let mut done: BTreeSet<u16> = v.reached.iter().copied().collect();
    if resumed && let Some(c) = v.mission_current {
        done.extend(0..c);
    }
    done.into_iter().collect()
}

fn grid_xy(state: &ClassificationState, lat: f64, lon: f64) -> Option<(f64, f64)> {
    state.grid.to_xy(LatLon::new(lat, lon)).ok()
}

/// Where telemetry puts the team: a vehicle within 0.75 cell of the cell `expected` says is
/// on that cell; a drone within 2.5 m of a station is on the nearest such station's cell;
/// otherwise the cell its position is in.
fn observed_config(
    state: &ClassificationState,
    snap: &BTreeMap<u8, VehicleSnapshot>,
    expected: &TeamConfig,
) -> anyhow::Result<TeamConfig> {
    let s = state.grid.cell_size();
    let pos = |sysid: u8| -> anyhow::Result<(f64, f64)> {
        let v = snap
            .get(&sysid)
            .with_context(|| format!("vehicle {sysid} is not heard"))?;
        let p = v
            .position
            .with_context(|| format!("vehicle {sysid} reports no position"))?;
        grid_xy(state, p.lat, p.lon).with_context(|| format!("vehicle {sysid}: bad position"))
    };
    let near = |xy: (f64, f64), c: Cell, tol: f64| {
        (xy.0 - f64::from(c.col) * s).hypot(xy.1 - f64::from(c.row) * s) <= tol
    };
    let mut stations = Vec::new();
    let mut station_xy = Vec::new();
    for (m, &exp) in state.stations.iter().zip(&expected.stations) {
        let xy = pos(m.sysid)?;
        station_xy.push(xy);
        stations.push(if near(xy, exp, 0.75 * s) {
            exp
        } else {
            state.grid.cell_of_xy(xy.0, xy.1)
        });
    }
    let mut drones = Vec::new();
    for (m, &exp) in state.drones.iter().zip(&expected.drones) {
        let xy = pos(m.sysid)?;
        // The nearest station: two stations on neighbouring cells can stand closer than a
        // cell apart (a rover stops within its waypoint radius).
        let on = station_xy
            .iter()
            .map(|&q| (q.0 - xy.0).hypot(q.1 - xy.1))
            .enumerate()
            .filter(|&(_, d)| d <= 2.5)
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(a, _)| a);
        drones.push(match on {
            Some(a) => stations[a],
            None if near(xy, exp, 0.75 * s) => exp,
            None => state.grid.cell_of_xy(xy.0, xy.1),
        });
    }
    Ok(TeamConfig { drones, stations })
}

/// Seconds a drone's sortie should take: take-off, the legs, a stop per waypoint, the
/// hovers, the landing.
fn sortie_estimate_s(state: &ClassificationState, items: &[MissionItem]) -> f64 {
    let mut t = 20.0 + 2.0 * state.drones.first().map_or(10.0, |d| d.altitude_m);
    let mut last: Option<(f64, f64)> = None;
    for it in items {
        match it.command {
            crate::mission::item::cmd::NAV_WAYPOINT => {
                let p = (it.lat(), it.lon());
                if let Some(q) = last {
                    t += local::distance(q.0, q.1, p.0, p.1) / state.params.speed_m_s.max(0.1);
                }
                t += 2.0;
                last = Some(p);
            }
            crate::mission::item::cmd::NAV_LOITER_TIME => t += f64::from(it.param1),
            _ => {}
        }
        if last.is_none() && it.has_position() && (it.x != 0 || it.y != 0) {
            last = Some((it.lat(), it.lon()));
        }
    }
    t + state.grid.cell_size() / state.params.speed_m_s.max(0.1)
}

/// The longest sortie of the last five epochs, seconds of the fleet clock (0 before the
/// first): what a sortie really takes, waiting for the stations at the rendezvous and the
/// landings included, which the flight-path estimate does not see.
fn observed_sortie_s(state: &ClassificationState) -> f64 {
    state
        .epochs
        .iter()
        .rev()
        .take(5)
        .filter(|e| e.cycles > 0)
        .map(|e| e.flight_s / e.cycles as f64)
        .fold(0.0, f64::max)
}

/// Charge a drone needs before a sortie of `estimate_s` seconds, percent: the reserve plus
/// 1.5 × the estimated use (forward flight costs ~20 % more than hover).
fn charge_needed_pct(state: &ClassificationState, estimate_s: f64) -> f64 {
    let minutes = state.params.flight_time_min.max(0.5);
    let use_pct = estimate_s / 60.0 / minutes * 100.0 * 1.2;
    (state.params.rtl_reserve_pct + 1.5 * use_pct).min(98.0)
}

async fn enable_fence(fleet: &FleetHandle, v: &VehicleSnapshot) -> anyhow::Result<()> {
    if v.flavour.home_item() {
        // ArduPilot: FENCE_ENABLE follows DO_FENCE_ENABLE; PX4 enforces an uploaded fence.
        let cmd = Command::long(
            Endpoint::new(v.sysid, v.compid),
            MavCmd::MAV_CMD_DO_FENCE_ENABLE,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        fleet.command(cmd).await?;
    }
    Ok(())
}

/// Wait for every task of `tasks` (one per vehicle) and return the vehicles whose operation
/// failed, with the error on one line; a task that panicked or was cancelled is an error
/// (`what` names the task).
async fn join_failures(
    tasks: &mut tokio::task::JoinSet<(u8, anyhow::Result<()>)>,
    what: &'static str,
) -> anyhow::Result<Vec<(u8, String)>> {
    let mut failed = Vec::new();
    while let Some(r) = tasks.join_next().await {
        let (sysid, r) = r.context(what)?;
        if let Err(e) = r {
            failed.push((sysid, format!("{e:#}")));
        }
    }
    Ok(failed)
}

/// Whether a failed operation may succeed when tried again: no answer (a lost frame, a busy
/// link), as opposed to the vehicle saying no.
fn transient(e: &anyhow::Error) -> bool {
    use crate::fleet::FleetError;
    use crate::proto::mission::MissionError;
    e.chain().any(|c| match c.downcast_ref::<FleetError>() {
        Some(FleetError::Mission { error, .. }) => {
            matches!(
                error,
                MissionError::Timeout { .. } | MissionError::OverBudget { .. }
            )
        }
        Some(FleetError::Command { error, .. }) => {
            matches!(error, crate::proto::command::CommandError::Timeout { .. })
        }
        Some(FleetError::NotConfirmed { .. }) => true,
        _ => false,
    })
}

/// [`upload_once`], tried up to three times while the vehicle does not answer; a refusal
/// (MISSION_ACK with an error, or a list that reads back different) is final.
async fn upload_verified(
    fleet: &FleetHandle,
    sysid: u8,
    kind: MissionType,
    items: &[MissionItem],
    check: Option<(&ClassificationState, Cell, bool)>,
) -> anyhow::Result<()> {
    let mut attempt = 0;
    loop {
        attempt += 1;
        match upload_once(fleet, sysid, kind, items, check).await {
            Err(e) if attempt < 3 && transient(&e) => {
                tracing::warn!("vehicle {sysid}: {e:#} (trying again)");
            }
            r => return r,
        }
    }
}

/// Upload `items` of `kind`, read them back and compare (and, for missions, check the
/// read-back list against the no-fly cells).
async fn upload_once(
    fleet: &FleetHandle,
    sysid: u8,
    kind: MissionType,
    items: &[MissionItem],
    check: Option<(&ClassificationState, Cell, bool)>,
) -> anyhow::Result<()> {
    let v = fleet
        .vehicle(sysid)
        .ok_or(crate::fleet::FleetError::NoVehicle { sysid })?;
    fleet.upload_mission(sysid, kind, items.to_vec()).await?;
    let (back, _) = fleet.download_mission(sysid, kind).await?;
    crate::proto::mission::compare_items(items, &back, v.flavour.home_item())
        .map_err(|d| anyhow::anyhow!("the list read back differs from the one sent: {d}"))?;
    if let Some((state, start, station)) = check {
        let rules = AreaRules {
            rows: state.layout.rows,
            cols: state.layout.cols,
            obstacles: &state.layout.obstacles,
            roads: station.then_some(state.layout.roads.as_slice()),
        };
        missions::check_mission(&state.grid, &rules, start, &back)
            .map_err(|e| anyhow::anyhow!("the mission as read back is unsafe: {e}"))?;
    }
    Ok(())
}

struct Runner {
    shared: Arc<Shared>,
    plan_time_limit_s: Option<f64>,
    min_takeoff_pct: Option<f64>,
    pause: Option<watch::Receiver<bool>>,
}

impl Runner {
    fn fleet(&self) -> &FleetHandle {
        &self.shared.fleet
    }

    fn say(&self, line: String) {
        self.shared.say(line);
    }

    async fn upload_fences(&self) -> anyhow::Result<()> {
        let (items, sysids) = self
            .shared
            .read(|s| {
                (
                    missions::fence_items(
                        &s.grid,
                        s.layout.rows,
                        s.layout.cols,
                        &s.layout.obstacles,
                        (0.2 * s.grid.cell_size()).min(1.0),
                    ),
                    s.sysids(),
                )
            })
            .await;
        let items = items.context("building the geofence")?;
        let mut tasks = tokio::task::JoinSet::new();
        for sysid in sysids {
            let fleet = self.fleet().clone();
            let items = items.clone();
            tasks.spawn(async move {
                let r = async {
                    upload_verified(&fleet, sysid, MissionType::Fence, &items, None).await?;
                    let v = fleet
                        .vehicle(sysid)
                        .ok_or(crate::fleet::FleetError::NoVehicle { sysid })?;
                    enable_fence(&fleet, &v).await
                }
                .await;
                (sysid, r)
            });
        }
        let mut first_err = None;
        while let Some(r) = tasks.join_next().await {
            let (sysid, r) = r.context("fence task")?;
            match r {
                Ok(()) => {
                    self.shared
                        .commit(|_| {
                            Ok((
                                (),
                                vec![BanditEvent::Fence {
                                    sysid,
                                    items: items.len(),
                                }],
                            ))
                        })
                        .await?;
                }
                Err(e) => {
                    first_err.get_or_insert(anyhow::anyhow!(
                        "vehicle {sysid} refused the geofence of the no-fly cells: {e:#}"
                    ));
                }
            }
        }
        if let Some(e) = first_err {
            return Err(e);
        }
        self.say(format!(
            "geofence ({} items: the search area and its no-fly cells) on every vehicle",
            items.len()
        ));
        Ok(())
    }

    /// Check that every vehicle stands on its start cell (fresh runs).
    async fn check_start_positions(&self) -> anyhow::Result<()> {
        let snap = self.fleet().snapshot().vehicles;
        let (config, members, grid) = self
            .shared
            .read(|s| {
                let members: Vec<u8> = s.sysids();
                (s.config.clone(), members, s.grid.clone())
            })
            .await;
        let cells: Vec<Cell> = config
            .drones
            .iter()
            .chain(&config.stations)
            .copied()
            .collect();
        for (sysid, cell) in members.into_iter().zip(cells) {
            let v = snap
                .get(&sysid)
                .with_context(|| format!("vehicle {sysid} is not heard"))?;
            let p = v
                .position
                .with_context(|| format!("vehicle {sysid} reports no position yet"))?;
            let c = grid.cell_center(cell);
            let d = local::distance(p.lat, p.lon, c.lat, c.lon);
            if d > 0.75 * grid.cell_size() {
                anyhow::bail!(
                    "vehicle {sysid} is {d:.1} m from the centre of its start cell {cell}: place \
                     it there (or fix `start` in the mission file)"
                );
            }
        }
        Ok(())
    }

    async fn begin_epoch(&self) -> anyhow::Result<()> {
        let (p, goals) = self
            .shared
            .commit(|s| {
                let goals = s.begin_epoch()?;
                let p = s.bandit.epoch;
                let ev = (!goals.is_empty()).then(|| BanditEvent::EpochStarted {
                    epoch: p,
                    goals: goals.clone(),
                });
                Ok(((p, goals), ev.into_iter().collect()))
            })
            .await?;
        let list: Vec<String> = goals.iter().map(|c| c.to_string()).collect();
        self.say(format!("epoch {p}: goals {}", list.join(" ")));
        Ok(())
    }

    async fn plan(&self, replan: bool) -> anyhow::Result<()> {
        let (k0, p) = self.shared.read(|s| (s.params.k_max, s.bandit.epoch)).await;
        let mut k = k0.max(1);
        loop {
            let inst = self.shared.read(|s| s.instance(k)).await?;
            let goals = inst.goals.len();
            let opts = PlanOptions {
                time_limit: self.plan_time_limit_s,
                ..PlanOptions::default()
            };
            let out = tokio::task::spawn_blocking(move || {
                solve_instance(&inst, &opts, &crate::clock::stopwatch())
            })
            .await
            .context("planner task")?;
            match (out.status, out.plan) {
                (PlanStatus::Optimal | PlanStatus::TimeLimit, Some(plan)) => {
                    let secs = out.solve_seconds;
                    self.shared
                        .commit(|s| {
                            s.accept_plan(&plan, secs)?;
                            Ok((
                                (),
                                vec![BanditEvent::Planned {
                                    epoch: p,
                                    cycles: plan.cycles,
                                    goals,
                                    seconds: secs,
                                    replan,
                                }],
                            ))
                        })
                        .await?;
                    self.say(format!(
                        "epoch {p}: {} planned in {} sensing cycle(s) ({:.2} s){}",
                        if goals == 1 {
                            "1 goal".to_string()
                        } else {
                            format!("{goals} goals")
                        },
                        plan.cycles,
                        secs,
                        if replan {
                            ", re-planned from where the team is"
                        } else {
                            ""
                        }
                    ));
                    return Ok(());
                }
                (PlanStatus::Infeasible, _) if k < MAX_K => {
                    let secs = out.solve_seconds;
                    self.shared
                        .commit(|s| {
                            s.note_solve(secs);
                            Ok(((), Vec::new()))
                        })
                        .await?;
                    k *= 2;
                }
                (status, _) => anyhow::bail!(
                    "epoch {p}: the planner found no plan ({}{}): the goals cannot be reached \
                     from where the team is within {k} sensing cycles",
                    status.as_str(),
                    if out.message.is_empty() {
                        String::new()
                    } else {
                        format!(": {}", out.message)
                    }
                ),
            }
        }
    }

    async fn prepare(&self) -> anyhow::Result<()> {
        let (p, k, list) = self
            .shared
            .commit(|s| {
                let c = s.prepare_cycle()?.clone();
                // Check every mission before it goes anywhere.
                let rules = |station: bool| AreaRules {
                    rows: s.layout.rows,
                    cols: s.layout.cols,
                    obstacles: &s.layout.obstacles,
                    roads: station.then_some(s.layout.roads.as_slice()),
                };
                for d in c.drones.iter().filter(|d| d.flies) {
                    missions::check_mission(&s.grid, &rules(false), d.path[0], &d.items)
                        .map_err(|e| anyhow::anyhow!("drone {}: {e}", d.sysid))?;
                }
                for st in c.stations.iter().filter(|st| st.drives) {
                    missions::check_mission(&s.grid, &rules(true), st.path[0], &st.items)
                        .map_err(|e| anyhow::anyhow!("station {}: {e}", st.sysid))?;
                }
                let list: Vec<(u8, usize)> = c
                    .drones
                    .iter()
                    .filter(|d| d.flies)
                    .map(|d| (d.sysid, d.items.len()))
                    .chain(
                        c.stations
                            .iter()
                            .filter(|x| x.drives)
                            .map(|x| (x.sysid, x.items.len())),
                    )
                    .collect();
                let p = s.bandit.epoch;
                let ev = BanditEvent::SortiePrepared {
                    epoch: p,
                    cycle: c.k,
                    missions: list.clone(),
                };
                Ok(((p, c.k, list), vec![ev]))
            })
            .await?;
        let _ = (p, k, list);
        Ok(())
    }

    async fn upload(&self) -> anyhow::Result<()> {
        let (p, cycle) = self
            .shared
            .read(|s| (s.bandit.epoch, s.cycle().cloned()))
            .await;
        let cycle = cycle.context("no sortie is prepared")?;
        let state = Arc::new(self.shared.read(|s| s.clone()).await);
        let mut tasks = tokio::task::JoinSet::new();
        // Drones and the stations that drive: (sysid, items, start cell, is a station).
        let uploads = cycle
            .drones
            .iter()
            .filter(|d| d.flies)
            .map(|d| (d.sysid, d.items.clone(), d.path[0], false))
            .chain(
                cycle
                    .stations
                    .iter()
                    .filter(|s| s.drives)
                    .map(|s| (s.sysid, s.items.clone(), s.path[0], true)),
            );
        for (sysid, items, start, station) in uploads {
            let (fleet, state) = (self.fleet().clone(), state.clone());
            tasks.spawn(async move {
                let r = upload_verified(
                    &fleet,
                    sysid,
                    MissionType::Mission,
                    &items,
                    Some((&state, start, station)),
                )
                .await;
                (sysid, r)
            });
        }
        let mut rejected = join_failures(&mut tasks, "upload task").await?;
        rejected.sort();
        if let Some((sysid, reason)) = rejected.first().cloned() {
            let events = rejected
                .iter()
                .map(|(sysid, reason)| BanditEvent::SortieRejected {
                    sysid: *sysid,
                    reason: reason.clone(),
                })
                .collect();
            self.shared.commit(|_| Ok(((), events))).await?;
            return Err(SortieRejected {
                epoch: p,
                cycle: cycle.k,
                sysid,
                reason,
            }
            .into());
        }
        self.shared
            .commit(|s| {
                s.on_verified()?;
                Ok((
                    (),
                    vec![BanditEvent::SortieVerified {
                        epoch: p,
                        cycle: cycle.k,
                    }],
                ))
            })
            .await?;
        let n = cycle.drones.iter().filter(|d| d.flies).count()
            + cycle.stations.iter().filter(|s| s.drives).count();
        self.say(format!(
            "epoch {p} cycle {}: {n} mission(s) uploaded and verified",
            cycle.k
        ));
        Ok(())
    }

    /// " It is N m from station S." from telemetry (empty when a position is missing).
    async fn nearest_station(&self, sysid: u8) -> String {
        let stations: Vec<u8> = self
            .shared
            .read(|s| s.stations.iter().map(|m| m.sysid).collect())
            .await;
        let Some(p) = self.fleet().vehicle(sysid).and_then(|v| v.position) else {
            return String::new();
        };
        stations
            .iter()
            .filter_map(|&st| {
                let q = self.fleet().vehicle(st)?.position?;
                Some((local::distance(p.lat, p.lon, q.lat, q.lon), st))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|(d, st)| format!(" It is {d:.1} m from station {st}."))
            .unwrap_or_default()
    }

    /// Wait until every drone that flies the sortie has the charge it needs.
    async fn wait_for_charge(&self) -> anyhow::Result<()> {
        let (cycle, needs) = self
            .shared
            .read(|s| {
                let c = s.cycle().cloned();
                let needs: Vec<(u8, f64)> = c
                    .iter()
                    .flat_map(|c| c.drones.iter().filter(|d| d.flies))
                    .map(|d| {
                        let est = sortie_estimate_s(s, &d.items).max(observed_sortie_s(s));
                        (
                            d.sysid,
                            self.min_takeoff_pct
                                .unwrap_or_else(|| charge_needed_pct(s, est)),
                        )
                    })
                    .collect();
                (c, needs)
            })
            .await;
        if cycle.is_none() {
            return Ok(());
        }
        for (sysid, need) in needs {
            let ok = |v: &VehicleSnapshot| v.battery_pct.is_some_and(|p| f64::from(p) >= need);
            if self.fleet().vehicle(sysid).is_some_and(|v| ok(&v)) {
                continue;
            }
            let have = self
                .fleet()
                .vehicle(sysid)
                .and_then(|v| v.battery_pct)
                .unwrap_or(-1);
            self.say(format!(
                "drone {sysid}: charging on its station ({have} %, the sortie needs {need:.0} %)"
            ));
            // Charging, or stuck: a drone whose charge does not rise for two minutes (wall
            // clock × patience) is not on a charger.
            let stall = self.shared.patience.secs(120.0);
            let mut best = have;
            let mut since = tokio::time::Instant::now();
            loop {
                match self
                    .fleet()
                    .wait_until(sysid, self.shared.patience.secs(5.0), ok)
                    .await
                {
                    Ok(_) => break,
                    Err(v) => {
                        let now_pct = v.and_then(|v| v.battery_pct).unwrap_or(-1);
                        if now_pct > best {
                            best = now_pct;
                            since = tokio::time::Instant::now();
                        } else if since.elapsed() > stall {
                            let wh = self.nearest_station(sysid).await;
                            anyhow::bail!(
                                "drone {sysid} is not charging (stuck at {now_pct} %, the sortie \
                                 needs {need:.0} %): is it on its station's charger?{wh}"
                            );
                        }
                    }
                }
            }
        }
        Ok(())
    }

    /// Wait while the operator has paused the run (before a sortie starts).
    async fn wait_unpaused(&self) {
        let Some(mut rx) = self.pause.clone() else {
            return;
        };
        if !*rx.borrow_and_update() {
            return;
        }
        self.say("paused by the operator: the next sortie waits for RESUME".into());
        // A closed channel (the UI went away) lets the run carry on.
        while *rx.borrow_and_update() {
            if rx.changed().await.is_err() {
                break;
            }
        }
        self.say("resumed by the operator".into());
    }

    fn paused(&self) -> bool {
        self.pause.as_ref().is_some_and(|p| *p.borrow())
    }

    async fn start(&self) -> anyhow::Result<()> {
        // A pause that came while the drones charged holds the sortie too.
        loop {
            self.wait_unpaused().await;
            self.wait_for_charge().await?;
            if !self.paused() {
                break;
            }
        }
        let (p, cycle) = self
            .shared
            .read(|s| (s.bandit.epoch, s.cycle().cloned()))
            .await;
        let cycle = cycle.context("no sortie is verified")?;
        let patience = self.shared.patience;
        let mut tasks = tokio::task::JoinSet::new();
        let altitudes: BTreeMap<u8, f64> = self
            .shared
            .read(|s| s.drones.iter().map(|d| (d.sysid, d.altitude_m)).collect())
            .await;
        let speed = self.shared.read(|s| s.params.speed_m_s).await;
        for d in cycle.drones.iter().filter(|d| d.flies) {
            let fleet = self.fleet().clone();
            let sysid = d.sysid;
            let alt = altitudes.get(&sysid).copied().unwrap_or(10.0) as f32;
            tasks.spawn(async move {
                let mut attempt = 0;
                let r = loop {
                    attempt += 1;
                    let r = async {
                        // From the first item: ArduPilot resumes a mission at its current
                        // item (MIS_RESTART = 0), which may be left over from the last one.
                        fleet.set_mission_current(sysid, 0).await?;
                        flight::ensure_airborne(&fleet, sysid, alt, patience).await?;
                        fleet.start_mission(sysid).await?;
                        let _ = flight::set_speed(&fleet, sysid, speed as f32).await;
                        anyhow::Ok(())
                    }
                    .await;
                    match r {
                        Err(e) if attempt < 3 && transient(&e) => {
                            tracing::warn!("drone {sysid}: {e:#} (trying again)");
                        }
                        r => break r,
                    }
                };
                (sysid, r)
            });
        }
        // The stations drive off only once the drones are in the air: a drone that is still
        // spinning up on a rover's charger would be carried away from the cell its mission
        // starts on (and no field team lets a rover drive with a drone taking off from it).
        let mut failed = join_failures(&mut tasks, "start task").await?;
        for st in cycle.stations.iter().filter(|s| s.drives) {
            let fleet = self.fleet().clone();
            let sysid = st.sysid;
            tasks.spawn(async move {
                let mut attempt = 0;
                let r = loop {
                    attempt += 1;
                    let r = async {
                        let v = fleet
                            .vehicle(sysid)
                            .ok_or(crate::fleet::FleetError::NoVehicle { sysid })?;
                        fleet.set_mission_current(sysid, 0).await?;
                        if !v.armed && v.flavour.home_item() {
                            fleet.arm(sysid).await?;
                        }
                        fleet.start_mission(sysid).await?;
                        anyhow::Ok(())
                    }
                    .await;
                    match r {
                        Err(e) if attempt < 3 && transient(&e) => {
                            tracing::warn!("station {sysid}: {e:#} (trying again)");
                        }
                        r => break r,
                    }
                };
                (sysid, r)
            });
        }
        failed.extend(join_failures(&mut tasks, "start task").await?);
        let failed: Vec<String> = failed
            .into_iter()
            .map(|(sysid, e)| format!("vehicle {sysid}: {e}"))
            .collect();
        // Started (even partly): from now on the sortie is followed, and a resume follows it.
        self.shared
            .commit(|s| {
                s.on_started()?;
                Ok((
                    (),
                    vec![BanditEvent::SortieStarted {
                        epoch: p,
                        cycle: cycle.k,
                    }],
                ))
            })
            .await?;
        if !failed.is_empty() {
            anyhow::bail!(
                "the sortie of epoch {p}, cycle {} could not start every vehicle: {}",
                cycle.k,
                failed.join("; ")
            );
        }
        self.say(format!("epoch {p} cycle {}: flying", cycle.k));
        Ok(())
    }

    /// Follow the sortie in flight until every drone landed and every station arrived.
    async fn follow(&self, resumed: bool) -> anyhow::Result<()> {
        let (p, cycle) = self
            .shared
            .read(|s| (s.bandit.epoch, s.cycle().cloned()))
            .await;
        let cycle = cycle.context("no sortie is flying")?;
        let lock_step = self
            .shared
            .read(|s| s.params.separation == Separation::LockStep)
            .await;
        let estimate = {
            let st = self.shared.read(|s| s.clone()).await;
            cycle
                .drones
                .iter()
                .map(|d| sortie_estimate_s(&st, &d.items))
                .fold(60.0, f64::max)
        };
        let budget = self.shared.patience.secs(estimate * 4.0 + 300.0);
        let deadline = tokio::time::Instant::now() + budget;
        let mut pilots = tokio::task::JoinSet::new();
        for d in cycle.drones.iter().filter(|d| d.flies && !d.landed) {
            let pilot = DronePilot {
                shared: self.shared.clone(),
                sysid: d.sysid,
                items: d.items.clone(),
                resumed,
                deadline,
            };
            pilots.spawn(pilot.run());
        }
        let mut snaps = self.fleet().watch();
        let mut seen_active: BTreeSet<u8> = BTreeSet::new();
        let mut held: BTreeSet<u8> = BTreeSet::new();
        let mut tick = tokio::time::interval(Duration::from_millis(250));
        loop {
            tokio::select! {
                r = pilots.join_next(), if !pilots.is_empty() => {
                    if let Some(r) = r {
                        r.context("drone task")??;
                    }
                }
                r = snaps.changed() => {
                    if r.is_err() {
                        anyhow::bail!("the fleet stopped");
                    }
                }
                _ = tick.tick() => {}
            }
            if tokio::time::Instant::now() > deadline {
                anyhow::bail!(
                    "epoch {p} cycle {}: the sortie did not end within {:.0} s",
                    cycle.k,
                    budget.as_secs_f64()
                );
            }
            let snap = self.fleet().snapshot().vehicles;
            // Stations.
            for st in cycle.stations.iter().filter(|s| s.drives) {
                let Some(v) = snap.get(&st.sysid) else {
                    continue;
                };
                if v.mission_state == Some(3) {
                    seen_active.insert(st.sysid);
                }
                let active = resumed || seen_active.contains(&st.sysid);
                let complete = is_complete(v, &st.items, active);
                let done = done_items(v, &st.items, complete, resumed);
                let sysid = st.sysid;
                let changed = self
                    .shared
                    .read(|s| {
                        s.cycle()
                            .and_then(|c| c.stations.iter().find(|x| x.sysid == sysid))
                            .is_some_and(|x| {
                                !x.arrived
                                    && (complete
                                        || missions::steps_done(&x.step_done, &done) > x.step)
                            })
                    })
                    .await;
                if changed {
                    let arrived = self
                        .shared
                        .commit(|s| {
                            s.on_station_progress(sysid, &done, complete)?;
                            let arrived = s
                                .cycle()
                                .and_then(|c| c.stations.iter().find(|x| x.sysid == sysid))
                                .is_some_and(|x| x.arrived);
                            Ok((arrived, Vec::new()))
                        })
                        .await?;
                    if arrived {
                        tracing::debug!(
                            "station {sysid} arrived: reached {:?}, state {:?}, current {:?}, \
                             complete {complete}",
                            v.reached,
                            v.mission_state,
                            v.mission_current
                        );
                        self.say(format!("station {sysid}: at the rendezvous"));
                    }
                }
            }
            // Lock-step barrier (7e).
            if lock_step {
                self.barrier(&snap, &mut held, resumed).await?;
            }
            if self
                .shared
                .read(|s| s.cycle().is_none_or(|c| c.complete()))
                .await
            {
                break;
            }
        }
        while let Some(r) = pilots.join_next().await {
            r.context("drone task")??;
        }
        // Images still on their way (the last captures): wait until every visit has its B
        // images, or nothing new arrived for a second (lost images stay lost).
        let mut last = self
            .shared
            .read(|s| (s.measurements, s.ignored_images))
            .await;
        for _ in 0..10 {
            if self.shared.read(|s| s.captures_left()).await == 0 {
                break;
            }
            tokio::time::sleep(self.shared.patience.secs(1.0)).await;
            let now = self
                .shared
                .read(|s| (s.measurements, s.ignored_images))
                .await;
            if now == last {
                break;
            }
            last = now;
        }
        // The rendezvous: where is everyone?
        let snap = self.fleet().snapshot().vehicles;
        let planned = self
            .shared
            .read(|s| s.cycle().map(|c| c.planned_end()))
            .await
            .context("no sortie")?;
        let st = self.shared.read(|s| s.clone()).await;
        let actual = observed_config(&st, &snap, &planned)?;
        let (end, seconds, k) = self
            .shared
            .commit(|s| {
                let (seconds, k) = s.cycle().map_or((0.0, 0), |c| (c.elapsed_s, c.k));
                let end = s.finish_cycle(actual.clone(), resumed)?;
                let mut events = vec![BanditEvent::SortieDone {
                    epoch: p,
                    cycle: k,
                    seconds,
                    config: actual.clone(),
                }];
                if let CycleEnd::EpochDone(stats) = &end {
                    events.push(BanditEvent::EpochDone(stats.clone()));
                }
                Ok(((end, seconds, k), events))
            })
            .await?;
        self.say(format!(
            "epoch {p} cycle {k}: every drone on its station after {seconds:.0} s"
        ));
        if let CycleEnd::EpochDone(stats) = end {
            self.say(format!(
                "epoch {p} done: {} cycle(s), planner {:.2} s, {} measurements; keep {}, reject {}, \
                 unclassified {}",
                stats.cycles,
                stats.planner_s,
                stats.measurements,
                stats.keep,
                stats.reject,
                stats.unclassified
            ));
        }
        Ok(())
    }

    /// Hold the drones that are a step ahead; release the others.
    async fn barrier(
        &self,
        snap: &BTreeMap<u8, VehicleSnapshot>,
        held: &mut BTreeSet<u8>,
        resumed: bool,
    ) -> anyhow::Result<()> {
        let legs = self
            .shared
            .read(|s| s.cycle().map(|c| c.drones.clone()).unwrap_or_default())
            .await;
        let mut arrived = BTreeMap::new();
        let mut complete = BTreeSet::new();
        for d in legs.iter().filter(|d| d.flies && !d.landed) {
            let Some(v) = snap.get(&d.sysid) else {
                continue;
            };
            let c = is_complete(v, &d.items, true) && flight::airborne(v);
            if c {
                complete.insert(d.sysid);
            }
            let done = done_items(v, &d.items, c, resumed);
            arrived.insert(d.sysid, missions::steps_done(&d.step_arrive, &done));
        }
        let ahead: BTreeSet<u8> = self
            .shared
            .read(|s| s.ahead(&arrived))
            .await
            .into_iter()
            .collect();
        for d in legs.iter().filter(|d| d.flies && !d.landed) {
            let Some(v) = snap.get(&d.sysid) else {
                continue;
            };
            if complete.contains(&d.sysid) || !flight::airborne(v) {
                held.remove(&d.sysid);
                continue;
            }
            let in_mission = v
                .flavour
                .mission_mode()
                .is_ok_and(|m| v.flavour.is_mode(v.custom_mode, m));
            if ahead.contains(&d.sysid) {
                if !held.contains(&d.sysid) {
                    flight::hold_here(self.fleet(), d.sysid).await?;
                    held.insert(d.sysid);
                    let (sysid, step) = (d.sysid, arrived.get(&d.sysid).copied().unwrap_or(0));
                    self.shared
                        .commit(|_| Ok(((), vec![BanditEvent::Held { sysid, step }])))
                        .await?;
                    self.say(format!(
                        "drone {sysid}: holding at step {step} until the others catch up (7e)"
                    ));
                }
            } else if held.contains(&d.sysid) || !in_mission {
                let m = v.flavour.mission_mode()?;
                self.fleet().set_mode(d.sysid, m.name).await?;
                held.remove(&d.sysid);
            }
        }
        Ok(())
    }
}

/// One drone of a sortie: follows its mission, waits at the rendezvous, lands.
struct DronePilot {
    shared: Arc<Shared>,
    sysid: u8,
    items: Vec<MissionItem>,
    resumed: bool,
    deadline: tokio::time::Instant,
}

impl DronePilot {
    fn fleet(&self) -> &FleetHandle {
        &self.shared.fleet
    }

    async fn run(self) -> anyhow::Result<()> {
        let sysid = self.sysid;
        let mut snaps = self.fleet().watch();
        let mut seen_active = self.resumed;
        let mut step = 0;
        // The autopilot's last warning (severity ≤ WARNING), for the messages below.
        let mut warning: Option<String> = None;
        // 1. Its cells.
        loop {
            let v = self
                .fleet()
                .vehicle(sysid)
                .ok_or(crate::fleet::FleetError::NoVehicle { sysid })?;
            if v.mission_state == Some(3) {
                seen_active = true;
            }
            if let Some(t) = &v.last_text
                && t.severity <= 4
            {
                warning = Some(t.text.clone());
            }
            let complete = is_complete(&v, &self.items, seen_active);
            let done = done_items(&v, &self.items, complete, self.resumed);
            let s = self
                .shared
                .read(|s| {
                    s.cycle()
                        .and_then(|c| c.drones.iter().find(|d| d.sysid == sysid))
                        .map(|d| missions::steps_done(&d.step_done, &done))
                })
                .await
                .unwrap_or(0);
            if s > step {
                step = s;
                self.shared
                    .commit(|st| Ok((st.on_drone_progress(sysid, &done)?, Vec::new())))
                    .await?;
            }
            if complete && flight::airborne(&v) {
                break;
            }
            if v.on_ground() && !v.armed {
                if self.resumed {
                    // It landed while no GCS was listening (or never took off).
                    return self.landed().await;
                }
                if seen_active {
                    anyhow::bail!(
                        "drone {sysid} is on the ground before the end of its mission (mode {}, \
                         step {step}, battery {}, the autopilot's last warning: {})",
                        v.mode,
                        v.battery_pct
                            .map(|p| format!("{p} %"))
                            .unwrap_or_else(|| "?".into()),
                        warning.as_deref().unwrap_or("none")
                    );
                }
            }
            if tokio::time::Instant::now() > self.deadline {
                anyhow::bail!("drone {sysid}: its mission did not end in time (at step {step})");
            }
            let _ = tokio::time::timeout(Duration::from_millis(500), snaps.changed()).await;
        }
        // 2. The rendezvous: wait for the station.
        let station = self
            .shared
            .read(|s| s.landing_station(sysid).map(|st| st.sysid))
            .await
            .context("no landing station")?;
        let mut told = false;
        loop {
            let arrived = self
                .shared
                .read(|s| s.landing_station(sysid).is_some_and(|st| st.arrived))
                .await;
            if arrived {
                break;
            }
            if !told {
                self.shared.say(format!(
                    "drone {sysid}: waiting over its last cell for station {station}"
                ));
                told = true;
            }
            if tokio::time::Instant::now() > self.deadline {
                anyhow::bail!("drone {sysid}: station {station} never reached the rendezvous");
            }
            self.shared.wait_change(Duration::from_millis(500)).await;
        }
        // 3. Land on the station's charger slot.
        let (alt, slot) = self
            .shared
            .read(|s| {
                let alt = s
                    .drones
                    .iter()
                    .find(|d| d.sysid == sysid)
                    .map_or(10.0, |d| d.altitude_m);
                let slot = s
                    .cycle()
                    .and_then(|c| c.drones.iter().find(|d| d.sysid == sysid))
                    .map_or((0, 1), |d| d.slot);
                (alt, slot)
            })
            .await;
        dock(&self.shared, sysid, station, alt, slot).await?;
        self.landed().await
    }

    async fn landed(&self) -> anyhow::Result<()> {
        let sysid = self.sysid;
        let v = self.fleet().vehicle(sysid);
        let station = self
            .shared
            .read(|s| {
                s.landing_station(sysid)
                    .map(|st| (st.sysid, st.path.last().copied()))
            })
            .await;
        let (st, cell) = station.unwrap_or((0, None));
        let d = match (
            v.as_ref().and_then(|v| v.position),
            self.fleet().vehicle(st).and_then(|v| v.position),
        ) {
            (Some(a), Some(b)) => local::distance(a.lat, a.lon, b.lat, b.lon),
            _ => f64::NAN,
        };
        let cell = cell.unwrap_or_default();
        self.shared
            .commit(|s| {
                s.on_landed(sysid)?;
                Ok((
                    (),
                    vec![BanditEvent::Landed {
                        sysid,
                        cell,
                        from_station_m: d,
                    }],
                ))
            })
            .await?;
        if d.is_finite() && d > 1.5 {
            self.shared.say(format!(
                "drone {sysid}: landed {d:.1} m from station {st} — off its charger"
            ));
        }
        Ok(())
    }
}

/// Land drone `sysid` on charger slot `slot` = (index, of how many) of station `station`,
/// flying at `alt` metres: wait until the station has stopped, hover over its reported
/// position (its pad of [`pad_offset`]), land, and check that the drone charges — when its
/// autopilot reports charging at all; a drone that came down off the charger takes off and
/// lands again (three landings at most). Lost commands are tried again. Returns whether the
/// drone is known to charge.
async fn dock(
    shared: &Shared,
    sysid: u8,
    station: u8,
    alt: f64,
    slot: (usize, usize),
) -> anyhow::Result<bool> {
    let fleet = &shared.fleet;
    for landing in 1..=3 {
        let mut attempt = 0;
        loop {
            attempt += 1;
            match land_on(shared, sysid, station, alt, slot).await {
                Ok(()) => break,
                Err(e) if attempt < 5 => {
                    shared.say(format!(
                        "drone {sysid}: landing on station {station}: {e:#} (trying again)"
                    ));
                    if fleet
                        .vehicle(sysid)
                        .is_some_and(|v| v.on_ground() && !v.armed)
                    {
                        break;
                    }
                    tokio::time::sleep(shared.patience.secs(1.0)).await;
                }
                Err(e) => return Err(e),
            }
        }
        if charging(shared, sysid).await {
            return Ok(true);
        }
        if landing == 3 {
            shared.say(format!(
                "drone {sysid}: still off the charger of station {station} after 3 landings"
            ));
            return Ok(false);
        }
        shared.say(format!(
            "drone {sysid}: landed off the charger of station {station}: taking off to land again"
        ));
        flight::ensure_airborne(fleet, sysid, alt as f32, shared.patience).await?;
    }
    Ok(false)
}

/// Whether drone `sysid` charges once landed: `true` when its autopilot says so within a few
/// seconds, or has never reported charging in this run (nothing to check then).
async fn charging(shared: &Shared, sysid: u8) -> bool {
    let reports = shared
        .reports_charging
        .lock()
        .map(|s| s.contains(&sysid))
        .unwrap_or(false);
    if !reports {
        return true;
    }
    let wait = shared.patience.secs(8.0);
    shared
        .fleet
        .wait_until(sysid, wait, |v| v.charging == Some(true))
        .await
        .is_ok()
}

/// Spacing of the charging pads on a station, metres.
pub const PAD_SPACING_M: f64 = 0.6;

/// Where pad `slot.0` of `slot.1` lies from the station's centre, (north, east) metres: the
/// pads form the most compact square-ish grid ([`PAD_SPACING_M`] apart, centred), so five
/// drones on one station land within 0.85 m of its centre instead of 1.2 m in a row.
pub fn pad_offset(slot: (usize, usize)) -> (f64, f64) {
    let (i, n) = (slot.0, slot.1.max(1));
    let side = (1..=n).find(|s| s * s >= n).unwrap_or(n);
    let rows = n.div_ceil(side);
    let (r, c) = (i / side, i % side);
    let centre = |k: usize, of: usize| (k as f64 - (of as f64 - 1.0) / 2.0) * PAD_SPACING_M;
    (centre(r, rows), centre(c, side))
}

/// One landing of [`dock`].
async fn land_on(
    shared: &Shared,
    sysid: u8,
    station: u8,
    alt: f64,
    slot: (usize, usize),
) -> anyhow::Result<()> {
    let fleet = &shared.fleet;
    let patience = shared.patience;
    let speed = shared.read(|s| s.params.speed_m_s).await;
    // The station must stand still: a rover reports its waypoint reached up to its
    // acceptance radius before it stops.
    let _ = fleet
        .wait_until(station, patience.secs(10.0), |v| {
            v.groundspeed.is_none_or(|g| g < 0.2)
        })
        .await;
    let (north, east) = pad_offset(slot);
    let target = || -> anyhow::Result<(f64, f64)> {
        let pos = fleet
            .vehicle(station)
            .and_then(|v| v.position)
            .with_context(|| format!("station {station} reports no position"))?;
        Ok(local::offset(pos.lat, pos.lon, north, east))
    };
    let mut at = target()?;
    for _ in 0..3 {
        flight::fly_to(
            fleet,
            sysid,
            (at.0, at.1, alt as f32),
            speed as f32,
            0.25,
            patience,
        )
        .await?;
        let now = target()?;
        if local::distance(at.0, at.1, now.0, now.1) <= 0.3 {
            break;
        }
        at = now; // the station was still moving: follow it
    }
    fleet.land(sysid).await?;
    let wait = patience.secs(alt / 0.5 + 60.0);
    fleet
        .wait_until(sysid, wait, |v| v.on_ground() && !v.armed)
        .await
        .map_err(|_| anyhow::anyhow!("drone {sysid}: did not land within {wait:?}"))?;
    Ok(())
}

/// Most images measured and saved together (one state write for the batch).
const INTAKE_BATCH: usize = 64;

/// The image intake of the run: every image of a drone during a sortie becomes one
/// measurement (or a journalled reason why not).
///
/// Group commit: the images that are already waiting when one arrives (up to
/// [`INTAKE_BATCH`]) are measured together and saved in one state write, so the intake keeps
/// up with a large fleet (ten drones at 10× real time overran a write per image). A
/// measurement still counts only once the state that holds it is on disk.
async fn intake(shared: Arc<Shared>, mut rx: broadcast::Receiver<Arc<ReceivedImage>>) {
    let mut closed = false;
    while !closed {
        let mut batch = Vec::new();
        match rx.recv().await {
            Ok(img) => batch.push(img),
            Err(broadcast::error::RecvError::Lagged(n)) => {
                shared.say(format!("{n} image(s) dropped: the intake fell behind"));
                continue;
            }
            Err(broadcast::error::RecvError::Closed) => return,
        }
        while batch.len() < INTAKE_BATCH {
            match rx.try_recv() {
                Ok(img) => batch.push(img),
                Err(broadcast::error::TryRecvError::Lagged(n)) => {
                    shared.say(format!("{n} image(s) dropped: the intake fell behind"));
                }
                Err(broadcast::error::TryRecvError::Empty) => break,
                Err(broadcast::error::TryRecvError::Closed) => {
                    closed = true;
                    break;
                }
            }
        }
        if let Err(e) = take_images(&shared, batch).await {
            shared.say(format!("images not recorded: {e:#}"));
        }
    }
}

/// Where, when and how an image was taken.
#[derive(Clone, Debug)]
struct ImagePose {
    /// Latitude, degrees.
    lat: f64,
    /// Longitude, degrees.
    lon: f64,
    /// Altitude above home, metres (`None`: unknown).
    alt_m: Option<f64>,
    /// Attitude at the shutter (CAMERA_IMAGE_CAPTURED.q), body → NED (`None`: unknown).
    attitude: Option<UnitQuaternion<f64>>,
    /// The capture's name.
    key: CaptureKey,
}

/// Where, when and how an image was taken: what the camera said, else the vehicle's
/// latest telemetry.
fn image_pose(shared: &Shared, img: &ReceivedImage) -> anyhow::Result<ImagePose> {
    let sysid = img.sysid;
    Ok(match &img.pose {
        Some(p) => ImagePose {
            lat: p.lat,
            lon: p.lon,
            alt_m: Some(p.alt_rel_m),
            attitude: p.q.and_then(geometry::attitude_of_quaternion),
            key: (sysid, p.time_boot_ms, p.image_index),
        },
        None => {
            let v = shared.fleet.vehicle(sysid).context("vehicle not heard")?;
            let p = v.position.context("no position")?;
            let t = img.received.as_millis() as u32;
            ImagePose {
                lat: p.lat,
                lon: p.lon,
                alt_m: v.alt_rel.map(f64::from),
                attitude: None,
                key: (sysid, t, -1),
            }
        }
    })
}

/// The sanity limits of a measured image beyond its position (which
/// [`ClassificationState::match_image`] checks against the capture visits): the capture
/// altitude within [`sanity::VERTICAL_M`] of the drone's planned one and the camera within
/// [`sanity::MAX_TILT_DEG`] of level. A drone starts its batch as it reaches the cell's
/// waypoint, possibly still braking (14° at ArduCopter's 2.5 m/s²): tilted 10° at 10 m its
/// view is 1.8 m — almost half a cell — off the cell centre, and the measured square (0.6 of
/// the cell) would be mostly a neighbour's.
fn intake_limits() -> CaptureLimits {
    CaptureLimits {
        horizontal_m: f64::INFINITY,
        vertical_m: sanity::VERTICAL_M,
        max_tilt_deg: sanity::MAX_TILT_DEG,
        max_heading_error_deg: 180.0,
    }
}

/// What became of one image of a batch.
enum Taken {
    /// Not during a sortie of this drone: not journalled.
    NotFlying,
    /// Matched no capture visit.
    Ignored(String),
    /// Its measurement, or why it could not be measured.
    Measured(Result<(f64, bool), String>),
}

/// Measure a batch of images and record them in one commit (see [`intake`]).
async fn take_images(shared: &Arc<Shared>, batch: Vec<Arc<ReceivedImage>>) -> anyhow::Result<()> {
    let mut poses = Vec::with_capacity(batch.len());
    for img in &batch {
        match image_pose(shared, img) {
            Ok(p) => poses.push(Some(p)),
            Err(e) => {
                shared.say(format!("vehicle {}: image not recorded: {e:#}", img.sysid));
                poses.push(None);
            }
        }
    }
    // Which images match a capture visit (the commit below checks again, in order).
    let (pre, params, cell_m) = shared
        .read(|s| {
            let pre: Vec<Option<Result<f64, String>>> = batch
                .iter()
                .zip(&poses)
                .map(|(img, pose)| {
                    let pose = pose.as_ref()?;
                    let (lat, lon, key) = (pose.lat, pose.lon, pose.key);
                    let flying = s.cycle().is_some_and(|c| {
                        c.phase == CyclePhase::Started
                            && c.drones.iter().any(|d| d.sysid == img.sysid)
                    });
                    if !flying {
                        return None;
                    }
                    let m = match grid_xy(s, lat, lon) {
                        Some((e, n)) if !s.seen(key) => s.match_image(img.sysid, e, n),
                        Some(_) => Err("already counted".to_string()),
                        None => Err("position outside the grid's zone".to_string()),
                    };
                    let planned = s
                        .drones
                        .iter()
                        .find(|d| d.sysid == img.sysid)
                        .map_or(10.0, |d| d.altitude_m);
                    // Taken at the right altitude and level enough (one check with the
                    // runway runner's, vision::sanity).
                    let claim = CaptureClaim {
                        altitude_m: pose.alt_m,
                        attitude: pose.attitude,
                        ..CaptureClaim::default()
                    };
                    let m = m.and_then(|_| {
                        check_capture(&claim, planned, &intake_limits())
                            .map_err(|r| format!("picture {r}"))
                    });
                    Some(m.map(|_| pose.alt_m.unwrap_or(planned)))
                })
                .collect();
            (pre, s.params.clone(), s.grid.cell_size())
        })
        .await;
    let jobs: Vec<(usize, Arc<Vec<u8>>, f64)> = pre
        .iter()
        .enumerate()
        .filter_map(|(i, p)| match p {
            Some(Ok(alt)) => Some((i, batch[i].bytes.clone(), *alt)),
            _ => None,
        })
        .collect();
    let measured = tokio::task::spawn_blocking(move || {
        jobs.into_iter()
            .map(|(i, bytes, alt)| {
                let m = measure_image(
                    &bytes,
                    &params.green,
                    &params.camera,
                    alt,
                    cell_m,
                    params.crop_fraction,
                );
                (i, m)
            })
            .collect::<BTreeMap<usize, Result<(f64, bool), String>>>()
    })
    .await
    .context("measurement task")?;
    let mut measured = measured;
    let taken: Vec<Taken> = pre
        .into_iter()
        .enumerate()
        .map(|(i, p)| match p {
            None => Taken::NotFlying,
            Some(Err(reason)) => Taken::Ignored(reason),
            Some(Ok(_)) => Taken::Measured(
                measured
                    .remove(&i)
                    .unwrap_or_else(|| Err("not measured".to_string())),
            ),
        })
        .collect();
    if taken.iter().all(|t| matches!(t, Taken::NotFlying)) {
        return Ok(());
    }
    let classified = shared
        .commit(|s| {
            let mut events = Vec::new();
            let mut classified = Vec::new();
            for ((img, pose), t) in batch.iter().zip(&poses).zip(taken) {
                let sysid = img.sysid;
                let Some((lat, lon, key)) = pose.as_ref().map(|p| (p.lat, p.lon, p.key)) else {
                    continue;
                };
                let reason = match t {
                    Taken::NotFlying => continue,
                    Taken::Ignored(reason) => reason,
                    Taken::Measured(Err(reason)) => {
                        s.image_failures += 1;
                        events.push(BanditEvent::ImageFailed { sysid, reason });
                        continue;
                    }
                    Taken::Measured(Ok((fraction, positive))) => {
                        // Matched again: an earlier image of this batch may have taken the
                        // visit's last slot or the same capture.
                        let m = match grid_xy(s, lat, lon) {
                            Some((e, n)) if !s.seen(key) => s.match_image(sysid, e, n),
                            Some(_) => Err("already counted".to_string()),
                            None => Err("position outside the grid's zone".to_string()),
                        };
                        // `record` fails before it changes anything.
                        match m.and_then(|(visit, _)| {
                            s.record(sysid, visit, key, fraction, positive)
                                .map_err(|e| e.to_string())
                        }) {
                            Ok(r) => {
                                events.push(BanditEvent::Measurement(r.measurement.clone()));
                                for &(c, label) in &r.classified {
                                    let l = s.bandit.index_of(c);
                                    events.push(BanditEvent::Classified {
                                        cell: c,
                                        label,
                                        samples: l.map_or(0, |l| s.bandit.samples[l]),
                                        mean: l.map_or(0.0, |l| s.bandit.mean(l)),
                                    });
                                    classified.push((
                                        c,
                                        label,
                                        s.bandit.keep().len(),
                                        s.bandit.reject().len(),
                                        s.bandit.unclassified().len(),
                                    ));
                                }
                                continue;
                            }
                            Err(reason) => reason,
                        }
                    }
                };
                s.ignored_images += 1;
                events.push(BanditEvent::ImageIgnored { sysid, reason });
            }
            Ok((classified, events))
        })
        .await?;
    for (c, label, k, r, u) in classified {
        shared.say(format!(
            "cell {c}: {} (keep {k}, reject {r}, unclassified {u})",
            match label {
                Label::Keep => "interesting — keep",
                Label::Reject => "uninteresting — reject",
                Label::Unclassified => "unclassified",
            }
        ));
    }
    Ok(())
}

/// Airborne time of every drone and flight time of the sortie (in memory; saved with the
/// next change).
async fn track(shared: Arc<Shared>, drones: Vec<u8>) {
    let mut last = shared.fleet.clock().now();
    let mut tick = tokio::time::interval(Duration::from_millis(500));
    loop {
        tick.tick().await;
        let now = shared.fleet.clock().now();
        let dt = (now - last).as_secs_f64();
        last = now;
        let airborne: Vec<u8> = drones
            .iter()
            .copied()
            .filter(|&s| {
                shared
                    .fleet
                    .vehicle(s)
                    .is_some_and(|v| flight::airborne(&v))
            })
            .collect();
        if let Ok(mut set) = shared.reports_charging.lock() {
            for &s in &drones {
                if shared
                    .fleet
                    .vehicle(s)
                    .is_some_and(|v| v.charging == Some(true))
                {
                    set.insert(s);
                }
            }
        }
        let mut core = shared.core.lock().await;
        core.state.on_tick(&airborne, dt);
        if let Some(v) = &shared.view {
            let _ = v.send(Arc::new(core.state.clone()));
        }
    }
}

/// The image intake for a run: its receivers wait 300 ms of *wall* time for missing packets
/// whatever the fleet clock's speed-up (B images per visit arrive in bursts).
pub fn image_hub(fleet: &FleetHandle) -> ImageHub {
    let k = fleet.clock().speedup().clamp(1.0, 100.0);
    let d = crate::imagery::transfer::ReceiverConfig::default();
    crate::app::images::spawn_with(
        fleet,
        crate::imagery::transfer::ReceiverConfig {
            idle: d.idle.mul_f64(k),
            ..d
        },
    )
}

/// A new spatial-classification state for `def` once every vehicle is heard and reports a
/// position (`lock_step` overrides the separation the mission implies).
pub async fn new_state(
    fleet: &FleetHandle,
    def: &crate::mission::definition::MissionDef,
    wait: Duration,
    lock_step: Option<bool>,
) -> anyhow::Result<ClassificationState> {
    super::wait_for_team(fleet, def, wait).await?;
    for v in &def.vehicles {
        fleet
            .wait_until(v.sysid, wait, |s| s.position.is_some())
            .await
            .map_err(|_| {
                anyhow::anyhow!(
                    "vehicle {} reported no position within {:.0} s",
                    v.sysid,
                    wait.as_secs_f64()
                )
            })?;
    }
    let grid = super::mission_grid(fleet, def, wait).await?;
    Ok(ClassificationState::new(def, grid, lock_step)?)
}

/// Run (or resume) a spatial-classification run with `fleet` until every cell is classified.
/// The vehicles must already be heard. Returns the final state.
pub async fn run(
    fleet: FleetHandle,
    hub: &ImageHub,
    mut run_dir: RunDir,
    mut state: ClassificationState,
    mut opts: RunOptions,
) -> anyhow::Result<ClassificationState> {
    let resumed = state.measurements > 0 || state.epoch.is_some() || !state.epochs.is_empty();
    if resumed {
        state.on_resume();
        // The journal may lack the last measurement the state holds (killed between the
        // two writes): append it now, so journal and state agree.
        let last_logged = run_dir
            .read_events::<BanditEvent>()?
            .events
            .iter()
            .rev()
            .find_map(|e| match &e.event {
                BanditEvent::Measurement(m) if m.counted => Some(m.n),
                _ => None,
            })
            .unwrap_or(0);
        if let Some(m) = state.last_measurement.clone()
            && m.n > last_logged
        {
            run_dir.append_event(&BanditEvent::Measurement(m))?;
        }
    }
    run_dir.save_state(&state).context("saving the run state")?;
    run_dir
        .append_event(&BanditEvent::Started { resumed })
        .context("writing the run journal")?;
    let drones: Vec<u8> = state.drones.iter().map(|d| d.sysid).collect();
    let (changed, _) = watch::channel(0u64);
    let shared = Arc::new(Shared {
        core: Mutex::new(Core {
            state,
            run: run_dir,
        }),
        changed,
        progress: opts.progress.take(),
        view: opts.view.take(),
        fleet: fleet.clone(),
        patience: opts.patience,
        reports_charging: std::sync::Mutex::new(BTreeSet::new()),
    });
    let runner = Runner {
        shared: shared.clone(),
        plan_time_limit_s: opts.plan_time_limit_s,
        min_takeoff_pct: opts.min_takeoff_pct,
        pause: opts.pause.take(),
    };
    if !resumed {
        runner.check_start_positions().await?;
    }
    runner.upload_fences().await?;
    let tracker = tokio::spawn(track(shared.clone(), drones));
    let images = tokio::spawn(intake(shared.clone(), hub.subscribe()));
    let result = drive(&runner, resumed).await;
    tracker.abort();
    images.abort();
    let mut core = shared.core.lock().await;
    let Core { state, run } = &mut *core;
    run.save_state(state).context("saving the run state")?;
    if result.is_ok() && state.is_finished() {
        run.append_event(&BanditEvent::Finished {
            keep: state.bandit.keep(),
            reject: state.bandit.reject(),
        })
        .context("writing the run journal")?;
    }
    if let Some(v) = &shared.view {
        let _ = v.send(Arc::new(state.clone()));
    }
    result.map(|()| state.clone())
}

async fn drive(runner: &Runner, resumed: bool) -> anyhow::Result<()> {
    let mut resume_follow = false;
    if resumed {
        let next = runner.shared.read(|s| s.next()).await;
        match next {
            Next::Upload | Next::Start => {
                // Nothing had started: drop the sortie and plan again from where the team is.
                let snap = runner.fleet().snapshot().vehicles;
                let st = runner.shared.read(|s| s.clone()).await;
                let actual = observed_config(&st, &snap, &st.config)?;
                let p = st.bandit.epoch;
                runner
                    .shared
                    .commit(|s| {
                        s.abandon_cycle(actual)?;
                        Ok(((), vec![BanditEvent::SortieDropped { epoch: p }]))
                    })
                    .await?;
                runner.say(format!(
                    "resumed: the prepared sortie of epoch {p} had not started; planning again"
                ));
            }
            Next::Follow => {
                resume_follow = true;
                runner.say("resumed in the middle of a sortie: following it to its end".into());
            }
            Next::Plan | Next::Prepare => {
                runner
                    .shared
                    .commit(|s| {
                        if let Some(e) = &mut s.epoch {
                            e.plan = None;
                            e.next_cycle = 0;
                        }
                        Ok(((), Vec::new()))
                    })
                    .await?;
            }
            _ => {}
        }
    }
    let mut replan = resumed;
    loop {
        let next = runner.shared.read(|s| s.next()).await;
        match next {
            Next::Finished => {
                let (k, r) = runner
                    .shared
                    .read(|s| (s.bandit.keep(), s.bandit.reject()))
                    .await;
                let list: Vec<String> = k.iter().map(|c| c.to_string()).collect();
                runner.say(format!(
                    "every cell classified: keep {} ({}), reject {}",
                    k.len(),
                    list.join(" "),
                    r.len()
                ));
                return Ok(());
            }
            Next::BeginEpoch => {
                replan = false;
                runner.begin_epoch().await?;
            }
            Next::Plan => {
                runner.plan(replan).await?;
                replan = true;
            }
            Next::Prepare => runner.prepare().await?,
            Next::Upload => runner.upload().await?,
            Next::Start => runner.start().await?,
            Next::Follow => {
                runner.follow(resume_follow).await?;
                resume_follow = false;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A drone on the far pad of a station that stopped short of its cell, nearer to it than
    /// to the neighbouring station but within 2.5 m of both, is on its own station.
    #[test]
    fn a_drone_is_on_the_nearest_station() {
        use crate::mission::definition::{MissionDef, Origin};
        let def = MissionDef::parse(super::super::bandit_sim::HARDWARE_MISSION, "h.toml").unwrap();
        let Origin::Coordinates(o) = def.grid.origin else {
            panic!("fixed origin");
        };
        let grid = crate::geo::Grid::new(LatLon::new(o.lat, o.lon), def.grid.cell_size_m).unwrap();
        let state = ClassificationState::new(&def, grid, None).unwrap();
        // Stations 5 and 6 on the road cells (3, 1) and (3, 2), 5 m apart in the plan, but
        // station 5 stopped 2.2 m east of its cell's centre: 2.8 m from station 6.
        let expected = TeamConfig {
            drones: vec![
                Cell::new(3, 1),
                Cell::new(3, 1),
                Cell::new(3, 2),
                Cell::new(3, 2),
            ],
            stations: vec![Cell::new(3, 1), Cell::new(3, 2)],
        };
        let beat = crate::proto::heartbeat::Beat {
            custom_mode: 0,
            mav_type: 2,
            autopilot: 3,
            base_mode: 0,
            system_status: 3,
        };
        let s = state.grid.cell_size();
        let at = |sysid: u8, east: f64, north: f64| {
            let mut v = VehicleSnapshot::new(sysid, 1, &beat, 0, crate::time::Time::ZERO);
            let p = state.grid.from_xy(east, north).unwrap();
            v.position = Some(crate::fleet::GeoPoint {
                lat: p.lat,
                lon: p.lon,
                alt_amsl: 600.0,
            });
            (sysid, v)
        };
        let (e5, e6, n) = (1.0 * s + 2.2, 2.0 * s, 3.0 * s);
        let snap: BTreeMap<u8, VehicleSnapshot> = [
            at(1, e5 - 0.3, n),
            at(2, e5 + 0.3, n),
            // on station 6's west pad, landed 0.2 m off: 2.3 m from station 5 (listed first)
            at(3, e6 - 0.5, n),
            at(4, e6 + 0.3, n),
            at(5, e5, n),
            at(6, e6, n),
        ]
        .into_iter()
        .collect();
        assert!(
            (e6 - 0.5) - e5 <= 2.5,
            "drone 3 is within 2.5 m of station 5 too"
        );
        let c = observed_config(&state, &snap, &expected).unwrap();
        assert_eq!(c, expected);
        state.validate_config(&c).unwrap();
    }

    #[test]
    fn pads_are_distinct_and_close_to_the_centre() {
        assert_eq!(pad_offset((0, 1)), (0.0, 0.0));
        let two = [pad_offset((0, 2)), pad_offset((1, 2))];
        assert_eq!(two, [(0.0, -0.3), (0.0, 0.3)]);
        for n in 1..=9 {
            let pads: Vec<(f64, f64)> = (0..n).map(|i| pad_offset((i, n))).collect();
            for (i, a) in pads.iter().enumerate() {
                assert!(a.0.hypot(a.1) <= 0.85, "{n} pads: {a:?}");
                for b in &pads[i + 1..] {
                    assert!((a.0 - b.0).hypot(a.1 - b.1) >= PAD_SPACING_M - 1e-9);
                }
            }
        }
    }

    #[test]
    fn crop_covers_the_fraction_of_a_cell_at_any_altitude() {
        let cam = CameraModel::paper();
        let img = RgbImage::new(480, 480);
        // 10 m up: a 10 m footprint; 0.6 of a 5 m cell is 3 m = 144 px
        assert_eq!(
            crop_to_cell(&img, &cam, 10.0, 5.0, 0.6).dimensions(),
            (144, 144)
        );
        assert_eq!(
            crop_to_cell(&img, &cam, 20.0, 5.0, 0.6).dimensions(),
            (72, 72)
        );
        // lower than the cell: the whole image
        assert_eq!(
            crop_to_cell(&img, &cam, 2.0, 5.0, 0.6).dimensions(),
            (480, 480)
        );
    }

    #[test]
    fn a_green_tile_under_the_camera_is_a_positive_measurement() {
        let cam = CameraModel::paper();
        // the centre 40 % green, the rest grey: positive once cropped to the cell
        let img = RgbImage::from_fn(200, 200, |x, y| {
            if (60..140).contains(&x) && (60..140).contains(&y) {
                image::Rgb([40, 165, 70])
            } else {
                image::Rgb([128, 128, 128])
            }
        });
        let mut png = Vec::new();
        img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
            .unwrap();
        let g = GreenParams {
            min_fraction: 0.2,
            ..GreenParams::default()
        };
        let (f, pos) = measure_image(&png, &g, &cam, 10.0, 5.0, 0.6).unwrap();
        assert!(pos && f > 0.99, "{f}");
        // uncropped, a high drone would see mostly grey
        let (f, _) = measure_image(&png, &g, &cam, 2.0, 5.0, 0.6).unwrap();
        assert!(f < 0.2, "{f}");
        assert!(measure_image(b"not an image", &g, &cam, 10.0, 5.0, 0.6).is_err());
    }
}
