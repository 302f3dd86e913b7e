//! Step 3 of loading a mission file: value ranges and cross-field rules on the typed
//! definition. Each problem names the key path of the offending value; the reader's span
//! table turns it into a line and column. The common parts are checked here, then the
//! definition's kind checks the rest in its own module (`KindSection::check`) with the
//! [`Checker`] and helpers below.

use super::*;
use std::collections::HashMap;

/// One problem found by validation.
pub(super) struct Issue {
    /// Key path of the offending value (`classification.drone_cycle_steps`).
    pub path: String,
    /// Other values the rule depends on: if any of them failed to read, the rule's verdict
    /// is meaningless and the issue is dropped.
    pub(crate) involves: Vec<String>,
    /// What was expected and what was found.
    pub message: String,
    /// The value may come from a default (the key absent from the file): say so.
    pub(crate) defaulted_if_absent: bool,
}

/// A number as written in messages (`-4`, `0.0001`, `nan`).
pub(super) fn num(x: f64) -> String {
    format!("{x}")
}

/// A cell as written in messages (`[row, col]`).
pub(super) fn cell(c: Cell) -> String {
    format!("[{}, {}]", c.row, c.col)
}

/// The problems found so far, in the order they are reported.
#[derive(Default)]
pub(super) struct Checker {
    issues: Vec<Issue>,
}

impl Checker {
    /// A value out of range.
    pub(super) fn value(&mut self, path: impl Into<String>, involves: &[&str], message: String) {
        self.issues.push(Issue {
            path: path.into(),
            involves: involves.iter().map(|s| s.to_string()).collect(),
            message,
            defaulted_if_absent: true,
        });
    }

    /// A structural rule (something missing or misplaced).
    pub(super) fn rule(&mut self, path: impl Into<String>, involves: &[&str], message: String) {
        self.issues.push(Issue {
            path: path.into(),
            involves: involves.iter().map(|s| s.to_string()).collect(),
            message,
            defaulted_if_absent: false,
        });
    }

    /// `x` must be finite and satisfy `ok`.
    pub(super) fn number(&mut self, path: &str, x: f64, ok: bool, expected: &str) {
        if !(ok && x.is_finite()) {
            self.value(path, &[], format!("expected {expected}, found {}", num(x)));
        }
    }

    /// An integer `x` must be in `lo..=hi`.
    pub(super) fn int(&mut self, path: &str, x: u64, lo: u64, hi: u64, expected: &str) {
        if x < lo || x > hi {
            self.value(path, &[], format!("expected {expected}, found {x}"));
        }
    }
}

/// All problems of `def`.
pub(super) fn check(def: &MissionDef) -> Vec<Issue> {
    let mut c = Checker::default();
    if def.name.trim().is_empty() {
        c.value("name", &[], "expected a non-empty name".into());
    }
    check_grid(&mut c, def);
    check_flight(&mut c, def);
    check_vehicles(&mut c, def);
    check_cells(&mut c, def);
    def.kind.section().check(&mut c, def);
    c.issues
}

/// Every other kind's table that `def` has: a table is only for its kind. Each kind's check
/// calls this where its rules report it.
pub(super) fn check_other_tables(c: &mut Checker, def: &MissionDef) {
    for &k in MissionKind::ALL {
        if k != def.kind && k.has_table(def) {
            let table = k.table();
            c.rule(
                table,
                &["kind"],
                format!("a [{table}] table is only for kind = {:?}", k.as_str()),
            );
        }
    }
}

/// A WGS84 position: in the UTM range.
pub(super) fn check_latlon(c: &mut Checker, path: &str, p: LatLon) {
    c.number(
        &format!("{path}.lat"),
        p.lat,
        (-80.0..=84.0).contains(&p.lat),
        "a latitude in [-80, 84] degrees (the UTM range)",
    );
    c.number(
        &format!("{path}.lon"),
        p.lon,
        (-180.0..=180.0).contains(&p.lon),
        "a longitude in [-180, 180] degrees",
    );
}

fn check_grid(c: &mut Checker, def: &MissionDef) {
    if let Origin::Coordinates(p) = def.grid.origin {
        check_latlon(c, "grid.origin", p);
    }
    let s = def.grid.cell_size_m;
    c.number(
        "grid.cell_size_m",
        s,
        s > 0.0 && s <= 10_000.0,
        "a number > 0 and ≤ 10000 (metres)",
    );
}

