//! End-to-end tests of the mission grid (`fleetmap_core::geo`) and the `fleetmap grid` command.
//!
//! - Every row of `assets/golden/utm_pyproj.csv` (PROJ via pyproj, generated once by
//!   `scripts/gen_utm_golden.py`) is converted in both directions and must agree to 1 mm.
//! - The `utm` crate is measured against the same rows (its numbers are printed and recorded
//!   in docs/results/geo.md).
//! - cell → GPS → cell is exact (proptest), polygon coverage matches analytic areas and an
//!   independent polygon clipper, and the CLI rejects bad arguments with one line.

use fleetmap_core::geo::{Cell, GeoError, Grid, Hemisphere, LatLon, Utm, local, utm};
use proptest::prelude::*;
use std::collections::BTreeMap;

use crate::common;

/// Tolerance against PROJ, metres.
const TOL_M: f64 = 1e-3;

#[derive(Debug, Clone)]
struct Row {
    kind: String,
    p: LatLon,
    zone: u8,
    hemisphere: Hemisphere,
    standard: bool,
    easting: f64,
    northing: f64,
}

fn golden() -> Vec<Row> {
    let path = concat!(env!("CARGO_MANIFEST_DIR"), "/assets/golden/utm_pyproj.csv");
    let text = std::fs::read_to_string(path).expect("golden file assets/golden/utm_pyproj.csv");
    let mut rows = Vec::new();
    for (i, line) in text.lines().enumerate() {
        if line.starts_with('#') || line.starts_with("kind,") || line.is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f.len(), 8, "line {}: {line}", i + 1);
        let num = |s: &str| {
            s.parse::<f64>()
                .unwrap_or_else(|_| panic!("line {}: {s}", i + 1))
        };
        rows.push(Row {
            kind: f[0].to_string(),
            p: LatLon::new(num(f[1]), num(f[2])),
            zone: f[3].parse().unwrap(),
            hemisphere: f[4].parse().unwrap(),
            standard: f[5] == "1",
            easting: num(f[6]),
            northing: num(f[7]),
        });
    }
    assert!(rows.len() > 8000, "only {} golden rows", rows.len());
    rows
}

/// Metric distance between two nearby positions (tangent plane; exact to far better than a
/// micrometre at millimetre separations).
fn metres_between(a: LatLon, b: LatLon) -> f64 {
    local::distance(a.lat, a.lon, b.lat, b.lon)
}

#[derive(Default)]
struct MaxErr(BTreeMap<String, (f64, usize)>);

impl MaxErr {
    fn add(&mut self, kind: &str, err: f64) {
        let e = self.0.entry(kind.to_string()).or_insert((0.0, 0));
        e.0 = e.0.max(err);
        e.1 += 1;
    }
    fn max(&self) -> f64 {
        self.0.values().map(|v| v.0).fold(0.0, f64::max)
    }
    fn print(&self, title: &str) {
        println!("{title}: max {:.3e} m", self.max());
        for (k, (m, n)) in &self.0 {
            println!("  {k:18} {n:5} points, max {m:.3e} m");
        }
    }
}

#[test]
fn forward_matches_proj_within_1mm() {
    let mut errs = MaxErr::default();
    for r in golden() {
        let u =
            utm::to_utm_in_zone(r.p, r.zone, r.hemisphere).unwrap_or_else(|e| panic!("{r:?}: {e}"));
        let err = (u.easting - r.easting).hypot(u.northing - r.northing);
        assert!(err < TOL_M, "{r:?}: got {u:?}, error {err} m");
        errs.add(&r.kind, err);
        if r.standard && r.hemisphere == Hemisphere::of_lat(r.p.lat) {
            // The standard zone (with the Norway/Svalbard exceptions) picks the same frame.
            assert_eq!(utm::zone_for(r.p.lat, r.p.lon), Ok(r.zone), "{r:?}");
            assert_eq!(utm::to_utm(r.p), Ok(u));
        } else if !r.standard {
            assert_ne!(utm::zone_for(r.p.lat, r.p.lon), Ok(r.zone), "{r:?}");
        }
    }
    errs.print("fleetmap forward (lat/lon -> UTM) vs PROJ");
    assert!(errs.max() < 1e-6, "forward error should be nanometres");
}

