//! A visit's pictures taken over a lossy link with several in flight: which capture command
//! to send (again), which announcements to ask for again, and which pictures are the
//! visit's. Sans-IO in the style of `quinn-proto`: the caller feeds what it hears to the
//! `handle_*` methods at an explicit `now`, sends what [`CaptureLedger::poll_transmit`] returns
//! and wakes at [`CaptureLedger::poll_timeout`].
//!
//! **The protocol it drives** (the MAVLink camera protocol, mavlink-devguide
//! `en/services/camera.md`): each MAV_CMD_IMAGE_START_CAPTURE for one picture carries a sequence
//! number (param4) so that the same command sent again takes no second picture; the camera
//! acknowledges it and broadcasts a CAMERA_IMAGE_CAPTURED whose `image_index` counts every
//! picture since boot (a camera measuring on board sends its result right behind it); a GCS
//! that missed one asks for it with MAV_CMD_REQUEST_MESSAGE (263, first index, last index or
//! −1 for every later one), as MAVSDK's camera plugin recovers missing indexes
//! (`cpp/src/mavsdk/plugins/camera/camera_impl.cpp`).
//!
//! **The rules.**
//! * At most one *unconfirmed* command: neither the ACK nor CAMERA_IMAGE_CAPTURED names the
//!   sequence number, and a camera remembers only its last one, so a command sent again must
//!   always be the newest. A command is confirmed by an accepting ACK or by a new picture
//!   named beyond those already counted; the next command goes out at once, while the
//!   pictures before it are still crossing the link.
//! * Sent again after the retransmission timeout ([`RoundTrip::rto`], RFC 6298's estimator
//!   over the command → ACK times of commands sent once, Karn's rule), together with a request
//!   for every capture after the newest one known (the command may have been taken and its
//!   announcement lost).
//! * A picture named (its announcement or its on-board result heard) but not complete (both
//!   halves) is asked for after half a timeout; the holes go out as one range request.
//! * ACKs still owed for a confirmed command's repeats are not taken for the next command's.
//!   If one is anyway (the stale ACK's repeat was lost), a confirmed command whose picture is
//!   never named is probed twice and then forgotten: the next command goes out (a picture too
//!   many is better than one too few; the caller keeps the first it needs).
//! * The visit ends when `wanted` pictures are complete, or nothing has moved for
//!   `give_up_after` (the caller retakes what is missing).

use crate::time::Time;
use std::collections::BTreeMap;
use std::time::Duration;

/// The retransmission timeout of one link, from its round trips (RFC 6298 section 2: SRTT and
/// RTTVAR with gains 1/8 and 1/4, RTO = SRTT + max(G, 4·RTTVAR)), kept within
/// [`RoundTrip::min`, `RoundTrip::max`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundTrip {
    srtt: Option<Duration>,
    rttvar: Duration,
    initial: Duration,
    min: Duration,
    max: Duration,
}

impl RoundTrip {
    /// No sample yet: [`RoundTrip::rto`] is `initial`; afterwards within `min`..=`max`.
    pub fn new(initial: Duration, min: Duration, max: Duration) -> RoundTrip {
        let max = max.max(min);
        RoundTrip {
            srtt: None,
            rttvar: Duration::ZERO,
            initial: initial.clamp(min, max),
            min,
            max,
        }
    }

    /// One round trip measured (of a message sent once: Karn's rule is the caller's).
    pub fn sample(&mut self, rtt: Duration) {
        match self.srtt {
            None => {
                self.srtt = Some(rtt);
                self.rttvar = rtt / 2;
            }
            Some(srtt) => {
                let diff = srtt.abs_diff(rtt);
                self.rttvar = (self.rttvar * 3 + diff) / 4;
                self.srtt = Some((srtt * 7 + rtt) / 8);
            }
        }
    }

    /// The smoothed round trip, when measured.
    pub fn srtt(&self) -> Option<Duration> {
        self.srtt
    }

    /// How long to wait for an answer before asking again.
    pub fn rto(&self) -> Duration {
        match self.srtt {
            None => self.initial,
            Some(srtt) => (srtt + self.rttvar * 4).clamp(self.min, self.max),
        }
    }
}

/// What [`CaptureLedger::poll_transmit`] asks the caller to send to the camera.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CaptureSend {
    /// MAV_CMD_IMAGE_START_CAPTURE for one picture with sequence number `seq` (param4).
    Capture {
        /// The command's sequence number (the same when sent again).
        seq: u32,
    },
    /// MAV_CMD_REQUEST_MESSAGE for the CAMERA_IMAGE_CAPTURED of pictures `first` to `last`
    /// (`None`: `first` and every later one).
    Again {
        /// The first image index asked for.
        first: i32,
        /// The last one, or every later one.
        last: Option<i32>,
    },
}

