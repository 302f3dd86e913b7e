//! The high-level planner of the bandit paper (§III-A, Algorithm 1): upper confidence bounds
//! (3a, 3b), the top-D epoch goals among the unclassified cells, the keep and reject sets
//! (4a, 4b), and the completion bound P_max of Proposition 2 (12)–(14).
//!
//! Beyond the paper, a second confidence interval can replace (3b) in both the goal score (3)
//! and the labels (4): [`ConfidenceBound::Kl`], the Bernoulli KL form of Robbins' beta-binomial
//! mixture confidence sequence (`kl_interval`). It keeps Prop. 1's guarantee at the same δ
//! (P(some cell is ever mislabelled) ≤ δ, over all cells and all sample counts) and needs about
//! a quarter of (3b)'s samples; the proof and its conditions are in `kl_interval` and in
//! docs/results/bandit-bound.md.
//!
//! Conventions:
//! * **Logarithms.** (3b) writes `log` and `log₂`: `log` is the natural logarithm, `log₂` the
//!   binary one, exactly where written; (13) writes `log` only: natural logarithms.
//! * **No samples.** A cell without samples has μ̂ = U = ∞, hence J = ∞ (3a): it is chosen
//!   before any sampled cell.
//! * **Ties.** Cells with equal J (in particular all the unsampled ones, J = ∞) are ranked by
//!   their index in the candidate list, which is sorted row-major (by row, then column): the
//!   result is deterministic and independent of hashing or sort stability.
//! * **|C|.** U uses the number of candidate cells |C| given to [`BanditState::new`].
//! * **Monotone sets.** The paper argues K and R are monotone because U is non-increasing in
//!   |H_l|. That is not enough on its own (μ̂ moves with new data, and U(n) increases between
//!   n = 1 and 2 when log(12|C|/δ) < 2/ln 2), so monotonicity is *enforced*: a cell classified
//!   at some epoch stays in its set, and [`BanditState::record`] ignores measurements of
//!   classified cells (Algorithm 1 only measures unclassified cells, §V). With that, (4) is
//!   evaluated only for unclassified cells, which is exactly what the paper's sets become.
//!   Prop. 1 is unaffected: its proof bounds, for each cell, the probability that the
//!   confidence interval ever misses μ_l, whatever the sampling rule.
//! * **Both (4a) and (4b).** A cell can satisfy both only when U ≤ ε, i.e. μ̂ − U ≥ θ − ε and
//!   μ̂ + U ≤ θ + ε put μ_l in (θ − ε, θ + ε) on the good event of Prop. 1, where either label
//!   is correct (Assumption 1). It is labelled by the side of θ its mean is on (keep if
//!   μ̂ ≥ θ, as in the definition (1) of S_θ; reject otherwise).

use crate::geo::Cell;
use serde::{Deserialize, Serialize};

/// Why bandit parameters are rejected.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BanditError {
    /// A parameter is outside its range.
    #[error("{0}")]
    Invalid(String),
}

/// The classification of one candidate cell.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Label {
    /// In neither set yet.
    Unclassified,
    /// In the keep set K (classified interesting, eq. 4a).
    Keep,
    /// In the reject set R (classified uninteresting, eq. 4b).
    Reject,
}

/// The bandit's state (serialisable for crash-safe runs): the candidate cells C, the
/// measurement history H_l summarised by its size and its number of ones, the labels, and
/// the epoch each cell was classified at.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BanditState {
    /// θ ∈ (0, 1): the interest threshold (1).
    pub theta: f64,
    /// ε > 0: the labelling tolerance (Assumption 1).
    pub epsilon: f64,
    /// δ ∈ (0, 1): the labelling error probability (2).
    pub delta: f64,
    /// C: the candidate cells, sorted row-major.
    pub cells: Vec<Cell>,
    /// Σ_{h ∈ H_l} h: the positive measurements of each cell.
    pub ones: Vec<u64>,
    /// |H_l|: the measurements of each cell.
    pub samples: Vec<u64>,
    /// The label of each cell.
    pub labels: Vec<Label>,
    /// The epoch p at whose end (update to p + 1) each cell was classified.
    pub classified_at: Vec<Option<u64>>,
    /// The current epoch p (number of updates so far).
    pub epoch: u64,
    /// The base of `log` in (3b) (natural unless a study asks otherwise; unused by
    /// [`ConfidenceBound::Kl`]).
    #[serde(default)]
    pub log_base: LogBase,
    /// The confidence interval behind (3) and (4). Saved states from before the choice existed
    /// ran the paper's (3b), so that is their serde default; [`BanditState::new`] also starts
    /// with the paper's, and the field runner and the study set what the mission or the
    /// command line asks for.
    #[serde(default = "ConfidenceBound::paper")]
    pub bound: ConfidenceBound,
}

