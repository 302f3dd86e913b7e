//! A camera that went silent — captures unanswered, pictures that never came — is not a camera
//! whose pictures are wrong: the first may come back by itself (a camera that rebooted, a loose
//! cable refitted, its power back), the second needs a person. A silent camera takes its vehicle
//! out of the run as any camera fault does (home, land, its vertex kept); with auto-resume the
//! vehicle rejoins by itself once its camera is heard again, saying so, a few times per run at
//! most and for at most [`CAMERA_BACK_WAIT_S`]; then, and for wrong pictures, it waits for the
//! operator ([`OperatorTask::CameraFix`](crate::app::kind::OperatorTask::CameraFix)).

use super::*;
use crate::app::error::RunnerResult;

/// Longest wait on the ground for a silent camera to be heard again by itself (with
/// auto-resume), seconds since the vehicle began waiting for it (scaled by the patience), as
/// long as a grounded drone waits for its fix ([`grounded::GROUNDED_WAIT_S`]); then it waits
/// for the operator, and a run whose vehicles all wait for a person ends saying so.
pub(super) const CAMERA_BACK_WAIT_S: f64 = grounded::GROUNDED_WAIT_S;

/// Times one runner lets a vehicle's silent camera bring it back by itself; the next silence
/// waits for a person: a camera that keeps dropping out is no transient.
pub(super) const CAMERA_RETURNS: u32 = 3;

/// Longest wait, seconds of the fleet clock (× patience), of a pilot's first capture for its
/// vehicle's camera component to be heard ([`Pilot::wait_for_camera`]).
const CAMERA_WAIT_S: f64 = 5.0;

/// What a pilot remembers of its camera's silences (this process only: a resumed run starts
/// afresh, and takes a camera heard at all as back).
#[derive(Debug, Default)]
pub(super) struct CameraWatch {
    /// When the last picture of this vehicle arrived (fleet clock).
    pub(super) last_picture: Option<Time>,
    /// The camera is back when a run of its heartbeats began at or after this (fleet clock):
    /// the last picture before it went silent. `None`: any run heard now.
    pub(super) back_after: Option<Time>,
    /// When the vehicle began waiting for its camera (runtime clock, fleet clock).
    pub(super) waiting_since: Option<(tokio::time::Instant, Time)>,
    /// Returns by itself so far.
    pub(super) returns: u32,
}

impl Pilot {
    /// Before this pilot's first capture: wait (at most [`CAMERA_WAIT_S`]) until the vehicle's
    /// camera component has been heard. A GCS that has just started — a run resumed over
    /// drones in the air — may not have heard the camera's heartbeat yet (1 Hz through the
    /// autopilot, later still over a lossy radio), and without it the capture goes to the
    /// autopilot as MAV_CMD_DO_DIGICAM_CONTROL, which a MAVLink camera never sees: the
    /// picture would be waited for in vain and taken again.
    pub(super) async fn wait_for_camera(&self) {
        let wait = self.shared.patience.secs(CAMERA_WAIT_S);
        let _ = self
            .fleet()
            .wait_until(self.sysid, wait, |v| v.camera_compid.is_some())
            .await;
    }

    /// Whether this vehicle's camera fault is a camera that went silent (saved in the run
    /// state: [`RobotRecord::camera_silent`](fleetmap_core::explore::mapping::RobotRecord)).
    pub(super) async fn camera_silent_now(&self) -> bool {
        let sysid = self.sysid;
        self.shared
            .read(|s| {
                s.robot(sysid)
                    .is_ok_and(|r| r.camera_fault.is_some() && r.camera_silent)
            })
            .await
    }

    /// Whether the silent camera still waits to come back by itself: auto-resume, fewer than
    /// [`CAMERA_RETURNS`] returns in this runner, less than [`CAMERA_BACK_WAIT_S`] waited.
    pub(super) fn camera_waits_by_itself(&mut self) -> bool {
        let now = self.shared.now();
        let (since, _) = *self
            .camera
            .waiting_since
            .get_or_insert_with(|| (tokio::time::Instant::now(), now));
        self.shared.auto_resume
            && self.camera.returns < CAMERA_RETURNS
            && since.elapsed() < self.shared.patience.secs(CAMERA_BACK_WAIT_S)
    }

    /// Whether the silent camera is back: heard now, in a run of heartbeats that began after
    /// its last picture ([`CameraWatch::back_after`]) — a camera that heartbeats on while
    /// sending nothing has to restart first — and the vehicle heard and out of boot (a
    /// battery swap may be under way).
    pub(super) fn camera_back(&self) -> bool {
        let now = self.fleet().clock().now();
        self.vehicle().is_some_and(|v| {
            v.alive && !v.booting && v.camera_heard_since(self.camera.back_after, now)
        })
    }

