//! Image intake of the runway run: a received picture's pose, its crop and classification
//! (on a blocking thread), and a visit's pictures with their retakes and camera faults.

use super::*;
use crate::app::blocking::run_blocking;
use crate::app::error::RunnerResult;
use crate::app::images::{Announcement, CapturePose, OnboardAccept};
use fleetmap_core::mission::definition::MissionDef;
use fleetmap_core::vision::VisionError;
use fleetmap_core::vision::onboard::OnboardKind;
use fleetmap_core::vision::runway::onboard::{
    OnboardRegions, RunwayDefinition, RunwayMeasurement, RunwaySpec, ShutterPose,
};

pub(super) fn labels5(c: &RegionReading) -> [bool; 5] {
    let l = c.labels;
    [l.center, l.north, l.west, l.south, l.east]
}

pub(super) fn fractions5(c: &RegionReading) -> [f64; 5] {
    let f = c.fractions;
    [f.center, f.top, f.left, f.bottom, f.right]
}

/// How the 3 × 3 cells are cut out of a picture before it is classified.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Cut {
    /// The attitude is unknown: the centre crop of [`crop_to_cells`] at `altitude_m`, its
    /// regions turned by `heading_deg` (the image's top, degrees clockwise from north).
    Centre {
        /// Heading of the image's top, degrees.
        heading_deg: f64,
        /// Altitude the footprint is computed for, metres.
        altitude_m: f64,
    },
    /// The attitude is known: the north-up, grid-aligned orthophoto of
    /// [`geometry::orthophoto`] (whose regions need no turning).
    Ortho {
        /// Attitude at the shutter, body → NED.
        attitude: UnitQuaternion<f64>,
        /// Capture altitude above home (flat ground at home's elevation), metres.
        altitude_m: f64,
        /// Where the orthophoto is centred and how the grid is oriented.
        request: OrthoRequest,
    },
}

/// Decode a received image, cut it as `cut` says and classify it (blocking work). Errors:
/// the picture cannot be decoded, cut (no orthophoto from this pose) or classified.
pub(crate) fn classify_cut(
    bytes: &[u8],
    cut: &Cut,
    params: &RunwayParams,
    camera: &CameraModel,
    cell_m: f64,
) -> Result<RegionReading, VisionError> {
    let img = load_image_bytes(bytes, &LoadLimits::default())?;
    match cut {
        Cut::Centre {
            heading_deg,
            altitude_m,
        } => {
            let img = crop_to_cells(img, camera, *altitude_m, cell_m);
            classify(&img, *heading_deg, params)
        }
        Cut::Ortho {
            attitude,
            altitude_m,
            request,
        } => {
            let o = geometry::orthophoto(&img, camera, attitude, *altitude_m, request)?;
            classify(&o.image, 0.0, params)
        }
    }
}

/// The on-board definition of the runway mission `def` (what `fleetmap camera --mission`
/// and the simulated cameras are given): the camera crate's
/// [`fleetmap_camera::camera::onboard::runway::definition_of`], which the companion computer's camera
/// reads its mission with. `None` for another kind of mission.
pub fn runway_definition_of(def: &MissionDef) -> Option<RunwayDefinition> {
    fleetmap_camera::camera::onboard::runway::definition_of(def)
}

/// The definition a run accepts the cameras' on-board results of: its classifier, camera and
/// grid; `None` for a moving region, whose pictures are credited in the region's frame at
/// the shutter, which a camera does not follow (they stay on the picture path).
pub(super) fn runway_spec(s: &MappingState) -> Option<RunwaySpec> {
    (s.params.motion().speed() == 0.0).then(|| RunwaySpec {
        params: s.params.runway,
        camera: s.params.camera,
        grid: s.grid.clone(),
    })
}

/// What a run accepts of the cameras' results: those of `spec`, whose grid is announced to
/// the cameras of `cameras` (the run's drones) until each confirms it.
pub fn onboard_accept(spec: &RunwaySpec, cameras: Vec<u8>) -> OnboardAccept {
    OnboardAccept {
        fingerprint: spec.fingerprint(),
        announce: Some(Announcement {
            message: spec.announcement().to_message(),
            cameras,
        }),
    }
}

