//! The sweep phase: the vehicle flies its lanes with the camera on a timer, and every picture
//! that arrives is checked, classified and voted into the map as it comes.

use super::*;
use crate::app::blocking::run_blocking;
use crate::app::error::{Check, RunnerError, RunnerResult, Step};

impl Pilot {
    /// Fly (or keep flying) the sweep, classifying its images, until the phase changes, the
    /// sweep ends or the battery runs low.
    pub(super) async fn sweep(&mut self) -> RunnerResult<()> {
        let sysid = self.sysid;
        let fleet = self.fleet().clone();
        let (items, alt, speed, resume_item) = self
            .shared
            .read(|s| {
                let sw = s.sweep_of(sysid).ok().cloned();
                let r = s.robot(sysid).cloned()?;
                Ok::<_, MappingError>((
                    sw.map(|w| w.items).unwrap_or_default(),
                    r.altitude_m,
                    s.params.speed_m_s,
                    r.sweep_item,
                ))
            })
            .await?;
        let v = self
            .vehicle()
            .ok_or(crate::fleet::FleetError::NoVehicle { sysid })?;
        let mission_mode = v.flavour.mission_mode().ok();
        let in_mission = mission_mode.is_some_and(|m| v.flavour.is_mode(v.custom_mode, m));
        let holds_mission = v
            .mission_total
            .is_some_and(|t| usize::from(t) == items.len());
        if !(flight::airborne(&v) && holds_mission) {
            // Upload, verify by download, take off, start (or continue where it stopped).
            fleet
                .upload_mission(sysid, MissionType::Mission, items.clone())
                .await?;
            let (back, _) = fleet.download_mission(sysid, MissionType::Mission).await?;
            fleetmap_core::mission::wire::compare_items(&items, &back, v.flavour.home_item())
                .map_err(|source| {
                    RunnerError::ReadBack {
                        what: "sweep",
                        source,
                    }
                    .context(Step::SweepUpload { sysid })
                })?;
            self.shared.say(
                Progress::info(format!(
                    "vehicle {sysid}: sweep mission uploaded and verified ({} items)",
                    items.len()
                ))
                .about(sysid),
            );
            flight::ensure_airborne(&fleet, sysid, alt as f32, self.shared.patience).await?;
            if let Some(item) = resume_item.filter(|&i| i > 0) {
                fleet.set_mission_current(sysid, item).await?;
                let m = mission_mode.ok_or(Check::NoMissionMode)?;
                fleet.set_mode(sysid, m).await?;
            } else {
                fleet.start_mission(sysid).await?;
            }
            let _ = flight::set_speed(&fleet, sysid, speed as f32).await;
            self.shared
                .say(Progress::info(format!("vehicle {sysid}: sweeping")).about(sysid));
        } else if self.first_sweep || !in_mission {
            // Back after a GCS restart (or a hold): the vehicle may have flown on while no one
            // classified its images, so go back to the last capture we may have missed — the
            // waypoint before the one it was heading for when we last saw it.
            if self.first_sweep
                && let Some(item) = resume_item
            {
                let back = items
                    .iter()
                    .enumerate()
                    .take(usize::from(item))
                    .rev()
                    .find(|(_, it)| it.command == fleetmap_core::mission::item::cmd::NAV_WAYPOINT)
                    .map(|(j, _)| j as u16);
                if let Some(j) = back {
                    fleet.set_mission_current(sysid, j).await?;
                }
            }
            let m = mission_mode.ok_or(Check::NoMissionMode)?;
            fleet.set_mode(sysid, m).await?;
            let _ = flight::set_speed(&fleet, sysid, speed as f32).await;
        }
        self.first_sweep = false;
        let last_nav = items
            .iter()
            .rposition(|it| it.command == fleetmap_core::mission::item::cmd::NAV_WAYPOINT)
            .unwrap_or(0) as u16;
        let mut snaps = fleet.watch();
        let mut changed = self.shared.run.subscribe();
        changed.borrow_and_update();
        let mut tick = tokio::time::interval(Duration::from_millis(500));
        // Pictures the sweep's capture items should have produced and did not: an autopilot
        // that cannot take pictures (ArduPilot without a camera backend, CAM1_TYPE = 0) or a
        // camera that is not connected sends nothing at all — no rejected picture to count.
        let captures_before = |c: u16| {
            items
                .iter()
                .take(usize::from(c))
                .filter(|it| it.command == fleetmap_core::mission::item::cmd::IMAGE_START_CAPTURE)
                .count()
        };
        let mut captures_at_start = None;
        // The sweep's pictures as its frames tell of them (see `SweepFrames`).
        let mut heard = SweepFrames::new(v.compid, self.shared.now());
        let stall = Duration::from_secs_f64(SWEEP_IMAGE_STALL_S * fleet.clock().speedup());
        let mut frames = fleet.subscribe();
        // The vehicle has flown the whole sweep (its pictures may still be in transfer).
        let mut flown = false;
        loop {
            // `biased`: in this order, not tokio's random one, so that a run on a paused clock
            // is the same every time. The phase and the battery tick first: they are ready
            // seldom, so they cannot starve the frames, nor a stream of frames them; the
            // frames before the images and the snapshots, which then see them counted.
            tokio::select! {
                biased;
                _ = changed.changed() => {
                    // A new phase, or the operator's pause (the step loop holds the vehicle).
                    if *self.shared.paused.borrow()
                        || self.shared.read(|s| s.phase != Phase::Sweep).await
                    {
                        return Ok(());
                    }
                }
                _ = tick.tick() => {
                    if self.check_battery().await? {
                        return Ok(());
                    }
                }
                f = frames.recv() => {
                    match f {
                        Ok(inc) => heard.on_frame(sysid, &inc, &self.shared),
                        Err(broadcast::error::RecvError::Lagged(_)) => {}
                        Err(broadcast::error::RecvError::Closed) => return Err(RunnerError::FleetStopped),
                    }
                }
                r = self.images.recv() => {
                    let img = match r {
                        Ok(img) => img,
                        Err(broadcast::error::RecvError::Lagged(_)) => continue,
                        Err(broadcast::error::RecvError::Closed) => return Err(FlightError::ImagesClosed.into()),
                    };
                    if img.sysid != sysid {
                        continue;
                    }
                    // The frames before this image (its announcement among them) may still be
                    // queued: a busy machine can have the image before the broadcast of the
                    // frames reached this task. Read them first.
                    let now = self.shared.now();
                    loop {
                        match frames.try_recv() {
                            Ok(inc) => heard.on_frame(sysid, &inc, &self.shared),
                            Err(broadcast::error::TryRecvError::Lagged(_)) => {}
                            Err(_) => break,
                        }
                    }
                    heard.on_image(now);
                    self.camera.last_picture = Some(self.fleet().clock().now());
                    let key = img.pose.as_ref().map(|p| (p.time_boot_ms, p.image_index));
                    let announced_at = key.and_then(|k| heard.announced_at(k));
                    if self.sweep_image(&img, announced_at).await? {
                        return Ok(());
                    }
                }
                r = snaps.changed() => {
                    if r.is_err() {
                        return Err(RunnerError::FleetStopped);
                    }
                    let s = snaps.borrow_and_update().vehicles.get(&sysid).cloned();
                    let Some(s) = s else { continue };
                    if let Some(c) = s.mission_current {
                        let passed = captures_before(c);
                        let start = *captures_at_start.get_or_insert(passed);
                        let pending = heard.pending();
                        let stalled = heard.stalled(self.shared.now(), stall);
                        let missing = passed
                            .saturating_sub(start)
                            .saturating_sub(heard.arrived.max(heard.announced))
                            + if stalled { pending } else { 0 };
                        if missing > self.shared.max_retakes as usize {
                            let reason = format!(
                                "{missing} sweep pictures did not arrive (the vehicle passed their \
                                 capture points): check that the autopilot can take pictures \
                                 (ArduPilot: a camera backend, CAM1_TYPE) and that the camera is \
                                 connected"
                            );
                            self.camera_fault(None, reason, true).await?;
                            return Ok(());
                        }
                    }
                    if let Some(c) = s.mission_current
                        && self.shared.read(|st| st.robot(sysid).ok().and_then(|r| r.sweep_item)).await != Some(c)
                    {
                        self.shared.commit(|st| Ok((st.on_sweep_progress(sysid, c)?, None))).await?;
                    }
                    let complete = s.mission_complete()
                        || s.reached.contains(&last_nav)
                        || s.mission_current.is_some_and(|c| c > last_nav);
                    if complete && !flown {
                        flown = true;
                        let pending = heard.pending();
                        if pending > 0 {
                            self.doing(Activity::Waiting(Wait::Pictures));
                            self.shared.say(Progress::info(format!(
                                "vehicle {sysid}: sweep flown; waiting for {pending} pictures still in transfer"
                            )).about(sysid));
                        }
                    }
                }
            }
            // The sweep is complete once flown and its announced pictures are in (or their
            // transfer stalled: those were counted as missing above).
            if flown && (heard.pending() == 0 || heard.stalled(self.shared.now(), stall)) {
                let now = self.shared.now();
                self.shared
                    .commit(|st| {
                        st.on_sweep_complete(sysid, now)?;
                        Ok(((), Some(MappingEvent::SweepComplete { sysid })))
                    })
                    .await?;
                self.shared
                    .say(Progress::info(format!("vehicle {sysid}: sweep complete")).about(sysid));
                return Ok(());
            }
        }
    }

