use super::*;
use crate::proto::flavour::Flavour;

const MISSION: &str = r#"
name = "check"
kind = "runway-mapping"
[grid]
origin = "vehicle"
cell_size_m = 4.0
[flight]
altitude_m = 12.0
altitude_separation_m = 0.0
speed_m_s = 2.0
[[vehicles]]
sysid = 1
role = "drone"
[[vehicles]]
sysid = 2
role = "drone"
[runway]
sweep = { north_m = [0.0, 40.0], east_m = [0.0, 40.0] }
"#;

fn mission() -> MissionDef {
    match MissionDef::parse(MISSION, "check.toml") {
        Ok(d) => d,
        Err(e) => panic!("{e:?}"),
    }
}

fn params(kv: &[(&str, f32)]) -> BTreeMap<String, f32> {
    kv.iter().map(|(k, v)| ((*k).to_string(), *v)).collect()
}

/// An ArduCopter 4.7 SITL with every failsafe on, its camera heard, at its own home.
fn good_copter(sysid: u8) -> VehicleReport {
    VehicleReport {
        sysid,
        heard: true,
        flavour: Some(Flavour::from_heartbeat(3, 2)),
        params: params(&[
            (MAV_GCS_SYSID, 255.0),
            (MAV_OPTIONS, 0.0),
            (FS_GCS_ENABLE, 1.0),
            (BATT_FS_LOW_ACT, 2.0),
            (BATT_FS_CRT_ACT, 1.0),
            (FENCE_ENABLE, 1.0),
            (FENCE_ACTION, 1.0),
            (RTL_ALT, 1500.0 + 500.0 * f32::from(sysid)),
        ]),
        camera: true,
        home: Some((-35.3632, 149.1652 + 0.00003 * f64::from(sysid))),
        ..VehicleReport::default()
    }
}

fn checks(f: &[Finding]) -> Vec<(Severity, Check, u8)> {
    f.iter().map(|f| (f.severity, f.check, f.sysid)).collect()
}

#[test]
fn a_well_set_fleet_has_no_finding() {
    assert_eq!(
        check(&mission(), &[good_copter(1), good_copter(2)], 255),
        []
    );
}

#[test]
fn the_simulators_and_sitls_defaults_give_warnings_and_no_blocker() {
    // ArduCopter 4.7 SITL's defaults (read with PARAM_REQUEST_LIST)
    let sitl = |sysid| {
        let mut r = good_copter(sysid);
        r.params = params(&[
            (MAV_GCS_SYSID, 255.0),
            (MAV_OPTIONS, 0.0),
            (FS_GCS_ENABLE, 0.0),
            (BATT_FS_LOW_ACT, 0.0),
            (BATT_FS_CRT_ACT, 0.0),
            (FENCE_ENABLE, 0.0),
            (FENCE_ACTION, 1.0),
            (RTL_ALT, 1500.0),
        ]);
        r
    };
    let f = check(&mission(), &[sitl(1), sitl(2)], 255);
    assert_eq!(blockers(&f), 0);
    use Check::*;
    let w = Severity::Warning;
    assert_eq!(
        checks(&f),
        [
            (w, GcsFailsafe, 1),
            (w, BatteryFailsafe, 1),
            (w, Geofence, 1),
            (w, GcsFailsafe, 2),
            (w, BatteryFailsafe, 2),
            (w, RtlAltitude, 2),
            (w, Geofence, 2),
        ]
    );
    let fixes: Vec<&str> = f.iter().map(|f| f.fix.as_str()).collect();
    assert!(fixes.contains(&"param set FS_GCS_ENABLE 1"), "{fixes:?}");
    assert!(fixes.contains(&"param set BATT_FS_LOW_ACT 2"), "{fixes:?}");
    // the second drone is sent above the first (15 m + 5 m)
    assert!(fixes.contains(&"param set RTL_ALT 2000"), "{fixes:?}");
}

#[test]
fn an_enforced_foreign_gcs_id_is_a_blocker_an_unenforced_one_a_warning() {
    let mut a = good_copter(1);
    a.params.insert(MAV_GCS_SYSID.into(), 250.0);
    a.params.insert(MAV_OPTIONS.into(), 1.0);
    let f = check(&mission(), &[a.clone(), good_copter(2)], 255);
    assert_eq!(checks(&f), [(Severity::Blocker, Check::GcsId, 1)]);
    assert_eq!(f[0].fix, "param set MAV_GCS_SYSID 255");
    // a range that holds 255 is fine
    a.params.insert(MAV_GCS_SYSID_HI.into(), 255.0);
    assert_eq!(check(&mission(), &[a.clone(), good_copter(2)], 255), []);
    a.params.remove(MAV_GCS_SYSID_HI);
    a.params.insert(MAV_OPTIONS.into(), 0.0);
    let f = check(&mission(), &[a, good_copter(2)], 255);
    assert_eq!(checks(&f), [(Severity::Warning, Check::GcsId, 1)]);
    // ArduPilot before 4.7
    let mut old = good_copter(1);
    old.params.remove(MAV_GCS_SYSID);
    old.params.remove(MAV_OPTIONS);
    old.params.insert(SYSID_MYGCS.into(), 250.0);
    old.params.insert(SYSID_ENFORCE.into(), 1.0);
    let f = check(&mission(), &[old, good_copter(2)], 255);
    assert_eq!(checks(&f), [(Severity::Blocker, Check::GcsId, 1)]);
    assert_eq!(f[0].fix, "param set SYSID_MYGCS 255");
}

