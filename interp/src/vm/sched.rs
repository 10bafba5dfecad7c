//! The scheduler: the step due, each step's threads in their fixed order (see
//! [`crate::machine`], "Time"), what wakes a waiting thread, and the program's stop.

use std::sync::Arc;
use std::time::Duration;

use super::memory::thread_bytes;
use super::wait::rpc_done;
use super::{Flow, Machine, State, Thread, Wait, MAX_MOTION_SAMPLES};
use crate::error::{Fault, RuntimeError, RuntimeErrorKind as K};
use crate::event::{Event, Outcome, ReadRecord};
use crate::value::Value;

impl Machine {
    pub(super) fn next_wake_step(&self) -> Option<u64> {
        // A waiting read's deadline is the robot model's, not the interpreter's: its
        // step is the first whose time is at or after it.
        let st = self.config.step_time.as_nanos().max(1);
        let mut best: Option<u64> = self.ctl.sockets.poll_timeout().map(|d| {
            u64::try_from(d.as_nanos().div_ceil(st))
                .unwrap_or(u64::MAX)
                .max(self.ctl.step)
        });
        for t in &self.threads {
            if t.done {
                continue;
            }
            let at = match &t.wait {
                Wait::None | Wait::Resume(_) => Some(self.ctl.step),
                Wait::Steps { until, .. } | Wait::Slice(until) => Some((*until).max(self.ctl.step)),
                Wait::Motion { until, after, .. } => self
                    .ctl
                    .clock
                    .step_reaching(*until, (*after).max(self.ctl.step)),
                Wait::Read { .. } => None,
                Wait::Connect { .. } => None,
                Wait::Rpc(p) => Some(p.deadline.max(self.ctl.step)),
                Wait::Failed(_) => Some(self.ctl.step),
                Wait::Join(id) => match self.thread(*id) {
                    Some(_) => None,
                    None => Some(self.ctl.step),
                },
                Wait::Interpreter => self.interpreter_has_work().then_some(self.ctl.step),
            };
            if let Some(at) = at {
                best = Some(best.map_or(at, |b: u64| b.min(at)));
            }
        }
        let step_time = self.ctl.step_time.as_secs_f64();
        if let Some(at) = self
            .ctl
            .eip
            .next_deadline(self.ctl.arm.world.eip_connected, step_time)
        {
            let at = at.max(self.ctl.step);
            best = Some(best.map_or(at, |b: u64| b.min(at)));
        }
        if let Some(at) = self.ctl.next_rtde_watchdog() {
            let at = at.max(self.ctl.step);
            best = Some(best.map_or(at, |b: u64| b.min(at)));
        }
        best
    }

    /// Runs every step due at or before `now` (time since the program started).
    pub fn run_until(&mut self, now: Duration) {
        let st = self.config.step_time.as_nanos().max(1);
        // The first step whose time is after `now`.
        let target = u64::try_from(now.as_nanos() / st)
            .unwrap_or(u64::MAX - 1)
            .saturating_add(1);
        self.ctl.sync_speed();
        while self.state == State::Running && self.ctl.step < target {
            match self.next_wake_step() {
                Some(s) if s < target => {
                    self.sample_motion_until(s);
                    self.ctl.step = self.ctl.step.max(s);
                    self.run_step();
                    self.ctl.step += 1;
                }
                _ => {
                    self.sample_motion_until(target);
                    self.ctl.step = target;
                }
            }
        }
        // Steps where no thread ran still move the arm: it is where the motion has it at
        // the last step due.
        if self.state == State::Running
            && (self.ctl.motion.is_some() || self.ctl.arm.force_mode.is_some())
        {
            self.ctl.advance(self.ctl.step.saturating_sub(1));
        }
    }

    /// Puts the arm through every step from the next one up to (not including) `end`
    /// while a motion is under way, as the controller computes each step: a tool move's
    /// joints follow its path step by step (each step's inverse kinematics nearest the
    /// last), so where the arm goes does not depend on how often the driver calls
    /// [`run_until`](Self::run_until) (real time, or virtual time's jumps).
    ///
    /// At most [`MAX_MOTION_SAMPLES`] steps per call: a caller that jumps further (hours
    /// of a held `speedl` in one call) gets the arm where the motion has it at the end.
    fn sample_motion_until(&mut self, end: u64) {
        let mut step = self.ctl.step;
        let end = end.min(step.saturating_add(MAX_MOTION_SAMPLES));
        while step < end && self.ctl.motion.is_some() {
            self.ctl.advance(step);
            step += 1;
        }
    }

    /// The same as [`run_until`](Self::run_until), in quinn-proto's words: the moment
    /// [`poll_timeout`](Self::poll_timeout) gave has come.
    pub fn handle_timeout(&mut self, now: Duration) {
        self.run_until(now);
    }

    pub(super) fn stop(&mut self, state: State) {
        self.state = state;
        // The arm stops where it is; teach, freedrive and force mode end with the program.
        self.ctl.halt();
        self.ctl.end_modes();
        for t in &mut self.threads {
            t.done = true;
            if let Wait::Rpc(p) = std::mem::replace(&mut t.wait, Wait::None) {
                self.ctl.events.push_back(Event::Close {
                    socket_name: p.socket,
                });
            }
        }
        for name in self.ctl.sockets.open_names() {
            self.ctl.close(&name);
        }
    }

    /// A wait that ends after `d` of program time (at least one step).
    pub(super) fn wait_for(&self, d: Duration, result: Value) -> Wait {
        Wait::Steps {
            until: self.ctl.step.saturating_add(self.steps_for(d).max(1)),
            result,
        }
    }

