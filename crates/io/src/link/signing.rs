//! MAVLink 2 message signing (pure: the wall-clock time is a parameter).
//!
//! Follows the specification <https://mavlink.io/en/guide/message_signing.html> and the
//! reference C implementation (`mavlink/c_library_v2`, `mavlink_helpers.h`:
//! `mavlink_sign_packet`, `mavlink_signature_check`), with the acceptance rules of
//! ArduPilot (`ArduPilot/ardupilot`, `libraries/GCS_MAVLink/GCS_Signing.cpp`:
//! `accept_unsigned_callback` lets RADIO_STATUS and RADIO through unsigned) and MAVProxy
//! (`ArduPilot/MAVProxy`, `MAVProxy/modules/mavproxy_signing.py`: the key is the SHA-256
//! of a passphrase; the initial timestamp is `(unix_seconds - 1420070400) * 1e5`).
//!
//! Why our own implementation rather than the `mavlink` crate's `mav2-message-signing`
//! feature: the crate reads `SystemTime::now()` inside `sign_message`/`verify_signature`
//! and keeps its state behind a `Mutex`, which the sans-IO core cannot use (time must be a
//! parameter, so tests and the simulator's virtual clock control it), and it works on its
//! own raw-message type, while our codec keeps the exact received bytes for tlogs and
//! counts every drop by cause. The whole algorithm is ~100 lines on top of `sha2`.
//!
//! * Signature block (13 bytes, after the CRC): `link_id` (1), `timestamp` (6, little
//!   endian, units of 10 µs since 2015-01-01 00:00:00 UTC), `signature` (6) = the first 48
//!   bits of SHA-256(secret_key ‖ header (STX … msgid, 10 bytes) ‖ payload ‖ CRC ‖ link_id ‖
//!   timestamp).
//! * Outgoing timestamps never go backwards: each frame uses
//!   `max(last + 1, now)` (the C library increments after each frame and raises the value
//!   from the clock and from valid incoming frames).
//! * Incoming: the hash must match; a known stream (link_id, sysid, compid) must have a
//!   strictly larger timestamp than its last frame (replay protection); a new stream is
//!   refused if its timestamp is more than one minute older than our own timestamp.
//!   Unsigned frames (including every MAVLink 1 frame) are refused unless `accept_unsigned`
//!   is set or the message is RADIO_STATUS / RADIO (injected by telemetry radios).

use mavlink::MessageData;
use mavlink::dialects::ardupilotmega::RADIO_STATUS_DATA;
use sha2::{Digest, Sha256};
use std::collections::HashMap;
use std::path::Path;

/// Seconds from the Unix epoch to the MAVLink signing epoch (2015-01-01 00:00:00 UTC).
pub(crate) const SIGNING_EPOCH_UNIX_S: u64 = 1_420_070_400;

/// One minute in signing timestamp units (10 µs): how much older than our own timestamp
/// a new stream may start (the C library's `6000*1000UL`).
pub(crate) const NEW_STREAM_MAX_AGE: u64 = 6_000_000;

/// Length of the signature block appended to a signed MAVLink 2 frame, in bytes.
pub(crate) const SIGNATURE_LEN: usize = 13;

/// MAVLink 2 incompatibility flag: the frame carries a signature block.
pub(crate) const IFLAG_SIGNED: u8 = 0x01;

/// RADIO_STATUS message id (accepted unsigned, as ArduPilot and MAVProxy do).
const MSG_ID_RADIO_STATUS: u32 = <RADIO_STATUS_DATA as MessageData>::ID;
/// RADIO message id (ArduPilot's accept list).
#[allow(deprecated)] // RADIO: superseded by RADIO_STATUS in 2013, still on ArduPilot's accept list
const MSG_ID_RADIO: u32 = <mavlink::dialects::ardupilotmega::RADIO_DATA as MessageData>::ID;

