//! The GCS's image intake (async shell): every picture the fleet takes, whichever way it
//! arrives, as one stream of [`ReceivedImage`]s.
//!
//! Two ways in, as the MAVLink camera protocol allows
//! (<https://mavlink.io/en/services/camera.html>, <https://mavlink.io/en/services/image_transmission.html>):
//! * **image transmission**: DATA_TRANSMISSION_HANDSHAKE + ENCAPSULATED_DATA from a camera
//!   component, reassembled by one [`ImageReceiver`] per camera (it asks again for images
//!   with missing packets);
//! * **file URLs**: CAMERA_IMAGE_CAPTURED with a `file://` URL (a camera that writes to a
//!   directory the GCS can read: a Wi-Fi camera's mount, or `fleetmap sim --image-dir`).
//!
//! A capture that arrives both ways is delivered once: captures are named by (system,
//! time_boot_ms, image_index) — from CAMERA_IMAGE_CAPTURED, or from the metadata the JPEG
//! carries ([`fleetmap_core::vision::meta`]).
//!
//! **On-board measurements** ([`fleetmap_core::vision::onboard::Onboard`], any of the list's:
//! the green share, the runway's cell and five region counts): a camera that measures its
//! pictures itself sends, after a capture's CAMERA_IMAGE_CAPTURED, a DEBUG_FLOAT_ARRAY with
//! its result, and keeps the picture. A run accepts one definition per measurement
//! ([`ImageHub::accept_onboard`], by fingerprint), and may have it announced to the cameras
//! until each confirms it (`announce`: the runway's grid, which a camera may not know). A
//! result made with the accepted definition is delivered as a [`ReceivedImage`] without
//! bytes ([`ReceivedImage::onboard`]); for any other (a camera without the grid, or with
//! another definition) the intake asks the camera for the picture (a
//! DATA_TRANSMISSION_HANDSHAKE naming its size) and the picture is delivered when it
//! arrives. A runner may ask for a picture it has the result of ([`ImageHub::ask_picture`],
//! an audit): it comes back to the one who asked, never on the stream.
//!
//! **Pose** ([`CapturePose`]): where the camera says it took the picture. CAMERA_IMAGE_CAPTURED
//! (the camera protocol's record of the shutter: lat, lon, relative_alt, attitude `q`) is
//! remembered by its capture name, and an image that arrives by image transmission carrying
//! the same name in its JPEG metadata gets that record's position, altitude and attitude; the
//! JPEG's own metadata fills in what the message lacks (its heading is the camera's) and is the
//! whole pose when no message was heard. The runners check this pose before a picture counts
//! ([`fleetmap_core::vision::sanity`]).

use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::image_transfer::{
    FileUrlError, ImageEvent, ImageReceiver, ReceiverConfig, request_image,
};
use fleetmap_core::time::Time;
use fleetmap_core::vision::meta::{ImageMeta, read_meta};
use fleetmap_core::vision::onboard::{Onboard, OnboardKind};
use mavlink::dialects::ardupilotmega::{CAMERA_IMAGE_CAPTURED_DATA, MavMessage};
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

pub(crate) mod announce;
mod hub;
use self::announce::Announcer;
pub use self::announce::{Announcement, OnboardAccept};
pub use self::hub::{ImageHub, image_hub, spawn};

/// An image that did not arrive, and why: what the intake logs (its `Display` is the log
/// line) and what [`Intake::failures`] holds.
#[derive(Debug, thiserror::Error)]
pub enum ImageFailure {
    /// CAMERA_IMAGE_CAPTURED said the capture failed.
    #[error("vehicle {sysid}: camera reports capture {image_index} failed")]
    CaptureFailed {
        /// The vehicle (system id).
        sysid: u8,
        /// The camera's image index of the failed capture.
        image_index: i32,
    },
    /// The file a CAMERA_IMAGE_CAPTURED URL names could not be read.
    #[error("vehicle {sysid}: {source}")]
    File {
        /// The vehicle (system id).
        sysid: u8,
        /// Why the file was not read.
        source: FileUrlError,
    },
    /// An image transmission gave up with packets missing.
    #[error("vehicle {sysid}: image of {size} bytes lost ({received} of {packets} packets)")]
    Lost {
        /// The vehicle (system id).
        sysid: u8,
        /// The image's announced size, bytes.
        size: u32,
        /// Packets received.
        received: u16,
        /// Packets announced.
        packets: u16,
    },
}

