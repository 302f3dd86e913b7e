//! A simulated camera for a real autopilot (an ArduPilot or PX4 SITL, or a vehicle on the
//! bench): it listens to the autopilot's telemetry for its pose and renders the world's
//! ground truth whenever the autopilot takes a picture, answering as the vehicle's camera
//! component (id 100) exactly as the simulated vehicles' cameras do ([`super::camera`]).
//!
//! Triggers: ArduPilot's CAMERA_FEEDBACK (sent by AP_Camera for every picture it takes, with
//! the position and attitude at that moment), PX4's CAMERA_TRIGGER (camera_trigger module),
//! and the MAVLink camera protocol's own commands addressed to component 100
//! (MAV_CMD_IMAGE_START_CAPTURE / _STOP_CAPTURE, REQUEST_MESSAGE for CAMERA_INFORMATION,
//! CAMERA_CAPTURE_STATUS and a missed CAMERA_IMAGE_CAPTURED) from
//! any component but the autopilot's.
//! The pose comes from GLOBAL_POSITION_INT (position, altitude above home, heading) and
//! ATTITUDE (roll, pitch, yaw) of the autopilot component (id 1); the ground is taken as flat
//! at home altitude.
//!
//! **Asking for telemetry.** ArduCopter sends nothing but HEARTBEAT on a serial port until
//! someone asks (seen with `arducopter --serial1 udpclient:…`), so a camera that only
//! listens renders every picture at the boot pose. Like a GCS, the camera asks every
//! autopilot it hears, at its first autopilot HEARTBEAT from component 1, as component 100:
//! - for ArduPilot (HEARTBEAT.autopilot = MAV_AUTOPILOT_ARDUPILOTMEGA), REQUEST_DATA_STREAM
//!   for MAV_DATA_STREAM_POSITION (GLOBAL_POSITION_INT) and MAV_DATA_STREAM_EXTRA1 (ATTITUDE)
//!   at `TELEMETRY_HZ`, as QGroundControl's `APMFirmwarePlugin::initializeStreamRates`
//!   does stream by stream and MAVProxy's `set_stream_rates` (`--streamrate`) does with
//!   MAV_DATA_STREAM_ALL — both re-send them later (QGC when BATTERY_STATUS / HOME_POSITION
//!   stop for 10 s, MAVProxy every 15 s);
//! - for every autopilot, MAV_CMD_SET_MESSAGE_INTERVAL (COMMAND_LONG to component 1) for
//!   GLOBAL_POSITION_INT (33) and ATTITUDE (30) at 100 000 µs, the interface the MAVLink
//!   documentation recommends (<https://mavlink.io/en/mavgen_python/howto_requestmessages.html>)
//!   and the one PX4 documents; REQUEST_DATA_STREAM is deprecated in MAVLink and is not sent
//!   to PX4 (its stream groups are ArduPilot's). QGC follows its stream requests with
//!   SET_MESSAGE_INTERVAL the same way, so the per-message interval wins.
//!
//! It asks again, at most every `REQUEST_RETRY`, while the pose is stale, and at once when
//! the autopilot reboots (GLOBAL_POSITION_INT.time_boot_ms goes back by more than
//! `REBOOT_BACKSTEP_MS`; a smaller step back is a reordered datagram and is ignored):
//! message intervals do not survive a reboot.
//!
//! **Stale poses.** A picture is never rendered from a pose older than
//! `PairedCameras::max_pose_age` (`DEFAULT_MAX_POSE_AGE`, measured from the arrival of the
//! last GLOBAL_POSITION_INT). A capture asked for while the pose is stale produces no image:
//! MAV_CMD_IMAGE_START_CAPTURE is answered MAV_RESULT_TEMPORARILY_REJECTED (PX4's answer to a
//! command it cannot run yet), and CAMERA_TRIGGER or a due interval shot is dropped; each
//! refusal is counted ([`PairedCameras::refused`]) and explained by a STATUSTEXT from
//! component 100 ("camera: no position from vehicle 3 for 3.2 s", or "camera: never had a
//! position from vehicle 3"). CAMERA_FEEDBACK carries the pose of its own shutter and is
//! always rendered. [`PairedEvent`]s tell the shell when an episode of refusals starts and
//! ends, so it can warn once per episode.
//!
//! Image transmission is paced when the camera configuration says so
//! ([`super::camera::CameraConfig::transfer_rate_bps`]): a routing autopilot drops what its
//! ports cannot take.
//!
//! **Several cameras behind one port: each is paced on its own.** The budget a pacing rate
//! protects is the autopilot's: the port the camera talks to and the GCS link it forwards
//! to (ArduPilot forwards a frame only when the outgoing port's `comm_get_txspace` has room,
//! `MAVLink_routing::check_and_forward`; PX4 passes on two frames per loop of the outgoing
//! instance, `Mavlink::pass_message`). Each autopilot has its own, so each camera gets the
//! whole rate, provided its frames go through its own autopilot: the shell sends camera k's
//! frames to the address autopilot k was last heard from ([`crate::serve`]),
//! as a camera wired to that autopilot's serial port would. Sharing one rate among the N
//! cameras would make every picture N times slower to arrive for no link's sake. What the
//! cameras do share is the GCS's own port, which gets N × the rate: a UDP socket on the GCS
//! machine (four cameras at the default 20 000 B/s are 80 kB/s, 300 datagrams a second),
//! or in the field N radios, one per vehicle, each carrying its own camera.
//!
//! **Requests to send a picture again** (a GCS's DATA_TRANSMISSION_HANDSHAKE) name no
//! vehicle: DATA_TRANSMISSION_HANDSHAKE has no target fields, every autopilot on the shared
//! port forwards it (ArduPilot: no target system is a broadcast, sent to every port with a
//! learned route; PX4: target 0 reaches every forwarding instance that has seen a
//! component), and the request reaches every camera here once per autopilot. Each camera is
//! offered it; only the one holding a picture of the size it names answers, once
//! (`SimCamera::handle_handshake_request`). The runway run's grid announcement
//! (DEBUG_FLOAT_ARRAY `"fm.grid"`, [`fleetmap_core::vision::runway::onboard`]) is untargeted
//! too: every camera classifying runway pictures takes it and answers with its status
//! ([`SimCamera::handle_gcs_message`]).

