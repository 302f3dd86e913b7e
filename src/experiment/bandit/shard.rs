//! A study split over many machines: shard K of N runs the trials t with t mod N = K − 1 of
//! every variant, writes them whole ([`ShardFile`]), and [`merge`] joins the N parts into the
//! study they came from. Trial t of a study runs on the same world and sensing stream wherever
//! it runs ([`super::run_seeded`]), so the merged study's trials are the ones an undivided run
//! gives (the solve times aside, which are measured on whatever machine ran the part).

use super::{Study, TrialResult};
use serde::{Deserialize, Serialize};
use std::fmt;
use std::str::FromStr;

/// Part K of N of a study (1 ≤ K ≤ N).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Shard {
    /// K, 1-based (a Slurm array's `SLURM_ARRAY_TASK_ID` when the array is `1-N`).
    pub index: usize,
    /// N.
    pub count: usize,
}

impl Shard {
    /// The whole study (1/1).
    pub(crate) const WHOLE: Shard = Shard { index: 1, count: 1 };

    /// Whether trial `trial` belongs to this part.
    pub fn holds(self, trial: usize) -> bool {
        trial % self.count == self.index - 1
    }

    /// The file a part is written to: `shard-K-of-N.json`.
    pub fn file_name(self) -> String {
        format!("shard-{}-of-{}.json", self.index, self.count)
    }
}

impl fmt::Display for Shard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

/// A `--shard` that is not `K/N` with 1 ≤ K ≤ N (the text given).
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0:?} is not K/N with 1 ≤ K ≤ N (e.g. 3/10)")]
pub struct BadShard(pub String);

impl FromStr for Shard {
    type Err = BadShard;

    fn from_str(s: &str) -> Result<Shard, BadShard> {
        let bad = || BadShard(s.to_string());
        let (k, n) = s.split_once('/').ok_or_else(bad)?;
        let k: usize = k.trim().parse().map_err(|_| bad())?;
        let n: usize = n.trim().parse().map_err(|_| bad())?;
        if k == 0 || k > n {
            return Err(bad());
        }
        Ok(Shard { index: k, count: n })
    }
}

/// The version of [`ShardFile`]'s layout.
pub(crate) const SHARD_FORMAT: u32 = 1;

/// One part of a study as written to disk: the study it belongs to, which part, and every
/// trial of the part, whole (epochs included), so that the joined study can write the same
/// CSV, summary and plot as an undivided run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ShardFile {
    /// `SHARD_FORMAT`.
    pub format: u32,
    /// The whole study (every part holds the same).
    pub study: Study,
    /// Which part.
    pub shard: Shard,
    /// The part's trials.
    pub results: Vec<TrialResult>,
}

/// Why parts do not join into one study.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MergeError {
    /// Nothing to join.
    #[error("no parts to merge")]
    Empty,
    /// A part of another layout version.
    #[error("{part}: shard file format {found}, this fleetmap reads {SHARD_FORMAT}")]
    Format {
        /// The part's name.
        part: String,
        /// Its format.
        found: u32,
    },
    /// Parts of different studies (preset, seed, trials, or a variant's parameters).
    #[error(
        "{part} belongs to another study than {first} (preset, seed, trials or variants differ)"
    )]
    OtherStudy {
        /// The first part's name.
        first: String,
        /// The part that differs.
        part: String,
    },
    /// Parts of different splits.
    #[error("{part} is part {shard} but {first} splits the study into {count}")]
    OtherSplit {
        /// The first part's name.
        first: String,
        /// The part that differs.
        part: String,
        /// Its shard.
        shard: Shard,
        /// The first part's N.
        count: usize,
    },
    /// The same part twice.
    #[error("part {0} given twice")]
    Duplicate(Shard),
    /// Parts missing.
    #[error("parts missing: {0} (of {1})")]
    Missing(String, usize),
    /// A part whose trials are not the ones its shard runs.
    #[error("{part}: {why}")]
    Contents {
        /// The part's name.
        part: String,
        /// What is wrong.
        why: String,
    },
}

