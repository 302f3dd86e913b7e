//! A sans-IO MAVLink frame codec: feed bytes, get frames; encode messages into frames.
//!
//! * Decoding accepts MAVLink 1 (STX 0xFE) and MAVLink 2 (STX 0xFD) frames from a byte
//!   stream (UDP datagrams, TCP, serial), keeps each frame's exact bytes (for `.tlog`
//!   recording), its header, and the parsed [`MavMessage`] — or why it could not be parsed
//!   (an id outside the dialect, or a field value the dialect does not know, e.g. a newer
//!   MAV_TYPE: such frames are delivered as [`Unparsed`] and counted, never fatal).
//! * Bad-CRC frames are counted and dropped; after garbage or a bad CRC the decoder resyncs
//!   on the next start byte one byte further (so a corrupted length byte cannot swallow the
//!   frames behind it). Frames with an id we do not know cannot have their CRC checked
//!   (the CRC includes a per-message `crc_extra`); like pymavlink (`mavlink.py`
//!   `__parse_char_legacy` raises "unknown MAVLink message ID" and consumes the frame) we
//!   deliver them as unknown, but only when the next byte is a start byte or the end of the
//!   data, which rejects most random garbage.
//! * MAVLink 2 frames with unknown incompatibility flags are dropped, as the MAVLink 2
//!   specification requires (<https://mavlink.io/en/guide/serialization.html>).
//! * Encoding produces MAVLink 2 frames (payload trailing zeros trimmed, as
//!   `_mav_trim_payload` in the C library does) with a sequence number per
//!   (sysid, compid) source, optionally signed ([`super::signing`]). MAVLink 1 encoding is
//!   available for tests and simulated legacy peers.
//! * Statistics: frames and bytes in/out, bad CRC, garbage bytes, unparsed frames, signature
//!   failures, unsigned frames dropped, and per (sysid, compid) the sequence-gap loss
//!   computed as pymavlink's `mavutil` does (`mav_loss += (seq - expected) % 256`), except
//!   that a backwards jump (duplicate or reordered frame, gap ≥ 128) is counted as
//!   out-of-order instead of 255 lost frames.
//!
//! The wire format follows <https://mavlink.io/en/guide/serialization.html> and the C
//! reference `mavlink/c_library_v2` `mavlink_helpers.h` (`mavlink_finalize_message_buffer`,
//! `mavlink_frame_char_buffer`). The CRC is CRC-16/MCRF4XX (`checksum.h`).
//!
//! Time is a parameter: `unix_us` (wall-clock microseconds since the Unix epoch) is only
//! used by signing (timestamps), so unsigned use may pass 0.
//!
//! The wire format (constants, CRC, [`Frame`], [`encode_frame`]) is in `frame`, the
//! statistics ([`LinkStats`]) in `stats`; this file holds the stateful [`Codec`].

mod frame;
mod stats;

pub use frame::{
    Frame, MAX_FRAME_LEN, STX_V1, STX_V2, SignatureInfo, Unparsed, crc_accumulate, encode_frame,
    frame_crc, is_known_id,
};
pub use stats::{LinkStats, SourceStats};

use super::signing::{IFLAG_SIGNED, Rejection, SIGNATURE_LEN, Signing};
use fleetmap_core::proto::Endpoint;
use frame::{HDR_V1, HDR_V2};
use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavHeader, MavlinkVersion, Message};
use std::collections::HashMap;

/// The bytes of one incoming byte stream that do not yet form a whole frame.
///
/// A link that hears several peers at once (a `udpin` port that many vehicles send to, a
/// `tcpin` server with several clients) keeps one of these per peer and decodes with
/// [`Codec::decode_stream`], so that a frame split over two reads of one peer is never
/// spliced onto another peer's bytes, while statistics and signing (replay protection)
/// stay those of the link.
#[derive(Debug, Default)]
pub(crate) struct StreamBuffer {
    buf: Vec<u8>,
    pos: usize,
}