// CAMERA_FEEDBACK and CAMERA_TRIGGER are ArduPilot / legacy messages.
#![allow(deprecated)]

use crate::camera::{CameraConfig, CaptureContext, CapturedImage, Shot, SimCamera};
use crate::pose::CameraPose;
use fleetmap_core::proto::{AUTOPILOT_COMPID, CAMERA_COMPID};
use fleetmap_core::time::Time;
use fleetmap_core::world::World;
use image::RgbImage;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;
use std::time::Duration;

/// Oldest pose a picture may be rendered from by default (age of the last
/// GLOBAL_POSITION_INT's arrival): five periods of the [`TELEMETRY_HZ`] stream, so a few lost
/// datagrams do not refuse a picture, while a copter at 5 m/s has moved at most 2.5 m.
pub(crate) const DEFAULT_MAX_POSE_AGE: Duration = Duration::from_millis(500);
/// Rate asked of GLOBAL_POSITION_INT and ATTITUDE, Hz (10 Hz is QGroundControl's default for
/// ArduPilot's EXTRA1 stream; the pose is then at most 0.1 s old between messages).
pub(crate) const TELEMETRY_HZ: u16 = 10;
/// Shortest time between two requests for telemetry to one autopilot while its pose is
/// stale.
pub(crate) const REQUEST_RETRY: Duration = Duration::from_secs(2);
/// How far GLOBAL_POSITION_INT.time_boot_ms must go backwards, milliseconds, to count as a
/// reboot rather than a reordered datagram.
pub(crate) const REBOOT_BACKSTEP_MS: u32 = 1000;

/// What the cameras did that an operator should hear of (the shell logs these).
#[derive(Clone, Debug, PartialEq)]
pub enum PairedEvent {
    /// The first autopilot HEARTBEAT of a vehicle: its camera exists and asked for telemetry.
    Discovered {
        /// The vehicle's system id.
        sysid: u8,
        /// HEARTBEAT.autopilot.
        autopilot: mav::MavAutopilot,
    },
    /// The autopilot rebooted (its time_boot_ms went backwards): telemetry asked for again.
    Rebooted {
        /// The vehicle's system id.
        sysid: u8,
    },
    /// The first capture refused in an episode of stale poses (one event per episode).
    PoseStale {
        /// The vehicle's system id.
        sysid: u8,
        /// Age of the last GLOBAL_POSITION_INT (None: never heard one).
        age: Option<Duration>,
        /// Captures refused for this vehicle since the start, this one included.
        refused_total: u64,
    },
    /// A fresh GLOBAL_POSITION_INT after refused captures: the episode is over.
    PoseRestored {
        /// The vehicle's system id.
        sysid: u8,
        /// Captures refused during the episode.
        refused: u64,
    },
}

#[derive(Debug)]
struct Tracked {
    camera: SimCamera,
    pose: Option<CameraPose>,
    alt_amsl_m: f64,
    boot: Option<(Time, u32)>, // our time and the autopilot's time_boot_ms at that moment
    seq: u8,
    last_heartbeat: Option<Time>,
    /// HEARTBEAT.autopilot of component 1 (None: no autopilot heartbeat heard yet).
    autopilot: Option<mav::MavAutopilot>,
    /// Arrival of the last GLOBAL_POSITION_INT.
    pose_at: Option<Time>,
    /// When telemetry was last asked for.
    last_request: Option<Time>,
    /// Times telemetry was asked for.
    requests: u32,
    /// Captures refused for a stale pose.
    refused: u64,
    /// Captures refused in the current episode (None: no episode).
    episode: Option<u64>,
}

/// Cameras for the autopilots heard on one link. See the module documentation.
#[derive(Debug)]
pub struct PairedCameras {
    /// What the cameras render; `None` with an outside source ([`CameraConfig::external`]).
    world: Option<Arc<World>>,
    /// Where local east/north are measured from for distance triggering without a world:
    /// the first position heard (degrees).
    origin: Option<(f64, f64)>,
    config: CameraConfig,
    seed: u64,
    max_pose_age: Duration,
    tracked: BTreeMap<u8, Tracked>,
    outbox: VecDeque<(MavHeader, MavMessage)>,
    images: VecDeque<(u8, CapturedImage)>,
    events: VecDeque<PairedEvent>,
    refused: u64,
}

impl PairedCameras {
    /// Cameras rendering `world` with `config`, seeded; poses may be
    /// `DEFAULT_MAX_POSE_AGE` old.
    pub fn new(world: Arc<World>, config: CameraConfig, seed: u64) -> PairedCameras {
        PairedCameras::with_world(Some(world), config, seed)
    }

    /// Cameras whose pictures come from outside: every capture is a [`Shot`] to take with
    /// `PairedCameras::poll_shot` and complete with `PairedCameras::deliver` (`config`'s
    /// `external` is set).
    pub fn external(config: CameraConfig, seed: u64) -> PairedCameras {
        let config = CameraConfig {
            external: true,
            ..config
        };
        PairedCameras::with_world(None, config, seed)
    }

    fn with_world(world: Option<Arc<World>>, config: CameraConfig, seed: u64) -> PairedCameras {
        PairedCameras {
            world,
            origin: None,
            config,
            seed,
            max_pose_age: DEFAULT_MAX_POSE_AGE,
            tracked: BTreeMap::new(),
            outbox: VecDeque::new(),
            images: VecDeque::new(),
            events: VecDeque::new(),
            refused: 0,
        }
    }

