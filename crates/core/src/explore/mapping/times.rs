//! The mission clock of a runway-mapping run: how long the team took from the first
//! take-off to the start of the DFS, to the complete map and to the last landing, and where
//! each drone's time went — flying, hovering while it waits, on the ground.
//!
//! Every figure is in seconds of the **fleet clock** the runner reads (the vehicles' clock:
//! the wall clock with real vehicles, the simulator's own time when the simulator runs in the
//! same process, tokio's virtual time in the tests). The core reads no clock: the runner
//! samples every drone every [`CLOCK_SAMPLE_S`] seconds of that clock
//! ([`MappingState::sample_clock`]: airborne or not, and what its pilot is doing) and each
//! sample's interval goes to one share; the milestones are stamped by the `on_*` calls that
//! reach them, at their own `now`. The figures are saved with the state, so a resumed run
//! carries on from them; the time between a stop and its resume (no runner, no clock) is not
//! counted ([`MissionClock::starts`] says how many times the runner started).

use super::*;

/// How often the runner samples the drones for the mission clock, seconds of the fleet clock.
pub const CLOCK_SAMPLE_S: f64 = 0.5;

/// Why an airborne drone holds instead of working (what its pilot waits for).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Wait {
    /// Another drone is confirming a candidate cell; the sweeps are stopped (§7).
    Confirmation,
    /// Its own sweep is flown; the others' are not (nothing found yet).
    Sweep,
    /// Its sweep is flown and pictures are still in transfer.
    Pictures,
    /// At the DFS's root before the team's first split: the drones that flew there first wait
    /// for the last one (Algorithm 1 decides with every robot at the vertex).
    DfsStart,
    /// At a vertex later: companions still on their way, or another drone imaging the cell.
    Vertex,
    /// The operator paused the run.
    Operator,
}

/// What a drone's pilot is doing, as the runner reports it with each sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Activity {
    /// Flying a directive: its sweep, to a cell, home (the default).
    Working,
    /// Over a cell, taking its pictures (confirmation or DFS visit).
    Imaging,
    /// Holding, waiting for something else to happen.
    Waiting(Wait),
}

/// The share one sample's interval went to.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Share {
    /// Airborne, working (sweep lanes, to a cell, home at the end).
    Flying,
    /// Airborne over a cell taking its pictures.
    Imaging,
    /// Airborne, flying home: for a battery swap (or landing for good when the map is complete
    /// by then), or at the end.
    Homing,
    /// Airborne after the map was complete, not yet homing: the DFS's way back to its start
    /// (Algorithm 1 ends with every robot at the start).
    Returning,
    /// Airborne, holding.
    Waiting(Wait),
    /// On the ground, before its first take-off.
    GroundBefore,
    /// On the ground between two flights (a battery swap, a camera fault, the take-off after).
    GroundSwap,
    /// On the ground, done, while others still fly.
    GroundDone,
}

/// Seconds an airborne drone spent holding, by what it waited for.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct WaitTimes {
    /// While another drone confirmed a candidate.
    pub confirmation_s: f64,
    /// Its sweep flown, the others' not.
    pub sweep_s: f64,
    /// Its sweep flown, pictures still in transfer.
    pub pictures_s: f64,
    /// At the DFS root before the team's first split.
    pub dfs_start_s: f64,
    /// At a later vertex.
    pub vertex_s: f64,
    /// Paused by the operator.
    pub operator_s: f64,
}

impl WaitTimes {
    /// Every wait, seconds.
    pub fn total(&self) -> f64 {
        self.confirmation_s
            + self.sweep_s
            + self.pictures_s
            + self.dfs_start_s
            + self.vertex_s
            + self.operator_s
    }

    fn add(&mut self, w: Wait, dt: f64) {
        *match w {
            Wait::Confirmation => &mut self.confirmation_s,
            Wait::Sweep => &mut self.sweep_s,
            Wait::Pictures => &mut self.pictures_s,
            Wait::DfsStart => &mut self.dfs_start_s,
            Wait::Vertex => &mut self.vertex_s,
            Wait::Operator => &mut self.operator_s,
        } += dt;
    }
}

