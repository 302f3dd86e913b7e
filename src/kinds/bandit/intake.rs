//! The image intake of the bandit run: every received picture's pose, its crop and green
//! measurement (on a blocking thread), committed in groups.

use super::*;
use crate::app::error::RunnerResult;
use fleetmap_core::vision::VisionError;
use fleetmap_core::vision::onboard::{Onboard, OnboardMeasurement};

/// Why a received picture does not count: journalled (its `Display`) as the reason of
/// [`BanditEvent::ImageIgnored`] or, for a picture that could not be measured,
/// [`BanditEvent::ImageFailed`].
#[derive(Debug, thiserror::Error)]
pub(super) enum NotCounted {
    /// It matches no capture visit of the sortie (the state's reason).
    #[error("{0}")]
    NoVisit(fleetmap_core::planner::sortie::ImageMismatch),
    /// Its capture was counted already.
    #[error("already counted")]
    AlreadyCounted,
    /// Its position is outside the grid's zone.
    #[error("position outside the grid's zone")]
    OutsideGrid,
    /// Taken at the wrong altitude or not level enough ([`check_capture`]).
    #[error("picture {0}")]
    Picture(fleetmap_core::vision::sanity::Rejection),
    /// The state refused to record it.
    #[error("{0}")]
    NotRecorded(fleetmap_core::planner::sortie::SortieError),
    /// It could not be decoded.
    #[error(transparent)]
    Unreadable(#[from] VisionError),
    /// It was due to be measured but no measurement came back.
    #[error("not measured")]
    NotMeasured,
}

/// The measurement of one received image (blocking work: decode, crop, count green
/// pixels): the green share and the Bernoulli realisation — [`GreenSpec::measure`], the
/// computation a camera that measures on board runs.
pub fn measure_image(
    bytes: &[u8],
    green: &GreenParams,
    camera: &CameraModel,
    altitude_m: f64,
    cell_m: f64,
    fraction: f64,
) -> Result<(f64, bool), VisionError> {
    let img = load_image_bytes(bytes, &LoadLimits::default())?;
    let spec = GreenSpec {
        green: *green,
        camera: *camera,
        cell_m,
        crop_fraction: fraction,
    };
    let m = spec.measure(&img, altitude_m);
    Ok((m.share, m.positive(green)))
}

/// The measurement definition of the spatial-classification mission `def` — what
/// `green_spec` gives for its runs — or `None` for another kind of mission.
pub fn green_spec_of(def: &fleetmap_core::mission::definition::MissionDef) -> Option<GreenSpec> {
    // the camera crate's, which the companion computer's camera reads its mission with
    fleetmap_camera::camera::onboard::green::spec_of(def)
}

/// The run's measurement definition, as a camera that measures on board must be given it
/// (`fleetmap camera --mission`): the mission's green box, camera, cell size and crop.
pub(crate) fn green_spec(s: &ClassificationState) -> GreenSpec {
    GreenSpec {
        green: s.params.green,
        camera: s.params.camera,
        cell_m: s.grid.cell_size(),
        crop_fraction: s.params.crop_fraction,
    }
}

/// Most images measured and saved together (one state write for the batch).
pub(super) const INTAKE_BATCH: usize = 64;

/// The image intake of the run: every image of a drone during a sortie becomes one
/// measurement (or a journalled reason why not).
///
/// Group commit: the images that are already waiting when one arrives (up to
/// [`INTAKE_BATCH`]) are measured together and saved in one state write, so the intake keeps
/// up with a large fleet (ten drones at 10× real time overran a write per image). A
/// measurement still counts only once the state that holds it is on disk.
pub(super) async fn intake(shared: Arc<Shared>, mut rx: broadcast::Receiver<Arc<ReceivedImage>>) {
    let mut closed = false;
    while !closed {
        let mut batch = Vec::new();
        match rx.recv().await {
            Ok(img) => batch.push(img),
            Err(broadcast::error::RecvError::Lagged(n)) => {
                shared.say(Progress::warning(format!(
                    "{n} image(s) dropped: the intake fell behind"
                )));
                continue;
            }
            Err(broadcast::error::RecvError::Closed) => return,
        }
        while batch.len() < INTAKE_BATCH {
            match rx.try_recv() {
                Ok(img) => batch.push(img),
                Err(broadcast::error::TryRecvError::Lagged(n)) => {
                    shared.say(Progress::warning(format!(
                        "{n} image(s) dropped: the intake fell behind"
                    )));
                }
                Err(broadcast::error::TryRecvError::Empty) => break,
                Err(broadcast::error::TryRecvError::Closed) => {
                    closed = true;
                    break;
                }
            }
        }
        if let Err(e) = take_images(&shared, batch).await {
            shared.say(Progress::warning(format!(
                "images not recorded: {}",
                crate::app::error::chain(&e)
            )));
        }
    }
}

/// Where, when and how an image was taken.
#[derive(Clone, Debug)]
pub(super) struct ImagePose {
    /// Latitude, degrees.
    lat: f64,
    /// Longitude, degrees.
    lon: f64,
    /// Altitude above home, metres (`None`: unknown).
    alt_m: Option<f64>,
    /// Attitude at the shutter (CAMERA_IMAGE_CAPTURED.q), body → NED (`None`: unknown).
    attitude: Option<UnitQuaternion<f64>>,
    /// The capture's name.
    key: CaptureKey,
}

/// Why an image has no pose: it came without one and its vehicle's telemetry has none.
#[derive(Debug, thiserror::Error)]
pub(super) enum NoPose {
    /// The vehicle is not in the fleet's snapshot.
    #[error("vehicle not heard")]
    NotHeard,
    /// The vehicle reports no position.
    #[error("no position")]
    NoPosition,
}

/// Where, when and how an image was taken: what the camera said, else the vehicle's
/// latest telemetry.
pub(super) fn image_pose(shared: &Shared, img: &ReceivedImage) -> Result<ImagePose, NoPose> {
    let sysid = img.sysid;
    Ok(match &img.pose {
        Some(p) => ImagePose {
            lat: p.lat,
            lon: p.lon,
            alt_m: Some(p.alt_rel_m),
            attitude: p.q.and_then(geometry::attitude_of_quaternion),
            key: (sysid, p.time_boot_ms, p.image_index),
        },
        None => {
            let v = shared.fleet.vehicle(sysid).ok_or(NoPose::NotHeard)?;
            let p = v.position.ok_or(NoPose::NoPosition)?;
            let t = img.received.as_millis() as u32;
            ImagePose {
                lat: p.lat,
                lon: p.lon,
                alt_m: v.alt_rel.map(f64::from),
                attitude: None,
                key: (sysid, t, -1),
            }
        }
    })
}

/// The sanity limits of a measured image beyond its position (which
/// [`ClassificationState::match_image`] checks against the capture visits): the capture
/// altitude within [`sanity::VERTICAL_M`] of the drone's planned one and the camera within
/// [`sanity::MAX_TILT_DEG`] of level. A drone starts its batch as it reaches the cell's
/// waypoint, possibly still braking (14° at ArduCopter's 2.5 m/s²): tilted 10° at 10 m its
/// view is 1.8 m — almost half a cell — off the cell centre, and the measured square (0.6 of
/// the cell) would be mostly a neighbour's.
pub(super) fn intake_limits() -> CaptureLimits {
    CaptureLimits {
        horizontal_m: f64::INFINITY,
        vertical_m: sanity::VERTICAL_M,
        max_tilt_deg: sanity::MAX_TILT_DEG,
        max_heading_error_deg: 180.0,
    }
}

/// What became of one image of a batch.
pub(super) enum Taken {
    /// Not during a sortie of this drone: not journalled.
    NotFlying,
    /// Matched no capture visit (or not a picture that counts).
    Ignored(NotCounted),
    /// Its measurement, or why it could not be measured.
    Measured(Result<(f64, bool), NotCounted>),
}

/// Measure a batch of images and record them in one commit (see [`intake`]).
pub(super) async fn take_images(
    shared: &Arc<Shared>,
    batch: Vec<Arc<ReceivedImage>>,
) -> RunnerResult<()> {
    let mut poses = Vec::with_capacity(batch.len());
    for img in &batch {
        match image_pose(shared, img) {
            Ok(p) => poses.push(Some(p)),
            Err(e) => {
                shared.say(
                    Progress::warning(format!(
                        "vehicle {}: image not recorded: {}",
                        img.sysid,
                        crate::app::error::chain(&e)
                    ))
                    .about(img.sysid),
                );
                poses.push(None);
            }
        }
    }
    // Which images match a capture visit (the commit below checks again, in order).
    let (pre, params, cell_m) = shared
        .read(|s| {
            let pre: Vec<Option<Result<f64, NotCounted>>> = batch
                .iter()
                .zip(&poses)
                .map(|(img, pose)| {
                    let pose = pose.as_ref()?;
                    let (lat, lon, key) = (pose.lat, pose.lon, pose.key);
                    let flying = s.cycle().is_some_and(|c| {
                        c.phase == CyclePhase::Started
                            && c.drones.iter().any(|d| d.sysid == img.sysid)
                    });
                    if !flying {
                        return None;
                    }
                    let m = match grid_xy(s, lat, lon) {
                        Some((e, n)) if !s.seen(key) => {
                            s.match_image(img.sysid, e, n).map_err(NotCounted::NoVisit)
                        }
                        Some(_) => Err(NotCounted::AlreadyCounted),
                        None => Err(NotCounted::OutsideGrid),
                    };
                    let planned = s
                        .drones
                        .iter()
                        .find(|d| d.sysid == img.sysid)
                        .map_or(10.0, |d| d.altitude_m);
                    // Taken at the right altitude and level enough (one check with the
                    // runway runner's, vision::sanity).
                    let claim = CaptureClaim {
                        altitude_m: pose.alt_m,
                        attitude: pose.attitude,
                        ..CaptureClaim::default()
                    };
                    let m = m.and_then(|_| {
                        check_capture(&claim, planned, &intake_limits())
                            .map_err(NotCounted::Picture)
                    });
                    Some(m.map(|_| pose.alt_m.unwrap_or(planned)))
                })
                .collect();
            (pre, s.params.clone(), s.grid.cell_size())
        })
        .await;
    // Measured on board (the intake delivers only measurements made with this run's
    // definition): nothing to decode.
    let mut onboard = BTreeMap::new();
    for (i, p) in pre.iter().enumerate() {
        if let (Some(Ok(_)), Some(m)) = (
            p,
            batch[i]
                .onboard
                .as_ref()
                .and_then(Onboard::get::<OnboardMeasurement>),
        ) {
            onboard.insert(i, Ok((m.value.share, m.value.positive(&params.green))));
        }
    }
    let jobs: Vec<(usize, Arc<Vec<u8>>, f64)> = pre
        .iter()
        .enumerate()
        .filter_map(|(i, p)| match p {
            Some(Ok(alt)) if !onboard.contains_key(&i) => Some((i, batch[i].bytes.clone(), *alt)),
            _ => None,
        })
        .collect();
    let measured = crate::app::blocking::run_blocking(move || {
        jobs.into_iter()
            .map(|(i, bytes, alt)| {
                let m = measure_image(
                    &bytes,
                    &params.green,
                    &params.camera,
                    alt,
                    cell_m,
                    params.crop_fraction,
                );
                (i, m.map_err(NotCounted::from))
            })
            .collect::<BTreeMap<usize, Result<(f64, bool), NotCounted>>>()
    })
    .await?;
    let mut measured = measured;
    measured.extend(onboard);
    let taken: Vec<Taken> = pre
        .into_iter()
        .enumerate()
        .map(|(i, p)| match p {
            None => Taken::NotFlying,
            Some(Err(reason)) => Taken::Ignored(reason),
            Some(Ok(_)) => {
                Taken::Measured(measured.remove(&i).unwrap_or(Err(NotCounted::NotMeasured)))
            }
        })
        .collect();
    if taken.iter().all(|t| matches!(t, Taken::NotFlying)) {
        return Ok(());
    }
    let classified = shared
        .commit(|s| {
            let mut events = Vec::new();
            let mut classified = Vec::new();
            for ((img, pose), t) in batch.iter().zip(&poses).zip(taken) {
                let sysid = img.sysid;
                let Some((lat, lon, key)) = pose.as_ref().map(|p| (p.lat, p.lon, p.key)) else {
                    continue;
                };
                let reason = match t {
                    Taken::NotFlying => continue,
                    Taken::Ignored(reason) => reason,
                    Taken::Measured(Err(e)) => {
                        s.image_failures += 1;
                        let reason = e.to_string();
                        events.push(BanditEvent::ImageFailed { sysid, reason });
                        continue;
                    }
                    Taken::Measured(Ok((fraction, positive))) => {
                        // Matched again: an earlier image of this batch may have taken the
                        // visit's last slot or the same capture.
                        let m = match grid_xy(s, lat, lon) {
                            Some((e, n)) if !s.seen(key) => {
                                s.match_image(sysid, e, n).map_err(NotCounted::NoVisit)
                            }
                            Some(_) => Err(NotCounted::AlreadyCounted),
                            None => Err(NotCounted::OutsideGrid),
                        };
                        // `record` fails before it changes anything.
                        match m.and_then(|(visit, _)| {
                            s.record(sysid, visit, key, fraction, positive)
                                .map_err(NotCounted::NotRecorded)
                        }) {
                            Ok(r) => {
                                events.push(BanditEvent::Measurement(r.measurement.clone()));
                                for &(c, label) in &r.classified {
                                    let l = s.bandit.index_of(c);
                                    events.push(BanditEvent::Classified {
                                        cell: c,
                                        label,
                                        samples: l.map_or(0, |l| s.bandit.samples[l]),
                                        mean: l.map_or(0.0, |l| s.bandit.mean(l)),
                                    });
                                    classified.push((
                                        c,
                                        label,
                                        s.bandit.keep().len(),
                                        s.bandit.reject().len(),
                                        s.bandit.unclassified().len(),
                                    ));
                                }
                                continue;
                            }
                            Err(reason) => reason,
                        }
                    }
                };
                s.ignored_images += 1;
                let reason = reason.to_string();
                events.push(BanditEvent::ImageIgnored { sysid, reason });
            }
            Ok((classified, events))
        })
        .await?;
    for (c, label, k, r, u) in classified {
        shared.say(Progress::info(format!(
            "cell {c}: {} (keep {k}, reject {r}, unclassified {u})",
            match label {
                Label::Keep => "interesting — keep",
                Label::Reject => "uninteresting — reject",
                Label::Unclassified => "unclassified",
            }
        )));
    }
    Ok(())
}