#[test]
fn inverse_matches_proj_within_1mm() {
    let mut errs = MaxErr::default();
    for r in golden() {
        let u = Utm {
            easting: r.easting,
            northing: r.northing,
            zone: r.zone,
            hemisphere: r.hemisphere,
        };
        let p = utm::from_utm(&u).unwrap_or_else(|e| panic!("{r:?}: {e}"));
        let err = metres_between(p, r.p);
        assert!(err < TOL_M, "{r:?}: got {p:?}, error {err} m");
        errs.add(&r.kind, err);
    }
    errs.print("fleetmap inverse (UTM -> lat/lon) vs PROJ");
    assert!(errs.max() < 1e-6, "inverse error should be nanometres");
}

/// The `utm` crate (0.1.6) against the same reference values. It is in Cargo.toml, so a new
/// contributor would reach for it; these numbers are why geo::utm does not use it.
#[test]
fn utm_crate_against_proj() {
    let mut fwd = MaxErr::default();
    let mut inv = MaxErr::default();
    let (mut rejected, mut zone_disagree) = (0, 0);
    for r in golden() {
        if Hemisphere::of_lat(r.p.lat) != r.hemisphere {
            continue; // the crate picks the false northing from the latitude's sign
        }
        if r.standard && ::utm::lat_lon_to_zone_number(r.p.lat, r.p.lon) != r.zone {
            zone_disagree += 1;
        }
        // Give the crate the longitude unwrapped around the zone's central meridian (it does
        // not wrap across the antimeridian itself: 6.6e9 m errors otherwise).
        let cm = utm::central_meridian(r.zone);
        let lon = cm + (r.p.lon - cm + 180.0).rem_euclid(360.0) - 180.0;
        let (n, e, _) = ::utm::to_utm_wgs84(r.p.lat, lon, r.zone);
        fwd.add(&r.kind, (e - r.easting).hypot(n - r.northing));
        let letter = if r.hemisphere == Hemisphere::North {
            'N'
        } else {
            'M'
        };
        match ::utm::wsg84_utm_to_lat_lon(r.easting, r.northing, r.zone, letter) {
            Ok((lat, lon)) => {
                let lon = (lon + 180.0).rem_euclid(360.0) - 180.0;
                inv.add(&r.kind, metres_between(LatLon::new(lat, lon), r.p));
            }
            Err(_) => rejected += 1,
        }
    }
    fwd.print("utm crate forward vs PROJ");
    inv.print("utm crate inverse vs PROJ");
    println!(
        "utm crate: {rejected} points rejected by its inverse (easting/northing range checks), \
         {zone_disagree} standard zones differ"
    );
    // If the crate ever meets the 1 mm requirement this fails, and docs/results/geo.md should change.
    assert!(fwd.max() > TOL_M && inv.max() > TOL_M);
}

#[test]
fn outside_utm_is_a_clear_error() {
    for lat in [84.000_001, 85.0, 89.9, -80.000_001, -85.0] {
        let e = utm::to_utm(LatLon::new(lat, 10.0)).unwrap_err();
        assert_eq!(e, GeoError::OutsideUtm { lat });
        assert!(e.to_string().contains("outside UTM"), "{e}");
    }
    assert!(Grid::new(LatLon::new(-80.5, 0.0), 4.0).is_err());
    // A grid near 84°N: cells north of 84° exist as numbers but have no GPS position.
    let g = Grid::new(LatLon::new(83.9999, 10.0), 4.0).unwrap();
    assert!(g.checked_cell_center(Cell::new(0, 0)).is_ok());
    assert!(matches!(
        g.checked_cell_center(Cell::new(100, 0)),
        Err(GeoError::OutsideUtm { .. })
    ));
    assert!(!g.cell_in_domain(Cell::new(100, 0)));
}

/// A grid whose cells cover the given (east, north) rectangle stays in its zone: a point 3°
/// past the zone edge is converted in the forced zone and maps back to its cell.
#[test]
fn grid_reaching_into_the_next_zone() {
    // Origin 0.001° west of the 6°E edge between zones 31 and 32 at 40°N.
    let g = Grid::new(LatLon::new(40.0, 5.999), 5.0).unwrap();
    assert_eq!(g.zone(), 31);
    let p = LatLon::new(40.2, 9.0); // standard zone 32, 6° east of zone 31's meridian
    let c = g.cell_of(p).unwrap();
    assert!(c.col > 50_000, "{c}");
    let centre = g.cell_center(c);
    assert!(metres_between(centre, p) < 5.0 * std::f64::consts::SQRT_2 / 2.0 + 1e-6);
    assert_eq!(g.cell_of(centre), Ok(c));
    let u = g.cell_center_utm(c);
    assert_eq!((u.zone, u.hemisphere), (31, Hemisphere::North));
}

