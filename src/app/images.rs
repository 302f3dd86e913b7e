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
//! carries ([`crate::imagery::meta`]).

use crate::fleet::{FleetHandle, Incoming};
use crate::imagery::meta::{ImageMeta, read_meta};
use crate::imagery::transfer::{ImageEvent, ImageReceiver, ReceiverConfig, read_file_url};
use crate::time::Time;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::{HashMap, VecDeque};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::broadcast;

/// Largest image file read from a URL, bytes.
pub const MAX_IMAGE_FILE: u64 = 64 << 20;

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
    /// The JPEG (or other encoded image) bytes.
    pub bytes: Arc<Vec<u8>>,
    /// The capture pose, when the camera told it.
    pub pose: Option<CapturePose>,
    /// When it was complete, on the fleet's clock.
    pub received: Time,
    /// How it came: `"mavlink"` or the file path.
    pub source: String,
}

/// A capture counted as delivered: (system, time_boot_ms, image_index).
type CaptureKey = (u8, u32, i32);

fn pose_of_meta(m: &ImageMeta) -> CapturePose {
    CapturePose {
        lat: m.lat,
        lon: m.lon,
        alt_rel_m: m.alt_rel_m,
        heading_deg: Some(m.heading_deg),
        time_boot_ms: m.time_boot_ms,
        image_index: m.image_index,
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
#[derive(Debug, Default)]
pub struct Intake {
    gcs: (u8, u8),
    config: ReceiverConfig,
    receivers: HashMap<(u8, u8), ImageReceiver>,
    delivered: VecDeque<CaptureKey>,
    out: VecDeque<ReceivedImage>,
    /// Images that could not be read (file errors, lost transfers), with the reason.
    pub failures: VecDeque<String>,
}

impl Intake {
    /// An intake answering as `gcs` = (sysid, compid).
    pub fn new(gcs: (u8, u8)) -> Intake {
        Intake::with_config(gcs, ReceiverConfig::default())
    }

    /// An intake whose image receivers use `config` (their timers run on the fleet's
    /// clock: a clock sped up for a simulator needs a longer `idle`).
    pub fn with_config(gcs: (u8, u8), config: ReceiverConfig) -> Intake {
        Intake {
            gcs,
            config,
            ..Intake::default()
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

    /// Feed one received message from `from` = (sysid, compid) at `now`.
    pub fn handle_message(&mut self, from: (u8, u8), msg: &MavMessage, now: Time) {
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
            MavMessage::CAMERA_IMAGE_CAPTURED(c) => {
                if c.capture_result != mavlink::dialects::ardupilotmega::MavBool::MAV_BOOL_TRUE {
                    self.failures.push_back(format!(
                        "vehicle {}: camera reports capture {} failed",
                        from.0, c.image_index
                    ));
                    return;
                }
                let url: String = c
                    .file_url
                    .iter()
                    .map(|&b| b as char)
                    .take_while(|&ch| ch != '\0')
                    .collect();
                if !url.starts_with("file://") {
                    return; // the image comes by image transmission (or not at all)
                }
                let key = (from.0, c.time_boot_ms, c.image_index);
                if self.delivered.contains(&key) {
                    return;
                }
                match read_file_url(&url, MAX_IMAGE_FILE) {
                    Ok(bytes) => {
                        self.seen(key);
                        let pose = CapturePose {
                            lat: f64::from(c.lat) * 1e-7,
                            lon: f64::from(c.lon) * 1e-7,
                            alt_rel_m: f64::from(c.relative_alt) / 1000.0,
                            heading_deg: yaw_of_quaternion(c.q),
                            time_boot_ms: c.time_boot_ms,
                            image_index: c.image_index,
                        };
                        // The JPEG's own metadata, when present, has the camera's heading.
                        let pose = read_meta(&bytes)
                            .filter(|m| m.image_index == c.image_index)
                            .map(|m| pose_of_meta(&m))
                            .unwrap_or(pose);
                        self.out.push_back(ReceivedImage {
                            sysid: from.0,
                            bytes: Arc::new(bytes),
                            pose: Some(pose),
                            received: now,
                            source: url,
                        });
                    }
                    Err(e) => self.failures.push_back(format!("vehicle {}: {e}", from.0)),
                }
            }
            _ => {}
        }
    }

    fn drain(&mut self, cam: (u8, u8), now: Time) {
        let mut done = Vec::new();
        if let Some(rx) = self.receivers.get_mut(&cam) {
            while let Some(ev) = rx.poll_event() {
                done.push(ev);
            }
        }
        for ev in done {
            match ev {
                ImageEvent::Image { jpeg, meta, .. } => {
                    if let Some(m) = &meta
                        && self.seen((cam.0, m.time_boot_ms, m.image_index))
                    {
                        continue;
                    }
                    self.out.push_back(ReceivedImage {
                        sysid: cam.0,
                        bytes: Arc::new(jpeg),
                        pose: meta.as_ref().map(pose_of_meta),
                        received: now,
                        source: "mavlink".into(),
                    });
                }
                ImageEvent::Lost {
                    size,
                    received,
                    packets,
                } => self.failures.push_back(format!(
                    "vehicle {}: image of {size} bytes lost ({received} of {packets} packets)",
                    cam.0
                )),
            }
        }
    }

    /// The earliest time [`Intake::handle_timeout`] should run.
    pub fn poll_timeout(&self) -> Option<Time> {
        self.receivers
            .values()
            .filter_map(ImageReceiver::poll_timeout)
            .min()
    }

    /// Run the receivers' timers.
    pub fn handle_timeout(&mut self, now: Time) {
        let cams: Vec<(u8, u8)> = self.receivers.keys().copied().collect();
        for cam in cams {
            if let Some(rx) = self.receivers.get_mut(&cam) {
                rx.handle_timeout(now);
            }
            self.drain(cam, now);
        }
    }

    /// Messages to send: (camera (sysid, compid), message).
    pub fn poll_transmit(&mut self) -> Option<((u8, u8), MavMessage)> {
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

/// A running image intake: subscribe to get every image from now on.
#[derive(Clone, Debug)]
pub struct ImageHub {
    tx: broadcast::Sender<Arc<ReceivedImage>>,
    failures: broadcast::Sender<String>,
}

impl ImageHub {
    /// Images received from now on.
    pub fn subscribe(&self) -> broadcast::Receiver<Arc<ReceivedImage>> {
        self.tx.subscribe()
    }

    /// Image failures (lost transfers, unreadable files) from now on.
    pub fn failures(&self) -> broadcast::Receiver<String> {
        self.failures.subscribe()
    }
}

/// Start the intake on `fleet`'s received frames; it runs until the fleet stops.
pub fn spawn(fleet: &FleetHandle) -> ImageHub {
    spawn_with(fleet, ReceiverConfig::default())
}

/// [`spawn`] with the image receivers' configuration.
pub fn spawn_with(fleet: &FleetHandle, config: ReceiverConfig) -> ImageHub {
    let (tx, _) = broadcast::channel(256);
    let (ftx, _) = broadcast::channel(64);
    let hub = ImageHub {
        tx: tx.clone(),
        failures: ftx.clone(),
    };
    let mut frames = fleet.subscribe();
    let fleet = fleet.clone();
    tokio::spawn(async move {
        let gcs = fleet.config().gcs;
        let mut intake = Intake::with_config((gcs.sysid, gcs.compid), config);
        loop {
            let wait = intake
                .poll_timeout()
                .map(|t| fleet.clock().wall_until(t))
                .unwrap_or(Duration::from_secs(1));
            tokio::select! {
                r = frames.recv() => match r {
                    Ok(Incoming { frame, .. }) => {
                        if let Ok(msg) = &frame.message {
                            intake.handle_message((frame.sysid(), frame.compid()), msg, fleet.clock().now());
                        }
                    }
                    Err(broadcast::error::RecvError::Lagged(n)) => {
                        let f = format!("image intake fell behind: {n} frames skipped");
                        tracing::warn!("{f}");
                        let _ = ftx.send(f);
                    }
                    Err(broadcast::error::RecvError::Closed) => return,
                },
                _ = tokio::time::sleep(wait) => intake.handle_timeout(fleet.clock().now()),
            }
            while let Some(((sysid, compid), msg)) = intake.poll_transmit() {
                tracing::debug!("asking camera {sysid}/{compid} to send its image again");
                if fleet.send(msg).await.is_err() {
                    return;
                }
            }
            while let Some(img) = intake.poll_image() {
                let _ = tx.send(Arc::new(img));
            }
            while let Some(f) = intake.failures.pop_front() {
                tracing::warn!("{f}");
                let _ = ftx.send(f);
            }
        }
    });
    hub
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
}
