//! The handle callers hold: snapshots, subscriptions, raw sends, the actor's primitives
//! (command with ACK, mission operation) and the fleet's lifecycle.

use super::BOOT_GRACE;
use super::BOOT_RETRY;
use super::FleetConfig;
use super::Incoming;
use super::actor::Reply;
use super::actor::Request;
use super::error::FleetError;
use super::state::FleetSnapshot;
use super::state::VehicleSnapshot;
use fleetmap_core::mission::item::MissionItem;
use fleetmap_core::mission::item::MissionType;
use fleetmap_core::proto::Endpoint;
use fleetmap_core::proto::command::Command;
use fleetmap_core::proto::command::CommandAck;
use fleetmap_core::proto::command::CommandError;
use fleetmap_core::proto::flavour::VehicleClass;
use fleetmap_core::proto::mission::MissionError;
use fleetmap_core::proto::mission::MissionOp;
use fleetmap_core::proto::mission::MissionOutcome;
use fleetmap_io::clock::MonotonicClock;
use fleetmap_io::link::transport::LinkHandle;
use fleetmap_io::watch;
use mavlink::dialects::ardupilotmega::MavCmd;
use mavlink::dialects::ardupilotmega::MavMessage;
use std::time::Duration;
use tokio::sync::broadcast;
use tokio::sync::mpsc;
use tokio::sync::oneshot;

/// Handle to the fleet task (cheap to clone).
#[derive(Clone)]
pub struct FleetHandle {
    pub(super) tx: mpsc::Sender<Request>,
    pub(super) snapshot: watch::Receiver<FleetSnapshot>,
    pub(super) incoming: broadcast::Sender<Incoming>,
    pub(super) links: Vec<LinkHandle>,
    pub(super) clock: MonotonicClock,
    pub(super) cfg: FleetConfig,
}

impl FleetHandle {
    /// The fleet's clock (the `now` of snapshots).
    pub fn clock(&self) -> &MonotonicClock {
        &self.clock
    }

    /// The configuration the fleet was started with.
    pub fn config(&self) -> &FleetConfig {
        &self.cfg
    }

    /// The links, in `--connect` order.
    pub fn links(&self) -> &[LinkHandle] {
        &self.links
    }

    /// The latest snapshot.
    pub fn snapshot(&self) -> FleetSnapshot {
        self.snapshot.borrow().clone()
    }

    /// A watch receiver of snapshots (published every `snapshot_period`).
    pub fn watch(&self) -> watch::Receiver<FleetSnapshot> {
        self.snapshot.clone()
    }

    /// Every received frame, from now on.
    pub fn subscribe(&self) -> broadcast::Receiver<Incoming> {
        self.incoming.subscribe()
    }

    /// The vehicle `sysid`, if heard.
    pub fn vehicle(&self, sysid: u8) -> Option<VehicleSnapshot> {
        self.snapshot.borrow().vehicles.get(&sysid).cloned()
    }

    /// The vehicle `sysid`, to be commanded: an error when it is not heard, or when two
    /// autopilots answer as it ([`FleetError::SysidConflict`]).
    pub(super) fn require(&self, sysid: u8) -> Result<VehicleSnapshot, FleetError> {
        let v = self.vehicle(sysid).ok_or(FleetError::NoVehicle { sysid })?;
        match &v.sysid_conflict {
            Some(c) => Err(FleetError::SysidConflict {
                sysid,
                evidence: c.evidence.clone(),
            }),
            None => Ok(v),
        }
    }

    /// [`FleetError::SysidConflict`] when two autopilots answer as `sysid`.
    pub(crate) fn conflict(&self, sysid: u8) -> Option<FleetError> {
        let v = self.vehicle(sysid)?;
        v.sysid_conflict.map(|c| FleetError::SysidConflict {
            sysid,
            evidence: c.evidence,
        })
    }

    /// Wait until `pred` holds for vehicle `sysid` (checked on every snapshot).
    pub async fn wait_until(
        &self,
        sysid: u8,
        timeout: Duration,
        mut pred: impl FnMut(&VehicleSnapshot) -> bool,
    ) -> Result<VehicleSnapshot, Option<VehicleSnapshot>> {
        let mut rx = self.snapshot.clone();
        let fut = async {
            loop {
                {
                    let s = rx.borrow_and_update();
                    if let Some(v) = s.vehicles.get(&sysid)
                        && pred(v)
                    {
                        return Ok(v.clone());
                    }
                }
                if rx.changed().await.is_err() {
                    return Err(());
                }
            }
        };
        match tokio::time::timeout(timeout, fut).await {
            Ok(Ok(v)) => Ok(v),
            _ => Err(self.vehicle(sysid)),
        }
    }

    /// Wait for the first heartbeat of `sysid`.
    pub async fn wait_vehicle(
        &self,
        sysid: u8,
        timeout: Duration,
    ) -> Result<VehicleSnapshot, FleetError> {
        self.wait_until(sysid, timeout, |_| true)
            .await
            .map_err(|_| FleetError::NoVehicle { sysid })
    }