/// Join the parts (each with a name for the messages, e.g. its path) into the study and its
/// trials, ordered as an undivided run orders them (variant, then trial). Every part must
/// belong to the same study and split, each K of 1..=N exactly once, each holding exactly the
/// trials of its shard.
pub fn merge(parts: Vec<(String, ShardFile)>) -> Result<(Study, Vec<TrialResult>), MergeError> {
    let Some((first_name, first)) = parts.first() else {
        return Err(MergeError::Empty);
    };
    let (first_name, study, count) = (
        first_name.clone(),
        first.study.clone().normalized(),
        first.shard.count,
    );
    let mut seen = vec![false; count];
    let mut results = Vec::new();
    for (name, part) in parts {
        if part.format != SHARD_FORMAT {
            return Err(MergeError::Format {
                part: name,
                found: part.format,
            });
        }
        if part.study.normalized() != study {
            return Err(MergeError::OtherStudy {
                first: first_name,
                part: name,
            });
        }
        let shard = part.shard;
        if shard.count != count || shard.index == 0 || shard.index > count {
            return Err(MergeError::OtherSplit {
                first: first_name,
                part: name,
                shard,
                count,
            });
        }
        if std::mem::replace(&mut seen[shard.index - 1], true) {
            return Err(MergeError::Duplicate(shard));
        }
        let mut expected: Vec<(usize, usize)> = study.tasks(shard);
        let mut got = Vec::with_capacity(part.results.len());
        for r in &part.results {
            let Some(v) = study.variants.iter().position(|c| c.label == r.label) else {
                return Err(MergeError::Contents {
                    part: name,
                    why: format!("a trial of unknown variant {:?}", r.label),
                });
            };
            got.push((v, r.trial));
        }
        expected.sort_unstable();
        got.sort_unstable();
        if got != expected {
            return Err(MergeError::Contents {
                part: name,
                why: format!(
                    "holds {} trials, not the {} of part {shard}",
                    got.len(),
                    expected.len()
                ),
            });
        }
        results.extend(part.results);
    }
    let missing: Vec<String> = (1..=count)
        .filter(|k| !seen[k - 1])
        .map(|k| k.to_string())
        .collect();
    if !missing.is_empty() {
        return Err(MergeError::Missing(missing.join(", "), count));
    }
    let variant = |r: &TrialResult| study.variants.iter().position(|c| c.label == r.label);
    results.sort_by_key(|r| (variant(r), r.trial));
    Ok((study, results))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::experiment::bandit::{Preset, StudyConfig};

    fn study() -> Study {
        Study {
            preset: Preset::Table1,
            seed: 7,
            trials: 5,
            variants: vec![
                StudyConfig {
                    label: "a".into(),
                    ..StudyConfig::default()
                },
                StudyConfig {
                    label: "b".into(),
                    ..StudyConfig::default()
                },
            ],
            streams: Vec::new(),
        }
    }

    /// A part with placeholder trials (no planner run): merge only checks which trials a part
    /// holds.
    fn part(study: &Study, shard: Shard) -> (String, ShardFile) {
        let results = study
            .tasks(shard)
            .into_iter()
            .map(|(v, t)| TrialResult {
                label: study.variants[v].label.clone(),
                trial: t,
                world_seed: t as u64,
                epochs_interesting: Some(t),
                epochs_all: Some(t + 1),
                label_errors: 0,
                n_interesting: 1,
                n_cells: 2,
                epochs: Vec::new(),
                failure: None,
                p_max: None,
            })
            .collect();
        (
            format!("part {shard}"),
            ShardFile {
                format: SHARD_FORMAT,
                study: study.clone(),
                shard,
                results,
            },
        )
    }

    #[test]
    fn shards_parse_and_partition_the_trials() {
        assert_eq!(
            "3/10".parse::<Shard>(),
            Ok(Shard {
                index: 3,
                count: 10
            })
        );
        for bad in ["0/3", "4/3", "3", "a/b", "1/0", ""] {
            assert!(bad.parse::<Shard>().is_err(), "{bad}");
        }
        let s = study();
        let mut all: Vec<(usize, usize)> = (1..=3)
            .flat_map(|k| s.tasks(Shard { index: k, count: 3 }))
            .collect();
        all.sort_unstable();
        assert_eq!(all, s.tasks(Shard::WHOLE));
        assert_eq!(all.len(), 10);
        // More parts than trials: the extra parts are empty, and still join.
        assert!(s.tasks(Shard { index: 7, count: 7 }).is_empty());
    }

    #[test]
    fn parts_join_in_any_order_into_the_undivided_order() {
        let s = study();
        let whole = part(&s, Shard::WHOLE).1.results;
        let parts: Vec<_> = [3, 1, 2]
            .iter()
            .map(|&k| part(&s, Shard { index: k, count: 3 }))
            .collect();
        let (joined, results) = merge(parts).unwrap();
        assert_eq!(joined, s.clone().normalized());
        assert_eq!(results, whole);
        // A part that names the streams joins one that leaves them implicit.
        let mut named = part(&s, Shard { index: 1, count: 2 });
        named.1.study = named.1.study.normalized();
        assert!(merge(vec![named, part(&s, Shard { index: 2, count: 2 })]).is_ok());
    }

    #[test]
    fn parts_that_do_not_make_one_study_are_refused() {
        let s = study();
        let p = |k| part(&s, Shard { index: k, count: 3 });
        assert_eq!(merge(vec![]), Err(MergeError::Empty));
        assert!(matches!(
            merge(vec![p(1), p(3)]),
            Err(MergeError::Missing(m, 3)) if m == "2"
        ));
        assert!(matches!(
            merge(vec![p(1), p(2), p(2), p(3)]),
            Err(MergeError::Duplicate(_))
        ));
        let mut other = s.clone();
        other.seed = 8;
        let q = part(&other, Shard { index: 2, count: 3 });
        assert!(matches!(
            merge(vec![p(1), q, p(3)]),
            Err(MergeError::OtherStudy { .. })
        ));
        let halves = part(&s, Shard { index: 2, count: 2 });
        assert!(matches!(
            merge(vec![p(1), halves]),
            Err(MergeError::OtherSplit { .. })
        ));
        let mut short = p(2);
        short.1.results.pop();
        assert!(matches!(
            merge(vec![p(1), short, p(3)]),
            Err(MergeError::Contents { .. })
        ));
        let mut old = p(1);
        old.1.format = 0;
        assert!(matches!(
            merge(vec![old, p(2), p(3)]),
            Err(MergeError::Format { .. })
        ));
    }
}
