//! One vehicle's pilot: the loop that asks the mapping state for the next directive and
//! drives the vehicle through it (fly to a cell, battery checks and swaps, home and land).
//! The pictures of a visit are in [`super::intake`], the sweep in [`super::sweep`].

use super::*;
use crate::app::error::RunnerResult;
use crate::app::kind::OperatorTask;
use fleetmap_core::explore::reach::Reach;

/// Seconds a drone is counted over a cell per picture still to take, when the reach rule
/// charges a visit (the cell drifts on meanwhile). Measured on the embedded simulator's
/// plume demo: 2–3 s per picture (capture, transfer of a 480 × 480 JPEG, classification),
/// rounded up.
const DWELL_PER_PICTURE_S: f64 = 3.0;

/// Longest hold, seconds of the fleet clock, before a drone waiting for a drifting cell to
/// come within reach asks again.
const REACH_RECHECK_S: f64 = 10.0;

impl Pilot {
    pub(super) fn fleet(&self) -> &FleetHandle {
        &self.shared.fleet
    }

    pub(super) fn vehicle(&self) -> Option<VehicleSnapshot> {
        self.fleet().vehicle(self.sysid)
    }

    /// Wait until the state changes, or `timeout`.
    pub(super) async fn wait_change(&self, timeout: Duration) {
        let mut rx = self.shared.run.subscribe();
        rx.borrow_and_update();
        let _ = tokio::time::timeout(timeout, rx.changed()).await;
    }

    /// What this pilot is doing now, for the mission clock.
    pub(super) fn doing(&self, activity: Activity) {
        self.shared.doing(self.sysid, activity);
    }

    pub(super) async fn wait_unpaused(&self) {
        let mut rx = self.shared.paused.subscribe();
        let mut told = false;
        while *rx.borrow_and_update() {
            self.doing(Activity::Waiting(Wait::Operator));
            if !told && !self.held {
                let _ = flight::hold_here(self.fleet(), self.sysid).await;
                told = true;
            }
            if rx.changed().await.is_err() {
                return;
            }
        }
    }

    pub(super) async fn run(mut self) -> RunnerResult<PilotEnd> {
        let mut failures = 0u32;
        // When a step first failed with nothing heard from the vehicle (fleet clock): its
        // link is dark, said once, and again when it is back.
        let mut dark: Option<Time> = None;
        loop {
            self.wait_unpaused().await;
            let stepped = self.step().await;
            self.link_back(&mut dark);
            match stepped {
                Ok(Some(end)) => return Ok(end),
                Ok(None) => {
                    failures = 0;
                    // A step flown: groundings in a row start again from zero.
                    if self.vehicle().is_some_and(|v| flight::airborne(&v)) {
                        self.grounded.0 = 0;
                    }
                }
                Err(e) => {
                    failures += 1;
                    let reason = crate::app::error::chain(&e);
                    if !self.link_dark(&mut dark, &reason) {
                        self.shared.say(
                            Progress::warning(format!(
                                "vehicle {}: {reason} (retrying)",
                                self.sysid
                            ))
                            .about(self.sysid),
                        );
                    }
                    let sysid = self.sysid;
                    let max = self.shared.patience.secs(2.0);
                    let _ = self
                        .shared
                        .commit(|_| {
                            Ok((
                                (),
                                Some(MappingEvent::StepFailed {
                                    sysid,
                                    reason: reason.clone(),
                                }),
                            ))
                        })
                        .await;
                    // A drone that cannot take off, or whose steps keep failing, leaves the
                    // tree; the others go on.
                    if self.cannot_take_off(&e) || failures >= self.shared.max_failures.max(1) {
                        failures = 0;
                        self.ground(&e).await?;
                        continue;
                    }
                    tokio::time::sleep(max).await;
                }
            }
        }
    }

