//! A pair of SiK telemetry radios, one at the GCS and one on the vehicle, as the frames
//! crossing them see it: a byte budget on the air, a serial buffer in each radio, frames
//! lost at range, and the RADIO_STATUS reports each radio writes into its own serial port.
//! Pure: no clock, no tokio — every call takes `now` (the caller's clock, µs), so the same
//! arrivals and seed give the same deliveries. [`super::relay`] runs one between two links.
//!
//! **The air.** [`RadioConfig::bytes_per_s`] is what the pair carries of the MAVLink bytes
//! handed to it, after the radios' own packet headers, error correction and silence periods
//! (a 64 kbit/s air rate gives about 2–5 kB/s of MAVLink). Frames go on the air whole, one
//! after the other, in the order they arrived at their radio; a frame of `n` bytes occupies
//! the air for `n / bytes_per_s`, and it comes out of the other radio when its last byte
//! has crossed. Time is accounted exactly over each busy period (integer µs, rounded up),
//! as in a serializer that never drifts; an idle air banks no credit.
//!
//! * [`Duplex::Half`] — a SiK radio pair is time-division duplex (`Firmware/radio/tdm.c`):
//!   the two radios take turns on one channel, each transmitting in its own window and
//!   yielding the rest of it when its serial buffer is empty (a zero-length packet that
//!   gives the other radio a bonus window, `tdm.c` `sync_tx_windows`, `transmit_yield`). So
//!   both directions share one budget. Here one serializer carries both; when both radios
//!   have frames waiting it takes the next frame from the radio that has sent fewer bytes
//!   since both became busy (ties: the other radio than the last), which gives each
//!   direction half the air within one frame, as SiK's alternate equal windows give each
//!   half the time; when only one radio has frames, it gets the whole air, as a yielding
//!   radio gives its window away. SiK's windows hold several packets, so its real turns are
//!   coarser than a frame: over a second the shares are the same, within a window the
//!   order of frames from the two ends differs.
//! * [`Duplex::Full`] — each direction its own serializer at `bytes_per_s` (a radio link
//!   with a channel each way, or two radios): the relay's per-direction rate limit.
//!
//! **The buffers.** Each radio holds the frames its serial side has written and the air has
//! not yet taken, up to [`RadioConfig::buffer_bytes`] (SiK: the serial receive buffer
//! `rx_buf`, `RX_BUFF_MAX` = 1850 bytes on the Si1000 radios, `Firmware/radio/serial.c`); a
//! frame that does not fit is dropped whole and counted (tail drop). A frame leaves the
//! buffer when its transmission starts, as SiK reads a whole air packet out of the serial
//! buffer when it builds it (`packet.c` `packet_get_next`).
//!
//! **Loss.** Each frame is lost on the air with probability [`RadioConfig::loss`] (seeded,
//! one random stream per radio); a lost frame used its airtime, is counted, and adds one to
//! the receiving radio's receive errors (SiK `errors.rx_errors`, counted when a packet fails
//! to decode, `radio_446x.c` / `radio_443x.c`; it stops at 65 535 and so does this count).
//!
//! **RADIO_STATUS.** With [`RadioConfig::radio_status`], a radio writes a RADIO_STATUS
//! (message 109, system 51 `'3'`, component 68 `'D'`) into its own serial port each time a
//! heartbeat from that side leaves its buffer for the air: SiK notes a heartbeat as it packs
//! frames for the air (`packet.c` `check_response`, any frame with message id 0) and its
//! main loop then calls `MAVLink_report` (`mavlink.c`, from `tdm.c` `tdm_serial_loop`),
//! answering in the heartbeat's own MAVLink version. An autopilot and a GCS each send a
//! heartbeat a second, so each side gets about one report a second — none while its
//! heartbeats are being dropped on a full buffer. The report ([`RadioStatus`]) carries
//! txbuf = the percent of that radio's buffer free (`serial_read_space`), rssi/noise as
//! this radio hears them and remrssi/remnoise as the other does ([`SignalLevels`]), the
//! receive errors, and fixed = 0. It goes over the serial cable, not the air: it costs no
//! airtime and is never lost. ArduPilot slows its streams on it (`GCS_Common.cpp`
//! `handle_radio_status`: txbuf < 20 % adds 60 ms to every stream interval, < 50 % adds 20
//! ms, > 90 % / > 95 % takes them back).