    /// Classify a sweep image; returns true when the sweep must stop (it started a
    /// confirmation, or the camera was declared faulty). The picture must have been taken
    /// where the vehicle was: the camera's position within one cell more than the cell limit
    /// of `announced_at`, the vehicle's position when the camera announced the picture (else
    /// when it arrives: the vehicle flies on while it is transferred),
    /// its altitude within the limit and its tilt within
    /// [`fleetmap_core::vision::sanity::SWEEP_MAX_TILT_DEG`]; otherwise it is dropped, and
    /// [`RunOptions::max_retakes`] + 1 dropped in a row are a camera fault. With the attitude
    /// known, the picture stands for the cell its optical axis met, cut as an orthophoto
    /// around that point; without, for the cell under the vehicle, centre-cropped.
    pub(super) async fn sweep_image(
        &mut self,
        img: &ReceivedImage,
        announced: Option<(GeoPoint, Time)>,
    ) -> RunnerResult<bool> {
        let announced_at = announced.map(|(p, _)| p);
        // When the picture was taken, as near as the GCS knows: by the camera's clock when it
        // announced the picture, else now.
        let shutter = announced.map_or_else(|| self.shared.now(), |(_, t)| t);
        let sysid = self.sysid;
        let v = self.vehicle();
        let Some(pose) = shot_pose(img, v.as_ref()) else {
            return Ok(false);
        };
        let (params, camera, altitude, grid) = self.shared.picture_setting(sysid).await;
        let cell_m = grid.cell_size();
        let here = LatLon {
            lat: pose.lat,
            lon: pose.lon,
        };
        // The camera's position against the vehicle's (the telemetry's own is not checked).
        let reference = announced_at.or_else(|| v.as_ref().and_then(|v| v.position));
        let offset = match (reference, pose.from_camera) {
            (Some(r), true) => Some(local::distance(r.lat, r.lon, pose.lat, pose.lon)),
            // a vehicle that reports no position cannot vouch for its camera
            (None, true) => v.as_ref().map(|_| f64::INFINITY),
            (_, false) => None,
        };
        let limits = CaptureLimits {
            horizontal_m: self.shared.limits.horizontal_m + cell_m,
            max_tilt_deg: self.shared.limits.max_tilt_deg.max(SWEEP_MAX_TILT_DEG),
            ..self.shared.limits
        };
        let claim = CaptureClaim {
            horizontal_offset_m: offset,
            altitude_m: pose.alt_m,
            attitude: pose.attitude,
            heading_deg: None,
            expected_heading_deg: None,
        };
        let alt_m = pose.alt_m.unwrap_or(altitude);
        // With the attitude known, the picture is of the cell its optical axis met: the
        // orthophoto is centred there (grid metres from the point under the camera).
        let gamma = grid
            .convergence_and_scale(here)
            .map(|(g, _)| g)
            .unwrap_or(0.0);
        let looked = pose.attitude.as_ref().and_then(|a| {
            geometry::view_centre_offset(a, alt_m).map(|(n, e)| geometry::true_to_grid(n, e, gamma))
        });
        // The cell of the region's frame (the grid's own for a static region) at the shutter.
        let cell = grid.to_xy(here).map(|(e, n)| {
            let (de, dn) = looked.unwrap_or((0.0, 0.0));
            let (re, rn) = self.shared.roi.in_region(e + de, n + dn, shutter);
            grid.cell_of_xy(re, rn)
        });
        let verdict = match (check_capture(&claim, altitude, &limits), &cell) {
            (Err(r), _) => Err(format!(
                "sweep picture {r}; reference: where the vehicle was when it {}",
                if announced_at.is_some() {
                    "was announced"
                } else {
                    "arrived"
                }
            )),
            (Ok(()), Err(e)) => Err(format!("sweep: the picture's position: {e}")),
            (Ok(()), Ok(_)) => Ok(()),
        };
        if let Err(reason) = verdict {
            self.sweep_rejects += 1;
            let retakes = self.sweep_rejects;
            tracing::info!("vehicle {sysid}: picture dropped: {reason}");
            let r = reason.clone();
            self.shared
                .commit(|_| {
                    Ok((
                        (),
                        Some(MappingEvent::ImageRejected {
                            sysid,
                            cell: None,
                            reason: r,
                            retakes,
                        }),
                    ))
                })
                .await?;
            if retakes > self.shared.max_retakes {
                self.camera_fault(
                    None,
                    format!("{retakes} sweep pictures in a row did not count; the last: {reason}"),
                    false,
                )
                .await?;
                return Ok(true);
            }
            return Ok(false);
        }
        self.sweep_rejects = 0;
        let Ok(cell) = cell else {
            return Ok(false);
        };
        let heading = pose.heading_deg;
        // The camera's own classification when it made one with the run's definition: the
        // cell under the camera, the orthophoto centred on it. Else the GCS's, of the cell
        // its optical axis met.
        let onboard = super::intake::onboard_result(img);
        let measured = onboard.is_some();
        let result = match &onboard {
            Some(m) => self.shared.onboard.credited(m, img.pose.as_ref()),
            None => {
                let cut = match (pose.attitude, looked) {
                    (Some(attitude), Some(centre)) => Cut::Ortho {
                        attitude,
                        altitude_m: alt_m,
                        request: OrthoRequest {
                            cell_m,
                            centre_east_north_m: centre,
                            grid_north_deg: gamma,
                        },
                    },
                    _ => Cut::Centre {
                        heading_deg: heading,
                        altitude_m: altitude,
                    },
                };
                let bytes = img.bytes.clone();
                run_blocking(move || classify_cut(&bytes, &cut, &params, &camera, cell_m))
                    .await?
                    .map(|c| (cell, c))
                    .map_err(|e| e.to_string())
            }
        };
        let (cell, c) = match result {
            Ok(x) => x,
            Err(reason) => {
                self.shared
                    .commit(|s| {
                        s.image_failures += 1;
                        Ok(((), Some(MappingEvent::ImageFailed { sysid, reason })))
                    })
                    .await?;
                return Ok(false);
            }
        };
        let now = self.shared.now();
        let candidate = self
            .shared
            .commit(|s| {
                let image_id = s.next_image_id();
                let cand = s.on_sweep_image(sysid, cell, heading, c.fractions, c.labels, now)?;
                if measured {
                    s.onboard.sweep_pictures += 1;
                }
                let ev = match cand {
                    Some(cell) => MappingEvent::Candidate { sysid, cell },
                    None => MappingEvent::SweepImage {
                        sysid,
                        image_id,
                        cell,
                        labels: labels5(&c),
                        onboard: measured,
                    },
                };
                Ok((cand, Some(ev)))
            })
            .await?;
        if let Some(cand) = candidate {
            self.shared.say(Progress::info(format!(
                "vehicle {sysid}: runway seen near cell {cand}: stopping the sweep to confirm it"
            )).about(sysid));
            flight::hold_here(self.fleet(), sysid).await?;
            return Ok(true);
        }
        Ok(false)
    }
}

