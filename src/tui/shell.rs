//! The shell around the pure core: terminal setup and teardown, the async event loop, the
//! panic hook.
//!
//! [`run`] puts the terminal in raw mode on the alternate screen, then [`run_loop`] selects
//! over key events (crossterm's `EventStream`, forwarded by a task), a tick interval, a
//! `watch` channel of [`Model`] snapshots and an `mpsc` of [`JobResult`]s; every event goes
//! through [`update`]. The screen is redrawn at once after a key, a resize, a command's
//! result or a new snapshot, and on a tick when nothing else was drawn since the previous
//! tick: so it is redrawn at least once per tick ([`REFRESH`], 10 times a second) also when
//! no data arrives (the stale-data and confirmation countdowns move on), and a steady stream
//! of snapshots at the tick rate costs about one frame per tick, not two. Commands leave on
//! the caller's `mpsc` with `try_send`: the UI never waits for the network or for a full
//! queue (a command that cannot be queued is reported as failed in the log). The terminal is
//! restored on every exit path, including a panic (the hook is installed before raw mode is
//! entered), as ratatui's own `init`/`restore` do (`ratatui` 0.30, `src/init.rs`:
//! `set_panic_hook`).

use super::app::{App, CommandError, CommandRequest, Effect, Event, JobResult};
use super::update::update;
use super::view;
use crate::panes::Model;
use crossterm::event::{Event as TermEvent, KeyEventKind};
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::watch;
use ratatui::Terminal;
use ratatui::backend::Backend;
use std::collections::VecDeque;
use std::io::{self, Write};
use std::time::Duration;
use tokio::sync::mpsc;

/// A terminal UI failure.
#[derive(Debug, thiserror::Error)]
pub enum TuiError {
    /// Terminal I/O.
    #[error("terminal: {0}")]
    Io(#[from] io::Error),
    /// The backend failed to draw.
    #[error("drawing: {0}")]
    Draw(String),
}

/// The channels between the UI and the rest of the program.
pub struct ShellIo {
    /// Snapshots of fleet and mission state (the latest one is shown).
    pub snapshots: watch::Receiver<Model>,
    /// Outcomes of the commands the UI sent.
    pub job_results: mpsc::Receiver<JobResult>,
    /// Where the UI's commands go.
    pub commands: mpsc::Sender<CommandRequest>,
}

/// The screen's refresh period: the default tick (10 frames a second at least), and the
/// period at which the live session builds a new [`Model`] (`crate::tui::session`).
pub const REFRESH: Duration = Duration::from_millis(100);

/// Loop settings.
#[derive(Clone, Debug)]
pub struct ShellOptions {
    /// Tick interval (clock updates, countdowns, stale-data detection); the screen is redrawn
    /// at least once per tick. Default [`REFRESH`] (100 ms).
    pub tick: Duration,
    /// The clock whose time the ticks carry (the model's clock).
    pub clock: MonotonicClock,
}

impl Default for ShellOptions {
    fn default() -> Self {
        ShellOptions {
            tick: REFRESH,
            clock: MonotonicClock::new(),
        }
    }
}

/// Write the escape sequences that leave the alternate screen and show the cursor.
pub fn write_restore_sequence<W: Write>(w: &mut W) -> io::Result<()> {
    crossterm::execute!(
        w,
        crossterm::terminal::LeaveAlternateScreen,
        crossterm::cursor::Show
    )
}

/// Put the terminal back: raw mode off, main screen, cursor visible. Safe to call when the
/// terminal was never set up.
pub(crate) fn restore_terminal() -> io::Result<()> {
    // Raw mode first: it has more side effects than the alternate screen (as ratatui does).
    let raw = crossterm::terminal::disable_raw_mode();
    let screen = write_restore_sequence(&mut io::stdout());
    raw.and(screen)
}

/// Install a panic hook that calls `restore` and then the previous hook (so the panic
/// message is printed on a usable terminal). Returns nothing; hooks are process-wide.
pub fn install_panic_hook<F>(restore: F)
where
    F: Fn() + Send + Sync + 'static,
{
    let previous = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        restore();
        previous(info);
    }));
}

/// The terminal in UI mode (raw, alternate screen, cursor hidden) for as long as it lives:
/// dropping it restores the terminal, and a panic hook installed by [`TerminalGuard::enter`]
/// restores it on a panic too. [`run`] uses it; a caller with its own loop can as well.
pub struct TerminalGuard {
    _private: (),
}

impl TerminalGuard {
    /// Install the panic hook, then enter raw mode and the alternate screen.
    pub fn enter() -> io::Result<TerminalGuard> {
        install_panic_hook(|| {
            if let Err(e) = restore_terminal() {
                eprintln!("fleetmap: could not restore the terminal: {e}");
            }
        });
        crossterm::terminal::enable_raw_mode()?;
        let guard = TerminalGuard { _private: () };
        crossterm::execute!(
            io::stdout(),
            crossterm::terminal::EnterAlternateScreen,
            crossterm::cursor::Hide
        )?;
        Ok(guard)
    }
}