pub use crate::mission::strategy::ConfidenceBound;

/// kl(p, q) = p ln(p/q) + (1 − p) ln((1 − p)/(1 − q)), the Kullback–Leibler divergence between
/// Bernoulli(p) and Bernoulli(q), in nats, with 0 · ln 0 = 0; +∞ when q ∈ {0, 1} and p ≠ q.
/// Arguments are clamped to [0, 1].
pub(crate) fn bernoulli_kl(p: f64, q: f64) -> f64 {
    let (p, q) = (p.clamp(0.0, 1.0), q.clamp(0.0, 1.0));
    let term = |a: f64, b: f64| {
        if a <= 0.0 {
            0.0
        } else if b <= 0.0 {
            f64::INFINITY
        } else {
            a * (a / b).ln()
        }
    };
    (term(p, q) + term(1.0 - p, 1.0 - q)).max(0.0)
}

/// ln P(Bin(n, k/n) = k): the log-probability of the observed count under the binomial whose
/// mean is the observed frequency (≤ 0, and ≥ −ln(n + 1) since k is a mode). Exact sums of
/// logarithms, O(min(k, n − k)).
fn ln_binomial_at_mean(k: u64, n: u64) -> f64 {
    if n == 0 || k == 0 || k >= n {
        return 0.0;
    }
    let f = n - k;
    let m = k.min(f);
    // ln C(n, m) = Σ_{i=1..m} ln((n − m + i) / i).
    let ln_choose: f64 = (1..=m).map(|i| ((n - m + i) as f64 / i as f64).ln()).sum();
    let (kf, ff, nf) = (k as f64, f as f64, n as f64);
    (ln_choose + kf * (kf / nf).ln() + ff * (ff / nf).ln()).min(0.0)
}

/// β of the KL bound for a cell with `ones` positive measurements out of `n`, among
/// `n_cells = |C|` candidates, at level δ: the interval is {q : n·kl(μ̂, q) ≤ β}, with
///
/// β = ln(|C|/δ) + ln(n + 1) + ln P(Bin(n, μ̂) = ones).
///
/// This is the beta-binomial mixture of Robbins (1970) with a uniform Beta(1, 1) prior,
/// rewritten in KL form: the likelihood ratio mixed over the prior,
/// M_n(μ) = ∫₀¹ pˢ(1 − p)ⁿ⁻ˢ dp / (μˢ(1 − μ)ⁿ⁻ˢ) = 1 / ((n + 1) C(n, S) μˢ(1 − μ)ⁿ⁻ˢ),
/// satisfies ln M_n(μ) = n·kl(μ̂, μ) − (β − ln(|C|/δ)), so M_n(μ) ≥ |C|/δ exactly when
/// n·kl(μ̂, μ) ≥ β. β ≥ ln(|C|/δ) (the observed count is a mode of Bin(n, μ̂)) and
/// β ≤ ln(|C|(n + 1)/δ): beyond ln(|C|/δ) it grows like ½ ln n (a plain union bound over n
/// would add about 2 ln n).
pub(crate) fn kl_threshold(ones: u64, n: u64, n_cells: usize, delta: f64) -> f64 {
    (n_cells.max(1) as f64 / delta).ln()
        + ((n + 1) as f64).ln()
        + ln_binomial_at_mean(ones.min(n), n)
}

