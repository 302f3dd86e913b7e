//! The help overlay: every binding of the key map, grouped, generated from the same table
//! the key handling reads ([`KeyMap::bindings`]), so it cannot drift from what the keys do.
//! Laid out in as many columns as fit; scrolls when even that is not enough (80×24).

use super::theme;
use crate::tui::app::App;
use crate::tui::keymap::{Action, KeyMap};
use ratatui::Frame;
use ratatui::layout::{Margin, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, BorderType, Clear, Paragraph};

/// One line of the help.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum HelpLine {
    /// A section heading.
    Heading(&'static str),
    /// Keys and what they do.
    Entry {
        /// The keys, space separated.
        keys: String,
        /// What they do.
        desc: String,
        /// The actions listed on this line.
        actions: Vec<Action>,
    },
}

fn section(a: Action) -> &'static str {
    match a {
        Action::Help | Action::Quit | Action::QuitNow | Action::FocusNext | Action::FocusPrev => {
            "General"
        }
        Action::NextVehicle
        | Action::PrevVehicle
        | Action::SelectNumber(_)
        | Action::SelectById => "Select a vehicle",
        Action::Start
        | Action::PauseAll
        | Action::HoldVehicle
        | Action::Resume
        | Action::RtlVehicle
        | Action::RtlAll
        | Action::Land
        | Action::Arm
        | Action::Disarm
        | Action::BatterySwapped => "Commands",
        Action::ZoomIn | Action::ZoomOut | Action::ZoomFit | Action::FollowSelected => "Map",
        _ => a.context().heading(),
    }
}

/// The help's lines for `keys`, in table order. `select_1` … `select_9` share one line when
/// each is bound to its own digit.
pub fn lines(keys: &KeyMap) -> Vec<HelpLine> {
    let mut out = Vec::new();
    let mut current = "";
    let digits_default = (1..=9u8).all(|n| {
        keys.keys(Action::SelectNumber(n)) == Action::SelectNumber(n).default_keys().as_slice()
    });
    let mut digits_done = false;
    for (action, _) in keys.bindings() {
        let sec = section(action);
        if sec != current {
            out.push(HelpLine::Heading(sec));
            current = sec;
        }
        if let (Action::SelectNumber(_), true) = (action, digits_default) {
            if !digits_done {
                digits_done = true;
                out.push(HelpLine::Entry {
                    keys: "1 … 9".into(),
                    desc: "select vehicle with that system id".into(),
                    actions: (1..=9).map(Action::SelectNumber).collect(),
                });
            }
            continue;
        }
        out.push(HelpLine::Entry {
            keys: keys.keys_label(action),
            desc: action.description(),
            actions: vec![action],
        });
    }
    out
}

/// How many lines the help has.
pub(crate) fn line_count(keys: &KeyMap) -> usize {
    lines(keys).len()
}

/// Draw the help over `area`: as many columns as needed (and fit), scrolled by `scroll`
/// lines when even that is not enough.
pub fn render(app: &App, frame: &mut Frame, area: Rect, scroll: u16) {
    let all = lines(&app.config.keys);
    let key_w = all
        .iter()
        .map(|l| match l {
            HelpLine::Entry { keys, .. } => keys.chars().count(),
            HelpLine::Heading(_) => 0,
        })
        .max()
        .unwrap_or(0)
        .min(20);
    let desc_w = all
        .iter()
        .map(|l| match l {
            HelpLine::Entry { desc, .. } => desc.chars().count(),
            HelpLine::Heading(t) => t.chars().count().saturating_sub(key_w + 2),
        })
        .max()
        .unwrap_or(0);
    let col_w = key_w + 2 + desc_w + 3;
    let max = area.inner(Margin::new(2, 1));
    let max_rows = (max.height as usize).saturating_sub(2).max(1);
    let max_cols = ((max.width as usize).saturating_sub(2) / col_w).max(1);
    let ncols = all.len().div_ceil(max_rows).clamp(1, max_cols);
    let rows = all.len().div_ceil(ncols).min(max_rows);
    let log_note = app
        .log_file
        .as_ref()
        .map(|p| format!(" log file {p} "))
        .unwrap_or_default();
    let bottom = " Esc or ? close · up/down scroll ";
    let want_w = (ncols * col_w + 2)
        .max(bottom.len() + 4)
        .max(log_note.chars().count() + 4) as u16;
    let popup = max.centered(
        ratatui::layout::Constraint::Length(want_w.min(max.width)),
        ratatui::layout::Constraint::Length((rows as u16 + 2).min(max.height)),
    );
    frame.render_widget(Clear, popup);
    let mut block = Block::bordered()
        .border_type(BorderType::Double)
        .border_style(theme::border_focused())
        .title(Span::styled(" Help: every key ", theme::selected()))
        .title_bottom(Line::styled(bottom, theme::strong()));
    if !log_note.is_empty() {
        block = block.title_bottom(Line::styled(log_note, theme::text()).right_aligned());
    }
    let inner = block.inner(popup);
    frame.render_widget(block, popup);
    let h = inner.height as usize;
    if h == 0 || inner.width == 0 {
        return;
    }
    let max_scroll = all.len().saturating_sub(h * ncols);
    let start = (scroll as usize).min(max_scroll);
    let col_w = (inner.width as usize / ncols) as u16;
    for c in 0..ncols {
        let from = start + c * h;
        if from >= all.len() {
            break;
        }
        let to = (from + h).min(all.len());
        let text: Vec<Line> = all[from..to]
            .iter()
            .map(|l| match l {
                HelpLine::Heading(t) => Line::styled(t.to_string(), theme::header()),
                HelpLine::Entry { keys, desc, .. } => {
                    let k: String = keys.chars().take(key_w).collect();
                    Line::from(vec![
                        Span::styled(format!("{k:>key_w$}"), theme::strong()),
                        Span::raw("  "),
                        Span::styled(desc.clone(), theme::text()),
                    ])
                }
            })
            .collect();
        let r = Rect::new(inner.x + c as u16 * col_w, inner.y, col_w, inner.height);
        frame.render_widget(Paragraph::new(text), r);
    }
    if start + h * ncols < all.len() || start > 0 {
        let more = format!(
            " lines {}-{} of {} ",
            start + 1,
            (start + h * ncols).min(all.len()),
            all.len()
        );
        let w = more.len() as u16;
        if w + 2 < popup.width {
            let r = Rect::new(popup.x + popup.width - w - 1, popup.y, w, 1);
            frame.render_widget(Paragraph::new(Span::styled(more, theme::warn())), r);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tui::keymap::{ALL_ACTIONS, Key};

    #[test]
    fn every_action_is_listed_exactly_once() {
        let keys = KeyMap::default();
        let mut listed: Vec<Action> = lines(&keys)
            .into_iter()
            .flat_map(|l| match l {
                HelpLine::Entry { actions, .. } => actions,
                HelpLine::Heading(_) => Vec::new(),
            })
            .collect();
        listed.sort();
        let mut all = ALL_ACTIONS.to_vec();
        all.sort();
        assert_eq!(listed, all);
    }

    #[test]
    fn rebound_digits_are_listed_one_by_one() {
        let mut keys = KeyMap::default();
        keys.set(Action::SelectNumber(3), vec![Key::char('#')]);
        let entries: Vec<String> = lines(&keys)
            .into_iter()
            .filter_map(|l| match l {
                HelpLine::Entry { keys, .. } => Some(keys),
                _ => None,
            })
            .collect();
        assert!(entries.contains(&"#".to_string()));
        assert!(!entries.iter().any(|k| k.contains('…')));
    }
}
