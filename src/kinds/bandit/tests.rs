//! Unit tests of the bandit run: station proximity, charger pads, green measurement.

use super::pilot::{PAD_SPACING_M, pad_offset};
use super::*;
use image::RgbImage;

/// A drone on the far pad of a station that stopped short of its cell, nearer to it than
/// to the neighbouring station but within 2.5 m of both, is on its own station.
#[test]
fn a_drone_is_on_the_nearest_station() {
    use fleetmap_core::mission::definition::{MissionDef, Origin};
    let def = MissionDef::parse(super::sim::HARDWARE_MISSION, "h.toml").unwrap();
    let Origin::Coordinates(o) = def.grid.origin else {
        panic!("fixed origin");
    };
    let grid =
        fleetmap_core::geo::Grid::new(LatLon::new(o.lat, o.lon), def.grid.cell_size_m).unwrap();
    let state = ClassificationState::new(&def, grid, None).unwrap();
    // Stations 5 and 6 on the road cells (3, 1) and (3, 2), 5 m apart in the plan, but
    // station 5 stopped 2.2 m east of its cell's centre: 2.8 m from station 6.
    let expected = TeamConfig {
        drones: vec![
            Cell::new(3, 1),
            Cell::new(3, 1),
            Cell::new(3, 2),
            Cell::new(3, 2),
        ],
        stations: vec![Cell::new(3, 1), Cell::new(3, 2)],
    };
    let s = state.grid.cell_size();
    let at = |sysid: u8, east: f64, north: f64| {
        let mut v = VehicleSnapshot::test_copter(sysid);
        let p = state.grid.from_xy(east, north).unwrap();
        v.position = Some(crate::fleet::GeoPoint {
            lat: p.lat,
            lon: p.lon,
            alt_amsl: 600.0,
        });
        (sysid, v)
    };
    let (e5, e6, n) = (1.0 * s + 2.2, 2.0 * s, 3.0 * s);
    let snap: BTreeMap<u8, VehicleSnapshot> = [
        at(1, e5 - 0.3, n),
        at(2, e5 + 0.3, n),
        // on station 6's west pad, landed 0.2 m off: 2.3 m from station 5 (listed first)
        at(3, e6 - 0.5, n),
        at(4, e6 + 0.3, n),
        at(5, e5, n),
        at(6, e6, n),
    ]
    .into_iter()
    .collect();
    assert!(
        (e6 - 0.5) - e5 <= 2.5,
        "drone 3 is within 2.5 m of station 5 too"
    );
    let c = observed_config(&state, &snap, &expected).unwrap();
    assert_eq!(c, expected);
    state.validate_config(&c).unwrap();
}

#[test]
fn pads_are_distinct_and_close_to_the_centre() {
    assert_eq!(pad_offset((0, 1)), (0.0, 0.0));
    let two = [pad_offset((0, 2)), pad_offset((1, 2))];
    assert_eq!(two, [(0.0, -0.3), (0.0, 0.3)]);
    for n in 1..=9 {
        let pads: Vec<(f64, f64)> = (0..n).map(|i| pad_offset((i, n))).collect();
        for (i, a) in pads.iter().enumerate() {
            assert!(a.0.hypot(a.1) <= 0.85, "{n} pads: {a:?}");
            for b in &pads[i + 1..] {
                assert!((a.0 - b.0).hypot(a.1 - b.1) >= PAD_SPACING_M - 1e-9);
            }
        }
    }
}

#[test]
fn a_green_tile_under_the_camera_is_a_positive_measurement() {
    let cam = CameraModel::paper();
    // the centre 40 % green, the rest grey: positive once cropped to the cell
    let img = RgbImage::from_fn(200, 200, |x, y| {
        if (60..140).contains(&x) && (60..140).contains(&y) {
            image::Rgb([40, 165, 70])
        } else {
            image::Rgb([128, 128, 128])
        }
    });
    let mut png = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png)
        .unwrap();
    let g = GreenParams {
        min_fraction: 0.2,
        ..GreenParams::default()
    };
    let (f, pos) = measure_image(&png, &g, &cam, 10.0, 5.0, 0.6).unwrap();
    assert!(pos && f > 0.99, "{f}");
    // uncropped, a high drone would see mostly grey
    let (f, _) = measure_image(&png, &g, &cam, 2.0, 5.0, 0.6).unwrap();
    assert!(f < 0.2, "{f}");
    assert!(measure_image(b"not an image", &g, &cam, 10.0, 5.0, 0.6).is_err());
}

