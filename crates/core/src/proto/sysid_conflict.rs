//! Two autopilots answering as one system id on one link, told from their traffic.
//!
//! Every autopilot leaves the factory as system id 1 (ArduPilot's `SYSID_THISMAV`, PX4's
//! `MAV_SYS_ID`). Two of them left at the same id on one GCS port look like one vehicle whose
//! position, mode and mission jump back and forth; a GCS that does not notice uploads to,
//! arms and flies "vehicle 1" while two machines answer. QGroundControl merges them silently
//! ("the UI jumps rapidly between vehicles", mavlink/qgroundcontrol#14808, #2630, #12094);
//! its maintainers' proposed check (#14812) compares the board `uid` of AUTOPILOT_VERSION
//! replies, which needs a request and a board that fills the field. This watch needs nothing
//! from the vehicles: it reads what each (link, system id, component id) sends anyway.
//!
//! * **Sequence numbers.** Each MAVLink sender counts its frames (the header's `seq`, 0–255,
//!   one counter per component and channel: "allows to detect packet loss"; pymavlink's
//!   `mavutil` and MAVProxy count loss as forward gaps of it per source). Loss only skips
//!   forward; a duplicate repeats a frame exactly; a reordered frame fills a gap left
//!   moments before; a reboot restarts the counter once. Two senders interleave two
//!   counters: the frames fall into two runs ("tracks") that the stream keeps switching
//!   between. The watch assigns each frame to the track it continues (the nearest forward
//!   gap of at most [`SysidWatchConfig::max_gap`]), recognises duplicates by their content
//!   (same seq, same CRC) and late frames by the gap they fill, and starts a new track for
//!   anything else. A conflict is [`SysidWatchConfig::returns`] *returns* within
//!   [`SysidWatchConfig::window`] to a track the stream had left, both tracks established
//!   (at least [`SysidWatchConfig::min_track_frames`] frames). A reboot or a long outage
//!   moves the stream to a new track for good: no return. Two tracks a few numbers apart
//!   may be one counter braided by reordering across a burst of loss, so their switches do
//!   not count; two counters in step are told instead by *collisions*: a frame with the
//!   number of one received moments before ([`SysidWatchConfig::collision_ttl`]: well
//!   within a counter's round at the rate heard) but another content. A reboot restarts the counter
//!   from 0 after seconds of silence, or, behind a radio's buffer, right after the last frames
//!   before it. After a silence, or after a number below 8 that continues no track, earlier
//!   numbers no longer collide; and collisions make a conflict only when they spread over
//!   more than their ttl (a restart whose first frames were lost collides only within it).
//! * **Heartbeat identity.** A running autopilot keeps its MAV_TYPE and MAV_AUTOPILOT; the
//!   heartbeats of one (link, sysid, compid) that flip between two identities
//!   [`SysidWatchConfig::flips`] times within the window come from two autopilots (a copter
//!   and a rover both left at id 1).
//!
//! Streams are keyed by link: one vehicle heard over two links (a radio and Wi-Fi) has a
//! counter per channel in ArduPilot and PX4 and is two clean streams here. A conflict is
//! latched: two autopilots do not stop sharing an id until a person changes one and
//! reboots it, and the GCS should be restarted then.
//!
//! Pure: frames and heartbeats in with `now`, conflicts out ([`SysidWatch::poll_event`]).

use super::Endpoint;
use super::heartbeat::Beat;
use crate::time::Time;
use std::collections::{BTreeMap, VecDeque};
use std::fmt;
use std::time::Duration;

/// The watch's thresholds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SysidWatchConfig {
    /// The largest forward gap (frames lost in a row, plus one) that still continues a track.
    pub max_gap: u8,
    /// A gap left in a track accepts a late (reordered) frame for this long.
    pub hole_ttl: Duration,
    /// A track not continued for this long is forgotten (a counter that stopped: a reboot).
    pub track_ttl: Duration,
    /// A duplicate is recognised by content for this long after the original.
    pub dup_ttl: Duration,
    /// A frame with the number of one received this recently (and since the stream's last
    /// silence of [`SysidWatchConfig::silence`]) but another content is a collision: the
    /// time the stream takes to bring 64 frames (a quarter of a counter's round, so at most
    /// half of one at 50 % loss), within these bounds.
    pub collision_ttl: (Duration, Duration),
    /// Reception gap after which the counter may have restarted (a reboot is silent for
    /// longer: ArduPilot and PX4 take seconds to boot).
    pub silence: Duration,
    /// Collisions within `window` that make a conflict.
    pub collisions: usize,
    /// Frames a track needs before a switch to or from it counts.
    pub min_track_frames: u32,
    /// Returns to a left track within `window` that make a conflict.
    pub returns: usize,
    /// Heartbeat identity flips within `window` that make a conflict.
    pub flips: usize,
    /// The window the returns and flips are counted in.
    pub window: Duration,
    /// Frames of a system heard on one link before it counts as checked (no conflict seen).
    pub settle_frames: u64,
    /// Time a system must have been heard on one link before it counts as checked.
    pub settle_time: Duration,
}

