//! Drawing: one view function per pane, all reading `&App` (never changing it), plus the
//! layout that decides which panes a terminal of a given size gets.
//!
//! Two layouts:
//! - **wide** (at least `WIDE_MIN` columns × rows): the map on the left, the fleet table,
//!   the mission panel and the log stacked on the right — everything at once;
//! - **compact** (down to `MIN_SIZE`, e.g. 80×24): the fleet table on top and *one* of
//!   map / mission / log below, chosen with the focus keys (Tab); the lower pane's title
//!   lists the three so the operator sees what else there is.
//!
//! Both have a title bar (source, mission, phase, status, stale-data and pending-command
//! warnings) and a key-hint bar generated from the key map.

pub mod dialog;
pub mod fleet;
pub mod help;
pub mod log;
pub mod map;
pub mod mission;
pub(crate) mod theme;

use super::app::{App, Overlay, Pane};
use super::keymap::Action;
use crate::panes::format_hms;
use ratatui::Frame;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, BorderType, Paragraph};

/// Smallest terminal the UI draws in (columns, rows); below it a message asks for more.
pub(crate) const MIN_SIZE: (u16, u16) = (60, 16);
/// Smallest terminal that gets the wide layout (columns, rows): the full fleet table
/// ([`fleet::FULL_WIDTH`]) and a map of at least 35 columns beside it.
pub(crate) const WIDE_MIN: (u16, u16) = (185, 40);

/// Where each pane goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Areas {
    /// Title bar (one row).
    pub title: Rect,
    /// Fleet table.
    pub fleet: Rect,
    /// Map, when shown.
    pub map: Option<Rect>,
    /// Mission panel, when shown.
    pub mission: Option<Rect>,
    /// Log, when shown.
    pub log: Option<Rect>,
    /// Key hints (one row).
    pub(crate) hints: Rect,
    /// Whether this is the compact layout.
    pub(crate) compact: bool,
}

/// The layout for `area`, or `None` when the terminal is too small.
pub fn layout(app: &App, area: Rect) -> Option<Areas> {
    layout_with_lower(app, area, app.lower)
}

/// [`layout`] as if `lower` were the pane shown below the fleet in the compact layout.
pub(crate) fn layout_with_lower(app: &App, area: Rect, lower_pane: Pane) -> Option<Areas> {
    if area.width < MIN_SIZE.0 || area.height < MIN_SIZE.1 {
        return None;
    }
    let [title, body, hints] = area.layout(&Layout::vertical([
        Constraint::Length(1),
        Constraint::Fill(1),
        Constraint::Length(1),
    ]));
    let n = app.model.vehicles.len() as u16;
    if area.width >= WIDE_MIN.0 && area.height >= WIDE_MIN.1 {
        let right_w = (area.width * 45 / 100).clamp(fleet::FULL_WIDTH + 2, fleet::FULL_WIDTH + 5);
        let [map_area, right] = body.layout(&Layout::horizontal([
            Constraint::Fill(1),
            Constraint::Length(right_w),
        ]));
        let mission_h = mission::height_wanted(app, right_w.saturating_sub(2)) + 2;
        let fleet_h = (n.max(1) + 3).min(body.height * 55 / 100).max(6);
        let [fleet_area, mission_area, log_area] = right.layout(&Layout::vertical([
            Constraint::Length(fleet_h),
            Constraint::Length(mission_h),
            Constraint::Min(5),
        ]));
        Some(Areas {
            title,
            fleet: fleet_area,
            map: Some(map_area),
            mission: Some(mission_area),
            log: Some(log_area),
            hints,
            compact: false,
        })
    } else {
        let fleet_h = (n.max(1) + 3).min((body.height / 3).max(5));
        let [fleet_area, lower] = body.layout(&Layout::vertical([
            Constraint::Length(fleet_h),
            Constraint::Fill(1),
        ]));
        let (mut map, mut mission, mut log) = (None, None, None);
        match lower_pane {
            Pane::Mission => mission = Some(lower),
            Pane::Log => log = Some(lower),
            Pane::Map | Pane::Fleet => map = Some(lower),
        }
        Some(Areas {
            title,
            fleet: fleet_area,
            map,
            mission,
            log,
            hints,
            compact: true,
        })
    }
}

