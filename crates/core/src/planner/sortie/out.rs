//! Members out of the run for now: a drone that could not take off, a station that could not
//! drive. The run goes on without them and tries them again later; the state says who is out
//! and why, so a resumed run knows it too.
//!
//! What the sortie does without a member:
//!
//! * **A drone that cannot start** stays where it is — landed, disarmed, on its station's
//!   charger — and is left out of the plan: the integer program plans the other drones, and
//!   the station it stands on is **held on its cell** for the plan with that charger taken
//!   ([`crate::planner::scenario::Pin`]): no rover drives with a drone on its pad that may be
//!   armed or looked at by a person, and no other drone is sent to land on the pad it takes.
//!   Its capture visits of the sortie are not flown; the epoch's goals it would have measured
//!   are planned for the others (the rest of the epoch is re-planned), or left for later
//!   epochs.
//! * **A station that cannot drive** is held on its cell the same way (no charger taken):
//!   drones still take off from it and land on it.
//! * A sortie that finds a member unable to start is **dropped before anything moves**
//!   ([`ClassificationState::start_failed`]): the drones already in the air hover over their
//!   stations, which have not left, while the rest of the epoch is planned again without it.
//!
//! Trying again: a member that went out for a reason a retry may fix (a lost link, a refused
//! take-off) sits out `2^(n−1) − 1` sorties after its n-th failed start in a row (0, 1, 3, 7,
//! then 7), one that a person must fix (a pre-arm failure that persists, a vehicle that never
//! became ready) as many; then it is **eligible** ([`ClassificationState::eligible`]) and the
//! shell takes it back ([`ClassificationState::reinstate`]) once its telemetry says it is
//! ready. A resume (`fleetmap resume`: the operator says so) makes every member eligible at
//! once ([`ClassificationState::on_resume`]).

use super::*;

/// A member out of the run for now (see the module docs).
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Sidelined {
    /// Drone or station.
    pub role: Role,
    /// What failed, as the operator was told.
    pub reason: String,
    /// What a person must fix before it can take part again (`None`: it is tried again by
    /// itself).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fix: Option<String>,
    /// The epoch it went out in.
    pub epoch: u64,
    /// Sorties still to sit out before it is tried again.
    pub wait_sorties: u32,
}

/// Most sorties a member sits out between two tries.
pub(crate) const MAX_WAIT_SORTIES: u32 = 7;

impl ClassificationState {
    /// The role of member `sysid`.
    pub fn role_of(&self, sysid: u8) -> Option<Role> {
        if self.drones.iter().any(|m| m.sysid == sysid) {
            Some(Role::Drone)
        } else if self.stations.iter().any(|m| m.sysid == sysid) {
            Some(Role::Station)
        } else {
            None
        }
    }

    /// Whether member `sysid` is out of the run now.
    pub fn is_out(&self, sysid: u8) -> bool {
        self.out.contains_key(&sysid)
    }

    /// The drones that take part now (not out), in team order.
    pub fn active_drones(&self) -> Vec<u8> {
        self.drones
            .iter()
            .map(|m| m.sysid)
            .filter(|s| !self.is_out(*s))
            .collect()
    }

    /// The sortie could not start: `failed` = (vehicle, what failed, what a person must fix
    /// if anything). Each goes out ([`Sidelined`], its failed starts in a row counted for
    /// the back-off), and the sortie is dropped — nothing drove, the drones in the air hover
    /// over their stations — and the rest of the epoch planned again from `actual` (where
    /// telemetry puts the team) without them.
    pub fn start_failed(
        &mut self,
        actual: TeamConfig,
        failed: &[(u8, String, Option<String>)],
    ) -> Result<(), SortieError> {
        let p = self.bandit.epoch;
        for (sysid, reason, fix) in failed {
            let role = self
                .role_of(*sysid)
                .ok_or(SortieError::UnknownVehicle(*sysid))?;
            let n = self.start_failures.entry(*sysid).or_insert(0);
            *n += 1;
            let wait = (1u32 << (*n - 1).min(8))
                .saturating_sub(1)
                .min(MAX_WAIT_SORTIES);
            self.out.insert(
                *sysid,
                Sidelined {
                    role,
                    reason: reason.clone(),
                    fix: fix.clone(),
                    epoch: p,
                    wait_sorties: wait,
                },
            );
        }
        self.abandon_cycle(actual)
    }

