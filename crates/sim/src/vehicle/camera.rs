//! The camera payload: its pose and capture context each tick.

use super::*;

impl SimVehicle {
    // ------------------------------------------------------------------ camera

    pub(super) fn update_camera(&mut self, now: Time) {
        if self.camera.is_none() || self.faults.camera_failed {
            return;
        }
        let (lat, lon, u) = self.true_position();
        let (rlat, rlon, ru) = self.reported_position();
        let ctx = CaptureContext {
            true_pose: CameraPose {
                lat,
                lon,
                alt_agl_m: u,
                heading_deg: self.flight.m.heading_deg,
                roll_deg: self.flight.m.roll_deg,
                pitch_deg: self.flight.m.pitch_deg,
            },
            reported: (rlat, rlon, ru),
            alt_amsl_m: self.ground_amsl() + ru,
            time_boot_ms: self.time_boot_ms(now),
            now,
            world_t_s: now.as_secs_f64(),
        };
        let pos = (self.flight.m.e, self.flight.m.n);
        if self.world.is_none() {
            // no world file: the camera sees plain grass
            self.world = Some(Arc::new(World::flat(
                fleetmap_core::world::Surface::Grass,
                self.cfg.reference,
                self.cfg.ground_alt_amsl_m,
            )));
        }
        let world = self.world.clone();
        if let Some(c) = self.camera.as_mut() {
            c.update(&ctx, pos, world.as_deref());
        }
    }
}

impl SimVehicle {
    // ------------------------------------------------------------------ commands
    // (dispatched by `commands::command`)

    /// Camera commands sent to the autopilot (DO_DIGICAM_CONTROL, DO_SET_CAM_TRIGG_DIST,
    /// IMAGE_START/STOP_CAPTURE): run as the mission's do-command would; PX4 forwards image
    /// capture to the camera component, which answers (`None`).
    pub(super) fn cmd_camera(
        &mut self,
        from: Endpoint,
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

    pub(super) fn camera_command(&mut self, from: Endpoint, c: &mav::COMMAND_INT_DATA, now: Time) {
        use mav::MavResult as R;
        let tb = self.time_boot_ms(now);
        let Some(cam) = self.live_camera() else {
            return; // no camera component, or a failed one: nobody answers
        };
        use mav::MavCmd as C;
        let mut extra = Vec::new();
        let result = match c.command {
            C::MAV_CMD_IMAGE_START_CAPTURE => {
                // param2 interval s, param3 total images (0 = until stopped), param4 the
                // single capture's sequence number
                let count = c.param3.max(0.0) as u32;
                cam.capture_command(f64::from(c.param2), count, c.param4.max(0.0) as u32, now);
                R::MAV_RESULT_ACCEPTED
            }
            C::MAV_CMD_IMAGE_STOP_CAPTURE => {
                cam.stop_capture();
                R::MAV_RESULT_ACCEPTED
            }
            C::MAV_CMD_REQUEST_MESSAGE => {
                let (result, answer) = cam.request_message([c.param1, c.param2, c.param3], tb);
                extra = answer;
                result
            }
            C::MAV_CMD_REQUEST_CAMERA_INFORMATION => {
                extra = vec![cam.information(tb)];
                R::MAV_RESULT_ACCEPTED
            }
            C::MAV_CMD_REQUEST_CAMERA_CAPTURE_STATUS => {
                extra = vec![cam.capture_status(tb)];
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
                target_system: from.sysid,
                target_component: from.compid,
            }),
        );
        for m in extra {
            self.queue(CAMERA_COMPID, m);
        }
    }
}
