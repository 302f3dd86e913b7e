//! The paired cameras' serve loop (`fleetmap camera`): simulated cameras answering real
//! autopilots over one endpoint, on the wall clock.

use super::sockets::{Io, Received, open};
use super::{Bound, ServerError, UDP_PACE, write_images};
use crate::tx_queue::{Expired, TxQueue};
use fleetmap_core::time::Time;
use fleetmap_io::clock::MonotonicClock;
use std::collections::{BTreeMap, HashMap};
use std::net::SocketAddr;
use std::path::PathBuf;
use tokio::sync::mpsc;

/// Serve simulated cameras for real autopilots (see [`crate::paired`]): listen on
/// `endpoint` (typically `udpin:` where a SITL or MAVProxy sends its telemetry), render an
/// image for every picture the autopilots take and answer as their camera components, on
/// the wall clock. Images go to `image_dir` (and over MAVLink if the camera config says so,
/// paced by the cameras themselves when [`crate::camera::CameraConfig::transfer_rate_bps`]
/// is set). UDP datagrams are paced and aged as in [`serve`] ([`TxQueue`]); a datagram the
/// socket cannot take yet waits for the next turn.
/// What the cameras report ([`crate::paired::PairedEvent`]) is logged: a stale pose
/// warns once per episode of refused captures, not once per capture.
pub async fn serve_paired<F>(
    mut cams: crate::paired::PairedCameras,
    mut source: Option<fleetmap_io::files::pictures::FolderSource>,
    endpoint: fleetmap_io::link::ConnSpec,
    image_dir: Option<PathBuf>,
    duration_s: Option<f64>,
    on_bound: impl FnOnce(&[Bound]),
    shutdown: F,
) -> Result<crate::paired::PairedCameras, ServerError>
where
    F: std::future::Future<Output = ()>,
{
    use fleetmap_io::link::codec::Codec;
    /// Longest sleep between two camera steps (heartbeats, interval captures, requests for
    /// telemetry are due on this grid at worst).
    const STEP: std::time::Duration = std::time::Duration::from_millis(20);
    let (tx, mut rx) = mpsc::channel::<Received>(4096);
    let (bound, ios) = open(&[0], std::slice::from_ref(&endpoint), tx).await?;
    on_bound(&bound);
    if let Some(dir) = &image_dir {
        super::create_image_dir(dir).await?;
    }
    let clock = MonotonicClock::with_speedup(1.0);
    let unix0 = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map(|d| d.as_micros() as u64)
        .unwrap_or(0);
    let mut codec = Codec::new();
    let end = duration_s.map(|d| Time::ZERO + std::time::Duration::from_secs_f64(d.max(0.0)));
    // One outgoing queue per camera, each sent to the address its own autopilot was last
    // heard from (see `routes` below).
    let mut pending: BTreeMap<u8, TxQueue> = BTreeMap::new();
    // Where each vehicle's autopilot (component 1) was last heard from. Several autopilots
    // send to one `udpin` port (each copter's SERIAL1 in a SITL fleet): camera k's frames go
    // back to autopilot k, as a camera wired to its own autopilot's serial port would send
    // them. Sending everything to the last sender (as before) spread one camera's packets
    // over every autopilot: their paths differ in delay, so packets arrived out of order —
    // 29 reorderings in 120 pictures through four ArduCopter SITLs, and a packet that crossed
    // an image's DATA_TRANSMISSION_HANDSHAKE counted for the wrong image (pictures short of
    // packet 0, 1 or the last ones) — and requests for one autopilot's telemetry went to
    // another, which does not forward them back to the port they came from
    // (MAVLink_routing::check_and_forward), so a camera could wait minutes for a position.
    let mut routes: HashMap<u8, SocketAddr> = HashMap::new();
    tokio::pin!(shutdown);
    let result = loop {
        let now = Time::ZERO + std::time::Duration::from_micros(clock.now().as_micros());
        cams.step(now);
        while let Some(ev) = cams.poll_event() {
            log_paired_event(&ev);
        }
        // Pictures from outside: read on a blocking thread, one shot at a time.
        while let Some((sysid, shot)) = cams.poll_shot() {
            let picture = match source.take() {
                Some(mut src) => {
                    let r = tokio::task::spawn_blocking(move || {
                        let p = src.next_picture();
                        (src, p)
                    })
                    .await;
                    match r {
                        Ok((mut src, p)) => {
                            for s in src.skipped.drain(..) {
                                tracing::warn!("camera: picture skipped: {s}");
                            }
                            source = Some(src);
                            match p {
                                Ok(Some(p)) => Some(p.image),
                                Ok(None) => {
                                    tracing::warn!(
                                        "camera {sysid}: no new picture in the folder: capture {} failed",
                                        shot.index
                                    );
                                    None
                                }
                                Err(e) => {
                                    tracing::warn!("camera {sysid}: {e:#}");
                                    None
                                }
                            }
                        }
                        Err(e) => {
                            tracing::warn!("camera {sysid}: picture source stopped: {e}");
                            None
                        }
                    }
                }
                None => None,
            };
            let now = Time::ZERO + std::time::Duration::from_micros(clock.now().as_micros());
            cams.deliver(sysid, shot, picture.as_ref(), now);
        }
        let mut images = Vec::new();
        while let Some((_, img)) = cams.poll_image() {
            images.push(img);
        }
        if let Some(dir) = &image_dir {
            write_images(dir, images).await;
        }
        while let Some((h, m)) = cams.poll_transmit() {
            let unix = unix0 + now.as_micros();
            let frame = codec.encode_with_header(&h, &m, mavlink::MavlinkVersion::V2, unix);
            let sysid = u8::try_from(h.system_id).unwrap_or(0);
            pending.entry(sysid).or_default().push(now, frame);
        }
        for (sysid, q) in pending.iter_mut() {
            if let Expired::Began(n) = q.expire(now) {
                tracing::warn!(
                    "simulated camera {sysid}: the link is dropping datagrams older than {} ms \
                     ({n} now, {} in all)",
                    TxQueue::MAX_AGE.as_millis(),
                    q.dropped()
                );
            }
        }
        let mut backlog = false;
        match &ios[0] {
            Io::Udp { sock, peer } => {
                let last = peer.lock().ok().and_then(|p| *p);
                for (sysid, q) in pending.iter_mut() {
                    match routes.get(sysid).copied().or(last) {
                        Some(to) => {
                            q.refill(now);
                            while let Some(d) = q.ready() {
                                match sock.try_send_to(d, to) {
                                    Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                                        break;
                                    }
                                    // sent, or an error a retry would not mend (e.g. ICMP
                                    // port unreachable reported on this send)
                                    _ => q.sent(),
                                }
                            }
                        }
                        // nobody has spoken to us yet: nowhere to send
                        None => q.clear(),
                    }
                    backlog |= !q.is_empty();
                }
            }
            Io::Tcp { out } => {
                for q in pending.values_mut() {
                    for d in q.take_all() {
                        let _ = out.send(d);
                    }
                }
            }
        }
        if end.is_some_and(|e| now >= e) {
            break cams;
        }
        let mut wait = STEP;
        if let Some(t) = cams.poll_timeout() {
            wait = wait.min(
                t.saturating_since(now)
                    .max(std::time::Duration::from_millis(1)),
            );
        }
        if backlog {
            wait = wait.min(UDP_PACE);
        }
        tokio::select! {
            r = rx.recv() => {
                if let Some((_, bytes, from)) = r {
                    let now = Time::ZERO + std::time::Duration::from_micros(clock.now().as_micros());
                    for f in codec.decode(&bytes, unix0 + now.as_micros()) {
                        if let (Some(a), 1) = (from, f.header.component_id)
                            && let Ok(sysid) = u8::try_from(f.header.system_id)
                        {
                            routes.insert(sysid, a);
                        }
                        if let Ok(m) = f.message {
                            cams.handle_message(&f.header, &m, now);
                        }
                    }
                }
            }
            _ = tokio::time::sleep(wait) => {}
            _ = &mut shutdown => break cams,
        }
    };
    if result.refused() > 0 {
        tracing::warn!(
            "simulated cameras: {} captures refused in all for want of a fresh position",
            result.refused()
        );
    }
    Ok(result)
}

/// Log what the paired cameras report: stale poses as warnings (once per episode), the rest
/// at info.
fn log_paired_event(ev: &crate::paired::PairedEvent) {
    use crate::paired::PairedEvent as E;
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
