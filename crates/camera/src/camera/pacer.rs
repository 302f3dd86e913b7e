//! Pacing of image transmission: the token bucket in bytes per second of the camera's clock
//! and what each MAVLink 2 frame costs in it.

use fleetmap_core::time::Time;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;

/// MAVLink 2 framing around a payload, bytes: 10 of header (magic, lengths, flags, sequence,
/// system, component, 3-byte message id) and a 2-byte CRC; unsigned.
pub(crate) const FRAME_OVERHEAD: usize = 12;
/// Capacity of the pacing token bucket, in seconds of the configured rate (never less than
/// one frame): the longest burst a paced camera sends after being idle. Zero: one frame at a
/// time. PX4 1.16 keeps only two messages waiting to be forwarded to another of its links
/// (`Mavlink::pass_message`: a ring of two, one passed on per loop of its GCS link, at least
/// 1.5 ms), so the three-frame bursts a 50 ms bucket allowed at 20 kB/s lost a frame now and
/// then: 9 of 199 packets through PX4 SITL's payload link.
pub(crate) const PACE_BURST_S: f64 = 0.0;

/// Most frames a paced camera sends back to back when its shell polls late: two, what PX4's
/// forwarding ring holds.
const PACE_MAX_BACK_TO_BACK: f64 = 2.0;

/// A token bucket in bytes per second on the camera's clock.
#[derive(Clone, Copy, Debug)]
pub(super) struct Pacer {
    /// Bytes per second.
    pub(super) rate: f64,
    /// Capacity, bytes.
    pub(super) burst: f64,
    /// Bytes that may leave now.
    pub(super) tokens: f64,
    /// When `tokens` was last brought up to date (None: never, the bucket starts full).
    pub(super) at: Option<Time>,
    /// Whether frames were waiting at the last refill.
    busy: bool,
}

impl Pacer {
    /// The largest paced frame, bytes (an ENCAPSULATED_DATA).
    fn largest() -> f64 {
        (FRAME_OVERHEAD + mav::ENCAPSULATED_DATA_DATA::ENCODED_LEN) as f64
    }

    pub(super) fn new(rate: f64) -> Pacer {
        let burst = (rate * PACE_BURST_S).max(Self::largest());
        Pacer {
            rate,
            burst,
            tokens: burst,
            at: None,
            busy: false,
        }
    }

    /// Change the rate from now on (bytes per second, finite and positive); the tokens
    /// already earned are kept, up to the new capacity.
    pub(super) fn set_rate(&mut self, rate: f64) {
        self.rate = rate;
        self.burst = (rate * PACE_BURST_S).max(Self::largest());
        self.tokens = self.tokens.min(self.burst);
    }

    /// Add the tokens earned since the last refill. An idle bucket (`backlog` false) fills
    /// up to its capacity only; one with frames waiting keeps up to
    /// [`PACE_MAX_BACK_TO_BACK`] frames' worth (a shell that polls late loses that part of
    /// the rate rather than sending a burst an autopilot would drop).
    pub(super) fn refill(&mut self, now: Time, backlog: bool) {
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
pub(super) fn frame_len(msg: &MavMessage) -> usize {
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
