//! ArduPilot's side of the mission protocol: uploads written in place with MISSION_REQUEST,
//! stateless downloads (see the module documentation of `mission_server`).

use super::*;

impl MissionServer {
    pub(super) fn ap_count(&mut self, from: (u8, u8), t: MissionType, count: u16, now: Time) {
        if let Some(rx) = &self.ap_rx[idx(t)]
            && rx.partner != from
        {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_DENIED,
                0,
            ));
            return;
        }
        // `MissionItemProtocol::handle_mission_count`: count > max_items(), which is 0 until
        // the mission library is initialised (ArduCopter 4.7 SITL, seen: NO_SPACE and "Only 0
        // items are supported" for every MISSION_COUNT of its first 2 s).
        let max = if self.loaded { self.capacity.of(t) } else { 0 };
        if count > max {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_NO_SPACE,
                0,
            ));
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Only {max} items are supported"),
            ));
            self.ap_rx[idx(t)] = None;
            return;
        }
        // truncate(): mission and rally lists shrink at once; the fence is replaced at the end.
        if t != MissionType::Fence {
            self.lists[idx(t)].truncate(count as usize);
        }
        self.events.push_back(MissionEvent::UploadStarted {
            mission_type: t,
            count,
        });
        if count == 0 {
            self.ap_rx[idx(t)] = None;
            if t == MissionType::Fence {
                self.lists[idx(t)].clear();
            }
            self.ap_complete(from, t);
            return;
        }
        self.ap_rx[idx(t)] = Some(ApUpload {
            partner: from,
            request_i: 0,
            request_last: count - 1,
            last_receive: now,
            last_request: now,
            buffer: Vec::new(),
        });
        self.ap_warned_item = false;
        self.ap_warned_request = false;
        self.outbox.push_back(self.request_msg(from, 0, t, false));
    }

    pub(super) fn ap_complete(&mut self, to: (u8, u8), t: MissionType) {
        if t == MissionType::Mission {
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_INFO,
                "Flight plan received",
            ));
        }
        self.outbox
            .push_back(self.ack_to(to, t, mav::MavMissionResult::MAV_MISSION_ACCEPTED, 0));
        self.events.push_back(MissionEvent::Uploaded {
            mission_type: t,
            count: self.lists[idx(t)].len() as u16,
        });
    }

    pub(super) fn ap_item(&mut self, from: (u8, u8), rx: RxItem, now: Time) {
        let t = rx.mission_type;
        let Some(up) = self.ap_rx[idx(t)].as_ref() else {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_ERROR,
                0,
            ));
            return;
        };
        if rx.seq != up.request_i {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
                0,
            ));
            return;
        }
        if from != up.partner {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_DENIED,
                0,
            ));
            return;
        }
        let request_last = up.request_last;
        let stored = match t {
            MissionType::Mission => ardupilot_store_mission_item(&rx.item).and_then(|it| {
                if it.command == crate::mission::item::cmd::DO_JUMP {
                    let target = it.param1 as u16;
                    let count = self.lists[0].len() as u16;
                    if (target >= count && target > request_last) || target == 0 {
                        return Err(mav::MavMissionResult::MAV_MISSION_ERROR);
                    }
                }
                Ok(it)
            }),
            MissionType::Fence => ardupilot_store_fence_item(&rx.item),
            MissionType::Rally => ardupilot_store_rally_item(&rx.item),
        };
        let stored = match stored {
            Ok(s) => s,
            Err(result) => {
                self.outbox.push_back(self.ack_to(from, t, result, 0));
                self.ap_rx[idx(t)] = None;
                self.events
                    .push_back(MissionEvent::UploadFailed { mission_type: t });
                return;
            }
        };
        if t == MissionType::Fence {
            if let Some(up) = self.ap_rx[idx(t)].as_mut() {
                up.buffer.push(stored);
            }
        } else {
            let list = &mut self.lists[idx(t)];
            let seq = rx.seq as usize;
            if seq < list.len() {
                list[seq] = stored;
            } else if seq == list.len() {
                list.push(stored);
            } else {
                self.outbox.push_back(self.ack_to(
                    from,
                    t,
                    mav::MavMissionResult::MAV_MISSION_ERROR,
                    0,
                ));
                self.ap_rx[idx(t)] = None;
                self.events
                    .push_back(MissionEvent::UploadFailed { mission_type: t });
                return;
            }
        }
        if rx.float && !self.ap_warned_item {
            self.ap_warned_item = true;
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_WARNING,
                "got MISSION_ITEM; GCS should send MISSION_ITEM_INT",
            ));
        }
        let done = {
            let Some(up) = self.ap_rx[idx(t)].as_mut() else {
                return;
            };
            up.last_receive = now;
            up.request_i += 1;
            up.request_i > up.request_last
        };
        if done {
            if let Some(up) = self.ap_rx[idx(t)].take()
                && t == MissionType::Fence
            {
                self.lists[idx(t)] = up.buffer;
            }
            self.ap_complete(from, t);
        } else if let Some(up) = self.ap_rx[idx(t)].as_mut() {
            up.last_request = now;
            let (partner, seq) = (up.partner, up.request_i);
            self.outbox
                .push_back(self.request_msg(partner, seq, t, false));
        }
    }

    pub(super) fn ap_request_list(&mut self, from: (u8, u8), t: MissionType) {
        if self.ap_rx[idx(t)].is_some() {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_DENIED,
                0,
            ));
            return;
        }
        // Before the lists are loaded, the count is 0 (`AP_Mission::num_commands`).
        let n = if self.loaded {
            self.lists[idx(t)].len() as u16
        } else {
            0
        };
        self.outbox.push_back(self.count_msg(from, t, n, 0));
    }

    pub(super) fn ap_request(&mut self, from: (u8, u8), t: MissionType, seq: u16, int: bool) {
        if self.ap_rx[idx(t)].is_some() && int {
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_DENIED,
                0,
            ));
            return;
        }
        let n = self.lists[idx(t)].len() as u16;
        let item = if t == MissionType::Mission && seq == 0 {
            // AP_Mission::read_cmd_from_storage: slot 0 is always the AHRS home.
            let h = self.home.unwrap_or(HomeItem {
                lat_e7: 0,
                lon_e7: 0,
                alt_amsl_m: 0.0,
            });
            Some(MissionItem {
                frame: 0,
                command: crate::mission::item::cmd::NAV_WAYPOINT,
                current: false,
                autocontinue: true,
                param1: 0.0,
                param2: 0.0,
                param3: 0.0,
                param4: 0.0,
                x: h.lat_e7,
                y: h.lon_e7,
                z: (h.alt_amsl_m * 100.0).trunc() * 0.01,
            })
        } else if seq < n {
            Some(self.lists[idx(t)][seq as usize])
        } else {
            None
        };
        let Some(mut item) = item else {
            if t == MissionType::Mission {
                // "try to educate the GCS on the actual size of the mission"
                self.outbox.push_back(self.count_msg(from, t, n, 0));
            }
            self.outbox.push_back(self.ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_ERROR,
                0,
            ));
            return;
        };
        // MissionItemProtocol_Waypoints::get_item compares the command *id* with the current
        // nav command *index* to set `current` (sic); autocontinue is always 1.
        item.current = t == MissionType::Mission && item.command == self.current;
        item.autocontinue = true;
        if !int && !self.ap_warned_request {
            self.ap_warned_request = true;
            self.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_WARNING,
                "got MISSION_REQUEST; use MISSION_REQUEST_INT!",
            ));
        }
        self.outbox
            .push_back(self.item_msg(from, t, seq, &item, int));
    }
}