    /// What the operator is told when the vehicle landed for its camera (`why`).
    pub(super) async fn landed_for_camera(&mut self, why: &str) -> String {
        let sysid = self.sysid;
        if self.camera_silent_now().await && self.camera_waits_by_itself() {
            format!(
                "vehicle {sysid}: landed: its camera is silent ({why}); it rejoins by itself \
                 once the camera is heard again"
            )
        } else {
            format!(
                "vehicle {sysid}: landed: waiting for the operator to fix the camera ({why}); it \
                 will not resume by itself"
            )
        }
    }

    /// On the ground for a silent camera that still waits to come back by itself
    /// ([`Pilot::camera_waits_by_itself`]): `Some(true)` when it is back and the vehicle
    /// rejoins (or the run finished), `Some(false)` after waiting a little for it; `None`
    /// when it is no such camera (any more): the operator's.
    pub(super) async fn silent_camera_wait(&mut self) -> RunnerResult<Option<bool>> {
        if !self.camera_silent_now().await || !self.camera_waits_by_itself() {
            return Ok(None);
        }
        if self.camera_back() {
            self.camera_returned().await?;
            return Ok(Some(true));
        }
        if self
            .shared
            .read(|s| matches!(s.phase, Phase::Finished { .. }))
            .await
        {
            return Ok(Some(true));
        }
        self.wait_change(Duration::from_millis(500)).await;
        Ok(Some(false))
    }

    /// The silent camera is back: the vehicle rejoins (no battery swap counted), journalled
    /// ([`MappingEvent::CameraBack`]) and said.
    pub(super) async fn camera_returned(&mut self) -> RunnerResult<()> {
        let sysid = self.sysid;
        let now = self.shared.now();
        let waited = self
            .camera
            .waiting_since
            .take()
            .map_or(0.0, |(_, t)| now.saturating_since(t).as_secs_f64());
        self.camera.returns += 1;
        self.camera.back_after = None;
        self.shared
            .commit(|s| {
                s.on_swapped(sysid, now)?;
                Ok(((), Some(MappingEvent::CameraBack { sysid })))
            })
            .await?;
        self.shared.say(
            Progress::notice(format!(
                "vehicle {sysid}: its camera is back (heard again after {waited:.0} s on the \
                 ground): taking off to rejoin"
            ))
            .about(sysid),
        );
        Ok(())
    }

    /// The camera cannot be trusted (`reason`): warn, journal [`MappingEvent::CameraFault`]
    /// and take the vehicle out of the run as for a battery swap (its vertex is kept, a
    /// confirmation it was making is given up), so that [`Pilot::swap`] brings it home and
    /// waits for the operator. Nothing of this camera is credited after this.
    ///
    /// A camera that went `silent` (captures unanswered, pictures that never came) is saved
    /// as such ([`MappingState::on_camera_silent`]): with auto-resume the vehicle rejoins by
    /// itself once the camera is heard again ([`camera`]).
    pub(super) async fn camera_fault(
        &mut self,
        cell: Option<Cell>,
        reason: String,
        silent: bool,
    ) -> RunnerResult<()> {
        let sysid = self.sysid;
        let now = self.shared.now();
        let line = if silent {
            self.camera.back_after = self.camera.last_picture;
            self.camera.waiting_since = None;
            let then = if self.shared.auto_resume && self.camera.returns < camera::CAMERA_RETURNS {
                format!(
                    "it returns home, lands and rejoins by itself once its camera is heard \
                     again (within {:.0} min; else check the camera's power and cable, then \
                     `fleetmap resume` or `b`)",
                    camera::CAMERA_BACK_WAIT_S / 60.0
                )
            } else {
                "it returns home, lands and waits for the operator (check the camera's power \
                 and cable, then `fleetmap resume` or `b`)"
                    .to_string()
            };
            format!("vehicle {sysid}: CAMERA SILENT: {reason}. Its pictures stop counting; {then}")
        } else {
            format!(
                "vehicle {sysid}: CAMERA FAULT: {reason}. No more of its pictures are counted; \
                 it returns home, lands and waits for the operator (check where the camera gets \
                 its position and attitude from, then `fleetmap resume` or `b`)"
            )
        };
        self.shared.say(Progress::error(line).about(sysid));
        self.shared
            .commit(|s| {
                if silent {
                    s.on_camera_silent(sysid, reason.clone(), now)?;
                } else {
                    s.on_camera_fault(sysid, reason.clone(), now)?;
                }
                Ok((
                    (),
                    Some(MappingEvent::CameraFault {
                        sysid,
                        cell,
                        reason,
                        silent,
                    }),
                ))
            })
            .await?;
        Ok(())
    }
}
