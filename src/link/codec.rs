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

use super::signing::{IFLAG_SIGNED, Rejection, SIGNATURE_LEN, Signing};
use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavHeader, MavlinkVersion, Message};
use std::collections::HashMap;

/// MAVLink 1 start byte.
pub const STX_V1: u8 = 0xFE;
/// MAVLink 2 start byte.
pub const STX_V2: u8 = 0xFD;
/// MAVLink 1 header length including STX.
const HDR_V1: usize = 6;
/// MAVLink 2 header length including STX.
const HDR_V2: usize = 10;
/// Largest MAVLink 2 frame (header + 255 payload + CRC + signature), in bytes.
pub const MAX_FRAME_LEN: usize = HDR_V2 + 255 + 2 + SIGNATURE_LEN;

/// CRC-16/MCRF4XX ("X.25" in the MAVLink sources) of `data`, continuing from `crc`.
pub fn crc_accumulate(mut crc: u16, data: &[u8]) -> u16 {
    for &b in data {
        let mut tmp = b ^ (crc as u8);
        tmp ^= tmp << 4;
        let t = u16::from(tmp);
        crc = (crc >> 8) ^ (t << 8) ^ (t << 3) ^ (t >> 4);
    }
    crc
}

/// The MAVLink checksum of a frame body (`len` … end of payload) plus the message's
/// `crc_extra`.
pub fn frame_crc(body: &[u8], crc_extra: u8) -> u16 {
    crc_accumulate(crc_accumulate(0xFFFF, body), &[crc_extra])
}

/// Whether `msg_id` is a message of the dialect we parse (ardupilotmega ⊃ common).
pub fn is_known_id(msg_id: u32) -> bool {
    MavMessage::extra_crc(msg_id) != 0 || MavMessage::default_message_from_id(msg_id).is_some()
}

/// Why a frame's payload did not become a [`MavMessage`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Unparsed {
    /// The message id is not in the ardupilotmega dialect (CRC could not be checked).
    UnknownId,
    /// The id is known but a field did not parse (e.g. an enum value newer than our
    /// dialect); the text says which.
    Invalid(String),
}

/// The signature block of a signed frame.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SignatureInfo {
    /// The sender's link id.
    pub link_id: u8,
    /// Its timestamp (10 µs units since 2015-01-01).
    pub timestamp: u64,
}

/// One decoded frame.
#[derive(Clone, Debug)]
pub struct Frame {
    /// MAVLink 1 or 2.
    pub version: MavlinkVersion,
    /// Sender system, component and sequence number.
    pub header: MavHeader,
    /// Message id.
    pub msg_id: u32,
    /// Signature block, for signed MAVLink 2 frames.
    pub signature: Option<SignatureInfo>,
    /// The exact bytes of the frame (STX … CRC [… signature]).
    pub raw: Vec<u8>,
    /// The parsed message, or why not.
    pub message: Result<MavMessage, Unparsed>,
}

impl Frame {
    /// The sender's system id.
    pub fn sysid(&self) -> u8 {
        self.header.system_id as u8
    }

    /// The sender's component id.
    pub fn compid(&self) -> u8 {
        self.header.component_id
    }

    /// The payload bytes as on the wire (MAVLink 2 payloads may be trimmed).
    pub fn payload(&self) -> &[u8] {
        let (hdr, len) = match self.version {
            MavlinkVersion::V1 => (HDR_V1, self.raw[1] as usize),
            MavlinkVersion::V2 => (HDR_V2, self.raw[1] as usize),
        };
        &self.raw[hdr..hdr + len]
    }
}

/// Per (sysid, compid) receive statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SourceStats {
    /// Frames received.
    pub frames: u64,
    /// Frames missing according to sequence-number gaps.
    pub lost: u64,
    /// Frames that arrived with a sequence number behind the last one (duplicates,
    /// reordering, reboots).
    pub out_of_order: u64,
    /// Last sequence number seen.
    pub last_seq: u8,
}

impl SourceStats {
    /// Fraction of frames lost, 0…1 (0 when nothing was expected).
    pub fn loss_ratio(&self) -> f64 {
        let expected = self.frames + self.lost;
        if expected == 0 {
            0.0
        } else {
            self.lost as f64 / expected as f64
        }
    }
}

