//! Power and boot: the power switch, the boot sequence, the battery and the 20 Hz clock.

use super::*;

/// Power, boot count and the battery.
#[derive(Debug)]
pub(super) struct Power {
    /// Whether the vehicle is on (false while its battery is being swapped).
    pub(super) powered: bool,
    /// When it powers on again (set while it is off).
    pub(super) power_on_at: Option<Time>,
    /// When it last booted: the origin of `time_boot_ms`.
    pub(super) boot_time: Time,
    /// Boots so far (1 after the first power-up).
    pub(super) boots: u32,
    /// The last 20 Hz tick simulated.
    pub(super) last_tick: Time,
    /// The battery pack.
    pub(super) battery: Battery,
    /// Standing on a charging station during this tick (no drain).
    pub(super) charging: bool,
}

impl SimVehicle {
    // ------------------------------------------------------------------ time and power

    pub(super) fn advance(&mut self, now: Time) {
        let dt = Duration::from_secs_f64(DT);
        while self.power.last_tick + dt <= now {
            let t = self.power.last_tick + dt;
            self.power.last_tick = t;
            self.tick(t);
        }
    }

    pub(super) fn time_boot_ms(&self, now: Time) -> u32 {
        now.saturating_since(self.power.boot_time).as_millis() as u32
    }

    pub(super) fn boot_s(&self, now: Time) -> f64 {
        now.saturating_since(self.power.boot_time).as_secs_f64()
    }

    /// ArduPilot's first [`ARDUPILOT_BOOT_S`] after power-up: its heartbeat says
    /// MAV_STATE_BOOT and its mission lists are not loaded yet (see
    /// [`crate::mission_server::MissionServer::set_loaded`]).
    pub(super) fn ardupilot_booting(&self, now: Time) -> bool {
        self.cfg.flavour.is_ardupilot() && self.boot_s(now) < ARDUPILOT_BOOT_S
    }

    pub(super) fn boot(&mut self, now: Time) {
        self.power.powered = true;
        self.power.power_on_at = None;
        self.power.boots += 1;
        self.power.boot_time = now;
        self.telemetry.seq = [0; 2];
        self.arming.armed = false;
        self.arming.took_off = false;
        self.modes.mode = self.cfg.flavour.boot_mode();
        self.flight.home = None;
        self.estimator.position_ok_announced = false;
        self.flight.nav = Nav::Idle;
        self.flight.speed_override = None;
        self.flight.yaw_target_deg = None;
        self.missions.exec = Exec::default();
        self.modes.failsafe_level = 0;
        self.modes.last_gcs_heartbeat = None;
        self.modes.datalink_lost = false;
        self.arming.last_prearm_report = None;
        self.telemetry.outbox.clear();
        self.missions.server.reboot();
        self.missions.server.set_home(None);
        if let Some(c) = self.camera.as_mut()
            && self.power.boots > 1
        {
            c.reboot();
        }
        self.telemetry.terrain_request_at = None;
        // ArduPilot keeps its terrain on the SD card: a reboot keeps it
        self.telemetry.link_counts = Default::default();
        self.reset_schedule(now);
        // ArduPilot: FENCE_ENABLE 0 until the GCS enables it; PX4: any uploaded fence applies
        self.geofence.enabled = !self.cfg.flavour.is_ardupilot();
        self.geofence.breached = false;
        self.rebuild_fence(false);
        self.arming.disarmed_landed_since = Some(now);
        match self.cfg.flavour.autopilot {
            SimAutopilot::ArduPilot => {
                let name = if self.cfg.flavour.is_copter() {
                    "ArduCopter V4.5.7 (fleetmap sim)"
                } else {
                    "ArduRover V4.5.7 (fleetmap sim)"
                };
                self.text(mav::MavSeverity::MAV_SEVERITY_INFO, name);
                if self.cfg.flavour.is_copter() {
                    self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Frame: QUAD/X");
                }
            }
            SimAutopilot::Px4 => {}
        }
        self.telemetry.events.push_back(VehicleEvent::Booted {
            boot: self.power.boots,
        });
    }

    pub(super) fn power_cycle(&mut self, now: Time, new_battery: bool) {
        self.power.powered = false;
        self.power.power_on_at = Some(now + Duration::from_secs_f64(self.cfg.power_off_s.max(0.0)));
        // what was already queued (e.g. the ACK of the command that cut the power) still
        // leaves; nothing else does
        while self.missions.server.poll_transmit().is_some() {}
        if let Some(c) = self.camera.as_mut() {
            while c.poll_transmit().is_some() {}
        }
        if new_battery {
            self.power.battery = Battery::full(self.cfg.battery);
            self.telemetry
                .events
                .push_back(VehicleEvent::BatterySwapped);
        }
    }
}

impl SimVehicle {
    // ------------------------------------------------------------------ commands
    // (dispatched by `commands::command`)

    /// PREFLIGHT_REBOOT_SHUTDOWN: param1 = 1 reboots the autopilot (disarmed only); the ACK
    /// leaves before the power goes.
    pub(super) fn cmd_reboot(
        &mut self,
        from: Endpoint,
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
}