/// What a sweeping vehicle's frames tell of its pictures, read in the order the frames
/// arrived: the pictures its camera announced (CAMERA_IMAGE_CAPTURED) and the pictures that
/// arrived, the last time any image news was heard, and where the vehicle reported itself
/// (GLOBAL_POSITION_INT) when each picture was announced. An announced picture exists while
/// its transmission is queued behind others (a slow payload link: PX4 SITL's carries 4 kB/s),
/// so it is missing only once no image data at all has been heard for a while
/// ([`SweepFrames::stalled`]).
///
/// The reference position is the vehicle's last report *before the announcement in the
/// stream*, not its position when this task gets to run: on a busy machine the task can run
/// a third of a second late, and a vehicle sped up 20× flies 30 m in that time.
struct SweepFrames {
    /// The autopilot's component id: only its position reports are the vehicle's.
    autopilot: u8,
    /// Pictures the camera announced.
    announced: usize,
    /// Pictures that arrived.
    arrived: usize,
    /// When image news (an announcement while none was pending, or image data) was last heard.
    progress: Time,
    /// The vehicle's last reported position, in stream order, and its boot time.
    position: Option<GeoPoint>,
    position_boot_ms: Option<u32>,
    /// Where the vehicle was when each picture was announced, and when it was taken, by
    /// (time_boot_ms, image_index), the last [`ANNOUNCED_KEPT`].
    where_announced: std::collections::VecDeque<((u32, i32), GeoPoint, Time)>,
    /// Per component: its boot clock against ours — the smallest (arrival − time_boot_ms)
    /// seen since it last booted, µs — and its latest time_boot_ms (a smaller one is a reboot).
    boot: std::collections::BTreeMap<u8, (i64, u32)>,
}

