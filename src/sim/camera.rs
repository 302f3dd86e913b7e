//! The simulated camera: a MAVLink camera component (component id 100) on each vehicle.
//!
//! It answers the MAVLink camera protocol (MAV_CMD_REQUEST_MESSAGE for CAMERA_INFORMATION and
//! CAMERA_CAPTURE_STATUS, MAV_CMD_IMAGE_START_CAPTURE with interval and count,
//! MAV_CMD_IMAGE_STOP_CAPTURE) and is triggered by the autopilot's mission items
//! (IMAGE_START_CAPTURE, DO_DIGICAM_CONTROL, DO_SET_CAM_TRIGG_DIST). Each capture renders the
//! view at the vehicle's true pose ([`crate::sim::render`]), encodes it as JPEG with the
//! capture's metadata in a COM segment ([`crate::vision::meta`]) and delivers it
//! - as CAMERA_IMAGE_CAPTURED (lat, lon, alt, image index, and a `file://` URL when a
//!   directory is configured: the shell writes the file before the message is sent), and
//! - by MAVLink image transmission: DATA_TRANSMISSION_HANDSHAKE (type JPEG, size, width,
//!   height, packets, payload 253) then the ENCAPSULATED_DATA packets, pushed after every
//!   capture and re-sent when the GCS asks with a DATA_TRANSMISSION_HANDSHAKE of its own
//!   (the request form of the image transmission protocol).
//!
//! Pacing ([`CameraConfig::transfer_rate_bps`]): by default the handshake and every packet
//! are queued at once, as the embedded simulator's vehicles have always done (their shell,
//! [`crate::sim::server`], paces UDP datagrams per vehicle: [`crate::sim::tx_queue`]).
//! With a rate, the image transmission leaves through a token bucket in bytes per second of
//! the camera's own clock (the `now` of [`SimCamera::update`] / [`SimCamera::advance`]):
//! each message costs its MAVLink 2 frame (10 header bytes, the payload, 2 CRC bytes: 267
//! bytes per ENCAPSULATED_DATA), the bucket holds [`PACE_BURST_S`] of the rate (at least one
//! frame), and [`SimCamera::poll_transmit`] only hands out what the bucket has released.
//! This is for a camera whose images go through a routing autopilot: ArduPilot forwards a
//! frame only when the outgoing port's transmit buffer has room for it and silently drops
//! it otherwise (`MAVLink_routing::check_and_forward`, `comm_get_txspace`), so a 60–100 KB
//! JPEG sent as one burst loses a large share of its packets. CAMERA_IMAGE_CAPTURED is never
//! held back by the pacing.
//!
//! Re-sends ([`SimCamera::handle_handshake_request`]): a GCS that missed packets asks for the
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
//! A degraded sensor ([`CameraConfig::misclassify_probability`]): each image, independently
//! and with that probability, shows the bandit field's green tiles as grey and its grey
//! tiles as green, as the bandit paper's degraded-sensor run (§V) added 5 % classification
//! noise to its measurements. The GCS is not told; [`CapturedImage::misclassified`] says it
//! for scoring.

use crate::sim::render::{CameraPose, Disturbances, render};
use crate::time::Time;
use crate::vision::camera::CameraModel;
use crate::vision::meta::{ImageMeta, insert_meta};
use crate::vision::onboard::{GreenSpec, OnboardMeasurement};
use crate::world::World;
use image::RgbImage;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;

pub use crate::proto::CAMERA_COMPID;
/// Bytes of image per ENCAPSULATED_DATA packet.
pub const PAYLOAD: usize = 253;
/// MAVLink 2 framing around a payload, bytes: 10 of header (magic, lengths, flags, sequence,
/// system, component, 3-byte message id) and a 2-byte CRC; unsigned.
pub const FRAME_OVERHEAD: usize = 12;
/// Capacity of the pacing token bucket, in seconds of the configured rate (never less than
/// one frame): the longest burst a paced camera sends after being idle. Zero: one frame at a
/// time. PX4 1.16 keeps only two messages waiting to be forwarded to another of its links
/// (`Mavlink::pass_message`: a ring of two, one passed on per loop of its GCS link, at least
/// 1.5 ms), so the three-frame bursts a 50 ms bucket allowed at 20 kB/s lost a frame now and
/// then: 9 of 199 packets through PX4 SITL's payload link.
pub const PACE_BURST_S: f64 = 0.0;

