//! Receiving images by MAVLink image transmission, as a sans-IO machine.
//!
//! The image transmission protocol (<https://mavlink.io/en/services/image_transmission.html>):
//! the camera announces an image with DATA_TRANSMISSION_HANDSHAKE (type, size in bytes,
//! width, height, number of packets, payload bytes per packet, JPEG quality) and sends it
//! as ENCAPSULATED_DATA packets numbered from 0; a GCS may ask for the image again by sending
//! a DATA_TRANSMISSION_HANDSHAKE of its own. The protocol has no per-packet retransmission
//! and no image id, so on a lossy link a receiver asks for the image again and merges the
//! packets it was missing (a re-sent image has the same size and packet count). The request
//! carries the image's size and packet count, so that a camera that took newer pictures
//! meanwhile can send the right one. The JPEG's embedded metadata ([`crate::vision::meta`]) says which
//! capture it is.
//!
//! **When to ask.** An image whose packets stop arriving is asked for after [`ReceiverConfig::idle`]
//! of silence. A different announcement starts a new image; the incomplete one it interrupted
//! waits for its re-send and is asked for *at once*, while the camera goes on sending the
//! pictures it has queued: a paced camera (20 kB/s, a 54 kB picture every 2.7 s) with pictures
//! taken every 0.2 s is never quiet. Asking only once the camera had gone quiet (as before)
//! meant asking minutes late, for a picture the camera no longer held: through four ArduCopter
//! 4.7 SITLs and `fleetmap sim --camera-only`, every re-request of a run's 26 answered the
//! camera's latest picture, never the one missing a packet, and 5 of 120 pictures were lost. A
//! camera that answers a request sends the re-send after the picture leaving now
//! (`fleetmap_camera::camera`); so the receiver asks again only when the camera has gone on to a
//! new picture since the request without sending the one asked for (the request or its re-send
//! was lost), or has gone quiet, and after the request's wait (`ReceiverConfig::wait_after`).
//! A request costs one of [`ReceiverConfig::retries`] either way: a camera that never answers
//! loses the picture after that many new pictures or quiet spells.
//!
//! **Re-sends nobody asked for.** An announcement of an image just completed (same size, packet
//! count and payload as one of the last `DONE_KEPT` completed) is a re-send the receiver
//! did not need — a request heard twice, or a camera that answers any request with its latest
//! picture. It is received (a new picture of the very same size would be delivered whole), but
//! never asked for again if incomplete: asking would make such a camera send its latest picture
//! again, and again.
//!
//! Feed [`ImageReceiver::handle_message`] with what the camera component sends, call
//! [`ImageReceiver::handle_timeout`] when [`ImageReceiver::poll_timeout`] is due, send what
//! [`ImageReceiver::poll_transmit`] returns to the camera, and take complete images from
//! [`ImageReceiver::poll_event`].

use crate::proto::Endpoint;
use crate::time::Time;
use crate::vision::meta::{ImageMeta, read_meta};
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::VecDeque;
use std::time::Duration;

/// Bytes of image per ENCAPSULATED_DATA packet (the message's whole `data` field).
pub const PAYLOAD: usize = 253;

/// The image transmission of `jpeg` as a camera sends it: one DATA_TRANSMISSION_HANDSHAKE
/// (size, `width` × `height` pixels, packet count, [`PAYLOAD`] bytes a packet, `jpg_quality`),
/// then the ENCAPSULATED_DATA packets numbered from 0, the last one padded with zeros.
pub fn transmission(jpeg: &[u8], width: u16, height: u16, jpg_quality: u8) -> Vec<MavMessage> {
    let mut out = Vec::with_capacity(1 + jpeg.len().div_ceil(PAYLOAD));
    out.push(MavMessage::DATA_TRANSMISSION_HANDSHAKE(
        mav::DATA_TRANSMISSION_HANDSHAKE_DATA {
            size: jpeg.len() as u32,
            width,
            height,
            packets: jpeg.len().div_ceil(PAYLOAD) as u16,
            mavtype: mav::MavlinkDataStreamType::MAVLINK_DATA_STREAM_IMG_JPEG,
            payload: PAYLOAD as u8,
            jpg_quality,
        },
    ));
    for (i, chunk) in jpeg.chunks(PAYLOAD).enumerate() {
        let mut data = [0u8; PAYLOAD];
        data[..chunk.len()].copy_from_slice(chunk);
        out.push(MavMessage::ENCAPSULATED_DATA(mav::ENCAPSULATED_DATA_DATA {
            seqnr: i as u16,
            data,
        }));
    }
    out
}

