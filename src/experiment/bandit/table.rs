//! What a bandit study writes: the trials and epochs as CSV, one row per variant with the
//! paper's row beside it (`table.csv`), the summary JSON, and the table printed on the
//! terminal. Pure formatting; the command line writes the files.

use super::paper::{self, FIG6_CLAIM, Published};
use super::{Preset, Spread, Study, TrialResult, VariantSummary, quantile};
use serde::Serialize;
use std::fmt::Write as _;

/// The paper's name of a preset's table or figure.
pub fn title(preset: Preset) -> &'static str {
    match preset {
        Preset::Table1 => "Table I (worst-case sensor accuracy)",
        Preset::Table2 => "Table II (epoch goals D)",
        Preset::Table3 => "Table III (agility Td, Tc)",
        Preset::Table4 => "Table IV (team size Nd, Nc)",
        Preset::Fig6 => "Fig. 6 (Algorithm 1 against baselines)",
        Preset::Compare => "Algorithm 1 beside its improvements (not in the paper)",
    }
}

/// `summary.json`: the study, the command that made it, and one summary per variant.
#[derive(Debug, Serialize)]
pub(crate) struct StudySummary<'a> {
    /// Preset name (`table1`, …).
    pub preset: &'static str,
    /// [`title`].
    pub title: &'static str,
    /// The command line that ran the study (or merged its parts).
    pub command: &'a str,
    /// Study seed.
    pub seed: u64,
    /// Trials per variant.
    pub trials: usize,
    /// How the quantiles are computed.
    pub(crate) quantiles: &'static str,
    /// Fig. 6: the paper's claim and whether these results agree with it.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub fig6: Option<Fig6Check>,
    /// The rows.
    pub variants: &'a [VariantSummary],
}

/// The paper's Fig. 6 claim and our check of it.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct Fig6Check {
    /// [`FIG6_CLAIM`].
    pub(crate) claim: &'static str,
    /// [`paper::fig6_agrees`] on the medians (`None`: UCB or every baseline unfinished).
    pub(crate) agrees: Option<bool>,
}

impl<'a> StudySummary<'a> {
    /// The summary of `study` with its `variants`' summaries, made by `command`.
    pub(crate) fn new(study: &Study, command: &'a str, variants: &'a [VariantSummary]) -> Self {
        StudySummary {
            preset: study.preset.name(),
            title: title(study.preset),
            command,
            seed: study.seed,
            trials: study.trials,
            quantiles: "linear interpolation between order statistics (numpy default); epochs over finished trials; solve time over all epochs of all trials",
            fig6: (study.preset == Preset::Fig6).then(|| fig6_check(variants)),
            variants,
        }
    }
}

/// Fig. 6's claim checked on the variants' medians.
pub(crate) fn fig6_check(variants: &[VariantSummary]) -> Fig6Check {
    let rows: Vec<_> = variants
        .iter()
        .map(|s| {
            (
                s.config.rule,
                s.epochs_interesting.map(|e| e.median),
                s.epochs_all.map(|e| e.median),
            )
        })
        .collect();
    Fig6Check {
        claim: FIG6_CLAIM,
        agrees: paper::fig6_agrees(&rows),
    }
}

/// `trials.csv`: one line per trial (P_max empty where it does not apply).
pub fn trials_csv(results: &[TrialResult]) -> String {
    let mut s = String::from(
        "variant,trial,world_seed,epochs_interesting,epochs_all,label_errors,epochs_run,median_solve_seconds,n_interesting,n_cells,p_max,failure\n",
    );
    let opt = |x: Option<usize>| x.map_or(String::new(), |v| v.to_string());
    for r in results {
        let solve: Vec<f64> = r.epochs.iter().map(|e| e.solve_seconds).collect();
        // Writing to a String cannot fail.
        let _ = writeln!(
            s,
            "\"{}\",{},{},{},{},{},{},{},{},{},{},\"{}\"",
            r.label,
            r.trial,
            r.world_seed,
            opt(r.epochs_interesting),
            opt(r.epochs_all),
            r.label_errors,
            r.epochs.len(),
            quantile(&solve, 0.5).map_or(String::new(), |s| format!("{s:.4}")),
            r.n_interesting,
            r.n_cells,
            r.p_max.map_or(String::new(), |p| format!("{p:.1}")),
            r.failure.clone().unwrap_or_default().replace('"', "'")
        );
    }
    s
}

