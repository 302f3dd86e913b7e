#!/usr/bin/env python3
"""Raw MAVLink numbers written where the dialect has a name.

    .ci/mavlink_ids.py        # print them as `path:line: what, use NAME`; exit 1 when there are any

The workspace speaks the `mavlink` crate's ardupilotmega dialect. A message id, a MAV_CMD, a
MAV_TYPE or a MAV_COMPONENT spelled as a bare number (`msg_id == 0`, `2000 =>`,
`mav_type == 30`) is a second vocabulary beside the dialect's (`<HEARTBEAT_DATA as
MessageData>::ID`, `MavCmd::MAV_CMD_IMAGE_START_CAPTURE`, `MavType::MAV_TYPE_CAMERA`); the
GCS's own identity (system 255, component 190) has one name each in `fleetmap_core::proto`
(`GCS_SYSID`, `GCS_COMPID`).

What is scanned: the Rust sources of the crates, `src/` and `crates/*/src`, their unit tests
included (they use the crate's vocabulary), and `benches/` (fleetmap's API driven by fleetmap's
code). Left out: the integration tests, `tests/` and `crates/*/tests`: they stand for the world
outside the program (a third-party GCS or autopilot writing bytes), and a literal there pins
what the wire must carry independently of the constants the code under test uses.

The names come from the dialect itself: the message definitions the `mavlink` crate is generated
from (`message_definitions/v1.0/ardupilotmega.xml` and what it includes, found with
`cargo metadata`). A number counts only in a place that says which vocabulary it belongs to, so
ordinary numbers (sizes, colours, vehicle ids) never match. Comments and strings are blanked
first. The places, with FIELD the last name of the expression:

* message id: FIELD is `msg_id`, `message_id` (also a call `message_id(..)`, and `Some(N)`
  compared with it) or `msgid`;
* MAV_CMD: FIELD is `command` or `cmd`, and `param1` of a MAV_CMD_REQUEST_MESSAGE or
  MAV_CMD_SET_MESSAGE_INTERVAL written in the same braces (a message id);
* MAV_TYPE: FIELD is `mav_type`;
* MAV_COMPONENT: FIELD is `compid`, `component_id` or `target_component`, for any value the
  dialect names except 0 (MAV_COMP_ID_ALL: "every component" is an address, like system 0);
* the GCS: 255 in a `sysid`, `system_id` or `target_system` FIELD, and the pair `255, 190`
  (a `Codec::encode(255, 190, ..)`);
* an `Endpoint::new(SYSID, COMPID)`: its arguments as the two FIELDs above;

in these forms: `FIELD ==`/`!=` (either side) a literal; `FIELD: N` (a struct literal or
pattern); the arms of a `match FIELD { .. }` (`N =>`, `N | M`, `N..=M`); `matches!(FIELD, ..)`;
`(N..=M).contains(&FIELD)`. Also every `const NAME: T = N;` whose NAME is, apart from the
words MAV, MSG, MESSAGE, ID, CMD, COMP, COMPID, the tail of a dialect entry's name (an enum
entry or a message; a last word's trailing 1 may be left out: AUTOPILOT for AUTOPILOT1) and
whose N is that entry's value (`const NAV_WAYPOINT: u16 = 16`, `const RADIO_STATUS_ID: u32 =
109`, `const MAV_STATE_BOOT: u8 = 1`): a home-made copy of the dialect, of any of its enums.

Not a Rust parser: a number reached another way (`let c = 16; item.command == c`, `<=`
comparisons, a parameter's value) is not seen. What it finds, it finds without false alarms:
each place above says which vocabulary its number is in, and the number must be one the
dialect names.
"""
import glob
import json
import os
import re
import subprocess
import sys
import xml.etree.ElementTree as ET

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from module_cycles import strip  # noqa: E402

NOISE = {"MAV", "MSG", "MESSAGE", "ID", "CMD", "COMP", "COMPID"}
INT = r"(?:0x[0-9A-Fa-f_]+|[0-9][0-9_]*)(?:u8|u16|u32|u64|i32|usize)?"
# The component ids fleetmap_core::proto names (each from the dialect, GCS_COMPID being fleetmap's choice).
PROTO_COMPIDS = {1: "AUTOPILOT_COMPID", 100: "CAMERA_COMPID", 190: "GCS_COMPID"}
FIELDS = {
    "msg": ("msg_id", "message_id", "msgid"),
    "cmd": ("command", "cmd"),
    "type": ("mav_type",),
    "comp": ("compid", "component_id", "target_component"),
    "sys": ("sysid", "system_id", "target_system"),
}