    /// One directive. `Some` ends the pilot.
    pub(super) async fn step(&mut self) -> RunnerResult<Option<PilotEnd>> {
        let sysid = self.sysid;
        // A recall from the operator, or a low battery, comes first.
        if self.check_battery().await? {
            self.doing(Activity::Working);
            return Ok(None);
        }
        let d = self.shared.decide(sysid).await?;
        match d {
            Directive::Sweep => {
                self.held = false;
                self.doing(Activity::Working);
                self.sweep().await?;
            }
            Directive::Hold => {
                // Held by another drone's confirmation, or by the others' sweeps.
                let confirming = self
                    .shared
                    .read(|s| matches!(s.phase, Phase::Confirm { .. }))
                    .await;
                self.doing(Activity::Waiting(if confirming {
                    Wait::Confirmation
                } else {
                    Wait::Sweep
                }));
                if !self.held
                    && let Some(v) = self.vehicle()
                    && flight::airborne(&v)
                {
                    flight::hold_here(self.fleet(), sysid).await?;
                    self.held = true;
                }
                self.wait_change(Duration::from_millis(500)).await;
            }
            Directive::Confirm(cell) => {
                if !self.in_reach(cell).await? {
                    return Ok(None);
                }
                self.held = false;
                self.doing(Activity::Working);
                self.fly_to_cell(cell).await?;
                if self.take_images(cell).await? {
                    let now = self.shared.now();
                    let root = self
                        .shared
                        .commit(|s| {
                            let root = s.on_confirmed(sysid, cell, now)?;
                            Ok((root, Some(MappingEvent::Confirmed { sysid, cell, root })))
                        })
                        .await?;
                    match root {
                        Some(r) => self.shared.say(Progress::info(format!(
                            "vehicle {sysid}: cell {cell} confirmed: the recursive DFS starts at {r}"
                        )).about(sysid)),
                        None => self.shared.say(Progress::info(format!(
                            "vehicle {sysid}: cell {cell} is not runway after all: sweeping on"
                        )).about(sysid)),
                    }
                }
            }
            Directive::Dfs(Action::MoveTo(cell) | Action::Rejoin(cell)) => {
                if !self.in_reach(cell).await? {
                    return Ok(None);
                }
                self.held = false;
                self.doing(Activity::Working);
                self.fly_to_cell(cell).await?;
                let now = self.shared.now();
                self.shared
                    .commit(|s| {
                        s.on_arrived(sysid, cell, now)?;
                        Ok(((), Some(MappingEvent::Arrived { sysid, cell })))
                    })
                    .await?;
            }
            Directive::Dfs(Action::Observe) => {
                let cell = self
                    .shared
                    .read(|s| {
                        s.explorer
                            .as_ref()
                            .map(|e| e.robot_cell(fleetmap_core::explore::dfs::RobotId(sysid)))
                    })
                    .await
                    .ok_or(super::error::RunwayError::NoExplorer)??;
                if self.take_images(cell).await? {
                    let now = self.shared.now();
                    let added = self
                        .shared
                        .commit(|s| {
                            let added = s.on_observed(sysid, cell, now)?;
                            let ev = MappingEvent::Observed {
                                sysid,
                                cell,
                                added: added.clone(),
                            };
                            Ok((added, Some(ev)))
                        })
                        .await?;
                    let (explored, vertices) = self
                        .shared
                        .read(|s| {
                            let e = s.explorer.as_ref();
                            (
                                e.map(|e| {
                                    e.vertex_states()
                                        .iter()
                                        .filter(|(_, v)| {
                                            *v == fleetmap_core::explore::dfs::VertexState::Explored
                                        })
                                        .count()
                                })
                                .unwrap_or(0),
                                e.map(|e| e.tree().real_count()).unwrap_or(0),
                            )
                        })
                        .await;
                    self.shared.say(Progress::info(format!(
                        "vehicle {sysid}: vertex {cell} imaged, {} new ({} of {} vertices explored)",
                        added.len(),
                        explored,
                        vertices
                    )).about(sysid));
                }
            }
            Directive::Dfs(Action::Wait) => {
                // Before the team's first split every robot is still at the root it flew to.
                let start = self
                    .shared
                    .read(|s| {
                        s.explorer
                            .as_ref()
                            .is_some_and(|e| e.robots().iter().all(|r| r.moves == 0))
                    })
                    .await;
                self.doing(Activity::Waiting(if start {
                    Wait::DfsStart
                } else {
                    Wait::Vertex
                }));
                if !self.held
                    && let Some(v) = self.vehicle()
                    && flight::airborne(&v)
                {
                    flight::hold_here(self.fleet(), sysid).await?;
                    self.held = true;
                }
                self.wait_change(Duration::from_millis(500)).await;
            }
            Directive::Dfs(Action::ReturnHome) | Directive::Swap => {
                self.held = false;
                self.doing(Activity::Working);
                if let Some(end) = self.swap().await? {
                    return Ok(Some(end));
                }
            }
            Directive::Dfs(Action::Done) | Directive::GoHome => {
                self.held = false;
                self.doing(Activity::Working);
                self.go_home().await?;
            }
            Directive::Stop => return Ok(Some(PilotEnd::Done)),
        }
        Ok(None)
    }

