//! The command protocol, sender side: COMMAND_LONG and COMMAND_INT with COMMAND_ACK
//! (<https://mavlink.io/en/services/command.html>).
//!
//! Follows MAVSDK (`mavlink/MAVSDK`, `src/mavsdk/core/mavlink_command_sender.cpp`):
//! * a command is resent after [`CommandConfig::timeout`] without an ACK, at most
//!   [`CommandConfig::retries`] times; COMMAND_LONG resends increment `confirmation` as the
//!   specification requires (MAVSDK's `receive_timeout` retransmits; the spec's sequence
//!   diagram shows `confirmation=1` on the resend);
//! * MAV_RESULT_IN_PROGRESS means the command arrived: no more resends, and the wait is
//!   extended to [`CommandConfig::in_progress_timeout`] after each progress ACK (MAVSDK
//!   raises it to `retries × timeout`); the final ACK ends it;
//! * one command in flight per (target, command id): a second one queues behind the first
//!   (MAVSDK `do_work`: "Command … is already being sent, waiting…"), so two ACKs for the
//!   same command id can never be confused;
//! * an ACK counts when it comes from the target system (and component, unless the
//!   command was sent to component 0), names the same command, and is addressed to us or
//!   to everyone (`receive_command_ack` checks `target_system`/`target_component`);
//! * every MAV_RESULT other than ACCEPTED becomes a precise [`CommandError`].

use super::Endpoint;
use crate::time::Time;
use mavlink::MavHeader;
use mavlink::dialects::ardupilotmega::{
    COMMAND_INT_DATA, COMMAND_LONG_DATA, MavCmd, MavFrame, MavMessage, MavResult,
};
use std::collections::VecDeque;
use std::time::Duration;

/// Timeouts and retries of the command protocol.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommandConfig {
    /// Wait for a COMMAND_ACK before resending.
    pub timeout: Duration,
    /// Resends after the first transmission.
    pub retries: u32,
    /// Wait after a MAV_RESULT_IN_PROGRESS for the next ACK.
    pub in_progress_timeout: Duration,
}

impl Default for CommandConfig {
    fn default() -> Self {
        // QGroundControl: `MavCommandQueue` waits 3 s over high latency links and 1 s
        // otherwise, with 3 retries; MAVSDK 0.5 s and 3 retries. 1 s suits radios.
        CommandConfig {
            timeout: Duration::from_millis(1000),
            retries: 3,
            in_progress_timeout: Duration::from_secs(5),
        }
    }
}

/// Identifies a command started with [`CommandSender::start`].
pub type CmdId = u64;

/// The payload of a command.
#[derive(Clone, Debug, PartialEq)]
pub enum CommandArgs {
    /// COMMAND_LONG with params 1–7.
    Long([f32; 7]),
    /// COMMAND_INT: params 1–4, frame, x and y (degrees × 10⁷ in global frames), z.
    Int {
        /// Params 1–4.
        params: [f32; 4],
        /// Coordinate frame.
        frame: MavFrame,
        /// x (latitude × 10⁷).
        x: i32,
        /// y (longitude × 10⁷).
        y: i32,
        /// z (altitude, metres in `frame`).
        z: f32,
    },
}

/// A command to send.
#[derive(Clone, Debug, PartialEq)]
pub struct Command {
    /// Who executes it.
    pub target: Endpoint,
    /// The MAV_CMD.
    pub command: MavCmd,
    /// Its arguments.
    pub args: CommandArgs,
}

impl Command {
    /// COMMAND_LONG `command` with `params` to `target`.
    pub fn long(target: Endpoint, command: MavCmd, params: [f32; 7]) -> Command {
        Command {
            target,
            command,
            args: CommandArgs::Long(params),
        }
    }

    /// COMMAND_INT `command` to `target`.
    pub fn int(
        target: Endpoint,
        command: MavCmd,
        frame: MavFrame,
        params: [f32; 4],
        x: i32,
        y: i32,
        z: f32,
    ) -> Command {
        Command {
            target,
            command,
            args: CommandArgs::Int {
                params,
                frame,
                x,
                y,
                z,
            },
        }
    }