/// The KL confidence interval [lo, hi] of a cell with `ones` positive measurements out of `n`
/// among `n_cells = |C|` candidates, at level δ; (−∞, +∞) when `n = 0`.
///
/// lo = min{q ≤ μ̂ : n·kl(μ̂, q) ≤ β}, hi = max{q ≥ μ̂ : n·kl(μ̂, q) ≤ β}, β =
/// [`kl_threshold`], found by bisection (kl(μ̂, ·) is convex with its minimum 0 at μ̂);
/// the bisection returns the outer end of its last bracket, so the interval computed contains
/// the exact one.
///
/// **Guarantee (Prop. 1 at the same δ).** P(∃ cell l, ∃ n ≥ 1: μ_l ∉ [lo, hi]) ≤ δ.
/// Proof: fix a cell with mean μ ∈ (0, 1). Its measurements, in the order taken, are i.i.d.
/// Bernoulli(μ) whatever rule chose when to take them (the "stack of rewards" model of a
/// bandit: Lattimore & Szepesvári, *Bandit Algorithms*, 2020, §4.6), so M_n(μ) of
/// [`kl_threshold`] is a mixture over p of likelihood-ratio martingales, each with
/// E[M_{n+1} | past] = M_n since E[(p/μ)^X ((1 − p)/(1 − μ))^{1−X}] = 1, and M_0 = 1.
/// Ville's inequality (Ville 1939; Howard, Ramdas, McAuliffe & Sekhon, Ann. Statist. 49(2),
/// 2021) gives P(∃ n: M_n(μ) ≥ |C|/δ) ≤ δ/|C|, and μ ∉ [lo, hi] implies n·kl(μ̂, μ) > β, i.e.
/// M_n(μ) > |C|/δ. If μ ∈ {0, 1} the data are constant, μ̂ = μ and μ is never excluded.
/// A union over the |C| cells gives δ. The bound holds for every n at once, so it does not
/// matter that samples come in batches of B per visit, nor how often (4) is checked; with
/// (4a)/(4b) as in the paper, Prop. 1's argument then gives P(any cell mislabelled) ≤ δ.
pub(crate) fn kl_interval(ones: u64, n: u64, n_cells: usize, delta: f64) -> (f64, f64) {
    if n == 0 {
        return (f64::NEG_INFINITY, f64::INFINITY);
    }
    let ones = ones.min(n);
    let m = ones as f64 / n as f64;
    let beta = kl_threshold(ones, n, n_cells, delta);
    let inside = |q: f64| n as f64 * bernoulli_kl(m, q) <= beta;
    // Bisection between a point inside (μ̂) and an end; returns the end-side bracket bound.
    let search = |end: f64| -> f64 {
        if inside(end) {
            return end;
        }
        let (mut a, mut b) = (m, end);
        for _ in 0..200 {
            let c = 0.5 * (a + b);
            if c == a || c == b {
                break;
            }
            if inside(c) {
                a = c;
            } else {
                b = c;
            }
        }
        b
    };
    (search(0.0), search(1.0))
}

/// The base of the logarithms written `log` in (3b).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum LogBase {
    /// Natural logarithms: the mathematical reading of the paper's `log`, and the default.
    #[default]
    Natural,
    /// Base-10 logarithms: a sensitivity option only (see docs/results/planner.md —
    /// the paper's Table I numbers are much closer to what this base gives). The `log₂` in
    /// (3b) stays base 2. Prop. 1's guarantee is stated for natural logarithms.
    Ten,
}

/// U_l(p, δ) of (3b) for a cell with `n = |H_l|` samples among `n_cells = |C|` candidates,
/// natural logarithms; ∞ when `n = 0`.
pub fn ucb_width(n: u64, n_cells: usize, delta: f64) -> f64 {
    ucb_width_base(n, n_cells, delta, LogBase::Natural)
}

/// U_l(p, δ) of (3b) with the given base for `log` (`log₂` is always base 2).
pub(crate) fn ucb_width_base(n: u64, n_cells: usize, delta: f64, base: LogBase) -> f64 {
    if n == 0 {
        return f64::INFINITY;
    }
    let n = n as f64;
    let log = |x: f64| match base {
        LogBase::Natural => x.ln(),
        LogBase::Ten => x.log10(),
    };
    let inner = 2.0 * log((2.0 * n).log2()) + log(12.0 * n_cells as f64 / delta);
    2.0 * (inner / (2.0 * n)).sqrt()
}

impl BanditState {
    /// A fresh state (p = 0, K = R = ∅, no measurements) over the candidate cells `cells`
    /// (duplicates removed, sorted row-major).
    pub fn new(
        cells: Vec<Cell>,
        theta: f64,
        epsilon: f64,
        delta: f64,
    ) -> Result<BanditState, BanditError> {
        let bad = |m: &str| Err(BanditError::Invalid(m.into()));
        if !(theta > 0.0 && theta < 1.0) {
            return bad("θ must be in (0, 1)");
        }
        if !(epsilon > 0.0 && epsilon.is_finite()) {
            return bad("ε must be positive");
        }
        if !(delta > 0.0 && delta < 1.0) {
            return bad("δ must be in (0, 1)");
        }
        let mut cells = cells;
        cells.sort_unstable();
        cells.dedup();
        if cells.is_empty() {
            return bad("there must be at least one candidate cell");
        }
        let n = cells.len();
        Ok(BanditState {
            theta,
            epsilon,
            delta,
            cells,
            ones: vec![0; n],
            samples: vec![0; n],
            labels: vec![Label::Unclassified; n],
            classified_at: vec![None; n],
            epoch: 0,
            log_base: LogBase::Natural,
            bound: ConfidenceBound::Paper,
        })
    }

    /// |C|.
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether there are no candidates (never true for a built state).
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The candidate index of `cell`, if it is a candidate.
    pub fn index_of(&self, cell: Cell) -> Option<usize> {
        self.cells.binary_search(&cell).ok()
    }

    /// μ̂_l (3a); ∞ without samples.
    pub fn mean(&self, l: usize) -> f64 {
        if self.samples[l] == 0 {
            f64::INFINITY
        } else {
            self.ones[l] as f64 / self.samples[l] as f64
        }
    }

