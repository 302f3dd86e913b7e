//! End-to-end tests of the exploration module: property tests of Algorithm 1 on random ROIs
//! (coverage, termination, Lemma 1), the effect of adding robots, persistence after every
//! call, and the `fleetmap experiment dfs` command.

use fleetmap_core::explore::bounds::lemma1_upper_bound;
use fleetmap_core::explore::dfs::NodeKind;
use fleetmap_core::explore::dfs::{Action, Allocation, Explorer, ExplorerConfig, RobotId, Sharing};
use fleetmap_core::explore::simulate::{
    SimConfig, SimOutcome, random_roi, simulate, simulate_sensed,
};
use fleetmap_core::geo::{Cell, Dir4};
use proptest::prelude::*;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::collections::HashSet;

use crate::common;

fn roi_from_seed(seed: u64, cells: usize) -> (HashSet<Cell>, Cell) {
    random_roi(&mut ChaCha8Rng::seed_from_u64(seed), cells)
}

const DIRS: [(f64, f64); 4] = [(0.0, 1.0), (0.0, -1.0), (1.0, 0.0), (-1.0, 0.0)];

/// A sensor that flips each label with probability `noise` (a noisy classifier, §7).
fn noisy_sensor(roi: &HashSet<Cell>, seed: u64, noise: f64) -> impl FnMut(Cell) -> [bool; 4] + '_ {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x5eed_5e45_0000_0001);
    move |c: Cell| {
        Dir4::ALL.map(|d| {
            let truth = roi.contains(&c.step(d));
            if noise > 0.0 && rng.random_bool(noise) {
                !truth
            } else {
                truth
            }
        })
    }
}

/// The invariants of §4 on a finished run: termination (the run returned and the explorer
/// says finished), a binary tree (dummies over all children, each with two), every mapped
/// cell visited (every ROI cell with a perfect sensor), every robot back home, every move a
/// step between neighbours.
fn check_invariants(
    out: &SimOutcome,
    roi: &HashSet<Cell>,
    start: Cell,
    perfect: bool,
) -> Result<(), TestCaseError> {
    check_invariants_of(out, roi, start, perfect, false)
}

/// [`check_invariants`]; with `direct` (direct transit) a move may pass imaged vertices, so
/// consecutive cells of a path need not be neighbours — nor different: decisions made in
/// passing may bring a robot back to the cell it stands on (up to a parent it passes,
/// then down again as the need there says), a move of length 0.
fn check_invariants_of(
    out: &SimOutcome,
    roi: &HashSet<Cell>,
    start: Cell,
    perfect: bool,
    direct: bool,
) -> Result<(), TestCaseError> {
    prop_assert!(out.explorer.is_finished());
    let tree = out.explorer.tree();
    for n in tree.nodes() {
        prop_assert!(
            n.children.len() <= 2,
            "{} has {} children",
            n.cell,
            n.children.len()
        );
        if n.kind == NodeKind::Dummy {
            prop_assert_eq!(n.children.len(), 2);
        }
    }
    let visited: HashSet<Cell> = out.paths.iter().flatten().copied().collect();
    let mapped: HashSet<Cell> = tree.cells().collect();
    prop_assert_eq!(&visited, &mapped);
    if perfect {
        prop_assert_eq!(&mapped, roi);
    }
    for p in &out.paths {
        prop_assert_eq!(p.last(), Some(&start));
        for w in p.windows(2) {
            prop_assert!(w[0].manhattan(w[1]) == 1 || direct, "{} to {}", w[0], w[1]);
        }
    }
    Ok(())
}

/// The run's cost is within Lemma 1's bound (eq. 2, with C the cells of the tree the run
/// built) for `robots` robots and the ROI speed `sp`; `what` names the case in the failure.
fn within_lemma_1(
    out: &SimOutcome,
    robots: usize,
    sp: f64,
    what: &str,
) -> Result<(), TestCaseError> {
    let c = out.tree_cells;
    let bound = lemma1_upper_bound(c, out.d_max, robots, 1.0, sp);
    prop_assert!(
        out.cost <= bound * (1.0 + 1e-9),
        "cost {} > Lemma 1 bound {} (C {}, R {}, d_max {}, S_p {}{})",
        out.cost,
        bound,
        c,
        robots,
        out.d_max,
        sp,
        what
    );
    Ok(())
}

