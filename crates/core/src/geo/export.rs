//! Cells and polygons → GeoJSON and KML, for run outputs (runway paper Fig. 11: the mapped
//! cells over the runway in Google Earth) and for QGIS.
//!
//! GeoJSON follows RFC 7946: a `FeatureCollection` of `Polygon` features, positions
//! `[lon, lat]` in WGS84 degrees, exterior rings closed and counter-clockwise. Each cell is
//! drawn as its four UTM corners (`Grid::cell_corners`); for cells of a few metres the
//! straight lon/lat edges differ from the UTM square by far less than a millimetre.
//!
//! KML follows OGC KML 2.2 as read by Google Earth and QGIS: one `Style` per distinct
//! colour, one `Placemark` per cell with its row and column in `ExtendedData`, and the
//! extra polygons drawn as outlines. Colours are KML's `aabbggrr` hex (see [`kml_colour`]).

use super::{Cell, Grid, LatLon};
use serde_json::{Map, Value, json};
use std::collections::BTreeSet;
use std::fmt::Write as _;

/// Colour for invalid KML colour strings: opaque white.
pub(crate) const KML_FALLBACK_COLOUR: &str = "ffffffff";

/// A KML colour string `aabbggrr` from red, green, blue and alpha (0–255).
pub fn kml_colour(r: u8, g: u8, b: u8, a: u8) -> String {
    format!("{a:02x}{b:02x}{g:02x}{r:02x}")
}

/// `c` lower-cased if it is 8 hex digits, else [`KML_FALLBACK_COLOUR`].
fn clean_colour(c: &str) -> String {
    if c.len() == 8 && c.bytes().all(|b| b.is_ascii_hexdigit()) {
        c.to_ascii_lowercase()
    } else {
        KML_FALLBACK_COLOUR.to_string()
    }
}

/// Twice the signed area of a lon/lat ring (positive = counter-clockwise).
fn signed_area2(ring: &[LatLon]) -> f64 {
    let n = ring.len();
    (0..n)
        .map(|i| {
            let (a, b) = (ring[i], ring[(i + 1) % n]);
            a.lon * b.lat - b.lon * a.lat
        })
        .sum()
}

/// The ring without a repeated closing vertex, counter-clockwise, or `None` when it has
/// fewer than 3 vertices or a non-finite coordinate.
fn normalise_ring(ring: &[LatLon]) -> Option<Vec<LatLon>> {
    let mut r: Vec<LatLon> = ring.to_vec();
    if r.len() > 1 && r.first() == r.last() {
        r.pop();
    }
    if r.len() < 3 || r.iter().any(|p| !p.lat.is_finite() || !p.lon.is_finite()) {
        return None;
    }
    if signed_area2(&r) < 0.0 {
        r.reverse();
    }
    Some(r)
}

fn geojson_ring(ring: &[LatLon]) -> Value {
    let mut coords: Vec<Value> = ring.iter().map(|p| json!([p.lon, p.lat])).collect();
    if let Some(first) = ring.first() {
        coords.push(json!([first.lon, first.lat]));
    }
    Value::Array(coords)
}

fn polygon_feature(ring: &[LatLon], properties: Map<String, Value>) -> Value {
    json!({
        "type": "Feature",
        "geometry": { "type": "Polygon", "coordinates": [geojson_ring(ring)] },
        "properties": Value::Object(properties),
    })
}

/// `properties` as an object: objects as they are, `null` as `{}`, anything else as
/// `{"value": properties}`.
fn as_object(properties: &Value) -> Map<String, Value> {
    match properties {
        Value::Object(m) => m.clone(),
        Value::Null => Map::new(),
        other => {
            let mut m = Map::new();
            m.insert("value".to_string(), other.clone());
            m
        }
    }
}

