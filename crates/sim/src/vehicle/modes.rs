//! Flight modes and failsafes: mode changes and their checks, RTL and landing logic,
//! auto-disarm, the battery and data-link failsafes.

use super::*;

/// The flight mode and the failsafe state.
#[derive(Debug)]
pub(super) struct Modes {
    /// The current flight mode.
    pub(super) mode: SimMode,
    /// The battery failsafe level reached (0 none, 1 RTL, 2 land).
    pub(super) failsafe_level: u8,
    /// When the last GCS heartbeat arrived (`None` since boot: no GCS seen).
    pub(super) last_gcs_heartbeat: Option<Time>,
    /// Whether the data-link-loss failsafe is active.
    pub(super) datalink_lost: bool,
}

impl SimVehicle {
    // ------------------------------------------------------------------ modes

    pub(super) fn run_mode(&mut self, now: Time) {
        match self.modes.mode {
            SimMode::Auto => self.run_mission(now),
            SimMode::Takeoff => {
                if let Nav::Takeoff(p) = self.flight.nav
                    && self.arming.armed
                    && (self.flight.m.u - p.u).abs() < 0.8
                {
                    self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Takeoff detected");
                    self.enter_mode(SimMode::Hold, now);
                }
            }
            SimMode::Rtl => self.run_rtl(now),
            SimMode::Land => {
                if let Nav::Land { p, descending } = self.flight.nav
                    && !descending
                {
                    let (e, n) = self.est();
                    if (p.e - e).hypot(p.n - n) < 1.0 {
                        self.flight.nav = Nav::Land {
                            p,
                            descending: true,
                        };
                    }
                }
            }
            // PX4 offboard needs a setpoint stream (COM_OF_LOSS_T 1 s)
            SimMode::Guided
                if self.cfg.flavour.autopilot == SimAutopilot::Px4
                    && self
                        .flight
                        .guided_target_at
                        .is_none_or(|t| now.saturating_since(t) > Duration::from_secs(1)) =>
            {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Failsafe activated: offboard control lost",
                );
                self.enter_mode(SimMode::Hold, now);
            }
            _ => {}
        }
    }

    pub(super) fn run_rtl(&mut self, now: Time) {
        let Nav::Rtl { phase, ret_u } = self.flight.nav else {
            return;
        };
        let h = self.home_local();
        let (e, n) = self.est();
        let dist = (h.0 - e).hypot(h.1 - n);
        let copter = self.cfg.flavour.is_copter();
        let ap = self.cfg.flavour.is_ardupilot();
        let next = match phase {
            RtlPhase::Climb if !copter || self.flight.m.u >= ret_u - 0.5 => Some(RtlPhase::Return),
            RtlPhase::Return
                if dist < if copter { 0.5 } else { 2.0 } && self.flight.m.ground_speed() < 0.3 =>
            {
                if !copter {
                    if ap {
                        self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Reached destination");
                    }
                    Some(RtlPhase::Done)
                } else if ap {
                    // RTL_LOIT_TIME 5 s at RTL_ALT_FINAL 0 → land
                    Some(RtlPhase::Loiter(now + Duration::from_secs(5)))
                } else if self.flight.m.u > 30.5 {
                    Some(RtlPhase::Descend)
                } else {
                    Some(RtlPhase::Land)
                }
            }
            RtlPhase::Descend if self.flight.m.u <= 30.5 => Some(RtlPhase::Land),
            RtlPhase::Loiter(t) if now >= t => Some(RtlPhase::Land),
            _ => None,
        };
        if let Some(p) = next {
            let ret_u = if p == RtlPhase::Descend { 30.0 } else { ret_u };
            self.flight.nav = Nav::Rtl { phase: p, ret_u };
        }
    }

    pub(super) fn on_touchdown(&mut self, now: Time) {
        let ap = self.cfg.flavour.is_ardupilot();
        match self.modes.mode {
            SimMode::Land | SimMode::Rtl => {
                if let Nav::Rtl { ret_u, .. } = self.flight.nav {
                    self.flight.nav = Nav::Rtl {
                        phase: RtlPhase::Done,
                        ret_u,
                    };
                }
                if ap {
                    self.disarm(now, "landed");
                }
            }
            SimMode::Auto => {
                // the mission's LAND / RTL completes on touchdown (handled in run_mission)
            }
            _ => {}
        }
    }

    pub(super) fn check_auto_disarm(&mut self, now: Time) {
        if !self.arming.armed || self.cfg.flavour.kind == SimVehicleClass::Rover {
            return;
        }
        let ap = self.cfg.flavour.is_ardupilot();
        if self.arming.landed {
            let since = self
                .arming
                .landed_at
                .map(|t| t.max(self.arming.armed_at))
                .unwrap_or(self.arming.armed_at);
            let taking_off = matches!(self.flight.nav, Nav::Takeoff(_))
                || (self.modes.mode == SimMode::Auto && self.missions.exec.px4_takeoff.is_some())
                || (self.modes.mode == SimMode::Auto
                    && !self.missions.exec.waiting_auto_armed
                    && self.missions.exec.running
                    && self.current_item_is_takeoff());
            let limit = if self.arming.took_off {
                // after a landing: ArduCopter disarms at once in LAND/RTL/AUTO (done on
                // touchdown), else after DISARM_DELAY; PX4 COM_DISARM_LAND 2 s
                if ap { 10.0 } else { 2.0 }
            } else if ap {
                10.0 // DISARM_DELAY (measured 10.1 s after the ARM's ACK)
            } else {
                // COM_DISARM_PRFLT 10 s, counted from when the land detector says landed
                // after arming: 10.9–11.6 s after the ACK on PX4 1.16 SIH
                11.0
            };
            if !taking_off && now.saturating_since(since).as_secs_f64() >= limit {
                let reason = if self.arming.took_off {
                    "landing"
                } else {
                    "auto preflight disarming"
                };
                self.disarm(now, reason);
            }
        }
    }

    pub(super) fn current_item_is_takeoff(&self) -> bool {
        self.missions
            .exec
            .nav_index
            .and_then(|i| {
                self.missions
                    .server
                    .items(MissionType::Mission)
                    .get(i as usize)
            })
            .is_some_and(|it| it.command == mi::NAV_TAKEOFF)
    }

    pub(super) fn check_failsafes(&mut self, now: Time) {
        let pct = self.power.battery.fraction() * 100.0;
        let fs = self.cfg.failsafe;
        let ap = self.cfg.flavour.is_ardupilot();
        if self.modes.failsafe_level < 1 && pct <= fs.rtl_pct {
            self.modes.failsafe_level = 1;
            if ap {
                let msg = format!(
                    "Battery 1 is low {:.2}V used {:.0} mAh",
                    self.power.battery.voltage(),
                    self.power.battery.consumed_mah
                );
                self.text(mav::MavSeverity::MAV_SEVERITY_WARNING, &msg);
            } else {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Critical battery level! Executing RTL",
                );
            }
            if self.arming.armed && !self.arming.landed {
                if self.flight.home.is_some() && self.enter_mode(SimMode::Rtl, now) {
                    self.telemetry
                        .events
                        .push_back(VehicleEvent::BatteryFailsafe(SimMode::Rtl));
                } else if self.cfg.flavour.is_copter() {
                    self.enter_mode(SimMode::Land, now);
                    self.telemetry
                        .events
                        .push_back(VehicleEvent::BatteryFailsafe(SimMode::Land));
                }
            }
        }
        if self.modes.failsafe_level < 2 && pct <= fs.land_pct {
            self.modes.failsafe_level = 2;
            if ap {
                let msg = format!(
                    "Battery 1 is critical {:.2}V used {:.0} mAh",
                    self.power.battery.voltage(),
                    self.power.battery.consumed_mah
                );
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
            } else {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_EMERGENCY,
                    "Emergency battery level! Landing immediately",
                );
            }
            if self.arming.armed
                && !self.arming.landed
                && self.cfg.flavour.is_copter()
                && self.modes.mode != SimMode::Land
            {
                // already descending at home in RTL's landing phase: keep it
                let landing_home = matches!(
                    self.flight.nav,
                    Nav::Rtl {
                        phase: RtlPhase::Land,
                        ..
                    }
                );
                if !landing_home {
                    self.enter_mode(SimMode::Land, now);
                    self.telemetry
                        .events
                        .push_back(VehicleEvent::BatteryFailsafe(SimMode::Land));
                }
            }
        }
        // PX4 data link loss (NAV_DLL_ACT = RTL after COM_DL_LOSS_T 10 s)
        if self.cfg.flavour.autopilot == SimAutopilot::Px4
            && self.cfg.px4_datalink_required
            && self.arming.armed
            && !self.modes.datalink_lost
            && self
                .modes
                .last_gcs_heartbeat
                .is_some_and(|t| now.saturating_since(t) > self.gcs_link_loss_timeout())
        {
            self.modes.datalink_lost = true;
            self.text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "Connection to ground station lost",
            );
            if !self.arming.landed
                && self.modes.mode != SimMode::Rtl
                && self.modes.mode != SimMode::Land
            {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Failsafe activated: Return",
                );
                self.enter_mode(SimMode::Rtl, now);
            }
        }
    }

    pub(super) fn check_swap(&mut self, now: Time) {
        if self.arming.armed || !self.arming.landed {
            self.arming.disarmed_landed_since = None;
            return;
        }
        let since = *self.arming.disarmed_landed_since.get_or_insert(now);
        if let Some(s) = self.cfg.swap_after_s
            && self.power.battery.fraction() < 0.95
            && now.saturating_since(since).as_secs_f64() >= s
        {
            self.power_cycle(now, true);
        }
    }

    /// Switch mode as the autopilot would for an internal reason or a GCS request; returns
    /// whether the mode changed (or already was `mode`).
    pub(super) fn enter_mode(&mut self, mode: SimMode, now: Time) -> bool {
        let here = self.here();
        let copter = self.cfg.flavour.is_copter();
        match mode {
            SimMode::Hold
            | SimMode::Loiter
            | SimMode::Brake
            | SimMode::Stabilize
            | SimMode::AltHold
            | SimMode::Manual => {
                self.flight.nav = if self.arming.landed && copter {
                    Nav::Idle
                } else {
                    Nav::Hold(here)
                };
            }
            SimMode::Guided => {
                self.flight.nav = if self.arming.landed && copter {
                    Nav::Idle
                } else {
                    Nav::Hold(here)
                };
            }
            SimMode::Land => {
                self.flight.nav = Nav::Land {
                    p: here,
                    descending: true,
                };
            }
            SimMode::Rtl => {
                let ret_u = if !copter {
                    0.0
                } else if self.cfg.flavour.is_ardupilot() {
                    self.flight.m.u.max(15.0) // RTL_ALT 15 m is a minimum
                } else {
                    let h = self.home_local();
                    let dist = (h.0 - here.e).hypot(h.1 - here.n);
                    // RTL_RETURN_ALT 60 m, RTL_DESCEND_ALT 30 m, RTL_CONE_ANG 45°
                    self.flight.m.u.max(dist.clamp(30.0, 60.0))
                };
                let phase = if copter {
                    RtlPhase::Climb
                } else {
                    RtlPhase::Return
                };
                self.flight.nav = Nav::Rtl { phase, ret_u };
            }
            SimMode::Takeoff => {
                let alt = 2.5; // MIS_TAKEOFF_ALT
                self.flight.nav = Nav::Takeoff(Point { u: alt, ..here });
            }
            SimMode::Auto => {
                self.start_or_resume_mission(now);
            }
            SimMode::Initialising => {}
        }
        if self.modes.mode != mode {
            self.modes.mode = mode;
            // entering a mode re-initialises the navigation speed (ArduCopter
            // wp_and_spline_init → WPNAV_SPEED; PX4 navigator reset_cruising_speed)
            self.flight.speed_override = None;
            self.flight.yaw_target_deg = None;
            if mode != SimMode::Auto {
                self.missions.exec.running = false;
                self.missions.server.set_mission_running(false);
            }
            let name = self.cfg.flavour.mode_name(mode);
            if self.cfg.flavour.is_ardupilot() {
                // ArduPilot announces mode changes only through the HEARTBEAT
                let _ = name;
            }
            self.send_heartbeat(now);
        }
        true
    }

    /// A GCS mode request (DO_SET_MODE / SET_MODE): MAV_RESULT as the autopilot gives it.
    pub(super) fn set_mode_request(
        &mut self,
        base_mode: u8,
        custom_mode: u32,
        now: Time,
    ) -> mav::MavResult {
        use mav::MavResult as R;
        let f = self.cfg.flavour;
        if base_mode & 1 == 0 {
            // only custom modes are supported by the simulator (PX4 maps a few base modes)
            return if f.is_ardupilot() {
                R::MAV_RESULT_FAILED
            } else {
                R::MAV_RESULT_TEMPORARILY_REJECTED
            };
        }
        let Some(mode) = f.mode_from_custom(custom_mode) else {
            return if f.is_ardupilot() {
                R::MAV_RESULT_FAILED
            } else {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Unsupported auto mode",
                );
                R::MAV_RESULT_TEMPORARILY_REJECTED
            };
        };
        match self.check_mode_allowed(mode, now) {
            Ok(()) => {
                // ArduRover changes nothing when asked for the mode it is in, AUTO included:
                // `Rover::set_mode` returns true at once when `control_mode == &new_mode`
                // (ArduPilot/ardupilot Rover/system.cpp, V4.7.0-dev), so ModeAuto::_enter and
                // its `mission.start_or_resume()` do not run again. A finished mission (MIS_
                // DONE_BEHAVE 0 leaves the rover in AUTO) is not restarted by AUTO or by
                // MISSION_START (seen on ArduRover SITL V4.7.0-dev 90700977).
                let rover_ap = f.is_ardupilot() && f.kind == SimVehicleClass::Rover;
                if self.modes.mode == mode && (mode != SimMode::Auto || rover_ap) {
                    return R::MAV_RESULT_ACCEPTED;
                }
                self.enter_mode(mode, now);
                R::MAV_RESULT_ACCEPTED
            }
            Err(reason) => {
                if f.is_ardupilot() {
                    let msg = format!("Mode change to {} failed: {reason}", f.mode_name(mode));
                    self.text(mav::MavSeverity::MAV_SEVERITY_WARNING, &msg);
                    R::MAV_RESULT_FAILED
                } else {
                    let msg = format!(
                        "Switching to {} is currently not possible",
                        f.mode_name(mode)
                    );
                    self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
                    R::MAV_RESULT_TEMPORARILY_REJECTED
                }
            }
        }
    }

    pub(super) fn check_mode_allowed(
        &mut self,
        mode: SimMode,
        now: Time,
    ) -> Result<(), &'static str> {
        let f = self.cfg.flavour;
        // ArduPilot checks a mode's position requirement only when armed ("allow switching to
        // any mode if disarmed. We rely on the arming check": `ignore_checks =
        // !motors->armed()` in Copter::set_mode, the same in Rover's SimMode::enter); PX4's
        // commander refuses such a mode disarmed too.
        let ignore_checks = f.is_ardupilot() && !self.arming.armed;
        if mode.requires_position() && !ignore_checks && !self.position_ok(now) {
            return Err("requires position");
        }
        match (f.autopilot, mode) {
            (SimAutopilot::ArduPilot, SimMode::Auto) => {
                let n = self.missions.server.items(MissionType::Mission).len();
                if n <= 1 {
                    self.text(
                        mav::MavSeverity::MAV_SEVERITY_WARNING,
                        "AutoMode: Mission is empty",
                    );
                    return Err("init failed");
                }
                if f.is_copter()
                    && self.arming.armed
                    && self.arming.landed
                    && !self.mission_starts_with_takeoff()
                {
                    self.text(
                        mav::MavSeverity::MAV_SEVERITY_WARNING,
                        "Auto: Missing Takeoff Cmd",
                    );
                    return Err("init failed");
                }
                Ok(())
            }
            (SimAutopilot::ArduPilot, SimMode::Rtl | SimMode::Land)
                if self.arming.landed && !self.arming.armed =>
            {
                Ok(())
            }
            (SimAutopilot::Px4, SimMode::Auto) => {
                if self.missions.server.items(MissionType::Mission).is_empty()
                    || !self.missions.valid
                {
                    return Err("no valid mission");
                }
                Ok(())
            }
            (SimAutopilot::Px4, SimMode::Guided) => {
                if self
                    .flight
                    .guided_target_at
                    .is_none_or(|t| now.saturating_since(t) > Duration::from_millis(500))
                {
                    return Err("no offboard signal");
                }
                Ok(())
            }
            (SimAutopilot::Px4, SimMode::Rtl) if self.flight.home.is_none() => Err("no home"),
            _ => Ok(()),
        }
    }

    pub(super) fn mission_starts_with_takeoff(&self) -> bool {
        // AP_Mission::starts_with_takeoff_cmd: next nav command from the resume point (or 1)
        let items = self.missions.server.items(MissionType::Mission);
        let start = self
            .missions
            .exec
            .nav_index
            .filter(|_| !self.missions.exec.complete)
            .unwrap_or(1) as usize;
        for it in items.iter().skip(start).take(16) {
            match it.command {
                mi::NAV_TAKEOFF | mi::NAV_VTOL_TAKEOFF => return true,
                mi::NAV_DELAY | mi::DO_AUX_FUNCTION => continue,
                c if fleetmap_core::mission::item::cmd::is_nav(c) => return false,
                _ => continue,
            }
        }
        false
    }
}