impl SweepFrames {
    fn new(autopilot: u8, now: Time) -> SweepFrames {
        SweepFrames {
            autopilot,
            announced: 0,
            arrived: 0,
            progress: now,
            position: None,
            position_boot_ms: None,
            where_announced: std::collections::VecDeque::new(),
            boot: std::collections::BTreeMap::new(),
        }
    }

    /// Take a message of component `compid` stamped `time_boot_ms` that arrived at `now`;
    /// returns that component's clock offset (fleet-clock µs − boot-clock µs).
    ///
    /// A frame is never early, only late (the link, or a busy GCS that reads its socket late),
    /// so the smallest offset seen is the best (the minimum-delay filter of NTP and of PX4's
    /// and MAVSDK's TIMESYNC). It assumes the vehicle's clock runs at the fleet clock's rate,
    /// as it does for a real vehicle and for the simulator with the GCS at its speed-up.
    fn clock_offset(&mut self, compid: u8, time_boot_ms: u32, now: Time) -> i64 {
        let off = now.as_micros() as i64 - i64::from(time_boot_ms) * 1000;
        let e = self.boot.entry(compid).or_insert((off, time_boot_ms));
        if time_boot_ms < e.1 {
            *e = (off, time_boot_ms);
        } else {
            *e = (e.0.min(off), time_boot_ms);
        }
        e.0
    }