    /// The message the command travels as; `confirmation` counts its resends (COMMAND_LONG
    /// only). A caller that repeats a command on its own schedule, outside [`CommandSender`],
    /// sends this with 0.
    pub fn message(&self, confirmation: u8) -> MavMessage {
        match &self.args {
            CommandArgs::Long(p) => MavMessage::COMMAND_LONG(COMMAND_LONG_DATA {
                param1: p[0],
                param2: p[1],
                param3: p[2],
                param4: p[3],
                param5: p[4],
                param6: p[5],
                param7: p[6],
                command: self.command,
                target_system: self.target.sysid,
                target_component: self.target.compid,
                confirmation,
            }),
            CommandArgs::Int {
                params,
                frame,
                x,
                y,
                z,
            } => MavMessage::COMMAND_INT(COMMAND_INT_DATA {
                param1: params[0],
                param2: params[1],
                param3: params[2],
                param4: params[3],
                x: *x,
                y: *y,
                z: *z,
                command: self.command,
                target_system: self.target.sysid,
                target_component: self.target.compid,
                frame: *frame,
                current: 0,
                autocontinue: 0,
            }),
        }
    }
}

/// Why a command failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum CommandError {
    /// MAV_RESULT_TEMPORARILY_REJECTED.
    #[error(
        "{command:?}: temporarily rejected (valid, but cannot be executed now; retrying later may work)"
    )]
    TemporarilyRejected {
        /// The command.
        command: MavCmd,
    },
    /// MAV_RESULT_DENIED.
    #[error("{command:?}: denied (supported, but a parameter is invalid or not supported here)")]
    Denied {
        /// The command.
        command: MavCmd,
    },
    /// MAV_RESULT_UNSUPPORTED.
    #[error("{command:?}: not supported by the vehicle")]
    Unsupported {
        /// The command.
        command: MavCmd,
    },
    /// MAV_RESULT_FAILED.
    #[error("{command:?}: failed (valid, but execution failed; fix the cause before retrying)")]
    Failed {
        /// The command.
        command: MavCmd,
    },
    /// MAV_RESULT_CANCELLED.
    #[error("{command:?}: cancelled by the vehicle")]
    Cancelled {
        /// The command.
        command: MavCmd,
    },
    /// MAV_RESULT_COMMAND_LONG_ONLY.
    #[error("{command:?}: only accepted as COMMAND_LONG")]
    LongOnly {
        /// The command.
        command: MavCmd,
    },
    /// MAV_RESULT_COMMAND_INT_ONLY.
    #[error("{command:?}: only accepted as COMMAND_INT")]
    IntOnly {
        /// The command.
        command: MavCmd,
    },
    /// MAV_RESULT_COMMAND_UNSUPPORTED_MAV_FRAME.
    #[error("{command:?}: the coordinate frame is not supported")]
    UnsupportedFrame {
        /// The command.
        command: MavCmd,
    },
    /// MAV_RESULT_NOT_IN_CONTROL.
    #[error("{command:?}: refused, another system is in control of the vehicle")]
    NotInControl {
        /// The command.
        command: MavCmd,
    },
    /// No ACK after all retries.
    #[error("{command:?}: no COMMAND_ACK after {attempts} attempts ({timeout_ms} ms each)")]
    Timeout {
        /// The command.
        command: MavCmd,
        /// Transmissions made.
        attempts: u32,
        /// Wait per attempt, ms.
        timeout_ms: u64,
    },
    /// IN_PROGRESS was reported but no further ACK came.
    #[error(
        "{command:?}: in progress ({progress}%), then no further COMMAND_ACK within {timeout_ms} ms"
    )]
    StalledInProgress {
        /// The command.
        command: MavCmd,
        /// Last reported progress, % (255 = unknown).
        progress: u8,
        /// Wait, ms.
        timeout_ms: u64,
    },
    /// Cancelled by the caller before completion.
    #[error("{command:?}: abandoned by the caller")]
    Abandoned {
        /// The command.
        command: MavCmd,
    },
}