/// One drone's time since the team's first take-off, seconds of the fleet clock. The three
/// shares — `flying_s`, `waiting.total()`, `ground_s` — add up to the run's
/// [`MissionClock::elapsed_s`] (every drone is in exactly one of them at every sample).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct RobotTimes {
    /// Airborne and working: sweep, flights to cells, pictures, flights home.
    pub flying_s: f64,
    /// Of `flying_s`: over a cell taking its pictures.
    pub imaging_s: f64,
    /// Of `flying_s`: flying home — for a battery swap, or at the end.
    pub homing_s: f64,
    /// Of `flying_s`: after the map was complete, before homing: the step a drone was flying
    /// when the last vertex was imaged (in runs before drones went home from where they
    /// were, the walk back to the DFS's start).
    pub returning_s: f64,
    /// Airborne and holding, by reason.
    pub waiting: WaitTimes,
    /// On the ground.
    pub ground_s: f64,
    /// Of `ground_s`: before its first take-off (the others already flew).
    pub ground_before_s: f64,
    /// Of `ground_s`: between two flights (battery swap, camera fault, preparing to take off).
    pub ground_swap_s: f64,
    /// Of `ground_s`: landed for good while others still flew.
    pub ground_done_s: f64,
    /// It has been airborne in this run.
    pub flown: bool,
    /// The share of its last sample (the interval up to the last landing goes there).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub last: Option<Share>,
}

impl RobotTimes {
    /// Airborne, holding, seconds.
    pub fn waiting_s(&self) -> f64 {
        self.waiting.total()
    }

    /// All its shares: the time since the team's first take-off it was accounted for.
    pub fn accounted_s(&self) -> f64 {
        self.flying_s + self.waiting_s() + self.ground_s
    }

    fn add(&mut self, share: Share, dt: f64) {
        match share {
            Share::Flying => self.flying_s += dt,
            Share::Imaging => {
                self.flying_s += dt;
                self.imaging_s += dt;
            }
            Share::Homing => {
                self.flying_s += dt;
                self.homing_s += dt;
            }
            Share::Returning => {
                self.flying_s += dt;
                self.returning_s += dt;
            }
            Share::Waiting(w) => self.waiting.add(w, dt),
            Share::GroundBefore => {
                self.ground_s += dt;
                self.ground_before_s += dt;
            }
            Share::GroundSwap => {
                self.ground_s += dt;
                self.ground_swap_s += dt;
            }
            Share::GroundDone => {
                self.ground_s += dt;
                self.ground_done_s += dt;
            }
        }
    }
}

/// A moment of the mission, journalled when reached.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MilestoneKind {
    /// The first drone left the ground (the mission clock's zero).
    FirstTakeoff,
    /// A confirmation found the region: the DFS starts.
    DfsStart,
    /// Every cell decided: every vertex of the DFS tree imaged (or the sweep ended without
    /// finding the region).
    MapComplete,
    /// The last drone landed: the run is over.
    LastLanding,
}

/// A milestone and when, seconds since the first take-off (fleet clock).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Milestone {
    /// Which.
    pub what: MilestoneKind,
    /// Seconds since the first take-off.
    pub mission_s: f64,
}

/// The run's mission clock (see the module docs). Seconds of the fleet clock.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MissionClock {
    /// From the runner's first start to the first take-off (missions uploaded, drones armed).
    pub before_takeoff_s: f64,
    /// A drone has taken off: the clock runs.
    pub took_off: bool,
    /// Since the first take-off, up to the last sample (or the last landing).
    pub elapsed_s: f64,
    /// The DFS started (a confirmation found the region), seconds since the first take-off.
    pub dfs_start_s: Option<f64>,
    /// The map was complete (every cell decided), seconds since the first take-off.
    pub map_complete_s: Option<f64>,
    /// The last drone landed, seconds since the first take-off.
    pub last_landing_s: Option<f64>,
    /// How many times a runner started on this run (1: never resumed). The time between a
    /// stop and its resume is not in these figures.
    pub starts: u32,
    /// The fleet-clock time of the last sample by this runner (`None` until its first
    /// sample: a resumed run's fleet clock may have another epoch).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub(crate) sampled_at: Option<Time>,
    /// Milestones reached and not yet journalled ([`MappingState::take_milestones`]).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub(crate) unjournalled: Vec<Milestone>,
}

impl MissionClock {
    /// Seconds since the first take-off at fleet-clock time `now` (0 before it).
    pub(crate) fn mission_s_at(&self, now: Time) -> f64 {
        if !self.took_off {
            return 0.0;
        }
        let since = self
            .sampled_at
            .map_or(0.0, |t| now.saturating_since(t).as_secs_f64());
        self.elapsed_s + since
    }

    /// The milestones reached, in the order of the mission.
    pub fn milestones(&self) -> Vec<Milestone> {
        let mut out = Vec::new();
        if self.took_off {
            out.push(Milestone {
                what: MilestoneKind::FirstTakeoff,
                mission_s: 0.0,
            });
        }
        for (what, t) in [
            (MilestoneKind::DfsStart, self.dfs_start_s),
            (MilestoneKind::MapComplete, self.map_complete_s),
            (MilestoneKind::LastLanding, self.last_landing_s),
        ] {
            if let Some(mission_s) = t {
                out.push(Milestone { what, mission_s });
            }
        }
        out
    }

