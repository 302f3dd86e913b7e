//! The client: one operation at a time, a queue behind it, the settle time between two, and
//! the dispatch of received messages and timers to the upload and download sub-machines.

use super::download::{DlStep, Download, download_budget};
use super::peer::Peer;
use super::types::{
    MissionConfig, MissionError, MissionEvent, MissionOp, MissionOutcome, MissionResultCode, OpId,
};
use super::upload::{UpPhase, UpStep, Upload};
use crate::mission::item::MissionType;
use crate::mission::wire::{build_wire, from_wire_list, mav_type};
use crate::proto::Endpoint;
use crate::time::Time;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::{
    MISSION_CLEAR_ALL_DATA, MISSION_SET_CURRENT_DATA, MavMessage, MavMissionResult,
};
use std::collections::VecDeque;
use std::time::Duration;

/// The state of the active operation, by kind.
#[derive(Debug)]
enum ActiveKind {
    Upload(Upload),
    Download(Download),
    Clear {
        kind: MissionType,
        deadline: Time,
    },
    SetCurrent {
        user_seq: u16,
        wire_seq: u16,
        deadline: Time,
    },
}

/// The active operation.
#[derive(Debug)]
struct Active {
    id: OpId,
    name: &'static str,
    /// The overall deadline (a download's grows when the vehicle tells its count).
    overall: Time,
    budget: Duration,
    /// The last mission-protocol message from the vehicle for this operation.
    last_answer: Time,
    /// The last answer or restart: a stall is measured from here.
    quiet_since: Time,
    kind: ActiveKind,
}

impl Active {
    /// What the operation is waiting for, for a timeout's message.
    fn waiting_for(&self) -> String {
        let dl = |d: &Download| match d.count {
            None => "MISSION_COUNT after MISSION_REQUEST_LIST".to_string(),
            Some(_) => format!("MISSION_ITEM_INT {}", d.items.len()),
        };
        match &self.kind {
            ActiveKind::Upload(u) => match &u.phase {
                UpPhase::Count => "MISSION_REQUEST for item 0 after MISSION_COUNT".to_string(),
                UpPhase::Items if u.n_sent == u.wire.len() => "the final MISSION_ACK".to_string(),
                UpPhase::Items => format!(
                    "MISSION_REQUEST for item {} (after item {})",
                    u.requested.iter().position(|r| !r).unwrap_or(0),
                    u.last_sent.map(|s| s.to_string()).unwrap_or_default()
                ),
                UpPhase::Verify(d) => format!("{} (reading the list back)", dl(d)),
            },
            ActiveKind::Download(d) => dl(d),
            ActiveKind::Clear { .. } => "MISSION_ACK after MISSION_CLEAR_ALL".to_string(),
            ActiveKind::SetCurrent { .. } => {
                "MISSION_CURRENT after MISSION_SET_CURRENT".to_string()
            }
        }
    }
}

/// The GCS side of the mission protocol for one vehicle.
#[derive(Debug)]
pub struct MissionClient {
    /// Endpoints, configuration, outgoing messages and events, shared with the transfer
    /// machines.
    peer: Peer,
    queue: VecDeque<(OpId, MissionOp)>,
    active: Option<Active>,
    settle_until: Time,
    next_id: OpId,
}

impl MissionClient {
    /// A client speaking as `gcs` to the autopilot `target`. `home_item`: the autopilot
    /// keeps home as mission item 0 (ArduPilot; see [`crate::proto::flavour::Flavour`]).
    pub fn new(gcs: Endpoint, target: Endpoint, home_item: bool, cfg: MissionConfig) -> Self {
        MissionClient {
            peer: Peer::new(gcs, target, home_item, cfg),
            queue: VecDeque::new(),
            active: None,
            settle_until: Time::ZERO,
            next_id: 1,
        }
    }

    /// Mission messages dropped because they matched no operation (late duplicates).
    pub fn ignored(&self) -> u64 {
        self.peer.ignored
    }

    /// Change whether home is item 0 (when the flavour becomes known).
    pub fn set_home_item(&mut self, home_item: bool) {
        self.peer.home_item = home_item;
    }

    /// Whether home is mission item 0 for this vehicle.
    pub fn home_item(&self) -> bool {
        self.peer.home_item
    }

    /// The configuration.
    pub fn config(&self) -> &MissionConfig {
        &self.peer.cfg
    }

    /// No operation active or queued.
    pub fn is_idle(&self) -> bool {
        self.active.is_none() && self.queue.is_empty()
    }

