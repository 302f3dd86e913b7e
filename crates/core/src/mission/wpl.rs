//! QGC WPL 110 (`.waypoints`): the text mission format of Mission Planner, MAVProxy
//! (`wp save`) and QGroundControl's text import/export.
//!
//! ```text
//! QGC WPL 110 (fields separated by tabs)
//! 0  1  0  16  0  0  0  0  -35.363262  149.165237  584.090000  1
//! 1  0  3  22  0  0  0  0  0  0  20  1
//! ```
//!
//! One item per line, whitespace (tab) separated: INDEX, CURRENT, FRAME, COMMAND, PARAM1–4,
//! PARAM5/X/LATITUDE, PARAM6/Y/LONGITUDE, PARAM7/Z/ALTITUDE, AUTOCONTINUE — as
//! QGroundControl reads them (`mavlink/qgroundcontrol` `src/MissionManager/MissionItem.cc`
//! `MissionItem::load(QTextStream&)` splits on whitespace and needs 12 fields).
//!
//! Version 110 files start with the home position as line 0 (Mission Planner writes the
//! vehicle's home there; QGroundControl `MissionController::_loadTextMissionFile`: "ArduPilot
//! file, planned home position is already in position 0"); version 120 files (old QGC) have
//! no home line. The home line is returned separately and never becomes a user item. In
//! these files DO_JUMP targets count the home line (the ArduPilot numbering), so they are
//! shifted by one to our user numbering on read and back on write.
//!
//! Latitudes and longitudes are written with 8 decimals (the wire's 1e-7 degrees survive a
//! round trip exactly); other numbers in their shortest exact form.

use super::item::{MissionItem, cmd, deg_to_e7};
use crate::mission::wire::is_global_frame;

/// A malformed `.waypoints` file.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("line {line}: {message}")]
pub struct WplError {
    /// 1-based line number.
    pub line: usize,
    /// What is wrong.
    pub message: String,
}

/// The content of a `.waypoints` file.
#[derive(Clone, Debug, PartialEq)]
pub struct WplFile {
    /// The home line (version 110), if present.
    pub home: Option<MissionItem>,
    /// The items, user numbering (no home).
    pub items: Vec<MissionItem>,
    /// What was read differently from what the file says (items renumbered), for the user.
    pub warnings: Vec<String>,
}

fn err(line: usize, message: impl Into<String>) -> WplError {
    WplError {
        line,
        message: message.into(),
    }
}