def definitions():
    """The directory of the mavlink crate's message definitions (via `cargo metadata`)."""
    out = subprocess.run(
        ["cargo", "metadata", "--format-version", "1"], check=True, capture_output=True, text=True
    ).stdout
    for p in json.loads(out)["packages"]:
        if p["name"] == "mavlink":
            d = os.path.join(os.path.dirname(p["manifest_path"]), "mavlink", "message_definitions", "v1.0")
            if os.path.isdir(d):
                return d
    sys.exit("mavlink_ids: the mavlink crate's message definitions were not found")


def dialect(d, name="ardupilotmega.xml", seen=None):
    """(messages {id: name}, enums {enum name: {value: entry name}}) of a definition file and its includes."""
    seen = set() if seen is None else seen
    msgs, enums = {}, {}
    if name in seen:
        return msgs, enums
    seen.add(name)
    root = ET.parse(os.path.join(d, name)).getroot()
    for inc in root.iter("include"):
        m, e = dialect(d, inc.text.strip(), seen)
        msgs.update(m)
        for k, v in e.items():
            enums.setdefault(k, {}).update(v)
    for m in root.iter("message"):
        msgs[int(m.get("id"))] = m.get("name")
    for e in root.iter("enum"):
        entries = enums.setdefault(e.get("name"), {})
        for x in e.iter("entry"):
            if x.get("value") is not None:
                entries.setdefault(int(x.get("value"), 0), x.get("name"))
    return msgs, enums


def value(lit):
    lit = re.sub(r"(u8|u16|u32|u64|i32|usize)$", "", lit).replace("_", "")
    return int(lit, 16) if lit.lower().startswith("0x") else int(lit)


def block(text, start):
    """The end of the brace block whose `{` is at or after `start`."""
    i = text.find("{", start)
    depth = 0
    for j in range(i, len(text)):
        if text[j] == "{":
            depth += 1
        elif text[j] == "}":
            depth -= 1
            if depth == 0:
                return i, j
    return i, len(text)


