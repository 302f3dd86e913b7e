//! The fleet pane: one row per vehicle.
//!
//! Two column sets: the full one when the pane is at least `FULL_WIDTH` wide, and a
//! compact one that fits 80 columns (short type names, units in the headers, the camera in
//! a word). Values that need attention get a background colour *and* stay readable as text
//! (`LOST`, `nofix`, `OFF`).

use super::theme;
use super::{pane_block, pane_title};
use crate::panes::{Role, VehicleRow};
use crate::tui::app::{App, Pane};
use ratatui::Frame;
use ratatui::layout::{Constraint, Rect};
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::{Cell, HighlightSpacing, Paragraph, Row, Table, TableState};

/// Inner width from which the full column set is used (sum of its fixed columns, spacing
/// and the selection marker).
pub(crate) const FULL_WIDTH: u16 = 148;

struct Column {
    header: &'static str,
    width: u16,
    cell: fn(&VehicleRow, &App) -> (String, Style),
}

fn s(text: String) -> (String, Style) {
    (text, theme::text())
}

fn id(v: &VehicleRow, _: &App) -> (String, Style) {
    (format!("{:>3}", v.sysid), theme::strong())
}

fn role(v: &VehicleRow, _: &App) -> (String, Style) {
    s(v.role.to_string())
}

fn kind_full(v: &VehicleRow, _: &App) -> (String, Style) {
    s(format!("{} {}", v.autopilot.name(), v.vehicle_type.name()))
}

fn kind_short(v: &VehicleRow, _: &App) -> (String, Style) {
    let t = match v.role {
        Role::Station => "stn",
        Role::Drone => v.vehicle_type.short(),
    };
    s(format!("{} {t}", v.autopilot.short()))
}

fn mode(v: &VehicleRow, _: &App) -> (String, Style) {
    let m = if v.mode.is_empty() { "?" } else { &v.mode };
    (m.to_string(), theme::strong())
}

fn armed_full(v: &VehicleRow, _: &App) -> (String, Style) {
    if v.armed {
        ("ARMED".into(), theme::strong())
    } else {
        s("disarmed".into())
    }
}

fn armed_short(v: &VehicleRow, _: &App) -> (String, Style) {
    if v.armed {
        ("ARMED".into(), theme::strong())
    } else {
        s("off".into())
    }
}

fn battery(v: &VehicleRow, app: &App) -> (String, Style) {
    let b = &v.battery;
    let pct = b
        .remaining_pct
        .map(|p| format!("{p:>3}%"))
        .unwrap_or_else(|| "  -%".into());
    let volts = b
        .voltage_v
        .map(|x| format!("{x:>5.1}V"))
        .unwrap_or_else(|| "    -V".into());
    let lvl = theme::battery_level(b, &app.config.thresholds);
    (format!("{pct}{volts}"), theme::level(lvl))
}

fn gps(v: &VehicleRow, app: &App) -> (String, Style) {
    let g = &v.gps;
    let sats = g
        .satellites
        .map(|n| format!("{n:>2}"))
        .unwrap_or_else(|| " -".into());
    let lvl = theme::gps_level(g, &app.config.thresholds);
    (format!("{:<5} {sats}", g.fix.label()), theme::level(lvl))
}

fn alt(v: &VehicleRow, _: &App) -> (String, Style) {
    s(v.alt_m
        .map(|a| format!("{a:>6.1}"))
        .unwrap_or_else(|| "     -".into()))
}

/// Altitude in five characters (to 999.9 m), for the compact set.
fn alt_short(v: &VehicleRow, _: &App) -> (String, Style) {
    s(v.alt_m
        .map(|a| format!("{a:>5.1}"))
        .unwrap_or_else(|| "    -".into()))
}

fn speed(v: &VehicleRow, _: &App) -> (String, Style) {
    s(v.speed_mps
        .map(|a| format!("{a:>5.1}"))
        .unwrap_or_else(|| "    -".into()))
}

fn wp(v: &VehicleRow, _: &App) -> (String, Style) {
    s(v.mission
        .map(|m| format!("{:>3}/{:<3}", m.current, m.total))
        .unwrap_or_else(|| "  -/-  ".into()))
}

