//! Taking a picture: the capture context and the captured image, rendering (or a shot from
//! outside), the degraded sensor, JPEG with metadata, CAMERA_IMAGE_CAPTURED and the on-board
//! measurement.

use super::onboard::Picture;
use super::{FRAME_OVERHEAD, RECENT_IMAGES, SimCamera};
use crate::pose::CameraPose;
#[cfg(feature = "render")]
use crate::render::{Disturbances, render};
use fleetmap_core::time::Time;
use fleetmap_core::vision::meta::{ImageMeta, insert_meta};
use fleetmap_core::world::World;
use image::RgbImage;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::sync::Arc;
// named in the documentation only
#[cfg(doc)]
use super::CameraConfig;

/// A captured image, for the shell (files) and for scoring.
#[derive(Clone, Debug)]
pub struct CapturedImage {
    /// Metadata as embedded in the JPEG (the pose the autopilot reported).
    pub meta: ImageMeta,
    /// The pose the image was really taken from (true position, tilt).
    pub true_pose: CameraPose,
    /// JPEG bytes (with the metadata segment).
    pub jpeg: Arc<Vec<u8>>,
    /// The file name within the configured directory.
    pub file_name: String,
    /// When it was taken.
    pub time: Time,
    /// Whether the image shows the other class of tiles
    /// ([`CameraConfig::misclassify_probability`]); the JPEG does not say so.
    pub misclassified: bool,
}

/// Pose inputs for a capture.
#[derive(Clone, Copy, Debug)]
pub struct CaptureContext {
    /// True camera pose.
    pub true_pose: CameraPose,
    /// Position the autopilot reports (lat, lon degrees, altitude above home m).
    pub reported: (f64, f64, f64),
    /// AMSL altitude the autopilot reports, metres.
    pub alt_amsl_m: f64,
    /// Milliseconds since boot.
    pub time_boot_ms: u32,
    /// Simulation time.
    pub now: Time,
    /// World time, seconds (for moving regions).
    pub world_t_s: f64,
}

/// The attitude as a quaternion (w, x, y, z) rotating the body frame (x forward, y right,
/// z down) into the local NED frame: ZYX Euler angles in degrees — roll right wing down,
/// pitch nose up, yaw clockwise from north — as ATTITUDE / AHRS give them. This is what
/// CAMERA_IMAGE_CAPTURED.q carries for a camera fixed to the airframe looking down, the
/// pose the image was rendered at (`crate::render` tilts the view by the same roll
/// and pitch).
pub fn attitude_quaternion(roll_deg: f64, pitch_deg: f64, yaw_deg: f64) -> [f32; 4] {
    let (sr, cr) = (roll_deg.to_radians() / 2.0).sin_cos();
    let (sp, cp) = (pitch_deg.to_radians() / 2.0).sin_cos();
    let (sy, cy) = (yaw_deg.to_radians() / 2.0).sin_cos();
    [
        (cr * cp * cy + sr * sp * sy) as f32,
        (sr * cp * cy - cr * sp * sy) as f32,
        (cr * sp * cy + sr * cp * sy) as f32,
        (cr * cp * sy - sr * sp * cy) as f32,
    ]
}

/// Whether the image with per-image seed `image_seed` shows the other class of tiles, for a
/// sensor that misclassifies with probability `p` (see
/// [`CameraConfig::misclassify_probability`]): a uniform draw in [0, 1) from the seed, below
/// `p`. Pure: the same seed and `p` always give the same answer, and a larger `p` flips a
/// superset of the images a smaller one flips.
pub fn shows_other_class(image_seed: u64, p: f64) -> bool {
    if !(p.is_finite() && p > 0.0) {
        return false;
    }
    // salted apart from the disturbances drawn from the same seed (render::Disturbances::draw)
    let mut rng = ChaCha8Rng::seed_from_u64(image_seed ^ 0xF11B_5E45_0C1A_55E5);
    rng.random_range(0.0..1.0) < p
}

