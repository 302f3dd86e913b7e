//! A visit's pictures taken several at a time: the async shell of
//! [`fleetmap_core::proto::captures::CaptureLedger`]. Over a telemetry radio a capture is a
//! round trip and a tenth of its messages are lost; one capture at a time, each loss stalled
//! the visit for a timeout. With the next command sent as soon as the previous one is
//! confirmed, and the holes asked for as one range, the losses of a visit overlap.
//!
//! Used only where the pictures' order and place cannot go wrong: a camera that announces its
//! pictures (CAMERA_IMAGE_CAPTURED with an index) and measures them on board (a few hundred
//! bytes each, not a picture's transfer), over a region that does not move (a moving region
//! re-aims between pictures). Everything else takes one picture at a time
//! ([`flight::capture`]).

use super::{Cell, PictureFailure, Pilot};
use crate::app::error::RunnerResult;
use crate::app::flight::{self, Captured, FlightError, Patience, capture_again, measured_index};
use crate::app::images::ReceivedImage;
use crate::fleet::{FleetHandle, VehicleSnapshot, capture_command};
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::captures::{CaptureLedger, CaptureSend, RoundTrip};
use mavlink::dialects::ardupilotmega::{MavCmd, MavMessage, MavResult};
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::broadcast;

/// Nominal seconds without a picture named or completed before a visit's captures give up
/// (as one capture waits: [`flight::capture`]).
const GIVE_UP_S: f64 = 10.0;

/// The shortest time between two pictures of a visit, nominal seconds: a camera's own minimum
/// interval (`fleetmap camera` takes one picture per 0.2 s; ArduPilot's CAMx_INTRVAL_MIN is of
/// that order), and what one capture at a time took on a plain link. Taken as fast as the link
/// answers, five pictures of a hovering drone are one instant's view five times: on the field
/// test's seed the map lost 0.9 point of IoU.
const SPACING_S: f64 = 0.2;

/// The camera link's round trips before any was measured: the first timeout, and the bounds
/// of all later ones, nominal seconds. A camera answers a capture within a few hundred
/// milliseconds; a 2,000 B/s radio adds well under a second.
pub(super) fn round_trip(patience: Patience) -> RoundTrip {
    RoundTrip::new(
        patience.secs(flight::RESEND_AFTER_S / 3.0),
        patience.secs(0.2),
        patience.secs(flight::RESEND_AFTER_S),
    )
}

/// What one visit's captures brought.
pub(super) struct VisitShots {
    /// The pictures that arrived whole, in the camera's order.
    pub(super) shots: Vec<Captured>,
    /// The sequence number of the visit's last command.
    pub(super) last_seq: u32,
    /// The newest image index the camera named.
    pub(super) last_index: i32,
    /// The link's round trips as the visit left them.
    pub(super) round_trip: RoundTrip,
}

