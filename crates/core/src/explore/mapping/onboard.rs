//! What the run's cameras classified on board, and how the audits of their results went.

use super::MappingState;
use serde::{Deserialize, Serialize};

/// Counts of the pictures classified on board
/// ([`crate::vision::runway::onboard`]) and of their audits: when a visit's decision was won
/// by one vote, the GCS may ask for one of its pictures and classify it itself.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct OnboardTally {
    /// Cell-centre pictures whose votes are the camera's own classification.
    pub cell_pictures: u64,
    /// Sweep pictures classified by the camera.
    pub sweep_pictures: u64,
    /// Audits asked for (a picture of a disputed decision).
    pub audits: u64,
    /// Audits whose picture the GCS classified exactly as the camera had (cell, counts,
    /// labels).
    pub audits_agreed: u64,
    /// Audits whose picture the GCS classified otherwise.
    pub audits_disagreed: u64,
    /// Audits whose picture did not arrive (or could not be read).
    pub audits_lost: u64,
}

impl MappingState {
    /// An audit ended: the GCS's classification agreed with the camera's (`Some(true)`), did
    /// not (`Some(false)`), or the picture never came (`None`).
    pub fn on_audit(&mut self, agreed: Option<bool>) {
        let t = &mut self.onboard;
        match agreed {
            Some(true) => t.audits_agreed += 1,
            Some(false) => t.audits_disagreed += 1,
            None => t.audits_lost += 1,
        }
    }
}
