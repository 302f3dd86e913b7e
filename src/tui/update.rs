//! How the UI reacts to an event ([`update`]): keys, snapshots, ticks, command results. The
//! state it changes is [`App`]; what it needs of the screen's layout (a log page, the help's
//! length, the map's viewport) it asks [`super::view`], which only reads the state.

use super::app::*;
use super::keymap::{Action, Context, Key};
use super::view;
use crossterm::event::KeyCode;
use fleetmap_core::geo::Cell;
use fleetmap_core::proto::severity::Severity;

impl App {
    fn select_index(&mut self, i: usize) {
        if let Some(v) = self.model.vehicles.get(i) {
            self.selected = Some(v.sysid);
        }
    }

    fn selected_index(&self) -> Option<usize> {
        let id = self.selected?;
        self.model.vehicles.iter().position(|v| v.sysid == id)
    }

    fn step_selection(&mut self, forward: bool) {
        let n = self.model.vehicles.len();
        if n == 0 {
            return;
        }
        let i = match self.selected_index() {
            Some(i) if forward => (i + 1) % n,
            Some(i) => (i + n - 1) % n,
            None => 0,
        };
        self.select_index(i);
    }

    fn select_sysid(&mut self, id: u8) {
        if self.model.vehicle(id).is_some() {
            self.selected = Some(id);
        } else {
            self.log(Severity::Warning, format!("no vehicle with system id {id}"));
        }
    }

    fn ask(&mut self, pending: Pending) {
        self.overlay = Overlay::Confirm {
            pending,
            opened_at: self.now,
        };
    }

    /// The selected vehicle as a command target, or a log line saying there is none.
    fn selected_target(&mut self) -> Option<Target> {
        match self.selected {
            Some(id) if self.model.vehicle(id).is_some() => Some(Target::Vehicle(id)),
            _ => {
                self.log(Severity::Warning, "no vehicle selected");
                None
            }
        }
    }

    fn total_log_lines(&self) -> usize {
        self.model.log.len() + self.ui_log.len()
    }

    fn scroll_log(&mut self, older: isize) {
        let max = self.total_log_lines().saturating_sub(1);
        let cur = self.log_scroll as isize + older;
        self.log_scroll = cur.clamp(0, max as isize) as usize;
    }

    fn log_page(&self) -> isize {
        let rows = view::log_page_rows(self);
        (rows.max(2) - 1) as isize
    }
}

/// Apply `event` to `app`; return what the shell must do.
pub fn update(app: &mut App, event: Event) -> Vec<Effect> {
    match event {
        Event::Tick(now) => {
            app.now = now;
            if let Overlay::Confirm { pending, opened_at } = app.overlay
                && now.saturating_since(opened_at) > app.config.thresholds.confirm_timeout()
            {
                app.overlay = Overlay::None;
                app.log(
                    Severity::Warning,
                    format!("confirmation expired: {} not sent", pending_label(&pending)),
                );
            }
            Vec::new()
        }
        Event::Snapshot(model) => {
            app.model = *model;
            app.last_snapshot = Some(app.now);
            if app.selected_index().is_none() {
                app.selected = app.model.vehicles.first().map(|v| v.sysid);
            }
            let max = app.total_log_lines().saturating_sub(1);
            app.log_scroll = app.log_scroll.min(max);
            Vec::new()
        }
        Event::JobResult(result) => {
            let req = app
                .pending
                .iter()
                .position(|r| r.id == result.id)
                .map(|i| app.pending.remove(i));
            let what = match req {
                Some(r) => r.to_string(),
                None => format!("command #{}", result.id),
            };
            match result.outcome {
                Ok(detail) if detail.is_empty() => {
                    app.log(Severity::Notice, format!("{what}: accepted"))
                }
                Ok(detail) => app.log(Severity::Notice, format!("{what}: accepted, {detail}")),
                Err(reason) => app.log(Severity::Error, format!("{what} FAILED: {reason}")),
            }
            Vec::new()
        }
        Event::Resize(w, h) => {
            app.size = (w, h);
            Vec::new()
        }
        Event::Key(ev) => on_key(app, Key::from_event(&ev)),
    }
}