    /// System ids of the autopilots with a camera.
    pub fn sysids(&self) -> Vec<u8> {
        self.tracked.keys().copied().collect()
    }

    /// Captures refused for a stale pose, all vehicles together, since the start.
    pub fn refused(&self) -> u64 {
        self.refused
    }

    /// Captures refused for a stale pose of vehicle `sysid` (0 for an unknown vehicle).
    pub fn refused_for(&self, sysid: u8) -> u64 {
        self.tracked.get(&sysid).map_or(0, |t| t.refused)
    }

    /// How many times vehicle `sysid` was asked for its telemetry (0 for an unknown vehicle).
    pub fn telemetry_requests(&self, sysid: u8) -> u32 {
        self.tracked.get(&sysid).map_or(0, |t| t.requests)
    }

    fn tracked(&mut self, sysid: u8) -> &mut Tracked {
        let (cfg, seed) = (self.config.clone(), self.seed);
        self.tracked.entry(sysid).or_insert_with(|| Tracked {
            camera: SimCamera::new(sysid, cfg, seed ^ u64::from(sysid)),
            pose: None,
            alt_amsl_m: 0.0,
            boot: None,
            seq: 0,
            last_heartbeat: None,
            autopilot: None,
            pose_at: None,
            last_request: None,
            requests: 0,
            refused: 0,
            episode: None,
        })
    }

    fn ctx(t: &Tracked, pose: CameraPose, now: Time) -> CaptureContext {
        let tb = t
            .boot
            .map(|(at, ms)| ms.wrapping_add(now.saturating_since(at).as_millis() as u32))
            .unwrap_or(0);
        CaptureContext {
            true_pose: pose,
            reported: (pose.lat, pose.lon, pose.alt_agl_m),
            alt_amsl_m: t.alt_amsl_m,
            time_boot_ms: tb,
            now,
            world_t_s: now.as_secs_f64(),
        }
    }

    /// The pose to render from at `now`, if it is fresh enough.
    fn fresh_pose(t: &Tracked, now: Time, max_age: Duration) -> Option<CameraPose> {
        let at = t.pose_at?;
        (now.saturating_since(at) <= max_age)
            .then_some(t.pose)
            .flatten()
    }

    /// Feed a message heard on the link at `now`.
    pub fn handle_message(&mut self, h: &MavHeader, msg: &MavMessage, now: Time) {
        let Ok(sysid) = u8::try_from(h.system_id) else {
            return;
        };
        if h.component_id == AUTOPILOT_COMPID {
            match msg {
                MavMessage::HEARTBEAT(hb)
                    if hb.autopilot != mav::MavAutopilot::MAV_AUTOPILOT_INVALID =>
                {
                    let t = self.tracked(sysid);
                    let first = t.autopilot.is_none();
                    t.autopilot = Some(hb.autopilot);
                    if first {
                        self.events.push_back(PairedEvent::Discovered {
                            sysid,
                            autopilot: hb.autopilot,
                        });
                        self.request_telemetry(sysid, now);
                    }
                    return;
                }
                MavMessage::GLOBAL_POSITION_INT(p) => {
                    self.position(sysid, p, now);
                    return;
                }
                MavMessage::ATTITUDE(a) => {
                    let t = self.tracked(sysid);
                    if let Some(p) = t.pose.as_mut() {
                        p.roll_deg = f64::from(a.roll).to_degrees();
                        p.pitch_deg = f64::from(a.pitch).to_degrees();
                        p.heading_deg = f64::from(a.yaw).to_degrees().rem_euclid(360.0);
                    }
                    return;
                }
                MavMessage::CAMERA_FEEDBACK(f) => {
                    let world = self.world.clone();
                    let t = self.tracked(sysid);
                    // the pose at the moment the autopilot fired the shutter: always rendered
                    let pose = CameraPose {
                        lat: f64::from(f.lat) * 1e-7,
                        lon: f64::from(f.lng) * 1e-7,
                        alt_agl_m: f64::from(f.alt_rel).max(0.0),
                        heading_deg: f64::from(f.yaw).rem_euclid(360.0),
                        roll_deg: f64::from(f.roll),
                        pitch_deg: f64::from(f.pitch),
                    };
                    t.pose = Some(pose);
                    t.alt_amsl_m = f64::from(f.alt_msl);
                    let ctx = Self::ctx(t, pose, now);
                    t.camera.capture_now(&ctx, world.as_deref());
                    return;
                }
                MavMessage::CAMERA_TRIGGER(_) => {
                    let max_age = self.max_pose_age;
                    let t = self.tracked(sysid);
                    if Self::fresh_pose(t, now, max_age).is_some() {
                        t.camera.trigger();
                    } else {
                        self.refuse(sysid, 1, now);
                    }
                    return;
                }
                // PX4 1.16 passes a mission's interval capture (IMAGE_START_CAPTURE with an
                // interval, or a count other than one) on to component 100 as a command of
                // its own, and its camera_trigger module sends no CAMERA_TRIGGER for it: the
                // camera takes those, and IMAGE_STOP_CAPTURE (seen on PX4 SIH with the 6×6
                // mission: without this its drones' cameras took nothing).
                MavMessage::COMMAND_LONG(c)
                    if c.target_component == CAMERA_COMPID
                        && (c.command == mav::MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE
                            || (c.command == mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE
                                && (c.param2 > 0.0 || c.param3 != 1.0))) => {}
                // other commands from the autopilot itself are not taken: PX4 with the
                // MAVLink trigger interface sends a single IMAGE_START_CAPTURE to component
                // 100 *and* streams CAMERA_TRIGGER for the same picture
                _ => return,
            }
        }
        // commands to the camera component of a tracked vehicle
        let (command, target, p) = match msg {
            MavMessage::COMMAND_LONG(c) => (
                c.command,
                (c.target_system, c.target_component),
                [c.param1, c.param2, c.param3, c.param4],
            ),
            MavMessage::COMMAND_INT(c) => (
                c.command,
                (c.target_system, c.target_component),
                [c.param1, c.param2, c.param3, c.param4],
            ),
            // A request to send a picture again (no target: see the module documentation):
            // the camera holding a picture of that size answers, the others ignore it.
            // The runway run's grid, untargeted too: every camera takes it.
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(_) | MavMessage::DEBUG_FLOAT_ARRAY(_) => {
                for t in self.tracked.values_mut() {
                    t.camera.handle_gcs_message(msg);
                }
                return;
            }
            _ => return,
        };
        if target.1 != CAMERA_COMPID || !self.tracked.contains_key(&target.0) {
            return;
        }
        let from = (sysid, h.component_id);
        let tsys = target.0;
        let max_age = self.max_pose_age;
        let t = self.tracked(tsys);
        let tb = t
            .pose
            .map(|p| Self::ctx(t, p, now).time_boot_ms)
            .unwrap_or(0);
        let fresh = Self::fresh_pose(t, now, max_age).is_some();
        let mut extra = Vec::new();
        let mut refused = false;
        let result = match command {
            mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE if !fresh => {
                refused = true;
                mav::MavResult::MAV_RESULT_TEMPORARILY_REJECTED
            }
            mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE => {
                t.camera.capture_command(
                    f64::from(p[1]),
                    p[2].max(0.0) as u32,
                    p[3].max(0.0) as u32,
                    now,
                );
                mav::MavResult::MAV_RESULT_ACCEPTED
            }
            mav::MavCmd::MAV_CMD_IMAGE_STOP_CAPTURE => {
                t.camera.stop_capture();
                mav::MavResult::MAV_RESULT_ACCEPTED
            }
            mav::MavCmd::MAV_CMD_REQUEST_MESSAGE => {
                let (result, answer) = t.camera.request_message([p[0], p[1], p[2]], tb);
                extra = answer;
                result
            }
            mav::MavCmd::MAV_CMD_REQUEST_CAMERA_INFORMATION => {
                extra = vec![t.camera.information(tb)];
                mav::MavResult::MAV_RESULT_ACCEPTED
            }
            _ => mav::MavResult::MAV_RESULT_UNSUPPORTED,
        };
        if refused {
            // the reason first, as autopilots send their STATUSTEXT before the refusal
            self.refuse(tsys, 1, now);
        }
        let ack = MavMessage::COMMAND_ACK(mav::COMMAND_ACK_DATA {
            command,
            result,
            progress: 0,
            result_param2: 0,
            target_system: from.0,
            target_component: from.1,
        });
        self.push(tsys, ack);
        for m in extra {
            self.push(tsys, m);
        }
    }

