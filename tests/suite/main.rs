//! fleetmap's integration and end-to-end tests, in one test binary: each test binary is one
//! more link of the whole crate and its dependencies (on CI's two cores, tens of seconds
//! each), so every file here is a module of this one (`cargo test --test suite MODULE::`).
//!
//! `common` holds what several modules share and only this suite needs (worlds, missions,
//! pseudo-terminals, run drivers); what the camera crate's tests share with it (process
//! guards, the binaries, the MAVLink router, a test GCS, the simulator served on UDP) is the
//! `fleetmap-test-kit` crate. `make test` runs the slow and the waiting modules as their own processes beside
//! the rest (the Makefile's `SLOW_TESTS`, `WAITING_TESTS`).

mod common;

mod bandit_no_images;
mod bandit_radio;
mod bandit_run;
mod bandit_start;
mod camera_program;
mod conformance;
mod demo_headless;
mod explore;
mod fast_plain;
mod field_day;
mod field_kit;
mod field_wiring;
mod geo;
mod image_resend;
mod image_sanity;
mod link_budget;
mod links;
mod mavlink_e2e;
mod mavlink_proto;
mod mission_def;
mod mission_fly;
mod planner;
mod planner_study;
mod radio_fleet;
mod radio_sim;
mod relay_rate;
mod rover_mission_restart;
mod runway;
mod runway_kill;
mod runway_onboard;
mod runway_reach;
mod runway_start;
mod signing_cli;
mod sim_camera;
mod sim_lockstep;
mod sim_radio;
mod sim_server;
mod sim_vehicle;
mod solver;
mod store;
mod tui;
mod tui_demo;
mod tui_live;
mod vision;
