//! The study's outputs: `runway_trials.csv`, `runway_drones.csv`, `runway_summary.json`,
//! `runway_team.png`, the text table and the line printed as each trial ends.

use super::{Stat, Study, TrialRow, plot};
use anyhow::Context as _;
use std::path::{Path, PathBuf};

fn opt(x: Option<f64>) -> String {
    x.map(|v| format!("{v:.3}")).unwrap_or_default()
}

/// `runway_trials.csv`: one row per trial (seconds of simulated time). Nothing of the machine's
/// in it — a trial's wall time is in the JSON summary and the progress line — so that a study in
/// virtual time writes the same file for the same seed on every run.
pub fn trials_csv(study: &Study) -> String {
    let mut s = String::from(
        "drones,trial,seed,finished,to_dfs_start_s,to_map_complete_s,to_last_landing_s,iou,\
         iou_best_possible,cells_mapped,images,battery_swaps,airborne_s,flying_share,\
         waiting_share,ground_share,error\n",
    );
    for t in &study.trials {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{:.1},{:.4},{:.4},{:.4},{}\n",
            t.drones,
            t.trial,
            t.seed,
            t.finished,
            opt(t.to_dfs_start_s),
            opt(t.to_map_complete_s),
            opt(t.to_last_landing_s),
            opt(t.iou),
            opt(t.iou_best_possible),
            t.cells_mapped,
            t.images,
            t.battery_swaps,
            t.airborne_s,
            t.flying_share,
            t.waiting_share,
            t.ground_share,
            t.error
                .as_deref()
                .map(|e| format!("\"{}\"", e.replace('"', "'")))
                .unwrap_or_default()
        ));
    }
    s
}

/// `runway_drones.csv`: one row per drone of every trial (seconds of simulated time).
pub(crate) fn drones_csv(study: &Study) -> String {
    let mut s = String::from(
        "drones,trial,sysid,elapsed_s,flying_s,imaging_s,homing_s,returning_s,waiting_s,\
         wait_confirmation_s,wait_sweep_s,wait_pictures_s,wait_dfs_start_s,wait_vertex_s,\
         wait_operator_s,ground_s,ground_before_s,ground_swap_s,ground_done_s,distance_m,\
         battery_swaps,images\n",
    );
    for d in &study.drone_rows {
        let w = &d.waiting;
        s.push_str(&format!(
            "{},{},{},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.2},{:.1},{},{}\n",
            d.drones,
            d.trial,
            d.sysid,
            d.elapsed_s,
            d.flying_s,
            d.imaging_s,
            d.homing_s,
            d.returning_s,
            d.waiting_s,
            w.confirmation_s,
            w.sweep_s,
            w.pictures_s,
            w.dfs_start_s,
            w.vertex_s,
            w.operator_s,
            d.ground_s,
            d.ground_before_s,
            d.ground_swap_s,
            d.ground_done_s,
            d.distance_m,
            d.battery_swaps,
            d.images
        ));
    }
    s
}