/// A picture a camera wrote to a file (CAMERA_IMAGE_CAPTURED with a `file://` URL) that the
/// intake wants read: the driving task reads it off the runtime's workers
/// ([`tokio::task::spawn_blocking`]) and hands the bytes back ([`Intake::file_read`]).
#[derive(Clone, Debug)]
pub(crate) struct FileRead {
    /// The `file://` URL.
    pub url: String,
    /// The capture: (system, time_boot_ms, image_index).
    key: CaptureKey,
    /// The pose CAMERA_IMAGE_CAPTURED gave.
    pose: CapturePose,
    /// When the message was heard (the image's `received` time).
    heard: Time,
}

/// Largest image file read from a URL, bytes.
pub(crate) const MAX_IMAGE_FILE: u64 = 64 << 20;

/// Where and when the camera says a capture was taken (CAMERA_IMAGE_CAPTURED or the JPEG's
/// metadata).
#[derive(Clone, Debug, PartialEq)]
pub struct CapturePose {
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude above home, metres.
    pub alt_rel_m: f64,
    /// Heading (image up), degrees clockwise from north, when known.
    pub heading_deg: Option<f64>,
    /// Attitude at the shutter from CAMERA_IMAGE_CAPTURED.q (`[w, x, y, z]`, body → NED:
    /// roll, pitch and yaw of the airframe for a camera without a gimbal), when the message
    /// was heard and `q` is a rotation ([`fleetmap_core::vision::geometry::attitude_of_quaternion`]).
    pub q: Option<[f32; 4]>,
    /// Milliseconds since the vehicle booted.
    pub time_boot_ms: u32,
    /// The camera's image index (restarts at every boot).
    pub image_index: i32,
}

/// One image, as the GCS received it.
#[derive(Clone, Debug)]
pub struct ReceivedImage {
    /// The vehicle (system id).
    pub sysid: u8,
    /// The JPEG (or other encoded image) bytes; empty when the camera measured the picture on
    /// board and kept it (`onboard`).
    pub bytes: Arc<Vec<u8>>,
    /// The camera's own measurement of the picture, with a definition the run accepts
    /// ([`ImageHub::accept_onboard`]; [`Onboard::get`] gives the measurement's own type).
    pub onboard: Option<Onboard>,
    /// The capture pose, when the camera told it.
    pub pose: Option<CapturePose>,
    /// When it was complete, on the fleet's clock.
    pub received: Time,
    /// How it came: `"mavlink"`, `"on board"` (a measurement only) or the file path.
    pub source: String,
}

/// A capture counted as delivered: (system, time_boot_ms, image_index).
type CaptureKey = (u8, u32, i32);

/// A definition the run accepts results of, and its announcements to the cameras.
#[derive(Debug)]
struct Accepted {
    fingerprint: u32,
    announcer: Option<Announcer>,
}

/// Pictures asked for by [`Intake::want_picture`] and not arrived, at most this many (the
/// oldest is forgotten).
const WANTED_KEPT: usize = 32;

/// CAMERA_IMAGE_CAPTURED records kept for images still in transfer: a few hundred captures
/// (ten drones' batches of ten images, several times over).
const CAPTURED_KEPT: usize = 512;
/// On-board measurements kept while their CAMERA_IMAGE_CAPTURED has not arrived (a reordered
/// or delayed link); the oldest is dropped beyond.
const MEASURED_KEPT: usize = 256;

fn pose_of_meta(m: &ImageMeta) -> CapturePose {
    CapturePose {
        lat: m.lat,
        lon: m.lon,
        alt_rel_m: m.alt_rel_m,
        heading_deg: Some(m.heading_deg),
        q: None,
        time_boot_ms: m.time_boot_ms,
        image_index: m.image_index,
    }
}

/// The pose in a CAMERA_IMAGE_CAPTURED message (position in degE7, altitude in mm).
fn pose_of_captured(c: &CAMERA_IMAGE_CAPTURED_DATA) -> CapturePose {
    let q = fleetmap_core::vision::geometry::attitude_of_quaternion(c.q).map(|_| c.q);
    CapturePose {
        lat: f64::from(c.lat) * 1e-7,
        lon: f64::from(c.lon) * 1e-7,
        alt_rel_m: f64::from(c.relative_alt) / 1000.0,
        heading_deg: q.and_then(yaw_of_quaternion),
        q,
        time_boot_ms: c.time_boot_ms,
        image_index: c.image_index,
    }
}