fn inside_point(g: &Grid, c: Cell, fx: f64, fy: f64) -> LatLon {
    let s = g.cell_size();
    g.from_xy((f64::from(c.col) + fx) * s, (f64::from(c.row) + fy) * s)
        .unwrap()
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 2000,
        // Integration tests have no lib.rs beside them to persist failures next to.
        failure_persistence: None,
        ..ProptestConfig::default()
    })]

    /// cell → GPS → cell is exact, for random origins (both hemispheres, Norway/Svalbard,
    /// near the limits), cell sizes and cells (negative indices included) whose centre is
    /// in the UTM domain; points well inside a cell map to it too.
    #[test]
    fn cell_gps_cell_round_trip(
        lat in -79.99f64..83.99,
        lon in -180.0f64..180.0,
        size in prop_oneof![0.01f64..1.0, 1.0f64..20.0, 20.0f64..2000.0],
        row in -5000i32..5000,
        col in -5000i32..5000,
        fx in -0.499f64..0.499,
        fy in -0.499f64..0.499,
    ) {
        let g = Grid::new(LatLon::new(lat, lon), size).unwrap();
        let c = Cell::new(row, col);
        prop_assume!(g.cell_in_domain(c));
        let p = g.cell_center(c);
        prop_assert_eq!(g.cell_of(p), Ok(c));
        prop_assert_eq!(g.cell_of_utm(&g.cell_center_utm(c)), c);
        // Through the standard frame of the point too (zone/hemisphere conversion).
        if let Ok(u) = utm::to_utm(p) {
            prop_assert_eq!(g.cell_of_utm(&u), c);
        }
        let q = inside_point(&g, c, fx, fy);
        prop_assert_eq!(g.cell_of(q), Ok(c));
        // The grid survives serialisation unchanged.
        let back: Grid = serde_json::from_str(&serde_json::to_string(&g).unwrap()).unwrap();
        prop_assert_eq!(back, g);
    }

    /// to_xy and from_xy are inverse to a nanometre.
    #[test]
    fn xy_round_trip(
        lat in -79.9f64..83.9,
        lon in -180.0f64..180.0,
        e in -20_000.0f64..20_000.0,
        n in -20_000.0f64..20_000.0,
    ) {
        let g = Grid::new(LatLon::new(lat, lon), 4.0).unwrap();
        let Ok(p) = g.from_xy(e, n) else { return Ok(()) };
        let (e2, n2) = g.to_xy(p).unwrap();
        prop_assert!((e2 - e).abs() < 1e-8 && (n2 - n).abs() < 1e-8, "{} {} vs {} {}", e, n, e2, n2);
    }
}

/// Area of `subject` inside the axis-aligned square [x0, x0+s] × [y0, y0+s], by
/// Sutherland–Hodgman clipping and the shoelace formula (independent of geo's boolean ops).
fn clipped_area(subject: &[(f64, f64)], x0: f64, y0: f64, s: f64) -> f64 {
    type Inside = fn(&(f64, f64), f64) -> bool;
    let mut poly: Vec<(f64, f64)> = subject.to_vec();
    let edges: [(Inside, f64, bool); 4] = [
        (|p, v| p.0 >= v, x0, true),
        (|p, v| p.0 <= v, x0 + s, true),
        (|p, v| p.1 >= v, y0, false),
        (|p, v| p.1 <= v, y0 + s, false),
    ];
    for (inside, v, vertical) in edges {
        let input = std::mem::take(&mut poly);
        if input.is_empty() {
            break;
        }
        let cross = |a: (f64, f64), b: (f64, f64)| {
            if vertical {
                let t = (v - a.0) / (b.0 - a.0);
                (v, a.1 + t * (b.1 - a.1))
            } else {
                let t = (v - a.1) / (b.1 - a.1);
                (a.0 + t * (b.0 - a.0), v)
            }
        };
        for i in 0..input.len() {
            let cur = input[i];
            let prev = input[(i + input.len() - 1) % input.len()];
            match (inside(&cur, v), inside(&prev, v)) {
                (true, true) => poly.push(cur),
                (true, false) => {
                    poly.push(cross(prev, cur));
                    poly.push(cur);
                }
                (false, true) => poly.push(cross(prev, cur)),
                (false, false) => {}
            }
        }
    }
    let n = poly.len();
    (0..n)
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            a.0 * b.1 - b.0 * a.1
        })
        .sum::<f64>()
        .abs()
        / 2.0
}

