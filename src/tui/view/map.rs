//! The map pane: the mission grid, north up, cells coloured by state, vehicles and stations
//! at their cells, with zoom, pan, auto-fit and a legend.
//!
//! Geometry. A terminal character is about twice as tall as it is wide, so at zoom 1:1 a
//! grid cell is drawn 2 characters wide and 1 high (square on screen). A zoom level is a
//! ratio z = num/den from `ZOOMS`: a cell takes 2z × z characters; below 1:1 one
//! character covers 1/(2z) × 1/z cells and shows the one of highest
//! `CellState::priority` (a positive is never hidden by its negative neighbours).
//! A viewport is the zoom and the screen position of one anchor cell (the grid's north-west
//! corner): fitting centres the whole grid's characters in the canvas; following centres one
//! cell and then slides the grid so that no empty space shows beyond an edge when the grid
//! is larger than the canvas.

use super::theme;
use super::{Areas, lower_tabs, pane_block, pane_title};
use crate::panes::{CellState, MapModel, Role};
use crate::tui::app::{App, MapMode, Pane};
use crate::tui::kinds;
use fleetmap_core::geo::Cell;
use ratatui::Frame;
use ratatui::buffer::Buffer;
use ratatui::layout::Rect;
use ratatui::style::Style;
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;

pub(crate) use crate::tui::app::{BASE_ZOOM, ZOOMS};

/// Width of the legend column in the wide layout.
const LEGEND_W: u16 = 26;

/// The map's resolved view.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Viewport {
    /// Index into `ZOOMS`.
    pub zoom: usize,
    /// The cell whose top-left character is at (`x`, `y`) on the canvas.
    pub(crate) anchor: Cell,
    /// Canvas column of the anchor's first character (may be negative or beyond the canvas).
    pub x: i64,
    /// Canvas row of the anchor's first character.
    pub y: i64,
    /// The cell at the centre of the canvas (where zoom and pan start from).
    pub centre: Cell,
    /// Rows one pan step moves (a quarter of the visible rows, at least 1).
    pub(crate) page_rows: i32,
    /// Columns one pan step moves.
    pub(crate) page_cols: i32,
}

/// Zoom as text: "x2", "x1", "1/4".
pub(crate) fn zoom_label(zoom: usize) -> String {
    let (num, den) = ZOOMS[zoom.min(ZOOMS.len() - 1)];
    if den == 1 {
        format!("x{num}")
    } else {
        format!("1/{den}")
    }
}

/// Grid offsets `[lo, hi)` covered by the character at screen offset `d` from the anchor
/// along one axis (`scale` = 2 horizontally, 1 vertically).
fn span(d: i64, zoom: usize, scale: i64) -> (i64, i64) {
    let (num, den) = ZOOMS[zoom];
    let lo = (d * den).div_euclid(scale * num);
    let hi = ((d + 1) * den).div_euclid(scale * num).max(lo + 1);
    (lo, hi)
}

/// The screen offset of the (first) character showing grid offset `off`.
fn inverse(off: i64, zoom: usize, scale: i64) -> i64 {
    let (num, den) = ZOOMS[zoom];
    (off * scale * num).div_euclid(den)
}

/// Characters needed to show `n` cells along an axis.
fn chars_for(n: i64, zoom: usize, scale: i64) -> i64 {
    let (num, den) = ZOOMS[zoom];
    (n * scale * num + den - 1).div_euclid(den)
}

/// Characters one cell takes (at least 1).
fn cell_chars(zoom: usize, scale: i64) -> i64 {
    chars_for(1, zoom, scale).max(1)
}

/// The anchor: the grid's north-west cell (or home / the origin for an empty grid).
fn anchor_of(map: &MapModel) -> Cell {
    if map.is_empty() {
        map.home.unwrap_or_default()
    } else {
        Cell::new(map.north_east().row, map.south_west.col)
    }
}

/// Whether the whole grid fits a `w × h` canvas at `zoom`.
fn fits(map: &MapModel, zoom: usize, w: u16, h: u16) -> bool {
    chars_for(i64::from(map.cols), zoom, 2) <= i64::from(w)
        && chars_for(i64::from(map.rows), zoom, 1) <= i64::from(h)
}

