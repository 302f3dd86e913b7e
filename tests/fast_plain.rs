//! Fast = plain (issue 17, item 2), the small version kept in `make test`: both IP models on
//! Algorithm 1 epochs of small worlds with the paper's agility (T_d, T_c) = (8, 4) and drones
//! sharing chargers (C = 2 and 3). The paper-scale run (10×10, 10 drones, 5 stations, C = 1, 2,
//! 3, 50 instances each) is `fleetmap experiment fast-plain`, recorded in
//! docs/results/fast-plain.md; it takes tens of minutes, too long for CI.

use fleetmap::clock::stopwatch;
use fleetmap::experiment::fastplain::{self, FastPlainConfig, GoalSet, Verdict};
use fleetmap::planner::ip::PlanStatus;

fn small(capacities: Vec<usize>) -> FastPlainConfig {
    FastPlainConfig {
        instances: 6,
        capacities,
        seed: 17,
        // Generous: a dev build solves each of these in well under a second; a time-limited
        // solve would be "unknown", which the test refuses below.
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
    }
}

#[test]
fn fast_and_plain_agree_with_shared_chargers_at_td8_tc4() {
    let cfg = small(vec![2, 3]);
    let clock = stopwatch();
    let study = fastplain::run(&cfg, &clock, &mut |r| {
        eprintln!("{}", fastplain::row_line(r))
    })
    .expect("the comparison runs");
    eprint!("{}", fastplain::summary_lines(&study));
    let s = &study.summary;
    assert_eq!(s.instances, 12);
    for r in &study.rows {
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
                assert_eq!(solved.checker, Some(true));
            }
        }
    }
    assert_eq!((s.differences, s.unknown, s.plans_rejected), (0, 0, 0));
    // The sample must exercise what an over-pruned fast model would get wrong: epochs needing
    // several cycles, epochs infeasible within K, and both goal sets, at both capacities.
    assert!(s.multi_cycle >= 1, "no multi-cycle epoch in the sample");
    assert!(s.infeasible >= 1, "no infeasible epoch in the sample");
    assert_eq!(s.plans_checked, 2 * s.optimal);
    for g in [GoalSet::Epoch, GoalSet::Far] {
        assert!(study.rows.iter().any(|r| r.goal_set == g));
    }
    // C · N_c bounds the team (eq. (10) at every cycle boundary): 4 drones at C = 2, all 5 at
    // C = 3, where a charger holds three.
    for r in &study.rows {
        assert_eq!(r.drones, if r.capacity == 2 { 4 } else { 5 });
    }
}
