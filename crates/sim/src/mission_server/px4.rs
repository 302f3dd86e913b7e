//! PX4's side of the mission protocol: one transfer at a time (IDLE / GETLIST / SENDLIST),
//! int mode, double-buffered lists (see the module documentation of `mission_server`).

use super::*;

/// PX4's refusal: a critical STATUSTEXT, then a MISSION_ACK with `result` to `to` for list
/// `t` (the order of `MavlinkMissionManager`'s `_mavlink.send_statustext_critical` and
/// `send_mission_ack` in `mavlink_mission.cpp`).
fn refuse(
    core: &mut Core,
    to: Endpoint,
    t: MissionType,
    statustext: &str,
    result: mav::MavMissionResult,
) {
    core.outbox
        .push_back(text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, statustext));
    core.outbox.push_back(ack_to(to, t, result, 0));
}

/// PX4's answer to a MISSION_REQUEST(_INT) it did not expect during a download: the
/// download ends, MISSION_ACK ERROR, then "WPM: REJ. CMD: Req. WP was unexpected" (this
/// branch acknowledges before the text).
fn unexpected_request(core: &mut Core, to: Endpoint, t: MissionType) {
    core.outbox
        .push_back(ack_to(to, t, mav::MavMissionResult::MAV_MISSION_ERROR, 0));
    core.outbox.push_back(text(
        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
        "WPM: REJ. CMD: Req. WP was unexpected",
    ));
}

impl Px4State {
    pub(super) fn new() -> Px4State {
        Px4State {
            phase: Px4Phase::Idle,
            mission_type: MissionType::Mission,
            partner: Endpoint::new(0, 0),
            transfer_seq: 0,
            transfer_count: 0,
            transfer_items: Vec::new(),
            transfer_current_seq: None,
            transfer_crc: 0,
            last_sent: None,
            last_recv: None,
            int_mode: false,
            crc: [0; 3],
        }
    }

    /// A power cycle: the transfer in progress is lost and the GCS's int mode forgotten; the
    /// lists and their opaque ids survive (dataman).
    pub(super) fn reboot(&mut self) {
        self.phase = Px4Phase::Idle;
        self.transfer_seq = 0;
        self.transfer_count = 0;
        self.last_sent = None;
        self.last_recv = None;
        self.int_mode = false;
    }

    pub(super) fn poll_timeout(&self) -> Option<Time> {
        if self.phase == Px4Phase::Idle {
            return None;
        }
        let mut t = self
            .last_recv
            .map(|r| r + PX4_PROTOCOL_TIMEOUT + Duration::from_micros(1));
        if self.phase == Px4Phase::GetList
            && let Some(s) = self.last_sent
        {
            let retry = s + PX4_RETRY + Duration::from_micros(1);
            t = Some(t.map_or(retry, |t| t.min(retry)));
        }
        t
    }