    pub(super) async fn request<T>(
        &self,
        make: impl FnOnce(Reply<T>) -> Request,
    ) -> Result<T, FleetError> {
        let (tx, rx) = oneshot::channel();
        self.tx
            .send(make(tx))
            .await
            .map_err(|_| FleetError::Stopped)?;
        rx.await.map_err(|_| FleetError::Stopped)
    }

    /// Send a command and wait for its final ACK. A vehicle that is booting is waited for
    /// first, and a command it refuses as temporarily rejected or denied while it boots (or
    /// just after) is sent again once it is up ([`FleetHandle::wait_booted`]).
    pub async fn command(&self, cmd: Command) -> Result<CommandAck, FleetError> {
        let sysid = cmd.target.sysid;
        let give_up = tokio::time::Instant::now() + self.cfg.ops.boot_wait;
        loop {
            if let Some(e) = self.conflict(sysid) {
                return Err(e);
            }
            // A system not heard yet (a camera, a command sent blind) is not waited for.
            if self.vehicle(sysid).is_some() {
                self.wait_booted(sysid).await?;
            }
            let c = cmd.clone();
            let r = self
                .request(|reply| Request::Command { cmd: c, reply })
                .await?
                .map_err(|error| FleetError::Command { sysid, error });
            let boot_refusal = matches!(
                &r,
                Err(FleetError::Command {
                    error: CommandError::TemporarilyRejected { .. } | CommandError::Denied { .. },
                    ..
                })
            );
            if !(boot_refusal && self.refused_while_booting(sysid, give_up).await) {
                return r;
            }
        }
    }

    /// Whether a refusal from `sysid` came while it boots or just after (within
    /// [`BOOT_GRACE`] of leaving boot) and may be tried again before `give_up`; if so, waits
    /// a moment first.
    pub(super) async fn refused_while_booting(
        &self,
        sysid: u8,
        give_up: tokio::time::Instant,
    ) -> bool {
        let Some(v) = self.vehicle(sysid) else {
            return false;
        };
        let now = self.clock.now();
        let recent = v.booting
            || v.ready_since
                .is_some_and(|t| now.saturating_since(t) <= BOOT_GRACE);
        if !recent || tokio::time::Instant::now() + BOOT_RETRY > give_up {
            return false;
        }
        tracing::info!("vehicle {sysid}: refused while booting; trying again");
        tokio::time::sleep(BOOT_RETRY).await;
        true
    }

    /// Wait until vehicle `sysid` has finished booting (`VehicleSnapshot::booting`), at
    /// most `super::OpsConfig::boot_wait`; returns its snapshot then.
    pub async fn wait_booted(&self, sysid: u8) -> Result<VehicleSnapshot, FleetError> {
        let v = self.require(sysid)?;
        if !v.booting {
            return Ok(v);
        }
        let wait = self.cfg.ops.boot_wait;
        tracing::info!("vehicle {sysid} is booting: waiting for it");
        self.wait_until(sysid, wait, |s| !s.booting)
            .await
            .map_err(|last| FleetError::Booting {
                sysid,
                waited_s: wait.as_secs_f64(),
                why: match last {
                    Some(v) if v.system_status == 1 => "its heartbeat says MAV_STATE_BOOT".into(),
                    Some(_) => "no heartbeat since it rebooted".into(),
                    None => "vehicle gone".into(),
                },
            })
    }

    /// Send any message (routed by its target); returns the number of links it went out on.
    pub async fn send(&self, msg: MavMessage) -> Result<usize, FleetError> {
        use mavlink::Message;
        if let Some(e) = msg.target_system_id().and_then(|s| self.conflict(s)) {
            return Err(e);
        }
        self.request(|reply| Request::Send {
            msg: Box::new(msg),
            reply,
        })
        .await
    }

    /// Send `msg`, which has no target field (a DATA_TRANSMISSION_HANDSHAKE asking a camera
    /// for a picture), to system `to` only: over the link and peer it was last heard from,
    /// and on a radio as bulk traffic behind the vehicle's commands and mission transfers.
    /// Returns how many links it went to (1 when queued).
    pub async fn send_to(&self, to: u8, msg: MavMessage) -> Result<usize, FleetError> {
        if let Some(e) = self.conflict(to) {
            return Err(e);
        }
        self.request(|reply| Request::SendTo {
            to,
            msg: Box::new(msg),
            reply,
        })
        .await
    }

