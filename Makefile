# fleetmap — two commands: `make demo` and `make test`.
#
# `make` installs what the build needs on a fresh Debian machine that has only the Rust
# toolchain: system packages with apt-get (sudo when not root), and a Python virtual
# environment (.venv) with the third-party reference implementations the tests compare
# fleetmap against (pymavlink, MAVSDK, OpenCV, pyproj).

SHELL := /bin/bash
CARGO ?= cargo
PYTHON ?= python3
VENV := .venv
PY := $(VENV)/bin/python
# cmake + a C++ compiler build HiGHS (good_lp's solver); libclang-dev is for its bindgen.
APT_PACKAGES := cmake g++ libclang-dev pkg-config
BIN := target/debug/fleetmap

.PHONY: all build test demo sysdeps venv bench ci clean-venv

all: build

## Install missing system packages (says what it installs; does nothing when all are present).
sysdeps:
	@missing=""; \
	for p in $(APT_PACKAGES); do \
	  dpkg-query -W -f='$${Status}' $$p 2>/dev/null | grep -q "install ok installed" || missing="$$missing $$p"; \
	done; \
	if [ -n "$$missing" ]; then \
	  echo "make: installing system packages:$$missing"; \
	  SUDO=""; if [ "$$(id -u)" != 0 ]; then SUDO=sudo; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq $$missing; \
	fi
	@if ! $(PYTHON) -c 'import venv, ensurepip' 2>/dev/null; then \
	  echo "make: installing system package: python3-venv"; \
	  SUDO=""; if [ "$$(id -u)" != 0 ]; then SUDO=sudo; fi; \
	  $$SUDO apt-get update -qq && DEBIAN_FRONTEND=noninteractive $$SUDO apt-get install -y -qq python3-venv; \
	fi

## The Python reference implementations used by the conformance tests.
venv: $(VENV)/.installed
$(VENV)/.installed: tests/py/requirements.txt | sysdeps
	@echo "make: creating the Python environment $(VENV) (pymavlink, MAVSDK, OpenCV, pyproj, pytest)"
	$(PYTHON) -m venv $(VENV)
	$(PY) -m pip install -q --disable-pip-version-check -r tests/py/requirements.txt
	@touch $@

build: sysdeps
	$(CARGO) build --bins

## One build serves `make test` and `make demo`: TEST_BUILD compiles every crate's tests and
## the binaries, and `make demo` runs the binary it built. A `cargo build` would compile the
## workspace again: without the test targets cargo leaves out the dev-dependencies, and the
## features they turn on in shared crates (in today's tree serde's `alloc`, zerocopy's `derive`,
## rustix's `fs`, …) change every crate built on them. (`make build` is that other build.)
TEST_BUILD := $(CARGO) test --workspace --lib --bins --tests --no-fail-fast --no-run
## Whether cargo compiles incrementally is part of what it fingerprints: a `make demo` from a
## shell with another CARGO_INCREMENTAL than `make test`'s would compile the workspace's crates
## again. So every cargo command here builds without incremental compilation (which only adds
## work to a build from scratch) unless the caller sets CARGO_INCREMENTAL itself; CI sets the
## same 0.
export CARGO_INCREMENTAL ?= 0

## The whole test suite: Rust unit, property and end-to-end tests, then the Python
## conformance tests against the built binary. `cargo test` builds the binary itself (with the
## dev-dependency features): a separate `cargo build` first would compile the crate and
## everything that depends on them a second time.
#
## The Python environment is filled while cargo compiles (pip mostly waits on the network).
## The integration and end-to-end tests are one test binary (tests/suite: one link of the
## whole crate instead of one per file). Its longest modules ($(SLOW_TESTS)) fly simulated
## missions in real time, mostly waiting: they run as a second process beside the rest (their
## output follows), which takes minutes off `make test` on 2 cores. (demo_headless: the runway
## and bandit demos headless, in parallel, 3 to 5½ minutes.) The conformance checks
## ($(WAITING_TESTS): hitl/conformance.py against the simulator, an ArduPilot and a PX4 copter
## in parallel, about 5 minutes) judge mission transfers at real time and so mostly wait on the
## autopilots' timeouts: they run as a third process beside both. Then the documentation's
## examples (`--doc`: they must compile). The benchmarks are not run here (`make bench`; clippy
## compiles them). Every cargo command here selects the whole workspace: cargo unifies the
## crates' features over the packages selected, and a command for the root package alone
## would build the workspace's crates a second time with other features.
SLOW_TESTS := bandit_run demo_headless runway_kill
# The other crates' own integration tests (fleetmap-camera's, over a pseudo-terminal).
CRATE_TESTS := serial
WAITING_TESTS := conformance
# libtest filters: a module's tests are those whose path starts `MODULE::`.
SLOW_FILTERS := $(addsuffix ::,$(SLOW_TESTS))
WAITING_FILTERS := $(addsuffix ::,$(WAITING_TESTS))
SKIP_FILTERS := $(addprefix --skip ,$(SLOW_FILTERS) $(WAITING_FILTERS))
test: sysdeps
	@mkdir -p target
	@$(MAKE) --no-print-directory venv > target/venv.log 2>&1 & venv=$$!; \
	  $(TEST_BUILD); built=$$?; \
	  wait $$venv; v=$$?; cat target/venv.log; \
	  [ $$built = 0 ] && [ $$v = 0 ]
	@$(CARGO) test --no-fail-fast --workspace --test suite -- $(WAITING_FILTERS) > target/waiting-tests.log 2>&1 & waiting=$$!; \
	  $(CARGO) test --no-fail-fast --workspace --test suite -- $(SLOW_FILTERS) > target/slow-tests.log 2>&1 & slow=$$!; \
	  $(CARGO) test --no-fail-fast --workspace --lib --bins --test suite $(addprefix --test ,$(CRATE_TESTS)) -- $(SKIP_FILTERS); rest=$$?; \
	  wait $$slow; s=$$?; echo "--- $(SLOW_TESTS):"; cat target/slow-tests.log; \
	  wait $$waiting; w=$$?; echo "--- $(WAITING_TESTS):"; cat target/waiting-tests.log; \
	  [ $$rest = 0 ] && [ $$s = 0 ] && [ $$w = 0 ]
	$(CARGO) test --workspace --doc
	FLEETMAP_BIN=$(abspath $(BIN)) $(PY) -m pytest -q tests/py

## The main job on the embedded simulator (the TUI on a terminal, headless otherwise), on
## the binary of `make test`'s build (TEST_BUILD above).
demo: sysdeps
	$(TEST_BUILD)
	@if [ -t 0 ] && [ -t 1 ]; then $(BIN) demo; else $(BIN) demo --headless; fi

bench: sysdeps
	$(CARGO) bench

## What CI runs (.ci/run).
ci:
	.ci/run

clean-venv:
	rm -rf $(VENV)
