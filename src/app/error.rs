//! The application layer's errors: starting, resuming, flying and reporting a run.
//!
//! Each variant says what failed and on which file or vehicle, and keeps its cause as the
//! error's source, so that the command line's one-line report (`{:#}`) reads as before:
//! "what: why: deeper why".

use crate::fleet::FleetError;
use crate::store::StoreError;
use fleetmap_core::mission::definition::DefErrors;
use fleetmap_io::files::WorldFileError;
use std::path::PathBuf;

/// A blocking task ([`crate::app::runway::cpu`]: the classifier, file I/O) panicked or was
/// cancelled.
#[derive(Debug, thiserror::Error)]
#[error("classifier task")]
pub struct CpuError(#[source] pub tokio::task::JoinError);

/// Why a run could not be started, resumed, flown or reported.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A vehicle of the run stayed silent.
    #[error("no heartbeat from system {sysid} within {wait_s:.0} s")]
    NotHeard {
        /// The vehicle.
        sysid: u8,
        /// How long the run waited, seconds.
        wait_s: f64,
        /// The fleet's answer.
        #[source]
        source: FleetError,
    },
    /// A vehicle the mission file lists was not heard.
    #[error("mission vehicle {sysid} ({role})")]
    TeamVehicle {
        /// The vehicle.
        sysid: u8,
        /// Its role in the mission file (drone, station).
        role: String,
        /// The fleet's answer.
        #[source]
        source: FleetError,
    },
    /// The mission file lists no vehicles, so the grid has no vehicle to take its origin from.
    #[error("the mission lists no vehicles")]
    NoVehicles,
    /// The grid's origin is a vehicle's home, which it did not report.
    #[error(
        "vehicle {sysid} reported no home position within {wait_s:.0} s (the grid origin is \
         \"vehicle\"): is its GPS ready?"
    )]
    NoHome {
        /// The vehicle.
        sysid: u8,
        /// How long the run waited, seconds.
        wait_s: f64,
    },
    /// The mission grid could not be made at the origin.
    #[error(transparent)]
    Grid(#[from] fleetmap_core::geo::GeoError),
    /// The runway-mapping state could not be made from the mission.
    #[error(transparent)]
    Mapping(#[from] fleetmap_core::explore::mapping::MappingError),
    /// The mission file could not be read or has errors (each named with its line).
    #[error(transparent)]
    Mission(#[from] DefErrors),
    /// A world file could not be read or is wrong (the error names the file).
    #[error(transparent)]
    WorldFile(#[from] WorldFileError),
    /// The world a run directory names could not be loaded.
    #[error("world {}", path.display())]
    World {
        /// The world file.
        path: PathBuf,
        /// Why.
        #[source]
        source: WorldFileError,
    },
    /// The run directory could not be created.
    #[error("cannot create the run directory {}", path.display())]
    CreateRunDir {
        /// The directory.
        path: PathBuf,
        /// Why.
        #[source]
        source: StoreError,
    },
    /// A file of the run directory could not be written.
    #[error("{}", path.display())]
    Write {
        /// The file.
        path: PathBuf,
        /// The operating system's error.
        #[source]
        source: std::io::Error,
    },
    /// The run directory could not be read or written (the error names the file).
    #[error(transparent)]
    Store(#[from] StoreError),
    /// A run to resume has no saved state.
    #[error("{} has no saved state yet", path.display())]
    NoState {
        /// The run directory.
        path: PathBuf,
    },
    /// A finished flight left no state in its run directory.
    #[error("{}: the run saved no state", path.display())]
    NothingSaved {
        /// The run directory.
        path: PathBuf,
    },
    /// A vehicle to resume with does not report its position.
    #[error("vehicle {sysid} reports no position")]
    NoPosition {
        /// The vehicle.
        sysid: u8,
    },
    /// A run to resume has nothing left to do.
    #[error("{}: the run is already finished", path.display())]
    Finished {
        /// The run directory.
        path: PathBuf,
    },
    /// A blocking task failed.
    #[error(transparent)]
    Cpu(#[from] CpuError),
    /// The terminal UI failed.
    #[error(transparent)]
    Tui(#[from] crate::tui::TuiError),
    /// The report could not be made JSON.
    #[error("the report as JSON")]
    Json(#[from] serde_json::Error),
    /// An image could not be encoded.
    #[error("PNG encoding")]
    Png(#[from] image::ImageError),
    /// A plot could not be drawn.
    #[error(transparent)]
    Plot(#[from] PlotError),
    /// A run option is out of range (the message names the option).
    #[error("{0}")]
    Option(String),
    /// The flight failed: what a runner reported, with its causes (the runners' own errors
    /// are still untyped; see CHANGELOG, issue 27).
    #[error(transparent)]
    Flight(Box<dyn std::error::Error + Send + Sync + 'static>),
}

/// A figure (the bandit report's plot) could not be drawn.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The plotting library failed.
    #[error("plot drawing failed: {0}")]
    Drawing(String),
    /// The drawn buffer does not have the image's size.
    #[error("plot buffer size mismatch")]
    BufferSize,
    /// The drawn image could not be encoded as PNG.
    #[error("PNG encoding")]
    Encode(#[from] image::ImageError),
}

impl From<anyhow::Error> for RunError {
    fn from(e: anyhow::Error) -> Self {
        // A runner's error that already is a typed one stays that one.
        match e.downcast::<RunError>() {
            Ok(r) => r,
            Err(e) => RunError::Flight(e.into()),
        }
    }
}

/// `e` and its causes on one line, "what: why: deeper why" (as `anyhow` prints `{:#}`), for
/// the log and the title bar.
pub fn chain(e: &(dyn std::error::Error + 'static)) -> String {
    let mut line = e.to_string();
    let mut cause = e.source();
    while let Some(c) = cause {
        line.push_str(": ");
        line.push_str(&c.to_string());
        cause = c.source();
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;
    use anyhow::Context as _;

    /// A runner's error keeps its whole context chain through [`RunError`]: the command
    /// line (anyhow's `{:#}`) and the session's log ([`chain`]) print the line they printed
    /// when the runner's error reached them directly.
    #[test]
    fn a_runners_error_reads_the_same_through_run_error() {
        let inner: Result<(), std::io::Error> = Err(std::io::Error::other("disk full"));
        let runner = inner
            .context("writing the run journal")
            .context("vehicle 3: pilot task failed")
            .unwrap_err();
        let expected = format!("{runner:#}");
        let typed = RunError::from(runner);
        assert_eq!(chain(&typed), expected);
        assert_eq!(format!("{:#}", anyhow::Error::from(typed)), expected);
    }

    /// A typed error names its vehicle and keeps the fleet's answer as its cause.
    #[test]
    fn a_silent_vehicle_is_named_with_the_fleets_answer() {
        let e = RunError::NotHeard {
            sysid: 9,
            wait_s: 5.0,
            source: FleetError::NoVehicle { sysid: 9 },
        };
        let line = chain(&e);
        assert!(
            line.starts_with("no heartbeat from system 9 within 5 s: "),
            "{line}"
        );
        assert_eq!(format!("{:#}", anyhow::Error::from(e)), line);
    }
}
