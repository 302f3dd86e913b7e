//! Mission execution: the mission protocol server's events, the current item, nav and
//! do-commands (ArduPilot `AP_Mission`, PX4 navigator), MISSION_ITEM_REACHED.

use super::*;
use fleetmap_core::mission::item::cmd::is_nav;

/// The mission protocol server, the execution state and whether the stored mission is valid.
#[derive(Debug)]
pub(super) struct Missions {
    /// The mission protocol server and the stored lists.
    pub(super) server: MissionServer,
    /// Execution state, reset at boot.
    pub(super) exec: Exec,
    /// Whether the stored mission passed the autopilot's checks (PX4 refuses AUTO otherwise).
    pub(super) valid: bool,
}

/// Mission execution state (items in the autopilot's numbering).
#[derive(Clone, Debug, Default)]
pub(super) struct Exec {
    pub(super) running: bool,
    pub(super) complete: bool,
    pub(super) nav_index: Option<u16>,
    pub(super) nav_started: bool,
    pub(super) nav_arrived: Option<Time>,
    pub(super) nav_point: Option<Point>,
    /// PX4: takeoff inserted before the current item.
    pub(super) px4_takeoff: Option<f64>,
    /// PX4: the position a take-off item is flown to after the climb (`None` inside: the
    /// item has none, latitude/longitude 0, 0, and is never reached).
    pub(super) px4_takeoff_target: Option<Option<Point>>,
    /// ArduPilot: the mission is waiting for MISSION_START (auto_armed false on the ground).
    pub(super) waiting_auto_armed: bool,
    pub(super) jumps: HashMap<u16, i32>,
    pub(super) reached: Option<(u16, u8, Time)>, // PX4: last reached seq, times resent, next resend
}

impl SimVehicle {
    pub(super) fn drain_mission_events(&mut self, now: Time) {
        while let Some(ev) = self.missions.server.poll_event() {
            match ev {
                MissionEvent::Uploaded {
                    mission_type: MissionType::Fence,
                    ..
                }
                | MissionEvent::Cleared {
                    mission_type: MissionType::Fence,
                } => self.rebuild_fence(true),
                MissionEvent::SetCurrent { seq } => self.set_current_item(seq, now),
                MissionEvent::Uploaded {
                    mission_type: MissionType::Mission,
                    ..
                }
                | MissionEvent::Cleared {
                    mission_type: MissionType::Mission,
                } => {
                    self.rebuild_fence(true);
                    if self.cfg.flavour.autopilot == SimAutopilot::Px4 {
                        // navigator reloads the new mission from its current item
                        self.missions.exec.nav_index = None;
                        self.missions.exec.nav_started = false;
                        self.missions.exec.complete = false;
                        self.missions.exec.jumps.clear();
                        if self.modes.mode == SimMode::Auto && self.arming.armed {
                            self.start_or_resume_mission(now);
                        }
                    }
                    self.send_mission_current(now);
                }
                _ => {}
            }
        }
    }

    pub(super) fn set_current_item(&mut self, seq: u16, now: Time) {
        self.missions.exec.nav_index = Some(seq);
        self.missions.exec.nav_started = false;
        self.missions.exec.nav_arrived = None;
        self.missions.exec.complete = false;
        if seq <= 1 {
            self.missions.exec.jumps.clear();
        }
        self.missions.server.set_current(seq);
        self.send_mission_current(now);
    }

    pub(super) fn start_or_resume_mission(&mut self, now: Time) {
        let first = match self.cfg.flavour.autopilot {
            SimAutopilot::ArduPilot => 1,
            SimAutopilot::Px4 => 0,
        };
        if self.missions.exec.complete || self.missions.exec.nav_index.is_none() {
            self.missions.exec.nav_index = Some(self.missions.server.current().max(first));
            if self.missions.exec.complete {
                self.missions.exec.nav_index = Some(first);
                self.missions.exec.jumps.clear();
            }
            self.missions.exec.complete = false;
        }
        self.missions.exec.running = true;
        self.missions.exec.nav_started = false;
        self.missions.exec.nav_arrived = None;
        self.missions.exec.waiting_auto_armed = false;
        self.missions.exec.px4_takeoff = None;
        self.missions.exec.px4_takeoff_target = None;
        self.missions.server.set_mission_running(true);
        if let Some(i) = self.missions.exec.nav_index {
            self.missions.server.set_current(i);
        }
        self.send_mission_current(now);
    }