/// What the receiver produced.
#[derive(Clone, Debug, PartialEq)]
pub enum ImageEvent {
    /// A complete image.
    Image {
        /// The JPEG bytes.
        jpeg: Vec<u8>,
        /// Width announced by the handshake, pixels.
        width: u16,
        /// Height announced by the handshake, pixels.
        height: u16,
        /// The capture's metadata, when the JPEG carries it.
        meta: Option<ImageMeta>,
    },
    /// An image could not be completed (packets still missing after the retries, or more
    /// interrupted images than `MAX_WAITING`).
    Lost {
        /// Its announced size, bytes.
        size: u32,
        /// Packets received of the total.
        received: u16,
        /// Packets announced.
        packets: u16,
    },
}

/// Tuning of the receiver.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ReceiverConfig {
    /// Silence after the last packet before asking again; after the k-th request the receiver
    /// waits `idle` × 2^k (at most 16 × `idle`: 4.8 s by default) for the re-send to start,
    /// since a request routed through an autopilot can queue behind telemetry on a slow
    /// payload link (PX4 SITL's carries 4 kB/s).
    pub idle: Duration,
    /// How many times to ask again for one image.
    pub retries: u32,
}

impl ReceiverConfig {
    /// How long to wait for an image that has been asked for `retries` times.
    pub(crate) fn wait_after(&self, retries: u32) -> Duration {
        self.idle.saturating_mul(1u32 << retries.min(4))
    }
}

impl Default for ReceiverConfig {
    fn default() -> Self {
        ReceiverConfig {
            idle: Duration::from_millis(300),
            retries: 5,
        }
    }
}

#[derive(Clone, Debug)]
struct Transfer {
    size: u32,
    width: u16,
    height: u16,
    packets: u16,
    payload: u8,
    chunks: Vec<Option<Vec<u8>>>,
    received: u16,
    /// The last packet or announcement of it.
    last: Time,
    /// Requests sent for it.
    retries: u32,
    /// When it was last asked for since its last announcement (waiting images only).
    asked: Option<Time>,
    /// Whether the camera announced a new picture since it was last asked for.
    moved_on: bool,
    /// An announcement of an image completed lately: a re-send nobody needed.
    unneeded: bool,
}

/// A GCS's request for the image of `size` bytes: the request form of the image transmission
/// protocol, a DATA_TRANSMISSION_HANDSHAKE from the GCS naming the image by its size, and by
/// its packets and payload per packet when known (0 when not: a picture known only from its
/// on-board measurement).
pub fn request_image(size: u32, packets: u16, payload: u8) -> MavMessage {
    MavMessage::DATA_TRANSMISSION_HANDSHAKE(mav::DATA_TRANSMISSION_HANDSHAKE_DATA {
        size,
        width: 0,
        height: 0,
        packets,
        mavtype: mav::MavlinkDataStreamType::MAVLINK_DATA_STREAM_IMG_JPEG,
        payload,
        jpg_quality: 0,
    })
}

/// How many interrupted images a receiver keeps, waiting for them to be sent again.
pub(crate) const MAX_WAITING: usize = 8;

/// How many completed images a receiver remembers (size, packets, payload), to tell a re-send
/// it did not need from a new picture.
pub(crate) const DONE_KEPT: usize = 16;

