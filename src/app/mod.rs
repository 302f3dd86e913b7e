//! The run engine (async shell): what a mission kind is, and how a run of any kind starts,
//! flies, is saved and resumes. The kinds themselves are [`crate::kinds`] (each a folder and
//! one registry line); starting a run from a door (`run`, `resume`, `tui`, `demo`) is
//! [`crate::launch`]. Nothing here names a kind.
//!
//! | module | what |
//! |---|---|
//! | [`kind`] | one mission kind ([`kind::RunKind`]): its state, report, exports, resume, how it flies headless or in the TUI, the operator's commands and the panes' view |
//! | `preflight` | the fleet check on a connected fleet, and the gate it puts before every start |
//! | [`run`] | the run core every runner shares: state lock, durable commits through the store task, progress, view, tracker |
//! | [`images`] | every image the fleet takes as one stream (MAVLink image transmission, file URLs), and the run's image hub |
//! | [`flight`] | flight steps with timeouts: take off, fly to a point and settle, capture, land |
//! | `terrain` | terrain served from a folder of SRTM tiles: every vehicle's TERRAIN_REQUEST answered, what each waits for |
//! | `team` | connecting to a run's team: every vehicle heard, one autopilot per system id, the grid's origin |
//! | `command` | what an operator asks of a run or a vehicle ([`crate::tui::Command`], `Target`) and why it was not done (`CommandError`): the UI sends them, the kinds answer them |
//! | `blocking` | blocking work (the classifier, run-directory files) run off the async reactor |
//! | [`error`] | the layer's typed errors ([`error::RunError`] wrapping [`error::RunnerError`]): what failed, in which step, on which file or vehicle, with its cause |

pub(crate) mod blocking;
pub(crate) mod command;
pub mod error;
pub mod flight;
pub mod images;
pub mod kind;
pub(crate) mod preflight;
pub mod run;
pub(crate) mod team;
pub(crate) mod terrain;
