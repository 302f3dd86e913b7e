//! QGroundControl `.plan` files (JSON): mission, geofence and rally points together.
//!
//! Layout as QGroundControl writes it (`mavlink/qgroundcontrol`
//! `src/MissionManager/PlanMasterController.cc` `saveToJson`, `MissionController::save`,
//! `GeoFenceController::save`, `RallyPointController::save`, `MissionItem::save`,
//! `SimpleMissionItem::save`):
//!
//! ```json
//! { "fileType": "Plan", "version": 1, "groundStation": "QGroundControl",
//!   "mission": { "version": 2, "firmwareType": 3, "vehicleType": 2,
//!                "cruiseSpeed": 15, "hoverSpeed": 5, "globalPlanAltitudeMode": 1,
//!                "plannedHomePosition": [lat, lon, alt_amsl],
//!                "items": [ { "type": "SimpleItem", "command": 22, "frame": 3,
//!                             "params": [0, 0, 0, null, lat, lon, 20],
//!                             "autoContinue": true, "doJumpId": 1,
//!                             "Altitude": 20, "AltitudeMode": 1, "AMSLAltAboveTerrain": null } ] },
//!   "geoFence": { "version": 2, "polygons": [ { "inclusion": true, "version": 1,
//!                 "polygon": [[lat, lon], …] } ],
//!                 "circles": [ { "inclusion": false, "version": 1,
//!                 "circle": { "center": [lat, lon], "radius": 30 } } ] },
//!   "rallyPoints": { "version": 2, "points": [[lat, lon, alt], …] } }
//! ```
//!
//! * `params` holds the 7 MAV_CMD parameters; `null` is NaN (QGroundControl's JSON cannot
//!   hold NaN). For position frames params 5/6 are degrees.
//! * The planned home position is *not* a mission item: QGroundControl keeps it in
//!   `plannedHomePosition` and sends it as item 0 only to ArduPilot
//!   (`PlanManager::writeMissionItems`). It is read and written separately here.
//! * DO_JUMP `params[0]` names the target's `doJumpId` (QGroundControl resolves it on load:
//!   "Could not find doJumpId"); we write `doJumpId` = position + 1 (home is 0), as QGC does.
//! * An item in QGroundControl's "calculated above terrain" altitude mode (`AltitudeMode` 3)
//!   is sent as an AMSL altitude that QGroundControl computes from its terrain data; the test
//!   plans QGroundControl generates (`test/plans/generate_test_plans.py`) save it with
//!   `params[6]` null until terrain has arrived. Such an item is refused here, naming it
//!   ([`TERRAIN_CALCULATED`]): uploaded as it is, its altitude is NaN, and ArduCopter
//!   rejects the whole mission at that item with MAV_MISSION_INVALID_PARAM7.
//! * Complex items (survey, corridor and structure scans) are flattened to the mission items
//!   QGroundControl stored with them (`TransectStyleComplexItem.Items`); landing patterns
//!   without stored items are refused with a clear error.
//! * Fence polygons become runs of MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION/EXCLUSION items
//!   (param1 = vertex count), circles MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION/EXCLUSION (param1 =
//!   radius), frame GLOBAL (`GeoFenceManager`); rally points MAV_CMD_NAV_RALLY_POINT, frame
//!   GLOBAL_RELATIVE_ALT (`RallyPointManager`).
//!
//! Malformed files are rejected with the line (and column) where the problem is.

use super::item::{MissionItem, cmd, deg_to_e7, e7_to_deg, frame};
use crate::mission::wire::is_global_frame;
use mavlink::dialects::ardupilotmega::MavCmd;
use serde::Deserialize;
use serde_json::{Value, json};
use std::collections::HashMap;

/// MAV_CMD_NAV_FENCE_RETURN_POINT.
const FENCE_RETURN_POINT: u16 = MavCmd::MAV_CMD_NAV_FENCE_RETURN_POINT as u16;
/// MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION.
const FENCE_CIRCLE_INCLUSION: u16 = MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_INCLUSION as u16;
/// MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION.
const FENCE_CIRCLE_EXCLUSION: u16 = MavCmd::MAV_CMD_NAV_FENCE_CIRCLE_EXCLUSION as u16;

/// QGroundControl's `AltitudeMode` "calculated above terrain"
/// (`QGroundControlQmlGlobal::AltitudeModeCalcAboveTerrain`): the item's altitude above the
/// terrain, sent as the AMSL altitude QGroundControl computes from its own terrain data.
pub const TERRAIN_CALCULATED: u8 = 3;

/// A malformed `.plan` file.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum PlanError {
    /// JSON syntax or structure error (serde_json gives line and column).
    #[error("{0}")]
    Json(String),
    /// A semantic problem found after parsing.
    #[error("line {line}: {message}")]
    Invalid {
        /// 1-based line of the offending item (best effort: the line where its object starts).
        line: usize,
        /// What is wrong.
        message: String,
    },
}

