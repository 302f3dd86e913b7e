//! Vehicle events of the runway mapping run: low battery, camera faults, a drone that cannot
//! take off, battery swaps (landing, swapping, resuming), going home and landing.

use super::*;

/// Why a drone is on the ground out of the run (it could not take off, or its steps kept
/// failing) and what a person must fix, if anything.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Grounded {
    /// What failed.
    pub reason: String,
    /// What a person must fix (`None`: a retry may succeed by itself).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub fix: Option<String>,
    /// Times in a row it was grounded without flying a step in between.
    pub tries: u32,
}

impl MappingState {
    /// `sysid` must change its battery: it leaves the exploration (its vertex is kept) and
    /// flies home. Idempotent.
    pub fn on_battery_low(&mut self, sysid: u8, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        self.book.close_visit(sysid, now);
        self.robot_mut(sysid)?.visit = None;
        if let Some(ex) = self.explorer.as_mut() {
            ex.pause(RobotId(sysid))?;
        }
        let r = self.robot_mut(sysid)?;
        if !matches!(
            r.status,
            RobotStatus::ReturningForSwap | RobotStatus::AwaitingSwap
        ) {
            r.status_before_swap = Some(r.status);
            r.status = RobotStatus::ReturningForSwap;
        }
        // A robot out of the sweep cannot finish its strip now: the others carry on.
        Ok(())
    }

    /// `sysid`'s camera cannot be trusted (`reason`): it leaves the run as for a battery swap
    /// ([`MappingState::on_battery_low`]) and stays out until the operator confirms a fix.
    pub fn on_camera_fault(
        &mut self,
        sysid: u8,
        reason: String,
        now: Time,
    ) -> Result<(), MappingError> {
        self.abandon_confirmation(sysid);
        self.on_battery_low(sysid, now)?;
        let r = self.robot_mut(sysid)?;
        r.camera_fault = Some(reason);
        r.camera_silent = false;
        Ok(())
    }

    /// `sysid`'s camera went silent (`reason`: captures unanswered, pictures that never
    /// arrived): out of the run as for [`MappingState::on_camera_fault`], but marked as a camera
    /// that may come back by itself ([`RobotRecord::camera_silent`]); [`MappingState::on_swapped`]
    /// brings the vehicle back once it is heard again, no battery swap counted.
    pub fn on_camera_silent(
        &mut self,
        sysid: u8,
        reason: String,
        now: Time,
    ) -> Result<(), MappingError> {
        self.on_camera_fault(sysid, reason, now)?;
        self.robot_mut(sysid)?.camera_silent = true;
        Ok(())
    }

    /// `sysid` could not take off, or its steps kept failing (`reason`; `fix`: what a person
    /// must fix, if anything): it leaves the run as for a battery swap
    /// ([`MappingState::on_battery_low`]: its vertex is kept, a confirmation it was making is
    /// given up) and waits on the ground ([`MappingState::on_landed_for_swap`]) until it is
    /// ready again or the operator says so ([`MappingState::on_ready_again`],
    /// [`MappingState::on_swapped`]). `tries` counts the groundings in a row.
    pub fn on_grounded(
        &mut self,
        sysid: u8,
        reason: String,
        fix: Option<String>,
        tries: u32,
        now: Time,
    ) -> Result<(), MappingError> {
        self.abandon_confirmation(sysid);
        self.on_battery_low(sysid, now)?;
        self.robot_mut(sysid)?.grounded = Some(Grounded { reason, fix, tries });
        Ok(())
    }

    /// `sysid`, grounded ([`MappingState::on_grounded`]), is ready again: it goes back to
    /// what it was doing, as after a battery swap but without counting one.
    pub fn on_ready_again(&mut self, sysid: u8, now: Time) -> Result<(), MappingError> {
        if self.robot(sysid)?.grounded.is_none() {
            return Ok(());
        }
        self.on_swapped(sysid, now)
    }