mod status;

pub use status::{
    RADIO_COMPID, RADIO_STATUS_ID, RADIO_SYSID, RadioStatus, encode as encode_status, free_percent,
};

use super::codec::{STX_V1, STX_V2};
use fleetmap_core::time::Time;
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::HEARTBEAT_DATA;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, VecDeque};
use std::time::Duration;
use thiserror::Error;

/// One radio of the pair, named by what its serial port is wired to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum End {
    /// The radio at the ground station.
    Gcs,
    /// The radio on the vehicle, wired to the autopilot.
    Vehicle,
}

impl End {
    /// The radio at the other end of the air.
    pub fn other(self) -> End {
        match self {
            End::Gcs => End::Vehicle,
            End::Vehicle => End::Gcs,
        }
    }

    fn index(self) -> usize {
        match self {
            End::Gcs => 0,
            End::Vehicle => 1,
        }
    }
}

/// Whether the two directions share the air.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Duplex {
    /// One budget for both directions, shared fairly when both have data (SiK's TDM).
    Half,
    /// A budget each way.
    #[default]
    Full,
}

/// What a radio reports about the signal, in SiK's units (the Si1000's RSSI register as
/// SiK averages it: `statistics.average_rssi`, `average_noise`; higher is stronger, about
/// two units per dB).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct SignalLevels {
    /// Strength of the other radio's signal as this one receives it.
    pub rssi: u8,
    /// Background noise this radio hears.
    pub noise: u8,
}

impl Default for SignalLevels {
    /// A usable link some way off: rssi 100, noise 40 (60 units, about 30 dB, of margin).
    fn default() -> SignalLevels {
        SignalLevels {
            rssi: 100,
            noise: 40,
        }
    }
}

/// A radio pair's configuration (see the module documentation for what each part models).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RadioConfig {
    /// MAVLink bytes per second the air carries (in all for [`Duplex::Half`], each way for
    /// [`Duplex::Full`]); 0: unlimited (every frame crosses when it arrives, nothing waits).
    pub bytes_per_s: u32,
    /// Whether the directions share the air.
    pub duplex: Duplex,
    /// Each radio's serial buffer, bytes (never less than [`RadioConfig::MAX_FRAME_BYTES`];
    /// no limit when `bytes_per_s` is 0).
    pub buffer_bytes: u32,
    /// Probability that a frame is lost on the air, 0–1.
    pub loss: f64,
    /// Whether each radio writes RADIO_STATUS into its own side.
    pub radio_status: bool,
    /// What the GCS's radio hears.
    pub gcs_levels: SignalLevels,
    /// What the vehicle's radio hears.
    pub vehicle_levels: SignalLevels,
}

impl RadioConfig {
    /// The serial buffer of a SiK radio on an Si1000 (3DR, Holybro, HM-TRP radios), bytes:
    /// `RX_BUFF_MAX` in `Firmware/radio/serial.c` (1024 on the Si1030 build).
    pub const SIK_BUFFER_BYTES: u32 = 1850;

    /// The buffer of [`RadioConfig::radio`], bytes: 4 kB each way.
    pub const RADIO_BUFFER_BYTES: u32 = 4096;

    /// The longest MAVLink frame, bytes: a MAVLink 2 frame with a 255-byte payload and a
    /// signature (10 header + 255 + 2 CRC + 13 signature). A buffer is never smaller.
    pub const MAX_FRAME_BYTES: u32 = 280;