impl StreamBuffer {
    /// Bytes buffered but not yet consumed (an incomplete frame).
    #[cfg(test)]
    pub(crate) fn pending(&self) -> usize {
        self.buf.len() - self.pos
    }
}

/// The codec: a receive buffer, transmit sequence numbers, optional signing, statistics.
#[derive(Debug, Default)]
pub struct Codec {
    buf: Vec<u8>,
    pos: usize,
    tx_seq: HashMap<Endpoint, u8>,
    signing: Option<Signing>,
    stats: LinkStats,
}

impl Codec {
    /// A codec without signing.
    pub fn new() -> Codec {
        Codec::default()
    }

    /// A codec that signs outgoing frames and checks incoming ones with `signing`.
    pub fn with_signing(signing: Signing) -> Codec {
        Codec {
            signing: Some(signing),
            ..Codec::default()
        }
    }

    /// Install or remove signing.
    pub fn set_signing(&mut self, signing: Option<Signing>) {
        self.signing = signing;
    }

    /// The signing state, if any.
    pub fn signing(&self) -> Option<&Signing> {
        self.signing.as_ref()
    }

    /// Statistics so far.
    pub fn stats(&self) -> &LinkStats {
        &self.stats
    }

    /// Append received bytes to the buffer (then call [`Codec::poll_frame`]).
    pub fn push(&mut self, data: &[u8]) {
        if self.pos > 0 && self.pos >= self.buf.len() / 2 {
            self.buf.drain(..self.pos);
            self.pos = 0;
        }
        self.buf.extend_from_slice(data);
        self.stats.bytes_in += data.len() as u64;
    }

    /// Bytes buffered but not yet consumed (an incomplete frame).
    pub fn pending(&self) -> usize {
        self.buf.len() - self.pos
    }

    /// Feed `data` and return every complete frame in it.
    pub fn decode(&mut self, data: &[u8], unix_us: u64) -> Vec<Frame> {
        self.push(data);
        let mut out = Vec::new();
        while let Some(f) = self.poll_frame(unix_us) {
            out.push(f);
        }
        out
    }

    /// As [`Codec::decode`], for the bytes of one of several streams this codec hears:
    /// `stream` holds that stream's incomplete frame between calls (see [`StreamBuffer`]).
    pub(crate) fn decode_stream(
        &mut self,
        stream: &mut StreamBuffer,
        data: &[u8],
        unix_us: u64,
    ) -> Vec<Frame> {
        std::mem::swap(&mut self.buf, &mut stream.buf);
        std::mem::swap(&mut self.pos, &mut stream.pos);
        let out = self.decode(data, unix_us);
        std::mem::swap(&mut self.buf, &mut stream.buf);
        std::mem::swap(&mut self.pos, &mut stream.pos);
        out
    }

