use super::*;
use crate::vision::runway::votes::Detection;

fn def(drones: usize) -> MissionDef {
    let mut text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../missions/runway-field-test.toml"
    ))
    .unwrap();
    for k in 2..=drones {
        text.push_str(&format!("\n[[vehicles]]\nsysid = {k}\nrole = \"drone\"\n"));
    }
    MissionDef::parse(&text, "test.toml").unwrap()
}

fn grid() -> Grid {
    Grid::new(
        LatLon {
            lat: 37.1965,
            lon: -80.5785,
        },
        4.0,
    )
    .unwrap()
}

fn det(sysid: u8, cell: Cell, k: u64, all: bool) -> Detection {
    Detection {
        image_id: format!("i{k}"),
        vehicle: sysid,
        time: Time::from_secs(k),
        cell,
        position: None,
        heading_deg: 0.0,
        fractions: RegionFractions::default(),
        labels: NeighbourLabels {
            center: true,
            north: all,
            west: false,
            south: false,
            east: false,
        },
    }
}

#[test]
fn sweep_detection_confirmation_and_dfs_to_the_end() {
    let mut s = MappingState::new(&def(1), grid(), Sharing::Gcs).unwrap();
    assert_eq!(s.directive(1).unwrap(), Directive::Sweep);
    assert!(!s.sweeps[0].items.is_empty());
    // A sweep image with the centre positive starts a confirmation of that cell.
    let c = Cell::new(3, 2);
    let labels = NeighbourLabels {
        center: true,
        ..NeighbourLabels::default()
    };
    let got = s
        .on_sweep_image(1, c, 0.0, RegionFractions::default(), labels, Time::ZERO)
        .unwrap();
    assert_eq!(got, Some(c));
    assert_eq!(s.directive(1).unwrap(), Directive::Confirm(c));
    assert_eq!(s.images_missing(1, c), 5);
    for k in 0..3 {
        s.on_cell_image(det(1, c, k, true)).unwrap();
    }
    assert_eq!(s.images_missing(1, c), 2);
    for k in 3..5 {
        s.on_cell_image(det(1, c, k, true)).unwrap();
    }
    assert_eq!(s.images_missing(1, c), 0);
    assert_eq!(s.on_confirmed(1, c, Time::from_secs(5)).unwrap(), Some(c));
    // DFS: rejoin the root, observe (north is positive), move north, observe, come back.
    assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::Rejoin(c)));
    s.on_arrived(1, c, Time::from_secs(6)).unwrap();
    assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::Observe));
    for k in 5..10 {
        s.on_cell_image(det(1, c, k, true)).unwrap();
    }
    let n = c.step(Dir4::North);
    assert_eq!(s.on_observed(1, c, Time::from_secs(10)).unwrap(), vec![n]);
    assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::MoveTo(n)));
    // battery swap in the middle: the vertex is kept
    s.on_battery_low(1, Time::from_secs(11)).unwrap();
    assert_eq!(s.directive(1).unwrap(), Directive::Swap);
    s.on_landed_for_swap(1, 0, Time::from_secs(12)).unwrap();
    s.on_swapped(1, Time::from_secs(13)).unwrap();
    assert_eq!(s.robot(1).unwrap().battery_swaps, 1);
    assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::Rejoin(c)));
    s.on_arrived(1, c, Time::from_secs(14)).unwrap();
    let next = s.directive(1).unwrap();
    assert_eq!(next, Directive::Dfs(Action::MoveTo(n)));
    s.on_arrived(1, n, Time::from_secs(15)).unwrap();
    assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::Observe));
    for k in 15..20 {
        s.on_cell_image(det(1, n, k, false)).unwrap();
    }
    assert!(s.on_observed(1, n, Time::from_secs(20)).unwrap().is_empty());
    // The map is complete: home from where it is, not back along the tree to the start.
    assert!(s.map_complete());
    assert_eq!(s.directive(1).unwrap(), Directive::GoHome);
    assert_eq!(
        s.explorer
            .as_ref()
            .unwrap()
            .robot(RobotId(1))
            .unwrap()
            .moves,
        1,
        "no move back to the start"
    );
    s.on_going_home(1, Time::from_secs(25)).unwrap();
    assert!(!s.is_finished());
    s.on_landed(1, Time::from_secs(40)).unwrap();
    assert!(s.is_finished());
    assert_eq!(
        s.phase,
        Phase::Finished {
            found: true,
            gave_up: None
        }
    );
    assert_eq!(s.book.positive_cells(), vec![c, n]);
    // the whole state survives a JSON round trip
    let back: MappingState = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
    assert_eq!(back.book, s.book);
    assert_eq!(back.phase, s.phase);
    assert!(s.explorer.is_some(), "the DFS ran");
    assert_eq!(
        back.explorer, s.explorer,
        "the DFS tree and the robots' places"
    );
    assert_eq!(back.robots, s.robots);
    assert_eq!(back.params, s.params);
}

