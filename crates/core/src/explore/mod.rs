//! Runway-mapping exploration, pure: the lawnmower sweep and the multi-robot recursive DFS of
//! the runway paper (Sung, Dixit and Tokekar; docs/papers.md, §4.1 Algorithm 1, §4.2, §6, §7).
//!
//! Nothing here does I/O or reads a clock. The pieces:
//!
//! | module | what |
//! |---|---|
//! | [`dfs`] | [`Explorer`](dfs::Explorer): the sans-IO state machine of Algorithm 1 (tree built online from the 4-neighbour labels of each image, vertex states, dummy vertices, even splits, state shared on meeting or through the GCS, return to the start, pause/resume) |
//! | [`lawnmower`] | the boustrophedon sweep of a bounding box as mission items, split into strips among the robots (§7's first mode) |
//! | [`motion`] | the translating ROI (§3–4): ground position ↔ ROI-frame cell at time t, relative speeds, intercepts |
//! | [`reach`] | whether a drone can fly out to a moving region's cell and get back on its battery, or must swap first, or the region is beyond reach |
//! | [`bounds`] | Lemma 1 (eq. 2), Lemma 2 (eq. 10) and §6's lawnmower baseline |
//! | [`simulate`] | a discrete-event run of an [`Explorer`](dfs::Explorer) on a known ROI with a perfect sensor (§6's simulations, the property tests) |
//!
//! Cells follow docs/grid.md (rows grow north, columns east, cell (0, 0) centred on the grid
//! origin); the DFS works in the ROI's own frame, which equals the ground grid when the ROI is
//! static.

pub mod bounds;
pub mod dfs;
pub mod lawnmower;
pub mod mapping;
pub mod motion;
pub mod reach;
pub mod simulate;

use crate::geo::Cell;
use dfs::RobotId;

/// Errors of the exploration module.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ExploreError {
    /// `Explorer::new` was given no robots.
    #[error("an exploration needs at least one robot")]
    NoRobots,
    /// The same robot id was listed twice.
    #[error("robot {0} is listed twice")]
    DuplicateRobot(RobotId),
    /// A call named a robot the explorer does not know.
    #[error("unknown robot {0}")]
    UnknownRobot(RobotId),
    /// `arrived` reported a cell other than the one the robot was sent to.
    #[error("robot {robot} reported arriving at cell {cell}, but it was sent to {expected}")]
    WrongCell {
        /// The robot.
        robot: RobotId,
        /// Where the runner says it is.
        cell: Cell,
        /// Where it was sent.
        expected: Cell,
    },
    /// `arrived` for a robot that was not flying anywhere.
    #[error("robot {robot} reported arriving at {cell} but was not sent anywhere (it is {phase})")]
    NotMoving {
        /// The robot.
        robot: RobotId,
        /// The reported cell.
        cell: Cell,
        /// What the robot was doing, for the message.
        phase: &'static str,
    },
    /// `observe` for a cell the robot is not at.
    #[error("robot {robot} sent an observation of cell {cell} but is at {at}")]
    ObservedElsewhere {
        /// The robot.
        robot: RobotId,
        /// The observed cell.
        cell: Cell,
        /// Where the explorer has it.
        at: Cell,
    },
    /// `observe` while the robot is flying or paused.
    #[error("robot {robot} cannot observe now: it is {phase}")]
    CannotObserve {
        /// The robot.
        robot: RobotId,
        /// What the robot was doing.
        phase: &'static str,
    },
    /// `resume` for a robot that is not paused.
    #[error("robot {0} is not paused")]
    NotPaused(RobotId),
    /// A speed that makes the problem ill-posed (paper §3 requires S_r > S_p ≥ 0).
    #[error(
        "robot speed {robot_speed} must be positive and greater than the ROI speed {roi_speed}"
    )]
    Speeds {
        /// S_r.
        robot_speed: f64,
        /// S_p.
        roi_speed: f64,
    },
    /// A bad lawnmower input.
    #[error("lawnmower: {0}")]
    Lawnmower(String),
    /// The xy → lat/lon conversion failed.
    #[error(
        "cannot convert east {east_m:.2} m, north {north_m:.2} m to latitude/longitude: {reason}"
    )]
    Projection {
        /// East offset from the grid origin, metres.
        east_m: f64,
        /// North offset from the grid origin, metres.
        north_m: f64,
        /// The converter's message.
        reason: String,
    },
    /// The simulation stopped without finishing (a bug, reported rather than looping).
    #[error("simulation did not finish: {0}")]
    Simulation(String),
}
