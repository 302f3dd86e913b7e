//! Runway mapping's own errors: what its runner meets that no other kind does — the
//! mapping state's and the explorer's refusals, an observation with no explorer, a vehicle
//! with no position to aim at a moving region from ([`RunwayError`]). The runner's layer
//! carries them boxed ([`RunnerError::Kind`]) and reads them back typed
//! ([`RunnerError::kind`]); each reads as the operator read it before it moved here.

use crate::app::error::{KindError, RunnerError, kind_causes};
use fleetmap_core::explore::ExploreError;
use fleetmap_core::explore::mapping::MappingError;

/// What the runway-mapping runner meets that is its own. A person must see to it.
#[derive(Debug, thiserror::Error)]
pub enum RunwayError {
    /// The mapping state could not be made from the mission, or refused a change (an
    /// operator's swap on resume).
    #[error(transparent)]
    Mapping(#[from] MappingError),
    /// The explorer (the next cells) refused a step.
    #[error(transparent)]
    Explore(#[from] ExploreError),
    /// The state has no explorer to say where a vehicle observes.
    #[error("observing without an explorer")]
    NoExplorer,
    /// A vehicle has no position to aim at a moving region from.
    #[error("vehicle {sysid}: no position to aim from")]
    NoAimPosition {
        /// The vehicle.
        sysid: u8,
    },
}

impl From<RunwayError> for RunnerError {
    fn from(e: RunwayError) -> Self {
        RunnerError::Kind(KindError::new(e))
    }
}

// The mapping state is made or changed in the run layer too, on start and resume.
kind_causes!(run RunwayError: ExploreError, MappingError);
