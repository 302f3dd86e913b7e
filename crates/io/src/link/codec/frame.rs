//! The MAVLink wire format: start bytes, header lengths, the CRC, one decoded [`Frame`] and
//! the stateless encoder of one frame.

use crate::link::signing::{IFLAG_SIGNED, SIGNATURE_LEN, Signing};
use mavlink::dialects::ardupilotmega::MavMessage;
use mavlink::{MavHeader, MavlinkVersion, Message};

/// MAVLink 1 start byte.
pub const STX_V1: u8 = 0xFE;
/// MAVLink 2 start byte.
pub const STX_V2: u8 = 0xFD;
/// MAVLink 1 header length including STX.
pub(super) const HDR_V1: usize = 6;
/// MAVLink 2 header length including STX.
pub(super) const HDR_V2: usize = 10;
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
    pub(crate) link_id: u8,
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

/// Encode one frame (stateless apart from `signing`'s timestamp). See
/// [`super::Codec::encode_with_header`].
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