/// A GeoJSON `FeatureCollection`: one square `Polygon` per cell (its corners from
/// `Grid::cell_corners`) whose properties are the given ones plus `"row"` and `"col"`
/// (these two always reflect the cell), then one `Polygon` per extra polygon (e.g. the ground
/// truth) with its properties (non-object properties are wrapped as `{"value": …}`).
/// Extra polygons with fewer than 3 vertices or non-finite coordinates are left out and
/// counted in the collection's `"skipped_polygons"` member (present only when non-zero).
/// The collection also carries a `"grid"` member (origin, cell size, zone, hemisphere).
pub fn cells_geojson(
    grid: &Grid,
    cells: &[(Cell, Value)],
    extra_polygons: &[(Vec<LatLon>, Value)],
) -> Value {
    let mut features = Vec::with_capacity(cells.len() + extra_polygons.len());
    for (cell, props) in cells {
        let mut p = as_object(props);
        p.insert("row".to_string(), json!(cell.row));
        p.insert("col".to_string(), json!(cell.col));
        features.push(polygon_feature(&grid.cell_corners(*cell), p));
    }
    let mut skipped = 0usize;
    for (ring, props) in extra_polygons {
        match normalise_ring(ring) {
            Some(r) => features.push(polygon_feature(&r, as_object(props))),
            None => skipped += 1,
        }
    }
    let mut fc = json!({
        "type": "FeatureCollection",
        "grid": grid,
        "features": features,
    });
    if skipped > 0 {
        fc["skipped_polygons"] = json!(skipped);
    }
    fc
}

/// XML-escape text for element content and attribute values.
fn xml_escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for ch in s.chars() {
        match ch {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&apos;"),
            // Control characters other than tab/newline are not allowed in XML 1.0.
            c if (c as u32) < 0x20 && c != '\t' && c != '\n' && c != '\r' => out.push(' '),
            c => out.push(c),
        }
    }
    out
}

fn kml_coordinates(ring: &[LatLon]) -> String {
    let mut s = String::new();
    for p in ring.iter().chain(ring.first()) {
        let _ = write!(s, "{},{},0 ", p.lon, p.lat);
    }
    s.pop();
    s
}

fn kml_polygon(ring: &[LatLon]) -> String {
    format!(
        "<Polygon><tessellate>1</tessellate><altitudeMode>clampToGround</altitudeMode>\
         <outerBoundaryIs><LinearRing><coordinates>{}</coordinates></LinearRing>\
         </outerBoundaryIs></Polygon>",
        kml_coordinates(ring)
    )
}

