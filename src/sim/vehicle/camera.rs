//! The camera payload: its pose and capture context each tick.

use super::*;

impl SimVehicle {
    // ------------------------------------------------------------------ camera

    pub(super) fn update_camera(&mut self, now: Time) {
        if self.camera.is_none() {
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
                crate::sim::world::Surface::Grass,
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