/// Parse a `.waypoints` file.
pub fn parse_wpl(text: &str) -> Result<WplFile, WplError> {
    let mut lines = text.lines().enumerate();
    let (_, header) = lines
        .next()
        .ok_or_else(|| err(1, "empty file (expected \"QGC WPL 110\")"))?;
    let header = header.trim_start_matches('\u{feff}').trim();
    let words: Vec<&str> = header.split_whitespace().collect();
    let with_home = match words.as_slice() {
        ["QGC", "WPL", "110"] => true,
        ["QGC", "WPL", "120"] => false,
        [lat, lon] if lat.parse::<f64>().is_ok() && lon.parse::<f64>().is_ok() => {
            // MAVProxy's fence point list (`fence load`, the `fence-*.txt` files of
            // ArduPilot's Tools/autotest): one "latitude longitude" pair a line, the first
            // the return point. A geofence, not a mission: say so rather than only that the
            // header is missing.
            return Err(err(
                1,
                format!(
                    "expected \"QGC WPL 110\" (or 120), found {header:?}: a list of \
                     \"latitude longitude\" points (a MAVProxy fence point file), not a mission"
                ),
            ));
        }
        _ => {
            return Err(err(
                1,
                format!("expected \"QGC WPL 110\" (or 120), found {header:?}"),
            ));
        }
    };
    let mut all = Vec::new();
    // (line, index in the file, index given)
    let mut renumbered: Vec<(usize, usize, usize)> = Vec::new();
    for (i, line) in lines {
        let n = i + 1;
        let line = line.trim();
        if line.is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split_whitespace().collect();
        if f.len() < 12 {
            return Err(err(
                n,
                format!(
                    "expected 12 fields (INDEX CURRENT FRAME COMMAND P1 P2 P3 P4 X Y Z AUTOCONTINUE), found {}",
                    f.len()
                ),
            ));
        }
        let int = |k: usize, what: &str, max: u64| -> Result<u64, WplError> {
            let v: u64 = f[k].parse().map_err(|_| {
                err(
                    n,
                    format!(
                        "field {} ({what}) must be a whole number, found {:?}",
                        k + 1,
                        f[k]
                    ),
                )
            })?;
            if v > max {
                return Err(err(
                    n,
                    format!("field {} ({what}) is {v}, more than {max}", k + 1),
                ));
            }
            Ok(v)
        };
        let num = |k: usize, what: &str| -> Result<f64, WplError> {
            let s = f[k];
            if s.eq_ignore_ascii_case("nan") {
                return Ok(f64::NAN);
            }
            s.parse::<f64>().map_err(|_| {
                err(
                    n,
                    format!("field {} ({what}) must be a number, found {s:?}", k + 1),
                )
            })
        };
        let index = int(0, "index", u64::from(u16::MAX))? as usize;
        if index != all.len() {
            // Gaps and repeats are taken in file order, as pymavlink's loader does
            // (`MAVWPLoader.add` numbers each item by its position), so MAVProxy and
            // ArduPilot's own test suite fly such files (ArduCopter's weathervane mission
            // is numbered 0, 1, 2, 4, 12).
            renumbered.push((n, index, all.len()));
        }
        let current = int(1, "current", 1)? == 1;
        let frame = int(2, "frame", 255)? as u8;
        let command = int(3, "command", u64::from(u16::MAX))? as u16;
        let p: Vec<f64> = (4..11)
            .map(|k| {
                num(
                    k,
                    [
                        "param1",
                        "param2",
                        "param3",
                        "param4",
                        "x/latitude",
                        "y/longitude",
                        "z/altitude",
                    ][k - 4],
                )
            })
            .collect::<Result<_, _>>()?;
        let autocontinue = int(11, "autocontinue", 1)? == 1;
        let (x, y) = if is_global_frame(frame) {
            for (v, what, lim) in [(p[4], "latitude", 90.0), (p[5], "longitude", 180.0)] {
                if !(v.is_finite() && v.abs() <= lim) {
                    return Err(err(n, format!("{what} {v} is out of range (±{lim}°)")));
                }
            }
            (deg_to_e7(p[4]), deg_to_e7(p[5]))
        } else {
            let as_int = |v: f64, what: &str| -> Result<i32, WplError> {
                if v.is_nan() {
                    return Ok(0);
                }
                if !(v.is_finite() && v.abs() < 2.1e9) {
                    return Err(err(n, format!("{what} {v} does not fit the mission item")));
                }
                Ok(v.round() as i32)
            };
            (as_int(p[4], "param5")?, as_int(p[5], "param6")?)
        };
        all.push(MissionItem {
            frame,
            command,
            current,
            autocontinue,
            param1: p[0] as f32,
            param2: p[1] as f32,
            param3: p[2] as f32,
            param4: p[3] as f32,
            x,
            y,
            z: p[6] as f32,
        });
    }
    let home = if with_home && !all.is_empty() {
        Some(all.remove(0))
    } else {
        None
    };
    if with_home {
        for it in &mut all {
            if it.command == cmd::DO_JUMP {
                it.param1 -= 1.0;
            }
        }
    }
    let warnings = match renumbered.as_slice() {
        [] => Vec::new(),
        [(line, was, is), rest @ ..] => vec![format!(
            "items renumbered in file order: line {line} is numbered {was}, read as item {is}{} \
             (as pymavlink and MAVProxy read it; DO_JUMP targets are taken as written)",
            if rest.is_empty() {
                String::new()
            } else {
                format!(", and {} more line(s)", rest.len())
            }
        )],
    };
    Ok(WplFile {
        home,
        items: all,
        warnings,
    })
}

