use super::*;
use fleetmap_core::geo::Cell;
use fleetmap_core::proto::flavour::Autopilot;
use fleetmap_core::proto::severity::Severity;

#[test]
fn map_rows_are_north_up() {
    let m = MapModel::from_rows(MapKind::default(), 4.0, Cell::new(-1, 2), &["+.", "-#"])
        .expect("valid rows");
    assert_eq!((m.rows, m.cols), (2, 2));
    // The last string is the southern row (row -1).
    assert_eq!(m.get(Cell::new(-1, 2)), Some(CellState::Negative));
    assert_eq!(m.get(Cell::new(-1, 3)), Some(CellState::Explored));
    assert_eq!(m.get(Cell::new(0, 2)), Some(CellState::PositiveUnexplored));
    assert_eq!(m.get(Cell::new(0, 3)), Some(CellState::Unknown));
    assert_eq!(m.get(Cell::new(1, 2)), None);
    assert_eq!(m.north_east(), Cell::new(0, 3));
    assert_eq!(m.to_rows(), vec!["+.", "-#"]);
}

#[test]
fn map_json_round_trips_and_rejects_bad_rows() {
    const LEGEND: [CellState; 2] = [CellState::Unclassified, CellState::Keep];
    let mut m = MapModel::new(MapKind::new("fields", &LEGEND), 10.0, Cell::new(0, 0), 3, 4);
    assert!(m.set(Cell::new(2, 3), CellState::Keep));
    assert!(!m.set(Cell::new(3, 0), CellState::Keep));
    m.home = Some(Cell::new(0, 0));
    let json = serde_json::to_string(&m).expect("serialise");
    assert!(json.contains(r#""rows":["???K","????","????"]"#), "{json}");
    assert!(json.contains(r#""kind":"fields""#), "{json}");
    let mut back: MapModel = serde_json::from_str(&json).expect("parse");
    // The legend is not recorded: the UI takes it from the kind of that label.
    assert!(back.kind.legend.is_empty());
    back.kind.legend = m.kind.legend.clone();
    assert_eq!(back, m);

    let none = serde_json::to_value(MapModel::default()).expect("serialise");
    assert!(none.get("kind").is_none(), "{none}");

    let ragged = r#"{"rows":["..","..."]}"#;
    let err = serde_json::from_str::<MapModel>(ragged).unwrap_err();
    assert!(err.to_string().contains("map row 1 has 3 cells"), "{err}");
    let bad = r#"{"rows":["..Z"]}"#;
    let err = serde_json::from_str::<MapModel>(bad).unwrap_err();
    assert!(err.to_string().contains("'Z' is not a cell state"), "{err}");
}

#[test]
fn glyphs_are_unique() {
    for a in CellState::ALL {
        assert_eq!(CellState::from_glyph(a.glyph()), Some(a));
    }
}

/// Replay files spell the mission's kind as the UI's own enum did (`"none"`,
/// `"runway_mapping"`, `"spatial_classification"`): the kind's name with `_` for spaces.
#[test]
fn replay_files_keep_the_mission_kind_spelling() {
    let m = MissionModel {
        kind: Some(MissionKind::new("crop dusting", true)),
        ..MissionModel::default()
    };
    let v = serde_json::to_value(&m).expect("serialise");
    assert_eq!(v["kind"], "crop_dusting");
    let back: MissionModel = serde_json::from_value(v).expect("parse");
    let kind = back.kind.expect("a kind");
    assert_eq!(kind.name, "crop dusting");
    assert!(!kind.epochs, "not recorded: the UI asks the kind");
    let none = serde_json::to_value(MissionModel::default()).expect("serialise");
    assert_eq!(none["kind"], "none");
    let back: MissionModel = serde_json::from_value(none).expect("parse");
    assert_eq!(back.kind, None);
}

#[test]
fn hms_formats() {
    assert_eq!(format_hms(0.0), "00:00");
    assert_eq!(format_hms(75.9), "01:15");
    assert_eq!(format_hms(3725.0), "1:02:05");
    assert_eq!(format_hms(f64::NAN), "00:00");
    assert_eq!(format_hms(-5.0), "00:00");
}

#[test]
fn severity_from_wire() {
    assert_eq!(Severity::from_mav(0), Severity::Emergency);
    assert_eq!(Severity::from_mav(4), Severity::Warning);
    assert_eq!(Severity::from_mav(200), Severity::Debug);
}

/// Replay files spell the autopilot as the TUI's own enum did before it became
/// `proto::flavour::Autopilot` (snake_case unit variants); the MAV_AUTOPILOT number of
/// `Other` is not recorded.
#[test]
fn replay_files_keep_the_autopilot_spelling() {
    let spelled = |a: Autopilot| {
        let row = VehicleRow {
            autopilot: a,
            ..VehicleRow::default()
        };
        serde_json::to_value(&row).expect("a row serializes")["autopilot"].clone()
    };
    assert_eq!(spelled(Autopilot::ArduPilot), "ardu_pilot");
    assert_eq!(spelled(Autopilot::Px4), "px4");
    assert_eq!(spelled(Autopilot::Other(0)), "other");
    assert_eq!(spelled(Autopilot::default()), "other");
    let read = |s: &str| -> VehicleRow {
        serde_json::from_str(&format!(r#"{{"sysid": 3, "autopilot": "{s}"}}"#))
            .expect("a recorded row reads back")
    };
    assert_eq!(read("ardu_pilot").autopilot, Autopilot::ArduPilot);
    assert_eq!(read("px4").autopilot, Autopilot::Px4);
    assert_eq!(read("other").autopilot, Autopilot::default());
    assert!(serde_json::from_str::<VehicleRow>(r#"{"autopilot": "ArduPilot"}"#).is_err());
    let missing: VehicleRow = serde_json::from_str(r#"{"sysid": 3}"#).expect("defaults");
    assert_eq!(missing.autopilot, Autopilot::default());
}
