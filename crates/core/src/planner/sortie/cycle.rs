//! One sortie (a sensing cycle of the plan) on the run state: its missions built and
//! flown, the vehicles' progress, and its end at the rendezvous (or its abandonment).

use super::*;

impl ClassificationState {
    /// Build the missions of the plan's next cycle (capture at every unclassified candidate
    /// cell a drone arrives at).
    pub fn prepare_cycle(&mut self) -> Result<&CycleRun, SortieError> {
        let e = self
            .epoch
            .as_ref()
            .ok_or_else(|| SortieError::Phase("no epoch is open".into()))?;
        if e.cycle.is_some() {
            return Err(SortieError::Phase("a sortie is already prepared".into()));
        }
        let plan = e
            .plan
            .as_ref()
            .ok_or_else(|| SortieError::Phase("the epoch has no plan".into()))?;
        let k = e.next_cycle;
        if k >= plan.cycles {
            return Err(SortieError::Phase("the plan has no cycle left".into()));
        }
        let p = &self.params;
        let lock = p.separation == Separation::LockStep;
        let step_s = self.grid.cell_size() / p.speed_m_s.max(0.1);
        let station_paths: Vec<Vec<Cell>> = plan.stations.iter().map(|s| s[k].clone()).collect();
        let mut stations = Vec::new();
        for (m, path) in self.stations.iter().zip(&station_paths) {
            let drives = path.windows(2).any(|w| w[0] != w[1]);
            let cm = if drives {
                missions::station_mission(&self.grid, path, p.station_speed_m_s)
            } else {
                CycleMission {
                    items: Vec::new(),
                    step_done: vec![None; path.len()],
                    step_arrive: vec![None; path.len()],
                    capture_steps: Vec::new(),
                }
            };
            stations.push(StationLeg {
                sysid: m.sysid,
                path: path.clone(),
                drives,
                items: cm.items,
                step_done: cm.step_done,
                step: 0,
                arrived: !drives,
            });
        }
        let mut landing: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        let mut drones = Vec::new();
        for (i, m) in self.drones.iter().enumerate() {
            let path = plan.drones[i][k].clone();
            let last = path.last().copied().unwrap_or_default();
            let first = path.first().copied().unwrap_or_default();
            let out = self.is_out(m.sysid);
            let land_on = match station_paths.iter().position(|s| s.last() == Some(&last)) {
                Some(a) => a,
                // A drone out of the run, off every station: it does not fly (no slot).
                None if out => 0,
                None => {
                    return Err(SortieError::Plan(format!(
                        "drone {} ends cycle {k} at {last}, where no station ends it (9d)",
                        m.sysid
                    )));
                }
            };
            if !out || station_paths.get(land_on).and_then(|s| s.last()) == Some(&last) {
                landing.entry(land_on).or_default().push(i);
            }
            // The station it stands on at the start: if that station drives away, the drone
            // must be in the air even when its own path stays (a landed drone rides along).
            let under = station_paths.iter().position(|s| s.first() == Some(&first));
            let station_moves = under.is_none_or(|a| stations[a].drives);
            let moves = path.windows(2).any(|w| w[0] != w[1]);
            let flies = !out && (moves || station_moves || under != Some(land_on));
            let capture: Vec<bool> = path
                .iter()
                .enumerate()
                .map(|(j, &c)| {
                    j > 0
                        && c != path[j - 1]
                        && self
                            .bandit
                            .index_of(c)
                            .is_some_and(|l| self.bandit.is_unclassified(l))
                })
                .collect();
            let cm = if flies {
                missions::drone_mission(
                    &self.grid,
                    &DroneMissionSpec {
                        path: &path,
                        capture: &capture,
                        altitude_m: m.altitude_m,
                        speed_m_s: p.speed_m_s,
                        batch: p.batch,
                        capture_interval_s: p.capture_interval_s,
                        lock_step: lock,
                        step_s,
                        settle_s: 2.0,
                    },
                )
            } else {
                CycleMission {
                    items: Vec::new(),
                    step_done: vec![None; path.len()],
                    step_arrive: vec![None; path.len()],
                    capture_steps: Vec::new(),
                }
            };
            drones.push(DroneLeg {
                sysid: m.sysid,
                captures: cm
                    .capture_steps
                    .iter()
                    .map(|&j| CaptureVisit {
                        step: j,
                        cell: path[j],
                        counted: 0,
                    })
                    .collect(),
                path,
                flies,
                items: cm.items,
                step_done: cm.step_done,
                step_arrive: cm.step_arrive,
                land_on,
                slot: (0, 1),
                step: 0,
                landed: !flies,
            });
        }
        for list in landing.values() {
            for (s, &i) in list.iter().enumerate() {
                drones[i].slot = (s, list.len());
            }
        }
        let run = CycleRun {
            k,
            phase: CyclePhase::Prepared,
            drones,
            stations,
            seen: Vec::new(),
            elapsed_s: 0.0,
            measurements: 0,
        };
        let e = self
            .epoch
            .as_mut()
            .ok_or_else(|| SortieError::Phase("no epoch is open".into()))?;
        e.visits += run
            .drones
            .iter()
            .map(|d| d.captures.len() as u64)
            .sum::<u64>();
        Ok(e.cycle.insert(run))
    }

