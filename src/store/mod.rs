//! The run directory: crash-safe state snapshots and the append-only event journal.

pub mod atomic;

pub use atomic::atomic_write;
