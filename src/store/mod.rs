//! The run directory: crash-safe state snapshots and the append-only event journal.
//!
//! A *run* is a directory ([`RunDir`]): `run.json` ([`RunMeta`]: kind, mission source,
//! connections), `mission.toml` (copy of the mission definition), `state.json` (the latest
//! snapshot, replaced atomically after every change), `events.jsonl` (one `{"seq", "event"}`
//! object per line, fsync per record), and `images/`, `exports/` created on demand.
//! The store is generic: runners save their own state and event types (any serde type).
//!
//! ```no_run
//! use fleetmap::store::{RunDir, RunMeta};
//! # fn main() -> Result<(), fleetmap::store::StoreError> {
//! let mut run = RunDir::create("runs/r1", RunMeta::new("runway-mapping", 0), None)?;
//! let seq = run.append_event(&serde_json::json!({"visited": [3, 4]}))?; // durable now
//! run.save_state(&serde_json::json!({"tree": []}))?;
//! let run = RunDir::open("runs/r1")?;
//! let log = run.read_events::<serde_json::Value>()?; // log.torn_tail after a crash
//! # let _ = (seq, log); Ok(()) }
//! ```

mod error;
pub mod journal;
pub(crate) mod migrate;
mod run;
pub mod task;

pub use error::StoreError;
pub use run::{RunDir, RunMeta, StateEnvelope};
pub(crate) use task::RunStore;
