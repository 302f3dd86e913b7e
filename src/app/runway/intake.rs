//! Image intake of the runway run: a received picture's pose, its crop and classification
//! (on a blocking thread), and a visit's pictures with their retakes and camera faults.

use super::*;
use crate::app::error::CpuError;
use crate::app::error::RunnerResult;
use fleetmap_core::vision::VisionError;

pub(super) fn labels5(c: &Classification) -> [bool; 5] {
    let l = c.labels;
    [l.center, l.north, l.west, l.south, l.east]
}

pub(super) fn fractions5(c: &Classification) -> [f64; 5] {
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
) -> Result<Classification, VisionError> {
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

/// Run CPU-heavy work (decoding and classifying an image, a few milliseconds) off the
/// reactor: on a blocking thread in a multi-threaded runtime; inline in a current-thread one
/// (the virtual-clock tests, where a blocking thread would let virtual time run on while it
/// works).
pub(crate) async fn cpu<T: Send + 'static>(
    f: impl FnOnce() -> T + Send + 'static,
) -> Result<T, CpuError> {
    match tokio::runtime::Handle::current().runtime_flavor() {
        tokio::runtime::RuntimeFlavor::CurrentThread => Ok(f()),
        _ => tokio::task::spawn_blocking(f).await.map_err(CpuError),
    }
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
            self.capture_seq += 1;
            let fleet = self.shared.fleet.clone();
            let shutter = self.shared.now();
            let shot = match flight::capture(
                &fleet,
                &mut self.images,
                sysid,
                self.capture_seq,
                self.shared.patience,
            )
            .await
            {
                Ok(shot) => shot,
                Err(FlightError::NoImage { seq, waited_s, .. }) => {
                    retakes += 1;
                    let reason = format!(
                        "cell {cell}: no image arrived within {waited_s:.0} s of capture {seq}"
                    );
                    if self
                        .picture_failed(cell, retakes, PictureFailure::Lost(reason))
                        .await?
                    {
                        return Ok(false);
                    }
                    continue;
                }
                Err(e) => return Err(e.into()),
            };
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
                retakes += 1;
                if self
                    .picture_failed(cell, retakes, PictureFailure::Rejected(reason))
                    .await?
                {
                    return Ok(false);
                }
                continue;
            }
            // Checked above: a pose with a grid position.
            let (Some(pose), Some((e, n))) = (pose, xy) else {
                continue;
            };
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
            let result = cpu(move || classify_cut(&bytes, &cut, &params, &camera, cell_m)).await?;
            let c = match result {
                Ok(c) => c,
                Err(reason) => {
                    retakes += 1;
                    let reason = format!("cell {cell}: {reason}");
                    if self
                        .picture_failed(cell, retakes, PictureFailure::Unreadable(reason))
                        .await?
                    {
                        return Ok(false);
                    }
                    continue;
                }
            };
            let now = self.shared.now();
            let (lat, lon, heading) = (pose.lat, pose.lon, pose.heading_deg);
            let alt_m = pose.alt_m.unwrap_or(planned);
            self.shared
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
                    let changed = s
                        .on_cell_image(det)?
                        .into_iter()
                        .map(|u| (u.cell, format!("{:?}", u.to).to_lowercase()))
                        .collect();
                    let ev = MappingEvent::Image {
                        sysid,
                        image_id,
                        cell,
                        labels: labels5(&c),
                        fractions: fractions5(&c),
                        changed,
                    };
                    Ok(((), Some(ev)))
                })
                .await?;
        }
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

    /// The camera cannot be trusted (`reason`): warn, journal [`MappingEvent::CameraFault`]
    /// and take the vehicle out of the run as for a battery swap (its vertex is kept, a
    /// confirmation it was making is given up), so that [`Pilot::swap`] brings it home and
    /// waits for the operator. Nothing of this camera is credited after this.
    pub(super) async fn camera_fault(
        &mut self,
        cell: Option<Cell>,
        reason: String,
    ) -> RunnerResult<()> {
        let sysid = self.sysid;
        let now = self.shared.now();
        let line = format!(
            "vehicle {sysid}: CAMERA FAULT: {reason}. No more of its pictures are counted; it \
             returns home, lands and waits for the operator (check where the camera gets its \
             position and attitude from, then `fleetmap resume` or `b`)"
        );
        self.shared.say(Progress::error(line).about(sysid));
        self.shared
            .commit(|s| {
                s.on_camera_fault(sysid, reason.clone(), now)?;
                Ok((
                    (),
                    Some(MappingEvent::CameraFault {
                        sysid,
                        cell,
                        reason,
                    }),
                ))
            })
            .await?;
        Ok(())
    }
}
