#!/usr/bin/env python3
"""Generate assets/golden/utm_pyproj.csv: UTM reference values from PROJ (via pyproj).

Run ONCE (the output is committed; tests/suite/geo.rs compares fleetmap's UTM against every row in
both directions to 1 mm):

    /work/venv/bin/python scripts/gen_utm_golden.py

Each row is a WGS84 point and its UTM coordinates in the zone/hemisphere named in the row,
computed by PROJ's transverse Mercator (EPSG:326zz north / EPSG:327zz south, which PROJ
evaluates with the Poder/Engsager "exact" algorithm, src/projections/tmerc.cpp).

Columns:
  kind       which test family the row belongs to (random, south, zone_edge, norway, svalbard,
             forced, polar_limit, hemisphere_forced)
  lat, lon   degrees (WGS84), printed with repr() (17 significant digits, exact round trip)
  zone       the UTM zone the point is projected in (1..60)
  hemisphere N or S (S = 10 000 000 m false northing)
  standard   1 if `zone` is the standard zone of the point (Norway/Svalbard exceptions included),
             0 for a forced zone (a grid reaching into the next zone)
  easting, northing   metres, from PROJ

The standard-zone rule below follows GeographicLib's UTMUPS::StandardZone
(geographiclib/geographiclib, src/UTMUPS.cpp): zone = floor((lon + 180) / 6) + 1, band V
(56..64 N) lon 3..12 -> 32, band X (72..84 N) lon 0..42 -> 31/33/35/37.
"""

import csv
import math
import os
import random

import pyproj

SEED = 20240611
OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "assets", "golden", "utm_pyproj.csv")


