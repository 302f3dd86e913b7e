//! The simulated camera: a MAVLink camera component (component id 100) on each vehicle.
//!
//! It answers the MAVLink camera protocol (MAV_CMD_REQUEST_MESSAGE for CAMERA_INFORMATION and
//! CAMERA_CAPTURE_STATUS, MAV_CMD_IMAGE_START_CAPTURE with interval and count,
//! MAV_CMD_IMAGE_STOP_CAPTURE) and is triggered by the autopilot's mission items
//! (IMAGE_START_CAPTURE, DO_DIGICAM_CONTROL, DO_SET_CAM_TRIGG_DIST). Each capture renders the
//! view at the vehicle's true pose ([`crate::sim::render`]), encodes it as JPEG with the
//! capture's metadata in a COM segment ([`crate::imagery::meta`]) and delivers it
//! - as CAMERA_IMAGE_CAPTURED (lat, lon, alt, image index, and a `file://` URL when a
//!   directory is configured: the shell writes the file before the message is sent), and
//! - by MAVLink image transmission: DATA_TRANSMISSION_HANDSHAKE (type JPEG, size, width,
//!   height, packets, payload 253) then the ENCAPSULATED_DATA packets, pushed after every
//!   capture and re-sent when the GCS asks with a DATA_TRANSMISSION_HANDSHAKE of its own
//!   (the request form of the image transmission protocol).

use crate::imagery::meta::{ImageMeta, insert_meta};
use crate::sim::render::{CameraPose, Disturbances, render};
use crate::sim::world::World;
use crate::time::Time;
use crate::vision::camera::CameraModel;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;

/// MAV_COMP_ID_CAMERA.
pub const CAMERA_COMPID: u8 = 100;
/// Bytes of image per ENCAPSULATED_DATA packet.
pub const PAYLOAD: usize = 253;

/// How captured images leave the vehicle.
#[derive(Clone, Debug, PartialEq)]
pub struct CameraConfig {
    /// Optics and resolution.
    pub model: CameraModel,
    /// JPEG quality, 1–100.
    pub jpeg_quality: u8,
    /// Push every image over MAVLink image transmission.
    pub mavlink_transfer: bool,
    /// Directory (absolute) the images are written to and announced from in
    /// CAMERA_IMAGE_CAPTURED.file_url; `None` = no files.
    pub file_dir: Option<String>,
    /// Minimum time between two captures, seconds (a real camera needs time to expose and
    /// store).
    pub min_interval_s: f64,
}

impl Default for CameraConfig {
    fn default() -> Self {
        CameraConfig {
            model: CameraModel::paper(),
            jpeg_quality: 85,
            mavlink_transfer: true,
            file_dir: None,
            min_interval_s: 0.2,
        }
    }
}

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

/// The camera component of one vehicle.
#[derive(Debug)]
pub struct SimCamera {
    sysid: u8,
    boot: u32,
    seed: u64,
    config: CameraConfig,
    image_count: i32,
    interval: Option<(Time, Duration, u32)>, // next, period, remaining (0 = unlimited)
    trigger_dist: Option<(f64, (f64, f64))>, // distance, last trigger position (e, n)
    pending: u32,
    last_capture: Option<Time>,
    last_jpeg: Option<Arc<Vec<u8>>>,
    outbox: VecDeque<MavMessage>,
    images: VecDeque<CapturedImage>,
}

