//! Fast = plain, the small version kept in `make test`: both IP models with
//! the paper's agility (T_d, T_c) = (8, 4) and drones sharing chargers (C = 2 and 3), on
//! Algorithm 1 epochs of small random worlds and on corridors whose goals need two cycles. The
//! paper-scale run (10×10, 10 drones, 5 stations, C = 1, 2, 3, 50 instances each) is `fleetmap
//! experiment fast-plain`, recorded in docs/results/fast-plain.md; it takes half an hour, too
//! long for CI.

use fleetmap::experiment::bandit::fastplain::{
    self, FastPlainConfig, Generated, GoalSet, Row, Verdict, compare,
};
use fleetmap_core::geo::Cell;
use fleetmap_core::planner::grid::PlannerGrid;
use fleetmap_core::planner::ip::PlanStatus;
use fleetmap_core::planner::scenario::Instance;
use fleetmap_io::clock::stopwatch;

fn assert_same(r: &Row) {
    eprintln!("{}", fastplain::row_line(r));
    assert_eq!(
        r.verdict,
        Verdict::Same,
        "C = {}, instance {}: {}",
        r.capacity,
        r.index,
        r.scenario.as_deref().unwrap_or("")
    );
    for solved in [&r.fast, &r.plain] {
        if solved.status == PlanStatus::Optimal {
            assert_eq!(solved.checker, Some(true), "{}", solved.message);
        }
    }
}

#[test]
fn fast_and_plain_agree_on_algorithm_1_epochs_with_shared_chargers() {
    let cfg = FastPlainConfig {
        instances: 4,
        capacities: vec![2, 3],
        seed: 17,
        // A dev build solves each of these in well under a second; a time-limited solve would
        // be "unknown", which the test refuses.
        time_limit: Some(60.0),
        size: 6,
        obstacles: 4,
        drones: 5,
        stations: 2,
        goals: 5,
        td: 8,
        tc: 4,
        cycles: vec![1, 2, 3],
        max_epoch: 4,
    };
    let clock = stopwatch();
    let study = fastplain::run(&cfg, &clock, &mut assert_same).expect("the comparison runs");
    eprint!("{}", fastplain::summary_lines(&study));
    let s = &study.summary;
    assert_eq!((s.instances, s.differences, s.unknown), (8, 0, 0));
    assert_eq!((s.plans_checked, s.plans_rejected), (2 * s.optimal, 0));
    for g in [GoalSet::Epoch, GoalSet::Far] {
        assert!(study.rows.iter().any(|r| r.goal_set == g));
    }
    // C · N_c bounds the team (eq. (10) at every cycle boundary): 4 drones at C = 2, all 5 at
    // C = 3, where a charger holds three.
    for r in &study.rows {
        assert_eq!(r.drones, if r.capacity == 2 { 4 } else { 5 });
    }
}

/// A 4 × 12 corridor, the team at its west end (two stations, drones stacked on them), goals
/// in column 7 of every row: a station moves 3 cells per cycle and a drone 7 and must land on
/// one, so after one cycle a drone has been at most 5 columns out (5 out, 2 back to a station
/// 3 columns on), and column 7 needs two cycles.
fn corridor(capacity: usize, k_max: usize) -> Generated {
    let grid = PlannerGrid::new(4, 12, &[Cell::new(1, 4), Cell::new(2, 6)], None).expect("grid");
    let at = |r, c| grid.index(Cell::new(r, c)).expect("cell");
    let stations = vec![at(0, 0), at(3, 0)];
    let drones = (0..2 * capacity.min(2)).map(|i| stations[i % 2]).collect();
    let goals = (0..4).map(|r| at(r, 7)).collect();
    let instance = Instance::new(grid, drones, stations, goals, 8, 4, k_max, Some(capacity))
        .expect("a valid corridor");
    Generated {
        index: k_max,
        capacity,
        goal_set: GoalSet::Far,
        epoch: 0,
        world_seed: 0,
        instance,
    }
}

#[test]
fn fast_and_plain_agree_on_corridors_that_need_two_cycles() {
    let clock = stopwatch();
    for capacity in [2, 3] {
        for k_max in [1, 2, 3] {
            let r = compare(&corridor(capacity, k_max), Some(60.0), &clock);
            assert_same(&r);
            let expected = if k_max == 1 { None } else { Some(2) };
            assert_eq!(r.fast.cycles, expected, "C = {capacity}, K = {k_max}");
        }
    }
}
