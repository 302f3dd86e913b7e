//! End-to-end tests of the bandit/IP planner: the fast model against the paper's
//! plain model on random scenarios, every plan through the independent checker, the shipped
//! scenario files through `fleetmap plan`, and a small bandit study.

use fleetmap_core::geo::Cell;
use fleetmap_core::planner::check::{CheckOptions, check_plan_with};
use fleetmap_core::planner::grid::PlannerGrid;
use fleetmap_core::planner::ip::{Model, PlanOptions, PlanStatus, solve_instance};
use fleetmap_core::planner::scenario::{Instance, Scenario};
use fleetmap_io::clock::stopwatch;
use rand::seq::SliceRandom;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::path::PathBuf;

use crate::common;

/// A random small scenario: 3×3 to 5×5 grids, some obstacles, sometimes roads, 1–3 drones on
/// 1–2 stations, 1–4 goals, (Td, Tc) ∈ {(4, 2), (4, 4), (6, 3), (2, 2)}, K = 3, sometimes a
/// charger capacity. Goals may be unreachable (then both models must say infeasible).
fn random_instance(rng: &mut ChaCha8Rng) -> Instance {
    loop {
        let rows = rng.random_range(3..=5i64);
        let cols = rng.random_range(3..=5i64);
        let n = (rows * cols) as usize;
        let cell = |i: usize| Cell::new((i / cols as usize) as i32, (i % cols as usize) as i32);
        let mut order: Vec<usize> = (0..n).collect();
        order.shuffle(rng);
        let n_obst = rng.random_range(0..=n / 4);
        let obstacles: Vec<Cell> = order[..n_obst].iter().map(|&i| cell(i)).collect();
        let free: Vec<usize> = order[n_obst..].to_vec();
        let roads: Option<Vec<Cell>> = if rng.random_bool(0.4) {
            let k = rng.random_range(2..=free.len().max(2)).min(free.len());
            Some(free[..k].iter().map(|&i| cell(i)).collect())
        } else {
            None
        };
        let grid = match PlannerGrid::new(rows, cols, &obstacles, roads.as_deref()) {
            Ok(g) => g,
            Err(_) => continue,
        };
        let admissible: Vec<usize> = free
            .iter()
            .copied()
            .filter(|&i| grid.is_station_ok(i))
            .collect();
        let nc = rng.random_range(1..=2usize).min(admissible.len());
        if nc == 0 {
            continue;
        }
        let stations: Vec<usize> = admissible[..nc].to_vec();
        let nd = rng.random_range(1..=3usize);
        let drones: Vec<usize> = (0..nd).map(|_| stations[rng.random_range(0..nc)]).collect();
        let n_goals = rng.random_range(1..=4usize).min(free.len());
        let mut goal_pool = free.clone();
        goal_pool.shuffle(rng);
        let goals = goal_pool[..n_goals].to_vec();
        let (td, tc) = [(4, 2), (4, 4), (6, 3), (2, 2)][rng.random_range(0..4usize)];
        let capacity = if rng.random_bool(0.3) { Some(1) } else { None };
        if let Ok(inst) = Instance::new(grid, drones, stations, goals, td, tc, 3, capacity) {
            return inst;
        }
    }
}

fn check_strict(inst: &Instance, outcome: &fleetmap_core::planner::ip::PlanOutcome, what: &str) {
    if let Some(plan) = &outcome.plan
        && let Err(e) = check_plan_with(
            inst,
            plan,
            CheckOptions {
                no_head_on_swaps: true,
            },
        )
    {
        panic!(
            "{what} plan fails the checker: {e}\n{}",
            inst.to_scenario("").to_json()
        );
    }
}

