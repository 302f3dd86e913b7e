//! The spatial-classification section of a mission file: `[classification]` and its
//! `[classification.green]` measurement, with their defaults, how the reader reads them
//! (step 2) and the rules a spatial-classification definition obeys (step 3).

use super::kinds::KindSection;
use super::reader::{Ctx, Val};
use super::validate::{Checker, cell, check_other_tables, num};
use super::*;
use crate::mission::strategy::ConfidenceBound;
use std::collections::HashMap;
use toml::de::DeTable;

/// `[classification.green]`: the green-pixel measurement of the bandit paper's hardware
/// test (§V: OpenCV counts green pixels in each image). The paper gives no numbers; these
/// are ours.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GreenDef {
    /// Lower HSV bound, OpenCV scale: H 0–179, S 0–255, V 0–255.
    #[serde(default = "default_hsv_min")]
    pub hsv_min: [u8; 3],
    /// Upper HSV bound (inclusive), same scale; each channel ≥ the lower bound.
    #[serde(default = "default_hsv_max")]
    pub hsv_max: [u8; 3],
    /// An image is a positive measurement (ν_l = 1) when at least this fraction of its
    /// pixels is green, 0 < x ≤ 1.
    #[serde(default = "default_fraction_threshold")]
    pub fraction_threshold: f64,
}

fn default_hsv_min() -> [u8; 3] {
    [35, 60, 40]
}
fn default_hsv_max() -> [u8; 3] {
    [85, 255, 255]
}
fn default_fraction_threshold() -> f64 {
    0.2
}

impl Default for GreenDef {
    fn default() -> Self {
        GreenDef {
            hsv_min: default_hsv_min(),
            hsv_max: default_hsv_max(),
            fraction_threshold: default_fraction_threshold(),
        }
    }
}

/// `[classification]`: the bandit high-level planner (eq. 3–4) and the IP low-level planner
/// (eq. 7–11). Defaults are the paper's simulation defaults (§VI and Fig. 2); a definition of
/// this kind whose file has no `[classification]` table gets them all.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ClassificationDef {
    /// θ ∈ (0, 1): a cell is interesting when μ_l ≥ θ (eq. 1). Default 0.5.
    #[serde(default = "default_theta")]
    pub theta: f64,
    /// ε: labelling error tolerance (Assumption 1), 0 < ε < min(θ, 1 − θ). Default 0.05.
    #[serde(default = "default_epsilon")]
    pub epsilon: f64,
    /// δ ∈ (0, 1): labelling error probability (eq. 2, 3b). Default 0.0001.
    #[serde(default = "default_delta")]
    pub delta: f64,
    /// The confidence interval behind the goal score (3) and the labels (4): `"kl"` (the
    /// default: the KL form of the beta-binomial mixture confidence sequence, same guarantee
    /// as Prop. 1 at the same δ, about 4× fewer samples; docs/results/bandit-bound.md) or
    /// `"paper"` ((3b) as printed). A saved run resumes with the bound it started with.
    #[serde(default = "ConfidenceBound::field_default")]
    pub bound: ConfidenceBound,
    /// D ≥ 1: epoch goals chosen per epoch (Algorithm 1 step 3). Default 8.
    #[serde(default = "default_epoch_goals")]
    pub epoch_goals: u32,
    /// B ≥ 1: measurements (images) per visit of an unclassified cell. Default 10.
    #[serde(default = "default_batch_size")]
    pub batch_size: u32,
    /// Td ≥ 2: drone moves per sensing cycle (battery limit). Default 8.
    #[serde(default = "default_drone_cycle_steps")]
    pub drone_cycle_steps: u32,
    /// Tc ≥ 2: station moves per sensing cycle; Td must be a multiple (γ = Td/Tc). Default 4.
    #[serde(default = "default_station_cycle_steps")]
    pub station_cycle_steps: u32,
    /// K ≥ 1: most sensing cycles per epoch the IP may use (eq. 6). Default 4.
    #[serde(default = "default_max_cycles")]
    pub max_cycles: u32,
    /// C ≥ 1: most drones on one station at a cycle's start and end (eq. 10); absent = no
    /// limit.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub charger_capacity: Option<u32>,
    /// The green-pixel measurement.
    #[serde(default)]
    pub green: GreenDef,
}

fn default_theta() -> f64 {
    0.5
}
fn default_epsilon() -> f64 {
    0.05
}
fn default_delta() -> f64 {
    0.0001
}
fn default_epoch_goals() -> u32 {
    8
}
fn default_batch_size() -> u32 {
    10
}
fn default_drone_cycle_steps() -> u32 {
    8
}
fn default_station_cycle_steps() -> u32 {
    4
}
fn default_max_cycles() -> u32 {
    4
}