/// Anchor position along one axis that puts grid offset `off` (from the anchor) in the
/// middle of `n` characters, then slides so that a grid of `len` cells larger than the
/// canvas leaves no empty space at either end (a smaller grid is centred instead).
fn place(off: i64, len: i64, n: i64, zoom: usize, scale: i64) -> i64 {
    let grid = chars_for(len, zoom, scale);
    if grid <= n {
        return (n - grid) / 2;
    }
    let pos = (n - cell_chars(zoom, scale)) / 2 - inverse(off, zoom, scale);
    pos.clamp(n - grid, 0)
}

fn follow_target(app: &App) -> Option<Cell> {
    app.selected
        .and_then(|id| app.model.vehicle(id))
        .and_then(|v| v.cell)
}

fn viewport(map: &MapModel, zoom: usize, x: i64, y: i64, w: u16, h: u16) -> Viewport {
    let anchor = anchor_of(map);
    let (w, h) = (i64::from(w.max(1)), i64::from(h.max(1)));
    let cols = span(w / 2 - x, zoom, 2).0;
    let rows = span(h / 2 - y, zoom, 1).0;
    let visible_cols = span(w - 1 - x, zoom, 2).1 - span(-x, zoom, 2).0;
    let visible_rows = span(h - 1 - y, zoom, 1).1 - span(-y, zoom, 1).0;
    Viewport {
        zoom,
        anchor,
        x,
        y,
        centre: Cell::new(anchor.row - rows as i32, anchor.col + cols as i32),
        page_rows: (visible_rows / 4).max(1) as i32,
        page_cols: (visible_cols / 4).max(1) as i32,
    }
}

/// The viewport centred on `centre` (sliding to keep the grid's edges when it is larger).
fn centred_on(map: &MapModel, centre: Cell, zoom: usize, w: u16, h: u16, slide: bool) -> Viewport {
    let anchor = anchor_of(map);
    let dc = i64::from(centre.col) - i64::from(anchor.col);
    let dr = i64::from(anchor.row) - i64::from(centre.row);
    let (wi, hi) = (i64::from(w), i64::from(h));
    let (x, y) = if slide && !map.is_empty() {
        (
            place(dc, i64::from(map.cols), wi, zoom, 2),
            place(dr, i64::from(map.rows), hi, zoom, 1),
        )
    } else {
        (
            (wi - cell_chars(zoom, 2)) / 2 - inverse(dc, zoom, 2),
            (hi - cell_chars(zoom, 1)) / 2 - inverse(dr, zoom, 1),
        )
    };
    viewport(map, zoom, x, y, w, h)
}

/// The whole grid centred at `zoom`.
fn whole(map: &MapModel, zoom: usize, w: u16, h: u16) -> Viewport {
    let x = (i64::from(w) - chars_for(i64::from(map.cols), zoom, 2)) / 2;
    let y = (i64::from(h) - chars_for(i64::from(map.rows), zoom, 1)) / 2;
    viewport(map, zoom, x, y, w, h)
}

/// The viewport for a `w × h` canvas in the app's map mode.
pub(crate) fn resolve(app: &App, w: u16, h: u16) -> Viewport {
    let map = &app.model.map;
    let follow = |zoom| match follow_target(app) {
        Some(c) => centred_on(map, c, zoom, w, h, true),
        None => whole(map, zoom, w, h),
    };
    match app.map.mode {
        MapMode::Auto => match (BASE_ZOOM..ZOOMS.len()).rev().find(|&z| fits(map, z, w, h)) {
            Some(z) => whole(map, z, w, h),
            None => follow(BASE_ZOOM),
        },
        MapMode::Fit => {
            let z = (0..ZOOMS.len())
                .rev()
                .find(|&z| fits(map, z, w, h))
                .unwrap_or(0);
            whole(map, z, w, h)
        }
        MapMode::Follow => follow(app.map.zoom.min(ZOOMS.len() - 1)),
        MapMode::Manual { centre } => {
            centred_on(map, centre, app.map.zoom.min(ZOOMS.len() - 1), w, h, false)
        }
    }
}

/// Split the map pane's inner area into the canvas and the legend.
fn split(inner: Rect, compact: bool) -> (Rect, Rect) {
    if !compact && inner.width >= 80 {
        let canvas = Rect::new(inner.x, inner.y, inner.width - LEGEND_W, inner.height);
        let legend = Rect::new(
            inner.x + inner.width - LEGEND_W,
            inner.y,
            LEGEND_W,
            inner.height,
        );
        (canvas, legend)
    } else {
        let lh = 2.min(inner.height.saturating_sub(3));
        let canvas = Rect::new(inner.x, inner.y, inner.width, inner.height - lh);
        let legend = Rect::new(inner.x, inner.y + inner.height - lh, inner.width, lh);
        (canvas, legend)
    }
}

