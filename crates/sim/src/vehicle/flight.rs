//! Motion and navigation: the 20 Hz tick, the navigation target the controller flies to,
//! and home.

use super::*;

#[derive(Clone, Copy, Debug, PartialEq)]
/// A point in the local frame, metres (east, north, up above ground).
pub(super) struct Point {
    pub(super) e: f64,
    pub(super) n: f64,
    pub(super) u: f64,
}

#[derive(Clone, Copy, Debug, PartialEq)]
/// The phases of a return to launch.
pub(super) enum RtlPhase {
    Climb,
    Return,
    Descend,
    Loiter(Time),
    Land,
    Done,
}

#[derive(Clone, Copy, Debug, PartialEq)]
/// What the controller flies to.
pub(super) enum Nav {
    /// On the ground, motors off or idle.
    Idle,
    /// Hold a point.
    Hold(Point),
    /// Climb vertically to `u` at (e, n).
    Takeoff(Point),
    /// Fly to a point and stay there (guided / reposition / waypoint travel).
    Goto { p: Point, speed: Option<f64> },
    /// Land at (e, n): fly there first at the current height, then descend.
    Land { p: Point, descending: bool },
    /// Return to launch.
    Rtl { phase: RtlPhase, ret_u: f64 },
}

#[derive(Clone, Copy, Debug, PartialEq)]
/// Home: geodetic position, AMSL altitude and local (east, north) metres.
pub(super) struct Home {
    pub(super) lat: f64,
    pub(super) lon: f64,
    pub(super) alt_amsl: f64,
    pub(super) e: f64,
    pub(super) n: f64,
}

/// Motion state and the navigation target.
#[derive(Debug)]
pub(super) struct Flight {
    /// True motion state (position, velocity, heading).
    pub(super) m: motion::State,
    /// What the controller flies to.
    pub(super) nav: Nav,
    /// DO_CHANGE_SPEED's ground speed, m/s (`None`: the configured cruise speed).
    pub(super) speed_override: Option<f64>,
    /// A fixed heading for guided flight (degrees clockwise from north): ArduPilot's
    /// CONDITION_YAW, PX4's DO_REPOSITION yaw. `None`: face the direction of travel.
    pub(super) yaw_target_deg: Option<f64>,
    /// When the last guided setpoint arrived (PX4 offboard needs a stream).
    pub(super) guided_target_at: Option<Time>,
    /// Home, once set.
    pub(super) home: Option<Home>,
}

impl SimVehicle {
    // ------------------------------------------------------------------ the 20 Hz tick

    pub(super) fn tick(&mut self, now: Time) {
        // GPS error: first-order Gauss–Markov processes, 60 s correlation time. The shared
        // one advances also while this vehicle is off, to stay the same as the others'.
        let a = (-DT / 60.0f64).exp();
        let k = (1.0 - a * a).sqrt();
        let (b, bo) = (self.cfg.gps_error_sigma_m * k, self.cfg.gps_own_sigma_m * k);
        self.estimator.gps_common.0 =
            self.estimator.gps_common.0 * a + b * gauss(&mut self.estimator.gps_rng);
        self.estimator.gps_common.1 =
            self.estimator.gps_common.1 * a + b * gauss(&mut self.estimator.gps_rng);
        if !self.power.powered {
            if let Some(t) = self.power.power_on_at
                && now >= t
            {
                self.boot(now);
            }
            return;
        }
        self.estimator.gps_own.0 =
            self.estimator.gps_own.0 * a + bo * gauss(&mut self.estimator.rng);
        self.estimator.gps_own.1 =
            self.estimator.gps_own.1 * a + bo * gauss(&mut self.estimator.rng);
        // The mission protocol's own timers (see `mission_server`): ArduPilot re-requests an
        // item after 1 s and cancels an upload after 8 s without one, PX4 re-requests every
        // 250 ms and abandons a transfer after 5 s of silence.
        if self
            .missions
            .server
            .poll_timeout()
            .is_some_and(|t| t <= now)
        {
            self.missions.server.handle_timeout(now);
            self.drain_mission_events(now);
        }
        // The estimator smooths the GPS: the controller steers by a position whose error
        // drifts, but has no jumps from one 20 Hz tick to the next.
        let raw = self.gps_raw_err();
        let f = 1.0 - (-DT / ESTIMATE_LAG_S).exp();
        self.estimator.gps_lag.0 += f * (raw.0 - self.estimator.gps_lag.0);
        self.estimator.gps_lag.1 += f * (raw.1 - self.estimator.gps_lag.1);
        self.estimator.gps_err.0 += f * (self.estimator.gps_lag.0 - self.estimator.gps_err.0);
        self.estimator.gps_err.1 += f * (self.estimator.gps_lag.1 - self.estimator.gps_err.1);

        if !self.estimator.position_ok_announced && self.position_ok(now) {
            self.estimator.position_ok_announced = true;
            self.set_home_here(now);
            let origin = self.origin_msg(now);
            self.queue(AUTOPILOT_COMPID, origin);
            match self.cfg.flavour.autopilot {
                SimAutopilot::ArduPilot => {
                    self.text(
                        mav::MavSeverity::MAV_SEVERITY_INFO,
                        "EKF3 IMU0 is using GPS",
                    );
                }
                SimAutopilot::Px4 => {
                    self.text(mav::MavSeverity::MAV_SEVERITY_INFO, "Ready for takeoff!");
                }
            }
        }
        self.power.charging = false;
        self.run_mode(now);
        self.move_vehicle(now);
        self.drain_battery();
        self.check_failsafes(now);
        self.check_fence(now);
        self.check_auto_disarm(now);
        self.update_camera(now);
        self.update_mission_reached(now);
        self.emit_streams(now);
        self.check_swap(now);
    }

