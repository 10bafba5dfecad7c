//! The running program: threads, the scheduler in virtual time, and the sans-IO interface.
//!
//! ## Time
//! Time is an input: the machine never reads a clock. Program time advances in steps of
//! [`Config::step_time`] (2 ms e-Series, 8 ms CB3); step `k` runs at `k × step_time`
//! after the start. In each step the threads run **in a fixed order: the main program
//! first, then the threads in the order `run` started them** (a thread started during a
//! step runs in that same step, after the others). Each runs until it consumes physical
//! time: `sync()` (to the next step), `sleep(t)` and motion (to the step where the time is
//! over), a socket read whose bytes have not all arrived (until they arrive, checked at
//! each step, or its timeout), `socket_open` (until the driver reports the connection),
//! `join` of a thread that still runs. This is the manual's "Thread scheduling": 2 ms
//! frames, each runnable thread scheduled round robin, a thread that has used its frame
//! waits for the next. A thread that runs more than
//! [`Config::max_statements_per_step`] statements in one step without consuming time is a
//! runtime error, as the controller stops a thread that "used too much time" (a loop
//! without `sync()`).
//!
//! Threads only switch where time is consumed, so `enter_critical`/`exit_critical` never
//! needs to hold the others back: a thread inside a critical section already runs alone
//! until it consumes time, and when it does (as UR's External Control program does inside
//! one) the others run, as on the controller.
//!
//! ## Driving it
//! Call [`Machine::run_until`] with the time since the program started; it runs every
//! step due. Take the [`Event`]s with [`Machine::poll_event`]: connections to open, bytes
//! to send, messages. Report connections ([`Machine::handle_connected`]), received bytes
//! ([`Machine::handle_received`]) and closed peers. [`Machine::poll_timeout`] says when
//! the machine next has something to do (`None`: only an input can wake it).

use std::collections::VecDeque;
use std::f64::consts::FRAC_PI_2;
use std::sync::Arc;
use std::time::Duration;

use crate::compile::{Op, Program, Sym, NO_KW};
use crate::error::RuntimeError;
use crate::parser::{BinOp, Scope};
use crate::sockets::{Policy, ReadSpec, Sockets};
use crate::value::Value;

/// The most threads that may run at once (the program's own included).
pub const MAX_THREADS: usize = 64;

/// What replaces a function the program calls (a built-in not supported, or one to
/// override), set with [`Config::stub`].
#[derive(Debug, Clone, PartialEq)]
pub enum Stub {
    /// Does nothing and returns nothing.
    NoOp,
    /// Returns this value.
    Return(Value),
}

/// How the machine runs.
///
/// ```
/// use std::time::Duration;
/// use urscript_interp::{Config, Stub, Value};
/// let c = Config::cb3().stub("rq_activate", Stub::NoOp).stub("get_gripper_pos", Stub::Return(Value::Int(0)));
/// assert_eq!(c.step_time, Duration::from_millis(8));
/// ```
#[derive(Debug, Clone)]
pub struct Config {
    /// Length of one program step: 2 ms (e-Series, the default), 8 ms (CB3).
    pub step_time: Duration,
    /// The socket reads' choices where UR's manuals are silent.
    pub policy: Policy,
    /// Functions replaced by stubs, by name. A stub wins over a built-in of that name,
    /// but not over a function the program defines.
    pub stubs: Vec<(String, Stub)>,
    /// Statements a thread may run in one step without consuming time (default 100 000).
    pub max_statements_per_step: u32,
    /// Emit an [`Event::Call`] for every socket call (default true). Off, the machine
    /// does not format the calls at all.
    pub trace_socket_calls: bool,
    /// Emit an [`Event::Call`] for every built-in call, not only socket calls.
    pub trace_all_calls: bool,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            step_time: Duration::from_millis(2),
            policy: Policy::default(),
            stubs: Vec::new(),
            max_statements_per_step: 100_000,
            trace_socket_calls: true,
            trace_all_calls: false,
        }
    }
}

impl Stub {
    /// Reads a command-line stub: `NAME` (does nothing) or `NAME=VALUE`, the value a
    /// URScript constant (`3`, `-0.5`, `True`, `"ok"`, `[1, 2]`, `p[0, 0, 0.1, 0, 0, 0]`).
    ///
    /// ```
    /// use urscript_interp::{Stub, Value};
    /// assert_eq!(Stub::from_arg("rq_activate").unwrap(), ("rq_activate".to_string(), Stub::NoOp));
    /// assert_eq!(Stub::from_arg("rq_pos=-3").unwrap().1, Stub::Return(Value::Int(-3)));
    /// assert!(Stub::from_arg("x=1 +").is_err());
    /// ```
    pub fn from_arg(arg: &str) -> Result<(String, Stub), String> {
        let (name, value) = match arg.split_once('=') {
            Some((n, v)) => (n.trim(), Some(v)),
            None => (arg.trim(), None),
        };
        if name.is_empty() || !name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_') {
            return Err(format!("`{name}` is not a function name"));
        }
        let stub = match value {
            None => Stub::NoOp,
            Some(v) => Stub::Return(
                crate::parse_constant(v)
                    .map_err(|e| format!("the value of stub `{name}`: {}", e.message()))?,
            ),
        };
        Ok((name.to_string(), stub))
    }
}