/// Most frames a paced camera sends back to back when its shell polls late: two, what PX4's
/// forwarding ring holds.
const PACE_MAX_BACK_TO_BACK: f64 = 2.0;

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
    /// Pace MAVLink image transmission to this many bytes per second of MAVLink 2 frames
    /// (header, payload and CRC; 267 bytes per ENCAPSULATED_DATA), on the camera's clock.
    /// `None` (the default) queues an image's handshake and all its packets at once.
    /// Values that are not finite and positive count as `None`.
    pub transfer_rate_bps: Option<f64>,
    /// A degraded sensor: the probability (0–1, per image) that a picture shows the other
    /// class of the bandit field — rendered with every green tile drawn as a grey tile and
    /// every grey tile as a green one ([`Disturbances::swap_tiles`]), so the GCS's unchanged
    /// green-share measurement reads 0 over a green tile and 1 over a grey one. Drawn
    /// independently for each image from the camera's seed and the image's name (vehicle,
    /// boot, index): the same seed flips the same images. The bandit paper's degraded-sensor
    /// hardware run (§V) added 5 % of such classification noise: 0.05. 0 (the default), a
    /// negative or a non-finite value: no image is flipped. Other surfaces are drawn as they
    /// are.
    pub misclassify_probability: f64,
    /// Measure every picture on board with this definition and send the measurement
    /// (DEBUG_FLOAT_ARRAY, [`crate::vision::onboard`]) after CAMERA_IMAGE_CAPTURED instead
    /// of pushing the picture: the picture is kept ([`RECENT_IMAGES`]) and sent when a GCS
    /// asks for it. `None` (the default): no measurement, pictures pushed as
    /// `mavlink_transfer` says.
    pub onboard: Option<GreenSpec>,
    /// The pictures come from outside (a real camera's folder, a video device) instead of
    /// the renderer: a capture becomes a [`Shot`] the shell takes with
    /// [`SimCamera::poll_shot`] and completes with [`SimCamera::deliver`].
    pub external: bool,
}