/// A QGroundControl plan.
#[derive(Clone, Debug, PartialEq)]
pub struct Plan {
    /// Mission items (user numbering, no home).
    pub mission: Vec<MissionItem>,
    /// Planned home position: (lat, lon degrees, alt AMSL metres).
    pub home: Option<(f64, f64, f64)>,
    /// Geofence items (polygon vertices, circles, return point).
    pub fence: Vec<MissionItem>,
    /// Rally points.
    pub rally: Vec<MissionItem>,
    /// MAV_AUTOPILOT the plan was made for (3 ArduPilot, 12 PX4, 0 generic).
    pub firmware_type: u8,
    /// MAV_TYPE the plan was made for.
    pub vehicle_type: u8,
    /// Cruise speed, m/s (fixed wing / rover).
    pub cruise_speed: f64,
    /// Hover speed, m/s (multirotor).
    pub hover_speed: f64,
}

impl Default for Plan {
    fn default() -> Self {
        Plan {
            mission: Vec::new(),
            home: None,
            fence: Vec::new(),
            rally: Vec::new(),
            firmware_type: 0,
            vehicle_type: 2,
            cruise_speed: 15.0,
            hover_speed: 5.0,
        }
    }
}

/// The top level of a `.plan`. Keys it does not name are ignored, as QGroundControl
/// (`PlanMasterController::loadFromFile` checks only the keys it needs) and MAVSDK
/// (`MissionImport::parse_json`, which loads PX4's integration-test plans) do: PX4's
/// `multicopter_mission_geofence_avoid.plan` carries a `"UUID"`.
#[derive(Deserialize)]
#[allow(dead_code)]
struct FileJ {
    #[serde(rename = "fileType")]
    file_type: String,
    version: u32,
    #[serde(rename = "groundStation", default)]
    ground_station: Option<String>,
    mission: MissionJ,
    #[serde(rename = "geoFence", default)]
    geo_fence: Option<FenceJ>,
    #[serde(rename = "rallyPoints", default)]
    rally_points: Option<RallyJ>,
}

#[derive(Deserialize)]
#[allow(dead_code)]
struct MissionJ {
    version: u32,
    #[serde(rename = "firmwareType", default)]
    firmware_type: Option<u8>,
    #[serde(rename = "vehicleType", default)]
    vehicle_type: Option<u8>,
    #[serde(rename = "cruiseSpeed", default)]
    cruise_speed: Option<f64>,
    #[serde(rename = "hoverSpeed", default)]
    hover_speed: Option<f64>,
    #[serde(rename = "plannedHomePosition", default)]
    planned_home: Option<Vec<Option<f64>>>,
    items: Vec<Value>,
}

#[derive(Deserialize)]
#[allow(dead_code)]
struct FenceJ {
    version: u32,
    #[serde(default)]
    polygons: Vec<PolygonJ>,
    #[serde(default)]
    circles: Vec<CircleJ>,
    #[serde(rename = "breachReturn", default)]
    breach_return: Option<Vec<Option<f64>>>,
}

#[derive(Deserialize)]
struct PolygonJ {
    inclusion: bool,
    polygon: Vec<[f64; 2]>,
}

#[derive(Deserialize)]
struct CircleJ {
    inclusion: bool,
    circle: CircleInner,
}

#[derive(Deserialize)]
struct CircleInner {
    center: [f64; 2],
    radius: f64,
}

#[derive(Deserialize)]
#[allow(dead_code)]
struct RallyJ {
    version: u32,
    points: Vec<[f64; 3]>,
}

#[derive(Deserialize)]
#[allow(dead_code)]
struct SimpleJ {
    #[serde(rename = "type")]
    kind: String,
    command: u16,
    frame: u8,
    params: [Option<f64>; 7],
    #[serde(rename = "autoContinue")]
    auto_continue: bool,
    #[serde(rename = "doJumpId", default)]
    do_jump_id: Option<i64>,
    #[serde(rename = "AltitudeMode", default)]
    altitude_mode: Option<u8>,
    #[serde(rename = "Altitude", default)]
    altitude: Option<f64>,
}

/// The 1-based line where the JSON object enclosing the `n`-th occurrence of `needle`
/// starts (0 if not found), for messages: serde_json's `Value` keeps no positions.
fn line_of_nth(text: &str, needle: &str, n: usize) -> usize {
    let mut pos = 0;
    let mut at = None;
    for _ in 0..=n {
        match text[pos..].find(needle) {
            Some(i) => {
                at = Some(pos + i);
                pos += i + needle.len();
            }
            None => return 0,
        }
    }
    let Some(at) = at else { return 0 };
    let bytes = text.as_bytes();
    let mut depth = 0i32;
    let mut start = 0;
    for k in (0..at).rev() {
        match bytes[k] {
            b'}' => depth += 1,
            b'{' if depth == 0 => {
                start = k;
                break;
            }
            b'{' => depth -= 1,
            _ => {}
        }
    }
    text[..start].matches('\n').count() + 1
}

