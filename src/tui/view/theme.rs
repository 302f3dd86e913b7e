//! Colours and text styles. High contrast for a laptop in the sun over SSH: only the eight
//! basic ANSI colours and white (every terminal has them), no dim or dark-grey text;
//! emphasis by bold, reverse video and background colour, always paired with a glyph or a
//! word so that nothing depends on colour alone.

use crate::panes::{Battery, CellState, Gps, LinkState, Role, VehicleRow};
use crate::tui::config::Thresholds;
use fleetmap_core::proto::severity::Severity;
use ratatui::style::{Color, Modifier, Style};

/// Plain text.
pub(crate) fn text() -> Style {
    Style::new().fg(Color::White)
}

/// Labels and headers.
pub(crate) fn header() -> Style {
    Style::new()
        .fg(Color::White)
        .add_modifier(Modifier::BOLD | Modifier::UNDERLINED)
}

/// Emphasised values.
pub(crate) fn strong() -> Style {
    Style::new().fg(Color::White).add_modifier(Modifier::BOLD)
}

/// Borders of panes without focus.
pub(crate) fn border() -> Style {
    Style::new().fg(Color::White)
}

/// Border and title of the focused pane.
pub(crate) fn border_focused() -> Style {
    Style::new().fg(Color::Yellow).add_modifier(Modifier::BOLD)
}

/// The selected row.
pub(crate) fn selected() -> Style {
    Style::new().add_modifier(Modifier::REVERSED | Modifier::BOLD)
}

/// The title bar.
pub(crate) fn title_bar() -> Style {
    Style::new()
        .fg(Color::Black)
        .bg(Color::White)
        .add_modifier(Modifier::BOLD)
}

/// Something the operator must know (not live data, stale data, pending commands).
pub(crate) fn warn() -> Style {
    Style::new()
        .fg(Color::Black)
        .bg(Color::Yellow)
        .add_modifier(Modifier::BOLD)
}

/// Something wrong right now.
pub(crate) fn alarm() -> Style {
    Style::new()
        .fg(Color::White)
        .bg(Color::Red)
        .add_modifier(Modifier::BOLD)
}

/// Good state.
pub(crate) fn ok() -> Style {
    Style::new().fg(Color::Green).add_modifier(Modifier::BOLD)
}

/// Warning level of a value.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
pub(crate) enum Level {
    /// Fine.
    Ok,
    /// Needs attention.
    Warn,
    /// Act now.
    Critical,
    /// Not reported.
    Unknown,
}

/// The style of a value at `level`.
pub(crate) fn level(level: Level) -> Style {
    match level {
        Level::Ok => text(),
        Level::Warn => warn(),
        Level::Critical => alarm(),
        Level::Unknown => text(),
    }
}

/// Battery level from percent and per-cell voltage, whichever is worse.
pub(crate) fn battery_level(b: &Battery, t: &Thresholds) -> Level {
    let by_pct = b.remaining_pct.map(|p| {
        if p <= t.battery_crit_pct {
            Level::Critical
        } else if p <= t.battery_warn_pct {
            Level::Warn
        } else {
            Level::Ok
        }
    });
    let by_volts = match (b.voltage_v, b.cells) {
        (Some(v), Some(n)) if n > 0 => {
            let per_cell = v / f32::from(n);
            Some(if per_cell <= t.cell_crit_v {
                Level::Critical
            } else if per_cell <= t.cell_warn_v {
                Level::Warn
            } else {
                Level::Ok
            })
        }
        _ => None,
    };
    match (by_pct, by_volts) {
        (None, None) => Level::Unknown,
        (Some(a), None) | (None, Some(a)) => a,
        (Some(a), Some(b)) => a.max(b),
    }
}

/// GPS level: no 3D fix is critical, too few satellites a warning.
pub(crate) fn gps_level(g: &Gps, t: &Thresholds) -> Level {
    if !g.fix.is_3d() {
        Level::Critical
    } else if g.satellites.is_some_and(|n| n < t.min_satellites) {
        Level::Warn
    } else {
        Level::Ok
    }
}

/// Link level: lost is critical, low quality a warning.
pub(crate) fn link_level(l: &LinkState, t: &Thresholds) -> Level {
    if l.lost {
        Level::Critical
    } else {
        match l.quality_pct {
            Some(q) if q <= t.link_warn_pct => Level::Warn,
            Some(_) => Level::Ok,
            None => Level::Unknown,
        }
    }
}

/// Camera level: a drone's camera silent is critical (its pictures stop), never heard a
/// warning (the run cannot start without it); a station needs none.
pub(crate) fn camera_level(v: &VehicleRow) -> Level {
    match (&v.camera, v.role) {
        (Some(c), Role::Drone) if c.silent => Level::Critical,
        (Some(c), Role::Station) if c.silent => Level::Warn,
        (Some(_), _) => Level::Ok,
        (None, Role::Drone) => Level::Warn,
        (None, Role::Station) => Level::Unknown,
    }
}

/// Link load level: a link carrying nine tenths of its budget or more is a warning (its
/// radio's buffer fills; what the GCS sends waits).
pub(crate) fn load_level(l: &LinkState) -> Level {
    match (l.bytes_per_s, l.budget_bytes_per_s) {
        (Some(b), Some(max)) if f64::from(b) >= 0.9 * f64::from(max) => Level::Warn,
        (Some(_), _) => Level::Ok,
        (None, _) => Level::Unknown,
    }
}