    pub(super) fn move_vehicle(&mut self, now: Time) {
        let rover = self.cfg.flavour.kind == SimVehicleClass::Rover;
        let was_landed = self.arming.landed;
        let cmd = self.motion_command();
        let (ee, en) = (self.estimator.gps_err.0, self.estimator.gps_err.1);
        // the controller acts on the estimate: shift the target by the estimation error
        let cmd = match cmd {
            Command::Goto {
                e,
                n,
                u,
                speed,
                yaw_deg,
            } => Command::Goto {
                e: e - ee,
                n: n - en,
                u,
                speed,
                yaw_deg,
            },
            Command::Descend { e, n, rate } => Command::Descend {
                e: e - ee,
                n: n - en,
                rate,
            },
            Command::Ground => Command::Ground,
        };
        let wind = self.wind_ne();
        let pinned = (self.flight.m.e, self.flight.m.n, self.flight.m.heading_deg);
        motion::step(&mut self.flight.m, &cmd, &self.cfg.limits, wind, rover, DT);
        if self.faults.stuck {
            // no horizontal progress: it stays where it is (a rover cannot turn either), a
            // copter may still climb and descend
            self.flight.m.e = pinned.0;
            self.flight.m.n = pinned.1;
            self.flight.m.ve = 0.0;
            self.flight.m.vn = 0.0;
            if rover {
                self.flight.m.heading_deg = pinned.2;
            }
        }
        if rover {
            self.arming.landed = true;
            return;
        }
        if self.flight.m.u > 0.05 {
            if self.arming.landed {
                self.arming.landed = false;
                self.arming.took_off = true;
                self.arming.landed_at = None;
            }
        } else if !was_landed && matches!(cmd, Command::Descend { .. }) && self.flight.m.u <= 0.0 {
            self.arming.landed = true;
            self.arming.landed_at = Some(now);
            self.flight.m.vu = 0.0;
            self.telemetry.events.push_back(VehicleEvent::Landed);
            self.on_touchdown(now);
        }
    }

