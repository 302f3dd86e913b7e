//! COMMAND_LONG / COMMAND_INT handling: conversion to COMMAND_INT, dispatch on the
//! dialect's `MavCmd`, one handler per command group.

use super::*;
use mav::MavCmd;

/// [`CMD_BATTERY_SWAP`] as the dialect's command (MAV_CMD_USER_1).
const BATTERY_SWAP: MavCmd = MavCmd::MAV_CMD_USER_1;
/// COMPONENT_ARM_DISARM param2 that forces arming/disarming (ArduPilot and PX4 magic value).
const ARM_DISARM_FORCE: f32 = 21196.0;

/// Whether a command's frame gives altitudes relative to home (GLOBAL_RELATIVE_ALT, its
/// _INT form) rather than AMSL.
fn is_relative_alt(frame: mav::MavFrame) -> bool {
    matches!(
        frame,
        mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
            | mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    )
}

impl SimVehicle {
    // ------------------------------------------------------------------ commands

    pub(super) fn ack(&mut self, to: (u8, u8), command: mav::MavCmd, result: mav::MavResult) {
        self.queue(
            AUTOPILOT_COMPID,
            MavMessage::COMMAND_ACK(mav::COMMAND_ACK_DATA {
                command,
                result,
                progress: 0,
                result_param2: 0,
                target_system: to.0,
                target_component: to.1,
            }),
        );
    }

    pub(super) fn command_long(&mut self, from: (u8, u8), c: &mav::COMMAND_LONG_DATA, now: Time) {
        // COMMAND_LONG → COMMAND_INT the way ArduPilot converts it
        // (GCS_Common.cpp convert_COMMAND_LONG_to_COMMAND_INT / command_long_stores_location)
        use mav::MavCmd as C;
        let stores_location = matches!(
            c.command,
            C::MAV_CMD_DO_SET_HOME
                | C::MAV_CMD_DO_SET_ROI
                | C::MAV_CMD_DO_SET_ROI_LOCATION
                | C::MAV_CMD_DO_REPOSITION
                | C::MAV_CMD_EXTERNAL_POSITION_ESTIMATE
        );
        let (x, y) = if stores_location {
            (
                (f64::from(c.param5) * 1e7) as i32,
                (f64::from(c.param6) * 1e7) as i32,
            )
        } else {
            (
                if c.param5.is_nan() {
                    0
                } else {
                    c.param5 as i32
                },
                if c.param6.is_nan() {
                    0
                } else {
                    c.param6 as i32
                },
            )
        };
        // ArduPilot: mav_frame_for_command_long (takeoff altitudes are relative); PX4 reads
        // COMMAND_LONG position altitudes (takeoff, reposition) as AMSL
        let frame = match (self.cfg.flavour.autopilot, c.command) {
            (
                SimAutopilot::ArduPilot,
                C::MAV_CMD_NAV_TAKEOFF
                | C::MAV_CMD_NAV_VTOL_TAKEOFF
                | C::MAV_CMD_DO_SET_ROI_LOCATION
                | C::MAV_CMD_DO_SET_ROI,
            ) => mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
            _ => mav::MavFrame::MAV_FRAME_GLOBAL,
        };
        let ci = mav::COMMAND_INT_DATA {
            param1: c.param1,
            param2: c.param2,
            param3: c.param3,
            param4: c.param4,
            x,
            y,
            z: c.param7,
            command: c.command,
            target_system: c.target_system,
            target_component: c.target_component,
            frame,
            current: 0,
            autocontinue: 0,
        };
        // PX4 keeps COMMAND_LONG's float lat/lon (NaN = current position)
        let nan_pos = c.param5.is_nan() || c.param6.is_nan();
        self.command(from, &ci, true, nan_pos, now);
    }

    pub(super) fn command_int(&mut self, from: (u8, u8), c: &mav::COMMAND_INT_DATA, now: Time) {
        self.command(from, c, false, false, now);
    }

