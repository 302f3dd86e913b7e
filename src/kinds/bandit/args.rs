//! The spatial classification's choices on the command line: the planner's confidence
//! bound (`fleetmap demo --bandit --bound`, `experiment bandit --bound`, `bench plan --bound`)
//! and IP formulation (`fleetmap plan --model`, `bench plan --model`).

use clap::ValueEnum;
use fleetmap_core::planner::bandit::ConfidenceBound;
use fleetmap_core::planner::ip::Model;

/// The confidence interval behind the goal score (3) and the labels (4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum BoundArg {
    /// The paper's (3b), as printed.
    Paper,
    /// The KL form of the beta-binomial mixture confidence sequence: the same guarantee
    /// (Prop. 1 at the same δ), fewer samples (docs/results/bandit-bound.md).
    Kl,
}

impl BoundArg {
    /// The planner's bound.
    pub fn bound(self) -> ConfidenceBound {
        match self {
            BoundArg::Paper => ConfidenceBound::Paper,
            BoundArg::Kl => ConfidenceBound::Kl,
        }
    }
}

/// Which formulation to solve.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum ModelArg {
    /// The reformulated model (same optimum, much faster).
    Fast,
    /// The paper's model exactly as written (slow; the reference).
    Plain,
}

impl From<ModelArg> for Model {
    fn from(m: ModelArg) -> Model {
        match m {
            ModelArg::Fast => Model::Fast,
            ModelArg::Plain => Model::Plain,
        }
    }
}
