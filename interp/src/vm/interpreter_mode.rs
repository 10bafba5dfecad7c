//! Interpreter mode, the machine's side: lines from the interpreter socket compiled
//! against the running program and run by its main thread (the wire rules are in
//! [`crate::interpreter`]).

use std::sync::Arc;

use super::memory::{FRAME_BYTES, SLOT_BYTES};
use super::{Called, Frame, Machine, State, Wait};
use crate::error::Fault;
use crate::native::InterpreterRequest;
use crate::syntax::compile::Sym;
use crate::value::Value;

/// Interpreter mode: see [`crate::interpreter`] for the wire behaviour and its sources.
impl Machine {
    /// One line received on the interpreter socket (without its `\n`; a `\r` before it is
    /// dropped). A command (`skipbuffer`, `abort`, `statelast...`, `stateunexecuted`) is
    /// answered at once; a statement is compiled into the program and acknowledged (or
    /// discarded with the reason). `None`: the line waits behind a `clear_interpreter()`
    /// not run yet; its reply comes later from
    /// [`poll_interpreter_reply`](Self::poll_interpreter_reply).
    ///
    /// ```
    /// use std::time::Duration;
    /// use urscript_interp::{Config, Event, Machine, Program};
    /// let mut m = Machine::new(Program::parse("interpreter_mode()\n").unwrap(), Config::default());
    /// m.run_until(Duration::ZERO);
    /// let reply = m.interpreter_line(b"textmsg(\"hi\")").unwrap();
    /// assert_eq!(reply.to_string(), "ack: 1: textmsg(\"hi\")");
    /// m.run_until(Duration::from_millis(2));
    /// assert!(matches!(m.poll_event(), Some(Event::Message(msg)) if msg.text == "hi"));
    /// assert_eq!(m.interpreter_line(b"statelastexecuted").unwrap().to_string(), "state: 1: statelastexecuted");
    /// ```
    pub fn interpreter_line(&mut self, line: &[u8]) -> Option<crate::interpreter::Reply> {
        use crate::interpreter::{Command, Discard, Reply, MAX_LINE, MAX_UNEXECUTED};
        let line = line.strip_suffix(b"\r").unwrap_or(line);
        let discard = |reason: Discard, line: &[u8]| Reply::Discard {
            reason,
            statement: String::from_utf8_lossy(line).into_owned(),
        };
        if line.len() > MAX_LINE {
            return Some(discard(Discard::LineTooLong { len: line.len() }, line));
        }
        let Ok(text) = std::str::from_utf8(line) else {
            return Some(discard(Discard::NotUtf8, line));
        };
        if let Some(command) = Command::parse(text) {
            return Some(self.interpreter_command(command));
        }
        if self.state != State::Running {
            return Some(discard(Discard::NotRunning, line));
        }
        if self.interp.queue.len() + self.interp.held.len() >= MAX_UNEXECUTED {
            return Some(discard(Discard::QueueFull, line));
        }
        if self.interp.clearing.is_some() {
            self.interp.held.push_back(text.to_string());
            return None;
        }
        Some(self.interpret_text(text))
    }

    /// The reply to a line that [`interpreter_line`](Self::interpreter_line) held, once
    /// the clear it waited for has run (oldest first; at most
    /// [`MAX_UNEXECUTED`](crate::interpreter::MAX_UNEXECUTED) kept, the oldest dropped
    /// past it).
    pub fn poll_interpreter_reply(&mut self) -> Option<crate::interpreter::Reply> {
        self.interp.replies.pop_front()
    }

    /// The numbers the state commands answer, and whether interpreter mode is on.
    pub fn interpreter_status(&self) -> crate::interpreter::Status {
        crate::interpreter::Status {
            unexecuted: self.interp.queue.len(),
            ..self.interp.status
        }
    }

    /// Runs a command at once, as a line that is one does
    /// ([`interpreter_line`](Self::interpreter_line)): `skipbuffer` (drops the statements
    /// not started; answers how many), `abort` (stops the `movej`/`movel` under way;
    /// answers 1 if one was stopped), or a state command (answers its number).
    ///
    /// ```
    /// use urscript_interp::interpreter::Command;
    /// use urscript_interp::{Config, Machine, Program};
    /// let mut m = Machine::new(Program::parse("interpreter_mode()\n").unwrap(), Config::default());
    /// m.run_until(std::time::Duration::ZERO);
    /// m.interpreter_line(b"sleep(1)");
    /// m.interpreter_line(b"textmsg(1)");
    /// let r = m.interpreter_command(Command::SkipBuffer);
    /// assert_eq!(r.to_string(), "state: 2: skipbuffer");
    /// ```
    pub fn interpreter_command(
        &mut self,
        command: crate::interpreter::Command,
    ) -> crate::interpreter::Reply {
        use crate::interpreter::Command as C;
        let st = self.interp.status;
        let value = match command {
            C::SkipBuffer => {
                let n = self.interp.queue.len() as u64;
                self.interp.queue.clear();
                self.release_held();
                n
            }
            C::Abort => u64::from(self.interpreter_abort()),
            C::StateLastExecuted => u64::from(st.last_executed),
            C::StateLastInterpreted => u64::from(st.last_interpreted),
            C::StateLastCleared => u64::from(st.last_cleared),
            C::StateUnexecuted => self.interp.queue.len() as u64,
        };
        crate::interpreter::Reply::State { value, command }
    }