fn pending_label(p: &Pending) -> String {
    match p {
        Pending::Command { target, command } => format!("{} ({target})", command.verb()),
        Pending::Quit => "quit".to_string(),
    }
}

fn on_key(app: &mut App, key: Key) -> Vec<Effect> {
    let keys = &app.config.keys;
    if keys.keys(Action::QuitNow).contains(&key) {
        app.quit = true;
        return vec![Effect::Quit];
    }
    match app.overlay.clone() {
        Overlay::Confirm { pending, .. } => match keys.lookup(Context::Dialog, key) {
            Some(Action::Confirm) => {
                app.overlay = Overlay::None;
                match pending {
                    Pending::Command { target, command } => app.request(target, command),
                    Pending::Quit => {
                        app.quit = true;
                        vec![Effect::Quit]
                    }
                }
            }
            Some(Action::Cancel) => {
                app.overlay = Overlay::None;
                app.log(
                    Severity::Info,
                    format!("cancelled: {}", pending_label(&pending)),
                );
                Vec::new()
            }
            _ => Vec::new(),
        },
        Overlay::Help { scroll } => {
            let action = keys
                .lookup(Context::Help, key)
                .or_else(|| keys.lookup(Context::Dialog, key))
                .or_else(|| keys.lookup(Context::Global, key));
            match action {
                Some(Action::HelpUp) => {
                    app.overlay = Overlay::Help {
                        scroll: scroll.saturating_sub(1),
                    }
                }
                Some(Action::HelpDown) => {
                    let max = view::help::line_count(&app.config.keys).saturating_sub(1) as u16;
                    app.overlay = Overlay::Help {
                        scroll: (scroll + 1).min(max),
                    }
                }
                Some(Action::Cancel) | Some(Action::Help) => app.overlay = Overlay::None,
                _ => {}
            }
            Vec::new()
        }
        Overlay::Prompt { mut text } => {
            if keys.lookup(Context::Dialog, key) == Some(Action::Cancel) {
                app.overlay = Overlay::None;
                return Vec::new();
            }
            match key.code {
                KeyCode::Char(c) if c.is_ascii_digit() && key.mods.is_empty() => {
                    if text.len() < 3 {
                        text.push(c);
                    }
                    app.overlay = Overlay::Prompt { text };
                }
                KeyCode::Backspace => {
                    text.pop();
                    app.overlay = Overlay::Prompt { text };
                }
                KeyCode::Enter => {
                    app.overlay = Overlay::None;
                    match text.parse::<u16>() {
                        Ok(id @ 1..=255) => app.select_sysid(id as u8),
                        _ => app.log(
                            Severity::Warning,
                            format!("{text:?} is not a system id (1-255)"),
                        ),
                    }
                }
                _ => {}
            }
            Vec::new()
        }
        Overlay::None => {
            let action = app
                .focus
                .context()
                .and_then(|c| keys.lookup(c, key))
                .or_else(|| keys.lookup(Context::Global, key));
            match action {
                Some(a) => perform(app, a),
                None => Vec::new(),
            }
        }
    }
}