    /// When a picture announced by component `compid` with boot time `time_boot_ms` was
    /// taken, on the fleet clock. The camera sends its announcement right after the shutter,
    /// so the autopilot's last position report before it *in the stream* gives the vehicle's
    /// boot time then (within a report period), whatever the camera's own clock; that boot
    /// time is converted with the autopilot's offset, measured on many reports. A camera
    /// whose boot time agrees within 2 s shares the autopilot's clock (an autopilot's own
    /// camera, the simulator's): its own stamp is used. Without position reports yet, the
    /// camera's own offset.
    fn shutter(&mut self, compid: u8, time_boot_ms: u32, now: Time) -> Time {
        let own = self.clock_offset(compid, time_boot_ms, now);
        let (boot_ms, off) = match (self.position_boot_ms, self.boot.get(&self.autopilot)) {
            (Some(p), Some(&(ap, _))) if time_boot_ms.abs_diff(p) < 2000 => (time_boot_ms, ap),
            (Some(p), Some(&(ap, _))) => (p, ap),
            _ => (time_boot_ms, own),
        };
        let us = i64::from(boot_ms) * 1000 + off;
        Time::from_micros(u64::try_from(us).unwrap_or(0).min(now.as_micros()))
    }

    /// A frame from the fleet: `sysid`'s (any of its components) are taken, dated by their
    /// arrival.
    fn on_frame(&mut self, sysid: u8, inc: &crate::fleet::Incoming, shared: &Shared) {
        if inc.frame.sysid() == sysid
            && let Ok(m) = &inc.frame.message
        {
            self.on_message(inc.frame.compid(), m, shared.received_at(inc.received));
        }
    }