    /// Run a mission operation; `progress` receives (done, total) as items move. A vehicle
    /// that is booting is waited for first (a download would read an empty list from an
    /// ArduPilot that has not loaded its mission yet), and an operation it refuses with
    /// MAV_MISSION_NO_SPACE, MAV_MISSION_DENIED or MAV_MISSION_ERROR while it boots or just
    /// after is run again once it is up.
    pub(crate) async fn mission_op(
        &self,
        sysid: u8,
        op: MissionOp,
        progress: Option<mpsc::UnboundedSender<(usize, usize)>>,
    ) -> Result<MissionOutcome, FleetError> {
        use mavlink::dialects::ardupilotmega::MavMissionResult as R;
        let give_up = tokio::time::Instant::now() + self.cfg.ops.boot_wait;
        loop {
            if let Some(e) = self.conflict(sysid) {
                return Err(e);
            }
            self.wait_booted(sysid).await?;
            let (o, p) = (op.clone(), progress.clone());
            let r = self
                .request(|reply| Request::Mission {
                    sysid,
                    op: o,
                    reply,
                    progress: p,
                })
                .await?;
            let boot_refusal = matches!(
                &r,
                Err(FleetError::Mission {
                    error: MissionError::Rejected { result, .. },
                    ..
                }) if matches!(result.0, R::MAV_MISSION_NO_SPACE | R::MAV_MISSION_DENIED | R::MAV_MISSION_ERROR)
            );
            if !(boot_refusal && self.refused_while_booting(sysid, give_up).await) {
                return r;
            }
        }
    }

    /// Upload a mission, fence or rally list. For ArduPilot missions the known home is
    /// sent as item 0.
    pub async fn upload_mission(
        &self,
        sysid: u8,
        kind: MissionType,
        items: Vec<MissionItem>,
    ) -> Result<MissionOutcome, FleetError> {
        let v = self.require(sysid)?;
        let home = v.home.map(|h| MissionItem {
            frame: fleetmap_core::mission::item::frame::GLOBAL,
            x: fleetmap_core::mission::item::deg_to_e7(h.lat),
            y: fleetmap_core::mission::item::deg_to_e7(h.lon),
            z: h.alt_amsl,
            ..MissionItem::command(fleetmap_core::mission::item::cmd::NAV_WAYPOINT)
        });
        self.mission_op(sysid, MissionOp::Upload { kind, items, home }, None)
            .await
    }

    /// Download a list: (items in user numbering, ArduPilot's home item).
    pub async fn download_mission(
        &self,
        sysid: u8,
        kind: MissionType,
    ) -> Result<(Vec<MissionItem>, Option<MissionItem>), FleetError> {
        match self
            .mission_op(sysid, MissionOp::Download { kind }, None)
            .await?
        {
            MissionOutcome::Downloaded { items, home } => Ok((items, home)),
            other => Err(FleetError::NotConfirmed {
                sysid,
                what: "a downloaded list".into(),
                waited_s: 0.0,
                now: format!("{other:?}"),
            }),
        }
    }

    /// Clear a list.
    pub async fn clear_mission(&self, sysid: u8, kind: MissionType) -> Result<(), FleetError> {
        self.mission_op(sysid, MissionOp::Clear { kind }, None)
            .await
            .map(|_| ())
    }

    /// Make user item `seq` current: MAV_CMD_DO_SET_MISSION_CURRENT, or MISSION_SET_CURRENT
    /// when the autopilot does not support the command (ArduPilot < 4.3, PX4 < 1.14).
    pub async fn set_mission_current(&self, sysid: u8, seq: u16) -> Result<(), FleetError> {
        let v = self.require(sysid)?;
        let wire = v.flavour.wire_seq(seq);
        let cmd = Command::long(
            Endpoint::new(sysid, v.compid),
            MavCmd::MAV_CMD_DO_SET_MISSION_CURRENT,
            [f32::from(wire), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        match self.command(cmd).await {
            Ok(_) => Ok(()),
            Err(FleetError::Command {
                error: CommandError::Unsupported { .. },
                ..
            }) => self
                .mission_op(sysid, MissionOp::SetCurrent { seq }, None)
                .await
                .map(|_| ()),
            Err(e) => Err(e),
        }
    }

    /// Publish snapshots every `period` of the fleet's clock from now on (instead of
    /// [`FleetConfig::snapshot_period`]; [`FleetHandle::config`] still shows the period the
    /// fleet started with). The terminal UI asks for 100 ms of wall time so that its 10 frames
    /// a second each show fresh telemetry. A zero period is taken as 1 ms.
    pub(crate) async fn set_snapshot_period(&self, period: Duration) -> Result<(), FleetError> {
        let period = period.max(Duration::from_millis(1));
        self.tx
            .send(Request::SnapshotPeriod { period })
            .await
            .map_err(|_| FleetError::Stopped)
    }

    /// Forget the mission progress recorded for `sysid` (reached items).
    pub(crate) async fn reset_progress(&self, sysid: u8) -> Result<(), FleetError> {
        self.tx
            .send(Request::ResetProgress { sysid })
            .await
            .map_err(|_| FleetError::Stopped)
    }

    /// Whether vehicle `sysid` flies (copter) rather than drives.
    pub fn flies(&self, sysid: u8) -> bool {
        self.vehicle(sysid)
            .is_some_and(|v| v.flavour.flies() && v.flavour.class != VehicleClass::Other)
    }

    /// Stop the fleet task (links stop when the last handle is dropped).
    pub async fn shutdown(&self) {
        let (tx, rx) = oneshot::channel();
        if self.tx.send(Request::Shutdown { reply: tx }).await.is_ok() {
            let _ = rx.await;
        }
    }
}
