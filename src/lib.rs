//! fleetmap — a terminal ground-control station that maps regions of interest with fleets of
//! PX4 and ArduPilot vehicles over MAVLink.
//!
//! This package is the ground station, the top of a workspace of crates (docs/architecture.md,
//! "Crates"): the pure core that decides (`fleetmap_core`: grid, mission files, sans-IO MAVLink
//! machines, vision, exploration, planner, worlds, time), the I/O edge (`fleetmap_io`: links,
//! the clock, files), the simulated autopilot (`fleetmap_sim`, behind the default `sim`
//! feature) and the MAVLink camera (`fleetmap_camera`). Its own modules are the async shell
//! on tokio, top-down (the arrows between them, derived from the code:
//! docs/architecture.md, "Layers"):
//!
//! | module | responsibility |
//! |---|---|
//! | [`cli`] | the `fleetmap` command line: one file per subcommand, `mod.rs` declares and dispatches |
//! | [`tui`] | the ratatui operator interface: pure update, one view per pane, replay files |
//! | [`experiment`] | (feature `sim`) the Monte Carlo studies that reproduce the papers' tables and figures |
//! | [`app`] | the runs: one mission kind ([`app::kind::RunKind`]) and their registry, the run core, the runway-mapping and spatial-classification runners, the image hub, flight steps, the live session; with `sim`, the demos |
//! | [`fleet`] | the fleet actor: one task owning every vehicle's state and protocol machines, and its handle |
//! | [`store`] | the crash-safe run directory: atomic snapshots, the append-only journal, the store task |
//! | [`panes`] | what a run shows: the view-model the UI draws and each mission kind fills, plain `serde` data |
//! | `plot` | the font every PNG plot draws its text with |

#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![warn(unreachable_pub)]

pub mod app;
pub mod cli;
#[cfg(feature = "sim")]
pub mod experiment;
pub mod fleet;
pub mod panes;
mod plot;
pub mod store;
pub mod tui;
