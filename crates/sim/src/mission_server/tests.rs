use super::*;
use fleetmap_core::mission::item::{cmd, frame};

const GCS: MavHeader = MavHeader {
    system_id: fleetmap_core::proto::GCS_SYSID as u32,
    component_id: fleetmap_core::proto::GCS_COMPID,
    sequence: 0,
};

fn drain(s: &mut MissionServer) -> Vec<MavMessage> {
    std::iter::from_fn(|| s.poll_transmit()).collect()
}

fn count(n: u16, t: mav::MavMissionType) -> MavMessage {
    MavMessage::MISSION_COUNT(mav::MISSION_COUNT_DATA {
        count: n,
        target_system: 1,
        target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
        mission_type: t,
        opaque_id: 0,
    })
}

fn item_int(seq: u16, it: &MissionItem, t: mav::MavMissionType) -> MavMessage {
    MavMessage::MISSION_ITEM_INT(mav::MISSION_ITEM_INT_DATA {
        param1: it.param1,
        param2: it.param2,
        param3: it.param3,
        param4: it.param4,
        x: it.x,
        y: it.y,
        z: it.z,
        seq,
        command: mav::MavCmd::from_u16(it.command).unwrap(),
        target_system: 1,
        target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
        frame: mav::MavFrame::from_u8(it.frame).unwrap(),
        current: 0,
        autocontinue: 1,
        mission_type: t,
    })
}

fn upload(s: &mut MissionServer, items: &[MissionItem], now: Time) -> Vec<MavMessage> {
    let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
    let mut out = Vec::new();
    s.handle_message(&GCS, &count(items.len() as u16, mt), now);
    out.extend(drain(s));
    for (i, it) in items.iter().enumerate() {
        s.handle_message(&GCS, &item_int(i as u16, it, mt), now);
        out.extend(drain(s));
    }
    out
}

fn sample() -> Vec<MissionItem> {
    let mut wp = MissionItem::waypoint(37.1968, -80.5781, 12.345);
    wp.param2 = 2.0; // acceptance radius: not kept by ArduCopter
    wp.param1 = 3.7;
    vec![
        MissionItem::waypoint(37.19, -80.57, 0.0), // home slot (ArduPilot)
        MissionItem::takeoff(12.0),
        wp,
        MissionItem::image_start_capture(1.0, 5),
        MissionItem::jump(2, 1),
        MissionItem::return_to_launch(),
    ]
}

#[test]
fn ardupilot_upload_uses_mission_request_and_is_lossy() {
    let mut s = MissionServer::new(SimAutopilot::ArduPilot, 1, 1);
    s.set_home(Some(HomeItem {
        lat_e7: 371_960_000,
        lon_e7: -805_800_000,
        alt_amsl_m: 610.5,
    }));
    let out = upload(&mut s, &sample(), Time::ZERO);
    let requests = out
        .iter()
        .filter(|m| matches!(m, MavMessage::MISSION_REQUEST(_)))
        .count();
    assert_eq!(requests, 6);
    assert!(
        !out.iter()
            .any(|m| matches!(m, MavMessage::MISSION_REQUEST_INT(_)))
    );
    assert!(
        matches!(out.last(), Some(MavMessage::MISSION_ACK(a)) if a.mavtype == mav::MavMissionResult::MAV_MISSION_ACCEPTED)
    );
    let stored = s.items(MissionType::Mission);
    assert_eq!(stored.len(), 6);
    // the waypoint kept its delay (whole seconds) and position only
    assert_eq!(stored[2].param1, 3.0);
    assert_eq!(stored[2].param2, 0.0);
    assert!((stored[2].z - 12.34).abs() < 1e-4);
    assert_eq!(stored[2].frame, frame::GLOBAL_RELATIVE_ALT);
    // download of seq 0 returns the live home, frame GLOBAL
    s.handle_message(
        &GCS,
        &MavMessage::MISSION_REQUEST_INT(mav::MISSION_REQUEST_INT_DATA {
            seq: 0,
            target_system: 1,
            target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
            mission_type: mav::MavMissionType::MAV_MISSION_TYPE_MISSION,
        }),
        Time::ZERO,
    );
    match drain(&mut s).as_slice() {
        [MavMessage::MISSION_ITEM_INT(h)] => {
            assert_eq!((h.x, h.y), (371_960_000, -805_800_000));
            assert_eq!(h.frame, mav::MavFrame::MAV_FRAME_GLOBAL);
            assert!((h.z - 610.5).abs() < 1e-3);
        }
        other => panic!("{other:?}"),
    }
}

