//! End-to-end tests of `fleetmap experiment bandit` and `fleetmap bench plan` (issue 7): the
//! Monte Carlo study writes its CSV, JSON and PNG files, classifies correctly, runs every goal
//! rule, and the benchmark prints its figures.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn fleetmap(args: &[&str]) -> Output {
    Command::new(PathBuf::from(env!("CARGO_BIN_EXE_fleetmap")))
        .args(args)
        .output()
        .expect("run fleetmap")
}

fn read_json(p: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
}

/// A small Table I study with perfect sensors (μ_worst = 1: μ ∈ {0, 1}), where every label is
/// certain: two trials classify every cell, correctly, within the paper's order of magnitude.
#[test]
fn bandit_study_writes_results_and_classifies_correctly() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("t1");
    let o = fleetmap(&[
        "experiment",
        "bandit",
        "--preset",
        "table1",
        "--only",
        "mu_worst=1",
        "--trials",
        "2",
        "--seed",
        "5",
        "--quiet",
        "--json",
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let printed: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let summary = read_json(&out.join("summary.json"));
    assert_eq!(printed, summary);
    let v = &summary["variants"][0];
    assert_eq!(v["config"]["label"], "mu_worst=1");
    assert_eq!(v["trials"], 2);
    assert_eq!(v["censored"], 0);
    assert_eq!(v["label_errors"], 0);
    let ei = v["epochs_interesting"]["median"].as_f64().unwrap();
    let ea = v["epochs_all"]["median"].as_f64().unwrap();
    assert!(ei <= ea, "interesting cells are a subset of all cells");
    // With μ ∈ {0, 1}, (4) needs ~13 visits of B = 10 per cell: far more than one epoch,
    // far fewer than the 1000-epoch cap.
    assert!(
        (5.0..200.0).contains(&ea),
        "all cells classified after {ea} epochs"
    );
    assert!(v["solve_seconds"]["median"].as_f64().unwrap() > 0.0);
    let trials = std::fs::read_to_string(out.join("trials.csv")).unwrap();
    assert_eq!(trials.lines().count(), 3, "{trials}");
    let epochs = std::fs::read_to_string(out.join("epochs.csv")).unwrap();
    let rows: Vec<&str> = epochs.lines().skip(1).collect();
    let run: usize = trials
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(6).unwrap().parse::<usize>().unwrap())
        .sum();
    assert_eq!(rows.len(), run);
    // The last epoch of each trial has every cell classified.
    let progress = v["progress"].as_array().unwrap();
    let last = progress.last().unwrap();
    assert_eq!(last[0].as_f64(), Some(1.0));
    assert_eq!(last[1].as_f64(), Some(1.0));
    let png = image::open(out.join("progress.png")).unwrap();
    assert_eq!((png.width(), png.height()), (1100, 700));
}

/// Fig. 6 runs the faithful rule, the three baselines and the improved rule side by side.
#[test]
fn fig6_runs_every_goal_rule() {
    let dir = tempfile::tempdir().unwrap();
    let o = fleetmap(&[
        "experiment",
        "bandit",
        "--preset",
        "fig6",
        "--trials",
        "1",
        "--max-epochs",
        "3",
        "--quiet",
        "--json",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let labels: Vec<&str> = summary["variants"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v["config"]["label"].as_str().unwrap())
        .collect();
    assert_eq!(
        labels,
        ["ucb", "random", "greedy-cov", "greedy-trav", "apt"]
    );
    for v in summary["variants"].as_array().unwrap() {
        assert_eq!(v["config"]["d"], 10);
        assert_eq!(v["censored"], 1, "3 epochs cannot classify 84 cells");
        assert_eq!(v["solve_seconds"]["n"], 3, "{v}");
    }
    let trials = std::fs::read_to_string(dir.path().join("trials.csv")).unwrap();
    assert!(
        trials.lines().skip(1).all(|l| l.ends_with(",\"\"")),
        "no planner failure: {trials}"
    );
}

#[test]
fn bench_plan_prints_quantiles() {
    let o = fleetmap(&["bench", "plan", "--epochs", "4", "--json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    assert_eq!(v["epochs"], 4);
    let (q10, med, q90) = (
        v["q10_seconds"].as_f64().unwrap(),
        v["median_seconds"].as_f64().unwrap(),
        v["q90_seconds"].as_f64().unwrap(),
    );
    assert!(0.0 < q10 && q10 <= med && med <= q90, "{v}");
    assert!(v["max_variables"].as_u64().unwrap() > 0);
}

#[test]
fn bad_study_arguments_are_one_line_errors() {
    for args in [
        &["experiment", "bandit", "--trials", "0"][..],
        &["experiment", "bandit", "--only", "nope"],
        &["experiment", "bandit", "--preset", "fig6", "--rule", "apt"],
        &["experiment", "bandit", "--delta", "1.5"],
        &["bench", "plan", "--epochs", "0"],
    ] {
        let o = fleetmap(args);
        assert!(!o.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert_eq!(err.trim().lines().count(), 1, "{args:?}: {err}");
    }
}