    /// GLOBAL_POSITION_INT of vehicle `sysid`.
    fn position(&mut self, sysid: u8, p: &mav::GLOBAL_POSITION_INT_DATA, now: Time) {
        let t = self.tracked(sysid);
        let mut rebooted = false;
        if let Some((_, last_ms)) = t.boot
            && p.time_boot_ms < last_ms
        {
            if last_ms - p.time_boot_ms <= REBOOT_BACKSTEP_MS {
                return; // an older datagram arriving late: keep the newer pose
            }
            rebooted = true;
        }
        let old = t.pose;
        t.boot = Some((now, p.time_boot_ms));
        t.alt_amsl_m = f64::from(p.alt) / 1000.0;
        t.pose = Some(CameraPose {
            lat: f64::from(p.lat) * 1e-7,
            lon: f64::from(p.lon) * 1e-7,
            alt_agl_m: (f64::from(p.relative_alt) / 1000.0).max(0.0),
            heading_deg: if p.hdg == u16::MAX {
                old.map(|o| o.heading_deg).unwrap_or(0.0)
            } else {
                f64::from(p.hdg) / 100.0
            },
            roll_deg: old.map(|o| o.roll_deg).unwrap_or(0.0),
            pitch_deg: old.map(|o| o.pitch_deg).unwrap_or(0.0),
        });
        t.pose_at = Some(now);
        if let Some(refused) = t.episode.take() {
            self.events
                .push_back(PairedEvent::PoseRestored { sysid, refused });
        }
        if rebooted {
            self.events.push_back(PairedEvent::Rebooted { sysid });
            if self.tracked(sysid).autopilot.is_some() {
                self.request_telemetry(sysid, now);
            }
        }
    }

