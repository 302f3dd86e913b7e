//! ArduPilot's side of the mission protocol: uploads written in place with MISSION_REQUEST,
//! stateless downloads (see the module documentation of `mission_server`).

use super::*;

impl ArduPilotState {
    pub(super) fn new() -> ArduPilotState {
        ArduPilotState {
            loaded: true,
            home: None,
            mission_running: false,
            uploads: [None, None, None],
            warned_request: false,
            warned_item: false,
        }
    }

    /// A power cycle: uploads in progress are lost; the lists are loaded by the time the
    /// vehicle answers again and the mission is not running.
    pub(super) fn reboot(&mut self) {
        self.loaded = true;
        self.uploads = [None, None, None];
        self.warned_request = false;
        self.warned_item = false;
        self.mission_running = false;
    }

    pub(super) fn poll_timeout(&self) -> Option<Time> {
        self.uploads
            .iter()
            .flatten()
            .map(|r| {
                (r.last_request + ARDUPILOT_RESEND + Duration::from_millis(1))
                    .min(r.last_receive + ARDUPILOT_UPLOAD_TIMEOUT + Duration::from_millis(1))
            })
            .min()
    }

    pub(super) fn handle_timeout(&mut self, core: &mut Core, now: Time) {
        for t in [MissionType::Mission, MissionType::Fence, MissionType::Rally] {
            let Some(rx) = self.uploads[idx(t)].as_mut() else {
                continue;
            };
            if now.saturating_since(rx.last_receive) > ARDUPILOT_UPLOAD_TIMEOUT {
                let partner = rx.partner;
                self.uploads[idx(t)] = None;
                if t == MissionType::Mission {
                    core.outbox.push_back(text(
                        mav::MavSeverity::MAV_SEVERITY_WARNING,
                        "Mission upload timeout",
                    ));
                }
                core.outbox.push_back(ack_to(
                    partner,
                    t,
                    mav::MavMissionResult::MAV_MISSION_OPERATION_CANCELLED,
                    0,
                ));
                core.events
                    .push_back(MissionEvent::UploadFailed { mission_type: t });
            } else if now.saturating_since(rx.last_request) > ARDUPILOT_RESEND {
                rx.last_request = now;
                let (partner, seq) = (rx.partner, rx.request_i);
                core.outbox.push_back(request_msg(partner, seq, t, false));
            }
        }
    }

    pub(super) fn count(
        &mut self,
        core: &mut Core,
        from: Endpoint,
        t: MissionType,
        count: u16,
        now: Time,
    ) {
        if let Some(rx) = &self.uploads[idx(t)]
            && rx.partner != from
        {
            core.outbox.push_back(ack_to(
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
        let max = if self.loaded { core.capacity.of(t) } else { 0 };
        if count > max {
            core.outbox.push_back(ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_NO_SPACE,
                0,
            ));
            core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_WARNING,
                &format!("Only {max} items are supported"),
            ));
            self.uploads[idx(t)] = None;
            return;
        }
        // truncate(): mission and rally lists shrink at once; the fence is replaced at the end.
        if t != MissionType::Fence {
            core.lists[idx(t)].truncate(count as usize);
        }
        core.events.push_back(MissionEvent::UploadStarted {
            mission_type: t,
            count,
        });
        if count == 0 {
            self.uploads[idx(t)] = None;
            if t == MissionType::Fence {
                core.lists[idx(t)].clear();
            }
            Self::complete(core, from, t);
            return;
        }
        self.uploads[idx(t)] = Some(ApUpload {
            partner: from,
            request_i: 0,
            request_last: count - 1,
            last_receive: now,
            last_request: now,
            buffer: Vec::new(),
        });
        self.warned_item = false;
        self.warned_request = false;
        core.outbox.push_back(request_msg(from, 0, t, false));
    }