    /// U_l(p, δ) of (3b) (the paper's half-width, whichever bound the state uses; see
    /// [`BanditState::interval`]).
    pub fn width(&self, l: usize) -> f64 {
        ucb_width_base(self.samples[l], self.len(), self.delta, self.log_base)
    }

    /// The confidence interval [lo, hi] of cell `l` under [`BanditState::bound`]:
    /// [μ̂_l − U_l, μ̂_l + U_l] for the paper's (3b), `kl_interval` for the KL bound;
    /// (−∞, +∞) without samples.
    pub fn interval(&self, l: usize) -> (f64, f64) {
        if self.samples[l] == 0 {
            return (f64::NEG_INFINITY, f64::INFINITY);
        }
        match self.bound {
            ConfidenceBound::Paper => {
                let (m, u) = (self.mean(l), self.width(l));
                (m - u, m + u)
            }
            ConfidenceBound::Kl => {
                kl_interval(self.ones[l], self.samples[l], self.len(), self.delta)
            }
        }
    }

    /// J(l, p, δ) (3a): the upper end of the interval, μ̂_l + U_l with (3b) (the KL-UCB index
    /// of Garivier & Cappé, COLT 2011, with the KL bound); ∞ without samples.
    pub(crate) fn score(&self, l: usize) -> f64 {
        self.interval(l).1
    }

    /// Whether cell `l` is still unclassified.
    pub fn is_unclassified(&self, l: usize) -> bool {
        self.labels[l] == Label::Unclassified
    }

    /// The unclassified cells C \ (K ∪ R), by index.
    pub fn unclassified(&self) -> Vec<usize> {
        (0..self.len())
            .filter(|&l| self.is_unclassified(l))
            .collect()
    }

    /// Whether K ∪ R = C (Algorithm 1 terminates).
    pub fn is_done(&self) -> bool {
        self.labels.iter().all(|&l| l != Label::Unclassified)
    }

    /// The keep set K (cells classified interesting).
    pub fn keep(&self) -> Vec<Cell> {
        self.with_label(Label::Keep)
    }

    /// The reject set R (cells classified uninteresting).
    pub fn reject(&self) -> Vec<Cell> {
        self.with_label(Label::Reject)
    }

    fn with_label(&self, label: Label) -> Vec<Cell> {
        (0..self.len())
            .filter(|&l| self.labels[l] == label)
            .map(|l| self.cells[l])
            .collect()
    }

    /// Step 3 of Algorithm 1: the indices of the top-`d` unclassified cells by J (3),
    /// ties by candidate index.
    pub(crate) fn ucb_goal_indices(&self, d: usize) -> Vec<usize> {
        let mut cand: Vec<(f64, usize)> = self
            .unclassified()
            .into_iter()
            .map(|l| (self.score(l), l))
            .collect();
        cand.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        cand.into_iter().take(d).map(|(_, l)| l).collect()
    }

    /// The improved high level offered next to the faithful one: the `d` *most ambiguous*
    /// unclassified cells by the APT index of Locatelli, Gutzeit and Carpentier (ICML 2016,
    /// the paper's ref. \[18\]), B_l = √|H_l| · (|μ̂_l − θ| + ε), smallest first (unsampled cells,
    /// B = 0, first; ties by candidate index). It spends visits where (4) still needs data
    /// rather than on cells that merely look interesting, and keeps the labelling guarantee:
    /// Prop. 1 depends only on (3b) and (4), not on which cells are sampled.
    pub(crate) fn apt_goal_indices(&self, d: usize) -> Vec<usize> {
        let mut cand: Vec<(f64, usize)> = self
            .unclassified()
            .into_iter()
            .map(|l| {
                let n = self.samples[l];
                let b = if n == 0 {
                    0.0
                } else {
                    (n as f64).sqrt() * ((self.mean(l) - self.theta).abs() + self.epsilon)
                };
                (b, l)
            })
            .collect();
        cand.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        cand.into_iter().take(d).map(|(_, l)| l).collect()
    }

    /// Add `total` measurements of which `ones` are positive to cell `l` (one visit gives B
    /// of them). Ignored, returning `false`, if `l` is already classified or `ones > total`.
    pub fn record(&mut self, l: usize, ones: u64, total: u64) -> bool {
        if l >= self.len() || !self.is_unclassified(l) || ones > total {
            return false;
        }
        self.ones[l] += ones;
        self.samples[l] += total;
        true
    }

    /// Step 5 of Algorithm 1: update K and R by (4a), (4b) from the history so far, then
    /// p ← p + 1. Returns the cells classified by this update.
    pub fn update(&mut self) -> Vec<usize> {
        let newly = self.classify();
        self.epoch += 1;
        newly
    }

