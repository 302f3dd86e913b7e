//! Running (or resuming) a runway-mapping run: one pilot task per vehicle, the position
//! tracker, the operator's commands, and the final save.

use super::*;
use crate::app::error::{RunnerError, RunnerResult, Step};
use fleetmap_core::explore::mapping::CLOCK_SAMPLE_S;
use tokio::task::JoinSet;

/// Follow every robot's position for its track, distance and airborne time (in memory; saved
/// with the next step), as a task in `tasks`.
pub(super) fn track(shared: &Shared, sysids: Vec<u8>, tasks: &mut JoinSet<()>) {
    let fleet = shared.fleet.clone();
    shared.run.spawn_tracker(tasks, move |state, dt| {
        for &sysid in &sysids {
            let Some(v) = fleet.vehicle(sysid) else {
                continue;
            };
            let Some(p) = v.position else { continue };
            let Ok((e, n)) = state.grid.to_xy(LatLon {
                lat: p.lat,
                lon: p.lon,
            }) else {
                continue;
            };
            let air = if flight::airborne(&v) { dt } else { 0.0 };
            let _ = state.on_position(sysid, e, n, air);
        }
    });
}

/// Sample every robot for the mission clock every [`CLOCK_SAMPLE_S`] seconds of the fleet
/// clock — airborne or not (the fleet's snapshot) and what its pilot is doing (in memory;
/// saved with the next step). On the fleet clock, not the runtime's, so that the samples stay
/// [`CLOCK_SAMPLE_S`] apart in the vehicles' time however fast a simulator in this process
/// runs. A task in `tasks`.
fn sample_clock(shared: &Arc<Shared>, sysids: Vec<u8>, tasks: &mut JoinSet<()>) {
    let shared = shared.clone();
    tasks.spawn(async move {
        let clock = shared.fleet.clock().clone();
        let period = Duration::from_secs_f64(CLOCK_SAMPLE_S);
        let mut next = clock.now();
        loop {
            let now = clock.now();
            if now < next {
                // A lower bound when following a simulator: check again.
                tokio::time::sleep(clock.wall_until(next).max(Duration::from_millis(1))).await;
                continue;
            }
            let drones: Vec<(u8, bool, Activity)> = sysids
                .iter()
                .map(|&sysid| {
                    let airborne = shared
                        .fleet
                        .vehicle(sysid)
                        .is_some_and(|v| flight::airborne(&v));
                    (sysid, airborne, shared.activity(sysid))
                })
                .collect();
            let _ = shared
                .run
                .update(|s| {
                    s.sample_clock(now, &drones);
                    Ok::<_, MappingError>(((), Vec::<MappingEvent>::new(), false))
                })
                .await;
            next = now + period;
        }
    });
}

/// A new runway-mapping state for `def` once the team is connected
/// (`app::team::wait_for_team`), on the mission grid.
pub async fn new_mapping(
    fleet: &FleetHandle,
    def: &fleetmap_core::mission::definition::MissionDef,
    sharing: fleetmap_core::explore::dfs::Sharing,
    wait: Duration,
) -> RunnerResult<MappingState> {
    crate::app::team::wait_for_team(fleet, def, wait).await?;
    let grid = crate::app::team::mission_grid(fleet, def, wait).await?;
    Ok(MappingState::new(def, grid, sharing)?)
}