    /// Member `sysid` goes out during a sortie that goes on without it (`reason`; `fix`: what
    /// a person must do, if anything): a drone its autopilot's failsafe took home, a station
    /// stuck on its way. It is eligible again at once ([`ClassificationState::eligible`]):
    /// the shell takes it back when its telemetry says it is ready. The sortie's record is
    /// left as it is; the caller ends the member's part of it ([`Self::on_landed`],
    /// [`Self::on_station_stuck`]).
    pub fn sideline(
        &mut self,
        sysid: u8,
        reason: String,
        fix: Option<String>,
    ) -> Result<(), SortieError> {
        let role = self
            .role_of(sysid)
            .ok_or(SortieError::UnknownVehicle(sysid))?;
        self.out.insert(
            sysid,
            Sidelined {
                role,
                reason,
                fix,
                epoch: self.bandit.epoch,
                wait_sorties: 0,
            },
        );
        Ok(())
    }

    /// Station `sysid` is stuck on its way to the rendezvous (`reason`): it goes out
    /// ([`Self::sideline`]) and its leg of the sortie ends where it stands — the drones that
    /// were to land on it land on it there (its reported position), and the rest of the
    /// epoch is planned with it held on the cell it stands on.
    pub fn on_station_stuck(&mut self, sysid: u8, reason: String) -> Result<(), SortieError> {
        let fix = format!("free station {sysid} (it made no progress toward its rendezvous)");
        let leg = self
            .cycle_mut()?
            .stations
            .iter_mut()
            .find(|s| s.sysid == sysid)
            .ok_or(SortieError::UnknownVehicle(sysid))?;
        leg.arrived = true;
        self.sideline(sysid, reason, Some(fix))?;
        // One sortie out at least: a rover that is still stuck would be found so again.
        if let Some(o) = self.out.get_mut(&sysid) {
            o.wait_sorties = 1;
        }
        Ok(())
    }

    /// Drone `sysid`, out, now stands on the station cell `cell` (the shell flew it there):
    /// the team configuration says so, and the drone may be planned from it.
    pub fn relocate_drone(&mut self, sysid: u8, cell: Cell) -> Result<(), SortieError> {
        let i = self
            .drones
            .iter()
            .position(|m| m.sysid == sysid)
            .ok_or(SortieError::UnknownVehicle(sysid))?;
        if !self.config.stations.contains(&cell) {
            return Err(SortieError::Plan(format!(
                "drone {sysid} cannot be placed on cell {cell}: no station is there"
            )));
        }
        if let Some(c) = self.config.drones.get_mut(i) {
            *c = cell;
        }
        Ok(())
    }

    /// Members out whose wait is over: the shell tries them (their telemetry says whether
    /// they are ready) and takes them back with [`ClassificationState::reinstate`].
    pub fn eligible(&self) -> Vec<u8> {
        self.out
            .iter()
            .filter(|(_, o)| o.wait_sorties == 0)
            .map(|(s, _)| *s)
            .collect()
    }

    /// Member `sysid` takes part again; the rest of the epoch is planned again with it.
    /// Returns whether it was out.
    pub fn reinstate(&mut self, sysid: u8) -> bool {
        if self.out.remove(&sysid).is_none() {
            return false;
        }
        if let Some(e) = &mut self.epoch
            && e.cycle.is_none()
        {
            e.plan = None;
            e.next_cycle = 0;
        }
        true
    }

    /// The vehicles of a sortie that started: their failed starts in a row are forgotten.
    pub(super) fn forget_start_failures(&mut self, started: &[u8]) {
        for s in started {
            self.start_failures.remove(s);
        }
    }

    /// The stations held on their cells for planning ([`Pin`]): those out, and those with
    /// drones that are out on them (one charger taken per drone), by station index.
    pub(crate) fn pins(&self, config: &TeamConfig) -> Vec<Pin> {
        let mut pins: BTreeMap<usize, usize> = BTreeMap::new();
        for (a, m) in self.stations.iter().enumerate() {
            if self.is_out(m.sysid) {
                pins.entry(a).or_insert(0);
            }
        }
        for (m, cell) in self.drones.iter().zip(&config.drones) {
            if self.is_out(m.sysid)
                && let Some(a) = config.stations.iter().position(|s| s == cell)
            {
                *pins.entry(a).or_insert(0) += 1;
            }
        }
        pins.into_iter()
            .map(|(station, taken)| Pin { station, taken })
            .collect()
    }
}
