//! Mission definition files (`src/mission/definition`): every example in `missions/` loads
//! with the numbers of docs/fixtures.md and the papers, every broken file in `tests/missions/`
//! gives its exact errors (line, column, message), random input never panics, and
//! `fleetmap check` reports them end to end.

use fleetmap_core::geo::Cell;
use fleetmap_core::mission::definition::runway::SweepBox;
use fleetmap_core::mission::definition::{DefError, MissionDef, MissionKind, Origin, Role};
use fleetmap_io::files::load_mission;
use proptest::prelude::*;
use std::path::{Path, PathBuf};

use crate::common;

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn load(rel: &str) -> MissionDef {
    load_mission(root().join(rel)).unwrap_or_else(|e| panic!("{rel} must load:\n{e}"))
}

fn cells(v: &[(i32, i32)]) -> Vec<Cell> {
    v.iter().map(|&(r, c)| Cell::new(r, c)).collect()
}

fn sorted(mut v: Vec<Cell>) -> Vec<Cell> {
    v.sort();
    v
}

fn toml_files(dir: &Path, prefix: &str) -> Vec<PathBuf> {
    let mut out: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| {
            p.extension().is_some_and(|e| e == "toml")
                && p.file_name()
                    .and_then(|n| n.to_str())
                    .is_some_and(|n| n.starts_with(prefix))
        })
        .collect();
    out.sort();
    out
}

// ---- the examples ---------------------------------------------------------------------

#[test]
fn every_example_mission_loads() {
    let files = toml_files(&root().join("missions"), "");
    assert!(files.len() >= 3, "missions/ holds the three examples");
    for f in files {
        load_mission(&f).unwrap_or_else(|e| panic!("{} must load:\n{e}", f.display()));
    }
}

#[test]
fn runway_field_test_matches_the_paper_and_fixtures() {
    let d = load("missions/runway-field-test.toml");
    assert_eq!(d.kind, MissionKind::RunwayMapping);
    assert_eq!(d.grid.origin, Origin::Vehicle);
    assert_eq!(d.grid.cell_size_m, 4.0);
    assert_eq!(d.flight.altitude_m, 12.0);
    assert_eq!(d.flight.speed_m_s, 1.0);
    assert_eq!(d.battery.flight_time_min, 12.0);
    assert_eq!(d.drones().count(), 1);
    assert_eq!(d.stations().count(), 0);
    let r = d.runway.as_ref().unwrap();
    assert_eq!(
        (
            r.images_per_cell,
            r.votes_required,
            r.intensity_threshold,
            r.dilations
        ),
        (5, 3, 150, 7)
    );
    assert_eq!(
        r.sweep,
        SweepBox::Local {
            north_m: [-8.0, 32.0],
            east_m: [-20.0, 20.0]
        }
    );
    // The camera's centre ninth covers one 4 m cell at 12 m (runway paper §7).
    assert!((d.camera.altitude_for_cell(d.grid.cell_size_m) - 12.0).abs() < 1e-9);
    assert!(d.classification.is_none());
    // Sweep box: rows −2…8 and cols −5…5 have their centres inside it.
    assert_eq!(d.sweep_cells().unwrap().len(), 11 * 11);
}

#[test]
fn hardware_6x6_matches_fixtures() {
    let d = load("missions/hardware-6x6.toml");
    assert_eq!(d.kind, MissionKind::SpatialClassification);
    let Origin::Coordinates(o) = d.grid.origin else {
        panic!("fixed origin")
    };
    assert_eq!((o.lat, o.lon), (37.195, -80.58));
    assert_eq!(d.grid.cell_size_m, 5.0);
    assert_eq!((d.area.rows, d.area.cols), (Some(6), Some(6)));
    let obstacles = cells(&[
        (5, 2),
        (5, 4),
        (4, 0),
        (4, 3),
        (4, 5),
        (2, 2),
        (2, 4),
        (1, 0),
        (1, 3),
        (0, 2),
        (0, 4),
    ]);
    assert_eq!(sorted(d.area.obstacles.clone()), sorted(obstacles));
    let mut roads: Vec<Cell> = (0..6).map(|r| Cell::new(r, 1)).collect();
    roads.extend((0..6).filter(|&c| c != 1).map(|c| Cell::new(3, c)));
    assert_eq!(sorted(d.station_cells()), sorted(roads));
    // C = the 4 green + 10 grey cells of docs/fixtures.md.
    let candidates = cells(&[
        (5, 0),
        (4, 4),
        (2, 5),
        (1, 2),
        (5, 3),
        (5, 5),
        (4, 2),
        (2, 0),
        (2, 3),
        (1, 4),
        (1, 5),
        (0, 0),
        (0, 3),
        (0, 5),
    ]);
    assert_eq!(sorted(d.candidate_cells()), sorted(candidates));
    let team: Vec<(u8, Role, Option<Cell>)> = d
        .vehicles
        .iter()
        .map(|v| (v.sysid, v.role, v.start))
        .collect();
    let (w, e) = (Some(Cell::new(3, 1)), Some(Cell::new(3, 4)));
    assert_eq!(
        team,
        vec![
            (1, Role::Drone, w),
            (2, Role::Drone, w),
            (3, Role::Drone, e),
            (4, Role::Drone, e),
            (5, Role::Station, w),
            (6, Role::Station, e),
        ]
    );
    let c = d.classification.as_ref().unwrap();
    assert_eq!((c.theta, c.epsilon, c.delta), (0.5, 0.05, 0.0001));
    assert_eq!(
        (
            c.epoch_goals,
            c.batch_size,
            c.drone_cycle_steps,
            c.station_cycle_steps
        ),
        (6, 30, 8, 4)
    );
    assert_eq!(c.charger_capacity, Some(2));
    assert_eq!(d.station_speed_m_s(), Some(1.0));
    assert_eq!(d.altitude_for(3), Some(14.0));
    assert_eq!(d.altitude_for(5), None, "stations do not fly");
}