/// Draw the whole screen.
pub fn render(app: &App, frame: &mut Frame) {
    let area = frame.area();
    let Some(areas) = layout(app, area) else {
        let msg = format!(
            "Terminal too small: {}x{}. fleetmap needs at least {}x{}.",
            area.width, area.height, MIN_SIZE.0, MIN_SIZE.1
        );
        frame.render_widget(
            Paragraph::new(msg)
                .style(theme::alarm())
                .wrap(ratatui::widgets::Wrap { trim: true }),
            area,
        );
        return;
    };
    title_bar(app, frame, areas.title);
    fleet::render(app, frame, areas.fleet);
    if let Some(r) = areas.map {
        map::render(app, frame, r, areas.compact);
    }
    if let Some(r) = areas.mission {
        mission::render(app, frame, r, areas.compact);
    }
    if let Some(r) = areas.log {
        log::render(app, frame, r, areas.compact);
    }
    hints_bar(app, frame, areas.hints);
    match &app.overlay {
        Overlay::None => {}
        Overlay::Help { scroll } => help::render(app, frame, area, *scroll),
        Overlay::Confirm { pending, opened_at } => {
            dialog::render_confirm(app, frame, area, pending, *opened_at)
        }
        Overlay::Prompt { text } => dialog::render_prompt(app, frame, area, text),
    }
}

/// A pane's frame: bold double border in the focus colour when focused.
pub(crate) fn pane_block<'a>(app: &App, pane: Pane, title: Line<'a>) -> Block<'a> {
    let focused = app.focus == pane;
    Block::bordered()
        .border_type(if focused {
            BorderType::Double
        } else {
            BorderType::Plain
        })
        .border_style(if focused {
            theme::border_focused()
        } else {
            theme::border()
        })
        .title(title)
}

/// Title text of a pane: its name, reversed when focused.
pub(crate) fn pane_title(app: &App, pane: Pane, name: &str) -> Span<'static> {
    if app.focus == pane {
        Span::styled(format!(" {name} "), theme::selected())
    } else {
        Span::styled(format!(" {name} "), theme::strong())
    }
}

/// In the compact layout, the lower pane's title: all three names, the shown one marked.
pub(crate) fn lower_tabs(app: &App, shown: Pane) -> Line<'static> {
    let mut spans = Vec::new();
    for (pane, name) in [
        (Pane::Map, "Map"),
        (Pane::Mission, "Mission"),
        (Pane::Log, "Log"),
    ] {
        if pane == shown {
            spans.push(pane_title(app, pane, name));
        } else {
            spans.push(Span::styled(format!(" {name} "), theme::text()));
        }
    }
    let tab = app
        .config
        .keys
        .keys(Action::FocusNext)
        .first()
        .map(|k| k.to_string())
        .unwrap_or_default();
    if !tab.is_empty() {
        spans.push(Span::styled(format!("({tab}) "), theme::text()));
    }
    Line::from(spans)
}

