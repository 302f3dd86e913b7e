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
//! | [`kinds`] | the mission kinds, one folder each, and their registry: the runway-mapping run ([`kinds::runway`]) and the spatial-classification run ([`kinds::bandit`]) |
//! | [`launch`] | the one way to start or resume a run, for every door (`run`, `resume`, `tui`, `demo`); with `sim`, the demos and the embedded simulator's fleet |
//! | [`app`] | the run engine: what a mission kind is ([`app::kind::RunKind`]), the run core, the image hub, flight steps, terrain, the team, the preflight gate, the layer's errors |
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
pub mod kinds;
pub mod launch;
pub mod panes;
mod plot;
pub mod store;
pub mod tui;