fn run_case(
    seed: u64,
    cells: usize,
    robots: usize,
    ratio: f64,
    dir: usize,
    noise: f64,
    (sharing, allocation, direct_transit): (Sharing, Allocation, bool),
) -> (SimOutcome, HashSet<Cell>, Cell, f64) {
    let (roi, start) = roi_from_seed(seed, cells);
    let sp = if ratio == 0.0 { 0.0 } else { 1.0 / ratio };
    let v = (DIRS[dir].0 * sp, DIRS[dir].1 * sp);
    let cfg = SimConfig {
        robots,
        sharing,
        allocation,
        robot_speed: 1.0,
        roi_velocity: v,
        observe_time: 0.0,
        record_paths: true,
        direct_transit,
    };
    let out = {
        let mut sense = noisy_sensor(&roi, seed, noise);
        simulate_sensed(&roi, start, &cfg, &mut sense).expect("the exploration terminates")
    };
    (out, roi, start, sp)
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 1024, ..ProptestConfig::default() })]

    /// GCS sharing, random ROIs, R = 1…32, static or translating ROI, perfect or noisy
    /// sensing: the invariants of §4 hold and the cost never exceeds Lemma 1 (eq. 2, with
    /// C the cells of the tree the run built — the outer approximation of §5 when the sensor
    /// lies).
    #[test]
    fn dfs_covers_terminates_and_meets_lemma_1(
        seed in any::<u64>(),
        cells in 1usize..160,
        robots in 1usize..=32,
        ratio in prop_oneof![Just(0.0), 1.2f64..6.0],
        dir in 0usize..4,
        noise in prop_oneof![Just(0.0), 0.0f64..0.15],
    ) {
        let (out, roi, start, sp) = run_case(seed, cells, robots, ratio, dir, noise, (Sharing::Gcs, Allocation::Paper, false));
        check_invariants(&out, &roi, start, noise == 0.0)?;
        prop_assert_eq!(out.explorer.uninformed_decisions(), 0);
        within_lemma_1(&out, robots, sp, "")?;
    }

    /// GCS sharing with the nearest-frontier allocation, on the same cases: the invariants
    /// of §4 hold (binary tree, every mapped cell visited, every robot home, termination) and
    /// the cost never exceeds Lemma 1.
    #[test]
    fn nearest_frontier_covers_terminates_and_meets_lemma_1(
        seed in any::<u64>(),
        cells in 1usize..160,
        robots in 1usize..=20,
        ratio in prop_oneof![Just(0.0), 1.2f64..6.0],
        dir in 0usize..4,
        noise in prop_oneof![Just(0.0), 0.0f64..0.15],
    ) {
        let (out, roi, start, sp) =
            run_case(seed, cells, robots, ratio, dir, noise, (Sharing::Gcs, Allocation::NearestFrontier, false));
        check_invariants(&out, &roi, start, noise == 0.0)?;
        prop_assert_eq!(out.explorer.config().allocation, Allocation::NearestFrontier);
        within_lemma_1(&out, robots, sp, "")?;
    }

    /// GCS sharing with direct transit (fleetmap's field rule: a lone robot flies straight
    /// over imaged vertices), with Algorithm 1's split or the spread allocation: the
    /// invariants of §4 hold (every mapped cell visited, every robot home, termination).
    /// Lemma 1 does not always hold for it: [`direct_transit_can_exceed_lemma_1`].
    #[test]
    fn direct_transit_covers_and_terminates(
        seed in any::<u64>(),
        cells in 1usize..160,
        robots in 1usize..=20,
        ratio in prop_oneof![Just(0.0), 1.2f64..6.0],
        dir in 0usize..4,
        noise in prop_oneof![Just(0.0), 0.0f64..0.15],
        spread in any::<bool>(),
    ) {
        let allocation = if spread { Allocation::Spread } else { Allocation::Paper };
        let (out, roi, start, _) =
            run_case(seed, cells, robots, ratio, dir, noise, (Sharing::Gcs, allocation, true));
        check_invariants_of(&out, &roi, start, noise == 0.0, true)?;
    }

    /// Meeting-only sharing (the paper's model): the invariants of §4 hold, and the cost
    /// exceeds Lemma 1 only in runs where some decision was uninformed (the class worked out
    /// in docs/results/dfs.md: a robot chose where a fully informed team would not have).
    #[test]
    fn meeting_sharing_covers_terminates_and_exceeds_lemma_1_only_when_uninformed(
        seed in any::<u64>(),
        cells in 1usize..100,
        robots in 1usize..=32,
        ratio in prop_oneof![Just(0.0), 1.2f64..6.0],
        dir in 0usize..4,
        noise in prop_oneof![Just(0.0), 0.0f64..0.15],
    ) {
        let (out, roi, start, sp) = run_case(seed, cells, robots, ratio, dir, noise, (Sharing::Meet, Allocation::Paper, false));
        check_invariants(&out, &roi, start, noise == 0.0)?;
        if out.explorer.uninformed_decisions() == 0 {
            within_lemma_1(&out, robots, sp, ", an informed run")?;
        }
    }
}

