//! The camera program's serve loop: the paired cameras ([`crate::paired`]) answering the
//! autopilots heard on one link, on the wall clock.
//!
//! The link is fleetmap-io's ([`fleetmap_io::link::transport::open_link`]): a serial port
//! (`serial:/dev/ttyAMA0:921600`, the companion computer's UART wired to the autopilot's
//! TELEM2), `udpin` / `udpout` or `tcp` / `tcpin`, with the same framing, statistics and
//! per-system routing the ground station uses. Camera k's frames go to the peer autopilot k
//! was last heard from, whatever the message's target ([`LinkHandle::send_via`]; a `udpin`
//! port that several SITL autopilots send to: each camera's frames go back through its own
//! autopilot, as a camera wired to that autopilot's serial port would send them; spreading
//! them over every autopilot reordered packets between paths, counted a packet for the
//! wrong image, and sent a GCS every COMMAND_ACK once per autopilot).
//!
//! Pictures from outside ([`crate::source`]) are taken on a blocking thread, one shot at a
//! time, while the loop waits; files written for `--image-dir` are written (atomically) before
//! the frames announcing them are queued. Image transmission is paced by the cameras
//! themselves ([`crate::camera::CameraConfig::transfer_rate_bps`]).

use crate::paired::{PairedCameras, PairedEvent};
use crate::source::PictureSource;
use fleetmap_core::proto::Endpoint;
use fleetmap_core::time::Time;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::ConnSpec;
use fleetmap_io::link::transport::{LinkError, LinkEvent, LinkHandle, LinkOptions, open_link};
use std::path::{Path, PathBuf};
use std::time::Duration;
use tokio::sync::mpsc;

/// Longest sleep between two camera steps (heartbeats, interval captures, requests for
/// telemetry are due on this grid at worst).
const STEP: Duration = Duration::from_millis(20);

/// Why the camera could not serve.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The link could not be opened (bad port, no permission on the serial device, …).
    #[error(transparent)]
    Link(#[from] LinkError),
    /// The link stopped (a serial port that went away: a USB adapter unplugged); the
    /// program exits with an error so that its service manager starts it again.
    #[error("{0}: the link closed")]
    LinkClosed(String),
    /// The image directory could not be created.
    #[error("cannot create the image directory {}: {source}", dir.display())]
    ImageDir {
        /// The directory.
        dir: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
}

/// What a camera program did, per vehicle (for its last log lines and the tests).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Served {
    /// Pictures taken with a picture (system id, count), in system id order.
    pub pictures: Vec<(u8, u64)>,
    /// Shots whose source gave no picture.
    pub failed_shots: u64,
    /// Captures refused for want of a fresh position.
    pub refused: u64,
}

/// Serve cameras for the autopilots heard on `endpoint` (see the module documentation) until
/// `shutdown` completes or `duration_s` seconds have passed. `source` gives the pictures of
/// cameras made with [`PairedCameras::external`]; images also go to `image_dir` when given.
/// `on_bound` is called once the link is open, with it (its local address for a port 0).
pub async fn serve<F>(
    mut cams: PairedCameras,
    mut source: Option<PictureSource>,
    endpoint: ConnSpec,
    image_dir: Option<PathBuf>,
    duration_s: Option<f64>,
    on_bound: impl FnOnce(&LinkHandle),
    shutdown: F,
) -> Result<Served, ServeError>
where
    F: std::future::Future<Output = ()>,
{
    let (ev_tx, mut ev_rx) = mpsc::channel::<LinkEvent>(4096);
    let link = open_link(0, endpoint, &LinkOptions::default(), ev_tx).await?;
    on_bound(&link);
    if let Some(dir) = &image_dir {
        create_dir(dir).await?;
    }
    let clock = MonotonicClock::with_speedup(1.0);
    let clock_now = || Time::ZERO + Duration::from_micros(clock.now().as_micros());
    let end = duration_s.map(|d| Time::ZERO + Duration::from_secs_f64(d.max(0.0)));
    let mut served = Served::default();
    let mut pictures: std::collections::BTreeMap<u8, u64> = Default::default();
    let mut link_full = false;
    tokio::pin!(shutdown);
    loop {
        let now = clock_now();
        cams.step(now);
        while let Some(ev) = cams.poll_event() {
            log_event(&ev);
        }
        while let Some((sysid, shot)) = cams.poll_shot() {
            let picture = match source.take() {
                Some(src) => {
                    let (src, picture) = take_picture(src, sysid, shot.index).await;
                    source = src;
                    picture
                }
                None => None,
            };
            if picture.is_none() {
                served.failed_shots += 1;
            }
            cams.deliver(sysid, shot, picture.as_ref(), clock_now());
        }
        let mut images = Vec::new();
        while let Some((sysid, img)) = cams.poll_image() {
            *pictures.entry(sysid).or_default() += 1;
            images.push(img);
        }
        if let Some(dir) = &image_dir {
            write_images(dir, images).await;
        }
        while let Some((h, m)) = cams.poll_transmit() {
            let sysid = u8::try_from(h.system_id).unwrap_or(0);
            let src = Endpoint::new(sysid, h.component_id);
            let queued = link.send_via(src, sysid, m);
            if !queued && !link_full {
                tracing::warn!("camera: the link's queue is full, frames dropped");
            }
            link_full = !queued;
        }
        if end.is_some_and(|e| now >= e) {
            break;
        }
        let mut wait = STEP;
        if let Some(t) = cams.poll_timeout() {
            wait = wait.min(t.saturating_since(now).max(Duration::from_millis(1)));
        }
        tokio::select! {
            ev = ev_rx.recv() => match ev {
                Some(LinkEvent::Frame { frame, .. }) => {
                    if let Ok(m) = &frame.message {
                        cams.handle_message(&frame.header, m, clock_now());
                    }
                }
                Some(LinkEvent::Status { up, detail, .. }) => {
                    tracing::info!("camera link {}: {detail}", if up { "up" } else { "down" });
                }
                None => return Err(ServeError::LinkClosed(link.spec.to_string())),
            },
            _ = tokio::time::sleep(wait) => {}
            _ = &mut shutdown => break,
        }
    }
    served.refused = cams.refused();
    if served.refused > 0 {
        tracing::warn!(
            "camera: {} captures refused in all for want of a fresh position",
            served.refused
        );
    }
    served.pictures = pictures.into_iter().collect();
    Ok(served)
}