impl Config {
    /// A CB3 controller: 8 ms steps (125 Hz).
    pub fn cb3() -> Self {
        Config {
            step_time: Duration::from_millis(8),
            ..Config::default()
        }
    }

    /// Adds a stub for `name`.
    pub fn stub(mut self, name: &str, stub: Stub) -> Self {
        self.stubs.push((name.to_string(), stub));
        self
    }
}

/// What the machine asks of its driver, or reports.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// `socket_open`: connect to `host:port`, then call
    /// [`Machine::handle_connected`] with the outcome.
    Connect {
        /// The socket's name in the program.
        socket_name: String,
        /// The address argument.
        host: String,
        /// The port argument.
        port: u16,
    },
    /// Bytes the program sent on a socket.
    Transmit {
        /// The socket's name.
        socket_name: String,
        /// The bytes, in order.
        bytes: Vec<u8>,
    },
    /// The program closed a socket (or ended with it open).
    Close {
        /// The socket's name.
        socket_name: String,
    },
    /// `textmsg(...)` or `popup(...)` text.
    Message(String),
    /// A call and what it returned, as URScript text:
    /// `socket_read_ascii_float(6, "camera") -> [6, 0.1, ...]`. Every socket call is
    /// traced; other built-ins with [`Config::trace_all_calls`].
    Call {
        /// The line of the call.
        line: u32,
        /// The call and its result.
        text: String,
    },
}

/// Where the program is.
#[derive(Debug, Clone, PartialEq)]
pub enum State {
    /// It runs (or waits for time or input).
    Running,
    /// The program ended.
    Finished,
    /// `halt` ran.
    Halted,
    /// A runtime error stopped it.
    Error(RuntimeError),
}

/// How a blocked thread waits.
#[derive(Debug, Clone)]
pub(crate) enum Wait {
    /// Runnable now.
    None,
    /// Resumes at step `until`, with `result` as the value of the call.
    Steps { until: u64, result: Value },
    /// Resumes at the next step with this value (a read completed by received bytes).
    Resume(Value),
    /// A socket read waiting for bytes.
    Read {
        socket: String,
        spec: ReadSpec,
        call: String,
        line: u32,
    },
    /// `socket_open` waiting for the driver.
    Connect {
        socket: String,
        call: String,
        line: u32,
    },
    /// `join` of a running thread.
    Join(u32),
}

#[derive(Debug, Clone)]
pub(crate) struct Frame {
    func: u32,
    pc: u32,
    locals: Vec<(Sym, Option<Value>)>,
    base: usize,
}

#[derive(Debug, Clone)]
pub(crate) struct Thread {
    name: String,
    frames: Vec<Frame>,
    stack: Vec<Value>,
    wait: Wait,
    done: bool,
    critical: u32,
}

/// What a built-in did.
pub(crate) enum NativeOut {
    Value(Value),
    Block(Wait),
}

enum Flow {
    Blocked,
    Finished,
    Halt,
}

/// The virtual arm: commanded state, not dynamics (see [`crate::builtins`]).
#[derive(Debug, Clone)]
pub(crate) struct Arm {
    pub q: [f64; 6],
    pub qd: [f64; 6],
    pub pose: [f64; 6],
    pub tcp_speed: [f64; 6],
    pub tcp: [f64; 6],
    pub digital_out: [bool; 18],
    pub tool_out: [bool; 2],
    pub analog_out: [f64; 2],
    pub int_regs: [i32; 48],
    pub float_regs: [f64; 48],
    pub bool_regs: [bool; 64],
    pub random_state: u64,
}

impl Default for Arm {
    fn default() -> Self {
        Arm {
            q: [0.0, -FRAC_PI_2, 0.0, -FRAC_PI_2, 0.0, 0.0],
            qd: [0.0; 6],
            pose: [0.0; 6],
            tcp_speed: [0.0; 6],
            tcp: [0.0; 6],
            digital_out: [false; 18],
            tool_out: [false; 2],
            analog_out: [0.0; 2],
            int_regs: [0; 48],
            float_regs: [0.0; 48],
            bool_regs: [false; 64],
            random_state: 0x2545_F491_4F6C_DD1D,
        }
    }
}

/// A program running in virtual time. See the module docs for the time model.
///
/// ```
/// use std::time::Duration;
/// use urscript_interp::{Config, Event, Machine, Program, State};
/// let prog = Program::parse("i = 0\nwhile i < 3:\n  i = i + 1\n  sync()\nend\ntextmsg(\"done \", i)\n").unwrap();
/// let mut m = Machine::new(prog, Config::default());
/// m.run_until(Duration::from_millis(10));
/// assert_eq!(m.state(), &State::Finished);
/// assert_eq!(m.poll_event(), Some(Event::Message("done 3".into())));
/// ```
#[derive(Debug)]
pub struct Machine {
    pub(crate) prog: Arc<Program>,
    pub(crate) config: Config,
    globals: Vec<Option<Value>>,
    threads: Vec<Thread>,
    /// The next step to run.
    step: u64,
    pub(crate) events: VecDeque<Event>,
    state: State,
    pub(crate) sockets: Sockets,
    pub(crate) arm: Arm,
    /// Statements run by the current thread in this step.
    budget: u32,
    /// The thread running now.
    pub(crate) current: usize,
}