    /// Ask autopilot `sysid` for GLOBAL_POSITION_INT and ATTITUDE at [`TELEMETRY_HZ`] (see
    /// the module documentation).
    fn request_telemetry(&mut self, sysid: u8, now: Time) {
        let t = self.tracked(sysid);
        let ardupilot = t.autopilot == Some(mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA);
        t.last_request = Some(now);
        t.requests = t.requests.saturating_add(1);
        if ardupilot {
            for stream in [
                mav::MavDataStream::MAV_DATA_STREAM_POSITION,
                mav::MavDataStream::MAV_DATA_STREAM_EXTRA1,
            ] {
                self.push(
                    sysid,
                    MavMessage::REQUEST_DATA_STREAM(mav::REQUEST_DATA_STREAM_DATA {
                        req_message_rate: TELEMETRY_HZ,
                        target_system: sysid,
                        target_component: AUTOPILOT_COMPID,
                        req_stream_id: stream,
                        start_stop: 1,
                    }),
                );
            }
        }
        let interval_us = 1e6 / f32::from(TELEMETRY_HZ);
        for id in [33.0, 30.0] {
            // GLOBAL_POSITION_INT, ATTITUDE
            self.push(
                sysid,
                MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
                    param1: id,
                    param2: interval_us,
                    param3: 0.0,
                    param4: 0.0,
                    param5: 0.0,
                    param6: 0.0,
                    param7: 0.0,
                    command: mav::MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL,
                    target_system: sysid,
                    target_component: AUTOPILOT_COMPID,
                    confirmation: 0,
                }),
            );
        }
    }

    /// Whether vehicle `sysid` should be asked for telemetry again at `now`: an autopilot was
    /// heard, its pose is stale and the last request is [`REQUEST_RETRY`] old.
    fn should_ask_again(&self, sysid: u8, now: Time) -> bool {
        self.tracked.get(&sysid).is_some_and(|t| {
            t.autopilot.is_some()
                && Self::fresh_pose(t, now, self.max_pose_age).is_none()
                && t.last_request
                    .is_none_or(|x| now.saturating_since(x) >= REQUEST_RETRY)
        })
    }

    /// `n` captures of vehicle `sysid` refused at `now` for a stale pose: count them, say
    /// why, open an episode, ask for telemetry if it is time to.
    fn refuse(&mut self, sysid: u8, n: u64, now: Time) {
        self.refused += n;
        let t = self.tracked(sysid);
        t.refused += n;
        let age = t.pose_at.map(|at| now.saturating_since(at));
        let total = t.refused;
        match t.episode.as_mut() {
            Some(e) => *e += n,
            None => {
                t.episode = Some(n);
                self.events.push_back(PairedEvent::PoseStale {
                    sysid,
                    age,
                    refused_total: total,
                });
            }
        }
        let text = match age {
            Some(a) => format!(
                "camera: no position from vehicle {sysid} for {:.1} s",
                a.as_secs_f64()
            ),
            None => format!("camera: never had a position from vehicle {sysid}"),
        };
        self.push(
            sysid,
            MavMessage::STATUSTEXT(mav::STATUSTEXT_DATA {
                severity: mav::MavSeverity::MAV_SEVERITY_WARNING,
                text: text.as_str().into(),
                id: 0,
                chunk_seq: 0,
            }),
        );
        if self.should_ask_again(sysid, now) {
            self.request_telemetry(sysid, now);
        }
    }

    fn push(&mut self, sysid: u8, msg: MavMessage) {
        let t = self.tracked(sysid);
        let h = MavHeader {
            system_id: u32::from(sysid),
            component_id: CAMERA_COMPID,
            sequence: t.seq,
        };
        t.seq = t.seq.wrapping_add(1);
        self.outbox.push_back((h, msg));
    }

    /// Run the cameras at `now`: heartbeats at 1 Hz, requests for telemetry while a pose is
    /// stale, interval captures and pending triggers (rendered from a fresh pose, dropped
    /// and counted otherwise), and the release of paced image packets.
    pub fn step(&mut self, now: Time) {
        let world = self.world.clone();
        let mut origin = self.origin;
        let max_age = self.max_pose_age;
        let mut out = Vec::new();
        let mut dropped = Vec::new();
        for (&sysid, t) in self.tracked.iter_mut() {
            if t.last_heartbeat
                .is_none_or(|x| now.saturating_since(x).as_secs_f64() >= 1.0)
            {
                t.last_heartbeat = Some(now);
                out.push((
                    sysid,
                    MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
                        custom_mode: 0,
                        mavtype: mav::MavType::MAV_TYPE_CAMERA,
                        autopilot: mav::MavAutopilot::MAV_AUTOPILOT_INVALID,
                        base_mode: mav::MavModeFlag::empty(),
                        system_status: mav::MavState::MAV_STATE_ACTIVE,
                        mavlink_version: 3,
                    }),
                ));
            }
            match Self::fresh_pose(t, now, max_age) {
                Some(pose) => {
                    let ctx = Self::ctx(t, pose, now);
                    let (e, n) = match &world {
                        Some(w) => w.to_local(pose.lat, pose.lon),
                        None => local_en(origin.get_or_insert((pose.lat, pose.lon)), &pose),
                    };
                    t.camera.update(&ctx, (e, n), world.as_deref());
                }
                None => {
                    let n = t.camera.drop_due(now);
                    if n > 0 {
                        dropped.push((sysid, u64::from(n)));
                    }
                }
            }
            while let Some(m) = t.camera.poll_transmit() {
                out.push((sysid, m));
            }
            while let Some(img) = t.camera.poll_image() {
                self.images.push_back((sysid, img));
            }
        }
        self.origin = origin;
        for (sysid, m) in out {
            self.push(sysid, m);
        }
        for (sysid, n) in dropped {
            self.refuse(sysid, n, now);
        }
        let again: Vec<u8> = self
            .tracked
            .keys()
            .copied()
            .filter(|&s| self.should_ask_again(s, now))
            .collect();
        for sysid in again {
            self.request_telemetry(sysid, now);
        }
    }

    /// When [`PairedCameras::step`] next has paced image packets to release (None: nothing
    /// waits for a pacing bucket). Heartbeats, interval captures and requests for telemetry
    /// need a step at least every 100 ms as well.
    pub fn poll_timeout(&self) -> Option<Time> {
        self.tracked
            .values()
            .filter_map(|t| t.camera.poll_timeout())
            .min()
    }

    /// The next message to send (from a camera component).
    pub fn poll_transmit(&mut self) -> Option<(MavHeader, MavMessage)> {
        self.outbox.pop_front()
    }

    /// The next captured image (write its file before sending what follows).
    pub fn poll_image(&mut self) -> Option<(u8, CapturedImage)> {
        self.images.pop_front()
    }

    /// The next event for the operator.
    pub fn poll_event(&mut self) -> Option<PairedEvent> {
        self.events.pop_front()
    }

    /// The next picture to get from outside (cameras made by [`PairedCameras::external`]),
    /// with the vehicle it is for.
    pub(crate) fn poll_shot(&mut self) -> Option<(u8, Shot)> {
        self.tracked
            .iter_mut()
            .find_map(|(&sysid, t)| t.camera.poll_shot().map(|s| (sysid, s)))
    }

    /// The picture of `shot` on vehicle `sysid`'s camera (None: the source had none), at
    /// `now`: announced, measured and sent as [`SimCamera::deliver`] does.
    pub(crate) fn deliver(&mut self, sysid: u8, shot: Shot, img: Option<&RgbImage>, now: Time) {
        let Some(t) = self.tracked.get_mut(&sysid) else {
            return;
        };
        t.camera.deliver(shot, img, now);
        let mut out = Vec::new();
        while let Some(m) = t.camera.poll_transmit() {
            out.push(m);
        }
        while let Some(img) = t.camera.poll_image() {
            self.images.push_back((sysid, img));
        }
        for m in out {
            self.push(sysid, m);
        }
    }
}