    pub(super) fn motion_command(&self) -> Command {
        if !self.arming.armed {
            return Command::Ground;
        }
        let speed = self
            .flight
            .speed_override
            .unwrap_or(self.cfg.limits.speed_mps);
        let lim = &self.cfg.limits;
        match self.flight.nav {
            Nav::Idle => Command::Ground,
            Nav::Hold(p) => {
                if self.arming.landed && p.u <= 0.0 {
                    Command::Ground
                } else {
                    Command::Goto {
                        e: p.e,
                        n: p.n,
                        u: p.u,
                        speed,
                        yaw_deg: Some(self.flight.m.heading_deg),
                    }
                }
            }
            Nav::Takeoff(p) => Command::Goto {
                e: p.e,
                n: p.n,
                u: p.u,
                speed,
                yaw_deg: Some(self.flight.m.heading_deg),
            },
            Nav::Goto { p, speed: s } => {
                if self.arming.landed && self.cfg.flavour.is_copter() && p.u <= 0.0 {
                    return Command::Ground;
                }
                Command::Goto {
                    e: p.e,
                    n: p.n,
                    u: p.u,
                    speed: s.unwrap_or(speed),
                    yaw_deg: self.flight.yaw_target_deg,
                }
            }
            Nav::Land { p, descending } => {
                if self.arming.landed {
                    Command::Ground
                } else if descending {
                    let rate = if self.flight.m.u > 10.0 {
                        lim.descent_mps
                    } else if self.flight.m.u > 5.0 {
                        lim.land_mps
                            + (lim.descent_mps - lim.land_mps) * (self.flight.m.u - 5.0) / 5.0
                    } else {
                        lim.land_mps
                    };
                    Command::Descend {
                        e: p.e,
                        n: p.n,
                        rate,
                    }
                } else {
                    Command::Goto {
                        e: p.e,
                        n: p.n,
                        u: self.flight.m.u,
                        speed,
                        yaw_deg: None,
                    }
                }
            }
            Nav::Rtl { phase, ret_u } => {
                let h = self.home_local();
                let (ee, en) = self.est();
                match phase {
                    RtlPhase::Climb => Command::Goto {
                        e: ee,
                        n: en,
                        u: ret_u,
                        speed,
                        yaw_deg: Some(self.flight.m.heading_deg),
                    },
                    RtlPhase::Done if self.cfg.flavour.is_copter() => Command::Ground,
                    RtlPhase::Return | RtlPhase::Descend | RtlPhase::Loiter(_) | RtlPhase::Done => {
                        Command::Goto {
                            e: h.0,
                            n: h.1,
                            u: if self.cfg.flavour.is_copter() {
                                ret_u
                            } else {
                                0.0
                            },
                            speed: self.rtl_speed(),
                            yaw_deg: None,
                        }
                    }
                    RtlPhase::Land => {
                        if self.arming.landed {
                            Command::Ground
                        } else {
                            let rate = if self.flight.m.u > 10.0 {
                                lim.descent_mps
                            } else {
                                lim.land_mps
                            };
                            Command::Descend {
                                e: h.0,
                                n: h.1,
                                rate,
                            }
                        }
                    }
                }
            }
        }
    }

    pub(super) fn rtl_speed(&self) -> f64 {
        // ArduCopter RTL_SPEED 0 = WPNAV_SPEED; PX4 RTL uses the cruise speed; rovers WP_SPEED
        self.cfg.limits.speed_mps
    }

    pub(super) fn home_local(&self) -> (f64, f64) {
        self.flight
            .home
            .map(|h| (h.e, h.n))
            .unwrap_or_else(|| self.est())
    }

    pub(super) fn here(&self) -> Point {
        let (e, n) = self.est();
        Point {
            e,
            n,
            u: self.flight.m.u,
        }
    }

    pub(super) fn drain_battery(&mut self) {
        let load = if !self.arming.armed {
            0.01
        } else if self.cfg.flavour.kind == SimVehicleClass::Rover {
            0.05 + 0.95 * (self.flight.m.ground_speed() / 1.0).min(2.0)
        } else if self.arming.landed {
            0.1
        } else {
            let (wn, we) = self.wind_ne();
            let air = (self.flight.m.ve - we).hypot(self.flight.m.vn - wn);
            1.0 + 0.008 * air * air + 0.12 * self.flight.m.vu.max(0.0)
                - 0.08 * (-self.flight.m.vu).max(0.0)
        };
        if !self.power.charging {
            self.power.battery.drain(load, DT);
        }
        if self.power.battery.empty() && self.arming.armed && !self.arming.landed {
            // an empty pack: the vehicle comes down
            self.flight.nav = Nav::Land {
                p: self.here(),
                descending: true,
            };
        }
    }
}

/// Whether a command's frame gives altitudes relative to home (GLOBAL_RELATIVE_ALT, its
/// _INT form) rather than AMSL.
fn is_relative_alt(frame: mav::MavFrame) -> bool {
    matches!(
        frame,
        mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
            | mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
    )
}