impl Default for SysidWatchConfig {
    fn default() -> Self {
        SysidWatchConfig {
            max_gap: 32,
            hole_ttl: Duration::from_millis(1500),
            track_ttl: Duration::from_secs(2),
            dup_ttl: Duration::from_secs(3),
            // The lower bound is under half a counter's round up to 256 Hz.
            collision_ttl: (Duration::from_millis(500), Duration::from_secs(3)),
            silence: Duration::from_millis(500),
            collisions: 8,
            min_track_frames: 5,
            returns: 6,
            flips: 3,
            window: Duration::from_secs(10),
            settle_frames: 40,
            settle_time: Duration::from_secs(3),
        }
    }
}

/// What showed that two autopilots share a system id.
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Evidence {
    /// Frames with the same sequence number and different contents, moments apart: two
    /// counters in step.
    Collisions {
        /// Collisions within the window.
        collisions: usize,
        /// The window, seconds.
        window_s: u64,
    },
    /// The stream kept switching between two sequence counters.
    Sequence {
        /// Returns to a counter the stream had left, within the window.
        returns: usize,
        /// The window, seconds.
        window_s: u64,
    },
    /// The heartbeats flipped between two identities.
    Identity {
        /// (MAV_TYPE, MAV_AUTOPILOT) of one.
        a: (u8, u8),
        /// (MAV_TYPE, MAV_AUTOPILOT) of the other.
        b: (u8, u8),
    },
}

impl fmt::Display for Evidence {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Evidence::Sequence { returns, window_s } => write!(
                f,
                "its frames carry two interleaved MAVLink sequence counters \
                 ({returns} switches back within {window_s} s)"
            ),
            Evidence::Collisions {
                collisions,
                window_s,
            } => write!(
                f,
                "two different frames arrived with the same MAVLink sequence number \
                 moments apart ({collisions} times within {window_s} s)"
            ),
            Evidence::Identity { a, b } => write!(
                f,
                "its heartbeats alternate between MAV_TYPE {} / MAV_AUTOPILOT {} and \
                 MAV_TYPE {} / MAV_AUTOPILOT {}",
                a.0, a.1, b.0, b.1
            ),
        }
    }
}

/// Two (or more) senders seen behind one (link, system id, component id).
#[derive(Clone, Debug, PartialEq, Eq, serde::Serialize)]
pub struct Conflict {
    /// The shared endpoint.
    pub who: Endpoint,
    /// The link it was seen on (the caller's link index).
    pub link: usize,
    /// What showed it.
    pub evidence: Evidence,
    /// When it was decided.
    pub at: Time,
    /// When the stream was first heard.
    pub since: Time,
}

#[derive(Clone, Debug)]
struct Track {
    id: u64,
    last: u8,
    last_at: Time,
    /// [`Stream::advanced`] when it was last continued.
    stamp: u64,
    frames: u32,
    /// Sequence numbers skipped when the track moved on, and when.
    holes: VecDeque<(u8, Time)>,
}

#[derive(Clone, Debug)]
struct Stream {
    first: Time,
    frames: u64,
    /// How far the counters heard have moved in all (the sum of the forward gaps).
    advanced: u64,
    tracks: Vec<Track>,
    /// The track the last counted frame continued.
    current: Option<u64>,
    /// Tracks left with at least `min_track_frames` frames (their ids).
    left: Vec<u64>,
    next_id: u64,
    returns: VecDeque<Time>,
    collisions: VecDeque<Time>,
    /// The last frame received, and the first after the last silence or counter restart.
    last_at: Time,
    resumed_at: Time,
    /// The content check, time and [`Stream::advanced`] of the last frame per sequence
    /// number.
    seen: Vec<Option<(u16, Time, u64)>>,
}