/// Statistics of one codec (one link).
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct LinkStats {
    /// Frames accepted.
    pub frames_in: u64,
    /// Bytes received (everything fed, garbage included).
    pub bytes_in: u64,
    /// Frames encoded for sending.
    pub frames_out: u64,
    /// Bytes encoded for sending.
    pub bytes_out: u64,
    /// Frames dropped because their CRC did not match.
    pub bad_crc: u64,
    /// Bytes skipped while looking for a frame start.
    pub garbage_bytes: u64,
    /// Frames whose payload did not parse (unknown id, or unknown enum value).
    pub unparsed: u64,
    /// MAVLink 2 frames dropped for unknown incompatibility flags.
    pub bad_incompat_flags: u64,
    /// Signed frames dropped because the signature did not match.
    pub bad_signature: u64,
    /// Correctly signed frames dropped as replays (old timestamp).
    pub replayed: u64,
    /// Unsigned frames dropped while signing is required.
    pub unsigned_dropped: u64,
    /// Per source (sysid, compid).
    #[serde(serialize_with = "ser_sources")]
    pub sources: HashMap<(u8, u8), SourceStats>,
}

fn ser_sources<S: serde::Serializer>(
    m: &HashMap<(u8, u8), SourceStats>,
    s: S,
) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut keys: Vec<_> = m.keys().copied().collect();
    keys.sort_unstable();
    let mut map = s.serialize_map(Some(keys.len()))?;
    for k in keys {
        map.serialize_entry(&format!("{}:{}", k.0, k.1), &m[&k])?;
    }
    map.end()
}

impl LinkStats {
    /// Frames lost (sequence gaps) summed over sources of system `sysid`.
    pub fn lost_from(&self, sysid: u8) -> u64 {
        self.sources
            .iter()
            .filter(|(k, _)| k.0 == sysid)
            .map(|(_, s)| s.lost)
            .sum()
    }

    /// Frames received from system `sysid` (all components).
    pub fn frames_from(&self, sysid: u8) -> u64 {
        self.sources
            .iter()
            .filter(|(k, _)| k.0 == sysid)
            .map(|(_, s)| s.frames)
            .sum()
    }

    /// Signature-related drops (bad signature + replays + unsigned).
    pub fn signing_drops(&self) -> u64 {
        self.bad_signature + self.replayed + self.unsigned_dropped
    }
}

/// The bytes of one incoming byte stream that do not yet form a whole frame.
///
/// A link that hears several peers at once (a `udpin` port that many vehicles send to, a
/// `tcpin` server with several clients) keeps one of these per peer and decodes with
/// [`Codec::decode_stream`], so that a frame split over two reads of one peer is never
/// spliced onto another peer's bytes, while statistics and signing (replay protection)
/// stay those of the link.
#[derive(Debug, Default)]
pub struct StreamBuffer {
    buf: Vec<u8>,
    pos: usize,
}

impl StreamBuffer {
    /// Bytes buffered but not yet consumed (an incomplete frame).
    pub fn pending(&self) -> usize {
        self.buf.len() - self.pos
    }
}