    /// Low battery or an operator recall: leave the tree and fly home. Returns whether it
    /// did.
    pub(super) async fn check_battery(&mut self) -> RunnerResult<bool> {
        let sysid = self.sysid;
        let recalled = self
            .shared
            .recalled
            .lock()
            .map(|mut r| r.remove(&sysid))
            .unwrap_or(false);
        let Some(v) = self.vehicle() else {
            return Ok(false);
        };
        let status = self
            .shared
            .read(|s| s.robot(sysid).map(|r| r.status))
            .await?;
        if matches!(
            status,
            RobotStatus::ReturningForSwap
                | RobotStatus::AwaitingSwap
                | RobotStatus::ReturningHome
                | RobotStatus::Landed
        ) {
            return Ok(false);
        }
        if self
            .shared
            .read(|s| matches!(s.phase, Phase::Finished { .. }))
            .await
        {
            return Ok(false);
        }
        let alt = f64::from(v.alt_rel.unwrap_or(0.0));
        let needed = self
            .shared
            .read(|s| s.battery_needed_pct(flight::distance_home(&v), alt))
            .await;
        let pct = v.battery_pct.map(f64::from).filter(|p| *p >= 0.0);
        // The autopilot's own failsafe took over (RTL / LAND we did not ask for).
        let failsafe = flight::airborne(&v)
            && v.flight_mode()
                .is_some_and(|m| m.is_failsafe_return_or_land())
            && status != RobotStatus::Idle;
        let low = pct.is_some_and(|p| p <= needed) && flight::airborne(&v);
        if !(recalled || low || failsafe) {
            return Ok(false);
        }
        let now = self.shared.now();
        let pct_v = pct.unwrap_or(-1.0);
        self.send_for_swap(now, pct_v, needed).await?;
        let why = if recalled {
            "recalled by the operator".to_string()
        } else if failsafe {
            format!("the autopilot's failsafe took over ({})", v.mode)
        } else {
            format!("battery {pct_v:.0} % (home needs {needed:.0} %)")
        };
        self.shared.say(
            Progress::notice(format!(
                "vehicle {sysid}: {why}: returning home for a battery swap"
            ))
            .about(sysid),
        );
        Ok(true)
    }

    /// Send this drone home for a battery swap (a low battery, a recall, the autopilot's
    /// failsafe, or a flight the reach rule says the charge does not cover): its confirmation
    /// is given up and the state and journal say so, `pct` the charge it reported (−1 when it
    /// reports none) and `needed_pct` what the flight home (or out and back) needs, percent.
    async fn send_for_swap(&self, now: Time, pct: f64, needed_pct: f64) -> RunnerResult<()> {
        let sysid = self.sysid;
        self.shared
            .commit(|s| {
                s.abandon_confirmation(sysid);
                s.on_battery_low(sysid, now)?;
                Ok((
                    (),
                    Some(MappingEvent::BatteryLow {
                        sysid,
                        pct,
                        needed_pct,
                    }),
                ))
            })
            .await
    }

