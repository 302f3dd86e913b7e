//! The runs (async shell): what a mission kind is, how a run starts, flies, is saved and
//! resumes, and the two kinds this build flies — runway mapping and spatial classification.
//!
//! | module | what |
//! |---|---|
//! | [`kind`] | one mission kind ([`kind::RunKind`]): its state, report, exports, resume, how it flies headless or in the TUI, the operator's commands and the panes' view |
//! | [`kinds`] | the registry of kinds: one `registry!` line per kind; work for any kind is a `KindVisitor` |
//! | `launch` | the one way to start or resume a run (`prepare`, then `Ready::fly`), for `run`, `resume`, `tui --mission` and `demo` |
//! | `preflight` | the fleet check on a connected fleet, and the gate it puts before every start |
//! | [`run`] | the run core both runners share: state lock, durable commits through the store task, progress, view, tracker |
//! | [`runway`] | the runway-mapping run (sweep, confirmation, DFS, battery swaps, resume): events, pilot, intake, sweep, runner; its report and GeoJSON / KML / PNG exports, IoU against a simulated world |
//! | [`bandit`] | the spatial-classification run (epochs, sorties with charging rovers, measurements, resume): events, runner, sortie, pilot, intake, upload; its report (keep / reject / errors, per-epoch figures) and the progress PNG (Fig. 4) |
//! | [`images`] | every image the fleet takes as one stream (MAVLink image transmission, file URLs), and the run's image hub |
//! | [`flight`] | flight steps with timeouts: take off, fly to a point and settle, capture, land |
//! | `terrain` | terrain served from a folder of SRTM tiles: every vehicle's TERRAIN_REQUEST answered, what each waits for |
//! | `team` | connecting to a run's team: every vehicle heard, one autopilot per system id, the grid's origin |
//! | `command` | what an operator asks of a run or a vehicle ([`crate::tui::Command`], `Target`) and why it was not done (`CommandError`): the UI sends them, the kinds answer them |
//! | `blocking` | blocking work (the classifier, run-directory files) run off the async reactor |
//! | [`error`] | the layer's typed errors ([`error::RunError`] wrapping [`error::RunnerError`]): what failed, in which step, on which file or vehicle, with its cause |
//! | [`demo`] | (feature `sim`) `fleetmap demo`: what a kind's demo on the embedded simulator supplies (`demo::DemoKind`, in the kind's folder), and the flags every demo shares |
//! | [`sim_fleet`] | (feature `sim`) the embedded simulator and a fleet on it, started together over loopback UDP or in-process links (the demo, the bandit team, tests) |

pub mod bandit;
pub(crate) mod blocking;
pub(crate) mod command;
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
#[cfg(feature = "sim")]
pub mod sim_fleet;
pub(crate) mod team;
pub(crate) mod terrain;