/// The canvas rectangle of the map pane in `areas`, if the map is shown.
fn canvas_of(areas: &Areas) -> Option<Rect> {
    let outer = areas.map?;
    let inner = ratatui::widgets::Block::bordered().inner(outer);
    Some(split(inner, areas.compact).0)
}

/// The viewport the map shows (or would show, in the compact layout, when it is not the
/// lower pane) at the app's terminal size. Zoom and pan start from it.
pub fn current_viewport(app: &App) -> Viewport {
    let area = Rect::new(0, 0, app.size.0, app.size.1);
    let canvas = super::layout_with_lower(app, area, Pane::Map)
        .as_ref()
        .and_then(canvas_of)
        .unwrap_or(Rect::new(0, 0, 40, 10));
    resolve(app, canvas.width, canvas.height)
}

fn mode_label(app: &App, vp: &Viewport, w: u16, h: u16) -> String {
    match app.map.mode {
        MapMode::Auto if fits(&app.model.map, vp.zoom, w, h) => "auto: whole grid".into(),
        MapMode::Auto | MapMode::Follow => match app.selected {
            Some(id) => format!("following #{id}"),
            None => "following".into(),
        },
        MapMode::Fit => "fit".into(),
        MapMode::Manual { centre } => format!("centre {centre}"),
    }
}

/// Draw the map pane.
pub fn render(app: &App, frame: &mut Frame, area: Rect, compact: bool) {
    let map = &app.model.map;
    let kind = kinds::map_look(&map.kind).label;
    let title = if compact {
        lower_tabs(app, Pane::Map)
    } else {
        Line::from(vec![pane_title(app, Pane::Map, "Map")])
    };
    let block = pane_block(app, Pane::Map, title);
    let inner = block.inner(area);
    let (canvas, legend) = split(inner, compact);
    let vp = resolve(app, canvas.width, canvas.height);
    let mut bottom = vec![Span::styled(
        format!(
            " {kind} · north up · {} · {} ",
            zoom_label(vp.zoom),
            mode_label(app, &vp, canvas.width, canvas.height)
        ),
        theme::strong(),
    )];
    let selected_cell = app
        .selected
        .and_then(|id| app.model.vehicle(id))
        .and_then(|v| v.cell.map(|c| (v.sysid, c)));
    if let Some((id, c)) = selected_cell
        && screen_pos(&vp, canvas, c).is_none()
    {
        bottom.push(Span::styled(format!(" #{id} off-screen "), theme::warn()));
    }
    let block = block.title_bottom(Line::from(bottom));
    frame.render_widget(block, area);
    if map.is_empty() {
        frame.render_widget(
            Paragraph::new("No grid yet: the mission defines it.").style(theme::strong()),
            canvas,
        );
    } else {
        draw_cells(map, &vp, canvas, frame.buffer_mut());
        draw_overlays(app, &vp, canvas, frame.buffer_mut());
    }
    draw_legend(app, &vp, legend, compact, frame);
}

/// Screen position (absolute) of the first character of `cell`, if it is on the canvas.
fn screen_pos(vp: &Viewport, canvas: Rect, cell: Cell) -> Option<(u16, u16)> {
    let sx = vp.x + inverse(i64::from(cell.col) - i64::from(vp.anchor.col), vp.zoom, 2);
    let sy = vp.y + inverse(i64::from(vp.anchor.row) - i64::from(cell.row), vp.zoom, 1);
    let (w, h) = (i64::from(canvas.width), i64::from(canvas.height));
    (sx >= 0 && sy >= 0 && sx < w && sy < h).then(|| (canvas.x + sx as u16, canvas.y + sy as u16))
}

