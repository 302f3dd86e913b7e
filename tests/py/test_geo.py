"""`fleetmap grid` against live PROJ (pyproj): every number the CLI prints must agree with
PROJ to 1 mm, on random grids worldwide, in the southern hemisphere, at zone edges (cells
reaching into the next zone), in the Norway/Svalbard special zones and near 80 S / 84 N.

Run: FLEETMAP_BIN=target/debug/fleetmap python -m pytest -q tests/py/test_geo.py
"""

import json
import math
import os
import random
import subprocess
import xml.etree.ElementTree as ET

import pyproj
import pytest

BIN = os.environ.get("FLEETMAP_BIN", "target/debug/fleetmap")
TOL_M = 1e-3
GEOD = pyproj.Geod(ellps="WGS84")
_TRANSFORMERS = {}


def fleetmap(*args):
    return subprocess.run([BIN, *map(str, args)], capture_output=True, text=True, timeout=60)


def grid(origin, size, *args):
    lat, lon = origin
    r = fleetmap("grid", f"--origin={lat!r},{lon!r}", "--cell-size", repr(size), *args)
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert len(lines) == 1, r.stdout
    return json.loads(lines[0])


def transformer(zone, hemisphere):
    key = (zone, hemisphere)
    if key not in _TRANSFORMERS:
        epsg = (32600 if hemisphere == "N" else 32700) + zone
        _TRANSFORMERS[key] = pyproj.Transformer.from_crs("EPSG:4326", f"EPSG:{epsg}", always_xy=True)
    return _TRANSFORMERS[key]


def to_utm(lat, lon, zone, hemisphere):
    return transformer(zone, hemisphere).transform(lon, lat)


def from_utm(e, n, zone, hemisphere):
    lon, lat = transformer(zone, hemisphere).transform(e, n, direction="INVERSE")
    return lat, lon


def metres(lat1, lon1, lat2, lon2):
    return GEOD.inv(lon1, lat1, lon2, lat2)[2]