#[test]
fn sim_10x10_matches_fixtures() {
    let d = load("missions/sim-10x10.toml");
    assert_eq!((d.area.rows, d.area.cols), (Some(10), Some(10)));
    let obstacles = cells(&[
        (2, 3),
        (2, 5),
        (3, 1),
        (3, 3),
        (3, 8),
        (5, 2),
        (6, 0),
        (6, 8),
        (7, 4),
        (8, 1),
        (9, 1),
        (9, 2),
        (9, 3),
        (9, 4),
        (9, 6),
        (9, 7),
    ]);
    assert_eq!(sorted(d.area.obstacles.clone()), sorted(obstacles));
    assert_eq!(d.area.roads, None, "R = G \\ O");
    assert_eq!(d.station_cells().len(), 84);
    assert_eq!(d.candidate_cells().len(), 84);
    let stations = cells(&[(0, 9), (1, 8), (2, 8), (7, 3), (8, 7)]);
    let got: Vec<(u8, Cell)> = d.stations().map(|v| (v.sysid, v.start.unwrap())).collect();
    let want: Vec<(u8, Cell)> = (11..=15).zip(stations.iter().copied()).collect();
    assert_eq!(got, want);
    for v in d.drones() {
        let s = usize::from(v.sysid - 1) / 2; // drones 2s−1, 2s on station s
        assert_eq!(v.start, Some(stations[s]), "drone {}", v.sysid);
    }
    assert_eq!(d.drones().count(), 10);
    let c = d.classification.as_ref().unwrap();
    assert_eq!(
        (
            c.epoch_goals,
            c.batch_size,
            c.drone_cycle_steps,
            c.station_cycle_steps,
            c.max_cycles
        ),
        (8, 10, 8, 4, 4)
    );
    assert_eq!(c.charger_capacity, None);
}

#[test]
fn omitted_keys_get_the_papers_defaults() {
    let text = r#"
name = "minimal"
kind = "spatial-classification"
[grid]
origin = { lat = 10.0, lon = 20.0 }
cell_size_m = 5
[flight]
altitude_m = 10
speed_m_s = 2
[[vehicles]]
sysid = 1
role = "drone"
start = [0, 0]
[[vehicles]]
sysid = 2
role = "station"
start = [0, 0]
[area]
rows = 3
cols = 3
"#;
    let d = MissionDef::parse(text, "minimal.toml").unwrap();
    let c = d.classification.unwrap();
    assert_eq!((c.theta, c.epsilon, c.delta), (0.5, 0.05, 0.0001));
    // Not the paper's (3b) but the KL bound with the same guarantee, fewer samples.
    assert_eq!(c.bound, fleetmap_core::planner::bandit::ConfidenceBound::Kl);
    assert_eq!(
        (
            c.epoch_goals,
            c.batch_size,
            c.drone_cycle_steps,
            c.station_cycle_steps,
            c.max_cycles
        ),
        (8, 10, 8, 4, 4)
    );
    assert_eq!(c.charger_capacity, None);
    assert_eq!(d.battery.flight_time_min, 12.0);
    assert_eq!(d.flight.altitude_separation_m, 0.0);
    assert_eq!(
        d.camera,
        fleetmap_core::vision::camera::CameraModel::paper()
    );
    assert!(d.area.roads_are_candidates);
    assert_eq!(
        (
            d.battery.descent_rate_m_s,
            d.battery.landing_margin_s,
            d.battery.fresh_pct,
            d.battery.fresh_after_reboot_pct
        ),
        (1.0, 30.0, 95.0, 90.0)
    );
}

