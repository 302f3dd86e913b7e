"""The link checks of hitl/conformance.py, on the MAVLink link itself (standard-library Python:
a minimal MAVLink 2 client, as a GCS with system id 255, component 190):

  streams  what the vehicle sends, per message, after two sets of requests, against the
           tables measured on ArduCopter / ArduRover 4.7 SITL and PX4 1.16 SIH (its UDP GCS
           link): fleetmap's requests before the link budget (REQUEST_DATA_STREAM
           EXTENDED_STATUS 2 Hz, POSITION 5, EXTRA1 4, EXTRA2 4, EXTRA3 2 for ArduPilot, and
           SET_MESSAGE_INTERVAL for 8 messages), then a budget's (REQUEST_DATA_STREAM ALL
           stopped, SET_MESSAGE_INTERVAL for 8 messages). Bytes per second are counted in the
           vehicle's time (its time_boot_ms), so a simulator or SITL at ×N is judged alike. Then
           RADIO_STATUS from a SiK radio (system 51, component 68) with txbuf 10 % once a
           vehicle second for 12 s: ArduPilot slows its streams (`stream_slowdown_ms`), PX4's
           SITL GCS link (no `-s`) does not. The radio then says 100 % free until the streams
           are back.
  arming   arming and take-off answered as the autopilot answers them when commands come
           late or twice: a take-off disarmed, ARM twice, a mode change to the current mode,
           the auto-disarm of a copter that does not take off (ArduCopter DISARM_DELAY,
           PX4 COM_DISARM_PRFLT: 10 s), a take-off after it, a take-off repeated once it has
           left the ground (ArduCopter FAILED, PX4 ACCEPTED). Then it lands.
"""

import socket
import struct
import time

# CRC_EXTRA of the messages this client sends (MAVLink common / ardupilotmega definitions)
CRC_EXTRA = {0: 50, 66: 148, 76: 152, 109: 185}

ACCEPTED, TEMPORARILY_REJECTED, DENIED, UNSUPPORTED, FAILED = 0, 1, 2, 3, 4
RESULT = {0: "ACCEPTED", 1: "TEMPORARILY_REJECTED", 2: "DENIED", 3: "UNSUPPORTED", 4: "FAILED", None: "no ACK"}

# Bytes per second per message id measured on the real autopilots (docs/results/conformance.md,
# "Telemetry on the link"), without PARAM_VALUE, STATUSTEXT and TIMESYNC (event-driven).
TABLES = {
    ("ArduCopter", "fleetmap"): {
        164: 224, 11030: 224, 33: 200, 32: 200, 30: 160, 178: 144, 24: 104, 163: 80, 62: 68, 193: 68,
        136: 64, 241: 64, 74: 60, 147: 53, 2: 45, 1: 43, 152: 38, 242: 34, 168: 32, 125: 28, 0: 21,
        42: 17, 133: 14, 245: 14},
    ("ArduCopter", "budget"): {33: 201, 24: 105, 147: 53, 1: 43, 193: 34, 242: 34, 0: 21, 42: 17, 245: 14},
    ("ArduRover", "fleetmap"): {
        164: 224, 33: 200, 32: 200, 30: 160, 178: 144, 24: 104, 163: 80, 193: 68, 241: 64, 74: 60,
        65: 54, 147: 53, 2: 45, 1: 43, 27: 41, 152: 38, 116: 36, 129: 34, 34: 34, 242: 34, 125: 28,
        29: 26, 137: 26, 36: 22, 0: 21, 42: 17, 245: 13},
    ("ArduRover", "budget"): {33: 201, 24: 105, 147: 53, 1: 43, 193: 34, 242: 34, 0: 21, 42: 17, 245: 13},
    ("PX4", "fleetmap"): {
        85: 3151, 36: 2451, 83: 2399, 31: 2199, 30: 2001, 32: 2000, 33: 201, 24: 112, 12901: 71,
        74: 60, 147: 54, 1: 53, 141: 45, 12904: 38, 8: 37, 242: 34, 230: 27, 29: 26, 0: 21, 42: 16,
        245: 14, 132: 13},
    ("PX4", "budget"): {
        85: 3151, 36: 2451, 83: 2399, 31: 2199, 32: 2000, 30: 2000, 33: 200, 24: 112, 12901: 71,
        74: 60, 147: 54, 1: 53, 141: 44, 12904: 38, 8: 37, 242: 34, 230: 27, 29: 26, 0: 21, 42: 16,
        245: 14, 132: 13},
}
IGNORED = {22, 253, 111, 77, 244, 49}  # PARAM_VALUE, STATUSTEXT, TIMESYNC, ACKs, answers, origin

