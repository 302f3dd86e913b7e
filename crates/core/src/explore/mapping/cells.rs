//! Cell images and the DFS on the run state: detections voted per cell, a confirmed or
//! rejected cell handed to the explorers, arrivals and observations.

use super::*;

impl MappingState {
    /// A cell-centre image (confirmation or DFS) of `sysid` was classified: count its votes
    /// (none once the run is finished). Returns the cells whose state changed.
    pub fn on_cell_image(&mut self, det: Detection) -> Result<Vec<CellUpdate>, MappingError> {
        let sysid = det.vehicle;
        let cell = det.cell;
        self.touch(det.time);
        if matches!(self.phase, Phase::Finished { .. }) {
            // A picture that arrives after the run ended (given up while a drone was over a
            // cell) counts for nothing.
            return Ok(Vec::new());
        }
        self.images += 1;
        let r = self.robot_mut(sysid)?;
        r.images += 1;
        r.visit = match r.visit {
            Some((c, k)) if c == cell => Some((c, k + 1)),
            _ => Some((cell, 1)),
        };
        Ok(self.book.record(det))
    }

    /// The next image name (run-wide).
    pub fn next_image_id(&self) -> String {
        format!("img{:06}", self.images + 1)
    }

    /// Images `sysid` still has to take over `cell` for its current visit (a visit interrupted
    /// by a crash or a swap keeps the images already counted).
    pub fn images_missing(&self, sysid: u8, cell: Cell) -> u32 {
        let n = self.params.images_per_cell;
        match self.robot(sysid).ok().and_then(|r| r.visit) {
            Some((c, k)) if c == cell => n.saturating_sub(k),
            _ => n,
        }
    }

    /// The confirmation visit of `sysid` over `cell` is complete. Starts the DFS from the
    /// first positive cell among the candidate and its neighbours, or goes back to the sweep.
    /// Returns the DFS root if it started.
    pub fn on_confirmed(
        &mut self,
        sysid: u8,
        cell: Cell,
        now: Time,
    ) -> Result<Option<Cell>, MappingError> {
        self.touch(now);
        if self.phase != (Phase::Confirm { sysid, cell }) {
            return Err(MappingError::WrongPhase {
                sysid,
                what: "a confirmation",
                phase: self.phase.to_string(),
            });
        }
        self.book.close_visit(sysid, now);
        self.robot_mut(sysid)?.visit = None;
        let mut order = vec![cell];
        order.extend(cell.neighbours4());
        let root = order
            .into_iter()
            .find(|c| self.book.state(*c) == CellState::Positive);
        match root {
            Some(root) => {
                let ids: Vec<RobotId> = self.robots.iter().map(|r| RobotId(r.sysid)).collect();
                let mut ex = Explorer::new(
                    ExplorerConfig {
                        sharing: self.params.sharing,
                        allocation: self.params.allocation,
                        // The drones fly: no stop over cells already imaged on the way.
                        direct_transit: true,
                    },
                    root,
                    &ids,
                )?;
                for r in &self.robots {
                    if matches!(
                        r.status,
                        RobotStatus::ReturningForSwap | RobotStatus::AwaitingSwap
                    ) {
                        ex.pause(RobotId(r.sysid))?;
                    }
                }
                self.explorer = Some(ex);
                self.phase = Phase::Explore { root };
                for r in &mut self.robots {
                    match r.status {
                        RobotStatus::ReturningForSwap | RobotStatus::AwaitingSwap => {
                            r.status_before_swap = Some(RobotStatus::Exploring);
                        }
                        _ => r.status = RobotStatus::Exploring,
                    }
                }
                self.note_milestones(now);
                Ok(Some(root))
            }
            None => {
                self.rejected.insert(cell);
                self.phase = Phase::Sweep;
                for r in &mut self.robots {
                    if matches!(r.status, RobotStatus::Holding | RobotStatus::Confirming) {
                        r.status = RobotStatus::Sweeping;
                    }
                }
                Ok(None)
            }
        }
    }

    /// `sysid` reached `cell` (after `Dfs(MoveTo)` / `Dfs(Rejoin)`).
    pub fn on_arrived(&mut self, sysid: u8, cell: Cell, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        let ex = self.explorer_mut(sysid, "an arrival")?;
        ex.arrived(RobotId(sysid), cell)?;
        Ok(())
    }

    pub(super) fn explorer_mut(
        &mut self,
        sysid: u8,
        what: &'static str,
    ) -> Result<&mut Explorer, MappingError> {
        let phase = self.phase.to_string();
        self.explorer
            .as_mut()
            .ok_or(MappingError::WrongPhase { sysid, what, phase })
    }

    /// `sysid` finished imaging vertex `cell` (its visit is complete): the neighbours' labels
    /// are the vote book's states. Returns the cells added to the tree.
    pub fn on_observed(
        &mut self,
        sysid: u8,
        cell: Cell,
        now: Time,
    ) -> Result<Vec<Cell>, MappingError> {
        self.touch(now);
        self.book.close_visit(sysid, now);
        self.robot_mut(sysid)?.visit = None;
        let labels = Dir4::ALL.map(|d| self.book.state(cell.step(d)) == CellState::Positive);
        let ex = self.explorer_mut(sysid, "an observation")?;
        let added = ex.observe(RobotId(sysid), cell, labels)?;
        self.note_milestones(now);
        Ok(added)
    }
}