#[test]
fn a_negative_confirmation_rejects_the_cell_and_sweeps_on() {
    let mut s = MappingState::new(&def(2), grid(), Sharing::Gcs).unwrap();
    let c = Cell::new(0, 0);
    let pos = NeighbourLabels {
        center: true,
        ..NeighbourLabels::default()
    };
    assert_eq!(
        s.on_sweep_image(2, c, 0.0, RegionFractions::default(), pos, Time::ZERO)
            .unwrap(),
        Some(c)
    );
    assert_eq!(s.directive(1).unwrap(), Directive::Hold);
    for k in 0..5 {
        let mut d = det(2, c, k, false);
        d.labels.center = false;
        s.on_cell_image(d).unwrap();
    }
    assert_eq!(s.on_confirmed(2, c, Time::from_secs(5)).unwrap(), None);
    assert_eq!(s.phase, Phase::Sweep);
    assert!(s.rejected.contains(&c));
    assert_eq!(s.directive(1).unwrap(), Directive::Sweep);
    // the same cell seen again does not start another confirmation
    assert_eq!(
        s.on_sweep_image(1, c, 0.0, RegionFractions::default(), pos, Time::ZERO)
            .unwrap(),
        None
    );
    s.on_sweep_complete(1, Time::from_secs(9)).unwrap();
    assert_eq!(s.phase, Phase::Sweep);
    s.on_sweep_complete(2, Time::from_secs(9)).unwrap();
    assert_eq!(
        s.phase,
        Phase::Finished {
            found: false,
            gave_up: None
        }
    );
    assert_eq!(s.directive(1).unwrap(), Directive::GoHome);
}

/// A camera fault takes the robot out like a battery swap, is saved with the state (a
/// resumed run reads it back) and only the operator's confirmation clears it.
#[test]
fn a_camera_fault_is_saved_and_cleared_by_the_operator() {
    let mut s = MappingState::new(&def(1), grid(), Sharing::Gcs).unwrap();
    let t = Time::from_secs(10);
    s.on_camera_fault(1, "pictures 300 m from their cell".into(), t)
        .unwrap();
    assert_eq!(s.robot(1).unwrap().status, RobotStatus::ReturningForSwap);
    let json = serde_json::to_string(&s).unwrap();
    let mut back: MappingState = serde_json::from_str(&json).unwrap();
    assert_eq!(
        back.robot(1).unwrap().camera_fault.as_deref(),
        Some("pictures 300 m from their cell")
    );
    back.on_landed_for_swap(1, 0, t).unwrap();
    back.on_swapped(1, t).unwrap();
    assert_eq!(back.robot(1).unwrap().camera_fault, None);
    // the camera was fixed: no battery swap is counted
    assert_eq!(back.robot(1).unwrap().battery_swaps, 0);
    // Runs saved before the field existed load without it.
    let old = json.replace(",\"camera_fault\":\"pictures 300 m from their cell\"", "");
    assert_ne!(old, json);
    let old: MappingState = serde_json::from_str(&old).unwrap();
    assert_eq!(old.robot(1).unwrap().camera_fault, None);
}