/// The sweep and battery keys that used to be constants are read, checked, and reach the
/// runway state (lanes and the battery estimate).
#[test]
fn sweep_and_battery_keys_are_read_checked_and_used() {
    use fleetmap_core::explore::dfs::Sharing;
    use fleetmap_core::explore::mapping::MappingState;
    let base = std::fs::read_to_string(root().join("missions/runway-field-test.toml")).unwrap();
    let with = |runway: &str, battery: &str| {
        // Each table's header line ends in a comment: the keys go on the lines after it.
        base.replace("[runway]", &format!("[runway]\n{runway}\n#"))
            .replace("[battery]", &format!("[battery]\n{battery}\n#"))
    };
    // The field test's origin is the first vehicle's home: put it at the paper's runway.
    let grid = |d: &MissionDef| {
        let origin = fleetmap_core::geo::LatLon {
            lat: 37.1966,
            lon: -80.5785,
        };
        fleetmap_core::geo::Grid::new(origin, d.grid.cell_size_m).unwrap()
    };
    let plain = MissionDef::parse(&base, "plain.toml").unwrap();
    let s0 = MappingState::new(&plain, grid(&plain), Sharing::Gcs).unwrap();
    // Without the key the drones spread over the frontier (the field default).
    assert_eq!(
        s0.params.allocation,
        fleetmap_core::explore::dfs::Allocation::Spread
    );
    let text = with(
        "lane_spacing_m = 4.0\nsweep_position_tolerance_m = 0.5\nallocation = \"nearest_frontier\"",
        "descent_rate_m_s = 0.5\nlanding_margin_s = 60\nfresh_pct = 98",
    );
    let d = MissionDef::parse(&text, "keys.toml").unwrap();
    assert_eq!(d.runway.as_ref().unwrap().lane_spacing_m, Some(4.0));
    let s = MappingState::new(&d, grid(&d), Sharing::Gcs).unwrap();
    assert!(
        s.sweeps[0].lanes > s0.sweeps[0].lanes,
        "narrower lanes, more of them"
    );
    assert!(s.sweeps[0].spacing.across_m <= 4.0 + 1e-9);
    assert_eq!(
        s.params.allocation,
        fleetmap_core::explore::dfs::Allocation::NearestFrontier
    );
    // 12 m at 0.5 m/s instead of 1 m/s, and 30 s more margin: 42 s more of a 720 s battery.
    let more = s.battery_needed_pct(0.0, 12.0) - s0.battery_needed_pct(0.0, 12.0);
    assert!((more - 100.0 * 42.0 / 720.0).abs() < 1e-9, "{more}");
    assert!(!s.params.battery.is_fresh(97.0, false) && s.params.battery.is_fresh(98.0, false));
    // A spacing with gaps, and out-of-range values, are clear errors.
    let gapped = MissionDef::parse(&with("lane_spacing_m = 20.0", ""), "gap.toml").unwrap();
    let err = MappingState::new(&gapped, grid(&gapped), Sharing::Gcs)
        .unwrap_err()
        .to_string();
    assert!(err.contains("leaves gaps"), "{err}");
    let bad = with(
        "sweep_heading_error_deg = 50\nallocation = \"closest\"",
        "fresh_pct = 0",
    );
    let errs = MissionDef::parse(&bad, "bad.toml").unwrap_err().to_string();
    assert!(errs.contains("runway.sweep_heading_error_deg"), "{errs}");
    assert!(errs.contains("battery.fresh_pct"), "{errs}");
    assert!(
        errs.contains("runway.allocation") && errs.contains("\"nearest_frontier\""),
        "{errs}"
    );
}

