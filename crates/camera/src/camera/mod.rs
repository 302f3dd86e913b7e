//! The simulated camera: a MAVLink camera component (component id 100) on each vehicle.
//!
//! It answers the MAVLink camera protocol (MAV_CMD_REQUEST_MESSAGE for CAMERA_INFORMATION,
//! CAMERA_CAPTURE_STATUS and a missed CAMERA_IMAGE_CAPTURED with its on-board result:
//! `requests`; MAV_CMD_IMAGE_START_CAPTURE with interval, count and sequence number,
//! MAV_CMD_IMAGE_STOP_CAPTURE) and is triggered by the autopilot's mission items
//! (IMAGE_START_CAPTURE, DO_DIGICAM_CONTROL, DO_SET_CAM_TRIGG_DIST). Each capture renders the
//! view at the vehicle's true pose (`crate::render`, cargo feature `render`), encodes it as JPEG with the
//! capture's metadata in a COM segment ([`fleetmap_core::vision::meta`]) and delivers it
//! - as CAMERA_IMAGE_CAPTURED (lat, lon, alt, image index, and a `file://` URL when a
//!   directory is configured: the shell writes the file before the message is sent), and
//! - by MAVLink image transmission: DATA_TRANSMISSION_HANDSHAKE (type JPEG, size, width,
//!   height, packets, payload 253) then the ENCAPSULATED_DATA packets, pushed after every
//!   capture and re-sent when the GCS asks with a DATA_TRANSMISSION_HANDSHAKE of its own
//!   (the request form of the image transmission protocol).
//!
//! Pacing ([`CameraConfig::transfer_rate_bps`]): by default the handshake and every packet
//! are queued at once, as the embedded simulator's vehicles have always done (their shell,
//! `fleetmap_sim::server`, paces UDP datagrams per vehicle: `fleetmap_sim::tx_queue`).
//! With a rate, the image transmission leaves through a token bucket in bytes per second of
//! the camera's own clock (the `now` of [`SimCamera::update`] / [`SimCamera::advance`]):
//! each message costs its MAVLink 2 frame (10 header bytes, the payload, 2 CRC bytes: 267
//! bytes per ENCAPSULATED_DATA), the bucket holds `PACE_BURST_S` of the rate (at least one
//! frame), and [`SimCamera::poll_transmit`] only hands out what the bucket has released.
//! This is for a camera whose images go through a routing autopilot: ArduPilot forwards a
//! frame only when the outgoing port's transmit buffer has room for it and silently drops
//! it otherwise (`MAVLink_routing::check_and_forward`, `comm_get_txspace`), so a 60–100 KB
//! JPEG sent as one burst loses a large share of its packets. CAMERA_IMAGE_CAPTURED is never
//! held back by the pacing.
//!
//! Re-sends (`SimCamera::handle_handshake_request`): a GCS that missed packets asks for the
//! image again by its size. The request has no target (DATA_TRANSMISSION_HANDSHAKE has no
//! target fields), so an autopilot forwards it to every port it has heard a component on
//! (ArduPilot `MAVLink_routing::check_and_forward`: no target system is a broadcast; PX4
//! `Mavlink::forward_message`: target 0 goes to every forwarding instance that has seen a
//! component), and every camera behind a shared port hears it, once per autopilot. So
//! - only a camera holding an image of that size answers: one it sent lately (the last
//!   [`RECENT_IMAGES`] whose transmission started) or one it captured lately (the last
//!   [`RECENT_IMAGES`] captures: a picture measured on board and not sent). A paced camera
//!   with a queue sends pictures captured long ago, so "captured lately" alone missed the
//!   very image being asked for, and the old fallback to the latest image answered every
//!   such request — from every camera — with a picture the GCS already had;
//! - the same request heard again while that re-send waits or is leaving is ignored;
//! - a re-send goes out before the pictures still queued, as soon as the image leaving now
//!   is finished (never in the middle of one: ENCAPSULATED_DATA carries no image id, so the
//!   GCS counts every packet after an announcement for the image announced). Queued behind
//!   minutes of pictures, it came after the GCS had given up.
//!
//! Measured on board ([`CameraConfig::onboard`]): the picture is announced, its result sent
//! right after (the bandit mission's green share, or the runway mission's cell and 3 × 3
//! region counts, classified on the decoded JPEG the camera would send) and the picture kept
//! for a GCS that asks. A runway camera without the grid (a mission whose origin is the first
//! vehicle's home) takes it from the GCS's announcement and says it has none meanwhile
//! (`onboard`); it forgets it when it reboots with its vehicle.
//!
//! A degraded sensor ([`CameraConfig::misclassify_probability`]): each image, independently
//! and with that probability, shows the bandit field's green tiles as grey and its grey
//! tiles as green, as the bandit paper's degraded-sensor run (§V) added 5 % classification
//! noise to its measurements. The GCS is not told; [`CapturedImage::misclassified`] says it
//! for scoring.

mod capture;
mod config;
pub mod onboard;
mod pacer;
mod requests;
mod transfer;
mod trigger;