impl Default for CameraConfig {
    fn default() -> Self {
        CameraConfig {
            model: CameraModel::paper(),
            jpeg_quality: 85,
            mavlink_transfer: true,
            file_dir: None,
            min_interval_s: 0.2,
            transfer_rate_bps: None,
            misclassify_probability: 0.0,
            onboard: None,
            external: false,
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
/// pose the image was rendered at ([`crate::sim::render`] tilts the view by the same roll
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
/// [`SimCamera::deliver`].
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

/// How many recent images a camera keeps to send again on request.
pub const RECENT_IMAGES: usize = 16;

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
}

/// A token bucket in bytes per second on the camera's clock.
#[derive(Clone, Copy, Debug)]
struct Pacer {
    /// Bytes per second.
    rate: f64,
    /// Capacity, bytes.
    burst: f64,
    /// Bytes that may leave now.
    tokens: f64,
    /// When `tokens` was last brought up to date (None: never, the bucket starts full).
    at: Option<Time>,
    /// Whether frames were waiting at the last refill.
    busy: bool,
}

impl Pacer {
    /// The largest paced frame, bytes (an ENCAPSULATED_DATA).
    fn largest() -> f64 {
        (FRAME_OVERHEAD + mav::ENCAPSULATED_DATA_DATA::ENCODED_LEN) as f64
    }

    fn new(rate: f64) -> Pacer {
        let burst = (rate * PACE_BURST_S).max(Self::largest());
        Pacer {
            rate,
            burst,
            tokens: burst,
            at: None,
            busy: false,
        }
    }

    /// Add the tokens earned since the last refill. An idle bucket (`backlog` false) fills
    /// up to its capacity only; one with frames waiting keeps up to
    /// [`PACE_MAX_BACK_TO_BACK`] frames' worth (a shell that polls late loses that part of
    /// the rate rather than sending a burst an autopilot would drop).
    fn refill(&mut self, now: Time, backlog: bool) {
        if let Some(at) = self.at {
            if now <= at {
                return;
            }
            let dt = now.saturating_since(at).as_secs_f64();
            self.tokens += dt * self.rate;
            // Time spent idle (no backlog at the last refill) earns one burst at most, even
            // when frames have been queued since.
            let cap = if backlog && self.busy {
                PACE_MAX_BACK_TO_BACK * Self::largest()
            } else {
                self.burst
            };
            self.tokens = self.tokens.min(cap);
        }
        self.at = Some(now);
        self.busy = backlog;
    }
}

/// Bytes `msg` takes on the wire as an unsigned MAVLink 2 frame (payload untruncated).
fn frame_len(msg: &MavMessage) -> usize {
    FRAME_OVERHEAD
        + match msg {
            MavMessage::ENCAPSULATED_DATA(_) => mav::ENCAPSULATED_DATA_DATA::ENCODED_LEN,
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(_) => {
                mav::DATA_TRANSMISSION_HANDSHAKE_DATA::ENCODED_LEN
            }
            // only image transmission is paced; anything else costs its largest payload
            _ => 255,
        }
}

/// Whether the next paced message comes from the re-sends: the image leaving now goes on to
/// its last packet (from `resends` when `resending`, else from `paced`); at a boundary
/// between images a waiting re-send goes first.
fn resend_next(
    resends: &VecDeque<MavMessage>,
    paced: &VecDeque<MavMessage>,
    resending: bool,
) -> bool {
    let mid_image =
        |q: &VecDeque<MavMessage>| matches!(q.front(), Some(MavMessage::ENCAPSULATED_DATA(_)));
    if resending && mid_image(resends) {
        return true;
    }
    if !resending && mid_image(paced) {
        return false;
    }
    !resends.is_empty()
}

/// Keep `jpeg` as the newest of `store`, which holds at most [`RECENT_IMAGES`].
fn keep_recent(store: &mut VecDeque<Arc<Vec<u8>>>, jpeg: Arc<Vec<u8>>) {
    store.push_back(jpeg);
    if store.len() > RECENT_IMAGES {
        store.pop_front();
    }
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
            config,
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
        self.recent.clear();
        self.sent.clear();
        self.outbox.clear();
        self.paced.clear();
        self.queued.clear();
        self.resends.clear();
        self.resending = false;
        self.in_flight = None;
        self.shots.clear();
    }

    /// Images taken since boot.
    pub fn image_count(&self) -> i32 {
        self.image_count
    }

    /// Next message from the camera component: what is due as of the camera's clock (the
    /// last [`SimCamera::update`] or [`SimCamera::advance`]); a paced transmission's packets
    /// come out as the token bucket releases them.
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.outbox.pop_front()
    }

    /// Bring the camera's clock to `now` without a pose (no triggers run): the pacing bucket
    /// refills and releases the image packets due by then.
    pub fn advance(&mut self, now: Time) {
        let backlog = self.transfer_backlog() > 0;
        if let Some(p) = self.pacer.as_mut() {
            p.refill(now, backlog);
        }
        self.release();
    }

    /// When the next paced image packet can leave (None: nothing is waiting for the bucket).
    /// A shell that sleeps until then and calls [`SimCamera::advance`] keeps the rate.
    pub fn poll_timeout(&self) -> Option<Time> {
        let resend = resend_next(&self.resends, &self.paced, self.resending);
        let queue = if resend { &self.resends } else { &self.paced };
        let (p, front) = (self.pacer.as_ref()?, queue.front()?);
        let at = p.at?;
        let missing = frame_len(front) as f64 - p.tokens;
        if missing <= 0.0 {
            return Some(at);
        }
        // round up to the next microsecond so the bucket really holds the frame then
        Some(at + Duration::from_micros((missing / p.rate * 1e6).ceil() as u64))
    }

    /// Messages of image transmission still waiting for the pacing bucket (first
    /// transmissions and re-sends).
    pub fn transfer_backlog(&self) -> usize {
        self.paced.len() + self.resends.len()
    }

    /// Move what the bucket allows to the outbox: the image leaving now to its end, then a
    /// re-send if one waits, else the next queued image.
    fn release(&mut self) {
        let Some(p) = self.pacer.as_mut() else {
            return;
        };
        loop {
            let resend = resend_next(&self.resends, &self.paced, self.resending);
            let queue = if resend {
                &mut self.resends
            } else {
                &mut self.paced
            };
            let Some(front) = queue.front() else {
                break;
            };
            let cost = frame_len(front) as f64;
            // a tolerance for the rounding of the bucket's microsecond clock
            if p.tokens + 1e-6 < cost {
                break;
            }
            p.tokens -= cost;
            let Some(m) = queue.pop_front() else {
                break;
            };
            if let MavMessage::DATA_TRANSMISSION_HANDSHAKE(h) = &m {
                self.in_flight = Some(h.size);
                self.resending = resend;
                if !resend && let Some(j) = self.queued.pop_front() {
                    keep_recent(&mut self.sent, j);
                }
            }
            self.outbox.push_back(m);
        }
        if self.paced.is_empty() && self.resends.is_empty() {
            p.tokens = p.tokens.min(p.burst);
        }
    }