    /// `sysid` landed for its swap; `reboots` is the vehicle's reboot counter then. When it
    /// knows the map is complete it is retired instead (`Explorer::retire`): landed for good.
    pub fn on_landed_for_swap(
        &mut self,
        sysid: u8,
        reboots: u32,
        now: Time,
    ) -> Result<(), MappingError> {
        self.touch(now);
        // Landed when the map is complete: nothing to swap the battery for.
        let retired = match self.explorer.as_mut() {
            Some(ex) => ex.retire(RobotId(sysid))?,
            None => false,
        };
        let r = self.robot_mut(sysid)?;
        if retired {
            r.status = RobotStatus::Landed;
        } else {
            r.status = RobotStatus::AwaitingSwap;
            r.reboots_at_landing = Some(reboots);
        }
        self.check_finished(now);
        Ok(())
    }

    /// `sysid` has a fresh battery: it goes back to what it was doing (the DFS from its saved
    /// vertex). The operator's word for a drone that was grounded too
    /// ([`MappingState::on_grounded`]): then no battery swap is counted.
    pub fn on_swapped(&mut self, sysid: u8, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        let exploring = matches!(self.phase, Phase::Explore { .. });
        let r = self.robot_mut(sysid)?;
        if !matches!(
            r.status,
            RobotStatus::ReturningForSwap | RobotStatus::AwaitingSwap
        ) {
            return Ok(());
        }
        // A drone grounded (it could not take off) had no battery swapped, nor one whose
        // camera was fixed (a camera fault is not a battery swap).
        let grounded = r.grounded.take().is_some();
        let camera = r.camera_fault.take().is_some();
        r.camera_silent = false;
        if !grounded && !camera {
            r.battery_swaps += 1;
        }
        r.reboots_at_landing = None;
        let before = r.status_before_swap.take().unwrap_or(RobotStatus::Idle);
        r.status = match before {
            RobotStatus::Sweeping | RobotStatus::Holding | RobotStatus::Confirming => {
                RobotStatus::Sweeping
            }
            RobotStatus::SweepDone => RobotStatus::SweepDone,
            RobotStatus::Exploring => RobotStatus::Exploring,
            _ => RobotStatus::Idle,
        };
        if exploring {
            r.status = RobotStatus::Exploring;
            if let Some(ex) = self.explorer.as_mut()
                && ex.robot(RobotId(sysid))?.phase == crate::explore::dfs::Phase::Paused
            {
                ex.resume(RobotId(sysid))?;
            }
        }
        // A confirmation interrupted by the swap: the confirming robot's visit was closed, so
        // give the confirmation up and sweep on (the candidate may be seen again).
        if let Phase::Confirm { sysid: who, .. } = self.phase
            && who == sysid
        {
            self.phase = Phase::Sweep;
        }
        Ok(())
    }

    /// `sysid` has a low battery during a confirmation: the confirmation is abandoned (the
    /// sweep resumes without rejecting the cell).
    pub fn abandon_confirmation(&mut self, sysid: u8) {
        if let Phase::Confirm { sysid: who, .. } = self.phase
            && who == sysid
        {
            self.phase = Phase::Sweep;
            for r in &mut self.robots {
                if r.status == RobotStatus::Holding {
                    r.status = RobotStatus::Sweeping;
                }
            }
        }
    }

    /// `sysid` is flying home at the end.
    pub fn on_going_home(&mut self, sysid: u8, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        self.book.close_visit(sysid, now);
        let r = self.robot_mut(sysid)?;
        r.visit = None;
        r.status = RobotStatus::ReturningHome;
        Ok(())
    }

    /// `sysid` landed at the end. When the DFS is complete and every robot is down, the run
    /// is finished.
    pub fn on_landed(&mut self, sysid: u8, now: Time) -> Result<(), MappingError> {
        self.touch(now);
        self.robot_mut(sysid)?.status = RobotStatus::Landed;
        self.check_finished(now);
        Ok(())
    }
}