impl Machine {
    /// A machine about to run `program`'s first step at time 0.
    ///
    /// A step time below 100 µs is raised to 100 µs.
    pub fn new(program: Program, mut config: Config) -> Self {
        config.step_time = config.step_time.max(Duration::from_micros(100));
        let globals = vec![None; program.names.len()];
        let main = Thread {
            name: program.funcs[0].name.clone(),
            frames: vec![Frame {
                func: 0,
                pc: 0,
                locals: Vec::new(),
                base: 0,
            }],
            stack: Vec::new(),
            wait: Wait::None,
            done: false,
            critical: 0,
        };
        Machine {
            sockets: Sockets::new(config.policy),
            prog: Arc::new(program),
            config,
            globals,
            threads: vec![main],
            step: 0,
            events: VecDeque::new(),
            state: State::Running,
            arm: Arm::default(),
            budget: 0,
            current: 0,
        }
    }

    /// The functions the program calls that are neither defined by it, built in, nor
    /// stubbed, with the first line calling each: calling one is a runtime error. A
    /// driver can list them before running.
    ///
    /// ```
    /// use urscript_interp::{Config, Machine, Program, Stub};
    /// let p = Program::parse("rq_activate()\nsync()\n").unwrap();
    /// assert_eq!(Machine::new(p.clone(), Config::default()).unknown_functions(), [("rq_activate".to_string(), 1)]);
    /// let m = Machine::new(p, Config::default().stub("rq_activate", Stub::NoOp));
    /// assert!(m.unknown_functions().is_empty());
    /// ```
    pub fn unknown_functions(&self) -> Vec<(String, u32)> {
        self.prog
            .called_builtins_with_lines()
            .into_iter()
            .filter(|(n, _)| !crate::builtins::is_builtin(n) && !self.is_stubbed(n))
            .map(|(n, l)| (n.to_string(), l))
            .collect()
    }

    fn is_stubbed(&self, name: &str) -> bool {
        self.config.stubs.iter().any(|(n, _)| n == name)
    }

    /// Where the program is.
    pub fn state(&self) -> &State {
        &self.state
    }

    /// The virtual time of the next step to run.
    pub fn now(&self) -> Duration {
        self.step_time_at(self.step)
    }

    fn step_time_at(&self, step: u64) -> Duration {
        let nanos = self
            .config
            .step_time
            .as_nanos()
            .saturating_mul(u128::from(step));
        Duration::from_nanos(u64::try_from(nanos).unwrap_or(u64::MAX))
    }

    fn steps_for(&self, d: Duration) -> u64 {
        let st = self.config.step_time.as_nanos().max(1);
        let n = d.as_nanos().div_ceil(st);
        u64::try_from(n).unwrap_or(u64::MAX)
    }

    /// The next event, oldest first.
    pub fn poll_event(&mut self) -> Option<Event> {
        self.events.pop_front()
    }

    /// The value of a global variable, if set.
    ///
    /// ```
    /// # use urscript_interp::{Config, Machine, Program, Value};
    /// let mut m = Machine::new(Program::parse("x = 2 * 21\n").unwrap(), Config::default());
    /// m.run_until(std::time::Duration::ZERO);
    /// assert_eq!(m.global("x"), Some(&Value::Int(42)));
    /// ```
    pub fn global(&self, name: &str) -> Option<&Value> {
        let i = self.prog.names.iter().position(|n| n == name)?;
        self.globals.get(i)?.as_ref()
    }

    /// The arm's commanded joint positions.
    pub fn joint_positions(&self) -> [f64; 6] {
        self.arm.q
    }

    /// The arm's commanded tool pose.
    pub fn tcp_pose(&self) -> [f64; 6] {
        self.arm.pose
    }

    /// When the machine next has something to do: the time of the next step if a thread
    /// can run then, or of the first step where a sleep, a motion or a read timeout ends;
    /// `None` if it only waits for inputs (a connection, bytes) or has stopped.
    pub fn poll_timeout(&self) -> Option<Duration> {
        if self.state != State::Running {
            return None;
        }
        self.next_wake_step().map(|s| self.step_time_at(s))
    }