fn title_bar(app: &App, frame: &mut Frame, area: Rect) {
    use crate::panes::RunStatus;
    let m = &app.model.mission;
    let source_style = if app.source.kind == crate::tui::app::SourceKind::Live {
        theme::ok()
    } else {
        theme::warn()
    };
    let status_style = match m.status {
        RunStatus::Failed | RunStatus::BatterySwap => theme::alarm(),
        RunStatus::Paused | RunStatus::BeyondReach => theme::warn(),
        _ => theme::strong(),
    };
    // What must always show, in order; the long source label and the mission name are added
    // only when the line has room for them.
    let short_source = app
        .source
        .label
        .split([' ', ':'])
        .next()
        .unwrap_or_default()
        .to_string();
    let mut essentials: Vec<Span> = Vec::new();
    if let Some(age) = app.stale_for() {
        essentials.push(Span::styled(
            format!(" NO DATA {:.0}s ", age.floor()),
            theme::alarm(),
        ));
        essentials.push(Span::raw(" "));
    } else if app.last_snapshot.is_none() {
        essentials.push(Span::styled(" WAITING FOR DATA ", theme::warn()));
        essentials.push(Span::raw(" "));
    }
    essentials.push(Span::styled(format!("{} ", m.phase), theme::strong()));
    essentials.push(Span::styled(
        format!(" {} ", m.status.label()),
        status_style,
    ));
    essentials.push(Span::styled(
        format!(" T+{} ", format_hms(app.model.time.as_secs_f64())),
        theme::text(),
    ));
    if let Some(x) = app.model.sim_speed {
        // the simulator's achieved speed (lock-step: below its ceiling on a busy machine)
        essentials.push(Span::styled(format!(" {x:.1}× "), theme::text()));
    }
    if !app.pending.is_empty() {
        essentials.push(Span::styled(
            format!(" {} cmd pending ", app.pending.len()),
            theme::warn(),
        ));
    }
    let width = |spans: &[Span]| spans.iter().map(|s| s.width()).sum::<usize>();
    let head = Span::styled(" fleetmap ", theme::title_bar());
    let fixed = head.width() + 1 + width(&essentials);
    let long_source = format!(" {} ", app.source.label);
    let room = (area.width as usize).saturating_sub(fixed);
    let mut spans = vec![head, Span::raw(" ")];
    let source = if long_source.chars().count() < room {
        long_source
    } else {
        format!(" {short_source} ")
    };
    let used = fixed + source.chars().count() + 1;
    spans.push(Span::styled(source, source_style));
    spans.push(Span::raw(" "));
    let name = format!("{} ", m.name);
    if !m.name.is_empty() && used + name.chars().count() <= area.width as usize {
        spans.push(Span::styled(name, theme::strong()));
    }
    spans.extend(essentials);
    frame.render_widget(Paragraph::new(Line::from(spans)), area);
}

fn hints_bar(app: &App, frame: &mut Frame, area: Rect) {
    let keys = &app.config.keys;
    let items: Vec<(Action, &str)> = match app.overlay {
        Overlay::Confirm { .. } => vec![(Action::Confirm, "yes"), (Action::Cancel, "no")],
        Overlay::Help { .. } => vec![
            (Action::Cancel, "close"),
            (Action::HelpDown, "scroll"),
            (Action::QuitNow, "quit now"),
        ],
        Overlay::Prompt { .. } => vec![(Action::Cancel, "cancel")],
        Overlay::None => vec![
            (Action::Help, "help"),
            (Action::FocusNext, "pane"),
            (Action::NextVehicle, "next"),
            (Action::Start, "start"),
            (Action::PauseAll, "pause"),
            (Action::Resume, "resume"),
            (Action::RtlVehicle, "RTL"),
            (Action::RtlAll, "RTL all"),
            (Action::Land, "land"),
            (Action::BatterySwapped, "batt swapped"),
            (Action::Quit, "quit"),
        ],
    };
    let mut spans = Vec::new();
    let mut used = 0usize;
    if let Overlay::Prompt { .. } = app.overlay {
        let s = "0-9 type id  enter select  backspace erase  ";
        used += s.len();
        spans.push(Span::styled(s, theme::strong()));
    }
    let overlay = app.overlay != Overlay::None;
    for (action, label) in items {
        // In an overlay every key of the few actions; otherwise the first key of each.
        let k = if overlay {
            format!(" {} ", keys.keys_label(action))
        } else {
            match keys.keys(action).first() {
                Some(key) => format!(" {key} "),
                None => continue,
            }
        };
        let l = format!(" {label} ");
        let w = k.chars().count() + l.chars().count();
        if used + w > area.width as usize {
            break;
        }
        used += w;
        spans.push(Span::styled(k, theme::title_bar()));
        spans.push(Span::styled(l, theme::text()));
    }
    frame.render_widget(Paragraph::new(Line::from(spans)).style(Style::new()), area);
}

/// Rows the log pane shows at the app's terminal size (for page scrolling).
pub(crate) fn log_page_rows(app: &App) -> usize {
    let area = Rect::new(0, 0, app.size.0, app.size.1);
    layout_with_lower(app, area, Pane::Log)
        .and_then(|l| l.log)
        .map(|r| r.height.saturating_sub(2) as usize)
        .unwrap_or(10)
}