fn draw_cells(map: &MapModel, vp: &Viewport, canvas: Rect, buf: &mut Buffer) {
    let (w, h) = (i64::from(canvas.width), i64::from(canvas.height));
    let (ar, ac) = (i64::from(vp.anchor.row), i64::from(vp.anchor.col));
    let (sw, ne) = (map.south_west, map.north_east());
    for sy in 0..h {
        let (rlo, rhi) = span(sy - vp.y, vp.zoom, 1);
        // Screen rows go south; grid rows go north.
        let row_hi = ar - rlo;
        let row_lo = ar - (rhi - 1);
        let row_lo = row_lo.max(i64::from(sw.row));
        let row_hi = row_hi.min(i64::from(ne.row));
        for sx in 0..w {
            let x = canvas.x + sx as u16;
            let y = canvas.y + sy as u16;
            let (clo, chi) = span(sx - vp.x, vp.zoom, 2);
            let col_lo = (ac + clo).max(i64::from(sw.col));
            let col_hi = (ac + chi - 1).min(i64::from(ne.col));
            let mut best: Option<CellState> = None;
            for r in row_lo..=row_hi {
                for c in col_lo..=col_hi {
                    if let Some(s) = map.get(Cell::new(r as i32, c as i32))
                        && best.is_none_or(|b| s.priority() > b.priority())
                    {
                        best = Some(s);
                    }
                }
            }
            if let Some(cell) = buf.cell_mut((x, y)) {
                match best {
                    Some(s) => {
                        cell.set_char(s.glyph()).set_style(theme::cell(s));
                    }
                    None => {
                        cell.set_char(' ').set_style(Style::reset());
                    }
                }
            }
        }
    }
}

fn put(buf: &mut Buffer, canvas: Rect, x: u16, y: u16, text: &str, style: Style) {
    for (i, ch) in text.chars().enumerate() {
        let xi = x + i as u16;
        if xi >= canvas.x + canvas.width {
            break;
        }
        if let Some(cell) = buf.cell_mut((xi, y)) {
            cell.set_char(ch).set_style(style);
        }
    }
}

fn draw_overlays(app: &App, vp: &Viewport, canvas: Rect, buf: &mut Buffer) {
    let map = &app.model.map;
    let cw = cell_chars(vp.zoom, 2) as usize;
    for track in &map.tracks {
        for &c in &track.cells {
            let low = map.get(c).is_some_and(|s| s.priority() <= 1);
            if let (true, Some((x, y))) = (low, screen_pos(vp, canvas, c)) {
                put(buf, canvas, x, y, ":", theme::track());
            }
        }
    }
    if let Some(home) = map.home
        && let Some((x, y)) = screen_pos(vp, canvas, home)
    {
        put(buf, canvas, x, y, &format!("{:<cw$}", "H"), theme::home());
    }
    // Unselected first, the selected vehicle last so it is never hidden.
    let mut order: Vec<_> = app.model.vehicles.iter().collect();
    order.sort_by_key(|v| Some(v.sysid) == app.selected);
    for v in order {
        let Some(c) = v.cell else { continue };
        let Some((x, y)) = screen_pos(vp, canvas, c) else {
            continue;
        };
        let label = vehicle_label(v.sysid, v.role);
        let style = if Some(v.sysid) == app.selected {
            theme::selected_vehicle()
        } else if v.role == Role::Station {
            theme::station()
        } else {
            theme::drone()
        };
        put(buf, canvas, x, y, &format!("{label:<cw$}"), style);
    }
}

/// How a vehicle is labelled on the map: its system id, prefixed by `S` for a station.
pub(crate) fn vehicle_label(sysid: u8, role: Role) -> String {
    match role {
        Role::Drone => sysid.to_string(),
        Role::Station => format!("S{sysid}"),
    }
}

