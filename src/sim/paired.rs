//! A simulated camera for a real autopilot (an ArduPilot or PX4 SITL, or a vehicle on the
//! bench): it listens to the autopilot's telemetry for its pose and renders the world's
//! ground truth whenever the autopilot takes a picture, answering as the vehicle's camera
//! component (id 100) exactly as the simulated vehicles' cameras do ([`super::camera`]).
//!
//! Triggers: ArduPilot's CAMERA_FEEDBACK (sent by AP_Camera for every picture it takes, with
//! the position and attitude at that moment), PX4's CAMERA_TRIGGER (camera_trigger module),
//! and the MAVLink camera protocol's own commands addressed to component 100
//! (MAV_CMD_IMAGE_START_CAPTURE / _STOP_CAPTURE, REQUEST_MESSAGE for CAMERA_INFORMATION).
//! The pose comes from GLOBAL_POSITION_INT (position, altitude above home, heading) and
//! ATTITUDE (roll, pitch) of the autopilot component (id 1); the ground is taken as flat at
//! home altitude.

// CAMERA_FEEDBACK and CAMERA_TRIGGER are ArduPilot / legacy messages.
#![allow(deprecated)]

use crate::sim::camera::{CAMERA_COMPID, CameraConfig, CaptureContext, CapturedImage, SimCamera};
use crate::sim::render::CameraPose;
use crate::sim::world::World;
use crate::time::Time;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega as mav;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

#[derive(Debug)]
struct Tracked {
    camera: SimCamera,
    pose: Option<CameraPose>,
    alt_amsl_m: f64,
    boot: Option<(Time, u32)>, // our time and the autopilot's time_boot_ms at that moment
    seq: u8,
    last_heartbeat: Option<Time>,
}

/// Cameras for the autopilots heard on one link. See the module documentation.
#[derive(Debug)]
pub struct PairedCameras {
    world: Arc<World>,
    config: CameraConfig,
    seed: u64,
    tracked: BTreeMap<u8, Tracked>,
    outbox: VecDeque<(MavHeader, MavMessage)>,
    images: VecDeque<(u8, CapturedImage)>,
}

impl PairedCameras {
    /// Cameras rendering `world` with `config`, seeded.
    pub fn new(world: Arc<World>, config: CameraConfig, seed: u64) -> PairedCameras {
        PairedCameras {
            world,
            config,
            seed,
            tracked: BTreeMap::new(),
            outbox: VecDeque::new(),
            images: VecDeque::new(),
        }
    }

