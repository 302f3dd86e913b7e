//! Flight steps the mission runners compose (async shell over [`FleetHandle`]): take off if
//! needed, fly to a point and wait until the vehicle is there and steady, take a picture and
//! wait for it, come home and land. Each step has a timeout and a typed error; the runners
//! decide what to retry.
//!
//! Timeouts are wall-clock durations scaled by `Patience::factor` (a simulator served
//! slower than real time, or a slow radio link, needs more); with the fleet clock running
//! faster than real time (the in-process demo) they are generous by the same factor.

use crate::app::images::ReceivedImage;
use crate::fleet::capture_command;
use crate::fleet::{FleetError, FleetHandle, VehicleSnapshot};
use fleetmap_core::geo::local;
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::command::Command;
use fleetmap_core::proto::flavour::takeoff_reached;
use fleetmap_core::time::Time;
use mavlink::dialects::ardupilotmega::{MavCmd, MavMessage};
use std::sync::Arc;
use std::time::Duration;
use tokio::sync::broadcast;

/// Why a flight step failed.
#[derive(Debug, thiserror::Error)]
pub enum FlightError {
    /// A fleet operation failed.
    #[error(transparent)]
    Fleet(#[from] FleetError),
    /// The vehicle did not get where it was sent in time.
    #[error("vehicle {sysid}: not at the target after {waited_s:.0} s ({detail})")]
    NotArrived {
        /// The vehicle.
        sysid: u8,
        /// Seconds waited (wall clock).
        waited_s: f64,
        /// Where it is.
        detail: String,
    },
    /// No image arrived after a capture.
    #[error("vehicle {sysid}: no image arrived within {waited_s:.0} s of capture {seq}")]
    NoImage {
        /// The vehicle.
        sysid: u8,
        /// The capture number.
        seq: u32,
        /// Seconds waited.
        waited_s: f64,
    },
    /// The vehicle did not land / take off in time.
    #[error("vehicle {sysid}: {what} not seen within {waited_s:.0} s")]
    Timeout {
        /// The vehicle.
        sysid: u8,
        /// What was awaited.
        what: String,
        /// Seconds waited.
        waited_s: f64,
    },
    /// The image stream stopped.
    #[error("the image intake stopped")]
    ImagesClosed,
}

/// How long the runners wait for vehicles, as a multiple of the nominal (real-time) times.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Patience {
    /// 1 = real time; 2 = twice as long.
    pub(crate) factor: f64,
}

impl Default for Patience {
    fn default() -> Self {
        Patience { factor: 1.0 }
    }
}

impl Patience {
    /// `secs` nominal seconds, scaled.
    pub fn secs(&self, secs: f64) -> Duration {
        let f = if self.factor.is_finite() && self.factor > 0.0 {
            self.factor
        } else {
            1.0
        };
        Duration::from_secs_f64((secs * f).clamp(0.05, 86_400.0))
    }
}

/// Horizontal distance from the vehicle to (`lat`, `lon`), metres (infinite when its
/// position is unknown).
pub(crate) fn distance_to(v: &VehicleSnapshot, lat: f64, lon: f64) -> f64 {
    v.position
        .map(|p| local::distance(p.lat, p.lon, lat, lon))
        .unwrap_or(f64::INFINITY)
}

/// Whether the vehicle is in the air (armed and not landed).
pub fn airborne(v: &VehicleSnapshot) -> bool {
    v.armed && !v.on_ground()
}

/// Set the cruise speed (MAV_CMD_DO_CHANGE_SPEED, ground speed) — for GUIDED / Hold gotos
/// and missions alike. ArduPilot applies it to the current mode (it resets on a mode
/// change: send it after the mode is set); PX4 to the current navigation.
pub(crate) async fn set_speed(
    fleet: &FleetHandle,
    sysid: u8,
    speed_m_s: f32,
) -> Result<(), FleetError> {
    let v = fleet
        .vehicle(sysid)
        .ok_or(FleetError::NoVehicle { sysid })?;
    let cmd = Command::long(
        Endpoint::new(sysid, v.compid),
        MavCmd::MAV_CMD_DO_CHANGE_SPEED,
        [1.0, speed_m_s, -1.0, 0.0, 0.0, 0.0, 0.0],
    );
    fleet.command(cmd).await.map(|_| ())
}