/// East and north of `pose` from `origin` (degrees), metres, on a local tangent plane (an
/// equirectangular approximation: within 0.1 % over the few hundred metres a distance
/// trigger spans).
fn local_en(origin: &(f64, f64), pose: &CameraPose) -> (f64, f64) {
    const R: f64 = 6_371_000.0;
    let n = (pose.lat - origin.0).to_radians() * R;
    let e = (pose.lon - origin.1).to_radians() * R * origin.0.to_radians().cos();
    (e, n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_at_the_feedback_pose() {
        let world = Arc::new(World::flat(
            fleetmap_core::world::Surface::Grass,
            (37.0, -80.0),
            100.0,
        ));
        let mut cams = PairedCameras::new(world, CameraConfig::default(), 1);
        let ap = MavHeader {
            system_id: 3,
            component_id: fleetmap_core::proto::AUTOPILOT_COMPID,
            sequence: 0,
        };
        cams.handle_message(
            &ap,
            &MavMessage::CAMERA_FEEDBACK(mav::CAMERA_FEEDBACK_DATA {
                lat: 370_000_100,
                lng: -800_000_100,
                alt_msl: 112.0,
                alt_rel: 12.0,
                yaw: 90.0,
                ..mav::CAMERA_FEEDBACK_DATA::default()
            }),
            Time::from_secs(1),
        );
        cams.step(Time::from_secs(1));
        let (sysid, img) = cams.poll_image().expect("an image");
        assert_eq!(sysid, 3);
        assert!((img.true_pose.alt_agl_m - 12.0).abs() < 1e-9);
        assert_eq!(img.true_pose.heading_deg, 90.0);
        let msgs: Vec<_> = std::iter::from_fn(|| cams.poll_transmit()).collect();
        assert!(
            msgs.iter()
                .all(|(h, _)| h.system_id == 3 && h.component_id == CAMERA_COMPID)
        );
        assert!(
            msgs.iter().any(
                |(_, m)| matches!(m, MavMessage::CAMERA_IMAGE_CAPTURED(c) if c.image_index == 0)
            )
        );
        // a command to the camera component is answered
        let gcs = MavHeader {
            system_id: fleetmap_core::proto::GCS_SYSID as u32,
            component_id: fleetmap_core::proto::GCS_COMPID,
            sequence: 0,
        };
        cams.handle_message(
            &gcs,
            &MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
                param1: <mav::CAMERA_INFORMATION_DATA as mavlink::MessageData>::ID as f32,
                command: mav::MavCmd::MAV_CMD_REQUEST_MESSAGE,
                target_system: 3,
                target_component: CAMERA_COMPID,
                ..mav::COMMAND_LONG_DATA::default()
            }),
            Time::from_secs(2),
        );
        let msgs: Vec<_> = std::iter::from_fn(|| cams.poll_transmit()).collect();
        assert!(
            msgs.iter()
                .any(|(_, m)| matches!(m, MavMessage::CAMERA_INFORMATION(_)))
        );
    }

    fn flat() -> Arc<World> {
        Arc::new(World::flat(
            fleetmap_core::world::Surface::Grass,
            (37.0, -80.0),
            100.0,
        ))
    }

    fn small() -> CameraConfig {
        let mut cfg = CameraConfig::default();
        cfg.model.width_px = 32;
        cfg.model.height_px = 32;
        cfg
    }

    const AP: MavHeader = MavHeader {
        system_id: 3,
        component_id: fleetmap_core::proto::AUTOPILOT_COMPID,
        sequence: 0,
    };

    fn heartbeat(autopilot: mav::MavAutopilot) -> MavMessage {
        MavMessage::HEARTBEAT(mav::HEARTBEAT_DATA {
            autopilot,
            mavtype: mav::MavType::MAV_TYPE_QUADROTOR,
            ..mav::HEARTBEAT_DATA::default()
        })
    }

    fn position(time_boot_ms: u32) -> MavMessage {
        MavMessage::GLOBAL_POSITION_INT(mav::GLOBAL_POSITION_INT_DATA {
            time_boot_ms,
            lat: 370_000_100,
            lon: -800_000_100,
            alt: 112_000,
            relative_alt: 12_000,
            hdg: 9_000,
            ..mav::GLOBAL_POSITION_INT_DATA::default()
        })
    }

    fn sent(cams: &mut PairedCameras) -> Vec<MavMessage> {
        std::iter::from_fn(|| cams.poll_transmit())
            .map(|(h, m)| {
                assert_eq!((h.system_id, h.component_id), (3, 100));
                m
            })
            .collect()
    }

    /// (stream id, rate Hz) of each REQUEST_DATA_STREAM, (message id, interval µs) of each
    /// SET_MESSAGE_INTERVAL.
    type Requests = (Vec<(u8, u16)>, Vec<(f32, f32)>);

    fn requests(msgs: &[MavMessage]) -> Requests {
        let mut streams = Vec::new();
        let mut intervals = Vec::new();
        for m in msgs {
            match m {
                MavMessage::REQUEST_DATA_STREAM(r) => {
                    assert_eq!(
                        (r.target_system, r.target_component, r.start_stop),
                        (3, 1, 1)
                    );
                    streams.push((r.req_stream_id as u8, r.req_message_rate));
                }
                MavMessage::COMMAND_LONG(c)
                    if c.command == mav::MavCmd::MAV_CMD_SET_MESSAGE_INTERVAL =>
                {
                    assert_eq!((c.target_system, c.target_component), (3, 1));
                    intervals.push((c.param1, c.param2));
                }
                _ => {}
            }
        }
        (streams, intervals)
    }

    #[test]
    fn asks_once_per_autopilot_and_again_after_a_reboot() {
        let mut cams = PairedCameras::new(flat(), small(), 1);
        let ardupilot = heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA);
        cams.handle_message(&AP, &ardupilot, Time::from_secs(1));
        let (streams, intervals) = requests(&sent(&mut cams));
        assert_eq!(streams, vec![(6, 10), (10, 10)]);
        assert_eq!(intervals, vec![(33.0, 100_000.0), (30.0, 100_000.0)]);
        assert_eq!(
            cams.poll_event(),
            Some(PairedEvent::Discovered {
                sysid: 3,
                autopilot: mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA
            })
        );
        // more heartbeats and a fresh stream: nothing more to ask
        cams.handle_message(&AP, &ardupilot, Time::from_millis(1_500));
        cams.handle_message(&AP, &position(60_000), Time::from_millis(1_600));
        cams.step(Time::from_millis(1_700));
        assert_eq!(requests(&sent(&mut cams)), (vec![], vec![]));
        assert_eq!(cams.telemetry_requests(3), 1);
        // a datagram 200 ms older arriving late is not a reboot, and is not used
        cams.handle_message(&AP, &position(59_800), Time::from_millis(1_650));
        assert_eq!(cams.telemetry_requests(3), 1);
        assert_eq!(cams.tracked[&3].boot.map(|b| b.1), Some(60_000));
        // time_boot_ms back to 3 s: rebooted, ask again at once
        cams.handle_message(&AP, &position(3_000), Time::from_millis(1_800));
        let (streams, intervals) = requests(&sent(&mut cams));
        assert_eq!((streams.len(), intervals.len()), (2, 2));
        assert_eq!(cams.telemetry_requests(3), 2);
        assert_eq!(cams.poll_event(), Some(PairedEvent::Rebooted { sysid: 3 }));
    }

    #[test]
    fn px4_is_asked_for_message_intervals_only() {
        let mut cams = PairedCameras::new(flat(), small(), 1);
        cams.handle_message(
            &AP,
            &heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_PX4),
            Time::from_secs(1),
        );
        let (streams, intervals) = requests(&sent(&mut cams));
        assert!(streams.is_empty());
        assert_eq!(intervals, vec![(33.0, 100_000.0), (30.0, 100_000.0)]);
        // no GCS heartbeat-like autopilot: no camera
        let mut cams = PairedCameras::new(flat(), small(), 1);
        cams.handle_message(
            &AP,
            &heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_INVALID),
            Time::from_secs(1),
        );
        assert!(cams.sysids().is_empty());
    }

    /// PX4 1.16 passes a mission's interval capture on to the camera as a command from the
    /// autopilot (component 1) and sends no CAMERA_TRIGGER for it: the camera takes it. A
    /// single shot from the autopilot comes with a CAMERA_TRIGGER and is not taken twice.
    #[test]
    fn px4_interval_captures_from_the_autopilot_are_taken() {
        let capture = |interval: f32, count: f32| {
            MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
                param2: interval,
                param3: count,
                command: mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
                target_system: 3,
                target_component: CAMERA_COMPID,
                ..mav::COMMAND_LONG_DATA::default()
            })
        };
        let captured = |msgs: &[MavMessage]| {
            msgs.iter()
                .filter(|m| matches!(m, MavMessage::CAMERA_IMAGE_CAPTURED(_)))
                .count()
        };
        let mut cams = PairedCameras::new(flat(), small(), 1);
        cams.handle_message(
            &AP,
            &heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_PX4),
            Time::from_secs(1),
        );
        let _ = sent(&mut cams);
        let mut shots = 0;
        for (k, (interval, count)) in [(0.0, 1.0), (0.5, 3.0)].into_iter().enumerate() {
            let t0 = Time::from_secs(2 + 10 * k as u64);
            cams.handle_message(&AP, &position(2000 + 10_000 * k as u32), t0);
            cams.handle_message(&AP, &capture(interval, count), t0);
            for i in 0..40u64 {
                let t = t0 + Duration::from_millis(50 * i);
                cams.handle_message(&AP, &position(2000 + 10_000 * k as u32 + 50 * i as u32), t);
                cams.step(t);
            }
            shots += captured(&sent(&mut cams));
            // the single shot is not taken (its CAMERA_TRIGGER is); the interval one is
            assert_eq!(
                shots,
                if k == 0 { 0 } else { 3 },
                "after {interval} s × {count}"
            );
        }
    }

    #[test]
    fn stale_triggers_and_interval_shots_are_refused_once_per_episode() {
        let mut cams = PairedCameras::new(flat(), small(), 1);
        cams.handle_message(
            &AP,
            &heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_PX4),
            Time::ZERO,
        );
        // a CAMERA_TRIGGER before any position: no picture, a reason
        cams.handle_message(
            &AP,
            &MavMessage::CAMERA_TRIGGER(mav::CAMERA_TRIGGER_DATA::default()),
            Time::from_millis(100),
        );
        cams.step(Time::from_millis(100));
        assert!(cams.poll_image().is_none());
        assert_eq!(cams.refused(), 1);
        let texts: Vec<String> = sent(&mut cams)
            .iter()
            .filter_map(|m| match m {
                MavMessage::STATUSTEXT(t) => Some(t.text.to_str().unwrap_or("").to_string()),
                _ => None,
            })
            .collect();
        assert_eq!(texts, vec!["camera: never had a position from vehicle 3"]);
        // positions at 10 Hz for a second, pictures every second from t = 1 s
        let mut t = Time::from_millis(100);
        while t <= Time::from_secs(1) {
            cams.handle_message(&AP, &position(t.as_millis() as u32), t);
            cams.step(t);
            t += Duration::from_millis(100);
        }
        let gcs = MavHeader {
            system_id: fleetmap_core::proto::GCS_SYSID as u32,
            component_id: fleetmap_core::proto::GCS_COMPID,
            sequence: 0,
        };
        cams.handle_message(
            &gcs,
            &MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
                param2: 1.0,
                command: mav::MavCmd::MAV_CMD_IMAGE_START_CAPTURE,
                target_system: 3,
                target_component: CAMERA_COMPID,
                ..mav::COMMAND_LONG_DATA::default()
            }),
            Time::from_secs(1),
        );
        cams.step(Time::from_secs(1));
        assert_eq!(std::iter::from_fn(|| cams.poll_image()).count(), 1);
        // the positions stop: the shots at 2, 3, 4 s are refused, one warning event
        for ms in (1_100..=4_000).step_by(100) {
            cams.step(Time::from_millis(ms));
        }
        assert!(cams.poll_image().is_none());
        assert_eq!(cams.refused_for(3), 4);
        let events: Vec<_> = std::iter::from_fn(|| cams.poll_event()).collect();
        let stale: Vec<_> = events
            .iter()
            .filter(|e| matches!(e, PairedEvent::PoseStale { .. }))
            .collect();
        assert_eq!(stale.len(), 2, "{events:?}"); // the first episode, this one
        assert!(matches!(
            stale[1],
            PairedEvent::PoseStale { age: Some(a), refused_total: 2, .. }
                if (a.as_secs_f64() - 1.0).abs() < 1e-9
        ));
        // and asked for telemetry again, every 2 s at most
        assert!(cams.telemetry_requests(3) >= 2 && cams.telemetry_requests(3) <= 3);
        // positions again: the episode ends, pictures resume
        cams.handle_message(&AP, &position(4_100), Time::from_millis(4_100));
        assert_eq!(
            cams.poll_event(),
            Some(PairedEvent::PoseRestored {
                sysid: 3,
                refused: 3
            })
        );
        cams.handle_message(&AP, &position(5_000), Time::from_secs(5));
        cams.step(Time::from_secs(5));
        assert_eq!(std::iter::from_fn(|| cams.poll_image()).count(), 1);
    }

    /// The GCS's grid announcement reaches every camera classifying runway pictures; each
    /// answers with its status, from its own vehicle's camera component.
    #[test]
    fn every_paired_camera_takes_the_runway_grid() {
        use fleetmap_core::geo::{Grid, LatLon};
        use fleetmap_core::vision::onboard::OnboardSpec;
        use fleetmap_core::vision::runway::RunwayParams;
        use fleetmap_core::vision::runway::onboard::{
            RunwayDefinition, RunwayMeasurement, RunwaySpec,
        };
        let def = RunwayDefinition {
            params: RunwayParams::default(),
            camera: fleetmap_core::vision::camera::CameraModel::paper(),
            cell_m: 4.0,
            grid: None,
        };
        let cfg = CameraConfig {
            onboard: Some(OnboardSpec::Runway(def.clone())),
            ..small()
        };
        let mut cams = PairedCameras::new(flat(), cfg, 1);
        for sysid in [1, 2] {
            let ap = MavHeader {
                system_id: sysid,
                component_id: fleetmap_core::proto::AUTOPILOT_COMPID,
                sequence: 0,
            };
            cams.handle_message(
                &ap,
                &heartbeat(mav::MavAutopilot::MAV_AUTOPILOT_ARDUPILOTMEGA),
                Time::from_secs(1),
            );
        }
        cams.step(Time::from_secs(1));
        let spec = RunwaySpec {
            params: def.params,
            camera: def.camera,
            grid: Grid::new(LatLon::new(37.0, -80.0), 4.0).unwrap(),
        };
        let gcs = MavHeader {
            system_id: fleetmap_core::proto::GCS_SYSID as u32,
            component_id: fleetmap_core::proto::GCS_COMPID,
            sequence: 0,
        };
        let status = |cams: &mut PairedCameras| -> Vec<(u32, u32)> {
            std::iter::from_fn(|| cams.poll_transmit())
                .filter_map(|(h, m)| match m {
                    MavMessage::DEBUG_FLOAT_ARRAY(d) => {
                        assert_eq!(h.component_id, 100);
                        RunwayMeasurement::from_message(&d).map(|r| (h.system_id, r.spec))
                    }
                    _ => None,
                })
                .collect()
        };
        // no grid yet: each camera says so
        assert_eq!(status(&mut cams), vec![(1, 0), (2, 0)]);
        cams.handle_message(&gcs, &spec.announcement().to_message(), Time::from_secs(2));
        cams.step(Time::from_secs(2));
        let fp = spec.fingerprint();
        assert_eq!(status(&mut cams), vec![(1, fp), (2, fp)]);
    }
}