/// Take `wanted` pictures with `camera` of vehicle `sysid`, pictures newer than image index
/// `after`, commands numbered from `first_seq`: several in flight, each one's announcement
/// and on-board result matched by its image index.
#[allow(clippy::too_many_arguments)]
pub(super) async fn capture_visit(
    fleet: &FleetHandle,
    rx: &mut broadcast::Receiver<Arc<ReceivedImage>>,
    camera: Endpoint,
    first_seq: u32,
    wanted: u32,
    after: i32,
    round_trip: RoundTrip,
    patience: Patience,
) -> Result<VisitShots, FlightError> {
    let sysid = camera.sysid;
    let clock = fleet.clock();
    let started = clock.now();
    let longest = started + patience.secs(flight::CAPTURE_MAX_WAIT_S);
    let mut frames = fleet.subscribe();
    flight::drain_images(rx);
    let mut ledger = CaptureLedger::new(
        started,
        wanted,
        after,
        first_seq,
        round_trip,
        patience.secs(GIVE_UP_S),
    )
    .with_spacing(patience.secs(SPACING_S));
    // The vehicle as it was when each picture was named: where it was taken.
    let mut at_shutter: HashMap<i32, Option<VehicleSnapshot>> = HashMap::new();
    let mut shots: BTreeMap<i32, Captured> = BTreeMap::new();
    let mut last_seq = first_seq.saturating_sub(1);
    loop {
        let now = clock.now();
        if ledger.is_over(now) || now >= longest {
            break;
        }
        for send in ledger.poll_transmit(now) {
            let m = match send {
                CaptureSend::Capture { seq } => {
                    last_seq = seq;
                    capture_command(camera, seq).message(0)
                }
                CaptureSend::Again { first, last } => capture_again(camera, first, last),
            };
            // fire and forget: the ledger sends again what is not answered
            let _ = fleet.send_to(sysid, m).await;
        }
        let wake = ledger.poll_timeout().min(longest);
        let left = clock.wall_until(wake);
        tokio::select! {
            biased;
            f = frames.recv() => match f {
                Ok(inc) if inc.frame.sysid() == sysid && inc.frame.compid() == camera.compid => {
                    let now = clock.now();
                    let named = match &inc.frame.message {
                        Ok(MavMessage::COMMAND_ACK(a))
                            if a.command == MavCmd::MAV_CMD_IMAGE_START_CAPTURE =>
                        {
                            ledger.handle_ack(now, a.result == MavResult::MAV_RESULT_ACCEPTED);
                            None
                        }
                        Ok(MavMessage::CAMERA_IMAGE_CAPTURED(c)) => Some(c.image_index),
                        Ok(MavMessage::DEBUG_FLOAT_ARRAY(d)) => {
                            measured_index(d, Some(ledger.last_index()))
                        }
                        _ => None,
                    };
                    if let Some(index) = named
                        && ledger.handle_named(now, index)
                    {
                        at_shutter.entry(index).or_insert_with(|| fleet.vehicle(sysid));
                    }
                }
                Ok(_) | Err(broadcast::error::RecvError::Lagged(_)) => {}
                Err(broadcast::error::RecvError::Closed) => return Err(FlightError::ImagesClosed),
            },
            r = rx.recv() => match r {
                Ok(image) if image.sysid == sysid => {
                    if let Some(index) = image.pose.as_ref().map(|p| p.image_index)
                        && ledger.handle_complete(clock.now(), index)
                    {
                        let at_trigger = at_shutter
                            .get(&index)
                            .cloned()
                            .flatten()
                            .or_else(|| fleet.vehicle(sysid));
                        shots.insert(index, Captured { image, at_trigger });
                    }
                }
                Ok(_) | Err(broadcast::error::RecvError::Lagged(_)) => {}
                Err(broadcast::error::RecvError::Closed) => return Err(FlightError::ImagesClosed),
            },
            // woken to send again or to give up (a lower bound on a simulator's clock: waking
            // early only goes round the loop again)
            _ = tokio::time::sleep(left.max(Duration::from_millis(1))) => {}
        }
    }
    Ok(VisitShots {
        shots: shots.into_values().collect(),
        last_seq,
        last_index: ledger.last_index(),
        round_trip: ledger.round_trip(),
    })
}

impl Pilot {
    /// The camera and the image index to take pictures after when this visit's `missing`
    /// pictures may be taken several at a time (this module): its last picture came
    /// announced and measured on board, over a region that does not move.
    pub(super) fn visit_camera(&self, missing: u32) -> Option<(Endpoint, i32)> {
        if missing < 2 || !self.in_flight_ok || !self.shared.roi.is_static() {
            return None;
        }
        let after = self.last_image?;
        let compid = self.vehicle()?.camera_compid?;
        Some((Endpoint::new(self.sysid, compid), after))
    }

    /// Take `missing` pictures of `cell` several at a time, after image index `after`. A
    /// shortfall (nothing heard for a while) is one lost picture, and the next attempt takes
    /// one at a time.
    pub(super) async fn take_several(
        &mut self,
        cell: Cell,
        camera: Endpoint,
        after: i32,
        missing: u32,
    ) -> RunnerResult<Vec<Result<Captured, PictureFailure>>> {
        let fleet = self.shared.fleet.clone();
        let visit = capture_visit(
            &fleet,
            &mut self.images,
            camera,
            self.capture_seq.wrapping_add(1),
            missing,
            after,
            self.round_trip,
            self.shared.patience,
        )
        .await?;
        self.capture_seq = visit.last_seq.max(self.capture_seq);
        self.round_trip = visit.round_trip;
        self.last_image = Some(visit.last_index);
        if !visit.shots.is_empty() {
            self.camera.last_picture = Some(fleet.clock().now());
        }
        // a picture without its on-board result (the camera lost the run's grid): one at a
        // time again until one comes measured
        if visit
            .shots
            .iter()
            .any(|s| super::intake::onboard_result(&s.image).is_none())
        {
            self.in_flight_ok = false;
        }
        let got = visit.shots.len();
        let mut shots: Vec<_> = visit
            .shots
            .into_iter()
            .take(missing as usize)
            .map(Ok)
            .collect();
        if got < missing as usize {
            self.in_flight_ok = false;
            shots.push(Err(PictureFailure::Lost(format!(
                "cell {cell}: {} of {missing} pictures did not arrive (captures {} to {})",
                missing as usize - got,
                self.capture_seq.saturating_sub(missing.saturating_sub(1)),
                self.capture_seq
            ))));
        }
        Ok(shots)
    }
}
