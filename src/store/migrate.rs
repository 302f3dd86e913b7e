//! Schema versions of the run directory and where migrations hook in.
//!
//! One number, [`SCHEMA_VERSION`], versions the whole directory format: the `run.json`
//! metadata, the `state.json` envelope and the `events.jsonl` line format. Every JSON
//! document the store writes carries it (`run.json` and `state.json` as a
//! `schema_version` field; journal lines are governed by the version in `run.json`).
//!
//! Reading a file:
//! - `schema_version` > [`SCHEMA_VERSION`]: refused with [`StoreError::NewerVersion`]
//!   ("written by a newer fleetmap"), never guessed at;
//! - `schema_version` < [`SCHEMA_VERSION`]: the document (as a `serde_json::Value`) is passed
//!   through the upgrade steps `STEPS[v - 1]` for v = found … SCHEMA_VERSION − 1, each turning
//!   a version-v document into a version-(v+1) one, before it is deserialised. The upgraded
//!   state is written in the current version at the next `save_state`; journal lines are
//!   upgraded on every read (the journal is append-only and never rewritten).
//! - missing, 0, or not an integer: [`StoreError::Corrupt`].
//!
//! Version 1 is the first format, so the step tables are empty. To change the format:
//! bump [`SCHEMA_VERSION`], append one function per document kind to the tables below,
//! and add a test that upgrades a stored version-(n−1) fixture.
//!
//! Runners version their own state types independently: `RunDir::load_state_value`
//! returns the raw JSON so that a runner can migrate its own payload.

use super::StoreError;
use serde_json::Value;
use std::path::Path;

/// The run-directory format version this build writes and the newest it reads.
pub(crate) const SCHEMA_VERSION: u32 = 1;

/// One upgrade step: a version-v document in, a version-(v+1) document out.
type Step = fn(Value) -> Result<Value, StepError>;

/// Why an upgrade step cannot convert a document (the store reports it as
/// [`StoreError::Corrupt`], naming the file, the line and the version).
#[derive(Debug, thiserror::Error)]
#[expect(
    dead_code,
    reason = "constructed by the first upgrade step; version 1, the only one yet, has none"
)]
pub(crate) enum StepError {
    /// A field the step needs is missing.
    #[error("missing {0:?}")]
    Missing(&'static str),
    /// A field holds a value the step cannot convert.
    #[error("{field:?} cannot be upgraded from {found}")]
    Invalid {
        /// The field.
        field: &'static str,
        /// What it holds.
        found: Value,
    },
}

/// Upgrades of `run.json`, indexed by `from_version - 1`.
const META_STEPS: &[Step] = &[];
/// Upgrades of the `state.json` envelope, indexed by `from_version - 1`.
const STATE_STEPS: &[Step] = &[];
/// Upgrades of one `events.jsonl` line, indexed by `from_version - 1`.
const EVENT_STEPS: &[Step] = &[];

/// Which kind of document is being upgraded.
#[derive(Clone, Copy, Debug)]
pub(crate) enum Doc {
    /// `run.json`.
    Meta,
    /// `state.json`.
    State,
    /// One journal line.
    Event,
}

/// Read the `schema_version` of a JSON document, checking it is one this build can read.
pub(crate) fn version_of(path: &Path, line: Option<usize>, doc: &Value) -> Result<u32, StoreError> {
    let corrupt = |reason: String| StoreError::Corrupt {
        path: path.to_path_buf(),
        line,
        reason,
    };
    let v = doc
        .get("schema_version")
        .ok_or_else(|| corrupt("missing \"schema_version\"".into()))?;
    let n = v
        .as_u64()
        .and_then(|n| u32::try_from(n).ok())
        .filter(|n| *n >= 1)
        .ok_or_else(|| {
            corrupt(format!(
                "\"schema_version\" must be an integer ≥ 1, found {v}"
            ))
        })?;
    if n > SCHEMA_VERSION {
        return Err(StoreError::NewerVersion {
            path: path.to_path_buf(),
            found: n,
            supported: SCHEMA_VERSION,
        });
    }
    Ok(n)
}

/// Upgrade `doc` from `from` to [`SCHEMA_VERSION`] (a no-op when it is current).
pub(crate) fn upgrade(
    path: &Path,
    line: Option<usize>,
    kind: Doc,
    from: u32,
    mut doc: Value,
) -> Result<Value, StoreError> {
    let steps = match kind {
        Doc::Meta => META_STEPS,
        Doc::State => STATE_STEPS,
        Doc::Event => EVENT_STEPS,
    };
    for v in from..SCHEMA_VERSION {
        let step = steps
            .get((v - 1) as usize)
            .ok_or_else(|| StoreError::Corrupt {
                path: path.to_path_buf(),
                line,
                reason: format!("no upgrade from schema version {v} to {}", v + 1),
            })?;
        doc = step(doc).map_err(|reason| StoreError::Corrupt {
            path: path.to_path_buf(),
            line,
            reason: format!("upgrading from schema version {v}: {reason}"),
        })?;
        if let Some(obj) = doc.as_object_mut() {
            obj.insert("schema_version".into(), Value::from(v + 1));
        }
    }
    Ok(doc)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn newer_version_is_refused_with_a_clear_message() {
        let e =
            version_of(Path::new("run.json"), None, &json!({"schema_version": 99})).unwrap_err();
        let msg = e.to_string();
        assert!(msg.contains("written by a newer fleetmap"), "{msg}");
        assert!(msg.contains("99"), "{msg}");
    }

    #[test]
    fn missing_or_bad_version_is_corruption() {
        for doc in [
            json!({}),
            json!({"schema_version": 0}),
            json!({"schema_version": "1"}),
        ] {
            let e = version_of(Path::new("state.json"), None, &doc).unwrap_err();
            assert!(matches!(e, StoreError::Corrupt { .. }), "{e}");
        }
    }

    #[test]
    fn current_version_passes_unchanged() {
        let doc = json!({"schema_version": SCHEMA_VERSION, "x": 1});
        let v = version_of(Path::new("s"), None, &doc).unwrap();
        assert_eq!(
            upgrade(Path::new("s"), None, Doc::State, v, doc.clone()).unwrap(),
            doc
        );
    }
}