/// The camera's result of a picture, when it measured it on board with the run's
/// definition.
pub(super) fn onboard_result(img: &ReceivedImage) -> Option<RunwayMeasurement> {
    img.onboard.as_ref()?.get::<RunwayMeasurement>().copied()
}

/// Longest wait for an audited picture, nominal seconds (a 50 kB picture over a radio that
/// leaves a kilobyte a second for it, asked again when packets are lost).
pub(super) const AUDIT_WAIT_S: f64 = 240.0;

/// The run's side of on-board classification: the definition it accepts (announced to the
/// cameras through the image hub), and the audits in flight.
pub(super) struct Onboard {
    hub: ImageHub,
    spec: Option<RunwaySpec>,
    /// The audits' tasks (they end with their picture or their wait).
    pub(super) audits: tokio::sync::Mutex<tokio::task::JoinSet<()>>,
    /// Vehicles with an audit in flight, and the cells audited.
    busy: std::sync::Mutex<(HashSet<u8>, HashSet<Cell>)>,
    /// Set when the run ends: audits still waiting for their picture give up (and are
    /// journalled as lost).
    over: tokio::sync::watch::Sender<bool>,
}

impl Onboard {
    /// Accept the cameras' results for the run in `state` (its drones' cameras are told the
    /// grid), through `hub`.
    pub(super) fn start(hub: &ImageHub, state: &MappingState) -> Onboard {
        let spec = runway_spec(state);
        let cameras = state.robots.iter().map(|r| r.sysid).collect();
        hub.accept_onboard(
            OnboardKind::Runway,
            spec.as_ref().map(|s| onboard_accept(s, cameras)),
        );
        Onboard {
            hub: hub.clone(),
            spec,
            audits: tokio::sync::Mutex::new(tokio::task::JoinSet::new()),
            busy: std::sync::Mutex::new((HashSet::new(), HashSet::new())),
            over: tokio::sync::watch::Sender::new(false),
        }
    }

    /// The end of the runner: audits still waiting for their picture give up, each
    /// journalled as lost, and are waited for.
    pub(super) async fn finish(&self) {
        self.over.send_replace(true);
        let mut audits = self.audits.lock().await;
        while audits.join_next().await.is_some() {}
    }

    /// Whether a picture of vehicle `sysid` may be audited for a decision about `cell`: none
    /// of its audits is in flight and `cell` was not audited; if so, it now is.
    fn may_audit(&self, sysid: u8, cell: Cell) -> bool {
        let Ok(mut b) = self.busy.lock() else {
            return false;
        };
        if b.0.contains(&sysid) || b.1.contains(&cell) {
            return false;
        }
        b.0.insert(sysid);
        b.1.insert(cell);
        true
    }

    fn audit_done(&self, sysid: u8) {
        if let Ok(mut b) = self.busy.lock() {
            b.0.remove(&sysid);
        }
    }

    /// The camera's classification `m` of a picture taken at `pose` and the cell it is
    /// about: the cell the run's grid puts under the pose the picture was announced with
    /// (what the GCS credits), which must be the camera's. Errors say why it cannot be used.
    pub(super) fn credited(
        &self,
        m: &RunwayMeasurement,
        pose: Option<&CapturePose>,
    ) -> Result<(Cell, RegionReading), String> {
        let spec = self
            .spec
            .as_ref()
            .ok_or("a result of a definition the run does not use")?;
        let r = m.regions.ok_or("the camera did not classify the picture")?;
        let shutter = pose
            .and_then(shutter_pose)
            .ok_or("the camera's result has no pose with an attitude")?;
        let credited = spec.cut(&shutter).map_err(|e| e.to_string())?.cell;
        if credited != r.cell {
            return Err(format!(
                "the camera put its picture in cell {}, the grid puts its position in {credited}",
                r.cell
            ));
        }
        let c = m.reading(&spec.params).map_err(|e| e.to_string())?;
        Ok((r.cell, c))
    }

    /// [`Onboard::credited`] for a picture taken over `cell`: the camera's cell must be
    /// `cell` (the cell under the camera is the one visited when the picture passed the
    /// sanity check; otherwise it is taken again).
    fn reading(
        &self,
        m: &RunwayMeasurement,
        pose: Option<&CapturePose>,
        cell: Cell,
    ) -> Result<RegionReading, PictureFailure> {
        let (under, c) = self
            .credited(m, pose)
            .map_err(|why| PictureFailure::Unreadable(format!("cell {cell}: {why}")))?;
        if under != cell {
            return Err(PictureFailure::Rejected(format!(
                "cell {cell}: the camera classified its picture around cell {under} (the cell \
                 under it)"
            )));
        }
        Ok(c)
    }
}

