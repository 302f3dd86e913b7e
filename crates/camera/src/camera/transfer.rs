//! Image transmission: the DATA_TRANSMISSION_HANDSHAKE and ENCAPSULATED_DATA queues, their
//! release through the pacing bucket, the images kept and the re-sends a GCS asks for (the
//! rules are in the [camera module](super)'s documentation).

use super::SimCamera;
use super::pacer::frame_len;
use fleetmap_core::proto::image_transfer;
use fleetmap_core::time::Time;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::VecDeque;
use std::sync::Arc;
use std::time::Duration;

/// How many recent images a camera keeps to send again on request.
pub const RECENT_IMAGES: usize = 16;

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
        self.status_tick(now);
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
    pub(crate) fn transfer_backlog(&self) -> usize {
        self.paced.len() + self.resends.len()
    }

    /// Move what the bucket allows to the outbox: the image leaving now to its end, then a
    /// re-send if one waits, else the next queued image.
    pub(super) fn release(&mut self) {
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

    /// Queue the first transmission of `jpeg` (paced: behind the images already queued).
    pub(super) fn queue_transfer(&mut self, jpeg: &Arc<Vec<u8>>) {
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
        let model = self.config.model;
        queue.extend(image_transfer::transmission(
            jpeg,
            model.width_px as u16,
            model.height_px as u16,
            self.config.jpeg_quality,
        ));
    }

    /// A GCS's DATA_TRANSMISSION_HANDSHAKE asking for an image again (see the module
    /// documentation): the image of `size` bytes among those sent or captured lately, or the
    /// latest image when the request names no size (0). A size this camera does not hold is
    /// not answered: the request is for another camera behind the same autopilot port, or
    /// for a picture too old to keep. The re-send is paced like a first transmission and
    /// leaves before the images still queued; a request for an image whose transmission
    /// waits or is leaving is ignored (every autopilot on a shared port forwards the same
    /// request).
    pub(crate) fn handle_handshake_request(&mut self, size: u32) {
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::{CameraConfig, PACE_BURST_S};
    use fleetmap_core::proto::image_transfer::PAYLOAD;

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
}