/// A picture the camera fired and has not delivered yet: with an outside source
/// ([`CameraConfig::external`]) the shell gets the picture and hands it back with
/// `SimCamera::deliver`.
#[derive(Clone, Copy, Debug)]
pub struct Shot {
    /// The camera's image index (since boot).
    pub index: i32,
    /// The pose and time at the shutter.
    pub ctx: CaptureContext,
    /// Whether a degraded sensor shows this picture's tiles as the other class (rendered
    /// pictures only).
    misclassified: bool,
}

impl SimCamera {
    /// Take one picture now at `ctx`'s pose, whatever the triggers and the minimum interval
    /// say: the shutter an autopilot has already fired (ArduPilot's CAMERA_FEEDBACK).
    pub fn capture_now(&mut self, ctx: &CaptureContext, world: Option<&World>) {
        let backlog = self.transfer_backlog() > 0;
        if let Some(p) = self.pacer.as_mut() {
            p.refill(ctx.now, backlog);
        }
        self.capture(ctx, world);
        self.release();
    }

    /// Next captured image (for the shell to write files, and for scoring).
    pub fn poll_image(&mut self) -> Option<CapturedImage> {
        self.images.pop_front()
    }

    pub(super) fn capture(&mut self, ctx: &CaptureContext, world: Option<&World>) {
        let index = self.image_count;
        self.image_count += 1;
        self.last_capture = Some(ctx.now);
        let seed = self.image_seed(index);
        let misclassified = shows_other_class(seed, self.config.misclassify_probability);
        let shot = Shot {
            index,
            ctx: *ctx,
            misclassified,
        };
        if self.config.external {
            self.shots.push_back(shot);
            return;
        }
        #[cfg(feature = "render")]
        let img = world.map(|w| {
            let dist = Disturbances {
                swap_tiles: misclassified,
                ..Disturbances::draw(seed)
            };
            render(w, &ctx.true_pose, &self.config.model, ctx.world_t_s, &dist)
        });
        // built without the renderer: a camera that is not external has no picture to give
        #[cfg(not(feature = "render"))]
        let img: Option<RgbImage> = world.and(None);
        self.finish(shot, img.as_ref());
    }

    /// The next picture to take from outside ([`CameraConfig::external`]): get it and give
    /// it to [`SimCamera::deliver`]. Shots come out in the order they were fired.
    pub(crate) fn poll_shot(&mut self) -> Option<Shot> {
        self.shots.pop_front()
    }

    /// The picture of `shot` (None: the source had none: the capture failed), at `now`: the
    /// capture is announced (CAMERA_IMAGE_CAPTURED), measured when the camera measures on
    /// board, and sent or kept as a rendered one would be. A shot of an earlier boot is
    /// dropped.
    pub(crate) fn deliver(&mut self, shot: Shot, img: Option<&RgbImage>, now: Time) {
        if shot.index >= self.image_count {
            return; // fired before a reboot
        }
        let backlog = self.transfer_backlog() > 0;
        if let Some(p) = self.pacer.as_mut() {
            p.refill(now, backlog);
        }
        self.finish(shot, img);
        self.release();
    }