#[test]
fn fast_model_has_the_plain_models_optimum_on_100_random_scenarios() {
    let mut rng = ChaCha8Rng::seed_from_u64(7);
    let plain = PlanOptions {
        model: Model::Plain,
        ..PlanOptions::default()
    };
    let fast = PlanOptions::default();
    let (mut feasible, mut infeasible, mut multi) = (0, 0, 0);
    for n in 0..100 {
        let inst = random_instance(&mut rng);
        let a = solve_instance(&inst, &plain, &stopwatch());
        let b = solve_instance(&inst, &fast, &stopwatch());
        let scen = inst.to_scenario(&format!("random {n}")).to_json();
        assert!(
            matches!(a.status, PlanStatus::Optimal | PlanStatus::Infeasible),
            "plain model: {:?} {}\n{scen}",
            a.status,
            a.message
        );
        assert_eq!(a.status, b.status, "scenario {n}:\n{scen}");
        let cycles =
            |o: &fleetmap_core::planner::ip::PlanOutcome| o.plan.as_ref().map(|p| p.cycles);
        assert_eq!(cycles(&a), cycles(&b), "scenario {n}:\n{scen}");
        check_strict(&inst, &a, "plain");
        check_strict(&inst, &b, "fast");
        match cycles(&a) {
            None => infeasible += 1,
            Some(1) => feasible += 1,
            Some(_) => {
                feasible += 1;
                multi += 1
            }
        }
    }
    eprintln!("{feasible} feasible ({multi} with ≥ 2 cycles), {infeasible} infeasible");
    // The sample must exercise every outcome, or the comparison proves little.
    assert!(
        feasible >= 20 && infeasible >= 5 && multi >= 5,
        "{feasible} feasible ({multi} with ≥ 2 cycles), {infeasible} infeasible"
    );
}

/// Stations held on their cells ([`Pin`]: a rover that cannot drive, or one carrying a drone
/// that is out of the run, its charger taken): on random scenarios with a pinned station
/// (and sometimes a charger taken on it, under a capacity of 1 or 2), the fast model has the
/// plain model's optimum, and every plan keeps the pinned station on its cell and the drones
/// on it within the chargers left (the independent checker).
#[test]
fn pinned_stations_stay_and_keep_their_chargers_in_both_models() {
    use fleetmap_core::planner::scenario::Pin;
    let mut rng = ChaCha8Rng::seed_from_u64(11);
    let plain = PlanOptions {
        model: Model::Plain,
        ..PlanOptions::default()
    };
    let fast = PlanOptions::default();
    let (mut feasible, mut infeasible, mut taken_plans) = (0, 0, 0);
    let mut n = 0;
    while n < 60 {
        let mut inst = random_instance(&mut rng);
        if rng.random_bool(0.5) {
            let capacity = Some(rng.random_range(1..=2usize));
            let i = inst.clone();
            let goals = i.goals.clone();
            let Ok(with) = Instance::new(
                i.grid, i.drones, i.stations, goals, i.td, i.tc, i.k_max, capacity,
            ) else {
                continue;
            };
            inst = with;
        }
        let station = rng.random_range(0..inst.nc());
        let taken = usize::from(rng.random_bool(0.7));
        let Ok(inst) = inst.with_pins(vec![Pin { station, taken }]) else {
            continue;
        };
        n += 1;
        let a = solve_instance(&inst, &plain, &stopwatch());
        let b = solve_instance(&inst, &fast, &stopwatch());
        let scen = format!(
            "{}\npinned station {station}, {taken} taken",
            inst.to_scenario(&format!("pinned {n}")).to_json()
        );
        assert!(
            matches!(a.status, PlanStatus::Optimal | PlanStatus::Infeasible),
            "plain model: {:?} {}\n{scen}",
            a.status,
            a.message
        );
        assert_eq!(a.status, b.status, "{scen}");
        let cycles =
            |o: &fleetmap_core::planner::ip::PlanOutcome| o.plan.as_ref().map(|p| p.cycles);
        assert_eq!(cycles(&a), cycles(&b), "{scen}");
        check_strict(&inst, &a, "plain");
        check_strict(&inst, &b, "fast");
        for o in [&a, &b] {
            if let Some(p) = &o.plan {
                let home = inst.grid.cell(inst.stations[station]);
                assert!(p.stations[station].iter().flatten().all(|&c| c == home));
            }
        }
        match cycles(&a) {
            Some(_) => {
                feasible += 1;
                taken_plans += usize::from(taken > 0 && inst.capacity.is_some());
            }
            None => infeasible += 1,
        }
    }
    eprintln!("{feasible} feasible ({taken_plans} with a charger taken), {infeasible} infeasible");
    assert!(feasible >= 15 && infeasible >= 3 && taken_plans >= 3);
    // The checker catches a plan that overfills a pinned station's chargers, or moves it.
    let c = |col| Cell::new(0, col);
    let pinned = |cols, taken| {
        let grid = PlannerGrid::new(1, cols, &[], None).unwrap();
        let last = cols as usize - 1;
        Instance::new(grid, vec![0, 0], vec![0, last], vec![1], 2, 2, 1, Some(2))
            .unwrap()
            .with_pins(vec![Pin { station: 1, taken }])
            .unwrap()
    };
    let full = fleetmap_core::planner::plan::IpPlan {
        cycles: 1,
        drones: vec![vec![vec![c(0), c(1)]], vec![vec![c(0), c(1)]]],
        stations: vec![vec![vec![c(0), c(0)]], vec![vec![c(1), c(1)]]],
    };
    let e = check_plan_with(&pinned(2, 1), &full, CheckOptions::default()).unwrap_err();
    assert!(e.to_string().contains("1 charger(s) taken"), "{e}");
    assert!(check_plan_with(&pinned(2, 0), &full, CheckOptions::default()).is_ok());
    let moved = fleetmap_core::planner::plan::IpPlan {
        cycles: 1,
        drones: vec![vec![vec![c(0), c(1)]], vec![vec![c(0), c(1)]]],
        stations: vec![vec![vec![c(0), c(0)]], vec![vec![c(2), c(1)]]],
    };
    let e = check_plan_with(&pinned(3, 0), &moved, CheckOptions::default()).unwrap_err();
    assert!(e.to_string().contains("is held at [0, 2] but moves"), "{e}");
}