    fn next_wake_step(&self) -> Option<u64> {
        // A waiting read's deadline is the robot model's, not the interpreter's: its
        // step is the first whose time is at or after it.
        let st = self.config.step_time.as_nanos().max(1);
        let mut best: Option<u64> = self.sockets.poll_timeout().map(|d| {
            u64::try_from(d.as_nanos().div_ceil(st))
                .unwrap_or(u64::MAX)
                .max(self.step)
        });
        for t in &self.threads {
            if t.done {
                continue;
            }
            let at = match &t.wait {
                Wait::None | Wait::Resume(_) => Some(self.step),
                Wait::Steps { until, .. } => Some((*until).max(self.step)),
                Wait::Read { .. } => None,
                Wait::Connect { .. } => None,
                Wait::Join(id) => match self.threads.get(*id as usize) {
                    Some(j) if !j.done => None,
                    _ => Some(self.step),
                },
            };
            if let Some(at) = at {
                best = Some(best.map_or(at, |b: u64| b.min(at)));
            }
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
        while self.state == State::Running && self.step < target {
            match self.next_wake_step() {
                Some(s) if s < target => {
                    self.step = self.step.max(s);
                    self.run_step();
                    self.step += 1;
                }
                _ => self.step = target,
            }
        }
    }

    /// The same as [`run_until`](Self::run_until), in quinn-proto's words: the moment
    /// [`poll_timeout`](Self::poll_timeout) gave has come.
    pub fn handle_timeout(&mut self, now: Duration) {
        self.run_until(now);
    }

    /// The driver's answer to [`Event::Connect`]: the connection is up, or failed with a
    /// reason (then `socket_open` returns `False` and the program goes on).
    pub fn handle_connected(&mut self, socket_name: &str, result: Result<(), String>) {
        let ok = result.is_ok();
        if ok {
            self.sockets.open(socket_name);
        }
        for t in &mut self.threads {
            if let Wait::Connect { socket, call, line } = &t.wait {
                if socket == socket_name {
                    if self.config.trace_socket_calls {
                        let text = match &result {
                            Ok(()) => format!("{call} -> True"),
                            Err(e) => format!("{call} -> False ({e})"),
                        };
                        self.events.push_back(Event::Call { line: *line, text });
                    }
                    t.wait = Wait::Resume(Value::Bool(ok));
                }
            }
        }
    }

    /// Bytes the server sent on `socket_name`. Returns how many the socket's receive
    /// buffer accepted (the rest must be offered again later, as a full TCP window would).
    pub fn handle_received(&mut self, socket_name: &str, bytes: &[u8]) -> usize {
        let n = self.sockets.receive(socket_name, bytes);
        self.poll_reads(socket_name);
        n
    }

    /// The server closed `socket_name`: reads waiting on it end with their sentinels.
    pub fn handle_peer_closed(&mut self, socket_name: &str) {
        self.sockets.peer_closed(socket_name);
        self.poll_reads(socket_name);
    }

    /// Writing to `socket_name` failed (the peer is gone): later `socket_send_*` calls
    /// on it return `False`, and reads waiting on it end with their sentinels.
    pub fn handle_send_failed(&mut self, socket_name: &str) {
        self.sockets.send_failed(socket_name);
        self.handle_peer_closed(socket_name);
    }

    /// Completes a read waiting on `socket_name` if its bytes are there.
    fn poll_reads(&mut self, socket_name: &str) {
        for i in 0..self.threads.len() {
            let Wait::Read {
                socket, call, line, ..
            } = &self.threads[i].wait
            else {
                continue;
            };
            if socket != socket_name || self.threads[i].done {
                continue;
            }
            let (call, line) = (call.clone(), *line);
            if let Some(v) = self.sockets.poll(socket_name) {
                if self.config.trace_socket_calls {
                    self.events.push_back(Event::Call {
                        line,
                        text: format!("{call} -> {}", v.to_source()),
                    });
                }
                self.threads[i].wait = Wait::Resume(v);
            }
        }
    }

    /// Names of the sockets open now.
    pub fn open_sockets(&self) -> Vec<String> {
        self.sockets.open_names()
    }

    fn stop(&mut self, state: State) {
        self.state = state;
        for t in &mut self.threads {
            t.done = true;
        }
        for name in self.sockets.open_names() {
            self.flush(&name);
            self.sockets.close(&name);
            self.events.push_back(Event::Close { socket_name: name });
        }
    }

    /// Queues the socket's outgoing bytes as an event.
    pub(crate) fn flush(&mut self, name: &str) {
        let bytes = self.sockets.take_outgoing(name);
        if !bytes.is_empty() {
            self.events.push_back(Event::Transmit {
                socket_name: name.to_string(),
                bytes,
            });
        }
    }

    /// A wait that ends after `d` of program time (at least one step).
    pub(crate) fn wait_for(&self, d: Duration, result: Value) -> Wait {
        Wait::Steps {
            until: self.step.saturating_add(self.steps_for(d).max(1)),
            result,
        }
    }

    fn run_step(&mut self) {
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
                Wait::Resume(v) => {
                    self.threads[i].stack.push(v);
                    (true, Wait::None)
                }
                Wait::Steps { until, result } if until <= self.step => {
                    self.threads[i].stack.push(result);
                    (true, Wait::None)
                }
                Wait::Read {
                    socket,
                    spec,
                    call,
                    line,
                } => match self.sockets.handle_timeout(&socket, &spec, self.now()) {
                    Some(v) => {
                        if self.config.trace_socket_calls {
                            self.events.push_back(Event::Call {
                                line,
                                text: format!("{call} -> {} (timeout)", v.to_source()),
                            });
                        }
                        self.threads[i].stack.push(v);
                        (true, Wait::None)
                    }
                    None => (
                        false,
                        Wait::Read {
                            socket,
                            spec,
                            call,
                            line,
                        },
                    ),
                },
                Wait::Join(id) if self.threads.get(id as usize).is_none_or(|t| t.done) => {
                    (true, Wait::None)
                }
                other => (false, other),
            };
            self.threads[i].wait = wait;
            if runnable {
                self.current = i;
                self.budget = 0;
                let placeholder = Thread {
                    name: String::new(),
                    frames: Vec::new(),
                    stack: Vec::new(),
                    wait: Wait::None,
                    done: true,
                    critical: 0,
                };
                let mut th = std::mem::replace(&mut self.threads[i], placeholder);
                let prog = Arc::clone(&self.prog);
                let flow = self.exec(&mut th, &prog);
                self.threads[i] = th;
                match flow {
                    Ok(Flow::Blocked) => {}
                    Ok(Flow::Finished) => {
                        let t = &mut self.threads[i];
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

    fn exec(&mut self, th: &mut Thread, prog: &Program) -> Result<Flow, RuntimeError> {
        let mut line = 0;
        loop {
            let Some(frame) = th.frames.last_mut() else {
                return Ok(Flow::Finished);
            };
            let func = &prog.funcs[frame.func as usize];
            let pc = frame.pc as usize;
            let (Some(&op), Some(&l)) = (func.ops.get(pc), func.lines.get(pc)) else {
                return Err(RuntimeError::new(line, "internal error: code ended"));
            };
            line = l;
            frame.pc += 1;
            let fail = |m: String| RuntimeError::new(line, m);
            match op {
                Op::Stmt => {
                    self.budget += 1;
                    if self.budget > self.config.max_statements_per_step {
                        return Err(fail(format!(
                            "thread `{}` used too much time: {} statements in one step without consuming time (a loop needs `sync()`, `sleep()` or another call that takes time)",
                            th.name, self.config.max_statements_per_step
                        )));
                    }
                }
                Op::Const(c) => th.stack.push(prog.consts[c as usize].clone()),
                Op::Load(s) => {
                    let v = frame
                        .locals
                        .iter()
                        .rev()
                        .find(|(n, _)| *n == s)
                        .and_then(|(_, v)| v.as_ref())
                        .or_else(|| self.globals[s as usize].as_ref());
                    match v {
                        Some(v) => th.stack.push(v.clone()),
                        None => {
                            return Err(fail(format!(
                                "unknown variable `{}`",
                                prog.names[s as usize]
                            )))
                        }
                    }
                }
                Op::Store(s, scope) => {
                    let v = pop(&mut th.stack, line)?;
                    let program_scope = func.program_scope;
                    *self.slot(frame, s, scope, program_scope, true, prog, line)? = Some(v);
                }
                Op::StoreIndex(s, scope, n) => {
                    let v = pop(&mut th.stack, line)?;
                    let j = if n == 2 {
                        Some(pop(&mut th.stack, line)?)
                    } else {
                        None
                    };
                    let i = pop(&mut th.stack, line)?;
                    let program_scope = func.program_scope;
                    let slot = self.slot(frame, s, scope, program_scope, false, prog, line)?;
                    let name = &prog.names[s as usize];
                    let Some(target) = slot.as_mut() else {
                        return Err(fail(format!("unknown variable `{name}`")));
                    };
                    match j {
                        None => store_index(target, &i, v).map_err(fail)?,
                        Some(j) => {
                            let inner = index_mut(target, &i).map_err(fail)?;
                            store_index(inner, &j, v).map_err(fail)?;
                        }
                    }
                }
                Op::LoadIndex(s) => {
                    let i = pop(&mut th.stack, line)?;
                    let base = frame
                        .locals
                        .iter()
                        .rev()
                        .find(|(n, _)| *n == s)
                        .and_then(|(_, v)| v.as_ref())
                        .or_else(|| self.globals[s as usize].as_ref());
                    match base {
                        Some(b) => th.stack.push(index(b, &i).map_err(fail)?),
                        None => {
                            return Err(fail(format!(
                                "unknown variable `{}`",
                                prog.names[s as usize]
                            )))
                        }
                    }
                }
                Op::Index => {
                    let i = pop(&mut th.stack, line)?;
                    let b = pop(&mut th.stack, line)?;
                    th.stack.push(index(&b, &i).map_err(fail)?);
                }
                Op::MakeList(n) => {
                    let at = th.stack.len().saturating_sub(n as usize);
                    let items = th.stack.split_off(at);
                    th.stack.push(Value::List(items));
                }
                Op::MakePose(n) => {
                    let at = th.stack.len().saturating_sub(n as usize);
                    let items = th.stack.split_off(at);
                    let mut p = [0.0; 6];
                    for (k, (slot, v)) in p.iter_mut().zip(&items).enumerate() {
                        *slot = v.as_f64().ok_or_else(|| {
                            fail(format!(
                                "type error: pose element {k} must be a number, got {}",
                                v.type_name()
                            ))
                        })?;
                    }
                    th.stack.push(Value::Pose(p));
                }
                Op::Neg => {
                    let v = pop(&mut th.stack, line)?;
                    th.stack.push(match v {
                        Value::Int(i) => Value::Int(i.wrapping_neg()),
                        Value::Float(f) => Value::Float(-f),
                        Value::Pose(p) => Value::Pose(p.map(|x| -x)),
                        other => {
                            return Err(fail(format!(
                                "type error: cannot negate a {}",
                                other.type_name()
                            )))
                        }
                    });
                }
                Op::Not => {
                    let v = pop(&mut th.stack, line)?;
                    let b = as_bool(&v, "not").map_err(fail)?;
                    th.stack.push(Value::Bool(!b));
                }
                Op::Bin(op) => {
                    let r = pop(&mut th.stack, line)?;
                    let l = pop(&mut th.stack, line)?;
                    th.stack.push(binary(op, l, r).map_err(fail)?);
                }
                Op::Jump(t) => frame.pc = t,
                Op::JumpIfFalse(t) => {
                    let v = pop(&mut th.stack, line)?;
                    if !as_bool(&v, "condition").map_err(fail)? {
                        frame.pc = t;
                    }
                }
                Op::JumpIfFalseKeep(t) | Op::JumpIfTrueKeep(t) => {
                    let want = matches!(op, Op::JumpIfTrueKeep(_));
                    let v = th.stack.last().cloned().unwrap_or(Value::None);
                    let what = if want { "or" } else { "and" };
                    if as_bool(&v, what).map_err(fail)? == want {
                        frame.pc = t;
                    } else {
                        th.stack.pop();
                    }
                }
                Op::CheckBool => {
                    let v = th.stack.last().cloned().unwrap_or(Value::None);
                    as_bool(&v, "and/or").map_err(fail)?;
                }
                Op::Call(fid, argc, kw) => {
                    let args = th
                        .stack
                        .split_off(th.stack.len().saturating_sub(argc as usize));
                    let callee = &prog.funcs[fid as usize];
                    let locals = bind_user(prog, callee, args, kw).map_err(fail)?;
                    if th.frames.len() >= 256 {
                        return Err(fail(format!(
                            "calls nested too deeply (256) calling `{}`",
                            callee.name
                        )));
                    }
                    let base = th.stack.len();
                    th.frames.push(Frame {
                        func: fid,
                        pc: 0,
                        locals,
                        base,
                    });
                }
                Op::Native(s, argc, kw) => {
                    let args = th
                        .stack
                        .split_off(th.stack.len().saturating_sub(argc as usize));
                    let name = prog.names[s as usize].as_str();
                    let kwargs: Vec<(&str, Value)> = if kw == NO_KW {
                        Vec::new()
                    } else {
                        let names = &prog.kwnames[kw as usize];
                        let split = args.len().saturating_sub(names.len());
                        let mut args = args;
                        let kwv = args.split_off(split);
                        let out: Vec<(&str, Value)> = names
                            .iter()
                            .map(|n| prog.names[*n as usize].as_str())
                            .zip(kwv)
                            .collect();
                        let r = self.call_native(name, args, out, line).map_err(fail)?;
                        match r {
                            NativeOut::Value(v) => th.stack.push(v),
                            NativeOut::Block(w) => {
                                th.wait = w;
                                return Ok(Flow::Blocked);
                            }
                        }
                        continue;
                    };
                    match self.call_native(name, args, kwargs, line).map_err(fail)? {
                        NativeOut::Value(v) => th.stack.push(v),
                        NativeOut::Block(w) => {
                            th.wait = w;
                            return Ok(Flow::Blocked);
                        }
                    }
                }
                Op::Return | Op::ReturnNone => {
                    let v = if matches!(op, Op::Return) {
                        pop(&mut th.stack, line)?
                    } else {
                        Value::None
                    };
                    let base = frame.base;
                    th.frames.pop();
                    th.stack.truncate(base);
                    if th.frames.is_empty() {
                        return Ok(Flow::Finished);
                    }
                    th.stack.push(v);
                }
                Op::Pop => {
                    th.stack.pop();
                }
                Op::Halt => return Ok(Flow::Halt),
                Op::Run(fid) => {
                    let live = self.threads.iter().filter(|t| !t.done).count();
                    if live >= MAX_THREADS {
                        return Err(fail(format!(
                            "`run {}()`: more than {MAX_THREADS} threads running",
                            prog.funcs[fid as usize].name
                        )));
                    }
                    // Finished threads keep their slot: handles stay unique.
                    let id = self.threads.len() as u32;
                    self.threads.push(Thread {
                        name: prog.funcs[fid as usize].name.clone(),
                        frames: vec![Frame {
                            func: fid,
                            pc: 0,
                            locals: Vec::new(),
                            base: 0,
                        }],
                        stack: Vec::new(),
                        wait: Wait::None,
                        done: false,
                        critical: 0,
                    });
                    th.stack.push(Value::Thread(id));
                }
                Op::Join => {
                    let v = pop(&mut th.stack, line)?;
                    if let Value::Thread(id) = v {
                        if id as usize == self.current {
                            return Err(fail("a thread cannot join itself".into()));
                        }
                        if self.threads.get(id as usize).is_some_and(|t| !t.done) {
                            th.wait = Wait::Join(id);
                            // Resume without a value: `join` is a statement.
                            return Ok(Flow::Blocked);
                        }
                    }
                }
                Op::Kill => {
                    let v = pop(&mut th.stack, line)?;
                    if let Value::Thread(id) = v {
                        if id as usize == self.current {
                            return Ok(Flow::Finished);
                        }
                        if let Some(t) = self.threads.get_mut(id as usize) {
                            t.done = true;
                            t.frames = Vec::new();
                            t.stack = Vec::new();
                            // A read it was waiting for ends with it.
                            if let Wait::Read { socket, .. } =
                                std::mem::replace(&mut t.wait, Wait::None)
                            {
                                self.sockets.give_up(&socket);
                            }
                        }
                    }
                }
                Op::EnterCritical => th.critical = th.critical.saturating_add(1),
                Op::ExitCritical => th.critical = th.critical.saturating_sub(1),
            }
        }
    }

    /// The variable `s` an assignment writes: a local of the frame, or a global.
    #[allow(clippy::too_many_arguments)]
    fn slot<'a>(
        &'a mut self,
        frame: &'a mut Frame,
        s: Sym,
        scope: Scope,
        program_scope: bool,
        create: bool,
        prog: &Program,
        line: u32,
    ) -> Result<&'a mut Option<Value>, RuntimeError> {
        let local_at = frame.locals.iter().rposition(|(n, _)| *n == s);
        let global = match scope {
            Scope::Global => true,
            Scope::Local => false,
            Scope::Auto => {
                local_at.is_none() && (program_scope || self.globals[s as usize].is_some())
            }
        };
        if global {
            return Ok(&mut self.globals[s as usize]);
        }
        let at = match local_at {
            Some(i) => i,
            None if create => {
                frame.locals.push((s, None));
                frame.locals.len() - 1
            }
            None => {
                return Err(RuntimeError::new(
                    line,
                    format!("unknown variable `{}`", prog.names[s as usize]),
                ))
            }
        };
        Ok(&mut frame.locals[at].1)
    }
}

fn pop(stack: &mut Vec<Value>, line: u32) -> Result<Value, RuntimeError> {
    stack
        .pop()
        .ok_or_else(|| RuntimeError::new(line, "internal error: stack empty"))
}

/// A condition's truth: a bool, or a number (non-zero is true: UR's own External Control
/// script tests a float, `if has_qnear:`). Anything else is a type error.
fn as_bool(v: &Value, what: &str) -> Result<bool, String> {
    match v {
        Value::Bool(b) => Ok(*b),
        Value::Int(i) => Ok(*i != 0),
        Value::Float(f) => Ok(*f != 0.0),
        other => Err(format!(
            "type error: `{what}` needs a bool, got {} {}",
            other.type_name(),
            other.to_source()
        )),
    }
}

fn index_of(i: &Value, len: usize) -> Result<usize, String> {
    let Value::Int(k) = i else {
        return Err(format!(
            "type error: an index must be an int, got {} {}",
            i.type_name(),
            i.to_source()
        ));
    };
    usize::try_from(*k)
        .ok()
        .filter(|k| *k < len)
        .ok_or_else(|| format!("index out of range: index {k}, length {len}"))
}

fn index(b: &Value, i: &Value) -> Result<Value, String> {
    match b {
        Value::List(items) => Ok(items[index_of(i, items.len())?].clone()),
        Value::Pose(p) => Ok(Value::Float(p[index_of(i, 6)?])),
        other => Err(format!("type error: cannot index a {}", other.type_name())),
    }
}

fn index_mut<'a>(b: &'a mut Value, i: &Value) -> Result<&'a mut Value, String> {
    match b {
        Value::List(items) => {
            let k = index_of(i, items.len())?;
            Ok(&mut items[k])
        }
        other => Err(format!(
            "type error: cannot assign into an element of a {}",
            other.type_name()
        )),
    }
}

