//! Flying one sortie: wait for the charge, start every drone, follow them to the end with
//! their pilots and the lock-step barriers.

use super::*;
use crate::app::error::{RunnerError, RunnerResult};

impl Runner {
    /// Wait until every drone that flies the sortie has the charge it needs.
    pub(super) async fn wait_for_charge(&self) -> RunnerResult<()> {
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
                            return Err(RunnerError::check(format!(
                                "drone {sysid} is not charging (stuck at {now_pct} %, the sortie \
                                 needs {need:.0} %): is it on its station's charger?{wh}"
                            )));
                        }
                    }
                }
            }
        }
        Ok(())
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

    pub(super) async fn start(&self) -> RunnerResult<()> {
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
                        Ok::<_, RunnerError>(())
                    }
                    .await;
                    match r {
                        Err(e) if attempt < 3 && transient(&e) => {
                            tracing::warn!(
                                "drone {sysid}: {} (trying again)",
                                crate::app::error::chain(&e)
                            );
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
                        Ok::<_, RunnerError>(())
                    }
                    .await;
                    match r {
                        Err(e) if attempt < 3 && transient(&e) => {
                            tracing::warn!(
                                "station {sysid}: {} (trying again)",
                                crate::app::error::chain(&e)
                            );
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
            return Err(RunnerError::check(format!(
                "the sortie of epoch {p}, cycle {} could not start every vehicle: {}",
                cycle.k,
                failed.join("; ")
            )));
        }
        self.say(Progress::info(format!(
            "epoch {p} cycle {}: flying",
            cycle.k
        )));
        Ok(())
    }

    /// Follow the sortie in flight until every drone landed and every station arrived.
    pub(super) async fn follow(&self, resumed: bool) -> RunnerResult<()> {
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
        let deadline = self.fleet().clock().now() + budget;
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
                return Err(RunnerError::check(format!(
                    "epoch {p} cycle {}: the sortie did not end within {:.0} s",
                    cycle.k,
                    budget.as_secs_f64()
                )));
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
        self.warn_short_visits().await;
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
