"""Third-party conformance: pymavlink (mavutil + mavwp) and MAVSDK-Python talk to `fleetmap sim`.

For both autopilot flavours and both vehicle types, pymavlink connects to the simulator over
UDP, uploads a mission with mavwp, downloads it back, arms, takes off (copters), flies the
mission in AUTO and must see a MISSION_ITEM_REACHED for every item the autopilot reports.
MAVSDK's mission_raw plugin is a second, independent client for upload/download.

The binary under test is $FLEETMAP_BIN (CI: target/debug/fleetmap).
"""

import asyncio
import os
import socket
import subprocess
import time

import pytest

os.environ.setdefault("MAVLINK20", "1")
os.environ.setdefault("MAVLINK_DIALECT", "ardupilotmega")

from pymavlink import mavutil, mavwp  # noqa: E402

BIN = os.environ.get("FLEETMAP_BIN", "target/debug/fleetmap")
HOME = (37.1965, -80.5785)
SPEEDUP = 10.0
m = mavutil.mavlink


def free_udp_port():
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def offset(north, east):
    """A point north/east metres from HOME (local tangent plane, as geo::local)."""
    import math

    a = 6378137.0
    f = 1 / 298.257223563
    e2 = f * (2 - f)
    lat = math.radians(HOME[0])
    w = 1 - e2 * math.sin(lat) ** 2
    rn = a / math.sqrt(w)
    rm = a * (1 - e2) / (w * math.sqrt(w))
    return (HOME[0] + math.degrees(north / rm), HOME[1] + math.degrees(east / (rn * math.cos(lat))))