    /// The live thread with handle `id`.
    pub(super) fn thread(&self, id: u32) -> Option<&Thread> {
        self.threads.iter().find(|t| t.id == id && !t.done)
    }

    /// Runs one step: every live thread, in the order they started. Finished threads
    /// leave the list at the end of the step, so a step visits at most the live threads
    /// and those started during it.
    fn run_step(&mut self) {
        self.ctl.advance(self.ctl.step);
        let step_time = self.ctl.step_time.as_secs_f64();
        match self
            .ctl
            .eip
            .check(self.ctl.arm.world.eip_connected, self.ctl.step, step_time)
        {
            Some(crate::eip::Trip::Pause) => self.ctl.protective_stop(),
            Some(crate::eip::Trip::Stop(why)) => {
                self.ctl.protective_stop();
                self.state = State::Error(RuntimeError::at(0, 0, Fault::new(K::Limit, why)));
                return;
            }
            None => {}
        }
        match self.ctl.check_rtde_watchdogs() {
            Some(crate::runtime::WatchdogTrip::Pause) => self.ctl.effect(crate::Effect::Pause),
            Some(crate::runtime::WatchdogTrip::Stop(why)) => {
                self.state = State::Error(RuntimeError::at(0, 0, Fault::new(K::Limit, why)));
                return;
            }
            None => {}
        }
        self.run_threads();
        if self.state == State::Running {
            self.threads.retain(|t| !t.done);
        }
    }

    fn run_threads(&mut self) {
        let mut i = 0;
        while i < self.threads.len() {
            if self.state != State::Running {
                return;
            }
            if self.threads[i].done {
                i += 1;
                continue;
            }
            // Resolve the wait, if this step ends it.
            let wait = std::mem::replace(&mut self.threads[i].wait, Wait::None);
            let (runnable, wait) = match wait {
                Wait::None => (true, Wait::None),
                // A call's result comes onto the stack: counted (its size is bounded
                // by the call: a socket read, a checked XML-RPC reply), and checked with
                // the thread's next allocation.
                Wait::Resume(v) => {
                    self.ctl.mem.add(v.held_bytes());
                    self.threads[i].stack.push(v);
                    (true, Wait::None)
                }
                Wait::Steps { until, result } if until <= self.ctl.step => {
                    self.ctl.mem.add(result.held_bytes());
                    self.threads[i].stack.push(result);
                    (true, Wait::None)
                }
                Wait::Slice(until) if until <= self.ctl.step => (true, Wait::None),
                Wait::Motion {
                    until,
                    after,
                    result,
                } if after <= self.ctl.step && self.ctl.clock_now() >= until => {
                    self.ctl.mem.add(result.held_bytes());
                    self.threads[i].stack.push(result);
                    (true, Wait::None)
                }
                Wait::Read {
                    socket,
                    call,
                    record,
                    input,
                    buffered_at_start,
                } => match self.ctl.sockets.handle_timeout(&socket, &call, self.now()) {
                    Some(r) => {
                        let v = crate::sockets::to_value(&r);
                        if let Some(mut rec) = record {
                            rec.result = v.clone();
                            rec.outcome = Outcome::TimedOut;
                            rec.read = Some(ReadRecord {
                                call,
                                result: r,
                                input,
                                buffered_at_start,
                            });
                            self.ctl.events.push_back(Event::Call(rec));
                        }
                        self.ctl.mem.add(v.held_bytes());
                        self.threads[i].stack.push(v);
                        (true, Wait::None)
                    }
                    None => (
                        false,
                        Wait::Read {
                            socket,
                            call,
                            record,
                            input,
                            buffered_at_start,
                        },
                    ),
                },
                Wait::Join(id) if self.thread(id).is_none() => (true, Wait::None),
                Wait::Rpc(mut p) if p.deadline <= self.ctl.step => {
                    let msg = p.failure(&format!(
                        "no complete reply within {} s",
                        crate::rpc::TIMEOUT.as_secs()
                    ));
                    (
                        false,
                        rpc_done(
                            &mut self.ctl.events,
                            &mut p,
                            Err(msg),
                            self.config.max_value_size,
                        ),
                    )
                }
                Wait::Interpreter => self.interpreter_resume(i),
                other => (false, other),
            };
            if let Wait::Failed(e) = wait {
                self.stop(State::Error(*e));
                return;
            }
            self.threads[i].wait = wait;
            if runnable {
                self.current = i;
                self.budget = 0;
                let placeholder = Thread {
                    id: u32::MAX,
                    frames: Vec::new(),
                    stack: Vec::new(),
                    wait: Wait::None,
                    done: true,
                    critical: 0,
                };
                let mut th = std::mem::replace(&mut self.threads[i], placeholder);
                self.ctl.thread = th.id;
                let prog = Arc::clone(&self.prog);
                let flow = self.exec(&mut th, &prog);
                self.threads[i] = th;
                match flow {
                    Ok(Flow::Blocked) => {}
                    Ok(Flow::Finished) => {
                        let t = &mut self.threads[i];
                        self.ctl.mem.credit(thread_bytes(t));
                        t.done = true;
                        t.frames = Vec::new();
                        t.stack = Vec::new();
                        if i == 0 {
                            self.stop(State::Finished);
                        }
                    }
                    Ok(Flow::Halt) => self.stop(State::Halted),
                    Err(e) => self.stop(State::Error(e)),
                }
            }
            i += 1;
        }
    }
}
