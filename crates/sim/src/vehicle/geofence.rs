//! The geofence: built from the uploaded fence items, enabled per autopilot, checked against
//! the estimated position every tick.

use super::*;

/// The geofence and whether it is enabled and breached.
#[derive(Debug)]
pub(super) struct Geofence {
    /// The fence built from the stored fence items.
    pub(super) fence: Fence,
    /// ArduPilot FENCE_ENABLE (0 at boot); PX4: on whenever a fence is uploaded.
    pub(super) enabled: bool,
    /// Whether the vehicle is in breach (a breach event fires on entering it).
    pub(super) breached: bool,
}

impl SimVehicle {
    // ------------------------------------------------------------------ mission execution

    /// Rebuild the geofence from the stored fence list; PX4 also re-checks the mission
    /// against it (MissionFeasibilityChecker::checkGeofence) and says which item violates it.
    pub(super) fn rebuild_fence(&mut self, report: bool) {
        self.geofence.fence = Fence::from_items(
            self.missions.server.items(MissionType::Fence),
            self.cfg.reference,
        );
        self.missions.valid = true;
        if self.cfg.flavour.autopilot == SimAutopilot::Px4 && !self.geofence.fence.is_empty() {
            let bad = self
                .missions
                .server
                .items(MissionType::Mission)
                .iter()
                .position(|it| {
                    matches!(
                        it.frame,
                        mi::FRAME_GLOBAL
                            | mi::FRAME_GLOBAL_RELATIVE_ALT
                            | mi::FRAME_GLOBAL_INT
                            | mi::FRAME_GLOBAL_RELATIVE_ALT_INT
                    ) && it.has_position()
                        && (it.x != 0 || it.y != 0)
                        && {
                            let (n, e) = local::delta(
                                self.cfg.reference.0,
                                self.cfg.reference.1,
                                it.lat(),
                                it.lon(),
                            );
                            self.geofence.fence.breached(e, n)
                        }
                });
            if let Some(i) = bad {
                self.missions.valid = false;
                if report {
                    let msg = format!("Geofence violation for waypoint {}", i + 1);
                    self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
                }
            }
        }
    }

    pub(super) fn check_fence(&mut self, now: Time) {
        if !self.geofence.enabled
            || self.geofence.fence.is_empty()
            || !self.arming.armed
            || self.arming.landed
        {
            self.geofence.breached = false;
            return;
        }
        let (e, n) = self.est();
        let breached = self.geofence.fence.breached(e, n);
        if breached && !self.geofence.breached {
            self.telemetry
                .events
                .push_back(VehicleEvent::FenceBreached {
                    truth: (self.flight.m.e, self.flight.m.n, self.flight.m.u),
                    estimate: (e, n),
                    mode: self.modes.mode,
                });
            if self.cfg.flavour.is_ardupilot() {
                // FENCE_ACTION 1: RTL, or land when RTL is impossible
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, "Fence Breached");
                if !matches!(self.modes.mode, SimMode::Rtl | SimMode::Land) {
                    if self.flight.home.is_some() {
                        self.enter_mode(SimMode::Rtl, now);
                    } else if self.cfg.flavour.is_copter() {
                        self.enter_mode(SimMode::Land, now);
                    }
                }
            } else {
                // GF_ACTION 2: Hold
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Geofence breached, holding",
                );
                if !matches!(
                    self.modes.mode,
                    SimMode::Rtl | SimMode::Land | SimMode::Hold
                ) {
                    self.enter_mode(SimMode::Hold, now);
                }
            }
        }
        self.geofence.breached = breached;
    }
}

impl SimVehicle {
    // ------------------------------------------------------------------ commands
    // (dispatched by `commands::command`)

    /// DO_FENCE_ENABLE (ArduPilot): 0 disable, 1 enable, 2 disable the floor only.
    pub(super) fn cmd_fence_enable(&mut self, c: &mav::COMMAND_INT_DATA) -> mav::MavResult {
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
}
