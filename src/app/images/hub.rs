//! The image intake's task (async shell): the fleet's frames into an [`Intake`], its
//! requests out through the fleet, its images onto a broadcast stream, and what the runners
//! ask of it ([`ImageHub`]).

use super::{Intake, MAX_IMAGE_FILE, OnboardAccept, ReceivedImage};
use crate::fleet::{FleetHandle, Incoming};
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::image_transfer::{FileUrlError, ReceiverConfig};
use fleetmap_core::time::Time;
use fleetmap_core::vision::onboard::OnboardKind;
use fleetmap_io::files::read_file_url;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::{broadcast, mpsc, oneshot};

/// A runner's request for a picture whose on-board result it has ([`ImageHub::ask_picture`]).
#[derive(Debug)]
struct Ask {
    /// (system, time_boot_ms, image_index) of the capture.
    key: (u8, u32, i32),
    /// Its size, bytes.
    size: u32,
    /// Where the picture goes.
    reply: oneshot::Sender<Arc<ReceivedImage>>,
}

/// A running image intake: subscribe to get every image from now on.
#[derive(Clone, Debug)]
pub struct ImageHub {
    tx: broadcast::Sender<Arc<ReceivedImage>>,
    accepts: mpsc::UnboundedSender<(OnboardKind, Option<OnboardAccept>)>,
    asks: mpsc::UnboundedSender<Ask>,
    /// When each vehicle's camera last sent anything of a picture (a capture's record, its
    /// on-board result, or image-transmission data), on the fleet's clock.
    traffic: Arc<std::sync::Mutex<BTreeMap<u8, Time>>>,
}

impl ImageHub {
    /// Images received from now on.
    pub fn subscribe(&self) -> broadcast::Receiver<Arc<ReceivedImage>> {
        self.tx.subscribe()
    }

    /// Use the cameras' results of on-board measurement `kind` made with `accept`'s
    /// definition, and announce it to `accept`'s cameras until they confirm it when it says
    /// so (`super::announce`); `None` (the start): ask for the picture of every result of
    /// `kind`.
    pub fn accept_onboard(&self, kind: OnboardKind, accept: Option<OnboardAccept>) {
        let _ = self.accepts.send((kind, accept));
    }

    /// When vehicle `sysid`'s camera last sent anything of a picture (CAMERA_IMAGE_CAPTURED,
    /// an on-board result, DATA_TRANSMISSION_HANDSHAKE or ENCAPSULATED_DATA), on the fleet's
    /// clock: a runner waits for pictures still on their way while this moves (a camera
    /// slower than the samples asked still delivers them after the drone landed).
    pub fn last_picture_traffic(&self, sysid: u8) -> Option<Time> {
        self.traffic.lock().ok()?.get(&sysid).copied()
    }

    /// Ask vehicle `sysid`'s camera for the picture of `size` bytes it took at
    /// `time_boot_ms` as `image_index`, whose on-board result was delivered: the picture
    /// comes back here (with the pose its metadata gives) and not on the stream of received
    /// images. The receiver is closed when the intake stops; the caller decides how long to
    /// wait (the camera may have dropped the picture).
    pub fn ask_picture(
        &self,
        sysid: u8,
        time_boot_ms: u32,
        image_index: i32,
        size: u32,
    ) -> oneshot::Receiver<Arc<ReceivedImage>> {
        let (reply, rx) = oneshot::channel();
        let _ = self.asks.send(Ask {
            key: (sysid, time_boot_ms, image_index),
            size,
            reply,
        });
        rx
    }
}

/// Start the intake on `fleet`'s received frames; it runs until the fleet stops. Images that
/// do not arrive ([`super::ImageFailure`]) are logged (warnings); the runners count the
/// pictures they miss themselves. Files are read on tokio's blocking pool, one at a time, in
/// the order their messages came.
pub fn spawn(fleet: &FleetHandle) -> ImageHub {
    spawn_with(fleet, ReceiverConfig::default())
}

