//! The algorithm choices a mission file names (`[explore] allocation`, `[bandit] bound`):
//! plain words here, so that the definition ([`super::definition`]) does not depend on the
//! algorithms that read them. The DFS ([`crate::explore::dfs`]) and the bandit planner
//! ([`crate::planner::bandit`]) re-export them under their old paths.

use serde::{Deserialize, Serialize};
use std::fmt;

/// How the robots at a vertex are allocated to the work left (see [`crate::explore::dfs`],
/// "Allocation").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Allocation {
    /// Algorithm 1 as written: unexplored children before those under exploration, then
    /// more grid branches first; split ⌈k/2⌉/⌊k/2⌋ over two (line 19), all to one (line 22),
    /// back to the parent when no child is left (line 24).
    ///
    /// The default. Nearest frontier has the lower mean cost on the 2 800 Fig. 7 trials
    /// (0.977 of this split's per trial, no trial above Lemma 1) but a worse worst ratio to
    /// the lawnmower bound (14.0 against 13.1), and Lemma 1 is proved for this split only
    /// (docs/results/dfs.md, "Allocation").
    #[default]
    Paper,
    /// With [`Sharing::Gcs`](crate::explore::dfs::Sharing::Gcs) only: the robots at v go where the nearest unexplored vertex
    /// (a known ROI cell nobody has reached or been sent to) is, in tree distance. Children
    /// whose subtree holds one come first, nearest first, and are split as in line 19; when
    /// no child's subtree holds one but some other part of the tree does, the robots walk
    /// back up (line 24) instead of following a group into a subtree with nothing left to
    /// open; when nothing anywhere is unexplored, Algorithm 1's rule applies. With
    /// [`Sharing::Meet`](crate::explore::dfs::Sharing::Meet) this is the same as [`Allocation::Paper`] (a robot does not know
    /// where the frontier is).
    NearestFrontier,
    /// With [`Sharing::Gcs`](crate::explore::dfs::Sharing::Gcs) only: nearest frontier, with
    /// the robots spread over the frontier instead of halved at a branch. The robots at v
    /// send one robot to each child whose subtree holds a frontier vertex (nearest first),
    /// then more, up to one per frontier vertex of that subtree; robots left over walk back
    /// up when some other part of the tree holds a frontier vertex (else they join the
    /// children, as line 19 would). A robot decides on arriving at a vertex, without
    /// waiting for robots that did not travel with it (at the start: each robot reaching
    /// the root). With [`Sharing::Meet`](crate::explore::dfs::Sharing::Meet) it is
    /// [`Allocation::Paper`].
    Spread,
}

impl Allocation {
    /// Algorithm 1's split (the serde default of saved explorers that predate the choice).
    pub fn paper() -> Allocation {
        Allocation::Paper
    }

    /// Every allocation, the paper's first.
    pub const ALL: [Allocation; 3] = [
        Allocation::Paper,
        Allocation::NearestFrontier,
        Allocation::Spread,
    ];

    /// A stable name (the serde name): `paper`, `nearest_frontier` or `spread`, for reports.
    pub fn name(self) -> &'static str {
        match self {
            Allocation::Paper => "paper",
            Allocation::NearestFrontier => "nearest_frontier",
            Allocation::Spread => "spread",
        }
    }
}

impl fmt::Display for Allocation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The confidence interval [lo, hi] around μ̂_l that the goal score (3) and the labels (4) use:
/// J = hi, (4a) is lo ≥ θ − ε, (4b) is hi ≤ θ + ε (the tie rule of [`BanditState::classify`](crate::planner::bandit::BanditState::classify)
/// unchanged).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ConfidenceBound {
    /// The paper's (3b): [μ̂ − U, μ̂ + U], for reproducing its figures and tables.
    Paper,
    /// The Bernoulli KL form of the beta-binomial mixture confidence sequence
    /// (`planner::bandit::kl_interval`): the same guarantee (Prop. 1 at the same δ), about 4× fewer samples
    /// (40 instead of 210 for a cell at μ̂ = 0.1 with |C| = 100, δ = 10⁻⁴, ε = 0.05). The
    /// field default (docs/results/bandit-bound.md).
    Kl,
}

impl ConfidenceBound {
    /// Both bounds, the paper's first.
    pub const ALL: [ConfidenceBound; 2] = [ConfidenceBound::Paper, ConfidenceBound::Kl];

    /// The paper's (3b): the serde default of saved states that predate the choice.
    pub fn paper() -> ConfidenceBound {
        ConfidenceBound::Paper
    }

    /// What a new field run uses unless its mission file says otherwise: the KL bound, which
    /// classified Table I's μ_worst = 0.8 row in fewer epochs with no mislabelled cell
    /// (docs/results/bandit-bound.md).
    pub(crate) fn field_default() -> ConfidenceBound {
        ConfidenceBound::Kl
    }

    /// A stable name (the serde name): `paper` or `kl`.
    pub fn name(self) -> &'static str {
        match self {
            ConfidenceBound::Paper => "paper",
            ConfidenceBound::Kl => "kl",
        }
    }
}

impl fmt::Display for ConfidenceBound {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}