/// Reassembles the images of one camera (one system/component). See the module docs.
#[derive(Clone, Debug)]
pub struct ImageReceiver {
    camera: Endpoint,
    me: Endpoint,
    config: ReceiverConfig,
    /// The image whose packets arrive now (the last one announced).
    current: Option<Transfer>,
    /// Incomplete images that a newer announcement interrupted, oldest first, each asked for
    /// while the camera goes on with its queue (see the module docs).
    waiting: VecDeque<Transfer>,
    /// (size, packets, payload) of the latest images completed, newest last.
    done: VecDeque<(u32, u16, u8)>,
    /// The last packet or announcement from the camera.
    last_heard: Time,
    outbox: VecDeque<MavMessage>,
    events: VecDeque<ImageEvent>,
    /// Images completed.
    pub completed: u64,
    /// Images lost.
    pub lost: u64,
    /// Re-send requests sent.
    pub requests: u64,
    /// Incomplete re-sends of images already complete, dropped without asking.
    pub(crate) unneeded: u64,
}

impl Transfer {
    fn matches(&self, h: &mav::DATA_TRANSMISSION_HANDSHAKE_DATA) -> bool {
        self.size == h.size && self.packets == h.packets && self.payload == h.payload
    }

    fn complete(&self) -> bool {
        self.received == self.packets
    }
}

impl ImageReceiver {
    /// A receiver for the camera `camera`, answering as `me` (the GCS).
    pub fn new(camera: Endpoint, me: Endpoint, config: ReceiverConfig) -> ImageReceiver {
        ImageReceiver {
            camera,
            me,
            config,
            current: None,
            waiting: VecDeque::new(),
            done: VecDeque::new(),
            last_heard: Time::ZERO,
            outbox: VecDeque::new(),
            events: VecDeque::new(),
            completed: 0,
            lost: 0,
            requests: 0,
            unneeded: 0,
        }
    }

    /// Feed a message received from `from` = (sysid, compid) at `now`; returns whether it
    /// was part of an image transfer from this camera.
    pub fn handle_message(&mut self, from: Endpoint, msg: &MavMessage, now: Time) -> bool {
        if from != self.camera {
            return false;
        }
        match msg {
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(h) => {
                if h.size == 0 || h.packets == 0 || h.payload == 0 {
                    return true; // not an announcement
                }
                self.last_heard = now;
                if self.current.as_ref().is_some_and(|t| t.matches(h)) {
                    if let Some(t) = self.current.as_mut() {
                        t.last = now; // a re-send: keep what we have
                    }
                    return true;
                }
                let expected = (h.size as usize).div_ceil(usize::from(h.payload));
                if expected != usize::from(h.packets) {
                    // inconsistent announcement: ignore it
                    return true;
                }
                // The image it interrupts waits for a re-send.
                if let Some(t) = self.current.take() {
                    self.wait(t);
                }
                // A re-send of an image that was waiting: merge into what we have.
                let resent = self.waiting.iter().position(|t| t.matches(h));
                let mut t = match resent.and_then(|i| self.waiting.remove(i)) {
                    Some(t) => t,
                    None => {
                        let unneeded = self.done.contains(&(h.size, h.packets, h.payload));
                        if !unneeded {
                            // a new picture: the camera has moved on from those it was asked
                            // for
                            for w in self.waiting.iter_mut().filter(|w| w.asked.is_some()) {
                                w.moved_on = true;
                            }
                        }
                        Transfer {
                            size: h.size,
                            width: h.width,
                            height: h.height,
                            packets: h.packets,
                            payload: h.payload,
                            chunks: vec![None; usize::from(h.packets)],
                            received: 0,
                            last: now,
                            retries: 0,
                            asked: None,
                            moved_on: false,
                            unneeded,
                        }
                    }
                };
                t.last = now;
                t.asked = None;
                t.moved_on = false;
                self.current = Some(t);
                true
            }
            MavMessage::ENCAPSULATED_DATA(d) => {
                self.last_heard = now;
                let Some(t) = self.current.as_mut() else {
                    return true;
                };
                let i = usize::from(d.seqnr);
                if i < t.chunks.len() && t.chunks[i].is_none() {
                    let start = i * usize::from(t.payload);
                    let len = (t.size as usize - start).min(usize::from(t.payload));
                    t.chunks[i] = Some(d.data[..len.min(d.data.len())].to_vec());
                    t.received += 1;
                }
                t.last = now;
                if t.complete()
                    && let Some(t) = self.current.take()
                {
                    self.finish(t);
                }
                true
            }
            _ => false,
        }
    }

