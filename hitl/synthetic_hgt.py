#!/usr/bin/env python3
"""Write a SYNTHETIC SRTM3 tile (1201 x 1201 big-endian int16 heights, rows from the north)
for testing terrain serving without the internet.

The heights are invented: a plane through HOME_ALT metres at the home position, rising
SLOPE metres per kilometre to the north, plus a ripple of RIPPLE metres with a 1 km
wavelength to the east. They are not the real ground: use real SRTM tiles to fly.

    synthetic_hgt.py DIR [--home LAT,LON,ALT] [--slope M_PER_KM] [--ripple M]

writes DIR/<NAME>.hgt for the tile holding the home (default: ArduPilot SITL's CMAC home,
-35.363261,149.165230,584, tile S36E149).
"""

import argparse
import math
import os
import sys

import numpy as np


def tile_name(lat_sw: int, lon_sw: int) -> str:
    return "%s%02d%s%03d" % (
        "S" if lat_sw < 0 else "N", abs(lat_sw), "W" if lon_sw < 0 else "E", abs(lon_sw))


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("dir")
    ap.add_argument("--home", default="-35.363261,149.165230,584")
    ap.add_argument("--slope", type=float, default=20.0, help="metres per km northwards")
    ap.add_argument("--ripple", type=float, default=10.0, help="metres, 1 km wavelength east")
    a = ap.parse_args()
    lat0, lon0, alt0 = (float(x) for x in a.home.split(","))
    lat_sw, lon_sw = math.floor(lat0), math.floor(lon0)
    n = 1201
    rows = np.arange(n)
    lats = (lat_sw + 1) - rows / (n - 1)  # row 0 is the north edge
    lons = lon_sw + np.arange(n) / (n - 1)
    north_km = (lats - lat0) * 111.32
    east_km = (lons - lon0) * 111.32 * math.cos(math.radians(lat0))
    h = alt0 + a.slope * north_km[:, None] + a.ripple * np.sin(2 * math.pi * east_km)[None, :]
    h = np.clip(np.round(h), -32767, 32767).astype(">i2")
    os.makedirs(a.dir, exist_ok=True)
    path = os.path.join(a.dir, tile_name(lat_sw, lon_sw) + ".hgt")
    with open(path, "wb") as f:
        f.write(h.tobytes())
    print(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