class Scan:
    def __init__(self, msgs, enums):
        self.msgs = msgs
        self.enums = enums
        self.found = []
        # tail words -> {value: full name}, for the constants rule
        self.tails = {}
        names = [(n, v) for v, n in msgs.items()] + [
            (n, v) for e in enums.values() for v, n in e.items()
        ]
        for n, v in names:
            words = [w for w in n.split("_") if w not in NOISE]
            for k in range(1, len(words) + 1):
                self.tails.setdefault(tuple(words[-k:]), {}).setdefault(v, n)
                if words[-1].endswith("1") and len(words[-1]) > 1:  # AUTOPILOT for AUTOPILOT1
                    tail = tuple(words[-k:-1]) + (words[-1][:-1],)
                    self.tails.setdefault(tail, {}).setdefault(v, n)

    def name(self, kind, v):
        """The dialect's name for value v of a kind, or None when it has none."""
        if kind == "msg":
            n = self.msgs.get(v)
            return n and f"<{n}_DATA as MessageData>::ID"
        if kind == "cmd":
            n = self.enums["MAV_CMD"].get(v)
            return n and f"MavCmd::{n}"
        if kind == "type":
            n = self.enums["MAV_TYPE"].get(v)
            return n and f"MavType::{n}"
        if kind == "comp":
            if v in PROTO_COMPIDS:
                return "fleetmap_core::proto::" + PROTO_COMPIDS[v]
            n = self.enums["MAV_COMPONENT"].get(v) if v != 0 else None
            return n and f"MavComponent::{n}"
        if kind == "sys":
            return "fleetmap_core::proto::GCS_SYSID" if v == 255 else None
        return None

    def report(self, path, text, pos, what, use):
        line = text.count("\n", 0, pos) + 1
        self.found.append(f"{path}:{line}: {what}, use {use}")

    def lits(self, path, text, pos, s, kind, what):
        """Report every literal (or range end) of a pattern or list `s` at offset `pos`."""
        for m in re.finditer(r"(?<!\w)(?<!\d\.)(" + INT + r")(?!\w|\.\d)", s):
            v = value(m.group(1))
            use = self.name(kind, v)
            if use:
                self.report(path, text, pos + m.start(), f"{what} {m.group(1)}", use)

    def file(self, path):
        with open(path, encoding="utf-8") as f:
            text = strip(f.read(), blank=True)
        for kind, fields in FIELDS.items():
            field = r"(?:\b(?:" + "|".join(fields) + r")\b(?:\s*\([^()]*\))?)"
            what = {"msg": "message id", "cmd": "MAV_CMD", "type": "MAV_TYPE", "comp": "component id",
                    "sys": "system id"}[kind]
            # FIELD == N, FIELD != N, FIELD == Some(N)
            for m in re.finditer(field + r"\s*(?:==|!=)\s*(?:Some\()?(" + INT + r")\b", text):
                self.lits(path, text, m.start(1), m.group(1), kind, what)
            # N == FIELD
            for m in re.finditer(r"(?<![\w.])(" + INT + r")\s*(?:==|!=)\s*[\w.&*]*?" + field, text):
                self.lits(path, text, m.start(1), m.group(1), kind, what)
            # FIELD: N (struct literal or pattern)
            for m in re.finditer(field + r"\s*:\s*(" + INT + r")(?![\w.])", text):
                self.lits(path, text, m.start(1), m.group(1), kind, what)
            # (N..=M).contains(&FIELD)
            for m in re.finditer(r"\(\s*(" + INT + r")\s*\.\.=?\s*(" + INT + r")\s*\)\s*\.contains\(\s*&?[\w.]*?" + field, text):
                self.lits(path, text, m.start(1), m.group(0).split(".contains")[0], kind, what)
            # matches!(FIELD, N | M ..)
            for m in re.finditer(r"matches!\(\s*[\w.&*]*?" + field + r"\s*,([^)]*)\)", text):
                self.lits(path, text, m.start(1), m.group(1), kind, what)
            # match FIELD { N => .., N | M => .., N..=M => .. }
            for m in re.finditer(r"\bmatch\s+[\w.&*]*?" + field + r"(?:\s+as\s+\w+)?\s*\{", text):
                i, j = block(text, m.end() - 1)
                depth = 0
                k = i + 1
                # arms at the top depth of the block: patterns before `=>`
                while k < j:
                    ch = text[k]
                    if ch in "{([":
                        depth += 1
                    elif ch in "})]":
                        depth -= 1
                    elif depth == 0 and text.startswith("=>", k):
                        start = max(text.rfind(",", i, k), text.rfind("}", i, k), i) + 1
                        pat = text[start:k]
                        pat = pat.split(" if ")[0]
                        if re.fullmatch(r"[\s\d_xA-Fa-f|.=]+", pat.split(" if ")[0]) and re.search(r"\d", pat):
                            self.lits(path, text, start, pat, kind, what)
                    k += 1
        # param1 of a REQUEST_MESSAGE / SET_MESSAGE_INTERVAL in the same braces: a message id
        for m in re.finditer(r"MAV_CMD_(?:REQUEST_MESSAGE|SET_MESSAGE_INTERVAL)\b", text):
            i = text.rfind("{", 0, m.start())
            _, j = block(text, i)
            for p in re.finditer(r"\bparam1\s*:\s*(" + INT + r")(?:\.0)?\b", text[i:j]):
                self.lits(path, text, i + p.start(1), p.group(1), "msg", "message id")
        # Endpoint::new(SYSID, COMPID)
        for m in re.finditer(r"\bEndpoint::new\(\s*([^,()]*?)\s*,\s*([^,()]*?)\s*\)", text):
            self.lits(path, text, m.start(1), m.group(1), "sys", "system id")
            self.lits(path, text, m.start(2), m.group(2), "comp", "component id")
        # the GCS's pair
        for m in re.finditer(r"(?<![\w.])255\s*,\s*190(?![\w.])", text):
            self.report(path, text, m.start(), "the GCS's ids 255, 190",
                        "fleetmap_core::proto::GCS_SYSID, GCS_COMPID")
        # home-made copies of dialect constants
        for m in re.finditer(r"\bconst\s+([A-Z][A-Z0-9_]*)\s*:\s*\w+\s*=\s*(" + INT + r")\s*;", text):
            words = tuple(w for w in m.group(1).split("_") if w not in NOISE)
            v = value(m.group(2))
            n = words and self.tails.get(words, {}).get(v)
            if n:
                self.report(path, text, m.start(2), f"{m.group(1)} = {m.group(2)}", f"the dialect's {n}")


def main():
    os.chdir(os.path.join(os.path.dirname(os.path.abspath(__file__)), ".."))
    msgs, enums = dialect(definitions())
    scan = Scan(msgs, enums)
    for top in ["src", "benches"] + sorted(glob.glob("crates/*/src")):
        for root, _, files in os.walk(top):
            for name in sorted(files):
                if name.endswith(".rs"):
                    scan.file(os.path.join(root, name))
    for f in sorted(set(scan.found), key=lambda s: (s.split(":")[0], int(s.split(":")[1]))):
        print(f)
    n = len(set(scan.found))
    print(f"mavlink_ids: {n} raw MAVLink number(s) where the dialect has a name")
    return 1 if n else 0


if __name__ == "__main__":
    sys.exit(main())
