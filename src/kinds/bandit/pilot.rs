//! One drone's pilot during a sortie (follow its mission, land at the end) and the docking
//! on a charging rover's pad.

use super::error::{BanditError, Overdue};
use super::*;
use crate::app::error::RunnerResult;

impl DronePilot {
    pub(super) fn fleet(&self) -> &FleetHandle {
        &self.shared.fleet
    }

    pub(super) async fn run(self) -> RunnerResult<()> {
        let sysid = self.sysid;
        let mut snaps = self.fleet().watch();
        let mut seen_active = self.resumed;
        let mut step = 0;
        // The autopilot's last warning (severity ≤ WARNING), for the messages below.
        let mut warning: Option<String> = None;
        // 1. Its cells.
        loop {
            if self.no_mission {
                // Its mission did not start: it hovers over its station until the rendezvous.
                break;
            }
            let v = self
                .fleet()
                .vehicle(sysid)
                .ok_or(crate::fleet::FleetError::NoVehicle { sysid })?;
            if v.mission_active() {
                seen_active = true;
            }
            if let Some(t) = &v.last_text
                && t.severity <= fleetmap_core::proto::severity::Severity::Warning
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
            if taken_over(&v, self.resumed) {
                return self.taken_home(step, warning.as_deref()).await;
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
                    // Down before the end of its mission (a failsafe LAND, a crash, a
                    // disarm on the ground): out of the run, the others go on.
                    return self.taken_home(step, warning.as_deref()).await;
                }
            }
            if self.shared.fleet.clock().now() > self.deadline {
                return Err(Overdue::Mission { sysid, step }.into());
            }
            let _ = tokio::time::timeout(Duration::from_millis(500), snaps.changed()).await;
        }
        // 2. The rendezvous: wait for the station.
        let station = self
            .shared
            .read(|s| s.landing_station(sysid).map(|st| st.sysid))
            .await
            .ok_or(BanditError::NoLandingStation)?;
        let mut told = false;
        loop {
            let arrived = self
                .shared
                .read(|s| s.landing_station(sysid).is_some_and(|st| st.arrived))
                .await;
            if arrived {
                break;
            }
            if let Some(v) = self.fleet().vehicle(sysid) {
                if v.on_ground() && !v.armed && self.resumed {
                    // It landed while no GCS was listening.
                    return self.landed().await;
                }
                if taken_over(&v, self.resumed) || (v.on_ground() && !v.armed) {
                    return self.taken_home(step, warning.as_deref()).await;
                }
            }
            if !told {
                self.shared.say(
                    Progress::info(format!(
                        "drone {sysid}: waiting over its last cell for station {station}"
                    ))
                    .about(sysid),
                );
                told = true;
            }
            if self.shared.fleet.clock().now() > self.deadline {
                return Err(Overdue::Rendezvous { sysid, station }.into());
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

    /// The drone's autopilot took it out of its mission (a battery or link failsafe: RTL or
    /// LAND that the GCS did not ask for), or it came down before the end of its mission:
    /// the operator is told why, it is followed until it has landed where its autopilot
    /// takes it, and it goes out of the run ([`ClassificationState::sideline`]) — the
    /// measurements it made count, the visits it did not fly are planned again for the
    /// others, and it rejoins once ready again (a fresh battery: the runner flies it to a
    /// station first, [`Runner::members_back`]).
    pub(super) async fn taken_home(&self, step: usize, warning: Option<&str>) -> RunnerResult<()> {
        let sysid = self.sysid;
        let v = self
            .fleet()
            .vehicle(sysid)
            .ok_or(crate::fleet::FleetError::NoVehicle { sysid })?;
        let battery = v
            .battery_pct
            .map(|p| format!("{p} %"))
            .unwrap_or_else(|| "?".into());
        let reason = format!(
            "its autopilot took it out of its mission at step {step} (mode {}, battery {battery}, \
             its last warning: {})",
            v.mode,
            warning.unwrap_or("none")
        );
        self.shared.say(
            Progress::warning(format!(
                "drone {sysid}: {reason}: its measurements count, the visits it has not flown \
                 are planned again for the others; it lands where its autopilot takes it"
            ))
            .about(sysid),
        );
        let clock = self.fleet().clock();
        let wait = clock.wall_until(self.deadline);
        if self
            .fleet()
            .wait_until(sysid, wait, |v| v.on_ground() && !v.armed)
            .await
            .is_err()
        {
            return Err(Overdue::TakenOut {
                sysid,
                mode: v.mode.clone(),
            }
            .into());
        }
        let fix = format!(
            "swap its battery if it is low (battery {battery}) and check why its autopilot \
             took over; once it is ready to arm, fleetmap flies it to the nearest station and \
             it rejoins"
        );
        let epoch = self.shared.read(|s| s.bandit.epoch).await;
        self.shared
            .commit(|s| {
                s.on_landed(sysid)?;
                s.sideline(sysid, reason.clone(), Some(fix.clone()))?;
                Ok((
                    (),
                    vec![BanditEvent::VehicleOut {
                        sysid,
                        role: Role::Drone,
                        reason: reason.clone(),
                        fix: Some(fix.clone()),
                        epoch,
                    }],
                ))
            })
            .await?;
        self.shared.say(
            Progress::notice(format!("drone {sysid}: landed, out of the run: {fix}")).about(sysid),
        );
        Ok(())
    }

    pub(super) async fn landed(&self) -> RunnerResult<()> {
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
            self.shared.say(
                Progress::warning(format!(
                    "drone {sysid}: landed {d:.1} m from station {st} — off its charger"
                ))
                .about(sysid),
            );
        }
        Ok(())
    }
}

/// Whether the drone's autopilot has taken it over in flight: a return or a landing the GCS
/// does not ask for while a drone flies its mission or waits for its station. The GCS lands
/// a drone with LAND only in [`land_on`], after this pilot's watch — but a run resumed
/// (`resumed`) may find a drone in the LAND its last GCS gave it over its station: then only
/// a return (RTL, SMART_RTL: never asked for by this runner) is the autopilot's.
fn taken_over(v: &VehicleSnapshot, resumed: bool) -> bool {
    use fleetmap_core::proto::mode::{CopterMode, Mode, Px4Mode};
    let landing = |m: Mode| matches!(m, Mode::Copter(CopterMode::Land) | Mode::Px4(Px4Mode::Land));
    flight::airborne(v)
        && v.flight_mode()
            .is_some_and(|m| m.is_failsafe_return_or_land() && !(resumed && landing(m)))
}

/// Land drone `sysid` on charger slot `slot` = (index, of how many) of station `station`,
/// flying at `alt` metres: wait until the station has stopped, hover over its reported
/// position (its pad of [`pad_offset`]), land, and check that the drone charges — when its
/// autopilot reports charging at all; a drone that came down off the charger takes off and
/// lands again (three landings at most). Lost commands are tried again. Returns whether the
/// drone is known to charge.
pub(super) async fn dock(
    shared: &Shared,
    sysid: u8,
    station: u8,
    alt: f64,
    slot: (usize, usize),
) -> RunnerResult<bool> {
    let fleet = &shared.fleet;
    for landing in 1..=3 {
        let mut attempt = 0;
        loop {
            attempt += 1;
            match land_on(shared, sysid, station, alt, slot).await {
                Ok(()) => break,
                Err(e) if attempt < 5 => {
                    shared.say(
                        Progress::warning(format!(
                            "drone {sysid}: landing on station {station}: {} (trying again)",
                            crate::app::error::chain(&e)
                        ))
                        .about(sysid),
                    );
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
            shared.say(
                Progress::warning(format!(
                    "drone {sysid}: still off the charger of station {station} after 3 landings"
                ))
                .about(sysid),
            );
            return Ok(false);
        }
        shared.say(Progress::warning(format!(
            "drone {sysid}: landed off the charger of station {station}: taking off to land again"
        )).about(sysid));
        flight::ensure_airborne(fleet, sysid, alt as f32, shared.patience).await?;
    }
    Ok(false)
}

/// Whether drone `sysid` charges once landed: `true` when its autopilot says so within a few
/// seconds, or has never reported charging in this run (nothing to check then).
pub(super) async fn charging(shared: &Shared, sysid: u8) -> bool {
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
pub(crate) const PAD_SPACING_M: f64 = 0.6;

/// Where pad `slot.0` of `slot.1` lies from the station's centre, (north, east) metres: the
/// pads form the most compact square-ish grid ([`PAD_SPACING_M`] apart, centred), so five
/// drones on one station land within 0.85 m of its centre instead of 1.2 m in a row.
pub(crate) fn pad_offset(slot: (usize, usize)) -> (f64, f64) {
    let (i, n) = (slot.0, slot.1.max(1));
    let side = (1..=n).find(|s| s * s >= n).unwrap_or(n);
    let rows = n.div_ceil(side);
    let (r, c) = (i / side, i % side);
    let centre = |k: usize, of: usize| (k as f64 - (of as f64 - 1.0) / 2.0) * PAD_SPACING_M;
    (centre(r, rows), centre(c, side))
}

/// One landing of [`dock`].
pub(super) async fn land_on(
    shared: &Shared,
    sysid: u8,
    station: u8,
    alt: f64,
    slot: (usize, usize),
) -> RunnerResult<()> {
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
    let target = || -> RunnerResult<(f64, f64)> {
        let pos = fleet
            .vehicle(station)
            .and_then(|v| v.position)
            .ok_or(BanditError::StationPosition { station })?;
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
        .map_err(|_| Overdue::Landing { sysid, wait })?;
    Ok(())
}