    pub(super) fn item_point(&self, it: &MissionItem) -> Point {
        let (mut e, mut n) = self.est();
        if it.x != 0 || it.y != 0 {
            let (dn, de) = local::delta(
                self.cfg.reference.0,
                self.cfg.reference.1,
                f64::from(it.x) * 1e-7,
                f64::from(it.y) * 1e-7,
            );
            e = de;
            n = dn;
        }
        let u = match it.frame {
            mi::FRAME_GLOBAL | mi::FRAME_GLOBAL_INT => f64::from(it.z) - self.ground_amsl(),
            _ => f64::from(it.z),
        };
        let u = if self.cfg.flavour.is_copter() {
            u.max(0.0)
        } else {
            0.0
        };
        Point { e, n, u }
    }

    pub(super) fn run_mission(&mut self, now: Time) {
        if !self.missions.exec.running
            || self.missions.exec.complete
            || !self.arming.armed
            || self.missions.exec.waiting_auto_armed
        {
            if self.missions.exec.complete && !self.arming.armed && self.arming.landed {
                self.flight.nav = Nav::Idle;
            }
            return;
        }
        let mut guard = 0;
        loop {
            guard += 1;
            if guard > 300 {
                // a loop of items that never navigate (e.g. jumps only)
                self.mission_complete(now);
                return;
            }
            let Some(idx) = self.missions.exec.nav_index else {
                self.mission_complete(now);
                return;
            };
            let items = self.missions.server.items(MissionType::Mission);
            let Some(item) = items.get(idx as usize).copied() else {
                self.mission_complete(now);
                return;
            };
            if is_nav(item.command) {
                if !self.missions.exec.nav_started {
                    if !self.start_nav(idx, &item, now) {
                        // unsupported: skip (AP_Mission advances; PX4 skips)
                        self.advance_item(idx, &item, false, now);
                        continue;
                    }
                    self.missions.exec.nav_started = true;
                }
                if self.verify_nav(&item, now) {
                    self.nav_done(idx, &item, now);
                    continue;
                }
                return;
            }
            // do-commands
            if item.command == mi::DO_JUMP {
                // DO_JUMP
                self.do_jump(idx, &item, now);
                continue;
            }
            self.do_command(&item, now);
            let reached = match self.cfg.flavour.autopilot {
                // ArduCopter verify_command acknowledges DO_CHANGE_SPEED / DO_SET_HOME; the
                // camera commands are verified inside AP_Mission without a message
                SimAutopilot::ArduPilot => {
                    matches!(item.command, mi::DO_CHANGE_SPEED | mi::DO_SET_HOME)
                }
                SimAutopilot::Px4 => true,
            };
            self.advance_item(idx, &item, reached, now);
        }
    }

    pub(super) fn advance_item(&mut self, idx: u16, _item: &MissionItem, reached: bool, now: Time) {
        if reached {
            self.item_reached(idx, now);
        }
        self.missions.exec.nav_index = Some(idx + 1);
        self.missions.exec.nav_started = false;
        self.missions.exec.nav_arrived = None;
        let n = self.missions.server.items(MissionType::Mission).len() as u16;
        if idx + 1 < n {
            self.missions.server.set_current(idx + 1);
            // MISSION_CURRENT follows the nav command (ArduPilot) / every item (PX4)
            let next_is_nav = self
                .missions
                .server
                .items(MissionType::Mission)
                .get(usize::from(idx + 1))
                .is_some_and(|it| is_nav(it.command));
            if next_is_nav || self.cfg.flavour.autopilot == SimAutopilot::Px4 {
                self.send_mission_current(now);
            }
        }
    }

    pub(super) fn do_jump(&mut self, idx: u16, item: &MissionItem, now: Time) {
        let target = item.param1 as i64;
        let repeat = item.param2 as i32;
        let n = self.missions.server.items(MissionType::Mission).len() as i64;
        let first = if self.cfg.flavour.is_ardupilot() {
            1
        } else {
            0
        };
        if target < first || target >= n {
            self.advance_item(idx, item, false, now);
            return;
        }
        // Jumps are followed while looking for the next item and are never "reached"
        // themselves: AP_Mission::get_next_cmd, PX4 Mission::read_mission_item (which instead
        // re-sends the DO_JUMP item with its new counter when it changes).
        let done = self.missions.exec.jumps.entry(idx).or_insert(0);
        if repeat < 0 || *done < repeat {
            *done += 1;
            self.missions.exec.nav_index = Some(target as u16);
            self.missions.exec.nav_started = false;
            self.missions.exec.nav_arrived = None;
            self.missions.server.set_current(target as u16);
            self.send_mission_current(now);
        } else {
            self.advance_item(idx, item, false, now);
        }
    }

