//! PX4's side of the mission protocol: one transfer at a time (IDLE / GETLIST / SENDLIST),
//! int mode, double-buffered lists (see the module documentation of `mission_server`).

use super::*;

impl MissionServer {
    pub(super) fn px4_send_request(
        &mut self,
        to: (u8, u8),
        seq: u16,
        t: MissionType,
        int: bool,
        now: Time,
    ) {
        self.px4.last_sent = Some(now);
        self.outbox.push_back(self.request_msg(to, seq, t, int));
    }

    pub(super) fn px4_count(&mut self, from: (u8, u8), t: MissionType, count: u16, now: Time) {
        match self.px4.state {
            Px4State::Idle => {
                self.px4.last_recv = Some(now);
                self.px4.partner = from;
                self.px4.mission_type = t;
                if count > self.capacity.of(t) {
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_NO_SPACE,
                        0,
                    ));
                    return;
                }
                if count == 0 {
                    self.lists[idx(t)].clear();
                    self.crc[idx(t)] = 0;
                    if t == MissionType::Mission {
                        self.current = 0;
                    }
                    self.events
                        .push_back(MissionEvent::Cleared { mission_type: t });
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ACCEPTED,
                        0,
                    ));
                    return;
                }
                self.px4.state = Px4State::GetList;
                self.px4.transfer_seq = 0;
                self.px4.transfer_count = count;
                self.px4.transfer_items.clear();
                self.px4.transfer_current_seq = None;
                self.px4.transfer_crc = 0;
                self.events.push_back(MissionEvent::UploadStarted {
                    mission_type: t,
                    count,
                });
            }
            Px4State::GetList => {
                self.px4.last_recv = Some(now);
                if from != self.px4.partner {
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                        0,
                    ));
                    return;
                }
                if self.px4.transfer_seq != 0 {
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "WPM: REJ. CMD: Busy",
                    ));
                    let mt = self.px4.mission_type;
                    self.outbox.push_back(self.ack_to(
                        self.px4.partner,
                        mt,
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                        0,
                    ));
                    return;
                }
                // "looks like our MISSION_REQUEST was lost, try again"
            }
            Px4State::SendList => {
                self.outbox.push_back(text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "WPM: IGN MISSION_COUNT: Busy",
                ));
                self.outbox.push_back(self.ack_to(
                    from,
                    t,
                    mav::MavMissionResult::MAV_MISSION_ERROR,
                    0,
                ));
                return;
            }
        }
        let (partner, seq, mt, int) = (
            self.px4.partner,
            self.px4.transfer_seq,
            self.px4.mission_type,
            self.px4.int_mode,
        );
        self.px4_send_request(partner, seq, mt, int, now);
    }

    pub(super) fn px4_item(&mut self, from: (u8, u8), rx: RxItem, now: Time) {
        if from != self.px4.partner {
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "REJ. MIS ITEM: partner id mismatch",
            ));
            return;
        }
        let t = self.px4.mission_type;
        if rx.mission_type != t {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_ERROR,
                0,
            ));
            return;
        }
        match self.px4.state {
            Px4State::GetList => {
                self.px4.last_recv = Some(now);
                if rx.seq != self.px4.transfer_seq {
                    return; // "Item sequence not expected, ignore item"
                }
            }
            Px4State::Idle => {
                if self.px4.transfer_seq == rx.seq.wrapping_add(1) {
                    let crc = self.px4.transfer_crc;
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ACCEPTED,
                        crc,
                    ));
                } else {
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "IGN MISSION_ITEM: No transfer",
                    ));
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                        0,
                    ));
                }
                return;
            }
            Px4State::SendList => {
                self.outbox.push_back(text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "IGN MISSION_ITEM: Busy",
                ));
                self.outbox.push_back(self.ack_to(
                    from,
                    t,
                    mav::MavMissionResult::MAV_MISSION_ERROR,
                    0,
                ));
                return;
            }
        }
        let stored = match px4_parse_item(&rx.item, t, self.px4.int_mode) {
            Ok(s) => s,
            Err(result) => {
                self.outbox.push_back(text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "IGN MISSION_ITEM: Invalid item",
                ));
                self.outbox.push_back(self.ack_to(from, t, result, 0));
                self.px4.state = Px4State::Idle;
                self.events
                    .push_back(MissionEvent::UploadFailed { mission_type: t });
                return;
            }
        };
        self.px4.transfer_crc = crc32_item(&rx.item, self.px4.transfer_crc);
        if rx.item.current {
            self.px4.transfer_current_seq = Some(rx.seq);
        }
        self.px4.transfer_items.push(stored);
        self.px4.transfer_seq = rx.seq + 1;
        if self.px4.transfer_seq == self.px4.transfer_count {
            let items = std::mem::take(&mut self.px4.transfer_items);
            let n = items.len() as u16;
            self.lists[idx(t)] = items;
            self.crc[idx(t)] = self.px4.transfer_crc;
            if t == MissionType::Mission {
                self.current = self.px4.transfer_current_seq.unwrap_or(0);
            }
            self.px4.state = Px4State::Idle;
            let crc = self.px4.transfer_crc;
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_ACCEPTED,
                crc,
            ));
            self.events.push_back(MissionEvent::Uploaded {
                mission_type: t,
                count: n,
            });
        } else {
            let (seq, int) = (self.px4.transfer_seq, self.px4.int_mode);
            self.px4_send_request(from, seq, t, int, now);
        }
    }

    pub(super) fn px4_request_list(&mut self, from: (u8, u8), t: MissionType, now: Time) {
        let count = self.lists[idx(t)].len() as u16;
        if self.px4.state == Px4State::SendList
            && self.px4.transfer_seq == self.lists[idx(self.px4.mission_type)].len() as u16
        {
            self.px4.state = Px4State::Idle;
        }
        let same = self.px4.state == Px4State::SendList
            && self.px4.mission_type == t
            && self.px4.partner == from;
        if self.px4.state == Px4State::Idle || same {
            self.px4.last_recv = Some(now);
            self.px4.state = Px4State::SendList;
            self.px4.mission_type = t;
            self.px4.transfer_seq = 0;
            self.px4.transfer_count = count;
            self.px4.partner = from;
            self.px4.last_sent = Some(now);
            let crc = self.crc[idx(t)];
            self.outbox.push_back(self.count_msg(from, t, count, crc));
        } else {
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_INFO,
                "Mission download request ignored, already active",
            ));
        }
    }

    pub(super) fn px4_request(&mut self, from: (u8, u8), t: MissionType, seq: u16, now: Time) {
        if from != self.px4.partner {
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "WPM: REJ. CMD: partner id mismatch",
            ));
            return;
        }
        match self.px4.state {
            Px4State::Idle => {} // silently ignored
            Px4State::GetList => self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                "WPM: REJ. CMD: Busy",
            )),
            Px4State::SendList => {
                if t != self.px4.mission_type {
                    return;
                }
                self.px4.last_recv = Some(now);
                let p = &mut self.px4;
                if seq == p.transfer_seq && p.transfer_seq < p.transfer_count {
                    p.transfer_seq += 1;
                } else if seq.wrapping_add(1) == p.transfer_seq {
                    // a repeated request
                } else {
                    p.state = Px4State::Idle;
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                        0,
                    ));
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "WPM: REJ. CMD: Req. WP was unexpected",
                    ));
                    return;
                }
                let list = &self.lists[idx(t)];
                if let Some(stored) = list.get(seq as usize) {
                    let mut item = px4_format_item(stored, t, self.px4.int_mode);
                    item.current = t == MissionType::Mission && self.current == seq;
                    let int = self.px4.int_mode;
                    self.px4.last_sent = Some(now);
                    self.outbox
                        .push_back(self.item_msg(from, t, seq, &item, int));
                } else {
                    self.px4.state = Px4State::Idle;
                    self.outbox.push_back(self.ack_to(
                        from,
                        t,
                        mav::MavMissionResult::MAV_MISSION_ERROR,
                        0,
                    ));
                    self.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                        "WPM: REJ. CMD: Req. WP was unexpected",
                    ));
                }
            }
        }
    }

    pub(super) fn px4_ack(&mut self, from: (u8, u8), m: &mav::MISSION_ACK_DATA, now: Time) {
        if from != self.px4.partner {
            return;
        }
        match self.px4.state {
            Px4State::SendList if mtype(m.mission_type) == Some(self.px4.mission_type) => {
                self.px4.last_recv = Some(now);
                self.px4.state = Px4State::Idle;
            }
            Px4State::GetList => match m.mavtype {
                mav::MavMissionResult::MAV_MISSION_UNSUPPORTED => {
                    self.px4.int_mode = !self.px4.int_mode;
                    let (seq, t, int) = (
                        self.px4.transfer_seq,
                        self.px4.mission_type,
                        self.px4.int_mode,
                    );
                    self.px4_send_request(from, seq, t, int, now);
                }
                mav::MavMissionResult::MAV_MISSION_OPERATION_CANCELLED => {
                    self.px4.state = Px4State::Idle;
                    self.events.push_back(MissionEvent::UploadFailed {
                        mission_type: self.px4.mission_type,
                    });
                }
                _ => {}
            },
            _ => {}
        }
    }
}
