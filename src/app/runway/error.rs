//! Runway mapping's own errors: what its runner meets that no other kind does — the
//! explorer's refusal, an observation with no explorer, a vehicle with no position to aim at
//! a moving region from ([`RunwayError`]). The runner's layer carries them boxed
//! ([`RunnerError::Kind`]) and reads them back typed ([`RunnerError::kind`]); each reads as
//! the operator read it before it moved here.

use crate::app::error::{KindError, RunnerError};
use fleetmap_core::explore::ExploreError;

/// What the runway-mapping runner meets that is its own. A person must see to it.
#[derive(Debug, thiserror::Error)]
pub enum RunwayError {
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

/// The explorer's refusal as it is met (`?`).
impl From<ExploreError> for RunnerError {
    fn from(e: ExploreError) -> Self {
        RunwayError::from(e).into()
    }
}
