use super::*;
use crate::link::signing::SigningKey;
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
        0xfd, 0x09, 0x00, 0x00, 0x00, 0x01, 0x01, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x02,
        0x03, 0x51, 0x04, 0x03, 0x00, 0x00,
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
        component_id: fleetmap_core::proto::AUTOPILOT_COMPID,
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
    assert_eq!(
        s.sources[&fleetmap_core::proto::Endpoint::new(1, fleetmap_core::proto::AUTOPILOT_COMPID)]
            .lost,
        1
    );
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
                target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
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
            .filter(|f| f.msg_id == <MISSION_REQUEST_INT_DATA as mavlink::MessageData>::ID)
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
            target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
            secret_key: [7; 32],
        }),
    ];
    for m in &msgs {
        let f = c.encode(
            fleetmap_core::proto::GCS_SYSID,
            fleetmap_core::proto::GCS_COMPID,
            m,
            0,
        );
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