    /// The longest an operation may take before it fails with
    /// [`MissionError::OverBudget`]; it grows with the number of items. Each attempt of a
    /// transfer may wait [`MissionConfig::silence`], plus two answer timeouts per item of an
    /// upload (and a read-back), four item timeouts per item of a download; a download's
    /// deadline is set from the count the vehicle gives (this bound assumes the most a list
    /// can hold).
    pub fn budget(cfg: &MissionConfig, op: &MissionOp) -> Duration {
        match op {
            MissionOp::Upload { items, .. } => {
                let n = items.len() + 1;
                let per_attempt = cfg.silence + cfg.timeout * 2 * n as u32;
                per_attempt * (cfg.restarts + 1) + download_budget(cfg, n)
            }
            MissionOp::Download { .. } => download_budget(cfg, usize::from(u16::MAX)),
            MissionOp::Clear { .. } | MissionOp::SetCurrent { .. } => cfg.silence + cfg.timeout,
        }
    }

    /// Queue an operation; returns its id. It starts when the previous one has finished
    /// and the settle time has passed.
    pub fn start(&mut self, op: MissionOp, now: Time) -> OpId {
        let id = self.next_id;
        self.next_id += 1;
        self.queue.push_back((id, op));
        self.maybe_begin(now);
        id
    }

    /// Cancel an operation (queued or active). An active upload or download is ended
    /// with MAV_MISSION_OPERATION_CANCELLED sent to the vehicle, as MAVSDK does.
    pub fn cancel(&mut self, id: OpId, now: Time) {
        if let Some(pos) = self.queue.iter().position(|(i, _)| *i == id) {
            if let Some((_, op)) = self.queue.remove(pos) {
                self.peer.events.push_back(MissionEvent::Done {
                    id,
                    result: Err(MissionError::Cancelled { op: op.name() }),
                });
            }
            return;
        }
        if self.active.as_ref().is_some_and(|a| a.id == id) {
            let kind = match &self.active.as_ref().map(|a| &a.kind) {
                Some(ActiveKind::Upload(u)) => Some(u.kind),
                Some(ActiveKind::Download(d)) => Some(d.kind),
                _ => None,
            };
            if let Some(kind) = kind {
                self.peer
                    .send_ack(kind, MavMissionResult::MAV_MISSION_OPERATION_CANCELLED);
            }
            let name = self.active.as_ref().map(|a| a.name).unwrap_or("operation");
            self.finish(Err(MissionError::Cancelled { op: name }), now);
        }
    }

    /// The next message to send.
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.peer.out.pop_front()
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<MissionEvent> {
        self.peer.events.pop_front()
    }

    /// When [`MissionClient::handle_timeout`] must be called next.
    pub fn poll_timeout(&self) -> Option<Time> {
        match &self.active {
            Some(a) => {
                let step = match &a.kind {
                    ActiveKind::Upload(u) => match &u.phase {
                        UpPhase::Verify(d) => d.deadline,
                        _ => u.deadline,
                    },
                    ActiveKind::Download(d) => d.deadline,
                    ActiveKind::Clear { deadline, .. } => *deadline,
                    ActiveKind::SetCurrent { deadline, .. } => *deadline,
                };
                Some(
                    step.min(a.overall)
                        .min(a.last_answer + self.peer.cfg.silence),
                )
            }
            None if !self.queue.is_empty() => Some(self.settle_until),
            None => None,
        }
    }

    fn maybe_begin(&mut self, now: Time) {
        if self.active.is_some() || now < self.settle_until {
            return;
        }
        let Some((id, op)) = self.queue.pop_front() else {
            return;
        };
        let budget = match op {
            // Set from the count (see `download_item`'s caller); until then the silence
            // budget ends a download that never gets one.
            MissionOp::Download { .. } => self.peer.cfg.silence + self.peer.cfg.timeout,
            _ => MissionClient::budget(&self.peer.cfg, &op),
        };
        let name = op.name();
        let kind = match op {
            MissionOp::Upload { kind, items, home } => {
                match build_wire(kind, &items, home.as_ref(), self.peer.home_item) {
                    Ok(mut wire) => {
                        for w in &mut wire {
                            w.target_system = self.peer.target.sysid;
                            w.target_component = self.peer.target.compid;
                        }
                        let n = wire.len();
                        ActiveKind::Upload(Upload {
                            kind,
                            user: items,
                            requested: vec![false; n],
                            wire,
                            n_requested: 0,
                            sent: vec![false; n],
                            n_sent: 0,
                            ever_sent: vec![false; n],
                            n_ever_sent: 0,
                            stale_accepts: 0,
                            last_sent: None,
                            phase: UpPhase::Count,
                            deadline: now + self.peer.cfg.timeout,
                            idle_timeouts: 0,
                            nack: None,
                            verify_returns: 0,
                            busy_answers: 0,
                            restarts_left: self.peer.cfg.restarts,
                        })
                    }
                    Err(e) => {
                        self.peer.events.push_back(MissionEvent::Done {
                            id,
                            result: Err(e.into()),
                        });
                        return self.maybe_begin(now);
                    }
                }
            }
            MissionOp::Download { kind } => ActiveKind::Download(Download::new(
                kind,
                now + self.peer.cfg.timeout,
                false,
                self.peer.cfg.restarts,
            )),
            MissionOp::Clear { kind } => ActiveKind::Clear {
                kind,
                deadline: now + self.peer.cfg.timeout,
            },
            MissionOp::SetCurrent { seq } => {
                let wire_seq = if self.peer.home_item {
                    seq.saturating_add(1)
                } else {
                    seq
                };
                ActiveKind::SetCurrent {
                    user_seq: seq,
                    wire_seq,
                    deadline: now + self.peer.cfg.timeout,
                }
            }
        };
        self.active = Some(Active {
            id,
            name,
            overall: now + budget,
            budget,
            last_answer: now,
            quiet_since: now,
            kind,
        });
        self.send_initial();
    }

