//! The UI state; the pure update function is [`super::update`].
//!
//! `update(&mut App, Event) -> Vec<Effect>` is the whole behaviour of the UI: it reads no
//! clock (time arrives as [`Event::Tick`]), does no I/O and never waits on the network — a
//! command becomes an [`Effect::Command`] for the shell to hand to whoever flies the
//! vehicles, and its outcome comes back later as [`Event::JobResult`]. This is the split of
//! ratatui's component template (`ratatui/templates`, `async/src/app.rs`: events → actions →
//! `update`, `draw` separate) with the side effects returned instead of sent from inside.

use super::config::UiConfig;
use super::keymap::Context;
pub use crate::app::command::{Command, CommandError, Target};
use crate::panes::{LogEntry, Model};
use crossterm::event::KeyEvent;
use fleetmap_core::geo::Cell;
use fleetmap_core::proto::severity::Severity;
use fleetmap_core::time::Time;
use std::fmt;

/// Something that happened, for [`update`](fn@crate::tui::update).
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// A key press (the shell drops releases).
    Key(KeyEvent),
    /// Time passed; `now` is on the same clock as the model's times.
    Tick(Time),
    /// A new snapshot of fleet and mission state.
    Snapshot(Box<Model>),
    /// The outcome of a command the UI asked for.
    JobResult(JobResult),
    /// The terminal now has this many columns and rows.
    Resize(u16, u16),
}

/// Where the UI's data comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SourceKind {
    /// Vehicles on MAVLink links (the title bar's source shows in the "ok" colour; every
    /// other source in the warning colour: nothing there is flying for real).
    Live,
    /// The embedded simulator (`fleetmap demo`).
    Demo,
    /// A built-in sample (synthetic or a fixture).
    Sample,
    /// A recorded replay file.
    Replay,
    /// Generated data for a benchmark.
    Bench,
}

/// The title bar's source: what kind of data the screen shows, and how to say so.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Source {
    /// The kind of data.
    pub kind: SourceKind,
    /// The text, its first word the short form ("LIVE udpin:0.0.0.0:14550").
    pub label: String,
}

impl Source {
    /// A source of `kind` shown as `label`.
    pub fn new(kind: SourceKind, label: impl Into<String>) -> Source {
        Source {
            kind,
            label: label.into(),
        }
    }
}

/// A command with the id its [`JobResult`] will carry.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct CommandRequest {
    /// Unique per [`App`], increasing.
    pub id: u64,
    /// Who.
    pub target: Target,
    /// What.
    pub command: Command,
}

impl fmt::Display for CommandRequest {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.command.verb(), self.target)
    }
}

/// What the shell must do after an update.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Effect {
    /// Execute this command (send it to the fleet / mission runner) and report back with an
    /// [`Event::JobResult`] carrying the same id.
    Command(CommandRequest),
    /// Leave the UI.
    Quit,
}

/// The outcome of a [`CommandRequest`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct JobResult {
    /// The request's id.
    pub id: u64,
    /// `Ok(detail)` when the vehicles accepted it, `Err(why)` otherwise.
    pub outcome: Result<String, CommandError>,
}

/// Zoom levels as (num, den): a cell is 2·num/den characters wide and num/den high.
pub(crate) const ZOOMS: [(i64, i64); 7] = [(1, 8), (1, 4), (1, 2), (1, 1), (2, 1), (3, 1), (4, 1)];
/// The 1:1 level (one cell = 2×1 characters).
pub(crate) const BASE_ZOOM: usize = 3;

/// The panes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Pane {
    /// Vehicle table.
    Fleet,
    /// Grid map.
    Map,
    /// Mission phase and progress.
    Mission,
    /// Messages.
    Log,
}

impl Pane {
    /// Focus order.
    pub(crate) const ORDER: [Pane; 4] = [Pane::Fleet, Pane::Map, Pane::Mission, Pane::Log];

    /// The key context of the pane, if it has its own keys.
    pub fn context(self) -> Option<Context> {
        match self {
            Pane::Fleet => Some(Context::Fleet),
            Pane::Map => Some(Context::Map),
            Pane::Log => Some(Context::Log),
            Pane::Mission => None,
        }
    }

    /// The next pane (`forward`) or the previous one, in focus order.
    pub(super) fn step(self, forward: bool) -> Pane {
        let i = Pane::ORDER.iter().position(|p| *p == self).unwrap_or(0);
        let n = Pane::ORDER.len();
        Pane::ORDER[if forward {
            (i + 1) % n
        } else {
            (i + n - 1) % n
        }]
    }
}

/// Something that waits for `y`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pending {
    /// A command (without id yet: it gets one when confirmed).
    Command {
        /// Who.
        target: Target,
        /// What.
        command: Command,
    },
    /// Leaving the UI.
    Quit,
}

