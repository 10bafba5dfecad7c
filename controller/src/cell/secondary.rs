//! Secondary programs (`sec NAME(): ... end`) beside the main program.
//!
//! A secondary program runs on the live arm's settings (outputs, registers, TCP...),
//! never its motion: what it sets becomes the arm's, its joints cannot change. It gets
//! [`SECONDARY_STEPS`] steps at once; one that has finished by then is done, as before.
//! One still waiting for the network (`socket_*`, XML-RPC: UR allows quick calls of both
//! in secondary programs) goes on step by step beside the main program, its sockets
//! served by the caller like the main program's ([`CellEvent::Secondary`],
//! [`Cell::secondary_machine_mut`]), for at most [`SECONDARY_TIME`]; past that it is
//! ended and the controller says so. One secondary program waits for the network at a
//! time; the ones sent meanwhile wait their turn (at most [`MAX_SECONDARY_QUEUED`]).

use std::time::Duration;

use urscript_interp::{Event, Machine, State};

use super::{Cell, CellEvent, Compiled, Ended};
use crate::state::ProgramState;

/// The steps a secondary program gets at once: one, and the few a stray `sync()` might
/// take.
pub(super) const SECONDARY_STEPS: u32 = 4;

/// How long (controller time) a secondary program may wait for its sockets and XML-RPC
/// calls: 5 s, room for a connect and a reply across a plant network (UR allows only
/// quick calls there), and a bound on a server that never answers.
pub const SECONDARY_TIME: Duration = Duration::from_secs(5);

/// The secondary programs that may wait while one waits for the network: 16, more than
/// a client sends at once (drivers send one at a time); past it a new one is refused.
pub const MAX_SECONDARY_QUEUED: usize = 16;

/// A secondary program waiting for the network.
pub(super) struct Secondary {
    pub(super) machine: Machine,
    /// Controller time at which its program time 0 was.
    pub(super) origin: Duration,
    /// Whether it has used the network (the caller then holds its sockets).
    pub(super) networked: bool,
    /// The last connect it asked for, to name in the message if it never finishes.
    pub(super) waited: Option<String>,
}

impl Cell {
    /// The secondary program waiting for the network, for a driver that gives it what
    /// its sockets did (as [`Cell::machine_mut`] for the main program).
    pub fn secondary_machine_mut(&mut self) -> Option<&mut Machine> {
        self.secondary.as_mut().map(|s| &mut s.machine)
    }

    /// A `sec` program arrived at `now`: it runs now, or after the one waiting for the
    /// network.
    pub(super) fn run_secondary(&mut self, program: Compiled, now: Duration) {
        if self.secondary.is_some() {
            if self.secondary_queue.len() >= MAX_SECONDARY_QUEUED {
                return self.push(CellEvent::Refused {
                    line: 0,
                    column: 0,
                    text: format!(
                        "the secondary program was not run: {MAX_SECONDARY_QUEUED} secondary programs already wait behind one waiting for the network"
                    ),
                    code: None,
                });
            }
            self.secondary_queue.push_back(program);
            return;
        }
        self.start_secondary(program, now);
    }

    fn start_secondary(&mut self, program: Compiled, now: Duration) {
        let mut machine = match program.machine {
            Ok(m) => m,
            Err(refused) => return self.push(refused),
        };
        *machine.arm_mut() = self.arm().clone();
        machine.run_until(self.interp.step_time * SECONDARY_STEPS);
        self.settle_secondary(
            Secondary {
                machine,
                origin: now,
                networked: false,
                waited: None,
            },
            now,
        );
    }

    /// Runs the secondary program waiting for the network up to `now` (then the ones
    /// queued behind it, as far as they finish at once).
    pub(super) fn advance_secondary(&mut self, now: Duration) {
        let Some(mut s) = self.secondary.take() else {
            return;
        };
        // It works on the arm as it is now (the main program may have changed it).
        *s.machine.arm_mut() = self.arm().clone();
        s.machine.run_until(now.saturating_sub(s.origin));
        self.settle_secondary(s, now);
    }

    /// Hands on what the secondary program did; keeps it if it still waits (within
    /// [`SECONDARY_TIME`]), else ends it and starts the next one queued.
    fn settle_secondary(&mut self, s: Secondary, now: Duration) {
        let Secondary {
            mut machine,
            origin,
            mut networked,
            mut waited,
        } = s;
        if let State::Error(e) = machine.state() {
            let e = e.clone();
            self.push(CellEvent::Refused {
                line: e.line(),
                column: e.column(),
                text: e.message().to_string(),
                code: e.code().cloned(),
            });
        }
        while let Some(e) = machine.poll_event() {
            match e {
                Event::Message(_) => self.push(CellEvent::Program(e)),
                Event::Connect { .. } | Event::Transmit { .. } | Event::Close { .. } => {
                    if let Event::Connect { host, port, .. } = &e {
                        waited = Some(format!("socket_open(\"{host}\", {port})"));
                    }
                    networked = true;
                    self.push(CellEvent::Secondary(e));
                }
                _ => {}
            }
        }
        let stop = machine
            .take_effects()
            .contains(&urscript_interp::Effect::ProtectiveStop);
        let running = *machine.state() == State::Running;
        let in_time = now.saturating_sub(origin) < SECONDARY_TIME;
        if running && in_time {
            // Its settings so far are the arm's; it goes on at the next step.
            let arm = machine.arm().clone();
            self.merge_secondary_arm(arm, stop, now);
            self.secondary = Some(Secondary {
                machine,
                origin,
                networked,
                waited,
            });
            return;
        }
        if running {
            let what = waited.map_or_else(
                || "it was still waiting".to_string(),
                |call| format!("it was waiting for {call}"),
            );
            self.push(CellEvent::Refused {
                line: 0,
                column: 0,
                text: format!(
                    "the secondary program was ended unfinished after {} s: {what}",
                    SECONDARY_TIME.as_secs_f64()
                ),
                code: None,
            });
        }
        let arm = machine.into_arm();
        self.merge_secondary_arm(arm, stop, now);
        if networked {
            self.push(CellEvent::SecondaryEnded);
        }
        if let Some(next) = self.secondary_queue.pop_front() {
            self.start_secondary(next, now);
        }
    }

    /// What a secondary program set becomes the arm's, its motion excepted; `stop`: it
    /// made a protective stop.
    fn merge_secondary_arm(&mut self, done: urscript_interp::Arm, stop: bool, now: Duration) {
        let arm = self.arm_mut();
        let (q, qd, tcp_speed) = (arm.q, arm.qd, arm.tcp_speed);
        *arm = done;
        arm.q = q;
        arm.qd = qd;
        arm.tcp_speed = tcp_speed;
        // `protective_stop()` in a secondary program stops the arm as in a main one (UR's
        // client library's driver test sends one and waits for the stop's error code).
        if stop {
            self.controller.protective_stop(now);
            if self.controller.program_state() == ProgramState::Stopped {
                // The program a client sent ends (`Controller::protective_stop`).
                self.end_running(Ended::Stopped);
            } else if let Some(r) = &mut self.running {
                r.paused_at.get_or_insert(now);
            }
        }
    }
}
