#!/usr/bin/env python3
"""Conformance checks: the same checks against fleetmap's embedded simulator and any real
autopilot (ArduPilot SITL, PX4 SITL, a vehicle on the bench).

    hitl/conformance.py sim:ardupilot-copter            # the embedded simulator (CI runs this)
    hitl/conformance.py sim:px4-copter
    hitl/conformance.py tcp:127.0.0.1:5762 --sysid 1    # an ArduPilot SITL's SERIAL1
    hitl/conformance.py udpout:127.0.0.1:18570          # a PX4 SITL's GCS port
    hitl/conformance.py tcp:127.0.0.1:5760 --checks files --missions DIR --fly 3   # mission files
    hitl/conformance.py --checks bandit-fleet --ardupilot DIR --speedup 5           # a SITL team
    hitl/conformance.py --checks runway --team 3xarducopter --ardupilot DIR --speedup 5   # runway, a team

Everything goes through `fleetmap relay` (a lossy MAVLink relay) between fleetmap and the
vehicle, so the checks at 0, 30 and 50 % loss see the real autopilot's behaviour over a poor
radio. Each check prints one line; `--json FILE` writes them all. The checks:

  ready     the vehicle is heard and gets ready (GPS fix, position), waited for as a GCS does
  boot      a mission upload issued right after a reboot (MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN,
            what a battery swap does) waits for the vehicle and succeeds
  transfer  mission round trips (upload, download, compare) at each loss level of --losses
            with 5 % duplicates: all succeed up to 30 %; at 50 % each succeeds or fails with
            a clear error, never with a wrong mission
  fly       `fleetmap mission fly`: take off, a 20 m square, return and land
  signing   after `fleetmap signing setup`, an unsigned command is ignored and a signed one
            obeyed; the key is removed again at the end
  streams   (not run by default) bytes per second per message after fleetmap's stream requests
            and after a link budget's, within 12 % (each message within 30 %) of the tables
            measured on ArduCopter/ArduRover 4.7 SITL and PX4 1.16 SIH, in the vehicle's time;
            and the slowdown under RADIO_STATUS (txbuf 10 %) from a SiK radio: ArduPilot below
            40 %, PX4's SITL GCS link unchanged (hitl/link_checks.py)
  arming    (not run by default) arming and take-off answered as the autopilot answers them
            when commands come late or twice: a take-off disarmed, ARM twice, the same mode
            again, the auto-disarm 10 s after arming without a take-off, a take-off after it
            and one repeated while climbing; then it lands (hitl/link_checks.py)
  runway    the runway field test (`fleetmap run missions/runway-field-test.toml`) over a
            simulated world: the GCS is killed (SIGKILL) once in the middle and resumed, every
            battery swap is a power cycle done by the "crew" (a second GCS id rebooting a real
            autopilot; the simulator swaps by itself), and the map's IoU must be within 5
            points of the best the grid allows. A real autopilot needs a simulated camera:
            give --camera-link, where the autopilot's camera port sends (e.g. ArduPilot
            `--serial1 udpclient:127.0.0.1:14552` → udpin:127.0.0.1:14552); this runner
            starts `fleetmap sim --camera-only` there.
            With --team and no target, the runner starts a team of SITL copters itself, as
            bandit-fleet does (--team e.g. 3xarducopter or 2xarducopter,1xpx4; --wiring,
            --ardupilot, --px4, --speedup, --instance-base): the k-th drone of the mission at
            the world's k-th home ([homes]); a mission that lists fewer drones is written to
            the work directory with drones appended (sysid k, as `fleetmap experiment runway
            --drones N` does), its battery.flight_time_min set to --runway-battery-min (default
            6: the GCS's endurance estimate, below what the SITL batteries give). Batteries
            small enough for swaps: ArduPilot BATT_CAPACITY --battery-mah (default 4000; the
            SITL quad draws about 28 A hovering, about 8.5 minutes), PX4 SIH SIM_BAT_DRAIN
            --px4-battery-s (default 450 s) down to SIM_BAT_MIN_PCT 5. One `fleetmap camera
            --source render` serves every copter's camera port (pictures by image transmission
            at --image-rate). When the GCS says "vehicle N: landed: waiting for a battery swap"
            the crew power-cycles that drone at once: ArduPilot rebooted from GCS id 250 on its
            SERIAL2 (TCP 5762 + 10 × instance), PX4 (which refuses the reboot command) by
            restarting its process; PX4 SIH refills its battery when it disarms, so a PX4 drone
            the GCS sent up again before the crew came is not restarted (counted apart). One
            row: team, wiring, IoU (best possible), battery swaps (power cycles), cells,
            pictures (cell-centre + sweep), pictures lost (the report's image failures), wall
            seconds, mission time to the complete map / to the last landing (`fleetmap report
            --json`: the GCS's clock, i.e. wall seconds; the row adds the rate the SITLs' own
            clocks ran at, from the .tlog), result (pass: finished, GCS killed and resumed, IoU within
            1 point of the best, at least one swap and every power cycle done, no picture lost,
            every drone landed).
  files     (not run by default) every .txt, .waypoints and .plan file in --missions DIR, e.g.
            ArduPilot's Tools/autotest missions, through `fleetmap mission upload --verify`
            (upload, read back, compare by the autopilot's storage rules): verified, or the
            first difference or error. With --fly N, the first N verified files whose first
            position is within --fly-radius of the vehicle are flown with `fleetmap mission fly`.
            A table (file, items, verified, flown, error) is printed and goes into --json.
  bandit-fleet  (not run by default; needs no target) the spatial-classification mission
            (--mission, default missions/hardware-6x6.toml over assets/worlds/hardware-6x6.toml)
            on a team of SITL autopilots this runner starts, each at the start cell the mission
            gives it: --team lists them in the order of the mission's vehicles (arducopter or
            px4 drones, ardurover stations; default 4xarducopter,2xardurover). ArduPilot comes
            from --ardupilot DIR (build/sitl/bin/arducopter, ardurover and
            Tools/autotest/default_params), PX4 SIH from --px4 DIR (build/px4_sitl_default);
            every SITL runs at --speedup with BATT_CAPACITY --battery-mah (PX4: SIM_BAT_DRAIN
            --px4-battery-s) and no stream-rate parameter. Every vehicle sends to one GCS UDP
            port (--wiring shared) or each to its own (per-vehicle: one --connect each); the
            copters' camera port (ArduPilot SERIAL1, PX4's payload link) goes to one
            `fleetmap camera --source render --mission M` (measures on board; --camera-pictures:
            pushes every picture instead). Then `fleetmap run M --headless --auto-resume
            --tlog` to its end. One row: wiring, team, epochs, samples (measurements counted),
            pictures sent / lost by image transmission (0 / 0 when the camera measures on
            board), seconds per epoch on the wall clock and on the vehicles' clock
            (time_boot_ms), the longest drone flight of each epoch by the autopilots' own
            reports (landed state, vehicle clock), keep / reject / unclassified, errors,
            result (pass: the run finished, keep = the world's interesting cells, nothing
            unclassified, no labelling error). The figures beyond fleetmap's report come from
            the GCS's .tlog; the row is printed as a Markdown table row and goes into --json.

Telemetry radios (bandit-fleet, runway --team): with --radio BYTES (and --radio-loss P) every
vehicle's link (ArduPilot SERIAL0, PX4's GCS link) goes through its own `fleetmap relay --radio
BYTES --loss P --clock speedup:SPEEDUP --stats WORK/radio-SYSID.json` into the GCS's port: whole
datagrams, one budget for both directions (half duplex), 4 kB buffers, RADIO_STATUS, the budget
in the vehicles' time. The GCS gets `--link radio:BYTES`, the runway cameras classify on board
(`fleetmap camera --mission`), every camera's --image-rate defaults to 30 % of BYTES. The row
gains a column: the radios' bytes per second per vehicle (vehicle → GCS + GCS → vehicle, on the
vehicles' clock, mean and busiest), the share of frames lost and those dropped on a full buffer.

Field faults (bandit-fleet, runway --team): --fault SPEC, as many as wanted, in seconds of the
vehicles' clock. `K|all:outage@START..END` blacks out vehicle K's radio (or every one; needs
--radio) from START to END counted from the radios' start (a second or two before the GCS's);
`K:battery@T` sets off vehicle K's own battery failsafe T after it first armed (the crew sets
BATT_LOW_MAH above what is left on its SERIAL2, every ArduPilot of the team has
BATT_FS_LOW_ACT 2, RTL; the parameter is put back once the failsafe fired, and once the
vehicle is down the crew swaps the battery: a power cycle); `K:stuck@START[..END]` holds rover
K's throttle at neutral (SERVO3_MIN = SERVO3_MAX = its trim) from START after it first armed:
it stays in its mission and goes nowhere. --kill-at T (bandit-fleet; runway uses --kill-after)
kills the GCS with SIGKILL T after its start and resumes the run. The row adds the faults, the
crew's log and what the GCS told the operator; a system-id conflict reported fails it (no two
members share an id). The battery and stuck faults talk MAVLink through pymavlink (make's
.venv: run the script with .venv/bin/python).

Otherwise only standard-library Python; the binary is $FLEETMAP (default: fleetmap on the PATH, else
target/debug/fleetmap). Run it against simulators, or real vehicles in a safe open area only:
`fly` flies the vehicle.
"""

import argparse
import bisect
import json
import math
import os
import re
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time

import link_checks

HERE = os.path.dirname(os.path.abspath(__file__))
HOME = (37.1968, -80.5781)


def fleetmap_bin():
    if os.environ.get("FLEETMAP"):
        return os.environ["FLEETMAP"]
    if shutil.which("fleetmap"):
        return "fleetmap"
    return os.path.join(HERE, "..", "target", "debug", "fleetmap")


BIN = fleetmap_bin()


def free_udp_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def udp_inodes(port):
    """Socket inodes bound to local UDP `port` (Linux's /proc/net/udp), or None where there is
    no /proc."""
    try:
        rows = open("/proc/net/udp").read().splitlines()[1:]
    except OSError:
        return None
    inodes = set()
    for row in rows:
        f = row.split()
        if len(f) > 9 and int(f[1].rsplit(":", 1)[1], 16) == port:
            inodes.add(f[9])
    return inodes


def owns_socket(pid, inodes):
    try:
        fds = os.listdir(f"/proc/{pid}/fd")
    except OSError:
        return False
    for fd in fds:
        try:
            link = os.readlink(f"/proc/{pid}/fd/{fd}")
        except OSError:
            continue
        if link.startswith("socket:[") and link[8:-1] in inodes:
            return True
    return False


def serve(make_cmd, log, port=None, tries=5):
    """Start a fleetmap process that listens on a UDP port (`make_cmd(port)` builds its
    command line) and wait until it holds that port: returns (Proc, port).

    A port found free may be taken by any other process before ours binds it (a test beside
    this one, another runner), and a process restarted on its old port finds it taken the
    same way. Our process then exits ("Address already in use") while the commands pointed at
    the port would talk to whatever holds it, another vehicle perhaps. So the port counts only
    once /proc shows our process holding it; otherwise the next free port is tried."""
    why = ""
    for _ in range(tries):
        port = port or free_udp_port()
        proc = Proc(make_cmd(port), log)
        deadline = time.monotonic() + 30
        while proc.p.poll() is None and time.monotonic() < deadline:
            inodes = udp_inodes(port)
            if inodes is None:
                time.sleep(0.3)  # no /proc: the old way, a moment to bind
                return proc, port
            if owns_socket(proc.p.pid, inodes):
                return proc, port
            time.sleep(0.02)
        proc.stop()
        why = last_line(open(log, errors="replace").read()) or f"not listening on {port} after 30 s"
        port = None
    sys.exit(f"could not start {make_cmd(0)[1]} on a free port: {why}")


def offset(lat, lon, north, east):
    """The point `north`/`east` metres from (lat, lon), on a sphere (fine for tens of metres)."""
    r = 6371000.0
    return (lat + math.degrees(north / r), lon + math.degrees(east / (r * math.cos(math.radians(lat)))))


class Proc:
    """A background process whose output goes to a log file."""

    def __init__(self, args, log, cwd=None, env=None):
        self.log = open(log, "w")
        self.p = subprocess.Popen(args, stdout=self.log, stderr=subprocess.STDOUT, cwd=cwd, env=env)

    def stop(self, sig=signal.SIGINT):
        if self.p.poll() is None:
            self.p.send_signal(sig)
            try:
                self.p.wait(timeout=5)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()
        self.log.close()


def run(args, timeout):
    """Run fleetmap with `args`; returns (exit code, stdout, stderr, seconds)."""
    t0 = time.monotonic()
    try:
        r = subprocess.run([BIN, *args], capture_output=True, text=True, timeout=timeout)
        return r.returncode, r.stdout, r.stderr, time.monotonic() - t0
    except subprocess.TimeoutExpired as e:
        out = e.stdout.decode() if isinstance(e.stdout, bytes) else (e.stdout or "")
        return -1, out, f"timed out after {timeout} s", time.monotonic() - t0