/// Arm and take off to `alt` m above home unless the vehicle is already flying; returns
/// when the take-off is done: no lower than the autopilots' altitude acceptance below it
/// ([`takeoff_reached`], 0.8 m as PX4's NAV_MC_ALT_RAD), or above it.
pub(crate) async fn ensure_airborne(
    fleet: &FleetHandle,
    sysid: u8,
    alt: f32,
    patience: Patience,
) -> Result<(), FlightError> {
    let v = fleet
        .vehicle(sysid)
        .ok_or(FleetError::NoVehicle { sysid })?;
    if airborne(&v) && v.alt_rel.is_some_and(|a| a >= 0.5 * alt) {
        return Ok(());
    }
    if !airborne(&v) {
        // `takeoff` waits for the vehicle to be ready (after a power cycle ArduCopter
        // refuses GUIDED until its position estimate is good) before its first step.
        fleet.takeoff(sysid, alt).await?;
    }
    let wait = patience.secs(f64::from(alt) / 0.5 + 60.0);
    fleet
        .wait_until(sysid, wait, |s| {
            s.alt_rel.is_some_and(|a| takeoff_reached(a, alt))
        })
        .await
        .map(|_| ())
        .map_err(|_| FlightError::Timeout {
            sysid,
            what: format!("take-off to {alt:.1} m"),
            waited_s: wait.as_secs_f64(),
        })
}

/// Go to (`lat`, `lon`) at `alt` m above home at `speed` m/s, and wait until the vehicle is
/// within `tolerance_m` horizontally and 1 m vertically, moving slower than 0.3 m/s (there
/// and steady, so the pictures are taken over the cell). Sends the go-to again when the
/// vehicle drops it (a mode change by the pilot or the autopilot shows as no progress).
pub(crate) async fn fly_to(
    fleet: &FleetHandle,
    sysid: u8,
    target: (f64, f64, f32),
    speed: f32,
    tolerance_m: f64,
    patience: Patience,
) -> Result<(), FlightError> {
    let (lat, lon, alt) = target;
    let v = fleet
        .vehicle(sysid)
        .ok_or(FleetError::NoVehicle { sysid })?;
    let dist = distance_to(&v, lat, lon);
    let leg_s = if dist.is_finite() {
        dist / f64::from(speed.max(0.1))
    } else {
        120.0
    };
    let guided = v.flavour.guided_mode().ok();
    let in_guided =
        |s: &VehicleSnapshot| guided.is_some_and(|m| s.flavour.is_mode(s.custom_mode, m));
    // Speed: ArduPilot resets it when the mode changes, so enter the mode first. In the mode,
    // the speed and the target go together (two command ids: both in flight at once), one
    // round trip instead of two over a slow or lossy link.
    if !in_guided(&v) {
        fleet.goto(sysid, lat, lon, alt).await?;
    }
    let (_, went) = tokio::join!(
        set_speed(fleet, sysid, speed),
        fleet.goto(sysid, lat, lon, alt)
    );
    went?;
    let budget = patience.secs(leg_s * 2.0 + 30.0);
    let there = |s: &VehicleSnapshot| {
        distance_to(s, lat, lon) <= tolerance_m
            && s.alt_rel.is_some_and(|a| (a - alt).abs() <= 1.0)
            && s.groundspeed.is_some_and(|g| g < 0.3)
    };
    let mut attempts = 0;
    loop {
        match fleet.wait_until(sysid, budget, there).await {
            Ok(_) => return Ok(()),
            Err(last) => {
                attempts += 1;
                if attempts >= 3 {
                    return Err(FlightError::NotArrived {
                        sysid,
                        waited_s: budget.as_secs_f64() * f64::from(attempts),
                        detail: last
                            .map(|s| {
                                format!(
                                    "{:.1} m away at {} m, mode {}",
                                    distance_to(&s, lat, lon),
                                    s.alt_rel.map(|a| format!("{a:.1}")).unwrap_or("?".into()),
                                    s.mode
                                )
                            })
                            .unwrap_or_else(|| "vehicle lost".into()),
                    });
                }
                fleet.goto(sysid, lat, lon, alt).await?;
            }
        }
    }
}