    /// The reach rule before flying out to `cell` of a moving region
    /// ([`MappingState::reach_of`], [`fleetmap_core::explore::reach`]): the charge now, less the leg
    /// out to where the cell will be and the time over it, must cover the return from there.
    /// Returns whether to fly now. Otherwise it has done what the rule said: sent the drone
    /// home for a swap first (as a low battery does), held it while the cell drifts closer, or
    /// finished the run beyond reach (every drone then goes home). A static region, or a
    /// vehicle that reports no position or charge (or no home, airborne, and never did), is
    /// not judged here (the battery check between steps still is).
    pub(super) async fn in_reach(&mut self, cell: Cell) -> RunnerResult<bool> {
        let sysid = self.sysid;
        let roi = self.shared.roi;
        if roi.is_static() {
            return Ok(true);
        }
        // An autopilot that rebooted for its swap reports its position and charge again a
        // few seconds later: wait for them rather than fly unjudged.
        let known =
            |v: &VehicleSnapshot| v.position.is_some() && v.battery_pct.is_some_and(|p| p >= 0);
        let v = match self
            .fleet()
            .wait_until(sysid, self.shared.patience.secs(30.0), known)
            .await
        {
            Ok(v) => v,
            Err(Some(v)) => v,
            Err(None) => return Ok(true),
        };
        let (Some(p), Some(pct)) = (
            v.position,
            v.battery_pct.map(f64::from).filter(|p| *p >= 0.0),
        ) else {
            return Ok(true);
        };
        let grid = self.shared.read(|s| s.grid.clone()).await;
        let from = grid.to_xy(LatLon {
            lat: p.lat,
            lon: p.lon,
        })?;
        // Home: as the vehicle reports it; an autopilot that rebooted for its swap has none
        // until it arms, and stands on it then; else where it was last reported.
        let home = match v.home {
            Some(h) => Some(grid.to_xy(LatLon {
                lat: h.lat,
                lon: h.lon,
            })?),
            None if !flight::airborne(&v) => Some(from),
            None => self.home_xy,
        };
        let Some(home) = home else {
            return Ok(true);
        };
        self.home_xy = Some(home);
        let now = self.shared.now();
        let roi_now = roi.roi_time(now);
        let verdict = self
            .shared
            .read(|s| {
                let dwell_s = f64::from(s.images_missing(sysid, cell)) * DWELL_PER_PICTURE_S;
                s.reach_of(sysid, cell, from, home, pct, dwell_s, roi_now)
            })
            .await?;
        tracing::info!(
            "vehicle {sysid}: reach of cell {cell} at region time {:.1} s from ({:.1}, {:.1}) \
             with {pct:.0} %, home ({:.1}, {:.1}): {verdict:?}",
            roi_now.as_secs_f64(),
            from.0,
            from.1,
            home.0,
            home.1
        );
        match verdict {
            Reach::Fly { .. } => Ok(true),
            Reach::SwapFirst { needed_pct } => {
                self.send_for_swap(now, pct, needed_pct).await?;
                self.shared.say(
                    Progress::notice(format!(
                        "vehicle {sysid}: battery {pct:.0} % does not cover the flight to cell \
                         {cell} and back from where it will be ({needed_pct:.0} %): returning \
                         home for a battery swap first"
                    ))
                    .about(sysid),
                );
                Ok(false)
            }
            Reach::Wait { secs } => {
                self.doing(Activity::Waiting(Wait::Vertex));
                if !self.held && flight::airborne(&v) {
                    flight::hold_here(self.fleet(), sysid).await?;
                    self.held = true;
                }
                tracing::info!(
                    "vehicle {sysid}: cell {cell} is out of reach for {secs:.0} s more: waiting"
                );
                let until = now + Duration::from_secs_f64(secs.clamp(0.5, REACH_RECHECK_S));
                let wall = self.fleet().clock().wall_until(until);
                self.wait_change(wall.max(Duration::from_millis(50))).await;
                Ok(false)
            }
            Reach::BeyondReach(why) => {
                let finished = self
                    .shared
                    .commit(|s| {
                        let before = s.phase.finish_reason();
                        s.on_beyond_reach(sysid, cell, why, now)?;
                        let ev = before.is_none().then_some(MappingEvent::BeyondReach {
                            sysid,
                            cell,
                            why,
                        });
                        Ok((ev.is_some(), ev))
                    })
                    .await?;
                if finished {
                    self.shared.say(
                        Progress::error(format!(
                            "vehicle {sysid}: the region is beyond reach — cell {cell}: {why}. \
                             The run ends here (nothing labelled for it); every drone returns \
                             home"
                        ))
                        .about(sysid),
                    );
                }
                Ok(false)
            }
        }
    }