    /// One message from the vehicle (any of its components), received at `now`.
    fn on_message(&mut self, compid: u8, msg: &MavMessage, now: Time) {
        match msg {
            MavMessage::GLOBAL_POSITION_INT(p) if compid == self.autopilot => {
                self.position = Some(GeoPoint::of_global_position(p));
                self.position_boot_ms = Some(p.time_boot_ms);
                self.clock_offset(compid, p.time_boot_ms, now);
            }
            MavMessage::CAMERA_IMAGE_CAPTURED(c) => {
                let taken = self.shutter(compid, c.time_boot_ms, now);
                if self.pending() == 0 {
                    self.progress = now;
                }
                self.announced += 1;
                if let Some(p) = self.position {
                    if self.where_announced.len() >= ANNOUNCED_KEPT {
                        self.where_announced.pop_front();
                    }
                    self.where_announced
                        .push_back(((c.time_boot_ms, c.image_index), p, taken));
                }
            }
            MavMessage::ENCAPSULATED_DATA(_) | MavMessage::DATA_TRANSMISSION_HANDSHAKE(_) => {
                self.progress = now;
            }
            _ => {}
        }
    }

    /// A picture arrived at `now`.
    fn on_image(&mut self, now: Time) {
        self.arrived += 1;
        self.progress = now;
    }

    /// Where the vehicle was when picture `key` (time_boot_ms, image_index) was announced,
    /// and when.
    fn announced_at(&self, key: (u32, i32)) -> Option<(GeoPoint, Time)> {
        self.where_announced
            .iter()
            .find(|(k, ..)| *k == key)
            .map(|&(_, p, t)| (p, t))
    }

    /// Announced pictures that have not arrived.
    fn pending(&self) -> usize {
        self.announced.saturating_sub(self.arrived)
    }

