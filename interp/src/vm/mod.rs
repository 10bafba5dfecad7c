//! The machine: the running program's threads, the scheduler in virtual time, and the
//! sans-IO interface. Its public face is [`crate::machine`], whose docs give the time
//! model and the memory budget.

mod call;
mod exec;
mod interpreter_mode;
pub(crate) mod memory;
mod sched;
mod wait;

use std::sync::Arc;
use std::time::Duration;

use urscript_socket::robot::ReadCall;

use crate::error::{Fault, RuntimeError, RuntimeErrorKind as K};
pub use crate::event::Event;
use crate::event::{CallRecord, Effect};
use crate::runtime::{Arm, Runtime};
use crate::sockets::{Policy, Sockets};
use crate::syntax::compile::{Program, Sym};
use crate::value::Value;
use memory::thread_bytes;

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
    pub model: crate::arm::kinematics::Model,
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
            model: crate::arm::kinematics::Model::Ur5e,
            policy: Policy::default(),
            stubs: Vec::new(),
            max_statements_per_step: 10_000,
            trace_socket_calls: true,
            trace_all_calls: false,
            max_value_size: crate::value::DEFAULT_MAX_VALUE_SIZE,
            max_memory: memory::DEFAULT_MAX_MEMORY,
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
            model: crate::arm::kinematics::Model::Ur5,
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

/// A program running in virtual time. See [`crate::machine`] for the time model.
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
    ctl: Runtime,
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
                    Fault::name_not_found(
                        K::UnknownFunction,
                        name,
                        &format!(
                            "`{name}` is neither defined in the program nor a built-in of the controller{hint} (a URCap's function? stub it)"
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
                Fault::name_not_found(
                    K::UnknownVariable,
                    name,
                    &format!(
                        "`{name}` is never assigned in its scope (not a global the program assigns, not a parameter or variable of its function){hint}"
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
            ctl: Runtime {
                dh: config.model.dh(),
                step_time: config.step_time,
                step: 0,
                arm,
                sockets: Sockets::new(config.policy),
                events: memory::Events::default(),
                effects: Vec::new(),
                mem: memory::Memory::new(config.max_memory),
                motion: None,
                thread: 0,
                sampled: None,
                eip: crate::eip::Handles::default(),
                rtde_watchdogs: Vec::new(),
                tracked: None,
                queued: None,
                clock: crate::runtime::MotionClock::default(),
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

    /// What the program asks of the controller running it and has not been taken
    /// ([`Machine::take_effects`]), in the order asked.
    pub fn effects(&self) -> &[Effect] {
        &self.ctl.effects
    }

    /// Takes what the program asks of the controller running it: a controller calls this
    /// after each step and acts on each (a protective stop, a pause, a power-off).
    ///
    /// ```
    /// # use urscript_interp::{Config, Effect, Machine, Program};
    /// let mut m = Machine::new(Program::parse("protective_stop()\n").unwrap(), Config::default());
    /// m.run_until(std::time::Duration::ZERO);
    /// assert_eq!(m.take_effects(), [Effect::ProtectiveStop]);
    /// assert!(m.effects().is_empty());
    /// ```
    pub fn take_effects(&mut self) -> Vec<Effect> {
        std::mem::take(&mut self.ctl.effects)
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
    pub fn world(&self) -> &crate::runtime::World {
        &self.ctl.arm.world
    }

    /// The world, to change what the program will sense: a digital input switching, a
    /// temperature, an RTDE input register.
    pub fn world_mut(&mut self) -> &mut crate::runtime::World {
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

    /// Short-lived threads: finished threads leave the scheduler's list, so a
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