#[test]
fn a_moving_region_is_read_checked_and_kept_by_the_state() {
    use fleetmap_core::explore::dfs::Sharing;
    use fleetmap_core::explore::mapping::MappingState;
    let base = std::fs::read_to_string(root().join("missions/runway-field-test.toml")).unwrap();
    let with = |key: &str| base.replace("[runway]", &format!("[runway]\n{key}\n#"));
    let origin = fleetmap_core::geo::LatLon {
        lat: 37.1966,
        lon: -80.5785,
    };
    let d = MissionDef::parse(&with("roi_velocity_ne_mps = [0.1, -0.2]"), "moving.toml").unwrap();
    assert_eq!(
        d.runway.as_ref().unwrap().roi_velocity_ne_mps,
        Some([0.1, -0.2])
    );
    let s = MappingState::new(
        &d,
        fleetmap_core::geo::Grid::new(origin, 4.0).unwrap(),
        Sharing::Gcs,
    )
    .unwrap();
    let m = s.params.motion();
    assert_eq!((m.velocity_north, m.velocity_east), (0.1, -0.2));
    assert_eq!(
        s.roi_epoch_unix_ms, None,
        "the shell sets it when the run starts"
    );
    // A state saved before the key existed loads as a static region.
    let mut json = serde_json::to_value(&s).unwrap();
    json["params"]
        .as_object_mut()
        .unwrap()
        .remove("roi_velocity_ne_mps");
    let old: MappingState = serde_json::from_value(json).unwrap();
    assert_eq!(old.params.motion().speed(), 0.0);
    // The field test flies at 1 m/s: a region as fast, or a malformed velocity, is refused.
    for bad in [
        "roi_velocity_ne_mps = [0.6, 0.8]",
        "roi_velocity_ne_mps = [0.1]",
        "roi_velocity_ne_mps = \"east\"",
    ] {
        let errs = MissionDef::parse(&with(bad), "bad.toml")
            .unwrap_err()
            .to_string();
        assert!(errs.contains("runway.roi_velocity_ne_mps"), "{bad}: {errs}");
    }
}

#[test]
fn classification_bound_is_read_and_checked() {
    use fleetmap_core::planner::bandit::ConfidenceBound;
    let text = std::fs::read_to_string(root().join("missions/hardware-6x6.toml")).unwrap();
    let with = |line: &str| {
        assert!(text.contains("[classification]"));
        text.replace("[classification]", &format!("[classification]\n{line}"))
    };
    let d = MissionDef::parse(&with("bound = \"paper\""), "paper.toml").unwrap();
    assert_eq!(d.classification.unwrap().bound, ConfidenceBound::Paper);
    let d = MissionDef::parse(&with("bound = \"kl\""), "kl.toml").unwrap();
    assert_eq!(d.classification.unwrap().bound, ConfidenceBound::Kl);
    let errs = MissionDef::parse(&with("bound = \"hoeffding\""), "bad.toml")
        .unwrap_err()
        .to_string();
    assert!(
        errs.contains("classification.bound") && errs.contains("\"paper\" or \"kl\""),
        "{errs}"
    );
    assert_eq!(errs.trim().lines().count(), 1, "{errs}");
}

#[test]
fn links_are_read_per_mission_and_per_vehicle_and_checked() {
    use fleetmap_core::budget::LinkBudget;
    let text = std::fs::read_to_string(root().join("missions/hardware-6x6.toml")).unwrap();
    let d = MissionDef::parse(&text, "plain.toml").unwrap();
    assert_eq!((d.link, d.link_of(1)), (None, None));
    // Every vehicle on a 1,500 B/s radio but station 5 on a 5,000 B/s one.
    let with = text
        .replacen("[grid]", "link = \"radio:1500\"\n\n[grid]", 1)
        .replacen(
            "name = \"rover-west\"",
            "name = \"rover-west\"\nlink = \"radio:5000\"",
            1,
        );
    let d = MissionDef::parse(&with, "links.toml").unwrap();
    assert_eq!(d.link, Some(LinkBudget::Radio { bytes_per_s: 1500 }));
    assert_eq!(d.link_of(1), Some(LinkBudget::Radio { bytes_per_s: 1500 }));
    assert_eq!(d.link_of(5), Some(LinkBudget::Radio { bytes_per_s: 5000 }));
    // It survives the definition's JSON (run files, `fleetmap check --json`).
    let json = serde_json::to_string(&d).unwrap();
    let back: MissionDef = serde_json::from_str(&json).unwrap();
    assert_eq!(back.link_of(5), d.link_of(5));
    // A bad link is one located error naming the key and the words it takes.
    let bad = text.replacen("[grid]", "link = \"radio:99\"\n\n[grid]", 1);
    let errs = MissionDef::parse(&bad, "bad.toml").unwrap_err().to_string();
    assert!(
        errs.contains("bad.toml:") && errs.contains("link"),
        "{errs}"
    );
    assert!(errs.contains("300 to 100000"), "{errs}");
    assert_eq!(errs.trim().lines().count(), 1, "{errs}");
    let bad = text.replacen("[grid]", "link = \"wifi\"\n\n[grid]", 1);
    let errs = MissionDef::parse(&bad, "bad.toml").unwrap_err().to_string();
    assert!(errs.contains("`wifi` is not a link"), "{errs}");
}

// ---- serde agrees with the reader ------------------------------------------------------

