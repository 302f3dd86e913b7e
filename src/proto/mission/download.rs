//! The download sub-machine: MISSION_REQUEST_LIST, MISSION_COUNT, one MISSION_REQUEST_INT per
//! item, the final MISSION_ACK. It also reads a list back to verify an upload whose final
//! ACK was lost or ambiguous.

use super::client::MissionClient;
use super::types::{MissionConfig, MissionError, MissionEvent, MissionResultCode, OpId};
use crate::mission::MissionType;
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

impl MissionClient {
    pub(super) fn download_message(
        &mut self,
        id: OpId,
        d: &mut Download,
        msg: &MavMessage,
        now: Time,
    ) -> DlStep {
        let kind = mav_type(d.kind);
        match msg {
            MavMessage::MISSION_COUNT(c) if c.mission_type == kind => {
                if d.count.is_some() {
                    return DlStep::Continue; // duplicate
                }
                d.count = Some(c.count);
                if c.count == 0 {
                    self.send_ack(d.kind, MavMissionResult::MAV_MISSION_ACCEPTED);
                    return DlStep::Done(Vec::new());
                }
                d.deadline = now + self.cfg.item_timeout;
                self.out.push_back(self.request_item_msg(d.kind, 0));
                DlStep::Continue
            }
            MavMessage::MISSION_ITEM_INT(it) if it.mission_type == kind => {
                self.download_item(id, d, it.clone(), now)
            }
            MavMessage::MISSION_ITEM(it) if it.mission_type == kind => {
                self.download_item(id, d, item_int_from_float(it), now)
            }
            MavMessage::MISSION_ACK(a) if a.mission_type == kind => match a.mavtype {
                MavMissionResult::MAV_MISSION_ACCEPTED
                | MavMissionResult::MAV_MISSION_INVALID_SEQUENCE => DlStep::Continue,
                MavMissionResult::MAV_MISSION_ERROR if d.verify && d.count.is_none() => {
                    // A stale NACK of the upload being verified.
                    DlStep::Continue
                }
                MavMissionResult::MAV_MISSION_ERROR if d.restarts_left > 0 => {
                    self.restart_download(d, now);
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

    pub(super) fn download_item(
        &mut self,
        id: OpId,
        d: &mut Download,
        it: MISSION_ITEM_INT_DATA,
        now: Time,
    ) -> DlStep {
        let Some(count) = d.count else {
            return DlStep::Continue;
        };
        if usize::from(it.seq) != d.items.len() {
            return DlStep::Continue; // duplicate or stale
        }
        d.items.push(it);
        if d.items.len() == usize::from(count) {
            self.send_ack(d.kind, MavMissionResult::MAV_MISSION_ACCEPTED);
            return DlStep::Done(std::mem::take(&mut d.items));
        }
        if !d.verify {
            self.events.push_back(MissionEvent::Progress {
                id,
                done: d.items.len(),
                total: usize::from(count),
            });
        }
        if !self.home_item && !self.cfg.px4_request_gap.is_zero() {
            // PX4: the next request goes out after the gap (see `px4_request_gap`).
            d.gap = true;
            d.deadline = now + self.cfg.px4_request_gap;
            return DlStep::Continue;
        }
        d.deadline = now + self.cfg.item_timeout;
        self.out
            .push_back(self.request_item_msg(d.kind, d.items.len() as u16));
        DlStep::Continue
    }

    /// Start a download over (the vehicle aborted it, or stalled).
    pub(super) fn restart_download(&mut self, d: &mut Download, now: Time) {
        d.restarts_left = d.restarts_left.saturating_sub(1);
        d.gap = false;
        d.count = None;
        d.items.clear();
        d.deadline = now + self.cfg.timeout;
        self.out.push_back(self.request_list_msg(d.kind));
    }

    /// A download's timer: request again, or start over after a stall in the middle of
    /// the list (PX4 has then left its side of the transfer and ignores requests).
    pub(super) fn download_timeout(
        &mut self,
        d: &mut Download,
        stalled: bool,
        now: Time,
    ) -> DlStep {
        if now < d.deadline {
            return DlStep::Continue;
        }
        if d.gap {
            d.gap = false;
            d.deadline = now + self.cfg.item_timeout;
            self.out
                .push_back(self.request_item_msg(d.kind, d.items.len() as u16));
            return DlStep::Continue;
        }
        if stalled && d.count.is_some() && d.restarts_left > 0 {
            self.restart_download(d, now);
            return DlStep::Restarted(format!("no item for {:.0} s", self.cfg.stall.as_secs_f64()));
        }
        match d.count {
            None => {
                d.deadline = now + self.cfg.timeout;
                self.out.push_back(self.request_list_msg(d.kind));
            }
            Some(_) => {
                d.deadline = now + self.cfg.item_timeout;
                self.out
                    .push_back(self.request_item_msg(d.kind, d.items.len() as u16));
            }
        }
        DlStep::Continue
    }
}