fn store_index(b: &mut Value, i: &Value, v: Value) -> Result<(), String> {
    match b {
        Value::List(items) => {
            let k = index_of(i, items.len())?;
            items[k] = v;
            Ok(())
        }
        Value::Pose(p) => {
            let k = index_of(i, 6)?;
            p[k] = v.as_f64().ok_or_else(|| {
                format!(
                    "type error: a pose element must be a number, got {}",
                    v.type_name()
                )
            })?;
            Ok(())
        }
        other => Err(format!(
            "type error: cannot assign into an element of a {}",
            other.type_name()
        )),
    }
}

/// The binary operators. Ints: 32-bit, wrapping on overflow; `/` of two ints is a float
/// division, `%` of two ints the truncating remainder; both fail on an int 0. A float on
/// either side makes the result a float. Poses add and subtract element-wise; lists of
/// numbers add, subtract, multiply and divide element-wise with a list of the same length
/// or a number (`q + qd * steptime`, `[...] / MULT`, as UR's driver scripts do).
pub(crate) fn binary(op: BinOp, l: Value, r: Value) -> Result<Value, String> {
    use Value::{Bool, Float, Int, List, Pose};
    let type_err = |l: &Value, r: &Value, sym: &str| {
        Err(format!(
            "type error: {} {sym} {} ({} {sym} {})",
            l.type_name(),
            r.type_name(),
            l.to_source(),
            r.to_source()
        ))
    };
    let sym = match op {
        BinOp::Or => "or",
        BinOp::Xor => "xor",
        BinOp::And => "and",
        BinOp::Eq => "==",
        BinOp::Ne => "!=",
        BinOp::Lt => "<",
        BinOp::Le => "<=",
        BinOp::Gt => ">",
        BinOp::Ge => ">=",
        BinOp::Add => "+",
        BinOp::Sub => "-",
        BinOp::Mul => "*",
        BinOp::Div => "/",
        BinOp::Rem => "%",
    };
    match op {
        BinOp::Eq => return Ok(Bool(l == r)),
        BinOp::Ne => return Ok(Bool(l != r)),
        BinOp::Or | BinOp::Xor | BinOp::And => {
            return match (&l, &r) {
                (Bool(a), Bool(b)) => Ok(Bool(match op {
                    BinOp::Or => *a || *b,
                    BinOp::And => *a && *b,
                    _ => a != b,
                })),
                _ => type_err(&l, &r, sym),
            }
        }
        BinOp::Lt | BinOp::Le | BinOp::Gt | BinOp::Ge => {
            let (Some(a), Some(b)) = (l.as_f64(), r.as_f64()) else {
                return type_err(&l, &r, sym);
            };
            return Ok(Bool(match op {
                BinOp::Lt => a < b,
                BinOp::Le => a <= b,
                BinOp::Gt => a > b,
                _ => a >= b,
            }));
        }
        _ => {}
    }
    match (&l, &r) {
        (Int(a), Int(b)) => Ok(Int(match op {
            BinOp::Add => a.wrapping_add(*b),
            BinOp::Sub => a.wrapping_sub(*b),
            BinOp::Mul => a.wrapping_mul(*b),
            BinOp::Div | BinOp::Rem if *b == 0 => {
                return Err(format!("division by zero ({a} {sym} 0)"))
            }
            // As UR's own driver scripts rely on (`params[1] / MULT_jointstate`, two
            // ints): `/` of two ints is a float.
            BinOp::Div => return Ok(Float(f64::from(*a) / f64::from(*b))),
            _ => a.wrapping_rem(*b),
        })),
        (List(a), List(b)) if matches!(op, BinOp::Add | BinOp::Sub | BinOp::Mul | BinOp::Div) => {
            if a.len() != b.len() {
                return Err(format!(
                    "lists of different lengths: {} {sym} {}",
                    l.to_source(),
                    r.to_source()
                ));
            }
            let items: Result<Vec<Value>, String> = a
                .iter()
                .zip(b)
                .map(|(x, y)| binary(op, x.clone(), y.clone()))
                .collect();
            Ok(List(items?))
        }
        (List(a), s)
            if s.as_f64().is_some()
                && matches!(op, BinOp::Add | BinOp::Sub | BinOp::Mul | BinOp::Div) =>
        {
            let items: Result<Vec<Value>, String> =
                a.iter().map(|x| binary(op, x.clone(), s.clone())).collect();
            Ok(List(items?))
        }
        (s, List(b))
            if s.as_f64().is_some() && matches!(op, BinOp::Add | BinOp::Sub | BinOp::Mul) =>
        {
            let items: Result<Vec<Value>, String> =
                b.iter().map(|x| binary(op, s.clone(), x.clone())).collect();
            Ok(List(items?))
        }
        (Pose(a), Pose(b)) if matches!(op, BinOp::Add | BinOp::Sub) => {
            let mut p = *a;
            for (x, y) in p.iter_mut().zip(b) {
                *x = if op == BinOp::Add { *x + y } else { *x - y };
            }
            Ok(Pose(p))
        }
        _ => {
            let (Some(a), Some(b)) = (l.as_f64(), r.as_f64()) else {
                return type_err(&l, &r, sym);
            };
            Ok(Float(match op {
                BinOp::Add => a + b,
                BinOp::Sub => a - b,
                BinOp::Mul => a * b,
                BinOp::Div => a / b,
                _ => a % b,
            }))
        }
    }
}