#[test]
fn serde_round_trips_agree_with_the_reader() {
    for f in toml_files(&root().join("missions"), "") {
        let text = std::fs::read_to_string(&f).unwrap();
        let read = MissionDef::parse(&text, "x").unwrap();
        // 1. serde (deny_unknown_fields, same defaults) reads the same definition.
        let mut via_serde: MissionDef = toml::from_str(&text)
            .unwrap_or_else(|e| panic!("{}: serde disagrees: {e}", f.display()));
        via_serde.fill_defaults();
        assert_eq!(via_serde, read, "{}", f.display());
        // 2. written back as TOML, the reader gives the same definition.
        let written = toml::to_string(&read).unwrap();
        let again = MissionDef::parse(&written, "written")
            .unwrap_or_else(|e| panic!("{}: re-read failed:\n{e}\n{written}", f.display()));
        assert_eq!(again, read, "{}", f.display());
        // 3. JSON round trip (`fleetmap check --json`, run directories).
        let json = serde_json::to_string(&read).unwrap();
        let back: MissionDef = serde_json::from_str(&json).unwrap();
        assert_eq!(back, read, "{}", f.display());
        back.validate().unwrap();
    }
}

#[test]
fn serde_also_rejects_unknown_keys() {
    let text = std::fs::read_to_string(root().join("missions/hardware-6x6.toml")).unwrap();
    let typo = text.replace("cell_size_m = 5.0", "cell_size_m = 5.0\ncel_size = 5.0");
    let e = toml::from_str::<MissionDef>(&typo).unwrap_err();
    assert!(e.message().contains("unknown field"), "{e}");
}

#[test]
fn validate_checks_definitions_built_in_code() {
    let mut d = load("missions/sim-10x10.toml");
    d.classification.as_mut().unwrap().drone_cycle_steps = 6;
    d.vehicles[3].sysid = d.vehicles[0].sysid;
    let e = d.validate().unwrap_err();
    let msgs: Vec<String> = e.errors.iter().map(|e| e.to_string()).collect();
    assert_eq!(msgs.len(), 2, "{msgs:#?}");
    assert!(msgs.iter().any(|m| m.starts_with(
        "<mission>: classification.drone_cycle_steps: expected a multiple of station_cycle_steps = 4"
    )));
    assert!(
        msgs.iter()
            .any(|m| m.starts_with("<mission>: vehicles[3].sysid: system id 1"))
    );
    assert!(e.errors.iter().all(|e| e.line == 0 && e.column == 0));
}

// ---- broken files ----------------------------------------------------------------------

/// (file, [(line, column, key path, message substring)]) — every error, in file order.
type Expected = (
    &'static str,
    &'static [(usize, usize, &'static str, &'static str)],
);