    /// Send the first message of the active operation (also used for resends).
    fn send_initial(&mut self) {
        let Some(a) = &self.active else { return };
        let msg = match &a.kind {
            ActiveKind::Upload(u) => self.peer.count_msg(u.kind, u.wire.len() as u16),
            ActiveKind::Download(d) => self.peer.request_list_msg(d.kind),
            ActiveKind::Clear { kind, .. } => {
                MavMessage::MISSION_CLEAR_ALL(MISSION_CLEAR_ALL_DATA {
                    target_system: self.peer.target.sysid,
                    target_component: self.peer.target.compid,
                    mission_type: mav_type(*kind),
                })
            }
            ActiveKind::SetCurrent { wire_seq, .. } => {
                MavMessage::MISSION_SET_CURRENT(MISSION_SET_CURRENT_DATA {
                    seq: *wire_seq,
                    target_system: self.peer.target.sysid,
                    target_component: self.peer.target.compid,
                })
            }
        };
        self.peer.out.push_back(msg);
    }

    fn finish(&mut self, result: Result<MissionOutcome, MissionError>, now: Time) {
        if let Some(a) = self.active.take() {
            self.peer
                .events
                .push_back(MissionEvent::Done { id: a.id, result });
            self.settle_until = now + self.peer.cfg.settle;
        }
        self.maybe_begin(now);
    }