fn link_full(v: &VehicleRow, app: &App) -> (String, Style) {
    let l = &v.link;
    let lvl = theme::link_level(l, &app.config.thresholds);
    let text = if l.lost {
        match l.last_heard_s {
            Some(t) => format!("LOST {:.0}s", t.floor()),
            None => "LOST".into(),
        }
    } else {
        match l.quality_pct {
            Some(q) => format!("{q:>3}% ok"),
            None => "ok".into(),
        }
    };
    (text, theme::level(lvl))
}

fn link_short(v: &VehicleRow, app: &App) -> (String, Style) {
    let l = &v.link;
    let lvl = theme::link_level(l, &app.config.thresholds);
    let text = if l.lost {
        "LOST".into()
    } else {
        l.quality_pct
            .map(|q| format!("{q:>3}%"))
            .unwrap_or_else(|| "ok".into())
    };
    (text, theme::level(lvl))
}

/// Bytes per second the link carries for the vehicle, both ways: `612` or `12.4k`.
fn load(v: &VehicleRow, _: &App) -> (String, Style) {
    let l = &v.link;
    let text = match l.bytes_per_s {
        Some(b) if b >= 9999.5 => format!("{:>4.0}k", b / 1000.0),
        Some(b) if b >= 999.5 => format!("{:>4.1}k", b / 1000.0),
        Some(b) => format!("{b:>5.0}"),
        None => "    -".into(),
    };
    (text, theme::level(theme::load_level(l)))
}

/// The radio's signal at the GCS's end and at the vehicle's (SiK units, 0–255).
fn rssi(v: &VehicleRow, _: &App) -> (String, Style) {
    s(v.link
        .rssi
        .map(|(a, b)| format!("{a:>3}/{b:<3}"))
        .unwrap_or_else(|| "   -   ".into()))
}

/// The camera component: seconds since its heartbeat, pictures taken / measurements sent
/// (`  0s   12/12`; `OFF  12s 97/95` once silent); `none` for a drone whose camera was
/// never heard.
fn camera_full(v: &VehicleRow, _: &App) -> (String, Style) {
    let text = match &v.camera {
        Some(c) => {
            let age = c.heard_s.min(999.0).floor();
            if c.silent {
                format!("OFF {age:>3.0}s {}/{}", c.pictures, c.measurements)
            } else {
                format!("{age:>3.0}s {:>4}/{:<4}", c.pictures, c.measurements)
            }
        }
        None if v.role == Role::Drone => "none".into(),
        None => "-".into(),
    };
    (text, theme::level(theme::camera_level(v)))
}

/// The camera in a word: `ok`, `OFF` (silent), `no` (a drone's camera never heard), `-`.
fn camera_short(v: &VehicleRow, _: &App) -> (String, Style) {
    let text = match &v.camera {
        Some(c) if c.silent => "OFF",
        Some(_) => "ok",
        None if v.role == Role::Drone => "no",
        None => "-",
    };
    (text.into(), theme::level(theme::camera_level(v)))
}

fn activity(v: &VehicleRow, _: &App) -> (String, Style) {
    s(v.activity.clone().unwrap_or_default())
}

const FULL: &[Column] = &[
    Column {
        header: " ID",
        width: 3,
        cell: id,
    },
    Column {
        header: "ROLE",
        width: 7,
        cell: role,
    },
    Column {
        header: "AUTOPILOT",
        width: 16,
        cell: kind_full,
    },
    Column {
        header: "MODE",
        width: 12,
        cell: mode,
    },
    Column {
        header: "ARMED",
        width: 8,
        cell: armed_full,
    },
    Column {
        header: "BATTERY",
        width: 10,
        cell: battery,
    },
    Column {
        header: "GPS  SAT",
        width: 8,
        cell: gps,
    },
    Column {
        header: " ALT m",
        width: 6,
        cell: alt,
    },
    Column {
        header: "GS m/s",
        width: 6,
        cell: speed,
    },
    Column {
        header: "WP",
        width: 7,
        cell: wp,
    },
    Column {
        header: "LINK",
        width: 9,
        cell: link_full,
    },
    Column {
        header: "  B/s",
        width: 5,
        cell: load,
    },
    Column {
        header: " RSSI",
        width: 7,
        cell: rssi,
    },
    Column {
        header: " CAM PICT/MEAS",
        width: 14,
        cell: camera_full,
    },
    Column {
        header: "ACTIVITY",
        width: 14,
        cell: activity,
    },
];