/// The grid heading nearest to `heading_deg`: a multiple of 90° in [0, 360).
pub(crate) fn nearest_quarter(heading_deg: f64) -> f64 {
    ((heading_deg / 90.0).round() * 90.0).rem_euclid(360.0)
}

/// The smallest angle between two headings, degrees (0..=180).
pub(crate) fn heading_error(a_deg: f64, b_deg: f64) -> f64 {
    let d = (a_deg - b_deg).rem_euclid(360.0);
    d.min(360.0 - d)
}

/// Turn the vehicle, hovering at (`lat`, `lon`, `alt`), to the grid heading nearest to its
/// own (north, east, south or west) and wait until it points there within `tolerance_deg`
/// and is steady. The runway paper's sensing model reads an image's top, left, bottom and
/// right regions as the four neighbouring cells, which holds only when the camera is
/// aligned with the grid; a copter arriving on a diagonal faces its direction of travel.
/// Vehicles that cannot be turned by command (rovers) are left as they are.
pub(crate) async fn face_grid(
    fleet: &FleetHandle,
    sysid: u8,
    target: (f64, f64, f32),
    tolerance_deg: f64,
    patience: Patience,
) -> Result<(), FlightError> {
    let v = fleet
        .vehicle(sysid)
        .ok_or(FleetError::NoVehicle { sysid })?;
    let Some(now) = v.heading_deg.map(f64::from) else {
        return Ok(());
    };
    let want = nearest_quarter(now);
    if heading_error(now, want) <= tolerance_deg {
        return Ok(());
    }
    let (lat, lon, alt) = target;
    let aligned = |s: &VehicleSnapshot| {
        s.heading_deg
            .is_some_and(|h| heading_error(f64::from(h), want) <= tolerance_deg)
            && s.groundspeed.is_some_and(|g| g < 0.3)
    };
    // A quarter turn at ArduCopter's default yaw slew (ATC_SLEW_YAW, 60°/s) is under 2 s.
    let budget = patience.secs(15.0);
    for attempt in 1..=3 {
        match fleet.face(sysid, lat, lon, alt, want as f32).await {
            Ok(()) => {}
            Err(FleetError::Flavour { .. }) => return Ok(()),
            Err(e) => return Err(e.into()),
        }
        match fleet.wait_until(sysid, budget, aligned).await {
            Ok(_) => return Ok(()),
            Err(last) if attempt == 3 => {
                return Err(FlightError::Timeout {
                    sysid,
                    what: format!(
                        "turning to {want:.0}° (heading {})",
                        last.and_then(|s| s.heading_deg)
                            .map(|h| format!("{h:.0}°"))
                            .unwrap_or("?".into())
                    ),
                    waited_s: budget.as_secs_f64() * 3.0,
                });
            }
            Err(_) => {}
        }
    }
    Ok(())
}

/// Stop and hold where the vehicle is now, in its autopilot's hold mode
/// ([`fleetmap_core::proto::flavour::Flavour::pause`]: ArduCopter BRAKE, HOLD otherwise). Nothing to
/// do for a copter on the ground (ArduCopter disarms a landed copter in BRAKE).
pub(crate) async fn hold_here(fleet: &FleetHandle, sysid: u8) -> Result<(), FleetError> {
    let v = fleet
        .vehicle(sysid)
        .ok_or(FleetError::NoVehicle { sysid })?;
    if v.flavour.flies() && !airborne(&v) {
        return Ok(());
    }
    fleet.pause(sysid).await
}