/// The pose a camera cut its picture by, from what the GCS heard of the capture.
pub(super) fn shutter_pose(p: &CapturePose) -> Option<ShutterPose> {
    Some(ShutterPose {
        lat_deg: p.lat,
        lon_deg: p.lon,
        alt_rel_m: p.alt_rel_m,
        q: p.q?,
    })
}

/// An audit: ask for the picture of `img` (classified on board as `m`), wait for it and
/// classify it with the run's definition. Returns the GCS's labels (centre, north, west,
/// south, east) and whether its classification is the camera's exactly; an error says why
/// there is none.
async fn audit_picture(
    shared: &Shared,
    sysid: u8,
    img: &ReceivedImage,
    m: &RunwayMeasurement,
) -> Result<([bool; 5], bool), String> {
    let spec = shared
        .onboard
        .spec
        .clone()
        .ok_or("the run accepts no on-board result")?;
    let pose = img.pose.as_ref().ok_or("the picture has no pose")?;
    let shutter = shutter_pose(pose).ok_or("the picture has no attitude")?;
    let mut rx =
        shared
            .onboard
            .hub
            .ask_picture(sysid, pose.time_boot_ms, pose.image_index, m.picture_bytes);
    let clock = shared.fleet.clock().clone();
    let deadline = clock.now() + shared.patience.secs(AUDIT_WAIT_S);
    let mut over = shared.onboard.over.subscribe();
    let picture = loop {
        let left = clock.wall_until(deadline);
        tokio::select! {
            biased; // the picture first if it came at the deadline, and the same every run
            r = &mut rx => break r.map_err(|_| "the image intake stopped".to_string())?,
            _ = over.wait_for(|o| *o) => {
                return Err("the run ended before the picture arrived".to_string());
            }
            _ = tokio::time::sleep(left) => {
                if left.is_zero() || clock.now() >= deadline {
                    return Err(format!("the picture did not arrive within {AUDIT_WAIT_S:.0} s"));
                }
            }
        }
    };
    let bytes = picture.bytes.clone();
    let r = run_blocking(move || {
        let img = load_image_bytes(&bytes, &LoadLimits::default())?;
        spec.measure(&img, &shutter)
    })
    .await
    .map_err(|e| e.to_string())?
    .map_err(|e| format!("the picture: {e}"))?;
    let c = &r.reading;
    let l = c.labels;
    let ours = [l.center, l.north, l.west, l.south, l.east];
    Ok((ours, OnboardRegions::of(&r) == m.regions))
}

/// Where a picture was taken: what the camera said, else the vehicle's telemetry `v` (at
/// the shutter when known).
pub(super) fn shot_pose(img: &ReceivedImage, v: Option<&VehicleSnapshot>) -> Option<ShotPose> {
    let heading_now = v.and_then(|v| v.heading_deg).map(f64::from);
    if let Some(p) = &img.pose {
        let heading = p.heading_deg.or(heading_now).unwrap_or(0.0);
        let attitude =
            p.q.and_then(geometry::attitude_of_quaternion)
                .map(|a| geometry::with_yaw_deg(&a, heading));
        return Some(ShotPose {
            lat: p.lat,
            lon: p.lon,
            alt_m: Some(p.alt_rel_m),
            heading_deg: heading,
            camera_heading_deg: p.heading_deg,
            attitude,
            from_camera: true,
        });
    }
    let v = v?;
    let p = v.position?;
    Some(ShotPose {
        lat: p.lat,
        lon: p.lon,
        alt_m: v.alt_rel.map(f64::from),
        heading_deg: heading_now.unwrap_or(0.0),
        camera_heading_deg: None,
        attitude: None,
        from_camera: false,
    })
}

/// How far ahead of the region a vehicle aims before each picture of a visit, seconds of
/// its drift: a picture is taken as soon as the vehicle has stopped over the point, and the
/// cell should then be coming under it, not leaving.
const REAIM_LEAD_S: f64 = 0.5;