#[test]
fn duplicate_ids_missing_vehicles_and_cameras_are_blockers() {
    let mut a = good_copter(1);
    a.conflict = Some("two sequence counters".into());
    let mut b = good_copter(2);
    b.camera = false;
    let f = check(&mission(), &[a, b], 255);
    assert_eq!(
        checks(&f),
        [
            (Severity::Blocker, Check::DuplicateSysid, 1),
            (Severity::Blocker, Check::Camera, 2)
        ]
    );
    let gone = VehicleReport {
        sysid: 2,
        ..VehicleReport::default()
    };
    let f = check(&mission(), &[good_copter(1), gone], 255);
    assert_eq!(checks(&f), [(Severity::Blocker, Check::NotHeard, 2)]);
    assert_eq!(blockers(&f), 1);
}

#[test]
fn rtl_altitudes_matter_only_for_drones_that_share_a_home() {
    let mut b = good_copter(2);
    b.params.insert(RTL_ALT.into(), 2100.0); // 21 m against 20 m
    let f = check(&mission(), &[good_copter(1), b.clone()], 255);
    assert_eq!(checks(&f), [(Severity::Warning, Check::RtlAltitude, 2)]);
    // 0 = return at the current altitude: nothing to compare
    b.params.insert(RTL_ALT.into(), 0.0);
    assert_eq!(check(&mission(), &[good_copter(1), b.clone()], 255), []);
    // a home 200 m away
    b.params.insert(RTL_ALT.into(), 2000.0);
    b.home = Some((-35.3632 + 0.0018, 149.1652));
    assert_eq!(check(&mission(), &[good_copter(1), b], 255), []);
}

#[test]
fn px4_settings_are_read_by_their_names() {
    let px4 = |sysid, kv: &[(&str, f32)]| VehicleReport {
        sysid,
        heard: true,
        flavour: Some(Flavour::from_heartbeat(12, 2)),
        params: params(kv),
        camera: true,
        home: Some((47.0, 8.0)),
        ..VehicleReport::default()
    };
    let ok = [
        (NAV_DLL_ACT, 2.0),
        (COM_LOW_BAT_ACT, 3.0),
        (GF_ACTION, 2.0),
        (RTL_RETURN_ALT, 30.0),
    ];
    let bad = [
        (NAV_DLL_ACT, 0.0),
        (COM_LOW_BAT_ACT, 0.0),
        (GF_ACTION, 1.0),
        (RTL_RETURN_ALT, 30.0),
    ];
    let f = check(&mission(), &[px4(1, &ok), px4(2, &bad)], 255);
    use Check::*;
    let w = Severity::Warning;
    assert_eq!(
        checks(&f),
        [
            (w, GcsFailsafe, 2),
            (w, BatteryFailsafe, 2),
            (w, RtlAltitude, 2),
            (w, Geofence, 2)
        ]
    );
    assert!(f.iter().any(|f| f.fix == "param set RTL_RETURN_ALT 35"));
}

#[test]
fn telemetry_over_a_radios_share_and_unanswered_names_are_warnings() {
    let mut a = good_copter(1);
    a.budget = LinkBudget::radio();
    a.down_bytes_per_s = Some(1500.0); // share: 800 B/s
    a.unread = vec![FS_GCS_ENABLE.into()];
    let mut b = good_copter(2);
    b.budget = LinkBudget::radio();
    b.down_bytes_per_s = Some(700.0);
    let f = check(&mission(), &[a, b], 255);
    assert_eq!(
        checks(&f),
        [
            (Severity::Warning, Check::StreamRates, 1),
            (Severity::Warning, Check::Unread, 1)
        ]
    );
}

#[test]
fn older_names_are_asked_only_when_the_new_ones_are_missing() {
    let ap = Flavour::from_heartbeat(3, 2);
    assert!(first_read(ap).contains(&RTL_ALT));
    let rover = Flavour::from_heartbeat(3, 10);
    assert!(!first_read(rover).contains(&RTL_ALT));
    let read = params(&[(MAV_GCS_SYSID, 255.0)]);
    assert!(next_read(ap, &read, &[], 255).is_empty());
    let read = params(&[(MAV_GCS_SYSID, 250.0)]);
    assert_eq!(next_read(ap, &read, &[], 255), [MAV_GCS_SYSID_HI]);
    assert!(next_read(ap, &read, &[MAV_GCS_SYSID_HI.into()], 255).is_empty());
    let gone = [MAV_GCS_SYSID.to_string()];
    assert_eq!(
        next_read(ap, &BTreeMap::new(), &gone, 255),
        [SYSID_MYGCS, SYSID_ENFORCE]
    );
    let px4 = Flavour::from_heartbeat(12, 2);
    assert_eq!(
        first_read(px4),
        [NAV_DLL_ACT, COM_LOW_BAT_ACT, GF_ACTION, RTL_RETURN_ALT]
    );
    assert!(next_read(px4, &BTreeMap::new(), &gone, 255).is_empty());
}

#[test]
fn an_autopilot_that_answers_nothing_is_a_blocker() {
    let mut a = good_copter(1);
    a.unread = a.params.keys().cloned().collect();
    a.params.clear();
    let f = check(&mission(), &[a, good_copter(2)], 255);
    assert_eq!(checks(&f), [(Severity::Blocker, Check::GcsId, 1)]);
    // another ground station id chosen by the operator
    let mut b = good_copter(2);
    b.params.insert(MAV_GCS_SYSID.into(), 250.0);
    b.params.insert(MAV_OPTIONS.into(), 1.0);
    // (the first, still at 255, would not count fleetmap's heartbeats for its failsafe)
    let f = check(&mission(), &[good_copter(1), b], 250);
    assert_eq!(checks(&f), [(Severity::Warning, Check::GcsId, 1)]);
}