REPO = os.path.join(HERE, "..")


def last_line(text):
    lines = [l for l in text.strip().splitlines() if l.strip()]
    return lines[-1] if lines else ""


class Bench:
    """The vehicle (a simulator this runner starts, or a real autopilot at a connection
    string) behind a `fleetmap relay`; fleetmap commands talk to the relay."""

    def __init__(self, target, sysid, work, speedup):
        self.target = target
        self.sysid = sysid
        self.work = work
        self.sim = None
        self.relay = None
        self.relay_port = None
        if target.startswith("sim:"):
            flavour = target[4:]
            ap, _, klass = flavour.partition("-")
            self.autopilot = {"ardupilot": "ArduPilot", "px4": "PX4"}.get(ap)
            if self.autopilot is None or klass not in ("copter", "rover"):
                sys.exit(f"unknown simulator {target!r}: sim:ardupilot-copter, sim:ardupilot-rover or sim:px4-copter")
            # PX4 as on the SITL's GCS link (its 50 Hz streams, no RADIO_STATUS throttling):
            # what these checks compare with
            link = "@sitl" if ap == "px4" else ""
            self.sim, port = serve(
                lambda port: [BIN, "sim", "--vehicles", f"1x{klass}:{ap}{link}", "--connect",
                              f"udpin:127.0.0.1:{port}", f"--home={HOME[0]},{HOME[1]}", "--speedup",
                              str(speedup), "--seed", "1",
                              # the simulator stops by itself if this runner dies without stopping it
                              "--duration", str(int(7200 * speedup))],
                os.path.join(work, "sim.log"),
            )
            self.vehicle = f"udpout:127.0.0.1:{port}"
        else:
            self.autopilot = None
            self.vehicle = target
        # One relay without faults holds the vehicle's connection for the whole run: PX4 answers
        # only the first address that spoke to its GCS port (`MavlinkReceiver`: the partner is
        # set once), and an ArduPilot TCP port takes one client. The lossy relay in front of
        # it is restarted for every loss level; the base relay serves every peer it hears.
        self.base, self.base_port = serve(
            lambda port: [BIN, "relay", "--gcs", f"udpin:127.0.0.1:{port}", "--vehicle", self.vehicle,
                          "--report-every", "0"],
            os.path.join(work, "relay-base.log"),
        )
        self.set_loss(0.0)

    def set_loss(self, loss, dup=0.0):
        """Restart the lossy relay with `loss` and `dup`, on its port if it is still free
        (else on another: `conn` follows)."""
        if self.relay:
            self.relay.stop()
        self.relay, self.relay_port = serve(
            lambda port: [BIN, "relay", "--gcs", f"udpin:127.0.0.1:{port}",
                          "--vehicle", f"udpout:127.0.0.1:{self.base_port}",
                          "--loss", str(loss), "--dup", str(dup), "--report-every", "0", "--seed", "7"],
            os.path.join(self.work, f"relay-{int(loss * 100)}.log"),
            port=self.relay_port,
        )

    def conn(self, *extra):
        return ["--connect", f"udpout:127.0.0.1:{self.relay_port}", *extra]

    def close(self):
        if self.relay:
            self.relay.stop()
        self.base.stop()
        if self.sim:
            self.sim.stop()

    def vehicle_json(self, wait=3):
        code, out, err, _ = run(["vehicles", *self.conn("--wait", str(wait), "--json")], timeout=wait + 30)
        if code != 0:
            return None
        try:
            return json.loads(out)["vehicles"].get(str(self.sysid))
        except (ValueError, KeyError):
            return None