#[derive(Clone, Debug, Default)]
struct Identity {
    last: Option<(u8, u8)>,
    other: Option<(u8, u8)>,
    flips: VecDeque<Time>,
}

/// Holes kept per track (a gap is at most `max_gap` − 1 frames).
const MAX_HOLES: usize = 64;
/// Tracks kept per stream.
const MAX_TRACKS: usize = 4;
/// Tracks at most this many numbers apart may be one counter (see `handle_frame`).
const BRAID: u8 = 16;
/// Sequence numbers just before a track started after a long burst of loss that may still
/// arrive late (reordered across the burst).
const LATE_AFTER_JUMP: u8 = 8;

/// A frame numbered at most this, continuing no track, is a counter started again (from 0,
/// its first few frames possibly lost).
const RESTART_MAX_SEQ: u8 = 7;

impl Stream {
    /// Whether `seq` continues a live track (a forward gap of at most `max_gap`) or fills a
    /// gap one left moments ago.
    fn continues(&self, seq: u8, now: Time, cfg: &SysidWatchConfig) -> bool {
        self.tracks.iter().any(|t| {
            let gap = seq.wrapping_sub(t.last);
            (now.saturating_since(t.last_at) < cfg.track_ttl && gap >= 1 && gap <= cfg.max_gap)
                || t.holes
                    .iter()
                    .any(|&(h, at)| h == seq && now.saturating_since(at) <= cfg.hole_ttl)
        })
    }
}

/// Record the numbers a track skipped moving `gap` on from `last`.
fn push_holes(holes: &mut VecDeque<(u8, Time)>, last: u8, gap: u8, now: Time) {
    for k in 1..gap {
        if holes.len() == MAX_HOLES {
            holes.pop_front();
        }
        holes.push_back((last.wrapping_add(k), now));
    }
}

/// The watch over every (link, endpoint) heard. See the module documentation.
#[derive(Debug, Default)]
pub struct SysidWatch {
    cfg: SysidWatchConfig,
    streams: BTreeMap<(usize, Endpoint), Stream>,
    identities: BTreeMap<(usize, Endpoint), Identity>,
    conflicts: BTreeMap<u8, Conflict>,
    events: VecDeque<Conflict>,
}

impl SysidWatch {
    /// A watch with thresholds `cfg`.
    pub fn new(cfg: SysidWatchConfig) -> SysidWatch {
        SysidWatch {
            cfg,
            ..SysidWatch::default()
        }
    }