/// Log line style by severity.
pub(crate) fn severity(s: Severity) -> Style {
    match s {
        Severity::Emergency | Severity::Alert | Severity::Critical => alarm(),
        Severity::Error => Style::new().fg(Color::Red).add_modifier(Modifier::BOLD),
        Severity::Warning => Style::new().fg(Color::Yellow).add_modifier(Modifier::BOLD),
        Severity::Notice => Style::new().fg(Color::Cyan).add_modifier(Modifier::BOLD),
        Severity::Info | Severity::Debug => text(),
    }
}

/// Map cell style.
pub(crate) fn cell(s: CellState) -> Style {
    let bold = Modifier::BOLD;
    match s {
        CellState::Unknown | CellState::Unclassified => Style::new().fg(Color::White),
        CellState::Negative => Style::new().fg(Color::White).add_modifier(bold),
        CellState::PositiveUnexplored => Style::new()
            .fg(Color::Black)
            .bg(Color::Yellow)
            .add_modifier(bold),
        CellState::UnderExploration => Style::new()
            .fg(Color::White)
            .bg(Color::Magenta)
            .add_modifier(bold),
        CellState::Explored => Style::new()
            .fg(Color::Black)
            .bg(Color::Green)
            .add_modifier(bold),
        CellState::Keep => Style::new()
            .fg(Color::Black)
            .bg(Color::Green)
            .add_modifier(bold),
        CellState::Reject => Style::new()
            .fg(Color::Black)
            .bg(Color::Cyan)
            .add_modifier(bold),
        CellState::Obstacle => Style::new()
            .fg(Color::White)
            .bg(Color::Red)
            .add_modifier(bold),
        CellState::Road => Style::new()
            .fg(Color::Black)
            .bg(Color::White)
            .add_modifier(bold),
    }
}

/// A drone on the map.
pub(crate) fn drone() -> Style {
    Style::new()
        .fg(Color::White)
        .bg(Color::Blue)
        .add_modifier(Modifier::BOLD)
}

/// A station on the map.
pub(crate) fn station() -> Style {
    Style::new()
        .fg(Color::Black)
        .bg(Color::Cyan)
        .add_modifier(Modifier::BOLD | Modifier::UNDERLINED)
}

/// The selected vehicle on the map.
pub(crate) fn selected_vehicle() -> Style {
    Style::new()
        .fg(Color::Black)
        .bg(Color::White)
        .add_modifier(Modifier::BOLD | Modifier::UNDERLINED)
}

/// A vehicle's track.
pub(crate) fn track() -> Style {
    Style::new().fg(Color::Cyan).add_modifier(Modifier::BOLD)
}

/// The home cell.
pub(crate) fn home() -> Style {
    Style::new()
        .fg(Color::Black)
        .bg(Color::White)
        .add_modifier(Modifier::BOLD)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::panes::GpsFix;

    #[test]
    fn battery_takes_the_worse_of_percent_and_volts() {
        let t = Thresholds::default();
        let b = |pct, v| Battery {
            remaining_pct: pct,
            voltage_v: v,
            cells: Some(4),
        };
        assert_eq!(battery_level(&b(Some(80), Some(16.4)), &t), Level::Ok);
        assert_eq!(battery_level(&b(Some(30), Some(16.4)), &t), Level::Warn);
        assert_eq!(battery_level(&b(Some(20), None), &t), Level::Critical);
        // 80 % but 3.45 V per cell: the voltage wins.
        assert_eq!(battery_level(&b(Some(80), Some(13.8)), &t), Level::Critical);
        assert_eq!(battery_level(&b(None, Some(14.3)), &t), Level::Warn);
        assert_eq!(battery_level(&b(None, None), &t), Level::Unknown);
    }

    #[test]
    fn gps_and_link_levels() {
        let t = Thresholds::default();
        let g = |fix, sats| Gps {
            fix,
            satellites: sats,
        };
        assert_eq!(gps_level(&g(GpsFix::Fix3d, Some(12)), &t), Level::Ok);
        assert_eq!(gps_level(&g(GpsFix::Fix3d, Some(4)), &t), Level::Warn);
        assert_eq!(gps_level(&g(GpsFix::Fix2d, Some(12)), &t), Level::Critical);
        let l = |q, lost| LinkState {
            quality_pct: q,
            lost,
            ..LinkState::default()
        };
        assert_eq!(link_level(&l(Some(95), false), &t), Level::Ok);
        assert_eq!(link_level(&l(Some(60), false), &t), Level::Warn);
        assert_eq!(link_level(&l(Some(95), true), &t), Level::Critical);
        let load = |b: Option<f32>, max: Option<u32>| LinkState {
            bytes_per_s: b,
            budget_bytes_per_s: max,
            ..LinkState::default()
        };
        assert_eq!(load_level(&load(Some(700.0), Some(2000))), Level::Ok);
        assert_eq!(load_level(&load(Some(1850.0), Some(2000))), Level::Warn);
        assert_eq!(load_level(&load(Some(9e4), None)), Level::Ok);
        assert_eq!(load_level(&load(None, Some(2000))), Level::Unknown);
    }
}