    /// `abort`: stops the `movej`/`movel` under way (a joint or tool motion); the thread
    /// that commanded it goes on at once. Whether one was stopped.
    fn interpreter_abort(&mut self) -> bool {
        use crate::arm::trajectory::Kind;
        let Some(m) = &self.ctl.motion else {
            return false;
        };
        if !matches!(m.kind, Kind::Joint { .. } | Kind::Tool { .. }) {
            return false;
        }
        let owner = m.owner;
        self.ctl.halt();
        let step = self.ctl.step;
        for t in &mut self.threads {
            if t.id == owner && !t.done {
                match &mut t.wait {
                    Wait::Steps { until, .. } => *until = step,
                    Wait::Motion { until, after, .. } => {
                        *until = f64::NEG_INFINITY;
                        *after = step;
                    }
                    _ => {}
                }
            }
        }
        true
    }

    /// Compiles one statement line into the program and queues it.
    fn interpret_text(&mut self, text: &str) -> crate::interpreter::Reply {
        use crate::interpreter::{Discard, Queued, Reply, MAX_INTERPRETED};
        let discard = |reason: Discard| Reply::Discard {
            reason,
            statement: text.to_string(),
        };
        if text.trim().is_empty() {
            return discard(Discard::Empty);
        }
        if self.interp.interpreted.saturating_add(text.len()) > MAX_INTERPRETED {
            return discard(Discard::TooMuchInterpreted);
        }
        let compile_error = |e: crate::error::ParseError| Discard::Compile {
            column: e.column(),
            message: e.message().to_string(),
        };
        let stmts = match crate::syntax::lexer::lex(text)
            .and_then(|toks| crate::syntax::parser::Parser::new(toks).program())
        {
            Ok(s) => s,
            Err(e) => return discard(compile_error(e)),
        };
        let before = self.prog.sizes();
        let prog = Arc::make_mut(&mut self.prog);
        let done = match prog.interpret(stmts) {
            Ok(d) => d,
            Err(e) => return discard(compile_error(e)),
        };
        let mut stubs = Vec::new();
        let mut clears = false;
        let mut refused = None;
        for site in &prog.sites[done.first_site..] {
            let name = &prog.names[site.name as usize];
            let stub = self
                .config
                .stubs
                .iter()
                .position(|(n, _)| n == name)
                .map(|i| i as u32);
            match site.builtin.map(|b| b.name) {
                Some("interpreter_mode") => refused = refused.or(Some(Discard::Nested)),
                Some("clear_interpreter" | "end_interpreter") => clears = true,
                None if !site.user && stub.is_none() => {
                    refused = refused.or(Some(Discard::Compile {
                        column: site.at.col,
                        message: format!("compile_error_name_not_found:{name}:"),
                    }))
                }
                _ => {}
            }
            stubs.push(stub);
        }
        if let Some(reason) = refused {
            prog.truncate(before);
            return discard(reason);
        }
        self.site_stubs.extend(stubs);
        self.globals.resize(prog.names.len(), None);
        self.interp.base.get_or_insert(before);
        self.interp.interpreted += text.len();
        let id = self.interp.next_id();
        self.interp.status.last_interpreted = id;
        self.interp.queue.push_back(Queued {
            id,
            func: done.func,
        });
        if clears {
            self.interp.clearing = Some(id);
        }
        Reply::Ack {
            id,
            statement: text.to_string(),
        }
    }

    /// Whether the main thread, waiting in interpreter mode, has something to do.
    pub(super) fn interpreter_has_work(&self) -> bool {
        let i = &self.interp;
        i.ending || i.clear_pending || !i.queue.is_empty() || i.clearing.is_some()
    }