    pub(super) async fn fly_to_cell(&mut self, cell: Cell) -> RunnerResult<()> {
        let sysid = self.sysid;
        let (centre, alt, speed) = self
            .shared
            .read(|s| {
                (
                    s.grid.cell_center(cell),
                    s.altitude_of(sysid),
                    s.params.speed_m_s,
                )
            })
            .await;
        let alt = alt? as f32;
        flight::ensure_airborne(self.fleet(), sysid, alt, self.shared.patience).await?;
        let target = match self.aim_at(cell, speed, 0.0).await? {
            Some(p) => (p.lat, p.lon, alt),
            None => (centre.lat, centre.lon, alt),
        };
        flight::fly_to(
            self.fleet(),
            sysid,
            target,
            speed as f32,
            self.shared.tolerance_m,
            self.shared.patience,
        )
        .await?;
        // The images are read as the cell and its four neighbours: camera aligned with the
        // grid (the classifier then turns the regions by whole quarter turns).
        flight::face_grid(self.fleet(), sysid, target, 3.0, self.shared.patience).await?;
        Ok(())
    }

    /// Where the vehicle is on `grid` (east, north metres), if it reports a position.
    pub(super) fn vehicle_xy(&self, grid: &Grid) -> RunnerResult<Option<(f64, f64)>> {
        let Some(p) = self.vehicle().and_then(|v| v.position) else {
            return Ok(None);
        };
        Ok(Some(grid.to_xy(LatLon {
            lat: p.lat,
            lon: p.lon,
        })?))
    }

    /// Where to fly to meet region cell `cell` of a moving region: the intercept from where
    /// the vehicle is now at `speed` m/s, `lead_s` seconds further along the region's path
    /// (the time to settle over it). `None` for a static region (the cell's centre).
    pub(super) async fn aim_at(
        &self,
        cell: Cell,
        speed: f64,
        lead_s: f64,
    ) -> RunnerResult<Option<LatLon>> {
        let roi = self.shared.roi;
        if roi.is_static() {
            return Ok(None);
        }
        let grid = self.shared.read(|s| s.grid.clone()).await;
        let (e, n) = self
            .vehicle_xy(&grid)?
            .ok_or(super::error::RunwayError::NoAimPosition { sysid: self.sysid })?;
        let now = self.shared.now();
        let (me, mn) = roi.intercept((e, n), now, cell, grid.cell_size(), speed, lead_s)?;
        Ok(Some(grid.from_xy(me, mn)?))
    }