    /// Keep an interrupted image for a re-send (the oldest is given up beyond
    /// [`MAX_WAITING`]); an unneeded re-send is dropped.
    fn wait(&mut self, t: Transfer) {
        if t.complete() {
            self.finish(t);
            return;
        }
        if t.unneeded {
            self.unneeded += 1;
            return;
        }
        self.waiting.push_back(t);
        if self.waiting.len() > MAX_WAITING
            && let Some(old) = self.waiting.pop_front()
        {
            self.give_up(old);
        }
    }

    fn finish(&mut self, t: Transfer) {
        self.done.push_back((t.size, t.packets, t.payload));
        if self.done.len() > DONE_KEPT {
            self.done.pop_front();
        }
        let mut jpeg = Vec::with_capacity(t.size as usize);
        for c in t.chunks.into_iter().flatten() {
            jpeg.extend_from_slice(&c);
        }
        jpeg.truncate(t.size as usize);
        let meta = read_meta(&jpeg);
        self.completed += 1;
        self.events.push_back(ImageEvent::Image {
            jpeg,
            width: t.width,
            height: t.height,
            meta,
        });
    }

    fn give_up(&mut self, t: Transfer) {
        self.lost += 1;
        self.events.push_back(ImageEvent::Lost {
            size: t.size,
            received: t.received,
            packets: t.packets,
        });
    }

    /// When the image whose packets were arriving is due: asked for after its wait.
    fn current_due(&self, t: &Transfer) -> Time {
        t.last + self.config.wait_after(t.retries)
    }

    /// When a waiting image is due: at once if it has not been asked for since it was
    /// interrupted; else after its wait, and only once the camera has moved on to a new
    /// picture or gone quiet (its re-send comes after the picture leaving the camera now).
    fn waiting_due(&self, w: &Transfer) -> Time {
        match w.asked {
            None => w.last,
            Some(a) => {
                let after = a + self.config.wait_after(w.retries);
                if w.moved_on {
                    after
                } else {
                    after.max(self.last_heard + self.config.idle)
                }
            }
        }
    }

    /// When [`ImageReceiver::handle_timeout`] should run next.
    pub fn poll_timeout(&self) -> Option<Time> {
        let current = self.current.as_ref().map(|t| self.current_due(t));
        let waiting = self.waiting.iter().map(|w| self.waiting_due(w)).min();
        current.into_iter().chain(waiting).min()
    }

    /// Ask again for the images that are due (see the module docs), or give them up after
    /// their retries.
    pub fn handle_timeout(&mut self, now: Time) {
        if let Some(t) = &self.current
            && self.current_due(t) <= now
            && let Some(mut t) = self.current.take()
        {
            if t.unneeded {
                self.unneeded += 1;
            } else if t.retries >= self.config.retries {
                self.give_up(t);
            } else {
                t.last = now;
                self.ask(&mut t);
                self.current = Some(t);
            }
        }
        let mut i = 0;
        while i < self.waiting.len() {
            if self.waiting_due(&self.waiting[i]) > now {
                i += 1;
                continue;
            }
            let Some(mut w) = self.waiting.remove(i) else {
                break;
            };
            if w.retries >= self.config.retries {
                self.give_up(w);
                continue;
            }
            w.asked = Some(now);
            w.moved_on = false;
            self.ask(&mut w);
            self.waiting.insert(i, w);
            i += 1;
        }
    }

