//! Monte Carlo studies that reproduce the papers' tables and figures (CSV, JSON, PNG).

pub mod bandit;
pub mod dfs;
pub mod fastplain;
pub mod runway;