impl SimVehicle {
    // ------------------------------------------------------------------ commands
    // (dispatched by `commands::command`)

    pub(super) fn cmd_takeoff(&mut self, c: &mav::COMMAND_INT_DATA, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        let ap = self.cfg.flavour.is_ardupilot();
        if !self.cfg.flavour.is_copter() {
            return if ap {
                R::MAV_RESULT_UNSUPPORTED
            } else {
                R::MAV_RESULT_TEMPORARILY_REJECTED
            };
        }
        if ap {
            // GCS_MAVLINK_Copter::handle_MAV_CMD_NAV_TAKEOFF / SimMode::do_user_takeoff
            if c.frame != mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT {
                return R::MAV_RESULT_DENIED;
            }
            let alt = f64::from(c.z);
            let user_takeoff = matches!(
                self.modes.mode,
                SimMode::Guided | SimMode::Hold | SimMode::AltHold
            );
            if !self.arming.armed || !self.arming.landed || !user_takeoff || alt <= self.flight.m.u
            {
                return R::MAV_RESULT_FAILED;
            }
            let here = self.here();
            self.flight.nav = Nav::Takeoff(Point { u: alt, ..here });
            R::MAV_RESULT_ACCEPTED
        } else {
            // PX4 switches to AUTO_TAKEOFF on NAV_TAKEOFF in the air too (Commander's
            // VEHICLE_CMD_NAV_TAKEOFF; PX4 1.16 SIH: ACCEPTED while climbing and at altitude)
            if self.check_mode_allowed(SimMode::Takeoff, now).is_err() {
                let msg = format!(
                    "Switching to {} is currently not possible",
                    self.cfg.flavour.mode_name(SimMode::Takeoff)
                );
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            // param7 is an AMSL altitude; NaN → MIS_TAKEOFF_ALT
            let alt = if c.z.is_finite() {
                match c.frame {
                    mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
                    | mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT => f64::from(c.z),
                    _ => {
                        f64::from(c.z)
                            - self
                                .flight
                                .home
                                .map(|h| h.alt_amsl)
                                .unwrap_or(self.ground_amsl())
                    }
                }
            } else {
                // MIS_TAKEOFF_ALT, as the commander says
                self.text(
                    mav::MavSeverity::MAV_SEVERITY_INFO,
                    "Using default takeoff altitude: 2.5 m",
                );
                2.5
            };
            self.enter_mode(SimMode::Takeoff, now);
            let here = self.here();
            // already higher: the navigator's take-off holds the altitude it is at
            self.flight.nav = Nav::Takeoff(Point {
                u: alt.max(1.0).max(here.u),
                ..here
            });
            R::MAV_RESULT_ACCEPTED
        }
    }

    /// DO_CHANGE_SPEED: param2 the ground speed, m/s (ArduPilot denies a speed ≤ 0, PX4
    /// accepts and ignores it).
    pub(super) fn cmd_change_speed(&mut self, c: &mav::COMMAND_INT_DATA) -> mav::MavResult {
        use mav::MavResult as R;
        if c.param2 <= 0.0 {
            if self.cfg.flavour.is_ardupilot() {
                R::MAV_RESULT_DENIED
            } else {
                R::MAV_RESULT_ACCEPTED
            }
        } else {
            self.flight.speed_override = Some(f64::from(c.param2));
            R::MAV_RESULT_ACCEPTED
        }
    }

    /// GET_HOME_POSITION: HOME_POSITION, or FAILED before home is set.
    pub(super) fn cmd_get_home_position(&mut self, now: Time) -> mav::MavResult {
        if self.flight.home.is_some() {
            self.queue(AUTOPILOT_COMPID, self.home_position_msg(now));
            mav::MavResult::MAV_RESULT_ACCEPTED
        } else {
            mav::MavResult::MAV_RESULT_FAILED
        }
    }

    /// DO_SET_HOME: param1 = 1 the current position, else the given latitude/longitude
    /// (degrees × 1e7) and altitude (relative frames add the current home's altitude).
    pub(super) fn cmd_set_home(&mut self, c: &mav::COMMAND_INT_DATA, now: Time) -> mav::MavResult {
        use mav::MavResult as R;
        if c.param1 > 0.5 {
            return if self.position_ok(now) {
                self.set_home_here(now);
                R::MAV_RESULT_ACCEPTED
            } else {
                R::MAV_RESULT_FAILED
            };
        }
        let lat = f64::from(c.x) * 1e-7;
        let lon = f64::from(c.y) * 1e-7;
        if !(-90.0..=90.0).contains(&lat)
            || !(-180.0..=180.0).contains(&lon)
            || (c.x == 0 && c.y == 0)
        {
            return R::MAV_RESULT_DENIED;
        }
        let (n, e) = local::delta(self.cfg.reference.0, self.cfg.reference.1, lat, lon);
        let alt = if is_relative_alt(c.frame) {
            self.flight
                .home
                .map(|h| h.alt_amsl)
                .unwrap_or(self.ground_amsl())
                + f64::from(c.z)
        } else {
            f64::from(c.z)
        };
        self.flight.home = Some(Home {
            lat,
            lon,
            alt_amsl: alt,
            e,
            n,
        });
        self.missions.server.set_home(Some(HomeItem {
            lat_e7: c.x,
            lon_e7: c.y,
            alt_amsl_m: alt as f32,
        }));
        self.queue(AUTOPILOT_COMPID, self.home_position_msg(now));
        R::MAV_RESULT_ACCEPTED
    }

    pub(super) fn target_from_command(
        &self,
        c: &mav::COMMAND_INT_DATA,
        long: bool,
        nan_pos: bool,
    ) -> Point {
        let here = self.here();
        let px4 = !self.cfg.flavour.is_ardupilot();
        let (e, n) = if nan_pos || (c.x == 0 && c.y == 0) {
            (here.e, here.n)
        } else {
            let (dn, de) = local::delta(
                self.cfg.reference.0,
                self.cfg.reference.1,
                f64::from(c.x) * 1e-7,
                f64::from(c.y) * 1e-7,
            );
            (de, dn)
        };
        let u = if !c.z.is_finite() {
            here.u
        } else {
            match c.frame {
                mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT
                | mav::MavFrame::MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
                | mav::MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT
                | mav::MavFrame::MAV_FRAME_GLOBAL_TERRAIN_ALT_INT => f64::from(c.z),
                _ => {
                    // AMSL (COMMAND_LONG to ArduPilot is converted with frame GLOBAL; PX4's
                    // reposition altitude is AMSL)
                    let _ = (long, px4);
                    f64::from(c.z) - self.ground_amsl()
                }
            }
        };
        let u = if self.cfg.flavour.is_copter() {
            u.max(0.0)
        } else {
            0.0
        };
        Point { e, n, u }
    }

    pub(super) fn cmd_reposition(
        &mut self,
        c: &mav::COMMAND_INT_DATA,
        long: bool,
        nan_pos: bool,
        now: Time,
    ) -> mav::MavResult {
        use mav::MavResult as R;
        let change_mode = (c.param2 as i32) & 1 == 1;
        // PX4's navigator flies a reposition at param1 (ground speed) when positive;
        // ArduCopter ignores it (GUIDED keeps WPNAV_SPEED or the last DO_CHANGE_SPEED)
        let speed = if c.param1 > 0.0 && !self.cfg.flavour.is_ardupilot() {
            Some(f64::from(c.param1))
        } else {
            None
        };
        if self.cfg.flavour.is_ardupilot() {
            // GCS_MAVLINK_Copter::handle_command_int_do_reposition
            if self.modes.mode != SimMode::Guided && !change_mode {
                return R::MAV_RESULT_DENIED;
            }
            if !nan_pos && (c.x.abs() > 900_000_000 || c.y.abs() > 1_800_000_000) {
                return R::MAV_RESULT_DENIED;
            }
            if !self.position_ok(now) {
                return R::MAV_RESULT_FAILED;
            }
            let p = self.target_from_command(c, long, nan_pos);
            if self.modes.mode != SimMode::Guided
                && self.set_mode_request(
                    1,
                    self.cfg.flavour.custom_mode(SimMode::Guided).unwrap_or(4),
                    now,
                ) != R::MAV_RESULT_ACCEPTED
            {
                return R::MAV_RESULT_FAILED;
            }
            self.flight.guided_target_at = Some(now);
            // A new destination returns the yaw to WP_YAW_BEHAVIOR (ModeGuided::set_destination
            // without a yaw): a CONDITION_YAW must come after it.
            self.flight.yaw_target_deg = None;
            if !(self.arming.landed && self.cfg.flavour.is_copter()) {
                self.flight.nav = Nav::Goto { p, speed };
            }
            R::MAV_RESULT_ACCEPTED
        } else {
            // Commander: only the change-mode bit is supported; the navigator flies there in Hold
            if !change_mode || (c.param2 as i32) & !1 != 0 {
                return R::MAV_RESULT_UNSUPPORTED;
            }
            if self.check_mode_allowed(SimMode::Hold, now).is_err() {
                let msg = format!(
                    "Switching to {} is currently not possible",
                    self.cfg.flavour.mode_name(SimMode::Hold)
                );
                self.text(mav::MavSeverity::MAV_SEVERITY_CRITICAL, &msg);
                return R::MAV_RESULT_TEMPORARILY_REJECTED;
            }
            let p = self.target_from_command(c, long, nan_pos);
            self.enter_mode(SimMode::Hold, now);
            // navigator_main.cpp: a finite param4 is the yaw setpoint, in radians.
            self.flight.yaw_target_deg = c
                .param4
                .is_finite()
                .then(|| f64::from(c.param4).to_degrees().rem_euclid(360.0));
            if !(self.arming.landed && self.cfg.flavour.is_copter()) {
                self.flight.nav = Nav::Goto { p, speed };
            }
            R::MAV_RESULT_ACCEPTED
        }
    }

    /// ArduCopter's MAV_CMD_CONDITION_YAW outside a mission (GCS_MAVLINK_Copter): param1
    /// the angle (0..360), param2 the rate (0 = default), param3 the direction, param4 1 =
    /// relative to the current heading, 0 = absolute; anything else FAILED. It sets a fixed
    /// yaw for the guided flight; in other modes the yaw is accepted and soon forgotten.
    pub(super) fn cmd_condition_yaw(&mut self, c: &mav::COMMAND_INT_DATA) -> mav::MavResult {
        use mav::MavResult as R;
        let relative = c.param4 == 1.0;
        if !(0.0..=360.0).contains(&c.param1) || !(c.param4 == 0.0 || relative) {
            return R::MAV_RESULT_FAILED;
        }
        let angle = f64::from(c.param1);
        let target = if relative {
            let dir = if c.param3 < 0.0 { -1.0 } else { 1.0 };
            self.flight.m.heading_deg + dir * angle
        } else {
            angle
        };
        if self.modes.mode == SimMode::Guided {
            self.flight.yaw_target_deg = Some(target.rem_euclid(360.0));
        }
        R::MAV_RESULT_ACCEPTED
    }

    pub(super) fn position_target(
        &mut self,
        p: &mav::SET_POSITION_TARGET_GLOBAL_INT_DATA,
        now: Time,
    ) {
        let mask = p.type_mask.bits();
        let pos_ignore = mask & 0b111 == 0b111;
        let ap = self.cfg.flavour.is_ardupilot();
        if ap && self.modes.mode != SimMode::Guided {
            return; // ignored outside GUIDED
        }
        if pos_ignore {
            return; // velocity/acceleration targets are not simulated
        }
        let frame = p.coordinate_frame as u8;
        let c = mav::COMMAND_INT_DATA {
            x: p.lat_int,
            y: p.lon_int,
            z: p.alt,
            frame: mav::MavFrame::from_u8(frame).unwrap_or(mav::MavFrame::MAV_FRAME_GLOBAL),
            ..mav::COMMAND_INT_DATA::default()
        };
        if !matches!(frame, 0 | 3 | 5 | 6 | 10 | 11) {
            return;
        }
        let target = self.target_from_command(&c, false, false);
        self.flight.guided_target_at = Some(now);
        self.flight.yaw_target_deg = None;
        // ArduCopter does not take off for a position target; PX4 offboard does
        if self.modes.mode == SimMode::Guided
            && !(ap && self.arming.landed && self.cfg.flavour.is_copter())
        {
            self.flight.nav = Nav::Goto {
                p: target,
                speed: None,
            };
        }
    }
}