    pub(super) fn do_command(&mut self, item: &MissionItem, now: Time) {
        match item.command {
            mi::DO_CHANGE_SPEED => {
                // DO_CHANGE_SPEED: param2 speed m/s (≤ 0 keeps), -2 = default (PX4)
                if item.param2 > 0.0 {
                    self.flight.speed_override = Some(f64::from(item.param2));
                } else if item.param2 <= -2.0 {
                    self.flight.speed_override = None;
                }
            }
            // DO_DIGICAM_CONTROL: shooting command in param5 (x)
            mi::DO_DIGICAM_CONTROL if item.x == 1 => {
                if let Some(c) = self.live_camera() {
                    c.trigger();
                }
            }
            mi::DO_SET_CAM_TRIGG_DIST => {
                let pos = (self.flight.m.e, self.flight.m.n);
                if let Some(c) = self.live_camera() {
                    c.set_trigger_distance(f64::from(item.param1), pos);
                    if item.param3 >= 1.0 {
                        c.trigger();
                    }
                }
            }
            mi::IMAGE_START_CAPTURE => {
                if let Some(c) = self.live_camera() {
                    c.start_capture(f64::from(item.param2), item.param3.max(0.0) as u32, now);
                }
            }
            mi::IMAGE_STOP_CAPTURE => {
                if let Some(c) = self.live_camera() {
                    c.stop_capture();
                }
            }
            mi::DO_SET_HOME if item.param1 >= 0.5 => self.set_home_here(now),
            _ => {}
        }
    }

