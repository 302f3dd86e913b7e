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

/// A blocking task (`crate::app::runway::cpu`: the classifier, file I/O) panicked or was
/// cancelled.
#[derive(Debug, thiserror::Error)]
#[error("classifier task")]
pub struct CpuError(#[source] pub tokio::task::JoinError);

/// Why a run could not be started, resumed, flown or reported.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Two or more autopilots answer as one of the run's system ids: the run does not start
    /// (nothing was uploaded, armed or switched), or a resumed one does not go on.
    #[error(
        "REFUSED: two or more autopilots answer as system id {sysid} ({evidence}); nothing \
         was uploaded, armed or switched. {}",
        crate::fleet::SysidConflict::FIX
    )]
    SysidConflict {
        /// The shared system id.
        sysid: u8,
        /// What showed it.
        evidence: String,
    },
    /// The fleet check found what would make the run fail (`app::preflight`): the run
    /// does not start unless the operator overrides it with `--ignore-check`.
    #[error(
        "REFUSED: the fleet check found {blockers} blocker(s); nothing was uploaded, armed or \
         switched. Fix them, or start anyway with --ignore-check.\n{report}"
    )]
    CheckFailed {
        /// How many blockers.
        blockers: usize,
        /// Every finding, as printed.
        report: String,
    },
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
    /// The flight failed: what a runner reported, with its causes.
    #[error(transparent)]
    Flight(RunnerError),
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

