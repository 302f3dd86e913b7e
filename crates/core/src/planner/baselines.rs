//! How the epoch goals E_p are chosen (Step 3 of Algorithm 1): the paper's UCB rule, the
//! improved APT rule, and the three data-agnostic baselines of §VI-5 (Fig. 6).
//!
//! The paper says only that "Random chooses E_p randomly from the unclassified cells, and
//! GreedyCov/GreedyTrav greedily maximize coverage/minimize team travel distance". Our precise
//! definitions (all choose min(D, #unclassified) distinct unclassified cells, and none looks at
//! the measured values, only at where the team is and how often cells were sampled):
//!
//! * **Random**: a uniformly random subset of the unclassified cells (seeded).
//! * **GreedyCov** (coverage): repeatedly take the unclassified cell with the fewest samples
//!   |H_l| so far — the least covered part of the map —, ties broken by the largest
//!   obstacle-avoiding king's-move distance to the goals already taken this epoch (spreading the
//!   goals over the map), then by row-major order.
//! * **GreedyTrav** (travel): repeatedly take the unclassified cell nearest (obstacle-avoiding
//!   king's-move distance) to the team's current cells or to a goal already taken this epoch —
//!   a nearest-neighbour chain from the team, which keeps the team's travel short —, ties by
//!   row-major order.

use super::bandit::BanditState;
use super::grid::PlannerGrid;
use rand::seq::SliceRandom;
use serde::{Deserialize, Serialize};

/// A rule for choosing the epoch goals.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum GoalRule {
    /// The paper's rule: top-D by J = μ̂ + U (3).
    Ucb,
    /// The improved rule: the D most ambiguous cells by the APT index (see
    /// `BanditState::apt_goal_indices`).
    Apt,
    /// Baseline: uniformly random unclassified cells.
    Random,
    /// Baseline: least-sampled cells, spread out.
    GreedyCov,
    /// Baseline: cells nearest the team.
    GreedyTrav,
}

impl GoalRule {
    /// Every rule.
    pub const ALL: [GoalRule; 5] = [
        GoalRule::Ucb,
        GoalRule::Apt,
        GoalRule::Random,
        GoalRule::GreedyCov,
        GoalRule::GreedyTrav,
    ];

    /// The rule's name as printed and parsed (`ucb`, `apt`, `random`, `greedy-cov`,
    /// `greedy-trav`).
    pub fn name(self) -> &'static str {
        match self {
            GoalRule::Ucb => "ucb",
            GoalRule::Apt => "apt",
            GoalRule::Random => "random",
            GoalRule::GreedyCov => "greedy-cov",
            GoalRule::GreedyTrav => "greedy-trav",
        }
    }

    /// Parse a name of [`GoalRule::name`].
    pub fn parse(s: &str) -> Option<GoalRule> {
        GoalRule::ALL.into_iter().find(|r| r.name() == s)
    }
}

/// Choose the epoch goals with `rule`: candidate indices of `state`, at most `d` of them, all
/// unclassified. `grid` maps the candidates to the map (for the distance-based baselines),
/// `team` lists the cells (dense grid indices) the drones and stations occupy now.
pub fn choose_goals<R: rand::Rng + ?Sized>(
    rule: GoalRule,
    state: &BanditState,
    d: usize,
    grid: &PlannerGrid,
    team: &[usize],
    rng: &mut R,
) -> Vec<usize> {
    match rule {
        GoalRule::Ucb => state.ucb_goal_indices(d),
        GoalRule::Apt => state.apt_goal_indices(d),
        GoalRule::Random => {
            let mut open = state.unclassified();
            open.shuffle(rng);
            open.truncate(d);
            open.sort_unstable();
            open
        }
        GoalRule::GreedyCov => greedy(state, d, grid, team, true),
        GoalRule::GreedyTrav => greedy(state, d, grid, team, false),
    }
}

fn greedy(
    state: &BanditState,
    d: usize,
    grid: &PlannerGrid,
    team: &[usize],
    coverage: bool,
) -> Vec<usize> {
    let mut open: Vec<(usize, usize)> = state
        .unclassified()
        .into_iter()
        .filter_map(|l| grid.index(state.cells[l]).map(|g| (l, g)))
        .collect();
    let mut chosen: Vec<usize> = Vec::new();
    let mut anchors: Vec<usize> = if coverage { Vec::new() } else { team.to_vec() };
    while chosen.len() < d && !open.is_empty() {
        let dist = if anchors.is_empty() {
            vec![u32::MAX; grid.len()]
        } else {
            grid.distances(&anchors, false)
        };
        let best = if coverage {
            // Fewest samples, then farthest from the goals taken, then index.
            (0..open.len()).min_by(|&a, &b| {
                let (la, ga) = open[a];
                let (lb, gb) = open[b];
                state.samples[la]
                    .cmp(&state.samples[lb])
                    .then(dist[gb].cmp(&dist[ga]))
                    .then(la.cmp(&lb))
            })
        } else {
            (0..open.len()).min_by(|&a, &b| {
                let (la, ga) = open[a];
                let (lb, gb) = open[b];
                dist[ga].cmp(&dist[gb]).then(la.cmp(&lb))
            })
        };
        let Some(k) = best else { break };
        let (l, g) = open.swap_remove(k);
        chosen.push(l);
        anchors.push(g);
    }
    chosen
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geo::Cell;
    use rand::SeedableRng;

    fn setup() -> (PlannerGrid, BanditState) {
        let g = PlannerGrid::new(1, 6, &[], None).unwrap();
        let cells: Vec<Cell> = (0..6).map(|c| Cell::new(0, c)).collect();
        (g, BanditState::new(cells, 0.5, 0.05, 0.1).unwrap())
    }

    #[test]
    fn greedy_trav_chains_from_the_team() {
        let (g, s) = setup();
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        let goals = choose_goals(GoalRule::GreedyTrav, &s, 3, &g, &[5], &mut rng);
        assert_eq!(goals, vec![5, 4, 3]);
    }

    #[test]
    fn greedy_cov_takes_least_sampled_and_spreads() {
        let (g, mut s) = setup();
        s.record(0, 1, 10);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
        // Unsampled 1..=5; the first by index, then the farthest from it, and so on.
        let goals = choose_goals(GoalRule::GreedyCov, &s, 3, &g, &[0], &mut rng);
        assert_eq!(goals, vec![1, 5, 3]);
    }

    #[test]
    fn random_is_seeded_and_unclassified_only() {
        let (g, mut s) = setup();
        for _ in 0..200 {
            s.record(2, 10, 10);
        }
        s.update();
        let pick = |seed| {
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
            choose_goals(GoalRule::Random, &s, 4, &g, &[0], &mut rng)
        };
        assert_eq!(pick(3), pick(3));
        assert!(pick(3).iter().all(|&l| l != 2));
        assert_eq!(pick(3).len(), 4);
        assert_eq!(GoalRule::parse("greedy-cov"), Some(GoalRule::GreedyCov));
    }
}
