//! Mission runners that tie the layers together (async shell): the runway-mapping run, the
//! bandit sortie run and resuming a run directory.
//!
//! | module | what |
//! |---|---|
//! | [`run`] | the run core both runners share: state lock, durable commits through the store task, progress, view, tracker |
//! | [`images`] | every image the fleet takes as one stream (MAVLink image transmission, file URLs), and the run's image hub |
//! | [`crop`] | the centre crops of a picture both missions measure (3 × 3 cells, a share of one cell) |
//! | [`flight`] | flight steps with timeouts: take off, fly to a point and settle, capture, land |
//! | [`error`] | the layer's typed errors ([`error::RunError`]): what failed, on which file or vehicle, with its cause |
//! | [`kind`] | one mission kind ([`kind::RunKind`]): what run, resume, report, export, the TUI session and the demo need of a runner |
//! | [`runway`] | the runway-mapping run (sweep, confirmation, DFS, battery swaps, resume): events, pilot, intake, sweep, runner; its report and GeoJSON / KML / PNG exports, IoU against a simulated world |
//! | [`bandit`] | the spatial-classification run (epochs, sorties with charging rovers, measurements, resume): events, runner, sortie, pilot, intake, upload; its report (keep / reject / errors, per-epoch figures) and the progress PNG (Fig. 4) |
//! | [`terrain`] | terrain served from a folder of SRTM tiles: every vehicle's TERRAIN_REQUEST answered, what each waits for |
//! | `team` | connecting to a run's team: every vehicle heard, one autopilot per system id, the grid's origin |
//! | `blocking` | blocking work (the classifier, run-directory files) run off the async reactor |
//! | [`sim_fleet`] | the embedded simulator and a fleet on it, started together over loopback UDP or in-process links (the demo, the bandit team, tests) |
//! | [`bandit_sim`] | the embedded simulator with drones and charging rovers (`fleetmap demo --bandit`, tests) |

pub mod bandit;
#[cfg(feature = "sim")]
pub mod bandit_sim;
pub(crate) mod blocking;
#[cfg(feature = "sim")]
pub mod demo;
pub mod error;
pub mod flight;
pub mod images;
pub mod kind;
pub mod kinds;
pub(crate) mod launch;
pub(crate) mod preflight;
pub mod run;
pub mod runway;
pub(crate) mod session;
#[cfg(feature = "sim")]
pub mod sim_fleet;
pub(crate) mod team;
pub(crate) mod terrain;
