//! Operations composed on the handle from the actor's primitives: modes, arming, take-off,
//! go to, face, pause, return, land, reboot, start a mission, camera capture. Each step has
//! its own timeout and typed error ([`super::FleetError`]).

use super::error::FleetError;
use super::handle::FleetHandle;
use super::state::VehicleSnapshot;
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::command::Command;
use fleetmap_core::proto::command::CommandError;
use fleetmap_core::proto::flavour::Autopilot;
use fleetmap_core::proto::flavour::FlavourError;
use fleetmap_core::proto::flavour::Step;
use fleetmap_core::proto::mode::Mode;
use mavlink::dialects::ardupilotmega::MavCmd;
use std::time::Duration;

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
        let ep = Endpoint::new(sysid, v.compid);
        self.command(v.flavour.set_mode_command(ep, mode)).await?;
        let timeout = self.cfg.ops.mode_confirm;
        let flavour = v.flavour;
        self.wait_until(sysid, timeout, |s| flavour.is_mode(s.custom_mode, mode))
            .await
            .map(|_| ())
            .map_err(|now| FleetError::NotConfirmed {
                sysid,
                what: format!("mode {}", mode.name()),
                waited_s: timeout.as_secs_f64(),
                now: now.map(|v| format!("mode {}", v.mode)).unwrap_or_default(),
            })
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
            Err(last) => Err(FleetError::NotReady {
                sysid,
                waited_s: wait.as_secs_f64(),
                reasons: last
                    .map(|s| s.arm_blockers(self.clock.now()))
                    .unwrap_or_else(|| vec!["vehicle lost".into()]),
            }),
        }
    }

    /// Arm: wait until the vehicle is really ready ([`FleetHandle::wait_ready`]), send
    /// the arm command, and wait for the heartbeat to show armed.
    pub async fn arm(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        if v.armed {
            return Ok(());
        }
        self.wait_ready(sysid).await?;
        let ep = Endpoint::new(sysid, v.compid);
        match self.command(v.flavour.arm_command(ep, true)).await {
            Ok(_) => {}
            Err(FleetError::Command { error, .. }) => {
                let prearm = self
                    .vehicle(sysid)
                    .and_then(|s| s.prearm_text)
                    .map(|t| t.text);
                return Err(FleetError::ArmRefused {
                    sysid,
                    error,
                    prearm,
                });
            }
            Err(e) => return Err(e),
        }
        let timeout = self.cfg.ops.arm_confirm;
        self.wait_until(sysid, timeout, |s| s.armed)
            .await
            .map(|_| ())
            .map_err(|_| FleetError::NotConfirmed {
                sysid,
                what: "armed".into(),
                waited_s: timeout.as_secs_f64(),
                now: "disarmed".into(),
            })
    }

    /// Disarm and wait for the heartbeat to show it.
    pub(crate) async fn disarm(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        if !v.armed {
            return Ok(());
        }
        let ep = Endpoint::new(sysid, v.compid);
        self.command(v.flavour.arm_command(ep, false)).await?;
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
    /// (ArduCopter: GUIDED, arm, NAV_TAKEOFF; PX4: arm, NAV_TAKEOFF with AMSL altitude).
    /// Returns when the take-off command is accepted.
    ///
    /// A disarmed vehicle is first waited for until it is ready to arm
    /// ([`FleetHandle::wait_ready`]), before the first step and not only before arming
    /// (for the first 15–30 s after boot and after every battery swap it is not): a mode
    /// that needs a position may be refused until the estimate is good (PX4's mode
    /// requirements apply disarmed too; ArduCopter's `Copter::set_mode` takes GUIDED
    /// disarmed but the arming that follows fails), and PX4's take-off altitude is AMSL, so
    /// home must be known before the steps are built.
    pub async fn takeoff(&self, sysid: u8, alt: f32) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let v = if v.armed {
            v
        } else {
            self.wait_ready(sysid).await?
        };
        let ep = Endpoint::new(sysid, v.compid);
        let steps = v
            .flavour
            .takeoff(ep, alt, v.home.map(|h| h.alt_amsl))
            .map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
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
    pub async fn start_mission(&self, sysid: u8) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        if v.flavour.mission_start_needs_leaving_auto()
            && let Ok(auto) = v.flavour.mission_mode()
            && v.flavour.is_mode(v.custom_mode, auto)
        {
            let hold = v.flavour.hold_mode().map_err(Self::flavour_err(sysid))?;
            self.set_mode_to(&v, hold).await?;
        }
        let v = self.require(sysid)?;
        self.reset_progress(sysid).await?;
        let steps = v
            .flavour
            .start_mission(Endpoint::new(sysid, v.compid))
            .map_err(Self::flavour_err(sysid))?;
        self.run_steps(sysid, steps).await
    }

    /// Take one picture: MAV_CMD_IMAGE_START_CAPTURE to the vehicle's camera component when
    /// one was heard (the MAVLink camera protocol), otherwise MAV_CMD_DO_DIGICAM_CONTROL to
    /// the autopilot (param5 = 1: shoot), which ArduPilot's AP_Camera and PX4's
    /// camera_trigger handle. `seq` numbers the image (IMAGE_START_CAPTURE param4).
    pub async fn capture_image(&self, sysid: u8, seq: u32) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let cmd = match v.camera_compid {
            Some(c) => Command::long(
                Endpoint::new(sysid, c),
                MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
                [0.0, 0.0, 1.0, seq as f32, f32::NAN, f32::NAN, f32::NAN],
            ),
            None => Command::long(
                Endpoint::new(sysid, v.compid),
                MavCmd::MAV_CMD_DO_DIGICAM_CONTROL,
                [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0],
            ),
        };
        self.command(cmd).await.map(|_| ())
    }
}
