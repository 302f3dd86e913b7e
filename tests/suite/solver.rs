//! The MILP solver (good_lp + HiGHS) builds, links and solves a small integer program.

use good_lp::{Expression, Solution, SolverModel, constraint, highs, variable, variables};

/// 0/1 knapsack: values 10, 13, 7, 8; weights 5, 6, 3, 4; capacity 10. Every feasible
/// pair by hand: {0,1} too heavy, {0,2} 17, {0,3} 18, {1,2} 20, {1,3} 21, {2,3} 15; no triple
/// fits (the lightest, {0,2,3}, weighs 12). The optimum is items 1 and 3, value 21.
#[test]
fn highs_solves_a_small_knapsack_exactly() {
    let values = [10.0, 13.0, 7.0, 8.0];
    let weights = [5.0, 6.0, 3.0, 4.0];
    let mut vars = variables!();
    let x: Vec<_> = (0..4).map(|_| vars.add(variable().binary())).collect();
    let objective: Expression = x.iter().zip(values).map(|(&v, c)| c * v).sum();
    let weight: Expression = x.iter().zip(weights).map(|(&v, w)| w * v).sum();
    let solution = vars
        .maximise(objective.clone())
        .using(highs)
        .with(constraint!(weight <= 10.0))
        .solve()
        .expect("HiGHS solves the knapsack");
    let taken: Vec<bool> = x.iter().map(|&v| solution.value(v) > 0.5).collect();
    assert_eq!(taken, [false, true, false, true]);
    assert!((solution.eval(&objective) - 21.0).abs() < 1e-6);
}

/// An infeasible integer program is reported as such, not as a wrong answer.
#[test]
fn highs_reports_infeasibility() {
    let mut vars = variables!();
    let a = vars.add(variable().integer().min(0).max(3));
    let result = vars
        .minimise(a)
        .using(highs)
        .with(constraint!(2 * a == 3))
        .solve();
    assert!(matches!(result, Err(good_lp::ResolutionError::Infeasible)));
}