    /// Apply (4a), (4b) to the unclassified cells from the history so far *without* ending
    /// the epoch (p is unchanged; cells classified now get `classified_at = p`). Returns the
    /// cells classified now.
    ///
    /// A deviation from Algorithm 1, which applies (4) once per epoch (step 5): the field
    /// runner (`kinds::bandit`) applies it after every measurement, so that a cell
    /// settled in the middle of an epoch is not imaged again in the epoch's later sensing
    /// cycles. Prop. 1 still holds: (15) — [19, Lem. 1], a law-of-the-iterated-logarithm
    /// bound — holds for every sample count n simultaneously, so (4) may be checked after
    /// any number of samples; so does the KL bound's (`kl_interval`).
    pub fn classify(&mut self) -> Vec<usize> {
        let mut newly = Vec::new();
        let (lo, hi) = (self.theta - self.epsilon, self.theta + self.epsilon);
        for l in 0..self.len() {
            if !self.is_unclassified(l) || self.samples[l] == 0 {
                continue;
            }
            let m = self.mean(l);
            let (below, above) = self.interval(l);
            let label = match (below >= lo, above <= hi) {
                // Both (4a) and (4b) at once: μ̂ is within ε of θ and either label meets the
                // criterion (2). Fig. 2 rejects its μ = 0.5 cell, whose mean settles at θ:
                // a tie goes to R unless μ̂ is strictly above θ.
                (true, true) if m > self.theta => Label::Keep,
                (true, true) => Label::Reject,
                (true, false) => Label::Keep,
                (false, true) => Label::Reject,
                (false, false) => continue,
            };
            self.labels[l] = label;
            self.classified_at[l] = Some(self.epoch);
            newly.push(l);
        }
        newly
    }
}

/// Step 3 of Algorithm 1 as cells: the top-`d` unclassified cells by J (3).
pub fn epoch_goals(state: &BanditState, d: usize) -> Vec<Cell> {
    state
        .ucb_goal_indices(d)
        .into_iter()
        .map(|l| state.cells[l])
        .collect()
}

/// Step 5 of Algorithm 1: apply (4) and advance the epoch; returns the newly classified cells.
pub fn update(state: &mut BanditState) -> Vec<Cell> {
    state.update().into_iter().map(|l| state.cells[l]).collect()
}

/// Δ_l = |μ_l − θ| + ε (14).
pub fn gap(mu: f64, theta: f64, epsilon: f64) -> f64 {
    (mu - theta).abs() + epsilon
}

/// P_l of (13): visits of cell l after which (4) classifies it (w.p. 1 − δ), with batch B and
/// |C| = `n_cells`; natural logarithms.
pub(crate) fn visits_needed(delta_l: f64, batch: u32, n_cells: usize, delta: f64) -> f64 {
    let s = (3.0 * n_cells as f64 / delta).sqrt();
    16.0 / (batch as f64 * delta_l * delta_l)
        * (4.0 * s * (192.0 / (delta_l * delta_l) * s).ln()).ln()
}