    fn reach(&mut self, what: MilestoneKind, mission_s: f64) {
        self.unjournalled.push(Milestone { what, mission_s });
    }
}

impl MappingState {
    /// A runner starts (or resumes) on this run: the mission clock waits for its first
    /// sample.
    pub fn restart_clock(&mut self) {
        self.clock.starts += 1;
        self.clock.sampled_at = None;
    }

    /// One sample of the mission clock at fleet-clock time `now`: for every drone, whether
    /// it is airborne and what its pilot is doing. The interval since the previous sample
    /// goes to each drone's share; before any drone has flown it is time before the take-off,
    /// after the last landing nothing counts.
    pub fn sample_clock(&mut self, now: Time, drones: &[(u8, bool, Activity)]) {
        let dt = self
            .clock
            .sampled_at
            .map_or(0.0, |t| now.saturating_since(t).as_secs_f64());
        self.clock.sampled_at = Some(now);
        if self.clock.last_landing_s.is_some() {
            return;
        }
        if !self.clock.took_off {
            // The first drone left the ground within this interval: the clock starts now.
            self.clock.before_takeoff_s += dt;
            if drones.iter().any(|&(_, airborne, _)| airborne) {
                self.clock.took_off = true;
                self.clock.reach(MilestoneKind::FirstTakeoff, 0.0);
                for &(sysid, airborne, _) in drones {
                    if let Ok(r) = self.robot_mut(sysid) {
                        r.times.flown |= airborne;
                    }
                }
            }
            return;
        }
        self.clock.elapsed_s += dt;
        let mapped = self.clock.map_complete_s.is_some();
        for &(sysid, airborne, doing) in drones {
            let Ok(r) = self.robot_mut(sysid) else {
                continue;
            };
            let share = match (airborne, doing) {
                (true, Activity::Waiting(w)) => Share::Waiting(w),
                (true, Activity::Imaging) => Share::Imaging,
                (true, Activity::Working)
                    if matches!(
                        r.status,
                        RobotStatus::ReturningForSwap | RobotStatus::ReturningHome
                    ) =>
                {
                    Share::Homing
                }
                (true, Activity::Working) if mapped => Share::Returning,
                (true, Activity::Working) => Share::Flying,
                (false, _)
                    if matches!(r.status, RobotStatus::Landed | RobotStatus::ReturningHome) =>
                {
                    Share::GroundDone
                }
                (false, _) if r.times.flown => Share::GroundSwap,
                (false, _) => Share::GroundBefore,
            };
            r.times.add(share, dt);
            r.times.last = Some(share);
            r.times.flown |= airborne;
        }
    }

    /// Whether every cell the run will decide is decided: every vertex of the DFS tree imaged
    /// (nothing can add one then: only a vertex's pictures add children), or the run over.
    pub(crate) fn map_complete(&self) -> bool {
        match self.phase {
            // Given up: complete only if every vertex had been imaged by then.
            Phase::Finished {
                gave_up: Some(_), ..
            } => {}
            Phase::Finished { .. } => return true,
            _ => {}
        }
        self.explorer.as_ref().is_some_and(|e| {
            e.tree()
                .nodes()
                .iter()
                .filter(|n| n.kind == crate::explore::dfs::NodeKind::Real)
                .all(|n| n.observed)
        })
    }

    /// Stamp the milestones the last call reached at fleet-clock time `now`. At the last
    /// landing the interval since the last sample goes to each drone's last share, so the
    /// shares add up to the mission time exactly.
    pub(super) fn note_milestones(&mut self, now: Time) {
        let at = self.clock.mission_s_at(now);
        if self.clock.dfs_start_s.is_none() && self.explorer.is_some() {
            self.clock.dfs_start_s = Some(at);
            self.clock.reach(MilestoneKind::DfsStart, at);
        }
        if self.clock.map_complete_s.is_none() && self.map_complete() {
            self.clock.map_complete_s = Some(at);
            self.clock.reach(MilestoneKind::MapComplete, at);
        }
        if self.clock.last_landing_s.is_none() && self.is_finished() {
            if self.clock.took_off {
                let dt = at - self.clock.elapsed_s;
                for r in &mut self.robots {
                    if let Some(share) = r.times.last {
                        r.times.add(share, dt);
                    }
                }
                self.clock.elapsed_s = at;
                self.clock.sampled_at = Some(now);
            }
            self.clock.last_landing_s = Some(at);
            self.clock.reach(MilestoneKind::LastLanding, at);
        }
    }

    /// The milestones reached since the last call, for the journal (the runner writes them
    /// with the step that saves the state).
    pub fn take_milestones(&mut self) -> Vec<Milestone> {
        std::mem::take(&mut self.clock.unjournalled)
    }
}