    /// The next complete, valid, accepted frame in the buffer, or `None` until more bytes
    /// arrive. `unix_us` is the wall time (for signature timestamps).
    pub fn poll_frame(&mut self, unix_us: u64) -> Option<Frame> {
        loop {
            let data = &self.buf[self.pos..];
            let Some(start) = data.iter().position(|&b| b == STX_V1 || b == STX_V2) else {
                self.stats.garbage_bytes += data.len() as u64;
                self.buf.clear();
                self.pos = 0;
                return None;
            };
            self.stats.garbage_bytes += start as u64;
            self.pos += start;
            let data = &self.buf[self.pos..];
            let v2 = data[0] == STX_V2;
            let hdr = if v2 { HDR_V2 } else { HDR_V1 };
            if data.len() < hdr {
                return None;
            }
            let len = data[1] as usize;
            let (incompat, msg_id) = if v2 {
                (
                    data[2],
                    u32::from(data[7]) | u32::from(data[8]) << 8 | u32::from(data[9]) << 16,
                )
            } else {
                (0, u32::from(data[5]))
            };
            if incompat & !IFLAG_SIGNED != 0 {
                self.stats.bad_incompat_flags += 1;
                self.skip_one();
                continue;
            }
            let signed = incompat & IFLAG_SIGNED != 0;
            let total = hdr + len + 2 + if signed { SIGNATURE_LEN } else { 0 };
            if data.len() < total {
                // Incomplete. If a complete valid frame starts later in the buffer, this
                // start byte was garbage (e.g. a corrupted length): skip it instead of
                // waiting for bytes that may never come (the last datagram of a burst).
                if scan_after(data, data.len()).valid {
                    self.skip_one();
                    continue;
                }
                return None;
            }
            let crc_end = hdr + len;
            let got = u16::from_le_bytes([data[crc_end], data[crc_end + 1]]);
            let crc_ok = got == frame_crc(&data[1..crc_end], MavMessage::extra_crc(msg_id));
            let known = crc_ok || is_known_id(msg_id);
            if !crc_ok {
                if known {
                    self.stats.bad_crc += 1;
                    self.skip_one();
                    continue;
                }
                // Unknown id: plausible only if no valid frame starts inside it and a
                // frame start follows it (wait for that byte).
                let scan = scan_after(data, total);
                if scan.valid {
                    self.skip_one();
                    continue;
                }
                if scan.incomplete {
                    return None;
                }
                match data.get(total) {
                    None => return None,
                    Some(&STX_V1) | Some(&STX_V2) => {}
                    Some(_) => {
                        self.skip_one();
                        continue;
                    }
                }
            }
            let raw = data[..total].to_vec();
            self.pos += total;
            let sysid = raw[if v2 { 5 } else { 3 }];
            let compid = raw[if v2 { 6 } else { 4 }];
            let seq = raw[if v2 { 4 } else { 2 }];
            if let Some(signing) = self.signing.as_mut() {
                let checked = if signed {
                    &raw[..]
                } else {
                    &raw[..crc_end + 2]
                };
                match signing.check(checked, signed, sysid, compid, msg_id, unix_us) {
                    Ok(()) => {}
                    Err(Rejection::BadSignature) => {
                        self.stats.bad_signature += 1;
                        continue;
                    }
                    Err(Rejection::Replay) => {
                        self.stats.replayed += 1;
                        continue;
                    }
                    Err(Rejection::Unsigned) => {
                        self.stats.unsigned_dropped += 1;
                        continue;
                    }
                }
            }
            let version = if v2 {
                MavlinkVersion::V2
            } else {
                MavlinkVersion::V1
            };
            let message = if !known {
                Err(Unparsed::UnknownId)
            } else {
                MavMessage::parse(version, msg_id, &raw[hdr..crc_end]).map_err(|e| match e {
                    mavlink::error::ParserError::UnknownMessage { .. } => Unparsed::UnknownId,
                    e => Unparsed::Invalid(e.to_string()),
                })
            };
            if message.is_err() {
                self.stats.unparsed += 1;
            }
            let signature = signed.then(|| {
                let b = &raw[total - SIGNATURE_LEN..];
                let mut t = [0u8; 8];
                t[..6].copy_from_slice(&b[1..7]);
                SignatureInfo {
                    link_id: b[0],
                    timestamp: u64::from_le_bytes(t),
                }
            });
            self.note_source(sysid, compid, seq);
            self.stats.frames_in += 1;
            return Some(Frame {
                version,
                header: MavHeader {
                    system_id: u32::from(sysid),
                    component_id: compid,
                    sequence: seq,
                },
                msg_id,
                signature,
                raw,
                message,
            });
        }
    }

    fn skip_one(&mut self) {
        self.pos += 1;
        self.stats.garbage_bytes += 1;
    }