/// `epochs.csv`: one line per epoch of every trial.
pub(crate) fn epochs_csv(results: &[TrialResult]) -> String {
    let mut s = String::from(
        "variant,trial,epoch,solve_seconds,cycles,goals,variables,interesting_classified,uninteresting_classified,batches\n",
    );
    for r in results {
        for e in &r.epochs {
            let _ = writeln!(
                s,
                "\"{}\",{},{},{:.5},{},{},{},{},{},{}",
                r.label,
                r.trial,
                e.epoch,
                e.solve_seconds,
                e.cycles,
                e.goals,
                e.variables,
                e.interesting_classified,
                e.uninteresting_classified,
                e.batches
            );
        }
    }
    s
}

fn spread_cells(s: Option<(f64, f64, f64)>, digits: usize) -> String {
    match s {
        Some((m, lo, hi)) => format!("{m:.digits$},{lo:.digits$},{hi:.digits$}"),
        None => ",,".into(),
    }
}

fn ours(s: &Option<Spread>) -> Option<(f64, f64, f64)> {
    s.map(|s| (s.median, s.q10, s.q90))
}

fn theirs(p: Published) -> Option<(f64, f64, f64)> {
    Some((p.median, p.q10, p.q90))
}

/// `table.csv`: one line per variant, our medians and (0.1, 0.9) quantiles beside the paper's.
pub(crate) fn table_csv(variants: &[VariantSummary]) -> String {
    let mut s = String::from(
        "variant,trials,censored,label_errors,multi_cycle_epochs,\
solve_s_median,solve_s_q10,solve_s_q90,\
epochs_interesting_median,epochs_interesting_q10,epochs_interesting_q90,\
epochs_all_median,epochs_all_q10,epochs_all_q90,\
p_max_median,p_max_q10,p_max_q90,paper_trials,\
paper_solve_s_median,paper_solve_s_q10,paper_solve_s_q90,\
paper_epochs_interesting_median,paper_epochs_interesting_q10,paper_epochs_interesting_q90,\
paper_epochs_all_median,paper_epochs_all_q10,paper_epochs_all_q90\n",
    );
    for v in variants {
        let p = v.paper;
        let _ = writeln!(
            s,
            "\"{}\",{},{},{},{},{},{},{},{},{},{},{},{}",
            v.config.label,
            v.trials,
            v.censored,
            v.label_errors,
            v.multi_cycle_epochs,
            spread_cells(ours(&v.solve_seconds), 4),
            spread_cells(ours(&v.epochs_interesting), 1),
            spread_cells(ours(&v.epochs_all), 1),
            spread_cells(ours(&v.p_max), 1),
            p.map_or(String::new(), |p| p.trials.to_string()),
            spread_cells(p.and_then(|p| theirs(p.solve_seconds)), 2),
            spread_cells(p.and_then(|p| theirs(p.epochs_interesting)), 1),
            spread_cells(p.and_then(|p| theirs(p.epochs_all)), 1),
        );
    }
    s
}

fn fmt3(s: Option<(f64, f64, f64)>, digits: usize) -> String {
    match s {
        None => "n/a".into(),
        Some((m, lo, hi)) => format!("{m:.digits$} ({lo:.digits$}, {hi:.digits$})"),
    }
}