/// Throw away the images already waiting in `rx`.
pub(crate) fn drain_images(rx: &mut broadcast::Receiver<Arc<ReceivedImage>>) {
    loop {
        match rx.try_recv() {
            Ok(_) | Err(broadcast::error::TryRecvError::Lagged(_)) => {}
            Err(_) => return,
        }
    }
}

/// One picture as [`capture`] got it.
#[derive(Clone, Debug)]
pub struct Captured {
    /// The image.
    pub image: Arc<ReceivedImage>,
    /// The vehicle's telemetry right after the camera accepted the command (the shutter):
    /// where the picture was taken when the camera does not say.
    pub(crate) at_trigger: Option<VehicleSnapshot>,
}

/// Longest wait for one picture while its camera keeps sending image data, nominal seconds:
/// on a slow payload link (a telemetry radio, PX4 SITL's 4 kB/s) a picture can be queued
/// behind earlier ones; a hovering vehicle should not wait on a longer backlog (the caller
/// takes the picture again, by then the queue has moved on).
pub(crate) const CAPTURE_MAX_WAIT_S: f64 = 120.0;

/// Nominal seconds after the capture command, and between two requests, before the camera is
/// asked again for a capture it has not been heard to take ([`capture`]): a camera takes and
/// announces a single picture within a few hundred milliseconds, and over a 2,000 B/s radio
/// the command, the ACK and the announcement cross in well under a second more.
pub(crate) const RESEND_AFTER_S: f64 = 1.5;

/// Nominal seconds after half of a capture was heard (its announcement or its on-board
/// result: the camera sends them back to back) before the other half is asked for.
pub(crate) const RESULT_AFTER_S: f64 = 0.5;

/// MAV_CMD_REQUEST_MESSAGE for the CAMERA_IMAGE_CAPTURED of captures `first` to `last` from
/// `camera` (`None`: `first` and every capture after it). Param2 is the first index, param3 0
/// for that one alone, −1 for all the following or the last index of a range (common.xml,
/// CAMERA_IMAGE_CAPTURED).
pub(crate) fn capture_again(camera: Endpoint, first: i32, last: Option<i32>) -> MavMessage {
    const CAMERA_IMAGE_CAPTURED: f32 = 263.0;
    let range = match last {
        None => -1.0,
        Some(l) if l <= first => 0.0,
        Some(l) => l as f32,
    };
    Command::long(
        camera,
        MavCmd::MAV_CMD_REQUEST_MESSAGE,
        [
            CAMERA_IMAGE_CAPTURED,
            first as f32,
            range,
            0.0,
            0.0,
            0.0,
            0.0,
        ],
    )
    .message(0)
}

