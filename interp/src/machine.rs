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
//! an XML-RPC call `handle.name(...)` (until its reply is complete, at most 10 s), `join`
//! of a thread that still runs. This is the manual's "Thread scheduling": 2 ms
//! frames, each runnable thread scheduled round robin, a thread that has used its frame
//! waits for the next. A thread that computes without consuming time (a loop without
//! `sync()`) uses its slice up after [`Config::max_statements_per_step`] statements and
//! waits for the next step, where it goes on: the manual's "computational heavy
//! instructions (such as an infinite loop that do not control the robot)" that place a
//! thread "in a non-runnable state" until the next frame. (The manual adds that such a
//! loop may raise "Lost communication with Controller" on the arm; that depends on the
//! controller's load and is not modelled.)
//!
//! Threads only switch where time is consumed or a slice is used up, so `enter_critical`/`exit_critical` never
//! needs to hold the others back: a thread inside a critical section already runs alone
//! until it consumes time, and when it does (as UR's External Control program does inside
//! one) the others run, as on the controller.
//!
//! ## Memory
//! The program's memory is one budget, [`Config::max_memory`] (256 MiB by default),
//! counted in bytes as the program allocates: each value where it sits (a stack slot or
//! a list element: the size of a [`Value`], 56 bytes on 64-bit targets) plus what it
//! owns (list elements, string bytes, struct members, at every depth); each local
//! variable's entry; each call frame; each thread; and the events the driver has not
//! taken yet (bytes to send, messages and call records, with their copies of values).
//! A value is counted before it is made or copied (a list copied on assignment, a
//! `make_list`, list arithmetic and matrix products by an upper bound of their result,
//! the copies a built-in's call record and message keep), so no single step allocates
//! far past the budget; drops are credited where they happen. When a charge would pass
//! the budget the machine recounts what the program holds (the count never errs low)
//! and, if the recount confirms it, stops the program with a
//! [`Limit`](crate::RuntimeErrorKind::Limit) runtime error at that line:
//! `memory budget exceeded: the program holds N bytes and needs M more, over its budget
//! of B bytes (...)`. The counts are of contents, not of the allocator's overhead or a
//! vector's spare capacity: the process's own use is higher by a small factor.
//! Separately bounded and not counted: the robot model's receive buffers (64 KiB per
//! socket, 64 sockets), an XML-RPC reply being read (1 MiB), the interpreter-mode queue
//! ([`interpreter::MAX_UNEXECUTED`](crate::interpreter::MAX_UNEXECUTED) lines of at most
//! [`interpreter::MAX_LINE`](crate::interpreter::MAX_LINE) bytes), and the program's
//! code.
//!
//! ## Driving it
//! Call [`Machine::run_until`] with the time since the program started; it runs every
//! step due. Take the [`Event`]s with [`Machine::poll_event`]: connections to open, bytes
//! to send, messages. Report connections ([`Machine::handle_connected`]), received bytes
//! ([`Machine::handle_received`]) and closed peers. [`Machine::poll_timeout`] says when
//! the machine next has something to do (`None`: only an input can wake it).

use std::sync::Arc;
use std::time::Duration;

use urscript_socket::robot::ReadCall;

use crate::builtins::{Args, Out};
use crate::compile::{CallSite, Op, PathStep, Program, Sym};
use crate::controller::{Arm, Controller};
use crate::error::{Fault, RuntimeError, RuntimeErrorKind as K};
pub use crate::event::Event;
use crate::event::{CallRecord, Outcome, ReadRecord, MAX_READ_INPUT};
use crate::memory::{ENTRY_BYTES, FRAME_BYTES, SLOT_BYTES, THREAD_BYTES};
use crate::parser::{BinOp, Scope};
use crate::sockets::{Policy, Sockets};
use crate::value::{Value, MAX_VALUE_DEPTH, MEMBER_BYTES, VALUE_BYTES};

/// How many copies of a built-in's arguments (their content) must fit in the memory
/// budget before it runs: a call record's copy, a message's copy, and the message's
/// text (at most about the content's size: a list element writes as fewer than
/// [`VALUE_BYTES`](crate::value::VALUE_BYTES) characters).
const NATIVE_COPIES: usize = 3;

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
    /// The arm: its kinematics place the tool (UR5e by default; [`Config::cb3`]: UR5).
    pub model: crate::kinematics::Model,
    /// The socket reads' choices where UR's manuals are silent.
    pub policy: Policy,
    /// Functions replaced by stubs, by name. A stub wins over a built-in of that name,
    /// but not over a function the program defines.
    pub stubs: Vec<(String, Stub)>,
    /// A thread's time slice in statements: after this many in one step without
    /// consuming time it waits for the next step, where it goes on (default 10 000, a
    /// fraction of a millisecond of this interpreter's time, so one busy thread never
    /// holds the 2 ms step up).
    pub max_statements_per_step: u32,
    /// Emit an [`Event::Call`] for every socket call (default true). Off, the machine
    /// does not record the calls at all.
    pub trace_socket_calls: bool,
    /// Emit an [`Event::Call`] for every built-in call, not only socket calls.
    pub trace_all_calls: bool,
    /// The largest value the program may build (default 1 000 000): list elements at
    /// every depth, plus string bytes. A list made (`[...]`, list arithmetic, an element
    /// assigned, a built-in's or stub's result) over it stops the program with a
    /// [`Limit`](crate::RuntimeErrorKind::Limit) error, so a program that doubles a list
    /// in a loop fails instead of taking all memory.
    pub max_value_size: usize,
    /// The program's memory budget in bytes (default 256 MiB): everything it holds at
    /// once, counted as it allocates: the values of every variable of every frame of
    /// every thread and the globals, the temporaries being built, call frames, threads,
    /// and the events not yet taken by the driver (bytes to send, messages, call
    /// records). A step that would pass it stops the program with a
    /// [`Limit`](crate::RuntimeErrorKind::Limit) error naming the budget and the bytes,
    /// before it allocates. Each value, call depth and thread count has its own bound;
    /// this one bounds them together (64 threads 256 calls deep, each frame holding a
    /// list of [`max_value_size`](Self::max_value_size) elements, would be nearly a
    /// terabyte).
    /// See the [`machine`](crate::machine) module's "Memory" for what is counted and how.
    pub max_memory: usize,
}

impl Default for Config {
    fn default() -> Self {
        Config {
            step_time: Duration::from_millis(2),
            model: crate::kinematics::Model::Ur5e,
            policy: Policy::default(),
            stubs: Vec::new(),
            max_statements_per_step: 10_000,
            trace_socket_calls: true,
            trace_all_calls: false,
            max_value_size: crate::value::DEFAULT_MAX_VALUE_SIZE,
            max_memory: crate::memory::DEFAULT_MAX_MEMORY,
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
            model: crate::kinematics::Model::Ur5,
            ..Config::default()
        }
    }

    /// Adds a stub for `name`.
    pub fn stub(mut self, name: &str, stub: Stub) -> Self {
        self.stubs.push((name.to_string(), stub));
        self
    }
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
    /// Waits on a motion: resumes at the first step from `after` whose motion clock has
    /// reached `until`, with `result` as the value of the call.
    Motion {
        until: f64,
        after: u64,
        result: Value,
    },
    /// Used its time slice computing: resumes at step `until` (the next frame), where
    /// it left off.
    Slice(u64),
    /// Resumes at the next step with this value (a read completed by received bytes).
    Resume(Value),
    /// A socket read waiting for bytes, with its call's record and what the read has
    /// seen so far (when traced).
    Read {
        socket: String,
        call: ReadCall,
        record: Option<Box<CallRecord>>,
        input: Vec<u8>,
        buffered_at_start: usize,
    },
    /// `socket_open` waiting for the driver.
    Connect {
        socket: String,
        record: Option<Box<CallRecord>>,
    },
    /// `join` of a running thread.
    Join(u32),
    /// An XML-RPC call (`handle.name(...)`) connecting or waiting for its reply.
    Rpc(Box<crate::rpc::Pending>),
    /// The call it waited for failed: the program stops with this error.
    Failed(Box<RuntimeError>),
    /// The main thread in `interpreter_mode()`, between interpreted statements.
    Interpreter,
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
    /// The handle `run` gave (0: the program itself): unique for the machine's life,
    /// never reused, though the thread's slot is once it has finished.
    id: u32,
    frames: Vec<Frame>,
    stack: Vec<Value>,
    wait: Wait,
    done: bool,
    critical: u32,
}

/// What a built-in call did to its thread.
enum Called {
    /// It returned this value.
    Value(Value),
    /// The thread waits.
    Block(Wait),
}

enum Flow {
    Blocked,
    Finished,
    Halt,
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
/// assert!(matches!(m.poll_event(), Some(Event::Message(msg)) if msg.text == "done 3"));
/// ```
#[derive(Debug)]
pub struct Machine {
    pub(crate) prog: Arc<Program>,
    pub(crate) config: Config,
    globals: Vec<Option<Value>>,
    threads: Vec<Thread>,
    /// The controller's state: the arm, the sockets, the step to run next, events.
    ctl: Controller,
    /// For each call site, the stub that answers it (by index in `config.stubs`).
    site_stubs: Vec<Option<u32>>,
    state: State,
    /// Statements run by the current thread in this step.
    budget: u32,
    /// The thread running now.
    pub(crate) current: usize,
    /// The handle the next `run` gives.
    next_thread_id: u32,
    /// Interpreter mode: the queue of interpreted statements and its numbers.
    interp: crate::interpreter::Interpreter,
}

impl Machine {
    /// A machine about to run `program`'s first step at time 0.
    ///
    /// A step time below 100 µs is raised to 100 µs. As on the controller, a program that
    /// calls a function neither defined, built in nor stubbed, or reads a variable that
    /// nothing in its scope can have assigned, does not start: its state is already
    /// [`State::Error`], `compile_error_name_not_found:NAME:` at the first such name.
    ///
    /// ```
    /// use urscript_interp::{Config, Machine, Program, State};
    /// let m = Machine::new(Program::parse("x = 1\ntextmsg(x + y)\n").unwrap(), Config::default());
    /// let State::Error(e) = m.state() else { panic!() };
    /// assert_eq!((e.line(), e.column()), (2, 13));
    /// assert!(e.message().starts_with("compile_error_name_not_found:y:"));
    /// ```
    pub fn new(program: Program, config: Config) -> Self {
        Machine::with_arm(program, config, Arm::default())
    }

