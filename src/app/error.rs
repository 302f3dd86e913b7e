//! The application layer's errors, in two layers that convert one way.
//!
//! [`RunnerError`] is the lower one: why a step of a run failed — the fleet, the run store, a
//! blocking task, the core's models, the team that did not come up, a check of a runner that
//! did not hold, a vehicle late — with the step it failed in ([`Step`]) wrapped around it.
//! [`RunError`] is the upper one: starting, resuming and reporting a run — its files, its
//! options, its report and figures, the terminal UI — and wraps a [`RunnerError`] as its
//! cause ([`RunError::Runner`]); a runner never meets a [`RunError`]. Each cause is a
//! variant of one of the two.
//!
//! Each variant says what failed and on which file or vehicle, and keeps its cause as the
//! error's source (`thiserror`'s `#[source]`; `#[error(transparent)]` where the cause says
//! it all), so that the command line's one-line report (`{:#}`, [`chain`]) reads "what: why:
//! deeper why".

use crate::fleet::FleetError;
use crate::store::StoreError;
use fleetmap_core::mission::definition::DefErrors;
use fleetmap_io::files::WorldFileError;
use std::path::PathBuf;

/// A blocking task (`app::blocking::run_blocking`: the classifier, file I/O)
/// panicked or was cancelled.
#[derive(Debug, thiserror::Error)]
#[error("blocking task (the classifier, file I/O)")]
pub struct BlockingError(#[source] pub tokio::task::JoinError);

/// Why a run could not be started, resumed or reported: what the layer that starts, resumes
/// and reports runs meets itself, and, as [`RunError::Runner`], what a step of the run met.
#[derive(Debug, thiserror::Error)]
pub enum RunError {
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
    /// A run to resume has nothing left to do.
    #[error("{}: the run is already finished", path.display())]
    Finished {
        /// The run directory.
        path: PathBuf,
    },
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
    /// A step of the run failed (connecting to the team, flying, saving, a blocking task):
    /// what the runner's layer reported, with its causes.
    #[error(transparent)]
    Runner(#[from] RunnerError),
}

/// The causes the run layer meets itself that are variants of the layer below
/// ([`RunnerError`]), so that each cause is one variant: the run store (opening, loading, a
/// run directory's files), the blocking tasks it runs its file work in and the grid (a
/// report scored against its world); a kind's own are its (`app::<kind>::error`). They
/// read as themselves.
macro_rules! through_runner {
    ($($cause:ty => $variant:ident),* $(,)?) => {$(
        impl From<$cause> for RunError {
            fn from(e: $cause) -> Self {
                RunError::Runner(RunnerError::$variant(e))
            }
        }
    )*};
}

through_runner! {
    StoreError => Store,
    BlockingError => Blocking,
    fleetmap_core::geo::GeoError => Geo,
}

/// The causes that are a kind's own error (`$kind`, in `app::<kind>::error`) as they are met
/// (`?`): each converts into the kind's error and so into [`RunnerError::Kind`]. With `run`
/// first, each also converts into [`RunError`] (a cause the run layer meets itself, on start
/// and resume).
macro_rules! kind_causes {
    ($kind:ty: $($cause:ty),* $(,)?) => {$(
        impl From<$cause> for $crate::app::error::RunnerError {
            fn from(e: $cause) -> Self {
                <$kind>::from(e).into()
            }
        }
    )*};
    (run $kind:ty: $($cause:ty),* $(,)?) => {
        $crate::app::error::kind_causes!($kind: $($cause),*);
        $(
            impl From<$cause> for $crate::app::error::RunError {
                fn from(e: $cause) -> Self {
                    $crate::app::error::RunError::Runner(e.into())
                }
            }
        )*
    };
}
pub(crate) use kind_causes;

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

/// Why a step of a run stopped: connecting to its team, a mission kind's runner, its
/// pilots, the run store under them. A vehicle that refused or did not answer, a task that
/// failed, a check on the way that did not hold ([`Check`]), the kind's own failure
/// ([`RunnerError::Kind`]), a vehicle late ([`RunnerError::Overdue`]).
/// A cause is wrapped in the step the runner was in ([`RunnerError::Context`], a [`Step`]),
/// so the one-line report reads "step: why: deeper why".
#[derive(Debug, thiserror::Error)]
pub enum RunnerError {
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
    /// A vehicle refused a command or did not answer, or the fleet's task is gone.
    #[error(transparent)]
    Fleet(#[from] FleetError),
    /// A flight step (take-off, a move, a capture) failed.
    #[error(transparent)]
    Flight(#[from] crate::app::flight::FlightError),
    /// The fleet's event channel closed: the fleet stopped under the runner.
    #[error("the fleet stopped")]
    FleetStopped,
    /// The run directory could not be read or written (the error names the file).
    #[error(transparent)]
    Store(#[from] StoreError),
    /// The mission grid or a position on it could not be computed.
    #[error(transparent)]
    Geo(#[from] fleetmap_core::geo::GeoError),
    /// A vehicle's autopilot has no mode for what the runner needs.
    #[error(transparent)]
    Flavour(#[from] fleetmap_core::proto::flavour::FlavourError),
    /// The run store's thread is gone (a save panicked): nothing more can be saved.
    // The store's own message (`StoreGone` is crate-private, so not a source here).
    #[error("{}", crate::store::task::StoreGone)]
    StoreGone,
    /// The run store's thread could not be started.
    #[error("starting the run store thread")]
    StoreThread(#[source] std::io::Error),
    /// A blocking task (the classifier, file I/O) failed.
    #[error(transparent)]
    Blocking(#[from] BlockingError),
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
    /// A check the runner makes on its way did not hold. A person must see to it
    /// (`RunnerError::needs_person`).
    #[error(transparent)]
    Check(#[from] Check),
    /// What the mission kind's runner met that is the kind's own (its planner's or its
    /// explorer's refusal, a check of its own that did not hold): the kind's error
    /// (`app::<kind>::error`), read typed with [`RunnerError::kind`]. A person must see to
    /// it (`RunnerError::needs_person`).
    #[error(transparent)]
    Kind(KindError),
    /// A vehicle did not get where it was going, or did not end what it flew, in time: a
    /// link outage or a slow rendezvous, which trying again may get past. The kind's own
    /// delay (`app::<kind>::error`), read typed with [`RunnerError::kind`].
    #[error(transparent)]
    Overdue(KindError),
    /// The step the runner was in (and its vehicle) when `source` failed.
    #[error("{step}")]
    Context {
        /// The step.
        step: Step,
        /// Why it failed.
        #[source]
        source: Box<RunnerError>,
    },
}

/// A mission kind's own error (`app::<kind>::error`), boxed so that the runner's layer
/// names no kind: it reads as itself (its message, then its causes) and
/// [`KindError::get`] reads it back typed.
#[derive(Debug)]
pub struct KindError(Box<dyn std::error::Error + Send + Sync + 'static>);

impl KindError {
    /// `e`, a kind's error, as the runner's layer carries it.
    pub(crate) fn new(e: impl std::error::Error + Send + Sync + 'static) -> KindError {
        KindError(Box::new(e))
    }

    /// The kind's error, if it is an `E`.
    pub fn get<E: std::error::Error + 'static>(&self) -> Option<&E> {
        self.0.downcast_ref()
    }
}

impl std::fmt::Display for KindError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}

impl std::error::Error for KindError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        self.0.source()
    }
}

/// The step of a run an error is wrapped in ([`RunnerError::Context`]); it reads as the
/// operator sees it before the cause.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// Uploading a runway vehicle's sweep and reading it back.
    SweepUpload {
        /// The vehicle.
        sysid: u8,
    },
    /// A runway vehicle's pilot task.
    Pilot {
        /// The vehicle.
        sysid: u8,
    },
    /// Making the geofence of the bandit area's no-fly cells.
    BuildGeofence,
    /// Uploading and enabling the geofence on a vehicle.
    Geofence {
        /// The vehicle.
        sysid: u8,
    },
    /// Saving the run's state in its directory.
    SaveState,
    /// Appending the run's events to its journal.
    Journal,
}

impl std::fmt::Display for Step {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Step::SweepUpload { sysid } | Step::Pilot { sysid } => write!(f, "vehicle {sysid}"),
            Step::BuildGeofence => f.write_str("building the geofence"),
            Step::Geofence { sysid } => {
                write!(
                    f,
                    "vehicle {sysid} refused the geofence of the no-fly cells"
                )
            }
            Step::SaveState => f.write_str("saving the run state"),
            Step::Journal => f.write_str("writing the run journal"),
        }
    }
}

/// A check a runner makes on its way that did not hold: what it needed and did not find,
/// and on which vehicle.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum Check {
    /// The vehicle's autopilot has no mode that flies a mission.
    #[error("no mission mode")]
    NoMissionMode,
    /// A vehicle the runner needs is not in the fleet's snapshot.
    #[error("vehicle {sysid} is not heard")]
    NotHeard {
        /// The vehicle.
        sysid: u8,
    },
    /// A vehicle reports no position.
    #[error("vehicle {sysid} reports no position")]
    NoPosition {
        /// The vehicle.
        sysid: u8,
    },
    /// A vehicle reports no usable position yet (no GPS fix and home).
    #[error("vehicle {sysid} reports no position yet (no GPS fix and home)")]
    NoPositionYet {
        /// The vehicle.
        sysid: u8,
    },
    /// A vehicle reported no usable position while the run waited for it.
    #[error("vehicle {sysid} reported no position (a GPS fix and a home) within {wait_s:.0} s")]
    NoPositionWithin {
        /// The vehicle.
        sysid: u8,
        /// How long the run waited, seconds.
        wait_s: f64,
    },
    /// A vehicle's position is not on the mission grid.
    #[error("vehicle {sysid}: bad position")]
    BadPosition {
        /// The vehicle.
        sysid: u8,
    },
}

impl RunnerError {
    /// A task's failure as an error: `task` names it ("drone task").
    pub(crate) fn task(task: &'static str) -> impl FnOnce(tokio::task::JoinError) -> Self {
        move |source| RunnerError::Task { task, source }
    }

    /// This error as the cause of `step`.
    pub(crate) fn context(self, step: Step) -> Self {
        RunnerError::Context {
            step,
            source: Box::new(self),
        }
    }

    /// The steps this error is wrapped in, outermost first.
    pub fn steps(&self) -> Vec<Step> {
        let mut steps = Vec::new();
        let mut e = self;
        while let RunnerError::Context { step, source } = e {
            steps.push(*step);
            e = source;
        }
        steps
    }

    /// The cause under the steps ([`RunnerError::Context`]) this error is wrapped in.
    pub fn cause(&self) -> &RunnerError {
        match self {
            RunnerError::Context { source, .. } => source.cause(),
            other => other,
        }
    }

    /// The mission kind's own error under the steps ([`RunnerError::Kind`],
    /// [`RunnerError::Overdue`]), if it is an `E`.
    pub fn kind<E: std::error::Error + 'static>(&self) -> Option<&E> {
        match self.cause() {
            RunnerError::Kind(e) | RunnerError::Overdue(e) => e.get(),
            _ => None,
        }
    }

    /// Whether this error is a fleet error (itself or under the steps that name it,
    /// [`RunnerError::Context`]) that says the vehicle did not answer
    /// ([`FleetError::is_transient`]), so that trying again may succeed. A flight step's
    /// error ([`RunnerError::Flight`]) is final, as it was when the runners looked for a
    /// fleet error in the chain of causes (the step's fleet error is transparent, not a
    /// cause).
    pub(crate) fn is_transient(&self) -> bool {
        match self.cause() {
            RunnerError::Fleet(e) => e.is_transient(),
            _ => false,
        }
    }

    /// What a person must fix before trying again can succeed, for the operator; `None`
    /// when the failure may go away by itself — a lost ACK, a link outage that ends, a
    /// vehicle late at a rendezvous ([`RunnerError::Overdue`]), a flight step that timed
    /// out. The fleet's rule for a fleet error ([`FleetError::needs_person`]: a vehicle that
    /// never became ready, a pre-arm failure that persists, a list the autopilot refuses),
    /// also under a flight step or a step's context; a refused sortie, an unsafe or
    /// different mission, a failed check of the runner (placement, charger, camera), a team
    /// that did not come up, the run store and the rest need a person. `fleetmap run
    /// --auto-resume` carries on through the first kind and stops for the second.
    pub(crate) fn needs_person(&self) -> Option<String> {
        use crate::app::flight::FlightError;
        match self.cause() {
            RunnerError::Fleet(e) | RunnerError::Flight(FlightError::Fleet(e)) => e.needs_person(),
            e @ RunnerError::Flight(FlightError::ImagesClosed) => Some(e.to_string()),
            RunnerError::Flight(_) | RunnerError::Overdue(_) => None,
            other => Some(other.to_string()),
        }
    }
}

impl From<crate::store::task::StoreGone> for RunnerError {
    fn from(_: crate::store::task::StoreGone) -> Self {
        RunnerError::StoreGone
    }
}

/// A runner's result.
pub(crate) type RunnerResult<T> = Result<T, RunnerError>;

/// Name the step a result failed in ([`RunnerError::Context`]).
pub(crate) trait Context<T> {
    /// The error as the cause of `step`.
    fn context(self, step: Step) -> RunnerResult<T>;
}

impl<T, E: Into<RunnerError>> Context<T> for Result<T, E> {
    fn context(self, step: Step) -> RunnerResult<T> {
        self.map_err(|e| e.into().context(step))
    }
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
    use crate::kinds::bandit::error::{BanditError, Overdue, SortieStage};
    use std::time::Duration;

    /// A runner's error keeps its whole context chain through [`RunError`]: the session's
    /// log ([`chain`]) prints "step: why: deeper why", outermost step first, down to the
    /// store's error; the steps can be matched on.
    #[test]
    fn a_runners_error_reads_the_same_through_run_error() {
        let inner: Result<(), crate::store::task::StoreGone> = Err(crate::store::task::StoreGone);
        let runner = inner
            .context(Step::Journal)
            .context(Step::Pilot { sysid: 3 })
            .unwrap_err();
        let expected = "vehicle 3: writing the run journal: the run store task stopped (a save \
                        panicked): nothing more can be saved";
        assert_eq!(chain(&runner), expected);
        assert_eq!(runner.steps(), [Step::Pilot { sysid: 3 }, Step::Journal]);
        assert!(matches!(runner.cause(), RunnerError::StoreGone));
        let typed = RunError::from(runner);
        assert!(matches!(typed, RunError::Runner(_)));
        assert_eq!(chain(&typed), expected);
    }

    /// The run layer's own store errors read as the store's, as the layer below's cause.
    #[test]
    fn a_store_error_of_the_run_layer_reads_as_itself() {
        let e = StoreError::NotARun {
            path: PathBuf::from("runs/x"),
        };
        let line = e.to_string();
        let typed = RunError::from(e);
        assert!(matches!(typed, RunError::Runner(RunnerError::Store(_))));
        assert_eq!(chain(&typed), line);
    }

    /// The typed checks, delays and steps read as the messages the runners wrote before
    /// they were typed (what the operator reads, and what `--auto-resume` prints).
    #[test]
    fn typed_checks_read_as_the_operator_read_them() {
        let cases: [(String, &str); 7] = [
            (
                BanditError::NotCharging {
                    sysid: 3,
                    pct: 41,
                    need_pct: 79.6,
                    nearest: " It is 2.5 m from station 5.".into(),
                }
                .to_string(),
                "drone 3 is not charging (stuck at 41 %, the sortie needs 80 %): put it on its \
                 station's charger or swap its battery It is 2.5 m from station 5.",
            ),
            (
                BanditError::NoPlan {
                    epoch: 2,
                    status: "infeasible",
                    message: String::new(),
                    cycles: 8,
                }
                .to_string(),
                "epoch 2: the planner found no plan (infeasible): the goals cannot be reached \
                 from where the team is within 8 sensing cycles",
            ),
            (
                BanditError::NoPlan {
                    epoch: 2,
                    status: "error",
                    message: "time limit".into(),
                    cycles: 8,
                }
                .to_string(),
                "epoch 2: the planner found no plan (error: time limit): the goals cannot be \
                 reached from where the team is within 8 sensing cycles",
            ),
            (
                BanditError::Misplaced {
                    sysid: 1,
                    distance_m: 9.31,
                    cell: fleetmap_core::geo::Cell { row: 0, col: 2 },
                }
                .to_string(),
                "vehicle 1 is 9.3 m from the centre of its start cell (0, 2): place it there (or \
                 fix `start` in the mission file)",
            ),
            (
                Overdue::TakenOut {
                    sysid: 2,
                    mode: "RTL".into(),
                }
                .to_string(),
                "drone 2: taken out of its mission by its autopilot (RTL), it has not landed by \
                 the end of the sortie",
            ),
            (
                Overdue::Landing {
                    sysid: 2,
                    wait: Duration::from_secs(90),
                }
                .to_string(),
                "drone 2: did not land within 90s",
            ),
            (
                Step::Geofence { sysid: 4 }.to_string(),
                "vehicle 4 refused the geofence of the no-fly cells",
            ),
        ];
        for (got, want) in cases {
            assert_eq!(got, want);
        }
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
        .context(Step::Pilot { sysid: 2 });
        assert!(e.is_transient());
        assert!(
            !RunnerError::from(BanditError::NoSortie(SortieStage::Ended))
                .context(Step::Pilot { sysid: 2 })
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
        use fleetmap_core::proto::launch::{
            Cause, Goal, Landed, LaunchFailure, Step as LaunchStep,
        };
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
            .context(Step::Pilot { sysid: 4 })
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
                    step: LaunchStep::Takeoff,
                    error: takeoff,
                },
                None,
            ),
            RunnerError::from(Overdue::Rendezvous {
                sysid: 2,
                station: 5,
            }),
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
                    step: LaunchStep::Arm,
                    error: arm,
                },
                Some("PreArm: Compass not calibrated"),
            ),
            RunnerError::from(FleetError::NotReady {
                sysid: 4,
                waited_s: 60.0,
                reasons: vec!["pre-arm failure reported: PreArm: Compass not calibrated".into()],
            })
            .context(Step::Pilot { sysid: 4 }),
            RunnerError::from(BanditError::NotCharging {
                sysid: 3,
                pct: 40,
                need_pct: 80.0,
                nearest: String::new(),
            }),
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
        let e = RunnerError::NotHeard {
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
