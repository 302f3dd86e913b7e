//! The log pane: STATUSTEXT from the vehicles and the UI's own messages (commands sent,
//! their results), merged by time, newest at the bottom, coloured by severity. Long lines
//! wrap under their text instead of being cut.

use super::theme;
use super::{lower_tabs, pane_block, pane_title};
use crate::panes::{LogEntry, format_hms};
use crate::tui::app::{App, Pane};
use fleetmap_core::proto::severity::Severity;
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;

/// (time, severity tag, sender) columns of a log line.
fn columns(e: &LogEntry) -> (String, String, String) {
    let who = match e.sysid {
        Some(id) => format!("#{id:<3}"),
        None => "GCS ".to_string(),
    };
    (
        format!("{:>7} ", format_hms(e.time.as_secs_f64())),
        e.severity.tag().to_string(),
        format!(" {who} "),
    )
}

fn prefix(e: &LogEntry) -> String {
    let (a, b, c) = columns(e);
    format!("{a}{b}{c}")
}

/// Split `text` into pieces of at most `width` characters, at spaces when possible.
fn wrap(text: &str, width: usize) -> Vec<String> {
    let width = width.max(8);
    let mut out = Vec::new();
    let mut line = String::new();
    for word in text.split(' ') {
        let mut word = word.to_string();
        loop {
            let len = line.chars().count();
            let wlen = word.chars().count();
            let sep = usize::from(len > 0);
            if len + sep + wlen <= width {
                if sep == 1 {
                    line.push(' ');
                }
                line.push_str(&word);
                break;
            }
            if len > 0 {
                out.push(std::mem::take(&mut line));
                continue;
            }
            // A word longer than the line: hard split.
            let head: String = word.chars().take(width).collect();
            word = word.chars().skip(width).collect();
            out.push(head);
        }
    }
    out.push(line);
    out
}

fn entry_lines(e: &LogEntry, width: usize) -> Vec<Line<'static>> {
    let p = prefix(e);
    let plen = p.chars().count();
    let text_style = match e.severity {
        Severity::Info | Severity::Debug => theme::text(),
        s => theme::severity(s),
    };
    let tag_style = theme::severity(e.severity);
    let pieces = wrap(&e.text, width.saturating_sub(plen));
    pieces
        .into_iter()
        .enumerate()
        .map(|(i, piece)| {
            if i == 0 {
                let (time, tag, rest) = columns(e);
                Line::from(vec![
                    Span::styled(time, theme::text()),
                    Span::styled(tag, tag_style),
                    Span::styled(rest, theme::strong()),
                    Span::styled(piece, text_style),
                ])
            } else {
                Line::from(vec![
                    Span::raw(" ".repeat(plen)),
                    Span::styled(piece, text_style),
                ])
            }
        })
        .collect()
}

/// Draw the log pane.
pub fn render(app: &App, frame: &mut Frame, area: Rect, compact: bool) {
    let entries = app.merged_log();
    let mut title = if compact {
        lower_tabs(app, Pane::Log)
    } else {
        Line::from(vec![pane_title(app, Pane::Log, "Log")])
    };
    let warnings = entries
        .iter()
        .filter(|e| e.severity <= Severity::Warning)
        .count();
    title.push_span(Span::styled(
        format!(" {} lines, {warnings} warnings ", entries.len()),
        theme::text(),
    ));
    let block = pane_block(app, Pane::Log, title);
    let block = if app.log_scroll > 0 {
        block.title_bottom(Line::styled(
            format!(" scrolled back {} (End: newest) ", app.log_scroll),
            theme::warn(),
        ))
    } else {
        block
    };
    let inner = block.inner(area);
    frame.render_widget(block, area);
    if entries.is_empty() {
        frame.render_widget(
            Paragraph::new("No messages yet.").style(theme::text()),
            inner,
        );
        return;
    }
    let end = entries.len().saturating_sub(app.log_scroll).max(1);
    let height = inner.height as usize;
    let mut lines: Vec<Line> = Vec::new();
    // Walk back from the newest shown entry until the pane is full.
    for e in entries[..end].iter().rev() {
        let mut l = entry_lines(e, inner.width as usize);
        l.append(&mut lines);
        lines = l;
        if lines.len() >= height {
            break;
        }
    }
    let skip = lines.len().saturating_sub(height);
    let lines: Vec<Line> = lines.into_iter().skip(skip).collect();
    frame.render_widget(Paragraph::new(lines), inner);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_breaks_at_spaces_and_splits_long_words() {
        assert_eq!(wrap("a bb ccc dddd", 8), vec!["a bb ccc", "dddd"]);
        assert_eq!(wrap("abcdefghijkl", 8), vec!["abcdefgh", "ijkl"]);
        assert_eq!(wrap("", 8), vec![""]);
    }

    #[test]
    fn prefix_has_fixed_width() {
        let e = LogEntry {
            sysid: Some(12),
            ..Default::default()
        };
        let g = LogEntry::default();
        assert_eq!(prefix(&e).len(), prefix(&g).len());
        assert_eq!(prefix(&e), "  00:00 INFO #12  ");
    }
}