#[test]
fn ardupilot_count_truncates_at_once_and_times_out() {
    let mut s = MissionServer::new(SimAutopilot::ArduPilot, 1, 1);
    upload(&mut s, &sample(), Time::ZERO);
    let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
    s.handle_message(&GCS, &count(3, mt), Time::from_secs(1));
    assert_eq!(s.items(MissionType::Mission).len(), 3);
    drain(&mut s);
    // another GCS is denied
    let other = MavHeader {
        system_id: 254,
        ..GCS
    };
    s.handle_message(&other, &count(2, mt), Time::from_secs(1));
    assert!(
        matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_ACK(a)] if a.mavtype == mav::MavMissionResult::MAV_MISSION_DENIED)
    );
    // resend after 1 s, cancel after 8 s
    let t = s.poll_timeout().unwrap();
    assert!(t > Time::from_secs(2) && t <= Time::from_millis(2002));
    s.handle_timeout(t);
    assert!(matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_REQUEST(r)] if r.seq == 0));
    s.handle_timeout(Time::from_millis(9002));
    let out = drain(&mut s);
    assert!(out.iter().any(|m| matches!(m, MavMessage::MISSION_ACK(a) if a.mavtype == mav::MavMissionResult::MAV_MISSION_OPERATION_CANCELLED)));
    assert!(!s.receiving());
    // the old items past 3 are gone even though the upload failed
    assert_eq!(s.items(MissionType::Mission).len(), 3);
}

#[test]
fn ardupilot_wrong_seq_and_item_without_transfer() {
    let mut s = MissionServer::new(SimAutopilot::ArduPilot, 1, 1);
    let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
    let it = MissionItem::waypoint(1.0, 2.0, 3.0);
    s.handle_message(&GCS, &item_int(0, &it, mt), Time::ZERO);
    assert!(
        matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_ACK(a)] if a.mavtype == mav::MavMissionResult::MAV_MISSION_ERROR)
    );
    s.handle_message(&GCS, &count(2, mt), Time::ZERO);
    drain(&mut s);
    s.handle_message(&GCS, &item_int(1, &it, mt), Time::ZERO);
    assert!(
        matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_ACK(a)] if a.mavtype == mav::MavMissionResult::MAV_MISSION_INVALID_SEQUENCE)
    );
    assert!(s.receiving());
    // an unsupported command aborts
    let mut bad = it;
    bad.command = 31000; // MAV_CMD_USER_1
    s.handle_message(&GCS, &item_int(0, &bad, mt), Time::ZERO);
    assert!(
        matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_ACK(a)] if a.mavtype == mav::MavMissionResult::MAV_MISSION_UNSUPPORTED)
    );
    assert!(!s.receiving());
}

#[test]
fn px4_upload_switches_to_int_mode_and_reacks_duplicates() {
    let mut s = MissionServer::new(SimAutopilot::Px4, 1, 1);
    let items = &sample()[1..];
    let out = upload(&mut s, items, Time::ZERO);
    // first request is the float variant, then INT once the GCS sent MISSION_ITEM_INT
    assert!(matches!(out[0], MavMessage::MISSION_REQUEST(_)));
    assert!(matches!(out[1], MavMessage::MISSION_REQUEST_INT(_)));
    let ack = match out.last() {
        Some(MavMessage::MISSION_ACK(a)) => a.clone(),
        other => panic!("{other:?}"),
    };
    assert_eq!(ack.mavtype, mav::MavMissionResult::MAV_MISSION_ACCEPTED);
    assert_ne!(ack.opaque_id, 0);
    let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
    let last = items.len() as u16 - 1;
    s.handle_message(&GCS, &item_int(last, &items[last as usize], mt), Time::ZERO);
    assert!(
        matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_ACK(a)] if a.mavtype == mav::MavMissionResult::MAV_MISSION_ACCEPTED)
    );
    assert_eq!(s.items(MissionType::Mission).len(), items.len());
    // download: INT frames
    s.handle_message(
        &GCS,
        &MavMessage::MISSION_REQUEST_LIST(mav::MISSION_REQUEST_LIST_DATA {
            target_system: 1,
            target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
            mission_type: mt,
        }),
        Time::ZERO,
    );
    assert!(matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_COUNT(c)] if c.count == 5));
    s.handle_message(
        &GCS,
        &MavMessage::MISSION_REQUEST_INT(mav::MISSION_REQUEST_INT_DATA {
            seq: 1,
            target_system: 1,
            target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
            mission_type: mt,
        }),
        Time::ZERO,
    );
    // seq 1 while 0 is expected: PX4 aborts the transfer
    assert!(drain(&mut s).iter().any(|m| matches!(m, MavMessage::MISSION_ACK(a) if a.mavtype == mav::MavMissionResult::MAV_MISSION_ERROR)));
}