/// The pose of a capture named both by CAMERA_IMAGE_CAPTURED (`captured`) and by the
/// JPEG's metadata (`meta`): the message's position, altitude and attitude (the camera
/// protocol's record of the shutter), the metadata's heading (the camera's own).
fn merge_poses(captured: &CapturePose, meta: &ImageMeta) -> CapturePose {
    CapturePose {
        heading_deg: Some(meta.heading_deg),
        ..captured.clone()
    }
}

/// Yaw (degrees clockwise from north, 0..360) of an attitude quaternion [w, x, y, z] (NED).
fn yaw_of_quaternion(q: [f32; 4]) -> Option<f64> {
    let [w, x, y, z] = q.map(f64::from);
    let n = (w * w + x * x + y * y + z * z).sqrt();
    if !(n.is_finite() && n > 1e-6) {
        return None;
    }
    let yaw = (2.0 * (w * z + x * y)).atan2(1.0 - 2.0 * (y * y + z * z));
    Some(yaw.to_degrees().rem_euclid(360.0))
}

/// The image intake's state (pure; the task in [`spawn`] drives it).
#[derive(Debug)]
pub struct Intake {
    gcs: Endpoint,
    config: ReceiverConfig,
    /// One receiver per camera, in endpoint order (the order their timers and sends run in:
    /// the same every run).
    receivers: BTreeMap<Endpoint, ImageReceiver>,
    delivered: VecDeque<CaptureKey>,
    /// CAMERA_IMAGE_CAPTURED poses of the latest captures (for images that arrive by image
    /// transmission, whose JPEG metadata names the capture), at most [`CAPTURED_KEPT`].
    captured: VecDeque<(CaptureKey, CapturePose)>,
    /// On-board measurements whose CAMERA_IMAGE_CAPTURED has not arrived: (camera, measurement).
    measured: VecDeque<(Endpoint, Onboard)>,
    /// The definition the run accepts of each on-board measurement, and its announcements
    /// (a measurement without one: each result is replaced by its picture).
    accepted: BTreeMap<OnboardKind, Accepted>,
    /// Pictures asked for whose results were delivered: (system, time_boot_ms, image_index).
    wanted: VecDeque<CaptureKey>,
    /// Pictures asked for that arrived.
    asked: VecDeque<(CaptureKey, ReceivedImage)>,
    /// Requests for pictures to send to cameras.
    requests: VecDeque<(Endpoint, MavMessage)>,
    /// Files named by CAMERA_IMAGE_CAPTURED, to read ([`Intake::poll_file_read`]).
    reads: VecDeque<FileRead>,
    out: VecDeque<ReceivedImage>,
    /// Images that did not arrive (failed captures, unreadable files, lost transfers).
    pub failures: VecDeque<ImageFailure>,
}

impl Intake {
    /// An intake answering as `gcs`.
    pub fn new(gcs: Endpoint) -> Intake {
        Intake::with_config(gcs, ReceiverConfig::default())
    }

    /// An intake whose image receivers use `config` (their timers run on the fleet's
    /// clock: a clock sped up for a simulator needs a longer `idle`).
    pub(crate) fn with_config(gcs: Endpoint, config: ReceiverConfig) -> Intake {
        Intake {
            gcs,
            config,
            receivers: BTreeMap::new(),
            delivered: VecDeque::new(),
            captured: VecDeque::new(),
            measured: VecDeque::new(),
            accepted: BTreeMap::new(),
            wanted: VecDeque::new(),
            asked: VecDeque::new(),
            requests: VecDeque::new(),
            reads: VecDeque::new(),
            out: VecDeque::new(),
            failures: VecDeque::new(),
        }
    }

    /// Use the cameras' results of measurement `kind` made with `accept`'s definition,
    /// announcing it to them from `now` on when it says so (`announce`); `None`: ask for
    /// the picture of every result of `kind`.
    pub fn accept_onboard(&mut self, kind: OnboardKind, accept: Option<OnboardAccept>, now: Time) {
        match accept {
            Some(a) => {
                let accepted = Accepted {
                    fingerprint: a.fingerprint,
                    announcer: a.announce.map(|m| Announcer::new(a.fingerprint, m, now)),
                };
                self.accepted.insert(kind, accepted);
            }
            None => {
                self.accepted.remove(&kind);
            }
        }
    }