/// Why a runner (runway or bandit), its pilots or the simulated demo fleet stopped: a
/// vehicle that refused or did not answer, a task that failed, a check on the way that did not
/// hold. A step's error is wrapped, outermost first, in what the runner was doing and on which
/// vehicle ([`RunnerError::Context`]), so the one-line report reads "what: why: deeper why".
#[derive(Debug, thiserror::Error)]
pub enum RunnerError {
    /// A vehicle refused a command or did not answer, or the fleet's task is gone.
    #[error(transparent)]
    Fleet(#[from] FleetError),
    /// A flight step (take-off, a move, a capture) failed.
    #[error(transparent)]
    Step(#[from] crate::app::flight::FlightError),
    /// The vehicles refused the sortie's missions.
    #[error(transparent)]
    Rejected(#[from] SortieRejected),
    /// The fleet's event channel closed: the fleet stopped under the runner.
    #[error("the fleet stopped")]
    FleetStopped,
    /// The run directory could not be written (the error names the file).
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The mission grid or a position on it could not be computed.
    #[error(transparent)]
    Geo(#[from] fleetmap_core::geo::GeoError),
    /// The runway-mapping state refused a change.
    #[error(transparent)]
    Mapping(#[from] fleetmap_core::explore::mapping::MappingError),
    /// The bandit planner could not make or check a sortie.
    #[error(transparent)]
    Sortie(#[from] fleetmap_core::planner::sortie::SortieError),
    /// A vehicle's autopilot has no mode for what the runner needs.
    #[error(transparent)]
    Flavour(#[from] fleetmap_core::proto::flavour::FlavourError),
    /// The explorer (the runway's next cells) refused a step.
    #[error(transparent)]
    Explore(#[from] fleetmap_core::explore::ExploreError),
    /// The run store's thread is gone (a save panicked): nothing more can be saved.
    // The store's own message (`StoreGone` is crate-private, so not a source here).
    #[error("{}", crate::store::task::StoreGone)]
    StoreGone,
    /// The run store's thread could not be started.
    #[error("starting the run store thread")]
    StoreThread(#[source] std::io::Error),
    /// A blocking task (the classifier, file I/O) failed.
    #[error(transparent)]
    Cpu(#[from] CpuError),
    /// A task of the runner (a pilot, the planner, an upload) panicked or was cancelled.
    #[error("{task} failed")]
    Task {
        /// Which task ("drone task", "planner task").
        task: &'static str,
        /// The runtime's answer.
        #[source]
        source: tokio::task::JoinError,
    },
    /// A list a vehicle holds is not the one sent to it.
    #[error("the {what} read back differs from the one sent")]
    ReadBack {
        /// The list ("sweep", "list").
        what: &'static str,
        /// The first difference.
        #[source]
        source: fleetmap_core::mission::wire::ItemsDiffer,
    },
    /// A bandit mission would cross a no-fly cell (or leave the area, or a station its
    /// roads), before upload or as the vehicle read it back.
    #[error("{role} {sysid}: the mission{} is unsafe", if *.read_back { " as read back" } else { "" })]
    UnsafeMission {
        /// The vehicle's role ("drone", "station", "vehicle").
        role: &'static str,
        /// The vehicle.
        sysid: u8,
        /// Whether the list checked is the one the vehicle returned.
        read_back: bool,
        /// The first violation.
        #[source]
        source: fleetmap_core::planner::sortie::missions::UnsafeMission,
    },
    /// A check the runner makes on its way did not hold; the message says what, and on which
    /// vehicle. A person must see to it (`RunnerError::needs_person`).
    #[error("{0}")]
    Check(String),
    /// A vehicle did not get where it was going, or a sortie did not end, in time: a link
    /// outage or a slow rendezvous, which trying again may get past. The message says which
    /// vehicle and what it was doing.
    #[error("{0}")]
    Overdue(String),
    /// What the runner was doing (and on which vehicle) when `source` failed.
    #[error("{what}")]
    Context {
        /// The step, naming its vehicle where it has one.
        what: String,
        /// Why it failed.
        #[source]
        source: Box<RunnerError>,
    },
    /// An error of the layer itself, met while flying.
    #[error(transparent)]
    Run(Box<RunError>),
}

impl RunnerError {
    /// A failed check: `what` says what did not hold, and on which vehicle.
    pub(crate) fn check(what: impl Into<String>) -> Self {
        RunnerError::Check(what.into())
    }

    /// A task's failure as an error: `task` names it ("drone task").
    pub(crate) fn task(task: &'static str) -> impl FnOnce(tokio::task::JoinError) -> Self {
        move |source| RunnerError::Task { task, source }
    }

    /// This error as the cause of the step `what`.
    pub(crate) fn context(self, what: impl Into<String>) -> Self {
        RunnerError::Context {
            what: what.into(),
            source: Box::new(self),
        }
    }

    /// Whether this error is a fleet error (itself or under the steps that name it,
    /// [`RunnerError::Context`]) that says the vehicle did not answer
    /// ([`FleetError::is_transient`]), so that trying again may succeed. A flight step's
    /// error ([`RunnerError::Step`]) is final, as it was when the runners looked for a fleet
    /// error in the chain of causes (the step's fleet error is transparent, not a cause).
    pub(crate) fn is_transient(&self) -> bool {
        match self {
            RunnerError::Fleet(e) => e.is_transient(),
            RunnerError::Context { source, .. } => source.is_transient(),
            _ => false,
        }
    }

    /// What a person must fix before trying again can succeed, for the operator; `None`
    /// when the failure may go away by itself — a lost ACK, a link outage that ends, a
    /// vehicle late at a rendezvous ([`RunnerError::Overdue`]), a flight step that timed
    /// out. The fleet's rule for a fleet error ([`FleetError::needs_person`]: a vehicle that
    /// never became ready, a pre-arm failure that persists, a list the autopilot refuses),
    /// also under a flight step or a step's context; a refused sortie, an unsafe or
    /// different mission, a failed check of the runner (placement, charger, camera), the
    /// run store and the layer's own errors need a person. `fleetmap run --auto-resume`
    /// carries on through the first kind and stops for the second.
    pub(crate) fn needs_person(&self) -> Option<String> {
        use crate::app::flight::FlightError;
        match self {
            RunnerError::Fleet(e) | RunnerError::Step(FlightError::Fleet(e)) => e.needs_person(),
            RunnerError::Step(FlightError::ImagesClosed) => Some(self.to_string()),
            RunnerError::Step(_) | RunnerError::Overdue(_) => None,
            RunnerError::Context { source, .. } => source.needs_person(),
            other => Some(other.to_string()),
        }
    }
}

impl From<RunnerError> for RunError {
    fn from(e: RunnerError) -> Self {
        // An error of the layer that a runner met stays that error.
        match e {
            RunnerError::Run(r) => *r,
            other => RunError::Flight(other),
        }
    }
}

impl From<crate::store::task::StoreGone> for RunnerError {
    fn from(_: crate::store::task::StoreGone) -> Self {
        RunnerError::StoreGone
    }
}

impl From<RunError> for RunnerError {
    fn from(e: RunError) -> Self {
        match e {
            RunError::Flight(f) => f,
            other => RunnerError::Run(Box::new(other)),
        }
    }
}

/// A runner's result.
pub(crate) type RunnerResult<T> = Result<T, RunnerError>;

/// Name the step a [`RunnerResult`] (or an absent value) failed in.
pub(crate) trait Context<T> {
    /// The error (or the absence) as the cause of the step `what`.
    fn context(self, what: impl Into<String>) -> RunnerResult<T>;
    /// Like [`Context::context`], the step's name made only on failure.
    fn with_context<W: Into<String>>(self, what: impl FnOnce() -> W) -> RunnerResult<T>;
}

impl<T, E: Into<RunnerError>> Context<T> for Result<T, E> {
    fn context(self, what: impl Into<String>) -> RunnerResult<T> {
        self.map_err(|e| e.into().context(what))
    }

    fn with_context<W: Into<String>>(self, what: impl FnOnce() -> W) -> RunnerResult<T> {
        self.map_err(|e| e.into().context(what()))
    }
}

impl<T> Context<T> for Option<T> {
    fn context(self, what: impl Into<String>) -> RunnerResult<T> {
        self.ok_or_else(|| RunnerError::check(what))
    }

    fn with_context<W: Into<String>>(self, what: impl FnOnce() -> W) -> RunnerResult<T> {
        self.ok_or_else(|| RunnerError::check(what()))
    }
}

/// Why a sortie stopped before take-off.
#[derive(Debug, thiserror::Error)]
#[error(
    "the sortie of epoch {epoch}, cycle {cycle} stopped before take-off: vehicle {sysid} \
     rejected its mission: {reason}"
)]
pub struct SortieRejected {
    /// Epoch p.
    pub epoch: u64,
    /// Cycle.
    pub cycle: usize,
    /// The vehicle.
    pub sysid: u8,
    /// Why.
    pub reason: String,
}

/// Why a simulated fleet (the demo's, the bandit's) could not be started.
#[cfg(feature = "sim")]
#[derive(Debug, thiserror::Error)]
pub enum SimStartError {
    /// The speed-up is zero, negative or not a number.
    #[error("the speed-up must be positive")]
    Speed,
    /// The simulator's vehicles or world are wrong.
    #[error(transparent)]
    Sim(#[from] fleetmap_sim::harness::SimError),
    /// A connection string the simulator cannot serve (the message names it).
    #[error(transparent)]
    Connection(fleetmap_sim::server::ServerError),
    /// The simulator's links could not be opened.
    #[error("starting the simulator")]
    Server(#[source] fleetmap_sim::server::ServerError),
    /// A link between the fleet and the simulator could not be opened.
    #[error(transparent)]
    Link(#[from] fleetmap_io::link::transport::LinkError),
    /// A link's address is wrong (the message names it).
    #[error("{0}")]
    Address(#[from] fleetmap_io::link::ConnSpecError),
    /// The fleet's UDP socket reports no local address to point the simulator at.
    #[error("the GCS's UDP port has no local address")]
    NoLocalAddress,
    /// A built-in mission has errors (each named with its line).
    #[error("{0}")]
    Mission(DefErrors),
    /// A built-in mission lacks the line the demo rewrites to set the battery.
    #[error("the built-in mission {file} has no line `{line}` to set the battery in")]
    NoBatteryLine {
        /// The mission's file name.
        file: String,
        /// The line looked for.
        line: &'static str,
    },
    /// The world's regions of interest move at different velocities; the runner maps one
    /// moving frame.
    #[error(
        "the world {world} has regions of interest moving at different velocities; the \
         runner maps one moving frame"
    )]
    MovingRegions {
        /// The world's name.
        world: String,
    },
}

/// `e` and its causes on one line, "what: why: deeper why" (as the command line prints them), for
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

    /// A runner's error keeps its whole context chain through [`RunError`]: the session's
    /// log ([`chain`]) prints "what: why: deeper why", outermost step first, down to the
    /// store's error.
    #[test]
    fn a_runners_error_reads_the_same_through_run_error() {
        let inner: Result<(), crate::store::task::StoreGone> = Err(crate::store::task::StoreGone);
        let runner = inner
            .context("writing the run journal")
            .context("vehicle 3: pilot task failed")
            .unwrap_err();
        let expected = "vehicle 3: pilot task failed: writing the run journal: the run store \
                        task stopped (a save panicked): nothing more can be saved";
        assert_eq!(chain(&runner), expected);
        let typed = RunError::from(runner);
        assert!(matches!(typed, RunError::Flight(_)));
        assert_eq!(chain(&typed), expected);
    }

    /// An error of the layer a runner met comes out of it as itself, not wrapped.
    #[test]
    fn a_run_error_passes_through_a_runner_unwrapped() {
        let runner = RunnerError::from(RunError::NoVehicles);
        assert!(matches!(RunError::from(runner), RunError::NoVehicles));
    }

    /// A fleet error that says the vehicle did not answer is transient under the runner's
    /// steps; a check that failed is not.
    #[test]
    fn transient_looks_through_the_steps() {
        let e = RunnerError::from(FleetError::NotConfirmed {
            sysid: 2,
            what: "armed".into(),
            waited_s: 5.0,
            now: "disarmed".into(),
        })
        .context("vehicle 2: arming");
        assert!(e.is_transient());
        assert!(
            !RunnerError::check("no sortie")
                .context("starting")
                .is_transient()
        );
    }

    /// What `--auto-resume` carries on through and what it stops for: a lost link, a take-off
    /// refused because the copter had disarmed meanwhile, a late rendezvous, a flight step
    /// that timed out go away by themselves; a pre-arm failure that persists, a vehicle that
    /// never became ready, a refused list, a failed check of the runner need a person, also
    /// under the runner's steps.
    #[test]
    fn what_a_person_must_fix_and_what_goes_away() {
        use crate::fleet::StateSeen;
        use fleetmap_core::proto::command::CommandError;
        use fleetmap_core::proto::launch::{Cause, Goal, Landed, LaunchFailure, Step};
        use mavlink::dialects::ardupilotmega::MavCmd;
        use std::time::Duration;
        let state = |prearm: Option<&str>| StateSeen {
            heard: true,
            armed: false,
            mode: "GUIDED".into(),
            landed: Landed::OnGround,
            alt_rel_m: Some(0.0),
            prearm: prearm.map(Into::into),
        };
        let started = |cause: Cause, prearm: Option<&str>| {
            RunnerError::from(FleetError::NotStarted {
                sysid: 4,
                failure: Box::new(LaunchFailure {
                    goal: Goal::Airborne { mode: None },
                    commands: 6,
                    failures: 5,
                    waited: Duration::from_secs(40),
                    cause,
                }),
                state: Box::new(state(prearm)),
            })
            .context("drone 4: starting")
        };
        let takeoff = CommandError::Failed {
            command: MavCmd::MAV_CMD_NAV_TAKEOFF,
        };
        let arm = CommandError::Failed {
            command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
        };
        let goes_away = [
            started(
                Cause::Silent {
                    waited: Duration::from_secs(20),
                },
                None,
            ),
            started(
                Cause::Refused {
                    step: Step::Takeoff,
                    error: takeoff,
                },
                None,
            ),
            RunnerError::Overdue("drone 2: station 5 never reached the rendezvous".into()),
            RunnerError::from(FleetError::Command {
                sysid: 1,
                error: CommandError::Timeout {
                    command: MavCmd::MAV_CMD_MISSION_START,
                    attempts: 4,
                    timeout_ms: 1000,
                },
            }),
        ];
        for e in &goes_away {
            assert_eq!(e.needs_person(), None, "{e}");
        }
        let person = [
            started(
                Cause::Refused {
                    step: Step::Arm,
                    error: arm,
                },
                Some("PreArm: Compass not calibrated"),
            ),
            RunnerError::from(FleetError::NotReady {
                sysid: 4,
                waited_s: 60.0,
                reasons: vec!["pre-arm failure reported: PreArm: Compass not calibrated".into()],
            })
            .context("drone 4: starting"),
            RunnerError::check("drone 3 is not charging: is it on its station's charger?"),
        ];
        for e in &person {
            assert!(e.needs_person().is_some(), "{e}");
        }
        assert!(
            person[0]
                .needs_person()
                .is_some_and(|f| f.contains("Compass not calibrated"))
        );
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
    }
}