    fn note_source(&mut self, sysid: u8, compid: u8, seq: u8) {
        let s = self
            .stats
            .sources
            .entry(Endpoint::new(sysid, compid))
            .or_default();
        if s.frames > 0 {
            let gap = seq.wrapping_sub(s.last_seq.wrapping_add(1));
            if gap < 128 {
                s.lost += u64::from(gap);
                s.last_seq = seq;
            } else {
                s.out_of_order += 1;
            }
        } else {
            s.last_seq = seq;
        }
        s.frames += 1;
    }

    /// Restart the sequence numbers of a source at 0 (a simulated reboot).
    #[cfg(test)]
    pub(crate) fn reset_sequence(&mut self, sysid: u8, compid: u8) {
        self.tx_seq.remove(&Endpoint::new(sysid, compid));
    }

    /// The next sequence number for source (`sysid`, `compid`) (and advance it).
    pub(crate) fn next_sequence(&mut self, sysid: u8, compid: u8) -> u8 {
        let s = self.tx_seq.entry(Endpoint::new(sysid, compid)).or_insert(0);
        let v = *s;
        *s = s.wrapping_add(1);
        v
    }

    /// Encode `msg` from (`sysid`, `compid`) as a MAVLink 2 frame with the source's next
    /// sequence number, signed if signing is configured to sign outgoing frames.
    pub fn encode(&mut self, sysid: u8, compid: u8, msg: &MavMessage, unix_us: u64) -> Vec<u8> {
        let header = MavHeader {
            system_id: u32::from(sysid),
            component_id: compid,
            sequence: self.next_sequence(sysid, compid),
        };
        self.encode_with_header(&header, msg, MavlinkVersion::V2, unix_us)
    }

    /// Encode with an explicit header (sequence number included) and version. MAVLink 1
    /// frames are never signed; messages with an id above 255 cannot be MAVLink 1 and
    /// are sent as MAVLink 2.
    pub fn encode_with_header(
        &mut self,
        header: &MavHeader,
        msg: &MavMessage,
        version: MavlinkVersion,
        unix_us: u64,
    ) -> Vec<u8> {
        let sign = self.signing.as_mut().filter(|s| s.sign_outgoing);
        let out = encode_frame(header, msg, version, sign, unix_us);
        self.stats.frames_out += 1;
        self.stats.bytes_out += out.len() as u64;
        out
    }
}

/// What starts at the start bytes at offsets `1..limit` of `data`.
#[derive(Default)]
struct Scan {
    /// A complete frame with a valid CRC (and known id) starts there.
    valid: bool,
    /// A frame header starts there whose frame is not complete in `data` yet.
    incomplete: bool,
}

fn scan_after(data: &[u8], limit: usize) -> Scan {
    let mut scan = Scan::default();
    for i in 1..limit.min(data.len()) {
        let d = &data[i..];
        if d[0] != STX_V1 && d[0] != STX_V2 {
            continue;
        }
        let v2 = d[0] == STX_V2;
        let hdr = if v2 { HDR_V2 } else { HDR_V1 };
        if d.len() < hdr {
            scan.incomplete = true;
            continue;
        }
        let len = d[1] as usize;
        let incompat = if v2 { d[2] } else { 0 };
        if incompat & !IFLAG_SIGNED != 0 {
            continue;
        }
        let sig = if incompat & IFLAG_SIGNED != 0 {
            SIGNATURE_LEN
        } else {
            0
        };
        if d.len() < hdr + len + 2 + sig {
            scan.incomplete = true;
            continue;
        }
        let msg_id = if v2 {
            u32::from(d[7]) | u32::from(d[8]) << 8 | u32::from(d[9]) << 16
        } else {
            u32::from(d[5])
        };
        let extra = MavMessage::extra_crc(msg_id);
        let got = u16::from_le_bytes([d[hdr + len], d[hdr + len + 1]]);
        if extra != 0 && got == frame_crc(&d[1..hdr + len], extra) {
            scan.valid = true;
            return scan;
        }
    }
    scan
}

#[cfg(test)]
mod tests;