const BROKEN: &[Expected] = &[
    (
        "broken-missing-field.toml",
        &[(
            5,
            1,
            "grid.cell_size_m",
            "missing in [grid] (expected a number > 0",
        )],
    ),
    (
        "broken-wrong-type.toml",
        &[
            (
                10,
                14,
                "flight.altitude_m",
                "expected a number, found string \"12\"",
            ),
            (
                21,
                9,
                "vehicles[1].start",
                "expected a cell [row, col] (two integers), found string \"3, 1\"",
            ),
            (
                26,
                22,
                "area.obstacles[1]",
                "expected a cell [row, col] (two integers), found an array of 3 values",
            ),
        ],
    ),
    (
        "broken-unknown-key.toml",
        &[
            (5, 1, "grid.cell_size_m", "missing in [grid]"),
            (
                7,
                1,
                "grid.cell_size",
                "unknown key \"cell_size\" (did you mean \"cell_size_m\"?)",
            ),
            (
                18,
                1,
                "runway.images_per_cel",
                "unknown key \"images_per_cel\" (did you mean \"images_per_cell\"?)",
            ),
            (24, 2, "wind", "unknown key \"wind\""),
        ],
    ),
    (
        "broken-out-of-range.toml",
        &[
            (
                6,
                18,
                "grid.origin.lat",
                "expected a latitude in [-80, 84] degrees (the UTM range), found 95",
            ),
            (
                7,
                15,
                "grid.cell_size_m",
                "expected a number > 0 and ≤ 10000 (metres), found -4",
            ),
            (
                14,
                9,
                "vehicles[0].sysid",
                "expected an integer 1–254, found integer 300",
            ),
            (
                18,
                18,
                "runway.votes_required",
                "expected an integer 1–5 (at most images_per_cell), found 6",
            ),
            (
                19,
                23,
                "runway.intensity_threshold",
                "expected an integer 0–255, found integer 256",
            ),
            (
                22,
                11,
                "runway.sweep.north_m",
                "expected [min, max] with min < max",
            ),
        ],
    ),
    (
        "broken-malformed.toml",
        &[
            (7, 14, "", "TOML syntax:"),
            (15, 14, "", "TOML syntax: invalid basic string"),
        ],
    ),
    (
        "broken-duplicate-sysid.toml",
        &[
            (
                19,
                9,
                "vehicles[1].sysid",
                "system id 3 is already used by vehicles[0]",
            ),
            (
                21,
                8,
                "vehicles[1].name",
                "name \"alpha\" is already used by vehicles[0]",
            ),
        ],
    ),
    (
        "broken-obstacle-road.toml",
        &[
            (27, 9, "vehicles[2].start", "cell [2, 2] is an obstacle"),
            (
                32,
                30,
                "area.obstacles[2]",
                "cell [6, 1] is outside the search area (rows 0–5, cols 0–5)",
            ),
            (
                33,
                26,
                "area.roads[2]",
                "cell [4, 0] is both a road and an obstacle (area.obstacles[1])",
            ),
        ],
    ),
    (
        "broken-planner.toml",
        &[
            (13, 1, "vehicles", "drones but no charging station"),
            (
                23,
                9,
                "classification.theta",
                "expected θ in (0, 1), found 1.5",
            ),
            (
                24,
                15,
                "classification.epoch_goals",
                "expected an integer D ≥ 1, found 0",
            ),
            (
                25,
                21,
                "classification.drone_cycle_steps",
                "expected a multiple of station_cycle_steps = 4",
            ),
        ],
    ),
    (
        "broken-team.toml",
        &[
            (
                22,
                9,
                "vehicles[1].start",
                "more than charger_capacity = 1 drones start on the station at [0, 0]",
            ),
            (
                27,
                9,
                "vehicles[2].start",
                "cell [5, 5] is not a station's start cell",
            ),
            (29, 1, "vehicles[3]", "missing start = [row, col]"),
            (
                41,
                9,
                "vehicles[5].start",
                "cell [0, 0] is already the start of vehicles[4]",
            ),
            (49, 11, "classification.epsilon", "expected ε in (0, 0.5)"),
        ],
    ),
    (
        "broken-kind-mix.toml",
        &[
            (1, 1, "runway", "missing table [runway] with [runway.sweep]"),
            (
                17,
                9,
                "vehicles[0].start",
                "start cells are only for kind = \"spatial-classification\"",
            ),
            (
                21,
                8,
                "vehicles[1].role",
                "runway mapping flies drones only, found a station",
            ),
            (
                24,
                8,
                "area.rows",
                "only for kind = \"spatial-classification\"",
            ),
            (
                26,
                1,
                "classification",
                "a [classification] table is only for kind = \"spatial-classification\"",
            ),
        ],
    ),
];

fn check_errors(file: &str, got: &[DefError], want: &[(usize, usize, &str, &str)]) {
    let shown: Vec<String> = got.iter().map(|e| e.to_string()).collect();
    assert_eq!(
        got.len(),
        want.len(),
        "{file}: errors:\n{}",
        shown.join("\n")
    );
    for (e, &(line, column, path, msg)) in got.iter().zip(want) {
        assert_eq!((e.line, e.column), (line, column), "{file}: {e}");
        assert_eq!(e.path, path, "{file}: {e}");
        assert!(
            e.message.contains(msg),
            "{file}: {e}\n  expected to contain: {msg}"
        );
        // The one-line form: file:line:col: path: message.
        let prefix = if path.is_empty() {
            format!("{}:{line}:{column}: ", e.file)
        } else {
            format!("{}:{line}:{column}: {path}: ", e.file)
        };
        assert!(e.to_string().starts_with(&prefix), "{e}");
    }
}

#[test]
fn every_broken_file_gives_its_exact_errors() {
    let dir = root().join("tests/missions");
    let on_disk: Vec<String> = toml_files(&dir, "broken-")
        .iter()
        .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
        .collect();
    let mut listed: Vec<String> = BROKEN.iter().map(|(f, _)| f.to_string()).collect();
    listed.sort();
    assert_eq!(
        on_disk, listed,
        "every broken fixture has expectations, and vice versa"
    );
    for (file, want) in BROKEN {
        let path = dir.join(file);
        let e = load_mission(&path).expect_err(file);
        assert!(
            e.errors
                .iter()
                .all(|x| x.file == path.display().to_string())
        );
        check_errors(file, &e.errors, want);
    }
}