/// Take picture `seq` and wait for its image from `sysid`, at most 10 s (scaled by
/// `patience`) after the command or after the last image data heard from the vehicle, and
/// never more than `CAPTURE_MAX_WAIT_S`. One capture: an image that does not arrive is
/// [`FlightError::NoImage`], for the caller to retry as a new capture (the runway runner
/// counts it against its retake limit).
///
/// The picture is one announced after the command (CAMERA_IMAGE_CAPTURED, matched by
/// `time_boot_ms` and `image_index`): earlier pictures still in transfer are passed over.
/// From a camera that announces nothing, the image that arrived, a second after it did.
///
/// A picture measured on board needs both its announcement (the pose) and its result; over a
/// lossy radio one of them is lost now and then, and so are the command and its ACK. The
/// command runs beside the wait (an image that comes before the ACK counts), and the capture
/// is asked for again on its own schedule, fire and forget: `RESULT_AFTER_S` after one half
/// named the picture, the camera is asked for it (MAV_CMD_REQUEST_MESSAGE for that
/// CAMERA_IMAGE_CAPTURED, as the MAVLink camera protocol recovers a missed capture; the camera
/// sends the announcement and its result again); when nothing has named it
/// `RESEND_AFTER_S` after the command, the command is sent again while unacknowledged (its
/// sequence number makes a repeat take no second picture) and the captures after `after`
/// (the image index of the vehicle's last picture that arrived) are asked for — the one
/// commanded is among them unless the camera restarted its count, and then it answers that it
/// has none. Both repeat every `RESEND_AFTER_S` until the picture arrives or the wait ends.
pub async fn capture(
    fleet: &FleetHandle,
    rx: &mut broadcast::Receiver<Arc<ReceivedImage>>,
    sysid: u8,
    seq: u32,
    after: Option<i32>,
    patience: Patience,
) -> Result<Captured, FlightError> {
    // Every instant on the fleet's clock, the one the links and the vehicles' timeouts use.
    let clock = fleet.clock();
    let wait = patience.secs(10.0);
    let started = clock.now();
    let longest = started + patience.secs(CAPTURE_MAX_WAIT_S);
    let mut frames = fleet.subscribe();
    drain_images(rx);
    // The command runs beside the wait: a picture whose ACK was lost is taken all the same
    // (the command sent again carries the same sequence number and takes no second one).
    let command = fleet.capture_image(sysid, seq);
    tokio::pin!(command);
    let mut commanded = false;
    let mut at_trigger = None;
    let key_of =
        |image: &ReceivedImage| image.pose.as_ref().map(|p| (p.time_boot_ms, p.image_index));
    // The pictures announced since the command (the camera's, and any other component's),
    // and the last image whose announcement has not been seen.
    let mut announced: Vec<(u32, i32)> = Vec::new();
    let mut early: Option<(Arc<ReceivedImage>, Time)> = None;
    let mut deadline = started + wait;
    // The capture as the camera named it (announcement or on-board result), and when the
    // camera will next be asked for it.
    let mut named: Option<i32> = None;
    let camera = fleet
        .vehicle(sysid)
        .and_then(|v| v.camera_compid)
        .map(|c| Endpoint::new(sysid, c));
    let mut ask_at = started + patience.secs(RESEND_AFTER_S);
    // A capture after the vehicle's last picture: not an earlier one sent again late.
    let is_new = |index: i32| after.is_none_or(|a| index > a);
    loop {
        // Ask again, on this capture's own schedule: fire and forget, every RESEND_AFTER_S,
        // not through the command protocol (whose retries wait for its own timeout, stretched
        // on a sped-up simulator, and queue behind earlier requests of the same command).
        if let Some(cam) = camera
            && clock.now() >= ask_at
        {
            ask_at = clock.now() + patience.secs(RESEND_AFTER_S);
            let mut again = Vec::new();
            match named {
                Some(index) => again.push(capture_again(cam, index, Some(index))),
                None => {
                    // the command may not have arrived: the same sequence number takes no
                    // second picture if it did
                    if !commanded {
                        again.push(capture_command(cam, seq).message(0));
                    }
                    if let Some(a) = after {
                        again.push(capture_again(cam, a.saturating_add(1), None));
                    }
                }
            }
            if !again.is_empty() {
                tracing::info!(
                    "vehicle {sysid}: asking the camera again for capture {seq} ({named:?})"
                );
            }
            for m in again {
                let _ = fleet.send_to(sysid, m).await;
            }
        }
        // An image came and nothing was announced since the command: its announcement, sent
        // before it, would be in within a second; without one the camera does not announce.
        let until = match &early {
            Some((_, at)) if announced.is_empty() => deadline.min(*at + patience.secs(1.0)),
            _ => deadline,
        };
        // woken to ask the camera again, or to give up
        let wake = match camera {
            Some(_) => until.min(ask_at),
            None => until,
        };
        let left = clock.wall_until(wake);
        tokio::select! {
            biased;
            r = &mut command, if !commanded => {
                commanded = true;
                at_trigger.get_or_insert_with(|| fleet.vehicle(sysid));
                // a command that failed took no picture, unless one came meanwhile
                if announced.is_empty() && named.is_none() {
                    r?;
                }
            }
            f = frames.recv() => match f {
                Ok(inc) if inc.frame.sysid() == sysid => match &inc.frame.message {
                    Ok(MavMessage::CAMERA_IMAGE_CAPTURED(c)) => {
                        let key = (c.time_boot_ms, c.image_index);
                        announced.push(key);
                        if is_new(c.image_index) {
                            named.get_or_insert(c.image_index);
                        }
                        at_trigger.get_or_insert_with(|| fleet.vehicle(sysid));
                        // its result follows it at once: asked for if it is not in soon
                        ask_at = ask_at.min(clock.now() + patience.secs(RESULT_AFTER_S));
                        if let Some((image, _)) = early.take_if(|(i, _)| key_of(i) == Some(key)) {
                            return Ok(Captured { image, at_trigger: at_trigger.flatten() });
                        }
                    }
                    Ok(MavMessage::ENCAPSULATED_DATA(_) | MavMessage::DATA_TRANSMISSION_HANDSHAKE(_)) => {
                        deadline = (clock.now() + wait).min(longest);
                    }
                    // an on-board result whose announcement may have been lost: its index
                    // (low 16 bits: a camera takes fewer pictures between two boots)
                    Ok(MavMessage::DEBUG_FLOAT_ARRAY(d)) if named.is_none() => {
                        named = measured_index(d, after).filter(|&i| is_new(i));
                        if named.is_some() {
                            ask_at = ask_at.min(clock.now() + patience.secs(RESULT_AFTER_S));
                        }
                    }
                    _ => {}
                },
                Ok(_) | Err(broadcast::error::RecvError::Lagged(_)) => {}
                Err(broadcast::error::RecvError::Closed) => return Err(FlightError::ImagesClosed),
            },
            r = rx.recv() => match r {
                Ok(image) if image.sysid == sysid => {
                    let at_trigger = at_trigger.clone().unwrap_or_else(|| fleet.vehicle(sysid));
                    match key_of(&image) {
                        Some(k) if announced.contains(&k) => return Ok(Captured { image, at_trigger }),
                        // Announced before the command (an earlier picture still in transfer),
                        // or its announcement is still on the way.
                        Some(_) => early = Some((image, clock.now())),
                        None => return Ok(Captured { image, at_trigger }),
                    }
                }
                Ok(_) | Err(broadcast::error::RecvError::Lagged(_)) => {}
                Err(broadcast::error::RecvError::Closed) => return Err(FlightError::ImagesClosed),
            },
            // The wall time until `wake` on the fleet's clock (a lower bound when it
            // follows a simulator: waking early only goes round the loop again).
            _ = tokio::time::sleep(left) => {
                if clock.now() >= until || (left.is_zero() && wake == until) {
                    break;
                }
            }
        }
    }
    let at_trigger = at_trigger.flatten();
    // Nothing was announced: a camera that does not announce its pictures.
    if announced.is_empty()
        && let Some((image, _)) = early
    {
        return Ok(Captured { image, at_trigger });
    }
    Err(FlightError::NoImage {
        sysid,
        seq,
        waited_s: clock.now().saturating_since(started).as_secs_f64(),
    })
}

