//! The mission pane: phase, progress, flight time, battery swaps, planner time.

use super::theme;
use super::{lower_tabs, pane_block, pane_title};
use crate::panes::{MissionKind, MissionModel, format_hms};
use crate::tui::app::{App, Pane};
use crate::tui::kinds;
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;

const LABEL_W: usize = 9;

fn label(s: &str) -> Span<'static> {
    Span::styled(format!("{s:<LABEL_W$}"), theme::strong())
}

/// A text progress bar `[#####.....]` of `width` characters inside the brackets.
pub fn bar(done: u32, total: u32, width: usize) -> String {
    let filled = if total == 0 {
        0
    } else {
        ((u64::from(done.min(total)) * width as u64) / u64::from(total)) as usize
    };
    format!("[{}{}]", "#".repeat(filled), ".".repeat(width - filled))
}

fn kind_name(k: Option<&MissionKind>) -> &str {
    k.map_or("no mission", |k| &k.name)
}

fn lines(m: &MissionModel, width: u16) -> Vec<Line<'static>> {
    let mut out = Vec::new();
    if m.kind.is_none() && m.name.is_empty() {
        out.push(Line::styled("No mission loaded.", theme::strong()));
        return out;
    }
    let name = if m.name.is_empty() {
        "(unnamed)"
    } else {
        &m.name
    };
    out.push(Line::from(vec![
        label("Mission"),
        Span::styled(name.to_string(), theme::strong()),
        Span::styled(format!("  ({})", kind_name(m.kind.as_ref())), theme::text()),
    ]));
    let status_style = match m.status {
        crate::panes::RunStatus::Failed | crate::panes::RunStatus::BatterySwap => theme::alarm(),
        crate::panes::RunStatus::Paused | crate::panes::RunStatus::BeyondReach => theme::warn(),
        _ => theme::strong(),
    };
    out.push(Line::from(vec![
        label("Phase"),
        Span::styled(format!("{:<12}", m.phase.to_string()), theme::strong()),
        Span::styled("Status ", theme::strong()),
        Span::styled(format!(" {} ", m.status.label()), status_style),
    ]));
    let counts = match m.cells_total {
        Some(t) => format!(" {}/{} classified", m.cells_classified, t),
        None => format!(" {} classified", m.cells_classified),
    };
    let mut cells = vec![label("Cells")];
    if let Some(total) = m.cells_total {
        let room = (width as usize).saturating_sub(LABEL_W + counts.len() + 2);
        if room >= 10 {
            cells.push(Span::styled(
                bar(m.cells_classified, total, room.min(40)),
                theme::strong(),
            ));
        }
    }
    cells.push(Span::styled(counts, theme::text()));
    out.push(Line::from(cells));
    if let Some(d) = m.dfs {
        out.push(Line::from(vec![
            label("DFS"),
            Span::styled(
                format!(
                    "{} explored, {} in progress, {} unexplored",
                    d.explored, d.under_exploration, d.unexplored
                ),
                theme::text(),
            ),
        ]));
    }
    if m.kind.as_ref().is_some_and(kinds::counts_epochs) || m.epochs_done > 0 {
        out.push(Line::from(vec![
            label("Epochs"),
            Span::styled(format!("{} done", m.epochs_done), theme::text()),
        ]));
    }
    out.push(Line::from(vec![
        label("Flight"),
        Span::styled(
            format!("{:<10}", format_hms(m.flight_time_s)),
            theme::text(),
        ),
        Span::styled("Swaps ", theme::strong()),
        Span::styled(format!("{:<4}", m.battery_swaps), theme::text()),
        Span::styled("Planner ", theme::strong()),
        Span::styled(format!("{:.1} s", m.planner_time_s), theme::text()),
    ]));
    // Extra figures, packed into lines.
    let mut line: Vec<Span> = Vec::new();
    let mut used = 0usize;
    let mut first = true;
    for s in &m.stats {
        let w = s.label.chars().count() + s.value.chars().count() + 4;
        if used + w > width as usize && !line.is_empty() {
            out.push(Line::from(std::mem::take(&mut line)));
            used = 0;
        }
        if line.is_empty() {
            line.push(label(if first { "Figures" } else { "" }));
            first = false;
            used = LABEL_W;
        }
        line.push(Span::styled(format!("{} ", s.label), theme::strong()));
        line.push(Span::styled(format!("{}   ", s.value), theme::text()));
        used += w;
    }
    if !line.is_empty() {
        out.push(Line::from(line));
    }
    out
}

/// Lines the pane wants at inner width `width` (the wide layout sizes it to fit).
pub(crate) fn height_wanted(app: &App, width: u16) -> u16 {
    lines(&app.model.mission, width).len() as u16
}

/// Draw the mission pane.
pub fn render(app: &App, frame: &mut Frame, area: Rect, compact: bool) {
    let title = if compact {
        lower_tabs(app, Pane::Mission)
    } else {
        Line::from(vec![pane_title(app, Pane::Mission, "Mission")])
    };
    let block = pane_block(app, Pane::Mission, title);
    let inner = block.inner(area);
    frame.render_widget(block, area);
    frame.render_widget(
        Paragraph::new(lines(&app.model.mission, inner.width)),
        inner,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bar_fills_proportionally() {
        assert_eq!(bar(0, 10, 10), "[..........]");
        assert_eq!(bar(5, 10, 10), "[#####.....]");
        assert_eq!(bar(10, 10, 4), "[####]");
        assert_eq!(bar(20, 10, 4), "[####]");
        assert_eq!(bar(3, 0, 4), "[....]");
    }
}
