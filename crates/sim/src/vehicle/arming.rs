//! Arming: pre-arm checks, arm and disarm, the ground/air state and home at arming.

use super::*;

/// Armed and landed state.
#[derive(Debug)]
pub(super) struct Arming {
    /// Whether the motors are armed.
    pub(super) armed: bool,
    /// When it last armed (auto-disarm timers).
    pub(super) armed_at: Time,
    /// Whether it left the ground since arming (PX4 COM_DISARM_PRFLT).
    pub(super) took_off: bool,
    /// Whether it is on the ground.
    pub(super) landed: bool,
    /// When it last touched down.
    pub(super) landed_at: Option<Time>,
    /// Since when it has been disarmed on the ground (a battery swap needs that).
    pub(super) disarmed_landed_since: Option<Time>,
    /// When the last "PreArm: …" text was sent (repeated every 30 s at most).
    pub(super) last_prearm_report: Option<Time>,
}

impl SimVehicle {
    // ------------------------------------------------------------------ arming

    /// PX4's COM_DL_LOSS_T (10 s) in simulated time: how long without a GCS heartbeat the
    /// connection counts as lost (arming refused, data-link-loss failsafe), scaled by
    /// [`VehicleConfig::gcs_time_scale`] (non-finite or non-positive scales count as 1).
    pub(super) fn gcs_link_loss_timeout(&self) -> Duration {
        let k = self.cfg.gcs_time_scale;
        let k = if k.is_finite() && k > 0.0 { k } else { 1.0 };
        Duration::from_secs_f64((PX4_DL_LOSS_S * k).min(1.0e9))
    }

    /// The mission flies an item in the terrain frame and the terrain under the vehicle has
    /// not all arrived.
    fn needs_terrain(&self) -> bool {
        !self.telemetry.terrain.complete()
            && self
                .missions
                .server
                .user_items()
                .iter()
                .any(|it| fleetmap_core::mission::item::frame::is_terrain(it.frame))
    }

