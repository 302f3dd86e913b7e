//! The live adapter (`fleetmap::tui::live`): a runway-mapping run's state and fleet snapshots
//! as the operator sees them — snapshots of the map, mission, fleet and log panes at 80×24 and
//! 250×70 from a state built by the run's own state machine.

use fleetmap::app::kind::RunKind;
use fleetmap::fleet::{FleetSnapshot, GeoPoint, StatusText, VehicleSnapshot};
use fleetmap::kinds::bandit::Classification;
use fleetmap::kinds::runway::Runway;
use fleetmap::panes::*;
use fleetmap::tui::live::{LiveLog, build_model};
use fleetmap::tui::*;
use fleetmap_core::explore::dfs::Sharing;
use fleetmap_core::explore::mapping::MappingState;
use fleetmap_core::geo::{Cell, Dir4, Grid, LatLon};
use fleetmap_core::mission::definition::{MissionDef, Role};
use fleetmap_core::proto::heartbeat::Beat;
use fleetmap_core::proto::severity::Severity;
use fleetmap_core::time::Time;
use fleetmap_core::vision::regions::RegionFractions;
use fleetmap_core::vision::runway::NeighbourLabels;
use fleetmap_core::vision::runway::votes::Detection;
use ratatui::Terminal;
use ratatui::backend::TestBackend;

fn mission(drones: usize) -> MissionDef {
    let mut text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/missions/runway-field-test.toml"
    ))
    .unwrap();
    for k in 2..=drones {
        text.push_str(&format!("\n[[vehicles]]\nsysid = {k}\nrole = \"drone\"\n"));
    }
    MissionDef::parse(&text, "runway-field-test.toml").unwrap()
}

fn labels(c: bool, n: bool, w: bool, s: bool, e: bool) -> NeighbourLabels {
    NeighbourLabels {
        center: c,
        north: n,
        west: w,
        south: s,
        east: e,
    }
}

/// A run in its DFS: found the runway at (5, 2), explored a few vertices.
fn run_state() -> MappingState {
    let grid = Grid::new(
        LatLon {
            lat: 37.1965,
            lon: -80.5785,
        },
        4.0,
    )
    .unwrap();
    let mut s = MappingState::new(&mission(2), grid, Sharing::Gcs).unwrap();
    let mut t = 0u64;
    let mut visit = |s: &mut MappingState, sysid: u8, cell: Cell, l: NeighbourLabels| {
        for _ in 0..5 {
            t += 1;
            s.on_cell_image(Detection {
                image_id: format!("i{t}"),
                vehicle: sysid,
                time: Time::from_secs(t),
                cell,
                position: None,
                heading_deg: 0.0,
                fractions: RegionFractions::default(),
                labels: l,
            })
            .unwrap();
        }
    };
    let root = Cell::new(5, 2);
    s.directive(1).unwrap();
    s.directive(2).unwrap();
    s.on_sweep_image(
        2,
        root,
        0.0,
        RegionFractions::default(),
        labels(true, false, false, false, false),
        Time::from_secs(60),
    )
    .unwrap();
    visit(&mut s, 2, root, labels(true, true, false, false, true));
    s.on_confirmed(2, root, Time::from_secs(90)).unwrap();
    for id in [1, 2] {
        s.directive(id).unwrap();
        s.on_arrived(id, root, Time::from_secs(100)).unwrap();
    }
    s.directive(1).unwrap();
    s.directive(2).unwrap();
    visit(&mut s, 1, root, labels(true, true, false, false, true));
    s.on_observed(1, root, Time::from_secs(110)).unwrap();
    // both children: the group splits
    let d1 = s.directive(1).unwrap();
    let d2 = s.directive(2).unwrap();
    for (id, d) in [(1, d1), (2, d2)] {
        if let fleetmap_core::explore::mapping::Directive::Dfs(
            fleetmap_core::explore::dfs::Action::MoveTo(c),
        ) = d
        {
            s.on_arrived(id, c, Time::from_secs(120)).unwrap();
        }
    }
    let north = root.step(Dir4::North);
    s.directive(1).unwrap();
    visit(&mut s, 1, north, labels(true, false, true, false, false));
    s.on_observed(1, north, Time::from_secs(130)).unwrap();
    for (id, track) in [
        (1u8, [[8.0, 20.0], [8.0, 24.0]]),
        (2, [[8.0, 20.0], [12.0, 20.0]]),
    ] {
        for p in track {
            s.on_position(id, p[0], p[1], 10.0).unwrap();
        }
    }
    s
}

