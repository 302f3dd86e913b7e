//! The upload sub-machine: MISSION_COUNT, the items the vehicle requests (and those offered
//! unrequested after a timeout), the final MISSION_ACK, and the read-back when that ACK is
//! lost or ambiguous (see the module docs of [`super`]).

use super::download::{DlStep, Download};
use super::peer::Peer;
use super::types::{
    MAX_OFFERED, MissionError, MissionEvent, MissionOutcome, MissionResultCode, OpId,
};
use crate::mission::item::{MissionItem, MissionType};
use crate::mission::wire::{compare_items, from_wire_list, mav_type};
use crate::time::Time;
use mavlink::dialects::ardupilotmega::{MISSION_ITEM_INT_DATA, MavMessage, MavMissionResult};

/// What a step of an upload led to.
pub(super) enum UpStep {
    Continue,
    /// Started over with MISSION_COUNT, or the read-back started over (why).
    Restarted(String),
    Finish(Result<MissionOutcome, MissionError>),
}

/// Where an upload stands.
#[derive(Debug)]
pub(super) enum UpPhase {
    /// MISSION_COUNT sent, waiting for the first request.
    Count,
    /// Items being requested.
    Items,
    /// Final ACK lost or ambiguous: reading the list back.
    Verify(Box<Download>),
}

/// The upload sub-machine's state.
#[derive(Debug)]
pub(super) struct Upload {
    pub(super) kind: MissionType,
    pub(super) user: Vec<MissionItem>,
    pub(super) wire: Vec<MISSION_ITEM_INT_DATA>,
    pub(super) requested: Vec<bool>,
    pub(super) n_requested: usize,
    /// Items sent at least once (requested or offered) in this attempt.
    pub(super) sent: Vec<bool>,
    pub(super) n_sent: usize,
    /// Items sent at least once in any attempt of this operation. After a restart the
    /// vehicle may still be in (and complete) the transfer of an earlier attempt, whose
    /// items are the same wire list.
    pub(super) ever_sent: Vec<bool>,
    pub(super) n_ever_sent: usize,
    /// MAV_MISSION_ACCEPTED answers that could not be for this operation (not every item
    /// was ever sent): stale ACKs of an earlier operation, or a vehicle whose transfer
    /// state is not ours.
    pub(super) stale_accepts: u32,
    pub(super) last_sent: Option<u16>,
    pub(super) phase: UpPhase,
    /// When the last item (or MISSION_COUNT) is sent again.
    pub(super) deadline: Time,
    /// Timeouts since the last new request (how many items to offer ahead).
    pub(super) idle_timeouts: u32,
    pub(super) nack: Option<MavMissionResult>,
    pub(super) verify_returns: u32,
    /// MAV_MISSION_ERROR answers to MISSION_COUNT in a row (PX4: busy with a transfer).
    pub(super) busy_answers: u32,
    /// Restarts from scratch left.
    pub(super) restarts_left: u32,
}

impl Upload {
    /// Record that wire item `i` went out (in this attempt and in the operation).
    pub(super) fn mark_sent(&mut self, i: usize) {
        if !self.sent[i] {
            self.sent[i] = true;
            self.n_sent += 1;
        }
        if !self.ever_sent[i] {
            self.ever_sent[i] = true;
            self.n_ever_sent += 1;
        }
    }

