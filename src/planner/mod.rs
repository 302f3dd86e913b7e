//! The spatial-classification planner of the bandit paper: UCB epoch goals (eq. 3–4), the
//! integer program (eq. 7–11), linear-assignment re-pairing (§III-C) and baselines.
