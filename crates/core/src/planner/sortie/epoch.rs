//! Algorithm 1's epochs on the run state: choosing the goals (3), the integer program
//! instance for the team where it stands, accepting the solved plan, and closing the epoch
//! with (4) and its statistics.

use super::*;

impl ClassificationState {
    /// Step 3 of Algorithm 1: open epoch p with the top-D unclassified cells by J (3).
    /// Returns the goals (empty when everything is classified; no epoch is opened then).
    pub fn begin_epoch(&mut self) -> Result<Vec<Cell>, SortieError> {
        if self.epoch.is_some() {
            return Err(SortieError::Phase("an epoch is already open".into()));
        }
        let goals = bandit::epoch_goals(&self.bandit, self.params.epoch_goals);
        if goals.is_empty() {
            return Ok(goals);
        }
        self.epoch = Some(EpochRun {
            p: self.bandit.epoch,
            goals: goals.clone(),
            plan: None,
            next_cycle: 0,
            cycle: None,
            cycles_flown: 0,
            solves: 0,
            planner_s: 0.0,
            flight_s: 0.0,
            measured: BTreeSet::new(),
            measurements: 0,
            visits: 0,
        });
        Ok(goals)
    }

    /// The epoch's goals still to visit: not measured in this epoch and still unclassified.
    pub(crate) fn remaining_goals(&self) -> Vec<Cell> {
        let Some(e) = &self.epoch else {
            return Vec::new();
        };
        e.goals
            .iter()
            .copied()
            .filter(|c| !e.measured.contains(c))
            .filter(|c| {
                self.bandit
                    .index_of(*c)
                    .is_some_and(|l| self.bandit.is_unclassified(l))
            })
            .collect()
    }

    /// The IP instance (Algorithm 2's input) for the rest of the epoch: the remaining goals
    /// from the current team configuration, at most `k_max` cycles, for the drones that take
    /// part ([`ClassificationState::active_drones`]) — the stations that are out, or carry a
    /// drone that is out, held on their cells (`ClassificationState::pins`).
    pub fn instance(&self, k_max: usize) -> Result<Instance, SortieError> {
        let grid = self.layout.planner_grid()?;
        let idx = |c: Cell| -> Result<usize, SortieError> {
            grid.index(self.layout.to_planner(c))
                .ok_or_else(|| SortieError::Plan(format!("cell {c} is outside the area")))
        };
        // The drones that take part; those out stay where they are (not planned).
        let drones = self
            .drones
            .iter()
            .zip(&self.config.drones)
            .filter(|(m, _)| !self.is_out(m.sysid))
            .map(|(_, &c)| idx(c))
            .collect::<Result<_, _>>()?;
        let stations = self
            .config
            .stations
            .iter()
            .map(|&c| idx(c))
            .collect::<Result<_, _>>()?;
        let goals = self
            .remaining_goals()
            .into_iter()
            .map(idx)
            .collect::<Result<_, _>>()?;
        let pins: Vec<Pin> = self.pins(&self.config);
        Instance::new(
            grid,
            drones,
            stations,
            goals,
            self.params.td,
            self.params.tc,
            k_max.max(1),
            self.params.capacity,
        )
        .and_then(|i| i.with_pins(pins))
        .map_err(|e| SortieError::Plan(e.to_string()))
    }

    /// Count a solve that found no plan (its time still counts as planner time).
    pub fn note_solve(&mut self, seconds: f64) {
        if let Some(e) = &mut self.epoch {
            e.solves += 1;
            e.planner_s += seconds.max(0.0);
        }
    }

    /// Take the IP's plan (planner cells, re-paired) for the rest of the epoch: paths for
    /// the drones that take part, in team order; the drones out stay on their cells.
    pub fn accept_plan(&mut self, plan: &IpPlan, seconds: f64) -> Result<(), SortieError> {
        let layout = self.layout.clone();
        let conv = |v: &Vec<Vec<Vec<Cell>>>| -> Vec<Vec<Vec<Cell>>> {
            v.iter()
                .map(|cycles| {
                    cycles
                        .iter()
                        .map(|steps| {
                            steps
                                .iter()
                                .map(|&c| layout.planner_to_mission(c))
                                .collect()
                        })
                        .collect()
                })
                .collect()
        };
        let active = self.active_drones();
        if plan.drones.len() != active.len() || plan.stations.len() != self.stations.len() {
            return Err(SortieError::Plan("the plan does not match the team".into()));
        }
        // The drones out stay where they are for every cycle of the plan.
        let mut planned = conv(&plan.drones).into_iter();
        let mut drones = Vec::with_capacity(self.drones.len());
        for (m, &cell) in self.drones.iter().zip(&self.config.drones) {
            if self.is_out(m.sysid) {
                drones.push(vec![vec![cell; self.params.td]; plan.cycles]);
            } else {
                drones.push(
                    planned.next().ok_or_else(|| {
                        SortieError::Plan("the plan does not match the team".into())
                    })?,
                );
            }
        }
        let sp = SortiePlan {
            cycles: plan.cycles,
            drones,
            stations: conv(&plan.stations),
        };
        let e = self
            .epoch
            .as_mut()
            .ok_or_else(|| SortieError::Phase("no epoch is open".into()))?;
        e.solves += 1;
        e.planner_s += seconds.max(0.0);
        e.plan = Some(sp);
        e.next_cycle = 0;
        Ok(())
    }

    pub(super) fn end_epoch(&mut self) -> EpochStats {
        let p = self.bandit.epoch;
        self.bandit.update();
        let e = self.epoch.take();
        let classified: Vec<(Cell, Label)> = self
            .bandit
            .cells
            .iter()
            .enumerate()
            .filter(|(l, _)| self.bandit.classified_at[*l] == Some(p))
            .map(|(l, c)| (*c, self.bandit.labels[l]))
            .collect();
        let stats = EpochStats {
            epoch: p,
            goals: e.as_ref().map(|e| e.goals.clone()).unwrap_or_default(),
            cycles: e.as_ref().map_or(0, |e| e.cycles_flown),
            solves: e.as_ref().map_or(0, |e| e.solves),
            planner_s: e.as_ref().map_or(0.0, |e| e.planner_s),
            flight_s: e.as_ref().map_or(0.0, |e| e.flight_s),
            measurements: e.as_ref().map_or(0, |e| e.measurements),
            visits: e.as_ref().map_or(0, |e| e.visits),
            classified,
            keep: self.bandit.keep().len(),
            reject: self.bandit.reject().len(),
            unclassified: self.bandit.unclassified().len(),
        };
        self.epochs.push(stats.clone());
        stats
    }
}
