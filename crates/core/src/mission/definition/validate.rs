//! Step 3 of loading a mission file: value ranges and cross-field rules on the typed
//! definition. Each problem names the key path of the offending value; the reader's span
//! table turns it into a line and column.

use super::*;
use std::collections::{HashMap, HashSet};

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
fn num(x: f64) -> String {
    format!("{x}")
}

fn cell(c: Cell) -> String {
    format!("[{}, {}]", c.row, c.col)
}

#[derive(Default)]
struct Checker {
    issues: Vec<Issue>,
}

impl Checker {
    /// A value out of range.
    fn value(&mut self, path: impl Into<String>, involves: &[&str], message: String) {
        self.issues.push(Issue {
            path: path.into(),
            involves: involves.iter().map(|s| s.to_string()).collect(),
            message,
            defaulted_if_absent: true,
        });
    }

    /// A structural rule (something missing or misplaced).
    fn rule(&mut self, path: impl Into<String>, involves: &[&str], message: String) {
        self.issues.push(Issue {
            path: path.into(),
            involves: involves.iter().map(|s| s.to_string()).collect(),
            message,
            defaulted_if_absent: false,
        });
    }

    /// `x` must be finite and satisfy `ok`.
    fn number(&mut self, path: &str, x: f64, ok: bool, expected: &str) {
        if !(ok && x.is_finite()) {
            self.value(path, &[], format!("expected {expected}, found {}", num(x)));
        }
    }