    /// A received message. Messages not from the target autopilot, not addressed to us,
    /// or not part of the mission protocol are ignored.
    pub fn handle_message(&mut self, header: &MavHeader, msg: &MavMessage, now: Time) {
        if Endpoint::of(header) != self.peer.target {
            return;
        }
        let for_us = |ts: u8, tc: u8| self.peer.gcs.is_addressed_by(ts, tc);
        let relevant = match msg {
            MavMessage::MISSION_REQUEST(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_REQUEST_INT(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_ACK(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_COUNT(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_ITEM_INT(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_ITEM(m) => for_us(m.target_system, m.target_component),
            MavMessage::MISSION_CURRENT(_) => true,
            _ => false,
        };
        if !relevant {
            return;
        }
        if self.active.is_none() {
            if !matches!(msg, MavMessage::MISSION_CURRENT(_)) {
                self.peer.ignored += 1;
            }
            return;
        }
        let Some(mut active) = self.active.take() else {
            return;
        };
        // MISSION_CURRENT is telemetry, streamed whatever we do: not an answer.
        if !matches!(msg, MavMessage::MISSION_CURRENT(_)) {
            active.last_answer = now;
            active.quiet_since = now;
        }
        let id = active.id;
        let outcome = match &mut active.kind {
            ActiveKind::Upload(u) => u.on_message(&mut self.peer, id, msg, now),
            ActiveKind::Download(d) => {
                let had_count = d.count.is_some();
                let step = d.on_message(&mut self.peer, id, msg, now);
                if !had_count && let Some(c) = d.count {
                    // The vehicle told its count: the deadline now follows the list's size.
                    let budget = download_budget(&self.peer.cfg, usize::from(c));
                    active.budget = active.budget.max(budget);
                    active.overall = active.overall.max(now + budget);
                }
                match step {
                    DlStep::Continue => UpStep::Continue,
                    DlStep::Restarted(why) => UpStep::Restarted(why),
                    DlStep::Done(wire) => {
                        let (items, home) = from_wire_list(d.kind, &wire, self.peer.home_item);
                        UpStep::Finish(Ok(MissionOutcome::Downloaded { items, home }))
                    }
                    DlStep::Failed(e) => UpStep::Finish(Err(e)),
                }
            }
            ActiveKind::Clear { kind, .. } => match msg {
                MavMessage::MISSION_ACK(a) if a.mission_type == mav_type(*kind) => {
                    match a.mavtype {
                        MavMissionResult::MAV_MISSION_ACCEPTED => {
                            UpStep::Finish(Ok(MissionOutcome::Cleared))
                        }
                        MavMissionResult::MAV_MISSION_INVALID_SEQUENCE => UpStep::Continue,
                        r => UpStep::Finish(Err(MissionError::Rejected {
                            op: "clear",
                            result: MissionResultCode(r),
                            seq: None,
                        })),
                    }
                }
                _ => UpStep::Continue,
            },
            ActiveKind::SetCurrent {
                user_seq, wire_seq, ..
            } => match msg {
                MavMessage::MISSION_CURRENT(c) if c.seq == *wire_seq => {
                    UpStep::Finish(Ok(MissionOutcome::CurrentSet { seq: *user_seq }))
                }
                _ => UpStep::Continue,
            },
        };
        self.active = Some(active);
        self.after_step(outcome, now);
    }

    /// Report a restart or finish the operation, as a step decided.
    fn after_step(&mut self, step: UpStep, now: Time) {
        match step {
            UpStep::Continue => {}
            UpStep::Restarted(reason) => {
                if let Some(a) = self.active.as_mut() {
                    a.quiet_since = now;
                    let left = match &a.kind {
                        ActiveKind::Upload(u) => match &u.phase {
                            UpPhase::Verify(d) => d.restarts_left,
                            _ => u.restarts_left,
                        },
                        ActiveKind::Download(d) => d.restarts_left,
                        _ => 0,
                    };
                    self.peer.events.push_back(MissionEvent::Restarted {
                        id: a.id,
                        reason,
                        left,
                    });
                }
            }
            UpStep::Finish(result) => self.finish(result, now),
        }
    }

    /// A MISSION_ITEM(_INT) from the target that did not decode (e.g. a command number our
    /// dialect lacks): fails a download waiting for that item with a precise error instead
    /// of timing out.
    pub fn handle_unparsed_item(&mut self, from: Endpoint, seq: u16, detail: &str, now: Time) {
        if from != self.peer.target {
            return;
        }
        let waiting = match self.active.as_ref().map(|a| &a.kind) {
            Some(ActiveKind::Download(d)) => d.count.is_some() && d.items.len() == usize::from(seq),
            Some(ActiveKind::Upload(Upload {
                phase: UpPhase::Verify(d),
                ..
            })) => d.count.is_some() && d.items.len() == usize::from(seq),
            _ => false,
        };
        if waiting {
            self.finish(
                Err(MissionError::Undecodable {
                    seq,
                    detail: detail.to_string(),
                }),
                now,
            );
        }
    }

    /// Advance timers: resend, start over, give up, or start the next queued operation.
    pub fn handle_timeout(&mut self, now: Time) {
        let Some(mut active) = self.active.take() else {
            self.maybe_begin(now);
            return;
        };
        if now >= active.overall {
            let (name, budget) = (active.name, active.budget);
            self.active = Some(active);
            self.finish(
                Err(MissionError::OverBudget {
                    op: name,
                    budget_ms: budget.as_millis() as u64,
                }),
                now,
            );
            return;
        }
        let silent = now.saturating_since(active.last_answer);
        if silent >= self.peer.cfg.silence {
            let err = MissionError::Timeout {
                op: active.name,
                waiting_for: active.waiting_for(),
                silent_ms: silent.as_millis() as u64,
            };
            self.active = Some(active);
            self.finish(Err(err), now);
            return;
        }
        let stalled = now.saturating_since(active.quiet_since) >= self.peer.cfg.stall;
        let timeout = self.peer.cfg.timeout;
        let step = match &mut active.kind {
            ActiveKind::Upload(u) => u.on_timeout(&mut self.peer, stalled, now),
            ActiveKind::Download(d) => match d.on_timeout(&mut self.peer, stalled, now) {
                DlStep::Continue | DlStep::Done(_) => UpStep::Continue,
                DlStep::Restarted(why) => UpStep::Restarted(why),
                DlStep::Failed(e) => UpStep::Finish(Err(e)),
            },
            ActiveKind::Clear { deadline, .. } | ActiveKind::SetCurrent { deadline, .. } => {
                if now >= *deadline {
                    *deadline = now + timeout;
                    self.active = Some(active);
                    self.send_initial();
                    return;
                }
                UpStep::Continue
            }
        };
        self.active = Some(active);
        self.after_step(step, now);
    }
}