    /// A received mission message.
    pub(super) fn on_message(
        &mut self,
        p: &mut Peer,
        id: OpId,
        msg: &MavMessage,
        now: Time,
    ) -> UpStep {
        let u = self;
        let kind = mav_type(u.kind);
        let request = match msg {
            MavMessage::MISSION_REQUEST(r) if r.mission_type == kind => Some(r.seq),
            MavMessage::MISSION_REQUEST_INT(r) if r.mission_type == kind => Some(r.seq),
            _ => None,
        };
        if let Some(seq) = request {
            if usize::from(seq) >= u.wire.len() {
                p.ignored += 1;
                return UpStep::Continue;
            }
            if matches!(u.phase, UpPhase::Verify(_)) {
                // The vehicle is still receiving: back to answering requests.
                if u.verify_returns >= 2 {
                    return UpStep::Finish(Err(MissionError::Unconfirmed {
                        detail:
                            "the vehicle keeps requesting items after the transfer looked complete"
                                .into(),
                    }));
                }
                u.verify_returns += 1;
                u.nack = None;
            }
            u.phase = UpPhase::Items;
            u.busy_answers = 0;
            let i = usize::from(seq);
            if !u.requested[i] {
                u.requested[i] = true;
                u.n_requested += 1;
                u.idle_timeouts = 0;
                u.deadline = now + p.cfg.timeout;
                p.events.push_back(MissionEvent::Progress {
                    id,
                    done: u.n_requested,
                    total: u.wire.len(),
                });
            }
            u.last_sent = Some(seq);
            u.mark_sent(i);
            p.out
                .push_back(MavMessage::MISSION_ITEM_INT(u.wire[i].clone()));
            return UpStep::Continue;
        }
        if let UpPhase::Verify(d) = &mut u.phase {
            return match d.on_message(p, id, msg, now) {
                DlStep::Continue => UpStep::Continue,
                DlStep::Restarted(why) => UpStep::Restarted(why),
                DlStep::Done(wire) => UpStep::Finish(u.verify_result(p, &wire)),
                DlStep::Failed(e) => UpStep::Finish(u.verify_failed(e)),
            };
        }
        let MavMessage::MISSION_ACK(ack) = msg else {
            return UpStep::Continue;
        };
        if ack.mission_type != kind {
            return UpStep::Continue;
        }
        // Every item reached the vehicle at least once as far as we know: requested ones
        // were answered, offered ones may have been taken.
        let all_sent = u.n_sent == u.wire.len();
        let rejected = |r| {
            UpStep::Finish(Err(MissionError::Rejected {
                op: "upload",
                result: MissionResultCode(r),
                seq: u.last_sent,
            }))
        };
        match ack.mavtype {
            MavMissionResult::MAV_MISSION_ACCEPTED if all_sent => {
                UpStep::Finish(Ok(MissionOutcome::Uploaded {
                    count: u.user.len(),
                    verified_by_download: false,
                }))
            }
            MavMissionResult::MAV_MISSION_ACCEPTED if u.n_ever_sent == u.wire.len() => {
                // Every item went out in some attempt, but not in this one: after a restart
                // the vehicle may have gone on with an earlier attempt's transfer (PX4 keeps
                // requesting the next item of the transfer it is in) and accepted the list.
                // Ambiguous: read the list back (seen in the property test: a restart on a
                // PX4 "busy" ERROR, then ACCEPTED for the earlier transfer, ignored, and the
                // last item resent and ACCEPTED again until the overall deadline).
                u.begin_verify(p, now);
                UpStep::Continue
            }
            MavMissionResult::MAV_MISSION_ACCEPTED => {
                // Premature or stale: keep waiting for requests, a bounded number of times.
                p.ignored += 1;
                u.stale_accepts += 1;
                if u.stale_accepts <= p.cfg.restarts + 1 {
                    return UpStep::Continue;
                }
                u.stale_accepts = 0;
                if u.restarts_left == 0 {
                    return UpStep::Finish(Err(MissionError::Unconfirmed {
                        detail: "the vehicle keeps accepting a transfer that did not carry all \
                                 our items"
                            .into(),
                    }));
                }
                u.restart(p, now);
                UpStep::Restarted("the vehicle accepted a transfer we did not complete".into())
            }
            MavMissionResult::MAV_MISSION_INVALID_SEQUENCE => {
                // ArduPilot's answer to a duplicated item; the transfer goes on.
                UpStep::Continue
            }
            MavMissionResult::MAV_MISSION_ERROR if matches!(u.phase, UpPhase::Count) => {
                // PX4 answers a MISSION_COUNT with ERROR while it is still in a transfer
                // (`handle_mission_count`: "busy, already receiving"); it ends that one
                // after 5 s of silence. Resent at the next timeout, a bounded number of times.
                u.busy_answers += 1;
                if u.busy_answers > p.cfg.restarts + 1 {
                    return rejected(ack.mavtype);
                }
                UpStep::Continue
            }
            r @ (MavMissionResult::MAV_MISSION_OPERATION_CANCELLED
            | MavMissionResult::MAV_MISSION_ERROR)
                if !all_sent =>
            {
                // The vehicle ended its side: ArduPilot cancels after 8 s without an item
                // and answers items after that with ERROR. Start over.
                if u.restarts_left == 0 {
                    return rejected(r);
                }
                u.restart(p, now);
                UpStep::Restarted(format!("the vehicle answered {r:?}"))
            }
            MavMissionResult::MAV_MISSION_OPERATION_CANCELLED => rejected(ack.mavtype),
            r if all_sent => {
                // Could be a real refusal of the last item, or ArduPilot's "not receiving"
                // answer to a repeated last item after its ACK was lost: read back.
                u.nack = Some(r);
                u.begin_verify(p, now);
                UpStep::Continue
            }
            r => rejected(r),
        }
    }

