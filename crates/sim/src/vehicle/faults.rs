//! Injected faults ([`crate::fault`]): a failed camera component, a vehicle stuck where it is,
//! a battery that drops, a camera slowed down. The harness switches them as its schedule
//! says; the vehicle then behaves as the real one would with that fault.

use super::*;

/// The faults in force on this vehicle.
#[derive(Debug, Default)]
pub(super) struct Faults {
    /// The camera component has failed: it sends nothing, captures nothing, answers nothing.
    pub(super) camera_failed: bool,
    /// The vehicle makes no horizontal progress (wheels in mud).
    pub(super) stuck: bool,
}

impl SimVehicle {
    /// The camera component when there is one and it works.
    pub(super) fn live_camera(&mut self) -> Option<&mut SimCamera> {
        if self.faults.camera_failed {
            return None;
        }
        self.camera.as_mut()
    }

    /// Whether the camera component has failed ([`crate::fault::Fault::CameraOff`]).
    pub fn camera_failed(&self) -> bool {
        self.faults.camera_failed
    }

    /// Whether the vehicle is stuck ([`crate::fault::Fault::Stuck`]).
    pub fn stuck(&self) -> bool {
        self.faults.stuck
    }

    /// The battery's charge drops to `percent` of its capacity (never up): the autopilot's
    /// battery failsafe acts at its next check, as it would at that level.
    pub(crate) fn drop_battery_to(&mut self, percent: f64) {
        self.power.battery.drop_to(percent / 100.0);
    }

    /// The camera component fails (`true`): what it had queued is lost, and it stays silent;
    /// or it comes back (`false`) as a camera that rebooted — a new boot, its message
    /// sequence from 0, its heartbeat with the autopilot's next one.
    pub(crate) fn set_camera_failed(&mut self, failed: bool) {
        if failed == self.faults.camera_failed {
            return;
        }
        self.faults.camera_failed = failed;
        if failed {
            if let Some(c) = self.camera.as_mut() {
                c.reboot();
                while c.poll_image().is_some() {}
            }
            self.telemetry
                .outbox
                .retain(|(comp, _)| *comp != CAMERA_COMPID);
        } else {
            // a rebooted component's sequence numbers start again
            self.telemetry.seq[1] = 0;
        }
    }

    /// Pace the camera's image transmission to `rate` bytes per second (`None`: as
    /// configured).
    pub(crate) fn set_camera_transfer_rate(&mut self, rate: Option<f64>) {
        let configured = self.cfg.camera.as_ref().and_then(|c| c.transfer_rate_bps);
        if let Some(c) = self.camera.as_mut() {
            c.set_transfer_rate(rate.or(configured));
        }
    }

    /// The camera's minimum interval between captures, seconds (`None`: as configured).
    pub(crate) fn set_camera_min_interval(&mut self, seconds: Option<f64>) {
        let configured = self.cfg.camera.as_ref().map(|c| c.min_interval_s);
        if let (Some(c), Some(s)) = (self.camera.as_mut(), seconds.or(configured)) {
            c.set_min_interval(s);
        }
    }

    /// The vehicle gets stuck (`true`: no horizontal progress from now) or free again.
    pub(crate) fn set_stuck(&mut self, stuck: bool) {
        self.faults.stuck = stuck;
    }
}