    /// No radio: unlimited, lossless, no reports (the relay's default).
    pub fn unlimited() -> RadioConfig {
        RadioConfig {
            bytes_per_s: 0,
            duplex: Duplex::Full,
            buffer_bytes: Self::SIK_BUFFER_BYTES,
            loss: 0.0,
            radio_status: false,
            gcs_levels: SignalLevels::default(),
            vehicle_levels: SignalLevels::default(),
        }
    }

    /// A byte rate each way with a SiK buffer in each radio and no reports:
    /// `fleetmap relay --rate` (about 5,000 for a 57,600-baud radio).
    pub fn per_direction(bytes_per_s: u32) -> RadioConfig {
        RadioConfig {
            bytes_per_s,
            ..RadioConfig::unlimited()
        }
    }

    /// A SiK radio pair carrying `bytes_per_s` in all: half duplex, 4 kB buffers, RADIO_STATUS
    /// injected, no loss (`fleetmap relay --radio`).
    pub fn radio(bytes_per_s: u32) -> RadioConfig {
        RadioConfig {
            bytes_per_s,
            duplex: Duplex::Half,
            buffer_bytes: Self::RADIO_BUFFER_BYTES,
            radio_status: true,
            ..RadioConfig::unlimited()
        }
    }

    /// Check the loss probability.
    pub fn validate(&self) -> Result<(), RadioError> {
        if !(0.0..=1.0).contains(&self.loss) {
            return Err(RadioError(format!(
                "loss must be between 0 and 1, got {}",
                self.loss
            )));
        }
        Ok(())
    }

    /// Each radio's buffer as used: `buffer_bytes`, at least one longest frame.
    pub fn capacity(&self) -> u64 {
        u64::from(self.buffer_bytes.max(Self::MAX_FRAME_BYTES))
    }

    fn levels(&self, end: End) -> SignalLevels {
        match end {
            End::Gcs => self.gcs_levels,
            End::Vehicle => self.vehicle_levels,
        }
    }
}

impl Default for RadioConfig {
    fn default() -> RadioConfig {
        RadioConfig::unlimited()
    }
}

/// A radio configuration is out of range.
#[derive(Debug, Error, PartialEq)]
#[error("invalid radio: {0}")]
pub struct RadioError(pub String);

/// How a delivered frame got there.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Carried {
    /// Across the air, from the other radio.
    Air,
    /// Written by the radio itself: a RADIO_STATUS report.
    Status,
}

/// A frame that comes out of a radio's serial port.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Delivery {
    /// The radio it comes out of (a report comes out of the radio that wrote it).
    pub to: End,
    /// When: the air frame's last byte crossed, or the report was written.
    pub at: Time,
    /// The frame's bytes, unchanged.
    pub frame: Vec<u8>,
    /// Air frame or report.
    pub carried: Carried,
}

/// Counts of one message id in one direction.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct MessageCounts {
    /// Frames handed to the sending radio.
    pub frames_in: u64,
    /// Their bytes.
    pub bytes_in: u64,
    /// Frames that came out of the other radio.
    pub frames_out: u64,
    /// Their bytes.
    pub bytes_out: u64,
    /// Frames dropped on a full buffer.
    pub dropped: u64,
    /// Frames lost on the air.
    pub lost: u64,
}

/// Counts of one direction (frames one radio sends to the other).
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct DirectionCounts {
    /// Frames handed to the sending radio by its side.
    pub frames_in: u64,
    /// Their bytes (whole frames, signatures included).
    pub bytes_in: u64,
    /// Frames that came out of the other radio.
    pub frames_out: u64,
    /// Their bytes.
    pub bytes_out: u64,
    /// Frames dropped because the sending radio's buffer had no room (tail drop).
    pub dropped: u64,
    /// Their bytes.
    pub bytes_dropped: u64,
    /// Frames lost on the air (they used their airtime).
    pub lost: u64,
    /// Their bytes.
    pub bytes_lost: u64,
    /// Most bytes ever waiting at once in the sending radio's buffer (the frame just
    /// accepted included), bytes (0 when unlimited: nothing waits).
    pub peak_buffer_bytes: u64,
    /// Time this direction held the air (lost frames included), µs (0 when unlimited).
    pub air_us: u64,
    /// The same counts per MAVLink message id.
    pub by_message: BTreeMap<u32, MessageCounts>,
}

