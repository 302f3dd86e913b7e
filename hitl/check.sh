#!/usr/bin/env bash
# hitl/check.sh [--no-fly] CONN [SYSID] — end-to-end check of fleetmap against whatever
# autopilot answers at the connection string CONN (see hitl/README.md):
#   1. fleetmap vehicles            (the vehicle is heard; waits, bounded, until it is ready)
#   2. mission upload/download      (a short mission round trip, .waypoints and .plan)
#   3. fleetmap mission fly         (arm, take off, fly a 20 m square, return, land)
# Step 3 FLIES THE VEHICLE: simulators, or real vehicles in a safe area only.
set -euo pipefail

FLY=1
if [[ "${1:-}" == "--no-fly" ]]; then
  FLY=0
  shift
fi
if [[ $# -lt 1 || $# -gt 2 ]]; then
  echo "usage: $0 [--no-fly] CONN [SYSID]   (e.g. $0 udpin:0.0.0.0:14550 1)" >&2
  exit 2
fi
CONN=$1
SYSID=${2:-1}
HERE=$(cd "$(dirname "$0")" && pwd)
if [[ -n "${FLEETMAP:-}" ]]; then
  BIN=$FLEETMAP
elif command -v fleetmap >/dev/null 2>&1; then
  BIN=fleetmap
else
  BIN="$HERE/../target/debug/fleetmap"
fi
PY=${PYTHON:-python3}
WORK=$(mktemp -d -t fleetmap-check.XXXXXX)
step() { printf '\n== %s\n' "$*"; }

step "1. vehicles on $CONN"
"$BIN" vehicles --connect "$CONN" --wait 5 --tlog "$WORK/vehicles.tlog"
# A vehicle that was just started has no GPS fix or position yet: wait for it (at most
# READY_WAIT seconds, 180 by default), as a GCS does, before building the mission around it.
READY_WAIT=${READY_WAIT:-180}
deadline=$(( $(date +%s) + READY_WAIT ))
while :; do
  "$BIN" vehicles --connect "$CONN" --wait 3 --json >"$WORK/vehicles.json"
  if ready=$("$PY" - "$WORK/vehicles.json" "$SYSID" <<'EOF'
import json, sys
snap = json.load(open(sys.argv[1]))
v = snap["vehicles"].get(sys.argv[2])
if v is None:
    sys.exit("system %s not heard (heard: %s)" % (sys.argv[2], ", ".join(snap["vehicles"]) or "none"))
p = v.get("position") or v.get("home")
if not p or (p["lat"] == 0 and p["lon"] == 0) or (v.get("gps_fix") or 0) < 3:
    sys.exit("vehicle %s has no position yet (GPS fix %s)" % (sys.argv[2], v.get("gps_fix")))
print(p["lat"], p["lon"], 1 if v["flavour"]["class"] == "Copter" else 0)
EOF
  ); then
    read -r LAT LON FLIES <<<"$ready"
    break
  fi
  if (( $(date +%s) >= deadline )); then
    echo "not ready after ${READY_WAIT} s" >&2
    exit 1
  fi
  sleep 2
done
echo "vehicle $SYSID at $LAT,$LON"

step "2. mission round trip"
"$PY" - "$LAT" "$LON" "$FLIES" "$WORK/square.waypoints" <<'EOF'
import math, sys
lat, lon, flies, out = float(sys.argv[1]), float(sys.argv[2]), sys.argv[3] == "1", sys.argv[4]
def off(n, e):
    return lat + n / 6371000.0 * 180 / math.pi, lon + e / (6371000.0 * math.cos(math.radians(lat))) * 180 / math.pi
rows = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t%.8f\t%.8f\t0\t1" % (lat, lon)]
items = []
if flies:
    items.append((3, 22, lat, lon, 0, 10))  # at the launch position: PX4 flies it as a waypoint
for n, e in [(20, 0), (20, 20), (0, 20), (0, 0)]:
    a, b = off(n, e)
    items.append((3, 16, a, b, 0, 10))
items.append((2, 20, 0, 0, 0, 0))
for i, (frame, cmd, a, b, _, z) in enumerate(items, 1):
    rows.append("%d\t0\t%d\t%d\t0\t0\t0\t0\t%.8f\t%.8f\t%g\t1" % (i, frame, cmd, a, b, z))
open(out, "w").write("\n".join(rows) + "\n")
EOF
"$BIN" mission upload --connect "$CONN" --sysid "$SYSID" "$WORK/square.waypoints" --tlog "$WORK/upload.tlog"
"$BIN" mission download --connect "$CONN" --sysid "$SYSID" "$WORK/back.waypoints"
"$BIN" mission download --connect "$CONN" --sysid "$SYSID" "$WORK/back.plan"
"$PY" - "$WORK/square.waypoints" "$WORK/back.waypoints" <<'EOF'
import sys
def items(path):
    rows = [l.split() for l in open(path).read().splitlines()[2:] if l.strip()]
    return [(int(r[3]), round(float(r[8]), 7), round(float(r[9]), 7), round(float(r[10]), 2)) for r in rows]
a, b = items(sys.argv[1]), items(sys.argv[2])
if a != b:
    sys.exit("round trip differs:\n sent %s\n back %s" % (a, b))
print("round trip: %d items identical (command, position, altitude)" % len(a))
EOF
"$BIN" mission upload --connect "$CONN" --sysid "$SYSID" "$WORK/back.plan"
"$BIN" mission download --connect "$CONN" --sysid "$SYSID" "$WORK/back2.waypoints"
cmp <(tail -n +3 "$WORK/back.waypoints") <(tail -n +3 "$WORK/back2.waypoints")
echo ".plan round trip identical"

if [[ $FLY == 1 ]]; then
  step "3. mission fly (the vehicle flies now)"
  "$BIN" mission fly --connect "$CONN" --sysid "$SYSID" "$WORK/square.waypoints" --tlog "$WORK/fly.tlog" --timeout 600
else
  step "3. mission fly skipped (--no-fly)"
fi

step "all checks passed; files and tlogs in $WORK"
