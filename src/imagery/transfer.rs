//! Receiving images by MAVLink image transmission, as a sans-IO machine.
//!
//! The image transmission protocol (<https://mavlink.io/en/services/image_transmission.html>):
//! the camera announces an image with DATA_TRANSMISSION_HANDSHAKE (type, size in bytes,
//! width, height, number of packets, payload bytes per packet, JPEG quality) and sends it
//! as ENCAPSULATED_DATA packets numbered from 0; a GCS may ask for the image again by sending
//! a DATA_TRANSMISSION_HANDSHAKE of its own. The protocol has no per-packet retransmission
//! and no image id, so on a lossy link a receiver waits a little after the last packet, then
//! asks for the image again and merges the packets it was missing (a re-sent image has the
//! same size and packet count). A different announcement starts a new image; the one it
//! interrupted waits (a paced camera sends its queued pictures back to back) and is asked for
//! once the camera is quiet. The request carries the image's size and packet count, so that a
//! camera that took newer pictures meanwhile can send the right one. The JPEG's embedded
//! metadata ([`super::meta`]) says which capture it is.
//!
//! Feed [`ImageReceiver::handle_message`] with what the camera component sends, call
//! [`ImageReceiver::handle_timeout`] when [`ImageReceiver::poll_timeout`] is due, send what
//! [`ImageReceiver::poll_transmit`] returns to the camera, and take complete images from
//! [`ImageReceiver::poll_event`].

use crate::imagery::meta::{ImageMeta, read_meta};
use crate::time::Time;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::VecDeque;
use std::time::Duration;

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
    /// An image could not be completed (packets still missing after the retries, or a new
    /// image was announced first).
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
    fn wait_after(&self, retries: u32) -> Duration {
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
    last: Time,
    retries: u32,
}

/// How many interrupted images a receiver keeps, waiting for them to be sent again.
pub const MAX_WAITING: usize = 8;

/// Reassembles the images of one camera (one system/component). See the module docs.
#[derive(Clone, Debug)]
pub struct ImageReceiver {
    camera: (u8, u8),
    me: (u8, u8),
    config: ReceiverConfig,
    /// The image whose packets arrive now (the last one announced).
    current: Option<Transfer>,
    /// Incomplete images that a newer announcement interrupted, oldest first: a camera that
    /// paces its transmission sends its queued pictures back to back, so the packets an
    /// image missed can only be asked for once the camera has gone quiet.
    waiting: VecDeque<Transfer>,
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
    /// A receiver for the camera `camera` = (sysid, compid), answering as `me` (the GCS).
    pub fn new(camera: (u8, u8), me: (u8, u8), config: ReceiverConfig) -> ImageReceiver {
        ImageReceiver {
            camera,
            me,
            config,
            current: None,
            waiting: VecDeque::new(),
            last_heard: Time::ZERO,
            outbox: VecDeque::new(),
            events: VecDeque::new(),
            completed: 0,
            lost: 0,
            requests: 0,
        }
    }