    /// Dispatch one command to the autopilot (or the camera component) and acknowledge it.
    /// `long`: it came as COMMAND_LONG (converted); `nan_pos`: PX4's NaN latitude/longitude
    /// ("the current position").
    pub(super) fn command(
        &mut self,
        from: (u8, u8),
        c: &mav::COMMAND_INT_DATA,
        long: bool,
        nan_pos: bool,
        now: Time,
    ) {
        use mav::MavCmd as C;
        use mav::MavResult as R;
        if c.target_component == CAMERA_COMPID {
            self.camera_command(from, c, now);
            return;
        }
        if c.target_component != AUTOPILOT_COMPID && c.target_component != 0 {
            return;
        }
        let ap = self.cfg.flavour.is_ardupilot();
        let copter = self.cfg.flavour.is_copter();
        // `None`: the handler answered (or had the camera answer) itself
        let result = match c.command {
            C::MAV_CMD_COMPONENT_ARM_DISARM => Some(self.cmd_arm_disarm(c, now)),
            C::MAV_CMD_DO_SET_MODE => Some(self.cmd_do_set_mode(c, now)),
            C::MAV_CMD_NAV_TAKEOFF => Some(self.cmd_takeoff(c, now)),
            C::MAV_CMD_NAV_LAND => Some(self.cmd_land(now)),
            C::MAV_CMD_NAV_RETURN_TO_LAUNCH => Some(self.cmd_rtl(now)),
            C::MAV_CMD_NAV_LOITER_UNLIM if ap => Some(self.cmd_loiter_unlim(now)),
            C::MAV_CMD_MISSION_START => Some(self.cmd_mission_start(c, now)),
            C::MAV_CMD_DO_REPOSITION => Some(self.cmd_reposition(c, long, nan_pos, now)),
            C::MAV_CMD_CONDITION_YAW if ap && copter => Some(self.cmd_condition_yaw(c)),
            C::MAV_CMD_DO_CHANGE_SPEED => Some(self.cmd_change_speed(c)),
            C::MAV_CMD_DO_SET_MISSION_CURRENT => Some(self.cmd_set_mission_current(c, now)),
            C::MAV_CMD_DO_FENCE_ENABLE if ap => Some(self.cmd_fence_enable(c)),
            C::MAV_CMD_SET_MESSAGE_INTERVAL => {
                Some(self.cmd_message_interval(c.param1 as u32, c.param2, now))
            }
            C::MAV_CMD_REQUEST_MESSAGE => Some(self.cmd_request_message(c.param1 as u32, now)),
            C::MAV_CMD_GET_HOME_POSITION => Some(self.cmd_get_home_position(now)),
            C::MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES => {
                self.queue(AUTOPILOT_COMPID, self.autopilot_version_msg());
                Some(R::MAV_RESULT_ACCEPTED)
            }
            C::MAV_CMD_DO_SET_HOME => Some(self.cmd_set_home(c, now)),
            C::MAV_CMD_DO_DIGICAM_CONTROL
            | C::MAV_CMD_DO_SET_CAM_TRIGG_DIST
            | C::MAV_CMD_IMAGE_START_CAPTURE
            | C::MAV_CMD_IMAGE_STOP_CAPTURE => self.cmd_camera(from, c, long, now),
            C::MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN => self.cmd_reboot(from, c, now),
            BATTERY_SWAP => self.cmd_battery_swap(from, c, now),
            C::MAV_CMD_DO_PAUSE_CONTINUE if ap && copter => Some(self.cmd_pause_continue(c)),
            _ => Some(R::MAV_RESULT_UNSUPPORTED),
        };
        if let Some(result) = result {
            self.ack(from, c.command, result);
        }
    }

