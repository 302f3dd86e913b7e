//! Receive and transmit statistics of one codec (one link), with the per-source
//! sequence-gap loss.

use fleetmap_core::proto::Endpoint;
use std::collections::HashMap;

/// Per (sysid, compid) receive statistics.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct SourceStats {
    /// Frames received.
    pub frames: u64,
    /// Frames missing according to sequence-number gaps.
    pub lost: u64,
    /// Frames that arrived with a sequence number behind the last one (duplicates,
    /// reordering, reboots).
    pub(crate) out_of_order: u64,
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
    pub(crate) garbage_bytes: u64,
    /// Frames whose payload did not parse (unknown id, or unknown enum value).
    pub(crate) unparsed: u64,
    /// MAVLink 2 frames dropped for unknown incompatibility flags.
    pub(crate) bad_incompat_flags: u64,
    /// Signed frames dropped because the signature did not match.
    pub bad_signature: u64,
    /// Correctly signed frames dropped as replays (old timestamp).
    pub(crate) replayed: u64,
    /// Unsigned frames dropped while signing is required.
    pub unsigned_dropped: u64,
    /// Per source endpoint; serialized with keys `"sysid:compid"`.
    #[serde(serialize_with = "ser_sources")]
    pub sources: HashMap<Endpoint, SourceStats>,
}

fn ser_sources<S: serde::Serializer>(
    m: &HashMap<Endpoint, SourceStats>,
    s: S,
) -> Result<S::Ok, S::Error> {
    use serde::ser::SerializeMap;
    let mut keys: Vec<_> = m.keys().copied().collect();
    keys.sort_unstable();
    let mut map = s.serialize_map(Some(keys.len()))?;
    for k in keys {
        map.serialize_entry(&format!("{}:{}", k.sysid, k.compid), &m[&k])?;
    }
    map.end()
}

impl LinkStats {
    /// Signature-related drops (bad signature + replays + unsigned).
    pub fn signing_drops(&self) -> u64 {
        self.bad_signature + self.replayed + self.unsigned_dropped
    }
}