fn scenarios() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/scenarios")
}

fn plan_json(file: &str) -> serde_json::Value {
    let scenario = scenarios().join(file);
    let out = common::fleetmap().ok(&["plan", "--json", "--scenario", scenario.to_str().unwrap()]);
    serde_json::from_slice(&out.stdout).unwrap()
}

#[test]
fn cli_solves_the_shipped_scenarios_in_the_spec_format() {
    for (file, status, cycles) in [
        ("hardware-6x6.json", "optimal", 1),
        ("sim-10x10.json", "optimal", 1),
        ("corridor-two-cycles.json", "optimal", 2),
        ("corridor-infeasible.json", "infeasible", 0),
    ] {
        let v = plan_json(file);
        let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
        let mut want = vec![
            "constraints",
            "cycles",
            "drones",
            "solve_seconds",
            "stations",
            "status",
            "variables",
        ];
        want.sort();
        let mut keys = keys;
        keys.sort();
        assert_eq!(keys, want, "{file}");
        assert_eq!(v["status"], status, "{file}");
        assert_eq!(v["cycles"], cycles, "{file}");
        // Rebuild the plan from the JSON and check it independently.
        let text = std::fs::read_to_string(scenarios().join(file)).unwrap();
        let inst = Scenario::from_json(&text).unwrap().instance().unwrap();
        if status == "optimal" {
            let parse = |x: &serde_json::Value| -> Vec<Vec<Vec<Cell>>> {
                let raw: Vec<Vec<Vec<[i32; 2]>>> = serde_json::from_value(x.clone()).unwrap();
                raw.into_iter()
                    .map(|v| {
                        v.into_iter()
                            .map(|s| s.into_iter().map(|[r, c]| Cell::new(r, c)).collect())
                            .collect()
                    })
                    .collect()
            };
            let plan = fleetmap_core::planner::plan::IpPlan {
                cycles: cycles as usize,
                drones: parse(&v["drones"]),
                stations: parse(&v["stations"]),
            };
            assert_eq!(
                plan.drones[0][0].len(),
                inst.td,
                "{file}: Td cells per cycle"
            );
            check_plan_with(
                &inst,
                &plan,
                CheckOptions {
                    no_head_on_swaps: true,
                },
            )
            .unwrap_or_else(|e| panic!("{file}: {e}"));
        }
    }
}

#[test]
fn cli_rejects_malformed_scenarios_with_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(scenarios().join("hardware-6x6.json")).unwrap();
    let mut v: serde_json::Value = serde_json::from_str(&text).unwrap();
    v["stations"][1] = serde_json::json!([0, 0]);
    let bad = dir.path().join("bad.json");
    std::fs::write(&bad, v.to_string()).unwrap();
    let out = common::fleetmap()
        .command()
        .args(["plan", "--scenario"])
        .arg(&bad)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("stations[1] at [0, 0] is outside station_cells"),
        "{err}"
    );
    assert_eq!(err.trim().lines().count(), 1, "{err}");
}