    pub(super) fn prearm_failure(&self, now: Time) -> Option<&'static str> {
        let f = self.cfg.flavour;
        let compass = self
            .cfg
            .compass_fault_until_s
            .is_some_and(|t| now.as_secs_f64() < t);
        match f.autopilot {
            SimAutopilot::ArduPilot => {
                if compass {
                    Some("PreArm: Compass not calibrated")
                } else if !self.gps_fix(now) {
                    Some("PreArm: GPS 1: Bad fix")
                } else if !self.position_ok(now) {
                    if f.is_copter() {
                        Some("PreArm: Need Position Estimate")
                    } else {
                        Some("PreArm: AHRS: waiting for home")
                    }
                } else if self.power.battery.fraction() * 100.0 <= self.cfg.failsafe.rtl_pct {
                    Some("PreArm: Battery 1 below minimum arming capacity")
                } else if f.is_copter() && self.needs_terrain() {
                    // ArduCopter with TERRAIN_ENABLE and terrain-frame items (seen on 4.7 SITL)
                    Some("PreArm: waiting for terrain data")
                } else {
                    None
                }
            }
            SimAutopilot::Px4 => {
                if self.cfg.px4_datalink_required
                    && self
                        .modes
                        .last_gcs_heartbeat
                        .is_none_or(|t| now.saturating_since(t) > self.gcs_link_loss_timeout())
                {
                    Some("Preflight Fail: No connection to the GCS")
                } else if compass {
                    Some("Preflight Fail: Compass Sensor 0 missing")
                } else if !self.gps_fix(now) || !self.position_ok(now) {
                    Some("Preflight Fail: No valid global position estimate")
                } else if self.power.battery.fraction() * 100.0 <= self.cfg.failsafe.rtl_pct {
                    Some("Preflight Fail: low battery")
                } else {
                    None
                }
            }
        }
    }

    /// Try to arm; Err(result) with the MAV_RESULT the autopilot gives.
    pub(super) fn arm(&mut self, now: Time, forced: bool) -> Result<(), mav::MavResult> {
        let ap = self.cfg.flavour.is_ardupilot();
        if self.arming.armed {
            return Ok(());
        }
        if !forced && let Some(msg) = self.prearm_failure(now) {
            self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, msg);
            if !ap {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Arming denied: Resolve system health failures first",
                );
            }
            return Err(if ap {
                mav::MavResult::MAV_RESULT_FAILED
            } else {
                mav::MavResult::MAV_RESULT_TEMPORARILY_REJECTED
            });
        }
        if self.cfg.flavour.is_copter() && ap && !self.mode_can_arm(self.modes.mode) {
            self.text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "Arm: Mode not armable",
            );
            return Err(mav::MavResult::MAV_RESULT_FAILED);
        }
        self.arming.armed = true;
        self.arming.armed_at = now;
        self.arming.took_off = false;
        // a battery failsafe stays latched until the next boot (as ArduPilot's and PX4's do)
        self.arming.disarmed_landed_since = None;
        // home moves to where the vehicle arms (ArduPilot unless locked; PX4 COM_HOME_EN)
        if self.position_ok(now) {
            self.set_home_here(now);
        }
        if ap {
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Arming motors");
        } else {
            self.text(
                mav::MavSeverity::MAV_SEVERITY_INFO,
                "Armed by external command",
            );
        }
        self.telemetry.events.push_back(VehicleEvent::Armed(true));
        // modes that start moving when armed
        match self.modes.mode {
            SimMode::Auto if !ap => self.start_or_resume_mission(now),
            SimMode::Takeoff => {
                let h = self.here();
                if let Nav::Takeoff(p) = self.flight.nav {
                    self.flight.nav = Nav::Takeoff(Point {
                        e: h.e,
                        n: h.n,
                        u: p.u,
                    });
                } else {
                    self.flight.nav = Nav::Takeoff(Point { u: 2.5, ..h });
                }
            }
            SimMode::Auto if !self.cfg.flavour.is_copter() => self.start_or_resume_mission(now),
            SimMode::Auto => {
                // ArduCopter: armed in AUTO on the ground waits for MISSION_START (no throttle)
                self.missions.exec.waiting_auto_armed = true;
            }
            SimMode::Hold | SimMode::Guided | SimMode::Loiter if !self.cfg.flavour.is_copter() => {
                self.flight.nav = Nav::Hold(self.here());
            }
            _ => {}
        }
        self.send_heartbeat(now);
        Ok(())
    }

    pub(super) fn mode_can_arm(&self, mode: SimMode) -> bool {
        !matches!(mode, SimMode::Rtl | SimMode::Land | SimMode::Brake)
    }

    pub(super) fn disarm(&mut self, now: Time, reason: &str) {
        if !self.arming.armed {
            return;
        }
        self.arming.armed = false;
        self.flight.nav = Nav::Idle;
        self.missions.exec.waiting_auto_armed = false;
        self.arming.disarmed_landed_since = Some(now);
        if self.cfg.flavour.is_ardupilot() {
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Disarming motors");
        } else {
            let msg = format!("Disarmed by {reason}");
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, &msg);
        }
        if self.modes.mode == SimMode::Auto {
            self.missions.exec.running = false;
            self.missions.server.set_mission_running(false);
        }
        self.telemetry.events.push_back(VehicleEvent::Armed(false));
        self.send_heartbeat(now);
    }

    pub(super) fn set_home_here(&mut self, now: Time) {
        let (lat, lon, _) = self.reported_position();
        let (e, n) = self.est();
        let alt = self.ground_amsl() + self.flight.m.u;
        self.flight.home = Some(Home {
            lat,
            lon,
            alt_amsl: alt,
            e,
            n,
        });
        self.missions.server.set_home(Some(HomeItem {
            lat_e7: (lat * 1e7).round() as i32,
            lon_e7: (lon * 1e7).round() as i32,
            alt_amsl_m: alt as f32,
        }));
        self.queue(AUTOPILOT_COMPID, self.home_position_msg(now));
    }
}

/// COMPONENT_ARM_DISARM param2 that forces arming/disarming (ArduPilot and PX4 magic value).
const ARM_DISARM_FORCE: f32 = 21196.0;

impl SimVehicle {
    // ------------------------------------------------------------------ commands
    // (dispatched by `commands::command`)

    /// COMPONENT_ARM_DISARM: param1 1 arm / 0 disarm; 21196 in param2 forces.
    pub(super) fn cmd_arm_disarm(
        &mut self,
        c: &mav::COMMAND_INT_DATA,
        now: Time,
    ) -> mav::MavResult {
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
}

#[cfg(test)]
mod tests;