/// The codec: a receive buffer, transmit sequence numbers, optional signing, statistics.
#[derive(Debug, Default)]
pub struct Codec {
    buf: Vec<u8>,
    pos: usize,
    tx_seq: HashMap<(u8, u8), u8>,
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
    pub fn decode_stream(
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
        let s = self.stats.sources.entry((sysid, compid)).or_default();
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

    /// The next sequence number for source (`sysid`, `compid`) (and advance it).
    pub fn next_sequence(&mut self, sysid: u8, compid: u8) -> u8 {
        let s = self.tx_seq.entry((sysid, compid)).or_insert(0);
        let v = *s;
        *s = s.wrapping_add(1);
        v
    }

    /// Restart the sequence numbers of a source at 0 (a simulated reboot).
    pub fn reset_sequence(&mut self, sysid: u8, compid: u8) {
        self.tx_seq.remove(&(sysid, compid));
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

/// Encode one frame (stateless apart from `signing`'s timestamp). See
/// [`Codec::encode_with_header`].
pub fn encode_frame(
    header: &MavHeader,
    msg: &MavMessage,
    version: MavlinkVersion,
    signing: Option<&mut Signing>,
    unix_us: u64,
) -> Vec<u8> {
    let msg_id = msg.message_id();
    let v1 = matches!(version, MavlinkVersion::V1) && msg_id <= 255;
    let mut payload = [0u8; 255];
    let len = msg.ser(
        if v1 {
            MavlinkVersion::V1
        } else {
            MavlinkVersion::V2
        },
        &mut payload,
    );
    let mut out = Vec::with_capacity(MAX_FRAME_LEN);
    let sysid = header.system_id as u8;
    if v1 {
        out.extend_from_slice(&[
            STX_V1,
            len as u8,
            header.sequence,
            sysid,
            header.component_id,
            msg_id as u8,
        ]);
    } else {
        let incompat = if signing.is_some() { IFLAG_SIGNED } else { 0 };
        let id = msg_id.to_le_bytes();
        out.extend_from_slice(&[
            STX_V2,
            len as u8,
            incompat,
            0,
            header.sequence,
            sysid,
            header.component_id,
            id[0],
            id[1],
            id[2],
        ]);
    }
    out.extend_from_slice(&payload[..len]);
    let crc = frame_crc(&out[1..], MavMessage::extra_crc(msg_id));
    out.extend_from_slice(&crc.to_le_bytes());
    if !v1 && let Some(s) = signing {
        let block = s.sign(&out, unix_us);
        out.extend_from_slice(&block);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::super::signing::SigningKey;
    use super::*;
    use mavlink::dialects::ardupilotmega::*;

    fn heartbeat() -> MavMessage {
        MavMessage::HEARTBEAT(HEARTBEAT_DATA {
            custom_mode: 4,
            mavtype: MavType::MAV_TYPE_QUADROTOR,
            autopilot: MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA,
            base_mode: MavModeFlag::MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            system_status: MavState::MAV_STATE_STANDBY,
            mavlink_version: 3,
        })
    }

    #[test]
    fn crc_matches_reference() {
        // CRC-16/MCRF4XX check value for "123456789" is 0x6F91.
        assert_eq!(crc_accumulate(0xFFFF, b"123456789"), 0x6F91);
    }

    #[test]
    fn known_heartbeat_bytes_decode() {
        // A MAVLink 2 HEARTBEAT captured from ArduCopter SITL (sysid 1, compid 1).
        let bytes: [u8; 21] = [
            0xfd, 0x09, 0x00, 0x00, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00,
            0x02, 0x03, 0x51, 0x04, 0x03, 0x00, 0x00,
        ];
        // Recompute the CRC so the vector is self-consistent.
        let mut b = bytes.to_vec();
        let crc = frame_crc(&b[1..19], 50);
        b[19..21].copy_from_slice(&crc.to_le_bytes());
        let mut c = Codec::new();
        let frames = c.decode(&b, 0);
        assert_eq!(frames.len(), 1);
        match &frames[0].message {
            Ok(MavMessage::HEARTBEAT(h)) => {
                assert_eq!(h.custom_mode, 4);
                assert_eq!(h.mavtype, MavType::MAV_TYPE_QUADROTOR);
            }
            other => panic!("unexpected {other:?}"),
        }
        assert_eq!(frames[0].raw, b);
    }

    #[test]
    fn round_trip_v1_v2_with_garbage_and_bad_crc() {
        let mut tx = Codec::new();
        let mut rx = Codec::new();
        let a = tx.encode(1, 1, &heartbeat(), 0);
        let h1 = MavHeader {
            system_id: 2,
            component_id: 1,
            sequence: 7,
        };
        let b = tx.encode_with_header(&h1, &heartbeat(), MavlinkVersion::V1, 0);
        let mut bad = tx.encode(1, 1, &heartbeat(), 0);
        let n = bad.len();
        bad[n - 3] ^= 0x55; // corrupt payload
        let c = tx.encode(1, 1, &heartbeat(), 0);
        let mut stream = vec![0x00, 0x13, 0xFD, 0x44];
        stream.extend_from_slice(&a);
        stream.extend_from_slice(&[0xFE, 0xFE]); // stray start bytes
        stream.extend_from_slice(&b);
        stream.extend_from_slice(&bad);
        stream.extend_from_slice(&c);
        // Feed one byte at a time (serial-like).
        let mut frames = Vec::new();
        for byte in &stream {
            frames.extend(rx.decode(std::slice::from_ref(byte), 0));
        }
        assert_eq!(frames.len(), 3);
        assert_eq!(frames[0].raw, a);
        assert!(matches!(frames[1].version, MavlinkVersion::V1));
        assert_eq!(frames[1].header.sequence, 7);
        assert_eq!(frames[2].raw, c);
        let s = rx.stats();
        assert_eq!(s.bad_crc, 1);
        assert!(s.garbage_bytes >= 4);
        // seq 0, then (bad seq 1 lost), then seq 2 from source (1,1).
        assert_eq!(s.sources[&(1, 1)].lost, 1);
        assert_eq!(s.frames_in, 3);
    }

    #[test]
    fn unknown_id_and_invalid_enum_are_unparsed_not_fatal() {
        // Unknown message id 43210 with arbitrary payload.
        let mut f = vec![STX_V2, 3, 0, 0, 9, 1, 1];
        f.extend_from_slice(&43210u32.to_le_bytes()[..3]);
        f.extend_from_slice(&[1, 2, 3]);
        let crc = frame_crc(&f[1..], 77);
        f.extend_from_slice(&crc.to_le_bytes());
        // HEARTBEAT with MAV_TYPE 250 (not in the dialect).
        let mut tx = Codec::new();
        let mut hb = tx.encode(1, 1, &heartbeat(), 0);
        hb[10 + 4] = 250;
        let n = hb.len();
        let crc = frame_crc(&hb[1..n - 2], 50);
        hb[n - 2..].copy_from_slice(&crc.to_le_bytes());
        let good = tx.encode(1, 1, &heartbeat(), 0);
        let mut rx = Codec::new();
        let frames = rx.decode(&[f.clone(), hb, good].concat(), 0);
        assert_eq!(frames.len(), 3);
        assert_eq!(frames[0].message, Err(Unparsed::UnknownId));
        assert!(matches!(frames[1].message, Err(Unparsed::Invalid(_))));
        assert!(frames[2].message.is_ok());
        assert_eq!(rx.stats().unparsed, 2);
    }

    #[test]
    fn sequences_per_source() {
        let mut c = Codec::new();
        let f1 = c.encode(1, 1, &heartbeat(), 0);
        let f2 = c.encode(1, 1, &heartbeat(), 0);
        let g1 = c.encode(2, 1, &heartbeat(), 0);
        assert_eq!((f1[4], f2[4], g1[4]), (0, 1, 0));
        c.reset_sequence(1, 1);
        assert_eq!(c.encode(1, 1, &heartbeat(), 0)[4], 0);
    }

    #[test]
    fn signing_accepts_signed_and_drops_unsigned_and_wrong_key() {
        let key = SigningKey::from_passphrase("secret");
        let now = 1_750_000_000_000_000;
        let mut tx = Codec::with_signing(Signing::new(key.clone(), 1));
        let mut rx = Codec::with_signing(Signing::new(key, 0));
        let mut plain = Codec::new();
        let mut wrong = Codec::with_signing(Signing::new(SigningKey::from_passphrase("x"), 1));
        let a = tx.encode(1, 1, &heartbeat(), now);
        assert_eq!(a[2] & IFLAG_SIGNED, IFLAG_SIGNED);
        let b = plain.encode(3, 1, &heartbeat(), now);
        let c = wrong.encode(4, 1, &heartbeat(), now);
        let frames = rx.decode(&[a.clone(), b, c, a].concat(), now);
        assert_eq!(frames.len(), 1);
        assert!(frames[0].signature.is_some());
        let s = rx.stats();
        assert_eq!((s.unsigned_dropped, s.bad_signature, s.replayed), (1, 1, 1));
        // Without signing configured, signed frames are accepted as they are.
        let mut open = Codec::new();
        let f = tx.encode(1, 1, &heartbeat(), now);
        assert_eq!(open.decode(&f, now).len(), 1);
    }

    #[test]
    fn resyncs_through_random_garbage_and_chunking() {
        use rand::{RngExt, SeedableRng};
        let mut tx = Codec::new();
        for seed in 0..40u64 {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            let mut stream = Vec::new();
            let mut sent = Vec::new();
            for i in 0..60u16 {
                // Garbage, rich in start bytes.
                for _ in 0..rng.random_range(0..12) {
                    let b = match rng.random_range(0..4) {
                        0 => STX_V1,
                        1 => STX_V2,
                        _ => rng.random(),
                    };
                    stream.push(b);
                }
                let m = MavMessage::MISSION_REQUEST_INT(MISSION_REQUEST_INT_DATA {
                    seq: i,
                    target_system: rng.random(),
                    target_component: 1,
                    mission_type: MavMissionType::MAV_MISSION_TYPE_MISSION,
                });
                let f = tx.encode(1, 1, &m, 0);
                stream.extend_from_slice(&f);
                sent.push(f);
            }
            // Terminate with a heartbeat so the last frame is followed by data.
            stream.extend_from_slice(&tx.encode(1, 1, &heartbeat(), 0));
            let mut rx = Codec::new();
            let mut got = Vec::new();
            let mut i = 0;
            while i < stream.len() {
                let n = rng.random_range(1..64).min(stream.len() - i);
                got.extend(rx.decode(&stream[i..i + n], 0));
                i += n;
            }
            let got: Vec<Vec<u8>> = got
                .into_iter()
                .filter(|f| f.msg_id == 51)
                .map(|f| f.raw)
                .collect();
            assert_eq!(got, sent, "seed {seed}");
        }
    }

    #[test]
    fn every_message_type_round_trips() {
        let mut c = Codec::new();
        let msgs = [
            MavMessage::MISSION_ITEM_INT(MISSION_ITEM_INT_DATA {
                seq: 7,
                x: 377_000_000,
                y: -1_220_000_000,
                z: 12.5,
                command: MavCmd::MAV_CMD_NAV_WAYPOINT,
                frame: MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT,
                ..Default::default()
            }),
            MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                param1: 1.0,
                ..Default::default()
            }),
            // A message with id > 255 (MAVLink 2 only).
            MavMessage::SETUP_SIGNING(SETUP_SIGNING_DATA {
                initial_timestamp: 5,
                target_system: 1,
                target_component: 1,
                secret_key: [7; 32],
            }),
        ];
        for m in &msgs {
            let f = c.encode(255, 190, m, 0);
            let frames = c.decode(&f, 0);
            assert_eq!(frames.len(), 1);
            assert_eq!(frames[0].message.as_ref().ok(), Some(m));
        }
    }

    /// Two peers' bytes interleaved on one link, each frame split over two reads: with a
    /// buffer per stream every frame comes out whole and the statistics are the link's;
    /// through one shared buffer the halves would be spliced together and lost.
    #[test]
    fn streams_keep_their_own_incomplete_frames() {
        let mut a_tx = Codec::new();
        let mut b_tx = Codec::new();
        let a = a_tx.encode(1, 1, &heartbeat(), 0);
        let b = b_tx.encode(2, 1, &heartbeat(), 0);
        let (a1, a2) = a.split_at(7);
        let (b1, b2) = b.split_at(11);
        let mut rx = Codec::new();
        let (mut sa, mut sb) = (StreamBuffer::default(), StreamBuffer::default());
        assert!(rx.decode_stream(&mut sa, a1, 0).is_empty());
        assert!(rx.decode_stream(&mut sb, b1, 0).is_empty());
        assert_eq!(sa.pending(), a1.len());
        let fb = rx.decode_stream(&mut sb, b2, 0);
        let fa = rx.decode_stream(&mut sa, a2, 0);
        assert_eq!((fa.len(), fb.len()), (1, 1));
        assert_eq!((fa[0].sysid(), fb[0].sysid()), (1, 2));
        assert_eq!(rx.stats().frames_in, 2);
        assert_eq!(rx.pending(), 0);
        // The same reads through one buffer: both frames are lost.
        let mut shared = Codec::new();
        let n: usize = [a1, b1, b2, a2]
            .iter()
            .map(|d| shared.decode(d, 0).len())
            .sum();
        assert!(n < 2, "{n} frames decoded from spliced halves");
    }
}