def mission_file(path, lat, lon, n, flies):
    """A QGC WPL 110 mission of `n` items around (lat, lon): take-off (copters), then
    waypoints on a small grid at altitudes in whole centimetres, as both autopilots store."""
    rows = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t%.7f\t%.7f\t0\t1" % (lat, lon)]
    seq = 1
    if flies:
        # The take-off item at the launch position: PX4 flies it as a waypoint to its position.
        rows.append("1\t0\t3\t22\t0\t0\t0\t0\t%.7f\t%.7f\t10\t1" % (lat, lon))
        seq = 2
    while seq <= n:
        a, b = offset(lat, lon, 2.0 * (seq % 10), 2.0 * (seq // 10))
        rows.append("%d\t0\t3\t16\t%d\t0\t0\t0\t%.7f\t%.7f\t%.2f\t1" % (seq, seq % 3, a, b, 10 + seq % 7))
        seq += 1
    with open(path, "w") as f:
        f.write("\n".join(rows) + "\n")


def first_position(path):
    """(lat, lon) of the first mission item with a position in a QGC WPL file (not home, line
    0), or None (a .plan, or no item with a position)."""
    try:
        lines = open(path, errors="replace").read().splitlines()
    except OSError:
        return None
    if not lines or not lines[0].startswith("QGC WPL"):
        return None
    for line in lines[2:]:
        f = line.split()
        if len(f) < 12:
            continue
        try:
            lat, lon = float(f[8]), float(f[9])
        except ValueError:
            continue
        if lat != 0.0 or lon != 0.0:
            return lat, lon
    return None


def distance_m(a, b):
    """Great-circle distance between two (lat, lon) points, metres."""
    la1, lo1, la2, lo2 = map(math.radians, (*a, *b))
    h = math.sin((la2 - la1) / 2) ** 2 + math.cos(la1) * math.cos(la2) * math.sin((lo2 - lo1) / 2) ** 2
    return 2 * 6371000.0 * math.asin(min(1.0, math.sqrt(h)))


def fleetmap_error(err, code):
    """What a failed fleetmap command said: its last line on stderr without the "fleetmap: "
    prefix, else its exit code."""
    e = last_line(err)
    return e[len("fleetmap: "):] if e.startswith("fleetmap: ") else (e or f"exit {code}")


def json_lines(text):
    """The JSON objects among the lines of `text` (fleetmap --json prints one a line)."""
    out = []
    for line in text.splitlines():
        try:
            o = json.loads(line)
        except ValueError:
            continue
        if isinstance(o, dict):
            out.append(o)
    return out


def first_difference(sent, read):
    """Where two lists of `read_wpl` rows first differ, for a failure's message."""
    for i, (a, b) in enumerate(zip(sent, read)):
        if a != b:
            return f"item {i + 1} of {len(sent)}: sent {a}, read back {b}; {len(read)} read back"
    return f"{len(sent)} sent, {len(read)} read back"


def read_wpl(path):
    rows = [l.split("\t") for l in open(path).read().splitlines()[1:] if l.strip()]
    return [(int(r[3]), round(float(r[8]), 6), round(float(r[9]), 6), round(float(r[10]), 2)) for r in rows[1:]]


class Checks:
    def __init__(self, bench, args):
        self.b = bench
        self.args = args
        self.pos = HOME
        self.flies = True
        self.results = []

    def ardupilot(self):
        return (self.b.autopilot or "").lower().startswith("ardu")

    def record(self, name, ok, detail, seconds, **extra):
        line = {"check": name, "pass": ok, "detail": detail, "seconds": round(seconds, 1), **extra}
        self.results.append(line)
        print(f"{'PASS' if ok else 'FAIL'}  {name:<14} {seconds:7.1f} s  {detail}", flush=True)
        return ok

    def power_cycle(self, wait):
        """What a battery swap does: --power-cycle CMD if given (e.g. a script restarting a SITL
        process), else MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN from a second GCS id. Returns
        (ok, why)."""
        if self.args.power_cycle:
            r = subprocess.run(self.args.power_cycle, shell=True, capture_output=True, text=True)
            return r.returncode == 0, last_line(r.stderr) or f"exit {r.returncode}"
        cmd = ["command", *self.b.conn("--gcs-sysid", "250", "--sysid", str(self.b.sysid)), "reboot"]
        code, out, err, _ = run(cmd if wait else [*cmd, "--no-wait"], timeout=180)
        return code == 0, last_line(err)

    def ready(self, name="ready", limit=240):
        """Waits (bounded) until the vehicle has a GPS fix and a position, as a GCS does."""
        t0 = time.monotonic()
        v = None
        while time.monotonic() - t0 < limit:
            v = self.b.vehicle_json(wait=3)
            if v and (v.get("gps_fix") or 0) >= 3 and v.get("position") and not v.get("booting"):
                p = v["position"]
                self.pos = (p["lat"], p["lon"])
                self.flies = v["flavour"]["class"] == "Copter"
                self.b.autopilot = self.b.autopilot or v["flavour"]["autopilot"]
                return self.record(name, True, f"{v['flavour']['autopilot']} {v['flavour']['class']}, "
                                   f"GPS fix {v['gps_fix']}, battery {v.get('battery_pct')} %",
                                   time.monotonic() - t0)
            time.sleep(1)
        why = "never heard" if v is None else f"GPS fix {v.get('gps_fix')}, position {v.get('position')}"
        return self.record(name, False, f"not ready after {limit} s: {why}", time.monotonic() - t0)

    def boot(self):
        """Reboot (from a second GCS id, as a crew would power-cycle it) and upload at once."""
        path = os.path.join(self.b.work, "boot.waypoints")
        mission_file(path, *self.pos, 10, self.flies)
        t0 = time.monotonic()
        ok, why = self.power_cycle(wait=False)
        if not ok:
            if "denied" in why or "not supported" in why:
                # PX4 SITL cannot reboot its process (real PX4 hardware does): give the runner
                # a command that restarts it (--power-cycle) to run this check.
                return self.record("boot", True, f"n/a: the autopilot refuses to reboot ({why}); "
                                   "give --power-cycle CMD", time.monotonic() - t0, supported=False)
            return self.record("boot", False, f"reboot: {why}", time.monotonic() - t0)
        code, out, err, _ = run(["mission", "upload", *self.b.conn("--sysid", str(self.b.sysid), "--wait", "60"),
                                 path], timeout=180)
        ok = code == 0
        detail = last_line(out) if ok else f"upload after reboot: {last_line(err)}"
        ok = self.record("boot", ok, detail, time.monotonic() - t0)
        self.ready("ready again")
        return ok

    def round_trip(self, n, tag):
        up = os.path.join(self.b.work, f"rt-{tag}.waypoints")
        back = os.path.join(self.b.work, f"rt-{tag}-back.waypoints")
        mission_file(up, *self.pos, n, self.flies)
        sysid = ["--sysid", str(self.b.sysid), "--wait", "30"]
        code, out, err, t_up = run(["mission", "upload", *self.b.conn(*sysid), up], timeout=1800)
        if code != 0:
            return False, f"upload: {last_line(err)}", t_up, bool(last_line(err))
        code, out, err, t_down = run(["mission", "download", *self.b.conn(*sysid), back], timeout=1800)
        if code != 0:
            return False, f"download: {last_line(err)}", t_up + t_down, bool(last_line(err))
        sent, read = read_wpl(up), read_wpl(back)
        if read != sent:
            return False, ("WRONG MISSION: the list read back differs from the one sent ("
                           + first_difference(sent, read) + ")"), t_up + t_down, False
        return True, last_line(out), t_up + t_down, True

    def transfer(self):
        all_ok = True
        for loss in self.args.losses:
            self.b.set_loss(loss / 100.0, 0.05 if loss > 0 else 0.0)
            results = []
            for i in range(self.args.trials):
                ok, detail, secs, clear = self.round_trip(self.args.items, f"{loss}-{i}")
                results.append((ok, detail, secs, clear))
            n_ok = sum(r[0] for r in results)
            times = sorted(r[2] for r in results if r[0])
            # Up to 30 % every round trip must succeed; beyond, a failure must be a clear error
            # (never a wrong mission, never a hang).
            if loss <= 30:
                ok = n_ok == len(results)
            else:
                ok = all(r[0] or r[3] for r in results)
            failures = "; ".join(r[1] for r in results if not r[0])
            dup = " + 5 % dup" if loss > 0 else ""
            detail = (f"{self.args.items} items, {loss} % loss{dup}: {n_ok}/{len(results)} ok"
                      + (f", {min(times):.0f}–{max(times):.0f} s" if times else "")
                      + (f" — {failures}" if failures else ""))
            all_ok &= self.record(f"transfer {loss}%", ok, detail, sum(r[2] for r in results),
                                  loss=loss, succeeded=n_ok, trials=len(results), round_trip_s=times)
        self.b.set_loss(0.0)
        return all_ok

    def streams(self):
        return link_checks.streams_check(self, self.b.relay_port, self.b.sysid)

    def arming(self):
        return link_checks.arming_check(self, self.b.relay_port, self.b.sysid)

    def fly(self):
        path = os.path.join(self.b.work, "square.waypoints")
        lat, lon = self.pos
        rows = ["QGC WPL 110", "0\t1\t0\t16\t0\t0\t0\t0\t%.7f\t%.7f\t0\t1" % (lat, lon)]
        seq = 1
        if self.flies:
            rows.append("1\t0\t3\t22\t0\t0\t0\t0\t%.7f\t%.7f\t10\t1" % (lat, lon))
            seq = 2
        for n, e in [(20, 0), (20, 20), (0, 20), (0, 0)]:
            a, b = offset(lat, lon, n, e)
            rows.append("%d\t0\t3\t16\t0\t0\t0\t0\t%.7f\t%.7f\t10\t1" % (seq, a, b))
            seq += 1
        # Return to launch, in frame MISSION (2): PX4 refuses it in a global frame.
        rows.append("%d\t0\t2\t20\t0\t0\t0\t0\t0\t0\t0\t1" % seq)
        open(path, "w").write("\n".join(rows) + "\n")
        code, out, err, secs = run(["mission", "fly", *self.b.conn("--sysid", str(self.b.sysid), "--wait", "30"), path],
                                   timeout=900)
        return self.record("fly", code == 0, last_line(out) if code == 0 else last_line(err), secs)

    def files(self):
        """Every mission file of --missions through `mission upload --verify`; --fly N of them
        flown. One line per file, then the table."""
        d = self.args.missions
        if not d or not os.path.isdir(d):
            return self.record("files", False, f"give --missions DIR (a directory of mission files; got {d!r})", 0)
        names = sorted(os.path.relpath(os.path.join(root, f), d)
                       for root, _, fs in os.walk(d) for f in fs
                       if f.lower().endswith((".txt", ".waypoints", ".plan")))
        if not names:
            return self.record("files", False, f"no .txt, .waypoints or .plan file in {d}", 0)
        sysid = ["--sysid", str(self.b.sysid), "--wait", "30"]
        table = []
        for name in names:
            path = os.path.join(d, name)
            code, out, err, secs = run(["mission", "upload", *self.b.conn(*sysid, "--json"), "--verify", path],
                                       timeout=600)
            lines = json_lines(out)
            items = next((o.get("uploaded") for o in lines if "uploaded" in o), None)
            verified = code == 0 and any(o.get("event") == "verified" for o in lines)
            # The first difference or error: fleetmap's last line on stderr ("fleetmap: ...").
            error = "" if verified else fleetmap_error(err, code)
            row = {"file": name, "items": items, "verified": verified, "flown": None, "error": error,
                   "seconds": round(secs, 1)}
            table.append(row)
            self.record(f"file {name}", verified, "verified" if verified else error, secs,
                        items=items, verified=verified)
        flights = 0
        for row in table:
            if flights >= self.args.fly or not row["verified"]:
                continue
            path = os.path.join(d, row["file"])
            first = first_position(path)
            if first is not None and distance_m(first, self.pos) > self.args.fly_radius:
                row["error"] = (f"not flown: its first position is {distance_m(first, self.pos) / 1000:.1f} km "
                                f"from the vehicle (--fly-radius {self.args.fly_radius:.0f} m)")
                continue
            flights += 1
            code, out, err, secs = run(["mission", "fly", *self.b.conn(*sysid), "--timeout",
                                        str(self.args.fly_timeout), path], timeout=self.args.fly_timeout + 60)
            row["flown"] = code == 0
            row["fly_seconds"] = round(secs, 1)
            if code != 0:
                row["error"] = "fly: " + fleetmap_error(err, code)
            self.record(f"fly {row['file']}", code == 0, last_line(out) if code == 0 else row["error"], secs)
        n_ok = sum(r["verified"] for r in table)
        width = max(len(r["file"]) for r in table)
        print(f"\n{'file':<{width}}  items  verified  flown  error")
        for r in table:
            flown = {None: "-", True: "yes", False: "no"}[r["flown"]]
            items = "-" if r["items"] is None else str(r["items"])
            print(f"{r['file']:<{width}}  {items:>5}  {'yes' if r['verified'] else 'no':<8}  {flown:<5}  {r['error']}")
        print(flush=True)
        flown = sum(1 for r in table if r["flown"])
        tried = sum(1 for r in table if r["flown"] is not None)
        # The summary line passes when every file verified and every flight tried landed.
        return self.record("files", n_ok == len(table) and flown == tried,
                           f"{n_ok}/{len(table)} files verified, {flown}/{tried} flown", 0,
                           files=table, verified=n_ok, total=len(table), flown=flown, flights=tried)

    def signing(self):
        key = os.path.join(self.b.work, "team.key")
        t0 = time.monotonic()
        code, _, err, _ = run(["signing", "keygen", "--passphrase", "conformance check", "--out", key], timeout=30)
        if code != 0:
            return self.record("signing", False, f"keygen: {last_line(err)}", 0)
        sysid = ["--sysid", str(self.b.sysid)]
        # Autopilots keep their key while armed (a rover stays armed at home after `fly`).
        run(["command", *self.b.conn(*sysid, "--wait", "10"), "disarm"], timeout=60)
        code, out, err, _ = run(["signing", "setup", *self.b.conn(*sysid, "--json"), "--key", key], timeout=60)
        if code != 0:
            return self.record("signing", False, f"setup: {last_line(err)}", time.monotonic() - t0)
        try:
            confirmed = json.loads(last_line(out)).get("confirmed", False)
        except ValueError:
            confirmed = False
        if not confirmed and not self.ardupilot():
            # PX4 (1.16) has no MAVLink signing: SETUP_SIGNING is ignored, nothing is signed.
            return self.record("signing", True, "n/a: the autopilot does not sign (PX4 has no MAVLink "
                               "signing; SETUP_SIGNING ignored)", time.monotonic() - t0, supported=False)
        # A mode change to a mode the vehicle is not in: unsigned, it must be ignored (no ACK,
        # no change); signed, obeyed.
        v = self.b.vehicle_json(wait=3) or {}
        modes = ("GUIDED", "LOITER") if self.ardupilot() else ("HOLD", "POSCTL")
        mode = modes[1] if v.get("mode") == modes[0] else modes[0]
        code_u, _, err_u, _ = run(["command", *self.b.conn(*sysid, "--wait", "10"), "mode", mode], timeout=60)
        code_s, out_s, err_s, _ = run(["command", *self.b.conn(*sysid, "--wait", "10", "--signing-key", key),
                                       "mode", mode], timeout=60)
        removed, _, err_r, _ = run(["signing", "remove", *self.b.conn(*sysid, "--signing-key", key)], timeout=60)
        ok = code_u != 0 and code_s == 0 and removed == 0
        detail = (f"unsigned: {'ignored' if code_u != 0 else 'OBEYED'}; signed: "
                  f"{last_line(out_s) if code_s == 0 else last_line(err_s)}; "
                  f"key removed: {'yes' if removed == 0 else last_line(err_r)}")
        return self.record("signing", ok, detail, time.monotonic() - t0)


def runway_check(checks):
    """The runway field test with a GCS crash and resume, and battery swaps as power cycles."""
    b, args = checks.b, checks.args
    work = os.path.join(b.work, "runway")
    os.makedirs(work, exist_ok=True)
    run_dir = os.path.join(work, "run")
    world = os.path.abspath(args.world or os.path.join(REPO, "assets", "worlds", "runway.toml"))
    mission = os.path.abspath(args.mission or os.path.join(REPO, "missions", "runway-field-test.toml"))
    t0 = time.monotonic()
    extra = []
    if b.sim is not None:
        # A simulator of its own, over the world, at --runway-speedup (the transfers were judged
        # at real time above); its crew swaps batteries 5 s after a landing.
        ap, _, klass = b.target[4:].partition("-")
        sim, port = serve(
            lambda port: [BIN, "sim", "--vehicles", f"1x{klass}:{ap}", "--world", world,
                          "--connect", f"udpin:127.0.0.1:{port}", "--speedup", str(args.runway_speedup),
                          "--seed", "2", "--swap-after", "5", "--duration", str(int(7200 * args.runway_speedup))],
            os.path.join(work, "sim.log"))
        camera = None
        conn = ["--connect", f"udpout:127.0.0.1:{port}"]
        crew = None
    else:
        if not args.camera_link:
            return checks.record("runway", False, "a real autopilot needs --camera-link (its camera port)", 0)
        sim = None
        camera = Proc([BIN, "sim", "--camera-only", "--world", world, "--connect", args.camera_link,
                       "--image-rate", str(image_rate(args))], os.path.join(work, "camera.log"))
        conn = b.conn()
        crew = True
    log_path = os.path.join(work, "run.log")

    def start(cmd):
        return Proc([BIN, *cmd], log_path + (".resume" if cmd[0] == "resume" else ""))

    def text():
        out = ""
        for p in (log_path, log_path + ".resume"):
            if os.path.exists(p):
                out += open(p, errors="replace").read()
        return out

    def images():
        path = os.path.join(run_dir, "events.jsonl")
        if not os.path.exists(path):
            return 0
        return sum(1 for l in open(path, errors="replace") if '"event":"image"' in l)

    gcs = start(["run", mission, *conn, "--world", world, "--headless", "--run-dir", run_dir, "--auto-resume"])
    killed, swaps, handled = False, 0, 0
    deadline = t0 + args.runway_timeout
    result = None
    try:
        while time.monotonic() < deadline:
            time.sleep(1)
            if not killed and images() >= args.kill_after:
                gcs.stop(signal.SIGKILL)
                killed = True
                time.sleep(2)
                gcs = start(["resume", run_dir, *conn, "--headless", "--auto-resume"])
                continue
            waiting = text().count("waiting for a battery swap")
            if crew and waiting > handled:
                handled = waiting
                swaps += checks.power_cycle(wait=True)[0]
            if gcs.p.poll() is not None:
                result = gcs.p.returncode
                break
    finally:
        gcs.stop(signal.SIGKILL)
        if sim:
            sim.stop()
        if camera:
            camera.stop()
    secs = time.monotonic() - t0
    if result is None:
        return checks.record("runway", False, f"not finished within {args.runway_timeout} s "
                             f"({images()} images); see {work}", secs)
    if result != 0:
        return checks.record("runway", False, f"the run exited {result}: {last_line(text())}", secs)
    code, out, err, _ = run(["report", run_dir, "--world", world, "--json"], timeout=120)
    try:
        rep = json.loads(out)
    except ValueError:
        return checks.record("runway", False, f"report: {last_line(err)}", secs)
    iou, best = rep.get("iou") or 0.0, rep.get("iou_best_possible") or 0.0
    swaps_done = rep.get("battery_swaps", swaps)
    ok = killed and best - iou <= 0.05
    detail = (f"IoU {100 * iou:.1f} % (best possible {100 * best:.1f} %), {rep.get('cells_mapped')} cells, "
              f"{images()} images, GCS killed and resumed: {'yes' if killed else 'NO'}, "
              f"battery swaps {swaps_done}")
    return checks.record("runway", ok, detail, secs, iou=iou, iou_best_possible=best, killed=killed)



# ---------------------------------------------------------------------------------------------
# runway --team: the runway field test on a team of SITL copters

SWAP_WANTED = re.compile(r"vehicle (\d+): landed: waiting for a battery swap")


def image_rate(args):
    """The cameras' --image-rate: --image-rate, else 60 000 B/s, or on a radio (--radio) 30 %
    of its budget (pictures go only when the GCS asks for one)."""
    if args.image_rate:
        return args.image_rate
    return round(0.3 * args.radio) if args.radio else 60000


def world_homes(world, n):
    """(lat, lon) of the world's first `n` homes: vehicle k (k = 0, 1, ...) at the [homes]
    reference plus first + k steps, metres north and east, as `fleetmap sim --vehicles`
    places its vehicles."""
    h = world.get("homes")
    if not h:
        sys.exit("--team: the world has no [homes] table (where the vehicles start)")
    ref = h["reference"]
    return [offset(ref[0], ref[1], h.get("first_north_m", 0.0) + k * h.get("step_north_m", 0.0),
                   h.get("first_east_m", 0.0) + k * h.get("step_east_m", 0.0)) for k in range(n)]


def team_runway_mission(path, n, out, battery_min):
    """The runway mission `path` for a team of `n` drones: the file's own when it lists `n`
    drones, else a variant written to `out` with drones appended as `fleetmap experiment
    runway --drones N` adds them (sysid k, name uavk); with `battery_min`, its
    battery.flight_time_min (the GCS's endurance estimate) set to that. Returns (path, sysids)
    or (None, why)."""
    import tomllib
    text = open(path).read()
    vehicles = tomllib.loads(text).get("vehicles", [])
    if any(v.get("role", "drone") != "drone" for v in vehicles):
        return None, f"{path}: a runway team is drones only"
    if len(vehicles) > n:
        return None, f"--team has {n} drones, the mission {len(vehicles)}"
    sysids = [v["sysid"] for v in vehicles]
    k = 1
    while len(sysids) < n:
        while k in sysids:
            k += 1
        # appended at the end, after every table: the header starts its own entry
        text += f'\n[[vehicles]]\nsysid = {k}\nrole = "drone"\nname = "uav{k}"\n'
        sysids.append(k)
    if battery_min is not None:
        line = f"flight_time_min = {battery_min:g}"
        text, hits = re.subn(r"(?m)^flight_time_min\s*=\s*[-+0-9.eE]+", line, text)
        if hits == 0:
            text, hits = re.subn(r"(?m)^\[battery\][ \t]*(#.*)?$", lambda m: m.group(0) + "\n" + line, text)
        if hits == 0:
            text += f"\n[battery]\n{line}\n"
    if text == open(path).read():
        return path, sysids
    open(out, "w").write(text)
    code, _, err, _ = run(["check", out], timeout=60)
    if code != 0:
        return None, f"the team's mission {out}: {fleetmap_error(err, code)}"
    return out, sysids


def vehicle_clock_rate(tlogs, drones):
    """Vehicle seconds per wall second over the run: the drones' time_boot_ms (in
    GLOBAL_POSITION_INT) against the .tlogs' wall clock, each step between two reports
    counted when the clock went forward (a reboot restarts it), mean over the drones; None
    without reports. The GCS's clock is the wall clock: a SITL at --speedup runs faster."""
    pad = lambda p, k: p + bytes(max(0, k - len(p)))
    rates = []
    for s in drones:
        vehicle = wall = 0.0
        for path in tlogs:
            last = None
            for ts, sysid, compid, msgid, p in mavlink_frames(path):
                if sysid != s or compid != 1 or msgid != 33:
                    continue
                boot = struct.unpack_from("<I", pad(p, 4), 0)[0] / 1000.0
                if last is not None and boot > last[1] and ts - last[0] < 5.0:
                    vehicle += boot - last[1]
                    wall += ts - last[0]
                last = (ts, boot)
        if wall > 0:
            rates.append(vehicle / wall)
    return round(sum(rates) / len(rates), 2) if rates else None


class Gcs:
    """`fleetmap run` or `resume` whose output lines are handed to `on_line` as they come
    (and written to `log`)."""

    def __init__(self, args, log, on_line):
        self.log = open(log, "w")
        self.p = subprocess.Popen([BIN, *args], stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                  errors="replace")
        self.reader = threading.Thread(target=self.read, args=(on_line,), daemon=True)
        self.reader.start()

    def read(self, on_line):
        for line in self.p.stdout:
            self.log.write(line)
            self.log.flush()
            on_line(line.rstrip("\n"))

    def stop(self, sig=signal.SIGINT):
        if self.p.poll() is None:
            self.p.send_signal(sig)
            try:
                self.p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.p.kill()
                self.p.wait()
        self.reader.join(timeout=5)
        self.log.close()


def runway_team_check(checks, work):
    """The runway field test on a team of SITL copters this runner starts (--team, --wiring,
    as bandit-fleet): each drone at the world's home for its place in the mission, batteries
    small enough that the GCS sends drones home for swaps, every swap a power cycle done by
    the crew as soon as the GCS says a drone waits for one, the GCS killed (SIGKILL) once and
    resumed. One row (see the module's docstring)."""
    import tomllib
    args = checks.args
    work = os.path.join(work, "runway-team")
    os.makedirs(work, exist_ok=True)
    world = os.path.abspath(args.world or os.path.join(REPO, "assets", "worlds", "runway.toml"))
    base = os.path.abspath(args.mission or os.path.join(REPO, "missions", "runway-field-test.toml"))
    team = parse_team(args.team)
    if any(FLEET_KINDS[k] != "drone" for k in team):
        return checks.record("runway", False, f"--team {args.team}: the runway team is copters only "
                             "(arducopter, px4)", 0)
    # The GCS's endurance estimate (battery.flight_time_min) below what the SITL batteries
    # below give: 6 minutes by default
    mission, sysids = team_runway_mission(base, len(team), os.path.join(work, "mission.toml"),
                                          args.runway_battery_min or 6.0)
    if mission is None:
        return checks.record("runway", False, sysids, 0)
    world_def = tomllib.load(open(world, "rb"))
    members = [(s, k, home) for s, k, home in zip(sysids, team, world_homes(world_def, len(team)))]
    label = team_label(team)
    wiring = "one port" if args.wiring == "shared" else "one port per vehicle"
    # SITL batteries: ArduPilot's BATT_CAPACITY, PX4 SIH draining to 5 % (its default stops at
    # 50 %, where the GCS would never send it home) in --px4-battery-s seconds of flight
    battery_mah = args.battery_mah or 4000
    px4_battery_s = args.px4_battery_s or 450
    run_dir = os.path.join(work, "run")
    log_path = os.path.join(work, "run.log")
    camera_port = free_udp_port()
    lock = threading.Lock()
    lines = []                      # (wall, line) of every GCS process
    cycles = []                     # (sysid, ok, how, wall seconds it took)
    busy = set()                    # drones being power-cycled
    resumed = set()                 # drones the GCS sent up again since they landed for a swap
    refills = []                    # PX4 drones resumed before their power cycle
    cycle_starts = []               # (sysid, monotonic start) of each power cycle
    crews = []

    def crew(sysid):
        t = time.monotonic()
        with lock:
            refilled = sysid in resumed and fleet.kinds[sysid] == "px4"
        if refilled:
            # PX4 SIH refills its simulated battery when it disarms (battery_simulator): the
            # GCS may see a full battery and take off again before the crew could restart the
            # process; it is not restarted under a drone that is taking off.
            with lock:
                refills.append(sysid)
                busy.discard(sysid)
            print(f"  | crew: vehicle {sysid} resumed before its power cycle (PX4 SIH refills its "
                  "battery at disarm): not restarted", flush=True)
            return
        ok, how = fleet.power_cycle(sysid)
        with lock:
            cycles.append((sysid, ok, how, round(time.monotonic() - t, 1)))
            cycle_starts.append((sysid, t))
            busy.discard(sysid)
        print(f"  | crew: vehicle {sysid} {how} ({'ok' if ok else 'FAILED'})", flush=True)

    def fault_swap(sysid, since):
        """The battery a failsafe brought down swapped, unless the crew above (the GCS asked
        for it) is at it or did it after `since` (monotonic)."""
        with lock:
            if sysid in busy or any(s == sysid and t >= since for s, t in cycle_starts):
                return True, "swapped by the crew when the GCS asked"
            busy.add(sysid)
        t = time.monotonic()
        ok, how = fleet.power_cycle(sysid)
        with lock:
            cycles.append((sysid, ok, how, round(time.monotonic() - t, 1)))
            cycle_starts.append((sysid, t))
            busy.discard(sysid)
        return ok, how

    def on_line(line):
        with lock:
            lines.append((time.time(), line))
        m = re.search(r"vehicle (\d+): fresh battery", line)
        if m:
            with lock:
                resumed.add(int(m.group(1)))
        m = SWAP_WANTED.search(line)
        if m:
            sysid = int(m.group(1))
            with lock:
                resumed.discard(sysid)
                if sysid in busy or sysid not in fleet.kinds:
                    return
                busy.add(sysid)
            t = threading.Thread(target=crew, args=(sysid,), daemon=True)
            crews.append(t)
            t.start()
        if re.search(r"battery swap|fresh battery|map is complete|finished|error|lost", line, re.I):
            print(f"  | {line}", flush=True)

    def images():
        path = os.path.join(run_dir, "events.jsonl")
        if not os.path.exists(path):
            return 0
        return sum(1 for l in open(path, errors="replace") if '"event":"image"' in l)

    t0 = time.monotonic()
    fleet = camera = gcs = None
    killed, result, stopped = False, None, False
    faults = None
    tlogs = [os.path.join(work, "gcs.tlog"), os.path.join(work, "gcs-resume.tlog")]
    try:
        fleet, conns = start_team(args, work, members, world_def.get("ground_alt_amsl_m", 0.0), camera_port,
                                  battery_mah=battery_mah, px4_battery_s=px4_battery_s, px4_min_pct=5)
        # one camera for every copter: renders the world at each capture and sends the
        # picture back through the copter's autopilot (image transmission); on a radio it
        # classifies on board (the mission's definition) and sends its 84-byte result, the
        # picture only when the GCS asks for it
        onboard = ["--mission", mission] if args.radio else []
        camera = Proc([args.camera_bin or BIN, "camera", "--source", "render", "--world", world, *onboard,
                       "--image-rate", str(image_rate(args)), "--connect", f"udpin:127.0.0.1:{camera_port}"],
                      os.path.join(work, "camera.log"))
        faults = FaultCrew(args, fleet, args.faults, fault_swap)
        gcs = Gcs(["run", mission, *conns, "--world", world, "--headless", "--auto-resume", "--run-dir", run_dir,
                   "--tlog", tlogs[0], "--wait", str(args.fleet_wait)], log_path, on_line)
        faults.start()
        deadline = t0 + args.runway_timeout
        while time.monotonic() < deadline:
            time.sleep(1)
            if not killed and images() >= args.kill_after:
                gcs.stop(signal.SIGKILL)
                killed = True
                print(f"  | GCS killed (SIGKILL) after {images()} images; resuming", flush=True)
                time.sleep(2)
                gcs = Gcs(["resume", run_dir, *conns, "--headless", "--auto-resume", "--tlog", tlogs[1],
                           "--wait", str(args.fleet_wait)], log_path + ".resume", on_line)
                continue
            if gcs.p.poll() is not None:
                result = gcs.p.returncode
                break
    except (KeyboardInterrupt, SystemExit):
        stopped = True
    finally:
        if faults:
            faults.close()
        if gcs is not None:
            gcs.stop(signal.SIGINT)
        for t in crews:
            t.join(timeout=60)
        if camera:
            camera.stop()
        if fleet:
            fleet.close()
    secs = time.monotonic() - t0
    radio = radio_figures(work, sysids)
    code, out, err, _ = run(["report", run_dir, "--world", world, "--json"], timeout=120)
    try:
        rep = json.loads(out)
    except ValueError:
        rep = {}
    tl = [tlog_figures(t, sysids, []) for t in tlogs if os.path.exists(t)]
    # the report's mission times are on the GCS's clock (wall seconds); the SITLs' own clock
    # ran this many times faster
    rate = vehicle_clock_rate([t for t in tlogs if os.path.exists(t)], sysids)
    iou, best = rep.get("iou") or 0.0, rep.get("iou_best_possible") or 0.0
    mt = rep.get("mission_time") or {}
    robots = rep.get("robots") or []
    not_landed = [f"{r['sysid']} ({r['status']})" for r in robots if r.get("status") != "landed"]
    cycled_ok = sum(1 for c in cycles if c[1])
    failed_cycles = [f"vehicle {c[0]}: {c[2]}" for c in cycles if not c[1]]
    lost = rep.get("image_failures")
    if stopped:
        error = f"stopped after {secs:.0f} s"
    elif result is None:
        error = f"not finished within {args.runway_timeout} s ({images()} images)"
    elif result != 0:
        error = f"the run exited {result}: {last_line(open(log_path + ('.resume' if killed else '')).read())}"
    elif not rep:
        error = f"report: {last_line(err)}"
    else:
        error = ""
    problems = [p for p in [
        error,
        "" if rep.get("finished") else "the run did not finish",
        "" if killed else "the GCS was never killed",
        "" if best - iou <= 0.01 else f"IoU {100 * (best - iou):.1f} points below the best",
        "" if (rep.get("battery_swaps") or 0) > 0 else "no battery swap",
        "; ".join(failed_cycles),
        "" if lost == 0 else f"{lost} pictures lost",
        "" if not not_landed else "not landed: " + ", ".join(not_landed),
        # no two drones of the team share a system id: a conflict said is a false alarm
        next((f"a system-id conflict was reported: {l[:160]}" for _, l in lines if "ID CONFLICT" in l), ""),
    ] if p]
    ok = not problems
    row = {"team": label, "wiring": wiring, "speedup": args.speedup, "iou": iou, "iou_best_possible": best,
           "battery_swaps": rep.get("battery_swaps"), "power_cycles": cycled_ok,
           "power_cycles_by_vehicle": {s: sum(1 for c in cycles if c[0] == s and c[1]) for s in sysids},
           "resumed_before_power_cycle": {s: refills.count(s) for s in sysids if s in refills},
           "swaps_by_vehicle": {r["sysid"]: r.get("battery_swaps") for r in robots},
           "cells": rep.get("cells_mapped"), "pictures": rep.get("images"), "sweep_pictures": rep.get("sweep_images"),
           "lost_pictures": lost, "pictures_incomplete_in_tlog": sum(f["pictures_lost"] for f in tl),
           "pictures_announced_in_tlog": sum(f["pictures_sent"] for f in tl),
           "lowest_battery_pct": {s: min((f["lowest_battery_pct"].get(s) for f in tl
                                          if f["lowest_battery_pct"].get(s) is not None), default=None)
                                  for s in sysids},
           "killed": killed, "seconds": round(secs, 1), "to_map_complete_s": mt.get("to_map_complete_s"),
           "to_last_landing_s": mt.get("to_last_landing_s"), "vehicle_clock_rate": rate,
           "battery_mah": battery_mah,
           "px4_battery_s": px4_battery_s, "mission": mission, "radio_bps": args.radio,
           "radio_loss": args.radio_loss if args.radio else None, "radio": radio, "problems": problems,
           "faults": [f["spec"] for f in args.faults], "fault_crew": faults.log if faults else [],
           "told": told_lines(lines),
           "result": "pass" if ok else "fail"}
    fmt = lambda x: "-" if x is None else f"{x:.0f}"
    detail = (f"{wiring}, {label}, ×{args.speedup:g}: IoU {100 * iou:.1f} % (best possible {100 * best:.1f} %), "
              f"{row['cells']} cells, {row['pictures']} pictures + {row['sweep_pictures']} sweep, {lost} lost, "
              f"battery swaps {row['battery_swaps']} ({cycled_ok} power cycles: {row['power_cycles_by_vehicle']}"
              + (f"; resumed before the power cycle: {row['resumed_before_power_cycle']}" if refills else "")
              + "), "
              f"GCS killed and resumed: {'yes' if killed else 'NO'}, mission time (GCS clock) to map complete "
              f"{fmt(row['to_map_complete_s'])} s, to last landing {fmt(row['to_last_landing_s'])} s, the "
              f"vehicles' clock ran ×{rate}; "
              + (f"radios {radio_cell(args, radio)}; " if args.radio else "")
              + f"{'; '.join(problems) or 'no problem'}; work {work}")
    cells = [f"{label}, ×{args.speedup:g}", wiring, f"{100 * iou:.1f} % ({100 * best:.1f} %)",
             f"{row['battery_swaps']} ({cycled_ok} power cycles"
             + (f", {len(refills)} resumed before theirs" if refills else "") + ")", str(row["cells"]),
             f"{row['pictures']} + {row['sweep_pictures']}", str(lost), f"{secs:.0f}",
             f"{fmt(row['to_map_complete_s'])} / {fmt(row['to_last_landing_s'])} (vehicles ×{rate})",
             *([radio_cell(args, radio)] if args.radio else []),
             "pass" if ok else "fail: " + "; ".join(problems)]
    print("| " + " | ".join(cells) + " |", flush=True)
    return checks.record("runway", ok, detail, secs, row=row)


# ---------------------------------------------------------------------------------------------
# bandit-fleet: the spatial-classification mission on a team of real autopilots (SITL)

# Team kinds: what each runs as, and what role it can take in the mission.
FLEET_KINDS = {"arducopter": "drone", "px4": "drone", "ardurover": "station"}


def parse_team(spec):
    """`4xarducopter,2xardurover` → ["arducopter"] * 4 + ["ardurover"] * 2 (in order)."""
    team = []
    for part in spec.split(","):
        part = part.strip()
        if not part:
            continue
        n, x, kind = part.partition("x")
        if not x or not n.isdigit():
            n, kind = "1", part
        if kind not in FLEET_KINDS:
            sys.exit(f"--team: unknown kind {kind!r} (arducopter, px4, ardurover)")
        team += [kind] * int(n)
    return team


def cell_centre(origin, cell_m, cell):
    """(lat, lon) of the centre of cell (row, col), from `fleetmap grid to-gps` (the GCS's own
    grid, UTM-aligned)."""
    code, out, err, _ = run(["grid", "--origin", f"{origin[0]},{origin[1]}", "--cell-size", str(cell_m),
                             "to-gps", str(cell[0]), str(cell[1])], timeout=30)
    if code != 0:
        sys.exit(f"fleetmap grid: {last_line(err)}")
    o = json.loads(last_line(out))
    return o["lat"], o["lon"]


def mavlink_frames(path):
    """Every frame of a .tlog as (unix seconds, sysid, compid, msgid, payload); MAVLink 1 and 2,
    payloads as sent (MAVLink 2 trims trailing zeros: pad before unpacking)."""
    try:
        data = open(path, "rb").read()
    except OSError:
        return
    i, n = 0, len(data)
    while i + 8 < n:
        (ts,) = struct.unpack_from(">Q", data, i)
        i += 8
        magic = data[i]
        if magic == 0xFD and i + 10 <= n:
            ln, incompat = data[i + 1], data[i + 2]
            sysid, compid = data[i + 5], data[i + 6]
            msgid = data[i + 7] | data[i + 8] << 8 | data[i + 9] << 16
            payload = data[i + 10:i + 10 + ln]
            i += 12 + ln + (13 if incompat & 1 else 0)
        elif magic == 0xFE and i + 6 <= n:
            ln = data[i + 1]
            sysid, compid, msgid = data[i + 3], data[i + 4], data[i + 5]
            payload = data[i + 6:i + 6 + ln]
            i += 8 + ln
        else:
            return  # not a record boundary: the file is damaged from here
        yield ts / 1e6, sysid, compid, msgid, payload


def tlog_figures(path, drones, epochs):
    """What the autopilots and the camera said during the run, from the GCS's .tlog:
    per epoch (wall-clock spans `epochs` = [(epoch, t0, t1)]) the vehicle time that passed
    (the drones' time_boot_ms) and the drones' time in the air by their own reports
    (EXTENDED_SYS_STATE landed state, else armed in HEARTBEAT), on the vehicle clock; the
    camera's captures, on-board measurements and pictures (image transmission: announced,
    complete); the lowest battery and the charge states each drone reported."""
    pad = lambda p, k: p + bytes(max(0, k - len(p)))
    clock = {s: [] for s in drones}          # sysid → [(wall, time_boot_s)]
    in_air = {s: False for s in drones}
    has_landed_state = set()
    flights = {s: [] for s in drones}        # sysid → [(wall, seconds in the air since last sample)]
    last_boot = {}
    captures, onboard = set(), 0
    pictures = {}                            # (sysid, size) → [packets, set of seqnr]
    current = {}                             # sysid → the picture being received
    requests = 0
    battery = {s: None for s in drones}
    charge_states = {s: set() for s in drones}
    for ts, sysid, compid, msgid, p in mavlink_frames(path):
        if sysid == 255:
            if msgid == 130:  # a GCS asking a camera for a picture again
                requests += 1
            continue
        if msgid == 263 and compid == 100:  # CAMERA_IMAGE_CAPTURED
            time_boot, image_index = struct.unpack_from("<I", pad(p, 255), 8)[0], \
                struct.unpack_from("<i", pad(p, 255), 44)[0]
            captures.add((sysid, time_boot, image_index))
        elif msgid == 350 and compid == 100:  # DEBUG_FLOAT_ARRAY: an on-board measurement
            onboard += 1
        elif msgid == 130 and compid == 100:  # DATA_TRANSMISSION_HANDSHAKE: a picture follows
            size, _, _, packets = struct.unpack_from("<IHHH", pad(p, 13), 0)
            if size > 0 and packets > 0:
                pictures.setdefault((sysid, size), [packets, set()])
                current[sysid] = (sysid, size)
        elif msgid == 131 and sysid in current:  # ENCAPSULATED_DATA
            pictures[current[sysid]][1].add(struct.unpack_from("<H", pad(p, 2), 0)[0])
        if sysid not in clock or compid != 1:
            continue
        if msgid == 0:  # HEARTBEAT
            if sysid not in has_landed_state:
                in_air[sysid] = bool(pad(p, 9)[6] & 128)
        elif msgid == 245:  # EXTENDED_SYS_STATE
            has_landed_state.add(sysid)
            in_air[sysid] = pad(p, 2)[1] in (2, 3, 4)
        elif msgid == 1:  # SYS_STATUS
            pct = struct.unpack_from("<b", pad(p, 31), 30)[0]
            if pct >= 0:
                battery[sysid] = pct if battery[sysid] is None else min(battery[sysid], pct)
        elif msgid == 147:  # BATTERY_STATUS
            charge_states[sysid].add(pad(p, 41)[40])
        elif msgid == 33:  # GLOBAL_POSITION_INT
            boot = struct.unpack_from("<I", pad(p, 4), 0)[0] / 1000.0
            clock[sysid].append((ts, boot))
            if sysid in last_boot and in_air[sysid] and boot > last_boot[sysid]:
                flights[sysid].append((ts, boot - last_boot[sysid]))
            last_boot[sysid] = boot
    per_epoch = []
    for epoch, t0, t1 in epochs:
        spans, air = [], []
        for s in drones:
            c = clock[s]
            walls = [w for w, _ in c]
            a, b = bisect.bisect_left(walls, t0), bisect.bisect_right(walls, t1) - 1
            if 0 <= a < len(c) and a < b:
                spans.append(c[b][1] - c[a][1])
            air.append(sum(d for w, d in flights[s] if t0 <= w <= t1))
        per_epoch.append({"epoch": epoch, "wall_s": round(t1 - t0, 1),
                          "vehicle_s": round(sum(spans) / len(spans), 1) if spans else None,
                          "flight_max_s": round(max(air), 1) if air else None,
                          "flight_total_s": round(sum(air), 1)})
    lost = sum(1 for packets, got in pictures.values() if len(got) < packets)
    return {"per_epoch": per_epoch, "captures": len(captures), "onboard_measurements": onboard,
            "pictures_sent": len(pictures), "pictures_lost": lost, "picture_requests": requests,
            "lowest_battery_pct": battery,
            "charge_states": {s: sorted(v) for s, v in charge_states.items()}}


class Team:
    """A team of SITL autopilots (bandit-fleet, runway with --team), each at the position its
    check gives it: ArduCopter / ArduRover SITL (`--ardupilot DIR`: a build tree with
    build/sitl/bin and Tools/autotest/default_params) with SERIAL0 to the GCS, a copter's
    SERIAL1 to the camera and SERIAL2 a TCP port for the crew; PX4 SIH (`--px4 DIR`: a tree
    with build/px4_sitl_default) with its GCS link to the GCS and its payload link to the
    camera. Every vehicle sends to a GCS UDP port (one for all with `--wiring shared`, one
    each with `per-vehicle`); the GCS listens (udpin). Batteries: ArduPilot BATT_CAPACITY
    `battery_mah`; PX4 SIM_BAT_DRAIN `px4_battery_s` (and SIM_BAT_MIN_PCT `px4_min_pct`
    when given: SIH's default stops the drain at 50 %)."""

    def __init__(self, args, work, members, gcs_ports, camera_port, ground_alt, battery_mah,
                 px4_battery_s, px4_min_pct=None):
        self.procs = {}                 # sysid → Proc
        self.radios = {}                # sysid → its radio's relay (start_team, with --radio)
        self.starts = {}                # sysid → (args, log, cwd, env): to start it again
        self.crew = {}                  # sysid → the crew's connection (ArduPilot SERIAL2)
        self.work = work
        self.args = args
        self.ground_alt = ground_alt    # the world's ground, metres above sea level (homes)
        self.members = members          # [(sysid, kind, (lat, lon))]
        self.battery_mah = battery_mah
        self.px4_battery_s = px4_battery_s
        self.px4_min_pct = px4_min_pct
        self.kinds = {sysid: kind for sysid, kind, _ in members}
        try:
            for i, (sysid, kind, (lat, lon)) in enumerate(members):
                gcs = gcs_ports[i]
                if kind == "px4":
                    self.start_px4(sysid, lat, lon, gcs, camera_port)
                else:
                    self.start_ardupilot(sysid, kind, lat, lon, gcs, camera_port)
        except BaseException:
            self.close()
            raise

    def spawn(self, sysid, cmd, log, cwd, env=None):
        self.starts[sysid] = (cmd, log, cwd, env)
        self.procs[sysid] = Proc(cmd, log, cwd=cwd, env=env)

    def start_ardupilot(self, sysid, kind, lat, lon, gcs, camera):
        root = self.args.ardupilot
        if not root:
            sys.exit("an ArduPilot team member needs --ardupilot DIR (an ArduPilot tree built for SITL)")
        copter = kind == "arducopter"
        binary = os.path.join(root, "build", "sitl", "bin", kind)
        defaults = os.path.join(root, "Tools", "autotest", "default_params",
                                "copter.parm" if copter else "rover.parm")
        for f in (binary, defaults):
            if not os.path.exists(f):
                sys.exit(f"--ardupilot {root}: no {f}")
        d = os.path.join(self.work, f"vehicle{sysid}")
        os.makedirs(d, exist_ok=True)
        extra = os.path.join(d, "fleet.parm")
        # No stream-rate parameters: the GCS asks for what it needs. A copter takes pictures
        # through a MAVLink camera (CAM1_TYPE 1, with CAM2_TYPE 0 beside it: see hitl/README.md).
        lines = [f"MAV_SYSID {sysid}", f"BATT_CAPACITY {self.battery_mah}"]
        if copter:
            lines += ["CAM1_TYPE 1", "CAM2_TYPE 0"]
        if any(f["kind"] == "battery" for f in self.args.faults):
            # the battery failsafe a field team sets: RTL (--fault battery sets it off)
            lines += ["BATT_FS_LOW_ACT 2"]
        open(extra, "w").write("\n".join(lines) + "\n")
        instance = self.args.instance_base + sysid
        cmd = [binary, "--model", "+" if copter else "rover", "--speedup", f"{self.args.speedup:g}",
               "-I", str(instance), "--home", f"{lat:.8f},{lon:.8f},{self.ground_alt},0",
               "--defaults", f"{defaults},{extra}", "--serial0", f"udpclient:127.0.0.1:{gcs}"]
        # SITL's SERIAL1 listens on TCP 5762 + 10 × instance unless told otherwise: a rover's
        # moves to 5761 so that SERIAL2 can take 5762 (a clash stops the SITL at its start)
        cmd += ["--serial1", f"udpclient:127.0.0.1:{camera}" if copter else "tcp:1"]
        # SERIAL2 (MAVLink 2 by default) listens on TCP 5760 + 2 + 10 × instance for the crew.
        cmd += ["--serial2", "tcp:2"]
        self.crew[sysid] = f"tcp:127.0.0.1:{5762 + 10 * instance}"
        self.spawn(sysid, cmd, os.path.join(d, "sitl.log"), d)

    def start_px4(self, sysid, lat, lon, gcs, camera):
        root = self.args.px4
        if not root:
            sys.exit("a PX4 team member needs --px4 DIR (a PX4-Autopilot tree built with make px4_sitl_default)")
        build = os.path.join(root, "build", "px4_sitl_default")
        etc = os.path.join(build, "etc")
        binary = os.path.join(build, "bin", "px4")
        if not os.path.exists(binary):
            sys.exit(f"--px4 {root}: no {binary}")
        instance = self.args.instance_base + sysid
        d = os.path.join(self.work, f"vehicle{sysid}")
        os.makedirs(d, exist_ok=True)
        # Copies of two start-up scripts: the system id (rcS sets instance + 1), the GCS link
        # sent to the GCS's port and the camera (payload) link to the camera's.
        rcs = open(os.path.join(etc, "init.d-posix", "rcS")).read()
        rcs = rcs.replace("param set MAV_SYS_ID $((px4_instance+1))", f"param set MAV_SYS_ID {sysid}")
        rcs = rcs.replace("\n. px4-rc.mavlink\n", f"\n. {d}/px4-rc.mavlink\n")
        links = open(os.path.join(etc, "init.d-posix", "px4-rc.mavlink")).read()
        links = links.replace("mavlink start -x -u $udp_gcs_port_local -r 4000000 -f\n",
                              f"mavlink start -x -u $udp_gcs_port_local -r 4000000 -f -o {gcs}\n")
        links = links.replace("-o $udp_onboard_payload_port_remote", f"-o {camera}")
        if f"MAV_SYS_ID {sysid}" not in rcs or f"-o {gcs}" not in links or f"-o {camera}" not in links:
            sys.exit(f"--px4 {root}: its rcS / px4-rc.mavlink are not the ones this runner knows (v1.16)")
        open(os.path.join(d, "rcS"), "w").write(rcs)
        open(os.path.join(d, "px4-rc.mavlink"), "w").write(links)
        env = dict(os.environ, PX4_SYS_AUTOSTART="10040", PX4_SIMULATOR="sihsim", PX4_SIM_MODEL="quadx",
                   PX4_SIM_SPEED_FACTOR=f"{self.args.px4_speedup or self.args.speedup:g}",
                   PX4_HOME_LAT=f"{lat:.8f}", PX4_HOME_LON=f"{lon:.8f}", PX4_HOME_ALT=str(self.ground_alt),
                   # pictures through a MAVLink camera at each capture item; the battery
                   # (SIH drains to SIM_BAT_MIN_PCT in SIM_BAT_DRAIN seconds while armed)
                   PX4_PARAM_TRIG_MODE="1", PX4_PARAM_TRIG_INTERFACE="3",
                   PX4_PARAM_SIM_BAT_DRAIN=str(self.px4_battery_s))
        if self.px4_min_pct is not None:
            env["PX4_PARAM_SIM_BAT_MIN_PCT"] = f"{self.px4_min_pct:g}"
        self.spawn(sysid, [binary, "-i", str(instance), "-d", "-w", d, "-s", os.path.join(d, "rcS"), etc],
                   os.path.join(d, "px4.log"), d, env)

    def power_cycle(self, sysid):
        """A battery swap on vehicle `sysid` as its crew does it: ArduPilot is rebooted with
        MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN from a second GCS id (250) on its SERIAL2; PX4 SITL
        refuses that command (it cannot restart its own process), so its process is stopped
        and started again in its working directory (parameters and missions kept).
        Returns (ok, how)."""
        if self.kinds.get(sysid) == "px4":
            self.procs[sysid].stop(signal.SIGTERM)
            cmd, log, cwd, env = self.starts[sysid]
            restarts = sum(1 for f in os.listdir(cwd) if f.startswith("px4.log"))
            self.procs[sysid] = Proc(cmd, f"{log}.{restarts}", cwd=cwd, env=env)
            return True, "process restarted"
        code, out, err, _ = run(["command", "--connect", self.crew[sysid], "--gcs-sysid", "250",
                                 "--sysid", str(sysid), "--wait", "30", "reboot"], timeout=180)
        return code == 0, "rebooted" if code == 0 else f"reboot: {fleetmap_error(err, code)}"

    def close(self):
        for p in self.procs.values():
            p.stop(signal.SIGTERM)
        for r in self.radios.values():
            r.stop()  # SIGINT: the relay writes its --stats file


TEAM_NAMES = {"arducopter": "ArduCopter", "ardurover": "ArduRover", "px4": "PX4 SIH"}


def team_label(team):
    """["arducopter"] * 2 + ["px4"] → "2 ArduCopter + 1 PX4 SIH"."""
    return " + ".join(f"{team.count(k)} {TEAM_NAMES[k]}" for k in dict.fromkeys(team))


def start_team(args, work, members, ground_alt, camera_port, battery_mah, px4_battery_s, px4_min_pct=None):
    """Starts the SITL team `members` [(sysid, kind, (lat, lon))] wired as --wiring says: every
    vehicle to one GCS UDP port (shared) or each to its own (per-vehicle). Returns the Team
    and the GCS's --connect arguments (one udpin per port)."""
    if args.wiring == "shared":
        gcs_ports = [free_udp_port()] * len(members)
    else:
        gcs_ports = [free_udp_port() for _ in members]
    radios, vehicle_ports = radio_relays(args, work, members, gcs_ports)
    try:
        team = Team(args, work, members, vehicle_ports, camera_port, ground_alt, battery_mah, px4_battery_s,
                    px4_min_pct)
    except BaseException:
        for r in radios.values():
            r.stop()
        raise
    team.radios = radios
    conns = []
    for p in dict.fromkeys(gcs_ports):
        conns += ["--connect", f"udpin:127.0.0.1:{p}"]
    if args.radio:
        # the GCS plans for the budget (as a mission file's `link = "radio:BYTES"`)
        conns += ["--link", f"radio:{args.radio}"]
    return team, conns


def radio_relays(args, work, members, gcs_ports):
    """With --radio: every vehicle's link (its SERIAL0, PX4's GCS link) through its own
    emulated SiK radio pair, `fleetmap relay --radio BYTES --loss P`, into the GCS port
    `gcs_ports` gives it: whole datagrams, one byte budget for both directions (half duplex),
    a 4 kB buffer each way, RADIO_STATUS as SiK radios write it, the budget counted in the
    vehicle's time (`--clock speedup:N`: a SITL at ×N sends N times the bytes per wall
    second). Each relay writes its counts per message to WORK/radio-SYSID.json when it stops.
    Returns ({sysid: relay Proc}, the ports the vehicles send to); without --radio, ({}, the
    GCS ports themselves)."""
    if not args.radio:
        return {}, list(gcs_ports)
    relays, ports = {}, []
    try:
        for (sysid, kind, _), gcs in zip(members, gcs_ports):
            speedup = (args.px4_speedup or args.speedup) if kind == "px4" else args.speedup
            dark = blackouts_for(args.faults, sysid)
            relays[sysid], port = serve(
                lambda port, gcs=gcs, speedup=speedup, dark=dark, sysid=sysid: [
                    BIN, "relay", "--gcs", f"udpout:127.0.0.1:{gcs}", "--vehicle", f"udpin:127.0.0.1:{port}",
                    "--radio", str(args.radio), "--loss", f"{args.radio_loss:g}", "--clock", f"speedup:{speedup:g}",
                    "--seed", str(sysid), "--report-every", "0",
                    *(["--blackout", dark] if dark else []),
                    "--stats", os.path.join(work, f"radio-{sysid}.json")],
                os.path.join(work, f"radio-{sysid}.log"))
            ports.append(port)
    except BaseException:
        for r in relays.values():
            r.stop()
        raise
    return relays, ports


def radio_figures(work, sysids):
    """What the radios of radio_relays carried, from their --stats files: per vehicle the
    bytes per second delivered each way (vehicle → GCS "down", GCS → vehicle "up", on the
    vehicle's clock), frames lost on the air and dropped on a full buffer; and the means over
    the vehicles. None without radio stats."""
    per = {}
    for s in sysids:
        try:
            st = json.load(open(os.path.join(work, f"radio-{s}.json")))
        except (OSError, ValueError):
            continue
        secs = st["clock_us"] / 1e6
        if secs <= 0:
            continue
        d, u = st["down"], st["up"]
        frames = d["frames_in"] + u["frames_in"]
        per[s] = {"vehicle_s": round(secs, 1), "down_bps": round(d["bytes_out"] / secs),
                  "up_bps": round(u["bytes_out"] / secs), "offered_down_bps": round(d["bytes_in"] / secs),
                  "frames": frames, "lost": d["lost"] + u["lost"],
                  "dropped": d["rate_dropped"] + u["rate_dropped"],
                  "loss": round((d["lost"] + u["lost"]) / frames, 3) if frames else None}
    if not per:
        return None
    mean = lambda k: round(sum(v[k] for v in per.values()) / len(per))
    lost = sum(v["lost"] for v in per.values())
    frames = sum(v["frames"] for v in per.values())
    return {"by_vehicle": per, "down_bps": mean("down_bps"), "up_bps": mean("up_bps"),
            "max_bps": max(v["down_bps"] + v["up_bps"] for v in per.values()),
            "loss": round(lost / frames, 3) if frames else 0.0,
            "dropped": sum(v["dropped"] for v in per.values())}


def radio_cell(args, fig):
    """The radios' column of a row: "2000 B/s, 10 %: 1 512 + 96 B/s a vehicle (at most 1 700),
    10.1 % lost, 0 dropped"."""
    if not args.radio:
        return None
    head = f"{args.radio} B/s, {100 * args.radio_loss:g} %"
    if not fig:
        return head + ": no radio stats"
    return (f"{head}: {fig['down_bps']} + {fig['up_bps']} B/s a vehicle (at most {fig['max_bps']}), "
            f"{100 * fig['loss']:.1f} % lost, {fig['dropped']} dropped")


# ---------------------------------------------------------------------------------------------
# Field faults on a SITL team (--fault, --kill-at): what a field day does to the team checks

FAULT_SPEC = re.compile(r"^(all|\d+):(outage|battery|stuck)@(\d+(?:\.\d+)?)(?:\.\.(\d+(?:\.\d+)?))?$")


def parse_faults(specs):
    """--fault specs → [{"who": "all" | sysid, "kind", "start", "end"}] (seconds of the
    vehicles' clock; `end` None for an instant or for ever). Raises ValueError with the spec.
      K|all:outage@START..END  the vehicle's radio (or every one) carries nothing either way
                               from START to END, counted from the radios' start (a second or
                               two before the GCS's); needs --radio
      K:battery@T              T after vehicle K first armed, its battery failsafe fires (the
                               crew sets BATT_LOW_MAH above what is left; BATT_FS_LOW_ACT 2,
                               RTL, on every ArduPilot of the team): the autopilot returns by
                               itself; once it is down the crew swaps the battery (power cycle)
      K:stuck@START[..END]     from START after rover K first armed (to END, or for ever) its
                               throttle is held at neutral (SERVO3_MIN = SERVO3_MAX = 1500): it
                               stays in its mission and goes nowhere, a rover bogged down"""
    out = []
    for spec in specs or []:
        m = FAULT_SPEC.match(spec.strip())
        if not m:
            raise ValueError(f"--fault {spec!r}: expected K|all:outage@START..END, K:battery@T or "
                             "K:stuck@START[..END] (seconds of the vehicles' clock)")
        who = m.group(1) if m.group(1) == "all" else int(m.group(1))
        kind, start = m.group(2), float(m.group(3))
        end = float(m.group(4)) if m.group(4) else None
        if kind == "outage" and end is None:
            raise ValueError(f"--fault {spec!r}: an outage needs START..END")
        if kind != "outage" and who == "all":
            raise ValueError(f"--fault {spec!r}: a {kind} fault names one vehicle")
        if end is not None and end <= start:
            raise ValueError(f"--fault {spec!r}: END before START")
        out.append({"who": who, "kind": kind, "start": start, "end": end, "spec": spec.strip()})
    return out


def blackouts_for(faults, sysid):
    """The relay's --blackout windows for `sysid` (START+DURATION, comma separated), or None."""
    w = [f"{f['start']:g}+{f['end'] - f['start']:g}" for f in faults
         if f["kind"] == "outage" and f["who"] in ("all", sysid)]
    return ",".join(w) or None


class Crew:
    """A second GCS (system id 250) on one ArduPilot's SERIAL2 (TCP: one client at a time, so
    it is opened for each step and closed again), through pymavlink: what the field crew
    does to a vehicle by hand, set a parameter, watch its heartbeat."""

    def __init__(self, conn, sysid):
        self.conn, self.sysid = conn, sysid

    def _open(self):
        try:
            from pymavlink import mavutil
        except ImportError:
            sys.exit("--fault battery / stuck need pymavlink (make's .venv: run with .venv/bin/python)")
        return mavutil, mavutil.mavlink_connection(self.conn, source_system=250, source_component=190)

    def set_param(self, name, value, tries=5):
        """PARAM_SET until PARAM_VALUE echoes `value`. Returns the value read back or None."""
        mavutil, m = self._open()
        try:
            for _ in range(tries):
                m.mav.param_set_send(self.sysid, 1, name.encode(), float(value),
                                     mavutil.mavlink.MAV_PARAM_TYPE_REAL32)
                end = time.monotonic() + 3
                while time.monotonic() < end:
                    msg = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
                    if msg and msg.get_srcSystem() == self.sysid and msg.param_id == name \
                            and abs(msg.param_value - float(value)) < 1e-3:
                        return msg.param_value
        finally:
            m.close()
        return None

    def get_param(self, name):
        mavutil, m = self._open()
        try:
            for _ in range(5):
                m.mav.param_request_read_send(self.sysid, 1, name.encode(), -1)
                msg = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=2)
                if msg and msg.get_srcSystem() == self.sysid and msg.param_id == name:
                    return msg.param_value
        finally:
            m.close()
        return None

    def wait_heartbeat(self, test, timeout, stop):
        """Wait (wall seconds) until `test(armed, mode)` holds for the autopilot's heartbeat;
        returns (armed, mode) then, or None on timeout or when `stop` is set."""
        mavutil, m = self._open()
        try:
            end = time.monotonic() + timeout
            while time.monotonic() < end and not stop.is_set():
                msg = m.recv_match(type="HEARTBEAT", blocking=True, timeout=1)
                if not msg or msg.get_srcSystem() != self.sysid or msg.get_srcComponent() != 1:
                    continue
                armed = bool(msg.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
                mode = mavutil.mode_string_v10(msg)
                if test(armed, mode):
                    return armed, mode
        finally:
            m.close()
        return None


class FaultCrew:
    """Plays --fault's battery and stuck faults on a running SITL team (outages are the radio
    relays' --blackout): one thread per fault, each logging what it did with the vehicles'
    clock (wall × speedup since the GCS started). `power_cycle(sysid, since)` is the team's
    swap (`since`: when the failsafe was set off, monotonic), returning (ok, how)."""

    def __init__(self, args, team, faults, power_cycle):
        self.args, self.team, self.power_cycle = args, team, power_cycle
        self.faults = [f for f in faults if f["kind"] in ("battery", "stuck")]
        self.stop = threading.Event()
        self.log = []                   # (vehicle seconds since the GCS's start, sysid, what)
        self.threads = []
        self.t0 = time.monotonic()
        for f in self.faults:
            if self.team.kinds.get(f["who"]) not in ("arducopter", "ardurover"):
                sys.exit(f"--fault {f['spec']}: vehicle {f['who']} is not an ArduPilot of the team")
            if f["kind"] == "stuck" and self.team.kinds[f["who"]] != "ardurover":
                sys.exit(f"--fault {f['spec']}: only a rover gets stuck")

    def start(self):
        self.t0 = time.monotonic()
        for f in self.faults:
            t = threading.Thread(target=self.play, args=(f,), daemon=True)
            self.threads.append(t)
            t.start()

    def now(self):
        return round((time.monotonic() - self.t0) * self.args.speedup, 1)

    def say(self, sysid, what):
        self.log.append((self.now(), sysid, what))
        print(f"  | fault crew, t={self.now():.0f} s (vehicles' clock): vehicle {sysid}: {what}", flush=True)

    def sleep_vehicle(self, secs):
        return not self.stop.wait(secs / self.args.speedup)

    def play(self, f):
        sysid = f["who"]
        crew = Crew(self.team.crew[sysid], sysid)
        try:
            if crew.wait_heartbeat(lambda armed, _m: armed, 3600, self.stop) is None:
                return
            self.say(sysid, "armed")
            if not self.sleep_vehicle(f["start"]):
                return
            if f["kind"] == "battery":
                self.battery(crew, sysid)
            else:
                self.stuck(crew, sysid, f)
        except Exception as e:  # the row says it; the run goes on
            self.say(sysid, f"the crew failed: {e!r}")

    def battery(self, crew, sysid):
        cap = crew.get_param("BATT_CAPACITY") or self.team.battery_mah
        if crew.set_param("BATT_LOW_MAH", cap - 1) is None:
            self.say(sysid, "BATT_LOW_MAH not taken")
            return
        since = time.monotonic()
        self.say(sysid, f"battery failsafe set off (BATT_LOW_MAH {cap - 1:.0f} of {cap:.0f} mAh)")
        got = crew.wait_heartbeat(lambda _a, mode: mode in ("RTL", "LAND", "SMART_RTL"), 120, self.stop)
        self.say(sysid, f"its autopilot switched to {got[1]}" if got else "no failsafe mode seen in 120 s")
        # the failsafe holds until the next boot; the crew puts the parameter back at once
        crew.set_param("BATT_LOW_MAH", 0)
        if crew.wait_heartbeat(lambda armed, _m: not armed, 1800, self.stop) is None:
            return
        self.say(sysid, "down and disarmed")
        if self.sleep_vehicle(20):
            ok, how = self.power_cycle(sysid, since)
            self.say(sysid, f"battery swapped: {how}" if ok else f"battery swap failed: {how}")

    def stuck(self, crew, sysid, f):
        low, high = crew.get_param("SERVO3_MIN"), crew.get_param("SERVO3_MAX")
        trim = crew.get_param("SERVO3_TRIM") or 1500
        if low is None or high is None:
            self.say(sysid, "SERVO3_MIN / SERVO3_MAX not read")
            return
        if crew.set_param("SERVO3_MIN", trim) is None or crew.set_param("SERVO3_MAX", trim) is None:
            self.say(sysid, "SERVO3 limits not taken")
            return
        self.say(sysid, f"stuck: throttle held at {trim:.0f} µs (was {low:.0f}–{high:.0f})")
        if f["end"] is None or not self.sleep_vehicle(f["end"] - f["start"]):
            return
        crew.set_param("SERVO3_MIN", low)
        crew.set_param("SERVO3_MAX", high)
        self.say(sysid, "free again")

    def close(self):
        self.stop.set()
        for t in self.threads:
            t.join(timeout=30)


def told_lines(lines, limit=40):
    """The GCS's lines an operator would read about faults (warnings naming a vehicle)."""
    pat = re.compile(r"out of its mission|ready again|stuck|LINK LOST|link back|not heard|failsafe|"
                     r"battery swap|flying it to station|CAMERA|waiting for pictures|no measurement|"
                     r"ID CONFLICT|resum", re.I)
    # the progress lines ("[  12.3 s] …"), not the log's copy of the same warning
    return [l for _, l in lines if pat.search(l) and "\x1b[" not in l][:limit]


def bandit_fleet_check(checks, work):
    """The spatial-classification mission on a team of SITL autopilots with the camera
    process and `fleetmap run`, to its end: one row (see the module's docstring)."""
    import tomllib  # Python 3.11; only this check reads TOML
    args = checks.args
    work = os.path.join(work, "bandit-fleet")
    os.makedirs(work, exist_ok=True)
    mission = os.path.abspath(args.mission or os.path.join(REPO, "missions", "hardware-6x6.toml"))
    world = os.path.abspath(args.world or os.path.join(REPO, "assets", "worlds", "hardware-6x6.toml"))
    definition = tomllib.load(open(mission, "rb"))
    ground_alt = tomllib.load(open(world, "rb")).get("ground_alt_amsl_m", 0.0)
    team = parse_team(args.team or "4xarducopter,2xardurover")
    vehicles = definition.get("vehicles", [])
    if len(team) != len(vehicles):
        return checks.record("bandit-fleet", False, f"--team has {len(team)} vehicles, the mission "
                             f"{len(vehicles)}", 0)
    origin = definition["grid"]["origin"]
    origin = (origin["lat"], origin["lon"])
    members = []
    for kind, v in zip(team, vehicles):
        role = v.get("role", "drone")
        if FLEET_KINDS[kind] != role:
            return checks.record("bandit-fleet", False, f"--team: vehicle {v['sysid']} is a {role} in the "
                                 f"mission, not a {kind}", 0)
        members.append((v["sysid"], kind, cell_centre(origin, definition["grid"]["cell_size_m"], v["start"])))
    drones = [s for s, k, _ in members if FLEET_KINDS[k] == "drone"]
    label = team_label(team)
    shared = args.wiring == "shared"
    camera_port = free_udp_port()
    run_dir = os.path.join(work, "run")
    tlog = os.path.join(work, "gcs.tlog")
    t0 = time.monotonic()
    fleet = camera = gcs = None
    lines = []  # (unix time, line) of the GCS's output

    def on_line(line):
        lines.append((time.time(), line))
        if re.search(r"epoch \d+ done|every cell classified|run finished", line) or told_lines([(0, line)]):
            print(f"  | {line}", flush=True)

    result, stopped, killed = None, False, None
    crew = None
    tlogs = [tlog, os.path.join(work, "gcs-resume.tlog")]
    logs = [os.path.join(work, "run.log"), os.path.join(work, "run.log.resume")]
    try:
        fleet, conns = start_team(args, work, members, ground_alt, camera_port,
                                  battery_mah=args.battery_mah or 30000,
                                  px4_battery_s=args.px4_battery_s or 7200)
        # The camera measures on board (the mission's definition) and sends 52 bytes a picture;
        # with --camera-pictures it pushes every picture instead (image transmission).
        measure = [] if args.camera_pictures else ["--mission", mission]
        camera = Proc([args.camera_bin or BIN, "camera", "--source", "render", "--world", world, *measure,
                       "--image-rate", str(image_rate(args)), "--connect", f"udpin:127.0.0.1:{camera_port}"],
                      os.path.join(work, "camera.log"))
        crew = FaultCrew(args, fleet, args.faults, lambda sysid, _since: fleet.power_cycle(sysid))
        gcs = Gcs(["run", mission, *conns, "--world", world, "--headless", "--auto-resume",
                   "--run-dir", run_dir, "--tlog", tlogs[0], "--wait", str(args.fleet_wait)], logs[0], on_line)
        crew.start()
        deadline = time.monotonic() + args.fleet_timeout
        try:
            while time.monotonic() < deadline:
                time.sleep(0.5)
                if killed is None and args.kill_at is not None and crew.now() >= args.kill_at:
                    # the laptop dies (SIGKILL: nothing more written), and `fleetmap resume`
                    gcs.stop(signal.SIGKILL)
                    killed = crew.now()
                    print(f"  | GCS killed (SIGKILL) at t={killed:.0f} s (vehicles' clock); resuming", flush=True)
                    time.sleep(2)
                    gcs = Gcs(["resume", run_dir, *conns, "--headless", "--auto-resume", "--tlog", tlogs[1],
                               "--wait", str(args.fleet_wait)], logs[1], on_line)
                    continue
                if gcs.p.poll() is not None:
                    result = gcs.p.returncode
                    break
        except (KeyboardInterrupt, SystemExit):
            # stopped (Ctrl-C, SIGTERM): the row still says how far the run got
            result, stopped = None, True
    finally:
        if crew:
            crew.close()
        if gcs is not None:
            gcs.stop(signal.SIGINT)
        if camera:
            camera.stop()
        if fleet:
            fleet.close()
    secs = time.monotonic() - t0
    radio = radio_figures(work, [s for s, _, _ in members])
    # The epochs' wall-clock spans, from the GCS's progress lines.
    starts, ends = {}, {}
    for t, line in lines:
        m = re.search(r"\] epoch (\d+): goals", line)
        if m:
            starts.setdefault(int(m.group(1)), t)
        m = re.search(r"\] epoch (\d+) done:", line)
        if m:
            ends[int(m.group(1))] = t
    spans = [(e, starts[e], ends[e]) for e in sorted(ends) if e in starts]
    figures = tlog_figures(tlog, drones, spans)
    if killed is not None and os.path.exists(tlogs[1]):
        # the epochs after the kill are in the resumed GCS's .tlog
        # (an epoch the kill cut in two: the vehicle time and flights of both halves)
        later = tlog_figures(tlogs[1], drones, spans)
        add = lambda x, y: None if x is None and y is None else (x or 0) + (y or 0)
        for e, f in zip(figures["per_epoch"], later["per_epoch"]):
            e["vehicle_s"] = add(e["vehicle_s"], f["vehicle_s"])
            e["flight_max_s"] = max(e["flight_max_s"] or 0, f["flight_max_s"] or 0)
            e["flight_total_s"] = add(e["flight_total_s"], f["flight_total_s"])
        for k in ("pictures_sent", "pictures_lost", "onboard_measurements", "captures"):
            figures[k] += later[k]
    row = {"wiring": "one port" if shared else "one port per vehicle", "team": label,
           "camera": "pictures" if args.camera_pictures else "on board",
           "speedup": args.speedup, "seconds": round(secs, 1), "exit": result, "radio_bps": args.radio,
           "faults": [f["spec"] for f in args.faults], "killed_at_vehicle_s": killed,
           "fault_crew": crew.log if crew else [], "told": told_lines(lines),
           "radio_loss": args.radio_loss if args.radio else None, "radio": radio, **figures}
    code, out, err, _ = run(["report", run_dir, "--world", world, "--json"], timeout=120)
    try:
        rep = json.loads(out)
    except ValueError:
        rep = {}
    keep = sorted(map(tuple, rep.get("keep", [])))
    truth = sorted(map(tuple, rep.get("interesting_truth", [])))
    row.update(epochs=rep.get("epochs"), samples=rep.get("measurements"), keep=keep,
               reject=len(rep.get("reject", [])), unclassified=len(rep.get("unclassified", [])),
               labelling_errors=len(rep.get("errors", [])), fleetmap_flight_s_per_epoch=[
                   round(x, 1) for x in rep.get("flight_seconds_per_epoch", [])])
    if stopped:
        error = f"stopped after {secs:.0f} s"
    elif result is None:
        error = f"not finished within {args.fleet_timeout} s"
    elif result != 0:
        error = f"the run exited {result}: " + last_line(open(logs[1 if killed is not None else 0],
                                                              errors="replace").read())
    elif not rep:
        error = f"report: {last_line(err)}"
    else:
        error = ""
    # no two members of the team share a system id: a conflict said is a false alarm
    conflicts = [l for _, l in lines if "ID CONFLICT" in l]
    if conflicts and not error:
        error = f"a system-id conflict was reported: {conflicts[0][:160]}"
    ok = (not error and rep.get("finished") and keep == truth and row["unclassified"] == 0
          and row["labelling_errors"] == 0)
    row["error"] = error
    row["result"] = "pass" if ok else "fail"
    epochs = "; ".join(
        f"{e['wall_s']:.0f} s ({e['vehicle_s']:.0f} s vehicle, flight {e['flight_max_s']:.0f} s)"
        if e["vehicle_s"] is not None else f"{e['wall_s']:.0f} s" for e in figures["per_epoch"])
    detail = (f"{row['wiring']}, {label}, ×{args.speedup:g}: {row['epochs']} epoch(s), "
              f"{row['samples']} samples, pictures {figures['pictures_sent']}/{figures['pictures_lost']} "
              f"sent/lost ({figures['onboard_measurements']} measured on board of {figures['captures']} "
              f"captures); per epoch {epochs or '-'}; keep {len(keep)} reject {row['reject']} unclassified "
              f"{row['unclassified']}; errors: {error or 'none'}, {row['labelling_errors']} labelling; "
              + (f"radios {radio_cell(args, radio)}; " if args.radio else "") + f"work {work}")
    # The row as docs/results/conformance.md tabulates it.
    per = figures["per_epoch"]
    cells = [row["wiring"], f"{label}, ×{args.speedup:g}", str(row["epochs"]), str(row["samples"]),
             f"{figures['pictures_sent']} / {figures['pictures_lost']}",
             ", ".join(f"{e['wall_s']:.0f} ({e['vehicle_s']:.0f})" if e["vehicle_s"] is not None
                       else f"{e['wall_s']:.0f}" for e in per) or "-",
             ", ".join(f"{e['flight_max_s']:.0f}" for e in per) or "-",
             f"{len(keep)} / {row['reject']} / {row['unclassified']}",
             error or f"none ({row['labelling_errors']} labelling)",
             *([radio_cell(args, radio)] if args.radio else []), row["result"]]
    print("| " + " | ".join(cells) + " |", flush=True)
    return checks.record("bandit-fleet", bool(ok), detail, secs, row=row)


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("target", nargs="?",
                    help="sim:ardupilot-copter | sim:ardupilot-rover | sim:px4-copter | a connection string "
                         "(none for --checks bandit-fleet or runway with --team: they start their own team)")
    ap.add_argument("--sysid", type=int, default=1)
    ap.add_argument("--checks", default="ready,boot,transfer,fly,signing")
    ap.add_argument("--items", type=int, default=100, help="mission items per round trip")
    ap.add_argument("--trials", type=int, default=3, help="round trips per loss level")
    ap.add_argument("--losses", default="0,30,50", help="loss levels, percent each way")
    ap.add_argument("--speedup", type=float, default=1.0,
                    help="simulator speed (sim: targets), the SITLs' --speedup (bandit-fleet, runway --team)")
    ap.add_argument("--world", help="runway, bandit-fleet checks: the simulated world "
                    "(default: assets/worlds/runway.toml, hardware-6x6.toml)")
    ap.add_argument("--mission", help="runway, bandit-fleet checks: the mission file "
                    "(default: missions/runway-field-test.toml, hardware-6x6.toml)")
    ap.add_argument("--camera-link", help="runway check on a real autopilot: where its camera port sends")
    ap.add_argument("--image-rate", type=int,
                    help="runway, bandit-fleet: camera bytes per second (default 60000; with --radio 30 %% of it)")
    ap.add_argument("--runway-speedup", type=float, default=10.0, help="runway check on a simulator: its speed")
    ap.add_argument("--kill-after", type=int, default=60, help="runway check: kill the GCS after this many images")
    ap.add_argument("--runway-timeout", type=int, default=7200, help="runway check: seconds")
    ap.add_argument("--runway-battery-min", type=float, metavar="MIN",
                    help="runway --team: the mission's battery.flight_time_min (the GCS's endurance "
                         "estimate), written to the team's mission variant (default: the mission's)")
    ap.add_argument("--missions", metavar="DIR", help="files check: a directory of mission files")
    ap.add_argument("--fly", type=int, default=0, metavar="N", help="files check: fly the first N verified files")
    ap.add_argument("--fly-radius", type=float, default=2000.0, metavar="METRES",
                    help="files check: fly only files whose first position is this close to the vehicle")
    ap.add_argument("--fly-timeout", type=int, default=900, help="files check: seconds per flight")
    ap.add_argument("--team",
                    help="bandit-fleet: the autopilots, in the order of the mission's vehicles "
                         "(arducopter, px4 drones; ardurover stations; default 4xarducopter,2xardurover), "
                         "e.g. 2xpx4,2xarducopter,2xardurover; runway without a target: the copters to "
                         "start (e.g. 3xarducopter, 2xarducopter,1xpx4)")
    ap.add_argument("--wiring", choices=["shared", "per-vehicle"], default="shared",
                    help="bandit-fleet, runway --team: every vehicle to one GCS UDP port, or one port (and "
                         "--connect) each")
    ap.add_argument("--ardupilot", metavar="DIR",
                    help="bandit-fleet: an ArduPilot tree built for SITL (build/sitl/bin/arducopter, "
                         "ardurover; Tools/autotest/default_params)")
    ap.add_argument("--px4", metavar="DIR",
                    help="bandit-fleet: a PX4-Autopilot tree built with make px4_sitl_default (SIH)")
    ap.add_argument("--px4-speedup", type=float, help="bandit-fleet: PX4 SIH's speed (default --speedup)")
    ap.add_argument("--battery-mah", type=int,
                    help="bandit-fleet, runway --team: ArduPilot BATT_CAPACITY (a SITL battery never "
                         "charges; default 30000 for bandit-fleet, 4000 for runway: swaps)")
    ap.add_argument("--px4-battery-s", type=int,
                    help="bandit-fleet, runway --team: PX4 SIM_BAT_DRAIN, seconds of flight from full to "
                         "empty (default 7200 for bandit-fleet, 450 for runway: swaps)")
    ap.add_argument("--instance-base", type=int, default=20,
                    help="bandit-fleet: SITL instance = this + system id (ports, working files)")
    ap.add_argument("--camera-pictures", action="store_true",
                    help="bandit-fleet: the camera sends every picture (image transmission, --image-rate) "
                         "instead of measuring on board")
    ap.add_argument("--camera-bin", metavar="PATH",
                    help="bandit-fleet: the fleetmap binary that plays the camera (default: $FLEETMAP)")
    ap.add_argument("--fleet-wait", type=int, default=180,
                    help="bandit-fleet: the GCS waits this long for every vehicle (`run --wait`)")
    ap.add_argument("--fleet-timeout", type=int, default=7200, help="bandit-fleet: seconds")
    ap.add_argument("--power-cycle", metavar="CMD",
                    help="shell command that power-cycles the vehicle (default: MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN)")
    ap.add_argument("--radio", type=int, metavar="BYTES",
                    help="bandit-fleet, runway --team: every vehicle's link through its own emulated SiK "
                         "radio (`fleetmap relay --radio BYTES`, half duplex, 4 kB buffers, the budget in "
                         "the vehicles' time) into the GCS port; the GCS gets --link radio:BYTES, runway "
                         "cameras classify on board (default: no radio)")
    ap.add_argument("--radio-loss", type=float, default=0.0, metavar="P",
                    help="with --radio: the share of frames each radio loses, each way (e.g. 0.1)")
    ap.add_argument("--fault", action="append", default=[], metavar="SPEC",
                    help="bandit-fleet, runway --team: a field fault, K|all:outage@START..END (needs --radio), "
                         "K:battery@T or K:stuck@START[..END], seconds of the vehicles' clock (see "
                         "'Field faults' in the module's docstring); may be given several times")
    ap.add_argument("--kill-at", type=float, metavar="SECONDS",
                    help="bandit-fleet: kill the GCS (SIGKILL) this long after its start (vehicles' clock) "
                         "and resume the run")
    ap.add_argument("--json", help="write the results here")
    ap.add_argument("--keep", action="store_true", help="keep the working directory")
    args = ap.parse_args()
    try:
        args.faults = parse_faults(args.fault)
    except ValueError as e:
        sys.exit(str(e))
    if any(f["kind"] == "outage" for f in args.faults) and not args.radio:
        sys.exit("--fault …:outage needs --radio (the radio relays black the link out)")
    # A runner stopped with SIGTERM (or Ctrl-C) still stops what it started (the finally below).
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    args.losses = [int(x) for x in args.losses.split(",") if x.strip()]
    order = [c.strip() for c in args.checks.split(",") if c.strip()]
    own = ("runway", "bandit-fleet")
    unknown = [c for c in order if c not in own and (not hasattr(Checks, c) or c.startswith("_"))]
    if unknown:
        sys.exit(f"unknown check(s): {', '.join(unknown)}")
    # bandit-fleet, and runway with --team and no target, start their own team: a target is
    # needed only for the other checks.
    team_runway = "runway" in order and args.team and not args.target
    if not args.team and "bandit-fleet" in order:
        args.team = "4xarducopter,2xardurover"
    needs_target = any(c != "bandit-fleet" and not (c == "runway" and team_runway) for c in order)
    if needs_target and not args.target:
        sys.exit("give a target (sim:ardupilot-copter, a connection string), or only --checks bandit-fleet "
                 "or runway with --team")
    work = tempfile.mkdtemp(prefix="fleetmap-conformance.")
    bench = Bench(args.target, args.sysid, work, args.speedup) if needs_target else None
    checks = Checks(bench, args)
    if bench:
        print(f"conformance: {args.target} (system {args.sysid}), fleetmap {BIN}, work {work}", flush=True)
    else:
        print(f"conformance: team {args.team}, wiring {args.wiring}, fleetmap {BIN}, work {work}", flush=True)
    try:
        if bench and order and order[0] != "ready":
            checks.ready()
        for c in order:
            if c == "runway":
                if bench:
                    runway_check(checks)
                else:
                    runway_team_check(checks, work)
            elif c == "bandit-fleet":
                bandit_fleet_check(checks, work)
            else:
                getattr(checks, c)()
    finally:
        if bench:
            bench.close()
    ok = all(r["pass"] for r in checks.results)
    report = {"target": args.target, "autopilot": bench.autopilot if bench else args.team,
              "sysid": args.sysid, "pass": ok, "checks": checks.results, "work": work}
    if args.json:
        with open(args.json, "w") as f:
            json.dump(report, f, indent=1)
    if ok and not args.keep:
        shutil.rmtree(work, ignore_errors=True)
    print(f"conformance: {'PASS' if ok else 'FAIL'} ({sum(r['pass'] for r in checks.results)}/{len(checks.results)} checks)")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