#[test]
fn crlf_line_endings_and_unicode_keep_positions_right() {
    let text = "name = \"élan ✈\"\r\nkind = \"runway-mapping\"\r\n[grid]\r\norigin = \"vehicle\"\r\ncell_size_m = -4\r\n";
    let e = MissionDef::parse(text, "crlf.toml").unwrap_err();
    let grid = e.errors.iter().find(|e| e.path == "flight").unwrap();
    assert_eq!(
        (grid.line, grid.column),
        (1, 1),
        "a missing top-level table: line 1"
    );
    let cs = e
        .errors
        .iter()
        .find(|e| e.path == "grid.cell_size_m")
        .unwrap();
    assert_eq!((cs.line, cs.column), (5, 15));
    // A value after multi-byte characters: the column counts characters.
    let text = "name = \"é\"\nkind = \"✈✈\"\n";
    let e = MissionDef::parse(text, "u.toml").unwrap_err();
    let k = e.errors.iter().find(|e| e.path == "kind").unwrap();
    assert_eq!((k.line, k.column), (2, 8));
    assert!(k.message.contains("found string \"✈✈\""), "{k}");
}

#[test]
fn unreadable_and_non_utf8_files_are_errors_not_panics() {
    let e = load_mission("/nonexistent/mission.toml").unwrap_err();
    assert!(e.to_string().contains("cannot read the file"), "{e}");
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("latin1.toml");
    std::fs::write(&p, b"name = \"ok\"\nkind = \"caf\xe9\"\n").unwrap();
    let e = load_mission(&p).unwrap_err();
    assert_eq!((e.errors[0].line, e.errors[0].column), (2, 12));
    assert!(e.to_string().contains("not UTF-8"), "{e}");
}

#[test]
fn an_empty_file_lists_every_missing_key() {
    let e = MissionDef::parse("", "empty.toml").unwrap_err();
    let paths: Vec<&str> = e.errors.iter().map(|e| e.path.as_str()).collect();
    assert_eq!(paths, ["name", "kind", "grid", "flight", "vehicles"]);
    assert!(e.errors.iter().all(|e| (e.line, e.column) == (1, 1)));
}

#[test]
fn wgs84_sweep_corners_are_accepted_and_checked() {
    let base = std::fs::read_to_string(root().join("missions/runway-field-test.toml")).unwrap();
    let corners = base.replace(
        "north_m = [-8.0, 32.0]         # [min, max] northward\neast_m = [-20.0, 20.0]         # [min, max] eastward",
        "south_west = { lat = 37.1965, lon = -80.5785 }\nnorth_east = { lat = 37.1970, lon = -80.5779 }",
    );
    assert_ne!(corners, base);
    let d = MissionDef::parse(&corners, "c.toml").unwrap();
    assert!(matches!(d.runway.unwrap().sweep, SweepBox::Corners { .. }));
    let swapped = corners.replace("lat = 37.1970", "lat = 37.1960");
    let e = MissionDef::parse(&swapped, "c.toml").unwrap_err();
    assert_eq!(e.errors.len(), 1, "{e}");
    assert_eq!(e.errors[0].path, "runway.sweep.north_east");
    assert!(
        e.errors[0].message.contains("north and east of south_west"),
        "{e}"
    );
    let both = base.replace(
        "east_m = [-20.0, 20.0]",
        "east_m = [-20.0, 20.0]\nsouth_west = { lat = 37.1965, lon = -80.5785 }",
    );
    let e = MissionDef::parse(&both, "c.toml").unwrap_err();
    assert!(e.errors[0].message.contains("not both"), "{e}");
}

// ---- never a panic ---------------------------------------------------------------------

fn assert_sane(
    text: &str,
    result: Result<MissionDef, fleetmap_core::mission::definition::DefErrors>,
) {
    if let Err(e) = result {
        assert!(!e.errors.is_empty());
        let lines = text.split('\n').count();
        for err in &e.errors {
            assert!(
                err.line >= 1 && err.line <= lines,
                "{err} (text has {lines} lines)"
            );
            assert!(err.column >= 1, "{err}");
            assert!(!err.message.is_empty());
        }
    }
}