    pub(super) fn start_nav(&mut self, idx: u16, item: &MissionItem, now: Time) -> bool {
        let copter = self.cfg.flavour.is_copter();
        let px4 = self.cfg.flavour.autopilot == SimAutopilot::Px4;
        let p = self.item_point(item);
        self.missions.exec.nav_arrived = None;
        if self.cfg.flavour.is_ardupilot() {
            let msg = format!("Mission: {} {}", idx, cmd_name(item.command));
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, &msg);
        }
        match item.command {
            mi::NAV_TAKEOFF => {
                if !copter {
                    // rovers: a takeoff is a no-op (ArduRover skips it)
                    return false;
                }
                let here = self.here();
                let u = if px4
                    && !matches!(
                        item.frame,
                        mi::FRAME_GLOBAL_RELATIVE_ALT
                            | mi::FRAME_GLOBAL_RELATIVE_ALT_INT
                            | mi::FRAME_GLOBAL_TERRAIN_ALT
                            | mi::FRAME_GLOBAL_TERRAIN_ALT_INT
                    ) {
                    p.u
                } else {
                    f64::from(item.z).max(0.0)
                };
                if px4 {
                    // PX4 (navigator/mission.cpp): a take-off item is flown as a waypoint to its
                    // own position — at once when the copter is already in the air ("treat it
                    // as waypoint"), after the climb from the ground. An item without a
                    // position means latitude/longitude 0, 0: PX4 1.16 SITL never reached it
                    // and hovered at the take-off altitude, the mission stuck at item 0.
                    let target = (item.x != 0 || item.y != 0).then_some(Point { u, ..p });
                    self.missions.exec.px4_takeoff_target = Some(target);
                    self.missions.exec.nav_point = target;
                    self.flight.nav = if self.arming.landed {
                        Nav::Takeoff(Point { u, ..here })
                    } else {
                        match target {
                            Some(p) => Nav::Goto { p, speed: None },
                            None => Nav::Hold(Point { u, ..here }),
                        }
                    };
                    return true;
                }
                self.flight.nav = Nav::Takeoff(Point { u, ..here });
                self.missions.exec.nav_point = Some(Point { u, ..here });
            }
            mi::NAV_WAYPOINT
            | mi::NAV_LOITER_TIME
            | mi::NAV_LOITER_UNLIM
            | mi::NAV_SPLINE_WAYPOINT => {
                if px4
                    && self.arming.landed
                    && copter
                    && !matches!(self.flight.nav, Nav::Takeoff(_))
                {
                    // PX4 navigator: vertical takeoff to the item's altitude first
                    self.missions.exec.px4_takeoff = Some(p.u.max(2.5));
                    let here = self.here();
                    self.flight.nav = Nav::Takeoff(Point {
                        u: p.u.max(2.5),
                        ..here
                    });
                } else {
                    self.flight.nav = Nav::Goto { p, speed: None };
                }
                self.missions.exec.nav_point = Some(p);
            }
            mi::NAV_LAND => {
                if !copter {
                    return false;
                }
                let p = if item.x == 0 && item.y == 0 {
                    self.here()
                } else {
                    p
                };
                self.flight.nav = Nav::Land {
                    p,
                    descending: false,
                };
                self.missions.exec.nav_point = Some(p);
            }
            mi::NAV_RETURN_TO_LAUNCH => {
                let ret_u = if copter {
                    if px4 {
                        self.flight.m.u.max(30.0)
                    } else {
                        self.flight.m.u.max(15.0)
                    }
                } else {
                    0.0
                };
                self.flight.nav = Nav::Rtl {
                    phase: if copter {
                        RtlPhase::Climb
                    } else {
                        RtlPhase::Return
                    },
                    ret_u,
                };
            }
            mi::NAV_DELAY => {
                // NAV_DELAY: hold here for param1 seconds
                self.flight.nav = Nav::Hold(self.here());
                self.missions.exec.nav_arrived = Some(now);
            }
            _ => return false,
        }
        true
    }

    pub(super) fn verify_nav(&mut self, item: &MissionItem, now: Time) -> bool {
        let copter = self.cfg.flavour.is_copter();
        let px4 = self.cfg.flavour.autopilot == SimAutopilot::Px4;
        match item.command {
            mi::NAV_TAKEOFF if px4 && copter => {
                let Some(target) = self.missions.exec.px4_takeoff_target else {
                    return true;
                };
                if let Nav::Takeoff(p) = self.flight.nav {
                    if self.flight.m.u < p.u - 0.8 {
                        return false;
                    }
                    // Climbed: on to the item's position (or hover, without one).
                    self.flight.nav = match target {
                        Some(t) => Nav::Goto { p: t, speed: None },
                        None => Nav::Hold(p),
                    };
                }
                let Some(t) = target else {
                    return false;
                };
                let (e, n) = self.est();
                (t.e - e).hypot(t.n - n) <= 2.0 && (self.flight.m.u - t.u).abs() < 0.8
            }
            mi::NAV_TAKEOFF => match self.flight.nav {
                Nav::Takeoff(p) => self.flight.m.u >= p.u - 0.3,
                _ => true,
            },
            mi::NAV_WAYPOINT
            | mi::NAV_LOITER_TIME
            | mi::NAV_LOITER_UNLIM
            | mi::NAV_SPLINE_WAYPOINT => {
                if let Some(alt) = self.missions.exec.px4_takeoff {
                    if self.flight.m.u >= alt - 0.8 {
                        self.missions.exec.px4_takeoff = None;
                        if let Some(p) = self.missions.exec.nav_point {
                            self.flight.nav = Nav::Goto { p, speed: None };
                        }
                    }
                    return false;
                }
                let Some(p) = self.missions.exec.nav_point else {
                    return true;
                };
                let (e, n) = self.est();
                let dist = (p.e - e).hypot(p.n - n);
                let radius = if px4 {
                    if item.command == mi::NAV_WAYPOINT && item.param2 > 0.0 {
                        f64::from(item.param2)
                    } else {
                        2.0 // NAV_ACC_RAD
                    }
                } else if copter {
                    // ArduCopter SCurves: reached when the target is reached and the vehicle
                    // is close (WPNAV_RADIUS 2 m is the blend radius, not the acceptance)
                    0.3
                } else {
                    2.0 // WP_RADIUS
                };
                let vert_ok =
                    !copter || (self.flight.m.u - p.u).abs() < if px4 { 0.8 } else { 0.3 };
                let arrived = dist <= radius
                    && vert_ok
                    && (px4 || !copter || self.flight.m.ground_speed() < 0.5);
                if self.missions.exec.nav_arrived.is_none() {
                    if !arrived {
                        return false;
                    }
                    self.missions.exec.nav_arrived = Some(now);
                    let hold = self.hold_time(item);
                    if self.cfg.flavour.is_ardupilot() && hold > 0.0 {
                        // verify_nav_wp sends the reached message on arrival when there is a delay
                        if let Some(i) = self.missions.exec.nav_index {
                            self.send_item_reached_msg(i);
                        }
                    }
                    // hold at the waypoint during the delay
                    self.flight.nav = Nav::Hold(p);
                }
                let hold = self.hold_time(item);
                now.saturating_since(self.missions.exec.nav_arrived.unwrap_or(now))
                    .as_secs_f64()
                    >= hold
            }
            mi::NAV_LAND => {
                if let Nav::Land { p, descending } = self.flight.nav
                    && !descending
                {
                    let (e, n) = self.est();
                    if (p.e - e).hypot(p.n - n) < 1.0 {
                        self.flight.nav = Nav::Land {
                            p,
                            descending: true,
                        };
                    }
                }
                self.arming.landed && self.arming.took_off
            }
            mi::NAV_RETURN_TO_LAUNCH => {
                self.run_rtl(now);
                if !copter {
                    return matches!(
                        self.flight.nav,
                        Nav::Rtl {
                            phase: RtlPhase::Done,
                            ..
                        }
                    );
                }
                self.arming.landed && self.arming.took_off
            }
            mi::NAV_DELAY => {
                now.saturating_since(self.missions.exec.nav_arrived.unwrap_or(now))
                    .as_secs_f64()
                    >= f64::from(item.param1.max(0.0))
            }
            _ => true,
        }
    }

    pub(super) fn hold_time(&self, item: &MissionItem) -> f64 {
        match item.command {
            mi::NAV_WAYPOINT => f64::from(item.param1.max(0.0)),
            mi::NAV_LOITER_TIME => f64::from(item.param1.max(0.0)),
            mi::NAV_LOITER_UNLIM => f64::INFINITY,
            _ => 0.0,
        }
    }

    pub(super) fn nav_done(&mut self, idx: u16, item: &MissionItem, now: Time) {
        let ap = self.cfg.flavour.is_ardupilot();
        let arrived_msg_already =
            ap && item.command == mi::NAV_WAYPOINT && self.hold_time(item) > 0.0;
        if ap && item.command == mi::NAV_WAYPOINT {
            let msg = format!("Reached command #{idx}");
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, &msg);
        }
        if !arrived_msg_already {
            self.item_reached(idx, now);
        }
        // keep holding where the item ended until the next nav command starts
        if !self.arming.landed {
            self.flight.nav = Nav::Hold(
                self.missions
                    .exec
                    .nav_point
                    .filter(|_| item.command != mi::NAV_RETURN_TO_LAUNCH)
                    .unwrap_or(self.here()),
            );
        }
        if (item.command == mi::NAV_LAND || item.command == mi::NAV_RETURN_TO_LAUNCH)
            && self.arming.landed
        {
            self.advance_item(idx, item, false, now);
            self.mission_complete(now);
            return;
        }
        self.advance_item(idx, item, false, now);
    }

    pub(super) fn item_reached(&mut self, idx: u16, now: Time) {
        self.send_item_reached_msg(idx);
        if self.cfg.flavour.autopilot == SimAutopilot::Px4 {
            self.missions.exec.reached = Some((idx, 0, now + Duration::from_secs(1)));
        }
    }

    pub(super) fn send_item_reached_msg(&mut self, idx: u16) {
        self.queue(
            AUTOPILOT_COMPID,
            MavMessage::MISSION_ITEM_REACHED(mav::MISSION_ITEM_REACHED_DATA { seq: idx }),
        );
    }

    pub(super) fn update_mission_reached(&mut self, now: Time) {
        // PX4 mavlink_mission.cpp: resend the last reached item 10 times at 1 Hz
        if let Some((idx, count, next)) = self.missions.exec.reached
            && now >= next
        {
            if count >= 10 {
                self.missions.exec.reached = None;
            } else {
                self.send_item_reached_msg(idx);
                self.missions.exec.reached = Some((idx, count + 1, next + Duration::from_secs(1)));
            }
        }
    }

    pub(super) fn mission_complete(&mut self, now: Time) {
        self.missions.exec.complete = true;
        self.missions.exec.running = false;
        self.missions.server.set_mission_running(false);
        let px4 = self.cfg.flavour.autopilot == SimAutopilot::Px4;
        if self.arming.landed {
            if self.arming.armed {
                if px4 {
                    self.text(
                        mav::MavSeverity::MAV_SEVERITY_INFO,
                        "Mission finished, landed",
                    );
                }
                if self.cfg.flavour.is_copter() {
                    self.disarm(now, "landing");
                } else {
                    self.flight.nav = Nav::Hold(self.here());
                }
            }
        } else {
            if px4 {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_INFO,
                    "Mission finished, loitering",
                );
            }
            self.flight.nav = Nav::Hold(self.here());
        }
        self.send_mission_current(now);
    }
}