#[test]
fn px4_rejects_rtl_in_a_global_frame_and_retries() {
    let mut s = MissionServer::new(SimAutopilot::Px4, 1, 1);
    let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
    s.handle_message(&GCS, &count(1, mt), Time::ZERO);
    drain(&mut s);
    assert_eq!(s.poll_timeout(), Some(Time::from_micros(250_001)));
    s.handle_timeout(Time::from_micros(250_001));
    assert!(matches!(drain(&mut s).as_slice(), [MavMessage::MISSION_REQUEST(r)] if r.seq == 0));
    let mut rtl = MissionItem::return_to_launch();
    rtl.frame = frame::GLOBAL_RELATIVE_ALT;
    s.handle_message(&GCS, &item_int(0, &rtl, mt), Time::from_millis(300));
    assert!(drain(&mut s).iter().any(|m| matches!(m, MavMessage::MISSION_ACK(a) if a.mavtype == mav::MavMissionResult::MAV_MISSION_UNSUPPORTED)));
    assert!(!s.receiving());
    let _ = cmd::NAV_RETURN_TO_LAUNCH;
}

#[test]
fn reboot_keeps_lists() {
    for ap in [SimAutopilot::ArduPilot, SimAutopilot::Px4] {
        let mut s = MissionServer::new(ap, 1, 1);
        upload(&mut s, &sample(), Time::ZERO);
        s.set_current(3);
        s.reboot();
        assert_eq!(s.items(MissionType::Mission).len(), 6);
        assert_eq!(
            s.current(),
            if ap == SimAutopilot::ArduPilot { 1 } else { 0 }
        );
    }
}

/// ArduCopter 4.7 SITL in its first 2 s (seen with pymavlink): MISSION_COUNT gets
/// MAV_MISSION_NO_SPACE and "Only 0 items are supported", MISSION_REQUEST_LIST a count
/// of 0 whatever is stored; once loaded, both work. PX4 is never "not loaded".
#[test]
fn ardupilot_refuses_uploads_and_reads_empty_while_booting() {
    let mt = mav::MavMissionType::MAV_MISSION_TYPE_MISSION;
    let mut s = MissionServer::new(SimAutopilot::ArduPilot, 1, 1);
    upload(&mut s, &sample(), Time::ZERO);
    s.reboot();
    s.set_loaded(false);
    let out = upload(&mut s, &sample(), Time::from_secs(1));
    assert!(out.iter().any(|m| matches!(m, MavMessage::MISSION_ACK(a)
        if a.mavtype == mav::MavMissionResult::MAV_MISSION_NO_SPACE)));
    assert!(out.iter().any(|m| matches!(m, MavMessage::STATUSTEXT(t)
        if t.text.to_str().is_ok_and(|x| x.starts_with("Only 0 items")))));
    let list = MavMessage::MISSION_REQUEST_LIST(mav::MISSION_REQUEST_LIST_DATA {
        target_system: 1,
        target_component: fleetmap_core::proto::AUTOPILOT_COMPID,
        mission_type: mt,
    });
    s.handle_message(&GCS, &list, Time::from_secs(1));
    assert!(
        drain(&mut s)
            .iter()
            .any(|m| matches!(m, MavMessage::MISSION_COUNT(c) if c.count == 0))
    );
    assert_eq!(
        s.items(MissionType::Mission).len(),
        6,
        "nothing lost meanwhile"
    );
    s.set_loaded(true);
    s.handle_message(&GCS, &list, Time::from_secs(3));
    assert!(
        drain(&mut s)
            .iter()
            .any(|m| matches!(m, MavMessage::MISSION_COUNT(c) if c.count == 6))
    );
    let mut p = MissionServer::new(SimAutopilot::Px4, 1, 1);
    p.set_loaded(false);
    let out = upload(&mut p, &sample()[1..], Time::ZERO);
    assert!(out.iter().any(|m| matches!(m, MavMessage::MISSION_ACK(a)
        if a.mavtype == mav::MavMissionResult::MAV_MISSION_ACCEPTED)));
}