    /// Whether the camera of vehicle `sysid` confirmed the announced definition of
    /// measurement `kind`.
    pub fn confirmed(&self, kind: OnboardKind, sysid: u8) -> bool {
        self.accepted
            .get(&kind)
            .and_then(|a| a.announcer.as_ref())
            .is_some_and(|a| a.is_confirmed(sysid))
    }

    /// Ask the camera of vehicle `sysid` for the picture of `size` bytes it took at
    /// `time_boot_ms` as `image_index` (one whose on-board result was delivered): it is
    /// given back by [`Intake::poll_asked`], not as a received image.
    pub fn want_picture(&mut self, sysid: u8, time_boot_ms: u32, image_index: i32, size: u32) {
        let key = (sysid, time_boot_ms, image_index);
        if !self.wanted.contains(&key) {
            self.wanted.push_back(key);
            if self.wanted.len() > WANTED_KEPT {
                self.wanted.pop_front();
            }
        }
        let cam = Endpoint::new(sysid, fleetmap_core::proto::CAMERA_COMPID);
        self.requests.push_back((cam, request_image(size, 0, 0)));
    }

    /// The next picture asked for with [`Intake::want_picture`] that arrived.
    pub fn poll_asked(&mut self) -> Option<((u8, u32, i32), ReceivedImage)> {
        self.asked.pop_front()
    }

    /// An on-board measurement `m` from camera `cam` whose capture's pose is `pose`: delivered
    /// when its definition is the accepted one, else the picture is asked for.
    fn measured(&mut self, cam: Endpoint, m: Onboard, pose: CapturePose, now: Time) {
        let key = (cam.sysid, pose.time_boot_ms, pose.image_index);
        if self.delivered.contains(&key) {
            return;
        }
        let accepted = m.has_result()
            && self
                .accepted
                .get(&m.kind())
                .is_some_and(|a| a.fingerprint == m.spec());
        if accepted {
            self.seen(key);
            self.out.push_back(ReceivedImage {
                sysid: cam.sysid,
                bytes: Arc::new(Vec::new()),
                onboard: Some(m),
                pose: Some(pose),
                received: now,
                source: "on board".into(),
            });
            return;
        }
        // Measured with another definition (or not at all): measure the picture here. It
        // arrives by image transmission with the capture's name in its metadata, and takes
        // this pose.
        self.remember_pose(key, pose);
        self.requests
            .push_back((cam, request_image(m.picture_bytes(), 0, 0)));
    }

    fn remember_pose(&mut self, key: CaptureKey, pose: CapturePose) {
        self.captured.retain(|(k, _)| *k != key);
        self.captured.push_back((key, pose));
        if self.captured.len() > CAPTURED_KEPT {
            self.captured.pop_front();
        }
    }

    fn seen(&mut self, key: CaptureKey) -> bool {
        if self.delivered.contains(&key) {
            return true;
        }
        self.delivered.push_back(key);
        if self.delivered.len() > 4096 {
            self.delivered.pop_front();
        }
        false
    }

    /// Feed one received message from `from` at `now`.
    pub fn handle_message(&mut self, from: Endpoint, msg: &MavMessage, now: Time) {
        match msg {
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(_) | MavMessage::ENCAPSULATED_DATA(_) => {
                let (gcs, config) = (self.gcs, self.config);
                let rx = self
                    .receivers
                    .entry(from)
                    .or_insert_with(|| ImageReceiver::new(from, gcs, config));
                rx.handle_message(from, msg, now);
                self.drain(from, now);
            }
            MavMessage::DEBUG_FLOAT_ARRAY(d) => {
                let Some(m) = Onboard::from_message(d) else {
                    return;
                };
                if let Some(a) = self
                    .accepted
                    .get_mut(&m.kind())
                    .and_then(|a| a.announcer.as_mut())
                {
                    a.heard(from.sysid, m.spec(), now);
                }
                if m.capture().is_none() {
                    return; // a status: about no picture
                }
                let pose = self
                    .captured
                    .iter()
                    .find(|(k, _)| k.0 == from.sysid && m.is_of(k.1, k.2))
                    .map(|(_, p)| p.clone());
                match pose {
                    Some(p) => self.measured(from, m, p, now),
                    None => {
                        self.measured.push_back((from, m));
                        if self.measured.len() > MEASURED_KEPT {
                            self.measured.pop_front();
                        }
                    }
                }
            }
            MavMessage::CAMERA_IMAGE_CAPTURED(c) => {
                if c.capture_result != mavlink::dialects::ardupilotmega::MavBool::MAV_BOOL_TRUE {
                    self.failures.push_back(ImageFailure::CaptureFailed {
                        sysid: from.sysid,
                        image_index: c.image_index,
                    });
                    return;
                }
                let url: String = c
                    .file_url
                    .iter()
                    .map(|&b| b as char)
                    .take_while(|&ch| ch != '\0')
                    .collect();
                let key = (from.sysid, c.time_boot_ms, c.image_index);
                if self.delivered.contains(&key) {
                    return;
                }
                let pose = pose_of_captured(c);
                if !url.starts_with("file://") {
                    // The image comes by image transmission, as an on-board measurement, or
                    // not at all: keep the pose for it.
                    let early = self.measured.iter().position(|(cam, m)| {
                        *cam == from && m.is_of(c.time_boot_ms, c.image_index)
                    });
                    match early.and_then(|i| self.measured.remove(i)) {
                        Some((cam, m)) => self.measured(cam, m, pose, now),
                        None => self.remember_pose(key, pose),
                    }
                    return;
                }
                self.reads.push_back(FileRead {
                    url,
                    key,
                    pose,
                    heard: now,
                });
            }
            _ => {}
        }
    }