/// The 1-based line of the first occurrence of `needle` (0 if absent).
fn line_of_key(text: &str, needle: &str) -> usize {
    text.find(needle)
        .map_or(0, |i| text[..i].matches('\n').count() + 1)
}

/// What is wrong with one position or item of a plan file; [`parse_plan`] adds where it is
/// ([`PlanError::Invalid`]).
#[derive(Debug, thiserror::Error)]
enum ItemError {
    /// A latitude outside ±90° (or not a number).
    #[error("latitude {0} is out of range (±90°)")]
    Latitude(f64),
    /// A longitude outside ±180° (or not a number).
    #[error("longitude {0} is out of range (±180°)")]
    Longitude(f64),
    /// A `SimpleItem` whose fields do not read.
    #[error("{0}")]
    Json(#[from] serde_json::Error),
    /// An item whose altitude QGroundControl computes from terrain data, saved without it.
    #[error(
        "{command} {above} m in altitude mode \"calculated above terrain\" (QGroundControl \
         AltitudeMode 3) has no altitude: QGroundControl sends it as an AMSL altitude it \
         computes from its terrain data, and saved none; fleetmap does not compute it (the \
         autopilot would refuse the mission at this item). Open the plan in QGroundControl \
         until it shows terrain heights and save it again, or set the item to \"terrain \
         frame\" (AltitudeMode 4), which the vehicle follows with terrain data \
         (`--terrain DIR` serves it)"
    )]
    TerrainCalculated {
        /// The item's command, named.
        command: String,
        /// The altitude above terrain it asked for, metres (as text; "?" if none).
        above: String,
    },
}

/// MAV_CMD `c` by its MAVLink name without the `MAV_CMD_` prefix.
fn command_name(c: u16) -> String {
    use mavlink::dialects::ardupilotmega::MavCmd;
    use num_traits::FromPrimitive;
    MavCmd::from_u16(c)
        .map(|m| format!("{m:?}").trim_start_matches("MAV_CMD_").to_string())
        .unwrap_or_else(|| format!("command {c}"))
}

fn check_latlon(lat: f64, lon: f64) -> Result<(), ItemError> {
    if !(lat.is_finite() && lat.abs() <= 90.0) {
        return Err(ItemError::Latitude(lat));
    }
    if !(lon.is_finite() && lon.abs() <= 180.0) {
        return Err(ItemError::Longitude(lon));
    }
    Ok(())
}

fn simple_item(v: &Value) -> Result<(MissionItem, Option<i64>), ItemError> {
    let s: SimpleJ = serde_json::from_value(v.clone())?;
    if s.altitude_mode == Some(TERRAIN_CALCULATED) && s.params[6].is_none() {
        return Err(ItemError::TerrainCalculated {
            command: command_name(s.command),
            above: s.altitude.map_or("?".into(), |a| format!("{a}")),
        });
    }
    let p = |i: usize| s.params[i].unwrap_or(f64::NAN);
    let global = is_global_frame(s.frame);
    let (x, y) = if global {
        let (lat, lon) = (p(4), p(5));
        check_latlon(lat, lon)?;
        (deg_to_e7(lat), deg_to_e7(lon))
    } else {
        let int = |v: f64| if v.is_finite() { v.round() as i32 } else { 0 };
        (int(p(4)), int(p(5)))
    };
    Ok((
        MissionItem {
            frame: s.frame,
            command: s.command,
            current: false,
            autocontinue: s.auto_continue,
            param1: p(0) as f32,
            param2: p(1) as f32,
            param3: p(2) as f32,
            param4: p(3) as f32,
            x,
            y,
            z: p(6) as f32,
        },
        s.do_jump_id,
    ))
}

/// `text` with its `//` and `/* */` comments outside strings blanked (each comment character
/// a space, line breaks kept, so serde_json's line and column still point into the file).
/// MAVSDK reads `.plan` files with jsoncpp's default reader, which allows such comments
/// (`MissionImport::parse_json`, `Json::CharReaderBuilder`), and PX4's own
/// `test/mavsdk_tests/fw_mission.plan` has one after an item's `params`.
fn blank_comments(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    let mut chars = text.chars().peekable();
    let (mut in_string, mut escaped) = (false, false);
    while let Some(c) = chars.next() {
        if in_string {
            out.push(c);
            match (escaped, c) {
                (true, _) => escaped = false,
                (false, '\\') => escaped = true,
                (false, '"') => in_string = false,
                _ => {}
            }
            continue;
        }
        match (c, chars.peek()) {
            ('"', _) => {
                in_string = true;
                out.push(c);
            }
            ('/', Some('/')) => {
                out.push(' ');
                while let Some(&n) = chars.peek() {
                    if n == '\n' {
                        break;
                    }
                    out.push(if n == '\r' { n } else { ' ' });
                    chars.next();
                }
            }
            ('/', Some('*')) => {
                chars.next();
                out.push_str("  ");
                let mut prev = ' ';
                for n in chars.by_ref() {
                    out.push(if n == '\n' || n == '\r' { n } else { ' ' });
                    if prev == '*' && n == '/' {
                        break;
                    }
                    prev = n;
                }
            }
            _ => out.push(c),
        }
    }
    out
}