impl SimVehicle {
    // ------------------------------------------------------------------ commands
    // (dispatched by `commands::command`)

    /// DO_SET_MODE: ArduPilot custom_mode = param2; PX4 main mode = param2, sub mode = param3.
    pub(super) fn cmd_do_set_mode(
        &mut self,
        c: &mav::COMMAND_INT_DATA,
        now: Time,
    ) -> mav::MavResult {
        let ap = self.cfg.flavour.is_ardupilot();
        let custom = if ap {
            c.param2 as u32
        } else {
            ((c.param2 as u32) << 16) | ((c.param3 as u32) << 24)
        };
        let custom = if !ap && (c.param2 as u32) == 4 && (c.param3 as u32) == 0 {
            (4 << 16) | (4 << 24) // AUTO without sub mode = mission
        } else {
            custom
        };
        self.set_mode_request(c.param1 as u8, custom, now)
    }

    /// NAV_LAND (copters only): land where it is.
    pub(super) fn cmd_land(&mut self, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        if !self.cfg.flavour.is_copter() {
            R::MAV_RESULT_UNSUPPORTED
        } else if self.cfg.flavour.is_ardupilot() {
            if self.check_mode_allowed(SimMode::Land, now).is_ok() {
                self.enter_mode(SimMode::Land, now);
                R::MAV_RESULT_ACCEPTED
            } else {
                R::MAV_RESULT_FAILED
            }
        } else {
            self.enter_mode(SimMode::Land, now);
            self.text(
                mav::MavSeverity::MAV_SEVERITY_INFO,
                "Landing at current position",
            );
            R::MAV_RESULT_ACCEPTED
        }
    }

    /// NAV_RETURN_TO_LAUNCH.
    pub(super) fn cmd_rtl(&mut self, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        let ap = self.cfg.flavour.is_ardupilot();
        match self.check_mode_allowed(SimMode::Rtl, now) {
            Ok(()) => {
                self.enter_mode(SimMode::Rtl, now);
                if !ap {
                    self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Returning to launch");
                }
                R::MAV_RESULT_ACCEPTED
            }
            Err(_) if ap => R::MAV_RESULT_FAILED,
            Err(_) => R::MAV_RESULT_TEMPORARILY_REJECTED,
        }
    }

    /// NAV_LOITER_UNLIM (ArduPilot): copters hold (LOITER), rovers loiter.
    pub(super) fn cmd_loiter_unlim(&mut self, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        let m = if self.cfg.flavour.is_copter() {
            SimMode::Hold
        } else {
            SimMode::Loiter
        };
        match self.check_mode_allowed(m, now) {
            Ok(()) => {
                self.enter_mode(m, now);
                R::MAV_RESULT_ACCEPTED
            }
            Err(_) => R::MAV_RESULT_FAILED,
        }
    }
}