impl SimCamera {
    /// A camera on vehicle `sysid`; `seed` drives the image disturbances.
    pub fn new(sysid: u8, config: CameraConfig, seed: u64) -> SimCamera {
        SimCamera {
            sysid,
            boot: 1,
            seed,
            config,
            image_count: 0,
            interval: None,
            trigger_dist: None,
            pending: 0,
            last_capture: None,
            last_jpeg: None,
            outbox: VecDeque::new(),
            images: VecDeque::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &CameraConfig {
        &self.config
    }

    /// Power cycle with the vehicle: counters restart, captures in progress stop.
    pub fn reboot(&mut self) {
        self.boot += 1;
        self.image_count = 0;
        self.interval = None;
        self.trigger_dist = None;
        self.pending = 0;
        self.last_capture = None;
        self.last_jpeg = None;
        self.outbox.clear();
    }

    /// Images taken since boot.
    pub fn image_count(&self) -> i32 {
        self.image_count
    }

    /// Next message from the camera component.
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.outbox.pop_front()
    }

    /// Next captured image (for the shell to write files, and for scoring).
    pub fn poll_image(&mut self) -> Option<CapturedImage> {
        self.images.pop_front()
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

    /// Run the camera: distance and interval triggers, pending captures.
    pub fn update(&mut self, ctx: &CaptureContext, pos: (f64, f64), world: Option<&World>) {
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
    }

    fn capture(&mut self, ctx: &CaptureContext, world: Option<&World>) {
        let index = self.image_count;
        self.image_count += 1;
        self.last_capture = Some(ctx.now);
        let model = self.config.model;
        let meta = ImageMeta {
            sysid: self.sysid,
            boot: self.boot,
            image_index: index,
            time_boot_ms: ctx.time_boot_ms,
            lat: ctx.reported.0,
            lon: ctx.reported.1,
            alt_rel_m: ctx.reported.2,
            heading_deg: ctx.true_pose.heading_deg,
            width: model.width_px,
            height: model.height_px,
        };
        let file_name = format!(
            "sys{:03}_boot{:03}_img{:05}.jpg",
            self.sysid, self.boot, index
        );
        let mut jpeg = None;
        if let Some(w) = world {
            let seed = self
                .seed
                .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                .wrapping_add(u64::from(self.sysid) << 40)
                .wrapping_add(u64::from(self.boot) << 24)
                .wrapping_add(index as u64);
            let img = render(
                w,
                &ctx.true_pose,
                &model,
                ctx.world_t_s,
                &Disturbances::draw(seed),
            );
            let mut raw = Vec::new();
            let ok = image::codecs::jpeg::JpegEncoder::new_with_quality(
                &mut raw,
                self.config.jpeg_quality.clamp(1, 100),
            )
            .encode_image(&img)
            .is_ok();
            if ok {
                jpeg = insert_meta(&raw, &meta).map(Arc::new);
            }
        }
        let url = match (&self.config.file_dir, &jpeg) {
            (Some(dir), Some(_)) => format!("file://{}/{}", dir.trim_end_matches('/'), file_name),
            _ => String::new(),
        };
        // Quaternion of the camera (w, x, y, z) with only the heading, as ArduPilot/PX4 fill it
        // for a nadir camera without a gimbal report.
        let h = ctx.true_pose.heading_deg.to_radians() / 2.0;
        self.outbox.push_back(MavMessage::CAMERA_IMAGE_CAPTURED(
            mav::CAMERA_IMAGE_CAPTURED_DATA {
                time_utc: 0,
                time_boot_ms: ctx.time_boot_ms,
                lat: (ctx.reported.0 * 1e7).round() as i32,
                lon: (ctx.reported.1 * 1e7).round() as i32,
                alt: (ctx.alt_amsl_m * 1000.0).round() as i32,
                relative_alt: (ctx.reported.2 * 1000.0).round() as i32,
                q: [h.cos() as f32, 0.0, 0.0, h.sin() as f32],
                image_index: index,
                camera_id: 0,
                capture_result: if jpeg.is_some() {
                    mav::MavBool::MAV_BOOL_TRUE
                } else {
                    mav::MavBool::MAV_BOOL_FALSE
                },
                file_url: url.as_str().into(),
            },
        ));
        if let Some(j) = &jpeg {
            if self.config.mavlink_transfer {
                self.queue_transfer(j);
            }
            self.last_jpeg = Some(j.clone());
            self.images.push_back(CapturedImage {
                meta,
                true_pose: ctx.true_pose,
                jpeg: j.clone(),
                file_name,
                time: ctx.now,
            });
        }
    }

    fn queue_transfer(&mut self, jpeg: &[u8]) {
        let packets = jpeg.len().div_ceil(PAYLOAD);
        let model = self.config.model;
        self.outbox
            .push_back(MavMessage::DATA_TRANSMISSION_HANDSHAKE(
                mav::DATA_TRANSMISSION_HANDSHAKE_DATA {
                    size: jpeg.len() as u32,
                    width: model.width_px as u16,
                    height: model.height_px as u16,
                    packets: packets as u16,
                    mavtype: mav::MavlinkDataStreamType::MAVLINK_DATA_STREAM_IMG_JPEG,
                    payload: PAYLOAD as u8,
                    jpg_quality: self.config.jpeg_quality,
                },
            ));
        for (i, chunk) in jpeg.chunks(PAYLOAD).enumerate() {
            let mut data = [0u8; PAYLOAD];
            data[..chunk.len()].copy_from_slice(chunk);
            self.outbox
                .push_back(MavMessage::ENCAPSULATED_DATA(mav::ENCAPSULATED_DATA_DATA {
                    seqnr: i as u16,
                    data,
                }));
        }
    }

    /// A GCS's DATA_TRANSMISSION_HANDSHAKE: re-send the latest image.
    pub fn handle_handshake_request(&mut self) {
        if let Some(j) = self.last_jpeg.clone() {
            self.queue_transfer(&j);
        }
    }

    /// CAMERA_INFORMATION for this camera.
    pub fn information(&self, time_boot_ms: u32) -> MavMessage {
        let m = self.config.model;
        // a 1/2.3" sensor (6.17 mm wide) behind the lens that gives the model's field of view
        let sensor_h = 6.17f32;
        let sensor_v = sensor_h * m.height_px as f32 / m.width_px.max(1) as f32;
        let focal = (f64::from(sensor_h) / 2.0 / (m.hfov_deg.to_radians() / 2.0).tan()) as f32;
        let mut vendor = [0u8; 32];
        vendor[..8].copy_from_slice(b"fleetmap");
        let mut model = [0u8; 32];
        model[..9].copy_from_slice(b"sim-nadir");
        MavMessage::CAMERA_INFORMATION(mav::CAMERA_INFORMATION_DATA {
            time_boot_ms,
            firmware_version: 1,
            focal_length: focal,
            sensor_size_h: sensor_h,
            sensor_size_v: sensor_v,
            flags: mav::CameraCapFlags::CAMERA_CAP_FLAGS_CAPTURE_IMAGE,
            resolution_h: m.width_px as u16,
            resolution_v: m.height_px as u16,
            cam_definition_version: 0,
            vendor_name: vendor,
            model_name: model,
            lens_id: 0,
            cam_definition_uri: "".into(),
            gimbal_device_id: 0,
            camera_device_id: 0,
        })
    }

    /// CAMERA_CAPTURE_STATUS.
    pub fn capture_status(&self, time_boot_ms: u32) -> MavMessage {
        MavMessage::CAMERA_CAPTURE_STATUS(mav::CAMERA_CAPTURE_STATUS_DATA {
            time_boot_ms,
            image_interval: self
                .interval
                .map(|(_, p, _)| p.as_secs_f32())
                .unwrap_or(0.0),
            recording_time_ms: 0,
            available_capacity: 1.0e4,
            image_status: if self.interval.is_some() { 3 } else { 0 },
            video_status: 0,
            image_count: self.image_count,
            camera_device_id: 0,
        })
    }
}