FLEETMAP_STREAMS = [(2, 2), (6, 5), (10, 4), (11, 4), (12, 2)]  # MAV_DATA_STREAM, Hz
FLEETMAP_INTERVALS = [(33, 200000), (24, 500000), (1, 1000000), (42, 1000000),
                      (245, 1000000), (242, 2000000), (147, 1000000), (74, 500000)]
BUDGET_INTERVALS = [(33, 200000), (1, 1000000), (24, 500000), (245, 1000000),
                    (42, 1000000), (242, 2000000), (147, 1000000), (193, 1000000)]

MAV_CMD_NAV_TAKEOFF, MAV_CMD_NAV_LAND, MAV_CMD_DO_SET_MODE = 22, 21, 176
MAV_CMD_COMPONENT_ARM_DISARM, MAV_CMD_SET_MESSAGE_INTERVAL = 400, 511
NAN = float("nan")


def x25(data, crc=0xFFFF):
    for b in data:
        tmp = b ^ (crc & 0xFF)
        tmp = (tmp ^ (tmp << 4)) & 0xFF
        crc = ((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4)) & 0xFFFF
    return crc


class Link:
    """A GCS on UDP: sends to `port` on loopback (a relay's GCS side, or an autopilot's) and
    keeps what the vehicle `sysid` says."""

    def __init__(self, port, sysid):
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.05)
        self.addr = ("127.0.0.1", port)
        self.sysid = sysid
        self.seq = 0
        self.tb = None  # the vehicle's latest time_boot_ms
        self.frames = []  # (time_boot_ms, msgid, bytes) of the autopilot component
        self.acks = []
        self.texts = []
        self.armed = False
        self.custom_mode = None
        self.autopilot = None
        self.mav_type = None
        self.rel_alt = 0.0
        self.last_hb = 0.0
        self.radio_txbuf = None
        self.radio_tb = None
        self.ekf_flags = None
        self.system_status = None

    def close(self):
        self.sock.close()

    def send(self, msgid, payload, sysid=255, compid=190):
        while len(payload) > 1 and payload[-1] == 0:
            payload = payload[:-1]
        hdr = bytes([0xFD, len(payload), 0, 0, self.seq, sysid, compid,
                     msgid & 0xFF, (msgid >> 8) & 0xFF, msgid >> 16])
        crc = x25(bytes([CRC_EXTRA[msgid]]), x25(hdr[1:] + payload))
        self.seq = (self.seq + 1) & 0xFF
        self.sock.sendto(hdr + payload + struct.pack("<H", crc), self.addr)

    def heartbeat(self):
        self.send(0, struct.pack("<IBBBBB", 0, 6, 8, 0, 0, 3))

    def command(self, cmd, params, wait=3.0):
        """COMMAND_LONG; the ACK's result (None: no ACK within `wait` wall seconds)."""
        p = (list(params) + [0.0] * 7)[:7]
        self.acks = [a for a in self.acks if a[0] != cmd]
        self.send(76, struct.pack("<fffffffHBBB", *p, cmd, self.sysid, 1, 0))
        end = time.monotonic() + wait
        while time.monotonic() < end:
            self.pump(0.05)
            for c, r in self.acks:
                if c == cmd:
                    return r
        return None

    def request_data_stream(self, stream, hz, start):
        self.send(66, struct.pack("<HBBBB", hz, self.sysid, 1, stream, start))

    def radio_status(self, txbuf):
        self.send(109, struct.pack("<HHBBBBB", 0, 0, 200, 200, txbuf, 40, 40), sysid=51, compid=68)

    def pump(self, seconds):
        """Receive for `seconds` of wall time: heartbeat at 1 Hz, RADIO_STATUS once a vehicle
        second while `radio_txbuf` is set."""
        end = time.monotonic() + seconds
        while True:
            now = time.monotonic()
            if now - self.last_hb >= 1.0:
                self.last_hb = now
                self.heartbeat()
            if self.radio_txbuf is not None and self.tb is not None and (
                    self.radio_tb is None or self.tb - self.radio_tb >= 1000):
                self.radio_tb = self.tb
                self.radio_status(self.radio_txbuf)
            try:
                data = self.sock.recv(65536)
                self.parse(data)
            except socket.timeout:
                pass
            if time.monotonic() >= end:
                return

    def parse(self, data):
        i = 0
        while i + 8 <= len(data):
            if data[i] == 0xFD and i + 12 <= len(data):
                ln, incompat = data[i + 1], data[i + 2]
                sysid, compid = data[i + 5], data[i + 6]
                msgid = data[i + 7] | data[i + 8] << 8 | data[i + 9] << 16
                size = 12 + ln + (13 if incompat & 1 else 0)
                payload = data[i + 10:i + 10 + ln]
            elif data[i] == 0xFE:
                ln = data[i + 1]
                sysid, compid, msgid = data[i + 3], data[i + 4], data[i + 5]
                size = 8 + ln
                payload = data[i + 6:i + 6 + ln]
            else:
                i += 1
                continue
            i += size
            if sysid == self.sysid:
                self.on(compid, msgid, payload.ljust(64, b"\0"), size)

    def on(self, compid, msgid, p, size):
        if msgid in (30, 33):  # ATTITUDE, GLOBAL_POSITION_INT
            self.tb = struct.unpack_from("<I", p, 0)[0]
        elif msgid == 2:  # SYSTEM_TIME
            self.tb = struct.unpack_from("<I", p, 8)[0]
        if msgid == 33:
            self.rel_alt = struct.unpack_from("<i", p, 16)[0] / 1000.0
        elif msgid == 0 and compid == 1:
            mode, typ, ap, base, status = struct.unpack_from("<IBBBB", p, 0)
            self.custom_mode, self.mav_type, self.autopilot = mode, typ, ap
            self.armed = bool(base & 128)
            self.system_status = status
        elif msgid == 77:
            cmd, res = struct.unpack_from("<HB", p, 0)
            self.acks.append((cmd, res))
        elif msgid == 193:  # EKF_STATUS_REPORT
            self.ekf_flags = struct.unpack_from("<H", p, 20)[0]
        elif msgid == 253:
            self.texts.append(p[1:51].split(b"\0")[0].decode(errors="replace"))
        if compid == 1 and self.tb is not None:
            self.frames.append((self.tb, msgid, size))

    def vehicle_wait(self, seconds, until=None, limit=None):
        """Pump until `seconds` of vehicle time passed (or `until()` holds); False when the
        vehicle's clock did not move for `limit` wall seconds."""
        limit = limit or max(30.0, seconds * 3)
        t_end_wall = time.monotonic() + limit
        while self.tb is None and time.monotonic() < t_end_wall:
            self.pump(0.1)
        if self.tb is None:
            return False
        start = self.tb
        while self.tb - start < seconds * 1000 and time.monotonic() < t_end_wall:
            if until and until():
                return True
            self.pump(0.05)
        return (until() if until else self.tb - start >= seconds * 1000)

    def rates(self, since_tb):
        """Per message id: bytes per vehicle second since `since_tb`."""
        rows = [f for f in self.frames if f[0] >= since_tb]
        if len(rows) < 2:
            return {}, 0.0
        secs = (rows[-1][0] - rows[0][0]) / 1000.0
        per = {}
        for _, mid, size in rows:
            if mid not in IGNORED:
                per[mid] = per.get(mid, 0) + size
        return {k: v / secs for k, v in per.items()}, secs


