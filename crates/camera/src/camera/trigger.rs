//! When the camera fires: single shots, interval and distance triggering, and the captures
//! dropped when there is no pose.

use super::{CaptureContext, SimCamera};
use fleetmap_core::time::Time;
use fleetmap_core::world::World;
use std::time::Duration;

impl SimCamera {
    /// Drop the captures due at `now` when there is no pose to render them from: pending
    /// pictures and interval shots that came due (distance triggering needs a position and
    /// does not run). Returns how many were dropped. The clock advances as in
    /// [`SimCamera::advance`].
    pub(crate) fn drop_due(&mut self, now: Time) -> u32 {
        self.advance(now);
        let mut dropped = std::mem::take(&mut self.pending);
        if let Some((next, period, remaining)) = self.interval
            && now >= next
        {
            dropped += 1;
            // the schedule goes on from now: no burst of catch-up shots when a pose returns
            let next = now + period;
            self.interval = match remaining {
                0 => Some((next, period, 0)),
                1 => None,
                r => Some((next, period, r - 1)),
            };
        }
        dropped
    }

    /// Take one picture as soon as possible.
    pub fn trigger(&mut self) {
        self.pending += 1;
    }

    /// Start capturing `count` images (0 = until stopped) every `interval_s` seconds; an
    /// interval of 0 with count ≤ 1 takes one picture (MAV_CMD_IMAGE_START_CAPTURE).
    pub fn start_capture(&mut self, interval_s: f64, count: u32, now: Time) {
        if interval_s <= 0.0 || !interval_s.is_finite() {
            self.pending += count.max(1);
            self.interval = None;
            return;
        }
        if count == 1 {
            self.pending += 1;
            self.interval = None;
            return;
        }
        self.pending += 1;
        let period = Duration::from_secs_f64(interval_s.max(self.config.min_interval_s));
        self.interval = Some((now + period, period, count.saturating_sub(1)));
        if count == 0 {
            self.interval = Some((now + period, period, 0));
        }
    }

    /// Stop interval and distance triggering.
    pub fn stop_capture(&mut self) {
        self.interval = None;
        self.trigger_dist = None;
    }

    /// Trigger every `meters` of horizontal travel (0 stops), from position (e, n).
    pub fn set_trigger_distance(&mut self, meters: f64, pos: (f64, f64)) {
        self.trigger_dist = if meters > 0.0 && meters.is_finite() {
            Some((meters, pos))
        } else {
            None
        };
    }

    /// Run the camera: distance and interval triggers, pending captures, and (when paced)
    /// the release of image packets due by `ctx.now`.
    pub fn update(&mut self, ctx: &CaptureContext, pos: (f64, f64), world: Option<&World>) {
        let backlog = self.transfer_backlog() > 0;
        if let Some(p) = self.pacer.as_mut() {
            p.refill(ctx.now, backlog);
        }
        if let Some((d, last)) = self.trigger_dist
            && (pos.0 - last.0).hypot(pos.1 - last.1) >= d
        {
            self.pending += 1;
            self.trigger_dist = Some((d, pos));
        }
        if let Some((next, period, remaining)) = self.interval
            && ctx.now >= next
        {
            self.pending += 1;
            self.interval = match remaining {
                0 => Some((next + period, period, 0)),
                1 => None,
                r => Some((next + period, period, r - 1)),
            };
        }
        if self.pending > 0 {
            let ready = self.last_capture.is_none_or(|t| {
                ctx.now.saturating_since(t).as_secs_f64() + 1e-9 >= self.config.min_interval_s
            });
            if ready {
                self.pending -= 1;
                self.capture(ctx, world);
            }
        }
        self.status_tick(ctx.now);
        self.release();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::CameraConfig;

    #[test]
    fn drop_due_counts_pending_and_interval_shots() {
        let mut cam = SimCamera::new(1, CameraConfig::default(), 1);
        cam.trigger();
        cam.trigger();
        assert_eq!(cam.drop_due(Time::from_secs(1)), 2);
        assert_eq!(cam.drop_due(Time::from_secs(1)), 0);
        // every second, three pictures: the first is pending, the next two come due
        cam.start_capture(1.0, 3, Time::from_secs(2));
        assert_eq!(cam.drop_due(Time::from_secs(2)), 1);
        assert_eq!(cam.drop_due(Time::from_millis(2_500)), 0);
        assert_eq!(cam.drop_due(Time::from_secs(3)), 1);
        assert_eq!(cam.drop_due(Time::from_secs(4)), 1);
        assert_eq!(cam.drop_due(Time::from_secs(9)), 0);
        assert_eq!(cam.image_count(), 0);
    }
}
