use super::missions::{AreaRules, check_mission};
use super::*;
use crate::geo::LatLon;
use crate::planner::bandit::ConfidenceBound;
use crate::planner::ip::{PlanOptions, PlanStatus, solve_instance};

const HARDWARE: &str = include_str!("../../../../../missions/hardware-6x6.toml");

/// The green tiles of the hardware field (assets/worlds/hardware-6x6.toml), mission cells.
fn green() -> BTreeSet<Cell> {
    [(5, 0), (4, 4), (2, 5), (1, 2)]
        .iter()
        .map(|&(r, c)| Cell::new(r, c))
        .collect()
}

fn state(text: &str, lock_step: Option<bool>) -> ClassificationState {
    let def = MissionDef::parse(text, "hardware-6x6.toml").unwrap();
    let grid = GeoGrid::new(LatLon::new(37.195, -80.58), 5.0).unwrap();
    ClassificationState::new(&def, grid, lock_step).unwrap()
}

fn plan(s: &mut ClassificationState) {
    let mut k = s.params.k_max;
    loop {
        let inst = s.instance(k).unwrap();
        let out = solve_instance(&inst, &PlanOptions::default(), &|| 0.0);
        match (out.status, &out.plan) {
            (PlanStatus::Optimal, Some(p)) => {
                crate::planner::check::check_plan(&inst, p).unwrap();
                s.accept_plan(p, out.solve_seconds).unwrap();
                return;
            }
            (PlanStatus::Infeasible, _) if k < MAX_K => {
                s.note_solve(out.solve_seconds);
                k *= 2;
            }
            other => panic!("no plan: {other:?}"),
        }
    }
}

/// The hardware mission with its first epoch planned and its first sortie started.
fn first_sortie_started() -> ClassificationState {
    let mut s = state(HARDWARE, None);
    s.begin_epoch().unwrap();
    plan(&mut s);
    s.prepare_cycle().unwrap();
    s.on_verified().unwrap();
    s.on_started().unwrap();
    s
}

/// Fly the prepared sortie in the model: every capture gets its B images (positive on the
/// green tiles), every vehicle reaches its last step.
fn fly(s: &mut ClassificationState, key: &mut i32) {
    s.on_verified().unwrap();
    s.on_started().unwrap();
    let c = s.cycle().unwrap().clone();
    let drones = AreaRules {
        rows: 6,
        cols: 6,
        obstacles: &s.layout.obstacles,
        roads: None,
    };
    let stations = AreaRules {
        roads: Some(&s.layout.roads),
        ..drones.clone()
    };
    for d in &c.drones {
        check_mission(&s.grid, &drones, d.path[0], &d.items).unwrap();
    }
    for st in &c.stations {
        check_mission(&s.grid, &stations, st.path[0], &st.items).unwrap();
    }
    let green = green();
    let sz = s.grid.cell_size();
    for d in &c.drones {
        for v in &d.captures {
            for _ in 0..s.params.batch {
                let (e, n) = (f64::from(v.cell.col) * sz, f64::from(v.cell.row) * sz + 0.4);
                let (visit, cell) = s.match_image(d.sysid, e, n).unwrap();
                assert_eq!(cell, v.cell);
                *key += 1;
                let pos = green.contains(&cell);
                s.record(
                    d.sysid,
                    visit,
                    (d.sysid, 0, *key),
                    if pos { 0.9 } else { 0.0 },
                    pos,
                )
                .unwrap();
            }
            // the visit is full: a further image is refused
            let (e, n) = (f64::from(v.cell.col) * sz, f64::from(v.cell.row) * sz);
            if d.captures.iter().filter(|w| w.cell == v.cell).count() == 1 {
                assert!(
                    s.match_image(d.sysid, e, n)
                        .unwrap_err()
                        .to_string()
                        .contains("already has")
                );
            }
        }
    }
    for d in &c.drones {
        let all: Vec<u16> = (0..d.items.len() as u16).collect();
        s.on_drone_progress(d.sysid, &all).unwrap();
        s.on_landed(d.sysid).unwrap();
    }
    for st in &c.stations {
        s.on_station_progress(st.sysid, &[], true).unwrap();
    }
    assert!(s.cycle().unwrap().complete());
}

