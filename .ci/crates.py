#!/usr/bin/env python3
"""Fail when a crate of the workspace depends on what its layer forbids.

    .ci/crates.py

The crates are the architecture (docs/architecture.md, "Crates"):

* `fleetmap-core` is pure: nothing async, no sockets. Its normal dependency tree
  (`cargo tree -e normal`) must not contain tokio, mio, socket2 or tokio-serial.
* `fleetmap-io` and `fleetmap-core` are shared by the ground station and the simulator, so
  neither may depend on `fleetmap-sim` or on the ground station `fleetmap`.
* `fleetmap-camera` runs on a drone's companion computer (a Raspberry Pi): its normal tree
  must not contain HiGHS (good_lp, highs-sys, cmake), the terminal UI (ratatui, crossterm),
  the simulator or the ground station, so that `cargo build -p fleetmap-camera` builds none
  of them (the core comes without its `highs` feature).
* `fleetmap-test-kit`, what the integration tests share, is a dev-dependency of the camera
  too: the same holds for it, so that `cargo test -p fleetmap-camera` builds none of them.
* The ground station built without its default features (`--no-default-features`, no `sim`)
  must not contain `fleetmap-sim`: a GCS for real vehicles carries no simulator code.
* tokio's `test-util` (the paused clock, for tests and the simulated studies) is not in the
  camera program's or the station-without-`sim`'s build: those are the binaries that fly.

Exit status 1 with one line per broken rule.
"""
import subprocess
import sys


def tree(*args):
    """The package names (without versions) in `cargo tree` for these arguments."""
    out = subprocess.run(
        ["cargo", "tree", "--edges", "normal", "--prefix", "none", "--format", "{p}", *args],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    return {line.split()[0] for line in out.splitlines() if line.strip()}


RULES = [
    (["-p", "fleetmap-core"], {"tokio", "mio", "socket2", "tokio-serial", "fleetmap-io", "fleetmap-sim", "fleetmap"},
     "the pure core"),
    (["-p", "fleetmap-io"], {"fleetmap-sim", "fleetmap"}, "the I/O edge"),
    (["-p", "fleetmap-camera"],
     {"good_lp", "highs-sys", "cmake", "ratatui", "crossterm", "fleetmap-sim", "fleetmap"},
     "the companion computer's camera"),
    (["-p", "fleetmap-test-kit"],
     {"good_lp", "highs-sys", "cmake", "ratatui", "crossterm", "fleetmap"},
     "the tests' kit, which the camera's tests use"),
    (["-p", "fleetmap", "--no-default-features"], {"fleetmap-sim", "indicatif"},
     "the ground station without the `sim` feature"),
]


# The builds that must not enable tokio's `test-util` (its normal-edge feature tree).
NO_TEST_UTIL = [["-p", "fleetmap-camera", "--features", "v4l2"], ["-p", "fleetmap", "--no-default-features"]]


def tokio_features(*args):
    out = subprocess.run(
        ["cargo", "tree", "--edges", "normal,build,features", "--invert", "tokio", *args],
        check=True,
        capture_output=True,
        text=True,
    ).stdout
    return out


def main():
    broken = 0
    for args in NO_TEST_UTIL:
        if 'tokio feature "test-util"' in tokio_features(*args):
            broken += 1
            print(f"crates: cargo tree {' '.join(args)} enables tokio's test-util (a test clock in a flying binary)")
    for args, forbidden, what in RULES:
        found = sorted(tree(*args) & forbidden)
        for name in found:
            broken += 1
            print(f"crates: {what} (cargo tree {' '.join(args)}) depends on {name}")
    if broken:
        sys.exit(1)
    print("crates: core without tokio or sockets; io and core without the simulator; "
          "the camera without HiGHS, TUI or simulator; the test kit without HiGHS, TUI or GCS; the GCS without `sim` has no simulator code; "
          "neither the camera nor the GCS without `sim` has tokio's test-util")


if __name__ == "__main__":
    main()