impl CommandError {
    /// The error for a non-accepted, non-in-progress MAV_RESULT.
    pub(crate) fn from_result(command: MavCmd, result: MavResult) -> Option<CommandError> {
        use MavResult::*;
        Some(match result {
            MAV_RESULT_ACCEPTED | MAV_RESULT_IN_PROGRESS => return None,
            MAV_RESULT_TEMPORARILY_REJECTED => CommandError::TemporarilyRejected { command },
            MAV_RESULT_DENIED => CommandError::Denied { command },
            MAV_RESULT_UNSUPPORTED => CommandError::Unsupported { command },
            MAV_RESULT_FAILED => CommandError::Failed { command },
            MAV_RESULT_CANCELLED => CommandError::Cancelled { command },
            MAV_RESULT_COMMAND_LONG_ONLY => CommandError::LongOnly { command },
            MAV_RESULT_COMMAND_INT_ONLY => CommandError::IntOnly { command },
            MAV_RESULT_COMMAND_UNSUPPORTED_MAV_FRAME => CommandError::UnsupportedFrame { command },
            MAV_RESULT_NOT_IN_CONTROL => CommandError::NotInControl { command },
        })
    }

    /// Whether trying the command again may succeed because the vehicle never answered:
    /// only [`CommandError::Timeout`]. Every MAV_RESULT the vehicle sent (including
    /// TEMPORARILY_REJECTED) is its answer and counts as final here, as does a cancel.
    pub fn is_transient(&self) -> bool {
        matches!(self, CommandError::Timeout { .. })
    }
}

/// A successful command's ACK details.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct CommandAck {
    /// `result_param2` of the ACK (command specific, e.g. the reason code for some).
    pub result_param2: i32,
    /// Transmissions it took.
    pub attempts: u32,
}

/// What the sender reports.
#[derive(Clone, Debug, PartialEq)]
pub enum CommandEvent {
    /// MAV_RESULT_IN_PROGRESS with `progress` percent (255 = unknown).
    Progress {
        /// The command.
        id: CmdId,
        /// Percent, 255 unknown.
        progress: u8,
    },
    /// Finished.
    Done {
        /// The command.
        id: CmdId,
        /// Success or why not.
        result: Result<CommandAck, CommandError>,
    },
}

#[derive(Debug)]
struct Pending {
    id: CmdId,
    cmd: Command,
    attempts: u32,
    deadline: Time,
    in_progress: Option<u8>,
}

/// Sends commands and matches their ACKs; one in flight per (target, command id).
#[derive(Debug)]
pub struct CommandSender {
    gcs: Endpoint,
    cfg: CommandConfig,
    in_flight: Vec<Pending>,
    waiting: VecDeque<(CmdId, Command)>,
    next_id: CmdId,
    out: VecDeque<MavMessage>,
    events: VecDeque<CommandEvent>,
}

impl CommandSender {
    /// A sender speaking as `gcs`.
    pub fn new(gcs: Endpoint, cfg: CommandConfig) -> Self {
        CommandSender {
            gcs,
            cfg,
            in_flight: Vec::new(),
            waiting: VecDeque::new(),
            next_id: 1,
            out: VecDeque::new(),
            events: VecDeque::new(),
        }
    }

    /// The configuration.
    pub fn config(&self) -> &CommandConfig {
        &self.cfg
    }

    /// Commands in flight or queued.
    pub fn busy(&self) -> usize {
        self.in_flight.len() + self.waiting.len()
    }

    /// The longest a command can take without IN_PROGRESS reports.
    pub fn budget(cfg: &CommandConfig) -> Duration {
        cfg.timeout * (cfg.retries + 1)
    }

    /// Send `cmd` (now, or after the in-flight command with the same target and id).
    pub fn start(&mut self, cmd: Command, now: Time) -> CmdId {
        let id = self.next_id;
        self.next_id += 1;
        self.waiting.push_back((id, cmd));
        self.launch(now);
        id
    }

    fn launch(&mut self, now: Time) {
        let mut i = 0;
        while i < self.waiting.len() {
            let (target, command) = (self.waiting[i].1.target, self.waiting[i].1.command);
            let busy = self
                .in_flight
                .iter()
                .any(|p| p.cmd.target == target && p.cmd.command == command);
            if busy {
                i += 1;
                continue;
            }
            let Some((id, cmd)) = self.waiting.remove(i) else {
                break;
            };
            self.out.push_back(cmd.message(0));
            self.in_flight.push(Pending {
                id,
                cmd,
                attempts: 1,
                deadline: now + self.cfg.timeout,
                in_progress: None,
            });
        }
    }