fn draw_legend(app: &App, vp: &Viewport, area: Rect, compact: bool, frame: &mut Frame) {
    if area.height == 0 || area.width == 0 {
        return;
    }
    let map = &app.model.map;
    let name = |s: CellState| {
        if compact { s.short_name() } else { s.name() }
    };
    let legend = kinds::map_look(&map.kind).legend;
    let mut items: Vec<(String, Style, String)> = legend
        .iter()
        .map(|&s| {
            (
                format!("{0}{0}", s.glyph()),
                theme::cell(s),
                name(s).to_string(),
            )
        })
        .collect();
    items.push((
        "1 ".into(),
        theme::drone(),
        if compact { "drone" } else { "drone (sysid)" }.into(),
    ));
    if app.model.vehicles.iter().any(|v| v.role == Role::Station) {
        items.push(("S1".into(), theme::station(), "station".into()));
    }
    items.push(("1 ".into(), theme::selected_vehicle(), "selected".into()));
    if map.home.is_some() {
        items.push(("H ".into(), theme::home(), "home".into()));
    }
    if !map.tracks.is_empty() {
        items.push((": ".into(), theme::track(), "track".into()));
    }
    let scale = format!("{} m cells", fmt_size(map.cell_size_m));
    if compact {
        let mut lines: Vec<Vec<Span>> = vec![Vec::new()];
        let mut used = 0usize;
        items.push((String::new(), Style::new(), scale));
        for (sample, style, name) in items {
            let w = sample.chars().count() + 1 + name.chars().count() + 1;
            if used + w > area.width as usize && used > 0 {
                lines.push(Vec::new());
                used = 0;
            }
            used += w;
            let line = lines.last_mut().expect("at least one line");
            if !sample.is_empty() {
                line.push(Span::styled(sample, style));
            }
            line.push(Span::styled(format!(" {name} "), theme::text()));
        }
        let text: Vec<Line> = lines.into_iter().map(Line::from).collect();
        frame.render_widget(Paragraph::new(text), area);
    } else {
        let mut text: Vec<Line> = vec![Line::styled("Legend", theme::header())];
        for (sample, style, name) in items {
            text.push(Line::from(vec![
                Span::raw(" "),
                Span::styled(sample, style),
                Span::styled(format!(" {name}"), theme::text()),
            ]));
        }
        text.push(Line::raw(""));
        text.push(Line::styled(format!(" {scale}"), theme::text()));
        text.push(Line::styled(
            format!(" grid {} x {} cells", map.rows, map.cols),
            theme::text(),
        ));
        text.push(Line::styled(
            format!(" zoom {}", zoom_label(vp.zoom)),
            theme::text(),
        ));
        let counts = map.counts();
        text.push(Line::raw(""));
        text.push(Line::styled("Cells", theme::header()));
        for &s in legend.iter() {
            let i = CellState::ALL.iter().position(|x| *x == s).unwrap_or(0);
            text.push(Line::styled(
                format!(" {:<21}{:>4}", s.name(), counts[i]),
                theme::text(),
            ));
        }
        frame.render_widget(Paragraph::new(text), area);
    }
}

fn fmt_size(m: f64) -> String {
    if (m - m.round()).abs() < 1e-9 {
        format!("{m:.0}")
    } else {
        format!("{m:.1}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spans_tile_the_axis_without_gaps() {
        for zoom in 0..ZOOMS.len() {
            for scale in [1, 2] {
                let mut next = span(-50, zoom, scale).0;
                for d in -50..50 {
                    let (lo, hi) = span(d, zoom, scale);
                    assert!(hi > lo);
                    // Either the same cell as the previous character or the next ones.
                    assert!(lo == next || lo == next - 1, "zoom {zoom} d {d}");
                    next = hi;
                }
            }
        }
    }

    #[test]
    fn inverse_lands_on_a_character_showing_the_offset() {
        for zoom in 0..ZOOMS.len() {
            for off in -40..40 {
                let dx = inverse(off, zoom, 2);
                let (lo, hi) = span(dx, zoom, 2);
                assert!(lo <= off && off < hi, "zoom {zoom} off {off}");
                let dy = inverse(-off, zoom, 1);
                let (lo, hi) = span(dy, zoom, 1);
                assert!(lo <= -off && -off < hi, "zoom {zoom} off {off}");
            }
        }
    }

    #[test]
    fn grids_fit_in_whole_characters() {
        let map = MapModel::new(crate::panes::MapKind::default(), 4.0, Cell::new(0, 0), 6, 6);
        // x2: a cell is 4 x 2 characters; 6 rows need 12 screen rows.
        assert!(!fits(&map, BASE_ZOOM + 1, 78, 11));
        assert!(fits(&map, BASE_ZOOM + 1, 78, 12));
        assert!(fits(&map, BASE_ZOOM, 12, 6));
        assert!(!fits(&map, BASE_ZOOM, 11, 6));
        // 1/8: one character covers 4 columns and 8 rows; 6x6 needs 2 x 1 characters.
        assert!(fits(&map, 0, 2, 1));
        assert_eq!(chars_for(100, 0, 2), 25);
        assert_eq!(chars_for(100, 0, 1), 13);
    }

    #[test]
    fn following_a_corner_vehicle_keeps_the_grid_on_screen() {
        // 40 columns of 2 characters in a 20-character canvas: the view slides, clamped
        // to the grid's edges.
        assert_eq!(place(0, 40, 20, BASE_ZOOM, 2), 0);
        assert_eq!(place(39, 40, 20, BASE_ZOOM, 2), 20 - 80);
        // In the middle the cell is centred: offset 20 -> character 40 at (20-2)/2 = 9.
        assert_eq!(place(20, 40, 20, BASE_ZOOM, 2), 9 - 40);
        // A small grid is centred whatever the offset.
        assert_eq!(place(0, 4, 20, BASE_ZOOM, 2), 6);
    }
}