/// Parse a `.plan` file.
pub fn parse_plan(text: &str) -> Result<Plan, PlanError> {
    let text = &blank_comments(text);
    let f: FileJ = serde_json::from_str(text).map_err(|e| PlanError::Json(e.to_string()))?;
    let invalid = |line: usize, message: String| PlanError::Invalid { line, message };
    if f.file_type != "Plan" {
        return Err(invalid(
            line_of_key(text, "\"fileType\""),
            format!("fileType is {:?}, expected \"Plan\"", f.file_type),
        ));
    }
    if f.version != 1 {
        return Err(invalid(
            1,
            format!(
                "plan version {} is not supported (QGroundControl writes 1)",
                f.version
            ),
        ));
    }
    if f.mission.version != 2 {
        return Err(invalid(
            line_of_key(text, "\"mission\""),
            format!(
                "mission version {} is not supported (expected 2)",
                f.mission.version
            ),
        ));
    }
    // Flatten simple and complex items, remembering doJumpIds.
    let mut items: Vec<MissionItem> = Vec::new();
    let mut jump_ids: HashMap<i64, usize> = HashMap::new();
    let mut jumps: Vec<(usize, usize)> = Vec::new(); // (item index, line)
    let mut simple_seen = 0usize;
    let mut complex_seen = 0usize;
    for v in &f.mission.items {
        let kind = v.get("type").and_then(Value::as_str).unwrap_or("");
        match kind {
            "SimpleItem" => {
                let line = line_of_nth(text, "\"SimpleItem\"", simple_seen);
                simple_seen += 1;
                // numbered as QGroundControl shows it: home is 0
                let n = items.len() + 1;
                let (it, id) =
                    simple_item(v).map_err(|m| invalid(line, format!("mission item {n}: {m}")))?;
                if let Some(id) = id {
                    jump_ids.insert(id, items.len());
                }
                if it.command == cmd::DO_JUMP {
                    jumps.push((items.len(), line));
                }
                items.push(it);
            }
            "ComplexItem" => {
                let line = line_of_nth(text, "\"ComplexItem\"", complex_seen);
                complex_seen += 1;
                let name = v
                    .get("complexItemType")
                    .and_then(Value::as_str)
                    .unwrap_or("?")
                    .to_string();
                let inner = v
                    .get("TransectStyleComplexItem")
                    .and_then(|t| t.get("Items"))
                    .and_then(Value::as_array)
                    .ok_or_else(|| {
                        invalid(
                            line,
                            format!(
                                "complex item {name:?} has no stored mission items (TransectStyleComplexItem.Items); open and re-save it in QGroundControl 4 or later"
                            ),
                        )
                    })?;
                let _ = line;
                for sub in inner {
                    let line = line_of_nth(text, "\"SimpleItem\"", simple_seen);
                    simple_seen += 1;
                    let n = items.len() + 1;
                    let (it, id) = simple_item(sub).map_err(|m| {
                        invalid(line, format!("mission item {n} (in {name:?}): {m}"))
                    })?;
                    if let Some(id) = id {
                        jump_ids.insert(id, items.len());
                    }
                    items.push(it);
                }
            }
            other => {
                return Err(invalid(
                    line_of_key(text, "\"items\""),
                    format!(
                        "mission item {} has type {other:?}, expected \"SimpleItem\" or \"ComplexItem\"",
                        items.len()
                    ),
                ));
            }
        }
    }
    for (i, line) in jumps {
        let id = items[i].param1 as i64;
        let target = jump_ids
            .get(&id)
            .ok_or_else(|| invalid(line, format!("DO_JUMP to doJumpId {id}, which no item has")))?;
        items[i].param1 = *target as f32;
    }
    let home = match &f.mission.planned_home {
        Some(h) if h.len() == 3 => {
            let lat = h[0].unwrap_or(f64::NAN);
            let lon = h[1].unwrap_or(f64::NAN);
            check_latlon(lat, lon).map_err(|m| {
                invalid(
                    line_of_key(text, "\"plannedHomePosition\""),
                    format!("plannedHomePosition: {m}"),
                )
            })?;
            Some((lat, lon, h[2].unwrap_or(0.0)))
        }
        Some(h) => {
            return Err(invalid(
                line_of_key(text, "\"plannedHomePosition\""),
                format!(
                    "plannedHomePosition has {} values, expected [lat, lon, alt]",
                    h.len()
                ),
            ));
        }
        None => None,
    };
    let mut fence = Vec::new();
    if let Some(g) = &f.geo_fence {
        for (k, p) in g.polygons.iter().enumerate() {
            let line = line_of_nth(text, "\"polygon\"", k);
            if p.polygon.len() < 3 {
                return Err(invalid(
                    line,
                    format!(
                        "fence polygon {k} has {} vertices (at least 3)",
                        p.polygon.len()
                    ),
                ));
            }
            let command = if p.inclusion {
                cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION
            } else {
                cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION
            };
            for v in &p.polygon {
                check_latlon(v[0], v[1])
                    .map_err(|m| invalid(line, format!("fence polygon {k}: {m}")))?;
                let mut it = MissionItem::at(command, v[0], v[1], 0.0);
                it.frame = frame::GLOBAL;
                it.param1 = p.polygon.len() as f32;
                fence.push(it);
            }
        }
        for (k, c) in g.circles.iter().enumerate() {
            let line = line_of_nth(text, "\"circle\"", k);
            check_latlon(c.circle.center[0], c.circle.center[1])
                .map_err(|m| invalid(line, format!("fence circle {k}: {m}")))?;
            if !(c.circle.radius.is_finite() && c.circle.radius > 0.0) {
                return Err(invalid(
                    line,
                    format!(
                        "fence circle {k}: radius {} must be positive",
                        c.circle.radius
                    ),
                ));
            }
            let command = if c.inclusion {
                FENCE_CIRCLE_INCLUSION
            } else {
                FENCE_CIRCLE_EXCLUSION
            };
            let mut it = MissionItem::at(command, c.circle.center[0], c.circle.center[1], 0.0);
            it.frame = frame::GLOBAL;
            it.param1 = c.circle.radius as f32;
            fence.push(it);
        }
        if let Some(b) = &g.breach_return
            && b.len() >= 2
            && let (Some(lat), Some(lon)) = (b[0], b[1])
        {
            check_latlon(lat, lon)
                .map_err(|m| invalid(line_of_key(text, "\"breachReturn\""), m.to_string()))?;
            let mut it = MissionItem::at(
                FENCE_RETURN_POINT,
                lat,
                lon,
                b.get(2).copied().flatten().unwrap_or(0.0) as f32,
            );
            it.frame = frame::GLOBAL_RELATIVE_ALT;
            fence.push(it);
        }
    }
    let mut rally = Vec::new();
    if let Some(r) = &f.rally_points {
        for (k, p) in r.points.iter().enumerate() {
            check_latlon(p[0], p[1]).map_err(|m| {
                invalid(
                    line_of_key(text, "\"points\""),
                    format!("rally point {k}: {m}"),
                )
            })?;
            rally.push(MissionItem::at(
                cmd::NAV_RALLY_POINT,
                p[0],
                p[1],
                p[2] as f32,
            ));
        }
    }
    Ok(Plan {
        mission: items,
        home,
        fence,
        rally,
        firmware_type: f.mission.firmware_type.unwrap_or(0),
        vehicle_type: f.mission.vehicle_type.unwrap_or(2),
        cruise_speed: f.mission.cruise_speed.unwrap_or(15.0),
        hover_speed: f.mission.hover_speed.unwrap_or(5.0),
    })
}

