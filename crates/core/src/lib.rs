//! fleetmap's pure core: everything that decides, and nothing that waits.
//!
//! No module here opens a socket or a file, reads a clock or spawns a task: time is a
//! [`time::Time`] parameter, bytes and text come in as arguments and leave as return values.
//! The ground station (`fleetmap`) and the simulator (`fleetmap-sim`) drive these machines
//! from their async shells; `docs/architecture.md` draws the layers.
//!
//! | module | responsibility |
//! |---|---|
//! | [`budget`] | what a vehicle's link carries (a telemetry radio's bytes per second) |
//! | [`geo`] | mission grid, cell ↔ UTM ↔ WGS84, polygons → cells |
//! | [`mission`] | mission items, mission definition files, QGC file formats |
//! | [`preflight`] | the fleet check before take-off: findings (blocker / warning) with their fixes |
//! | [`proto`] | sans-IO MAVLink micro-services, autopilot flavours and modes, image transmission |
//! | [`vision`] | the runway classifier, votes, green-pixel measurements, camera geometry |
//! | [`explore`] | lawnmower sweep and the multi-robot recursive DFS |
//! | [`planner`] | UCB bandit, the integer program, linear assignment, baselines |
//! | [`terrain`] | SRTM `.hgt` tiles parsed from bytes, the terrain protocol's grids, which squares to send |
//! | [`world`] | ground-truth worlds parsed from TOML text: what the simulator renders and runs are scored against |
//! | [`time`] | the core's notion of time: plain values handed in by the shell |

#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![warn(unreachable_pub)]

pub mod budget;
pub mod explore;
pub mod geo;
mod identity;
mod kinds;
pub mod mission;
pub mod planner;
pub mod preflight;
pub mod proto;
pub mod terrain;
pub mod time;
pub mod vision;
pub mod world;