    /// An integer `x` must be in `lo..=hi`.
    fn int(&mut self, path: &str, x: u64, lo: u64, hi: u64, expected: &str) {
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
    match def.kind {
        MissionKind::RunwayMapping => check_runway(&mut c, def),
        MissionKind::SpatialClassification => check_classification(&mut c, def),
    }
    c.issues
}

fn check_latlon(c: &mut Checker, path: &str, p: LatLon) {
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

const ONLY_CLASSIFICATION: &str = "only for kind = \"spatial-classification\"";

fn check_runway(c: &mut Checker, def: &MissionDef) {
    let mut drones = 0;
    for (i, v) in def.vehicles.iter().enumerate() {
        match v.role {
            Role::Drone => drones += 1,
            Role::Station => c.rule(
                format!("vehicles[{i}].role"),
                &["kind"],
                "runway mapping flies drones only, found a station (charging stations belong \
                 to spatial-classification missions)"
                    .into(),
            ),
        }
        if v.start.is_some() {
            c.rule(
                format!("vehicles[{i}].start"),
                &["kind"],
                format!(
                    "start cells are {ONLY_CLASSIFICATION} (runway drones start at their home)"
                ),
            );
        }
    }
    if drones == 0 && !def.vehicles.is_empty() {
        c.rule(
            "vehicles",
            &["kind"],
            "expected at least one vehicle with role = \"drone\"".into(),
        );
    }
    for (key, present) in [
        ("area.rows", def.area.rows.is_some()),
        ("area.cols", def.area.cols.is_some()),
        ("area.roads", def.area.roads.is_some()),
    ] {
        if present {
            c.rule(
                key,
                &["kind"],
                format!("{ONLY_CLASSIFICATION} (the runway grid is unbounded and has no roads)"),
            );
        }
    }
    if def.classification.is_some() {
        c.rule(
            "classification",
            &["kind"],
            format!("a [classification] table is {ONLY_CLASSIFICATION}"),
        );
    }
    let Some(r) = &def.runway else {
        c.rule(
            "runway",
            &["kind"],
            "missing table [runway] with [runway.sweep] (the box the lawnmower sweeps first)"
                .into(),
        );
        return;
    };
    c.int(
        "runway.images_per_cell",
        r.images_per_cell.into(),
        1,
        100,
        "an integer 1–100",
    );
    if r.votes_required == 0 || r.votes_required > r.images_per_cell {
        c.value(
            "runway.votes_required",
            &["runway.images_per_cell"],
            format!(
                "expected an integer 1–{} (at most images_per_cell), found {}",
                r.images_per_cell, r.votes_required
            ),
        );
    }
    c.int(
        "runway.dilations",
        r.dilations.into(),
        0,
        100,
        "an integer 0–100",
    );
    c.number(
        "runway.black_fraction",
        r.black_fraction,
        r.black_fraction > 0.0 && r.black_fraction <= 1.0,
        "a fraction > 0 and ≤ 1",
    );
    if let Some(l) = r.lane_spacing_m {
        c.number(
            "runway.lane_spacing_m",
            l,
            l > 0.0 && l <= 10_000.0,
            "a number > 0 and ≤ 10000 (metres)",
        );
    }
    if let Some(e) = r.sweep_heading_error_deg {
        c.number(
            "runway.sweep_heading_error_deg",
            e,
            (0.0..45.0).contains(&e),
            "a number ≥ 0 and < 45 (degrees)",
        );
    }
    c.number(
        "runway.sweep_position_tolerance_m",
        r.sweep_position_tolerance_m,
        (0.0..=100.0).contains(&r.sweep_position_tolerance_m),
        "a number ≥ 0 and ≤ 100 (metres)",
    );
    if let Some([n, e]) = r.roi_velocity_ne_mps {
        let speed = n.hypot(e);
        if !(n.is_finite() && e.is_finite() && speed < def.flight.speed_m_s) {
            c.value(
                "runway.roi_velocity_ne_mps",
                &["flight.speed_m_s"],
                format!(
                    "expected [north, east] m/s slower than flight.speed_m_s = {} (a robot \
                     must outrun the region to visit its cells), found [{}, {}]",
                    num(def.flight.speed_m_s),
                    num(n),
                    num(e)
                ),
            );
        }
    }
    match r.sweep {
        SweepBox::Local { north_m, east_m } => {
            for (key, [lo, hi]) in [("north_m", north_m), ("east_m", east_m)] {
                let ok = lo.is_finite()
                    && hi.is_finite()
                    && lo < hi
                    && lo.abs().max(hi.abs()) <= 100_000.0;
                if !ok {
                    c.value(
                        format!("runway.sweep.{key}"),
                        &[],
                        format!(
                            "expected [min, max] with min < max, within 100 km of the origin \
                             (metres), found [{}, {}]",
                            num(lo),
                            num(hi)
                        ),
                    );
                }
            }
        }
        SweepBox::Corners {
            south_west,
            north_east,
        } => {
            check_latlon(c, "runway.sweep.south_west", south_west);
            check_latlon(c, "runway.sweep.north_east", north_east);
            if !(south_west.lat < north_east.lat && south_west.lon < north_east.lon) {
                c.value(
                    "runway.sweep.north_east",
                    &["runway.sweep.south_west"],
                    format!(
                        "expected a corner north and east of south_west ({}, {}), found ({}, {})",
                        num(south_west.lat),
                        num(south_west.lon),
                        num(north_east.lat),
                        num(north_east.lon)
                    ),
                );
            }
        }
    }
}

fn check_classification(c: &mut Checker, def: &MissionDef) {
    if def.runway.is_some() {
        c.rule(
            "runway",
            &["kind"],
            "a [runway] table is only for kind = \"runway-mapping\"".into(),
        );
    }
    let area = &def.area;
    let mut bounded = true;
    for (key, v) in [("area.rows", area.rows), ("area.cols", area.cols)] {
        match v {
            None => {
                bounded = false;
                c.rule(
                    key,
                    &["kind"],
                    "missing: spatial classification needs the search area \
                     (rows = …, cols = … in [area])"
                        .into(),
                );
            }
            Some(n) => c.int(key, n.into(), 1, 1000, "an integer 1–1000"),
        }
    }
    let bounded = bounded
        && area.rows.is_some_and(|n| (1..=1000).contains(&n))
        && area.cols.is_some_and(|n| (1..=1000).contains(&n));

    let drones = def.drones().count();
    let stations = def.stations().count();
    if !def.vehicles.is_empty() {
        if drones == 0 {
            c.rule(
                "vehicles",
                &["kind"],
                "expected at least one vehicle with role = \"drone\" (the sensors)".into(),
            );
        }
        if stations == 0 {
            c.rule(
                "vehicles",
                &["kind"],
                "drones but no charging station: spatial classification needs at least one \
                 vehicle with role = \"station\" (drones recharge on stations every Td moves)"
                    .into(),
            );
        }
    }

    let d = ClassificationDef::default();
    let p = def.classification.as_ref().unwrap_or(&d);
    check_planner(c, p);

    if !bounded {
        return;
    }
    let obstacles: HashSet<Cell> = area.obstacles.iter().copied().collect();
    let station_ok: HashSet<Cell> = def.station_cells().into_iter().collect();
    let deps = [
        "area.rows",
        "area.cols",
        "area.obstacles",
        "area.roads",
        "kind",
    ];
    // Stations: on a free road cell, pairwise distinct (eq. 7a, 7d, 8b, 8c).
    let mut station_at: HashMap<Cell, usize> = HashMap::new();
    for (i, v) in def.vehicles.iter().enumerate() {
        if v.role != Role::Station {
            continue;
        }
        let path = format!("vehicles[{i}].start");
        let Some(s) = v.start else {
            c.rule(
                format!("vehicles[{i}]"),
                &["kind"],
                "missing start = [row, col] (stations need their start cell: the initial team \
                 configuration of eq. 7a)"
                    .into(),
            );
            continue;
        };
        if !def.in_area(s) {
            c.value(
                &path,
                &deps,
                format!(
                    "cell {} is outside the search area (rows 0–{}, cols 0–{})",
                    cell(s),
                    area.rows.unwrap_or(1) - 1,
                    area.cols.unwrap_or(1) - 1
                ),
            );
        } else if obstacles.contains(&s) {
            c.value(&path, &deps, format!("cell {} is an obstacle", cell(s)));
        } else if !station_ok.contains(&s) {
            c.value(
                &path,
                &deps,
                format!(
                    "cell {} is not station-admissible: stations start on a road (area.roads)",
                    cell(s)
                ),
            );
        }
        if let Some(&first) = station_at.get(&s) {
            let other = format!("vehicles[{first}].start");
            c.value(
                &path,
                &[&other],
                format!(
                    "cell {} is already the start of vehicles[{first}] (two stations never \
                     share a cell, eq. 7d)",
                    cell(s)
                ),
            );
        } else {
            station_at.insert(s, i);
        }
    }
    // Drones: on a station's start cell (eq. 9d), at most C per station (eq. 10).
    let mut per_station: HashMap<Cell, u32> = HashMap::new();
    for (i, v) in def.vehicles.iter().enumerate() {
        if v.role != Role::Drone {
            continue;
        }
        let path = format!("vehicles[{i}].start");
        let Some(s) = v.start else {
            c.rule(
                format!("vehicles[{i}]"),
                &["kind"],
                "missing start = [row, col] (drones start on a station's cell: the initial \
                 team configuration of eq. 7a)"
                    .into(),
            );
            continue;
        };
        if stations == 0 {
            continue; // reported once above: no station at all
        }
        if !station_at.contains_key(&s) {
            let mut cells: Vec<Cell> = station_at.keys().copied().collect();
            cells.sort();
            let list = cells
                .iter()
                .map(|&x| cell(x))
                .collect::<Vec<_>>()
                .join(", ");
            c.value(
                &path,
                &["vehicles"],
                format!(
                    "cell {} is not a station's start cell: drones start on a station \
                     (eq. 9d); stations start on {}",
                    cell(s),
                    if list.is_empty() {
                        "no cell".into()
                    } else {
                        list
                    }
                ),
            );
            continue;
        }
        let n = per_station.entry(s).or_insert(0);
        *n += 1;
        if let Some(cap) = p.charger_capacity
            && *n == cap + 1
        {
            c.value(
                &path,
                &["classification.charger_capacity", "vehicles"],
                format!(
                    "more than charger_capacity = {cap} drones start on the station at {} \
                     (eq. 10)",
                    cell(s)
                ),
            );
        }
    }
    if def.candidate_cells().is_empty() {
        c.rule(
            "area",
            &deps,
            "no candidate cells to classify: every cell of the area is an obstacle or \
             (with roads_are_candidates = false) a road"
                .into(),
        );
    }
}

fn check_planner(c: &mut Checker, p: &ClassificationDef) {
    let cp = "classification";
    c.number(
        &format!("{cp}.theta"),
        p.theta,
        p.theta > 0.0 && p.theta < 1.0,
        "θ in (0, 1)",
    );
    let eps_max = p.theta.min(1.0 - p.theta);
    if p.theta > 0.0 && p.theta < 1.0 && !(p.epsilon > 0.0 && p.epsilon < eps_max) {
        c.value(
            format!("{cp}.epsilon"),
            &["classification.theta"],
            format!(
                "expected ε in (0, {}) (0 < ε < min(θ, 1 − θ)), found {}",
                num(eps_max),
                num(p.epsilon)
            ),
        );
    }
    c.number(
        &format!("{cp}.delta"),
        p.delta,
        p.delta > 0.0 && p.delta < 1.0,
        "δ in (0, 1)",
    );
    let big = 1_000_000;
    c.int(
        &format!("{cp}.epoch_goals"),
        p.epoch_goals.into(),
        1,
        big,
        "an integer D ≥ 1",
    );
    c.int(
        &format!("{cp}.batch_size"),
        p.batch_size.into(),
        1,
        big,
        "an integer B ≥ 1",
    );
    c.int(
        &format!("{cp}.drone_cycle_steps"),
        p.drone_cycle_steps.into(),
        2,
        1000,
        "an integer Td in 2–1000",
    );
    c.int(
        &format!("{cp}.station_cycle_steps"),
        p.station_cycle_steps.into(),
        2,
        1000,
        "an integer Tc in 2–1000",
    );
    if p.station_cycle_steps >= 2
        && p.drone_cycle_steps >= 2
        && !p.drone_cycle_steps.is_multiple_of(p.station_cycle_steps)
    {
        c.value(
            format!("{cp}.drone_cycle_steps"),
            &["classification.station_cycle_steps"],
            format!(
                "expected a multiple of station_cycle_steps = {} (Td = γ·Tc with an integer \
                 speed ratio γ, bandit paper §II), found {}",
                p.station_cycle_steps, p.drone_cycle_steps
            ),
        );
    }
    c.int(
        &format!("{cp}.max_cycles"),
        p.max_cycles.into(),
        1,
        1000,
        "an integer K in 1–1000",
    );
    if let Some(cap) = p.charger_capacity {
        c.int(
            &format!("{cp}.charger_capacity"),
            cap.into(),
            1,
            big,
            "an integer C ≥ 1",
        );
    }
    let g = &p.green;
    let gp = "classification.green";
    for (key, hsv) in [("hsv_min", g.hsv_min), ("hsv_max", g.hsv_max)] {
        if hsv[0] > 179 {
            c.value(
                format!("{gp}.{key}[0]"),
                &[],
                format!("expected a hue 0–179 (OpenCV scale), found {}", hsv[0]),
            );
        }
    }
    if (0..3).any(|i| g.hsv_max[i] < g.hsv_min[i]) {
        c.value(
            format!("{gp}.hsv_max"),
            &["classification.green.hsv_min"],
            format!(
                "expected every channel ≥ hsv_min {:?}, found {:?}",
                g.hsv_min, g.hsv_max
            ),
        );
    }
    c.number(
        &format!("{gp}.fraction_threshold"),
        g.fraction_threshold,
        g.fraction_threshold > 0.0 && g.fraction_threshold <= 1.0,
        "a fraction > 0 and ≤ 1",
    );
}
