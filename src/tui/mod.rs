//! The terminal user interface (ratatui): app state, a pure update function and one view per
//! pane.
//!
//! Layers (docs/architecture.md, "Layers"): the UI reads [`Model`](crate::panes::Model) snapshots from a `watch` channel and sends
//! [`CommandRequest`]s; it never touches the fleet actor or the network itself. What it draws,
//! the view-model ([`Model`](crate::panes::Model)), is [`crate::panes`]: plain `serde` data an adapter fills from
//! fleet snapshots and the run's panes (or a replay file, or a test).
//!
//! - `app` — [`App`] state and the pure [`update`](fn@update)`(&mut App, Event) -> Vec<Effect>`;
//! - [`view`] — one render function per pane (fleet, map, mission, log, help, dialogs);
//! - `keymap` / `config` — the key table ([`KeyMap`], shared by key handling and help) and
//!   the TOML config file ([`UiConfig`]: keys and warning thresholds);
//! - `shell` — crossterm terminal setup, the tokio event loop ([`run`]), the panic hook;
//! - [`live`] — the view-model filled from a fleet snapshot and a run's state (what the live
//!   session shows);
//! - `kinds` — the mission kinds as the UI sees them (their looks and built-in samples,
//!   through the registry); [`replay`] — JSON Lines recordings of models; [`sample`] — a
//!   generated fleet.
//!
//! `app`, `keymap`, `config`, `shell` and `update` are private: their items have one
//! public path, `fleetmap::tui::Item`. The view-model's `Severity` is the core's
//! (`fleetmap_core::proto::severity::Severity`), imported from there.
//!
//! An adapter drives it like this:
//!
//! ```no_run
//! # async fn demo() -> Result<(), Box<dyn std::error::Error>> {
//! use fleetmap::panes::Model;
//! use fleetmap::tui::{App, ShellIo, ShellOptions, Source, SourceKind, UiConfig};
//! use tokio::sync::mpsc;
//! use fleetmap_io::watch;
//! let (snap_tx, snap_rx) = watch::channel(Model::default());
//! let (cmd_tx, mut cmd_rx) = mpsc::channel(32);
//! let (result_tx, result_rx) = mpsc::channel(32);
//! // elsewhere: snap_tx.send_replace(model) on every fleet change; for every request from
//! // cmd_rx, run it and result_tx.send(JobResult { id: req.id, outcome }).
//! let io = ShellIo { snapshots: snap_rx, job_results: result_rx, commands: cmd_tx };
//! let app = App::new(UiConfig::default(), Source::new(SourceKind::Live, "LIVE udpin:0.0.0.0:14550"));
//! fleetmap::tui::run(app, io, ShellOptions::default()).await?;
//! # drop((snap_tx, result_tx)); Ok(()) }
//! ```

mod app;
mod config;
mod keymap;
pub(crate) mod kinds;
pub mod live;
pub mod replay;
pub mod sample;
pub(crate) mod session;
mod shell;
mod update;
pub mod view;

pub use app::{
    App, Command, CommandError, CommandRequest, Effect, Event, JobResult, MapMode, MapView,
    Overlay, Pane, Pending, Source, SourceKind, Target,
};
pub use config::{ConfigError, Thresholds, UiConfig};
pub use keymap::{ALL_ACTIONS, Action, Context, Key, KeyMap, KeyMapError};
pub use shell::{
    REFRESH, ShellIo, ShellOptions, TerminalGuard, TuiError, install_panic_hook, run, run_loop,
    write_restore_sequence,
};
pub use update::update;