def kind(link):
    if link.autopilot == 12:
        return "PX4"
    return "ArduRover" if link.mav_type == 10 else "ArduCopter"


def compare(measured, table):
    """(ok, detail): total within 12 %, each message of 25 B/s or more in either within 30 %."""
    tot_m, tot_t = sum(measured.values()), sum(table.values())
    bad = []
    for mid in sorted(set(measured) | set(table)):
        m, t = measured.get(mid, 0.0), table.get(mid, 0.0)
        if max(m, t) >= 25 and abs(m - t) > 0.3 * max(t, 1.0):
            bad.append(f"{mid}: {m:.0f} vs {t:.0f}")
    ok = abs(tot_m - tot_t) <= 0.12 * tot_t and not bad
    return ok, f"{tot_m:.0f} B/s (table {tot_t:.0f})" + (f"; off: {', '.join(bad)}" if bad else "")


def wait_heartbeat(link, limit=30.0):
    end = time.monotonic() + limit
    while link.autopilot is None and time.monotonic() < end:
        link.pump(0.2)
    return link.autopilot is not None


def wait_estimate(link, limit=120.0):
    """ArduPilot: until its EKF has an absolute horizontal position and has left constant
    position mode (EKF_STATUS_REPORT flags 0x10 set, 0x80 clear): what arming needs, and what
    the tables were measured with (LOCAL_POSITION_NED and WIND come only then). PX4: until its
    heartbeat says STANDBY or ACTIVE (its preflight checks pass: a position estimate)."""
    if link.autopilot == 12:
        end = time.monotonic() + limit
        while link.system_status not in (3, 4) and time.monotonic() < end:
            link.pump(0.2)
        return link.system_status in (3, 4)
    link.command(MAV_CMD_SET_MESSAGE_INTERVAL, [193, 1000000])
    end = time.monotonic() + limit
    ok = lambda f: f is not None and f & 0x10 and not f & 0x80  # noqa: E731
    while not ok(link.ekf_flags) and time.monotonic() < end:
        link.pump(0.2)
    link.command(MAV_CMD_SET_MESSAGE_INTERVAL, [193, -1])
    return ok(link.ekf_flags)