/// The summary tables: per team size the mission times (mean, and min–max with several
/// trials), their ratio to one drone's, the goal, IoU and swaps; then where a drone's time
/// went (mean seconds per drone).
pub fn table(study: &Study) -> String {
    let secs = |x: &Option<Stat>| match x {
        Some(s) if (s.max - s.min).abs() < 0.5 => format!("{:.0}", s.mean),
        Some(s) => format!("{:.0} ({:.0}–{:.0})", s.mean, s.min, s.max),
        None => "—".into(),
    };
    let ratio = |x: Option<f64>| x.map_or("—".into(), |r| format!("{r:.2}×"));
    let pct = |x: &Option<Stat>| x.map_or("—".into(), |s| format!("{:.1} %", 100.0 * s.mean));
    let mut s = format!(
        "{:>6} {:>7} | {:>16} {:>18} {:>6} {:>18} {:>6} {:>5} | {:>7} {:>7} {:>5} | {:>6} {:>6} {:>6}\n",
        "drones",
        "trials",
        "DFS start s",
        "map complete s",
        "×1",
        "last landing s",
        "×1",
        "goal",
        "IoU",
        "best",
        "swaps",
        "fly",
        "wait",
        "ground"
    );
    for x in &study.summaries {
        s.push_str(&format!(
            "{:>6} {:>7} | {:>16} {:>18} {:>6} {:>18} {:>6} {:>5} | {:>7} {:>7} {:>5} | {:>5.0}% {:>5.0}% {:>5.0}%\n",
            x.drones,
            format!("{}/{}", x.finished, x.trials),
            secs(&x.to_dfs_start_s),
            secs(&x.to_map_complete_s),
            ratio(x.map_ratio),
            secs(&x.to_last_landing_s),
            ratio(x.landing_ratio),
            x.goal.map_or("".into(), |g| format!("{g}×")),
            pct(&x.iou),
            pct(&x.iou_best_possible),
            x.battery_swaps.map_or("—".into(), |b| format!("{:.1}", b.mean)),
            100.0 * x.flying_share,
            100.0 * x.waiting_share,
            100.0 * x.ground_share
        ));
    }
    s.push_str(&format!(
        "\nper drone, mean seconds: {:>6} {:>7} {:>6} {:>6} {:>6} | {:>7} {:>7} {:>7} {:>7} {:>7} | {:>7} {:>7} {:>7} | {:>6}\n",
        "drones",
        "flying",
        "(imag)",
        "(home)",
        "(back)",
        "confirm",
        "sweep",
        "DFSstart",
        "vertex",
        "other",
        "before",
        "swaps",
        "done",
        "metres"
    ));
    for x in &study.summaries {
        let p = &x.per_drone;
        let w = &p.waiting;
        s.push_str(&format!(
            "                         {:>6} {:>7.0} {:>6.0} {:>6.0} {:>6.0} | {:>7.0} {:>7.0} {:>7.0} {:>7.0} {:>7.0} | {:>7.0} {:>7.0} {:>7.0} | {:>6.0}\n",
            x.drones,
            p.flying_s,
            p.imaging_s,
            p.homing_s,
            p.returning_s,
            w.confirmation_s,
            w.sweep_s + w.pictures_s,
            w.dfs_start_s,
            w.vertex_s,
            w.operator_s,
            p.ground_before_s,
            p.ground_swap_s,
            p.ground_done_s,
            p.distance_m
        ));
    }
    s
}

/// One progress line per trial.
pub(crate) fn trial_line(t: &TrialRow) -> String {
    let secs = |x: Option<f64>| x.map_or("—".into(), |v| format!("{v:.0} s"));
    format!(
        "{} drone(s), trial {} (seed {}): {} — map complete {}, last landing {}, IoU {}, {} swap(s), \
         {:.0} % flying / {:.0} % waiting / {:.0} % ground, {:.0} s wall{}",
        t.drones,
        t.trial,
        t.seed,
        if t.finished {
            "finished"
        } else {
            "NOT FINISHED"
        },
        secs(t.to_map_complete_s),
        secs(t.to_last_landing_s),
        t.iou.map_or("—".into(), |i| format!("{:.1} %", 100.0 * i)),
        t.battery_swaps,
        100.0 * t.flying_share,
        100.0 * t.waiting_share,
        100.0 * t.ground_share,
        t.wall_s,
        t.error
            .as_deref()
            .map(|e| format!(" ({e})"))
            .unwrap_or_default()
    )
}

/// Write `runway_trials.csv`, `runway_drones.csv`, `runway_summary.json` and
/// `runway_team.png` into `dir`; returns the files written.
pub fn write_outputs(study: &Study, dir: &Path) -> anyhow::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir).with_context(|| format!("cannot create {}", dir.display()))?;
    let mut files = Vec::new();
    let mut write = |name: &str, bytes: &[u8]| -> anyhow::Result<()> {
        let path = dir.join(name);
        fleetmap_io::files::atomic_write(&path, bytes)
            .with_context(|| format!("cannot write {}", path.display()))?;
        files.push(path);
        Ok(())
    };
    write("runway_trials.csv", trials_csv(study).as_bytes())?;
    write("runway_drones.csv", drones_csv(study).as_bytes())?;
    write(
        "runway_summary.json",
        serde_json::to_string_pretty(study)?.as_bytes(),
    )?;
    write("runway_team.png", &plot::team_png(study)?)?;
    Ok(files)
}