fn fleet(s: &MappingState) -> FleetSnapshot {
    let mut f = FleetSnapshot {
        time: Time::from_secs(135),
        ..FleetSnapshot::default()
    };
    for (id, cell, pct) in [(1u8, Cell::new(6, 2), 71i8), (2, Cell::new(5, 3), 18)] {
        let beat = Beat {
            custom_mode: 4,
            mav_type: 2,
            autopilot: 3,
            base_mode: 0x80,
            system_status: 4,
        };
        let mut v = VehicleSnapshot::new(id, 1, &beat, 0, Time::from_secs(135));
        let p = s.grid.cell_center(cell);
        v.position = Some(GeoPoint {
            lat: p.lat,
            lon: p.lon,
            alt_amsl: 612.0,
        });
        v.alt_rel = Some(12.0);
        v.groundspeed = Some(0.1);
        v.gps_fix = Some(3);
        v.satellites = Some(14);
        v.battery_pct = Some(pct);
        v.battery_v = Some(if pct > 20 { 15.6 } else { 14.3 });
        v.mission_current = Some(4);
        v.mission_total = Some(26);
        f.vehicles.insert(id, v);
    }
    f
}

fn app(w: u16, h: u16) -> App {
    let s = run_state();
    let f = fleet(&s);
    let mut log = LiveLog::default();
    log.push(
        Time::from_secs(60),
        Severity::Notice,
        Some(2),
        "vehicle 2: runway seen near cell (5, 2): stopping the sweep to confirm it",
    );
    log.push(
        Time::from_secs(90),
        Severity::Info,
        Some(2),
        "vehicle 2: cell (5, 2) confirmed: the recursive DFS starts at (5, 2)",
    );
    let mut fs = f.clone();
    if let Some(v) = fs.vehicles.get_mut(&2) {
        v.last_text = Some(StatusText {
            severity: Severity::Warning,
            text: "Battery 1 is low 14.30V".into(),
            at: Time::from_secs(132),
        });
    }
    log.absorb(&fs);
    let info = RunInfo {
        name: "runway-field-test".into(),
        started: true,
        paused: false,
        failed: None,
    };
    let model = build_model(&fs, Some(Runway::panes(&s, &info)), &log);
    let mut app = App::new(
        UiConfig::default(),
        Source::new(SourceKind::Live, "LIVE udpout:127.0.0.1:14560"),
    );
    update(&mut app, Event::Resize(w, h));
    update(&mut app, Event::Tick(model.time));
    update(&mut app, Event::Snapshot(Box::new(model)));
    app
}

fn screen(app: &App, w: u16, h: u16) -> String {
    let mut t = Terminal::new(TestBackend::new(w, h)).unwrap();
    t.draw(|f| view::render(app, f)).unwrap();
    let buf = t.backend().buffer();
    (0..h)
        .map(|y| {
            (0..w)
                .map(|x| buf[(x, y)].symbol().to_string())
                .collect::<String>()
                .trim_end()
                .to_string()
        })
        .collect::<Vec<_>>()
        .join("\n")
}

#[test]
fn live_runway_run_at_250x70_shows_every_pane() {
    let app = app(250, 70);
    let s = screen(&app, 250, 70);
    for needle in [
        "DFS",
        "RUNNING",
        "runway-field-test",
        "confirmed",
        "Battery 1 is low",
        "18%",
    ] {
        assert!(s.contains(needle), "{needle:?} missing:\n{s}");
    }
    insta::assert_snapshot!("live_250x70", s);
}

#[test]
fn live_runway_run_at_80x24_every_lower_pane() {
    let mut app = app(80, 24);
    // Tab from the fleet table to the map, then on to the mission and the log.
    update(
        &mut app,
        Event::Key(Key::plain(crossterm::event::KeyCode::Tab).to_event()),
    );
    for tag in ["map", "mission", "log"] {
        let s = screen(&app, 80, 24);
        insta::assert_snapshot!(format!("live_80x24_{tag}"), s);
        // Tab moves the focus (and the lower pane) on
        update(
            &mut app,
            Event::Key(Key::plain(crossterm::event::KeyCode::Tab).to_event()),
        );
    }
}

#[test]
fn model_follows_the_run() {
    let s = run_state();
    let f = fleet(&s);
    let info = RunInfo {
        name: "runway".into(),
        started: true,
        ..RunInfo::default()
    };
    let m = build_model(&f, Some(Runway::panes(&s, &info)), &LiveLog::default());
    assert_eq!(m.mission.phase, Phase::Dfs);
    assert_eq!(m.mission.status, RunStatus::Running);
    let root = Cell::new(5, 2);
    assert_eq!(m.map.get(root), Some(CellState::UnderExploration));
    let north = root.step(Dir4::North);
    // imaged, but its west neighbour (a new child) is not visited yet
    assert_eq!(m.map.get(north), Some(CellState::UnderExploration));
    assert_eq!(
        m.map.get(north.step(Dir4::West)),
        Some(CellState::PositiveUnexplored)
    );
    assert_eq!(m.map.get(root.step(Dir4::West)), Some(CellState::Negative));
    assert_eq!(m.map.get(Cell::new(0, 0)), Some(CellState::Unknown));
    assert_eq!(m.mission.dfs.map(|d| d.unexplored), Some(1));
    assert_eq!(m.vehicles.len(), 2);
    assert_eq!(m.vehicles[0].cell, Some(Cell::new(6, 2)));
    assert_eq!(m.vehicles[1].battery.remaining_pct, Some(18));
    let paused = RunInfo {
        paused: true,
        ..info
    };
    assert_eq!(
        build_model(&f, Some(Runway::panes(&s, &paused)), &LiveLog::default())
            .mission
            .status,
        RunStatus::Paused
    );
}

