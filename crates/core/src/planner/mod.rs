//! The spatial-classification planner of the bandit paper: UCB epoch goals (eq. 3–4), the
//! integer program (eq. 7–11), linear-assignment re-pairing (§III-C) and baselines.
//!
//! | module | what |
//! |---|---|
//! | [`grid`] | G, O, R and the king's-move neighbourhoods N(l), N_c(l) |
//! | [`scenario`] | IP scenario files (docs/ip-scenario.md) and validated instances |
//! | [`bandit`] | UCB (3), keep/reject sets (4), the APT variant, the bound P_max (12)–(14) |
//! | [`baselines`] | the goal rules of §VI-5: Random, GreedyCov, GreedyTrav |
//! | [`plan`] | a plan: cells per vehicle and sensing cycle, and the models' timelines |
//! | [`ip`] | the IP (11) with (7)–(10): the paper's plain model and the fast model |
//! | `assign` | linear-assignment re-pairing of §III-C |
//! | [`check`] | an independent checker of plans |
//! | [`sortie`] | the run on a real fleet: epochs, sorties, measurements (pure state), missions and geofence |

// Without `highs` the integer program is not built, and the helpers only it uses are idle.
#![cfg_attr(not(feature = "highs"), allow(dead_code))]

pub(crate) mod assign;
pub mod bandit;
pub mod baselines;
pub mod check;
pub mod grid;
#[cfg(feature = "highs")]
pub mod ip;
pub mod plan;
pub mod scenario;
pub mod sortie;