    /// COMPONENT_ARM_DISARM: param1 1 arm / 0 disarm; 21196 in param2 forces.
    fn cmd_arm_disarm(&mut self, c: &mav::COMMAND_INT_DATA, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        let ap = self.cfg.flavour.is_ardupilot();
        let copter = self.cfg.flavour.is_copter();
        let forced = (c.param2 - ARM_DISARM_FORCE).abs() < 0.5;
        if c.param1 > 0.5 {
            match self.arm(now, forced) {
                Ok(()) => R::MAV_RESULT_ACCEPTED,
                Err(r) => r,
            }
        } else if !self.arming.armed {
            R::MAV_RESULT_ACCEPTED
        } else if !self.arming.landed && !forced && copter {
            if ap {
                R::MAV_RESULT_FAILED
            } else {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Disarming denied: not landed",
                );
                R::MAV_RESULT_TEMPORARILY_REJECTED
            }
        } else {
            self.disarm(now, "external command");
            R::MAV_RESULT_ACCEPTED
        }
    }

    /// DO_SET_MODE: ArduPilot custom_mode = param2; PX4 main mode = param2, sub mode = param3.
    fn cmd_do_set_mode(&mut self, c: &mav::COMMAND_INT_DATA, now: Time) -> mav::MavResult {
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
    fn cmd_land(&mut self, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        if !self.cfg.flavour.is_copter() {
            R::MAV_RESULT_UNSUPPORTED
        } else if self.cfg.flavour.is_ardupilot() {
            if self.check_mode_allowed(Mode::Land, now).is_ok() {
                self.enter_mode(Mode::Land, now);
                R::MAV_RESULT_ACCEPTED
            } else {
                R::MAV_RESULT_FAILED
            }
        } else {
            self.enter_mode(Mode::Land, now);
            self.text(
                mav::MavSeverity::MAV_SEVERITY_INFO,
                "Landing at current position",
            );
            R::MAV_RESULT_ACCEPTED
        }
    }

    /// NAV_RETURN_TO_LAUNCH.
    fn cmd_rtl(&mut self, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        let ap = self.cfg.flavour.is_ardupilot();
        match self.check_mode_allowed(Mode::Rtl, now) {
            Ok(()) => {
                self.enter_mode(Mode::Rtl, now);
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
    fn cmd_loiter_unlim(&mut self, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        let m = if self.cfg.flavour.is_copter() {
            Mode::Hold
        } else {
            Mode::Loiter
        };
        match self.check_mode_allowed(m, now) {
            Ok(()) => {
                self.enter_mode(m, now);
                R::MAV_RESULT_ACCEPTED
            }
            Err(_) => R::MAV_RESULT_FAILED,
        }
    }

    /// DO_CHANGE_SPEED: param2 the ground speed, m/s (ArduPilot denies a speed ≤ 0, PX4
    /// accepts and ignores it).
    fn cmd_change_speed(&mut self, c: &mav::COMMAND_INT_DATA) -> mav::MavResult {
        use mav::MavResult as R;
        if c.param2 <= 0.0 {
            if self.cfg.flavour.is_ardupilot() {
                R::MAV_RESULT_DENIED
            } else {
                R::MAV_RESULT_ACCEPTED
            }
        } else {
            self.flight.speed_override = Some(f64::from(c.param2));
            R::MAV_RESULT_ACCEPTED
        }
    }

    /// DO_SET_MISSION_CURRENT: param1 the item, param2 > 0.5 also resets the DO_JUMP counters.
    fn cmd_set_mission_current(&mut self, c: &mav::COMMAND_INT_DATA, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        let ap = self.cfg.flavour.is_ardupilot();
        let seq = c.param1 as i64;
        let n = self.missions.server.items(MissionType::Mission).len() as i64;
        if seq >= 0 && seq < n {
            self.set_current_item(seq.max(if ap { 1 } else { 0 }) as u16, now);
            if c.param2 > 0.5 {
                self.missions.exec.jumps.clear();
            }
            R::MAV_RESULT_ACCEPTED
        } else if ap {
            R::MAV_RESULT_FAILED
        } else {
            R::MAV_RESULT_DENIED
        }
    }

    /// DO_FENCE_ENABLE (ArduPilot): 0 disable, 1 enable, 2 disable the floor only.
    fn cmd_fence_enable(&mut self, c: &mav::COMMAND_INT_DATA) -> mav::MavResult {
        use mav::MavResult as R;
        match c.param1 as i32 {
            0 => {
                self.geofence.enabled = false;
                R::MAV_RESULT_ACCEPTED
            }
            1 => {
                self.geofence.enabled = true;
                R::MAV_RESULT_ACCEPTED
            }
            2 => R::MAV_RESULT_ACCEPTED,
            _ => R::MAV_RESULT_FAILED,
        }
    }

    /// GET_HOME_POSITION: HOME_POSITION, or FAILED before home is set.
    fn cmd_get_home_position(&mut self, now: Time) -> mav::MavResult {
        if self.flight.home.is_some() {
            self.queue(AUTOPILOT_COMPID, self.home_position_msg(now));
            mav::MavResult::MAV_RESULT_ACCEPTED
        } else {
            mav::MavResult::MAV_RESULT_FAILED
        }
    }

    /// DO_SET_HOME: param1 = 1 the current position, else the given latitude/longitude
    /// (degrees × 1e7) and altitude (relative frames add the current home's altitude).
    fn cmd_set_home(&mut self, c: &mav::COMMAND_INT_DATA, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        if c.param1 > 0.5 {
            return if self.position_ok(now) {
                self.set_home_here(now);
                R::MAV_RESULT_ACCEPTED
            } else {
                R::MAV_RESULT_FAILED
            };
        }
        let lat = f64::from(c.x) * 1e-7;
        let lon = f64::from(c.y) * 1e-7;
        if !(-90.0..=90.0).contains(&lat)
            || !(-180.0..=180.0).contains(&lon)
            || (c.x == 0 && c.y == 0)
        {
            return R::MAV_RESULT_DENIED;
        }
        let (n, e) = local::delta(self.cfg.reference.0, self.cfg.reference.1, lat, lon);
        let alt = if is_relative_alt(c.frame) {
            self.flight
                .home
                .map(|h| h.alt_amsl)
                .unwrap_or(self.ground_amsl())
                + f64::from(c.z)
        } else {
            f64::from(c.z)
        };
        self.flight.home = Some(Home {
            lat,
            lon,
            alt_amsl: alt,
            e,
            n,
        });
        self.missions.server.set_home(Some(HomeItem {
            lat_e7: c.x,
            lon_e7: c.y,
            alt_amsl_m: alt as f32,
        }));
        self.queue(AUTOPILOT_COMPID, self.home_position_msg(now));
        R::MAV_RESULT_ACCEPTED
    }

    /// Camera commands sent to the autopilot (DO_DIGICAM_CONTROL, DO_SET_CAM_TRIGG_DIST,
    /// IMAGE_START/STOP_CAPTURE): run as the mission's do-command would; PX4 forwards image
    /// capture to the camera component, which answers (`None`).
    fn cmd_camera(
        &mut self,
        from: (u8, u8),
        c: &mav::COMMAND_INT_DATA,
        long: bool,
        now: Time,
    ) -> Option<mav::MavResult> {
        use mav::MavCmd as C;
        if self.camera.is_none() {
            return Some(mav::MavResult::MAV_RESULT_UNSUPPORTED);
        }
        if !self.cfg.flavour.is_ardupilot()
            && matches!(
                c.command,
                C::MAV_CMD_IMAGE_START_CAPTURE | C::MAV_CMD_IMAGE_STOP_CAPTURE
            )
        {
            self.camera_command(from, c, now);
            return None;
        }
        let mut item = MissionItem::command(c.command as u16);
        item.param1 = c.param1;
        item.param2 = c.param2;
        item.param3 = c.param3;
        item.param4 = c.param4;
        item.x = c.x;
        item.y = c.y;
        item.z = c.z;
        if c.command == C::MAV_CMD_DO_DIGICAM_CONTROL && long {
            item.x = c.x; // param5 shooting command, cast by the conversion
        }
        self.do_command(&item, now);
        Some(mav::MavResult::MAV_RESULT_ACCEPTED)
    }

    /// PREFLIGHT_REBOOT_SHUTDOWN: param1 = 1 reboots the autopilot (disarmed only); the ACK
    /// leaves before the power goes.
    fn cmd_reboot(
        &mut self,
        from: (u8, u8),
        c: &mav::COMMAND_INT_DATA,
        now: Time,
    ) -> Option<mav::MavResult> {
        if c.param1 as i32 == 1 && !self.arming.armed {
            self.ack(from, c.command, mav::MavResult::MAV_RESULT_ACCEPTED);
            self.power_cycle(now, false);
            None
        } else if self.cfg.flavour.is_ardupilot() {
            Some(mav::MavResult::MAV_RESULT_FAILED)
        } else {
            Some(mav::MavResult::MAV_RESULT_DENIED)
        }
    }

    /// [`CMD_BATTERY_SWAP`]: landed and disarmed, power-cycle with a full battery (the ACK
    /// leaves first).
    fn cmd_battery_swap(
        &mut self,
        from: (u8, u8),
        c: &mav::COMMAND_INT_DATA,
        now: Time,
    ) -> Option<mav::MavResult> {
        if self.arming.landed && !self.arming.armed {
            self.ack(from, c.command, mav::MavResult::MAV_RESULT_ACCEPTED);
            self.power_cycle(now, true);
            return None;
        }
        Some(mav::MavResult::MAV_RESULT_DENIED)
    }

    /// DO_PAUSE_CONTINUE (ArduCopter): param1 0 pauses (hold here), 1 resumes the mission.
    fn cmd_pause_continue(&mut self, c: &mav::COMMAND_INT_DATA) -> mav::MavResult {
        if self.modes.mode == Mode::Auto && !self.arming.landed {
            if c.param1 < 0.5 {
                self.missions.exec.running = false;
                self.flight.nav = Nav::Hold(self.here());
            } else {
                self.missions.exec.running = true;
                self.missions.exec.nav_started = false;
            }
            mav::MavResult::MAV_RESULT_ACCEPTED
        } else {
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Failed to pause");
            mav::MavResult::MAV_RESULT_FAILED
        }
    }

    pub(super) fn cmd_takeoff(&mut self, c: &mav::COMMAND_INT_DATA, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        let ap = self.cfg.flavour.is_ardupilot();
        if !self.cfg.flavour.is_copter() {
            return if ap {
                R::MAV_RESULT_UNSUPPORTED
            } else {
                R::MAV_RESULT_TEMPORARILY_REJECTED
            };
        }
        if ap {
            // GCS_MAVLINK_Copter::handle_MAV_CMD_NAV_TAKEOFF / Mode::do_user_takeoff
            if c.frame != mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT {
                return R::MAV_RESULT_DENIED;
            }
            let alt = f64::from(c.z);
            let user_takeoff = matches!(self.modes.mode, Mode::Guided | Mode::Hold | Mode::AltHold);
            if !self.arming.armed || !self.arming.landed || !user_takeoff || alt <= self.flight.m.u
            {
                return R::MAV_RESULT_FAILED;
            }
            let here = self.here();
            self.flight.nav = Nav::Takeoff(Point { u: alt, ..here });
            R::MAV_RESULT_ACCEPTED
        } else {
            if self.check_mode_allowed(Mode::Takeoff, now).is_err() || !self.arming.landed {
                let msg = format!(
                    "Switching to {} is currently not possible",
                    self.cfg.flavour.mode_name(Mode::Takeoff)
                );
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            // param7 is an AMSL altitude; NaN → MIS_TAKEOFF_ALT
            let alt = if c.z.is_finite() {
                match c.frame {
                    mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
                    | mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT => f64::from(c.z),
                    _ => {
                        f64::from(c.z)
                            - self
                                .flight
                                .home
                                .map(|h| h.alt_amsl)
                                .unwrap_or(self.ground_amsl())
                    }
                }
            } else {
                2.5
            };
            self.enter_mode(Mode::Takeoff, now);
            let here = self.here();
            self.flight.nav = Nav::Takeoff(Point {
                u: alt.max(1.0),
                ..here
            });
            R::MAV_RESULT_ACCEPTED
        }
    }

    pub(super) fn cmd_mission_start(
        &mut self,
        c: &mav::COMMAND_INT_DATA,
        now: Time,
    ) -> mav::MavResult {
        use mav::MavResult as R;
        if self.cfg.flavour.is_ardupilot() {
            if c.param1 != 0.0 || c.param2 != 0.0 {
                return R::MAV_RESULT_DENIED;
            }
            if self.set_mode_request(
                1,
                self.cfg.flavour.custom_mode(Mode::Auto).unwrap_or(3),
                now,
            ) != R::MAV_RESULT_ACCEPTED
            {
                return R::MAV_RESULT_FAILED;
            }
            if !self.missions.exec.running || self.missions.exec.waiting_auto_armed {
                self.start_or_resume_mission(now);
            }
            R::MAV_RESULT_ACCEPTED
        } else {
            if self.missions.server.items(MissionType::Mission).is_empty() || !self.missions.valid {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Mission start denied! No valid mission",
                );
                return R::MAV_RESULT_DENIED;
            }
            if self.check_mode_allowed(Mode::Auto, now).is_err() {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Switching to Mission is currently not possible",
                );
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            if !self.arming.armed && self.arm(now, false).is_err() {
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            if self.modes.mode != Mode::Auto {
                self.enter_mode(Mode::Auto, now);
            } else {
                self.start_or_resume_mission(now);
            }
            R::MAV_RESULT_ACCEPTED
        }
    }

    pub(super) fn target_from_command(
        &self,
        c: &mav::COMMAND_INT_DATA,
        long: bool,
        nan_pos: bool,
    ) -> Point {
        let here = self.here();
        let px4 = !self.cfg.flavour.is_ardupilot();
        let (e, n) = if nan_pos || (c.x == 0 && c.y == 0) {
            (here.e, here.n)
        } else {
            let (dn, de) = local::delta(
                self.cfg.reference.0,
                self.cfg.reference.1,
                f64::from(c.x) * 1e-7,
                f64::from(c.y) * 1e-7,
            );
            (de, dn)
        };
        let u = if !c.z.is_finite() {
            here.u
        } else {
            match c.frame {
                mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
                | mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
                | mav::MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT
                | mav::MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT => f64::from(c.z),
                _ => {
                    // AMSL (COMMAND_LONG to ArduPilot is converted with frame GLOBAL; PX4's
                    // reposition altitude is AMSL)
                    let _ = (long, px4);
                    f64::from(c.z) - self.ground_amsl()
                }
            }
        };
        let u = if self.cfg.flavour.is_copter() {
            u.max(0.0)
        } else {
            0.0
        };
        Point { e, n, u }
    }

    pub(super) fn cmd_reposition(
        &mut self,
        c: &mav::COMMAND_INT_DATA,
        long: bool,
        nan_pos: bool,
        now: Time,
    ) -> mav::MavResult {
        use mav::MavResult as R;
        let change_mode = (c.param2 as i32) & 1 == 1;
        // PX4's navigator flies a reposition at param1 (ground speed) when positive;
        // ArduCopter ignores it (GUIDED keeps WPNAV_SPEED or the last DO_CHANGE_SPEED)
        let speed = if c.param1 > 0.0 && !self.cfg.flavour.is_ardupilot() {
            Some(f64::from(c.param1))
        } else {
            None
        };
        if self.cfg.flavour.is_ardupilot() {
            // GCS_MAVLINK_Copter::handle_command_int_do_reposition
            if self.modes.mode != Mode::Guided && !change_mode {
                return R::MAV_RESULT_DENIED;
            }
            if !nan_pos && (c.x.abs() > 900_000_000 || c.y.abs() > 1_800_000_000) {
                return R::MAV_RESULT_DENIED;
            }
            if !self.position_ok(now) {
                return R::MAV_RESULT_FAILED;
            }
            let p = self.target_from_command(c, long, nan_pos);
            if self.modes.mode != Mode::Guided
                && self.set_mode_request(
                    1,
                    self.cfg.flavour.custom_mode(Mode::Guided).unwrap_or(4),
                    now,
                ) != R::MAV_RESULT_ACCEPTED
            {
                return R::MAV_RESULT_FAILED;
            }
            self.flight.guided_target_at = Some(now);
            // A new destination returns the yaw to WP_YAW_BEHAVIOR (ModeGuided::set_destination
            // without a yaw): a CONDITION_YAW must come after it.
            self.flight.yaw_target_deg = None;
            if !(self.arming.landed && self.cfg.flavour.is_copter()) {
                self.flight.nav = Nav::Goto { p, speed };
            }
            R::MAV_RESULT_ACCEPTED
        } else {
            // Commander: only the change-mode bit is supported; the navigator flies there in Hold
            if !change_mode || (c.param2 as i32) & !1 != 0 {
                return R::MAV_RESULT_UNSUPPORTED;
            }
            if self.check_mode_allowed(Mode::Hold, now).is_err() {
                let msg = format!(
                    "Switching to {} is currently not possible",
                    self.cfg.flavour.mode_name(Mode::Hold)
                );
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            let p = self.target_from_command(c, long, nan_pos);
            self.enter_mode(Mode::Hold, now);
            // navigator_main.cpp: a finite param4 is the yaw setpoint, in radians.
            self.flight.yaw_target_deg = c
                .param4
                .is_finite()
                .then(|| f64::from(c.param4).to_degrees().rem_euclid(360.0));
            if !(self.arming.landed && self.cfg.flavour.is_copter()) {
                self.flight.nav = Nav::Goto { p, speed };
            }
            R::MAV_RESULT_ACCEPTED
        }
    }

    /// ArduCopter's MAV_CMD_CONDITION_YAW outside a mission (GCS_MAVLINK_Copter): param1
    /// the angle (0..360), param2 the rate (0 = default), param3 the direction, param4 1 =
    /// relative to the current heading, 0 = absolute; anything else FAILED. It sets a fixed
    /// yaw for the guided flight; in other modes the yaw is accepted and soon forgotten.
    pub(super) fn cmd_condition_yaw(&mut self, c: &mav::COMMAND_INT_DATA) -> mav::MavResult {
        use mav::MavResult as R;
        let relative = c.param4 == 1.0;
        if !(0.0..=360.0).contains(&c.param1) || !(c.param4 == 0.0 || relative) {
            return R::MAV_RESULT_FAILED;
        }
        let angle = f64::from(c.param1);
        let target = if relative {
            let dir = if c.param3 < 0.0 { -1.0 } else { 1.0 };
            self.flight.m.heading_deg + dir * angle
        } else {
            angle
        };
        if self.modes.mode == Mode::Guided {
            self.flight.yaw_target_deg = Some(target.rem_euclid(360.0));
        }
        R::MAV_RESULT_ACCEPTED
    }

    pub(super) fn position_target(
        &mut self,
        p: &mav::SET_POSITION_TARGET_GLOBAL_INT_DATA,
        now: Time,
    ) {
        let mask = p.type_mask.bits();
        let pos_ignore = mask & 0b111 == 0b111;
        let ap = self.cfg.flavour.is_ardupilot();
        if ap && self.modes.mode != Mode::Guided {
            return; // ignored outside GUIDED
        }
        if pos_ignore {
            return; // velocity/acceleration targets are not simulated
        }
        let frame = p.coordinate_frame as u8;
        let c = mav::COMMAND_INT_DATA {
            x: p.lat_int,
            y: p.lon_int,
            z: p.alt,
            frame: mav::MavFrame::from_u8(frame).unwrap_or(mav::MavFrame::MAV_FRAME_GLOBAL),
            ..mav::COMMAND_INT_DATA::default()
        };
        if !matches!(frame, 0 | 3 | 5 | 6 | 10 | 11) {
            return;
        }
        let target = self.target_from_command(&c, false, false);
        self.flight.guided_target_at = Some(now);
        self.flight.yaw_target_deg = None;
        // ArduCopter does not take off for a position target; PX4 offboard does
        if self.modes.mode == Mode::Guided
            && !(ap && self.arming.landed && self.cfg.flavour.is_copter())
        {
            self.flight.nav = Nav::Goto {
                p: target,
                speed: None,
            };
        }
    }

    pub(super) fn camera_command(&mut self, from: (u8, u8), c: &mav::COMMAND_INT_DATA, now: Time) {
        use mav::MavResult as R;
        let tb = self.time_boot_ms(now);
        let Some(cam) = self.camera.as_mut() else {
            return; // no camera component: nobody answers
        };
        use mav::MavCmd as C;
        let mut extra = None;
        let result = match c.command {
            C::MAV_CMD_IMAGE_START_CAPTURE => {
                // param2 interval s, param3 total images (0 = until stopped)
                let count = c.param3.max(0.0) as u32;
                cam.start_capture(f64::from(c.param2), count, now);
                R::MAV_RESULT_ACCEPTED
            }
            C::MAV_CMD_IMAGE_STOP_CAPTURE => {
                cam.stop_capture();
                R::MAV_RESULT_ACCEPTED
            }
            C::MAV_CMD_REQUEST_MESSAGE => match c.param1 as u32 {
                telemetry::id::CAMERA_INFORMATION => {
                    extra = Some(cam.information(tb));
                    R::MAV_RESULT_ACCEPTED
                }
                telemetry::id::CAMERA_CAPTURE_STATUS => {
                    extra = Some(cam.capture_status(tb));
                    R::MAV_RESULT_ACCEPTED
                }
                _ => R::MAV_RESULT_UNSUPPORTED,
            },
            C::MAV_CMD_REQUEST_CAMERA_INFORMATION => {
                extra = Some(cam.information(tb));
                R::MAV_RESULT_ACCEPTED
            }
            C::MAV_CMD_REQUEST_CAMERA_CAPTURE_STATUS => {
                extra = Some(cam.capture_status(tb));
                R::MAV_RESULT_ACCEPTED
            }
            C::MAV_CMD_DO_DIGICAM_CONTROL => {
                if c.x == 1 {
                    cam.trigger();
                }
                R::MAV_RESULT_ACCEPTED
            }
            _ => R::MAV_RESULT_UNSUPPORTED,
        };
        self.queue(
            CAMERA_COMPID,
            MavMessage::COMMAND_ACK(mav::COMMAND_ACK_DATA {
                command: c.command,
                result,
                progress: 0,
                result_param2: 0,
                target_system: from.0,
                target_component: from.1,
            }),
        );
        if let Some(m) = extra {
            self.queue(CAMERA_COMPID, m);
        }
    }
}