/// The command not confirmed yet.
#[derive(Clone, Copy, Debug)]
struct Open {
    seq: u32,
    first_sent: Time,
    resend_at: Time,
    sends: u32,
}

/// A picture of the visit named by the camera.
#[derive(Clone, Copy, Debug)]
struct Named {
    complete: bool,
    ask_at: Time,
}

/// One visit's captures (module documentation).
#[derive(Clone, Debug)]
pub struct CaptureLedger {
    wanted: u32,
    after: i32,
    next_seq: u32,
    open: Option<Open>,
    confirmed: u32,
    pictures: BTreeMap<i32, Named>,
    complete: u32,
    rtt: RoundTrip,
    progress_at: Time,
    give_up_after: Duration,
    /// ACKs the last confirmed command may still get for its repeats, until when.
    stale_acks: (u32, Time),
    /// Probes for a confirmed command's picture never named: when next, how many so far.
    probe: (Option<Time>, u32),
    /// The shortest time between two new commands, and when the last one went out.
    spacing: (Duration, Option<Time>),
}

impl CaptureLedger {
    /// A visit that wants `wanted` pictures newer than image index `after` (the camera's last
    /// picture heard), numbering its commands from `first_seq`.
    pub fn new(
        now: Time,
        wanted: u32,
        after: i32,
        first_seq: u32,
        rtt: RoundTrip,
        give_up_after: Duration,
    ) -> CaptureLedger {
        CaptureLedger {
            wanted,
            after,
            next_seq: first_seq,
            open: None,
            confirmed: 0,
            pictures: BTreeMap::new(),
            complete: 0,
            rtt,
            progress_at: now,
            give_up_after,
            stale_acks: (0, now),
            probe: (None, 0),
            spacing: (Duration::ZERO, None),
        }
    }

    /// New commands at least `spacing` apart (pictures spread over the visit rather than
    /// taken as fast as the link answers).
    pub fn with_spacing(mut self, spacing: Duration) -> CaptureLedger {
        self.spacing.0 = spacing;
        self
    }

    /// When the next new command may go out.
    fn next_command_at(&self) -> Option<Time> {
        self.spacing.1.map(|at| at + self.spacing.0)
    }

    /// Pictures believed taken: commands confirmed, or pictures named when more were.
    fn taken(&self) -> u32 {
        self.confirmed.max(self.pictures.len() as u32)
    }

    fn newest_known(&self) -> i32 {
        self.pictures
            .keys()
            .next_back()
            .copied()
            .unwrap_or(self.after)
    }

    fn confirm(&mut self, now: Time, sample: bool) {
        if let Some(o) = self.open.take() {
            if sample && o.sends == 1 {
                self.rtt.sample(now.saturating_since(o.first_sent));
            }
            self.confirmed += 1;
            let rto = self.rtt.rto();
            // each repeat may still be acknowledged (the one just heard is not owed)
            let owed = o.sends - u32::from(sample);
            self.stale_acks = (owed, now + rto * 2);
            self.probe = (Some(now + rto), 0);
        }
        self.progress_at = now;
    }

    /// The camera acknowledged MAV_CMD_IMAGE_START_CAPTURE (`accepted`: MAV_RESULT_ACCEPTED;
    /// otherwise busy or refused, and the command is sent again after a timeout).
    pub fn handle_ack(&mut self, now: Time, accepted: bool) {
        if self.stale_acks.0 > 0 && now < self.stale_acks.1 {
            self.stale_acks.0 -= 1;
            return;
        }
        if !accepted {
            if let Some(o) = &mut self.open {
                o.resend_at = o.resend_at.min(now + self.rtt.rto());
                // a refusal is an answer: no round trip to learn from this command
                o.sends = o.sends.max(2);
            }
            return;
        }
        if self.open.is_some() {
            self.confirm(now, true);
        }
    }

    /// Picture `index` named by its announcement or its on-board result. Returns whether it
    /// is one of the visit's (newer than `after`).
    pub fn handle_named(&mut self, now: Time, index: i32) -> bool {
        if index <= self.after {
            return false;
        }
        if self.pictures.contains_key(&index) {
            return true;
        }
        let half = self.rtt.rto() / 2;
        self.pictures.insert(
            index,
            Named {
                complete: false,
                ask_at: now + half,
            },
        );
        self.progress_at = now;
        // a picture beyond those counted: the open command was taken
        if self.pictures.len() as u32 > self.confirmed {
            if self.open.is_some() {
                self.confirm(now, false);
            } else {
                self.confirmed = self.pictures.len() as u32;
            }
        }
        if self.pictures.len() as u32 >= self.confirmed {
            self.probe = (None, 0);
        }
        true
    }