fn cmd_name(cmd: u16) -> &'static str {
    match cmd {
        mi::NAV_WAYPOINT => "WP",
        mi::NAV_LOITER_UNLIM => "LoitUnlim",
        mi::NAV_LOITER_TIME => "LoitTime",
        mi::NAV_RETURN_TO_LAUNCH => "RTL",
        mi::NAV_LAND => "Land",
        mi::NAV_TAKEOFF => "Takeoff",
        mi::NAV_DELAY => "Delay",
        _ => "Cmd",
    }
}

impl SimVehicle {
    // ------------------------------------------------------------------ commands
    // (dispatched by `commands::command`)

    /// DO_SET_MISSION_CURRENT: param1 the item, param2 > 0.5 also resets the DO_JUMP counters.
    pub(super) fn cmd_set_mission_current(
        &mut self,
        c: &mav::COMMAND_INT_DATA,
        now: Time,
    ) -> mav::MavResult {
        use mav::MavResult as R;
        let ap = self.cfg.flavour.is_ardupilot();
        let seq = c.param1 as i64;
        let n = self.missions.server.items(MissionType::Mission).len() as i64;
        if seq >= 0 && seq < n {
            self.set_current_item(seq.max(if ap { 1 } else { 0 }) as u16, now);
            if c.param2 > 0.5 {
                self.missions.exec.jumps.clear();
            }
            R::MAV_RESULT_ACCEPTED
        } else if ap {
            R::MAV_RESULT_FAILED
        } else {
            R::MAV_RESULT_DENIED
        }
    }