def streams_check(checks, port, sysid):
    t0 = time.monotonic()
    link = Link(port, sysid)
    try:
        if not wait_heartbeat(link) or not wait_estimate(link):
            return checks.record("streams", False, "no heartbeat or no position estimate",
                                 time.monotonic() - t0)
        k = kind(link)
        ardupilot = k != "PX4"
        details, ok_all = [], True

        def fleetmap_requests():
            if ardupilot:
                for stream, hz in FLEETMAP_STREAMS:
                    link.request_data_stream(stream, hz, 1)
            for mid, us in FLEETMAP_INTERVALS:
                link.command(MAV_CMD_SET_MESSAGE_INTERVAL, [mid, us])

        for phase in ("fleetmap", "budget"):
            if phase == "fleetmap":
                if ardupilot:
                    # every group back to the vehicle's boot rate (ArduCopter 0, ArduRover 1 Hz)
                    link.request_data_stream(0, 1 if k == "ArduRover" else 0, 1)
                fleetmap_requests()
            else:
                if ardupilot:
                    link.request_data_stream(0, 0, 0)
                for mid, us in BUDGET_INTERVALS:
                    link.command(MAV_CMD_SET_MESSAGE_INTERVAL, [mid, us])
            if not link.vehicle_wait(3.0):
                return checks.record("streams", False, f"{k}: no message with time_boot_ms",
                                     time.monotonic() - t0)
            start = link.tb
            link.vehicle_wait(10.0)
            measured, _ = link.rates(start)
            ok, detail = compare(measured, TABLES[(k, phase)])
            ok_all &= ok
            details.append(f"{phase}: {detail}")
        # RADIO_STATUS back-pressure, after fleetmap's requests again
        fleetmap_requests()
        link.vehicle_wait(3.0)
        start = link.tb
        link.vehicle_wait(6.0)
        base = sum(link.rates(start)[0].values())
        link.radio_txbuf = 10
        link.vehicle_wait(12.0)
        start = link.tb
        link.vehicle_wait(4.0)
        low = sum(link.rates(start)[0].values())
        link.radio_txbuf = None
        for _ in range(80):  # 100 % free: ArduPilot −40 ms a message, PX4 ×1.025
            link.radio_status(100)
            time.sleep(0.01)
        ratio = low / base if base else 0.0
        ok = ratio < 0.4 if ardupilot else 0.85 < ratio < 1.15
        ok_all &= ok
        expect = "slowed below 40 %" if ardupilot else "unchanged: no -s on the SITL's GCS link"
        details.append(f"RADIO_STATUS txbuf 10 % for 12 s: {base:.0f} → {low:.0f} B/s ({expect})")
        return checks.record("streams", ok_all, f"{k}: " + "; ".join(details), time.monotonic() - t0)
    finally:
        link.close()


