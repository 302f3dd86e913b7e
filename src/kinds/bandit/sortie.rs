//! Flying one sortie: wait for the charge, start every drone, follow them to the end with
//! their pilots and the lock-step barriers.

use super::error::{BanditError, Overdue, SortieStage};
use super::pilot::dock;
use super::*;
use crate::app::error::{RunnerError, RunnerResult};

impl Runner {
    /// Wait until every drone that flies the sortie has the charge it needs. Returns the
    /// drones that do not charge (their charge has not risen for two minutes): they cannot
    /// start, and the sortie is planned again without them ([`Self::drop_start`]).
    pub(super) async fn wait_for_charge(&self) -> RunnerResult<Vec<(u8, RunnerError)>> {
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
        let mut flat = Vec::new();
        if cycle.is_none() {
            return Ok(flat);
        }
        'drones: for (sysid, need) in needs {
            // A drone already in the air (a sortie dropped for a vehicle that could not
            // start left it hovering over its station) flies on what it has.
            if self
                .fleet()
                .vehicle(sysid)
                .is_some_and(|v| flight::airborne(&v))
            {
                continue;
            }
            let ok = |v: &VehicleSnapshot| v.battery_pct.is_some_and(|p| f64::from(p) >= need);
            if self.fleet().vehicle(sysid).is_some_and(|v| ok(&v)) {
                continue;
            }
            let have = self
                .fleet()
                .vehicle(sysid)
                .and_then(|v| v.battery_pct)
                .unwrap_or(-1);
            self.say(Progress::info(format!(
                "drone {sysid}: charging on its station ({have} %, the sortie needs {need:.0} %)"
            )).about(sysid));
            // Charging, or stuck: a drone whose charge does not rise for two minutes (the
            // fleet's clock × patience) is not on a charger.
            let stall = self.shared.patience.secs(120.0);
            let mut best = have;
            let mut since = self.fleet().clock().now();
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
                            since = self.fleet().clock().now();
                        } else if self.fleet().clock().now().saturating_since(since) > stall {
                            let wh = self.nearest_station(sysid).await;
                            flat.push((
                                sysid,
                                BanditError::NotCharging {
                                    sysid,
                                    pct: now_pct,
                                    need_pct: need,
                                    nearest: wh,
                                }
                                .into(),
                            ));
                            continue 'drones;
                        }
                    }
                }
            }
        }
        Ok(flat)
    }

    /// Wait while the operator has paused the run (before a sortie starts).
    pub(super) async fn wait_unpaused(&self) {
        let Some(mut rx) = self.pause.clone() else {
            return;
        };
        if !*rx.borrow_and_update() {
            return;
        }
        self.say(Progress::notice(
            "paused by the operator: the next sortie waits for RESUME",
        ));
        // A closed channel (the UI went away) lets the run carry on.
        while *rx.borrow_and_update() {
            if rx.changed().await.is_err() {
                break;
            }
        }
        self.say(Progress::notice("resumed by the operator"));
    }

    pub(super) fn paused(&self) -> bool {
        self.pause.as_ref().is_some_and(|p| *p.borrow())
    }

    /// Start the verified sortie, in an order that keeps anything from driving until every
    /// vehicle is known to start:
    ///
    /// 0. every vehicle that moves is ready to arm ([`FleetHandle::wait_ready`]);
    /// 1. every drone that flies takes off over its station and hovers there
    ///    ([`flight::ensure_airborne`]: arming and take-off confirmed from its state and
    ///    retried from it, [`FleetHandle::launch`]); a drone in the air that does not fly
    ///    this sortie (left hovering by a sortie dropped before) lands on its station;
    /// 2. every station that drives is armed, its mission at the first item;
    /// 3. a vehicle that could not do its part goes out of the run ([`drop_start`](Self::drop_start)):
    ///    the sortie is dropped — nothing has driven, the drones in the air hover over their
    ///    stations — and the rest of the epoch is planned again without it;
    /// 4. otherwise the stations drive (MISSION_START, confirmed by their mode); a station
    ///    that will not is out as in 3, after every station that drove is stopped (HOLD);
    /// 5. then the drones fly their missions. A drone whose mission will not start hovers
    ///    over its station and lands at the rendezvous (its visits are not flown).
    pub(super) async fn start(&self) -> RunnerResult<()> {
        // A pause that came while the drones charged holds the sortie too.
        let flat = loop {
            self.wait_unpaused().await;
            let flat = self.wait_for_charge().await?;
            if !self.paused() {
                break flat;
            }
        };
        let (p, cycle) = self
            .shared
            .read(|s| (s.bandit.epoch, s.cycle().cloned()))
            .await;
        let cycle = cycle.ok_or(BanditError::NoSortie(SortieStage::Verified))?;
        if !flat.is_empty() {
            return self.drop_start(p, cycle.k, flat).await;
        }
        let patience = self.shared.patience;
        let altitudes: BTreeMap<u8, f64> = self
            .shared
            .read(|s| s.drones.iter().map(|d| (d.sysid, d.altitude_m)).collect())
            .await;
        let speed = self.shared.read(|s| s.params.speed_m_s).await;
        let mut tasks = tokio::task::JoinSet::new();
        // 0. Every vehicle that moves ready to arm (a vehicle still booting, or with a
        // pre-arm check failing, is waited for), before any drone leaves the ground.
        let moving = cycle
            .drones
            .iter()
            .filter(|d| d.flies)
            .map(|d| d.sysid)
            .chain(cycle.stations.iter().filter(|s| s.drives).map(|s| s.sysid));
        for sysid in moving {
            let fleet = self.fleet().clone();
            if fleet.vehicle(sysid).is_some_and(|v| v.armed) {
                continue;
            }
            tasks.spawn(async move {
                (
                    sysid,
                    fleet
                        .wait_ready(sysid)
                        .await
                        .map(|_| ())
                        .map_err(Into::into),
                )
            });
        }
        let unready = join_errors(&mut tasks, "start task").await?;
        if !unready.is_empty() {
            return self.drop_start(p, cycle.k, unready).await;
        }
        // 1. The drones: off the ground, over their stations.
        for d in &cycle.drones {
            let fleet = self.fleet().clone();
            let sysid = d.sysid;
            let alt = altitudes.get(&sysid).copied().unwrap_or(10.0) as f32;
            if d.flies {
                tasks.spawn(async move {
                    let r = async {
                        // From the first item: ArduPilot resumes a mission at its current
                        // item (MIS_RESTART = 0), which may be left over from the last one.
                        again(|| fleet.set_mission_current(sysid, 0)).await?;
                        flight::ensure_airborne(&fleet, sysid, alt, patience).await?;
                        Ok::<_, RunnerError>(())
                    }
                    .await;
                    (sysid, r)
                });
            } else if fleet.vehicle(sysid).is_some_and(|v| flight::airborne(&v)) {
                // In the air for a sortie that was dropped, and staying this time: down on
                // its station (which stays too).
                let shared = self.shared.clone();
                let (station, slot) = self
                    .shared
                    .read(|s| (s.landing_station(sysid).map(|st| st.sysid), d.slot))
                    .await;
                if let Some(station) = station {
                    tasks.spawn(async move {
                        let r = dock(&shared, sysid, station, f64::from(alt), slot)
                            .await
                            .map(|_| ());
                        (sysid, r)
                    });
                }
            }
        }
        let mut failed = join_errors(&mut tasks, "start task").await?;
        // 2. The stations that drive: armed, at their first item, not moving yet.
        for st in cycle.stations.iter().filter(|s| s.drives) {
            let fleet = self.fleet().clone();
            let sysid = st.sysid;
            tasks.spawn(async move {
                let r = async {
                    let v = fleet
                        .vehicle(sysid)
                        .ok_or(crate::fleet::FleetError::NoVehicle { sysid })?;
                    again(|| fleet.set_mission_current(sysid, 0)).await?;
                    if !v.armed && v.flavour.home_item() {
                        fleet.arm(sysid).await?;
                    }
                    Ok::<_, RunnerError>(())
                }
                .await;
                (sysid, r)
            });
        }
        failed.extend(join_errors(&mut tasks, "start task").await?);
        if !failed.is_empty() {
            return self.drop_start(p, cycle.k, failed).await;
        }
        // 4. The stations drive only once the drones are in the air: a drone that is still
        // spinning up on a rover's charger would be carried away from the cell its mission
        // starts on (and no field team lets a rover drive with a drone taking off from it).
        for st in cycle.stations.iter().filter(|s| s.drives) {
            let fleet = self.fleet().clone();
            let sysid = st.sysid;
            tasks.spawn(
                async move { (sysid, fleet.start_mission(sysid).await.map_err(Into::into)) },
            );
        }
        let failed = join_errors(&mut tasks, "start task").await?;
        if !failed.is_empty() {
            for st in cycle.stations.iter().filter(|s| s.drives) {
                if let Err(e) = flight::hold_here(self.fleet(), st.sysid).await {
                    tracing::warn!("station {}: stopping it: {e}", st.sysid);
                }
            }
            return self.drop_start(p, cycle.k, failed).await;
        }
        // 5. The drones fly their missions.
        for d in cycle.drones.iter().filter(|d| d.flies) {
            let fleet = self.fleet().clone();
            let sysid = d.sysid;
            tasks.spawn(async move {
                let r = fleet.start_mission(sysid).await;
                if r.is_ok() {
                    let _ = flight::set_speed(&fleet, sysid, speed as f32).await;
                }
                (sysid, r.map_err(Into::into))
            });
        }
        let unstarted = join_errors(&mut tasks, "start task").await?;
        if let Ok(mut set) = self.no_mission.lock() {
            set.clear();
            set.extend(unstarted.iter().map(|(s, _)| *s));
        }
        for (sysid, e) in &unstarted {
            self.say(
                Progress::warning(format!(
                    "drone {sysid}: its mission did not start ({}): it hovers over its station \
                     and lands at the rendezvous; its visits of this sortie are not flown",
                    crate::app::error::chain(e)
                ))
                .about(*sysid),
            );
        }
        // Started: from now on the sortie is followed, and a resume follows it.
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
        self.say(Progress::info(format!(
            "epoch {p} cycle {}: flying",
            cycle.k
        )));
        Ok(())
    }

    /// The sortie could not start every vehicle (`failed`, before anything drove): each goes
    /// out of the run — the operator told which and why, the journal says so — and the
    /// sortie is dropped, to be planned again without them
    /// ([`ClassificationState::start_failed`]). First, once the commands still being resent
    /// have died out, each is made safe: a drone in the air lands on its station, one armed
    /// on the ground is disarmed.
    pub(super) async fn drop_start(
        &self,
        p: u64,
        k: usize,
        failed: Vec<(u8, RunnerError)>,
    ) -> RunnerResult<()> {
        // The command sender's budget is on the fleet's clock (a simulator's time when the
        // fleet follows one).
        let clock = self.fleet().clock();
        let budget =
            fleetmap_core::proto::command::CommandSender::budget(&self.fleet().config().command);
        tokio::time::sleep(clock.wall_until(clock.now() + budget)).await;
        let alt: BTreeMap<u8, f64> = self
            .shared
            .read(|s| s.drones.iter().map(|d| (d.sysid, d.altitude_m)).collect())
            .await;
        for (sysid, _) in &failed {
            let Some(v) = self.fleet().vehicle(*sysid) else {
                continue;
            };
            let r = if v.flavour.flies() && flight::airborne(&v) {
                let station = self.nearest_station_id(*sysid).await;
                match station {
                    Some(st) => dock(
                        &self.shared,
                        *sysid,
                        st,
                        alt.get(sysid).copied().unwrap_or(10.0),
                        (0, 1),
                    )
                    .await
                    .map(|_| ()),
                    None => flight::land_here(self.fleet(), *sysid, self.shared.patience)
                        .await
                        .map_err(Into::into),
                }
            } else if v.armed && v.flavour.flies() {
                self.fleet().disarm(*sysid).await.map_err(Into::into)
            } else {
                Ok(())
            };
            if let Err(e) = r {
                tracing::warn!("vehicle {sysid}: making it safe after a failed start: {e}");
            }
        }
        let snap = self.fleet().snapshot().vehicles;
        let st = self.shared.read(|s| s.clone()).await;
        let actual = observed_config(&st, &snap, &st.config)?;
        let list: Vec<(u8, String, Option<String>)> = failed
            .iter()
            .map(|(sysid, e)| (*sysid, crate::app::error::chain(e), e.needs_person()))
            .collect();
        let outs = self
            .shared
            .commit(|s| {
                s.start_failed(actual, &list)?;
                let mut events: Vec<BanditEvent> = list
                    .iter()
                    .filter_map(|(sysid, reason, fix)| {
                        Some(BanditEvent::VehicleOut {
                            sysid: *sysid,
                            role: s.role_of(*sysid)?,
                            reason: reason.clone(),
                            fix: fix.clone(),
                            epoch: p,
                        })
                    })
                    .collect();
                events.push(BanditEvent::SortieDropped { epoch: p });
                let outs: Vec<(u8, Role, u32)> = list
                    .iter()
                    .filter_map(|(sysid, _, _)| {
                        let o = s.out.get(sysid)?;
                        Some((*sysid, o.role, o.wait_sorties))
                    })
                    .collect();
                Ok((outs, events))
            })
            .await?;
        for ((sysid, reason, fix), (_, role, wait)) in list.iter().zip(&outs) {
            let then = match (fix, wait) {
                (Some(fix), _) => format!("a person must fix it: {fix}; it rejoins once ready"),
                (None, 0) => "it is tried again at the next sortie".to_string(),
                (None, w) => format!("it is tried again after {w} more sortie(s)"),
            };
            self.say(
                Progress::warning(format!(
                    "{} {sysid} cannot start ({reason}): the sortie of epoch {p}, cycle {k} is \
                     planned again without it — {then}",
                    role
                ))
                .about(*sysid),
            );
        }
        Ok(())
    }

    /// The station nearest to vehicle `sysid` by telemetry (within 5 m).
    pub(super) async fn nearest_station_id(&self, sysid: u8) -> Option<u8> {
        self.nearest_station_to(sysid, |_| true)
            .await
            .filter(|(d, _)| *d <= 5.0)
            .map(|(_, st)| st)
    }

    /// Follow the sortie in flight until every drone landed and every station arrived.
    pub(super) async fn follow(&self, resumed: bool) -> RunnerResult<()> {
        let (p, cycle) = self
            .shared
            .read(|s| (s.bandit.epoch, s.cycle().cloned()))
            .await;
        let cycle = cycle.ok_or(BanditError::NoSortie(SortieStage::Flying))?;
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
        let deadline = self.fleet().clock().now() + budget;
        let mut pilots = tokio::task::JoinSet::new();
        let no_mission = self
            .no_mission
            .lock()
            .map(|s| s.clone())
            .unwrap_or_default();
        for d in cycle.drones.iter().filter(|d| d.flies && !d.landed) {
            let pilot = DronePilot {
                shared: self.shared.clone(),
                sysid: d.sysid,
                items: d.items.clone(),
                resumed,
                no_mission: no_mission.contains(&d.sysid),
                deadline,
            };
            pilots.spawn(pilot.run());
        }
        let mut snaps = self.fleet().watch();
        let mut seen_active: BTreeSet<u8> = BTreeSet::new();
        let mut held: BTreeSet<u8> = BTreeSet::new();
        // Where each driving station last made progress, and when (fleet clock).
        let mut moved: BTreeMap<u8, (crate::fleet::GeoPoint, fleetmap_core::time::Time)> =
            BTreeMap::new();
        let mut tick = tokio::time::interval(Duration::from_millis(250));
        loop {
            // `biased`: in this order, not tokio's random one (a run on a paused clock is the
            // same every time); the checks below run whichever branch woke.
            tokio::select! {
                biased;
                r = pilots.join_next(), if !pilots.is_empty() => {
                    if let Some(r) = r {
                        r.map_err(RunnerError::task("drone task"))??;
                    }
                }
                r = snaps.changed() => {
                    if r.is_err() {
                        return Err(RunnerError::FleetStopped);
                    }
                }
                _ = tick.tick() => {}
            }
            if self.fleet().clock().now() > deadline {
                return Err(Overdue::Sortie {
                    epoch: p,
                    cycle: cycle.k,
                    budget_s: budget.as_secs_f64(),
                }
                .into());
            }
            let snap = self.fleet().snapshot().vehicles;
            // Stations.
            for st in cycle.stations.iter().filter(|s| s.drives) {
                let Some(v) = snap.get(&st.sysid) else {
                    continue;
                };
                if v.mission_active() {
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
                let arrived_now = self
                    .shared
                    .read(|s| {
                        s.cycle()
                            .and_then(|c| c.stations.iter().find(|x| x.sysid == sysid))
                            .is_some_and(|x| x.arrived)
                    })
                    .await;
                if !changed && !arrived_now && !complete && active {
                    self.watch_station(sysid, v, &mut moved).await?;
                }
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
                        self.say(
                            Progress::info(format!("station {sysid}: at the rendezvous"))
                                .about(sysid),
                        );
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
            r.map_err(RunnerError::task("drone task"))??;
        }
        self.wait_for_pictures(&cycle).await;
        self.warn_short_visits().await;
        // The rendezvous: where is everyone?
        let snap = self.fleet().snapshot().vehicles;
        let planned = self
            .shared
            .read(|s| s.cycle().map(|c| c.planned_end()))
            .await
            .ok_or(BanditError::NoSortie(SortieStage::Ended))?;
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
        self.say(Progress::info(format!(
            "epoch {p} cycle {k}: every drone on its station after {seconds:.0} s"
        )));
        if let CycleEnd::EpochDone(stats) = end {
            self.say(Progress::info(format!(
                "epoch {p} done: {} cycle(s), planner {:.2} s, {} measurements; keep {}, reject {}, \
                 unclassified {}",
                stats.cycles,
                stats.planner_s,
                stats.measurements,
                stats.keep,
                stats.reject,
                stats.unclassified
            )));
        }
        Ok(())
    }

    /// One warning per drone whose capture visits of the sortie ended short of their B
    /// images: a camera that takes no picture, or whose pictures do not reach the GCS, is
    /// otherwise seen only as an epoch with no measurement.
    pub(super) async fn warn_short_visits(&self) {
        let (short, b) = self
            .shared
            .read(|s| (s.short_visits(), s.params.batch))
            .await;
        let mut by_drone: BTreeMap<u8, Vec<String>> = BTreeMap::new();
        for (sysid, cell, counted) in short {
            by_drone
                .entry(sysid)
                .or_default()
                .push(format!("{counted} of {b} at cell {cell}"));
        }
        for (sysid, cells) in by_drone {
            self.say(
                Progress::warning(format!(
                    "drone {sysid}: images missing after the sortie ({}): does its camera \
                     take the pictures, and do they reach the GCS?",
                    cells.join(", ")
                ))
                .about(sysid),
            );
        }
    }

    /// Hold the drones that are a step ahead; release the others.
    pub(super) async fn barrier(
        &self,
        snap: &BTreeMap<u8, VehicleSnapshot>,
        held: &mut BTreeSet<u8>,
        resumed: bool,
    ) -> RunnerResult<()> {
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
                    self.say(
                        Progress::info(format!(
                            "drone {sysid}: holding at step {step} until the others catch up (7e)"
                        ))
                        .about(sysid),
                    );
                }
            } else if held.contains(&d.sysid) || !in_mission {
                let m = v.flavour.mission_mode()?;
                self.fleet().set_mode(d.sysid, m).await?;
                held.remove(&d.sysid);
            }
        }
        Ok(())
    }
}

/// `op`, tried up to three times while it fails for want of an answer.
pub(super) async fn again<F, Fut>(mut op: F) -> Result<(), crate::fleet::FleetError>
where
    F: FnMut() -> Fut,
    Fut: std::future::Future<Output = Result<(), crate::fleet::FleetError>>,
{
    let mut attempt = 0;
    loop {
        attempt += 1;
        match op().await {
            Err(e) if attempt < 3 && e.is_transient() => {
                tracing::warn!("{e} (trying again)");
            }
            r => return r,
        }
    }
}

/// The tasks' errors, by vehicle.
pub(super) async fn join_errors(
    tasks: &mut tokio::task::JoinSet<(u8, RunnerResult<()>)>,
    what: &'static str,
) -> RunnerResult<Vec<(u8, RunnerError)>> {
    let mut failed = Vec::new();
    while let Some(r) = tasks.join_next().await {
        let (sysid, r) = r.map_err(RunnerError::task(what))?;
        if let Err(e) = r {
            failed.push((sysid, e));
        }
    }
    failed.sort_by_key(|(s, _)| *s);
    Ok(failed)
}