impl Pilot {
    /// The run's cruise speed, m/s.
    async fn speed(&self) -> f64 {
        self.shared.read(|s| s.params.speed_m_s).await
    }

    /// Whether region cell `cell` of a moving region has drifted more than the arrival
    /// tolerance from under the vehicle (always false for a static region).
    async fn drifted_from(&self, cell: Cell) -> RunnerResult<bool> {
        let roi = self.shared.roi;
        if roi.is_static() {
            return Ok(false);
        }
        let grid = self.shared.read(|s| s.grid.clone()).await;
        let Some((e, n)) = self.vehicle_xy(&grid)? else {
            return Ok(true);
        };
        let (ce, cn) = roi.cell_centre(cell, self.shared.now(), grid.cell_size());
        Ok((ce - e).hypot(cn - n) > self.shared.tolerance_m)
    }

    /// Take the images still missing for this visit of `cell`, counting each one's votes.
    /// A picture counts only when it was taken over the cell ([`check_capture`]); one that
    /// does not, never arrives or cannot be read is taken again, up to
    /// [`RunOptions::max_retakes`] times in this visit, after which the camera is declared
    /// faulty ([`Pilot::camera_fault`]). Returns false when the visit was cut short (battery,
    /// camera fault).
    pub(super) async fn take_images(&mut self, cell: Cell) -> RunnerResult<bool> {
        let sysid = self.sysid;
        self.doing(Activity::Imaging);
        let mut retakes = 0u32;
        loop {
            let (missing, over) = self
                .shared
                .read(|s| {
                    (
                        s.images_missing(sysid, cell),
                        matches!(s.phase, Phase::Finished { .. }),
                    )
                })
                .await;
            if over {
                // The run ended meanwhile (the region beyond reach): the visit is cut short.
                return Ok(false);
            }
            if missing == 0 {
                return Ok(true);
            }
            if let Some(v) = self.vehicle() {
                let alt = f64::from(v.alt_rel.unwrap_or(0.0));
                let needed = self
                    .shared
                    .read(|s| s.battery_needed_pct(flight::distance_home(&v), alt))
                    .await;
                if v.battery_pct.is_some_and(|p| f64::from(p) <= needed) {
                    return Ok(false);
                }
            }
            // A moving region moves on under a hovering vehicle: once the cell's centre is
            // more than the arrival tolerance away, over it again first.
            if self.drifted_from(cell).await?
                && let Some(p) = self.aim_at(cell, self.speed().await, REAIM_LEAD_S).await?
            {
                let alt = self.shared.read(|s| s.altitude_of(sysid)).await? as f32;
                flight::fly_to(
                    self.fleet(),
                    sysid,
                    (p.lat, p.lon, alt),
                    self.speed().await as f32,
                    self.shared.tolerance_m,
                    self.shared.patience,
                )
                .await?;
            }
            if self.capture_seq == 0 {
                self.wait_for_camera().await;
            }
            let shutter = self.shared.now();
            let shots = match self.visit_camera(missing) {
                Some((camera, after)) => self.take_several(cell, camera, after, missing).await?,
                None => vec![self.take_one(cell).await?],
            };
            for shot in shots {
                let failure = match shot {
                    Ok(shot) => match self.count_shot(cell, shot, shutter).await? {
                        Ok(()) => continue,
                        Err(failure) => failure,
                    },
                    Err(failure) => failure,
                };
                retakes += 1;
                if self.picture_failed(cell, retakes, failure).await? {
                    return Ok(false);
                }
            }
        }
    }