impl Default for ClassificationDef {
    fn default() -> Self {
        ClassificationDef {
            theta: default_theta(),
            epsilon: default_epsilon(),
            delta: default_delta(),
            bound: ConfidenceBound::field_default(),
            epoch_goals: default_epoch_goals(),
            batch_size: default_batch_size(),
            drone_cycle_steps: default_drone_cycle_steps(),
            station_cycle_steps: default_station_cycle_steps(),
            max_cycles: default_max_cycles(),
            charger_capacity: None,
            green: GreenDef::default(),
        }
    }
}

impl MissionDef {
    /// Station driving speed, m/s: `speed_m_s · Tc / Td` (bandit paper §II: γ = v_d/v_c =
    /// Td/Tc); `None` for runway mapping.
    pub fn station_speed_m_s(&self) -> Option<f64> {
        let c = self.classification.as_ref()?;
        let td = f64::from(c.drone_cycle_steps.max(1));
        Some(self.flight.speed_m_s * f64::from(c.station_cycle_steps) / td)
    }
}

/// The spatial-classification kind's section: `[classification]`, read by
/// [`read_classification`] and checked by [`check_classification`]; absent, it has the
/// defaults.
pub(super) struct Section;

impl KindSection for Section {
    fn read(&self, ctx: &mut Ctx<'_>, root: &DeTable<'_>, def: &mut MissionDef) {
        def.classification = read_classification(ctx, root);
    }

    fn fill_default(&self, def: &mut MissionDef) {
        if def.classification.is_none() {
            def.classification = Some(ClassificationDef::default());
        }
    }

    fn check(&self, c: &mut Checker, def: &MissionDef) {
        check_classification(c, def);
    }

    fn has_stations(&self) -> bool {
        true
    }
}

/// `[classification]` and `[classification.green]` with their defaults, `None` when the
/// file has no `[classification]` table.
fn read_classification(ctx: &mut Ctx<'_>, root: &DeTable<'_>) -> Option<ClassificationDef> {
    let known = [
        "theta",
        "epsilon",
        "delta",
        "bound",
        "epoch_goals",
        "batch_size",
        "drone_cycle_steps",
        "station_cycle_steps",
        "max_cycles",
        "charger_capacity",
        "green",
    ];
    let t = ctx.sub_table(root, "", "classification", &known)?;
    let d = ClassificationDef::default();
    let p = "classification";
    let count = |c: &mut Ctx<'_>, p: &str, v: &Val<'_>| c.int_of::<u32>(p, v, "an integer ≥ 1");
    let mut out = ClassificationDef {
        theta: ctx.or(t, p, "theta", d.theta, Ctx::num_of),
        epsilon: ctx.or(t, p, "epsilon", d.epsilon, Ctx::num_of),
        delta: ctx.or(t, p, "delta", d.delta, Ctx::num_of),
        bound: ctx.or(t, p, "bound", d.bound, |c, p, v| {
            c.word_of(p, v, &ConfidenceBound::ALL.map(|b| (b.name(), b)))
        }),
        epoch_goals: ctx.or(t, p, "epoch_goals", d.epoch_goals, count),
        batch_size: ctx.or(t, p, "batch_size", d.batch_size, count),
        drone_cycle_steps: ctx.or(t, p, "drone_cycle_steps", d.drone_cycle_steps, count),
        station_cycle_steps: ctx.or(t, p, "station_cycle_steps", d.station_cycle_steps, count),
        max_cycles: ctx.or(t, p, "max_cycles", d.max_cycles, count),
        charger_capacity: ctx.opt(t, p, "charger_capacity", count).unwrap_or(None),
        green: d.green,
    };
    let gk = ["hsv_min", "hsv_max", "fraction_threshold"];
    if let Some(g) = ctx.sub_table(t, p, "green", &gk) {
        let gp = "classification.green";
        let hsv = "[h, s, v] (OpenCV HSV: h 0–179, s and v 0–255)";
        let dg = GreenDef::default();
        out.green = GreenDef {
            hsv_min: ctx.or(g, gp, "hsv_min", dg.hsv_min, |c, p, v| {
                c.u8s_of::<3>(p, v, hsv)
            }),
            hsv_max: ctx.or(g, gp, "hsv_max", dg.hsv_max, |c, p, v| {
                c.u8s_of::<3>(p, v, hsv)
            }),
            fraction_threshold: ctx.or(
                g,
                gp,
                "fraction_threshold",
                dg.fraction_threshold,
                Ctx::num_of,
            ),
        };
    }
    Some(out)
}

/// Step 3 for a spatial-classification definition: no other kind's table, the bounded
/// search area, drones and stations with their start cells (eq. 7a, 7d, 9d, 10), the planner's
/// values and at least one candidate cell.
fn check_classification(c: &mut Checker, def: &MissionDef) {
    check_other_tables(c, def);
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

/// The planner's values (eq. 3–11) and the green measurement.
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