fn example_texts() -> Vec<String> {
    toml_files(&root().join("missions"), "")
        .iter()
        .chain(toml_files(&root().join("tests/missions"), "broken-").iter())
        .map(|p| std::fs::read_to_string(p).unwrap())
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..400)) {
        let text = String::from_utf8_lossy(&bytes).into_owned();
        let r = MissionDef::parse(&text, "fuzz.toml");
        assert_sane(&text, r);
    }

    #[test]
    fn mutated_examples_never_panic(
        which in 0usize..64,
        edits in proptest::collection::vec((0usize..10_000, 0usize..12, 0u8..6, any::<char>()), 1..6),
    ) {
        let texts = example_texts();
        let mut text = texts[which % texts.len()].clone();
        for (at, len, op, ch) in edits {
            let mut at = at % (text.len() + 1);
            while !text.is_char_boundary(at) { at -= 1; }
            let mut end = (at + len).min(text.len());
            while !text.is_char_boundary(end) { end -= 1; }
            match op {
                0 => text.replace_range(at..end, ""),
                1 => text.insert(at, ch),
                2 => text.replace_range(at..end, &ch.to_string()),
                3 => { let piece = text[at..end].to_string(); text.insert_str(at, &piece) }
                4 => text.insert_str(at, ["=", "[", "]", "\"", "\n", "-1", "1e999", "[[vehicles]]\n", "nan", "{"][len % 10]),
                _ => {
                    // Swap two lines.
                    let mut lines: Vec<&str> = text.split('\n').collect();
                    let n = lines.len();
                    lines.swap(at % n, len % n);
                    text = lines.join("\n");
                }
            }
        }
        let r = MissionDef::parse(&text, "mutated.toml");
        assert_sane(&text, r);
    }
}

// ---- fleetmap check ----------------------------------------------------------------------

fn fleetmap(args: &[&str]) -> std::process::Output {
    common::fleetmap()
        .command()
        .args(args)
        .current_dir(root())
        .output()
        .expect("run fleetmap")
}

#[test]
fn check_prints_a_summary_and_exits_0() {
    let out = fleetmap(&["check", "missions/hardware-6x6.toml"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for needle in [
        "missions/hardware-6x6.toml: ok",
        "spatial-classification",
        "origin = 37.195000, -80.580000; 5 m cells; 6 x 6 cells",
        "4 drones (sysid 1, 2, 3, 4); 2 stations (sysid 5, 6)",
        "10 m above home",
        "11 obstacles; 11 road cells; 14 candidate cells (roads excluded)",
        "D=6 B=30 Td=8 Tc=4 K=4 C=2",
    ] {
        assert!(stdout.contains(needle), "missing {needle:?} in:\n{stdout}");
    }
    let out = fleetmap(&["check", "missions/runway-field-test.toml"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    for needle in [
        "runway-mapping",
        "origin = home of the first vehicle (sysid 1); 4 m cells; unbounded",
        "12 m above home; drones 1 m/s",
        "north -8 to 32 m, east -20 to 20 m from the origin (121 cells)",
        "5 images per cell, 3 votes, threshold 150, 7 dilations",
        "12 min",
    ] {
        assert!(stdout.contains(needle), "missing {needle:?} in:\n{stdout}");
    }
}

#[test]
fn check_prints_every_error_and_exits_1() {
    let out = fleetmap(&["check", "tests/missions/broken-out-of-range.toml"]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    let lines: Vec<&str> = stderr.lines().collect();
    assert_eq!(lines.len(), 7, "{stderr}");
    assert_eq!(
        lines[1],
        "tests/missions/broken-out-of-range.toml:7:15: grid.cell_size_m: expected a number > 0 \
         and ≤ 10000 (metres), found -4"
    );
    for l in &lines[..6] {
        assert!(
            l.starts_with("tests/missions/broken-out-of-range.toml:"),
            "{l}"
        );
    }
    assert_eq!(
        lines[6],
        "fleetmap: tests/missions/broken-out-of-range.toml: 6 errors"
    );
}

#[test]
fn check_json_prints_the_definition_or_the_errors() {
    let out = fleetmap(&["check", "--json", "missions/sim-10x10.toml"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["kind"], "spatial-classification");
    assert_eq!(v["vehicles"].as_array().unwrap().len(), 15);
    assert_eq!(v["vehicles"][14]["start"], serde_json::json!([8, 7]));
    assert_eq!(v["classification"]["epoch_goals"], 8);
    assert_eq!(v["area"]["obstacles"][0], serde_json::json!([2, 3]));
    let def: MissionDef = serde_json::from_value(v).unwrap();
    assert_eq!(def, load("missions/sim-10x10.toml"));

    let out = fleetmap(&["check", "--json", "tests/missions/broken-planner.toml"]);
    assert_eq!(out.status.code(), Some(1));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let errs = v["errors"].as_array().unwrap();
    assert_eq!(errs.len(), 4);
    assert_eq!(errs[1]["line"], 23);
    assert_eq!(errs[1]["column"], 9);
    assert_eq!(errs[1]["path"], "classification.theta");
}

#[test]
fn check_of_a_missing_file_exits_1_with_one_line() {
    let out = fleetmap(&["check", "missions/nope.toml"]);
    assert_eq!(out.status.code(), Some(1));
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.starts_with("missions/nope.toml: cannot read the file"),
        "{stderr}"
    );
}