/// Counts of one radio.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct EndCounts {
    /// RADIO_STATUS reports it wrote into its side.
    pub radio_status: u64,
    /// Frames it failed to receive (its reports' rxerrors; stops at 65 535).
    pub rx_errors: u16,
    /// Bytes waiting in its buffer now.
    pub buffered_bytes: u64,
}

/// What a radio pair did.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct RadioStats {
    /// From the GCS's radio to the vehicle's.
    pub up: DirectionCounts,
    /// From the vehicle's radio to the GCS's.
    pub down: DirectionCounts,
    /// The GCS's radio.
    pub gcs: EndCounts,
    /// The vehicle's radio.
    pub vehicle: EndCounts,
}

/// The MAVLink message id of a frame (MAVLink 1 or 2), if it has a whole header.
pub fn message_id(frame: &[u8]) -> Option<u32> {
    match *frame.first()? {
        STX_V1 if frame.len() >= 6 => Some(u32::from(frame[5])),
        STX_V2 if frame.len() >= 10 => Some(u32::from_le_bytes([frame[7], frame[8], frame[9], 0])),
        _ => None,
    }
}

/// One radio: its buffer, its random stream, its report counter and its counts.
#[derive(Debug)]
struct Radio {
    queue: VecDeque<Vec<u8>>,
    buffered: u64,
    rng: ChaCha8Rng,
    seq: u8,
    rx_errors: u16,
    reports: u64,
    sent: DirectionCounts,
}

/// A frame on the air.
#[derive(Debug)]
struct InFlight {
    from: End,
    frame: Vec<u8>,
    until: Time,
    lost: bool,
}

/// One serializer (the one shared channel when half duplex; one per direction when full).
#[derive(Debug, Default)]
struct Air {
    /// When the current busy period began.
    busy_start: Time,
    /// Bytes put on the air since.
    busy_bytes: u64,
    /// When the last frame's last byte crossed.
    free_at: Time,
    flight: Option<InFlight>,
    /// Bytes each radio sent since both last had frames waiting (half duplex fairness).
    served: [u64; 2],
    /// The radio that sent last.
    last: Option<End>,
}

/// A pair of radios and the air between them. Frames go in with [`RadioPair::push`] (which
/// radio's serial port they were written to) and come out with [`RadioPair::poll`]; call
/// `poll` again at [`RadioPair::poll_timeout`]. Times passed in must not go back (an
/// earlier `now` counts as the latest seen).
#[derive(Debug)]
pub struct RadioPair {
    cfg: RadioConfig,
    radios: [Radio; 2],
    airs: Vec<Air>,
    out: VecDeque<Delivery>,
    now: Time,
}