    /// Take one picture of `cell` ([`flight::capture`]).
    async fn take_one(
        &mut self,
        cell: Cell,
    ) -> RunnerResult<Result<flight::Captured, PictureFailure>> {
        let sysid = self.sysid;
        self.capture_seq += 1;
        let fleet = self.shared.fleet.clone();
        let shot = match flight::capture(
            &fleet,
            &mut self.images,
            sysid,
            self.capture_seq,
            self.last_image,
            self.shared.patience,
        )
        .await
        {
            Ok(shot) => {
                if let Some(p) = &shot.image.pose {
                    self.last_image = Some(p.image_index);
                }
                // announced with its index and measured on board: the next visit may
                // take its pictures several at a time
                self.in_flight_ok =
                    shot.image.pose.is_some() && onboard_result(&shot.image).is_some();
                self.camera.last_picture = Some(self.fleet().clock().now());
                Ok(shot)
            }
            // The camera did not answer while its autopilot is heard: a camera gone
            // silent (off, rebooting, unplugged), retaken like a picture that never came;
            // a vehicle not heard at all is a link outage, a step retried.
            Err(FlightError::Fleet(crate::fleet::FleetError::Command {
                error: fleetmap_core::proto::command::CommandError::Timeout { attempts, .. },
                ..
            })) if self.vehicle().is_some_and(|v| v.alive) => Err(PictureFailure::Lost(format!(
                "cell {cell}: its camera did not answer capture {} ({attempts} tries)",
                self.capture_seq
            ))),
            Err(FlightError::NoImage { seq, waited_s, .. }) => Err(PictureFailure::Lost(format!(
                "cell {cell}: no image arrived within {waited_s:.0} s of capture {seq}"
            ))),
            Err(e) => return Err(e.into()),
        };
        Ok(shot)
    }

    /// Count picture `shot` of `cell` (taken at region time `shutter`): checked where it
    /// was taken, classified (on board or here), its votes journalled. Returns why it did
    /// not count.
    async fn count_shot(
        &mut self,
        cell: Cell,
        shot: flight::Captured,
        shutter: Time,
    ) -> RunnerResult<Result<(), PictureFailure>> {
        let sysid = self.sysid;
        let v_now = self.vehicle();
        let at_shutter = shot.at_trigger.as_ref().or(v_now.as_ref());
        let pose = shot_pose(&shot.image, at_shutter);
        let (params, camera, planned, grid) = self.shared.picture_setting(sysid).await;
        let cell_m = grid.cell_size();
        let centre = (f64::from(cell.col) * cell_m, f64::from(cell.row) * cell_m);
        // In the region's frame (the grid's own for a static region) at the shutter.
        let xy = pose.as_ref().and_then(|p| {
            grid.to_xy(LatLon {
                lat: p.lat,
                lon: p.lon,
            })
            .ok()
            .map(|(e, n)| self.shared.roi.in_region(e, n, shutter))
        });
        let verdict = match (&pose, xy) {
            (Some(p), Some((e, n))) => check_capture(
                &CaptureClaim {
                    horizontal_offset_m: Some((centre.0 - e).hypot(centre.1 - n)),
                    altitude_m: p.alt_m,
                    attitude: p.attitude,
                    heading_deg: p.camera_heading_deg,
                    expected_heading_deg: at_shutter.and_then(|v| v.heading_deg).map(f64::from),
                },
                planned,
                &self.shared.limits,
            )
            .map_err(|r| {
                format!(
                    "cell {cell}: {} picture {r}",
                    if p.from_camera {
                        "the camera's"
                    } else {
                        "the telemetry's"
                    }
                )
            }),
            (Some(p), None) => Err(format!(
                "cell {cell}: the picture's position ({:.7}, {:.7}) is not on the grid",
                p.lat, p.lon
            )),
            (None, _) => Err(format!(
                "cell {cell}: neither the camera nor the telemetry says where the picture was taken"
            )),
        };
        if let Err(reason) = verdict {
            return Ok(Err(PictureFailure::Rejected(reason)));
        }
        // Checked above: a pose with a grid position.
        let (Some(pose), Some((e, n))) = (pose, xy) else {
            return Ok(Ok(()));
        };
        // The camera's own classification when it made one with the run's definition,
        // else the GCS's of the picture.
        let onboard = onboard_result(&shot.image);
        let result = match &onboard {
            Some(m) => self
                .shared
                .onboard
                .reading(m, shot.image.pose.as_ref(), cell),
            None => {
                let cut = match pose.attitude {
                    Some(attitude) => Cut::Ortho {
                        attitude,
                        altitude_m: pose.alt_m.unwrap_or(planned),
                        request: OrthoRequest {
                            cell_m,
                            centre_east_north_m: (centre.0 - e, centre.1 - n),
                            grid_north_deg: grid
                                .convergence_and_scale(LatLon {
                                    lat: pose.lat,
                                    lon: pose.lon,
                                })
                                .map(|(g, _)| g)
                                .unwrap_or(0.0),
                        },
                    },
                    None => Cut::Centre {
                        heading_deg: pose.heading_deg,
                        altitude_m: planned,
                    },
                };
                let bytes = shot.image.bytes.clone();
                run_blocking(move || classify_cut(&bytes, &cut, &params, &camera, cell_m))
                    .await?
                    .map_err(|r| PictureFailure::Unreadable(format!("cell {cell}: {r}")))
            }
        };
        let c = match result {
            Ok(c) => c,
            Err(failure) => return Ok(Err(failure)),
        };
        let now = self.shared.now();
        let (lat, lon, heading) = (pose.lat, pose.lon, pose.heading_deg);
        let alt_m = pose.alt_m.unwrap_or(planned);
        let measured = onboard.is_some();
        let audit = self
            .shared
            .commit(|s| {
                let image_id = s.next_image_id();
                let det = Detection {
                    image_id: image_id.clone(),
                    vehicle: sysid,
                    time: now,
                    cell,
                    position: Some(GeoPosition {
                        lat_deg: lat,
                        lon_deg: lon,
                        alt_m,
                    }),
                    heading_deg: heading,
                    fractions: c.fractions,
                    labels: c.labels,
                };
                let decided = s.book.decisions().len();
                let changed = s
                    .on_cell_image(det)?
                    .into_iter()
                    .map(|u| (u.cell, format!("{:?}", u.to).to_lowercase()))
                    .collect();
                // A decision of this visit won by one vote, settled by a picture the
                // camera classified: ask for the picture (an audit), if none is asked
                // for this vehicle or this cell yet.
                let disputed = s.book.decisions()[decided..]
                    .iter()
                    .find(|d| d.vehicle == sysid && d.votes_for.abs_diff(d.votes_against) <= 1)
                    .map(|d| d.cell);
                let audit =
                    measured && disputed.is_some_and(|d| self.shared.onboard.may_audit(sysid, d));
                if measured {
                    s.onboard.cell_pictures += 1;
                }
                if audit {
                    s.onboard.audits += 1;
                }
                let ev = MappingEvent::Image {
                    sysid,
                    image_id: image_id.clone(),
                    cell,
                    labels: labels5(&c),
                    fractions: fractions5(&c),
                    changed,
                    onboard: measured,
                };
                Ok((audit.then_some(image_id), Some(ev)))
            })
            .await?;
        if let (Some(image_id), Some(m)) = (audit, onboard) {
            self.audit(cell, image_id, shot.image.clone(), m).await;
        }
        Ok(Ok(()))
    }