    /// The next file to read ([`FileRead`]): read it (at most [`MAX_IMAGE_FILE`] bytes,
    /// [`fleetmap_io::files::read_file_url`]) and hand the result to [`Intake::file_read`].
    pub(crate) fn poll_file_read(&mut self) -> Option<FileRead> {
        self.reads.pop_front()
    }

    /// The outcome of reading `read`'s file: the image, or a failure.
    pub(crate) fn file_read(&mut self, read: FileRead, bytes: Result<Vec<u8>, FileUrlError>) {
        let FileRead {
            url,
            key,
            pose,
            heard,
        } = read;
        match bytes {
            Ok(bytes) => {
                if self.seen(key) {
                    return;
                }
                // The JPEG's own metadata, when present, has the camera's heading.
                let pose = read_meta(&bytes)
                    .filter(|m| m.image_index == key.2)
                    .map(|m| merge_poses(&pose, &m))
                    .unwrap_or(pose);
                self.out.push_back(ReceivedImage {
                    sysid: key.0,
                    bytes: Arc::new(bytes),
                    onboard: None,
                    pose: Some(pose),
                    received: heard,
                    source: url,
                });
            }
            Err(source) => self.failures.push_back(ImageFailure::File {
                sysid: key.0,
                source,
            }),
        }
    }

    fn drain(&mut self, cam: Endpoint, now: Time) {
        let mut done = Vec::new();
        if let Some(rx) = self.receivers.get_mut(&cam) {
            while let Some(ev) = rx.poll_event() {
                done.push(ev);
            }
        }
        for ev in done {
            match ev {
                ImageEvent::Image { jpeg, meta, .. } => {
                    let key = meta
                        .as_ref()
                        .map(|m| (cam.sysid, m.time_boot_ms, m.image_index));
                    if let Some(i) = key.and_then(|k| self.wanted.iter().position(|w| *w == k))
                        && let (Some(key), Some(m)) = (self.wanted.remove(i), &meta)
                    {
                        // asked for by a runner that has its result: back to it alone
                        self.asked.push_back((
                            key,
                            ReceivedImage {
                                sysid: cam.sysid,
                                bytes: Arc::new(jpeg),
                                onboard: None,
                                pose: Some(pose_of_meta(m)),
                                received: now,
                                source: "mavlink (asked for)".into(),
                            },
                        ));
                        continue;
                    }
                    if let Some(k) = key
                        && self.seen(k)
                    {
                        continue;
                    }
                    let pose = meta.as_ref().map(|m| {
                        let key = (cam.sysid, m.time_boot_ms, m.image_index);
                        let i = self.captured.iter().position(|(k, _)| *k == key);
                        match i.and_then(|i| self.captured.remove(i)) {
                            Some((_, p)) => merge_poses(&p, m),
                            None => pose_of_meta(m),
                        }
                    });
                    self.out.push_back(ReceivedImage {
                        sysid: cam.sysid,
                        bytes: Arc::new(jpeg),
                        onboard: None,
                        pose,
                        received: now,
                        source: "mavlink".into(),
                    });
                }
                ImageEvent::Lost {
                    size,
                    received,
                    packets,
                } => self.failures.push_back(ImageFailure::Lost {
                    sysid: cam.sysid,
                    size,
                    received,
                    packets,
                }),
            }
        }
    }