fn num(v: f32) -> String {
    if v.is_nan() {
        return "nan".into();
    }
    if v == v.trunc() && v.abs() < 1e9 {
        return format!("{}", v as i64);
    }
    format!("{v}")
}

/// Write a version 110 file: `home` (or an all-zero placeholder) as line 0, then `items`
/// (user numbering; DO_JUMP targets shifted for the home line).
pub fn write_wpl(home: Option<&MissionItem>, items: &[MissionItem]) -> String {
    let placeholder = crate::mission::wire::home_placeholder();
    let home = home.copied().unwrap_or(placeholder);
    let mut out = String::from("QGC WPL 110\n");
    let mut all = vec![home];
    all.extend(items.iter().map(|it| {
        let mut it = *it;
        if it.command == cmd::DO_JUMP {
            it.param1 += 1.0;
        }
        it
    }));
    for (i, it) in all.iter().enumerate() {
        let (x, y) = if is_global_frame(it.frame) {
            (
                format!("{:.8}", f64::from(it.x) / 1e7),
                format!("{:.8}", f64::from(it.y) / 1e7),
            )
        } else {
            (it.x.to_string(), it.y.to_string())
        };
        out.push_str(&format!(
            "{i}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{x}\t{y}\t{}\t{}\n",
            u8::from(i == 0),
            it.frame,
            it.command,
            num(it.param1),
            num(it.param2),
            num(it.param3),
            num(it.param4),
            num(it.z),
            u8::from(it.autocontinue),
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A file as Mission Planner writes it for ArduCopter SITL (home, takeoff, waypoints,
    /// a DO_JUMP back to the first waypoint, RTL).
    const MP: &str = "QGC WPL 110\r
0\t1\t0\t16\t0\t0\t0\t0\t-35.363262\t149.165237\t584.090000\t1\r
1\t0\t3\t22\t0.000000\t0.000000\t0.000000\t0.000000\t0.000000\t0.000000\t20.000000\t1\r
2\t0\t3\t16\t0.000000\t0.000000\t0.000000\t0.000000\t-35.36198800\t149.16375300\t20.000000\t1\r
3\t0\t3\t16\t2.000000\t0.000000\t0.000000\t0.000000\t-35.36210000\t149.16500000\t25.500000\t1\r
4\t0\t3\t177\t2.000000\t3.000000\t0.000000\t0.000000\t0.000000\t0.000000\t0.000000\t1\r
5\t0\t3\t20\t0.000000\t0.000000\t0.000000\t0.000000\t0.000000\t0.000000\t0.000000\t1\r
";

    #[test]
    fn reads_mission_planner_files() {
        let f = parse_wpl(MP).unwrap();
        let home = f.home.unwrap();
        assert_eq!(
            (home.x, home.y, home.z),
            (-353_632_620, 1_491_652_370, 584.09)
        );
        assert_eq!(f.items.len(), 5);
        assert_eq!(f.items[0].command, cmd::NAV_TAKEOFF);
        assert_eq!(f.items[1].x, -353_619_880);
        assert_eq!(f.items[2].param1, 2.0);
        assert_eq!(f.items[3].command, cmd::DO_JUMP);
        assert_eq!(f.items[3].param1, 1.0, "jump to user item 1 (file line 2)");
        assert!(!f.items[0].current);
    }

    #[test]
    fn round_trips_exactly() {
        let f = parse_wpl(MP).unwrap();
        let text = write_wpl(f.home.as_ref(), &f.items);
        assert!(text.starts_with("QGC WPL 110\n0\t1\t0\t16\t"));
        let g = parse_wpl(&text).unwrap();
        assert_eq!(g.items, f.items);
        assert_eq!(g.home, f.home);
        // And with an item in a non-global frame carrying param5.
        let mut d = MissionItem::command(203);
        d.x = 1;
        let text = write_wpl(None, &[d]);
        assert_eq!(parse_wpl(&text).unwrap().items, vec![d]);
    }

    /// ArduPilot's `Tools/autotest/ArduCopter_Tests/Weathervane/weathervane_mission.txt` is
    /// numbered 0, 1, 2, 4, 12, with tabs and spaces mixed; pymavlink renumbers it in file order.
    #[test]
    fn gaps_in_the_numbering_are_renumbered_in_file_order_with_a_warning() {
        let text = "QGC WPL 110\n\
            0\t1\t0\t16\t0\t0\t0\t0\t-35.36\t149.16\t584\t1\n\
            1 0 3\t22 0 0 0 0 0 0 10 1\n\
            2\t0\t3\t16\t0\t0\t0\t0\t-35.361\t149.16\t10\t1\n\
            4\t0\t3\t16 0 0 0 0 -35.362 149.16 10 1\n\
            12\t0\t3\t20\t0\t0\t0\t0\t0\t0\t0\t1\n";
        let f = parse_wpl(text).unwrap();
        let cmds: Vec<u16> = f.items.iter().map(|i| i.command).collect();
        assert_eq!(cmds, vec![22, 16, 16, 20]);
        assert_eq!(f.items[2].x, -353_620_000);
        assert_eq!(f.warnings.len(), 1, "{:?}", f.warnings);
        assert!(
            f.warnings[0].contains("line 5 is numbered 4, read as item 3, and 1 more line"),
            "{:?}",
            f.warnings
        );
        // a file numbered in order says nothing
        assert!(parse_wpl(MP).unwrap().warnings.is_empty());
        // a repeated number too
        let rep = "QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n1 0 3 16 0 0 0 0 0 0 5 1\n1 0 3 16 0 0 0 0 0 0 6 1\n";
        let f = parse_wpl(rep).unwrap();
        assert_eq!(f.items.len(), 2);
        assert_eq!(f.items[1].z, 6.0);
        assert!(f.warnings[0].contains("line 4 is numbered 1, read as item 2"));
    }

    #[test]
    fn version_120_has_no_home() {
        let f = parse_wpl("QGC WPL 120\n0 1 3 16 0 0 0 0 1.5 2.5 10 1\n").unwrap();
        assert!(f.home.is_none());
        assert_eq!(f.items.len(), 1);
        assert_eq!(f.items[0].x, 15_000_000);
    }

    #[test]
    fn malformed_input_is_rejected_with_line_numbers() {
        let cases = [
            ("", 1, "empty"),
            ("QGC WPL 999\n", 1, "expected \"QGC WPL 110\""),
            ("QGC WPL 110\n0\t1\t0\t16\t0\n", 2, "expected 12 fields"),
            (
                "QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n1 0 3 16 0 0 0 0 95.0 0 0 1\n",
                3,
                "latitude 95",
            ),
            (
                "QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n1 0 3 sixteen 0 0 0 0 0 0 0 1\n",
                3,
                "command",
            ),
            (
                "QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n\n1 0 3 16 x 0 0 0 0 0 0 1\n",
                4,
                "param1",
            ),
            (
                "QGC WPL 110\n0 1 0 16 0 0 0 0 0 0 0 1\n1 0 3 16 0 0 0 0 0 0 0 7\n",
                3,
                "autocontinue",
            ),
        ];
        for (text, line, what) in cases {
            let e = parse_wpl(text).unwrap_err();
            assert_eq!(e.line, line, "{text:?}: {e}");
            assert!(e.to_string().contains(what), "{e}");
        }
    }

    /// A MAVProxy fence point list shaped like ArduPilot's
    /// `Tools/autotest/Generic_Missions/fence-in-middle-of-nowhere.txt` (one tab-separated
    /// "latitude longitude" pair a line): refused as a mission, and the message says what the
    /// file is instead.
    #[test]
    fn a_fence_point_list_is_named_as_such() {
        let text = "-35.361359\t149.162872\n-35.3608\t149.1620\n-35.3620\t149.1620\n";
        let e = parse_wpl(text).unwrap_err();
        assert_eq!(e.line, 1);
        assert!(e.to_string().contains("a MAVProxy fence point file"), "{e}");
        // a header that is not two numbers keeps the plain message
        let e = parse_wpl("hello world\n").unwrap_err();
        assert!(!e.to_string().contains("fence"), "{e}");
    }
}