    pub(super) fn cmd_mission_start(
        &mut self,
        c: &mav::COMMAND_INT_DATA,
        now: Time,
    ) -> mav::MavResult {
        use mav::MavResult as R;
        if self.cfg.flavour.is_ardupilot() {
            if c.param1 != 0.0 || c.param2 != 0.0 {
                return R::MAV_RESULT_DENIED;
            }
            if self.set_mode_request(
                1,
                self.cfg.flavour.custom_mode(SimMode::Auto).unwrap_or(3),
                now,
            ) != R::MAV_RESULT_ACCEPTED
            {
                return R::MAV_RESULT_FAILED;
            }
            // ArduRover's MISSION_START is only a switch to AUTO (GCS_MAVLINK_Rover::
            // handle_command_int_packet, ArduPilot/ardupilot Rover/GCS_MAVLink_Rover.cpp): in
            // AUTO already — a finished mission leaves the rover there — it is ACCEPTED and
            // starts nothing (the mode switch above was a no-op). ArduCopter's handler also
            // calls `mission.start_or_resume()` when the mission is not running.
            let rover = self.cfg.flavour.kind == SimVehicleClass::Rover;
            if !rover && (!self.missions.exec.running || self.missions.exec.waiting_auto_armed) {
                self.start_or_resume_mission(now);
            }
            R::MAV_RESULT_ACCEPTED
        } else {
            if self.missions.server.items(MissionType::Mission).is_empty() || !self.missions.valid {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Mission start denied! No valid mission",
                );
                return R::MAV_RESULT_DENIED;
            }
            if self.check_mode_allowed(SimMode::Auto, now).is_err() {
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_CRITICAL,
                    "Switching to Mission is currently not possible",
                );
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            if !self.arming.armed && self.arm(now, false).is_err() {
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            if self.modes.mode != SimMode::Auto {
                self.enter_mode(SimMode::Auto, now);
            } else {
                self.start_or_resume_mission(now);
            }
            R::MAV_RESULT_ACCEPTED
        }
    }

    /// DO_PAUSE_CONTINUE (ArduCopter): param1 0 pauses (hold here), 1 resumes the mission.
    pub(super) fn cmd_pause_continue(&mut self, c: &mav::COMMAND_INT_DATA) -> mav::MavResult {
        if self.modes.mode == SimMode::Auto && !self.arming.landed {
            if c.param1 < 0.5 {
                self.missions.exec.running = false;
                self.flight.nav = Nav::Hold(self.here());
            } else {
                self.missions.exec.running = true;
                self.missions.exec.nav_started = false;
            }
            mav::MavResult::MAV_RESULT_ACCEPTED
        } else {
            self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Failed to pause");
            mav::MavResult::MAV_RESULT_FAILED
        }
    }
}