/// A station's snapshot (ArduRover: MAV_TYPE_GROUND_ROVER, MAV_AUTOPILOT_ARDUPILOTMEGA) and
/// the messages ArduRover SITL V4.7.0-dev (90700977) sent for a station mission of one
/// waypoint on the cell the rover stood on (DO_CHANGE_SPEED, NAV_WAYPOINT: wire seq 1, 2).
mod ardurover_arrival {
    use super::*;
    use fleetmap_core::time::Time;
    use mavlink::dialects::ardupilotmega::{
        MISSION_CURRENT_DATA, MISSION_ITEM_REACHED_DATA, MavMessage, MissionState,
    };

    fn rover() -> VehicleSnapshot {
        let beat = fleetmap_core::proto::heartbeat::Beat {
            custom_mode: 0,
            mav_type: mavlink::dialects::ardupilotmega::MavType::MAV_TYPE_GROUND_ROVER as u8,
            autopilot: 3,
            base_mode: 0,
            system_status: 3,
        };
        VehicleSnapshot::new(5, 1, &beat, 0, Time::ZERO)
    }

    fn current(seq: u16, state: MissionState) -> MavMessage {
        MavMessage::MISSION_CURRENT(MISSION_CURRENT_DATA {
            seq,
            total: 2,
            mission_state: state,
            ..Default::default()
        })
    }

    fn reached(seq: u16) -> MavMessage {
        MavMessage::MISSION_ITEM_REACHED(MISSION_ITEM_REACHED_DATA { seq })
    }

    fn items() -> Vec<MissionItem> {
        vec![
            MissionItem::change_speed(1.0),
            MissionItem::waypoint(37.195135, -80.579943, 0.0),
        ]
    }

    /// Uploaded, made current from item 0 (ArduPilot moves on to the next nav command: seq
    /// 2), armed, then MISSION_START (the fleet forgets the progress first).
    fn started() -> VehicleSnapshot {
        let mut v = rover();
        let t = Time::ZERO;
        v.apply(&current(0, MissionState::MISSION_STATE_NOT_STARTED), t);
        v.apply(&current(2, MissionState::MISSION_STATE_NOT_STARTED), t);
        v.reset_progress();
        v
    }

    #[test]
    fn the_whole_sequence_is_an_arrival() {
        let mut v = started();
        let t = Time::ZERO;
        v.apply(&reached(1), t);
        v.apply(&current(2, MissionState::MISSION_STATE_ACTIVE), t);
        let seen_active = v.mission_active();
        v.apply(&reached(2), t);
        v.apply(&current(2, MissionState::MISSION_STATE_COMPLETE), t);
        let it = items();
        assert!(is_complete(&v, &it, seen_active));
        assert_eq!(done_items(&v, &it, true, false), vec![0, 1]);
    }

    /// The waypoint was reached within a second: the GCS never sampled the ACTIVE report,
    /// and the last MISSION_ITEM_REACHED was lost; MISSION_ITEM_REACHED of item 0 and
    /// MISSION_CURRENT COMPLETE on the last item still say it arrived.
    #[test]
    fn complete_on_the_last_item_after_an_early_reached_is_an_arrival() {
        let mut v = started();
        let t = Time::ZERO;
        v.apply(&reached(1), t);
        v.apply(&current(2, MissionState::MISSION_STATE_COMPLETE), t);
        let it = items();
        assert!(is_complete(&v, &it, false));
        assert_eq!(done_items(&v, &it, true, false), vec![0, 1]);
    }

    /// The next sortie: the last mission finished (COMPLETE on its last item, the rover left
    /// in AUTO), a new one made current; MISSION_START in AUTO starts nothing on ArduRover.
    /// Nothing of the old mission may count as an arrival.
    #[test]
    fn the_previous_missions_completion_is_no_arrival() {
        let mut v = rover();
        let t = Time::ZERO;
        v.apply(&reached(2), t);
        v.apply(&current(2, MissionState::MISSION_STATE_COMPLETE), t);
        v.apply(&current(2, MissionState::MISSION_STATE_NOT_STARTED), t);
        v.reset_progress();
        let it = items();
        assert!(!is_complete(&v, &it, false));
        // Stale COMPLETE before the reset of the new start is not this mission's either.
        let mut w = rover();
        w.apply(&current(2, MissionState::MISSION_STATE_COMPLETE), t);
        w.reset_progress();
        w.apply(&current(2, MissionState::MISSION_STATE_COMPLETE), t);
        assert!(!is_complete(&w, &it, false));
        assert!(done_items(&w, &it, false, false).is_empty());
    }
}
