//! The spatial-classification section of a mission file: `[classification]` and its
//! `[classification.green]` measurement, with their defaults.

use super::*;

/// `[classification.green]`: the green-pixel measurement of the bandit paper's hardware
/// test (§V: OpenCV counts green pixels in each image). The paper gives no numbers; these
/// are ours.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GreenDef {
    /// Lower HSV bound, OpenCV scale: H 0–179, S 0–255, V 0–255.
    #[serde(default = "default_hsv_min")]
    pub hsv_min: [u8; 3],
    /// Upper HSV bound (inclusive), same scale; each channel ≥ the lower bound.
    #[serde(default = "default_hsv_max")]
    pub hsv_max: [u8; 3],
    /// An image is a positive measurement (ν_l = 1) when at least this fraction of its
    /// pixels is green, 0 < x ≤ 1.
    #[serde(default = "default_fraction_threshold")]
    pub fraction_threshold: f64,
}

fn default_hsv_min() -> [u8; 3] {
    [35, 60, 40]
}
fn default_hsv_max() -> [u8; 3] {
    [85, 255, 255]
}
fn default_fraction_threshold() -> f64 {
    0.2
}

impl Default for GreenDef {
    fn default() -> Self {
        GreenDef {
            hsv_min: default_hsv_min(),
            hsv_max: default_hsv_max(),
            fraction_threshold: default_fraction_threshold(),
        }
    }
}

/// `[classification]`: the bandit high-level planner (eq. 3–4) and the IP low-level planner
/// (eq. 7–11). Defaults are the paper's simulation defaults (§VI and Fig. 2).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClassificationDef {
    /// θ ∈ (0, 1): a cell is interesting when μ_l ≥ θ (eq. 1). Default 0.5.
    #[serde(default = "default_theta")]
    pub theta: f64,
    /// ε: labelling error tolerance (Assumption 1), 0 < ε < min(θ, 1 − θ). Default 0.05.
    #[serde(default = "default_epsilon")]
    pub epsilon: f64,
    /// δ ∈ (0, 1): labelling error probability (eq. 2, 3b). Default 0.0001.
    #[serde(default = "default_delta")]
    pub delta: f64,
    /// The confidence interval behind the goal score (3) and the labels (4): `"kl"` (the
    /// default: the KL form of the beta-binomial mixture confidence sequence, same guarantee
    /// as Prop. 1 at the same δ, about 4× fewer samples; docs/results/bandit-bound.md) or
    /// `"paper"` ((3b) as printed). A saved run resumes with the bound it started with.
    #[serde(default = "ConfidenceBound::field_default")]
    pub bound: ConfidenceBound,
    /// D ≥ 1: epoch goals chosen per epoch (Algorithm 1 step 3). Default 8.
    #[serde(default = "default_epoch_goals")]
    pub epoch_goals: u32,
    /// B ≥ 1: measurements (images) per visit of an unclassified cell. Default 10.
    #[serde(default = "default_batch_size")]
    pub batch_size: u32,
    /// Td ≥ 2: drone moves per sensing cycle (battery limit). Default 8.
    #[serde(default = "default_drone_cycle_steps")]
    pub drone_cycle_steps: u32,
    /// Tc ≥ 2: station moves per sensing cycle; Td must be a multiple (γ = Td/Tc). Default 4.
    #[serde(default = "default_station_cycle_steps")]
    pub station_cycle_steps: u32,
    /// K ≥ 1: most sensing cycles per epoch the IP may use (eq. 6). Default 4.
    #[serde(default = "default_max_cycles")]
    pub max_cycles: u32,
    /// C ≥ 1: most drones on one station at a cycle's start and end (eq. 10); absent = no
    /// limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub charger_capacity: Option<u32>,
    /// The green-pixel measurement.
    #[serde(default)]
    pub green: GreenDef,
}

fn default_theta() -> f64 {
    0.5
}
fn default_epsilon() -> f64 {
    0.05
}
fn default_delta() -> f64 {
    0.0001
}
fn default_epoch_goals() -> u32 {
    8
}
fn default_batch_size() -> u32 {
    10
}
fn default_drone_cycle_steps() -> u32 {
    8
}
fn default_station_cycle_steps() -> u32 {
    4
}
fn default_max_cycles() -> u32 {
    4
}

impl Default for ClassificationDef {
    fn default() -> Self {
        ClassificationDef {
            theta: default_theta(),
            epsilon: default_epsilon(),
            delta: default_delta(),
            bound: ConfidenceBound::field_default(),
            epoch_goals: default_epoch_goals(),
            batch_size: default_batch_size(),
            drone_cycle_steps: default_drone_cycle_steps(),
            station_cycle_steps: default_station_cycle_steps(),
            max_cycles: default_max_cycles(),
            charger_capacity: None,
            green: GreenDef::default(),
        }
    }
}