/// Errors reading a signing key.
#[derive(Debug, thiserror::Error)]
pub enum KeyError {
    /// The key file could not be read.
    #[error("cannot read signing key file {path}: {source}")]
    Io {
        /// The file.
        path: String,
        /// The OS error.
        source: std::io::Error,
    },
    /// The content is neither 32 raw bytes, 64 hex digits nor base64 of 32 bytes.
    #[error(
        "signing key file {path}: expected 64 hexadecimal digits (as written by `fleetmap signing keygen`), base64 of 32 bytes, or 32 raw bytes; found {found}"
    )]
    Format {
        /// The file.
        path: String,
        /// What was found instead.
        found: String,
    },
}

/// A 32-byte MAVLink signing secret key.
#[derive(Clone, PartialEq, Eq)]
pub struct SigningKey(pub [u8; 32]);

impl std::fmt::Debug for SigningKey {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        // Never print the secret itself.
        write!(f, "SigningKey(sha256 fingerprint {})", self.fingerprint())
    }
}

impl SigningKey {
    /// The key MAVProxy (`signing setup PASSPHRASE`) and Mission Planner derive from a
    /// passphrase: SHA-256 of its UTF-8 bytes.
    pub fn from_passphrase(passphrase: &str) -> SigningKey {
        let digest = Sha256::digest(passphrase.as_bytes());
        let mut key = [0u8; 32];
        key.copy_from_slice(&digest);
        SigningKey(key)
    }

    /// The key as 64 lowercase hexadecimal digits (the key file format we write).
    pub fn to_hex(&self) -> String {
        self.0.iter().map(|b| format!("{b:02x}")).collect()
    }

    /// The first 4 bytes of SHA-256(key) in hex: identifies a key without revealing it.
    pub fn fingerprint(&self) -> String {
        let d = Sha256::digest(self.0);
        d[..4].iter().map(|b| format!("{b:02x}")).collect()
    }

    /// Parse a key from the content of a key file: 64 hex digits (whitespace around is
    /// ignored), base64 of 32 bytes (Mission Planner's stored form), or exactly 32 raw bytes.
    pub fn parse(content: &[u8], path: &str) -> Result<SigningKey, KeyError> {
        let text = std::str::from_utf8(content).ok().map(str::trim);
        if let Some(t) = text {
            if t.len() == 64 && t.chars().all(|c| c.is_ascii_hexdigit()) {
                let mut key = [0u8; 32];
                for (i, k) in key.iter_mut().enumerate() {
                    *k = u8::from_str_radix(&t[2 * i..2 * i + 2], 16).map_err(|_| {
                        KeyError::Format {
                            path: path.to_string(),
                            found: "invalid hex".into(),
                        }
                    })?;
                }
                return Ok(SigningKey(key));
            }
            if let Some(bytes) = base64_decode(t)
                && bytes.len() == 32
            {
                let mut key = [0u8; 32];
                key.copy_from_slice(&bytes);
                return Ok(SigningKey(key));
            }
        }
        if content.len() == 32 {
            let mut key = [0u8; 32];
            key.copy_from_slice(content);
            return Ok(SigningKey(key));
        }
        Err(KeyError::Format {
            path: path.to_string(),
            found: format!("{} bytes", content.len()),
        })
    }

    /// Read a key file (see [`SigningKey::parse`]).
    pub fn read(path: &Path) -> Result<SigningKey, KeyError> {
        let content = std::fs::read(path).map_err(|source| KeyError::Io {
            path: path.display().to_string(),
            source,
        })?;
        SigningKey::parse(&content, &path.display().to_string())
    }
}