/// Do what `action` means in the normal (no overlay) state.
fn perform(app: &mut App, action: Action) -> Vec<Effect> {
    let dangerous = |app: &mut App, target: Option<Target>, command: Command| {
        if let Some(target) = target {
            app.ask(Pending::Command { target, command });
        }
        Vec::new()
    };
    match action {
        Action::Help => {
            app.overlay = Overlay::Help { scroll: 0 };
            Vec::new()
        }
        Action::Quit => {
            app.ask(Pending::Quit);
            Vec::new()
        }
        Action::QuitNow => {
            app.quit = true;
            vec![Effect::Quit]
        }
        Action::FocusNext | Action::FocusPrev => {
            app.focus = app.focus.step(action == Action::FocusNext);
            if app.focus != Pane::Fleet {
                app.lower = app.focus;
            }
            Vec::new()
        }
        Action::NextVehicle | Action::FleetDown => {
            app.step_selection(true);
            Vec::new()
        }
        Action::PrevVehicle | Action::FleetUp => {
            app.step_selection(false);
            Vec::new()
        }
        Action::SelectNumber(n) => {
            app.select_sysid(n);
            Vec::new()
        }
        Action::SelectById => {
            app.overlay = Overlay::Prompt {
                text: String::new(),
            };
            Vec::new()
        }
        Action::ZoomIn | Action::ZoomOut => {
            let vp = view::map::current_viewport(app);
            let zoom = if action == Action::ZoomIn {
                (vp.zoom + 1).min(view::map::ZOOMS.len() - 1)
            } else {
                vp.zoom.saturating_sub(1)
            };
            app.map.zoom = zoom;
            if app.map.mode != MapMode::Follow {
                app.map.mode = MapMode::Manual { centre: vp.centre };
            }
            Vec::new()
        }
        Action::ZoomFit => {
            app.map.mode = MapMode::Fit;
            Vec::new()
        }
        Action::FollowSelected => {
            let vp = view::map::current_viewport(app);
            app.map.zoom = vp.zoom;
            app.map.mode = MapMode::Follow;
            Vec::new()
        }
        Action::PanNorth | Action::PanSouth | Action::PanWest | Action::PanEast => {
            let vp = view::map::current_viewport(app);
            let (dr, dc) = match action {
                Action::PanNorth => (vp.page_rows, 0),
                Action::PanSouth => (-vp.page_rows, 0),
                Action::PanWest => (0, -vp.page_cols),
                _ => (0, vp.page_cols),
            };
            let map = &app.model.map;
            let mut centre = Cell::new(vp.centre.row + dr, vp.centre.col + dc);
            if !map.is_empty() {
                let (sw, ne) = (map.south_west, map.north_east());
                centre.row = centre.row.clamp(sw.row, ne.row);
                centre.col = centre.col.clamp(sw.col, ne.col);
            }
            app.map.zoom = vp.zoom;
            app.map.mode = MapMode::Manual { centre };
            Vec::new()
        }
        Action::LogUp => {
            app.scroll_log(1);
            Vec::new()
        }
        Action::LogDown => {
            app.scroll_log(-1);
            Vec::new()
        }
        Action::LogPageUp => {
            let p = app.log_page();
            app.scroll_log(p);
            Vec::new()
        }
        Action::LogPageDown => {
            let p = app.log_page();
            app.scroll_log(-p);
            Vec::new()
        }
        Action::LogLatest => {
            app.log_scroll = 0;
            Vec::new()
        }
        Action::LogOldest => {
            app.log_scroll = app.total_log_lines().saturating_sub(1);
            Vec::new()
        }
        Action::Start => dangerous(app, Some(Target::All), Command::Start),
        Action::Resume => dangerous(app, Some(Target::All), Command::Resume),
        Action::RtlAll => dangerous(app, Some(Target::All), Command::Rtl),
        Action::RtlVehicle => {
            let t = app.selected_target();
            dangerous(app, t, Command::Rtl)
        }
        Action::Land => {
            let t = app.selected_target();
            dangerous(app, t, Command::Land)
        }
        Action::Arm => {
            let t = app.selected_target();
            dangerous(app, t, Command::Arm)
        }
        Action::Disarm => {
            let t = app.selected_target();
            dangerous(app, t, Command::Disarm)
        }
        Action::BatterySwapped => {
            let t = app.selected_target();
            dangerous(app, t, Command::BatterySwapped)
        }
        Action::PauseAll => app.request(Target::All, Command::Hold),
        Action::HoldVehicle => match app.selected_target() {
            Some(t) => app.request(t, Command::Hold),
            None => Vec::new(),
        },
        // Overlay-only actions do nothing without their overlay.
        Action::Confirm | Action::Cancel | Action::HelpUp | Action::HelpDown => Vec::new(),
    }
}