/// The image index of the picture an on-board result (any DEBUG_FLOAT_ARRAY of
/// [`fleetmap_core::vision::onboard::Onboard`]'s, not a status) is of. The result carries its low 16 bits; the high ones are
/// those of the index nearest `after` (the vehicle's last picture) with those low bits.
pub(crate) fn measured_index(
    d: &mavlink::dialects::ardupilotmega::DEBUG_FLOAT_ARRAY_DATA,
    after: Option<i32>,
) -> Option<i32> {
    let (_, lo) = fleetmap_core::vision::onboard::Onboard::from_message(d)?.capture()?;
    let lo = i32::from(lo);
    Some(match after {
        Some(a) if a >= 0 => {
            let full = (a & !0xFFFF) | lo;
            // well behind `after`: the low bits wrapped; just behind: an earlier picture
            if a - full > 0x8000 {
                full.saturating_add(0x1_0000)
            } else {
                full
            }
        }
        _ => lo,
    })
}

/// Return to launch and wait until the vehicle has landed and disarmed (already down: at
/// once).
pub(crate) async fn return_and_land(
    fleet: &FleetHandle,
    sysid: u8,
    distance_hint_m: f64,
    speed: f64,
    patience: Patience,
) -> Result<(), FlightError> {
    let down = |s: &VehicleSnapshot| s.on_ground() && !s.armed;
    if fleet.vehicle(sysid).is_some_and(|s| down(&s)) {
        return Ok(());
    }
    fleet.rtl(sysid).await?;
    let wait = patience.secs(distance_hint_m.max(0.0) / speed.max(0.5) * 2.0 + 180.0);
    fleet
        .wait_until(sysid, wait, down)
        .await
        .map(|_| ())
        .map_err(|_| FlightError::Timeout {
            sysid,
            what: "landing at home".into(),
            waited_s: wait.as_secs_f64(),
        })
}

