//! Sortie helpers without a runner: what the team observably did (missions done, the
//! configuration it ended in), time and charge estimates, and the verified upload of
//! missions and fences with retries of transient failures.

use super::error::BanditError;
use super::*;
use crate::app::error::{Check, RunnerError, RunnerResult};

/// Whether the vehicle has done its whole mission `items`: MISSION_ITEM_REACHED of the last
/// item, or MISSION_CURRENT COMPLETE on the last item once this mission is known to have
/// run — MISSION_STATE_ACTIVE was seen (`seen_active`), or an item of it was reported
/// reached (the fleet forgets reached items when a mission starts, so any is this one's).
///
/// What ArduRover sends (SITL V4.7.0-dev 90700977, fleetmap's station mission
/// DO_CHANGE_SPEED + NAV_WAYPOINT, wire seq 1 and 2 behind home): on MISSION_START at once
/// MISSION_ITEM_REACHED 1 (AP_Mission reports the do-command as it starts the next nav
/// command), MISSION_CURRENT seq 2 ACTIVE, then MISSION_ITEM_REACHED 2 with "Reached
/// waypoint #2" and "Mission Complete", MISSION_CURRENT seq 2 COMPLETE, the rover staying in
/// AUTO. A waypoint within WP_RADIUS is reached within a second of the start, so the one
/// ACTIVE report (MISSION_CURRENT comes at 1 Hz) is easily missed; the early MISSION_ITEM_
/// REACHED of item 0 still says the mission ran when the last item's report is lost.
pub(super) fn is_complete(v: &VehicleSnapshot, items: &[MissionItem], seen_active: bool) -> bool {
    let Some(last) = items.len().checked_sub(1) else {
        return true;
    };
    let last = last as u16;
    let ran = seen_active || !v.reached.is_empty();
    v.reached.contains(&last) || (ran && v.mission_complete() && v.mission_current == Some(last))
}