    /// A frame from `who` on link `link`: its header's sequence number `seq` and a check of
    /// its content `check` (its CRC), received at `now`.
    pub fn handle_frame(&mut self, link: usize, who: Endpoint, seq: u8, check: u16, now: Time) {
        let cfg = self.cfg;
        let s = self.streams.entry((link, who)).or_insert_with(|| Stream {
            first: now,
            frames: 0,
            advanced: 0,
            tracks: Vec::new(),
            current: None,
            left: Vec::new(),
            next_id: 0,
            returns: VecDeque::new(),
            collisions: VecDeque::new(),
            last_at: now,
            resumed_at: now,
            seen: vec![None; 256],
        });
        s.frames += 1;
        if now.saturating_since(s.last_at) >= cfg.silence {
            s.resumed_at = now;
        }
        s.last_at = now;
        let rate = s.frames as f64 / now.saturating_since(s.first).as_secs_f64().max(1.0);
        let ttl = Duration::from_secs_f64(64.0 / rate.max(1e-3))
            .clamp(cfg.collision_ttl.0, cfg.collision_ttl.1);
        let prior = s.seen[usize::from(seq)];
        // A duplicate: the same frame again (a radio's retry, a second path).
        if let Some((c, at, _)) = prior
            && c == check
            && now.saturating_since(at) <= cfg.dup_ttl
        {
            return;
        }
        // A counter that starts again from 0 (a reboot) behind a radio's buffer: the frames
        // sent before the reboot arrive right before those after it, without the silence
        // that tells a reboot otherwise (ArduCopter SITL at ×5 through a SiK radio's 4 kB:
        // 0.3 s). The numbers of the new count are not collisions with the old one.
        if seq <= RESTART_MAX_SEQ && s.frames > 1 && !s.continues(seq, now, &cfg) {
            s.resumed_at = now;
        }
        match prior {
            // The same number, another content, moments ago and since the last silence or
            // restart (a counter restarted by a reboot) with the counters not gone round
            // since: a second counter in step with the first.
            Some((_, at, stamp))
                if at >= s.resumed_at
                    && now.saturating_since(at) <= ttl
                    && s.advanced.saturating_sub(stamp) < 128 =>
            {
                // Collisions that stopped for `ttl` were a restart's (below): two restarts
                // unseen within the window are not one long run of collisions.
                if s.collisions
                    .back()
                    .is_some_and(|t| now.saturating_since(*t) > ttl)
                {
                    s.collisions.clear();
                }
                s.collisions.push_back(now);
            }
            _ => {}
        }
        s.seen[usize::from(seq)] = Some((check, now, s.advanced));
        while s
            .collisions
            .front()
            .is_some_and(|t| now.saturating_since(*t) > cfg.window)
        {
            s.collisions.pop_front();
        }
        // Spread over more than `ttl` without a pause of `ttl`: a reboot's new count collides
        // with the old one only for `ttl` after it (even when the restart was not seen, its
        // first frames lost), and then stops; two counters in step go on colliding.
        if s.collisions.len() >= cfg.collisions
            && let (Some(first), Some(last)) = (s.collisions.front(), s.collisions.back())
            && last.saturating_since(*first) > ttl
        {
            let evidence = Evidence::Collisions {
                collisions: s.collisions.len(),
                window_s: cfg.window.as_secs(),
            };
            let since = s.first;
            self.conflict(link, who, evidence, since, now);
            return;
        }
        // A track is forgotten once it stopped for `track_ttl`, or once the counters heard
        // have moved on by 2 × `max_gap` without it: a counter left behind by a burst of
        // loss would otherwise be "continued" when the stream comes round to it again.
        // (Two senders keep both tracks fresh: each frame of one moves the counters by the
        // other's few frames in between.)
        let horizon = 2 * u64::from(cfg.max_gap);
        let advanced = s.advanced;
        s.tracks.retain(|t| {
            now.saturating_since(t.last_at) < cfg.track_ttl
                && advanced.saturating_sub(t.stamp) <= horizon
        });
        let live: Vec<u64> = s.tracks.iter().map(|t| t.id).collect();
        s.left.retain(|id| live.contains(id));
        // A late frame filling a gap a track left moments ago (before anything else: after
        // a long burst of loss, a reordered frame may also look like the next of a track the
        // counter left behind).
        for t in &mut s.tracks {
            if let Some(p) = t
                .holes
                .iter()
                .position(|&(h, at)| h == seq && now.saturating_since(at) <= cfg.hole_ttl)
            {
                t.holes.remove(p);
                return;
            }
        }
        // The track this frame continues: the nearest forward gap, the current track on a tie.
        let next = s
            .tracks
            .iter()
            .enumerate()
            .filter_map(|(i, t)| {
                let gap = seq.wrapping_sub(t.last);
                (gap >= 1 && gap <= cfg.max_gap).then_some((gap, s.current != Some(t.id), i))
            })
            .min();
        let idx = match next {
            Some((gap, _, i)) => {
                let t = &mut s.tracks[i];
                push_holes(&mut t.holes, t.last, gap, now);
                s.advanced += u64::from(gap);
                t.last = seq;
                t.last_at = now;
                t.stamp = s.advanced;
                t.frames = t.frames.saturating_add(1);
                i
            }
            None => {
                // Anything else is another counter: a new track. When the frame is ahead of
                // a track (a burst of loss longer than `max_gap`), the few numbers just
                // before it may still arrive late.
                let ahead = s
                    .tracks
                    .iter()
                    .map(|t| seq.wrapping_sub(t.last))
                    .filter(|g| *g < 128)
                    .min();
                if s.tracks.len() == MAX_TRACKS
                    && let Some(oldest) = s
                        .tracks
                        .iter()
                        .enumerate()
                        .min_by_key(|(_, t)| t.last_at)
                        .map(|(i, _)| i)
                {
                    let gone = s.tracks.remove(oldest).id;
                    s.left.retain(|id| *id != gone);
                }
                let mut holes = VecDeque::new();
                if let Some(g) = ahead {
                    let late = g.min(LATE_AFTER_JUMP + 1);
                    push_holes(&mut holes, seq.wrapping_sub(late), late, now);
                }
                s.next_id += 1;
                s.advanced += u64::from(ahead.unwrap_or(1));
                s.tracks.push(Track {
                    id: s.next_id,
                    last: seq,
                    last_at: now,
                    stamp: s.advanced,
                    frames: 1,
                    holes,
                });
                s.tracks.len() - 1
            }
        };
        let (id, frames) = (s.tracks[idx].id, s.tracks[idx].frames);
        if s.current != Some(id) {
            let min = cfg.min_track_frames;
            // The track left, when it is established (a stray frame's track is not).
            let prev = s
                .current
                .and_then(|c| s.tracks.iter().find(|t| t.id == c))
                .filter(|t| t.frames >= min)
                .map(|t| t.id);
            // Two tracks a few numbers apart are one counter braided by reordering across a
            // burst of loss; counters in step are told by their collisions instead.
            let last = s.tracks[idx].last;
            let far = |p: u64| {
                s.tracks.iter().find(|t| t.id == p).is_some_and(|t| {
                    let d = last.wrapping_sub(t.last);
                    d.min(d.wrapping_neg()) > BRAID
                })
            };
            if let Some(prev) = prev {
                if frames >= min && s.left.contains(&id) && far(prev) {
                    s.returns.push_back(now);
                }
                if !s.left.contains(&prev) {
                    s.left.push(prev);
                }
            }
            s.current = Some(id);
        }
        while s
            .returns
            .front()
            .is_some_and(|t| now.saturating_since(*t) > cfg.window)
        {
            s.returns.pop_front();
        }
        if s.returns.len() >= cfg.returns {
            let evidence = Evidence::Sequence {
                returns: s.returns.len(),
                window_s: cfg.window.as_secs(),
            };
            let since = s.first;
            self.conflict(link, who, evidence, since, now);
        }
    }