/// Land where the vehicle is and wait until it has landed and disarmed.
pub(crate) async fn land_here(
    fleet: &FleetHandle,
    sysid: u8,
    patience: Patience,
) -> Result<(), FlightError> {
    let down = |s: &VehicleSnapshot| s.on_ground() && !s.armed;
    if fleet.vehicle(sysid).is_some_and(|s| down(&s)) {
        return Ok(());
    }
    fleet.land(sysid).await?;
    let wait = patience.secs(180.0);
    fleet
        .wait_until(sysid, wait, down)
        .await
        .map(|_| ())
        .map_err(|_| FlightError::Timeout {
            sysid,
            what: "landing".into(),
            waited_s: wait.as_secs_f64(),
        })
}

/// Distance from the vehicle to its home, metres (0 when unknown).
pub(crate) fn distance_home(v: &VehicleSnapshot) -> f64 {
    match (v.position, v.home) {
        (Some(p), Some(h)) => local::distance(p.lat, p.lon, h.lat, h.lon),
        _ => 0.0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_on_board_result_names_the_picture_nearest_the_last_one() {
        use fleetmap_core::vision::onboard::OnboardMeasurement;
        let result = |index: i32| match (OnboardMeasurement {
            time_boot_ms: 1000,
            image_index_lo: index as u16,
            spec: 7,
            picture_bytes: 1000,
            value: fleetmap_core::vision::onboard::GreenShare {
                share: 0.5,
                pixels: 100,
            },
        })
        .to_message()
        {
            MavMessage::DEBUG_FLOAT_ARRAY(d) => d,
            m => panic!("{m:?}"),
        };
        assert_eq!(measured_index(&result(5), None), Some(5));
        assert_eq!(measured_index(&result(8), Some(6)), Some(8));
        // an earlier picture sent again: behind the last one, not 65,536 ahead
        assert_eq!(measured_index(&result(5), Some(6)), Some(5));
        // the low 16 bits wrapped past the last picture
        assert_eq!(measured_index(&result(2), Some(0xFFFF)), Some(0x1_0002));
        assert_eq!(
            measured_index(&result(0x1_0003), Some(0x1_0001)),
            Some(0x1_0003)
        );
    }

    #[test]
    fn grid_headings() {
        assert_eq!(nearest_quarter(229.8), 270.0);
        assert_eq!(nearest_quarter(-30.0), 0.0);
        assert_eq!(nearest_quarter(359.0), 0.0);
        assert_eq!(nearest_quarter(134.0), 90.0);
        assert!((heading_error(359.0, 1.0) - 2.0).abs() < 1e-12);
        assert!((heading_error(90.0, 270.0) - 180.0).abs() < 1e-12);
        assert!((heading_error(-45.0, 45.0) - 90.0).abs() < 1e-12);
    }
}