/// A KML 2.2 document: one filled square `Placemark` per cell, named `name` and filled
/// with `colour` (`aabbggrr` hex, e.g. from [`kml_colour`]; anything else becomes
/// `KML_FALLBACK_COLOUR`), with `row` and `col` in its `ExtendedData`; then each extra
/// polygon (e.g. the ground truth) as a yellow outline `Placemark` named by its string.
/// Extra polygons with fewer than 3 vertices or non-finite coordinates are left out.
pub fn cells_kml(
    grid: &Grid,
    cells: &[(Cell, String, String)],
    extra_polygons: &[(Vec<LatLon>, String)],
) -> String {
    let colours: BTreeSet<String> = cells.iter().map(|(_, _, c)| clean_colour(c)).collect();
    let mut k = String::new();
    k.push_str("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    k.push_str("<kml xmlns=\"http://www.opengis.net/kml/2.2\">\n<Document>\n");
    let o = grid.origin();
    let _ = writeln!(
        k,
        "<name>fleetmap grid: origin {},{}, {} m cells, UTM zone {}{}</name>",
        o.lat,
        o.lon,
        grid.cell_size(),
        grid.zone(),
        grid.hemisphere()
    );
    for c in &colours {
        let _ = writeln!(
            k,
            "<Style id=\"c{c}\"><LineStyle><color>ff{}</color><width>1</width></LineStyle>\
             <PolyStyle><color>{c}</color></PolyStyle></Style>",
            &c[2..]
        );
    }
    k.push_str(
        "<Style id=\"outline\"><LineStyle><color>ff00ffff</color><width>3</width></LineStyle>\
         <PolyStyle><fill>0</fill></PolyStyle></Style>\n",
    );
    for (cell, name, colour) in cells {
        let _ = writeln!(
            k,
            "<Placemark><name>{}</name><styleUrl>#c{}</styleUrl><ExtendedData>\
             <Data name=\"row\"><value>{}</value></Data><Data name=\"col\"><value>{}</value></Data>\
             </ExtendedData>{}</Placemark>",
            xml_escape(name),
            clean_colour(colour),
            cell.row,
            cell.col,
            kml_polygon(&grid.cell_corners(*cell))
        );
    }
    for (ring, name) in extra_polygons {
        if let Some(r) = normalise_ring(ring) {
            let _ = writeln!(
                k,
                "<Placemark><name>{}</name><styleUrl>#outline</styleUrl>{}</Placemark>",
                xml_escape(name),
                kml_polygon(&r)
            );
        }
    }
    k.push_str("</Document>\n</kml>\n");
    k
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid() -> Grid {
        Grid::new(LatLon::new(-33.9, 151.2), 4.0).unwrap()
    }

    #[test]
    fn geojson_cells_and_polygons() {
        let g = grid();
        let cells = vec![
            (Cell::new(0, 0), json!({"state": "positive", "row": 99})),
            (Cell::new(-1, 2), Value::Null),
            (Cell::new(3, -4), json!(0.7)),
        ];
        // A clockwise triangle, given closed: it must come out counter-clockwise.
        let a = g.from_xy(0.0, 0.0).unwrap();
        let b = g.from_xy(0.0, 10.0).unwrap();
        let c = g.from_xy(10.0, 0.0).unwrap();
        let extra = vec![
            (vec![a, b, c, a], json!({"name": "truth"})),
            (vec![a, b], json!("degenerate")),
        ];
        let fc = cells_geojson(&g, &cells, &extra);
        assert_eq!(fc["type"], "FeatureCollection");
        assert_eq!(fc["skipped_polygons"], 1);
        assert_eq!(fc["grid"]["zone"], 56);
        assert_eq!(fc["grid"]["hemisphere"], "S");
        let f = fc["features"].as_array().unwrap();
        assert_eq!(f.len(), 4);
        assert_eq!(
            f[0]["properties"],
            json!({"state": "positive", "row": 0, "col": 0})
        );
        assert_eq!(f[1]["properties"], json!({"row": -1, "col": 2}));
        assert_eq!(
            f[2]["properties"],
            json!({"value": 0.7, "row": 3, "col": -4})
        );
        let ring = f[1]["geometry"]["coordinates"][0].as_array().unwrap();
        assert_eq!(ring.len(), 5);
        assert_eq!(ring[0], ring[4]);
        let corners = g.cell_corners(Cell::new(-1, 2));
        for (i, p) in corners.iter().enumerate() {
            assert_eq!(ring[i], json!([p.lon, p.lat]));
        }
        let tri: Vec<LatLon> = f[3]["geometry"]["coordinates"][0]
            .as_array()
            .unwrap()
            .iter()
            .map(|v| LatLon::new(v[1].as_f64().unwrap(), v[0].as_f64().unwrap()))
            .collect();
        assert_eq!(tri.len(), 4);
        assert!(signed_area2(&tri[..3]) > 0.0);
        assert_eq!(f[3]["properties"]["name"], "truth");
    }

    #[test]
    fn kml_document() {
        let g = grid();
        let red = kml_colour(255, 0, 0, 0x80);
        assert_eq!(red, "800000ff");
        let cells = vec![
            (Cell::new(0, 0), "cell <0,0> & co".to_string(), red.clone()),
            (Cell::new(1, 0), "b".to_string(), "nonsense".to_string()),
            (Cell::new(2, 0), "c".to_string(), "800000FF".to_string()),
        ];
        let a = g.from_xy(0.0, 0.0).unwrap();
        let b = g.from_xy(0.0, 10.0).unwrap();
        let c = g.from_xy(10.0, 0.0).unwrap();
        let k = cells_kml(&g, &cells, &[(vec![a, b, c], "truth".to_string())]);
        assert!(k.starts_with("<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<kml"));
        assert!(k.ends_with("</Document>\n</kml>\n"));
        assert!(k.contains("<name>cell &lt;0,0&gt; &amp; co</name>"));
        assert_eq!(k.matches("<Style id=\"c800000ff\">").count(), 1);
        assert!(k.contains("<Style id=\"cffffffff\">"));
        assert_eq!(k.matches("<Placemark>").count(), 4);
        assert!(k.contains("<styleUrl>#outline</styleUrl>"));
        assert!(k.contains("<Data name=\"row\"><value>2</value></Data>"));
        let sw = g.cell_corners(Cell::new(0, 0))[0];
        assert!(k.contains(&format!("<coordinates>{},{},0 ", sw.lon, sw.lat)));
        assert_eq!(
            k.matches("<Placemark>").count(),
            k.matches("</Placemark>").count()
        );
    }
}