fn jnum(v: f32) -> Value {
    if v.is_finite() {
        // Shortest decimal that reads back as the same f32.
        let s = format!("{v}");
        s.parse::<f64>().map(|f| json!(f)).unwrap_or(Value::Null)
    } else {
        Value::Null
    }
}

fn item_json(it: &MissionItem, seq: usize) -> Value {
    let global = is_global_frame(it.frame);
    let (p5, p6) = if global {
        (json!(e7_to_deg(it.x)), json!(e7_to_deg(it.y)))
    } else {
        (json!(it.x), json!(it.y))
    };
    let mut o = json!({
        "type": "SimpleItem",
        "autoContinue": it.autocontinue,
        "command": it.command,
        "doJumpId": seq,
        "frame": it.frame,
        "params": [jnum(it.param1), jnum(it.param2), jnum(it.param3), jnum(it.param4), p5, p6, jnum(it.z)],
    });
    if global && let Some(m) = o.as_object_mut() {
        // QGroundControl's AltitudeMode: 1 relative, 2 absolute, 4 terrain frame.
        let mode = match it.frame {
            3 | 6 => 1,
            10 | 11 => 4,
            _ => 2,
        };
        m.insert("AMSLAltAboveTerrain".into(), Value::Null);
        m.insert("Altitude".into(), jnum(it.z));
        m.insert("AltitudeMode".into(), json!(mode));
    }
    o
}