const COMPACT: &[Column] = &[
    Column {
        header: " ID",
        width: 3,
        cell: id,
    },
    Column {
        header: "TYPE",
        width: 7,
        cell: kind_short,
    },
    Column {
        header: "MODE",
        width: 8,
        cell: mode,
    },
    Column {
        header: "ARM",
        width: 5,
        cell: armed_short,
    },
    Column {
        header: "BATTERY",
        width: 10,
        cell: battery,
    },
    Column {
        header: "GPS  SAT",
        width: 8,
        cell: gps,
    },
    Column {
        header: "ALT m",
        width: 5,
        cell: alt_short,
    },
    Column {
        header: "GS m/s",
        width: 6,
        cell: speed,
    },
    Column {
        header: "WP",
        width: 7,
        cell: wp,
    },
    Column {
        header: "LINK",
        width: 4,
        cell: link_short,
    },
    Column {
        header: "CAM",
        width: 3,
        cell: camera_short,
    },
];

fn columns_for(inner_width: u16) -> &'static [Column] {
    if inner_width >= FULL_WIDTH {
        FULL
    } else {
        COMPACT
    }
}

/// Total width a column set needs: columns, one space between, two for the marker.
fn needed(cols: &[Column]) -> u16 {
    cols.iter().map(|c| c.width).sum::<u16>() + cols.len() as u16 - 1 + 2
}

/// Draw the fleet pane.
pub fn render(app: &App, frame: &mut Frame, area: Rect) {
    let vehicles = &app.model.vehicles;
    let drones = vehicles.iter().filter(|v| v.role == Role::Drone).count();
    let stations = vehicles.len() - drones;
    let lost = vehicles.iter().filter(|v| v.link.lost).count();
    let mut title = vec![pane_title(app, Pane::Fleet, "Fleet")];
    title.push(Span::styled(
        format!(" {drones} drones, {stations} stations "),
        theme::text(),
    ));
    if lost > 0 {
        title.push(Span::styled(format!(" {lost} LINK LOST "), theme::alarm()));
    }
    let block = pane_block(app, Pane::Fleet, Line::from(title));
    let inner = block.inner(area);
    frame.render_widget(block, area);
    if vehicles.is_empty() {
        frame.render_widget(
            Paragraph::new("No vehicles yet: waiting for heartbeats.").style(theme::strong()),
            inner,
        );
        return;
    }
    let cols = columns_for(inner.width);
    debug_assert!(
        needed(COMPACT) <= 78,
        "compact fleet table must fit 80 columns"
    );
    let header = Row::new(cols.iter().map(|c| Cell::from(c.header))).style(theme::header());
    let rows = vehicles.iter().map(|v| {
        Row::new(cols.iter().map(|c| {
            let (text, style) = (c.cell)(v, app);
            Cell::from(Span::styled(text, style))
        }))
    });
    let widths = cols.iter().enumerate().map(|(i, c)| {
        if i + 1 == cols.len() && cols.len() == FULL.len() {
            Constraint::Min(c.width)
        } else {
            Constraint::Length(c.width)
        }
    });
    let table = Table::new(rows, widths)
        .header(header)
        .column_spacing(1)
        .row_highlight_style(theme::selected())
        .highlight_symbol(">")
        .highlight_spacing(HighlightSpacing::Always);
    let selected = app
        .selected
        .and_then(|id| vehicles.iter().position(|v| v.sysid == id));
    let mut state = TableState::default().with_selected(selected);
    frame.render_stateful_widget(table, inner, &mut state);
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn compact_columns_fit_80_columns_and_full_fits_its_threshold() {
        assert!(needed(COMPACT) <= 78, "{}", needed(COMPACT));
        assert!(needed(FULL) <= FULL_WIDTH, "{}", needed(FULL));
    }

    #[test]
    fn headers_fit_their_columns() {
        for c in FULL.iter().chain(COMPACT) {
            assert!(c.header.len() <= c.width as usize, "{}", c.header);
        }
    }
}