    /// A heartbeat from `who` on link `link` at `now`.
    pub fn handle_heartbeat(&mut self, link: usize, who: Endpoint, beat: &Beat, now: Time) {
        let cfg = self.cfg;
        let id = self.identities.entry((link, who)).or_default();
        let this = (beat.mav_type, beat.autopilot);
        match id.last {
            Some(last) if last != this => {
                id.other = Some(last);
                id.flips.push_back(now);
            }
            _ => {}
        }
        id.last = Some(this);
        while id
            .flips
            .front()
            .is_some_and(|t| now.saturating_since(*t) > cfg.window)
        {
            id.flips.pop_front();
        }
        if id.flips.len() >= cfg.flips
            && let Some(other) = id.other
        {
            let evidence = Evidence::Identity { a: other, b: this };
            let since = self
                .streams
                .get(&(link, who))
                .map_or(now, |s| s.first.min(now));
            self.conflict(link, who, evidence, since, now);
        }
    }

    fn conflict(&mut self, link: usize, who: Endpoint, evidence: Evidence, since: Time, now: Time) {
        if self.conflicts.contains_key(&who.sysid) {
            return;
        }
        let c = Conflict {
            who,
            link,
            evidence,
            at: now,
            since,
        };
        self.conflicts.insert(who.sysid, c.clone());
        self.events.push_back(c);
    }

    /// The conflict seen on system `sysid`, if any (latched).
    pub fn conflict_of(&self, sysid: u8) -> Option<&Conflict> {
        self.conflicts.get(&sysid)
    }

    /// Whether system `sysid` has been heard long enough on some link to say that no second
    /// autopilot shares its id there ([`SysidWatchConfig::settle_frames`] frames over
    /// [`SysidWatchConfig::settle_time`]) — or a conflict was seen.
    pub fn checked(&self, sysid: u8, now: Time) -> bool {
        self.conflicts.contains_key(&sysid)
            || self.streams.iter().any(|((_, who), s)| {
                who.sysid == sysid
                    && s.frames >= self.cfg.settle_frames
                    && now.saturating_since(s.first) >= self.cfg.settle_time
            })
    }

    /// The next conflict found (each system once).
    pub fn poll_event(&mut self) -> Option<Conflict> {
        self.events.pop_front()
    }
}

#[cfg(test)]
mod tests;