class Sim:
    def __init__(self, vehicle, extra=()):
        self.port = free_udp_port()
        args = [
            BIN, "sim", "--vehicles", f"1x{vehicle}",
            "--connect", f"udpout:127.0.0.1:{self.port}",
            "--home", f"{HOME[0]},{HOME[1]}",
            "--speedup", str(SPEEDUP), "--seed", "3",
            # a safety net: the simulator stops by itself if this test dies without stopping it
            "--duration", "1200", *extra,
        ]
        self.master = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{self.port}", source_system=255, source_component=190, dialect="ardupilotmega"
        )
        self.proc = subprocess.Popen(args, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        self.last_hb = 0.0
        self.reached = []
        self.texts = []

    def close(self):
        self.proc.terminate()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
        self.master.close()

    def heartbeat(self):
        now = time.monotonic()
        if now - self.last_hb > 0.2:  # PX4 wants a GCS; 0.2 s wall = 2 s simulated
            self.last_hb = now
            self.master.mav.heartbeat_send(m.MAV_TYPE_GCS, m.MAV_AUTOPILOT_INVALID, 0, 0, 0)

    def recv(self, types, timeout, cond=None):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self.heartbeat()
            msg = self.master.recv_match(blocking=True, timeout=0.05)
            if msg is None:
                continue
            t = msg.get_type()
            if t == "MISSION_ITEM_REACHED":
                self.reached.append(msg.seq)
            if t == "STATUSTEXT":
                self.texts.append(msg.text)
            if msg.get_srcComponent() != 1:
                continue
            if t in types and (cond is None or cond(msg)):
                return msg
        return None

    def command(self, cmd, *params, timeout=5):
        p = list(params) + [0] * (7 - len(params))
        self.master.mav.command_long_send(self.master.target_system, 1, cmd, 0, *p)
        ack = self.recv(["COMMAND_ACK"], timeout, lambda a: a.command == cmd)
        assert ack is not None, f"no COMMAND_ACK for {cmd}"
        return ack.result


def custom_mode(vehicle, mode):
    kind, autopilot = vehicle.split(":")
    if autopilot == "ardupilot":
        table = {"copter": {"GUIDED": 4, "AUTO": 3}, "rover": {"GUIDED": 15, "AUTO": 10}}
        return 1, table[kind][mode], 0
    main, sub = {"AUTO": (4, 4), "HOLD": (4, 3)}[mode]
    return 1, main, sub


def mission_items(master, vehicle):
    kind, autopilot = vehicle.split(":")
    ts, tc = master.target_system, 1
    items = []
    frame = m.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT

    def add(cmd, frm, p1=0, p2=0, p3=0, p4=0, lat=0.0, lon=0.0, alt=0.0):
        seq = len(items)
        items.append(m.MAVLink_mission_item_int_message(
            ts, tc, seq, frm, cmd, 0, 1, p1, p2, p3, p4, int(round(lat * 1e7)), int(round(lon * 1e7)), alt,
            m.MAV_MISSION_TYPE_MISSION))

    if autopilot == "ardupilot":
        add(m.MAV_CMD_NAV_WAYPOINT, m.MAV_FRAME_GLOBAL_INT, lat=HOME[0], lon=HOME[1], alt=0)  # home slot
    if kind == "copter":
        # At the launch position: PX4 flies a take-off item as a waypoint to its position (one
        # without a position, lat/lon 0, 0, is never reached).
        add(m.MAV_CMD_NAV_TAKEOFF, frame, lat=HOME[0], lon=HOME[1], alt=10)
    add(m.MAV_CMD_DO_CHANGE_SPEED, m.MAV_FRAME_MISSION, p1=1, p2=4, p3=-1)
    for n, e in [(20, 0), (20, 20), (0, 20)]:
        lat, lon = offset(n, e)
        add(m.MAV_CMD_NAV_WAYPOINT, frame, lat=lat, lon=lon, alt=10 if kind == "copter" else 0)
    add(m.MAV_CMD_NAV_RETURN_TO_LAUNCH, m.MAV_FRAME_MISSION)
    return items


def expected_reached(items, vehicle):
    kind, autopilot = vehicle.split(":")
    out = set()
    for it in items:
        if autopilot == "ardupilot" and it.seq == 0:
            continue
        if autopilot == "ardupilot" and it.command > 95 and it.command != m.MAV_CMD_DO_CHANGE_SPEED:
            continue
        if kind == "rover" and it.command == m.MAV_CMD_NAV_TAKEOFF:
            continue
        out.add(it.seq)
    return out


@pytest.mark.parametrize("vehicle", ["copter:ardupilot", "copter:px4", "rover:ardupilot", "rover:px4"])
def test_pymavlink_flies_a_mission(vehicle):
    sim = Sim(vehicle)
    try:
        master = sim.master
        hb = master.wait_heartbeat(timeout=20)
        assert hb is not None, "no heartbeat from fleetmap sim"
        assert hb.autopilot == (m.MAV_AUTOPILOT_ARDUPILOTMEGA if "ardupilot" in vehicle else m.MAV_AUTOPILOT_PX4)
        assert hb.type == (m.MAV_TYPE_QUADROTOR if "copter" in vehicle else m.MAV_TYPE_GROUND_ROVER)
        master.target_component = 1
        master.mav.request_data_stream_send(master.target_system, 1, m.MAV_DATA_STREAM_ALL, 4, 1)
        # ArduPilot heartbeats MAV_STATE_BOOT for its first ~2 s and refuses a mission with
        # MAV_MISSION_NO_SPACE until then; a client waits for it to leave BOOT/UNINIT, as against SITL
        ready = sim.recv(
            ["HEARTBEAT"], 20, lambda h: h.system_status not in (m.MAV_STATE_BOOT, m.MAV_STATE_UNINIT)
        )
        assert ready is not None, "the simulated autopilot never left MAV_STATE_BOOT"

        # upload with mavwp
        wp = mavwp.MAVWPLoader(target_system=master.target_system, target_component=1)
        items = mission_items(master, vehicle)
        for it in items:
            wp.add(it)
        master.mav.mission_count_send(master.target_system, 1, wp.count(), m.MAV_MISSION_TYPE_MISSION)
        while True:
            req = sim.recv(["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"], 10)
            assert req is not None, "upload stalled"
            if req.get_type() == "MISSION_ACK":
                assert req.type == m.MAV_MISSION_ACCEPTED, req
                break
            master.mav.send(wp.wp(req.seq))

        # download and compare
        master.mav.mission_request_list_send(master.target_system, 1, m.MAV_MISSION_TYPE_MISSION)
        count = sim.recv(["MISSION_COUNT"], 5)
        assert count is not None and count.count == len(items)
        for seq in range(count.count):
            master.mav.mission_request_int_send(master.target_system, 1, seq, m.MAV_MISSION_TYPE_MISSION)
            it = sim.recv(["MISSION_ITEM_INT"], 5, lambda x, s=seq: x.seq == s)
            assert it is not None, f"no item {seq}"
            if "ardupilot" in vehicle and seq == 0:
                continue  # ArduPilot returns its live home in slot 0
            assert it.command == items[seq].command
            assert (it.x, it.y) == (items[seq].x, items[seq].y)
        master.mav.mission_ack_send(master.target_system, 1, m.MAV_MISSION_ACCEPTED, m.MAV_MISSION_TYPE_MISSION)

        # wait for the position estimate, then arm (retrying as a GCS would)
        ok = False
        for _ in range(40):
            if "copter:ardupilot" == vehicle:
                sim.command(m.MAV_CMD_DO_SET_MODE, *custom_mode(vehicle, "GUIDED"))
            elif "rover" in vehicle:
                sim.command(m.MAV_CMD_DO_SET_MODE, *custom_mode(vehicle, "AUTO"))
            if vehicle == "copter:px4":
                ok = sim.command(m.MAV_CMD_MISSION_START) == m.MAV_RESULT_ACCEPTED
            else:
                ok = sim.command(m.MAV_CMD_COMPONENT_ARM_DISARM, 1) == m.MAV_RESULT_ACCEPTED
            if ok:
                break
            time.sleep(0.2)
        assert ok, f"never armed: {sim.texts}"
        if vehicle == "copter:ardupilot":
            assert sim.command(m.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10) == m.MAV_RESULT_ACCEPTED
            pos = sim.recv(["GLOBAL_POSITION_INT"], 20, lambda p: p.relative_alt > 9500)
            assert pos is not None, "no takeoff"
            assert sim.command(m.MAV_CMD_DO_SET_MODE, *custom_mode(vehicle, "AUTO")) == m.MAV_RESULT_ACCEPTED

        expected = expected_reached(items, vehicle)
        last = max(expected)
        done = sim.recv(["MISSION_ITEM_REACHED"], 60, lambda r: r.seq == last)
        assert done is not None, f"mission not flown: reached {sorted(set(sim.reached))}, texts {sim.texts}"
        assert set(sim.reached) == expected, (sorted(set(sim.reached)), sorted(expected))
    finally:
        sim.close()


def test_mavsdk_mission_raw_round_trip():
    """MAVSDK-Python (libcmavsdk bundled in the wheel, no mavsdk_server process) uploads and
    downloads a raw mission to the PX4 flavour."""
    mavsdk = pytest.importorskip("mavsdk")
    try:
        from mavsdk.asyncio import Mavsdk, Configuration, ComponentType
        from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync
        from mavsdk.plugins.mission_raw import MissionItem
    except ImportError as e:  # older wheels need a separate mavsdk_server
        pytest.skip(f"this mavsdk wheel has no in-process library: {e}")

    async def run():
        port = free_udp_port()
        proc = subprocess.Popen(
            [BIN, "sim", "--vehicles", "1xcopter:px4", "--connect", f"udpout:127.0.0.1:{port}",
             "--home", f"{HOME[0]},{HOME[1]}", "--speedup", "5", "--seed", "4", "--duration", "600"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
            await sdk.add_any_connection(f"udpin://127.0.0.1:{port}")
            system = await sdk.first_autopilot(20.0)
            assert system is not None, "MAVSDK saw no autopilot"
            mission = MissionRawAsync(system)
            items = []
            pts = [offset(20, 0), offset(20, 20), offset(0, 20)]
            for i, (lat, lon) in enumerate(pts):
                items.append(MissionItem(i, 6, 16, 1 if i == 0 else 0, 1, 0.0, 0.0, 0.0, float("nan"),
                                         int(round(lat * 1e7)), int(round(lon * 1e7)), 10.0, 0))
            await mission.upload_mission(items)
            back = await mission.download_mission()
            assert len(back) == len(items)
            for a, b in zip(items, back):
                assert (a.command, a.x, a.y) == (b.command, b.x, b.y)
                assert abs(a.z - b.z) < 1e-3
            sdk.destroy()
        finally:
            proc.terminate()
            proc.wait(timeout=5)

    asyncio.run(asyncio.wait_for(run(), 90))