/// The items a vehicle is known to have done: those reported reached since the mission
/// started and, after a restart of the GCS (`resumed`: the reports sent meanwhile are gone),
/// every item before the current one. (MISSION_CURRENT is not used otherwise: the fleet
/// keeps the previous sortie's value until the vehicle reports the new one.)
pub(super) fn done_items(
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

pub(super) fn grid_xy(state: &ClassificationState, lat: f64, lon: f64) -> Option<(f64, f64)> {
    state.grid.to_xy(LatLon::new(lat, lon)).ok()
}

/// Where telemetry puts the team: a vehicle within 0.75 cell of the cell `expected` says is
/// on that cell; a drone within 2.5 m of a station is on the nearest such station's cell;
/// otherwise the cell its position is in.
pub(super) fn observed_config(
    state: &ClassificationState,
    snap: &BTreeMap<u8, VehicleSnapshot>,
    expected: &TeamConfig,
) -> RunnerResult<TeamConfig> {
    let s = state.grid.cell_size();
    let pos = |sysid: u8| -> RunnerResult<(f64, f64)> {
        let v = snap.get(&sysid).ok_or(Check::NotHeard { sysid })?;
        let p = v.position.ok_or(Check::NoPosition { sysid })?;
        Ok(grid_xy(state, p.lat, p.lon).ok_or(Check::BadPosition { sysid })?)
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
pub(super) fn sortie_estimate_s(state: &ClassificationState, items: &[MissionItem]) -> f64 {
    let mut t = 20.0 + 2.0 * state.drones.first().map_or(10.0, |d| d.altitude_m);
    let mut last: Option<(f64, f64)> = None;
    for it in items {
        match it.command {
            fleetmap_core::mission::item::cmd::NAV_WAYPOINT => {
                let p = (it.lat(), it.lon());
                if let Some(q) = last {
                    t += local::distance(q.0, q.1, p.0, p.1) / state.params.speed_m_s.max(0.1);
                }
                t += 2.0;
                last = Some(p);
            }
            fleetmap_core::mission::item::cmd::NAV_LOITER_TIME => t += f64::from(it.param1),
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
pub(super) fn observed_sortie_s(state: &ClassificationState) -> f64 {
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
pub(super) fn charge_needed_pct(state: &ClassificationState, estimate_s: f64) -> f64 {
    let minutes = state.params.flight_time_min.max(0.5);
    let use_pct = estimate_s / 60.0 / minutes * 100.0 * 1.2;
    (state.params.rtl_reserve_pct + 1.5 * use_pct).min(98.0)
}

/// Enable the uploaded fence on an ArduPilot drone (DO_FENCE_ENABLE). Not on an ArduPilot
/// rover: with its fence enabled, ArduRover's simple avoidance (AVOID_ENABLE fence bit, on by
/// default) keeps it AVOID_MARGIN (2 m) from every fence edge and backs it off
/// (`Mode::calc_throttle` → `AC_Avoid::adjust_speed`, ArduPilot/ardupilot Rover/mode.cpp),
/// and the no-fly polygons, shrunk by at most 1 m, lie only 1–1.5 m from a station's road:
/// on ArduRover SITL V4.7.0-dev (90700977), hardware-6x6 epoch 0, station 5 rocked for
/// minutes 2 m from no-fly cell (2, 2)'s polygon — on the diagonal leg (2, 1) → (3, 2), and,
/// with that leg routed through (3, 1), on the U-turn at (3, 2) — its waypoint never reached.
/// A station's list is checked by the GCS instead (road cells only, no leg
/// through a no-fly cell: [`missions::check_mission`], in [`upload_once`]); the fence stays
/// uploaded (disabled) for the operator to see.
pub(super) async fn enable_fence(fleet: &FleetHandle, v: &VehicleSnapshot) -> RunnerResult<()> {
    if v.flavour.home_item() && v.flavour.flies() {
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

/// Whether a failed operation may succeed when tried again: no answer (a lost frame, a busy
/// link), as opposed to the vehicle saying no.
pub(super) fn transient(e: &RunnerError) -> bool {
    // The rule itself is the fleet's ([`crate::fleet::FleetError::is_transient`]).
    e.is_transient()
}

/// [`upload_once`], tried up to three times while the vehicle does not answer; a refusal
/// (MISSION_ACK with an error, or a list that reads back different) is final.
pub(super) async fn upload_verified(
    fleet: &FleetHandle,
    sysid: u8,
    kind: MissionType,
    items: &[MissionItem],
    check: Option<(&ClassificationState, Cell, bool)>,
) -> RunnerResult<()> {
    let mut attempt = 0;
    loop {
        attempt += 1;
        match upload_once(fleet, sysid, kind, items, check).await {
            Err(e) if attempt < 3 && transient(&e) => {
                tracing::warn!(
                    "vehicle {sysid}: {} (trying again)",
                    crate::app::error::chain(&e)
                );
            }
            r => return r,
        }
    }
}

/// Upload `items` of `kind`, read them back and compare (and, for missions, check the
/// read-back list against the no-fly cells).
pub(super) async fn upload_once(
    fleet: &FleetHandle,
    sysid: u8,
    kind: MissionType,
    items: &[MissionItem],
    check: Option<(&ClassificationState, Cell, bool)>,
) -> RunnerResult<()> {
    let v = fleet
        .vehicle(sysid)
        .ok_or(crate::fleet::FleetError::NoVehicle { sysid })?;
    fleet.upload_mission(sysid, kind, items.to_vec()).await?;
    let (back, _) = fleet.download_mission(sysid, kind).await?;
    fleetmap_core::mission::wire::compare_items(items, &back, v.flavour.home_item()).map_err(
        |source| RunnerError::ReadBack {
            what: "list",
            source,
        },
    )?;
    if let Some((state, start, station)) = check {
        let rules = AreaRules {
            rows: state.layout.rows,
            cols: state.layout.cols,
            obstacles: &state.layout.obstacles,
            roads: station.then_some(state.layout.roads.as_slice()),
        };
        missions::check_mission(&state.grid, &rules, start, &back).map_err(|source| {
            BanditError::UnsafeMission {
                role: "vehicle",
                sysid,
                read_back: true,
                source,
            }
        })?;
    }
    Ok(())
}