/// Algorithm 1 on the hardware field with the given confidence bound, to the end.
fn hardware_field_run(bound: Option<ConfidenceBound>) -> ClassificationState {
    let mut s = state(HARDWARE, None);
    if let Some(b) = bound {
        s.bandit.bound = b;
    }
    assert_eq!(s.params.separation, Separation::Altitude);
    assert_eq!(
        s.bandit.len(),
        14,
        "the paper's 14 candidate cells (R excluded)"
    );
    let mut key = 0;
    let mut epochs = 0;
    while s.next() != Next::Finished {
        match s.next() {
            Next::BeginEpoch => {
                assert_eq!(
                    s.begin_epoch().unwrap().len(),
                    6.min(s.bandit.unclassified().len())
                );
                epochs += 1;
            }
            Next::Plan => plan(&mut s),
            Next::Prepare => {
                s.prepare_cycle().unwrap();
                fly(&mut s, &mut key);
                let end = s.cycle().unwrap().planned_end();
                s.finish_cycle(end, false).unwrap();
            }
            other => panic!("unexpected {other:?}"),
        }
        assert!(epochs < 40, "Algorithm 1 did not terminate");
        // the state survives a JSON round trip at every step
        let back: ClassificationState =
            serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
        assert_eq!(back, s);
    }
    let keep: BTreeSet<Cell> = s.bandit.keep().into_iter().collect();
    assert_eq!(keep, green());
    assert_eq!(s.bandit.reject().len(), 10);
    assert_eq!(s.epochs.len(), epochs);
    let total: u64 = s.epochs.iter().map(|e| e.measurements).sum();
    assert_eq!(total, s.measurements);
    assert_eq!(s.bandit.samples.iter().sum::<u64>(), s.measurements);
    assert!(s.epochs.iter().all(|e| e.cycles >= 1 && e.solves >= 1));
    s
}

#[test]
fn algorithm_1_on_the_hardware_field_keeps_the_green_tiles() {
    let s = hardware_field_run(Some(ConfidenceBound::Paper));
    // (3b) with |C| = 14, δ = 1e-4 needs ≈ 150 samples for μ̂ ∈ {0, 1}: 5 visits of B = 30
    assert!(
        s.bandit.samples.iter().all(|&n| (120..=300).contains(&n)),
        "{:?}",
        s.bandit.samples
    );
}

#[test]
fn the_hardware_field_with_the_default_kl_bound_needs_19_samples_a_cell() {
    let s = hardware_field_run(None);
    assert_eq!(
        s.bandit.bound,
        ConfidenceBound::Kl,
        "the mission file's default"
    );
    // The KL bound with |C| = 14, δ = 1e-4 labels μ̂ ∈ {0, 1} after 19 samples:
    // 19·ln(1/0.45) = 15.17 ≥ β(19) = ln(14/δ) + ln 20 = 14.85, while 18·ln(1/0.45) = 14.37 <
    // β(18) = 14.79. (4) runs after every measurement, so each cell stops there, within its
    // first visit of B = 30.
    assert_eq!(s.bandit.samples, vec![19; 14]);
}

#[test]
fn an_interrupted_sortie_is_replanned_from_where_the_team_is() {
    let mut s = first_sortie_started();
    // two images of the first capture visit, then the GCS dies
    let c = s.cycle().unwrap().clone();
    let d = c.drones.iter().find(|d| !d.captures.is_empty()).unwrap();
    let v = &d.captures[0];
    let sz = s.grid.cell_size();
    for key in 0..2 {
        let (visit, _) = s
            .match_image(
                d.sysid,
                f64::from(v.cell.col) * sz,
                f64::from(v.cell.row) * sz,
            )
            .unwrap();
        s.record(d.sysid, visit, (d.sysid, 7, key), 0.0, false)
            .unwrap();
    }
    assert!(s.seen((d.sysid, 7, 1)));
    let text = serde_json::to_string(&s).unwrap();
    let mut r: ClassificationState = serde_json::from_str(&text).unwrap();
    assert_eq!(r.measurements, 2);
    assert_eq!(r.next(), Next::Follow);
    // the sortie ends (vehicles fly their missions on their own), elsewhere than planned for
    // one drone's station: the rest of the epoch is planned from there
    let end = r.cycle().unwrap().planned_end();
    let goals_left = r.remaining_goals();
    assert!(!goals_left.contains(&v.cell), "the measured goal is done");
    match r.finish_cycle(end.clone(), true).unwrap() {
        CycleEnd::Replan => {}
        CycleEnd::EpochDone(_) => assert!(goals_left.is_empty()),
        other => panic!("{other:?}"),
    }
    assert_eq!(r.config, end);
    if r.next() == Next::Plan {
        let inst = r.instance(r.params.k_max).unwrap();
        assert_eq!(inst.goals.len(), r.remaining_goals().len());
        plan(&mut r);
        assert_eq!(r.next(), Next::Prepare);
    }
    // a configuration with a drone off any station is refused with a clear message
    let mut bad = end;
    bad.drones[0] = Cell::new(0, 0);
    let e = r.validate_config(&bad).unwrap_err().to_string();
    assert!(e.contains("where no station is"), "{e}");
}

