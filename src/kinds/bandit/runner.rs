//! The bandit runner: plans epochs and sorties (HiGHS), prepares and uploads them, and drives
//! the run through [`ClassificationState::next`] until every cell is classified; also the
//! airborne-time tracker and the run's start and final save.

use super::error::{BanditError, SortieStage};
use super::*;
use crate::app::error::{Check, RunnerError, RunnerResult, Step};

impl Runner {
    pub(super) fn fleet(&self) -> &FleetHandle {
        &self.shared.fleet
    }

    pub(super) fn say(&self, event: Progress) {
        self.shared.say(event);
    }

    pub(super) async fn upload_fences(&self) -> RunnerResult<()> {
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
        let items = items.context(Step::BuildGeofence)?;
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
            let (sysid, r) = r.map_err(RunnerError::task("fence task"))?;
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
                    first_err.get_or_insert(e.context(Step::Geofence { sysid }));
                }
            }
        }
        if let Some(e) = first_err {
            return Err(e);
        }
        self.say(Progress::info(format!(
            "geofence ({} items: the search area and its no-fly cells) on every vehicle",
            items.len()
        )));
        Ok(())
    }

    /// Check that every vehicle stands on its start cell (fresh runs).
    pub(super) async fn check_start_positions(&self) -> RunnerResult<()> {
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
            let v = snap.get(&sysid).ok_or(Check::NotHeard { sysid })?;
            let p = known_position(v).ok_or(Check::NoPositionYet { sysid })?;
            let c = grid.cell_center(cell);
            let d = local::distance(p.lat, p.lon, c.lat, c.lon);
            if d > 0.75 * grid.cell_size() {
                return Err(BanditError::Misplaced {
                    sysid,
                    distance_m: d,
                    cell,
                }
                .into());
            }
        }
        Ok(())
    }

    pub(super) async fn begin_epoch(&self) -> RunnerResult<()> {
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
        self.say(Progress::info(format!(
            "epoch {p}: goals {}",
            list.join(" ")
        )));
        Ok(())
    }

    pub(super) async fn plan(&self, replan: bool) -> RunnerResult<()> {
        let (k0, p) = self.shared.read(|s| (s.params.k_max, s.bandit.epoch)).await;
        let mut k = k0.max(1);
        loop {
            let inst = self.shared.read(|s| s.instance(k)).await?;
            let goals = inst.goals.len();
            let opts = PlanOptions {
                time_limit: self.plan_time_limit_s,
                ..PlanOptions::default()
            };
            // Off the reactor (inline on a current-thread runtime: a paused clock would run on
            // while the solver worked on another thread).
            let out = crate::app::blocking::run_blocking(move || {
                solve_instance(&inst, &opts, &fleetmap_io::clock::stopwatch())
            })
            .await?;
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
                    self.say(Progress::info(format!(
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
                    )));
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
                (status, _) if self.shared.read(|s| !s.out.is_empty()).await => {
                    // Without the members that are out the goals may be out of reach: wait
                    // for them (those a retry may bring back), then plan again.
                    let why = format!(
                        "epoch {p}: no plan without the vehicles that are out ({})",
                        status.as_str()
                    );
                    self.wait_for_members(&why).await?;
                    k = k0.max(1);
                }
                (status, _) => {
                    return Err(BanditError::NoPlan {
                        epoch: p,
                        status: status.as_str(),
                        message: out.message.clone(),
                        cycles: k,
                    }
                    .into());
                }
            }
        }
    }

    pub(super) async fn prepare(&self) -> RunnerResult<()> {
        let (p, k, list) =
            self.shared
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
                            .map_err(|source| BanditError::UnsafeMission {
                                role: "drone",
                                sysid: d.sysid,
                                read_back: false,
                                source,
                            })?;
                    }
                    for st in c.stations.iter().filter(|st| st.drives) {
                        missions::check_mission(&s.grid, &rules(true), st.path[0], &st.items)
                            .map_err(|source| BanditError::UnsafeMission {
                                role: "station",
                                sysid: st.sysid,
                                read_back: false,
                                source,
                            })?;
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

    pub(super) async fn upload(&self) -> RunnerResult<()> {
        let (p, cycle) = self
            .shared
            .read(|s| (s.bandit.epoch, s.cycle().cloned()))
            .await;
        let cycle = cycle.ok_or(BanditError::NoSortie(SortieStage::Prepared))?;
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
        let failed = super::sortie::join_errors(&mut tasks, "upload task").await?;
        // A vehicle that did not answer (after the upload's own retries) cannot start this
        // sortie: it goes out, the others fly; one that refused its mission stops the run.
        let (lost, refused): (Vec<_>, Vec<_>) = failed
            .into_iter()
            .partition(|(_, e)| e.needs_person().is_none());
        if refused.is_empty() && !lost.is_empty() {
            return self.drop_start(p, cycle.k, lost).await;
        }
        let mut rejected: Vec<(u8, String)> = refused
            .iter()
            .chain(&lost)
            .map(|(s, e)| (*s, crate::app::error::chain(e)))
            .collect();
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
        self.say(Progress::info(format!(
            "epoch {p} cycle {}: {n} mission(s) uploaded and verified",
            cycle.k
        )));
        Ok(())
    }

    /// The station nearest to vehicle `sysid` by telemetry among those `among` accepts: its
    /// distance, metres, and its system id (None when a position is missing).
    pub(super) async fn nearest_station_to(
        &self,
        sysid: u8,
        among: impl Fn(u8) -> bool,
    ) -> Option<(f64, u8)> {
        let stations: Vec<u8> = self
            .shared
            .read(|s| s.stations.iter().map(|m| m.sysid).collect())
            .await;
        let p = self.fleet().vehicle(sysid)?.position?;
        stations
            .into_iter()
            .filter(|&st| among(st))
            .filter_map(|st| {
                let q = self.fleet().vehicle(st)?.position?;
                Some((local::distance(p.lat, p.lon, q.lat, q.lon), st))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }

    /// " It is N m from station S." from telemetry (empty when a position is missing).
    pub(super) async fn nearest_station(&self, sysid: u8) -> String {
        self.nearest_station_to(sysid, |_| true)
            .await
            .map(|(d, st)| format!(" It is {d:.1} m from station {st}."))
            .unwrap_or_default()
    }
}

/// Stop the run when [`MAX_EPOCHS_WITHOUT_MEASUREMENT`] epochs in a row (of those that ended
/// since epoch index `since`) had capture visits and no measurement: the pictures do not
/// reach the GCS, and the next epoch would fly the same goals again.
///
/// [`MAX_EPOCHS_WITHOUT_MEASUREMENT`]: fleetmap_core::planner::sortie::MAX_EPOCHS_WITHOUT_MEASUREMENT
pub(super) async fn no_measurement_stop(runner: &Runner, since: usize) -> RunnerResult<()> {
    use fleetmap_core::planner::sortie::MAX_EPOCHS_WITHOUT_MEASUREMENT as MAX;
    let (dry, visits) = runner
        .shared
        .read(|s| {
            let n = s.epochs_without_measurement(since);
            let visits: u64 = s.epochs.iter().rev().take(n).map(|e| e.visits).sum();
            (n, visits)
        })
        .await;
    if dry >= MAX {
        return Err(BanditError::NoMeasurements {
            epochs: dry,
            visits,
        }
        .into());
    }
    Ok(())
}

/// Airborne time of every drone and flight time of the sortie (in memory; saved with the
/// next change), as a task in `tasks`.
pub(super) fn track(shared: &Shared, drones: Vec<u8>, tasks: &mut tokio::task::JoinSet<()>) {
    let fleet = shared.fleet.clone();
    let reports_charging = shared.reports_charging.clone();
    shared.run.spawn_tracker(tasks, move |state, dt| {
        let airborne: Vec<u8> = drones
            .iter()
            .copied()
            .filter(|&s| fleet.vehicle(s).is_some_and(|v| flight::airborne(&v)))
            .collect();
        if let Ok(mut set) = reports_charging.lock() {
            for &s in &drones {
                if fleet.vehicle(s).is_some_and(|v| v.charging == Some(true)) {
                    set.insert(s);
                }
            }
        }
        state.on_tick(&airborne, dt);
    })
}

/// Where a vehicle stands, once its autopilot knows: its reported position once it has a
/// home, and never 0° N 0° E. ArduPilot sends GLOBAL_POSITION_INT at 0°, 0° until its EKF has
/// an origin (ArduCopter SITL V4.7.0-dev for its first 2–3 s after boot: a GCS started with
/// the vehicles found drone 1 "9868047.0 m from the centre of its start cell").
pub(super) fn known_position(v: &VehicleSnapshot) -> Option<crate::fleet::GeoPoint> {
    v.position
        .filter(|p| v.home.is_some() && (p.lat != 0.0 || p.lon != 0.0))
}

/// A new spatial-classification state for `def` once every vehicle is heard and reports a
/// position (`known_position`; `lock_step` overrides the separation the mission implies).
pub async fn new_state(
    fleet: &FleetHandle,
    def: &fleetmap_core::mission::definition::MissionDef,
    wait: Duration,
    lock_step: Option<bool>,
) -> RunnerResult<ClassificationState> {
    crate::app::team::wait_for_team(fleet, def, wait).await?;
    for v in &def.vehicles {
        fleet
            .wait_until(v.sysid, wait, |s| known_position(s).is_some())
            .await
            .map_err(|_| Check::NoPositionWithin {
                sysid: v.sysid,
                wait_s: wait.as_secs_f64(),
            })?;
    }
    let grid = crate::app::team::mission_grid(fleet, def, wait).await?;
    Ok(ClassificationState::new(def, grid, lock_step)?)
}

/// Run (or resume) a spatial-classification run with `fleet` until every cell is classified.
/// The vehicles must already be heard. Returns the final state.
pub async fn run(
    fleet: FleetHandle,
    hub: &ImageHub,
    run_dir: RunDir,
    mut state: ClassificationState,
    mut opts: RunOptions,
) -> RunnerResult<ClassificationState> {
    // Nothing is sent to a system id two autopilots answer to.
    crate::app::team::refuse_conflicts(&fleet, state.sysids())?;
    let resumed = state.measurements > 0 || state.epoch.is_some() || !state.epochs.is_empty();
    if resumed {
        state.on_resume();
    }
    let last = state.last_measurement.clone();
    let drones: Vec<u8> = state.drones.iter().map(|d| d.sysid).collect();
    // Cameras that measure on board with this run's definition send the green share, not
    // the picture.
    hub.accept_onboard(
        fleetmap_core::vision::onboard::OnboardKind::Green,
        Some(crate::app::images::OnboardAccept {
            fingerprint: green_spec(&state).fingerprint(),
            announce: None,
        }),
    );
    let core = RunCore::new(
        state,
        run_dir,
        fleet.clock().clone(),
        opts.progress.take(),
        opts.view.take(),
    )?;
    if resumed {
        // The journal may lack the last measurement the state holds (killed between the
        // two writes): append it now, so journal and state agree.
        core.store()
            .run(move |run_dir| -> RunnerResult<()> {
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
                if let Some(m) = last
                    && m.n > last_logged
                {
                    run_dir.append_event(&BanditEvent::Measurement(m))?;
                }
                Ok(())
            })
            .await??;
    }
    let shared = Arc::new(Shared {
        run: Arc::new(core),
        fleet: fleet.clone(),
        patience: opts.patience,
        reports_charging: Arc::new(std::sync::Mutex::new(BTreeSet::new())),
        hub: hub.clone(),
    });
    shared
        .commit(|_| Ok(((), vec![BanditEvent::Started { resumed }])))
        .await?;
    let runner = Runner {
        shared: shared.clone(),
        plan_time_limit_s: opts.plan_time_limit_s,
        min_takeoff_pct: opts.min_takeoff_pct,
        pause: opts.pause.take(),
        no_mission: std::sync::Mutex::new(BTreeSet::new()),
    };
    if !resumed {
        runner.check_start_positions().await?;
    }
    runner.upload_fences().await?;
    // The tracker and the image intake end with the drive (shut down below; dropped with
    // this future if it is cancelled).
    let mut background = tokio::task::JoinSet::new();
    track(&shared, drones, &mut background);
    background.spawn(intake(shared.clone(), hub.subscribe()));
    let mut result = drive(&runner, resumed).await;
    // Auto-resume: carry on from the saved state, as `fleetmap resume` would, through what
    // may go away by itself; stop for what a person must fix.
    let mut again = 0u32;
    let mut measured = runner.shared.read(|s| s.measurements).await;
    while opts.auto_resume
        && let Err(e) = &result
        && e.needs_person().is_none()
        && again < AUTO_RESUMES
    {
        // Ten in a row without a measurement between them: something keeps failing.
        let now = runner.shared.read(|s| s.measurements).await;
        if now > measured {
            (again, measured) = (0, now);
        }
        again += 1;
        let wait = runner.shared.patience.secs(10.0 * f64::from(again.min(6)));
        runner.say(Progress::warning(format!(
            "{}: carrying on by itself in {:.0} s (auto-resume {again} of {AUTO_RESUMES})",
            crate::app::error::chain(e),
            wait.as_secs_f64()
        )));
        tokio::time::sleep(wait).await;
        runner
            .shared
            .commit(|s| {
                s.on_resume();
                Ok(((), vec![BanditEvent::Started { resumed: true }]))
            })
            .await?;
        result = drive(&runner, true).await;
    }
    if let Err(e) = &result
        && let Some(fix) = e.needs_person()
    {
        runner.say(Progress::error(format!(
            "the run stops: {fix} — then `fleetmap resume` the run"
        )));
    }
    background.shutdown().await;
    let ok = result.is_ok();
    shared
        .commit(|state| {
            let events = if ok && state.is_finished() {
                vec![BanditEvent::Finished {
                    keep: state.bandit.keep(),
                    reject: state.bandit.reject(),
                }]
            } else {
                Vec::new()
            };
            Ok(((), events))
        })
        .await?;
    result?;
    Ok(shared.read(|s| s.clone()).await)
}

/// Auto-resumes in a row (without a measurement between two of them) after which a run stops
/// even for a failure that may go away.
const AUTO_RESUMES: u32 = 10;

pub(super) async fn drive(runner: &Runner, resumed: bool) -> RunnerResult<()> {
    let mut resume_follow = false;
    // Epochs that end from here on (a resume gives a repaired camera a fresh count).
    let since = runner.shared.read(|s| s.epochs.len()).await;
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
                runner.say(Progress::info(format!(
                    "resumed: the prepared sortie of epoch {p} had not started; planning again"
                )));
            }
            Next::Follow => {
                resume_follow = true;
                runner.say(Progress::info(
                    "resumed in the middle of a sortie: following it to its end",
                ));
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
                runner.say(Progress::notice(format!(
                    "every cell classified: keep {} ({}), reject {}",
                    k.len(),
                    list.join(" "),
                    r.len()
                )));
                return Ok(());
            }
            Next::BeginEpoch => {
                replan = false;
                no_measurement_stop(runner, since).await?;
                runner.begin_epoch().await?;
            }
            Next::Plan => {
                runner.members_back().await?;
                runner.need_a_drone().await?;
                if runner.shared.read(|s| s.next()).await == Next::Plan {
                    runner.plan(replan).await?;
                    replan = true;
                }
            }
            Next::Prepare => {
                // A member whose wait is over and who is ready: plan again with it.
                if runner.members_back().await? == 0 {
                    runner.prepare().await?;
                }
            }
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
mod position_tests {
    use super::*;

    /// ArduCopter SITL (V4.7.0-dev) sends GLOBAL_POSITION_INT at 0° N 0° E, and no home, for
    /// its first seconds after boot, before its EKF has an origin: a GCS started with the
    /// vehicles took that for where drone 1 stood and stopped ("9868047.0 m from the centre of
    /// its start cell"). A position counts once the vehicle has a home, and never at 0°, 0°.
    #[test]
    fn a_position_before_the_autopilot_has_an_origin_is_not_where_it_stands() {
        let mut v = VehicleSnapshot::test_copter(1);
        let null = crate::fleet::GeoPoint {
            lat: 0.0,
            lon: 0.0,
            alt_amsl: 0.0,
        };
        let here = crate::fleet::GeoPoint {
            lat: 37.195135,
            lon: -80.579943,
            alt_amsl: 600.0,
        };
        v.position = Some(null);
        assert_eq!(known_position(&v), None, "0°, 0° without a home");
        v.home = Some(here);
        assert_eq!(
            known_position(&v),
            None,
            "0°, 0° (the last report before the origin)"
        );
        v.position = Some(here);
        assert_eq!(known_position(&v), Some(here));
        v.home = None;
        assert_eq!(known_position(&v), None, "a position without a home");
    }
}
