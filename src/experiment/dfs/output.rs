//! The study's outputs: the trials as CSV, Lemma 1 violations, the summary table, and the
//! files written to the output directory.

use super::*;

/// The trials as CSV (one row per trial).
pub fn trials_csv(study: &Study) -> String {
    let mut s = String::from(
        "sweep,sharing,allocation,cells,robots,speed_ratio,trial,direction,cost,lemma1_upper,lemma2_lower,\
         lawnmower_lower,d_max,tree_cells,eq8_upper,opt_lower,theorem1_upper,theorem2_upper,\
         reach_lower,moves,opening_moves,flight_share,uninformed_decisions,within_lemma1\n",
    );
    for r in &study.records {
        let c = &study.configurations[r.config];
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{},{}\n",
            c.sweep,
            c.sharing,
            c.allocation,
            c.cells,
            c.robots,
            c.speed_ratio,
            r.trial,
            r.direction,
            r.cost,
            r.lemma1_upper,
            r.lemma2_lower,
            r.lawnmower_lower,
            r.d_max,
            r.tree_cells,
            r.eq8_upper.map(|b| b.to_string()).unwrap_or_default(),
            r.opt_lower,
            r.theorem1_upper,
            r.theorem2_upper,
            r.reach_lower,
            r.moves,
            r.opening_moves,
            r.flight_share,
            r.uninformed_decisions,
            r.within_lemma1
        ));
    }
    s
}

/// The trials that exceeded Lemma 1, as readable lines.
pub fn violation_lines(study: &Study) -> Vec<String> {
    study
        .records
        .iter()
        .filter(|r| !r.within_lemma1)
        .map(|r| {
            format!(
                "{}, trial {} (direction {}): cost {:.3} > Lemma 1 bound {:.3}",
                study.configurations[r.config], r.trial, r.direction, r.cost, r.lemma1_upper
            )
        })
        .collect()
}

fn write(path: &Path, bytes: &[u8]) -> Result<(), DfsStudyError> {
    fleetmap_io::files::atomic_write(path, bytes).map_err(|e| DfsStudyError::Output {
        path: path.to_path_buf(),
        reason: e.to_string(),
    })
}

/// Write `dfs_trials.csv`, `dfs_summary.json` and the PNG plots (Fig. 7a–d) into `dir`.
/// Returns the files written.
pub fn write_outputs(study: &Study, dir: &Path) -> Result<Vec<PathBuf>, DfsStudyError> {
    std::fs::create_dir_all(dir).map_err(|e| DfsStudyError::Output {
        path: dir.to_path_buf(),
        reason: e.to_string(),
    })?;
    let mut files = Vec::new();
    let csv = dir.join("dfs_trials.csv");
    write(&csv, trials_csv(study).as_bytes())?;
    files.push(csv);
    let json = dir.join("dfs_summary.json");
    let text = serde_json::to_string_pretty(study).map_err(|e| DfsStudyError::Output {
        path: json.clone(),
        reason: e.to_string(),
    })?;
    write(&json, text.as_bytes())?;
    files.push(json);
    for (name, png) in plot::figures(study)? {
        let path = dir.join(name);
        write(&path, &png)?;
        files.push(path);
    }
    Ok(files)
}

/// A fixed-width table of the summaries (one line per configuration): ALG, Lemma 1, eq. (8)
/// (R = 1 only), Theorem 1 at OPT's lower bound, the lawnmower baseline, Lemma 2, the mean
/// ratios ALG/LM and ALG/max(LM, longest round trip), the worst ALG/Lemma 1, the trials
/// above Lemma 1, and the team's flight and transit shares; then, after a blank line, the
/// allocation comparison over all trials (`modes_table`).
pub fn table(study: &Study) -> String {
    let mut s = format!(
        "{:<6} {:<4} {:<5} {:>5} {:>4} {:>6} | {:>8} {:>8} {:>8} | {:>9} {:>7} {:>8} | {:>9} {:>8} | {:>7} {:>7} {:>6} {:>4} | {:>6} {:>7}\n",
        "sweep",
        "shr",
        "alloc",
        "C",
        "R",
        "ratio",
        "ALG mean",
        "min",
        "max",
        "Lemma1 UB",
        "eq8 UB",
        "Thm1 UB",
        "lawnmower",
        "Lemma2",
        "ALG/LM",
        "ALG/LR",
        "max/UB",
        "viol",
        "flight",
        "transit"
    );
    for x in &study.summaries {
        let c = &x.config;
        let eq8 = x
            .eq8_upper
            .map(|e| format!("{:.1}", e.mean))
            .unwrap_or_else(|| "-".into());
        s.push_str(&format!(
            "{:<6} {:<4} {:<5} {:>5} {:>4} {:>6} | {:>8.1} {:>8.1} {:>8.1} | {:>9.1} {:>7} {:>8.1} | {:>9.1} {:>8.2} | {:>7.2} {:>7.2} {:>6.3} {:>4} | {:>6.2} {:>7.2}\n",
            c.sweep.to_string(),
            c.sharing.to_string(),
            match c.allocation {
                Allocation::Paper => "paper",
                Allocation::NearestFrontier => "near",
                Allocation::Spread => "spread",
            },
            c.cells,
            c.robots,
            c.speed_ratio.to_string(),
            x.cost.mean,
            x.cost.min,
            x.cost.max,
            x.lemma1_upper.mean,
            eq8,
            x.theorem1_upper.mean,
            x.lawnmower_lower.mean,
            x.lemma2_lower.mean,
            x.mean_ratio_to_lawnmower,
            x.mean_ratio_to_lawnmower_or_reach,
            x.max_ratio_to_lemma1,
            x.violations,
            x.mean_flight_share,
            x.mean_transit_share
        ));
    }
    s.push('\n');
    s.push_str(&modes_table(study));
    s
}