/// A camera that went silent is saved as such (a resumed run knows it may come back by
/// itself), a wrong-pictures fault is not, and the vehicle's return clears both without
/// counting a battery swap.
#[test]
fn a_silent_camera_is_saved_as_one_and_its_return_is_no_battery_swap() {
    let mut s = MappingState::new(&def(1), grid(), Sharing::Gcs).unwrap();
    let t = Time::from_secs(10);
    s.on_camera_silent(1, "6 captures unanswered".into(), t)
        .unwrap();
    assert_eq!(s.robot(1).unwrap().status, RobotStatus::ReturningForSwap);
    let json = serde_json::to_string(&s).unwrap();
    let mut back: MappingState = serde_json::from_str(&json).unwrap();
    let r = back.robot(1).unwrap();
    assert!(r.camera_silent);
    assert_eq!(r.camera_fault.as_deref(), Some("6 captures unanswered"));
    back.on_landed_for_swap(1, 0, t).unwrap();
    back.on_swapped(1, t).unwrap();
    let r = back.robot(1).unwrap();
    assert!(!r.camera_silent && r.camera_fault.is_none());
    assert_eq!(r.battery_swaps, 0);
    // a fault of wrong pictures is not a silent camera, nor one after it
    s.on_camera_fault(1, "pictures 300 m from their cell".into(), t)
        .unwrap();
    assert!(!s.robot(1).unwrap().camera_silent);
    // not written when false: earlier runs' files are unchanged
    assert!(!serde_json::to_string(&s).unwrap().contains("camera_silent"));
}

#[test]
fn battery_need_grows_with_distance() {
    let s = MappingState::new(&def(1), grid(), Sharing::Gcs).unwrap();
    let near = s.battery_needed_pct(0.0, 12.0);
    let far = s.battery_needed_pct(100.0, 12.0);
    // 12-minute battery: 100 m at 1 m/s is 100 s ≈ 13.9 %
    assert!((far - near - 100.0 * 100.0 / 720.0).abs() < 1e-9);
    assert!(near > s.params.rtl_reserve_pct);
}

#[test]
fn not_a_runway_mission() {
    let text = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../missions/hardware-6x6.toml"
    ))
    .unwrap();
    let d = MissionDef::parse(&text, "h.toml").unwrap();
    assert!(matches!(
        MappingState::new(&d, grid(), Sharing::Gcs),
        Err(MappingError::Mission(_))
    ));
}