#[test]
fn a_sortie_waiting_on_the_ground_for_pictures_is_not_flight_time() {
    let mut s = first_sortie_started();
    let d = s.cycle().unwrap().drones[0].sysid;
    s.on_tick(&[d], 60.0);
    // landed, the cameras still sending: ten minutes on the ground
    s.on_tick(&[], 600.0);
    assert_eq!(s.cycle().unwrap().elapsed_s, 60.0);
    assert_eq!(s.airborne_s.get(&d).copied(), Some(60.0));
}

#[test]
fn lock_step_holds_the_drones_that_are_ahead() {
    let text = HARDWARE.replace("altitude_separation_m = 2.0", "altitude_separation_m = 0.0");
    let mut s = state(&text, None);
    assert_eq!(s.params.separation, Separation::LockStep);
    s.begin_epoch().unwrap();
    plan(&mut s);
    s.prepare_cycle().unwrap();
    let flying: Vec<u8> = s
        .cycle()
        .unwrap()
        .drones
        .iter()
        .filter(|d| d.flies)
        .map(|d| d.sysid)
        .collect();
    assert!(flying.len() >= 2);
    let mut arrived: BTreeMap<u8, usize> = flying.iter().map(|&s| (s, 2)).collect();
    assert!(s.ahead(&arrived).is_empty());
    arrived.insert(flying[0], 3);
    assert_eq!(s.ahead(&arrived), vec![flying[0]]);
    arrived.insert(flying[1], 1);
    let ahead = s.ahead(&arrived);
    assert!(ahead.contains(&flying[0]) && !ahead.contains(&flying[1]));
    // every drone mission loiters at every step (the barrier's window)
    for d in s.cycle().unwrap().drones.iter().filter(|d| d.flies) {
        assert!(
            d.step_arrive.iter().skip(1).all(Option::is_some),
            "{:?}",
            d.step_arrive
        );
    }
    // with altitude separation, nobody is ever held
    let mut a = state(HARDWARE, None);
    a.begin_epoch().unwrap();
    plan(&mut a);
    a.prepare_cycle().unwrap();
    assert!(a.ahead(&arrived).is_empty());
}

#[test]
fn cells_flip_between_mission_and_planner_indexing() {
    let s = state(HARDWARE, None);
    assert_eq!(s.layout.to_planner(Cell::new(5, 0)), Cell::new(0, 0));
    assert_eq!(
        s.layout.planner_to_mission(Cell::new(0, 0)),
        Cell::new(5, 0)
    );
    let g = s.layout.planner_grid().unwrap();
    // the road column 1 and mission row 3 (planner row 2), as in tests/scenarios/hardware-6x6.json
    assert!(g.is_station_ok(g.index(Cell::new(2, 4)).unwrap()));
    assert!(g.is_blocked(g.index(Cell::new(0, 2)).unwrap()));
}

/// A sortie whose cameras delivered nothing: every capture visit is short, by drone and cell;
/// the epoch it ends has visits and no measurement, and such epochs are counted in a row from
/// the latest (only those from index `since` on), a measured epoch ending the row.
#[test]
fn visits_without_images_and_epochs_without_measurement() {
    // Fly an epoch to its end; `measure`: every capture gets its B images, else none.
    fn epoch(s: &mut ClassificationState, measure: bool, key: &mut i32) {
        assert_eq!(s.next(), Next::BeginEpoch);
        s.begin_epoch().unwrap();
        while !matches!(s.next(), Next::BeginEpoch | Next::Finished) {
            match s.next() {
                Next::Plan => plan(s),
                Next::Prepare => {
                    s.prepare_cycle().unwrap();
                    if measure {
                        fly(s, key);
                        assert!(s.short_visits().is_empty());
                    } else {
                        s.on_verified().unwrap();
                        s.on_started().unwrap();
                        let c = s.cycle().unwrap();
                        let visits: Vec<(u8, Cell, u32)> = c
                            .drones
                            .iter()
                            .flat_map(|d| d.captures.iter().map(move |v| (d.sysid, v.cell, 0)))
                            .collect();
                        assert_eq!(s.short_visits(), visits);
                    }
                    let end = s.cycle().unwrap().planned_end();
                    s.finish_cycle(end, false).unwrap();
                }
                other => panic!("{other:?}"),
            }
        }
    }
    let mut s = state(HARDWARE, None);
    let mut key = 0;
    epoch(&mut s, true, &mut key);
    assert_eq!(s.epochs_without_measurement(0), 0);
    epoch(&mut s, false, &mut key);
    epoch(&mut s, false, &mut key);
    assert_eq!(s.epochs.len(), 3);
    assert!(
        s.epochs[1..]
            .iter()
            .all(|e| e.visits > 0 && e.measurements == 0)
    );
    assert_eq!(s.epochs_without_measurement(0), 2);
    assert_eq!(s.epochs_without_measurement(2), 1, "from epoch index 2 on");
    assert_eq!(s.epochs_without_measurement(3), 0);
    epoch(&mut s, true, &mut key);
    assert_eq!(
        s.epochs_without_measurement(0),
        0,
        "a measured epoch ends the row"
    );
}

