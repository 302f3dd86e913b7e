"""A .tlog written by fleetmap is read by pymavlink's mavlogdump.py without errors.

A pymavlink endpoint plays the vehicle (ArduCopter heartbeats, a position, a status text)
on a UDP port; `fleetmap vehicles --connect udpout:... --tlog FILE` talks to it; then
mavlogdump.py dumps the file and must see both directions (our GCS heartbeats from system
255 and the vehicle's messages) with no parse errors.
"""

import os
import shutil
import socket
import subprocess
import sys
import threading
import time

import pytest
from pymavlink import mavutil

FLEETMAP = os.environ.get("FLEETMAP_BIN", "fleetmap")


def free_udp_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def mavlogdump():
    exe = shutil.which("mavlogdump.py")
    if exe is None:
        exe = os.path.join(os.path.dirname(sys.executable), "mavlogdump.py")
    return exe


def vehicle(port, stop, seen):
    os.environ["MAVLINK20"] = "1"
    m = mavutil.mavlink_connection(
        "udpin:127.0.0.1:%d" % port, source_system=1, source_component=1, dialect="ardupilotmega"
    )
    t0 = time.time()
    while not stop.is_set():
        m.mav.heartbeat_send(
            mavutil.mavlink.MAV_TYPE_QUADROTOR,
            mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
            mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            4,
            mavutil.mavlink.MAV_STATE_STANDBY,
        )
        m.mav.global_position_int_send(
            int((time.time() - t0) * 1000), 371950000, -805800000, 600000, 0, 0, 0, 0, 9000
        )
        m.mav.statustext_send(mavutil.mavlink.MAV_SEVERITY_INFO, b"fleetmap tlog test")
        deadline = time.time() + 0.2
        while time.time() < deadline:
            msg = m.recv_match(blocking=True, timeout=0.05)
            if msg is not None:
                seen.append(msg.get_type())


def test_mavlogdump_reads_fleetmap_tlog(tmp_path):
    port = free_udp_port()
    stop = threading.Event()
    seen = []
    th = threading.Thread(target=vehicle, args=(port, stop, seen), daemon=True)
    th.start()
    tlog = tmp_path / "flight.tlog"
    try:
        out = subprocess.run(
            [
                FLEETMAP,
                "vehicles",
                "--connect",
                "udpout:127.0.0.1:%d" % port,
                "--wait",
                "3",
                "--tlog",
                str(tlog),
                "--json",
            ],
            capture_output=True,
            text=True,
            timeout=30,
        )
    finally:
        stop.set()
        th.join(timeout=5)
    assert out.returncode == 0, out.stderr
    assert '"sysid": 1' in out.stdout
    assert "HEARTBEAT" in seen, "the vehicle heard the GCS"
    assert tlog.stat().st_size > 0

    dump = subprocess.run(
        [sys.executable, mavlogdump(), str(tlog)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert dump.returncode == 0, dump.stderr
    assert "Traceback" not in dump.stderr
    lines = dump.stdout.splitlines()
    gcs_beats = [l for l in lines if "HEARTBEAT {type : 6," in l]
    assert gcs_beats, lines[:20]
    assert any("GLOBAL_POSITION_INT" in l for l in lines)
    assert any("fleetmap tlog test" in l for l in lines)
    assert not any("BAD_DATA" in l for l in lines), [l for l in lines if "BAD_DATA" in l][:5]

    # The timestamps are microseconds since the epoch, in order, around now.
    m = mavutil.mavlink_connection(str(tlog))
    stamps = []
    types = set()
    while True:
        msg = m.recv_match()
        if msg is None:
            break
        stamps.append(msg._timestamp)
        types.add((msg.get_srcSystem(), msg.get_type()))
    assert (255, "HEARTBEAT") in types and (1, "HEARTBEAT") in types
    now = time.time()
    assert all(now - 120 < t <= now + 1 for t in stamps)
    assert stamps == sorted(stamps) or max(a - b for a, b in zip(stamps, stamps[1:])) < 0.5