/// Take shot `index`'s picture for vehicle `sysid` from `src` on a blocking thread; gives the
/// source back (None if its thread died) and the picture (None: the shot failed, logged).
async fn take_picture(
    mut src: PictureSource,
    sysid: u8,
    index: i32,
) -> (Option<PictureSource>, Option<image::RgbImage>) {
    let r = tokio::task::spawn_blocking(move || {
        let p = src.next_picture();
        (src, p)
    })
    .await;
    match r {
        Ok((mut src, p)) => {
            for s in src.drain_warnings() {
                tracing::warn!("camera: {s}");
            }
            let picture = match p {
                Ok(Some(p)) => Some(p),
                Ok(None) => {
                    tracing::warn!("camera {sysid}: no new picture: capture {index} failed");
                    None
                }
                Err(e) => {
                    tracing::warn!("camera {sysid}: capture {index} failed: {e:#}");
                    None
                }
            };
            (Some(src), picture)
        }
        Err(e) => {
            tracing::warn!("camera {sysid}: picture source stopped: {e}");
            (None, None)
        }
    }
}

/// Create `dir` (and its parents) on tokio's blocking pool.
async fn create_dir(dir: &Path) -> Result<(), ServeError> {
    let d = dir.to_path_buf();
    tokio::task::spawn_blocking(move || std::fs::create_dir_all(&d))
        .await
        .unwrap_or_else(|e| Err(std::io::Error::other(e)))
        .map_err(|source| ServeError::ImageDir {
            dir: dir.to_path_buf(),
            source,
        })
}

/// Write `images` into `dir`, each atomically ([`fleetmap_io::files::atomic_write`]: fsynced),
/// in order, on tokio's blocking pool; returns once all are on disk. One that cannot be
/// written is logged and skipped. (The simulator's paired cameras write theirs with it too.)
pub async fn write_images(dir: &Path, images: Vec<crate::camera::CapturedImage>) {
    if images.is_empty() {
        return;
    }
    let dir = dir.to_path_buf();
    let written = tokio::task::spawn_blocking(move || {
        for img in images {
            let path = dir.join(&img.file_name);
            if let Err(e) = fleetmap_io::files::atomic_write(&path, &img.jpeg) {
                tracing::warn!("cannot write image {}: {e}", path.display());
            }
        }
    })
    .await;
    if let Err(e) = written {
        tracing::warn!("the image writer stopped: {e}");
    }
}

/// Log what the paired cameras report: stale poses as warnings (once per episode), the rest
/// at info.
fn log_event(ev: &PairedEvent) {
    use PairedEvent as E;
    match ev {
        E::Discovered { sysid, autopilot } => tracing::info!(
            "camera for vehicle {sysid} ({autopilot:?}): asked for GLOBAL_POSITION_INT and \
             ATTITUDE at {} Hz",
            crate::paired::TELEMETRY_HZ
        ),
        E::Rebooted { sysid } => {
            tracing::info!("vehicle {sysid} rebooted: camera asked for its telemetry again")
        }
        E::PoseStale {
            sysid,
            age,
            refused_total,
        } => match age {
            Some(a) => tracing::warn!(
                "camera for vehicle {sysid}: no position for {:.1} s, refusing captures \
                 ({refused_total} refused so far)",
                a.as_secs_f64()
            ),
            None => tracing::warn!(
                "camera for vehicle {sysid}: never had a position, refusing captures \
                 ({refused_total} refused so far)"
            ),
        },
        E::PoseRestored { sysid, refused } => tracing::info!(
            "camera for vehicle {sysid}: position again after {refused} refused captures"
        ),
    }
}