/// A drone that cannot start goes out: the sortie is dropped before anything moved, the rest
/// of the epoch is planned for the three others with its station held on its cell (its
/// charger taken), and the run classifies every cell without it; a resume makes it eligible,
/// and taken back it flies again. What is out, and why, survives a save.
#[test]
fn a_drone_that_cannot_start_is_left_out_and_its_station_held() {
    let mut s = state(HARDWARE, None);
    s.begin_epoch().unwrap();
    plan(&mut s);
    s.prepare_cycle().unwrap();
    s.on_verified().unwrap();
    assert_eq!(s.next(), Next::Start);
    let start = s.config.clone();
    let fix = Some("clear the pre-arm failure it reports: PreArm: Compass not calibrated".into());
    s.start_failed(start.clone(), &[(4, "arming refused".into(), fix)])
        .unwrap();
    assert!(
        s.cycle().is_none() && s.next() == Next::Plan,
        "the sortie is dropped"
    );
    assert_eq!(s.active_drones(), vec![1, 2, 3]);
    assert_eq!(
        s.eligible(),
        vec![4],
        "tried again at the next sortie (first failure)"
    );
    // Drone 4 stands on station 6 at [3, 4]: station 6 is held, one charger taken.
    assert_eq!(
        s.pins(&s.config),
        vec![Pin {
            station: 1,
            taken: 1
        }]
    );
    let inst = s.instance(s.params.k_max).unwrap();
    assert_eq!(inst.nd(), 3);
    let text = serde_json::to_string(&s).unwrap();
    let back: ClassificationState = serde_json::from_str(&text).unwrap();
    assert_eq!(back.out, s.out);
    assert_eq!(back.start_failures.get(&4), Some(&1));
    // Fly the rest without drone 4 (it is not taken back: its checks keep failing).
    let mut key = 0;
    let mut sorties = 0;
    while s.next() != Next::Finished {
        match s.next() {
            Next::BeginEpoch => {
                s.begin_epoch().unwrap();
            }
            Next::Plan => plan(&mut s),
            Next::Prepare => {
                s.prepare_cycle().unwrap();
                let c = s.cycle().unwrap();
                let d4 = c.drones.iter().find(|d| d.sysid == 4).unwrap();
                assert!(!d4.flies && d4.captures.is_empty() && d4.items.is_empty());
                assert!(d4.path.iter().all(|&c| c == Cell::new(3, 4)));
                let st6 = c.stations.iter().find(|x| x.sysid == 6).unwrap();
                assert!(!st6.drives, "station 6 holds drone 4: it does not drive");
                // at most C − 1 drones of the plan land on it
                let on6 = c
                    .drones
                    .iter()
                    .filter(|d| d.sysid != 4 && d.path.last() == Some(&Cell::new(3, 4)))
                    .count();
                assert!(on6 < 2, "{on6} drones land beside drone 4 on station 6");
            }
            Next::Upload | Next::Start => {
                fly(&mut s, &mut key);
                sorties += 1;
                let end = s.cycle().unwrap().planned_end();
                s.finish_cycle(end, false).unwrap();
            }
            Next::Follow | Next::Finished => unreachable!(),
        }
        assert!(sorties < 200);
    }
    assert_eq!(
        s.bandit.keep().into_iter().collect::<BTreeSet<_>>(),
        green()
    );
    assert!(s.is_out(4));
    // The operator resumes: drone 4 may be tried; taken back, it flies in the next plan.
    s.on_resume();
    assert_eq!(s.eligible(), vec![4]);
    assert!(s.reinstate(4));
    assert!(!s.is_out(4) && s.pins(&s.config).is_empty());
    assert_eq!(s.instance(1).unwrap().nd(), 4);
}