def standard_zone(lat, lon):
    ilon = math.floor(lon)
    if ilon >= 180:
        ilon -= 360
    zone = (ilon + 186) // 6
    if 56 <= lat < 64 and zone == 31 and ilon >= 3:
        zone = 32
    elif 72 <= lat <= 84 and 0 <= ilon < 42:
        zone = 2 * ((ilon + 183) // 12) + 1
    return zone


_transformers = {}


def utm(lat, lon, zone, hemisphere):
    key = (zone, hemisphere)
    if key not in _transformers:
        epsg = (32600 if hemisphere == "N" else 32700) + zone
        _transformers[key] = pyproj.Transformer.from_crs("EPSG:4326", f"EPSG:{epsg}", always_xy=True)
    e, n = _transformers[key].transform(lon, lat)
    if not (math.isfinite(e) and math.isfinite(n)):
        raise ValueError(f"PROJ failed for {lat} {lon} zone {zone}{hemisphere}")
    return e, n


def central_meridian(zone):
    return zone * 6.0 - 183.0


def main():
    rng = random.Random(SEED)
    rows = []

    def add(kind, lat, lon, zone=None, hemisphere=None):
        std = standard_zone(lat, lon)
        if zone is None:
            zone = std
        if hemisphere is None:
            hemisphere = "N" if lat >= 0 else "S"
        e, n = utm(lat, lon, zone, hemisphere)
        rows.append((kind, lat, lon, zone, hemisphere, 1 if zone == std else 0, e, n))

    # 1. Random points worldwide (uniform on the sphere between 80 S and 84 N).
    smin, smax = math.sin(math.radians(-80)), math.sin(math.radians(84))
    for _ in range(2000):
        lat = math.degrees(math.asin(rng.uniform(smin, smax)))
        add("random", lat, rng.uniform(-180, 180))

    # 2. Southern hemisphere, including just south of the equator.
    for _ in range(800):
        add("south", rng.uniform(-80, -1e-9), rng.uniform(-180, 180))
    for _ in range(100):
        add("south", -rng.uniform(0, 1e-3), rng.uniform(-180, 180))

    # 3. +-0.0001 deg around every zone edge, in both adjacent zones (the standard one and the
    #    neighbour as a forced zone), at several latitudes in both hemispheres.
    for z in range(1, 61):
        edge = -180.0 + 6.0 * z  # east edge of zone z (180 for zone 60)
        for lat in (-79.5, -61.0, -33.9, -0.5, 0.3, 12.0, 45.5, 55.9, 70.0, 83.9):
            for d in (-1e-4, 0.0, 1e-4):
                lon = edge + d
                if lon >= 180.0:
                    lon -= 360.0
                west_zone = z
                east_zone = z % 60 + 1
                add("zone_edge", lat, lon, zone=west_zone)
                add("zone_edge", lat, lon, zone=east_zone)

    # 4. Norway (32V: 56..64 N, 3..12 E) and Svalbard (31X/33X/35X/37X: 72..84 N, 0..42 E),
    #    with points on and just beside their boundaries.
    for _ in range(300):
        add("norway", rng.uniform(56, 64), rng.uniform(2.5, 12.5))
    for lat in (56.0, 56.0001, 60.0, 63.9999):
        for lon in (2.9999, 3.0, 3.0001, 5.9999, 6.0, 11.9999, 12.0):
            add("norway", lat, lon)
    for _ in range(400):
        add("svalbard", rng.uniform(72, 84), rng.uniform(-0.5, 42.5))
    for lat in (71.9999, 72.0, 78.0, 84.0):
        for lon in (0.0, 8.9999, 9.0, 20.9999, 21.0, 32.9999, 33.0, 41.9999, 42.0):
            add("svalbard", lat, lon)

    # 5. Forced zones: points up to ~4 deg outside the zone (a grid anchored in one zone whose
    #    cells reach into the next), in both hemispheres, plus a few up to 10 deg outside.
    for _ in range(1000):
        zone = rng.randint(1, 60)
        cm = central_meridian(zone)
        side = rng.choice((-1.0, 1.0))
        beyond = rng.uniform(0.0, 4.0) if rng.random() < 0.9 else rng.uniform(4.0, 10.0)
        lon = cm + side * (3.0 + beyond)
        if lon >= 180.0:
            lon -= 360.0
        elif lon < -180.0:
            lon += 360.0
        lat = rng.uniform(-80, 84)
        add("forced", lat, lon, zone=zone)

    # 6. Near the limits of UTM: 80 S and 84 N (inside, and on the limit).
    for _ in range(200):
        add("polar_limit", rng.uniform(-80, -79.9), rng.uniform(-180, 180))
        add("polar_limit", rng.uniform(83.9, 84), rng.uniform(-180, 180))
    for lon in (-177.0, -3.0, 0.0, 3.0, 15.0, 39.0, 177.0):
        add("polar_limit", -80.0, lon)
        add("polar_limit", 84.0, lon)

    # 7. A grid anchored just north (south) of the equator keeps its hemisphere for cells on
    #    the other side: forced hemisphere (negative northing / northing above 10 000 km).
    for _ in range(100):
        lon = rng.uniform(-180, 180)
        add("hemisphere_forced", rng.uniform(-0.5, 0.0), lon, hemisphere="N")
        add("hemisphere_forced", rng.uniform(0.0, 0.5), lon, hemisphere="S")

    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    with open(OUT, "w", newline="") as f:
        f.write(f"# UTM reference values from PROJ {pyproj.proj_version_str} via pyproj {pyproj.__version__}"
                f" (scripts/gen_utm_golden.py, seed {SEED}); {len(rows)} rows\n")
        w = csv.writer(f, lineterminator="\n")
        w.writerow(["kind", "lat", "lon", "zone", "hemisphere", "standard", "easting", "northing"])
        for kind, lat, lon, zone, hem, std, e, n in rows:
            w.writerow([kind, repr(lat), repr(lon), zone, hem, std, repr(e), repr(n)])
    print(f"wrote {len(rows)} rows to {os.path.normpath(OUT)}")


if __name__ == "__main__":
    main()