    /// The next message to send.
    pub fn poll_transmit(&mut self) -> Option<MavMessage> {
        self.out.pop_front()
    }

    /// The next event.
    pub fn poll_event(&mut self) -> Option<CommandEvent> {
        self.events.pop_front()
    }

    /// When [`CommandSender::handle_timeout`] must be called next.
    pub fn poll_timeout(&self) -> Option<Time> {
        self.in_flight.iter().map(|p| p.deadline).min()
    }

    /// A received message (only COMMAND_ACK matters).
    pub fn handle_message(&mut self, header: &MavHeader, msg: &MavMessage, now: Time) {
        let MavMessage::COMMAND_ACK(ack) = msg else {
            return;
        };
        if !self
            .gcs
            .is_addressed_by(ack.target_system, ack.target_component)
        {
            return;
        }
        let from = Endpoint::of(header);
        let Some(pos) = self.in_flight.iter().position(|p| {
            p.cmd.command == ack.command
                && p.cmd.target.sysid == from.sysid
                && (p.cmd.target.compid == 0 || p.cmd.target.compid == from.compid)
        }) else {
            return;
        };
        if ack.result == MavResult::MAV_RESULT_IN_PROGRESS {
            let p = &mut self.in_flight[pos];
            p.in_progress = Some(ack.progress);
            p.deadline = now + self.cfg.in_progress_timeout;
            self.events.push_back(CommandEvent::Progress {
                id: p.id,
                progress: ack.progress,
            });
            return;
        }
        let p = self.in_flight.remove(pos);
        let result = match CommandError::from_result(p.cmd.command, ack.result) {
            None => Ok(CommandAck {
                result_param2: ack.result_param2,
                attempts: p.attempts,
            }),
            Some(e) => Err(e),
        };
        self.events
            .push_back(CommandEvent::Done { id: p.id, result });
        self.launch(now);
    }

