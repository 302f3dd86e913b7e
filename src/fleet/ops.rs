//! Operations composed on the handle from the actor's primitives: modes, arming, take-off,
//! go to, face, pause, return, land, reboot, start a mission, camera capture. Each step has
//! its own timeout and typed error ([`super::FleetError`]).

use super::error::{FleetError, StateSeen};
use super::handle::FleetHandle;
use super::state::VehicleSnapshot;
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::command::Command;
use fleetmap_core::proto::command::CommandError;
use fleetmap_core::proto::command::CommandSender;
use fleetmap_core::proto::flavour::Autopilot;
use fleetmap_core::proto::flavour::FlavourError;
use fleetmap_core::proto::flavour::Step;
use fleetmap_core::proto::launch::{
    Action, Cause, Goal, Landed, Launch, LaunchConfig, LaunchFailure, Observed, Step as LaunchStep,
};
use fleetmap_core::proto::mode::Mode;
use fleetmap_core::time::Time;
use mavlink::dialects::ardupilotmega::{MavCmd, MavLandedState};
use std::time::Duration;
use tokio::task::JoinSet;

/// EXTENDED_SYS_STATE's landed state as the launch machine reads it.
fn landed_of(s: Option<MavLandedState>) -> Landed {
    use MavLandedState::*;
    match s {
        Some(MAV_LANDED_STATE_ON_GROUND) => Landed::OnGround,
        Some(MAV_LANDED_STATE_TAKEOFF) => Landed::TakingOff,
        Some(MAV_LANDED_STATE_IN_AIR) => Landed::InAir,
        Some(MAV_LANDED_STATE_LANDING) => Landed::Landing,
        _ => Landed::Unknown,
    }
}

impl FleetHandle {
    pub(super) fn flavour_err(sysid: u8) -> impl Fn(FlavourError) -> FleetError {
        move |error| FleetError::Flavour { sysid, error }
    }