/// The case the property test once found with GCS sharing (seed 12612413762222925005,
/// 156 cells, 17 robots, static ROI): before robots meeting at a vertex were pooled and
/// decisions at one instant waited for that instant's images, it cost 128 > Lemma 1's 124.8.
#[test]
fn gcs_regression_156_cells_17_robots() {
    let (roi, start) = roi_from_seed(12612413762222925005, 156);
    let out = simulate(
        &roi,
        start,
        &SimConfig {
            robots: 17,
            sharing: Sharing::Gcs,
            allocation: Allocation::Paper,
            record_paths: true,
            ..SimConfig::default()
        },
    )
    .expect("the exploration terminates");
    let bound = lemma1_upper_bound(156, out.d_max, 17, 1.0, 0.0);
    eprintln!("cost {} bound {} d_max {}", out.cost, bound, out.d_max);
    assert!(
        out.cost <= bound,
        "cost {} > Lemma 1 bound {bound}",
        out.cost
    );
}

/// Over 200 random ROIs of 80 cells, the mean exploration time does not grow as robots are
/// added (R = 1, 2, 4, 8), with static and translating ROIs.
#[test]
fn mean_time_does_not_grow_with_more_robots() {
    for ratio in [0.0, 2.5] {
        let sp = if ratio == 0.0 { 0.0 } else { 1.0 / ratio };
        let mut means = Vec::new();
        for robots in [1usize, 2, 4, 8] {
            let mut sum = 0.0;
            for trial in 0..200u64 {
                let (roi, start) = roi_from_seed(1000 + trial, 80);
                let d = DIRS[(trial % 4) as usize];
                let out = simulate(
                    &roi,
                    start,
                    &SimConfig {
                        robots,
                        sharing: Sharing::Gcs,
                        roi_velocity: (d.0 * sp, d.1 * sp),
                        ..SimConfig::default()
                    },
                )
                .unwrap();
                sum += out.cost;
            }
            means.push(sum / 200.0);
        }
        for w in means.windows(2) {
            assert!(w[1] <= w[0], "ratio {ratio}: means {means:?}");
        }
        // And more than one robot actually helps.
        assert!(means[3] < 0.75 * means[0], "ratio {ratio}: means {means:?}");
    }
}

/// A runner that saves the explorer after every call and restores it before the next one
/// (a GCS crashing between any two calls) builds the same map with the same moves as one
/// that never stops.
#[test]
fn persisting_after_every_call_changes_nothing() {
    let (roi, start) = roi_from_seed(77, 60);
    let ids: Vec<RobotId> = (1..=4).map(RobotId).collect();
    let drive = |persist: bool| {
        let mut ex = Explorer::new(ExplorerConfig::default(), start, &ids).unwrap();
        let mut log = Vec::new();
        let mut done = HashSet::new();
        for _round in 0..10_000 {
            if done.len() == ids.len() {
                break;
            }
            for &r in &ids {
                if persist {
                    let json = serde_json::to_vec(&ex).unwrap();
                    ex = serde_json::from_slice(&json).unwrap();
                }
                let a = ex.next_action(r).unwrap();
                log.push((r, a));
                match a {
                    Action::Rejoin(c) | Action::MoveTo(c) => ex.arrived(r, c).unwrap(),
                    Action::Observe => {
                        let at = ex.robot_cell(r).unwrap();
                        let labels = Dir4::ALL.map(|d| roi.contains(&at.step(d)));
                        ex.observe(r, at, labels).unwrap();
                    }
                    Action::Done => {
                        done.insert(r);
                    }
                    Action::Wait => {}
                    Action::ReturnHome => panic!("nobody was paused"),
                }
            }
        }
        assert!(ex.is_finished());
        (log, ex.tree().cells().collect::<Vec<_>>())
    };
    let (log_a, map_a) = drive(false);
    let (log_b, map_b) = drive(true);
    assert_eq!(map_a, map_b);
    assert_eq!(log_a, log_b);
    assert_eq!(map_a.into_iter().collect::<HashSet<_>>(), roi);
}