    pub(super) fn handle_timeout(&mut self, core: &mut Core, now: Time) {
        if self.phase == Px4Phase::GetList
            && self
                .last_sent
                .is_some_and(|s| now.saturating_since(s) > PX4_RETRY)
        {
            let (partner, seq, t) = (self.partner, self.transfer_seq, self.mission_type);
            self.send_request(core, partner, seq, t, now);
        } else if self.phase != Px4Phase::Idle
            && self
                .last_recv
                .is_some_and(|r| now.saturating_since(r) > PX4_PROTOCOL_TIMEOUT)
        {
            core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "Operation timeout",
            ));
            if self.phase == Px4Phase::GetList {
                core.events.push_back(MissionEvent::UploadFailed {
                    mission_type: self.mission_type,
                });
            }
            self.phase = Px4Phase::Idle;
            self.last_sent = None;
            self.last_recv = None;
        }
    }

    /// Request item `seq` of list `t` from `to`, in the GCS's int mode.
    fn send_request(&mut self, core: &mut Core, to: Endpoint, seq: u16, t: MissionType, now: Time) {
        self.last_sent = Some(now);
        core.outbox
            .push_back(request_msg(to, seq, t, self.int_mode));
    }

    pub(super) fn count(
        &mut self,
        core: &mut Core,
        from: Endpoint,
        t: MissionType,
        count: u16,
        now: Time,
    ) {
        match self.phase {
            Px4Phase::Idle => {
                self.last_recv = Some(now);
                self.partner = from;
                self.mission_type = t;
                if count > core.capacity.of(t) {
                    core.outbox.push_back(ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_NO_SPACE,
                        0,
                    ));
                    return;
                }
                if count == 0 {
                    core.lists[idx(t)].clear();
                    self.crc[idx(t)] = 0;
                    if t == MissionType::Mission {
                        core.current = 0;
                    }
                    core.events
                        .push_back(MissionEvent::Cleared { mission_type: t });
                    core.outbox.push_back(ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ACCEPTED,
                        0,
                    ));
                    return;
                }
                self.phase = Px4Phase::GetList;
                self.transfer_seq = 0;
                self.transfer_count = count;
                self.transfer_items.clear();
                self.transfer_current_seq = None;
                self.transfer_crc = 0;
                core.events.push_back(MissionEvent::UploadStarted {
                    mission_type: t,
                    count,
                });
            }
            Px4Phase::GetList => {
                self.last_recv = Some(now);
                if from != self.partner {
                    core.outbox.push_back(ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                        0,
                    ));
                    return;
                }
                if self.transfer_seq != 0 {
                    refuse(
                        core,
                        self.partner,
                        self.mission_type,
                        "WPM: REJ. CMD: Busy",
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                    );
                    return;
                }
                // "looks like our MISSION_REQUEST was lost, try again"
            }
            Px4Phase::SendList => {
                refuse(
                    core,
                    from,
                    t,
                    "WPM: IGN MISSION_COUNT: Busy",
                    mav::MavMissionResult::MAV_MISSION_ERROR,
                );
                return;
            }
        }
        let (partner, seq, mt) = (self.partner, self.transfer_seq, self.mission_type);
        self.send_request(core, partner, seq, mt, now);
    }

    pub(super) fn item(&mut self, core: &mut Core, from: Endpoint, rx: RxItem, now: Time) {
        if from != self.partner {
            core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "REJ. MIS ITEM: partner id mismatch",
            ));
            return;
        }
        let t = self.mission_type;
        if rx.mission_type != t {
            core.outbox
                .push_back(ack_to(from, t, mav::MavMissionResult::MAV_MISSION_ERROR, 0));
            return;
        }
        match self.phase {
            Px4Phase::GetList => {
                self.last_recv = Some(now);
                if rx.seq != self.transfer_seq {
                    return; // "Item sequence not expected, ignore item"
                }
            }
            Px4Phase::Idle => {
                if self.transfer_seq == rx.seq.wrapping_add(1) {
                    core.outbox.push_back(ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ACCEPTED,
                        self.transfer_crc,
                    ));
                } else {
                    refuse(
                        core,
                        from,
                        t,
                        "IGN MISSION_ITEM: No transfer",
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                    );
                }
                return;
            }
            Px4Phase::SendList => {
                refuse(
                    core,
                    from,
                    t,
                    "IGN MISSION_ITEM: Busy",
                    mav::MavMissionResult::MAV_MISSION_ERROR,
                );
                return;
            }
        }
        let stored = match px4_parse_item(&rx.item, t, self.int_mode) {
            Ok(s) => s,
            Err(result) => {
                refuse(core, from, t, "IGN MISSION_ITEM: Invalid item", result);
                self.phase = Px4Phase::Idle;
                core.events
                    .push_back(MissionEvent::UploadFailed { mission_type: t });
                return;
            }
        };
        self.transfer_crc = crc32_item(&rx.item, self.transfer_crc);
        if rx.item.current {
            self.transfer_current_seq = Some(rx.seq);
        }
        self.transfer_items.push(stored);
        self.transfer_seq = rx.seq + 1;
        if self.transfer_seq == self.transfer_count {
            let items = std::mem::take(&mut self.transfer_items);
            let n = items.len() as u16;
            core.lists[idx(t)] = items;
            self.crc[idx(t)] = self.transfer_crc;
            if t == MissionType::Mission {
                core.current = self.transfer_current_seq.unwrap_or(0);
            }
            self.phase = Px4Phase::Idle;
            core.outbox.push_back(ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_ACCEPTED,
                self.transfer_crc,
            ));
            core.events.push_back(MissionEvent::Uploaded {
                mission_type: t,
                count: n,
            });
        } else {
            let seq = self.transfer_seq;
            self.send_request(core, from, seq, t, now);
        }
    }

    pub(super) fn request_list(
        &mut self,
        core: &mut Core,
        from: Endpoint,
        t: MissionType,
        now: Time,
    ) {
        let count = core.lists[idx(t)].len() as u16;
        if self.phase == Px4Phase::SendList
            && self.transfer_seq == core.lists[idx(self.mission_type)].len() as u16
        {
            self.phase = Px4Phase::Idle;
        }
        let same =
            self.phase == Px4Phase::SendList && self.mission_type == t && self.partner == from;
        if self.phase == Px4Phase::Idle || same {
            self.last_recv = Some(now);
            self.phase = Px4Phase::SendList;
            self.mission_type = t;
            self.transfer_seq = 0;
            self.transfer_count = count;
            self.partner = from;
            self.last_sent = Some(now);
            core.outbox
                .push_back(count_msg(from, t, count, self.crc[idx(t)]));
        } else {
            core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_INFO,
                "Mission download request ignored, already active",
            ));
        }
    }

    /// MISSION_REQUEST(_INT) for item `seq` of list `t` (the int mode is already set by the
    /// message's variant).
    pub(super) fn request(
        &mut self,
        core: &mut Core,
        from: Endpoint,
        t: MissionType,
        seq: u16,
        now: Time,
    ) {
        if from != self.partner {
            core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "WPM: REJ. CMD: partner id mismatch",
            ));
            return;
        }
        match self.phase {
            Px4Phase::Idle => {} // silently ignored
            Px4Phase::GetList => core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "WPM: REJ. CMD: Busy",
            )),
            Px4Phase::SendList => {
                if t != self.mission_type {
                    return;
                }
                self.last_recv = Some(now);
                if seq == self.transfer_seq && self.transfer_seq < self.transfer_count {
                    self.transfer_seq += 1;
                } else if seq.wrapping_add(1) == self.transfer_seq {
                    // a repeated request
                } else {
                    self.phase = Px4Phase::Idle;
                    unexpected_request(core, from, t);
                    return;
                }
                if let Some(stored) = core.lists[idx(t)].get(seq as usize) {
                    let mut item = px4_format_item(stored, t, self.int_mode);
                    item.current = t == MissionType::Mission && core.current == seq;
                    self.last_sent = Some(now);
                    let xy_degrees = Self::float_xy_is_degrees(item.frame);
                    core.outbox
                        .push_back(item_msg(from, t, seq, &item, self.int_mode, xy_degrees));
                } else {
                    self.phase = Px4Phase::Idle;
                    unexpected_request(core, from, t);
                }
            }
        }
    }

    pub(super) fn ack(
        &mut self,
        core: &mut Core,
        from: Endpoint,
        m: &mav::MISSION_ACK_DATA,
        now: Time,
    ) {
        if from != self.partner {
            return;
        }
        match self.phase {
            Px4Phase::SendList if mtype(m.mission_type) == Some(self.mission_type) => {
                self.last_recv = Some(now);
                self.phase = Px4Phase::Idle;
            }
            Px4Phase::GetList => match m.mavtype {
                mav::MavMissionResult::MAV_MISSION_UNSUPPORTED => {
                    self.int_mode = !self.int_mode;
                    let (seq, t) = (self.transfer_seq, self.mission_type);
                    self.send_request(core, from, seq, t, now);
                }
                mav::MavMissionResult::MAV_MISSION_OPERATION_CANCELLED => {
                    self.phase = Px4Phase::Idle;
                    core.events.push_back(MissionEvent::UploadFailed {
                        mission_type: self.mission_type,
                    });
                }
                _ => {}
            },
            _ => {}
        }
    }

    /// MISSION_CLEAR_ALL: one list or all of them (MAV_MISSION_TYPE_ALL), refused while a
    /// transfer runs.
    pub(super) fn clear_all(
        &mut self,
        core: &mut Core,
        from: Endpoint,
        t: mav::MavMissionType,
        now: Time,
    ) {
        let types: Vec<MissionType> = match mtype(t) {
            Some(x) => vec![x],
            None if t == mav::MavMissionType::MAV_MISSION_TYPE_ALL => {
                vec![MissionType::Mission, MissionType::Fence, MissionType::Rally]
            }
            None => {
                core.outbox.push_back(ack_raw(
                    from,
                    t,
                    mav::MavMissionResult::MAV_MISSION_UNSUPPORTED,
                    0,
                ));
                return;
            }
        };
        if self.phase != Px4Phase::Idle {
            core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "WPM: IGN CLEAR CMD: Busy",
            ));
            return;
        }
        self.last_recv = Some(now);
        for mt in &types {
            core.lists[idx(*mt)].clear();
            self.crc[idx(*mt)] = 0;
            if *mt == MissionType::Mission {
                core.current = 0;
            }
            core.events
                .push_back(MissionEvent::Cleared { mission_type: *mt });
        }
        core.outbox.push_back(ack_raw(
            from,
            t,
            mav::MavMissionResult::MAV_MISSION_ACCEPTED,
            0,
        ));
    }

    /// MISSION_SET_CURRENT: refused while a transfer runs, "Not in list" past the end.
    pub(super) fn set_current(&mut self, core: &mut Core, seq: u16, now: Time) {
        if self.phase != Px4Phase::Idle {
            core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "WPM: IGN WP CURR CMD: Busy",
            ));
            return;
        }
        self.last_recv = Some(now);
        let n = core.lists[0].len() as u16;
        if seq < n {
            core.current = seq;
            core.events.push_back(MissionEvent::SetCurrent { seq });
        } else {
            core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "WPM: WP CURR CMD: Not in list",
            ));
        }
    }
}