    /// Switch to `mode` and wait until the heartbeat shows it.
    pub async fn set_mode(&self, sysid: u8, mode: Mode) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        self.set_mode_to(&v, mode).await
    }

    /// [`FleetHandle::set_mode`] to the mode a user typed: `name` as the vehicle's autopilot
    /// names it (case-insensitive, QGroundControl / MAVProxy aliases:
    /// [`fleetmap_core::proto::flavour::Flavour::mode`]).
    pub async fn set_mode_named(&self, sysid: u8, name: &str) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let mode = v.flavour.mode(name).map_err(Self::flavour_err(sysid))?;
        self.set_mode_to(&v, mode).await
    }

    pub(super) async fn set_mode_to(
        &self,
        v: &VehicleSnapshot,
        mode: Mode,
    ) -> Result<(), FleetError> {
        let sysid = v.sysid;
        let current = self.require(sysid)?;
        if current.flavour.is_mode(current.custom_mode, mode) {
            return Ok(());
        }
        self.launch(sysid, Goal::Mode(mode), None).await
    }

    /// Wait until vehicle `sysid` is really ready to arm (GPS fix, position estimate, home,
    /// pre-arm checks: see [`fleetmap_core::proto::flavour::Flavour::arm_blockers`]), at most [`super::OpsConfig::arm_ready`];
    /// returns its snapshot at that moment, or [`FleetError::NotReady`] with what still
    /// blocks it.
    pub(crate) async fn wait_ready(&self, sysid: u8) -> Result<VehicleSnapshot, FleetError> {
        self.require(sysid)?;
        let wait = self.cfg.ops.arm_ready;
        let clock = self.clock.clone();
        match self
            .wait_until(sysid, wait, |s| s.arm_blockers(clock.now()).is_empty())
            .await
        {
            Ok(v) => Ok(v),
            // Not heard at the end: the link, not the vehicle's checks.
            Err(Some(v)) if !v.alive => Err(FleetError::NotStarted {
                sysid,
                failure: Box::new(LaunchFailure {
                    goal: Goal::Armed { mode: None },
                    commands: 0,
                    failures: 0,
                    waited: wait,
                    cause: Cause::Silent {
                        waited: Duration::from_secs_f64(v.heartbeat_age_s.max(0.0)),
                    },
                }),
                state: Box::new(self.state_seen(sysid)),
            }),
            Err(last) => Err(FleetError::NotReady {
                sysid,
                waited_s: wait.as_secs_f64(),
                reasons: last
                    .map(|s| s.arm_blockers(self.clock.now()))
                    .unwrap_or_else(|| vec!["vehicle lost".into()]),
            }),
        }
    }

    /// Arm, confirmed from the heartbeat (`FleetHandle::launch` with [`Goal::Armed`]): a
    /// vehicle that is not ready to arm is waited for (GPS fix, position estimate, home,
    /// pre-arm checks: see [`fleetmap_core::proto::flavour::Flavour::arm_blockers`]), at most
    /// `super::OpsConfig::arm_ready`; an ARM whose ACK was lost counts once the heartbeat
    /// shows armed; a refused one is tried again with a back-off.
    pub async fn arm(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        if v.armed {
            return Ok(());
        }
        self.launch(sysid, Goal::Armed { mode: None }, None).await
    }

    /// Disarm and wait for the heartbeat to show it.
    pub(crate) async fn disarm(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        if !v.armed {
            return Ok(());
        }
        let ep = Endpoint::new(sysid, v.compid);
        // An unanswered DISARM may still have worked: the heartbeat says.
        match self.command(v.flavour.arm_command(ep, false)).await {
            Ok(_)
            | Err(FleetError::Command {
                error: CommandError::Timeout { .. },
                ..
            }) => {}
            Err(e) => return Err(e),
        }
        let timeout = self.cfg.ops.arm_confirm;
        self.wait_until(sysid, timeout, |s| !s.armed)
            .await
            .map(|_| ())
            .map_err(|_| FleetError::NotConfirmed {
                sysid,
                what: "disarmed".into(),
                waited_s: timeout.as_secs_f64(),
                now: "armed".into(),
            })
    }

    /// Carry out flavour steps in order.
    pub(crate) async fn run_steps(&self, sysid: u8, steps: Vec<Step>) -> Result<(), FleetError> {
        for step in steps {
            match step {
                Step::SetMode(mode) => {
                    let v = self.require(sysid)?;
                    self.set_mode_to(&v, mode).await?;
                }
                Step::Arm => self.arm(sysid).await?,
                Step::Command(c) => {
                    self.command(c).await?;
                }
                Step::Send(m) => {
                    self.send(*m).await?;
                }
            }
        }
        Ok(())
    }

    /// Arm and take off to `alt` metres above home, in the way this autopilot wants
    /// (ArduCopter: GUIDED, arm, NAV_TAKEOFF; PX4: arm, NAV_TAKEOFF with AMSL altitude),
    /// confirmed from the vehicle's state (`FleetHandle::launch` with [`Goal::Airborne`]).
    /// Returns once the vehicle is seen leaving the ground (taking off or in the air); the
    /// climb to `alt` is the caller's to wait for.
    ///
    /// A disarmed vehicle is waited for until it is ready to arm before the first step, not
    /// only before arming (for the first 15–30 s after boot and after every battery swap it
    /// is not): a mode that needs a position may be refused until the estimate is good
    /// (PX4's mode requirements apply disarmed too; ArduCopter's `Copter::set_mode` takes
    /// GUIDED disarmed but the arming that follows fails), and PX4's take-off altitude is
    /// AMSL, so home must be known before the command is built.
    pub async fn takeoff(&self, sysid: u8, alt: f32) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let v = if v.armed || v.home.is_some() {
            v
        } else {
            self.wait_ready(sysid).await?
        };
        let ep = Endpoint::new(sysid, v.compid);
        let steps = v
            .flavour
            .takeoff(ep, alt, v.home.map(|h| h.alt_amsl))
            .map_err(Self::flavour_err(sysid))?;
        let mut mode = None;
        let mut command = None;
        for step in steps {
            match step {
                Step::SetMode(m) => mode = Some(m),
                Step::Command(c) => command = Some(c),
                Step::Arm | Step::Send(_) => {}
            }
        }
        self.launch(sysid, Goal::Airborne { mode }, command).await
    }

    /// The vehicle's state as the launch machine reads it (not heard: nothing).
    fn observed(&self, sysid: u8) -> Observed {
        let Some(v) = self.vehicle(sysid) else {
            return Observed::default();
        };
        Observed {
            heard: v.alive,
            booting: v.booting,
            armed: v.armed,
            mode: v.flight_mode(),
            landed: landed_of(v.landed_state),
            alt_rel_m: v.alt_rel,
            climb_m_s: v.climb,
            blockers: if v.armed {
                Vec::new()
            } else {
                v.arm_blockers(self.clock.now())
            },
        }
    }

    /// What vehicle `sysid`'s telemetry says now, for an error message.
    pub(crate) fn state_seen(&self, sysid: u8) -> StateSeen {
        let now = self.clock.now();
        match self.vehicle(sysid) {
            Some(v) => StateSeen {
                heard: v.alive,
                armed: v.armed,
                mode: v.mode.clone(),
                landed: landed_of(v.landed_state),
                alt_rel_m: v.alt_rel,
                prearm: v.arm_inputs(now).prearm_text,
            },
            None => StateSeen {
                heard: false,
                armed: false,
                mode: "?".into(),
                landed: Landed::Unknown,
                alt_rel_m: None,
                prearm: None,
            },
        }
    }

    /// Get vehicle `sysid` to `goal` — a mode, armed, off the ground — confirmed from its own
    /// state and retried from it ([`fleetmap_core::proto::launch`]: the rules, the bounds,
    /// what QGroundControl and MAVSDK do): this drives the sans-IO [`Launch`] on the
    /// runtime's clock (the timeouts of [`super::OpsConfig`] are wall-clock times, as every
    /// wait of the composed operations), sending each step's command through the fleet
    /// ([`FleetHandle::command`]: resends on a lost ACK, waits for a booting vehicle) while
    /// it watches the vehicle's snapshots. `takeoff` is the take-off command for
    /// [`Goal::Airborne`].
    ///
    /// A step whose effect shows goes on to the next at once, while its command may still
    /// be resent for an ACK (harmless: ARM when armed is accepted, a second NAV_TAKEOFF is
    /// refused); a mode command still out when the launch ends is waited for (its ACK or the
    /// command sender's timeout), so that a late copy cannot undo a mode the caller sets
    /// next.
    pub(crate) async fn launch(
        &self,
        sysid: u8,
        goal: Goal,
        takeoff: Option<Command>,
    ) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let ep = Endpoint::new(sysid, v.compid);
        let ops = self.cfg.ops;
        let cfg = LaunchConfig {
            mode_confirm: ops.mode_confirm,
            arm_confirm: ops.arm_confirm,
            ready_wait: ops.arm_ready,
            ..LaunchConfig::default()
        };
        let t0 = tokio::time::Instant::now();
        let since =
            move || Time::from_micros(u64::try_from(t0.elapsed().as_micros()).unwrap_or(u64::MAX));
        let mut machine = Launch::new(goal, cfg, Time::ZERO);
        let mut snaps = self.watch();
        // Commands out: mode commands apart (waited for at the end).
        let mut modes: JoinSet<(LaunchStep, Result<(), CommandError>)> = JoinSet::new();
        let mut others: JoinSet<(LaunchStep, Result<(), CommandError>)> = JoinSet::new();
        let result = loop {
            snaps.borrow_and_update();
            if let Some(e) = self.conflict(sysid) {
                break Err(e);
            }
            let now = since();
            match machine.poll(now, &self.observed(sysid)) {
                Action::Done => break Ok(()),
                Action::Failed(failure) => {
                    break Err(match failure.cause {
                        Cause::NotReady { reasons } => FleetError::NotReady {
                            sysid,
                            waited_s: failure.waited.as_secs_f64(),
                            reasons,
                        },
                        _ => FleetError::NotStarted {
                            sysid,
                            failure: Box::new(failure),
                            state: Box::new(self.state_seen(sysid)),
                        },
                    });
                }
                Action::Send(step) => {
                    let cmd = match step {
                        LaunchStep::SetMode(m) => v.flavour.set_mode_command(ep, m),
                        LaunchStep::Arm => v.flavour.arm_command(ep, true),
                        LaunchStep::Takeoff => match &takeoff {
                            Some(c) => c.clone(),
                            None => {
                                break Err(FleetError::Flavour {
                                    sysid,
                                    error: FlavourError::Unknown {
                                        action: "take-off",
                                        what: "the take-off command",
                                    },
                                });
                            }
                        },
                    };
                    tracing::debug!("vehicle {sysid}: launch ({goal}): {step}");
                    let fleet = self.clone();
                    let task = async move {
                        let command = cmd.command;
                        let r = match fleet.command(cmd).await {
                            Ok(_) => Ok(()),
                            Err(FleetError::Command { error, .. }) => Err(error),
                            // Not sent, or no vehicle to answer: unanswered.
                            Err(_) => Err(CommandError::Timeout {
                                command,
                                attempts: 0,
                                timeout_ms: 0,
                            }),
                        };
                        (step, r)
                    };
                    if matches!(step, LaunchStep::SetMode(_)) {
                        modes.spawn(task);
                    } else {
                        others.spawn(task);
                    }
                }
                Action::Wait(until) => {
                    let sleep = until.saturating_since(now);
                    // `biased`: in this order, not tokio's random one, so that a run on a
                    // paused clock is the same every time.
                    tokio::select! {
                        biased;
                        Some(r) = modes.join_next(), if !modes.is_empty() => {
                            if let Ok((step, r)) = r {
                                machine.on_result(step, r, since());
                            }
                        }
                        Some(r) = others.join_next(), if !others.is_empty() => {
                            if let Ok((step, r)) = r {
                                machine.on_result(step, r, since());
                            }
                        }
                        changed = snaps.changed() => {
                            if changed.is_err() {
                                break Err(FleetError::Stopped);
                            }
                        }
                        _ = tokio::time::sleep(sleep) => {}
                    }
                }
            }
        };
        if let Err(e) = &result {
            tracing::warn!("{e}");
        } else if machine.failures() > 0 {
            tracing::info!(
                "vehicle {sysid}: {goal} after {} command(s), {} failed attempt(s)",
                machine.commands(),
                machine.failures()
            );
        }
        others.shutdown().await;
        // The command sender's budget is on the fleet's clock.
        let budget = CommandSender::budget(&self.cfg.command);
        let budget = self.clock.wall_until(self.clock.now() + budget);
        let _ = tokio::time::timeout(budget, async { while modes.join_next().await.is_some() {} })
            .await;
        result
    }

    /// Go to (`lat`, `lon`) degrees at `alt` metres above home now (DO_REPOSITION; for
    /// ArduPilot builds without it, GUIDED + SET_POSITION_TARGET_GLOBAL_INT).
    pub(crate) async fn goto(
        &self,
        sysid: u8,
        lat: f64,
        lon: f64,
        alt: f32,
    ) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let ep = Endpoint::new(sysid, v.compid);
        let (lat_e7, lon_e7) = (
            fleetmap_core::mission::item::deg_to_e7(lat),
            fleetmap_core::mission::item::deg_to_e7(lon),
        );
        let steps = v
            .flavour
            .goto(ep, lat_e7, lon_e7, alt, v.home.map(|h| h.alt_amsl))
            .map_err(Self::flavour_err(sysid))?;
        match self.run_steps(sysid, steps).await {
            Err(FleetError::Command {
                error: CommandError::Unsupported { .. } | CommandError::IntOnly { .. },
                ..
            }) if v.flavour.home_item() => {
                let steps = v
                    .flavour
                    .goto_fallback(ep, lat_e7, lon_e7, alt)
                    .map_err(Self::flavour_err(sysid))?;
                self.run_steps(sysid, steps).await
            }
            r => r,
        }
    }

    /// Turn vehicle `sysid` to the absolute heading `yaw_deg` (degrees clockwise from north)
    /// while it holds (`lat`, `lon`) at `alt` m above home: PX4 with a DO_REPOSITION that
    /// carries the yaw, ArduPilot with CONDITION_YAW (after the go-to that put it there).
    pub(crate) async fn face(
        &self,
        sysid: u8,
        lat: f64,
        lon: f64,
        alt: f32,
        yaw_deg: f32,
    ) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let ep = Endpoint::new(sysid, v.compid);
        let steps = if v.flavour.autopilot == Autopilot::ArduPilot {
            v.flavour.set_yaw(ep, yaw_deg)
        } else {
            v.flavour.goto_facing(
                ep,
                fleetmap_core::mission::item::deg_to_e7(lat),
                fleetmap_core::mission::item::deg_to_e7(lon),
                alt,
                v.home.map(|h| h.alt_amsl),
                Some(yaw_deg),
            )
        }
        .map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
    }

    /// Stop and hold where the vehicle is now (its autopilot's hold mode,
    /// [`fleetmap_core::proto::flavour::Flavour::pause`]).
    pub(crate) async fn pause(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let steps = v.flavour.pause().map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
    }

    /// Return to launch.
    pub async fn rtl(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let steps = v
            .flavour
            .rtl(Endpoint::new(sysid, v.compid))
            .map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
    }

    /// Land where the vehicle is.
    pub async fn land(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let steps = v
            .flavour
            .land(Endpoint::new(sysid, v.compid))
            .map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
    }

    /// Reboot the autopilot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, param1 = 1; both autopilots
    /// refuse it armed) and wait until it has rebooted and finished booting: its heartbeat
    /// or boot clock shows the reboot ([`VehicleSnapshot::reboots`]), then
    /// [`FleetHandle::wait_booted`]. Returns how long that took on the fleet's clock. Real
    /// vehicles may answer the command or go silent before the ACK gets out (ArduPilot
    /// SITL re-executes itself at once): a missing ACK is not an error when the reboot is
    /// then seen.
    pub(crate) async fn reboot(&self, sysid: u8) -> Result<Duration, FleetError> {
        let t0 = self.clock.now();
        let before = self.require(sysid)?.reboots;
        self.send_reboot(sysid).await?;
        let wait = self.cfg.ops.boot_wait;
        self.wait_until(sysid, wait, |s| s.reboots > before)
            .await
            .map_err(|_| FleetError::NotConfirmed {
                sysid,
                what: "a reboot".into(),
                waited_s: wait.as_secs_f64(),
                now: "the same boot".into(),
            })?;
        self.wait_booted(sysid).await?;
        Ok(self.clock.now().saturating_since(t0))
    }

    /// Send MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN (reboot the autopilot) and return once it is
    /// acknowledged — or not answered, as when the autopilot goes down before its ACK gets
    /// out ([`FleetHandle::reboot`] also waits for it to come back).
    pub(crate) async fn send_reboot(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let cmd = Command::long(
            Endpoint::new(sysid, v.compid),
            MavCmd::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        match self.command(cmd).await {
            Ok(_)
            | Err(FleetError::Command {
                error: CommandError::Timeout { .. },
                ..
            }) => Ok(()),
            Err(e) => Err(e),
        }
    }

    /// Start the uploaded mission (MAV_CMD_MISSION_START; the vehicle must be armed, and
    /// airborne if it flies — see [`FleetHandle::takeoff`]). An ArduRover still in AUTO (its
    /// last mission finished there) is switched to HOLD first: MISSION_START in AUTO is
    /// accepted and starts nothing ([`fleetmap_core::proto::flavour::Flavour::
    /// mission_start_needs_leaving_auto`]); from HOLD, MISSION_START enters AUTO and runs the
    /// mission from its current item (seen on ArduRover SITL V4.7.0-dev).
    ///
    /// Confirmed from the heartbeat, as `FleetHandle::launch` confirms a mode: the start
    /// counts once the vehicle is seen in its mission mode — also when the ACK was lost —
    /// and not before; an accepted start that does not show within
    /// `super::OpsConfig::mode_confirm`, or a refused one, is tried again (three times,
    /// 1 s then 2 s apart) from the state the vehicle is in then.
    pub async fn start_mission(&self, sysid: u8) -> Result<(), FleetError> {
        let in_mission = |s: &VehicleSnapshot| {
            s.flavour
                .mission_mode()
                .is_ok_and(|m| s.flavour.is_mode(s.custom_mode, m))
        };
        let mut last = None;
        for attempt in 0..3u32 {
            if attempt > 0 {
                tokio::time::sleep(Duration::from_secs(1 << (attempt - 1))).await;
            }
            let v = self.require(sysid)?;
            if v.flavour.mission_start_needs_leaving_auto() && in_mission(&v) {
                let hold = v.flavour.hold_mode().map_err(Self::flavour_err(sysid))?;
                self.set_mode_to(&v, hold).await?;
            }
            let v = self.require(sysid)?;
            self.reset_progress(sysid).await?;
            let steps = v
                .flavour
                .start_mission(Endpoint::new(sysid, v.compid))
                .map_err(Self::flavour_err(sysid))?;
            let sent = self.run_steps(sysid, steps).await;
            let seen = self
                .wait_until(sysid, self.cfg.ops.mode_confirm, in_mission)
                .await
                .is_ok();
            match sent {
                _ if seen => return Ok(()),
                Err(e @ (FleetError::Stopped | FleetError::Flavour { .. })) => return Err(e),
                Err(e) => {
                    tracing::warn!("vehicle {sysid}: starting its mission: {e}");
                    last = Some(e);
                }
                Ok(()) => {
                    tracing::warn!(
                        "vehicle {sysid}: MISSION_START accepted, not in its mission mode"
                    );
                    last = None;
                }
            }
        }
        Err(last.unwrap_or_else(|| FleetError::NotConfirmed {
            sysid,
            what: "the mission mode after MISSION_START".into(),
            waited_s: self.cfg.ops.mode_confirm.as_secs_f64(),
            now: self
                .vehicle(sysid)
                .map(|v| format!("mode {}", v.mode))
                .unwrap_or_default(),
        }))
    }

    /// Take one picture: MAV_CMD_IMAGE_START_CAPTURE to the vehicle's camera component when
    /// one was heard (the MAVLink camera protocol), otherwise MAV_CMD_DO_DIGICAM_CONTROL to
    /// the autopilot (param5 = 1: shoot), which ArduPilot's AP_Camera and PX4's
    /// camera_trigger handle. `seq` numbers the image (IMAGE_START_CAPTURE param4).
    pub async fn capture_image(&self, sysid: u8, seq: u32) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let cmd = match v.camera_compid {
            Some(c) => capture_command(Endpoint::new(sysid, c), seq),
            None => Command::long(
                Endpoint::new(sysid, v.compid),
                MavCmd::MAV_CMD_DO_DIGICAM_CONTROL,
                [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
            ),
        };
        self.command(cmd).await.map(|_| ())
    }
}

/// MAV_CMD_IMAGE_START_CAPTURE to `camera` for single capture `seq`: no interval, one image,
/// the sequence number that makes a command sent again take no second picture (common.xml).
pub(crate) fn capture_command(camera: Endpoint, seq: u32) -> Command {
    Command::long(
        camera,
        MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
        [0.0, 0.0, 1.0, seq as f32, f32::NAN, f32::NAN, f32::NAN],
    )
}
