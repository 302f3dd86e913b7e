//! The study's command-line arguments (`fleetmap experiment dfs`, clap) and the choices
//! they name.

use super::*;

/// The speed ratio S_r / S_p of a configuration: a number > 1, or a static ROI.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum SpeedRatio {
    /// S_p = 0.
    Static,
    /// S_r / S_p.
    Ratio(f64),
}

impl SpeedRatio {
    /// S_p for S_r = 1.
    pub(crate) fn roi_speed(self) -> f64 {
        match self {
            SpeedRatio::Static => 0.0,
            SpeedRatio::Ratio(r) => 1.0 / r,
        }
    }
}

impl fmt::Display for SpeedRatio {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SpeedRatio::Static => f.write_str("static"),
            SpeedRatio::Ratio(r) => write!(f, "{r}"),
        }
    }
}

/// A speed ratio that is neither a number greater than 1 nor `static` (the text given).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("speed ratio {0:?}: expected a number greater than 1 (S_r > S_p) or \"static\"")]
pub struct BadSpeedRatio(pub String);

impl FromStr for SpeedRatio {
    type Err = BadSpeedRatio;
    fn from_str(s: &str) -> Result<Self, BadSpeedRatio> {
        if s.eq_ignore_ascii_case("static") || s.eq_ignore_ascii_case("inf") {
            return Ok(SpeedRatio::Static);
        }
        match s.parse::<f64>() {
            Ok(r) if r.is_finite() && r > 1.0 => Ok(SpeedRatio::Ratio(r)),
            _ => Err(BadSpeedRatio(s.to_string())),
        }
    }
}

impl Serialize for SpeedRatio {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            SpeedRatio::Static => s.serialize_str("static"),
            SpeedRatio::Ratio(r) => s.serialize_f64(*r),
        }
    }
}

/// Which sharing modes to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum SharingChoice {
    /// Vertex states through the GCS (the default; Lemma 1 holds).
    Gcs,
    /// Vertex states exchanged only when robots meet (the paper's stated model).
    Meet,
    /// Both, on the same ROIs.
    Both,
}

impl SharingChoice {
    pub(super) fn modes(self) -> Vec<Sharing> {
        match self {
            SharingChoice::Gcs => vec![Sharing::Gcs],
            SharingChoice::Meet => vec![Sharing::Meet],
            SharingChoice::Both => vec![Sharing::Gcs, Sharing::Meet],
        }
    }
}

/// Which allocations to run (with GCS sharing; meeting-only sharing always runs the paper's).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum AllocationChoice {
    /// Algorithm 1's split ([`Allocation::Paper`]).
    Paper,
    /// Idle robots to the nearest unexplored vertex ([`Allocation::NearestFrontier`]).
    NearestFrontier,
    /// The robots spread over the frontier ([`Allocation::Spread`]).
    Spread,
    /// The paper's and nearest frontier, on the same ROIs.
    Both,
}

impl AllocationChoice {
    pub(super) fn allocations(self, sharing: Sharing) -> Vec<Allocation> {
        match (sharing, self) {
            // Nearest-frontier needs the global view: with meetings it is the paper's rule.
            (Sharing::Meet, _) | (_, AllocationChoice::Paper) => vec![Allocation::Paper],
            (_, AllocationChoice::NearestFrontier) => vec![Allocation::NearestFrontier],
            (_, AllocationChoice::Spread) => vec![Allocation::Spread],
            (_, AllocationChoice::Both) => vec![Allocation::Paper, Allocation::NearestFrontier],
        }
    }
}

/// Parameters of `fleetmap experiment dfs`.
#[derive(Clone, Debug, clap::Args)]
pub struct DfsArgs {
    /// Trials per configuration.
    #[arg(long, default_value_t = 100)]
    pub trials: usize,
    /// Seed of the random ROIs and directions.
    #[arg(long, default_value_t = 2019)]
    pub seed: u64,
    /// Directory for the CSV, the JSON summary and the PNG plots (created if missing).
    #[arg(long, value_name = "DIR", default_value = "experiment-dfs")]
    pub out: PathBuf,
    /// How robots share vertex states.
    #[arg(long, value_enum, default_value_t = SharingChoice::Gcs)]
    pub sharing: SharingChoice,
    /// How the robots at a vertex are allocated (with GCS sharing).
    #[arg(long, value_enum, default_value_t = AllocationChoice::Paper)]
    pub allocation: AllocationChoice,
    /// Which sweeps to run (comma-separated).
    #[arg(
        long,
        value_delimiter = ',',
        value_enum,
        default_value = "cells,robots,ratio"
    )]
    pub sweeps: Vec<Sweep>,
    /// Numbers of ROI cells for Fig. 7b (comma-separated).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "40,60,80,100,120,140,160,180,200"
    )]
    pub cells: Vec<usize>,
    /// Numbers of robots for Fig. 7c (comma-separated, 1..=255).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1,2,4,8,12,16,20,24,28,32"
    )]
    pub robots: Vec<usize>,
    /// Speed ratios S_r/S_p for Fig. 7d (comma-separated; `static` for S_p = 0).
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "1.5,2,2.5,3,3.5,4,4.5,5,static"
    )]
    pub ratios: Vec<SpeedRatio>,
    /// ROI cells when another variable is swept.
    #[arg(long, default_value_t = 120)]
    pub(crate) base_cells: usize,
    /// Robots when another variable is swept.
    #[arg(long, default_value_t = 20)]
    pub(crate) base_robots: usize,
    /// Speed ratio when another variable is swept.
    #[arg(long, default_value = "2.5")]
    pub(crate) base_ratio: SpeedRatio,
    /// Print the JSON summary on stdout instead of the table.
    #[arg(long)]
    pub json: bool,
}

impl DfsArgs {
    /// The paper's defaults with `trials` trials (for tests and benches).
    pub fn paper(trials: usize, seed: u64, out: PathBuf) -> DfsArgs {
        DfsArgs {
            trials,
            seed,
            out,
            sharing: SharingChoice::Gcs,
            allocation: AllocationChoice::Paper,
            sweeps: vec![Sweep::Cells, Sweep::Robots, Sweep::Ratio],
            cells: vec![40, 60, 80, 100, 120, 140, 160, 180, 200],
            robots: vec![1, 2, 4, 8, 12, 16, 20, 24, 28, 32],
            ratios: [1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5, 5.0]
                .map(SpeedRatio::Ratio)
                .into_iter()
                .chain([SpeedRatio::Static])
                .collect(),
            base_cells: 120,
            base_robots: 20,
            base_ratio: SpeedRatio::Ratio(2.5),
            json: false,
        }
    }

    pub(super) fn validate(&self) -> Result<(), DfsStudyError> {
        let bad = |m: String| Err(DfsStudyError::Invalid(m));
        if self.trials == 0 {
            return bad("--trials must be at least 1".into());
        }
        for &c in self.cells.iter().chain([&self.base_cells]) {
            if !(1..=100_000).contains(&c) {
                return bad(format!("{c} cells: expected 1 to 100000"));
            }
        }
        for &r in self.robots.iter().chain([&self.base_robots]) {
            if !(1..=255).contains(&r) {
                return bad(format!("{r} robots: expected 1 to 255"));
            }
        }
        if configurations(self).is_empty() {
            return bad("nothing to sweep: no --sweeps, or their value lists are empty".into());
        }
        Ok(())
    }
}