    /// Resend or give up on commands whose ACK is overdue.
    pub fn handle_timeout(&mut self, now: Time) {
        let mut i = 0;
        let mut finished = false;
        while i < self.in_flight.len() {
            if now < self.in_flight[i].deadline {
                i += 1;
                continue;
            }
            let p = &mut self.in_flight[i];
            if let Some(progress) = p.in_progress {
                let p = self.in_flight.remove(i);
                self.events.push_back(CommandEvent::Done {
                    id: p.id,
                    result: Err(CommandError::StalledInProgress {
                        command: p.cmd.command,
                        progress,
                        timeout_ms: self.cfg.in_progress_timeout.as_millis() as u64,
                    }),
                });
                finished = true;
                continue;
            }
            if p.attempts > self.cfg.retries {
                let p = self.in_flight.remove(i);
                self.events.push_back(CommandEvent::Done {
                    id: p.id,
                    result: Err(CommandError::Timeout {
                        command: p.cmd.command,
                        attempts: p.attempts,
                        timeout_ms: self.cfg.timeout.as_millis() as u64,
                    }),
                });
                finished = true;
                continue;
            }
            let confirmation = p.attempts.min(255) as u8;
            p.attempts += 1;
            p.deadline = now + self.cfg.timeout;
            self.out.push_back(p.cmd.message(confirmation));
            i += 1;
        }
        if finished {
            self.launch(now);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use mavlink::dialects::ardupilotmega::COMMAND_ACK_DATA;

    fn hdr(sysid: u8, compid: u8) -> MavHeader {
        MavHeader {
            system_id: u32::from(sysid),
            component_id: compid,
            sequence: 0,
        }
    }

    fn ack(command: MavCmd, result: MavResult) -> MavMessage {
        MavMessage::COMMAND_ACK(COMMAND_ACK_DATA {
            command,
            result,
            progress: 0,
            result_param2: 0,
            target_system: crate::proto::GCS_SYSID,
            target_component: crate::proto::GCS_COMPID,
        })
    }

    fn arm(target: Endpoint) -> Command {
        Command::long(
            target,
            MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
            [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        )
    }

    #[test]
    fn retries_increment_confirmation_then_time_out() {
        let mut s = CommandSender::new(Endpoint::gcs(), CommandConfig::default());
        let t = Endpoint::new(1, crate::proto::AUTOPILOT_COMPID);
        let id = s.start(arm(t), Time::ZERO);
        let mut confirmations = Vec::new();
        let mut now = Time::ZERO;
        loop {
            while let Some(m) = s.poll_transmit() {
                if let MavMessage::COMMAND_LONG(c) = m {
                    confirmations.push(c.confirmation);
                }
            }
            if let Some(ev) = s.poll_event() {
                match ev {
                    CommandEvent::Done { id: i, result } => {
                        assert_eq!(i, id);
                        assert!(matches!(
                            result,
                            Err(CommandError::Timeout { attempts: 4, .. })
                        ));
                        break;
                    }
                    e => panic!("{e:?}"),
                }
            }
            now = s.poll_timeout().unwrap();
            s.handle_timeout(now);
        }
        assert_eq!(confirmations, vec![0, 1, 2, 3]);
        assert_eq!(now, Time::from_millis(4000));
    }

    #[test]
    fn in_progress_extends_and_final_ack_completes() {
        let mut s = CommandSender::new(Endpoint::gcs(), CommandConfig::default());
        let t = Endpoint::new(1, crate::proto::AUTOPILOT_COMPID);
        let id = s.start(arm(t), Time::ZERO);
        s.handle_message(
            &hdr(1, 1),
            &ack(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                MavResult::MAV_RESULT_IN_PROGRESS,
            ),
            Time::from_millis(100),
        );
        assert_eq!(s.poll_timeout(), Some(Time::from_millis(5100)));
        assert!(matches!(
            s.poll_event(),
            Some(CommandEvent::Progress { .. })
        ));
        // No resend while in progress.
        s.poll_transmit();
        s.handle_timeout(Time::from_millis(3000));
        assert!(s.poll_transmit().is_none());
        // An ACK from another system or for another command does not count.
        s.handle_message(
            &hdr(2, 1),
            &ack(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                MavResult::MAV_RESULT_ACCEPTED,
            ),
            Time::from_millis(3100),
        );
        s.handle_message(
            &hdr(1, 1),
            &ack(MavCmd::MAV_CMD_NAV_TAKEOFF, MavResult::MAV_RESULT_ACCEPTED),
            Time::from_millis(3100),
        );
        assert!(s.poll_event().is_none());
        s.handle_message(
            &hdr(1, 1),
            &ack(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                MavResult::MAV_RESULT_ACCEPTED,
            ),
            Time::from_millis(3200),
        );
        assert!(matches!(
            s.poll_event(),
            Some(CommandEvent::Done { id: i, result: Ok(_) }) if i == id
        ));
    }

    #[test]
    fn same_command_queues_and_errors_are_precise() {
        let mut s = CommandSender::new(Endpoint::gcs(), CommandConfig::default());
        let t = Endpoint::new(1, crate::proto::AUTOPILOT_COMPID);
        let a = s.start(arm(t), Time::ZERO);
        let b = s.start(arm(t), Time::ZERO);
        assert!(s.poll_transmit().is_some());
        assert!(
            s.poll_transmit().is_none(),
            "second ARM waits for the first"
        );
        s.handle_message(
            &hdr(1, 1),
            &ack(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                MavResult::MAV_RESULT_FAILED,
            ),
            Time::from_millis(10),
        );
        assert_eq!(
            s.poll_event(),
            Some(CommandEvent::Done {
                id: a,
                result: Err(CommandError::Failed {
                    command: MavCmd::MAV_CMD_COMPONENT_ARM_DISARM
                })
            })
        );
        assert!(s.poll_transmit().is_some(), "now the second goes out");
        s.handle_message(
            &hdr(1, 1),
            &ack(
                MavCmd::MAV_CMD_COMPONENT_ARM_DISARM,
                MavResult::MAV_RESULT_TEMPORARILY_REJECTED,
            ),
            Time::from_millis(20),
        );
        assert!(matches!(
            s.poll_event(),
            Some(CommandEvent::Done { id, result: Err(CommandError::TemporarilyRejected { .. }) }) if id == b
        ));
    }
}