#[test]
fn experiment_dfs_writes_csv_json_and_plots() {
    let dir = tempfile::tempdir().unwrap();
    let out = common::fleetmap()
        .command()
        .args([
            "experiment",
            "dfs",
            "--trials",
            "4",
            "--seed",
            "11",
            "--cells",
            "30,60",
            "--robots",
            "1,4",
            "--ratios",
            "2,static",
            "--base-cells",
            "40",
            "--base-robots",
            "5",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("stayed within the Lemma 1 upper bound"),
        "{stderr}"
    );
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("ALG/LM"), "{stdout}");
    let csv = std::fs::read_to_string(dir.path().join("dfs_trials.csv")).unwrap();
    // 6 configurations × 4 trials + header.
    assert_eq!(csv.lines().count(), 25);
    assert!(csv.lines().skip(1).all(|l| l.ends_with(",true")));
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(dir.path().join("dfs_summary.json")).unwrap(),
    )
    .unwrap();
    let confs = summary["summaries"].as_array().unwrap();
    assert_eq!(confs.len(), 6);
    for c in confs {
        assert!(c["mean_ratio_to_lawnmower"].as_f64().unwrap() > 0.0);
        assert_eq!(c["violations"], 0);
        assert!(c["cost"]["min"].as_f64().unwrap() <= c["cost"]["max"].as_f64().unwrap());
    }
    for png in [
        "fig7a_roi.png",
        "fig7b_cells.png",
        "fig7c_robots.png",
        "fig7d_ratio.png",
    ] {
        let img = image::open(dir.path().join(png)).unwrap().to_rgb8();
        assert!(img.width() >= 640, "{png}");
        // Not blank: the plot has colour in it (lines, cells, text).
        let colours: HashSet<[u8; 3]> = img.pixels().map(|p| p.0).take(400_000).collect();
        assert!(colours.len() > 8, "{png} looks blank");
    }
    // --json prints the summary.
    let out = common::fleetmap()
        .command()
        .args([
            "experiment",
            "dfs",
            "--trials",
            "1",
            "--cells",
            "20",
            "--robots",
            "2",
        ])
        .args(["--ratios", "3", "--json", "--out"])
        .arg(dir.path().join("j"))
        .output()
        .unwrap();
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["trials"], 1);
}

#[test]
fn experiment_dfs_reports_lemma_1_violations_loudly() {
    // Meeting-only sharing exceeds the bound on such ROIs (see explore::dfs): the run says
    // so and fails.
    let dir = tempfile::tempdir().unwrap();
    let out = common::fleetmap()
        .command()
        .args(["experiment", "dfs", "--sharing", "meet", "--trials", "10"])
        .args(["--sweeps", "cells", "--cells", "60", "--base-robots", "8"])
        .args(["--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("LEMMA 1 VIOLATED"), "{stderr}");
    assert!(stderr.contains("meet sharing, C = 60, R = 8"), "{stderr}");
    assert!(dir.path().join("dfs_trials.csv").exists());
}

#[test]
fn experiment_dfs_rejects_bad_arguments() {
    for args in [
        vec!["--ratios", "0.5"],
        vec!["--trials", "0"],
        vec!["--robots", "0"],
        vec!["--sweeps", "cells", "--cells", ""],
    ] {
        let dir = tempfile::tempdir().unwrap();
        let out = common::fleetmap()
            .command()
            .args(["experiment", "dfs"])
            .args(&args)
            .arg("--out")
            .arg(dir.path())
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?}");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!stderr.trim().is_empty(), "{args:?}");
        assert!(!stderr.contains("panicked"), "{stderr}");
    }
}

/// Direct transit is outside Lemma 1: a robot that flies straight to the next vertex with
/// work left decides with what the team knew when it set out, and here the vertex it flies to
/// is done by the other robot before it arrives. Two robots, 15 static cells (ROI seed
/// 9 389 100 676 073 550 037, found by the property test): walking the tree, everyone is back
/// after 18 s; with direct transit after 23.04 s, above eq. (2)'s 23 s (docs/results/dfs.md).
#[test]
fn direct_transit_can_exceed_lemma_1() {
    let seed = 9_389_100_676_073_550_037;
    let cfg = (Sharing::Gcs, Allocation::Paper, false);
    let (walk, ..) = run_case(seed, 15, 2, 0.0, 0, 0.0, cfg);
    let (direct, _, _, sp) = run_case(seed, 15, 2, 0.0, 0, 0.0, (cfg.0, cfg.1, true));
    let bound = lemma1_upper_bound(direct.tree_cells, direct.d_max, 2, 1.0, sp);
    assert_eq!((direct.tree_cells, direct.d_max), (15, 8));
    assert!((walk.cost - 18.0).abs() < 1e-9, "walk {}", walk.cost);
    assert!((bound - 23.0).abs() < 1e-9, "bound {bound}");
    assert!(
        (direct.cost - 23.035).abs() < 1e-3,
        "direct transit {}",
        direct.cost
    );
    // The same ROI seed, 17 cells and four robots: 24.39 s against 23.33 s (walking: 20 s).
    let (walk, ..) = run_case(seed, 17, 4, 0.0, 0, 0.0, cfg);
    let (direct, _, _, sp) = run_case(seed, 17, 4, 0.0, 0, 0.0, (cfg.0, cfg.1, true));
    let bound = lemma1_upper_bound(direct.tree_cells, direct.d_max, 4, 1.0, sp);
    assert!((walk.cost - 20.0).abs() < 1e-9, "walk {}", walk.cost);
    assert!(
        direct.cost > bound + 1.0,
        "direct transit {} bound {bound}",
        direct.cost
    );
}