/// Write a plan as QGroundControl does.
pub fn write_plan(plan: &Plan) -> String {
    let items: Vec<Value> = plan
        .mission
        .iter()
        .enumerate()
        .map(|(i, it)| {
            let mut it = *it;
            if it.command == cmd::DO_JUMP {
                it.param1 += 1.0; // target's doJumpId
            }
            item_json(&it, i + 1)
        })
        .collect();
    let home = plan
        .home
        .map(|(a, b, c)| json!([a, b, c]))
        .unwrap_or(json!([0.0, 0.0, 0.0]));
    // Fence: group vertex runs into polygons.
    let mut polygons = Vec::new();
    let mut circles = Vec::new();
    let mut breach: Option<Value> = None;
    let mut i = 0;
    while i < plan.fence.len() {
        let it = &plan.fence[i];
        match it.command {
            cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION | cmd::NAV_FENCE_POLYGON_VERTEX_EXCLUSION => {
                let n = (it.param1.max(1.0) as usize).min(plan.fence.len() - i);
                let verts: Vec<Value> = plan.fence[i..i + n]
                    .iter()
                    .map(|v| json!([e7_to_deg(v.x), e7_to_deg(v.y)]))
                    .collect();
                let inclusion = it.command == cmd::NAV_FENCE_POLYGON_VERTEX_INCLUSION;
                polygons.push(json!({"inclusion": inclusion, "polygon": verts, "version": 1}));
                i += n;
            }
            FENCE_CIRCLE_INCLUSION | FENCE_CIRCLE_EXCLUSION => {
                circles.push(json!({
                    "circle": {"center": [e7_to_deg(it.x), e7_to_deg(it.y)], "radius": jnum(it.param1)},
                    "inclusion": it.command == FENCE_CIRCLE_INCLUSION,
                    "version": 1,
                }));
                i += 1;
            }
            FENCE_RETURN_POINT => {
                breach = Some(json!([e7_to_deg(it.x), e7_to_deg(it.y), jnum(it.z)]));
                i += 1;
            }
            _ => i += 1,
        }
    }
    let mut fence = json!({"circles": circles, "polygons": polygons, "version": 2});
    if let (Some(b), Some(m)) = (breach, fence.as_object_mut()) {
        m.insert("breachReturn".into(), b);
    }
    let rally: Vec<Value> = plan
        .rally
        .iter()
        .map(|r| json!([e7_to_deg(r.x), e7_to_deg(r.y), jnum(r.z)]))
        .collect();
    let doc = json!({
        "fileType": "Plan",
        "geoFence": fence,
        "groundStation": "QGroundControl",
        "mission": {
            "cruiseSpeed": plan.cruise_speed,
            "firmwareType": plan.firmware_type,
            "globalPlanAltitudeMode": 1,
            "hoverSpeed": plan.hover_speed,
            "items": items,
            "plannedHomePosition": home,
            "vehicleType": plan.vehicle_type,
            "version": 2,
        },
        "rallyPoints": {"points": rally, "version": 2},
        "version": 1,
    });
    let mut s = serde_json::to_string_pretty(&doc).unwrap_or_default();
    s.push('\n');
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Trimmed from a plan saved by QGroundControl 4.3 (PX4 quad; survey flattened).
    const QGC: &str = r#"{
    "fileType": "Plan",
    "geoFence": {
        "circles": [
            { "circle": { "center": [47.3977, 8.5456], "radius": 25.5 }, "inclusion": false, "version": 1 }
        ],
        "polygons": [
            { "inclusion": true, "polygon": [[47.398, 8.544], [47.398, 8.547], [47.396, 8.547], [47.396, 8.544]], "version": 1 }
        ],
        "version": 2
    },
    "groundStation": "QGroundControl",
    "mission": {
        "cruiseSpeed": 15,
        "firmwareType": 12,
        "globalPlanAltitudeMode": 1,
        "hoverSpeed": 5,
        "items": [
            {
                "AMSLAltAboveTerrain": null, "Altitude": 15, "AltitudeMode": 1,
                "autoContinue": true, "command": 22, "doJumpId": 1, "frame": 3,
                "params": [0, 0, 0, null, 47.3977419, 8.5455938, 15],
                "type": "SimpleItem"
            },
            {
                "complexItemType": "survey",
                "TransectStyleComplexItem": {
                    "Items": [
                        { "autoContinue": true, "command": 16, "doJumpId": 2, "frame": 3,
                          "params": [0, 0, 0, null, 47.3978, 8.5449, 50], "type": "SimpleItem" },
                        { "autoContinue": true, "command": 206, "doJumpId": 3, "frame": 2,
                          "params": [25, 0, 1, 0, 0, 0, 0], "type": "SimpleItem" },
                        { "autoContinue": true, "command": 16, "doJumpId": 4, "frame": 3,
                          "params": [0, 0, 0, null, 47.3969, 8.5449, 50], "type": "SimpleItem" }
                    ]
                },
                "type": "ComplexItem",
                "version": 5
            },
            {
                "autoContinue": true, "command": 177, "doJumpId": 5, "frame": 2,
                "params": [2, 1, 0, 0, 0, 0, 0], "type": "SimpleItem"
            },
            {
                "autoContinue": true, "command": 20, "doJumpId": 6, "frame": 2,
                "params": [0, 0, 0, 0, 0, 0, 0], "type": "SimpleItem"
            }
        ],
        "plannedHomePosition": [47.3977419, 8.5455938, 487.967],
        "vehicleType": 2,
        "version": 2
    },
    "rallyPoints": { "points": [[47.3985, 8.5459, 30]], "version": 2 },
    "version": 1
}
"#;

    #[test]
    fn reads_qgroundcontrol_plans() {
        let p = parse_plan(QGC).unwrap();
        assert_eq!(p.firmware_type, 12);
        assert_eq!(p.home, Some((47.3977419, 8.5455938, 487.967)));
        assert_eq!(p.mission.len(), 6, "takeoff + 3 survey items + jump + RTL");
        assert_eq!(p.mission[0].command, 22);
        assert!(p.mission[0].param4.is_nan(), "null is NaN");
        assert_eq!(p.mission[0].x, 473_977_419);
        assert_eq!(p.mission[2].command, 206);
        assert_eq!(p.mission[4].command, cmd::DO_JUMP);
        assert_eq!(p.mission[4].param1, 1.0, "doJumpId 2 is user item 1");
        assert_eq!(p.fence.len(), 5, "4 vertices + 1 circle");
        assert_eq!(p.fence[0].param1, 4.0);
        assert_eq!(p.fence[4].command, FENCE_CIRCLE_EXCLUSION);
        assert_eq!(p.rally.len(), 1);
        assert_eq!(p.rally[0].z, 30.0);
    }

    #[test]
    fn round_trips() {
        let p = parse_plan(QGC).unwrap();
        let text = write_plan(&p);
        let q = parse_plan(&text).unwrap();
        assert_eq!(q.mission.len(), p.mission.len());
        for (a, b) in p.mission.iter().zip(&q.mission) {
            assert_eq!(
                (a.command, a.frame, a.x, a.y),
                (b.command, b.frame, b.x, b.y)
            );
            assert!(a.param4.is_nan() == b.param4.is_nan());
            assert_eq!(a.param1, b.param1);
            assert_eq!(a.z, b.z);
        }
        assert_eq!(q.fence, p.fence);
        assert_eq!(q.rally, p.rally);
        assert_eq!(q.home, p.home);
        let v: Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["mission"]["items"][4]["params"][0], json!(2.0));
        assert_eq!(v["mission"]["items"][0]["params"][3], Value::Null);
    }

    #[test]
    fn malformed_plans_name_the_line() {
        let bad_json = "{\n  \"fileType\": \"Plan\",\n  \"version\": 1,\n  \"mission\": {\n";
        let e = parse_plan(bad_json).unwrap_err();
        assert!(e.to_string().contains("line"), "{e}");
        let wrong_params =
            QGC.replacen("[0, 0, 0, null, 47.3977419, 8.5455938, 15]", "[0, 0, 0]", 1);
        let e = parse_plan(&wrong_params).unwrap_err();
        assert!(matches!(e, PlanError::Invalid { line: 19, .. }), "{e}");
        assert!(e.to_string().contains("length"), "{e}");
        let bad_jump = QGC.replacen(
            "\"params\": [2, 1, 0, 0, 0, 0, 0]",
            "\"params\": [42, 1, 0, 0, 0, 0, 0]",
            1,
        );
        let e = parse_plan(&bad_jump).unwrap_err();
        assert!(e.to_string().contains("doJumpId 42"), "{e}");
        let bad_lat = QGC.replacen("47.3977419, 8.5455938, 15", "97.3977419, 8.5455938, 15", 1);
        let e = parse_plan(&bad_lat).unwrap_err();
        assert!(e.to_string().contains("latitude 97"), "{e}");
        let not_plan = QGC.replacen("\"fileType\": \"Plan\"", "\"fileType\": \"Mission\"", 1);
        assert!(matches!(
            parse_plan(&not_plan),
            Err(PlanError::Invalid { line: 2, .. })
        ));
    }

    /// PX4's integration-test plans as MAVSDK reads them: `fw_mission.plan` has a
    /// `//` comment after an item's params and `multicopter_mission_geofence_avoid.plan` a
    /// top-level `"UUID"`; both were refused. Comments are skipped outside strings only, and
    /// an error after a comment still names its line.
    #[test]
    fn reads_comments_and_unknown_keys_as_mavsdk_does() {
        let with_comment = QGC.replacen(
            "[0, 0, 0, null, 47.3977419, 8.5455938, 15]",
            "[0, 0, 0, null, 47.3977419, 8.5455938, 15]  // radius 75, \"quoted\" */\n  /* a\n block */",
            1,
        );
        // (compared as written: the items hold NaN, which is never equal to itself)
        let written = |text: &str| parse_plan(text).map(|p| write_plan(&p));
        assert_eq!(written(&with_comment), written(QGC));
        let with_uuid = QGC.replacen(
            "\"fileType\": \"Plan\"",
            "\"UUID\": \"0123456789abcdef0123456789abcdef01234567\", \"fileType\": \"Plan\"",
            1,
        );
        assert_eq!(written(&with_uuid), written(QGC));
        // "//" inside a string is not a comment
        let url = QGC.replacen(
            "\"groundStation\": \"QGroundControl\"",
            "\"groundStation\": \"http://example.org/*x*/\"",
            1,
        );
        assert!(parse_plan(&url).is_ok());
        assert_eq!(blank_comments("\"a//b\" // c\n1"), "\"a//b\"     \n1");
        let bad_after_comment = format!("// header\n{}", &QGC[..40]);
        let e = parse_plan(&bad_after_comment).unwrap_err();
        assert!(e.to_string().contains("line"), "{e}");
    }

    /// Plans of the shape QGroundControl generates for its ArduCopter tests
    /// (`test/plans/*-ArduCopter.plan`: every altitude mode, item 6 "calculated above terrain"
    /// saved without an altitude, item 8 in the terrain frame), written for fleetmap around
    /// three homes (`tests/plans/`). Each is refused, naming item 6 and its altitude mode,
    /// before anything is uploaded.
    #[test]
    fn calculated_above_terrain_items_without_an_altitude_are_refused_by_number() {
        let plans = [
            include_str!("../../../../tests/plans/arducopter-mixed-altitudes-cmac.plan"),
            include_str!("../../../../tests/plans/arducopter-mixed-altitudes-zurich.plan"),
            include_str!("../../../../tests/plans/arducopter-mixed-altitudes-issaquah.plan"),
        ];
        for text in plans {
            let e = parse_plan(text).unwrap_err();
            let m = e.to_string();
            assert!(m.contains("mission item 6:"), "{m}");
            assert!(m.contains("calculated above terrain"), "{m}");
            assert!(m.contains("AltitudeMode 3"), "{m}");
            assert!(m.contains("NAV_WAYPOINT 60 m"), "{m}");
            // the line is item 6's
            let PlanError::Invalid { line, .. } = e else {
                panic!("{e:?}")
            };
            let item6 = text.find("\"doJumpId\": 6").unwrap();
            let item5 = text.find("\"doJumpId\": 5").unwrap();
            let line_of = |at: usize| text[..at].matches('\n').count() + 1;
            assert!(line > line_of(item5) && line <= line_of(item6), "{line}");
            // With the altitude QGroundControl computes once it has terrain, the plan loads:
            // item 6 is an AMSL waypoint and item 8 stays in the terrain frame.
            let fixed = text.replacen(
                "\"AltitudeMode\": 3,\n        \"AMSLAltAboveTerrain\": null,\n        \"params\": [\n          0,\n          0,\n          0,\n          null,",
                "\"AltitudeMode\": 3,\n        \"AMSLAltAboveTerrain\": 652,\n        \"params\": [\n          0,\n          0,\n          0,\n          null,",
                1,
            );
            let fixed = {
                let at = fixed.find("\"AMSLAltAboveTerrain\": 652").unwrap();
                let close = at + fixed[at..].find("null\n        ]").unwrap();
                format!("{}652{}", &fixed[..close], &fixed[close + 4..])
            };
            let p = parse_plan(&fixed).unwrap();
            assert_eq!(p.mission.len(), 11);
            assert_eq!((p.mission[5].frame, p.mission[5].z), (frame::GLOBAL, 652.0));
            assert_eq!(p.mission[7].frame, 10, "terrain frame");
        }
        // A complex item's inner item is numbered in the flattened list.
        let inner = QGC.replacen(
            "\"params\": [0, 0, 0, null, 47.3969, 8.5449, 50], \"type\": \"SimpleItem\"",
            "\"params\": [0, 0, 0, null, 47.3969, 8.5449, null], \"AltitudeMode\": 3, \"type\": \"SimpleItem\"",
            1,
        );
        let m = parse_plan(&inner).unwrap_err().to_string();
        assert!(m.contains("mission item 4 (in \"survey\")"), "{m}");
        // Ordinary plans (relative, absolute, terrain frame) still load.
        assert!(parse_plan(QGC).is_ok());
        assert!(parse_plan(&write_plan(&parse_plan(QGC).unwrap())).is_ok());
    }
}