    /// The earliest time [`Intake::handle_timeout`] should run.
    pub fn poll_timeout(&self) -> Option<Time> {
        self.receivers
            .values()
            .filter_map(ImageReceiver::poll_timeout)
            .chain(
                self.accepted
                    .values()
                    .filter_map(|a| a.announcer.as_ref()?.poll_timeout()),
            )
            .min()
    }

    /// Run the receivers' timers, and announce an accepted definition when it is due.
    pub fn handle_timeout(&mut self, now: Time) {
        for a in self.accepted.values_mut() {
            if let Some(m) = a.announcer.as_mut().and_then(|a| a.handle_timeout(now)) {
                // untargeted: every camera behind every link hears it
                self.requests.push_back((Endpoint::new(0, 0), m));
            }
        }
        let cams: Vec<Endpoint> = self.receivers.keys().copied().collect();
        for cam in cams {
            if let Some(rx) = self.receivers.get_mut(&cam) {
                rx.handle_timeout(now);
            }
            self.drain(cam, now);
        }
    }

    /// Messages to send: (camera, message).
    pub fn poll_transmit(&mut self) -> Option<(Endpoint, MavMessage)> {
        if let Some(r) = self.requests.pop_front() {
            return Some(r);
        }
        for (cam, rx) in &mut self.receivers {
            if let Some(m) = rx.poll_transmit() {
                return Some((*cam, m));
            }
        }
        None
    }