/// A modal layer over the panes.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Overlay {
    /// Nothing.
    None,
    /// The help, scrolled by this many lines.
    Help {
        /// Lines scrolled.
        scroll: u16,
    },
    /// A confirmation dialog opened at `opened_at`.
    Confirm {
        /// What happens on `y`.
        pending: Pending,
        /// When it opened (it expires after the configured timeout).
        opened_at: Time,
    },
    /// The "select vehicle by system id" prompt with what was typed so far.
    Prompt {
        /// Digits typed.
        text: String,
    },
}

/// How the map chooses its viewport.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapMode {
    /// Fit the whole grid if it fits at full size, otherwise follow the selected vehicle.
    Auto,
    /// Fit the whole grid, zooming out as far as needed.
    Fit,
    /// Keep the selected vehicle centred at the chosen zoom.
    Follow,
    /// Centred on a fixed cell at the chosen zoom (after panning).
    Manual {
        /// The centre.
        centre: Cell,
    },
}

/// The map pane's view state.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct MapView {
    /// Index into `ZOOMS` (used by Follow and Manual).
    pub zoom: usize,
    /// Viewport mode.
    pub mode: MapMode,
}

/// Most lines of the UI's own log kept.
pub(crate) const UI_LOG_CAPACITY: usize = 1000;

/// The whole UI state.
#[derive(Clone, Debug)]
pub struct App {
    /// Key map and thresholds.
    pub config: UiConfig,
    /// The latest snapshot.
    pub model: Model,
    /// What the screen shows, said plainly in the title bar ("LIVE", "REPLAY file", "SAMPLE").
    pub source: Source,
    /// Pane with the keyboard focus.
    pub focus: Pane,
    /// In the compact layout, the pane shown below the fleet table.
    pub lower: Pane,
    /// Selected vehicle (system id).
    pub selected: Option<u8>,
    /// Modal layer.
    pub overlay: Overlay,
    /// Map viewport.
    pub map: MapView,
    /// Log lines scrolled back from the newest (0 = follow the newest).
    pub log_scroll: usize,
    /// Messages from the UI itself (commands sent, results, warnings), oldest first.
    pub ui_log: Vec<LogEntry>,
    /// Commands sent whose result has not come back.
    pub pending: Vec<CommandRequest>,
    /// Latest tick.
    pub now: Time,
    /// When the latest snapshot arrived (tick time).
    pub(crate) last_snapshot: Option<Time>,
    /// Terminal size (columns, rows).
    pub size: (u16, u16),
    /// Set once the UI decided to quit.
    pub quit: bool,
    /// Where the shell writes its log (shown in the help).
    pub(crate) log_file: Option<String>,
    next_id: u64,
}

impl App {
    /// A UI with `config`, an empty model and `source` in the title bar.
    pub fn new(config: UiConfig, source: Source) -> App {
        App {
            config,
            model: Model::default(),
            source,
            focus: Pane::Fleet,
            lower: Pane::Map,
            selected: None,
            overlay: Overlay::None,
            map: MapView {
                zoom: BASE_ZOOM,
                mode: MapMode::Auto,
            },
            log_scroll: 0,
            ui_log: Vec::new(),
            pending: Vec::new(),
            now: Time::ZERO,
            last_snapshot: None,
            size: (80, 24),
            quit: false,
            log_file: None,
            next_id: 1,
        }
    }

    /// Add a line to the UI's own log, stamped with the model's time (the clock of every
    /// other log line: the fleet's, the replay's), not the UI's own wall clock, so that the
    /// merged log keeps the order in which things happened.
    pub fn log(&mut self, severity: Severity, text: impl Into<String>) {
        self.ui_log.push(LogEntry {
            time: self.model.time,
            severity,
            sysid: None,
            text: text.into(),
        });
        if self.ui_log.len() > UI_LOG_CAPACITY {
            let excess = self.ui_log.len() - UI_LOG_CAPACITY;
            self.ui_log.drain(..excess);
        }
    }

    /// The model's log and the UI's log merged by time (stable: model lines first on ties).
    pub(crate) fn merged_log(&self) -> Vec<&LogEntry> {
        let mut all: Vec<&LogEntry> = self.model.log.iter().chain(&self.ui_log).collect();
        all.sort_by_key(|e| e.time);
        all
    }

    /// Seconds since the last snapshot, when it is older than the stale threshold.
    pub fn stale_for(&self) -> Option<f64> {
        let limit = self.config.thresholds.stale_after()?;
        let last = self.last_snapshot?;
        let age = self.now.saturating_since(last);
        (age > limit).then_some(age.as_secs_f64())
    }

    /// Send `command` to `target`: a new request, pending until its result comes back.
    pub(super) fn request(&mut self, target: Target, command: Command) -> Vec<Effect> {
        let req = CommandRequest {
            id: self.next_id,
            target,
            command,
        };
        self.next_id += 1;
        self.pending.push(req);
        self.log(Severity::Notice, format!("sent {req}"));
        vec![Effect::Command(req)]
    }
}