/// A station that cannot drive is held on its cell with no charger taken, and a failed
/// start counted in a row backs the member off: 0, 1, 3, 7, 7 sorties.
#[test]
fn a_station_that_cannot_drive_is_held_and_retries_back_off() {
    let mut s = state(HARDWARE, None);
    s.begin_epoch().unwrap();
    let cfg = s.config.clone();
    let mut waits = Vec::new();
    for _ in 0..5 {
        s.start_failed(cfg.clone(), &[(5, "MISSION_START refused".into(), None)])
            .unwrap();
        waits.push(s.out[&5].wait_sorties);
        assert!(s.reinstate(5));
    }
    assert_eq!(waits, vec![0, 1, 3, 7, 7]);
    s.start_failed(cfg, &[(5, "MISSION_START refused".into(), None)])
        .unwrap();
    assert_eq!(s.out[&5].role, Role::Station);
    assert_eq!(
        s.pins(&s.config),
        vec![Pin {
            station: 0,
            taken: 0
        }]
    );
    plan(&mut s);
    s.prepare_cycle().unwrap();
    let c = s.cycle().unwrap();
    assert!(c.stations.iter().any(|x| x.sysid == 5 && !x.drives));
    // Started: its failures in a row are forgotten by the vehicles that moved.
    s.on_verified().unwrap();
    s.on_started().unwrap();
    assert_eq!(s.start_failures.get(&5), Some(&6), "station 5 did not move");
}

/// A drone whose autopilot's failsafe took it home mid-sortie goes out without dropping the
/// sortie: the others finish it, the sortie ends with the drone off every station (allowed
/// for a drone out), the rest is planned without it, and once flown back onto a station
/// it is taken back and planned again. What is out survives a save.
#[test]
fn a_drone_taken_home_by_its_failsafe_is_out_and_rejoins_from_a_station() {
    let mut s = first_sortie_started();
    s.sideline(
        2,
        "battery failsafe (RTL at 18 %)".into(),
        Some("swap its battery".into()),
    )
    .unwrap();
    s.on_landed(2).unwrap();
    assert!(s.is_out(2) && s.eligible() == vec![2]);
    assert_eq!(s.active_drones(), vec![1, 3, 4]);
    let back: ClassificationState =
        serde_json::from_str(&serde_json::to_string(&s).unwrap()).unwrap();
    assert_eq!(back.out, s.out);
    // It landed where its autopilot took it: a cell with no station.
    let mut actual = s.cycle().unwrap().planned_end();
    let off = (0..6)
        .flat_map(|r| (0..6).map(move |c| Cell::new(r, c)))
        .find(|c| !actual.stations.contains(c) && !s.layout.obstacles.contains(c))
        .unwrap();
    actual.drones[1] = off;
    s.finish_cycle(actual.clone(), false).unwrap();
    assert_eq!(s.config.drones[1], off);
    // Planned without it, from where the others are.
    assert_eq!(s.instance(s.params.k_max).unwrap().nd(), 3);
    // Flown back onto a station, it is taken back and planned again.
    assert!(s.relocate_drone(2, off).is_err(), "no station there");
    let station = s.config.stations[0];
    s.relocate_drone(2, station).unwrap();
    assert!(s.reinstate(2));
    assert_eq!(s.instance(s.params.k_max).unwrap().nd(), 4);
}

/// A station stuck on its way to the rendezvous ends its leg where it stands and goes out
/// for one sortie at least: the sortie can complete (the drones land on it there), the rest
/// is planned with it held on its cell.
#[test]
fn a_stuck_station_ends_its_leg_where_it_stands_and_is_held() {
    let mut s = first_sortie_started();
    let c = s.cycle().unwrap().clone();
    let st = c.stations[0].sysid;
    assert!(s.on_station_stuck(99, "stuck".into()).is_err());
    s.on_station_stuck(st, "no progress for 60 s".into())
        .unwrap();
    assert!(s.cycle().unwrap().stations[0].arrived);
    assert!(s.is_out(st) && s.eligible().is_empty(), "out for a sortie");
    for d in &c.drones {
        s.on_landed(d.sysid).unwrap();
    }
    // It stands where it started (a road cell): the drones that were to land on it did.
    let mut actual = c.planned_end();
    let first = c.stations[0].path[0];
    for (i, d) in actual.drones.clone().iter().enumerate() {
        if *d == actual.stations[0] {
            actual.drones[i] = first;
        }
    }
    actual.stations[0] = first;
    assert_ne!(actual.stations[1], first);
    s.finish_cycle(actual, false).unwrap();
    assert_eq!(s.eligible(), vec![st], "tried again after a sortie");
    assert!(s.pins(&s.config).iter().any(|p| p.station == 0));
}