// ---- spatial classification ------------------------------------------------------------

/// The hardware 6×6 mission after some sensing: (0, 0) kept, (5, 5) rejected.
fn classification_state() -> fleetmap_core::planner::sortie::ClassificationState {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/missions/hardware-6x6.toml"
    ))
    .unwrap();
    let def = MissionDef::parse(&text, "hardware-6x6.toml").unwrap();
    let fleetmap_core::mission::definition::Origin::Coordinates(origin) = def.grid.origin else {
        panic!("the hardware mission has a fixed origin");
    };
    let grid = Grid::new(LatLon::new(origin.lat, origin.lon), def.grid.cell_size_m).unwrap();
    let mut s = fleetmap_core::planner::sortie::ClassificationState::new(&def, grid, None).unwrap();
    for (cell, ones) in [(Cell::new(0, 0), 200), (Cell::new(5, 5), 0)] {
        let l = s.bandit.index_of(cell).unwrap();
        assert!(s.bandit.record(l, ones, 200));
    }
    assert_eq!(s.bandit.classify().len(), 2);
    s.measurements = 400;
    s
}

fn classification_fleet(s: &fleetmap_core::planner::sortie::ClassificationState) -> FleetSnapshot {
    let mut f = FleetSnapshot {
        time: Time::from_secs(600),
        ..FleetSnapshot::default()
    };
    let team: Vec<(u8, Cell, u8)> = s
        .drones
        .iter()
        .zip(&s.config.drones)
        .map(|(m, c)| (m.sysid, *c, 2))
        .chain(
            s.stations
                .iter()
                .zip(&s.config.stations)
                .map(|(m, c)| (m.sysid, *c, 10)),
        )
        .collect();
    for (id, cell, mav_type) in team {
        let beat = Beat {
            custom_mode: 0,
            mav_type,
            autopilot: 3,
            base_mode: 0,
            system_status: 3,
        };
        let mut v = VehicleSnapshot::new(id, 1, &beat, 0, Time::from_secs(600));
        let p = s.grid.cell_center(cell);
        v.position = Some(GeoPoint {
            lat: p.lat,
            lon: p.lon,
            alt_amsl: 600.0,
        });
        v.alt_rel = Some(0.0);
        v.gps_fix = Some(3);
        v.satellites = Some(12);
        v.battery_pct = Some(64);
        v.battery_v = Some(15.9);
        f.vehicles.insert(id, v);
    }
    f
}

#[test]
fn live_classification_run_shows_labels_obstacles_roads_and_the_team() {
    let s = classification_state();
    let f = classification_fleet(&s);
    let info = RunInfo {
        name: s.mission.clone(),
        started: true,
        ..RunInfo::default()
    };
    let m = build_model(
        &f,
        Some(Classification::panes(&s, &info)),
        &LiveLog::default(),
    );
    assert_eq!(m.map.kind, Classification::LOOK.map);
    assert_eq!((m.map.rows, m.map.cols), (6, 6));
    assert_eq!(m.map.get(Cell::new(0, 0)), Some(CellState::Keep));
    assert_eq!(m.map.get(Cell::new(5, 5)), Some(CellState::Reject));
    for &o in &s.layout.obstacles {
        assert_eq!(m.map.get(o), Some(CellState::Obstacle), "{o}");
    }
    let roads = s
        .layout
        .roads
        .iter()
        .filter(|&&c| m.map.get(c) == Some(CellState::Road))
        .count();
    assert!(roads > 0);
    assert_eq!(
        m.mission.kind,
        Some(MissionKind::new("spatial classification", true))
    );
    assert_eq!(m.mission.phase, Phase::Epoch { p: 1 });
    assert_eq!(m.mission.cells_classified, 2);
    assert_eq!(m.mission.cells_total, Some(s.bandit.len() as u32));
    // drones first, then the stations, each with what it is doing
    let ids: Vec<u8> = m.vehicles.iter().map(|v| v.sysid).collect();
    assert_eq!(ids, [1, 2, 3, 4, 5, 6]);
    assert_eq!(m.vehicles[4].role, Role::Station);
    assert_eq!(m.vehicles[0].activity.as_deref(), Some("charging (3, 1)"));
    assert_eq!(m.vehicles[5].activity.as_deref(), Some("station (3, 4)"));

    let mut app = App::new(
        UiConfig::default(),
        Source::new(SourceKind::Demo, "DEMO (simulated)"),
    );
    for (w, h) in [(250u16, 70u16), (80, 24)] {
        update(&mut app, Event::Resize(w, h));
        update(&mut app, Event::Tick(m.time));
        update(&mut app, Event::Snapshot(Box::new(m.clone())));
        if w == 80 {
            // the map pane below the fleet table
            update(
                &mut app,
                Event::Key(Key::plain(crossterm::event::KeyCode::Tab).to_event()),
            );
        }
        let text = screen(&app, w, h);
        assert!(text.contains("epoch 1"), "{text}");
        insta::assert_snapshot!(format!("live_classification_{w}x{h}"), text);
    }
}