/// What the spec does not list as malformed — a goal on an obstacle, a drone off the stations'
/// cells, more drones on a station than its chargers — is a well-formed scenario without a
/// plan: status "infeasible", exit status 0, in the spec's output keys.
#[test]
fn cli_answers_infeasible_for_scenarios_no_plan_can_satisfy() {
    let dir = tempfile::tempdir().unwrap();
    let text = std::fs::read_to_string(scenarios().join("hardware-6x6.json")).unwrap();
    let base: serde_json::Value = serde_json::from_str(&text).unwrap();
    let obstacle = base["obstacles"][0].clone();
    let station = base["stations"][0].clone();
    type Edit = Box<dyn Fn(&mut serde_json::Value)>;
    let edits: Vec<(&str, Edit)> = vec![
        (
            "on an obstacle",
            Box::new(move |v| v["goals"].as_array_mut().unwrap().push(obstacle.clone())),
        ),
        (
            "not on a station",
            Box::new(|v| {
                let free = (0..6)
                    .flat_map(|r| (0..6).map(move |c| serde_json::json!([r, c])))
                    .find(|c| {
                        !v["obstacles"].as_array().unwrap().contains(c)
                            && !v["stations"].as_array().unwrap().contains(c)
                    })
                    .unwrap();
                v["drones"][0] = free;
            }),
        ),
        (
            "charger capacity is 1",
            Box::new(move |v| {
                v["capacity"] = serde_json::json!(1);
                v["drones"][0] = station.clone();
                v["drones"][1] = station.clone();
            }),
        ),
    ];
    for (why, edit) in edits {
        let mut v = base.clone();
        edit(&mut v);
        let file = dir.path().join("never.json");
        std::fs::write(&file, v.to_string()).unwrap();
        let out = common::fleetmap()
            .command()
            .args(["plan", "--json", "--scenario"])
            .arg(&file)
            .output()
            .unwrap();
        assert!(
            out.status.success(),
            "{why}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let o: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(o["status"], "infeasible", "{why}: {o}");
        assert_eq!(o["cycles"], 0, "{why}");
        assert_eq!(o["drones"], serde_json::json!([]), "{why}");
        let text = common::fleetmap()
            .command()
            .args(["plan", "--scenario"])
            .arg(&file)
            .output()
            .unwrap();
        let shown = String::from_utf8_lossy(&text.stdout);
        assert!(text.status.success());
        assert!(
            shown.contains("status: infeasible") && shown.contains(why),
            "{why}: {shown}"
        );
    }
}

/// The sortie planner's fence items ([`fleetmap_core::planner::sortie::missions::fence_items`])
/// as the simulated autopilot's fence reads them: obstacle cells are breached, a free cell's
/// centre is not, the margin (1 m) keeps an obstacle's corner free, and outside the area is
/// breached. (Was in the planner's unit tests; the simulator is not part of the core.)
#[test]
fn sortie_fence_items_keep_their_margin_in_the_simulator() {
    use fleetmap_core::geo::{Grid as GeoGrid, LatLon};
    let g = GeoGrid::new(LatLon::new(37.195, -80.58), 5.0).expect("a 5 m grid");
    let obstacles = [
        Cell::new(9, 1),
        Cell::new(9, 2),
        Cell::new(9, 3),
        Cell::new(8, 1),
        Cell::new(5, 5),
    ];
    let items = fleetmap_core::planner::sortie::missions::fence_items(&g, 10, 10, &obstacles, 1.0)
        .expect("fence items");
    let f = fleetmap_sim::fence::Fence::from_items(&items, (37.195, -80.58));
    let xy = |r: f64, c: f64| {
        let p = g.from_xy(c * 5.0, r * 5.0).expect("a point of the grid");
        let (n, e) = fleetmap_core::geo::local::delta(37.195, -80.58, p.lat, p.lon);
        (e, n)
    };
    let breached = |r, c| {
        let (e, n) = xy(r, c);
        f.breached(e, n)
    };
    assert!(breached(5.0, 5.0), "inside an obstacle");
    assert!(breached(9.0, 2.0));
    assert!(!breached(5.0, 4.0), "a free cell centre");
    assert!(
        !breached(5.5, 5.5),
        "the obstacle's corner is within the margin"
    );
    assert!(breached(-1.0, 0.0), "outside the area");
    assert!(!breached(0.0, 0.0));
}