    /// Drop the captures due at `now` when there is no pose to render them from: pending
    /// pictures and interval shots that came due (distance triggering needs a position and
    /// does not run). Returns how many were dropped. The clock advances as in
    /// [`SimCamera::advance`].
    pub fn drop_due(&mut self, now: Time) -> u32 {
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
        self.release();
    }

    fn capture(&mut self, ctx: &CaptureContext, world: Option<&World>) {
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
        let img = world.map(|w| {
            let dist = Disturbances {
                swap_tiles: misclassified,
                ..Disturbances::draw(seed)
            };
            render(w, &ctx.true_pose, &self.config.model, ctx.world_t_s, &dist)
        });
        self.finish(shot, img.as_ref());
    }

    /// The next picture to take from outside ([`CameraConfig::external`]): get it and give
    /// it to [`SimCamera::deliver`]. Shots come out in the order they were fired.
    pub fn poll_shot(&mut self) -> Option<Shot> {
        self.shots.pop_front()
    }

    /// The picture of `shot` (None: the source had none: the capture failed), at `now`: the
    /// capture is announced (CAMERA_IMAGE_CAPTURED), measured when the camera measures on
    /// board, and sent or kept as a rendered one would be. A shot of an earlier boot is
    /// dropped.
    pub fn deliver(&mut self, shot: Shot, img: Option<&RgbImage>, now: Time) {
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
        let mut measured = None;
        if let Some(img) = img {
            // measured at the altitude the capture message reports, as the GCS would
            measured = self
                .config
                .onboard
                .map(|spec| (spec.fingerprint(), spec.measure(img, ctx.reported.2)));
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
        self.outbox.push_back(MavMessage::CAMERA_IMAGE_CAPTURED(
            mav::CAMERA_IMAGE_CAPTURED_DATA {
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
            },
        ));
        if let (Some(j), Some((spec, value))) = (&jpeg, measured) {
            self.outbox.push_back(
                OnboardMeasurement {
                    time_boot_ms: ctx.time_boot_ms,
                    image_index_lo: index as u16,
                    spec,
                    picture_bytes: j.len() as u32,
                    value,
                }
                .to_message(),
            );
        }
        if let Some(j) = &jpeg {
            if self.config.mavlink_transfer && measured.is_none() {
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

    /// Queue the first transmission of `jpeg` (paced: behind the images already queued).
    fn queue_transfer(&mut self, jpeg: &Arc<Vec<u8>>) {
        if self.pacer.is_some() {
            self.queued.push_back(jpeg.clone());
            let mut q = std::mem::take(&mut self.paced);
            self.transfer_messages(jpeg, &mut q);
            self.paced = q;
        } else {
            keep_recent(&mut self.sent, jpeg.clone());
            let mut q = std::mem::take(&mut self.outbox);
            self.transfer_messages(jpeg, &mut q);
            self.outbox = q;
        }
    }

    /// Queue a re-send of `jpeg` (paced: before the images still queued, after the one
    /// leaving now).
    fn queue_resend(&mut self, jpeg: &[u8]) {
        let mut q = if self.pacer.is_some() {
            std::mem::take(&mut self.resends)
        } else {
            std::mem::take(&mut self.outbox)
        };
        self.transfer_messages(jpeg, &mut q);
        if self.pacer.is_some() {
            self.resends = q;
        } else {
            self.outbox = q;
        }
    }

    /// The image transmission of `jpeg`: its DATA_TRANSMISSION_HANDSHAKE, then its
    /// ENCAPSULATED_DATA packets, appended to `queue`.
    fn transfer_messages(&self, jpeg: &[u8], queue: &mut VecDeque<MavMessage>) {
        let packets = jpeg.len().div_ceil(PAYLOAD);
        let model = self.config.model;
        let quality = self.config.jpeg_quality;
        queue.push_back(MavMessage::DATA_TRANSMISSION_HANDSHAKE(
            mav::DATA_TRANSMISSION_HANDSHAKE_DATA {
                size: jpeg.len() as u32,
                width: model.width_px as u16,
                height: model.height_px as u16,
                packets: packets as u16,
                mavtype: mav::MavlinkDataStreamType::MAVLINK_DATA_STREAM_IMG_JPEG,
                payload: PAYLOAD as u8,
                jpg_quality: quality,
            },
        ));
        for (i, chunk) in jpeg.chunks(PAYLOAD).enumerate() {
            let mut data = [0u8; PAYLOAD];
            data[..chunk.len()].copy_from_slice(chunk);
            queue.push_back(MavMessage::ENCAPSULATED_DATA(mav::ENCAPSULATED_DATA_DATA {
                seqnr: i as u16,
                data,
            }));
        }
    }

    /// A GCS's DATA_TRANSMISSION_HANDSHAKE asking for an image again (see the module
    /// documentation): the image of `size` bytes among those sent or captured lately, or the
    /// latest image when the request names no size (0). A size this camera does not hold is
    /// not answered: the request is for another camera behind the same autopilot port, or
    /// for a picture too old to keep. The re-send is paced like a first transmission and
    /// leaves before the images still queued; a request for an image whose transmission
    /// waits or is leaving is ignored (every autopilot on a shared port forwards the same
    /// request).
    pub fn handle_handshake_request(&mut self, size: u32) {
        let wanted = if size == 0 {
            self.last_jpeg.clone()
        } else {
            self.sent
                .iter()
                .rev()
                .chain(self.recent.iter().rev())
                .find(|j| j.len() == size as usize)
                .cloned()
        };
        let Some(j) = wanted else {
            return;
        };
        let size = j.len() as u32;
        let queued = self
            .paced
            .iter()
            .chain(&self.resends)
            .chain(&self.outbox)
            .any(|m| matches!(m, MavMessage::DATA_TRANSMISSION_HANDSHAKE(h) if h.size == size));
        let leaving_queue = if self.resending {
            &self.resends
        } else {
            &self.paced
        };
        let leaving = self.in_flight == Some(size)
            && matches!(
                leaving_queue.front(),
                Some(MavMessage::ENCAPSULATED_DATA(_))
            );
        if !(queued || leaving) {
            self.queue_resend(&j);
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

#[cfg(test)]
mod tests {
    use super::*;

    fn paced(rate: f64) -> SimCamera {
        SimCamera::new(
            1,
            CameraConfig {
                transfer_rate_bps: Some(rate),
                ..CameraConfig::default()
            },
            1,
        )
    }

    /// Run `cam` from `t0` in steps of `dt` until its paced queue is empty; returns each
    /// message with the time it came out.
    fn drain(cam: &mut SimCamera, t0: Time, dt: Duration) -> Vec<(Time, MavMessage)> {
        let mut out = Vec::new();
        let mut t = t0;
        for _ in 0..1_000_000 {
            cam.advance(t);
            while let Some(m) = cam.poll_transmit() {
                out.push((t, m));
            }
            if cam.transfer_backlog() == 0 {
                break;
            }
            t += dt;
        }
        out
    }

    /// Sizes announced by the handshakes waiting in `cam`'s paced queues, in the order they
    /// will leave.
    fn announced(cam: &SimCamera) -> Vec<u32> {
        let hs = |q: &VecDeque<MavMessage>| -> Vec<u32> {
            q.iter()
                .filter_map(|m| match m {
                    MavMessage::DATA_TRANSMISSION_HANDSHAKE(h) => Some(h.size),
                    _ => None,
                })
                .collect()
        };
        [hs(&cam.resends), hs(&cam.paced)].concat()
    }

    /// A request naming an image's size gets that image back, not the latest; a request that
    /// names none gets the latest; one naming a size the camera does not hold (another
    /// camera's picture) gets nothing; a paced copy still waiting is not queued twice.
    #[test]
    fn a_re_send_request_names_the_image_it_wants() {
        let cfg = CameraConfig {
            transfer_rate_bps: Some(20_000.0),
            ..CameraConfig::default()
        };
        let mut cam = SimCamera::new(1, cfg, 1);
        let (old, new) = (Arc::new(vec![1u8; 3_000]), Arc::new(vec![2u8; 5_000]));
        cam.recent.extend([old.clone(), new.clone()]);
        cam.last_jpeg = Some(new.clone());
        cam.handle_handshake_request(3_000);
        assert_eq!(announced(&cam), vec![3_000]);
        cam.handle_handshake_request(3_000);
        assert_eq!(announced(&cam), vec![3_000], "queued once");
        cam.handle_handshake_request(4_444);
        assert_eq!(announced(&cam), vec![3_000], "not this camera's picture");
        cam.handle_handshake_request(0);
        assert_eq!(announced(&cam), vec![3_000, 5_000]);
    }

    /// A paced camera with a queue: the image being sent was captured long before the
    /// latest captures, and a request for it is still answered — after the image leaving
    /// now, before the queued ones — and is not answered twice while it leaves.
    #[test]
    fn a_re_send_goes_between_images_ahead_of_the_queue() {
        let mut cam = paced(2_670.0); // ten packets a second
        let t0 = Time::from_secs(1);
        cam.advance(t0);
        // the first picture and 2 × RECENT_IMAGES more queued behind it
        let pictures: Vec<Arc<Vec<u8>>> = (0..=2 * RECENT_IMAGES)
            .map(|k| Arc::new(vec![k as u8; 3 * PAYLOAD + 10 + k]))
            .collect();
        for p in &pictures {
            cam.queue_transfer(p);
            keep_recent(&mut cam.recent, p.clone());
        }
        // half of the first picture leaves: its handshake, then two packets
        let mut out = Vec::new();
        while out.len() < 3 {
            let t = cam.poll_timeout().expect("packets wait");
            cam.advance(t);
            out.extend(std::iter::from_fn(|| cam.poll_transmit()));
        }
        let first = pictures[0].len() as u32;
        assert_eq!(cam.in_flight, Some(first));
        assert!(
            !cam.recent.iter().any(|j| j.len() as u32 == first),
            "captured too long ago"
        );
        // asked for while it is still leaving (every autopilot forwards the request): nothing
        cam.handle_handshake_request(first);
        assert_eq!(cam.resends.len(), 0);
        // the rest of it (4 packets in all) leaves, then the request comes again: the
        // re-send goes next
        while out.len() < 5 {
            let t = cam.poll_timeout().expect("packets wait");
            cam.advance(t);
            out.extend(std::iter::from_fn(|| cam.poll_transmit()));
        }
        assert_eq!(out.len(), 5);
        cam.handle_handshake_request(first);
        cam.handle_handshake_request(first);
        assert_eq!(announced(&cam)[..2], [first, pictures[1].len() as u32]);
        // … once the first picture's last packet is out
        let sizes: Vec<u32> = std::iter::from_fn(|| {
            let t = cam.poll_timeout()?;
            cam.advance(t);
            Some(std::iter::from_fn(|| cam.poll_transmit()).collect::<Vec<_>>())
        })
        .flatten()
        .filter_map(|m| match m {
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(h) => Some(h.size),
            _ => None,
        })
        .collect();
        assert_eq!(sizes[..2], [first, pictures[1].len() as u32], "{sizes:?}");
        assert_eq!(sizes.len(), 2 * RECENT_IMAGES + 1);
        // a request now for the first picture: sent long ago, no longer kept
        cam.handle_handshake_request(first);
        assert_eq!(cam.transfer_backlog(), 0);
    }

    /// PX4 forwards two messages at a time: after an idle spell a paced camera starts with one
    /// frame, and a shell that polls late gets at most two frames back to back.
    #[test]
    fn paced_frames_never_leave_more_than_two_back_to_back() {
        let mut cam = paced(20_000.0);
        let t0 = Time::from_secs(10);
        cam.advance(t0);
        cam.last_jpeg = Some(Arc::new(vec![7u8; 20 * PAYLOAD]));
        cam.handle_handshake_request(0);
        // 10 s idle before the first poll: one frame's worth, the handshake (25 bytes) leaves
        // and packet 0 (267) waits for the rest
        cam.advance(t0 + Duration::from_secs(10));
        let first: Vec<_> = std::iter::from_fn(|| cam.poll_transmit()).collect();
        assert_eq!(first.len(), 1, "{first:?}");
        assert!(matches!(
            first[0],
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(_)
        ));
        // a poll 5 s late releases two frames, not 5 s of the rate
        cam.advance(t0 + Duration::from_secs(15));
        let late: Vec<_> = std::iter::from_fn(|| cam.poll_transmit()).collect();
        assert_eq!(late.len(), 2, "{late:?}");
        // on time, one frame per 267 / 20 000 s
        let due = cam.poll_timeout().expect("packets wait");
        cam.advance(due);
        assert_eq!(std::iter::from_fn(|| cam.poll_transmit()).count(), 1);
    }

    #[test]
    fn unpaced_transfer_is_queued_at_once() {
        let mut cam = SimCamera::new(1, CameraConfig::default(), 1);
        cam.last_jpeg = Some(Arc::new(vec![7u8; 10_000]));
        cam.handle_handshake_request(0);
        assert_eq!(cam.transfer_backlog(), 0);
        assert_eq!(cam.poll_timeout(), None);
        let n = std::iter::from_fn(|| cam.poll_transmit()).count();
        assert_eq!(n, 1 + 10_000usize.div_ceil(PAYLOAD));
    }

    #[test]
    fn paced_transfer_keeps_the_rate_and_sends_everything() {
        let rate = 5_000.0;
        let mut cam = paced(rate);
        let t0 = Time::from_secs(10);
        cam.advance(t0);
        cam.last_jpeg = Some(Arc::new((0..10_000u32).map(|i| i as u8).collect()));
        cam.handle_handshake_request(0);
        let packets = 10_000usize.div_ceil(PAYLOAD);
        assert_eq!(cam.transfer_backlog(), packets + 1);
        let out = drain(&mut cam, t0, Duration::from_millis(10));
        assert_eq!(out.len(), packets + 1);
        assert!(matches!(
            out[0].1,
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(_)
        ));
        let seqs: Vec<u16> = out
            .iter()
            .filter_map(|(_, m)| match m {
                MavMessage::ENCAPSULATED_DATA(d) => Some(d.seqnr),
                _ => None,
            })
            .collect();
        assert_eq!(seqs, (0..packets as u16).collect::<Vec<_>>());
        // never more than the bucket plus the rate over any prefix
        let burst = (rate * PACE_BURST_S).max(267.0);
        let mut bytes = 0.0;
        for (t, m) in &out {
            bytes += frame_len(m) as f64;
            let allowed = burst + rate * t.saturating_since(t0).as_secs_f64();
            assert!(bytes <= allowed + 1e-6, "{bytes} bytes by {t}");
        }
        let total = 25.0 + 267.0 * packets as f64;
        let took = out
            .last()
            .map(|(t, _)| t.saturating_since(t0).as_secs_f64())
            .unwrap_or(0.0);
        let expect = (total - burst) / rate;
        assert!(
            (took - expect).abs() <= 0.02,
            "took {took} s, expected {expect} s"
        );
    }

    #[test]
    fn poll_timeout_says_when_the_next_packet_leaves() {
        let mut cam = paced(2_670.0); // one ENCAPSULATED_DATA frame per 0.1 s
        let t0 = Time::from_secs(1);
        cam.advance(t0);
        cam.last_jpeg = Some(Arc::new(vec![1u8; 5 * PAYLOAD]));
        cam.handle_handshake_request(0);
        cam.advance(t0);
        // the bucket held one frame: the handshake (25 bytes) left, packet 0 waits
        let first: Vec<_> = std::iter::from_fn(|| cam.poll_transmit()).collect();
        assert_eq!(first.len(), 1);
        let due = cam.poll_timeout().expect("a packet is waiting");
        let wait = due.saturating_since(t0).as_secs_f64();
        assert!((wait - 25.0 / 2_670.0).abs() < 1e-4, "{wait}");
        cam.advance(due - Duration::from_micros(50));
        assert!(cam.poll_transmit().is_none());
        cam.advance(due);
        assert!(matches!(
            cam.poll_transmit(),
            Some(MavMessage::ENCAPSULATED_DATA(d)) if d.seqnr == 0
        ));
    }

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

    /// Take `n` 16-pixel pictures over a flat green field with a sensor that misclassifies
    /// with probability `p`; returns which of them were flipped.
    fn flips(p: f64, n: usize, seed: u64) -> Vec<bool> {
        let world = World::flat(crate::world::Surface::GreenTile, (37.0, -80.0), 100.0);
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