fn check_flight(c: &mut Checker, def: &MissionDef) {
    let f = &def.flight;
    c.number(
        "flight.altitude_m",
        f.altitude_m,
        f.altitude_m > 0.0 && f.altitude_m <= 1000.0,
        "a number > 0 and ≤ 1000 (metres above home)",
    );
    c.number(
        "flight.altitude_separation_m",
        f.altitude_separation_m,
        (0.0..=100.0).contains(&f.altitude_separation_m),
        "a number ≥ 0 and ≤ 100 (metres)",
    );
    c.number(
        "flight.speed_m_s",
        f.speed_m_s,
        f.speed_m_s > 0.0 && f.speed_m_s <= 50.0,
        "a number > 0 and ≤ 50 (m/s)",
    );
    let cam = &def.camera;
    c.number(
        "camera.hfov_deg",
        cam.hfov_deg,
        cam.hfov_deg > 0.0 && cam.hfov_deg < 180.0,
        "a number > 0 and < 180 (degrees)",
    );
    let px = "an integer 1–100000 (pixels)";
    c.int("camera.width_px", cam.width_px.into(), 1, 100_000, px);
    c.int("camera.height_px", cam.height_px.into(), 1, 100_000, px);
    let b = &def.battery;
    c.number(
        "battery.flight_time_min",
        b.flight_time_min,
        b.flight_time_min > 0.0 && b.flight_time_min <= 1440.0,
        "a number > 0 and ≤ 1440 (minutes)",
    );
    c.number(
        "battery.rtl_reserve_pct",
        b.rtl_reserve_pct,
        (0.0..100.0).contains(&b.rtl_reserve_pct),
        "a number ≥ 0 and < 100 (percent)",
    );
    c.number(
        "battery.descent_rate_m_s",
        b.descent_rate_m_s,
        b.descent_rate_m_s > 0.0 && b.descent_rate_m_s <= 20.0,
        "a number > 0 and ≤ 20 (m/s)",
    );
    c.number(
        "battery.landing_margin_s",
        b.landing_margin_s,
        (0.0..=3600.0).contains(&b.landing_margin_s),
        "a number ≥ 0 and ≤ 3600 (seconds)",
    );
    for (key, v) in [
        ("battery.fresh_pct", b.fresh_pct),
        ("battery.fresh_after_reboot_pct", b.fresh_after_reboot_pct),
    ] {
        c.number(
            key,
            v,
            v > 0.0 && v <= 100.0,
            "a number > 0 and ≤ 100 (percent)",
        );
    }
}

fn check_vehicles(c: &mut Checker, def: &MissionDef) {
    if def.vehicles.is_empty() {
        c.rule(
            "vehicles",
            &[],
            "expected at least one [[vehicles]] entry".into(),
        );
        return;
    }
    let mut sysids: HashMap<u8, usize> = HashMap::new();
    let mut names: HashMap<&str, usize> = HashMap::new();
    for (i, v) in def.vehicles.iter().enumerate() {
        let path = format!("vehicles[{i}].sysid");
        if v.sysid == 0 || v.sysid == crate::identity::GCS_SYSID {
            c.value(
                &path,
                &[],
                format!(
                    "expected an integer 1–254 (0 is broadcast, 255 is the ground station), found {}",
                    v.sysid
                ),
            );
        } else if let Some(&first) = sysids.get(&v.sysid) {
            let other = format!("vehicles[{first}].sysid");
            c.value(
                &path,
                &[&other],
                format!(
                    "system id {} is already used by vehicles[{first}] (system ids must be unique)",
                    v.sysid
                ),
            );
        } else {
            sysids.insert(v.sysid, i);
        }
        if let Some(name) = &v.name {
            let npath = format!("vehicles[{i}].name");
            if name.trim().is_empty() {
                c.value(&npath, &[], "expected a non-empty name".into());
            } else if let Some(&first) = names.get(name.as_str()) {
                let other = format!("vehicles[{first}].name");
                c.value(
                    &npath,
                    &[&other],
                    format!("name {name:?} is already used by vehicles[{first}]"),
                );
            } else {
                names.insert(name, i);
            }
        }
    }
}

/// Obstacles and roads: no duplicates, no cell both, inside the area when it is bounded.
fn check_cells(c: &mut Checker, def: &MissionDef) {
    let area = &def.area;
    let bounded = area.rows.is_some() && area.cols.is_some();
    let outside = |cl: Cell| {
        format!(
            "cell {} is outside the search area (rows 0–{}, cols 0–{})",
            cell(cl),
            area.rows.unwrap_or(0).saturating_sub(1),
            area.cols.unwrap_or(0).saturating_sub(1)
        )
    };
    let mut obstacles: HashMap<Cell, usize> = HashMap::new();
    for (i, &o) in area.obstacles.iter().enumerate() {
        let path = format!("area.obstacles[{i}]");
        if bounded && !def.in_area(o) {
            c.value(&path, &["area.rows", "area.cols"], outside(o));
        }
        if let Some(&first) = obstacles.get(&o) {
            c.value(
                &path,
                &[],
                format!(
                    "cell {} is listed twice (also area.obstacles[{first}])",
                    cell(o)
                ),
            );
        } else {
            obstacles.insert(o, i);
        }
    }
    if let Some(roads) = &area.roads {
        let mut seen: HashMap<Cell, usize> = HashMap::new();
        for (i, &r) in roads.iter().enumerate() {
            let path = format!("area.roads[{i}]");
            if bounded && !def.in_area(r) {
                c.value(&path, &["area.rows", "area.cols"], outside(r));
            }
            if let Some(&k) = obstacles.get(&r) {
                let other = format!("area.obstacles[{k}]");
                c.value(
                    &path,
                    &[&other, "area.obstacles"],
                    format!(
                        "cell {} is both a road and an obstacle (area.obstacles[{k}]); \
                         roads must be free cells",
                        cell(r)
                    ),
                );
            }
            if let Some(&first) = seen.get(&r) {
                c.value(
                    &path,
                    &[],
                    format!(
                        "cell {} is listed twice (also area.roads[{first}])",
                        cell(r)
                    ),
                );
            } else {
                seen.insert(r, i);
            }
        }
    }
}
