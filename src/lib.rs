//! fleetmap — a terminal ground-control station that maps regions of interest with fleets of
//! PX4 and ArduPilot vehicles over MAVLink.
//!
//! The crate follows the layering of `docs/architecture.md`: a pure core (no sockets, no files, no clock
//! reads; time is a [`time::Time`] parameter) and a thin async shell (link, fleet, app, UI)
//! built on tokio. Module responsibilities:
//!
//! | module | layer | responsibility |
//! |---|---|---|
//! | [`geo`] | core | mission grid, cell ↔ UTM ↔ WGS84, polygons → cells |
//! | [`mission`] | core | mission items, mission definition files, QGC file formats |
//! | [`proto`] | core | sans-IO MAVLink micro-services and autopilot flavours |
//! | [`vision`] | core | the runway classifier, votes, green-pixel measurements, camera geometry |
//! | [`explore`] | core | lawnmower sweep and the multi-robot recursive DFS |
//! | [`planner`] | core | UCB bandit, the integer program, linear assignment, baselines |
//! | [`world`] | core | ground-truth worlds (regions and surfaces) parsed from TOML text: what the simulator renders and runs are scored against |
//! | [`store`] | core + files | the crash-safe run directory |
//! | [`sim`] | core + thin server | the simulated autopilot and camera (worlds: [`world`]) |
//! | [`link`] | shell | transports, framing, signing, tlogs |
//! | [`clock`] | shell | the only clock reader: the monotonic clock (tokio's, virtual when paused) and the planner's stopwatch |
//! | [`fleet`] | shell | the fleet actor and per-vehicle async operations |
//! | [`imagery`] | shell | image sources (MAVLink image transfer, directories, simulated camera) |
//! | [`app`] | shell | mission runners (runway mapping, bandit sorties, resume) |
//! | [`tui`] | shell | the ratatui operator interface |
//! | [`experiment`] | batch | Monte Carlo studies reproducing the papers |
//! | [`files`] | shell | the edge's loaders: the only place mission files, image files and `file://` URLs are read |
//! | [`cli`] | entry | the `fleetmap` command line |

#![forbid(unsafe_code)]
#![warn(missing_docs)]
#![warn(unreachable_pub)]

pub mod app;
pub mod cli;
#[cfg(feature = "sim")]
pub mod experiment;
pub mod fleet;
mod plot;
pub mod store;
pub mod tui;