def standard_zone(lat, lon):
    """UTM zone with the Norway and Svalbard exceptions, written independently of fleetmap."""
    if lon >= 180:
        lon -= 360
    zone = int((lon + 180) // 6) + 1
    if 56 <= lat < 64 and 3 <= lon < 12:
        return 32
    if 72 <= lat <= 84 and 0 <= lon < 42:
        for limit, z in ((9, 31), (21, 33), (33, 35), (42, 37)):
            if lon < limit:
                return z
    return zone


def check_cell(out, origin, size):
    """The printed cell centre agrees with PROJ: UTM = origin's UTM + (col, row)·size, and the
    printed lat/lon is PROJ's inverse of that UTM, both within 1 mm."""
    zone, hem = out["zone"], out["hemisphere"]
    assert hem in ("N", "S")
    e0, n0 = to_utm(origin[0], origin[1], zone, hem)
    assert abs(out["easting"] - (e0 + out["col"] * size)) < TOL_M, out
    assert abs(out["northing"] - (n0 + out["row"] * size)) < TOL_M, out
    lat, lon = from_utm(out["easting"], out["northing"], zone, hem)
    assert metres(lat, lon, out["lat"], out["lon"]) < TOL_M, (out, lat, lon)
    e, n = to_utm(out["lat"], out["lon"], zone, hem)
    assert math.hypot(e - out["easting"], n - out["northing"]) < TOL_M, out


def random_origins(rng, count):
    out = []
    for i in range(count):
        kind = i % 6
        if kind == 0:  # worldwide
            lat, lon = rng.uniform(-79.5, 83.5), rng.uniform(-180, 180)
        elif kind == 1:  # southern hemisphere
            lat, lon = rng.uniform(-79.5, -0.01), rng.uniform(-180, 180)
        elif kind == 2:  # within 0.0001 deg of a zone edge
            lat = rng.uniform(-79.5, 55.0)
            lon = -180 + 6 * rng.randint(1, 59) + rng.uniform(-1e-4, 1e-4)
        elif kind == 3:  # Norway 32V
            lat, lon = rng.uniform(56.01, 63.99), rng.uniform(3.0001, 11.999)
        elif kind == 4:  # Svalbard 31X..37X
            lat, lon = rng.uniform(72.01, 83.5), rng.uniform(0.0001, 41.999)
        else:  # just south of the equator / near 80 S
            lat, lon = rng.choice((rng.uniform(-0.01, -1e-6), rng.uniform(-79.99, -79.5))), rng.uniform(-180, 180)
        out.append((lat, lon))
    return out


def test_to_gps_matches_pyproj():
    rng = random.Random(7)
    for origin in random_origins(rng, 120):
        size = rng.choice((0.5, 1.0, 4.0, 5.0, 12.5, 100.0))
        # Cells up to ~20 km from the origin in every direction (negative indices included),
        # which carries zone-edge origins well into the next zone.
        reach = int(20_000 / size)
        row, col = rng.randint(-reach, reach), rng.randint(-reach, reach)
        if origin[0] > 83.0 and row > 0:
            row = -row  # keep the cell south of 84 N
        out = grid(origin, size, "to-gps", row, col)
        assert (out["row"], out["col"]) == (row, col)
        assert out["zone"] == standard_zone(*origin), (origin, out)
        assert out["hemisphere"] == ("N" if origin[0] >= 0 else "S")
        check_cell(out, origin, size)


def test_from_gps_matches_pyproj():
    rng = random.Random(11)
    checked = 0
    for origin in random_origins(rng, 120):
        size = rng.choice((1.0, 4.0, 5.0, 30.0))
        zone = standard_zone(*origin)
        hem = "N" if origin[0] >= 0 else "S"
        e0, n0 = to_utm(origin[0], origin[1], zone, hem)
        # A random point within ~10 km (into the neighbouring zone for edge origins).
        de, dn = rng.uniform(-10_000, 10_000), rng.uniform(-10_000, 10_000)
        lat, lon = from_utm(e0 + de, n0 + dn, zone, hem)
        if not -80 <= lat <= 84:
            continue
        e, n = to_utm(lat, lon, zone, hem)
        fc, fr = (e - e0) / size + 0.5, (n - n0) / size + 0.5
        # Skip points within a micrometre of a cell boundary (either answer is right there).
        if min(fc - math.floor(fc), math.ceil(fc) - fc) * size < 1e-6:
            continue
        if min(fr - math.floor(fr), math.ceil(fr) - fr) * size < 1e-6:
            continue
        out = grid(origin, size, "from-gps", repr(lat), repr(lon))
        assert (out["row"], out["col"]) == (math.floor(fr), math.floor(fc)), (origin, lat, lon, out)
        assert out["zone"] == zone
        check_cell(out, origin, size)
        # The printed lat/lon is the centre of the cell, not the point.
        assert metres(lat, lon, out["lat"], out["lon"]) <= size * math.sqrt(0.5) * 1.001 + TOL_M
        checked += 1
    assert checked > 100


def test_zone_edge_grid_stays_in_its_zone():
    # Origin 0.0001 deg west of the 30 E edge in the southern hemisphere (zone 35); a cell
    # 50 km east lies in zone 36 but is expressed in zone 35.
    origin = (-25.7, 29.9999)
    out = grid(origin, 4.0, "to-gps", 10, 12_500)
    assert out["zone"] == 35 and out["hemisphere"] == "S"
    assert out["lon"] > 30.4
    check_cell(out, origin, 4.0)
    back = grid(origin, 4.0, "from-gps", repr(out["lat"]), repr(out["lon"]))
    assert back == out


def test_negative_indices_and_round_trip():
    origin = (37.1968, -80.5781)
    for row, col in ((-3, -7), (-1, 0), (0, -1), (-250, 999), (17, -4242)):
        out = grid(origin, 4.0, "to-gps", row, col)
        assert (out["row"], out["col"]) == (row, col)
        check_cell(out, origin, 4.0)
        assert grid(origin, 4.0, "from-gps", repr(out["lat"]), repr(out["lon"])) == out


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--origin", "95,10", "--cell-size", "4", "to-gps", "0", "0"], "latitude 95"),
        (["--origin", "-85,10", "--cell-size", "4", "to-gps", "0", "0"], "outside UTM"),
        (["--origin", "37,-80", "--cell-size", "0", "to-gps", "0", "0"], "cell size"),
        (["--origin", "37,-80", "--cell-size", "nan", "to-gps", "0", "0"], "finite"),
        (["--origin", "37,-80", "--cell-size", "4", "from-gps", "abc", "1"], "not a number"),
        (["--origin", "37,-80", "--cell-size", "4", "to-gps", "1"], "missing"),
    ],
)
def test_bad_arguments(args, needle):
    r = fleetmap("grid", *args)
    assert r.returncode != 0
    assert r.stdout == ""
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0], r.stderr


def test_export_geojson_and_kml_corners_match_pyproj():
    origin, size = (-33.8688, 151.2093), 4.0
    r = fleetmap("grid", f"--origin={origin[0]},{origin[1]}", "--cell-size", "4", "export",
                 "--rows", "-2:1", "--cols", "-1:2")
    assert r.returncode == 0, r.stderr
    fc = json.loads(r.stdout)
    assert fc["type"] == "FeatureCollection" and len(fc["features"]) == 16
    e0, n0 = to_utm(origin[0], origin[1], 56, "S")
    for f in fc["features"]:
        row, col = f["properties"]["row"], f["properties"]["col"]
        ring = f["geometry"]["coordinates"][0]
        assert len(ring) == 5 and ring[0] == ring[4]
        expect = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]  # SW SE NE NW: CCW
        for (lon, lat), (dc, dr) in zip(ring[:4], expect):
            e, n = to_utm(lat, lon, 56, "S")
            assert abs(e - (e0 + (col + dc) * size)) < TOL_M
            assert abs(n - (n0 + (row + dr) * size)) < TOL_M

    r = fleetmap("grid", f"--origin={origin[0]},{origin[1]}", "--cell-size", "4", "export",
                 "--rows", "0:0", "--cols", "0:1", "--format", "kml")
    assert r.returncode == 0, r.stderr
    ns = {"k": "http://www.opengis.net/kml/2.2"}
    root = ET.fromstring(r.stdout)
    marks = root.findall(".//k:Placemark", ns)
    assert len(marks) == 2
    coords = marks[1].find(".//k:coordinates", ns).text.split()
    lon, lat, _ = map(float, coords[0].split(","))
    e, n = to_utm(lat, lon, 56, "S")
    assert abs(e - (e0 + 0.5 * size)) < TOL_M and abs(n - (n0 - 0.5 * size)) < TOL_M