use self::onboard::{Measurer, measurer};
use self::pacer::Pacer;
use fleetmap_core::time::Time;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;

pub use self::capture::{
    CaptureContext, CapturedImage, Shot, attitude_quaternion, shows_other_class,
};
pub use self::config::CameraConfig;
pub(crate) use self::pacer::FRAME_OVERHEAD;
#[cfg(test)]
pub(crate) use self::pacer::PACE_BURST_S;
pub use self::transfer::RECENT_IMAGES;

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
    /// The latest images captured (newest last, at most [`RECENT_IMAGES`]): a GCS may ask for
    /// one of them by its size ([`SimCamera::handle_handshake_request`]), e.g. a picture
    /// measured on board and not sent.
    recent: VecDeque<Arc<Vec<u8>>>,
    /// The latest images whose transmission started (newest last, at most
    /// [`RECENT_IMAGES`]): the ones a GCS may be missing packets of. With a queue, these
    /// were captured long before the images in `recent`.
    sent: VecDeque<Arc<Vec<u8>>>,
    outbox: VecDeque<MavMessage>,
    /// Image transmission waiting for the token bucket (only when paced): first
    /// transmissions, in the order of capture.
    paced: VecDeque<MavMessage>,
    /// The images whose first transmission waits in `paced`, in order (they move to `sent`
    /// when their handshake leaves).
    queued: VecDeque<Arc<Vec<u8>>>,
    /// Re-sends a GCS asked for, waiting for the token bucket (only when paced): they leave
    /// before the next image of `paced`.
    resends: VecDeque<MavMessage>,
    /// Whether the image leaving now comes from `resends`.
    resending: bool,
    /// Size of the image leaving now (its handshake was the last one to leave).
    in_flight: Option<u32>,
    pacer: Option<Pacer>,
    images: VecDeque<CapturedImage>,
    /// Shots waiting for their picture from outside ([`CameraConfig::external`]).
    shots: VecDeque<Shot>,
    /// What the camera measures on board ([`CameraConfig::onboard`]), with what it learnt
    /// since it booted (the runway's grid).
    onboard: Option<Box<dyn Measurer>>,
    /// The latest captures' announcements and on-board results, to send again
    /// ([`requests`]).
    kept: VecDeque<requests::KeptCapture>,
    /// The sequence number of the last single capture commanded ([`requests`]).
    last_capture_seq: Option<u32>,
}

impl SimCamera {
    /// A camera on vehicle `sysid`; `seed` drives the image disturbances.
    pub fn new(sysid: u8, config: CameraConfig, seed: u64) -> SimCamera {
        SimCamera {
            sysid,
            boot: 1,
            seed,
            image_count: 0,
            interval: None,
            trigger_dist: None,
            pending: 0,
            last_capture: None,
            last_jpeg: None,
            recent: VecDeque::new(),
            sent: VecDeque::new(),
            outbox: VecDeque::new(),
            paced: VecDeque::new(),
            queued: VecDeque::new(),
            resends: VecDeque::new(),
            resending: false,
            in_flight: None,
            pacer: config
                .transfer_rate_bps
                .filter(|r| r.is_finite() && *r > 0.0)
                .map(Pacer::new),
            images: VecDeque::new(),
            shots: VecDeque::new(),
            onboard: measurer(&config),
            kept: VecDeque::new(),
            last_capture_seq: None,
            config,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &CameraConfig {
        &self.config
    }

    /// Pace image transmission to `rate` bytes per second from now (`None`, or a rate that is
    /// not finite and positive: every image queued at once). Images already waiting for the
    /// bucket keep their order; unpaced, they are all queued now.
    pub fn set_transfer_rate(&mut self, rate: Option<f64>) {
        let rate = rate.filter(|r| r.is_finite() && *r > 0.0);
        self.config.transfer_rate_bps = rate;
        if let Some(r) = rate {
            match self.pacer.as_mut() {
                Some(p) => p.set_rate(r),
                None => self.pacer = Some(Pacer::new(r)),
            }
        } else if let Some(p) = self.pacer.as_mut() {
            // release everything waiting, in order, then stop pacing
            p.tokens = f64::INFINITY;
            self.release();
            self.pacer = None;
        }
    }

    /// The minimum time between two captures, seconds (negative or not finite: 0).
    pub fn set_min_interval(&mut self, seconds: f64) {
        self.config.min_interval_s = if seconds.is_finite() {
            seconds.max(0.0)
        } else {
            0.0
        };
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
        self.recent.clear();
        self.sent.clear();
        self.outbox.clear();
        self.paced.clear();
        self.queued.clear();
        self.resends.clear();
        self.resending = false;
        self.in_flight = None;
        self.shots.clear();
        // a companion computer powered by the vehicle's battery forgets the announced grid
        self.onboard = measurer(&self.config);
        self.kept.clear();
        self.last_capture_seq = None;
    }

    #[cfg(test)]
    /// Images taken since boot.
    pub(crate) fn image_count(&self) -> i32 {
        self.image_count
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