def arming_check(checks, port, sysid):
    t0 = time.monotonic()
    link = Link(port, sysid)
    got, want = [], []

    def expect(what, result, wanted):
        got.append(f"{what}: {RESULT.get(result, result)}")
        if result != wanted:
            want.append(f"{what}: {RESULT.get(result, result)}, expected {RESULT[wanted]}")

    try:
        if not wait_heartbeat(link) or not wait_estimate(link):
            return checks.record("arming", False, "no heartbeat or no position estimate",
                                 time.monotonic() - t0)
        link.request_data_stream(6, 5, 1)
        link.command(MAV_CMD_SET_MESSAGE_INTERVAL, [33, 200000])
        if not link.vehicle_wait(1.0):
            return checks.record("arming", False, "no position reports", time.monotonic() - t0)
        k = kind(link)
        if k == "ArduRover":
            return checks.record("arming", True, "n/a: a rover", time.monotonic() - t0, supported=False)
        px4 = k == "PX4"
        hold = [1, 4, 3] if px4 else [1, 4]  # PX4 AUTO_LOITER, ArduCopter GUIDED
        takeoff = [0, 0, 0, NAN, NAN, NAN, NAN if px4 else 10]
        expect("mode", link.command(MAV_CMD_DO_SET_MODE, hold), ACCEPTED)
        expect("same mode again", link.command(MAV_CMD_DO_SET_MODE, hold), ACCEPTED)
        expect("take-off disarmed", link.command(MAV_CMD_NAV_TAKEOFF, takeoff),
               ACCEPTED if px4 else FAILED)
        if px4:
            link.vehicle_wait(1.0)
            expect("mode back", link.command(MAV_CMD_DO_SET_MODE, hold), ACCEPTED)
        expect("arm", link.command(MAV_CMD_COMPONENT_ARM_DISARM, [1]), ACCEPTED)
        armed_tb = link.tb
        expect("arm again", link.command(MAV_CMD_COMPONENT_ARM_DISARM, [1]), ACCEPTED)
        link.vehicle_wait(3.0, until=lambda: link.armed)  # the 1 Hz heartbeat says so
        link.vehicle_wait(20.0, until=lambda: not link.armed)
        waited = (link.tb - armed_tb) / 1000.0
        if link.armed or not 8.5 <= waited <= 12.5:
            want.append(f"auto-disarm after {waited:.1f} s (expected 10 s)")
        got.append(f"auto-disarm after {waited:.1f} s")
        expect("take-off after it", link.command(MAV_CMD_NAV_TAKEOFF, takeoff),
               ACCEPTED if px4 else FAILED)
        if px4:
            link.vehicle_wait(1.0)
            link.command(MAV_CMD_DO_SET_MODE, hold)
        expect("arm", link.command(MAV_CMD_COMPONENT_ARM_DISARM, [1]), ACCEPTED)
        expect("take-off", link.command(MAV_CMD_NAV_TAKEOFF, takeoff), ACCEPTED)
        # once off the ground (ArduCopter accepts a repeat while it is still landed: spooling up)
        link.vehicle_wait(15.0, until=lambda: link.rel_alt > 1.0)
        expect(f"take-off again at {link.rel_alt:.1f} m", link.command(MAV_CMD_NAV_TAKEOFF, takeoff),
               ACCEPTED if px4 else FAILED)
        link.vehicle_wait(15.0, until=lambda: link.rel_alt > 2.0)
        if px4:
            link.command(MAV_CMD_NAV_LAND, [0, 0, 0, NAN, NAN, NAN, NAN])
        else:
            link.command(MAV_CMD_DO_SET_MODE, [1, 9])
        if not link.vehicle_wait(60.0, until=lambda: not link.armed):
            want.append("did not land and disarm within 60 s")
        ok = not want
        return checks.record("arming", ok, f"{k}: " + ("; ".join(want) if want else "; ".join(got)),
                             time.monotonic() - t0)
    finally:
        link.close()