    /// Queue a request for `t`. The request names the image (its size and packets): a
    /// camera that took newer pictures meanwhile can send the right one (one that only
    /// knows its latest image ignores the fields).
    fn ask(&mut self, t: &mut Transfer) {
        t.retries += 1;
        self.requests += 1;
        self.outbox
            .push_back(request_image(t.size, t.packets, t.payload));
    }

    /// The next message to send to the camera (a re-send request).
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.outbox.pop_front()
    }

    /// The next completed or lost image.
    pub fn poll_event(&mut self) -> Option<ImageEvent> {
        self.events.pop_front()
    }

    /// The GCS identity this receiver answers as.
    pub fn me(&self) -> Endpoint {
        self.me
    }
}

/// Errors reading an image announced by a file URL.
#[derive(Debug, thiserror::Error)]
pub enum FileUrlError {
    /// Only `file://` URLs are read.
    #[error("unsupported image URL {0:?}: only file:// URLs are read")]
    Unsupported(String),
    /// The file could not be read.
    #[error("cannot read image {path}")]
    Io {
        /// The path.
        path: String,
        /// Why.
        source: std::io::Error,
    },
    /// The file is larger than the limit.
    #[error("image {path} is {size} bytes, more than the {limit}-byte limit")]
    TooLarge {
        /// The path.
        path: String,
        /// Its size.
        size: u64,
        /// The limit.
        limit: u64,
    },
}

