//! A drone that cannot go on — it could not take off, or its steps kept failing — leaves the
//! tree as for a battery swap (its vertex kept) and waits on the ground while the others go
//! on; it is tried again by itself once ready (auto-resume) or when the operator says so.

use super::*;
use crate::app::error::{RunnerError, RunnerResult};

/// First wait before a grounded drone is tried again (with auto-resume), seconds (scaled by
/// the patience); doubled after every grounding in a row, up to 16 times as long.
const GROUNDED_RETRY_S: f64 = 10.0;

/// Groundings in a row after which a drone is no longer tried again by itself: it waits for
/// the operator (something a retry does not fix).
pub(super) const GROUNDED_TRIES: u32 = 5;

/// Longest wait for a grounded drone to be ready again by itself (with auto-resume), seconds
/// since it was grounded (scaled by the patience); then it waits for the operator: a run
/// whose drones all wait for a person ends, saying what to fix, instead of waiting for ever.
pub(super) const GROUNDED_WAIT_S: f64 = 600.0;

impl Pilot {
    /// Whether `e` says this drone could not get off the ground — its arming or take-off
    /// failed after the fleet's own retries, or it never became ready — while it is on the
    /// ground.
    pub(super) fn cannot_take_off(&self, e: &RunnerError) -> bool {
        use crate::app::flight::FlightError;
        use crate::fleet::FleetError;
        fn launch(e: &RunnerError) -> bool {
            match e {
                RunnerError::Fleet(f) | RunnerError::Flight(FlightError::Fleet(f)) => matches!(
                    f,
                    FleetError::NotStarted { .. }
                        | FleetError::NotReady { .. }
                        | FleetError::ArmRefused { .. }
                        | FleetError::Booting { .. }
                ),
                RunnerError::Context { source, .. } => launch(source),
                _ => false,
            }
        }
        launch(e) && self.vehicle().is_none_or(|v| !flight::airborne(&v))
    }

    /// Take this drone out of the run for now because of `e`: it leaves the tree as for a
    /// battery swap — its vertex is kept, a confirmation it was making is given up
    /// ([`MappingState::on_grounded`]) — and [`Pilot::swap`] brings it down (a drone in the
    /// air flies home and lands) and waits: with auto-resume it is tried again by itself once
    /// its telemetry says it is ready, after a back-off ([`GROUNDED_RETRY_S`], doubling, at
    /// most [`GROUNDED_TRIES`] times in a row); otherwise, or after that, the operator says
    /// when (`b`, or `fleetmap resume`). The operator is told which drone, why, and what a
    /// person must fix if anything; the journal has [`MappingEvent::Grounded`].
    pub(super) async fn ground(&mut self, e: &RunnerError) -> RunnerResult<()> {
        let sysid = self.sysid;
        let reason = crate::app::error::chain(e);
        let fix = e.needs_person();
        self.grounded = (self.grounded.0 + 1, Some(tokio::time::Instant::now()));
        let tries = self.grounded.0;
        let now = self.shared.now();
        let (r, f) = (reason.clone(), fix.clone());
        self.shared
            .commit(|s| {
                s.on_grounded(sysid, r.clone(), f.clone(), tries, now)?;
                Ok((
                    (),
                    Some(MappingEvent::Grounded {
                        sysid,
                        reason: r,
                        fix: f,
                    }),
                ))
            })
            .await?;
        let then = match (&fix, self.shared.auto_resume && tries <= GROUNDED_TRIES) {
            (Some(f), true) => format!(
                "a person must fix it: {f}; it rejoins once it is ready (within {:.0} min)",
                GROUNDED_WAIT_S / 60.0
            ),
            (Some(f), false) => {
                format!("a person must fix it: {f}; then `b` (or `fleetmap resume`)")
            }
            (None, true) => "it is tried again by itself once it is ready".into(),
            (None, false) => "it waits for the operator (`b`, or `fleetmap resume`)".into(),
        };
        self.shared.say(
            Progress::error(format!(
                "vehicle {sysid} cannot go on ({reason}): it leaves the tree as for a battery \
                 swap, its vertex kept, and the others go on — {then}"
            ))
            .about(sysid),
        );
        Ok(())
    }

    /// Whether this drone, grounded, still waits to be ready again by itself: auto-resume,
    /// at most [`GROUNDED_TRIES`] groundings in a row, and less than [`GROUNDED_WAIT_S`]
    /// since the last one.
    pub(super) fn waits_by_itself(&self) -> bool {
        let (tries, at) = self.grounded;
        self.shared.auto_resume
            && tries <= GROUNDED_TRIES
            && at.is_none_or(|t| t.elapsed() < self.shared.patience.secs(GROUNDED_WAIT_S))
    }

    /// Whether this drone, grounded, may be tried again by itself now
    /// ([`Pilot::waits_by_itself`]), the back-off since its last grounding over, and its
    /// telemetry ready (heard, booted, ready to arm).
    pub(super) fn ready_again(&self) -> bool {
        let (tries, at) = self.grounded;
        if !self.waits_by_itself() {
            return false;
        }
        let wait = self
            .shared
            .patience
            .secs(GROUNDED_RETRY_S * f64::from(1u32 << tries.saturating_sub(1).min(4)));
        if at.is_some_and(|t| t.elapsed() < wait) {
            return false;
        }
        let now = self.fleet().clock().now();
        self.vehicle()
            .is_some_and(|v| v.alive && !v.booting && v.arm_blockers(now).is_empty())
    }

    /// Why this drone is grounded, if it is ([`MappingState::on_grounded`]; saved in the
    /// run state, so a resumed run keeps it on the ground too).
    pub(super) async fn grounded_now(&self) -> Option<fleetmap_core::explore::mapping::Grounded> {
        let sysid = self.sysid;
        self.shared
            .read(|s| s.robot(sysid).ok().and_then(|r| r.grounded.clone()))
            .await
    }

    /// A step failed (`reason`) with nothing heard from the vehicle: its link is dark. Said
    /// once per outage (`dark` keeps when it was first seen, fleet clock) — its autopilot flies
    /// on meanwhile, as ArduPilot does with its GCS failsafe off — and the step retried.
    /// Returns whether the failure was that.
    pub(super) fn link_dark(&self, dark: &mut Option<Time>, reason: &str) -> bool {
        let Some(v) = self.vehicle().filter(|v| !v.alive) else {
            return false;
        };
        if dark.is_none() {
            *dark = Some(self.shared.now());
            self.shared.say(
                Progress::warning(format!(
                    "vehicle {}: LINK LOST: nothing heard from it for {:.0} s ({reason}); its \
                     autopilot flies on, and the GCS keeps trying",
                    self.sysid, v.heartbeat_age_s
                ))
                .about(self.sysid),
            );
        }
        true
    }

    /// The vehicle is heard again after its link was dark ([`Pilot::link_dark`]): said.
    pub(super) fn link_back(&self, dark: &mut Option<Time>) {
        if let Some(since) = *dark
            && self.vehicle().is_some_and(|v| v.alive)
        {
            *dark = None;
            self.shared.say(
                Progress::notice(format!(
                    "vehicle {}: link back (dark for {:.0} s at least): going on",
                    self.sysid,
                    self.shared.now().saturating_since(since).as_secs_f64()
                ))
                .about(self.sysid),
            );
        }
    }
}