    /// The sortie in flight (or prepared).
    pub fn cycle(&self) -> Option<&CycleRun> {
        self.epoch.as_ref().and_then(|e| e.cycle.as_ref())
    }

    pub(super) fn cycle_mut(&mut self) -> Result<&mut CycleRun, SortieError> {
        self.epoch
            .as_mut()
            .and_then(|e| e.cycle.as_mut())
            .ok_or_else(|| SortieError::Phase("no sortie is prepared".into()))
    }

    /// Every mission of the sortie is on its vehicle and read back identical.
    pub fn on_verified(&mut self) -> Result<(), SortieError> {
        let c = self.cycle_mut()?;
        if c.phase == CyclePhase::Prepared {
            c.phase = CyclePhase::Verified;
        }
        Ok(())
    }

    /// The vehicles were started (those that move: their failed starts in a row are
    /// forgotten).
    pub fn on_started(&mut self) -> Result<(), SortieError> {
        let c = self.cycle_mut()?;
        c.phase = CyclePhase::Started;
        let started: Vec<u8> = c
            .drones
            .iter()
            .filter(|d| d.flies)
            .map(|d| d.sysid)
            .chain(c.stations.iter().filter(|s| s.drives).map(|s| s.sysid))
            .collect();
        self.forget_start_failures(&started);
        Ok(())
    }

    /// Progress of a drone: the items it has reached. Returns whether its step changed.
    pub fn on_drone_progress(&mut self, sysid: u8, reached: &[u16]) -> Result<bool, SortieError> {
        let c = self.cycle_mut()?;
        let leg = c
            .drones
            .iter_mut()
            .find(|d| d.sysid == sysid)
            .ok_or(SortieError::UnknownVehicle(sysid))?;
        let step = missions::steps_done(&leg.step_done, reached).max(leg.step);
        let changed = step != leg.step;
        leg.step = step;
        Ok(changed)
    }

    /// Progress of a station; `complete` when its mission has ended. Returns whether it
    /// changed.
    pub fn on_station_progress(
        &mut self,
        sysid: u8,
        reached: &[u16],
        complete: bool,
    ) -> Result<bool, SortieError> {
        let c = self.cycle_mut()?;
        let leg = c
            .stations
            .iter_mut()
            .find(|s| s.sysid == sysid)
            .ok_or(SortieError::UnknownVehicle(sysid))?;
        let last = leg.path.len().saturating_sub(1);
        let mut step = missions::steps_done(&leg.step_done, reached).max(leg.step);
        if complete {
            step = last;
        }
        let arrived = leg.arrived || step >= last;
        let changed = step != leg.step || arrived != leg.arrived;
        leg.step = step;
        leg.arrived = arrived;
        Ok(changed)
    }

    /// A drone landed on its station.
    pub fn on_landed(&mut self, sysid: u8) -> Result<(), SortieError> {
        let c = self.cycle_mut()?;
        let leg = c
            .drones
            .iter_mut()
            .find(|d| d.sysid == sysid)
            .ok_or(SortieError::UnknownVehicle(sysid))?;
        leg.landed = true;
        leg.step = leg.path.len().saturating_sub(1);
        Ok(())
    }

