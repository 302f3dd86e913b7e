//! COMMAND_LONG / COMMAND_INT handling: conversion to COMMAND_INT, dispatch on the
//! dialect's `MavCmd` and the COMMAND_ACK. The handlers live with the part whose fields they
//! change: `arming` (arm/disarm), `modes` (set mode, land, RTL, loiter), `flight` (take-off,
//! reposition, yaw, speed, home, position targets), `mission` (start, set current,
//! pause/continue), `geofence` (fence enable), `power` (reboot) and `camera`. A command no handler knows
//! (MAV_CMD_USER_1 among them) gets MAV_RESULT_UNSUPPORTED, as ArduPilot answers it.

use super::*;

impl SimVehicle {
    // ------------------------------------------------------------------ commands

    pub(super) fn ack(&mut self, to: Endpoint, command: mav::MavCmd, result: mav::MavResult) {
        self.queue(
            AUTOPILOT_COMPID,
            MavMessage::COMMAND_ACK(mav::COMMAND_ACK_DATA {
                command,
                result,
                progress: 0,
                result_param2: 0,
                target_system: to.sysid,
                target_component: to.compid,
            }),
        );
    }

    pub(super) fn command_long(&mut self, from: Endpoint, c: &mav::COMMAND_LONG_DATA, now: Time) {
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

    pub(super) fn command_int(&mut self, from: Endpoint, c: &mav::COMMAND_INT_DATA, now: Time) {
        self.command(from, c, false, false, now);
    }

    /// Dispatch one command to the autopilot (or the camera component) and acknowledge it.
    /// `long`: it came as COMMAND_LONG (converted); `nan_pos`: PX4's NaN latitude/longitude
    /// ("the current position").
    pub(super) fn command(
        &mut self,
        from: Endpoint,
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
            C::MAV_CMD_REQUEST_MESSAGE => {
                Some(self.cmd_request_message(c.param1 as u32, c.param2, now))
            }
            C::MAV_CMD_GET_MESSAGE_INTERVAL => Some(self.cmd_get_message_interval(c.param1 as u32)),
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
            C::MAV_CMD_DO_PAUSE_CONTINUE if ap && copter => Some(self.cmd_pause_continue(c)),
            _ => Some(R::MAV_RESULT_UNSUPPORTED),
        };
        if let Some(result) = result {
            self.ack(from, c.command, result);
        }
    }
}