    /// No image news for longer than `stall`.
    fn stalled(&self, now: Time, stall: Duration) -> bool {
        now.saturating_since(self.progress) > stall
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::{CAMERA_IMAGE_CAPTURED_DATA, GLOBAL_POSITION_INT_DATA};

    fn at(lat_deg: f64) -> MavMessage {
        MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
            lat: (lat_deg * 1e7) as i32,
            lon: 1_490_000_000,
            ..Default::default()
        })
    }

    fn captured(index: i32) -> MavMessage {
        captured_at(index, 1000 + index as u32)
    }

    fn captured_at(index: i32, time_boot_ms: u32) -> MavMessage {
        MavMessage::CAMERA_IMAGE_CAPTURED(CAMERA_IMAGE_CAPTURED_DATA {
            time_boot_ms,
            image_index: index,
            ..Default::default()
        })
    }

    #[test]
    fn the_reference_is_the_report_before_the_announcement_in_the_stream() {
        let mut heard = SweepFrames::new(1, Time::ZERO);
        heard.on_message(1, &at(-35.0), Time::ZERO);
        heard.on_message(100, &captured(0), Time::from_secs(1));
        // Reports after the announcement, and a camera's own position, move nothing.
        heard.on_message(1, &at(-35.001), Time::from_secs(2));
        heard.on_message(100, &at(-36.0), Time::from_secs(2));
        heard.on_message(100, &captured(1), Time::from_secs(3));
        let first = heard.announced_at((1000, 0)).map(|(p, _)| p.lat);
        let second = heard.announced_at((1001, 1)).map(|(p, _)| p.lat);
        assert!(first.is_some_and(|l| (l + 35.0).abs() < 1e-9), "{first:?}");
        assert!(
            second.is_some_and(|l| (l + 35.001).abs() < 1e-9),
            "{second:?}"
        );
        assert_eq!(heard.announced_at((1002, 2)), None);
        // Both announced on time: taken when they arrived (the boot clock runs from 0 at 0).
        assert_eq!(
            heard.announced_at((1000, 0)).map(|(_, t)| t),
            Some(Time::from_secs(1))
        );
        assert_eq!(heard.pending(), 2);
        heard.on_image(Time::from_secs(4));
        assert_eq!(heard.pending(), 1);
        assert!(!heard.stalled(Time::from_secs(5), Duration::from_secs(2)));
        assert!(heard.stalled(Time::from_secs(7), Duration::from_secs(2)));
    }

    #[test]
    fn a_picture_read_late_is_dated_by_the_vehicles_clock() {
        let mut heard = SweepFrames::new(1, Time::ZERO);
        let report = |boot_ms: u32| {
            MavMessage::GLOBAL_POSITION_INT(GLOBAL_POSITION_INT_DATA {
                time_boot_ms: boot_ms,
                ..Default::default()
            })
        };
        // The vehicle booted 50 s before our clock's 60 s; reports arrive 0–300 ms late.
        for (k, late_ms) in [300u64, 20, 150, 0, 90].into_iter().enumerate() {
            let boot_ms = 10_000 + 100 * k as u32;
            heard.on_message(
                1,
                &report(boot_ms),
                Time::from_millis(60_000 + 100 * k as u64 + late_ms),
            );
        }
        // A picture taken at boot 10.6 s (our 60.6 s) read 3.4 s late: dated 60.6 s.
        heard.on_message(100, &captured_at(7, 10_600), Time::from_secs(64));
        assert_eq!(
            heard.announced_at((10_600, 7)).map(|(_, t)| t),
            Some(Time::from_millis(60_600))
        );
        // After a reboot the boot clock starts again: the offset is measured afresh.
        heard.on_message(1, &report(500), Time::from_secs(200));
        heard.on_message(100, &captured_at(0, 600), Time::from_millis(200_100));
        assert_eq!(
            heard.announced_at((600, 0)).map(|(_, t)| t),
            Some(Time::from_millis(200_100))
        );
    }
}