    /// System ids of the autopilots with a camera.
    pub fn sysids(&self) -> Vec<u8> {
        self.tracked.keys().copied().collect()
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
        })
    }

    fn ctx(t: &Tracked, now: Time) -> Option<CaptureContext> {
        let pose = t.pose?;
        let tb = t
            .boot
            .map(|(at, ms)| ms.wrapping_add(now.saturating_since(at).as_millis() as u32))
            .unwrap_or(0);
        Some(CaptureContext {
            true_pose: pose,
            reported: (pose.lat, pose.lon, pose.alt_agl_m),
            alt_amsl_m: t.alt_amsl_m,
            time_boot_ms: tb,
            now,
            world_t_s: now.as_secs_f64(),
        })
    }

    /// Feed a message heard on the link at `now`.
    pub fn handle_message(&mut self, h: &MavHeader, msg: &MavMessage, now: Time) {
        let Ok(sysid) = u8::try_from(h.system_id) else {
            return;
        };
        if h.component_id == 1 {
            match msg {
                MavMessage::HEARTBEAT(hb)
                    if hb.autopilot != mav::MavAutopilot::MAV_AUTOPILOT_INVALID =>
                {
                    self.tracked(sysid);
                }
                MavMessage::GLOBAL_POSITION_INT(p) => {
                    let t = self.tracked(sysid);
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
                }
                MavMessage::ATTITUDE(a) => {
                    let t = self.tracked(sysid);
                    if let Some(p) = t.pose.as_mut() {
                        p.roll_deg = f64::from(a.roll).to_degrees();
                        p.pitch_deg = f64::from(a.pitch).to_degrees();
                        p.heading_deg = f64::from(a.yaw).to_degrees().rem_euclid(360.0);
                    }
                }
                MavMessage::CAMERA_FEEDBACK(f) => {
                    let t = self.tracked(sysid);
                    // the pose at the moment the autopilot fired the shutter
                    t.pose = Some(CameraPose {
                        lat: f64::from(f.lat) * 1e-7,
                        lon: f64::from(f.lng) * 1e-7,
                        alt_agl_m: f64::from(f.alt_rel).max(0.0),
                        heading_deg: f64::from(f.yaw).rem_euclid(360.0),
                        roll_deg: f64::from(f.roll),
                        pitch_deg: f64::from(f.pitch),
                    });
                    t.alt_amsl_m = f64::from(f.alt_msl);
                    t.camera.trigger();
                }
                MavMessage::CAMERA_TRIGGER(_) => {
                    self.tracked(sysid).camera.trigger();
                }
                _ => {}
            }
            return;
        }
        // commands to the camera component of a tracked vehicle
        let (command, target, p) = match msg {
            MavMessage::COMMAND_LONG(c) => (
                c.command,
                (c.target_system, c.target_component),
                [c.param1, c.param2, c.param3],
            ),
            MavMessage::COMMAND_INT(c) => (
                c.command,
                (c.target_system, c.target_component),
                [c.param1, c.param2, c.param3],
            ),
            MavMessage::DATA_TRANSMISSION_HANDSHAKE(_) => {
                for t in self.tracked.values_mut() {
                    t.camera.handle_handshake_request();
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
        let t = self.tracked(tsys);
        let tb = Self::ctx(t, now).map(|c| c.time_boot_ms).unwrap_or(0);
        let mut extra = None;
        let result = match command as u16 {
            2000 => {
                t.camera
                    .start_capture(f64::from(p[1]), p[2].max(0.0) as u32, now);
                mav::MavResult::MAV_RESULT_ACCEPTED
            }
            2001 => {
                t.camera.stop_capture();
                mav::MavResult::MAV_RESULT_ACCEPTED
            }
            512 if p[0] as u32 == 259 => {
                extra = Some(t.camera.information(tb));
                mav::MavResult::MAV_RESULT_ACCEPTED
            }
            521 => {
                extra = Some(t.camera.information(tb));
                mav::MavResult::MAV_RESULT_ACCEPTED
            }
            _ => mav::MavResult::MAV_RESULT_UNSUPPORTED,
        };
        let ack = MavMessage::COMMAND_ACK(mav::COMMAND_ACK_DATA {
            command,
            result,
            progress: 0,
            result_param2: 0,
            target_system: from.0,
            target_component: from.1,
        });
        self.push(tsys, ack);
        if let Some(m) = extra {
            self.push(tsys, m);
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

    /// Run the cameras (interval captures, pending triggers, heartbeats at 1 Hz).
    pub fn step(&mut self, now: Time) {
        let world = self.world.clone();
        let mut out = Vec::new();
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
            if let Some(ctx) = Self::ctx(t, now) {
                let (e, n) = world.to_local(ctx.true_pose.lat, ctx.true_pose.lon);
                t.camera.update(&ctx, (e, n), Some(&world));
            }
            while let Some(m) = t.camera.poll_transmit() {
                out.push((sysid, m));
            }
            while let Some(img) = t.camera.poll_image() {
                self.images.push_back((sysid, img));
            }
        }
        for (sysid, m) in out {
            self.push(sysid, m);
        }
    }

    /// The next message to send (from a camera component).
    pub fn poll_transmit(&mut self) -> Option<(MavHeader, MavMessage)> {
        self.outbox.pop_front()
    }

    /// The next captured image (write its file before sending what follows).
    pub fn poll_image(&mut self) -> Option<(u8, CapturedImage)> {
        self.images.pop_front()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn renders_at_the_feedback_pose() {
        let world = Arc::new(World::flat(
            crate::sim::world::Surface::Grass,
            (37.0, -80.0),
            100.0,
        ));
        let mut cams = PairedCameras::new(world, CameraConfig::default(), 1);
        let ap = MavHeader {
            system_id: 3,
            component_id: 1,
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
                .all(|(h, _)| h.system_id == 3 && h.component_id == 100)
        );
        assert!(
            msgs.iter().any(
                |(_, m)| matches!(m, MavMessage::CAMERA_IMAGE_CAPTURED(c) if c.image_index == 0)
            )
        );
        // a command to the camera component is answered
        let gcs = MavHeader {
            system_id: 255,
            component_id: 190,
            sequence: 0,
        };
        cams.handle_message(
            &gcs,
            &MavMessage::COMMAND_LONG(mav::COMMAND_LONG_DATA {
                param1: 259.0,
                command: mav::MavCmd::MAV_CMD_REQUEST_MESSAGE,
                target_system: 3,
                target_component: 100,
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
}