    /// Feed a message received from `from` = (sysid, compid) at `now`; returns whether it
    /// was part of an image transfer from this camera.
    pub fn handle_message(&mut self, from: (u8, u8), msg: &MavMessage, now: Time) -> bool {
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
                    None => Transfer {
                        size: h.size,
                        width: h.width,
                        height: h.height,
                        packets: h.packets,
                        payload: h.payload,
                        chunks: vec![None; usize::from(h.packets)],
                        received: 0,
                        last: now,
                        retries: 0,
                    },
                };
                t.last = now;
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
    /// [`MAX_WAITING`]).
    fn wait(&mut self, t: Transfer) {
        if t.complete() {
            self.finish(t);
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

    /// When [`ImageReceiver::handle_timeout`] should run next.
    pub fn poll_timeout(&self) -> Option<Time> {
        let c = self.config;
        match (&self.current, self.waiting.front()) {
            (Some(t), _) => Some(t.last + c.wait_after(t.retries)),
            (None, Some(w)) => {
                Some((w.last + c.wait_after(w.retries)).max(self.last_heard + c.idle))
            }
            (None, None) => None,
        }
    }

    /// Ask again for an incomplete image once the camera has been quiet for the idle time —
    /// the one whose packets were arriving, else the oldest interrupted one — or give it up
    /// after its retries.
    pub fn handle_timeout(&mut self, now: Time) {
        let c = self.config;
        let idle = c.idle;
        let retries = c.retries;
        let t = match self.current.as_mut() {
            Some(t) if now.saturating_since(t.last) >= c.wait_after(t.retries) => t,
            Some(_) => return,
            None => match self.waiting.front_mut() {
                Some(w)
                    if now.saturating_since(w.last) >= c.wait_after(w.retries)
                        && now.saturating_since(self.last_heard) >= idle =>
                {
                    w
                }
                _ => return,
            },
        };
        if t.retries >= retries {
            let gone = match self.current.take() {
                Some(c) => Some(c),
                None => self.waiting.pop_front(),
            };
            if let Some(g) = gone {
                self.give_up(g);
            }
            return;
        }
        t.retries += 1;
        t.last = now;
        let (size, packets, payload) = (t.size, t.packets, t.payload);
        self.requests += 1;
        // The request names the image (its size and packets): a camera that took newer
        // pictures meanwhile can send the right one (one that only knows its latest image
        // ignores the fields).
        self.outbox
            .push_back(MavMessage::DATA_TRANSMISSION_HANDSHAKE(
                mav::DATA_TRANSMISSION_HANDSHAKE_DATA {
                    size,
                    width: 0,
                    height: 0,
                    packets,
                    mavtype: mav::MavlinkDataStreamType::MAVLINK_DATA_STREAM_IMG_JPEG,
                    payload,
                    jpg_quality: 0,
                },
            ));
    }

    /// The next message to send to the camera (a re-send request).
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.outbox.pop_front()
    }

    /// The next completed or lost image.
    pub fn poll_event(&mut self) -> Option<ImageEvent> {
        self.events.pop_front()
    }

    /// The GCS identity this receiver answers as (sysid, compid).
    pub fn me(&self) -> (u8, u8) {
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
        let mut v = vec![MavMessage::DATA_TRANSMISSION_HANDSHAKE(
            mav::DATA_TRANSMISSION_HANDSHAKE_DATA {
                size: data.len() as u32,
                width: 4,
                height: 2,
                packets: data.len().div_ceil(253) as u16,
                mavtype: mav::MavlinkDataStreamType::MAVLINK_DATA_STREAM_IMG_JPEG,
                payload: 253,
                jpg_quality: 80,
            },
        )];
        for (i, c) in data.chunks(253).enumerate() {
            let mut d = [0u8; 253];
            d[..c.len()].copy_from_slice(c);
            v.push(MavMessage::ENCAPSULATED_DATA(mav::ENCAPSULATED_DATA_DATA {
                seqnr: i as u16,
                data: d,
            }));
        }
        v
    }

    #[test]
    fn reassembles_and_recovers_lost_packets() {
        let data: Vec<u8> = (0..1000u32).map(|i| (i * 7 % 251) as u8).collect();
        let cam = (1, 100);
        let mut r = ImageReceiver::new(cam, (255, 190), ReceiverConfig::default());
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
        assert!(!r.handle_message((2, 100), &msgs[0], t));
    }

    /// A paced camera sends its queued pictures back to back: an image whose packets were
    /// lost is interrupted by the next announcement. It waits, is asked for by its size once
    /// the camera is quiet (not while it still sends), and completes from the re-send.
    #[test]
    fn an_interrupted_image_waits_and_is_completed_by_its_re_send() {
        let cam = (1, 100);
        let mut r = ImageReceiver::new(cam, (255, 190), ReceiverConfig::default());
        let a: Vec<u8> = (0..1000u32).map(|i| (i % 13) as u8).collect();
        let b: Vec<u8> = (0..600u32).map(|i| (i % 7) as u8).collect();
        let (pa, pb) = (packets(&a), packets(&b));
        let t0 = Time::ZERO;
        // A loses its packet 2; B follows at once and arrives whole.
        for (i, m) in pa.iter().enumerate() {
            if i != 3 {
                r.handle_message(cam, m, t0);
            }
        }
        let t1 = t0 + Duration::from_millis(100);
        for m in &pb {
            r.handle_message(cam, m, t1);
        }
        assert!(matches!(r.poll_event(), Some(ImageEvent::Image { jpeg, .. }) if jpeg == b));
        assert!(r.poll_event().is_none(), "A is not lost, it waits");
        // Nothing is asked while the camera was heard within the idle time.
        r.handle_timeout(t1 + Duration::from_millis(100));
        assert!(r.poll_transmit().is_none());
        let t = r.poll_timeout().expect("A waits for a re-send");
        r.handle_timeout(t);
        assert!(
            matches!(r.poll_transmit(), Some(MavMessage::DATA_TRANSMISSION_HANDSHAKE(h)) if h.size == 1000)
        );
        // The camera sends A again (only its announcement and the missing packet get through).
        r.handle_message(cam, &pa[0], t);
        r.handle_message(cam, &pa[3], t);
        assert!(matches!(r.poll_event(), Some(ImageEvent::Image { jpeg, .. }) if jpeg == a));
        assert_eq!((r.completed, r.lost), (2, 0));
        // More interrupted images than the receiver keeps: the oldest is given up.
        for k in 0..=MAX_WAITING {
            let img: Vec<u8> = vec![k as u8; 300 + k];
            r.handle_message(cam, &packets(&img)[0], t);
        }
        r.handle_message(cam, &packets(&[9u8; 200])[0], t);
        assert!(matches!(
            r.poll_event(),
            Some(ImageEvent::Lost { size: 300, .. })
        ));
    }

    #[test]
    fn gives_up_after_the_retries() {
        let cam = (1, 100);
        let mut r = ImageReceiver::new(cam, (255, 190), ReceiverConfig::default());
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