    /// Picture `index` arrived whole (announcement and result). Returns whether it is one of
    /// the visit's and new.
    pub fn handle_complete(&mut self, now: Time, index: i32) -> bool {
        if !self.handle_named(now, index) {
            return false;
        }
        match self.pictures.get_mut(&index) {
            Some(p) if !p.complete => {
                p.complete = true;
                self.complete += 1;
                self.progress_at = now;
                true
            }
            _ => false,
        }
    }

    /// Pictures complete so far.
    pub fn complete(&self) -> u32 {
        self.complete
    }

    /// The newest image index named in this visit (else `after`).
    pub fn last_index(&self) -> i32 {
        self.newest_known()
    }

    /// The sequence number the next command after this visit should use.
    pub fn next_seq(&self) -> u32 {
        self.next_seq
    }

    /// The link's round trips as this visit left them (for the next visit).
    pub fn round_trip(&self) -> RoundTrip {
        self.rtt
    }

    /// Whether the visit is over: `wanted` pictures complete, or nothing moved for
    /// `give_up_after`.
    pub fn is_over(&self, now: Time) -> bool {
        self.complete >= self.wanted || now.saturating_since(self.progress_at) >= self.give_up_after
    }

    /// What to send now.
    pub fn poll_transmit(&mut self, now: Time) -> Vec<CaptureSend> {
        let mut out = Vec::new();
        if self.is_over(now) {
            return out;
        }
        let rto = self.rtt.rto();
        // a confirmed command whose picture nobody named: probed twice, then forgotten
        if let (Some(at), n) = self.probe
            && self.open.is_none()
            && self.confirmed > self.pictures.len() as u32
            && now >= at
        {
            if n >= 2 {
                self.confirmed = self.pictures.len() as u32;
                self.probe = (None, 0);
            } else {
                out.push(CaptureSend::Again {
                    first: self.newest_known().saturating_add(1),
                    last: None,
                });
                self.probe = (Some(now + rto), n + 1);
            }
        }
        let taken = self.taken();
        let newest = self.newest_known();
        let spaced = self.next_command_at().is_none_or(|at| now >= at);
        match &mut self.open {
            None if taken < self.wanted && spaced => {
                self.spacing.1 = Some(now);
                let seq = self.next_seq;
                self.next_seq = self.next_seq.wrapping_add(1).max(1);
                self.open = Some(Open {
                    seq,
                    first_sent: now,
                    resend_at: now + rto,
                    sends: 1,
                });
                out.push(CaptureSend::Capture { seq });
            }
            Some(o) if now >= o.resend_at => {
                o.resend_at = now + rto;
                o.sends += 1;
                out.push(CaptureSend::Capture { seq: o.seq });
                let again = CaptureSend::Again {
                    first: newest.saturating_add(1),
                    last: None,
                };
                if !out.contains(&again) {
                    out.push(again);
                }
            }
            _ => {}
        }
        // the holes, as one range
        let due: Vec<i32> = self
            .pictures
            .iter()
            .filter(|(_, p)| !p.complete && now >= p.ask_at)
            .map(|(&i, _)| i)
            .collect();
        if let (Some(&first), Some(&last)) = (due.first(), due.last()) {
            for i in &due {
                if let Some(p) = self.pictures.get_mut(i) {
                    p.ask_at = now + rto;
                }
            }
            out.push(CaptureSend::Again {
                first,
                last: Some(last),
            });
        }
        out
    }

    /// When [`CaptureLedger::poll_transmit`] has something to send or the visit gives up.
    pub fn poll_timeout(&self) -> Time {
        let mut t = self.progress_at + self.give_up_after;
        match &self.open {
            Some(o) => t = t.min(o.resend_at),
            None if self.taken() < self.wanted => {
                t = t.min(self.next_command_at().unwrap_or(self.progress_at));
            }
            None => {}
        }
        if let (Some(at), _) = self.probe
            && self.confirmed > self.pictures.len() as u32
        {
            t = t.min(at);
        }
        for p in self.pictures.values().filter(|p| !p.complete) {
            t = t.min(p.ask_at);
        }
        t
    }
}

#[cfg(test)]
mod tests;