/// Run (or resume) a runway-mapping run with `fleet` until it finishes, or until robots wait
/// for the operator. `run` holds the state; the vehicles must already be heard.
pub async fn run(
    fleet: FleetHandle,
    hub: &ImageHub,
    run_dir: RunDir,
    state: MappingState,
    mut opts: RunOptions,
) -> RunnerResult<Outcome> {
    let mut state = state;
    let sysids: Vec<u8> = state.robots.iter().map(|r| r.sysid).collect();
    // Nothing is sent to a system id two autopilots answer to.
    crate::app::team::refuse_conflicts(&fleet, sysids.iter().copied())?;
    // A moving region: its epoch is this start unless the state has one (a resumed run, or
    // the demo's simulator start); read against the fleet clock once.
    let motion = state.params.motion();
    let roi = if motion.speed() > 0.0 {
        let clock = fleet.clock();
        // A new epoch is this very moment: no time has passed since (not a second reading of
        // the wall clock, which would put a machine's microseconds into a virtual-time run).
        let since_epoch_s = match state.roi_epoch_unix_ms {
            Some(epoch) => clock.secs_since_unix_ms(epoch),
            None => {
                state.roi_epoch_unix_ms = Some(fleetmap_io::clock::unix_ms());
                0.0
            }
        };
        RoiClock::new(motion, clock.now(), since_epoch_s)
    } else {
        RoiClock::fixed()
    };
    let resumed = state.started.is_some();
    // This runner's fleet clock is not the last one's: the mission clock waits for its
    // first sample.
    state.restart_clock();
    let (paused, _) = watch::channel(false);
    let interactive = opts.operator.is_some();
    // Cameras that classify on board with this run's definition send results, not pictures.
    let onboard = Onboard::start(hub, &state);
    let core = RunCore::new(
        state,
        run_dir,
        fleet.clock().clone(),
        opts.progress.take(),
        opts.view.take(),
    )?;
    let shared = Arc::new(Shared {
        run: Arc::new(core),
        paused,
        swapped: std::sync::Mutex::new(HashSet::new()),
        recalled: std::sync::Mutex::new(HashSet::new()),
        land_here: std::sync::Mutex::new(HashSet::new()),
        fleet: fleet.clone(),
        auto_resume: opts.auto_resume,
        interactive,
        patience: opts.patience,
        tolerance_m: opts.tolerance_m,
        max_failures: opts.max_failures,
        max_retakes: opts.max_retakes,
        limits: opts
            .capture_limits
            .unwrap_or_else(|| CaptureLimits::hover(opts.tolerance_m)),
        roi,
        doing: std::sync::Mutex::new(HashMap::new()),
        onboard,
    });
    // Saved and journalled before anything moves; also the view's first state.
    let started = MappingEvent::Started {
        robots: sysids.clone(),
        resumed,
    };
    shared.commit(|_| Ok(((), Some(started)))).await?;
    // The tracker, the clock sampler and the operator's commands: they end with the pilots
    // (shut down below; dropped with this future if it is cancelled).
    let mut background = JoinSet::new();
    track(&shared, sysids.clone(), &mut background);
    sample_clock(&shared, sysids.clone(), &mut background);
    if let Some(mut rx) = opts.operator.take() {
        let shared = shared.clone();
        background.spawn(async move {
            while let Some(cmd) = rx.recv().await {
                match cmd {
                    Operator::Pause => {
                        shared.paused.send_replace(true);
                        shared.say(Progress::notice("operator: pause — every vehicle holds"));
                    }
                    Operator::Resume => {
                        shared.paused.send_replace(false);
                        shared.say(Progress::notice("operator: resume"));
                    }
                    Operator::BatterySwapped(s) => {
                        if let Ok(mut set) = shared.swapped.lock() {
                            set.insert(s);
                        }
                        shared.say(
                            Progress::notice(format!("operator: vehicle {s} has a fresh battery"))
                                .about(s),
                        );
                    }
                    Operator::Land(s) => {
                        if let Ok(mut set) = shared.land_here.lock() {
                            set.insert(s);
                        }
                        if let Ok(mut set) = shared.recalled.lock() {
                            set.insert(s);
                        }
                        shared.say(
                            Progress::notice(format!("operator: vehicle {s} lands where it is"))
                                .about(s),
                        );
                    }
                    Operator::Recall(s) => {
                        if let Ok(mut set) = shared.recalled.lock() {
                            set.insert(s);
                        }
                        shared.say(
                            Progress::notice(format!(
                                "operator: vehicle {s} recalled for a battery swap"
                            ))
                            .about(s),
                        );
                    }
                }
                shared.run.notify();
            }
        });
    }
    // The pilots end with the run: dropped with this future (a GCS that stops), they stop
    // too, and nothing more is written for them.
    let mut pilots = JoinSet::new();
    let mut by_task = HashMap::new();
    for &sysid in &sysids {
        let pilot = Pilot {
            sysid,
            shared: shared.clone(),
            images: hub.subscribe(),
            capture_seq: 0,
            last_image: None,
            in_flight_ok: false,
            round_trip: super::visit_captures::round_trip(shared.patience),
            held: false,
            first_sweep: true,
            sweep_rejects: 0,
            home_xy: None,
            grounded: (0, None),
            camera: Default::default(),
        };
        let id = pilots.spawn(pilot.run()).id();
        by_task.insert(id, sysid);
    }
    let mut ended: Vec<(u8, RunnerResult<PilotEnd>)> = Vec::new();
    while let Some(r) = pilots.join_next_with_id().await {
        match r {
            Ok((id, r)) => ended.push((by_task.get(&id).copied().unwrap_or(0), r)),
            Err(e) => {
                let sysid = by_task.get(&e.id()).copied().unwrap_or(0);
                ended.push((
                    sysid,
                    Err(RunnerError::task("pilot task")(e).context(Step::Pilot { sysid })),
                ));
            }
        }
    }
    ended.sort_by_key(|(s, _)| *s);
    let mut waiting = Vec::new();
    let mut first_err = None;
    for (sysid, r) in ended {
        match r {
            Ok(PilotEnd::Done) => {}
            Ok(PilotEnd::WaitingForOperator(task)) => waiting.push((sysid, task)),
            Err(e) => {
                if first_err.is_none() {
                    first_err = Some(e);
                }
            }
        }
    }
    background.shutdown().await;
    shared.onboard.finish().await;
    // Save the final track and times (and the milestones not journalled yet).
    let now = fleet.clock().now();
    shared
        .commit(|state| {
            if state.is_finished() {
                let found = matches!(state.phase, Phase::Finished { found: true, .. });
                let reason = state.phase.finish_reason();
                state.book.close_all(now);
                Ok(((), Some(MappingEvent::Finished { found, reason })))
            } else {
                Ok(((), None))
            }
        })
        .await?;
    if let Some(e) = first_err {
        return Err(e);
    }
    if waiting.is_empty() {
        Ok(Outcome::Finished)
    } else {
        Ok(Outcome::WaitingForOperator { waiting })
    }
}