/// [`spawn`] with the image receivers' configuration.
pub(crate) fn spawn_with(fleet: &FleetHandle, config: ReceiverConfig) -> ImageHub {
    let (tx, _) = broadcast::channel(256);
    let (accepts, mut accepted) = mpsc::unbounded_channel();
    let (asks, mut asked) = mpsc::unbounded_channel::<Ask>();
    let traffic = Arc::new(std::sync::Mutex::new(BTreeMap::new()));
    let hub = ImageHub {
        tx: tx.clone(),
        accepts,
        asks,
        traffic: traffic.clone(),
    };
    let mut frames = fleet.subscribe();
    let fleet = fleet.clone();
    tokio::spawn(async move {
        let gcs = fleet.config().gcs;
        let mut intake = Intake::with_config(gcs, config);
        // pictures asked for and not arrived
        let mut waiting: Vec<Ask> = Vec::new();
        loop {
            let wait = intake
                .poll_timeout()
                .map(|t| fleet.clock().wall_until(t))
                .unwrap_or(Duration::from_secs(1));
            // `biased`: in this order, not tokio's random one, so that a run on a paused
            // clock is the same every time; the timers run below on every pass, so a stream of
            // frames cannot hold them back.
            tokio::select! {
                biased;
                r = frames.recv() => match r {
                    Ok(Incoming { frame, .. }) => {
                        if let Ok(msg) = &frame.message {
                            let now = fleet.clock().now();
                            if is_picture_traffic(msg)
                                && let Ok(mut t) = traffic.lock()
                            {
                                t.insert(frame.sysid(), now);
                            }
                            intake.handle_message(
                                Endpoint::new(frame.sysid(), frame.compid()),
                                msg,
                                now,
                            );
                        }
                    }
                    Err(broadcast::error::RecvError::Lagged(n)) => {
                        tracing::warn!("image intake fell behind: {n} frames skipped");
                    }
                    Err(broadcast::error::RecvError::Closed) => return,
                },
                Some((kind, a)) = accepted.recv() => {
                    let now = fleet.clock().now();
                    intake.accept_onboard(kind, a, now);
                    // the first announcement now, not at the next timer
                    intake.handle_timeout(now);
                }
                Some(ask) = asked.recv() => {
                    let (sysid, boot_ms, index) = ask.key;
                    intake.want_picture(sysid, boot_ms, index, ask.size);
                    waiting.retain(|a| !a.reply.is_closed());
                    waiting.push(ask);
                }
                _ = tokio::time::sleep(wait) => {}
            }
            let now = fleet.clock().now();
            if intake.poll_timeout().is_some_and(|t| t <= now) {
                intake.handle_timeout(now);
            }
            while let Some(read) = intake.poll_file_read() {
                let url = read.url.clone();
                let bytes =
                    tokio::task::spawn_blocking(move || read_file_url(&url, MAX_IMAGE_FILE))
                        .await
                        .unwrap_or_else(|e| {
                            Err(FileUrlError::Io {
                                path: read.url.clone(),
                                source: std::io::Error::other(e),
                            })
                        });
                intake.file_read(read, bytes);
            }
            while let Some((cam, msg)) = intake.poll_transmit() {
                match &msg {
                    MavMessage::DEBUG_FLOAT_ARRAY(_) => {
                        tracing::debug!("announcing the run's definition to the cameras")
                    }
                    _ => tracing::debug!(
                        "asking camera {}/{} to send its image again",
                        cam.sysid,
                        cam.compid
                    ),
                }
                // An announcement is for every camera; a request for a picture only
                // for the vehicle of the camera that holds it (on a radio: bulk traffic,
                // behind that vehicle's commands and mission transfers).
                let sent = if cam.sysid == 0 {
                    fleet.send(msg).await
                } else {
                    fleet.send_to(cam.sysid, msg).await
                };
                if sent.is_err() {
                    return;
                }
            }
            while let Some(img) = intake.poll_image() {
                let _ = tx.send(Arc::new(img));
            }
            while let Some((key, img)) = intake.poll_asked() {
                if let Some(i) = waiting.iter().position(|a| a.key == key) {
                    let _ = waiting.swap_remove(i).reply.send(Arc::new(img));
                }
            }
            while let Some(f) = intake.failures.pop_front() {
                tracing::warn!("{f}");
            }
        }
    });
    hub
}

/// Whether `msg` carries part of a picture or its record: what
/// [`ImageHub::last_picture_traffic`] follows.
fn is_picture_traffic(msg: &MavMessage) -> bool {
    matches!(
        msg,
        MavMessage::CAMERA_IMAGE_CAPTURED(_)
            | MavMessage::DATA_TRANSMISSION_HANDSHAKE(_)
            | MavMessage::ENCAPSULATED_DATA(_)
            | MavMessage::DEBUG_FLOAT_ARRAY(_)
    )
}

/// The image intake for a run: its receivers wait 300 ms of *wall* time for missing packets
/// whatever the fleet clock's speed-up (B images per visit arrive in bursts).
pub fn image_hub(fleet: &FleetHandle) -> ImageHub {
    let k = fleet.clock().speedup().clamp(1.0, 100.0);
    let d = ReceiverConfig::default();
    spawn_with(
        fleet,
        ReceiverConfig {
            idle: d.idle.mul_f64(k),
            ..d
        },
    )
}