    /// Announce, measure and send (or keep) the picture of `shot`.
    fn finish(&mut self, shot: Shot, img: Option<&RgbImage>) {
        let Shot {
            index,
            ctx,
            misclassified,
        } = shot;
        let ctx = &ctx;
        let (width, height) = img.map_or(
            (self.config.model.width_px, self.config.model.height_px),
            |i| i.dimensions(),
        );
        let meta = ImageMeta {
            sysid: self.sysid,
            boot: self.boot,
            image_index: index,
            time_boot_ms: ctx.time_boot_ms,
            lat: ctx.reported.0,
            lon: ctx.reported.1,
            alt_rel_m: ctx.reported.2,
            heading_deg: ctx.true_pose.heading_deg,
            width,
            height,
        };
        let file_name = format!(
            "sys{:03}_boot{:03}_img{:05}.jpg",
            self.sysid, self.boot, index
        );
        let mut jpeg = None;
        if let Some(img) = img {
            let mut raw = Vec::new();
            let ok = image::codecs::jpeg::JpegEncoder::new_with_quality(
                &mut raw,
                self.config.jpeg_quality.clamp(1, 100),
            )
            .encode_image(img)
            .is_ok();
            if ok {
                jpeg = insert_meta(&raw, &meta).map(Arc::new);
            }
        }
        let url = match (&self.config.file_dir, &jpeg) {
            (Some(dir), Some(_)) => format!("file://{}/{}", dir.trim_end_matches('/'), file_name),
            _ => String::new(),
        };
        let q = attitude_quaternion(
            ctx.true_pose.roll_deg,
            ctx.true_pose.pitch_deg,
            ctx.true_pose.heading_deg,
        );
        let captured = mav::CAMERA_IMAGE_CAPTURED_DATA {
            time_utc: 0,
            time_boot_ms: ctx.time_boot_ms,
            lat: (ctx.reported.0 * 1e7).round() as i32,
            lon: (ctx.reported.1 * 1e7).round() as i32,
            alt: (ctx.alt_amsl_m * 1000.0).round() as i32,
            relative_alt: (ctx.reported.2 * 1000.0).round() as i32,
            q,
            image_index: index,
            camera_id: 0,
            capture_result: if jpeg.is_some() {
                mav::MavBool::MAV_BOOL_TRUE
            } else {
                mav::MavBool::MAV_BOOL_FALSE
            },
            file_url: url.as_str().into(),
        };
        // the result goes right after the capture's announcement, which carries its pose
        let result = match (&jpeg, img) {
            (Some(j), Some(image)) => self.onboard_result(&Picture {
                image,
                jpeg: j,
                captured: &captured,
                alt_rel_m: ctx.reported.2,
            }),
            _ => None,
        };
        let measured = result.is_some();
        let messages: Vec<MavMessage> =
            std::iter::once(MavMessage::CAMERA_IMAGE_CAPTURED(captured))
                .chain(result)
                .collect();
        self.outbox.extend(messages.iter().cloned());
        self.keep_capture(index, messages);
        if let Some(j) = &jpeg {
            if self.config.mavlink_transfer && !measured {
                // The announcement just sent counts against the image's pacing: the
                // handshake does not follow it back to back.
                if let Some(p) = self.pacer.as_mut() {
                    p.tokens -=
                        (FRAME_OVERHEAD + mav::CAMERA_IMAGE_CAPTURED_DATA::ENCODED_LEN) as f64;
                }
                self.queue_transfer(j);
            }
            self.last_jpeg = Some(j.clone());
            self.recent.push_back(j.clone());
            if self.recent.len() > RECENT_IMAGES {
                self.recent.pop_front();
            }
            self.images.push_back(CapturedImage {
                meta,
                true_pose: ctx.true_pose,
                jpeg: j.clone(),
                file_name,
                time: ctx.now,
                misclassified,
            });
        }
    }