/// The mission clock on a two-drone run: time before the first take-off, the shares of every
/// sample's interval, the milestones in the order of the mission, the interval up to the
/// last landing, and a JSON round trip (a resumed run keeps the figures; older states load).
#[test]
fn the_mission_clock_accounts_every_drone_from_the_first_take_off_to_the_last_landing() {
    let mut s = MappingState::new(&def(2), grid(), Sharing::Gcs).unwrap();
    let t = Time::from_secs_f64;
    let work = Activity::Working;
    s.restart_clock();
    s.sample_clock(t(0.0), &[(1, false, work), (2, false, work)]);
    s.sample_clock(t(1.0), &[(1, false, work), (2, false, work)]);
    assert!(!s.clock.took_off);
    // Drone 1 leaves the ground: the clock starts.
    s.sample_clock(t(2.0), &[(1, true, work), (2, false, work)]);
    assert!(s.clock.took_off);
    assert_eq!(s.clock.before_takeoff_s, 2.0);
    s.sample_clock(t(3.0), &[(1, true, work), (2, false, work)]);
    s.sample_clock(t(4.0), &[(1, true, work), (2, true, work)]);
    assert_eq!(s.robot(2).unwrap().times.ground_before_s, 1.0);
    // Drone 2 sees the region; drone 1 holds while 2 confirms.
    let c = Cell::new(3, 2);
    let pos = NeighbourLabels {
        center: true,
        ..NeighbourLabels::default()
    };
    s.on_sweep_image(2, c, 0.0, RegionFractions::default(), pos, t(4.5))
        .unwrap();
    assert_eq!(s.directive(1).unwrap(), Directive::Hold);
    let held = Activity::Waiting(Wait::Confirmation);
    s.sample_clock(t(6.0), &[(1, true, held), (2, true, Activity::Imaging)]);
    for k in 0..5 {
        s.on_cell_image(det(2, c, k, false)).unwrap();
    }
    assert_eq!(s.on_confirmed(2, c, t(6.5)).unwrap(), Some(c));
    assert_eq!(s.clock.dfs_start_s, Some(4.5));
    // Both fly to the root; 1 images it while 2 waits; nothing around it is runway.
    s.directive(1).unwrap();
    s.directive(2).unwrap();
    s.on_arrived(1, c, t(7.0)).unwrap();
    s.on_arrived(2, c, t(7.0)).unwrap();
    assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::Observe));
    assert_eq!(s.directive(2).unwrap(), Directive::Dfs(Action::Wait));
    let start = Activity::Waiting(Wait::DfsStart);
    s.sample_clock(t(8.0), &[(1, true, Activity::Imaging), (2, true, start)]);
    assert!(!s.map_complete());
    for k in 5..10 {
        s.on_cell_image(det(1, c, k, false)).unwrap();
    }
    s.on_observed(1, c, t(8.25)).unwrap();
    assert!(s.map_complete());
    assert_eq!(s.clock.map_complete_s, Some(6.25));
    assert_eq!(s.directive(1).unwrap(), Directive::GoHome);
    assert_eq!(s.directive(2).unwrap(), Directive::GoHome);
    s.on_going_home(1, t(8.5)).unwrap();
    s.on_going_home(2, t(8.5)).unwrap();
    s.sample_clock(t(9.0), &[(1, true, work), (2, true, work)]);
    s.on_landed(1, t(9.5)).unwrap();
    s.sample_clock(t(10.0), &[(1, false, work), (2, true, work)]);
    assert_eq!(s.clock.last_landing_s, None);
    s.on_landed(2, t(10.4)).unwrap();
    assert!(s.is_finished());
    let end = s.clock.last_landing_s.unwrap();
    assert!((end - 8.4).abs() < 1e-9, "{end}");
    // After the last landing nothing counts.
    s.sample_clock(t(20.0), &[(1, false, work), (2, false, work)]);
    assert!((s.clock.elapsed_s - end).abs() < 1e-9);
    for r in &s.robots {
        let sum = r.times.accounted_s();
        assert!(
            (sum - end).abs() < 1e-9,
            "vehicle {}: {sum} of {end}",
            r.sysid
        );
    }
    let (one, two) = (&s.robot(1).unwrap().times, &s.robot(2).unwrap().times);
    assert!((one.waiting.confirmation_s - 2.0).abs() < 1e-9);
    assert!((one.imaging_s - 2.0).abs() < 1e-9);
    assert!((one.ground_done_s - 1.4).abs() < 1e-9, "{one:?}");
    assert!((two.waiting.dfs_start_s - 2.0).abs() < 1e-9);
    assert!((two.imaging_s - 2.0).abs() < 1e-9);
    assert!((two.ground_before_s - 1.0).abs() < 1e-9);
    // The milestones, in order, once each.
    let got: Vec<MilestoneKind> = s.take_milestones().iter().map(|m| m.what).collect();
    assert_eq!(
        got,
        [
            MilestoneKind::FirstTakeoff,
            MilestoneKind::DfsStart,
            MilestoneKind::MapComplete,
            MilestoneKind::LastLanding
        ]
    );
    assert!(s.take_milestones().is_empty());
    // Saved and read back: the same figures (a resumed run carries on from them).
    let json = serde_json::to_string(&s).unwrap();
    let mut back: MappingState = serde_json::from_str(&json).unwrap();
    assert_eq!(back.clock, s.clock);
    assert_eq!(back.robots, s.robots);
    back.restart_clock();
    assert_eq!((back.clock.starts, back.clock.sampled_at), (2, None));
    // A state saved before the clock existed loads with an empty one.
    let mut v: serde_json::Value = serde_json::from_str(&json).unwrap();
    v.as_object_mut().unwrap().remove("clock");
    for r in v["robots"].as_array_mut().unwrap() {
        r.as_object_mut().unwrap().remove("times");
    }
    let old: MappingState = serde_json::from_value(v).unwrap();
    assert_eq!(old.clock, MissionClock::default());
    assert_eq!(old.robot(1).unwrap().times, RobotTimes::default());
}