/// Binds a user function's arguments: positional first, then named, then defaults.
fn bind_user(
    prog: &Program,
    callee: &crate::compile::Func,
    mut args: Vec<Value>,
    kw: u32,
) -> Result<Vec<(Sym, Option<Value>)>, String> {
    let names: &[Sym] = if kw == NO_KW {
        &[]
    } else {
        &prog.kwnames[kw as usize]
    };
    let kwv = args.split_off(args.len().saturating_sub(names.len()));
    if args.len() > callee.params.len() {
        return Err(format!(
            "`{}` takes {} arguments, {} given",
            callee.name,
            callee.params.len(),
            args.len()
        ));
    }
    let mut slots: Vec<Option<Value>> = vec![None; callee.params.len()];
    for (slot, v) in slots.iter_mut().zip(args) {
        *slot = Some(v);
    }
    for (n, v) in names.iter().zip(kwv) {
        let Some(k) = callee.params.iter().position(|(p, _)| p == n) else {
            return Err(format!(
                "`{}` has no parameter `{}`",
                callee.name, prog.names[*n as usize]
            ));
        };
        if slots[k].is_some() {
            return Err(format!(
                "argument `{}` of `{}` given twice",
                prog.names[*n as usize], callee.name
            ));
        }
        slots[k] = Some(v);
    }
    let mut out = Vec::with_capacity(slots.len());
    for ((p, default), v) in callee.params.iter().zip(slots) {
        match v.or_else(|| default.clone()) {
            Some(v) => out.push((*p, Some(v))),
            None => {
                return Err(format!(
                    "`{}` needs argument `{}`",
                    callee.name, prog.names[*p as usize]
                ))
            }
        }
    }
    Ok(out)
}