    /// Ask for the picture `img` (whose on-board result `m` was counted as `image_id` over
    /// `cell`), classify it here with the run's definition and journal the comparison
    /// ([`MappingEvent::Audit`]): in the background, while the vehicle flies on. The picture
    /// is waited for at most [`AUDIT_WAIT_S`] (scaled by the run's patience).
    async fn audit(
        &self,
        cell: Cell,
        image_id: String,
        img: Arc<ReceivedImage>,
        m: RunwayMeasurement,
    ) {
        let (shared, sysid) = (self.shared.clone(), self.sysid);
        tracing::info!("vehicle {sysid}: asking for picture {image_id} of cell {cell} (audit)");
        let task = async move {
            let outcome = audit_picture(&shared, sysid, &img, &m).await;
            let camera = m.regions.map_or([false; 5], |r| {
                let l = r.labels;
                [l.center, l.north, l.west, l.south, l.east]
            });
            let (gcs, agreed, reason) = match outcome {
                Ok((labels, agreed)) => (Some(labels), Some(agreed), None),
                Err(why) => (None, None, Some(why)),
            };
            if agreed == Some(false) {
                shared.say(
                    Progress::warning(format!(
                        "vehicle {sysid}: the GCS classified picture {image_id} of cell {cell} \
                         otherwise than its camera did on board"
                    ))
                    .about(sysid),
                );
            }
            let _ = shared
                .commit(|s| {
                    s.on_audit(agreed);
                    let ev = MappingEvent::Audit {
                        sysid,
                        cell,
                        image_id,
                        camera,
                        gcs,
                        agreed,
                        reason,
                    };
                    Ok(((), Some(ev)))
                })
                .await;
            shared.onboard.audit_done(sysid);
        };
        self.shared.onboard.audits.lock().await.spawn(task);
    }