/// The local path of a `file://` URL (as CAMERA_IMAGE_CAPTURED.file_url carries it).
pub fn file_url_path(url: &str) -> Result<std::path::PathBuf, FileUrlError> {
    let rest = url
        .trim_end_matches('\0')
        .strip_prefix("file://")
        .ok_or_else(|| FileUrlError::Unsupported(url.to_string()))?;
    // file:///abs/path or file://localhost/abs/path
    let path = rest.strip_prefix("localhost").unwrap_or(rest);
    if !path.starts_with('/') {
        return Err(FileUrlError::Unsupported(url.to_string()));
    }
    Ok(std::path::PathBuf::from(path))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn packets(data: &[u8]) -> Vec<MavMessage> {
        transmission(data, 4, 2, 80)
    }

    #[test]
    fn reassembles_and_recovers_lost_packets() {
        let data: Vec<u8> = (0..1000u32).map(|i| (i * 7 % 251) as u8).collect();
        let cam = Endpoint::new(1, crate::proto::CAMERA_COMPID);
        let mut r = ImageReceiver::new(cam, Endpoint::gcs(), ReceiverConfig::default());
        let msgs = packets(&data);
        // first pass loses packets 1 and 3
        for (i, m) in msgs.iter().enumerate() {
            if i != 2 && i != 4 {
                r.handle_message(cam, m, Time::ZERO);
            }
        }
        assert!(r.poll_event().is_none());
        let t = r.poll_timeout().unwrap();
        r.handle_timeout(t);
        // The request names the image it wants (size and packets).
        assert!(
            matches!(r.poll_transmit(), Some(MavMessage::DATA_TRANSMISSION_HANDSHAKE(h))
                if h.size == 1000 && h.packets == 4 && h.payload == 253)
        );
        // the camera sends it again; this time packet 1 arrives, 3 again lost
        for (i, m) in msgs.iter().enumerate() {
            if i != 4 {
                r.handle_message(cam, m, t);
            }
        }
        assert!(r.poll_event().is_none());
        r.handle_message(cam, &msgs[4], t);
        match r.poll_event() {
            Some(ImageEvent::Image { jpeg, width, .. }) => {
                assert_eq!(jpeg, data);
                assert_eq!(width, 4);
            }
            other => panic!("{other:?}"),
        }
        // other senders are ignored
        assert!(!r.handle_message(Endpoint::new(2, crate::proto::CAMERA_COMPID), &msgs[0], t));
    }

    fn request_size(m: Option<MavMessage>) -> Option<u32> {
        match m {
            Some(MavMessage::DATA_TRANSMISSION_HANDSHAKE(h)) => Some(h.size),
            _ => None,
        }
    }

    /// A paced camera sends its queued pictures back to back: an image whose packets were
    /// lost is interrupted by the next announcement. It is asked for by its size at once,
    /// while the camera goes on sending (it is never quiet with a queue), asked again only
    /// once the camera has moved on to a new picture without sending it, and completes from
    /// the re-send.
    #[test]
    fn an_interrupted_image_is_asked_for_while_the_camera_goes_on() {
        let cam = Endpoint::new(1, crate::proto::CAMERA_COMPID);
        let mut r = ImageReceiver::new(cam, Endpoint::gcs(), ReceiverConfig::default());
        let a: Vec<u8> = (0..1000u32).map(|i| (i % 13) as u8).collect();
        let b: Vec<u8> = (0..3000u32).map(|i| (i % 7) as u8).collect();
        let c: Vec<u8> = (0..900u32).map(|i| (i % 5) as u8).collect();
        let (pa, pb, pc) = (packets(&a), packets(&b), packets(&c));
        let t0 = Time::ZERO;
        // A loses its packet 2; B follows at once.
        for (i, m) in pa.iter().enumerate() {
            if i != 3 {
                r.handle_message(cam, m, t0);
            }
        }
        let t1 = t0 + Duration::from_millis(100);
        r.handle_message(cam, &pb[0], t1);
        // asked for at once, though the camera is sending B
        assert_eq!(r.poll_timeout(), Some(t0));
        r.handle_timeout(t1);
        assert_eq!(request_size(r.poll_transmit()), Some(1000));
        assert!(r.poll_event().is_none(), "A is not lost, it waits");
        // B goes on for 2.4 s: no new request while the camera is busy with it
        for (k, m) in pb.iter().enumerate().skip(1) {
            let t = t1 + Duration::from_millis(200 * k as u64);
            r.handle_timeout(t);
            r.handle_message(cam, m, t);
        }
        assert!(r.poll_transmit().is_none());
        assert!(matches!(r.poll_event(), Some(ImageEvent::Image { jpeg, .. }) if jpeg == b));
        // the camera moves on to a new picture, C, without sending A: A is asked again
        let t2 = t1 + Duration::from_millis(2_500);
        r.handle_message(cam, &pc[0], t2);
        r.handle_timeout(r.poll_timeout().expect("A waits"));
        assert_eq!(request_size(r.poll_transmit()), Some(1000));
        assert_eq!(r.requests, 2);
        // C is interrupted whole by A's re-send (only the announcement and the missing packet
        // get through)
        for m in &pc[1..] {
            r.handle_message(cam, m, t2);
        }
        assert!(matches!(r.poll_event(), Some(ImageEvent::Image { jpeg, .. }) if jpeg == c));
        let t3 = t2 + Duration::from_millis(50);
        r.handle_message(cam, &pa[0], t3);
        r.handle_message(cam, &pa[3], t3);
        assert!(matches!(r.poll_event(), Some(ImageEvent::Image { jpeg, .. }) if jpeg == a));
        assert_eq!((r.completed, r.lost), (3, 0));
        // More interrupted images than the receiver keeps: the oldest is given up.
        for k in 0..=MAX_WAITING {
            let img: Vec<u8> = vec![k as u8; 300 + k];
            r.handle_message(cam, &packets(&img)[0], t3);
        }
        r.handle_message(cam, &packets(&[9u8; 200])[0], t3);
        assert!(matches!(
            r.poll_event(),
            Some(ImageEvent::Lost { size: 300, .. })
        ));
    }

    /// A camera that never answers: each request costs a retry when the camera moves on to a
    /// new picture (or goes quiet), and the picture is lost after the retries, not before.
    #[test]
    fn a_camera_that_never_re_sends_loses_the_picture_after_the_retries() {
        let cam = Endpoint::new(1, crate::proto::CAMERA_COMPID);
        let cfg = ReceiverConfig::default();
        let mut r = ImageReceiver::new(cam, Endpoint::gcs(), cfg);
        let a = packets(&[3u8; 800]);
        r.handle_message(cam, &a[0], Time::ZERO);
        let mut t = Time::ZERO;
        for k in 0..=cfg.retries {
            t += Duration::from_secs(10);
            // a new picture of its own size each time
            let img = vec![k as u8; 500 + k as usize];
            for m in packets(&img) {
                r.handle_message(cam, &m, t);
            }
            r.handle_timeout(t);
        }
        assert_eq!(r.requests, u64::from(cfg.retries));
        assert_eq!(r.lost, 1);
        let lost: Vec<ImageEvent> = std::iter::from_fn(|| r.poll_event())
            .filter(|e| matches!(e, ImageEvent::Lost { .. }))
            .collect();
        assert!(matches!(
            lost[..],
            [ImageEvent::Lost {
                size: 800,
                received: 0,
                packets: 4
            }]
        ));
    }

    /// A re-send of a picture already complete (a request heard twice, or a camera that
    /// answers any request with its latest picture) is taken if whole, but never asked for:
    /// no request feeds a loop of re-sends.
    #[test]
    fn a_re_send_nobody_needed_is_not_asked_for() {
        let cam = Endpoint::new(1, crate::proto::CAMERA_COMPID);
        let mut r = ImageReceiver::new(cam, Endpoint::gcs(), ReceiverConfig::default());
        let a: Vec<u8> = (0..700u32).map(|i| (i % 11) as u8).collect();
        let pa = packets(&a);
        for m in &pa {
            r.handle_message(cam, m, Time::ZERO);
        }
        assert!(matches!(r.poll_event(), Some(ImageEvent::Image { .. })));
        // sent again, and a packet lost
        let t = Time::from_secs(1);
        for m in pa.iter().take(2) {
            r.handle_message(cam, m, t);
        }
        let due = r.poll_timeout().expect("the idle wait");
        r.handle_timeout(due + Duration::from_secs(30));
        assert!(r.poll_transmit().is_none());
        assert_eq!((r.requests, r.unneeded, r.lost), (0, 1, 0));
        assert!(r.poll_event().is_none());
        // sent again whole: delivered (the intake knows the capture already)
        for m in &pa {
            r.handle_message(cam, m, t + Duration::from_secs(40));
        }
        assert!(matches!(r.poll_event(), Some(ImageEvent::Image { jpeg, .. }) if jpeg == a));
    }

    #[test]
    fn gives_up_after_the_retries() {
        let cam = Endpoint::new(1, crate::proto::CAMERA_COMPID);
        let mut r = ImageReceiver::new(cam, Endpoint::gcs(), ReceiverConfig::default());
        r.handle_message(cam, &packets(&[1u8; 600])[0], Time::ZERO);
        let mut t = Time::ZERO;
        for _ in 0..6 {
            t = r.poll_timeout().unwrap();
            r.handle_timeout(t);
        }
        assert_eq!(r.requests, 5);
        assert!(matches!(
            r.poll_event(),
            Some(ImageEvent::Lost { packets: 3, .. })
        ));
        assert!(r.poll_timeout().is_none());
        // The waits double after each request, at most 16 × idle: 0.3 + 0.6 + 1.2 + 2.4 + 4.8
        // + 4.8 s.
        assert_eq!(
            t.saturating_since(Time::ZERO),
            Duration::from_millis(14_100)
        );
    }

    #[test]
    fn file_urls() {
        assert_eq!(
            file_url_path("file:///tmp/a.jpg\0\0").unwrap(),
            std::path::PathBuf::from("/tmp/a.jpg")
        );
        assert!(file_url_path("http://x/a.jpg").is_err());
        assert!(file_url_path("file://relative.jpg").is_err());
    }
}