    /// A machine about to run `program` on an arm that already has a state: the joints,
    /// outputs, registers, payload and world a previous program left
    /// ([`Machine::into_arm`]), as a controller runs one program after another.
    ///
    /// ```
    /// use std::time::Duration;
    /// use urscript_interp::{Config, Machine, Program};
    /// let first = Program::parse("write_output_integer_register(3, 42)\n").unwrap();
    /// let mut m = Machine::new(first, Config::default());
    /// m.run_until(Duration::ZERO);
    /// let arm = m.into_arm();
    /// assert_eq!(arm.int_regs[3], 42);
    /// let second = Program::parse("x = read_output_integer_register(3)\n").unwrap();
    /// let mut m = Machine::with_arm(second, Config::default(), arm);
    /// m.run_until(Duration::ZERO);
    /// assert_eq!(m.global("x"), Some(&urscript_interp::Value::Int(42)));
    /// ```
    pub fn with_arm(program: Program, mut config: Config, arm: Arm) -> Self {
        config.step_time = config.step_time.max(Duration::from_micros(100));
        let globals = vec![None; program.names.len()];
        let main = Thread {
            id: 0,
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
        // A stub wins over a built-in, not over a function the program defines.
        let site_stubs: Vec<Option<u32>> = program
            .sites
            .iter()
            .map(|site| {
                let name = &program.names[site.name as usize];
                config
                    .stubs
                    .iter()
                    .position(|(n, _)| n == name)
                    .map(|i| i as u32)
            })
            .collect();
        // As on the controller, a name that is neither defined, built in nor stubbed is a
        // compile error: the program does not start.
        let unknown = program
            .sites
            .iter()
            .zip(&site_stubs)
            .find(|(site, stub)| !site.user && site.builtin.is_none() && stub.is_none())
            .map(|(site, _)| {
                let name = &program.names[site.name as usize];
                let hint = suggestion(name, &program);
                RuntimeError::at(
                    site.at.line,
                    site.at.col,
                    Fault::new(
                        K::UnknownFunction,
                        format!(
                            "compile_error_name_not_found:{name}: `{name}` is neither defined in the program nor a built-in of the controller{hint} (a URCap's function? stub it)"
                        ),
                    ),
                )
            });
        // A variable read that nothing can have given a value is the same compile error;
        // the controller names the first one in the text.
        let unknown_variable = program.unknown_variable.as_ref().map(|(name, at)| {
            let hint = suggestion(name, &program);
            RuntimeError::at(
                at.line,
                at.col,
                Fault::new(
                    K::UnknownVariable,
                    format!(
                        "compile_error_name_not_found:{name}: `{name}` is never assigned in its scope (not a global the program assigns, not a parameter or variable of its function){hint}"
                    ),
                ),
            )
        });
        let unknown = match (unknown, unknown_variable) {
            (Some(f), Some(v)) => Some(if (v.line(), v.column()) < (f.line(), f.column()) {
                v
            } else {
                f
            }),
            (f, v) => f.or(v),
        };
        let main_bytes = thread_bytes(&main);
        let mut m = Machine {
            ctl: Controller {
                dh: config.model.dh(),
                step_time: config.step_time,
                step: 0,
                arm,
                sockets: Sockets::new(config.policy),
                events: crate::memory::Events::default(),
                mem: crate::memory::Memory::new(config.max_memory),
                motion: None,
                thread: 0,
                sampled: None,
                eip: crate::eip::Handles::default(),
                rtde_watchdogs: Vec::new(),
                tracked: None,
                queued: None,
                clock: crate::controller::MotionClock::default(),
                contact_since: None,
                joint_history: Default::default(),
            },
            site_stubs,
            prog: Arc::new(program),
            config,
            globals,
            threads: vec![main],
            state: match unknown {
                Some(e) => State::Error(e),
                None => State::Running,
            },
            budget: 0,
            current: 0,
            next_thread_id: 1,
            interp: crate::interpreter::Interpreter::default(),
        };
        m.ctl.mem.add(main_bytes);
        m
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

    /// The length of one step ([`Config::step_time`], at least 100 µs).
    pub fn step_time(&self) -> Duration {
        self.config.step_time
    }

    /// The virtual time of the next step to run.
    pub fn now(&self) -> Duration {
        self.step_time_at(self.ctl.step)
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
        self.ctl.events.pop_front()
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

    /// The arm's joint positions now (mid-move: where the motion has the arm at the last
    /// step run).
    pub fn joint_positions(&self) -> [f64; 6] {
        self.ctl.arm.q
    }

    /// What the robot senses of the world (inputs, measurements, the operator's answers).
    pub fn world(&self) -> &crate::controller::World {
        &self.ctl.arm.world
    }

    /// The world, to change what the program will sense: a digital input switching, a
    /// temperature, an RTDE input register.
    pub fn world_mut(&mut self) -> &mut crate::controller::World {
        &mut self.ctl.arm.world
    }

    /// The arm and the I/O around it, as the program has set them so far.
    pub fn arm(&self) -> &Arm {
        &self.ctl.arm
    }

    /// The arm, to change what a client of the controller sets between steps (an RTDE
    /// client writing an output or an input register).
    pub fn arm_mut(&mut self) -> &mut Arm {
        &mut self.ctl.arm
    }

    /// The arm's state, for the next program ([`Machine::with_arm`]).
    pub fn into_arm(self) -> Arm {
        self.ctl.arm
    }

    /// The arm's tool pose now.
    pub fn tcp_pose(&self) -> [f64; 6] {
        self.ctl.tcp_pose()
    }

    /// When the machine next has something to do: the time of the next step if a thread
    /// can run then, or of the first step where a sleep, a motion or a read timeout ends;
    /// `None` if it only waits for inputs (a connection, bytes) or has stopped. A motion
    /// under way needs no wake-up: [`run_until`](Self::run_until) puts the arm where the
    /// motion has it at the last step due, whether or not a thread ran in between.
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

    /// The driver's answer to [`Event::Connect`]: the connection is up, or failed with a
    /// reason (then `socket_open` returns `False` and the program goes on).
    pub fn handle_connected(&mut self, socket_name: &str, result: Result<(), String>) {
        if self.rpc_connected(socket_name, &result) {
            return;
        }
        let ok = result.is_ok();
        if ok {
            self.ctl.sockets.open(socket_name);
        }
        for t in &mut self.threads {
            let Wait::Connect { socket, record } = &mut t.wait else {
                continue;
            };
            if socket != socket_name {
                continue;
            }
            if let Some(mut r) = record.take() {
                r.result = Value::Bool(ok);
                if let Err(why) = &result {
                    r.outcome = Outcome::Failed(why.clone());
                }
                self.ctl.events.push_back(Event::Call(r));
            }
            t.wait = Wait::Resume(Value::Bool(ok));
        }
    }

    /// Bytes the server sent on `socket_name`. Returns how many the socket's receive
    /// buffer accepted (the rest must be offered again later, as a full TCP window would).
    pub fn handle_received(&mut self, socket_name: &str, bytes: &[u8]) -> usize {
        if self.rpc_event(socket_name, Some(bytes)) {
            return bytes.len();
        }
        let n = self.ctl.sockets.receive(socket_name, bytes);
        // A recorded read waiting on the socket sees what arrived.
        for t in &mut self.threads {
            if let Wait::Read {
                socket,
                record: Some(_),
                input,
                ..
            } = &mut t.wait
            {
                if socket == socket_name {
                    let room = MAX_READ_INPUT.saturating_sub(input.len());
                    input.extend_from_slice(&bytes[..n.min(room)]);
                }
            }
        }
        self.poll_reads(socket_name);
        n
    }

    /// The server closed `socket_name`: reads waiting on it end with their sentinels.
    pub fn handle_peer_closed(&mut self, socket_name: &str) {
        if self.rpc_event(socket_name, None) {
            return;
        }
        self.ctl.sockets.peer_closed(socket_name);
        self.poll_reads(socket_name);
    }

    /// Writing to `socket_name` failed (the peer is gone): later `socket_send_*` calls
    /// on it return `False`, and reads waiting on it end with their sentinels.
    pub fn handle_send_failed(&mut self, socket_name: &str) {
        self.ctl.sockets.send_failed(socket_name);
        self.handle_peer_closed(socket_name);
    }

    /// The connection of an XML-RPC call is up (its request goes out) or failed (the
    /// call fails). False if no call waits for `socket_name`.
    fn rpc_connected(&mut self, socket_name: &str, result: &Result<(), String>) -> bool {
        let Some(t) = self
            .threads
            .iter_mut()
            .find(|t| !t.done && matches!(&t.wait, Wait::Rpc(p) if p.socket == socket_name))
        else {
            // A late answer for a call that already ended (timed out, its thread killed)
            // opens nothing; a `socket_open` of such a name still gets its own.
            let connecting = self.threads.iter().any(|t| {
                !t.done && matches!(&t.wait, Wait::Connect { socket, .. } if socket == socket_name)
            });
            return socket_name.starts_with("rpc:") && !connecting;
        };
        let Wait::Rpc(p) = &mut t.wait else {
            return false;
        };
        match result {
            Ok(()) => {
                if let Some(bytes) = p.request.take() {
                    self.ctl.events.push_back(Event::Transmit {
                        socket_name: socket_name.to_string(),
                        bytes,
                    });
                }
            }
            Err(why) => {
                let msg = p.failure(&format!("could not connect: {why}"));
                t.wait = rpc_done(
                    &mut self.ctl.events,
                    p,
                    Err(msg),
                    self.config.max_value_size,
                );
            }
        }
        true
    }

    /// Bytes (`Some`) or the peer's close (`None`) on `socket_name`, for the XML-RPC
    /// call waiting on it: the call ends when its reply is complete, malformed or cut
    /// short. False if no call waits for `socket_name`.
    fn rpc_event(&mut self, socket_name: &str, bytes: Option<&[u8]>) -> bool {
        let Some(t) = self
            .threads
            .iter_mut()
            .find(|t| !t.done && matches!(&t.wait, Wait::Rpc(p) if p.socket == socket_name))
        else {
            return false;
        };
        let Wait::Rpc(p) = &mut t.wait else {
            return false;
        };
        let reply = match bytes {
            Some(b) => p.receive(b),
            None => crate::rpc::reply(&p.reply, true),
        };
        let outcome = match reply {
            crate::rpc::Reply::Incomplete => return true,
            crate::rpc::Reply::Value(v) => Ok(v),
            crate::rpc::Reply::Error(e) => Err(p.failure(&e)),
        };
        t.wait = rpc_done(&mut self.ctl.events, p, outcome, self.config.max_value_size);
        true
    }

    /// Completes a read waiting on `socket_name` if its bytes are there.
    fn poll_reads(&mut self, socket_name: &str) {
        for t in &mut self.threads {
            let Wait::Read {
                socket,
                call,
                record,
                input,
                buffered_at_start,
            } = &mut t.wait
            else {
                continue;
            };
            if socket != socket_name || t.done {
                continue;
            }
            if let Some(r) = self.ctl.sockets.poll(socket_name) {
                let v = crate::sockets::to_value(&r);
                if let Some(mut rec) = record.take() {
                    rec.result = v.clone();
                    rec.read = Some(ReadRecord {
                        call: call.clone(),
                        result: r,
                        input: std::mem::take(input),
                        buffered_at_start: *buffered_at_start,
                    });
                    self.ctl.events.push_back(Event::Call(rec));
                }
                t.wait = Wait::Resume(v);
            }
        }
    }

    /// Names of the sockets open now.
    pub fn open_sockets(&self) -> Vec<String> {
        self.ctl.sockets.open_names()
    }

    /// `target.method(args)`: an XML-RPC call. `Ok(Some(v))` returns at once
    /// (`closeXMLRPCClientConnection()`), `Ok(None)`: the thread waits (its wait is set).
    fn rpc_call(
        &mut self,
        th: &mut Thread,
        target: Value,
        method: &str,
        args: Vec<Value>,
        at: crate::compile::Pos,
    ) -> Result<Option<Value>, RuntimeError> {
        let fail = |f: Fault| RuntimeError::at(at.line, at.col, f);
        let Value::Rpc(url) = target else {
            return Err(fail(Fault::new(
                K::Type,
                format!(
                    "type error: `.{method}(...)` calls a remote procedure on an rpc_factory handle, not on a {}",
                    target.type_name()
                ),
            )));
        };
        // Every call has its own connection (closed when its reply is in), so there is
        // nothing to close.
        if method == "closeXMLRPCClientConnection" && args.is_empty() {
            return Ok(Some(Value::None));
        }
        // The controller's own EtherNet/IP adapter service answers in-process.
        if crate::rpc::parse_url(&url).is_ok_and(|u| crate::eip::is_service(&u)) {
            let connected = self.ctl.arm.world.eip_connected;
            return crate::eip::service_call(&mut self.ctl.arm.eip, connected, method, &args)
                .map(Some)
                .map_err(|e| {
                    fail(Fault::new(
                        K::RemoteCall,
                        format!("XML-RPC call `{method}` to {url}: {e}"),
                    ))
                });
        }
        let socket = crate::rpc::socket_name(&url);
        if self
            .threads
            .iter()
            .any(|t| !t.done && matches!(&t.wait, Wait::Rpc(p) if p.socket == socket))
        {
            return Err(fail(Fault::new(
                K::RemoteCall,
                format!("XML-RPC call `{method}` to {url}: another thread's call to this server is under way"),
            )));
        }
        let parsed = crate::rpc::parse_url(&url).map_err(|e| fail(Fault::from(e)))?;
        let request = crate::rpc::request(&parsed, method, &args).map_err(|e| {
            fail(Fault::type_error(format!(
                "XML-RPC call `{method}` to {url}: {e}"
            )))
        })?;
        let record = (self.config.trace_socket_calls || self.config.trace_all_calls).then(|| {
            Box::new(CallRecord {
                line: at.line,
                column: at.col,
                // `rpc_factory("xmlrpc", "URL").name`: the call as the program could
                // write it, never mistaken for a built-in.
                name: format!("{}.{method}", Value::Rpc(url.clone()).to_source()),
                builtin: None,
                args: args.clone(),
                kwargs: Vec::new(),
                assigned_to: None,
                result: Value::None,
                outcome: Outcome::Returned,
                socket: Some(socket.clone()),
                read: None,
            })
        });
        self.ctl.events.push_back(Event::Connect {
            socket_name: socket.clone(),
            host: parsed.host,
            port: parsed.port,
        });
        let deadline = self
            .ctl
            .step
            .saturating_add(self.steps_for(crate::rpc::TIMEOUT));
        th.wait = Wait::Rpc(Box::new(crate::rpc::Pending {
            socket,
            url,
            method: method.to_string(),
            request: Some(request),
            reply: Vec::new(),
            deadline,
            line: at.line,
            col: at.col,
            record,
        }));
        Ok(None)
    }

    fn stop(&mut self, state: State) {
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
    fn wait_for(&self, d: Duration, result: Value) -> Wait {
        Wait::Steps {
            until: self.ctl.step.saturating_add(self.steps_for(d).max(1)),
            result,
        }
    }

    /// The live thread with handle `id`.
    fn thread(&self, id: u32) -> Option<&Thread> {
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
            Some(crate::controller::WatchdogTrip::Pause) => self.ctl.arm.pause_requested = true,
            Some(crate::controller::WatchdogTrip::Stop(why)) => {
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

    fn exec(&mut self, th: &mut Thread, prog: &Program) -> Result<Flow, RuntimeError> {
        let mut line = 0;
        let mut col;
        loop {
            let Some(frame) = th.frames.last_mut() else {
                return Ok(Flow::Finished);
            };
            let func = &prog.funcs[frame.func as usize];
            let pc = frame.pc as usize;
            let (Some(&op), Some(&at)) = (func.ops.get(pc), func.lines.get(pc)) else {
                return Err(RuntimeError::internal(line, "internal error: code ended"));
            };
            (line, col) = (at.line, at.col);
            frame.pc += 1;
            let fail = |f: Fault| RuntimeError::at(line, col, f);
            match op {
                Op::Stmt => {
                    if self.budget >= self.config.max_statements_per_step {
                        // The time slice is used: this statement runs in the next frame.
                        frame.pc -= 1;
                        th.wait = Wait::Slice(self.ctl.step.saturating_add(1));
                        return Ok(Flow::Blocked);
                    }
                    self.budget += 1;
                }
                Op::Const(c) => {
                    let v = &prog.consts[c as usize];
                    let bytes = if v.is_container() {
                        v.held_bytes()
                    } else {
                        SLOT_BYTES
                    };
                    self.charge(Some(&*th), bytes).map_err(fail)?;
                    th.stack.push(v.clone());
                }
                Op::Load(s) => {
                    let Some(v) = lookup(frame, &self.globals, s) else {
                        return Err(fail(Fault::new(
                            K::UnknownVariable,
                            format!("unknown variable `{}`", prog.names[s as usize]),
                        )));
                    };
                    if !v.is_container() {
                        let v = v.clone();
                        self.charge(Some(&*th), SLOT_BYTES).map_err(fail)?;
                        th.stack.push(v);
                        continue;
                    }
                    // A list, struct or string: the copy is counted before it is made.
                    let bytes = v.held_bytes();
                    self.charge(Some(&*th), bytes).map_err(fail)?;
                    let v = th
                        .frames
                        .last()
                        .and_then(|f| lookup(f, &self.globals, s))
                        .cloned()
                        .unwrap_or(Value::None);
                    th.stack.push(v);
                }
                Op::Store(s, scope) => {
                    let v = pop(&mut th.stack, line)?;
                    let program_scope = func.program_scope;
                    let entries = frame.locals.len();
                    let slot = self.slot(frame, s, scope, program_scope, true, prog, line)?;
                    let old = slot.replace(v);
                    // The value leaves its stack slot for the variable's; the old value
                    // and a new local's entry change the count.
                    let added = if frame.locals.len() > entries {
                        ENTRY_BYTES
                    } else {
                        0
                    };
                    self.ctl.mem.add(added);
                    self.ctl
                        .mem
                        .credit(SLOT_BYTES + old.as_ref().map_or(0, Value::content_bytes));
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
                    let max_size = self.config.max_value_size;
                    let slot = self.slot(frame, s, scope, program_scope, false, prog, line)?;
                    let name = &prog.names[s as usize];
                    let Some(target) = slot.as_mut() else {
                        return Err(fail(Fault::new(
                            K::UnknownVariable,
                            format!("unknown variable `{name}`"),
                        )));
                    };
                    // A list or string stored into a list may make it deeper or larger.
                    let grows = matches!(v, Value::List(_) | Value::Str(_));
                    // The value takes the element's place; the element (or, into a
                    // pose, the number) is dropped, and so are the indices.
                    let indices = if j.is_some() { 2 } else { 1 };
                    let dropped = match j {
                        None => store_index(target, &i, v).map_err(fail)?,
                        Some(j) => {
                            let inner = index_mut(target, &i).map_err(fail)?;
                            store_index(inner, &j, v).map_err(fail)?
                        }
                    };
                    let mut freed = dropped.held_bytes() + indices * SLOT_BYTES;
                    if grows {
                        if let Err(f) = check_value(target, max_size) {
                            // The variable keeps no value over the bounds.
                            freed = freed.saturating_add(target.content_bytes());
                            *slot = None;
                            self.ctl.mem.credit(freed);
                            return Err(fail(f));
                        }
                    }
                    self.ctl.mem.credit(freed);
                }
                Op::LoadIndex(s) => {
                    let Some(base) = lookup(frame, &self.globals, s) else {
                        return Err(fail(Fault::new(
                            K::UnknownVariable,
                            format!("unknown variable `{}`", prog.names[s as usize]),
                        )));
                    };
                    // The element's copy takes the index's stack slot.
                    let bytes = th.stack.last().map_or(0, |i| element_bytes(base, i));
                    self.charge(Some(&*th), bytes).map_err(fail)?;
                    let i = pop(&mut th.stack, line)?;
                    let base = th.frames.last().and_then(|f| lookup(f, &self.globals, s));
                    let v = base.map(|b| index(b, &i)).unwrap_or(Ok(Value::None));
                    th.stack.push(v.map_err(fail)?);
                }
                Op::Index => {
                    let bytes = match th.stack.as_slice() {
                        [.., b, i] => element_bytes(b, i),
                        _ => 0,
                    };
                    self.charge(Some(&*th), bytes).map_err(fail)?;
                    let i = pop(&mut th.stack, line)?;
                    let b = pop(&mut th.stack, line)?;
                    th.stack.push(index(&b, &i).map_err(fail)?);
                    // The list leaves the stack; the element's copy takes its index's slot.
                    self.ctl.mem.credit(b.held_bytes());
                }
                Op::MakeList(n) => {
                    // The items move into the list: one more stack slot, the list's.
                    self.charge(Some(&*th), SLOT_BYTES).map_err(fail)?;
                    let at = th.stack.len().saturating_sub(n as usize);
                    let items = th.stack.split_off(at);
                    let list = Value::List(items);
                    check_value(&list, self.config.max_value_size).map_err(fail)?;
                    th.stack.push(list);
                }
                Op::MakePose(n) => {
                    let at = th.stack.len().saturating_sub(n as usize);
                    let items = th.stack.split_off(at);
                    // Numbers into a pose: the items' slots but one are free.
                    self.ctl
                        .mem
                        .credit(held_all(&items).saturating_sub(SLOT_BYTES));
                    let mut p = [0.0; 6];
                    for (k, (slot, v)) in p.iter_mut().zip(&items).enumerate() {
                        *slot = v.as_f64().ok_or_else(|| {
                            fail(Fault::new(
                                K::Type,
                                format!(
                                    "type error: pose element {k} must be a number, got {}",
                                    v.type_name()
                                ),
                            ))
                        })?;
                    }
                    th.stack.push(Value::Pose(p));
                }
                Op::MakeStruct(shape) => {
                    let names = prog.shapes.get(shape as usize).map_or(&[][..], |v| v);
                    // The values become members (a name and a larger slot each), and the
                    // struct takes a stack slot.
                    let bytes = names
                        .iter()
                        .map(|n| MEMBER_BYTES - VALUE_BYTES + prog.names[*n as usize].len())
                        .fold(SLOT_BYTES, usize::saturating_add);
                    self.charge(Some(&*th), bytes).map_err(fail)?;
                    let at = th.stack.len().saturating_sub(names.len());
                    let values = th.stack.split_off(at);
                    let members = names
                        .iter()
                        .map(|n| prog.names[*n as usize].clone())
                        .zip(values)
                        .collect();
                    let v = Value::Struct(members);
                    check_value(&v, self.config.max_value_size).map_err(fail)?;
                    th.stack.push(v);
                }
                Op::Member(m) => {
                    let name = &prog.names[m as usize];
                    let bytes = th.stack.last().map_or(0, |v| member_bytes(v, name));
                    self.charge(Some(&*th), SLOT_BYTES + bytes).map_err(fail)?;
                    let v = pop(&mut th.stack, line)?;
                    th.stack.push(member(&v, name).map_err(fail)?);
                    self.ctl.mem.credit(v.held_bytes());
                }
                Op::LoadMember(s, m) => {
                    let name = &prog.names[m as usize];
                    let Some(bytes) =
                        lookup(frame, &self.globals, s).map(|v| member_bytes(v, name))
                    else {
                        return Err(fail(Fault::new(
                            K::UnknownVariable,
                            format!("unknown variable `{}`", prog.names[s as usize]),
                        )));
                    };
                    self.charge(Some(&*th), SLOT_BYTES + bytes).map_err(fail)?;
                    let v = th.frames.last().and_then(|f| lookup(f, &self.globals, s));
                    let v = v.map(|v| member(v, name)).unwrap_or(Ok(Value::None));
                    th.stack.push(v.map_err(fail)?);
                }
                Op::StorePath(s, path) => {
                    let steps = prog.paths.get(path as usize).map_or(&[][..], |v| v);
                    let v = pop(&mut th.stack, line)?;
                    let n = steps
                        .iter()
                        .filter(|p| matches!(p, PathStep::Index))
                        .count();
                    let at = th.stack.len().saturating_sub(n);
                    let indices = th.stack.split_off(at);
                    let program_scope = func.program_scope;
                    let max_size = self.config.max_value_size;
                    let slot =
                        self.slot(frame, s, Scope::Auto, program_scope, false, prog, line)?;
                    let name = &prog.names[s as usize];
                    let Some(target) = slot.as_mut() else {
                        return Err(fail(Fault::new(
                            K::UnknownVariable,
                            format!("unknown variable `{name}`"),
                        )));
                    };
                    // A list, struct or string stored may make the value deeper or
                    // larger; a number or pose cannot.
                    let grows = v.is_container();
                    // The indices leave the stack; the value takes the place of what it
                    // replaces (dropped).
                    let mut freed = held_all(&indices);
                    let dropped = store_path(target, steps, indices, v, prog).map_err(fail)?;
                    freed = freed.saturating_add(dropped.held_bytes());
                    if grows {
                        if let Err(f) = check_value(target, max_size) {
                            // The variable keeps no value over the bounds.
                            freed = freed.saturating_add(target.content_bytes());
                            *slot = None;
                            self.ctl.mem.credit(freed);
                            return Err(fail(f));
                        }
                    }
                    self.ctl.mem.credit(freed);
                }
                Op::Method(id) => {
                    let site = &prog.methods[id as usize];
                    let args = th
                        .stack
                        .split_off(th.stack.len().saturating_sub(usize::from(site.argc)));
                    let target = pop(&mut th.stack, line)?;
                    // The handle and the arguments leave the stack; the result (now,
                    // or when the call resumes) is counted as it comes.
                    let freed = held_all(&args).saturating_add(target.held_bytes());
                    let (target, method) =
                        method_target(target, &prog.names[site.name as usize])
                            .map_err(|f| RuntimeError::at(site.at.line, site.at.col, f))?;
                    if let Value::Eip(id) = target {
                        let v = self
                            .ctl
                            .eip
                            .call(
                                &mut self.ctl.arm.eip,
                                &self.ctl.arm.world.eip_from_plc,
                                id,
                                method,
                                &args,
                                self.ctl.step,
                            )
                            .map_err(|f| RuntimeError::at(site.at.line, site.at.col, f))?;
                        self.ctl.mem.credit(freed);
                        self.charge(Some(&*th), v.held_bytes()).map_err(fail)?;
                        th.stack.push(v);
                        continue;
                    }
                    let called = self.rpc_call(th, target, method, args, site.at)?;
                    self.ctl.mem.credit(freed);
                    match called {
                        Some(v) => {
                            self.charge(Some(&*th), v.held_bytes()).map_err(fail)?;
                            th.stack.push(v)
                        }
                        None => return Ok(Flow::Blocked),
                    }
                }
                Op::Neg => {
                    let v = pop(&mut th.stack, line)?;
                    th.stack.push(match v {
                        Value::Int(i) => Value::Int(i.wrapping_neg()),
                        Value::Float(f) => Value::Float(-f),
                        Value::Pose(p) => Value::Pose(p.map(|x| -x)),
                        other => {
                            return Err(fail(Fault::new(
                                K::Type,
                                format!("type error: cannot negate a {}", other.type_name()),
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
                    // Numbers in, a number out: nothing changes. A list or string
                    // result is bounded before it is made, then counted exactly.
                    if l.is_container() || r.is_container() {
                        th.stack.push(l);
                        th.stack.push(r);
                        let bytes = match th.stack.as_slice() {
                            [.., l, r] => binary_bytes(op, l, r),
                            _ => 0,
                        };
                        self.reserve(Some(&*th), bytes).map_err(fail)?;
                        let r = pop(&mut th.stack, line)?;
                        let l = pop(&mut th.stack, line)?;
                        let freed = l.held_bytes().saturating_add(r.held_bytes());
                        let v = binary(op, l, r).map_err(fail)?;
                        check_value(&v, self.config.max_value_size).map_err(fail)?;
                        self.ctl.mem.credit(freed);
                        self.charge(Some(&*th), v.held_bytes()).map_err(fail)?;
                        th.stack.push(v);
                    } else {
                        let v = binary(op, l, r).map_err(fail)?;
                        self.ctl.mem.credit(SLOT_BYTES);
                        th.stack.push(v);
                    }
                }
                Op::Jump(t) => frame.pc = t,
                Op::JumpIfFalse(t) => {
                    let v = pop(&mut th.stack, line)?;
                    if !as_bool(&v, "condition").map_err(fail)? {
                        frame.pc = t;
                    }
                    self.ctl.mem.credit(SLOT_BYTES);
                }
                Op::JumpIfFalseKeep(t) | Op::JumpIfTrueKeep(t) => {
                    let want = matches!(op, Op::JumpIfTrueKeep(_));
                    let v = th.stack.last().cloned().unwrap_or(Value::None);
                    let what = if want { "or" } else { "and" };
                    if as_bool(&v, what).map_err(fail)? == want {
                        frame.pc = t;
                    } else {
                        th.stack.pop();
                        self.ctl.mem.credit(SLOT_BYTES);
                    }
                }
                Op::CheckBool => {
                    let v = th.stack.last().cloned().unwrap_or(Value::None);
                    as_bool(&v, "and/or").map_err(fail)?;
                }
                Op::Call(fid, site) => {
                    let site = &prog.sites[site as usize];
                    let args = th
                        .stack
                        .split_off(th.stack.len().saturating_sub(usize::from(site.argc)));
                    let callee = &prog.funcs[fid as usize];
                    // The arguments leave the stack for the new frame's locals.
                    let freed = held_all(&args);
                    let locals = bind_user(
                        callee,
                        site,
                        args,
                        &self.globals,
                        &prog.names,
                        self.config.max_value_size,
                    )
                    .map_err(fail)?;
                    if th.frames.len() >= 256 {
                        return Err(fail(Fault::new(
                            K::Limit,
                            format!("calls nested too deeply (256) calling `{}`", callee.name),
                        )));
                    }
                    let frame = Frame {
                        func: fid,
                        pc: 0,
                        locals,
                        base: th.stack.len(),
                    };
                    self.ctl.mem.credit(freed);
                    self.charge(Some(&*th), frame_bytes(&frame)).map_err(fail)?;
                    th.frames.push(frame);
                }
                Op::Native(site) => {
                    let id = site as usize;
                    let site = &prog.sites[id];
                    let args = th
                        .stack
                        .split_off(th.stack.len().saturating_sub(usize::from(site.argc)));
                    let stub = self.site_stubs.get(id).copied().flatten();
                    // The arguments leave the stack; a call record or a message may keep
                    // copies of them and their text while the driver has not taken them.
                    let freed = held_all(&args);
                    let copies = freed.saturating_sub(args.len() * SLOT_BYTES);
                    self.reserve(Some(&*th), copies.saturating_mul(NATIVE_COPIES))
                        .map_err(fail)?;
                    let called = self
                        .call_native(prog, site, stub, args, &*th)
                        .map_err(fail)?;
                    self.ctl.mem.credit(freed);
                    match called {
                        // `powerdown()`: the program ends there, as `halt` ends it.
                        Called::Value(_) if self.ctl.arm.powerdown => return Ok(Flow::Halt),
                        Called::Value(v) => {
                            check_value(&v, self.config.max_value_size).map_err(fail)?;
                            self.charge(Some(&*th), v.held_bytes()).map_err(fail)?;
                            th.stack.push(v)
                        }
                        Called::Block(w) => {
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
                    // A returned value was counted on the stack; `None` is counted when
                    // it is pushed.
                    let returned = if matches!(op, Op::Return) {
                        v.held_bytes()
                    } else {
                        0
                    };
                    let base = frame.base;
                    let popped = th.frames.pop();
                    let left = th.stack.get(base..).map_or(0, held_all);
                    th.stack.truncate(base);
                    self.ctl.mem.credit(left);
                    if th.id == 0 && self.interp.executing == Some(th.frames.len()) {
                        // An interpreted statement ended: back to interpreter mode; the
                        // locals it borrowed go back to the function that called
                        // `interpreter_mode()`.
                        self.interp.executing = None;
                        self.ctl.mem.credit(FRAME_BYTES.saturating_add(returned));
                        if let (Some(p), Some(caller)) = (popped, th.frames.last_mut()) {
                            caller.locals = p.locals;
                        }
                        th.wait = Wait::Interpreter;
                        return Ok(Flow::Blocked);
                    }
                    self.ctl.mem.credit(popped.as_ref().map_or(0, frame_bytes));
                    if th.frames.is_empty() {
                        self.ctl.mem.credit(returned);
                        return Ok(Flow::Finished);
                    }
                    if returned == 0 {
                        self.ctl.mem.add(SLOT_BYTES);
                    }
                    th.stack.push(v);
                }
                Op::Pop => {
                    if let Some(v) = th.stack.pop() {
                        self.ctl.mem.credit(v.held_bytes());
                    }
                }
                Op::Halt => return Ok(Flow::Halt),
                Op::Run(fid) => {
                    let live = self.threads.iter().filter(|t| !t.done).count();
                    if live >= MAX_THREADS {
                        return Err(fail(Fault::new(
                            K::Limit,
                            format!(
                                "`run {}()`: more than {MAX_THREADS} threads running",
                                prog.funcs[fid as usize].name
                            ),
                        )));
                    }
                    // Handles are never reused: one of a finished thread names no other.
                    let id = self.next_thread_id;
                    self.next_thread_id = id.checked_add(1).ok_or_else(|| {
                        fail(Fault::new(K::Limit, "more than 4294967295 threads started"))
                    })?;
                    let new = Thread {
                        id,
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
                    };
                    // The thread and its handle on the stack.
                    self.charge(Some(&*th), thread_bytes(&new).saturating_add(SLOT_BYTES))
                        .map_err(fail)?;
                    self.threads.push(new);
                    th.stack.push(Value::Thread(id));
                }
                Op::Join => {
                    let v = pop(&mut th.stack, line)?;
                    self.ctl.mem.credit(v.held_bytes());
                    if let Value::Thread(id) = v {
                        if id == th.id {
                            return Err(fail(Fault::from("a thread cannot join itself")));
                        }
                        if self.thread(id).is_some() {
                            th.wait = Wait::Join(id);
                            // Resume without a value: `join` is a statement.
                            return Ok(Flow::Blocked);
                        }
                    }
                }
                Op::Kill => {
                    let v = pop(&mut th.stack, line)?;
                    self.ctl.mem.credit(v.held_bytes());
                    if let Value::Thread(id) = v {
                        if id == th.id {
                            return Ok(Flow::Finished);
                        }
                        if let Some(t) = self.threads.iter_mut().find(|t| t.id == id && !t.done) {
                            // The motion it commanded stops where the arm is.
                            if self.ctl.motion.as_ref().is_some_and(|m| m.owner == id) {
                                self.ctl.halt();
                            }
                            self.ctl.mem.credit(thread_bytes(t));
                            t.done = true;
                            t.frames = Vec::new();
                            t.stack = Vec::new();
                            // A read it was waiting for ends with it.
                            match std::mem::replace(&mut t.wait, Wait::None) {
                                Wait::Read { socket, .. } => self.ctl.sockets.give_up(&socket),
                                Wait::Rpc(p) => self.ctl.events.push_back(Event::Close {
                                    socket_name: p.socket,
                                }),
                                _ => {}
                            }
                        }
                    }
                }
                Op::EnterCritical => th.critical = th.critical.saturating_add(1),
                Op::ExitCritical => th.critical = th.critical.saturating_sub(1),
            }
        }
    }

    /// Sets the count to what the program holds now: the globals and every live thread,
    /// with `current` (the thread running, out of the list while it runs).
    fn recount(&mut self, current: Option<&Thread>) {
        let globals = self
            .globals
            .iter()
            .filter_map(Option::as_ref)
            .map(Value::content_bytes)
            .fold(0, usize::saturating_add);
        let threads = self
            .threads
            .iter()
            .filter(|t| !t.done)
            .chain(current)
            .map(thread_bytes)
            .fold(0, usize::saturating_add);
        self.ctl.mem.held = globals.saturating_add(threads);
    }

    /// Counts `bytes` the program is about to allocate, or refuses them (a recount
    /// first, if the count says they do not fit) with the budget's error.
    #[inline]
    fn charge(&mut self, current: Option<&Thread>, bytes: usize) -> Result<(), Fault> {
        if self.ctl.mem.try_add(self.ctl.events.bytes(), bytes) {
            return Ok(());
        }
        self.charge_after_recount(current, bytes)
    }

    /// [`charge`](Self::charge) when the count says the bytes do not fit.
    #[cold]
    #[inline(never)]
    fn charge_after_recount(
        &mut self,
        current: Option<&Thread>,
        bytes: usize,
    ) -> Result<(), Fault> {
        self.reserve(current, bytes)?;
        self.ctl.mem.add(bytes);
        Ok(())
    }

    /// Whether `bytes` more fit in the budget (a recount first, if the count says they
    /// do not), without counting them.
    #[inline]
    fn reserve(&mut self, current: Option<&Thread>, bytes: usize) -> Result<(), Fault> {
        let events = self.ctl.events.bytes();
        if !self.ctl.mem.fits(events, bytes) {
            self.recount(current);
            if !self.ctl.mem.fits(events, bytes) {
                return Err(self.ctl.mem.over(events, bytes));
            }
        }
        Ok(())
    }

    /// The count of the program's memory and a recount of it now, for tests of the
    /// accounting (the count must never be below the recount). Not for drivers.
    #[doc(hidden)]
    pub fn memory_audit(&mut self) -> (usize, usize) {
        let counted = self.ctl.mem.held;
        self.recount(None);
        let recounted = self.ctl.mem.held;
        self.ctl.mem.held = counted;
        (counted, recounted)
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
                return Err(RuntimeError::at(
                    line,
                    1,
                    Fault::new(
                        K::UnknownVariable,
                        format!("unknown variable `{}`", prog.names[s as usize]),
                    ),
                ))
            }
        };
        Ok(&mut frame.locals[at].1)
    }
}

/// The value of variable `s` as a frame reads it: its local, else the global.
fn lookup<'a>(frame: &'a Frame, globals: &'a [Option<Value>], s: Sym) -> Option<&'a Value> {
    frame
        .locals
        .iter()
        .rev()
        .find(|(n, _)| *n == s)
        .and_then(|(_, v)| v.as_ref())
        .or_else(|| globals.get(s as usize).and_then(Option::as_ref))
}

/// The bytes a frame holds: the frame, its locals' entries and their values' content.
fn frame_bytes(f: &Frame) -> usize {
    let values: usize = f
        .locals
        .iter()
        .filter_map(|(_, v)| v.as_ref())
        .map(Value::content_bytes)
        .fold(0, usize::saturating_add);
    FRAME_BYTES
        .saturating_add(f.locals.len().saturating_mul(ENTRY_BYTES))
        .saturating_add(values)
}

/// The bytes values on a stack hold.
fn held_all(values: &[Value]) -> usize {
    values
        .iter()
        .map(Value::held_bytes)
        .fold(0, usize::saturating_add)
}

/// The bytes a thread holds: itself, its name, its frames and its stack.
fn thread_bytes(t: &Thread) -> usize {
    t.frames
        .iter()
        .map(frame_bytes)
        .fold(THREAD_BYTES, usize::saturating_add)
        .saturating_add(held_all(&t.stack))
}

/// The content of the value at `i` in `b` (0 if there is none: indexing fails then).
fn element_bytes(b: &Value, i: &Value) -> usize {
    let Value::Int(k) = i else { return 0 };
    let Ok(k) = usize::try_from(*k) else { return 0 };
    match b {
        Value::List(items) => items.get(k).map_or(0, Value::content_bytes),
        Value::Struct(members) => members.get(k).map_or(0, |(_, v)| v.content_bytes()),
        _ => 0,
    }
}

/// The content of member `name` of `v` (0 if there is none).
fn member_bytes(v: &Value, name: &str) -> usize {
    match v {
        Value::Struct(members) => members
            .iter()
            .find(|(n, _)| n == name)
            .map_or(0, |(_, v)| v.content_bytes()),
        _ => 0,
    }
}

/// An upper bound of the bytes `binary(op, l, r)` allocates for its result, before it
/// runs: a list result has as many elements as its list operand (a matrix product: rows
/// times columns, plus the rows). Numbers, bools and poses make nothing; a string join
/// is at most [`MAX_STRING_LEN`](crate::builtins::MAX_STRING_LEN) bytes.
fn binary_bytes(op: BinOp, l: &Value, r: &Value) -> usize {
    use Value::List;
    match (l, r) {
        (List(a), List(b)) if op == BinOp::Mul && is_matrix(a) => {
            let cols = match b.first() {
                Some(List(row)) => row.len(),
                _ => 1,
            };
            let cells = a.len().saturating_mul(cols.saturating_add(1));
            VALUE_BYTES.saturating_add(cells.saturating_mul(VALUE_BYTES))
        }
        (List(_), _) | (_, List(_)) => {
            VALUE_BYTES.saturating_add(l.content_bytes().max(r.content_bytes()))
        }
        (Value::Str(_), Value::Str(_)) => VALUE_BYTES + crate::builtins::MAX_STRING_LEN,
        _ => VALUE_BYTES,
    }
}

/// A list, struct or string the program built, checked against [`MAX_VALUE_DEPTH`] and
/// [`Config::max_value_size`] (numbers and poses need no check).
fn check_value(v: &Value, max_size: usize) -> Result<(), Fault> {
    if !v.is_container() {
        return Ok(());
    }
    let (depth, size) = v.measure(max_size);
    if depth > MAX_VALUE_DEPTH {
        return Err(Fault::new(
            K::Limit,
            format!("a list or struct nested more than {MAX_VALUE_DEPTH} levels deep"),
        ));
    }
    if size > max_size {
        return Err(Fault::new(
            K::Limit,
            format!(
                "a value of more than {max_size} elements (list elements at every depth, string bytes)"
            ),
        ));
    }
    Ok(())
}

/// The end of an XML-RPC call: its connection closes, its record (if traced) is
/// emitted, and the thread resumes with the value or stops with the error.
fn rpc_done(
    events: &mut crate::memory::Events,
    p: &mut crate::rpc::Pending,
    outcome: Result<Value, String>,
    max_size: usize,
) -> Wait {
    // The reply's value is within the value bounds, as every value the program holds.
    let outcome = outcome.and_then(|v| {
        check_value(&v, max_size)
            .map(|()| v)
            .map_err(|f| p.failure(&f.message))
    });
    events.push_back(Event::Close {
        socket_name: p.socket.clone(),
    });
    if let Some(mut r) = p.record.take() {
        match &outcome {
            Ok(v) => r.result = v.clone(),
            Err(why) => r.outcome = Outcome::Failed(why.clone()),
        }
        events.push_back(Event::Call(r));
    }
    match outcome {
        Ok(v) => Wait::Resume(v),
        Err(msg) => Wait::Failed(Box::new(RuntimeError::at(
            p.line,
            p.col,
            Fault::new(K::RemoteCall, msg),
        ))),
    }
}

/// The value a method call `v.a.b.m(...)` calls on, and the method's name: a struct's
/// members are entered while the name has dots (`s.h.get()` calls `get` on member `h`);
/// what is left is called on whatever comes, so `h.server.getTCP()` on an `rpc_factory`
/// handle calls the XML-RPC method `server.getTCP`.
fn method_target(mut v: Value, mut method: &str) -> Result<(Value, &str), Fault> {
    while let (Value::Struct(_), Some((first, rest))) = (&v, method.split_once('.')) {
        v = member(&v, first)?;
        method = rest;
    }
    Ok((v, method))
}

/// `v.name`: a member of a struct.
fn member(v: &Value, name: &str) -> Result<Value, Fault> {
    match v {
        Value::Struct(members) => members
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v.clone())
            .ok_or_else(|| {
                Fault::new(
                    K::UnknownMember,
                    format!("the struct has no member `{name}`"),
                )
            }),
        other => Err(Fault::new(
            K::Type,
            format!(
                "type error: `.{name}` reads a member of a struct, not of a {}",
                other.type_name()
            ),
        )),
    }
}

/// Assigns `v` at `steps` (members and indices) inside `target`; the value it drops
/// (see [`store_index`]). A struct's members are fixed when it is made: assigning one it
/// does not have is an error, as reading one is.
fn store_path(
    target: &mut Value,
    steps: &[PathStep],
    indices: Vec<Value>,
    v: Value,
    prog: &Program,
) -> Result<Value, Fault> {
    let mut indices = indices.into_iter();
    let mut at = target;
    let Some((last, inner)) = steps.split_last() else {
        return Ok(std::mem::replace(at, v));
    };
    for step in inner {
        at = match step {
            PathStep::Member(m) => member_mut(at, &prog.names[*m as usize])?,
            PathStep::Index => {
                let i = indices.next().unwrap_or(Value::None);
                index_mut(at, &i)?
            }
        };
    }
    match last {
        PathStep::Member(m) => Ok(std::mem::replace(
            member_mut(at, &prog.names[*m as usize])?,
            v,
        )),
        PathStep::Index => {
            let i = indices.next().unwrap_or(Value::None);
            store_index(at, &i, v)
        }
    }
}

fn member_mut<'a>(v: &'a mut Value, name: &str) -> Result<&'a mut Value, Fault> {
    match v {
        Value::Struct(members) => members
            .iter_mut()
            .find(|(n, _)| n == name)
            .map(|(_, v)| v)
            .ok_or_else(|| {
                Fault::new(
                    K::UnknownMember,
                    format!("the struct has no member `{name}`"),
                )
            }),
        other => Err(Fault::new(
            K::Type,
            format!(
                "type error: `.{name} = ...` assigns a member of a struct, not of a {}",
                other.type_name()
            ),
        )),
    }
}

fn pop(stack: &mut Vec<Value>, line: u32) -> Result<Value, RuntimeError> {
    stack
        .pop()
        .ok_or_else(|| RuntimeError::internal(line, "internal error: stack empty"))
}

/// A condition's truth: a bool, or a number (non-zero is true: UR's own External Control
/// script tests a float, `if has_qnear:`). Anything else is a type error.
fn as_bool(v: &Value, what: &str) -> Result<bool, Fault> {
    match v {
        Value::Bool(b) => Ok(*b),
        Value::Int(i) => Ok(*i != 0),
        Value::Float(f) => Ok(*f != 0.0),
        other => Err(Fault::new(
            K::Type,
            format!(
                "type error: `{what}` needs a bool, got {} {}",
                other.type_name(),
                other.to_source()
            ),
        )),
    }
}

fn index_of(i: &Value, len: usize) -> Result<usize, Fault> {
    let Value::Int(k) = i else {
        return Err(Fault::new(
            K::Type,
            format!(
                "type error: an index must be an int, got {} {}",
                i.type_name(),
                i.to_source()
            ),
        ));
    };
    usize::try_from(*k)
        .ok()
        .filter(|k| *k < len)
        .ok_or_else(|| {
            Fault::new(
                K::Index,
                format!("index out of range: index {k}, length {len}"),
            )
        })
}

fn index(b: &Value, i: &Value) -> Result<Value, Fault> {
    match b {
        Value::List(items) => Ok(items[index_of(i, items.len())?].clone()),
        Value::Pose(p) => Ok(Value::Float(p[index_of(i, 6)?])),
        // A struct's members by position, in the order they were given (UR's own
        // EtherNet/IP example indexes the struct a `read` returns: `r[fixture]`).
        Value::Struct(members) => Ok(members[index_of(i, members.len())?].1.clone()),
        other => Err(Fault::new(
            K::Type,
            format!("type error: cannot index a {}", other.type_name()),
        )),
    }
}

fn index_mut<'a>(b: &'a mut Value, i: &Value) -> Result<&'a mut Value, Fault> {
    match b {
        Value::List(items) => {
            let k = index_of(i, items.len())?;
            Ok(&mut items[k])
        }
        Value::Struct(members) => {
            let k = index_of(i, members.len())?;
            Ok(&mut members[k].1)
        }
        other => Err(Fault::new(
            K::Type,
            format!(
                "type error: cannot assign into an element of a {}",
                other.type_name()
            ),
        )),
    }
}

/// Stores `v` at `i` in `b`; the value it drops: the element replaced, or `v` itself
/// when its number went into a pose.
fn store_index(b: &mut Value, i: &Value, v: Value) -> Result<Value, Fault> {
    match b {
        Value::List(items) => {
            let k = index_of(i, items.len())?;
            Ok(std::mem::replace(&mut items[k], v))
        }
        Value::Struct(members) => {
            let k = index_of(i, members.len())?;
            Ok(std::mem::replace(&mut members[k].1, v))
        }
        Value::Pose(p) => {
            let k = index_of(i, 6)?;
            p[k] = v.as_f64().ok_or_else(|| {
                Fault::type_error(format!(
                    "type error: a pose element must be a number, got {}",
                    v.type_name()
                ))
            })?;
            Ok(v)
        }
        other => Err(Fault::new(
            K::Type,
            format!(
                "type error: cannot assign into an element of a {}",
                other.type_name()
            ),
        )),
    }
}

/// The binary operators. Ints: 32-bit, wrapping on overflow; `/` of two ints is a float
/// division, `%` of two ints the truncating remainder; both fail on an int 0. A float on
/// either side makes the result a float. Poses add and subtract element-wise; lists of
/// numbers add, subtract, multiply and divide element-wise with a list of the same length
/// or a number (`q + qd * steptime`, `[...] / MULT`, as UR's driver scripts do).
pub(crate) fn binary(op: BinOp, l: Value, r: Value) -> Result<Value, Fault> {
    use Value::{Bool, Float, Int, List, Pose};
    let type_err = |l: &Value, r: &Value, sym: &str| {
        Err(Fault::new(
            K::Type,
            format!(
                "type error: {} {sym} {} ({} {sym} {})",
                l.type_name(),
                r.type_name(),
                l.to_source(),
                r.to_source()
            ),
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
    // Strings join with `+`, as on the controller (`"x = " + to_str(x)`), within the
    // controller's 1023-character strings.
    if let (Value::Str(a), Value::Str(b), BinOp::Add) = (&l, &r, op) {
        let len = a.len() + b.len();
        if len > crate::builtins::MAX_STRING_LEN {
            return Err(Fault::from(format!(
                "string + string: the result would be {len} characters, more than {}",
                crate::builtins::MAX_STRING_LEN
            )));
        }
        let mut out = Vec::with_capacity(len);
        out.extend_from_slice(a);
        out.extend_from_slice(b);
        return Ok(Value::Str(out));
    }
    // In arithmetic a bool is the number 0 or 1, as on the controller
    // (`1 * get_digital_in(0)`, `3 * True + False`).
    let as_number = |v: Value| match v {
        Bool(b) => Int(i32::from(b)),
        other => other,
    };
    let (l, r) = match (&l, &r) {
        (Bool(_), Int(_) | Float(_) | Bool(_)) | (Int(_) | Float(_), Bool(_)) => {
            (as_number(l), as_number(r))
        }
        _ => (l, r),
    };
    match (&l, &r) {
        (Int(a), Int(b)) => Ok(Int(match op {
            BinOp::Add => a.wrapping_add(*b),
            BinOp::Sub => a.wrapping_sub(*b),
            BinOp::Mul => a.wrapping_mul(*b),
            BinOp::Div | BinOp::Rem if *b == 0 => {
                return Err(Fault::new(
                    K::DivisionByZero,
                    format!("division by zero ({a} {sym} 0)"),
                ))
            }
            // As UR's own driver scripts rely on (`params[1] / MULT_jointstate`, two
            // ints): `/` of two ints is a float.
            BinOp::Div => return Ok(Float(f64::from(*a) / f64::from(*b))),
            _ => a.wrapping_rem(*b),
        })),
        // A matrix (a list of lists) times a matrix or a flat list is the matrix product,
        // as in the e-Series manual's matrix expressions (`inv(M) * f`); two flat lists
        // multiply element by element.
        (List(a), List(b)) if op == BinOp::Mul && is_matrix(a) => matrix_product(a, b),
        (List(a), List(b)) if matches!(op, BinOp::Add | BinOp::Sub | BinOp::Mul | BinOp::Div) => {
            if a.len() != b.len() {
                return Err(Fault::new(
                    K::Type,
                    format!(
                        "lists of different lengths: {} {sym} {}",
                        l.to_source(),
                        r.to_source()
                    ),
                ));
            }
            let items: Result<Vec<Value>, Fault> = a
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
            let items: Result<Vec<Value>, Fault> =
                a.iter().map(|x| binary(op, x.clone(), s.clone())).collect();
            Ok(List(items?))
        }
        (s, List(b))
            if s.as_f64().is_some() && matches!(op, BinOp::Add | BinOp::Sub | BinOp::Mul) =>
        {
            let items: Result<Vec<Value>, Fault> =
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

/// At most this many multiply-adds in one matrix product (a 1000×1000 by 1000×1000
/// product would hold the controller thread for seconds).
const MAX_MATRIX_PRODUCT_OPS: usize = 1 << 22;

/// Whether a list is a matrix: non-empty, and every element a list.
fn is_matrix(rows: &[Value]) -> bool {
    !rows.is_empty() && rows.iter().all(|r| matches!(r, Value::List(_)))
}

/// The numbers of one row of a matrix operand of `*`.
fn matrix_row(v: &Value) -> Result<Vec<f64>, Fault> {
    let Value::List(items) = v else {
        return Err(Fault::new(
            K::Type,
            format!(
                "matrix product: a row must be a list, got {}",
                v.type_name()
            ),
        ));
    };
    items
        .iter()
        .map(|x| {
            x.as_f64().ok_or_else(|| {
                Fault::new(
                    K::Type,
                    format!(
                        "matrix product: elements must be numbers, got {}",
                        x.type_name()
                    ),
                )
            })
        })
        .collect()
}

/// `a * b` where `a` is a matrix: `b` a matrix gives the matrix product, `b` a flat list
/// (a column vector) gives a flat list. Floats, as the controller's matrices hold.
fn matrix_product(a: &[Value], b: &[Value]) -> Result<Value, Fault> {
    let left: Vec<Vec<f64>> = a.iter().map(matrix_row).collect::<Result<_, _>>()?;
    let inner = left[0].len();
    if inner == 0 || left.iter().any(|r| r.len() != inner) {
        return Err(Fault::new(
            K::Type,
            "matrix product: rows empty or of different lengths",
        ));
    }
    let (right, column): (Vec<Vec<f64>>, bool) = if is_matrix(b) {
        (b.iter().map(matrix_row).collect::<Result<_, _>>()?, false)
    } else {
        let col = matrix_row(&Value::List(b.to_vec()))?;
        (col.into_iter().map(|x| vec![x]).collect(), true)
    };
    let cols = right.first().map_or(0, Vec::len);
    if right.len() != inner || right.iter().any(|r| r.len() != cols) {
        return Err(Fault::new(
            K::Type,
            format!(
                "matrix product: a {}×{inner} matrix times a {} with {} rows",
                left.len(),
                if column { "list" } else { "matrix" },
                right.len()
            ),
        ));
    }
    if left.len().saturating_mul(inner).saturating_mul(cols) > MAX_MATRIX_PRODUCT_OPS {
        return Err(Fault::new(
            K::Type,
            "matrix product: the matrices are too large",
        ));
    }
    let product: Vec<Vec<f64>> = left
        .iter()
        .map(|row| {
            (0..cols)
                .map(|j| row.iter().zip(&right).map(|(x, r)| x * r[j]).sum())
                .collect()
        })
        .collect();
    Ok(if column {
        Value::List(product.into_iter().map(|r| Value::Float(r[0])).collect())
    } else {
        Value::List(
            product
                .into_iter()
                .map(|r| Value::List(r.into_iter().map(Value::Float).collect()))
                .collect(),
        )
    })
}

/// Binds a user function's arguments to its parameters, as the compiler matched them
/// (every parameter without a default is given: the compiler checked). A default that
/// names a variable is that global's value now; a global never assigned is an error.
fn bind_user(
    callee: &crate::compile::Func,
    site: &CallSite,
    args: Vec<Value>,
    globals: &[Option<Value>],
    names: &[String],
    max_size: usize,
) -> Result<Vec<(Sym, Option<Value>)>, Fault> {
    let mut out: Vec<(Sym, Option<Value>)> = Vec::with_capacity(callee.params.len());
    let mut given = vec![false; callee.params.len()];
    for slot in &site.slots {
        if let Some(g) = given.get_mut(usize::from(*slot)) {
            *g = true;
        }
    }
    for ((p, default), given) in callee.params.iter().zip(&given) {
        let v = match default {
            _ if *given => None,
            None => None,
            Some(d) => {
                let v = default_value(d, globals, names, *p, &callee.name)?;
                check_value(&v, max_size)?;
                Some(v)
            }
        };
        out.push((*p, v));
    }
    for (slot, v) in site.slots.iter().zip(args) {
        if let Some(o) = out.get_mut(usize::from(*slot)) {
            o.1 = Some(v);
        }
    }
    Ok(out)
}

/// The value of parameter `param`'s default now: names are the globals' values (a
/// global never assigned is an error), list and pose literals are built from their items
/// (a pose item must be a number). The result is checked against the value bounds by
/// the caller.
fn default_value(
    d: &crate::parser::ParamDefault<Sym>,
    globals: &[Option<Value>],
    names: &[String],
    param: Sym,
    func: &str,
) -> Result<Value, Fault> {
    use crate::parser::ParamDefault as D;
    let name = |s: Sym| names.get(s as usize).map_or("?", |n| n.as_str());
    Ok(match d {
        D::Const(v) => v.clone(),
        D::Var(g) => match globals.get(*g as usize).and_then(|v| v.as_ref()) {
            Some(v) => v.clone(),
            None => {
                return Err(Fault::new(
                    K::UnknownVariable,
                    format!(
                        "unknown variable `{}`, the default of parameter `{}` of `{func}`",
                        name(*g),
                        name(param),
                    ),
                ))
            }
        },
        D::List(items) => Value::List(
            items
                .iter()
                .map(|d| default_value(d, globals, names, param, func))
                .collect::<Result<_, _>>()?,
        ),
        D::Pose(items) => {
            let mut p = [0.0; 6];
            for (slot, d) in p.iter_mut().zip(items) {
                let v = default_value(d, globals, names, param, func)?;
                *slot = v.as_f64().ok_or_else(|| {
                    Fault::new(
                        K::Type,
                        format!(
                            "the default of parameter `{}` of `{func}`: a pose item is {}, not a number",
                            name(param),
                            v.type_name()
                        ),
                    )
                })?;
            }
            Value::Pose(p)
        }
    })
}

impl Machine {
    /// Calls a built-in (or the stub that replaces it) from call site `site`.
    fn call_native(
        &mut self,
        prog: &Program,
        site: &CallSite,
        stub: Option<u32>,
        args: Vec<Value>,
        current: &Thread,
    ) -> Result<Called, Fault> {
        let name = &prog.names[site.name as usize];
        let traced = match site.builtin {
            _ if stub.is_some() => true,
            Some(b) if b.domain == crate::builtins::Domain::Sockets => {
                self.config.trace_socket_calls || self.config.trace_all_calls
            }
            _ => self.config.trace_all_calls,
        };
        let mut record = traced.then(|| {
            let positional = usize::from(site.positional).min(args.len());
            Box::new(CallRecord {
                line: site.at.line,
                column: site.at.col,
                name: name.clone(),
                builtin: site.builtin,
                args: args[..positional].to_vec(),
                kwargs: site
                    .kwnames
                    .iter()
                    .map(|k| prog.names[*k as usize].clone())
                    .zip(args[positional..].iter().cloned())
                    .collect(),
                assigned_to: site.assigned.map(|s| prog.names[s as usize].clone()),
                result: Value::None,
                outcome: Outcome::Returned,
                socket: None,
                read: None,
            })
        });
        if let Some(i) = stub {
            let v = match self.config.stubs.get(i as usize).map(|(_, s)| s) {
                Some(Stub::Return(v)) => v.clone(),
                _ => Value::None,
            };
            if let Some(mut r) = record {
                r.result = v.clone();
                r.outcome = Outcome::Stubbed;
                self.ctl.events.push_back(Event::Call(r));
            }
            return Ok(Called::Value(v));
        }
        if let Some(b) = site
            .builtin
            .filter(|b| b.domain == crate::builtins::Domain::Interpreter)
        {
            return self.interpreter_builtin(b, site, args);
        }
        let Some(builtin) = site.builtin else {
            return Err(Fault::new(
                K::UnknownFunction,
                format!(
                    "`{name}` is not a built-in this interpreter supports (stub it to run past it)"
                ),
            ));
        };
        let mut v: Vec<Value> = builtin
            .params
            .iter()
            .map(|p| p.default.value().unwrap_or(Value::None))
            .collect();
        for (slot, a) in site.slots.iter().zip(args) {
            if let Some(x) = v.get_mut(usize::from(*slot)) {
                *x = a;
            }
        }
        let mut a = Args {
            name: builtin.name,
            params: builtin.params,
            v,
            positional: usize::from(site.positional),
            line: site.at.line,
            read: None,
            failure: None,
            traced: record.is_some(),
        };
        if let Some(r) = record.as_mut() {
            if let Some(k) = builtin.param("socket_name") {
                r.socket = a.text(k).ok();
            }
        }
        // A built-in refuses to allocate past the count before it changes anything: the
        // count may be high (drops not credited), so a recount decides, once.
        let out = match (builtin.run)(&mut self.ctl, &mut a) {
            Err(_) if std::mem::take(&mut self.ctl.mem.refused) => {
                self.recount(Some(current));
                (builtin.run)(&mut self.ctl, &mut a)
            }
            out => out,
        };
        self.ctl.mem.refused = false;
        let out = out?;
        if let Some(r) = record.as_mut() {
            r.read = a.read.take();
            if let Some(why) = a.failure.take() {
                r.outcome = Outcome::Failed(why);
            }
        }
        let (value, wait) = match out {
            Out::Value(v) => (v, None),
            Out::Wait(d, v) => (v, Some(Ok(d))),
            Out::Motion(until, v) => (v, Some(Err(until))),
            Out::Read {
                socket,
                call,
                input,
                buffered_at_start,
            } => {
                return Ok(Called::Block(Wait::Read {
                    socket,
                    call,
                    record,
                    input,
                    buffered_at_start,
                }))
            }
            Out::Connect { socket } => return Ok(Called::Block(Wait::Connect { socket, record })),
        };
        if let Some(mut r) = record {
            r.result = value.clone();
            self.ctl.events.push_back(Event::Call(r));
        }
        Ok(match wait {
            Some(Ok(d)) => Called::Block(self.wait_for(d, value)),
            Some(Err(until)) => Called::Block(Wait::Motion {
                until,
                after: self.ctl.step.saturating_add(1),
                result: value,
            }),
            None => Called::Value(value),
        })
    }
}

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
        use crate::trajectory::Kind;
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
        let stmts = match crate::lexer::lex(text)
            .and_then(|toks| crate::parser::Parser::new(toks).program())
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
    fn interpreter_has_work(&self) -> bool {
        let i = &self.interp;
        i.ending || i.clear_pending || !i.queue.is_empty() || i.clearing.is_some()
    }

    /// The main thread (at `i`) waits in interpreter mode: a pending clear or end
    /// happens, then the next statement starts. Outside `exec`: the program may change.
    fn interpreter_resume(&mut self, i: usize) -> (bool, Wait) {
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
    fn interpreter_builtin(
        &mut self,
        builtin: &crate::builtins::Builtin,
        site: &CallSite,
        args: Vec<Value>,
    ) -> Result<Called, Fault> {
        let mut v: Vec<Value> = builtin
            .params
            .iter()
            .map(|p| p.default.value().unwrap_or(Value::None))
            .collect();
        for (slot, a) in site.slots.iter().zip(args) {
            if let Some(x) = v.get_mut(usize::from(*slot)) {
                *x = a;
            }
        }
        let flag = |i: usize| match v.get(i) {
            Some(Value::Bool(b)) => Ok(*b),
            other => Err(Fault::new(
                K::Type,
                format!(
                    "type error: `{}` argument {} must be a bool, got {}",
                    builtin.name,
                    i + 1,
                    other.map_or("nothing", |x| x.type_name())
                ),
            )),
        };
        match builtin.name {
            "interpreter_mode" => {
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
                let (clear_queue, clear_on_end) = (flag(0)?, flag(1)?);
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
            "end_interpreter" => {
                if self.interp.status.active {
                    self.interp.ending = true;
                }
                Ok(Called::Value(Value::None))
            }
            _ => {
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

/// The most steps of a motion one [`Machine::run_until`] call puts the arm through one by
/// one: 2^22, over two hours of 2 ms steps, a few seconds of computing at most.
pub const MAX_MOTION_SAMPLES: u64 = 1 << 22;

/// `: did you mean `NAME`?` for the built-in or program name (function, variable)
/// nearest `name` (a typo), else nothing.
fn suggestion(name: &str, program: &Program) -> String {
    let funcs = program.funcs.iter().map(|f| f.name.as_str());
    crate::builtins::nearest_name(name, funcs.chain(program.names.iter().map(String::as_str)))
        .map(|n| format!(": did you mean `{n}`?"))
        .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Short-lived threads (issue 18): finished threads leave the scheduler's list, so a
    /// step visits the live threads only, and a handle of a finished thread names no
    /// new one.
    #[test]
    fn finished_threads_leave_the_schedule() {
        let src = "thread t():\n  y = 1\nend\nwhile True:\n  k = 0\n  while k < 20:\n    h = run t()\n    k = k + 1\n  end\n  sync()\nend\n";
        let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
        for k in 0..500u32 {
            m.run_until(Duration::from_millis(2) * k);
            assert_eq!(m.state(), &State::Running);
            // The program, and no finished thread.
            assert_eq!(m.threads.len(), 1, "step {k}");
        }
        assert_eq!(m.next_thread_id, 500 * 20 + 1);
        assert!(m.threads.iter().all(|t| !t.done));
    }
}
