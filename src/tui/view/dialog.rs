//! The confirmation dialog and the vehicle-id prompt.

use super::theme;
use crate::panes::{Role, VehicleRow};
use crate::tui::app::{App, Pending, Target};
use crate::tui::keymap::Action;
use fleetmap_core::time::Time;
use ratatui::Frame;
use ratatui::layout::{Constraint, Rect};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, BorderType, Clear, Paragraph, Wrap};

fn vehicle_summary(v: &VehicleRow) -> String {
    let role = match v.role {
        Role::Drone => "drone",
        Role::Station => "station",
    };
    let mut s = format!(
        "{} {} {role}, {}, {}",
        v.autopilot.name(),
        v.vehicle_type.name(),
        if v.mode.is_empty() { "?" } else { &v.mode },
        if v.armed { "ARMED" } else { "disarmed" }
    );
    if let Some(a) = v.alt_m {
        s.push_str(&format!(", {a:.1} m"));
    }
    if let Some(p) = v.battery.remaining_pct {
        s.push_str(&format!(", battery {p}%"));
    }
    s
}

fn centred(area: Rect, w: u16, h: u16) -> Rect {
    area.centered(
        Constraint::Length(w.min(area.width)),
        Constraint::Length(h.min(area.height)),
    )
}

/// Draw the confirmation dialog for `pending`.
pub(crate) fn render_confirm(
    app: &App,
    frame: &mut Frame,
    area: Rect,
    pending: &Pending,
    opened: Time,
) {
    let keys = &app.config.keys;
    let (headline, detail, consequence) = match pending {
        Pending::Command { target, command } => {
            let detail = match target {
                Target::All => format!("all {} vehicles", app.model.vehicles.len()),
                Target::Vehicle(id) => match app.model.vehicle(*id) {
                    Some(v) => format!("#{id}: {}", vehicle_summary(v)),
                    None => format!("#{id} (no longer in the fleet list)"),
                },
            };
            (
                format!("{} — {target}?", command.verb()),
                detail,
                command.consequence().to_string(),
            )
        }
        Pending::Quit => (
            "QUIT fleetmap?".to_string(),
            "The UI closes; the mission runner keeps its state.".to_string(),
            "Vehicles keep flying their uploaded missions.".to_string(),
        ),
    };
    let timeout = app.config.thresholds.confirm_timeout();
    let left = timeout.saturating_sub(app.now.saturating_since(opened));
    let yes = keys.keys_label(Action::Confirm);
    let no = keys.keys_label(Action::Cancel);
    let text = vec![
        Line::styled(headline, theme::strong()),
        Line::styled(detail, theme::text()),
        Line::styled(consequence, theme::strong()),
        Line::raw(""),
        Line::from(vec![
            Span::styled(format!(" {yes} "), theme::alarm()),
            Span::styled(" yes    ", theme::strong()),
            Span::styled(format!(" {no} "), theme::title_bar()),
            Span::styled(" no    ", theme::strong()),
            Span::styled(
                format!("(closes in {} s)", left.as_secs_f64().ceil() as u64),
                theme::text(),
            ),
        ]),
    ];
    let w = 72u16.min(area.width.saturating_sub(2));
    let popup = centred(area, w, 9);
    frame.render_widget(Clear, popup);
    let block = Block::bordered()
        .border_type(BorderType::Thick)
        .border_style(theme::alarm())
        .title(Span::styled(" CONFIRM ", theme::alarm()));
    let inner = block.inner(popup);
    frame.render_widget(block, popup);
    frame.render_widget(Paragraph::new(text).wrap(Wrap { trim: false }), inner);
}

/// Draw the "select vehicle by system id" prompt with `typed` so far.
pub(crate) fn render_prompt(app: &App, frame: &mut Frame, area: Rect, typed: &str) {
    let ids: Vec<String> = app
        .model
        .vehicles
        .iter()
        .map(|v| v.sysid.to_string())
        .collect();
    let known = if ids.len() > 12 {
        format!(
            "{} … {}",
            ids[..6].join(" "),
            ids[ids.len() - 3..].join(" ")
        )
    } else {
        ids.join(" ")
    };
    let text = vec![
        Line::from(vec![
            Span::styled("System id: ", theme::strong()),
            Span::styled(format!("{typed}_"), theme::selected()),
        ]),
        Line::styled(format!("Fleet: {known}"), theme::text()),
        Line::styled(
            format!(
                "enter: select   {}: cancel",
                app.config.keys.keys_label(Action::Cancel)
            ),
            theme::text(),
        ),
    ];
    let w = 56u16.min(area.width.saturating_sub(2));
    let popup = centred(area, w, 5);
    frame.render_widget(Clear, popup);
    let block = Block::bordered()
        .border_type(BorderType::Double)
        .border_style(theme::border_focused())
        .title(Span::styled(" Select vehicle ", theme::selected()));
    let inner = block.inner(popup);
    frame.render_widget(block, popup);
    frame.render_widget(Paragraph::new(text), inner);
}