    /// Lock-step (7e): the drones that must hold because they are a step ahead of a drone
    /// that has not yet arrived at the step they are on, given each flying drone's last
    /// step *arrived at* (`arrived`, by system id).
    pub fn ahead(&self, arrived: &BTreeMap<u8, usize>) -> Vec<u8> {
        if self.params.separation != Separation::LockStep {
            return Vec::new();
        }
        let Some(c) = self.cycle() else {
            return Vec::new();
        };
        let flying: Vec<(u8, usize)> = c
            .drones
            .iter()
            .filter(|d| d.flies && !d.landed)
            .map(|d| (d.sysid, arrived.get(&d.sysid).copied().unwrap_or(0)))
            .collect();
        let Some(min) = flying.iter().map(|(_, a)| *a).min() else {
            return Vec::new();
        };
        flying
            .into_iter()
            .filter(|&(_, a)| a > min)
            .map(|(s, _)| s)
            .collect()
    }

    /// Add airborne time to the drones `airborne` and, while one of them is in the air,
    /// flight time to the sortie in flight, seconds. The time a sortie waits on the ground
    /// (its drones landed, their cameras still sending pictures) is not flight: the charge
    /// the next sortie needs is estimated from it ([`EpochRun::flight_s`]).
    pub fn on_tick(&mut self, airborne: &[u8], dt_s: f64) {
        let dt = dt_s.max(0.0);
        for s in airborne {
            *self.airborne_s.entry(*s).or_insert(0.0) += dt;
        }
        if !airborne.is_empty()
            && let Some(e) = &mut self.epoch
            && let Some(c) = &mut e.cycle
            && c.phase == CyclePhase::Started
        {
            c.elapsed_s += dt;
        }
    }

    /// End the sortie with the team at `actual` (the planned end, or where telemetry puts
    /// the vehicles). `replan` forces the rest of the epoch to be planned again (a resumed
    /// run); a team that ended elsewhere than planned forces it too. Ends the epoch — (4),
    /// p ← p + 1 — after the plan's last cycle or when no goal is left to visit.
    pub fn finish_cycle(
        &mut self,
        actual: TeamConfig,
        replan: bool,
    ) -> Result<CycleEnd, SortieError> {
        self.validate_config(&actual)?;
        let e = self
            .epoch
            .as_mut()
            .ok_or_else(|| SortieError::Phase("no epoch is open".into()))?;
        let c = e
            .cycle
            .take()
            .ok_or_else(|| SortieError::Phase("no sortie is flying".into()))?;
        let started = c.phase == CyclePhase::Started;
        if started {
            e.cycles_flown += 1;
            e.flight_s += c.elapsed_s;
            e.next_cycle = c.k + 1;
            // One sortie less for the members out to sit out.
            for o in self.out.values_mut() {
                o.wait_sorties = o.wait_sorties.saturating_sub(1);
            }
        }
        let as_planned = actual == c.planned_end();
        self.config = actual;
        let plan_cycles = e.plan.as_ref().map_or(0, |p| p.cycles);
        let plan_done = e.next_cycle >= plan_cycles;
        // A goal that cannot be measured (its images keep failing) must not hold the epoch
        // forever: after MAX_SOLVES plans the epoch ends with what it has.
        let exhausted = e.solves >= MAX_SOLVES && plan_done;
        if (plan_done && started && as_planned && !replan)
            || exhausted
            || self.remaining_goals().is_empty()
        {
            return Ok(CycleEnd::EpochDone(self.end_epoch()));
        }
        let e = self
            .epoch
            .as_mut()
            .ok_or_else(|| SortieError::Phase("no epoch is open".into()))?;
        if replan || !as_planned || !started || plan_done {
            e.plan = None;
            e.next_cycle = 0;
            return Ok(CycleEnd::Replan);
        }
        Ok(CycleEnd::NextCycle)
    }

    /// Drop the prepared sortie (nothing flew) and plan the rest of the epoch again from
    /// `actual`.
    pub fn abandon_cycle(&mut self, actual: TeamConfig) -> Result<(), SortieError> {
        self.validate_config(&actual)?;
        if let Some(e) = &mut self.epoch {
            if let Some(c) = e.cycle.take() {
                e.visits = e
                    .visits
                    .saturating_sub(c.drones.iter().map(|d| d.captures.len() as u64).sum());
            }
            e.plan = None;
            e.next_cycle = 0;
        }
        self.config = actual;
        Ok(())
    }
}