    /// The next complete image.
    pub fn poll_image(&mut self) -> Option<ReceivedImage> {
        self.out.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn yaw_of_identity_and_east() {
        assert_eq!(yaw_of_quaternion([1.0, 0.0, 0.0, 0.0]), Some(0.0));
        let h = std::f32::consts::FRAC_PI_4; // 90° yaw: w = cos 45°, z = sin 45°
        let y = yaw_of_quaternion([h.cos(), 0.0, 0.0, h.sin()]).unwrap();
        assert!((y - 90.0).abs() < 1e-4, "{y}");
        assert_eq!(yaw_of_quaternion([0.0; 4]), None);
    }

    fn transfer(jpeg: &[u8]) -> Vec<MavMessage> {
        fleetmap_core::proto::image_transfer::transmission(jpeg, 4, 4, 80)
    }

    /// An image sent by image transmission gets the position, altitude and attitude of the
    /// CAMERA_IMAGE_CAPTURED that names the same capture; the JPEG's heading stays.
    #[test]
    fn transmitted_images_take_the_capture_message_pose() {
        use fleetmap_core::vision::meta::insert_meta;
        use mavlink::dialects::ardupilotmega as mav;
        let meta = ImageMeta {
            sysid: 1,
            boot: 1,
            image_index: 7,
            time_boot_ms: 123_456,
            lat: 37.0,
            lon: -80.0,
            alt_rel_m: 12.0,
            heading_deg: 90.0,
            width: 4,
            height: 4,
        };
        let mut raw = vec![0xFF, 0xD8];
        raw.extend((0..600u32).map(|i| (i % 200) as u8));
        let jpeg = insert_meta(&raw, &meta).unwrap();
        let c = fleetmap_core::vision::geometry::attitude_from_euler_deg(2.0, -3.0, 90.0).coords;
        let q = [c.w as f32, c.x as f32, c.y as f32, c.z as f32];
        let cic = |index: i32| {
            MavMessage::CAMERA_IMAGE_CAPTURED(mav::CAMERA_IMAGE_CAPTURED_DATA {
                time_utc: 0,
                time_boot_ms: 123_456,
                lat: 370_003_000,
                lon: -800_000_000,
                alt: 612_000,
                relative_alt: 11_500,
                q,
                image_index: index,
                camera_id: 0,
                capture_result: mav::MavBool::MAV_BOOL_TRUE,
                file_url: "".into(),
            })
        };
        let cam = Endpoint::new(1, fleetmap_core::proto::CAMERA_COMPID);
        let mut intake = Intake::new(Endpoint::gcs());
        // another capture's record first, then this one's
        intake.handle_message(cam, &cic(6), Time::ZERO);
        intake.handle_message(cam, &cic(7), Time::ZERO);
        assert!(intake.poll_image().is_none());
        for m in transfer(&jpeg) {
            intake.handle_message(cam, &m, Time::ZERO);
        }
        let img = intake.poll_image().unwrap();
        let p = img.pose.unwrap();
        assert!((p.lat - 37.0003).abs() < 1e-9, "{}", p.lat);
        assert!((p.alt_rel_m - 11.5).abs() < 1e-9);
        assert_eq!(p.heading_deg, Some(90.0));
        assert_eq!(p.q, Some(q));
        // a capture without a message keeps the JPEG's pose
        let meta8 = ImageMeta {
            image_index: 8,
            ..meta
        };
        let jpeg8 = insert_meta(&raw, &meta8).unwrap();
        for m in transfer(&jpeg8) {
            intake.handle_message(cam, &m, Time::ZERO);
        }
        let p = intake.poll_image().unwrap().pose.unwrap();
        assert_eq!((p.lat, p.alt_rel_m, p.q), (37.0, 12.0, None));
        // an all-zero q is no attitude
        let mut zero = cic(9);
        if let MavMessage::CAMERA_IMAGE_CAPTURED(c) = &mut zero {
            c.q = [0.0; 4];
            assert_eq!(pose_of_captured(c).q, None);
            assert_eq!(pose_of_captured(c).heading_deg, None);
        }
    }

    /// A camera given the runway field test (grid origin: the first vehicle's home) and the
    /// GCS's intake, message by message: before it knows the grid the camera announces its
    /// picture unclassified and keeps it, and the intake asks for it; the grid the intake
    /// announces makes the camera confirm and classify; its result is delivered without a
    /// picture; a picture asked for as an audit comes back to the asker only, and the GCS's
    /// classification of it is the camera's bit for bit.
    #[test]
    fn runway_results_replace_pictures_once_the_camera_has_the_grid() {
        use fleetmap_camera::camera::{CameraConfig, CaptureContext, SimCamera};
        use fleetmap_camera::pose::CameraPose;
        use fleetmap_core::geo::{Grid, LatLon};
        use fleetmap_core::vision::camera::CameraModel;
        use fleetmap_core::vision::load::{LoadLimits, load_image_bytes};
        use fleetmap_core::vision::onboard::OnboardSpec;
        use fleetmap_core::vision::runway::RunwayParams;
        use fleetmap_core::vision::runway::onboard::{
            OnboardRegions, RunwayDefinition, RunwayMeasurement, RunwaySpec, ShutterPose,
        };
        let world =
            fleetmap_core::world::World::from_toml(crate::kinds::runway::demo::RUNWAY_WORLD)
                .unwrap();
        let model = CameraModel {
            width_px: 120,
            height_px: 120,
            ..CameraModel::paper()
        };
        let spec = RunwaySpec {
            params: RunwayParams::default(),
            camera: model,
            grid: Grid::new(LatLon::new(37.1966, -80.5783), 4.0).unwrap(),
        };
        let mut cam = SimCamera::new(
            1,
            CameraConfig {
                model,
                min_interval_s: 0.0,
                onboard: Some(OnboardSpec::Runway(RunwayDefinition {
                    params: spec.params,
                    camera: model,
                    cell_m: 4.0,
                    grid: None,
                })),
                ..CameraConfig::default()
            },
            7,
        );
        let from = Endpoint::new(1, fleetmap_core::proto::CAMERA_COMPID);
        let mut intake = Intake::new(Endpoint::gcs());
        let t0 = Time::from_secs(10);
        intake.accept_onboard(
            OnboardKind::Runway,
            Some(crate::kinds::runway::onboard_accept(&spec, vec![1])),
            t0,
        );
        // over the runway's edge, a little tilted
        let shot = |cam: &mut SimCamera, k: u32| {
            let p = spec.grid.from_xy(20.3, 12.6).unwrap();
            let now = t0 + std::time::Duration::from_secs(u64::from(k));
            let ctx = CaptureContext {
                true_pose: CameraPose {
                    lat: p.lat,
                    lon: p.lon,
                    alt_agl_m: 12.0,
                    heading_deg: 58.0,
                    roll_deg: 2.0,
                    pitch_deg: -1.5,
                },
                reported: (p.lat, p.lon, 12.0),
                alt_amsl_m: 612.0,
                time_boot_ms: 1_000 * k,
                now,
                world_t_s: now.as_secs_f64(),
            };
            cam.capture_now(&ctx, Some(&world));
            cam.advance(now);
            std::iter::from_fn(|| cam.poll_transmit()).collect::<Vec<_>>()
        };
        let feed = |intake: &mut Intake, msgs: &[MavMessage], k: u64| {
            for m in msgs {
                intake.handle_message(from, m, Time::from_secs(10 + k));
            }
        };
        let requests =
            |intake: &mut Intake| std::iter::from_fn(|| intake.poll_transmit()).collect::<Vec<_>>();
        // the grid is announced at once (the camera does not hear this one)
        intake.handle_timeout(t0);
        let first = requests(&mut intake);
        assert!(
            matches!(&first[..], [(_, MavMessage::DEBUG_FLOAT_ARRAY(_))]),
            "{first:?}"
        );
        // no grid: a status and the picture announced unclassified, kept (no transfer)
        let out = shot(&mut cam, 1);
        assert!(
            !out.iter()
                .any(|m| matches!(m, MavMessage::ENCAPSULATED_DATA(_)))
        );
        feed(&mut intake, &out, 1);
        assert!(intake.poll_image().is_none());
        assert!(!intake.confirmed(OnboardKind::Runway, 1));
        let asked = requests(&mut intake);
        let ask = asked
            .iter()
            .find_map(|(_, m)| match m {
                MavMessage::DATA_TRANSMISSION_HANDSHAKE(h) => {
                    Some(m.clone()).filter(|_| h.size > 0)
                }
                _ => None,
            })
            .expect("the picture is asked for");
        cam.handle_gcs_message(&ask);
        let picture: Vec<_> = std::iter::from_fn(|| cam.poll_transmit()).collect();
        feed(&mut intake, &picture, 1);
        let img = intake.poll_image().expect("the picture arrives");
        assert!(img.onboard.is_none() && !img.bytes.is_empty());
        // the camera said it had no grid: announced again (after the minimum gap)
        intake.handle_timeout(t0 + std::time::Duration::from_secs(2));
        let again = requests(&mut intake);
        let grid = again
            .iter()
            .find(|(_, m)| matches!(m, MavMessage::DEBUG_FLOAT_ARRAY(_)))
            .expect("the grid again")
            .1
            .clone();
        cam.handle_gcs_message(&grid);
        assert_eq!(cam.onboard_fingerprint(), Some(spec.fingerprint()));
        let status: Vec<_> = std::iter::from_fn(|| cam.poll_transmit()).collect();
        feed(&mut intake, &status, 2);
        assert!(intake.confirmed(OnboardKind::Runway, 1));
        // classified on board: delivered without the picture, nothing asked
        let out = shot(&mut cam, 3);
        feed(&mut intake, &out, 3);
        let img = intake.poll_image().expect("the result");
        let m = *img
            .onboard
            .as_ref()
            .and_then(Onboard::get::<RunwayMeasurement>)
            .expect("a runway result");
        assert!(img.bytes.is_empty());
        assert_eq!(img.source, "on board");
        assert!(requests(&mut intake).is_empty());
        let pose = img.pose.clone().unwrap();
        // an audit: the picture comes back to the asker, not on the stream
        intake.want_picture(1, pose.time_boot_ms, pose.image_index, m.picture_bytes);
        for (_, r) in requests(&mut intake) {
            cam.handle_gcs_message(&r);
        }
        let picture: Vec<_> = std::iter::from_fn(|| cam.poll_transmit()).collect();
        feed(&mut intake, &picture, 4);
        assert!(intake.poll_image().is_none());
        let (key, audit) = intake.poll_asked().expect("the audited picture");
        assert_eq!(key, (1, pose.time_boot_ms, pose.image_index));
        let decoded = load_image_bytes(&audit.bytes, &LoadLimits::default()).unwrap();
        let shutter = ShutterPose {
            lat_deg: pose.lat,
            lon_deg: pose.lon,
            alt_rel_m: pose.alt_rel_m,
            q: pose.q.unwrap(),
        };
        let ours = spec.measure(&decoded, &shutter).unwrap();
        assert_eq!(OnboardRegions::of(&ours), m.regions);
        let c = m.reading(&spec.params).unwrap();
        assert_eq!(c, ours.reading);
        // the picture straddles the runway's edge: both classes in it
        assert!(c.counts.black.iter().any(|&b| b > 0), "{c:?}");
    }
}