fn check_coverage(g: &Grid, xy: &[(f64, f64)], exact_area: f64) {
    let poly: Vec<LatLon> = xy.iter().map(|&(e, n)| g.from_xy(e, n).unwrap()).collect();
    let cov = g.polygon_coverage(&poly).unwrap();
    let s = g.cell_size();
    // Sorted, unique, fractions in (0, 1].
    assert!(cov.windows(2).all(|w| w[0].0 < w[1].0));
    assert!(cov.iter().all(|(_, f)| *f > 0.0 && *f <= 1.0));
    let total: f64 = cov.iter().map(|(_, f)| f * s * s).sum();
    assert!(
        (total - exact_area).abs() < 1e-6 * exact_area,
        "total {total} vs exact {exact_area}"
    );
    // Every cell of the bounding box: geo's answer equals the independent clipper's.
    let listed: BTreeMap<Cell, f64> = cov.iter().copied().collect();
    let (mut min_x, mut max_x, mut min_y, mut max_y) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in xy {
        min_x = min_x.min(x);
        max_x = max_x.max(x);
        min_y = min_y.min(y);
        max_y = max_y.max(y);
    }
    let idx = |v: f64| (v / s + 0.5).floor() as i32;
    for row in idx(min_y) - 1..=idx(max_y) + 1 {
        for col in idx(min_x) - 1..=idx(max_x) + 1 {
            let a = clipped_area(
                xy,
                (f64::from(col) - 0.5) * s,
                (f64::from(row) - 0.5) * s,
                s,
            ) / (s * s);
            let got = listed.get(&Cell::new(row, col)).copied().unwrap_or(0.0);
            assert!(
                (got - a).abs() < 1e-6,
                "cell ({row}, {col}): geo {got}, clipper {a}"
            );
        }
    }
}