    /// The seed of image `index` of this boot: its disturbances and whether it is flipped
    /// ([`shows_other_class`]) are drawn from it.
    fn image_seed(&self, index: i32) -> u64 {
        self.seed
            .wrapping_mul(0x9E37_79B9_7F4A_7C15)
            .wrapping_add(u64::from(self.sysid) << 40)
            .wrapping_add(u64::from(self.boot) << 24)
            .wrapping_add(index as u64)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::CameraConfig;

    /// Take `n` 16-pixel pictures over a flat green field with a sensor that misclassifies
    /// with probability `p`; returns which of them were flipped.
    fn flips(p: f64, n: usize, seed: u64) -> Vec<bool> {
        let world = World::flat(
            fleetmap_core::world::Surface::GreenTile,
            (37.0, -80.0),
            100.0,
        );
        let mut cfg = CameraConfig {
            misclassify_probability: p,
            min_interval_s: 0.0,
            mavlink_transfer: false,
            ..CameraConfig::default()
        };
        cfg.model.width_px = 16;
        cfg.model.height_px = 16;
        let mut cam = SimCamera::new(2, cfg, seed);
        let pose = CameraPose {
            lat: 37.0,
            lon: -80.0,
            alt_agl_m: 10.0,
            heading_deg: 0.0,
            roll_deg: 0.0,
            pitch_deg: 0.0,
        };
        (0..n)
            .map(|i| {
                let ctx = CaptureContext {
                    true_pose: pose,
                    reported: (37.0, -80.0, 10.0),
                    alt_amsl_m: 110.0,
                    time_boot_ms: i as u32 * 100,
                    now: Time::from_millis(i as u64 * 100),
                    world_t_s: i as f64 * 0.1,
                };
                cam.capture_now(&ctx, Some(&world));
                cam.poll_image()
                    .expect("an image of the world")
                    .misclassified
            })
            .collect()
    }

    /// A degraded sensor flips a share of its images within a binomial 5-sigma band of its
    /// probability, independently per image and the same way for the same seed; a perfect
    /// one (the default 0) never does.
    #[test]
    fn a_degraded_sensor_flips_its_share_of_images() {
        let n = 2000;
        assert!(flips(0.0, n, 7).iter().all(|&f| !f));
        assert_eq!(CameraConfig::default().misclassify_probability, 0.0);
        for p in [0.05, 0.2] {
            let k = flips(p, n, 7).iter().filter(|&&f| f).count() as f64;
            let (mean, sigma) = (n as f64 * p, (n as f64 * p * (1.0 - p)).sqrt());
            assert!(
                (k - mean).abs() <= 5.0 * sigma,
                "p = {p}: {k} of {n} flipped, expected {mean} ± {:.1}",
                5.0 * sigma
            );
        }
        // deterministic in the seed, different between seeds
        let a = flips(0.05, 400, 7);
        assert_eq!(a, flips(0.05, 400, 7));
        assert_ne!(a, flips(0.05, 400, 8));
        // consecutive images are not correlated: flips come apart, not in one run
        let flipped: Vec<usize> = a
            .iter()
            .enumerate()
            .filter(|(_, f)| **f)
            .map(|(i, _)| i)
            .collect();
        assert!(flipped.len() >= 5 && flipped.windows(2).any(|w| w[1] - w[0] > 1));
        // not a probability: nothing flipped
        for p in [f64::NAN, -0.1, f64::INFINITY] {
            assert!(!shows_other_class(1, p));
        }
    }

    #[test]
    fn quaternion_carries_roll_pitch_and_yaw() {
        // heading only: the old (w, 0, 0, z) form
        let q = attitude_quaternion(0.0, 0.0, 90.0);
        let h = 45f64.to_radians();
        assert!((f64::from(q[0]) - h.cos()).abs() < 1e-6);
        assert!(q[1].abs() < 1e-7 && q[2].abs() < 1e-7);
        assert!((f64::from(q[3]) - h.sin()).abs() < 1e-6);
        // back to Euler angles (ZYX) with the usual formulas
        let (r, p, y) = (5.0, -3.0, 250.0);
        let [w, x, yy, z] = attitude_quaternion(r, p, y).map(f64::from);
        let roll = (2.0 * (w * x + yy * z)).atan2(1.0 - 2.0 * (x * x + yy * yy));
        let pitch = (2.0 * (w * yy - z * x)).asin();
        let yaw = (2.0 * (w * z + x * yy)).atan2(1.0 - 2.0 * (yy * yy + z * z));
        assert!((roll.to_degrees() - r).abs() < 1e-4);
        assert!((pitch.to_degrees() - p).abs() < 1e-4);
        assert!((yaw.to_degrees().rem_euclid(360.0) - y).abs() < 1e-4);
        assert!(((w * w + x * x + yy * yy + z * z) - 1.0).abs() < 1e-6);
    }
}
