//! The RADIO_STATUS report (message 109) a SiK radio writes into its own serial port, byte
//! for byte as the firmware builds it (ArduPilot/SiK `Firmware/radio/mavlink.c`,
//! `MAVLink_report`): system id `'3'` and component id `'D'` ("3D" for 3DR Radio), the
//! payload in MAVLink wire order (rxerrors, fixed, rssi, remrssi, txbuf, noise, remnoise),
//! never trimmed, in the MAVLink version of the heartbeat that triggered it (a MAVLink 2
//! frame has zero incompatibility and compatibility flags and is never signed).

use crate::link::codec::{STX_V1, STX_V2, frame_crc};
use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::RADIO_STATUS_DATA;

/// System id of a SiK radio's reports: `'3'`.
pub const RADIO_SYSID: u8 = b'3';
/// Component id of a SiK radio's reports: `'D'`.
pub const RADIO_COMPID: u8 = b'D';
/// RADIO_STATUS's message id.
pub const RADIO_STATUS_ID: u32 = <RADIO_STATUS_DATA as MessageData>::ID;
/// RADIO_STATUS's CRC extra (`MAVLINK_RADIO_STATUS_CRC_EXTRA` in SiK's mavlink.c).
const CRC_EXTRA: u8 = 185;
/// Payload length: 2 + 2 + 5 × 1 bytes.
const PAYLOAD_LEN: u8 = 9;

/// What one report says (the fields of MAVLink's RADIO_STATUS): what a radio model writes,
/// and what the GCS shows of a radio it hears.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct RadioStatus {
    /// Signal strength this radio receives (SiK: the Si1000's RSSI register, filtered).
    pub rssi: u8,
    /// Signal strength the other radio receives (reported to this one over the air).
    pub remrssi: u8,
    /// Free space in this radio's serial buffer, percent (SiK `serial_read_space`).
    pub txbuf: u8,
    /// Background noise this radio hears.
    pub noise: u8,
    /// Background noise the other radio hears.
    pub remnoise: u8,
    /// Air packets this radio failed to receive (SiK `errors.rx_errors`, which stops at
    /// 65 535).
    pub rxerrors: u16,
    /// Packets repaired by error correction (always 0 here: no ECC is modelled).
    pub fixed: u16,
}

impl From<&mavlink::dialects::ardupilotmega::RADIO_STATUS_DATA> for RadioStatus {
    fn from(r: &mavlink::dialects::ardupilotmega::RADIO_STATUS_DATA) -> RadioStatus {
        RadioStatus {
            rssi: r.rssi,
            remrssi: r.remrssi,
            txbuf: r.txbuf,
            noise: r.noise,
            remnoise: r.remnoise,
            rxerrors: r.rxerrors,
            fixed: r.fixed,
        }
    }
}

/// Percent of a buffer of `capacity` bytes that is free with `used` bytes in it, computed
/// as SiK does (`serial_read_space`: both counts in units of 8 bytes, integer division),
/// so a just-full buffer reads 0 and an empty one 100.
pub fn free_percent(capacity: u64, used: u64) -> u8 {
    let units = (capacity / 8).max(1);
    let space = capacity.saturating_sub(used) / 8;
    u8::try_from((100 * space / units).min(100)).unwrap_or(100)
}

/// The frame a SiK radio writes for `status`: MAVLink 1 (17 bytes) when `v2` is false,
/// MAVLink 2 (21 bytes) otherwise, with sequence number `seq` (each radio counts its own).
pub fn encode(status: &RadioStatus, v2: bool, seq: u8) -> Vec<u8> {
    let mut f = Vec::with_capacity(21);
    if v2 {
        f.extend_from_slice(&[STX_V2, PAYLOAD_LEN, 0, 0, seq, RADIO_SYSID, RADIO_COMPID]);
        f.extend_from_slice(&RADIO_STATUS_ID.to_le_bytes()[..3]);
    } else {
        f.extend_from_slice(&[STX_V1, PAYLOAD_LEN, seq, RADIO_SYSID, RADIO_COMPID]);
        f.push(RADIO_STATUS_ID as u8);
    }
    f.extend_from_slice(&status.rxerrors.to_le_bytes());
    f.extend_from_slice(&status.fixed.to_le_bytes());
    f.extend_from_slice(&[
        status.rssi,
        status.remrssi,
        status.txbuf,
        status.noise,
        status.remnoise,
    ]);
    let crc = frame_crc(&f[1..], CRC_EXTRA);
    f.extend_from_slice(&crc.to_le_bytes());
    f
}