    /// Battery swap: home, land, wait for the fresh battery, then carry on.
    pub(super) async fn swap(&mut self) -> RunnerResult<Option<PilotEnd>> {
        let sysid = self.sysid;
        let fleet = self.fleet().clone();
        let status = self
            .shared
            .read(|s| s.robot(sysid).map(|r| r.status))
            .await?;
        if status != RobotStatus::AwaitingSwap {
            let (dist, speed) = match self.vehicle() {
                Some(v) => (
                    flight::distance_home(&v),
                    self.shared.read(|s| s.params.speed_m_s).await,
                ),
                None => (100.0, 1.0),
            };
            let here = self
                .shared
                .land_here
                .lock()
                .map(|s| s.contains(&sysid))
                .unwrap_or(false);
            let landed = if here {
                flight::land_here(&fleet, sysid, self.shared.patience).await
            } else {
                flight::return_and_land(&fleet, sysid, dist, speed, self.shared.patience).await
            };
            match landed {
                Ok(()) => {}
                // Grounded and out of reach (a link that stays dark): its autopilot's own
                // failsafe brings it down; it waits like the others.
                Err(e) if self.grounded_now().await.is_some() => {
                    self.shared.say(
                        Progress::warning(format!(
                            "vehicle {sysid}: could not bring it home ({}): it is left to its \
                             autopilot's failsafe",
                            crate::app::error::chain(&e)
                        ))
                        .about(sysid),
                    );
                }
                Err(e) => return Err(e.into()),
            }
            let reboots = self.vehicle().map(|v| v.reboots).unwrap_or(0);
            let now = self.shared.now();
            self.shared
                .commit(|s| {
                    s.on_landed_for_swap(sysid, reboots, now)?;
                    Ok(((), Some(MappingEvent::LandedForSwap { sysid })))
                })
                .await?;
            let fault = self.camera_fault_now().await;
            let retired = self
                .shared
                .read(|s| s.robot(sysid).map(|r| r.status == RobotStatus::Landed))
                .await?;
            let grounded = self.grounded_now().await;
            if retired {
                self.shared.say(
                    Progress::info(format!(
                        "vehicle {sysid}: landed: the map is complete, no battery swap needed"
                    ))
                    .about(sysid),
                );
            } else if let Some(g) = &grounded {
                self.shared.say(
                    Progress::notice(format!(
                        "vehicle {sysid}: on the ground, out of the run ({})",
                        g.fix.as_deref().unwrap_or(&g.reason)
                    ))
                    .about(sysid),
                );
            } else if let Some(why) = &fault {
                let line = self.landed_for_camera(why).await;
                self.shared.say(Progress::notice(line).about(sysid));
            } else {
                self.shared.say(
                    Progress::notice(format!(
                        "vehicle {sysid}: landed: waiting for a battery swap{}",
                        if self.shared.auto_resume {
                            " (resumes by itself when a fresh battery is in)"
                        } else {
                            ""
                        }
                    ))
                    .about(sysid),
                );
            }
        }
        if self
            .shared
            .read(|s| matches!(s.phase, Phase::Finished { .. }))
            .await
        {
            return Ok(None);
        }
        let reboots_at = self
            .shared
            .read(|s| s.robot(sysid).ok().and_then(|r| r.reboots_at_landing))
            .await;
        loop {
            let by_operator = self
                .shared
                .swapped
                .lock()
                .map(|mut s| s.remove(&sysid))
                .unwrap_or(false);
            if let Some(g) = self.grounded_now().await {
                if by_operator || self.ready_again() {
                    let now = self.shared.now();
                    let by = if by_operator { "operator" } else { "auto" }.to_string();
                    self.shared
                        .commit(|s| {
                            s.on_ready_again(sysid, now)?;
                            Ok(((), Some(MappingEvent::ReadyAgain { sysid, by })))
                        })
                        .await?;
                    self.shared.say(
                        Progress::notice(format!(
                            "vehicle {sysid} is ready again: taking off to rejoin (it was out: {})",
                            g.reason
                        ))
                        .about(sysid),
                    );
                    return Ok(None);
                }
                // The wait counts from the grounding (or from this runner's start).
                self.grounded
                    .1
                    .get_or_insert_with(tokio::time::Instant::now);
                if !self.waits_by_itself() && !self.shared.interactive {
                    self.shared.say(
                        Progress::error(format!(
                            "vehicle {sysid} waits for a person: {} — then `fleetmap resume`",
                            g.fix.as_deref().unwrap_or(&g.reason)
                        ))
                        .about(sysid),
                    );
                    return Ok(Some(PilotEnd::WaitingForOperator(OperatorTask::Fix(
                        g.fix.clone().unwrap_or_else(|| g.reason.clone()),
                    ))));
                }
                if self
                    .shared
                    .read(|s| matches!(s.phase, Phase::Finished { .. }))
                    .await
                {
                    return Ok(None);
                }
                self.wait_change(Duration::from_millis(500)).await;
                continue;
            }
            // A camera that went silent: back when it is heard again ([`camera`]).
            if !by_operator && let Some(back) = self.silent_camera_wait().await? {
                if back {
                    return Ok(None);
                }
                continue;
            }
            let rules = self.shared.read(|s| s.params.battery.clone()).await;
            let fresh = self.vehicle().is_some_and(|v| {
                let rebooted = reboots_at.is_none_or(|r| v.reboots > r);
                v.alive
                    && v.battery_pct
                        .is_some_and(|p| rules.is_fresh(f64::from(p), rebooted))
            });
            // A faulty camera waits for the operator: a fresh battery does not repair it.
            let auto = self.shared.auto_resume && self.camera_fault_now().await.is_none();
            if by_operator || (auto && fresh) {
                // A battery swap is a power cycle: the camera counts its pictures from 0
                // again, so no index of before names a picture it has not sent.
                self.last_image = None;
                self.in_flight_ok = false;
                let now = self.shared.now();
                if let Ok(mut set) = self.shared.land_here.lock() {
                    set.remove(&sysid);
                }
                let by = if by_operator { "operator" } else { "auto" }.to_string();
                self.shared
                    .commit(|s| {
                        s.on_swapped(sysid, now)?;
                        Ok(((), Some(MappingEvent::Swapped { sysid, by })))
                    })
                    .await?;
                self.shared.say(
                    Progress::notice(format!(
                        "vehicle {sysid}: fresh battery: taking off to resume"
                    ))
                    .about(sysid),
                );
                return Ok(None);
            }
            if !auto && !self.shared.interactive {
                let task = match self.camera_fault_now().await {
                    Some(why) => OperatorTask::CameraFix(why),
                    None => OperatorTask::BatterySwap,
                };
                return Ok(Some(PilotEnd::WaitingForOperator(task)));
            }
            if self
                .shared
                .read(|s| matches!(s.phase, Phase::Finished { .. }))
                .await
            {
                return Ok(None);
            }
            self.wait_change(Duration::from_millis(500)).await;
        }
    }

    pub(super) async fn go_home(&mut self) -> RunnerResult<()> {
        let sysid = self.sysid;
        let now = self.shared.now();
        self.shared
            .commit(|s| {
                s.on_going_home(sysid, now)?;
                Ok(((), Some(MappingEvent::GoingHome { sysid })))
            })
            .await?;
        let (dist, speed) = match self.vehicle() {
            Some(v) => (
                flight::distance_home(&v),
                self.shared.read(|s| s.params.speed_m_s).await,
            ),
            None => (100.0, 1.0),
        };
        flight::return_and_land(self.fleet(), sysid, dist, speed, self.shared.patience).await?;
        let now = self.shared.now();
        self.shared
            .commit(|s| {
                s.on_landed(sysid, now)?;
                Ok(((), Some(MappingEvent::Landed { sysid })))
            })
            .await?;
        self.shared
            .say(Progress::info(format!("vehicle {sysid}: landed at home")).about(sysid));
        Ok(())
    }
}