    /// A picture of this visit of `cell` did not count (the `retakes`-th): journal why, and
    /// declare the camera faulty when that is more than [`RunOptions::max_retakes`]. Returns
    /// whether it did (the visit is over).
    pub(super) async fn picture_failed(
        &mut self,
        cell: Cell,
        retakes: u32,
        failure: PictureFailure,
    ) -> RunnerResult<bool> {
        let sysid = self.sysid;
        let max = self.shared.max_retakes;
        // Pictures that never came (or captures the camera did not answer): a silent camera.
        // Wrong or unreadable pictures are not.
        let silent = matches!(failure, PictureFailure::Lost(_));
        let (reason, ev) = match failure {
            PictureFailure::Lost(r) | PictureFailure::Unreadable(r) => (
                r.clone(),
                MappingEvent::ImageFailed {
                    sysid,
                    reason: format!("{r} (failed picture {retakes}, at most {max} retaken)"),
                },
            ),
            PictureFailure::Rejected(r) => (
                r.clone(),
                MappingEvent::ImageRejected {
                    sysid,
                    cell: Some(cell),
                    reason: r,
                    retakes,
                },
            ),
        };
        let lost = matches!(ev, MappingEvent::ImageFailed { .. });
        tracing::info!("vehicle {sysid}: picture dropped: {reason}");
        self.shared
            .commit(|s| {
                if lost {
                    s.image_failures += 1;
                }
                Ok(((), Some(ev)))
            })
            .await?;
        if retakes > max {
            self.camera_fault(
                Some(cell),
                format!("{retakes} pictures in one visit did not count; the last: {reason}"),
                silent,
            )
            .await?;
            return Ok(true);
        }
        self.shared.say(
            Progress::warning(format!(
                "vehicle {sysid}: picture dropped ({reason}); taking it again ({retakes} of {max})"
            ))
            .about(sysid),
        );
        Ok(false)
    }

    /// Why this vehicle's camera is out of the run, if it is (saved in the run state, so a
    /// resumed run keeps it on the ground too).
    pub(super) async fn camera_fault_now(&self) -> Option<String> {
        let sysid = self.sysid;
        self.shared
            .read(|s| s.robot(sysid).ok().and_then(|r| r.camera_fault.clone()))
            .await
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use fleetmap_core::explore::dfs::Sharing;

    /// The definition a camera reads from the mission file, completed by the grid the GCS
    /// announces (or with the file's fixed origin), is the run's own: the same fingerprint.
    /// A moving region's run accepts none; another kind of mission gives none.
    #[test]
    fn the_cameras_definition_is_the_runs() {
        let def = MissionDef::parse(crate::kinds::runway::demo::RUNWAY_MISSION, "field").unwrap();
        let home = LatLon {
            lat: 37.1965,
            lon: -80.5785,
        };
        let state = MappingState::new(&def, Grid::new(home, 4.0).unwrap(), Sharing::Gcs).unwrap();
        let spec = runway_spec(&state).unwrap();
        let mut d = runway_definition_of(&def).unwrap();
        assert!(d.grid.is_none());
        assert_eq!(d.adopt(&spec.announcement()), spec.fingerprint());
        assert_eq!(d.spec(), Some(spec));
        // a fixed origin: the camera has the grid from the file
        let fixed = crate::kinds::runway::demo::RUNWAY_MISSION.replacen(
            "\norigin = \"vehicle\"",
            "\norigin = { lat = 37.1965, lon = -80.5785 }",
            1,
        );
        let def = MissionDef::parse(&fixed, "fixed").unwrap();
        let state = MappingState::new(&def, Grid::new(home, 4.0).unwrap(), Sharing::Gcs).unwrap();
        let d = runway_definition_of(&def).unwrap();
        assert_eq!(d.spec(), runway_spec(&state));
        // a region that moves: its pictures stay on the picture path
        let plume = MissionDef::parse(crate::kinds::runway::demo::PLUME_MISSION, "plume").unwrap();
        let state = MappingState::new(&plume, Grid::new(home, 4.0).unwrap(), Sharing::Gcs).unwrap();
        assert_eq!(runway_spec(&state), None);
        let bandit = MissionDef::parse(crate::kinds::bandit::sim::HARDWARE_MISSION, "6x6").unwrap();
        assert_eq!(runway_definition_of(&bandit), None);
    }
}