fn rotated_rect(cx: f64, cy: f64, len: f64, width: f64, angle_deg: f64) -> Vec<(f64, f64)> {
    let (s, c) = angle_deg.to_radians().sin_cos();
    [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
        .iter()
        .map(|&(u, v)| {
            let (x, y) = (u * len, v * width);
            (cx + x * c - y * s, cy + x * s + y * c)
        })
        .collect()
}

#[test]
fn coverage_of_a_rotated_rectangle() {
    // 37 m × 13 m rotated 30°, exact area 481 m², on 4 m cells (southern hemisphere).
    let g = Grid::new(LatLon::new(-33.8688, 151.2093), 4.0).unwrap();
    check_coverage(&g, &rotated_rect(5.3, 7.1, 37.0, 13.0, 30.0), 481.0);
    // The same rectangle clockwise.
    let mut cw = rotated_rect(5.3, 7.1, 37.0, 13.0, 30.0);
    cw.reverse();
    check_coverage(&g, &cw, 481.0);
}

#[test]
fn coverage_across_negative_indices() {
    // Centred south-west of the origin so that rows and columns span negative indices, on
    // a grid at a zone edge in Norway (32V) with 2.5 m cells.
    let g = Grid::new(LatLon::new(60.5, 3.0005), 2.5).unwrap();
    assert_eq!(g.zone(), 32);
    let rect = rotated_rect(-6.0, -9.0, 21.0, 8.0, -58.0);
    check_coverage(&g, &rect, 168.0);
    let poly: Vec<LatLon> = rect
        .iter()
        .map(|&(e, n)| g.from_xy(e, n).unwrap())
        .collect();
    let cov = g.polygon_coverage(&poly).unwrap();
    assert!(cov.iter().any(|(c, _)| c.row < 0 && c.col < 0));
    assert!(cov.iter().any(|(c, _)| c.row >= 0 || c.col >= 0));
    // A concave L-shape: 12×12 minus the 6×6 north-east quarter = 108 m².
    let l = [
        (-10.0, -10.0),
        (2.0, -10.0),
        (2.0, -4.0),
        (-4.0, -4.0),
        (-4.0, 2.0),
        (-10.0, 2.0),
    ];
    check_coverage(&g, &l, 108.0);
}

/// The runway of the field test (docs/fixtures.md: 92 m × 21 m, centre (37.1968, −80.5781),
/// long axis at 58°) given in GPS coordinates: the covered grid area is the ground area
/// times the UTM scale squared.
#[test]
fn coverage_of_the_runway_in_gps_coordinates() {
    let centre = LatLon::new(37.196_8, -80.578_1);
    let (h_sin, h_cos) = 58f64.to_radians().sin_cos();
    let corners: Vec<LatLon> = [(-46.0, -10.5), (46.0, -10.5), (46.0, 10.5), (-46.0, 10.5)]
        .iter()
        .map(|&(along, across)| {
            // along the heading (clockwise from north), across to its right
            let north = along * h_cos - across * h_sin;
            let east = along * h_sin + across * h_cos;
            let (lat, lon) = local::offset(centre.lat, centre.lon, north, east);
            LatLon::new(lat, lon)
        })
        .collect();
    let home = local::offset(centre.lat, centre.lon, -32.0, -18.0);
    let g = Grid::new(LatLon::new(home.0, home.1), 4.0).unwrap();
    let cov = g.polygon_coverage(&corners).unwrap();
    let (_gamma, k) = g.convergence_and_scale(centre).unwrap();
    let total: f64 = cov.iter().map(|(_, f)| f * 16.0).sum();
    let expect = 92.0 * 21.0 * k * k;
    assert!((total - expect).abs() < 0.01, "{total} vs {expect}");
    let full = cov.iter().filter(|(_, f)| *f > 0.999_999).count();
    assert!(
        full > 80 && cov.len() > full,
        "{} cells, {full} full",
        cov.len()
    );
}

// ---------------------------------------------------------------------------------------
// The command line.

fn json(s: &str) -> serde_json::Value {
    serde_json::from_str(s.trim()).unwrap_or_else(|e| panic!("not JSON ({e}): {s}"))
}

#[test]
fn cli_to_gps_and_from_gps() {
    let (code, out, err) = common::fleetmap().run(&[
        "grid",
        "--origin",
        "-33.8688,151.2093",
        "--cell-size",
        "4",
        "to-gps",
        "-3",
        "-7",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(out.lines().count(), 1, "{out}");
    let v = json(&out);
    let keys: Vec<&str> = v.as_object().unwrap().keys().map(String::as_str).collect();
    let mut expect = vec![
        "row",
        "col",
        "lat",
        "lon",
        "easting",
        "northing",
        "zone",
        "hemisphere",
    ];
    expect.sort();
    let mut keys_sorted = keys.clone();
    keys_sorted.sort();
    assert_eq!(keys_sorted, expect);
    assert_eq!((v["row"].as_i64(), v["col"].as_i64()), (Some(-3), Some(-7)));
    assert_eq!(v["zone"], 56);
    assert_eq!(v["hemisphere"], "S");
    let g = Grid::new(LatLon::new(-33.8688, 151.2093), 4.0).unwrap();
    let c = g.cell_center(Cell::new(-3, -7));
    assert_eq!(v["lat"].as_f64(), Some(c.lat));
    assert_eq!(v["lon"].as_f64(), Some(c.lon));
    let u = g.cell_center_utm(Cell::new(-3, -7));
    assert_eq!(v["easting"].as_f64(), Some(u.easting));
    assert_eq!(v["northing"].as_f64(), Some(u.northing));

    // from-gps of a point inside that cell prints the same cell and centre.
    let inside = inside_point(&g, Cell::new(-3, -7), 0.3, -0.4);
    let (lat, lon) = (inside.lat.to_string(), inside.lon.to_string());
    let (code, out2, err) = common::fleetmap().run(&[
        "grid",
        "--origin",
        "-33.8688,151.2093",
        "--cell-size",
        "4",
        "from-gps",
        &lat,
        &lon,
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(json(&out2), v);

    // --origin=… and a forced zone.
    let (code, out, err) = common::fleetmap().run(&[
        "grid",
        "--origin=-33.8688,151.2093",
        "--cell-size",
        "4",
        "--zone",
        "55S",
        "to-gps",
        "0",
        "0",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(json(&out)["zone"], 55);
}

#[test]
fn cli_export_geojson() {
    let (code, out, err) = common::fleetmap().run(&[
        "grid",
        "--origin",
        "37.1968,-80.5781",
        "--cell-size",
        "4",
        "export",
        "--rows",
        "-1:1",
        "--cols",
        "-2:0",
    ]);
    assert_eq!(code, 0, "{err}");
    let v = json(&out);
    assert_eq!(v["type"], "FeatureCollection");
    let f = v["features"].as_array().unwrap();
    assert_eq!(f.len(), 9);
    assert_eq!(
        f[0]["properties"],
        serde_json::json!({"row": -1, "col": -2})
    );
}

#[test]
fn cli_bad_arguments_fail_with_one_line() {
    let o = "37.1968,-80.5781";
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["--origin", "95,10", "--cell-size", "4", "to-gps", "0", "0"],
            "latitude 95",
        ),
        (
            vec!["--origin", "85,10", "--cell-size", "4", "to-gps", "0", "0"],
            "outside UTM",
        ),
        (
            vec!["--origin", "10,200", "--cell-size", "4", "to-gps", "0", "0"],
            "longitude 200",
        ),
        (
            vec!["--origin", o, "--cell-size", "0", "to-gps", "0", "0"],
            "greater than 0",
        ),
        (
            vec!["--origin", o, "--cell-size", "-4", "to-gps", "0", "0"],
            "greater than 0",
        ),
        (
            vec!["--origin", o, "--cell-size", "NaN", "to-gps", "0", "0"],
            "finite",
        ),
        (
            vec!["--origin", "NaN,3", "--cell-size", "4", "to-gps", "0", "0"],
            "finite",
        ),
        (
            vec!["--origin", o, "--cell-size", "four", "to-gps", "0", "0"],
            "not a number",
        ),
        (
            vec![
                "--origin",
                "north,west",
                "--cell-size",
                "4",
                "to-gps",
                "0",
                "0",
            ],
            "LAT,LON",
        ),
        (
            vec!["--origin", "37.1", "--cell-size", "4", "to-gps", "0", "0"],
            "LAT,LON",
        ),
        (
            vec!["--origin", o, "--cell-size", "4", "to-gps", "abc", "0"],
            "row \"abc\"",
        ),
        (
            vec!["--origin", o, "--cell-size", "4", "to-gps", "1.5", "0"],
            "not an integer",
        ),
        (
            vec!["--origin", o, "--cell-size", "4", "to-gps", "0"],
            "missing COL",
        ),
        (
            vec!["--origin", o, "--cell-size", "4", "to-gps"],
            "missing ROW",
        ),
        (
            vec!["--cell-size", "4", "to-gps", "0", "0"],
            "missing --origin",
        ),
        (
            vec!["--origin", o, "to-gps", "0", "0"],
            "missing --cell-size",
        ),
        (vec!["--origin", o, "--cell-size", "4"], "missing action"),
        (
            vec!["--origin", o, "--cell-size", "4", "from-gps", "95", "10"],
            "latitude 95",
        ),
        (
            vec!["--origin", o, "--cell-size", "4", "from-gps", "NaN", "10"],
            "finite",
        ),
        (
            vec![
                "--origin",
                o,
                "--cell-size",
                "4",
                "from-gps",
                "37.2",
                "text",
            ],
            "not a number",
        ),
        (
            vec!["--origin", o, "--cell-size", "4", "from-gps", "37.2"],
            "missing LON",
        ),
        // 2° of longitude east of zone 17's edge is fine; 40° is not.
        (
            vec!["--origin", o, "--cell-size", "4", "from-gps", "37.2", "-40"],
            "central meridian",
        ),
        (
            vec![
                "--origin",
                o,
                "--cell-size",
                "4",
                "--zone",
                "61",
                "to-gps",
                "0",
                "0",
            ],
            "zone",
        ),
        (
            vec![
                "--origin",
                o,
                "--cell-size",
                "4",
                "to-gps",
                "0",
                "100000000",
            ],
            "no GPS position",
        ),
        (
            vec![
                "--origin",
                o,
                "--cell-size",
                "4",
                "export",
                "--rows",
                "3:1",
                "--cols",
                "0:0",
            ],
            "FIRST",
        ),
    ];
    for (args, needle) in cases {
        let mut full = vec!["grid"];
        full.extend(&args);
        let (code, out, err) = common::fleetmap().run(&full);
        assert_eq!(code, 1, "{args:?} should fail: stdout {out} stderr {err}");
        assert!(out.is_empty(), "{args:?}: {out}");
        assert_eq!(err.lines().count(), 1, "{args:?}: not one line: {err}");
        assert!(err.starts_with("fleetmap: "), "{args:?}: {err}");
        assert!(err.contains(needle), "{args:?}: {err:?} lacks {needle:?}");
    }
    // A point 2° into zone 18 is converted in the grid's zone 17.
    let (code, out, err) = common::fleetmap().run(&[
        "grid",
        "--origin",
        o,
        "--cell-size",
        "4",
        "from-gps",
        "37.2",
        "-76.0",
    ]);
    assert_eq!(code, 0, "{err}");
    assert_eq!(json(&out)["zone"], 17);
}