/// Standard base64 (RFC 4648, with or without padding) → bytes; `None` when invalid.
fn base64_decode(s: &str) -> Option<Vec<u8>> {
    fn val(c: u8) -> Option<u32> {
        match c {
            b'A'..=b'Z' => Some(u32::from(c - b'A')),
            b'a'..=b'z' => Some(u32::from(c - b'a') + 26),
            b'0'..=b'9' => Some(u32::from(c - b'0') + 52),
            b'+' => Some(62),
            b'/' => Some(63),
            _ => None,
        }
    }
    let s = s.trim_end_matches('=');
    let mut out = Vec::with_capacity(s.len() * 3 / 4);
    let (mut acc, mut bits) = (0u32, 0u32);
    for c in s.bytes() {
        acc = (acc << 6) | val(c)?;
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

/// Unix time in microseconds → signing timestamp (10 µs units since 2015-01-01), 0 before.
pub fn signing_timestamp(unix_us: u64) -> u64 {
    unix_us.saturating_sub(SIGNING_EPOCH_UNIX_S * 1_000_000) / 10
}

/// Why an incoming frame was refused by [`Signing::check`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rejection {
    /// Signed, but the signature does not match our key.
    BadSignature,
    /// Signed correctly, but the timestamp is not newer than the stream's last one, or a new
    /// stream starts more than a minute in the past (replay).
    Replay,
    /// Not signed (or MAVLink 1) while signatures are required.
    Unsigned,
}

/// Signing configuration and state for one link (key, link id, timestamps of streams).
#[derive(Clone, Debug)]
pub struct Signing {
    key: SigningKey,
    /// Link id written into outgoing signatures.
    pub(crate) link_id: u8,
    /// Sign outgoing frames.
    pub(crate) sign_outgoing: bool,
    /// Accept unsigned incoming frames (otherwise only RADIO_STATUS / RADIO are).
    pub accept_unsigned: bool,
    /// Our timestamp (10 µs units since 2015): the last one used or seen.
    timestamp: u64,
    /// Last timestamp per incoming stream (link_id, sysid, compid).
    streams: HashMap<(u8, u8, u8), u64>,
}

impl Signing {
    /// Signing with `key`: outgoing frames signed with `link_id`, unsigned incoming
    /// frames refused (except RADIO_STATUS / RADIO).
    pub fn new(key: SigningKey, link_id: u8) -> Signing {
        Signing {
            key,
            link_id,
            sign_outgoing: true,
            accept_unsigned: false,
            timestamp: 0,
            streams: HashMap::new(),
        }
    }

    /// The key in use.
    pub fn key(&self) -> &SigningKey {
        &self.key
    }

    /// Our current timestamp (10 µs units since 2015-01-01).
    pub fn timestamp(&self) -> u64 {
        self.timestamp
    }

    /// Compute the 6-byte signature of a frame: `frame` is everything from STX through
    /// the CRC; `link_id` and `timestamp` are the block's first 7 bytes.
    pub fn signature(key: &SigningKey, frame: &[u8], link_id: u8, timestamp: u64) -> [u8; 6] {
        let mut h = Sha256::new();
        h.update(key.0);
        h.update(frame);
        h.update([link_id]);
        h.update(&timestamp.to_le_bytes()[..6]);
        let d = h.finalize();
        let mut s = [0u8; 6];
        s.copy_from_slice(&d[..6]);
        s
    }

    /// The 13-byte signature block for `frame` (STX … CRC) sent at wall time `unix_us`.
    pub(crate) fn sign(&mut self, frame: &[u8], unix_us: u64) -> [u8; SIGNATURE_LEN] {
        let ts = self.timestamp.max(signing_timestamp(unix_us)) & 0xFFFF_FFFF_FFFF;
        self.timestamp = ts + 1;
        let sig = Signing::signature(&self.key, frame, self.link_id, ts);
        let mut block = [0u8; SIGNATURE_LEN];
        block[0] = self.link_id;
        block[1..7].copy_from_slice(&ts.to_le_bytes()[..6]);
        block[7..].copy_from_slice(&sig);
        block
    }

    /// Check an incoming frame. `frame` is the whole frame (STX … signature block) when
    /// `signed`, the frame without signature otherwise; `sysid`/`compid`/`msg_id` from
    /// its header; `unix_us` the wall time now. Accepting updates the stream timestamps.
    pub fn check(
        &mut self,
        frame: &[u8],
        signed: bool,
        sysid: u8,
        compid: u8,
        msg_id: u32,
        unix_us: u64,
    ) -> Result<(), Rejection> {
        self.timestamp = self.timestamp.max(signing_timestamp(unix_us));
        if !signed {
            if self.accept_unsigned || msg_id == MSG_ID_RADIO_STATUS || msg_id == MSG_ID_RADIO {
                return Ok(());
            }
            return Err(Rejection::Unsigned);
        }
        if frame.len() < SIGNATURE_LEN + 12 {
            return Err(Rejection::BadSignature);
        }
        let (body, block) = frame.split_at(frame.len() - SIGNATURE_LEN);
        let link_id = block[0];
        let mut tsb = [0u8; 8];
        tsb[..6].copy_from_slice(&block[1..7]);
        let ts = u64::from_le_bytes(tsb);
        if Signing::signature(&self.key, body, link_id, ts) != block[7..] {
            return Err(Rejection::BadSignature);
        }
        let stream = (link_id, sysid, compid);
        match self.streams.get(&stream) {
            Some(&last) if ts <= last => return Err(Rejection::Replay),
            None if ts + NEW_STREAM_MAX_AGE < self.timestamp => return Err(Rejection::Replay),
            _ => {}
        }
        self.streams.insert(stream, ts);
        self.timestamp = self.timestamp.max(ts);
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn passphrase_key_is_sha256() {
        // sha256("fleetmap") computed independently (Python hashlib).
        let k = SigningKey::from_passphrase("fleetmap");
        assert_eq!(k.to_hex().len(), 64);
        let again = SigningKey::parse(k.to_hex().as_bytes(), "t").unwrap();
        assert_eq!(again, k);
        // Raw 32 bytes and base64 forms.
        assert_eq!(SigningKey::parse(&k.0, "t").unwrap(), k);
        let b64 = "AAECAwQFBgcICQoLDA0ODxAREhMUFRYXGBkaGxwdHh8=";
        let parsed = SigningKey::parse(b64.as_bytes(), "t").unwrap();
        let expect: Vec<u8> = (0u8..32).collect();
        assert_eq!(parsed.0.to_vec(), expect);
        assert!(SigningKey::parse(b"short", "t").is_err());
    }

    #[test]
    fn timestamps_are_monotonic_and_replays_refused() {
        let key = SigningKey::from_passphrase("a");
        let mut tx = Signing::new(key.clone(), 3);
        let mut rx = Signing::new(key, 0);
        let now = 1_700_000_000_000_000u64;
        let frame = [0xFDu8, 1, 1, 0, 0, 1, 1, 0, 0, 0, 7, 0xAA, 0xBB];
        let b1 = tx.sign(&frame, now);
        let b2 = tx.sign(&frame, now);
        let ts = |b: &[u8; 13]| {
            let mut t = [0u8; 8];
            t[..6].copy_from_slice(&b[1..7]);
            u64::from_le_bytes(t)
        };
        assert_eq!(ts(&b2), ts(&b1) + 1);
        let f1 = [&frame[..], &b1[..]].concat();
        let f2 = [&frame[..], &b2[..]].concat();
        assert_eq!(rx.check(&f1, true, 1, 1, 0, now), Ok(()));
        assert_eq!(rx.check(&f1, true, 1, 1, 0, now), Err(Rejection::Replay));
        assert_eq!(rx.check(&f2, true, 1, 1, 0, now), Ok(()));
        // A different key fails the hash.
        let mut other = Signing::new(SigningKey::from_passphrase("b"), 0);
        assert_eq!(
            other.check(&f2, true, 1, 1, 0, now),
            Err(Rejection::BadSignature)
        );
        // Unsigned: refused except radio status.
        assert_eq!(
            rx.check(&frame, false, 1, 1, 0, now),
            Err(Rejection::Unsigned)
        );
        assert_eq!(rx.check(&frame, false, 1, 1, 109, now), Ok(()));
        // A new stream more than a minute old is a replay.
        let mut late = Signing::new(SigningKey::from_passphrase("a"), 0);
        assert_eq!(
            late.check(&f1, true, 1, 1, 0, now + 61_000_000),
            Err(Rejection::Replay)
        );
    }
}
