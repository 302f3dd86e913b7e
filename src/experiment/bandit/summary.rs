//! A variant's summary over its trials: medians with 0.1 / 0.9 quantiles (a row of a
//! table).

use super::{StudyConfig, TrialResult, paper};
use serde::{Deserialize, Serialize};

/// The q-quantile of `v` with linear interpolation between order statistics (Hyndman & Fan
/// type 7, numpy's default); `None` for an empty slice.
pub(crate) fn quantile(v: &[f64], q: f64) -> Option<f64> {
    if v.is_empty() {
        return None;
    }
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let h = (s.len() - 1) as f64 * q.clamp(0.0, 1.0);
    let (lo, hi) = (h.floor() as usize, h.ceil() as usize);
    Some(s[lo] + (h - lo as f64) * (s[hi] - s[lo]))
}

/// Median and 0.1 / 0.9 quantiles.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    /// 0.5-quantile.
    pub median: f64,
    /// 0.1-quantile.
    pub q10: f64,
    /// 0.9-quantile.
    pub q90: f64,
    /// Number of values.
    pub n: usize,
}

impl Spread {
    /// The spread of `v` (`None` if empty).
    pub fn of(v: &[f64]) -> Option<Spread> {
        Some(Spread {
            median: quantile(v, 0.5)?,
            q10: quantile(v, 0.1)?,
            q90: quantile(v, 0.9)?,
            n: v.len(),
        })
    }
}

/// The summary of one variant (a row of a table).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct VariantSummary {
    /// The variant's configuration.
    pub config: StudyConfig,
    /// Trials run.
    pub trials: usize,
    /// Solve time per epoch, seconds, over every epoch of every trial.
    pub solve_seconds: Option<Spread>,
    /// Epochs to classify every interesting cell (finished trials only).
    pub epochs_interesting: Option<Spread>,
    /// Epochs to classify every cell (finished trials only).
    pub epochs_all: Option<Spread>,
    /// Trials that hit `max_epochs` or failed.
    pub censored: usize,
    /// Total labelling errors over all trials (Prop. 1 bounds P(any error) by δ per trial).
    pub label_errors: usize,
    /// Epochs whose plan needed more than one sensing cycle.
    pub(crate) multi_cycle_epochs: usize,
    /// P_max of Proposition 2 over the trials' worlds (`None` for a bound it is not proved
    /// for, see [`TrialResult::p_max`]).
    #[serde(default)]
    pub p_max: Option<Spread>,
    /// The paper's row this variant reproduces ([`paper::row_for`]), set by
    /// [`Study::summarise`].
    #[serde(default)]
    pub paper: Option<paper::PaperRow>,
    /// Mean fraction of interesting / uninteresting cells classified after each epoch
    /// (finished trials count as fully classified after they end) — the curves of Fig. 5/6.
    pub progress: Vec<(f64, f64)>,
}

/// Summarise the trials of one variant.
pub(crate) fn summarise(config: &StudyConfig, trials: &[TrialResult]) -> VariantSummary {
    let solve: Vec<f64> = trials
        .iter()
        .flat_map(|t| t.epochs.iter().map(|e| e.solve_seconds))
        .collect();
    let ei: Vec<f64> = trials
        .iter()
        .filter_map(|t| t.epochs_interesting.map(|e| e as f64))
        .collect();
    let ea: Vec<f64> = trials
        .iter()
        .filter_map(|t| t.epochs_all.map(|e| e as f64))
        .collect();
    let longest = trials.iter().map(|t| t.epochs.len()).max().unwrap_or(0);
    let progress = (0..longest)
        .map(|p| {
            let (mut si, mut su) = (0.0, 0.0);
            for t in trials {
                let ni = t.n_interesting.max(1) as f64;
                let nu = (t.n_cells - t.n_interesting).max(1) as f64;
                let e = t.epochs.get(p).or(t.epochs.last());
                if let Some(e) = e {
                    si += e.interesting_classified as f64 / ni;
                    su += e.uninteresting_classified as f64 / nu;
                }
            }
            let n = trials.len().max(1) as f64;
            (si / n, su / n)
        })
        .collect();
    VariantSummary {
        config: config.clone(),
        trials: trials.len(),
        solve_seconds: Spread::of(&solve),
        epochs_interesting: Spread::of(&ei),
        epochs_all: Spread::of(&ea),
        censored: trials
            .iter()
            .filter(|t| t.epochs_all.is_none() || t.failure.is_some())
            .count(),
        label_errors: trials.iter().map(|t| t.label_errors).sum(),
        multi_cycle_epochs: trials
            .iter()
            .flat_map(|t| &t.epochs)
            .filter(|e| e.cycles > 1)
            .count(),
        p_max: Spread::of(&trials.iter().filter_map(|t| t.p_max).collect::<Vec<f64>>()),
        paper: None,
        progress,
    }
}
