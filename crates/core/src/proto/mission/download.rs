//! The download sub-machine: MISSION_REQUEST_LIST, MISSION_COUNT, one MISSION_REQUEST_INT per
//! item, the final MISSION_ACK. It also reads a list back to verify an upload whose final
//! ACK was lost or ambiguous.

use super::peer::Peer;
use super::types::{MissionConfig, MissionError, MissionEvent, MissionResultCode, OpId};
use crate::mission::item::MissionType;
use crate::mission::wire::{item_int_from_float, mav_type};
use crate::time::Time;
use mavlink::dialects::ardupilotmega::{MISSION_ITEM_INT_DATA, MavMessage, MavMissionResult};
use std::time::Duration;

/// The download sub-machine (also used to verify an upload).
#[derive(Debug)]
pub(super) struct Download {
    pub(super) kind: MissionType,
    pub(super) count: Option<u16>,
    pub(super) items: Vec<MISSION_ITEM_INT_DATA>,
    /// When the current request is sent again.
    pub(super) deadline: Time,
    /// In verification mode, stale upload NACKs (ERROR / INVALID_SEQUENCE) are ignored.
    pub(super) verify: bool,
    /// Restarts left after the vehicle aborted or stalled.
    pub(super) restarts_left: u32,
    /// The next request waits for the end of [`MissionConfig::px4_request_gap`] (the
    /// deadline), not for a timeout.
    pub(super) gap: bool,
}

/// What a step of a download led to.
pub(super) enum DlStep {
    Continue,
    /// Started over with MISSION_REQUEST_LIST (why).
    Restarted(String),
    Done(Vec<MISSION_ITEM_INT_DATA>),
    Failed(MissionError),
}

/// The longest a download of `count` items may take, all restarts included: each attempt
/// may wait [`MissionConfig::silence`] and four item timeouts per item.
pub(super) fn download_budget(cfg: &MissionConfig, count: usize) -> Duration {
    let per_attempt = cfg.silence + cfg.item_timeout * 4 * count as u32;
    per_attempt * (cfg.restarts + 1)
}

impl Download {
    /// A download of the list `kind` whose first step times out at `deadline`.
    pub(super) fn new(kind: MissionType, deadline: Time, verify: bool, restarts: u32) -> Download {
        Download {
            kind,
            count: None,
            items: Vec::new(),
            deadline,
            verify,
            restarts_left: restarts,
            gap: false,
        }
    }
}

impl Download {
    /// A received mission message.
    pub(super) fn on_message(
        &mut self,
        p: &mut Peer,
        id: OpId,
        msg: &MavMessage,
        now: Time,
    ) -> DlStep {
        let d = self;
        let kind = mav_type(d.kind);
        match msg {
            MavMessage::MISSION_COUNT(c) if c.mission_type == kind => {
                if d.count.is_some() {
                    return DlStep::Continue; // duplicate
                }
                d.count = Some(c.count);
                if c.count == 0 {
                    p.send_ack(d.kind, MavMissionResult::MAV_MISSION_ACCEPTED);
                    return DlStep::Done(Vec::new());
                }
                d.deadline = now + p.cfg.item_timeout;
                p.out.push_back(p.request_item_msg(d.kind, 0));
                DlStep::Continue
            }
            MavMessage::MISSION_ITEM_INT(it) if it.mission_type == kind => {
                d.on_item(p, id, it.clone(), now)
            }
            MavMessage::MISSION_ITEM(it) if it.mission_type == kind => {
                d.on_item(p, id, item_int_from_float(it), now)
            }
            MavMessage::MISSION_ACK(a) if a.mission_type == kind => match a.mavtype {
                MavMissionResult::MAV_MISSION_ACCEPTED
                | MavMissionResult::MAV_MISSION_INVALID_SEQUENCE => DlStep::Continue,
                MavMissionResult::MAV_MISSION_ERROR if d.verify && d.count.is_none() => {
                    // A stale NACK of the upload being verified.
                    DlStep::Continue
                }
                MavMissionResult::MAV_MISSION_ERROR if d.restarts_left > 0 => {
                    d.restart(p, now);
                    DlStep::Restarted("the vehicle aborted the download (MAV_MISSION_ERROR)".into())
                }
                r => DlStep::Failed(MissionError::Rejected {
                    op: "download",
                    result: MissionResultCode(r),
                    seq: Some(d.items.len() as u16),
                }),
            },
            _ => DlStep::Continue,
        }
    }

    fn on_item(&mut self, p: &mut Peer, id: OpId, it: MISSION_ITEM_INT_DATA, now: Time) -> DlStep {
        let d = self;
        let Some(count) = d.count else {
            return DlStep::Continue;
        };
        if usize::from(it.seq) != d.items.len() {
            return DlStep::Continue; // duplicate or stale
        }
        d.items.push(it);
        if d.items.len() == usize::from(count) {
            p.send_ack(d.kind, MavMissionResult::MAV_MISSION_ACCEPTED);
            return DlStep::Done(std::mem::take(&mut d.items));
        }
        if !d.verify {
            p.events.push_back(MissionEvent::Progress {
                id,
                done: d.items.len(),
                total: usize::from(count),
            });
        }
        if !p.home_item && !p.cfg.px4_request_gap.is_zero() {
            // PX4: the next request goes out after the gap (see `px4_request_gap`).
            d.gap = true;
            d.deadline = now + p.cfg.px4_request_gap;
            return DlStep::Continue;
        }
        d.deadline = now + p.cfg.item_timeout;
        p.out
            .push_back(p.request_item_msg(d.kind, d.items.len() as u16));
        DlStep::Continue
    }

    /// Start a download over (the vehicle aborted it, or stalled).
    pub(super) fn restart(&mut self, p: &mut Peer, now: Time) {
        let d = self;
        d.restarts_left = d.restarts_left.saturating_sub(1);
        d.gap = false;
        d.count = None;
        d.items.clear();
        d.deadline = now + p.cfg.timeout;
        p.out.push_back(p.request_list_msg(d.kind));
    }

    /// A download's timer: request again, or start over after a stall in the middle of
    /// the list (PX4 has then left its side of the transfer and ignores requests).
    pub(super) fn on_timeout(&mut self, p: &mut Peer, stalled: bool, now: Time) -> DlStep {
        let d = self;
        if now < d.deadline {
            return DlStep::Continue;
        }
        if d.gap {
            d.gap = false;
            d.deadline = now + p.cfg.item_timeout;
            p.out
                .push_back(p.request_item_msg(d.kind, d.items.len() as u16));
            return DlStep::Continue;
        }
        if stalled && d.count.is_some() && d.restarts_left > 0 {
            d.restart(p, now);
            return DlStep::Restarted(format!("no item for {:.0} s", p.cfg.stall.as_secs_f64()));
        }
        match d.count {
            None => {
                d.deadline = now + p.cfg.timeout;
                p.out.push_back(p.request_list_msg(d.kind));
            }
            Some(_) => {
                d.deadline = now + p.cfg.item_timeout;
                p.out
                    .push_back(p.request_item_msg(d.kind, d.items.len() as u16));
            }
        }
        DlStep::Continue
    }
}