    fn complete(core: &mut Core, to: Endpoint, t: MissionType) {
        if t == MissionType::Mission {
            core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_INFO,
                "Flight plan received",
            ));
        }
        core.outbox.push_back(ack_to(
            to,
            t,
            mav::MavMissionResult::MAV_MISSION_ACCEPTED,
            0,
        ));
        core.events.push_back(MissionEvent::Uploaded {
            mission_type: t,
            count: core.lists[idx(t)].len() as u16,
        });
    }

    pub(super) fn item(
        &mut self,
        core: &mut Core,
        from: Endpoint,
        rx: RxItem,
        current: u8,
        now: Time,
    ) {
        if rx.mission_type == MissionType::Mission && (current == 2 || current == 3) {
            // Guided-mode waypoint requests through MISSION_ITEM (GCS_Common.cpp
            // handle_mission_item) are not supported by the simulator: DO_REPOSITION and
            // SET_POSITION_TARGET_GLOBAL_INT are.
            core.outbox.push_back(ack_to(
                from,
                MissionType::Mission,
                mav::MavMissionResult::MAV_MISSION_UNSUPPORTED,
                0,
            ));
            return;
        }
        let t = rx.mission_type;
        let Some(up) = self.uploads[idx(t)].as_ref() else {
            core.outbox
                .push_back(ack_to(from, t, mav::MavMissionResult::MAV_MISSION_ERROR, 0));
            return;
        };
        if rx.seq != up.request_i {
            core.outbox.push_back(ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_INVALID_SEQUENCE,
                0,
            ));
            return;
        }
        if from != up.partner {
            core.outbox.push_back(ack_to(
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
                if it.command == fleetmap_core::mission::item::cmd::DO_JUMP {
                    let target = it.param1 as u16;
                    let count = core.lists[0].len() as u16;
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
                core.outbox.push_back(ack_to(from, t, result, 0));
                self.uploads[idx(t)] = None;
                core.events
                    .push_back(MissionEvent::UploadFailed { mission_type: t });
                return;
            }
        };
        if t == MissionType::Fence {
            if let Some(up) = self.uploads[idx(t)].as_mut() {
                up.buffer.push(stored);
            }
        } else {
            let list = &mut core.lists[idx(t)];
            let seq = rx.seq as usize;
            if seq < list.len() {
                list[seq] = stored;
            } else if seq == list.len() {
                list.push(stored);
            } else {
                core.outbox
                    .push_back(ack_to(from, t, mav::MavMissionResult::MAV_MISSION_ERROR, 0));
                self.uploads[idx(t)] = None;
                core.events
                    .push_back(MissionEvent::UploadFailed { mission_type: t });
                return;
            }
        }
        if rx.float && !self.warned_item {
            self.warned_item = true;
            core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_WARNING,
                "got MISSION_ITEM; GCS should send MISSION_ITEM_INT",
            ));
        }
        let done = {
            let Some(up) = self.uploads[idx(t)].as_mut() else {
                return;
            };
            up.last_receive = now;
            up.request_i += 1;
            up.request_i > up.request_last
        };
        if done {
            if let Some(up) = self.uploads[idx(t)].take()
                && t == MissionType::Fence
            {
                core.lists[idx(t)] = up.buffer;
            }
            Self::complete(core, from, t);
        } else if let Some(up) = self.uploads[idx(t)].as_mut() {
            up.last_request = now;
            let (partner, seq) = (up.partner, up.request_i);
            core.outbox.push_back(request_msg(partner, seq, t, false));
        }
    }

    pub(super) fn request_list(&mut self, core: &mut Core, from: Endpoint, t: MissionType) {
        if self.uploads[idx(t)].is_some() {
            core.outbox.push_back(ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_DENIED,
                0,
            ));
            return;
        }
        // Before the lists are loaded, the count is 0 (`AP_Mission::num_commands`).
        let n = if self.loaded {
            core.lists[idx(t)].len() as u16
        } else {
            0
        };
        core.outbox.push_back(count_msg(from, t, n, 0));
    }

    pub(super) fn request(
        &mut self,
        core: &mut Core,
        from: Endpoint,
        t: MissionType,
        seq: u16,
        int: bool,
    ) {
        if self.uploads[idx(t)].is_some() && int {
            core.outbox.push_back(ack_to(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_DENIED,
                0,
            ));
            return;
        }
        let n = core.lists[idx(t)].len() as u16;
        let item = if t == MissionType::Mission && seq == 0 {
            // AP_Mission::read_cmd_from_storage: slot 0 is always the AHRS home.
            let h = self.home.unwrap_or(HomeItem {
                lat_e7: 0,
                lon_e7: 0,
                alt_amsl_m: 0.0,
            });
            Some(MissionItem {
                frame: 0,
                command: fleetmap_core::mission::item::cmd::NAV_WAYPOINT,
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
            Some(core.lists[idx(t)][seq as usize])
        } else {
            None
        };
        let Some(mut item) = item else {
            if t == MissionType::Mission {
                // "try to educate the GCS on the actual size of the mission"
                core.outbox.push_back(count_msg(from, t, n, 0));
            }
            core.outbox
                .push_back(ack_to(from, t, mav::MavMissionResult::MAV_MISSION_ERROR, 0));
            return;
        };
        // MissionItemProtocol_Waypoints::get_item compares the command *id* with the current
        // nav command *index* to set `current` (sic); autocontinue is always 1.
        item.current = t == MissionType::Mission && item.command == core.current;
        item.autocontinue = true;
        if !int && !self.warned_request {
            self.warned_request = true;
            core.outbox.push_back(text(
                mav::MavSeverity::MAV_SEVERITY_WARNING,
                "got MISSION_REQUEST; use MISSION_REQUEST_INT!",
            ));
        }
        let xy_degrees = Self::float_xy_is_degrees(item.command);
        core.outbox
            .push_back(item_msg(from, t, seq, &item, int, xy_degrees));
    }

    /// MISSION_CLEAR_ALL: one list, refused (MAV_MISSION_ERROR) during its upload or, for
    /// the mission, while it runs; MAV_MISSION_TYPE_ALL is not supported.
    pub(super) fn clear_all(&mut self, core: &mut Core, from: Endpoint, t: mav::MavMissionType) {
        let Some(mt) = mtype(t) else {
            core.outbox.push_back(ack_raw(
                from,
                t,
                mav::MavMissionResult::MAV_MISSION_UNSUPPORTED,
                0,
            ));
            return;
        };
        let ok = self.uploads[idx(mt)].is_none()
            && !(mt == MissionType::Mission && self.mission_running);
        if ok {
            core.lists[idx(mt)].clear();
            if mt == MissionType::Mission {
                core.current = 1;
            }
            core.events
                .push_back(MissionEvent::Cleared { mission_type: mt });
        }
        let r = if ok {
            mav::MavMissionResult::MAV_MISSION_ACCEPTED
        } else {
            mav::MavMissionResult::MAV_MISSION_ERROR
        };
        core.outbox.push_back(ack_to(from, mt, r, 0));
    }

    /// MISSION_SET_CURRENT (`AP_Mission::set_current_cmd`): index 0 restarts at 1; needs a
    /// mission.
    pub(super) fn set_current(core: &mut Core, seq: u16) {
        let n = core.lists[0].len() as u16;
        if seq < n && n > 1 {
            core.events
                .push_back(MissionEvent::SetCurrent { seq: seq.max(1) });
        }
    }
}