/// P_max of Proposition 2, eq. (12)–(14) of the paper: with probability ≥ 1 − δ, Algorithm 1
/// terminates within this many epochs, for true means `mu` (one per candidate cell), batch B
/// and D epoch goals.
/// D_Δ is the cell with the smallest Δ_l together with the D − 1 cells with the largest Δ_l.
pub fn p_max(mu: &[f64], theta: f64, epsilon: f64, delta: f64, batch: u32, d: usize) -> f64 {
    let n = mu.len();
    if n == 0 || d == 0 {
        return 0.0;
    }
    let mut by_gap: Vec<(f64, f64)> = mu
        .iter()
        .map(|&m| {
            let g = gap(m, theta, epsilon);
            (g, visits_needed(g, batch, n, delta))
        })
        .collect();
    // Ascending Δ: index 0 is the smallest; the last D − 1 are the largest.
    by_gap.sort_by(|a, b| a.0.total_cmp(&b.0));
    let mut in_d = vec![false; n];
    in_d[0] = true;
    for flag in in_d.iter_mut().skip(1).rev().take(d.saturating_sub(1)) {
        *flag = true;
    }
    let rest: f64 = (0..n).filter(|&i| !in_d[i]).map(|i| by_gap[i].1).sum();
    let worst = (0..n)
        .filter(|&i| in_d[i])
        .map(|i| by_gap[i].1)
        .fold(0.0, f64::max);
    rest / d as f64 + worst
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn width_matches_3b_by_hand() {
        // n = 10, |C| = 100, δ = 1e-4: 2·ln(log2 20) + ln(1.2e7) = 2·1.4638 + 16.3004 = 19.228.
        let inner: f64 = 2.0 * 20f64.log2().ln() + (1.2e7f64).ln();
        assert!((ucb_width(10, 100, 1e-4) - 2.0 * (inner / 20.0).sqrt()).abs() < 1e-12);
        assert!((ucb_width(10, 100, 1e-4) - 1.9610).abs() < 1e-3);
        assert!(ucb_width(0, 100, 1e-4).is_infinite());
        // Non-increasing in n from one batch on (Fig. 2 regime).
        let mut prev = f64::INFINITY;
        for n in (10..5000).step_by(10) {
            let u = ucb_width(n, 100, 1e-4);
            assert!(u <= prev);
            prev = u;
        }
    }

    #[test]
    fn fig2_classifies_the_three_example_cells() {
        // Fig. 2: μ ∈ {0.05, 0.5, 0.95}, θ = 0.5, ε = 0.05, |G| = 100, δ = 1e-4: 0.05 and 0.5
        // go to R, 0.95 to K. Empirical means exactly 0.05, 0.5 and 0.95, in batches of 100
        // (at 0.5, (4a) and (4b) hold in the same epoch: the tie goes to R as in the figure).
        for (ones, want) in [(5, Label::Reject), (50, Label::Reject), (95, Label::Keep)] {
            let cells: Vec<Cell> = (0..100).map(|i| Cell::new(i / 10, i % 10)).collect();
            let mut s = BanditState::new(cells, 0.5, 0.05, 1e-4).unwrap();
            let mut n = 0u64;
            while s.labels[0] == Label::Unclassified && n < 1_000_000 {
                n += 100;
                s.record(0, ones, 100);
                s.update();
            }
            assert_eq!(s.labels[0], want, "{ones} ones per 100");
        }
    }

    #[test]
    fn fig2_with_the_kl_bound_gives_the_same_labels() {
        // The same three cells under both bounds: the same labels (the tie at 50/100 goes to
        // R under either), after (pinned) numbers of samples: half with KL in batches of 100
        // at 0.05 and 0.95, 4.8× fewer at 0.5.
        for (ones, want, paper_n, kl_n) in [
            (5, Label::Reject, 200, 100),
            (50, Label::Reject, 17_400, 3_600),
            (95, Label::Keep, 200, 100),
        ] {
            let mut needed = Vec::new();
            for bound in ConfidenceBound::ALL {
                let cells: Vec<Cell> = (0..100).map(|i| Cell::new(i / 10, i % 10)).collect();
                let mut s = BanditState::new(cells, 0.5, 0.05, 1e-4).unwrap();
                s.bound = bound;
                let mut n = 0u64;
                while s.labels[0] == Label::Unclassified && n < 1_000_000 {
                    n += 100;
                    s.record(0, ones, 100);
                    s.update();
                }
                assert_eq!(s.labels[0], want, "{ones} ones per 100, {bound}");
                needed.push(n);
            }
            assert_eq!(
                needed,
                [paper_n, kl_n],
                "{ones} ones per 100: samples [paper, kl]"
            );
            assert!(2 * kl_n <= paper_n);
        }
    }

    #[test]
    fn bernoulli_kl_by_hand() {
        // kl(0.1, 0.55) = 0.1 ln(0.1/0.55) + 0.9 ln(0.9/0.45).
        let want = 0.1 * (0.1f64 / 0.55).ln() + 0.9 * 2f64.ln();
        assert!((bernoulli_kl(0.1, 0.55) - want).abs() < 1e-15);
        assert_eq!(bernoulli_kl(0.3, 0.3), 0.0);
        assert_eq!(bernoulli_kl(0.0, 0.0), 0.0);
        assert_eq!(bernoulli_kl(1.0, 1.0), 0.0);
        assert!((bernoulli_kl(0.0, 0.5) - 2f64.ln()).abs() < 1e-15);
        assert!(bernoulli_kl(0.2, 1.0).is_infinite());
        assert!(bernoulli_kl(0.2, 0.0).is_infinite());
        // β by hand: n = 10, 1 one, |C| = 100, δ = 1e-4: ln(1e6) + ln 11 + ln(10 · 0.1 · 0.9⁹).
        let b = 1e6f64.ln() + 11f64.ln() + (10.0 * 0.1 * 0.9f64.powi(9)).ln();
        assert!((kl_threshold(1, 10, 100, 1e-4) - b).abs() < 1e-12);
        // All ones or all zeros: P(Bin(n, μ̂) = S) = 1.
        assert!((kl_threshold(0, 10, 100, 1e-4) - (1e6f64 * 11.0).ln()).abs() < 1e-12);
        assert!((kl_threshold(10, 10, 100, 1e-4) - (1e6f64 * 11.0).ln()).abs() < 1e-12);
    }

    /// The smallest n (a multiple of the batch, so that μ̂ = `mu` exactly) at which a cell
    /// with empirical mean `mu` is labelled, for |C| = 100, δ = 1e-4, θ = 0.5, ε = 0.05.
    fn samples_to_label(mu_tenths: u64, bound: ConfidenceBound) -> u64 {
        let cells: Vec<Cell> = (0..100).map(|i| Cell::new(i / 10, i % 10)).collect();
        let mut s = BanditState::new(cells, 0.5, 0.05, 1e-4).unwrap();
        s.bound = bound;
        let mut n = 0;
        while s.labels[0] == Label::Unclassified {
            s.record(0, mu_tenths, 10);
            n += 10;
            s.classify();
            assert!(n < 100_000);
        }
        n
    }

    #[test]
    fn kl_needs_about_a_quarter_of_the_3b_samples() {
        // Why the KL bound was adopted ("roughly 40 against about 200" at μ = 0.1), exactly.
        use ConfidenceBound::{Kl, Paper};
        for (mu, kl, paper) in [
            (0, 30, 140),
            (1, 40, 210),
            (2, 70, 340),
            (3, 130, 680),
            (7, 130, 680),
            (8, 70, 340),
            (9, 40, 210),
            (10, 30, 140),
        ] {
            assert_eq!(samples_to_label(mu, Kl), kl, "KL at μ̂ = 0.{mu}");
            assert_eq!(samples_to_label(mu, Paper), paper, "(3b) at μ̂ = 0.{mu}");
        }
    }

    #[test]
    fn kl_interval_contains_the_mean_is_narrower_than_3b_and_shrinks() {
        for tenths in 0..=10u64 {
            let mut prev = f64::INFINITY;
            for j in 1..=2000u64 {
                let n = 10 * j;
                let ones = tenths * j;
                let m = ones as f64 / n as f64;
                let (lo, hi) = kl_interval(ones, n, 100, 1e-4);
                assert!(0.0 <= lo && lo <= m && m <= hi && hi <= 1.0, "{ones}/{n}");
                let u = ucb_width(n, 100, 1e-4);
                assert!(hi - m < u && m - lo < u, "{ones}/{n}: [{lo}, {hi}] vs ±{u}");
                assert!(hi - lo <= prev, "{ones}/{n}: wider than with fewer samples");
                prev = hi - lo;
                // The ends are where n·kl(μ̂, q) reaches β (or 0 and 1).
                let beta = kl_threshold(ones, n, 100, 1e-4);
                for q in [lo, hi] {
                    if q > 0.0 && q < 1.0 {
                        let v = n as f64 * bernoulli_kl(m, q);
                        assert!((v - beta).abs() < 1e-6 * beta, "{ones}/{n}: {v} vs {beta}");
                    }
                }
            }
        }
        assert_eq!(
            kl_interval(0, 0, 100, 1e-4),
            (f64::NEG_INFINITY, f64::INFINITY)
        );
    }

    #[test]
    fn kl_interval_covers_the_mean_at_all_times_in_simulation() {
        // 2,000 seeded sequences of up to 500 Bernoulli(μ) samples, one cell, δ = 0.1: the
        // fraction whose interval ever misses μ must be at most δ (Ville's inequality).
        use rand::{RngExt, SeedableRng};
        let delta = 0.1;
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let mus = [0.05, 0.3, 0.5, 0.8];
        let (runs, horizon) = (2000, 500u64);
        let mut missed = 0;
        for r in 0..runs {
            let mu = mus[r % mus.len()];
            let mut ones = 0;
            for n in 1..=horizon {
                ones += u64::from(rng.random_bool(mu));
                let (lo, hi) = kl_interval(ones, n, 1, delta);
                if mu < lo || mu > hi {
                    missed += 1;
                    break;
                }
            }
        }
        let rate = missed as f64 / runs as f64;
        eprintln!("KL coverage: {missed} of {runs} sequences left the interval (rate {rate})");
        assert!(rate <= delta, "miss rate {rate}");
        // Not vacuous: the intervals are tight enough that some sequences do leave them.
        assert!(missed > 0);
    }

    #[test]
    fn saved_states_without_a_bound_load_with_the_papers() {
        let cells: Vec<Cell> = (0..3).map(|i| Cell::new(0, i)).collect();
        let mut s = BanditState::new(cells, 0.5, 0.05, 0.1).unwrap();
        s.bound = ConfidenceBound::Kl;
        let mut v = serde_json::to_value(&s).unwrap();
        assert_eq!(v["bound"], "kl");
        assert_eq!(serde_json::from_value::<BanditState>(v.clone()).unwrap(), s);
        v.as_object_mut().unwrap().remove("bound");
        let old: BanditState = serde_json::from_value(v).unwrap();
        assert_eq!(old.bound, ConfidenceBound::Paper);
    }

    #[test]
    fn the_kl_score_is_the_upper_end_and_ranks_goals() {
        let cells: Vec<Cell> = (0..3).map(|i| Cell::new(0, i)).collect();
        let mut s = BanditState::new(cells, 0.5, 0.05, 1e-4).unwrap();
        s.bound = ConfidenceBound::Kl;
        s.record(0, 9, 10);
        s.record(1, 1, 10);
        assert_eq!(s.score(0), kl_interval(9, 10, 3, 1e-4).1);
        assert_eq!(
            s.ucb_goal_indices(3),
            vec![2, 0, 1],
            "unsampled, then higher J"
        );
        s.bound = ConfidenceBound::Paper;
        assert_eq!(s.score(1), s.mean(1) + s.width(1));
    }

    #[test]
    fn goals_are_top_d_by_j_with_index_ties_and_sets_are_monotone() {
        let cells: Vec<Cell> = (0..6).map(|i| Cell::new(0, i)).collect();
        let mut s = BanditState::new(cells, 0.5, 0.05, 0.1).unwrap();
        assert_eq!(
            s.ucb_goal_indices(3),
            vec![0, 1, 2],
            "all J = ∞: index order"
        );
        s.record(0, 10, 10);
        s.record(1, 0, 10);
        assert_eq!(s.ucb_goal_indices(4), vec![2, 3, 4, 5]);
        assert_eq!(s.ucb_goal_indices(6)[4..], [0, 1], "higher μ̂ + U first");
        for _ in 0..100 {
            s.record(0, 10, 10);
            s.record(1, 0, 10);
        }
        let newly = s.update();
        assert_eq!(newly, vec![0, 1]);
        assert_eq!(s.keep(), vec![Cell::new(0, 0)]);
        assert_eq!(s.reject(), vec![Cell::new(0, 1)]);
        // Classified cells take no more data and stay classified.
        assert!(!s.record(0, 0, 1000));
        s.update();
        assert_eq!(s.labels[0], Label::Keep);
        assert!(!s.ucb_goal_indices(6).contains(&0));
        assert_eq!(s.classified_at[0], Some(0));
        let json = serde_json::to_string(&s).unwrap();
        assert_eq!(serde_json::from_str::<BanditState>(&json).unwrap(), s);
    }

    #[test]
    fn apt_prefers_the_most_ambiguous_cells() {
        let cells: Vec<Cell> = (0..3).map(|i| Cell::new(0, i)).collect();
        let mut s = BanditState::new(cells, 0.5, 0.05, 0.1).unwrap();
        s.record(0, 10, 10); // μ̂ = 1: far from θ
        s.record(1, 5, 10); // μ̂ = 0.5: ambiguous
        assert_eq!(s.apt_goal_indices(3), vec![2, 1, 0]);
    }

    #[test]
    fn p_max_follows_12_to_14() {
        let mu = [0.9, 0.1, 0.45, 0.0];
        let (theta, eps, delta, b) = (0.5, 0.05, 1e-4, 10);
        let p = |m: f64| visits_needed(gap(m, theta, eps), b, 4, delta);
        // Δ: 0.45, 0.45, 0.1, 0.55. D = 2: D_Δ = {μ = 0.45 (smallest Δ), μ = 0 (largest)}.
        let want = (p(0.9) + p(0.1)) / 2.0 + p(0.45).max(p(0.0));
        assert!((p_max(&mu, theta, eps, delta, b, 2) - want).abs() < 1e-9);
        assert!(p(0.45) > p(0.9), "smaller gaps need more visits");
    }

    mod props {
        use super::*;
        use proptest::prelude::*;

        proptest! {
            /// lo ≤ μ̂ ≤ hi inside [0, 1], and twice the samples at the same μ̂ never widen it.
            #[test]
            fn kl_interval_brackets_the_mean_and_shrinks(
                n in 1u64..5000,
                frac in 0.0f64..=1.0,
                cells in 1usize..500,
                delta in 1e-8f64..0.5,
            ) {
                let ones = ((n as f64) * frac).round() as u64;
                let m = ones as f64 / n as f64;
                let (lo, hi) = kl_interval(ones, n, cells, delta);
                prop_assert!(0.0 <= lo && lo <= m && m <= hi && hi <= 1.0);
                let (lo2, hi2) = kl_interval(2 * ones, 2 * n, cells, delta);
                prop_assert!(lo2 >= lo - 1e-12 && hi2 <= hi + 1e-12,
                    "[{}, {}] then [{}, {}]", lo, hi, lo2, hi2);
                // A smaller δ gives a wider interval.
                let (lo3, hi3) = kl_interval(ones, n, cells, delta / 10.0);
                prop_assert!(lo3 <= lo + 1e-12 && hi3 >= hi - 1e-12);
            }
        }
    }
}
