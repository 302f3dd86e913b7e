//! Errors of the run store.

use std::path::PathBuf;

/// Everything that can go wrong while creating, opening, reading or writing a run directory.
///
/// Messages name the file (and the line for the journal) and say what was expected.
#[derive(Debug, thiserror::Error)]
pub enum StoreError {
    /// A file-system operation failed.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory involved.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// `RunDir::create` was given a directory that already holds files.
    #[error("{}: already exists and is not empty (refusing to overwrite a run)", path.display())]
    AlreadyExists {
        /// The directory.
        path: PathBuf,
    },
    /// The directory has no `run.json`: it is not a run, or its creation never finished.
    #[error("{}: not a fleetmap run directory (no run.json)", path.display())]
    NotARun {
        /// The directory.
        path: PathBuf,
    },
    /// A file carries a schema version newer than this build understands.
    #[error(
        "{}: written by a newer fleetmap (schema version {found}; this build reads versions up to {supported})",
        path.display()
    )]
    NewerVersion {
        /// The file.
        path: PathBuf,
        /// The version found in the file.
        found: u32,
        /// The newest version this build reads (`migrate::SCHEMA_VERSION`).
        supported: u32,
    },
    /// A file is damaged: not valid JSON, a field missing, a journal line out of sequence.
    /// `line` is 1-based (for `events.jsonl`, the journal line).
    #[error("{}{}: corrupt: {reason}", path.display(), line.map(|l| format!(":{l}")).unwrap_or_default())]
    Corrupt {
        /// The file.
        path: PathBuf,
        /// The 1-based line, when known.
        line: Option<usize>,
        /// What is wrong.
        reason: String,
    },
    /// `state.json` belongs to a different kind of run than `run.json` says.
    #[error("{}: the state is for a {found:?} run but run.json says {expected:?}", path.display())]
    KindMismatch {
        /// The state file.
        path: PathBuf,
        /// The kind in `run.json`.
        expected: String,
        /// The kind in `state.json`.
        found: String,
    },
    /// A value could not be turned into JSON (e.g. a map with non-string keys, a NaN).
    #[error("cannot serialise {what}: {source}")]
    Serialize {
        /// What was being written.
        what: &'static str,
        /// serde_json's error.
        #[source]
        source: serde_json::Error,
    },
    /// A file name given for `images/` or `exports/` is not a plain file name.
    #[error("{name:?} is not a plain file name (no directories, not empty, not . or ..)")]
    InvalidName {
        /// The rejected name.
        name: String,
    },
}

impl StoreError {
    pub(crate) fn io(path: impl Into<PathBuf>) -> impl FnOnce(std::io::Error) -> StoreError {
        let path = path.into();
        move |source| StoreError::Io { path, source }
    }
}