impl RadioPair {
    /// A pair configured by `cfg`; the GCS's radio draws its losses from `seed`, the
    /// vehicle's from `seed + 1`.
    pub fn new(cfg: RadioConfig, seed: u64) -> RadioPair {
        let radio = |seed: u64| Radio {
            queue: VecDeque::new(),
            buffered: 0,
            rng: ChaCha8Rng::seed_from_u64(seed),
            seq: 0,
            rx_errors: 0,
            reports: 0,
            sent: DirectionCounts::default(),
        };
        let airs = match cfg.duplex {
            Duplex::Half => 1,
            Duplex::Full => 2,
        };
        RadioPair {
            cfg,
            radios: [radio(seed), radio(seed.wrapping_add(1))],
            airs: (0..airs).map(|_| Air::default()).collect(),
            out: VecDeque::new(),
            now: Time::ZERO,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &RadioConfig {
        &self.cfg
    }

    /// `from`'s side wrote `frame` into its radio at `now`: buffered and `true`, or dropped
    /// (counted) and `false` when the radio's buffer has no room for it.
    pub fn push(&mut self, from: End, frame: Vec<u8>, now: Time) -> bool {
        self.advance(now);
        let now = self.now;
        let len = frame.len() as u64;
        let id = message_id(&frame);
        let cap = self.cfg.capacity();
        let limited = self.cfg.bytes_per_s > 0;
        let radio = &mut self.radios[from.index()];
        radio.sent.frames_in += 1;
        radio.sent.bytes_in += len;
        let full = limited && radio.buffered + len > cap;
        if full {
            radio.sent.dropped += 1;
            radio.sent.bytes_dropped += len;
        }
        if let Some(id) = id {
            let m = radio.sent.by_message.entry(id).or_default();
            m.frames_in += 1;
            m.bytes_in += len;
            m.dropped += u64::from(full);
        }
        if full {
            return false;
        }
        radio.queue.push_back(frame);
        radio.buffered += len;
        if limited {
            radio.sent.peak_buffer_bytes = radio.sent.peak_buffer_bytes.max(radio.buffered);
        }
        let air = self.air_of(from);
        if self.airs[air].flight.is_none() {
            self.start_next(air, now, true);
        }
        true
    }

    /// The next frame out of either radio by `now` (in time order), if any.
    pub fn poll(&mut self, now: Time) -> Option<Delivery> {
        self.advance(now);
        self.out.pop_front()
    }

    /// When [`RadioPair::poll`] next has something: a delivery waiting, or the end of the
    /// frame on the air that ends first.
    pub fn poll_timeout(&self) -> Option<Time> {
        if let Some(d) = self.out.front() {
            return Some(d.at);
        }
        self.airs
            .iter()
            .filter_map(|a| a.flight.as_ref().map(|f| f.until))
            .min()
    }

    /// Bytes waiting in `end`'s buffer.
    pub fn buffered_bytes(&self, end: End) -> u64 {
        self.radios[end.index()].buffered
    }

    /// Frames `end` failed to receive (stops at 65 535).
    pub fn rx_errors(&self, end: End) -> u16 {
        self.radios[end.index()].rx_errors
    }

    /// The counts so far.
    pub fn stats(&self) -> RadioStats {
        let end = |r: &Radio| EndCounts {
            radio_status: r.reports,
            rx_errors: r.rx_errors,
            buffered_bytes: r.buffered,
        };
        RadioStats {
            up: self.radios[0].sent.clone(),
            down: self.radios[1].sent.clone(),
            gcs: end(&self.radios[0]),
            vehicle: end(&self.radios[1]),
        }
    }

    fn air_of(&self, from: End) -> usize {
        match self.cfg.duplex {
            Duplex::Half => 0,
            Duplex::Full => from.index(),
        }
    }

    /// Finish every transmission that ends by `now` and start the next frames at the exact
    /// moments the air frees.
    fn advance(&mut self, now: Time) {
        self.now = self.now.max(now);
        loop {
            let next = self
                .airs
                .iter()
                .enumerate()
                .filter_map(|(i, a)| a.flight.as_ref().map(|f| (f.until, i)))
                .filter(|(t, _)| *t <= self.now)
                .min();
            let Some((t, i)) = next else { break };
            self.finish(i);
            self.start_next(i, t, false);
        }
    }

    /// The frame on air `i` has crossed (or was lost).
    fn finish(&mut self, i: usize) {
        let Some(f) = self.airs[i].flight.take() else {
            return;
        };
        let len = f.frame.len() as u64;
        let id = message_id(&f.frame);
        let sent = &mut self.radios[f.from.index()].sent;
        if let Some(id) = id {
            let m = sent.by_message.entry(id).or_default();
            if f.lost {
                m.lost += 1;
            } else {
                m.frames_out += 1;
                m.bytes_out += len;
            }
        }
        if f.lost {
            sent.lost += 1;
            sent.bytes_lost += len;
            let to = &mut self.radios[f.from.other().index()];
            to.rx_errors = to.rx_errors.saturating_add(1);
        } else {
            sent.frames_out += 1;
            sent.bytes_out += len;
            self.out.push_back(Delivery {
                to: f.from.other(),
                at: f.until,
                frame: f.frame,
                carried: Carried::Air,
            });
        }
    }

    /// Air `i` is free at `t`: put the next waiting frame on it, if any. `idle`: the air
    /// was idle before `t` (a new busy period starts), else a frame just ended at `t`.
    fn start_next(&mut self, i: usize, t: Time, idle: bool) {
        let waiting = |e: End| self.air_of(e) == i && !self.radios[e.index()].queue.is_empty();
        let from = match (waiting(End::Gcs), waiting(End::Vehicle)) {
            (false, false) => return,
            (true, false) => {
                self.airs[i].served = [0, 0];
                End::Gcs
            }
            (false, true) => {
                self.airs[i].served = [0, 0];
                End::Vehicle
            }
            (true, true) => {
                let [g, v] = self.airs[i].served;
                if g < v {
                    End::Gcs
                } else if v < g {
                    End::Vehicle
                } else {
                    self.airs[i].last.map_or(End::Gcs, End::other)
                }
            }
        };
        let radio = &mut self.radios[from.index()];
        let Some(frame) = radio.queue.pop_front() else {
            return;
        };
        let len = frame.len() as u64;
        radio.buffered -= len;
        let lost = radio.rng.random::<f64>() < self.cfg.loss;
        let rate = u128::from(self.cfg.bytes_per_s);
        let air = &mut self.airs[i];
        let until = if rate == 0 {
            t
        } else {
            if idle || t > air.free_at {
                air.busy_start = t;
                air.busy_bytes = 0;
            }
            air.busy_bytes += len;
            let us = (u128::from(air.busy_bytes) * 1_000_000).div_ceil(rate);
            air.busy_start + Duration::from_micros(u64::try_from(us).unwrap_or(u64::MAX))
        };
        air.free_at = until;
        air.served[from.index()] += len;
        air.last = Some(from);
        radio.sent.air_us += until.saturating_since(t).as_micros() as u64;
        let heartbeat = message_id(&frame) == Some(<HEARTBEAT_DATA as MessageData>::ID);
        let v2 = frame.first() == Some(&STX_V2);
        air.flight = Some(InFlight {
            from,
            frame,
            until,
            lost,
        });
        if heartbeat {
            self.report(from, v2, t);
        }
    }

    /// `end` writes a RADIO_STATUS into its own side at `t`, if reports are on.
    fn report(&mut self, end: End, v2: bool, t: Time) {
        if !self.cfg.radio_status {
            return;
        }
        let (mine, theirs) = (self.cfg.levels(end), self.cfg.levels(end.other()));
        let cap = self.cfg.capacity();
        let radio = &mut self.radios[end.index()];
        let txbuf = if self.cfg.bytes_per_s == 0 {
            100
        } else {
            free_percent(cap, radio.buffered)
        };
        let status = RadioStatus {
            rssi: mine.rssi,
            remrssi: theirs.rssi,
            txbuf,
            noise: mine.noise,
            remnoise: theirs.noise,
            rxerrors: radio.rx_errors,
            fixed: 0,
        };
        let frame = encode_status(&status, v2, radio.seq);
        radio.seq = radio.seq.wrapping_add(1);
        radio.reports += 1;
        self.out.push_back(Delivery {
            to: end,
            at: t,
            frame,
            carried: Carried::Status,
        });
    }
}

#[cfg(test)]
mod tests;