/// The table printed on the terminal: for each variant our row, then the paper's (where it
/// has one), then for Fig. 6 the paper's claim and whether our medians agree.
pub fn printed(study: &Study, variants: &[VariantSummary], out_dir: &str) -> String {
    let mut out = String::new();
    let _ = writeln!(
        out,
        "bandit study: {}, {} trials per variant (the paper: {}), seed {}; results in {out_dir}",
        title(study.preset),
        study.trials,
        paper::trials(study.preset),
        study.seed
    );
    let w = variants
        .iter()
        .map(|v| v.config.label.chars().count())
        .max()
        .unwrap_or(0)
        .max(7);
    let _ = writeln!(
        out,
        "{:<w$} {:<5} {:>6} {:>24} {:>21} {:>21} {:>21} {:>8} {:>6}",
        "variant",
        "row",
        "trials",
        "solve s/epoch (q10,q90)",
        "epochs: interesting",
        "epochs: all cells",
        "P_max (Prop. 2)",
        "censored",
        "errors"
    );
    for v in variants {
        let _ = writeln!(
            out,
            "{:<w$} {:<5} {:>6} {:>24} {:>21} {:>21} {:>21} {:>8} {:>6}",
            v.config.label,
            "ours",
            v.trials,
            fmt3(ours(&v.solve_seconds), 3),
            fmt3(ours(&v.epochs_interesting), 1),
            fmt3(ours(&v.epochs_all), 1),
            fmt3(ours(&v.p_max), 0),
            v.censored,
            v.label_errors
        );
        if let Some(p) = v.paper {
            let _ = writeln!(
                out,
                "{:<w$} {:<5} {:>6} {:>24} {:>21} {:>21}",
                "",
                "paper",
                p.trials,
                fmt3(theirs(p.solve_seconds), 2),
                fmt3(theirs(p.epochs_interesting), 1),
                fmt3(theirs(p.epochs_all), 1),
            );
        }
    }
    if study.preset == Preset::Fig6 {
        let c = fig6_check(variants);
        let _ = writeln!(out, "paper (Fig. 6): {}", c.claim);
        let _ = writeln!(
            out,
            "ours: {}",
            match c.agrees {
                Some(true) => "agrees (UCB's medians below every baseline's on both counts)",
                Some(false) => "does NOT agree (a baseline's median is at or below UCB's)",
                None => "cannot tell (UCB or every baseline unfinished or not run)",
            }
        );
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::bandit::EpochRecord;

    fn trial(label: &str, t: usize, all: Option<usize>) -> TrialResult {
        TrialResult {
            label: label.into(),
            trial: t,
            world_seed: 9,
            epochs_interesting: all.map(|a| a / 2),
            epochs_all: all,
            label_errors: 0,
            n_interesting: 10,
            n_cells: 84,
            epochs: vec![EpochRecord {
                epoch: 0,
                solve_seconds: 0.25,
                cycles: 1,
                goals: 8,
                variables: 900,
                interesting_classified: 2,
                uninteresting_classified: 30,
                batches: 70,
            }],
            failure: None,
            p_max: Some(1070.4),
        }
    }

    #[test]
    fn the_printed_table_puts_the_papers_row_under_ours() {
        let study = Study {
            preset: Preset::Table1,
            seed: 1,
            trials: 2,
            variants: Preset::Table1.variants(),
            streams: Vec::new(),
        };
        let results: Vec<TrialResult> = (0..2)
            .map(|t| trial("mu_worst=0.8", t, Some(44 + t)))
            .collect();
        let s = study.summarise(&results);
        let text = printed(&study, &s, "out");
        let lines: Vec<&str> = text.lines().collect();
        assert!(lines[0].contains("Table I") && lines[0].contains("(the paper: 100)"));
        let ours = lines
            .iter()
            .position(|l| l.starts_with("mu_worst=0.8 "))
            .unwrap();
        assert!(lines[ours].contains("44.5 (44.1, 44.9)"), "{text}");
        assert!(lines[ours].contains("1070 (1070, 1070)"), "{text}");
        assert!(lines[ours + 1].contains("paper"), "{text}");
        assert!(lines[ours + 1].contains("26.0 (23.0, 30.0)"), "{text}");
        assert!(lines[ours + 1].contains("11.37 (6.46, 387.38)"), "{text}");
        // A variant without trials still prints, with n/a.
        assert!(text.contains("mu_worst=0.6"), "{text}");
        let csv = table_csv(&s);
        assert_eq!(csv.lines().count(), 4);
        let row08: Vec<&str> = csv.lines().nth(2).unwrap().split(',').collect();
        assert_eq!(row08.len(), csv.lines().next().unwrap().split(',').count());
        assert_eq!(row08[11], "44.5");
        assert_eq!(row08[17], "100");
        assert_eq!(row08[24], "26.0");
    }

    #[test]
    fn fig6_prints_the_claim_and_the_check() {
        let study = Study {
            preset: Preset::Fig6,
            seed: 1,
            trials: 1,
            variants: Preset::Fig6.variants(),
            streams: Vec::new(),
        };
        let results: Vec<TrialResult> = study
            .variants
            .iter()
            .enumerate()
            .map(|(i, v)| trial(&v.label, 0, Some(if i == 0 { 40 } else { 50 + i })))
            .collect();
        let s = study.summarise(&results);
        let text = printed(&study, &s, "out");
        assert!(text.contains("paper (Fig. 6)"), "{text}");
        assert!(text.contains("ours: agrees"), "{text}");
        assert!(!text.contains(" paper "), "no numeric paper rows: {text}");
        let json = serde_json::to_value(StudySummary::new(&study, "cmd", &s)).unwrap();
        assert_eq!(json["fig6"]["agrees"], true);
        assert_eq!(json["command"], "cmd");
        let csv = trials_csv(&results);
        assert!(
            csv.lines().nth(1).unwrap().contains(",10,84,1070.4,"),
            "{csv}"
        );
    }
}