impl Drop for TerminalGuard {
    fn drop(&mut self) {
        if let Err(e) = restore_terminal() {
            tracing::error!("could not restore the terminal: {e}");
        }
    }
}

/// Forward crossterm's `EventStream` into a channel until the receiver is dropped.
async fn forward_terminal_events(tx: mpsc::Sender<TermEvent>) {
    use futures_core::Stream;
    use std::pin::Pin;
    let mut stream = crossterm::event::EventStream::new();
    loop {
        let next = std::future::poll_fn(|cx| Pin::new(&mut stream).poll_next(cx)).await;
        match next {
            Some(Ok(ev)) => {
                if tx.send(ev).await.is_err() {
                    break;
                }
            }
            Some(Err(e)) => {
                tracing::error!("reading terminal events: {e}");
                break;
            }
            None => break,
        }
    }
}

/// Run the UI on the real terminal until the operator quits; returns the final state.
pub async fn run(app: App, io: ShellIo, options: ShellOptions) -> Result<App, TuiError> {
    let guard = TerminalGuard::enter()?;
    let mut terminal = Terminal::new(ratatui::backend::CrosstermBackend::new(io::stdout()))?;
    let (tx, rx) = mpsc::channel(64);
    // The terminal reader ends with the loop (dropping the set aborts it), before the
    // terminal is restored.
    let mut reader = tokio::task::JoinSet::new();
    reader.spawn(forward_terminal_events(tx));
    let result = run_loop(&mut terminal, app, rx, io, options).await;
    drop(reader);
    drop(guard);
    result
}

/// The event loop on any backend (tests use ratatui's `TestBackend` and a scripted
/// `input` channel of terminal events).
pub async fn run_loop<B: Backend>(
    terminal: &mut Terminal<B>,
    mut app: App,
    mut input: mpsc::Receiver<TermEvent>,
    mut io: ShellIo,
    options: ShellOptions,
) -> Result<App, TuiError> {
    let draw = |terminal: &mut Terminal<B>, app: &App| -> Result<(), TuiError> {
        terminal
            .draw(|f| view::render(app, f))
            .map(|_| ())
            .map_err(|e| TuiError::Draw(e.to_string()))
    };
    if let Ok(size) = terminal.size() {
        update(&mut app, Event::Resize(size.width, size.height));
    }
    update(&mut app, Event::Tick(options.clock.now()));
    let first = io.snapshots.borrow_and_update().clone();
    update(&mut app, Event::Snapshot(Box::new(first)));
    draw(terminal, &app)?;
    let mut tick = tokio::time::interval(options.tick);
    tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut snapshots_open = true;
    // Whether a frame was drawn since the previous tick.
    let mut drawn_since_tick = true;
    loop {
        // Biased: results and snapshots first, so a key acts on the freshest state; keys
        // before ticks. (A watch fires once per new value, so keys cannot starve.)
        let event = tokio::select! {
            biased;
            Some(result) = io.job_results.recv() => Event::JobResult(result),
            changed = io.snapshots.changed(), if snapshots_open => match changed {
                Ok(()) => {
                    let model = io.snapshots.borrow_and_update().clone();
                    Event::Snapshot(Box::new(model))
                }
                Err(_) => {
                    snapshots_open = false;
                    tracing::warn!("the snapshot source closed");
                    continue;
                }
            },
            Some(ev) = input.recv() => match ev {
                TermEvent::Key(k) if k.kind != KeyEventKind::Release => Event::Key(k),
                TermEvent::Resize(w, h) => {
                    terminal.autoresize().map_err(|e| TuiError::Draw(e.to_string()))?;
                    Event::Resize(w, h)
                }
                _ => continue,
            },
            _ = tick.tick() => Event::Tick(options.clock.now()),
        };
        let is_tick = matches!(event, Event::Tick(_));
        let mut effects: VecDeque<Effect> = update(&mut app, event).into();
        let mut quit = false;
        while let Some(effect) = effects.pop_front() {
            match effect {
                Effect::Quit => quit = true,
                Effect::Command(req) => {
                    tracing::info!("operator command {req}");
                    if let Err(e) = io.commands.try_send(req) {
                        let reason = match e {
                            mpsc::error::TrySendError::Full(_) => "command queue full, not sent",
                            mpsc::error::TrySendError::Closed(_) => {
                                "nothing is executing commands, not sent"
                            }
                        };
                        let failed = JobResult {
                            id: req.id,
                            outcome: Err(CommandError::NotSent(reason)),
                        };
                        effects.extend(update(&mut app, Event::JobResult(failed)));
                    }
                }
            }
        }
        if quit {
            break;
        }
        if is_tick && drawn_since_tick {
            // Something else drew in this period already; the next tick draws if nothing does.
            drawn_since_tick = false;
            continue;
        }
        draw(terminal, &app)?;
        drawn_since_tick = !is_tick;
    }
    Ok(app)
}