    /// Start an upload over from MISSION_COUNT (the vehicle cancelled or stalled).
    pub(super) fn restart(&mut self, p: &mut Peer, now: Time) {
        let u = self;
        u.restarts_left = u.restarts_left.saturating_sub(1);
        u.requested.fill(false);
        u.sent.fill(false);
        u.n_requested = 0;
        u.n_sent = 0;
        u.last_sent = None;
        u.phase = UpPhase::Count;
        u.idle_timeouts = 0;
        u.nack = None;
        u.busy_answers = 0;
        u.deadline = now + p.cfg.timeout;
        p.out.push_back(p.count_msg(u.kind, u.wire.len() as u16));
    }

    pub(super) fn begin_verify(&mut self, p: &mut Peer, now: Time) {
        let u = self;
        let d = Download::new(u.kind, now + p.cfg.timeout, true, p.cfg.restarts);
        p.out.push_back(p.request_list_msg(u.kind));
        u.phase = UpPhase::Verify(Box::new(d));
    }

    fn verify_result(
        &self,
        p: &Peer,
        wire: &[MISSION_ITEM_INT_DATA],
    ) -> Result<MissionOutcome, MissionError> {
        let u = self;
        let (items, _home) = from_wire_list(u.kind, wire, p.home_item);
        match compare_items(&u.user, &items, p.home_item) {
            Ok(()) => Ok(MissionOutcome::Uploaded {
                count: u.user.len(),
                verified_by_download: true,
            }),
            Err(detail) => match u.nack {
                Some(r) => Err(MissionError::Rejected {
                    op: "upload",
                    result: MissionResultCode(r),
                    seq: u.last_sent,
                }),
                None => Err(MissionError::Unconfirmed {
                    detail: detail.to_string(),
                }),
            },
        }
    }

    fn verify_failed(&self, e: MissionError) -> Result<MissionOutcome, MissionError> {
        let u = self;
        match u.nack {
            Some(r) => Err(MissionError::Rejected {
                op: "upload",
                result: MissionResultCode(r),
                seq: u.last_sent,
            }),
            None => Err(MissionError::Unconfirmed {
                detail: format!("could not read the list back: {e}"),
            }),
        }
    }

    pub(super) fn on_timeout(&mut self, p: &mut Peer, stalled: bool, now: Time) -> UpStep {
        let u = self;
        if let UpPhase::Verify(d) = &mut u.phase {
            return match d.on_timeout(p, stalled, now) {
                DlStep::Continue | DlStep::Done(_) => UpStep::Continue,
                DlStep::Restarted(why) => UpStep::Restarted(format!("read-back: {why}")),
                DlStep::Failed(e) => UpStep::Finish(u.verify_failed(e)),
            };
        }
        if now < u.deadline {
            return UpStep::Continue;
        }
        let all_sent = u.n_sent == u.wire.len();
        if stalled && matches!(u.phase, UpPhase::Items) {
            if all_sent {
                // Everything went out and the final ACK never came: read the list back.
                u.begin_verify(p, now);
                return UpStep::Continue;
            }
            if u.restarts_left > 0 {
                u.restart(p, now);
                return UpStep::Restarted(format!(
                    "no request for {:.0} s",
                    p.cfg.stall.as_secs_f64()
                ));
            }
        }
        u.idle_timeouts += 1;
        u.deadline = now + p.cfg.timeout;
        let highest = u.requested.iter().rposition(|r| *r);
        match (&u.phase, highest) {
            (UpPhase::Items, Some(h)) => {
                // Resend the highest item requested (our answer may have been lost) and,
                // if the vehicle's request for the next one may have been lost instead,
                // offer that one too — and one more for every further timeout without
                // progress. See "A lost request" in the module docs.
                p.out
                    .push_back(MavMessage::MISSION_ITEM_INT(u.wire[h].clone()));
                let ahead = (u.idle_timeouts as usize).clamp(1, MAX_OFFERED);
                for i in (h + 1..u.wire.len()).take(ahead) {
                    u.mark_sent(i);
                    p.out
                        .push_back(MavMessage::MISSION_ITEM_INT(u.wire[i].clone()));
                }
            }
            _ => {
                p.out.push_back(p.count_msg(u.kind, u.wire.len() as u16));
            }
        }
        UpStep::Continue
    }
}