    /// The main thread (at `i`) waits in interpreter mode: a pending clear or end
    /// happens, then the next statement starts. Outside `exec`: the program may change.
    pub(super) fn interpreter_resume(&mut self, i: usize) -> (bool, Wait) {
        if std::mem::take(&mut self.interp.clear_pending) {
            self.interpreter_clear();
        }
        if std::mem::take(&mut self.interp.ending) {
            self.interp.status.active = false;
            if self.interp.clear_on_end {
                self.interpreter_clear();
            }
            self.release_held();
            // `interpreter_mode()` returns.
            self.ctl.mem.add(SLOT_BYTES);
            self.threads[i].stack.push(Value::None);
            return (true, Wait::None);
        }
        self.release_held();
        match self.interp.queue.pop_front() {
            Some(q) => {
                let th = &mut self.threads[i];
                self.interp.executing = Some(th.frames.len());
                self.interp.status.last_executed = q.id;
                let base = th.stack.len();
                // The statement runs in the scope `interpreter_mode()` was called from:
                // it borrows that function's locals (given back when it ends).
                let locals = th
                    .frames
                    .last_mut()
                    .map(|f| std::mem::take(&mut f.locals))
                    .unwrap_or_default();
                // The frame is counted; its locals were counted in the caller's.
                self.ctl.mem.add(FRAME_BYTES);
                th.frames.push(Frame {
                    func: q.func,
                    pc: 0,
                    locals,
                    base,
                });
                (true, Wait::None)
            }
            None => (false, Wait::Interpreter),
        }
    }

    /// Removes everything interpreted since the last clear: the queue, the functions and
    /// globals the lines made; threads running interpreted code stop.
    fn interpreter_clear(&mut self) {
        if let Some(last) = self
            .interp
            .base
            .map(|_| self.interp.status.last_interpreted)
        {
            self.interp.status.last_cleared = last;
        }
        self.interp.queue.clear();
        self.interp.interpreted = 0;
        let Some(base) = self.interp.base.take() else {
            return;
        };
        let first = base.funcs as u32;
        let owner = self.ctl.motion.as_ref().map(|m| m.owner);
        for t in &mut self.threads {
            if t.id == 0 || t.done || !t.frames.iter().any(|f| f.func >= first) {
                continue;
            }
            if owner == Some(t.id) {
                self.ctl.halt();
            }
            t.done = true;
            t.frames = Vec::new();
            t.stack = Vec::new();
            if let Wait::Read { socket, .. } = std::mem::replace(&mut t.wait, Wait::None) {
                self.ctl.sockets.give_up(&socket);
            }
        }
        Arc::make_mut(&mut self.prog).truncate(base);
        self.globals.truncate(base.names);
        // Locals the statements made in the main thread's frames go with their names.
        let names = base.names as Sym;
        if let Some(main) = self.threads.iter_mut().find(|t| t.id == 0) {
            for f in &mut main.frames {
                f.locals.retain(|(s, _)| *s < names);
            }
        }
        self.site_stubs.truncate(base.sites);
    }

    /// Once the statement that clears has run (or was dropped), the lines held behind it
    /// are compiled and answered, up to the next one that clears.
    fn release_held(&mut self) {
        let Some(id) = self.interp.clearing else {
            return;
        };
        let waiting = self.interp.queue.iter().any(|q| q.id == id)
            || (self.interp.executing.is_some() && self.interp.status.last_executed == id);
        if waiting {
            return;
        }
        self.interp.clearing = None;
        while self.interp.clearing.is_none() {
            let Some(text) = self.interp.held.pop_front() else {
                break;
            };
            let reply = self.interpret_text(&text);
            if self.interp.replies.len() >= crate::interpreter::MAX_UNEXECUTED {
                self.interp.replies.pop_front();
            }
            self.interp.replies.push_back(reply);
        }
    }

    /// `interpreter_mode`, `end_interpreter`, `clear_interpreter`: they act on the
    /// machine, not on the arm.
    pub(super) fn interpreter_request(&mut self, r: InterpreterRequest) -> Result<Called, Fault> {
        match r {
            InterpreterRequest::Enter {
                clear_queue,
                clear_on_end,
            } => {
                if self.ctl.thread != 0 {
                    return Err(Fault::from(
                        "interpreter_mode() can only be called in the main thread",
                    ));
                }
                if self.interp.status.active {
                    return Err(Fault::from(
                        "interpreter_mode(): nested interpreter modes are not supported",
                    ));
                }
                if clear_queue {
                    if let Some(last) = self.interp.queue.back() {
                        self.interp.status.last_cleared = last.id;
                    }
                    self.interp.queue.clear();
                }
                self.interp.status.active = true;
                self.interp.clear_on_end = clear_on_end;
                Ok(Called::Block(Wait::Interpreter))
            }
            InterpreterRequest::End => {
                if self.interp.status.active {
                    self.interp.ending = true;
                }
                Ok(Called::Value(Value::None))
            }
            InterpreterRequest::Clear => {
                if !self.interp.status.active {
                    return Err(Fault::from(
                        "clear_interpreter() can only be called in interpreter mode",
                    ));
                }
                self.interp.clear_pending = true;
                Ok(Called::Value(Value::None))
            }
        }
    }
}