#[test]
fn beyond_reach_finishes_the_run_with_its_reason_and_labels_nothing() {
    // Two drones in the DFS; drone 2 is over a cell with two of its five pictures when drone 1's
    // next flight is judged beyond reach.
    let mut s = MappingState::new(&def(2), grid(), Sharing::Gcs).unwrap();
    s.params.roi_velocity_ne_mps = Some([0.0, 3.0]); // east at 3 m/s, drones at 1 m/s
    let c = Cell::new(3, 2);
    let pos = NeighbourLabels {
        center: true,
        ..NeighbourLabels::default()
    };
    s.on_sweep_image(1, c, 0.0, RegionFractions::default(), pos, Time::ZERO)
        .unwrap();
    for k in 0..5 {
        s.on_cell_image(det(1, c, k, true)).unwrap();
    }
    assert_eq!(s.on_confirmed(1, c, Time::from_secs(5)).unwrap(), Some(c));
    let n = c.step(Dir4::North);
    let undecided = Cell::new(9, 9);
    for k in 5..7 {
        let mut d = det(2, undecided, k, false);
        d.labels.center = true; // two votes for: not yet settled either way
        s.on_cell_image(d).unwrap();
    }
    assert_eq!(s.book.state(undecided), CellState::Unknown);
    assert_eq!(s.robot(2).unwrap().visit, Some((undecided, 2)));
    let decisions = s.book.decisions().len();
    // The reach rule says so: outpaced, whatever the charge.
    let verdict = s
        .reach_of(
            1,
            n,
            (0.0, 0.0),
            (0.0, 0.0),
            100.0,
            10.0,
            Time::from_secs(8),
        )
        .unwrap();
    let Reach::BeyondReach(why) = verdict else {
        panic!("{verdict:?}")
    };
    assert!(matches!(why, Unreachable::Outpaced { .. }));
    s.on_beyond_reach(1, n, why, Time::from_secs(8)).unwrap();
    assert_eq!(s.phase.finish_reason(), Some(FinishReason::BeyondReach));
    assert!(
        s.phase
            .to_string()
            .starts_with("finished: beyond reach (vehicle 1")
    );
    // Nothing labelled by giving up: the open visit was dropped, not closed.
    assert_eq!(s.book.decisions().len(), decisions);
    assert_eq!(s.book.state(undecided), CellState::Unknown);
    assert_eq!(s.book.open_visit(2), None);
    assert_eq!(s.robot(2).unwrap().visit, None);
    // A picture still arriving counts for nothing.
    let mut late = det(2, undecided, 7, false);
    late.labels.center = true;
    assert!(s.on_cell_image(late).unwrap().is_empty());
    assert_eq!(s.book.state(undecided), CellState::Unknown);
    // The map is not complete; everyone goes home, and then the run is finished.
    assert!(!s.map_complete());
    assert_eq!(s.directive(1).unwrap(), Directive::GoHome);
    assert_eq!(s.directive(2).unwrap(), Directive::GoHome);
    for sysid in [1, 2] {
        s.on_going_home(sysid, Time::from_secs(9)).unwrap();
        s.on_landed(sysid, Time::from_secs(30)).unwrap();
    }
    assert!(s.is_finished());
    assert_eq!(s.clock.map_complete_s, None);
    // Saved and read back (a resumed run keeps it), and giving up again changes nothing.
    let mut back: MappingState = serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
    assert_eq!(back.phase, s.phase);
    back.on_beyond_reach(2, c, why, Time::from_secs(40))
        .unwrap();
    assert_eq!(back.phase, s.phase);
    // A state saved before the reason existed reads as an ordinary end.
    let old: Phase = serde_json::from_str(r#"{"phase":"finished","found":true}"#).unwrap();
    assert_eq!(old.finish_reason(), Some(FinishReason::Mapped));
}

#[test]
fn once_the_map_is_complete_an_unreachable_flight_sends_the_drone_home_instead() {
    let mut s = MappingState::new(&def(1), grid(), Sharing::Gcs).unwrap();
    s.params.roi_velocity_ne_mps = Some([0.0, 3.0]);
    let c = Cell::new(0, 0);
    let pos = NeighbourLabels {
        center: true,
        ..NeighbourLabels::default()
    };
    s.on_sweep_image(1, c, 0.0, RegionFractions::default(), pos, Time::ZERO)
        .unwrap();
    for k in 0..5 {
        let mut d = det(1, c, k, false);
        d.labels.center = true;
        s.on_cell_image(d).unwrap();
    }
    s.on_confirmed(1, c, Time::from_secs(5)).unwrap();
    assert!(!s.map_complete());
    let v = s
        .reach_of(1, c, (0.0, 0.0), (0.0, 0.0), 100.0, 0.0, Time::from_secs(6))
        .unwrap();
    assert!(matches!(v, Reach::BeyondReach(_)), "{v:?}");
    s.on_arrived(1, c, Time::from_secs(6)).unwrap();
    for k in 6..11 {
        let mut d = det(1, c, k, false);
        d.labels.center = true;
        s.on_cell_image(d).unwrap();
    }
    s.on_observed(1, c, Time::from_secs(11)).unwrap();
    assert!(s.map_complete());
    let v = s
        .reach_of(
            1,
            c,
            (0.0, 0.0),
            (0.0, 0.0),
            100.0,
            0.0,
            Time::from_secs(12),
        )
        .unwrap();
    assert!(matches!(v, Reach::SwapFirst { .. }), "{v:?}");
}

/// Start the DFS at `c` with every drone of `s` (confirmed by drone 1, nothing positive
/// around it in the confirmation's pictures).
fn start_dfs(s: &mut MappingState, c: Cell) {
    let pos = NeighbourLabels {
        center: true,
        ..NeighbourLabels::default()
    };
    s.on_sweep_image(1, c, 0.0, RegionFractions::default(), pos, Time::ZERO)
        .unwrap();
    for k in 0..5 {
        s.on_cell_image(det(1, c, 1000 + k, false)).unwrap();
    }
    assert_eq!(s.on_confirmed(1, c, Time::from_secs(1)).unwrap(), Some(c));
}

/// Home when the map is done: two drones walk north together from the start; once the last
/// vertex (two cells out) is imaged, both are told to fly home from where they are — no
/// move back along the tree — and the run finishes when both have landed.
#[test]
fn once_the_map_is_complete_every_drone_flies_home_from_where_it_is() {
    let mut s = MappingState::new(&def(2), grid(), Sharing::Gcs).unwrap();
    let c = Cell::new(3, 2);
    start_dfs(&mut s, c);
    let n = c.step(Dir4::North);
    let nn = n.step(Dir4::North);
    for id in [1, 2] {
        assert_eq!(s.directive(id).unwrap(), Directive::Dfs(Action::Rejoin(c)));
        s.on_arrived(id, c, Time::from_secs(2)).unwrap();
    }
    let mut k = 0;
    // Image `at` with drone 1 (north positive or not), drone 2 waiting beside it.
    let mut image = |s: &mut MappingState, at: Cell, north: bool| {
        assert_eq!(s.directive(1).unwrap(), Directive::Dfs(Action::Observe));
        assert_eq!(s.directive(2).unwrap(), Directive::Dfs(Action::Wait));
        for _ in 0..5 {
            s.on_cell_image(det(1, at, k, north)).unwrap();
            k += 1;
        }
        s.on_observed(1, at, Time::from_secs(3 + k)).unwrap();
    };
    image(&mut s, c, true);
    for to in [n, nn] {
        assert!(!s.map_complete());
        for id in [1, 2] {
            assert_eq!(s.directive(id).unwrap(), Directive::Dfs(Action::MoveTo(to)));
        }
        for id in [1, 2] {
            s.on_arrived(id, to, Time::from_secs(30)).unwrap();
        }
        image(&mut s, to, to == n);
    }
    assert!(s.map_complete());
    assert!(s.clock.map_complete_s.is_some());
    for id in [1, 2] {
        assert_eq!(s.directive(id).unwrap(), Directive::GoHome, "vehicle {id}");
        let ex = s.explorer.as_ref().unwrap();
        let r = ex.robot(RobotId(id)).unwrap();
        assert_eq!(r.moves, 2, "vehicle {id}: no move back towards the start");
        assert_eq!(r.phase, crate::explore::dfs::Phase::Done);
    }
    assert!(s.explorer.as_ref().unwrap().is_finished());
    for id in [1, 2] {
        s.on_going_home(id, Time::from_secs(60)).unwrap();
        assert_eq!(s.directive(id).unwrap(), Directive::GoHome);
    }
    s.on_landed(1, Time::from_secs(80)).unwrap();
    assert!(!s.is_finished());
    s.on_landed(2, Time::from_secs(81)).unwrap();
    assert!(s.is_finished());
    assert_eq!(s.book.positive_cells(), vec![c, n, nn]);
}
