//! # urscript-interp
//!
//! A URScript interpreter over [`urscript_socket`]'s robot model, so a server can be
//! tested against the robot program it will really run, without a robot or UR's
//! simulator.
//!
//! - [`Program::parse`] reads a whole program first: a syntax error, or a construct not
//!   supported, names its line and column before anything runs.
//! - [`Machine`] runs it **sans-IO** (quinn-proto style): time and socket events are
//!   inputs ([`Machine::run_until`], [`Machine::handle_connected`],
//!   [`Machine::handle_received`]), and what the program does comes out as [`Event`]s
//!   ([`Machine::poll_event`]): connections to open, bytes to send, typed messages
//!   (`textmsg`, `popup`), and a typed [`CallRecord`] of every socket call (line,
//!   column, arguments, result, outcome, the read rule used). Tests run in virtual time.
//! - [`builtins`] is one table: each built-in one entry (name, parameters with defaults,
//!   what it does, the code), grouped by the manual's chapters. [`Program::parse`]
//!   resolves every call to its entry and checks its arguments before anything runs.
//! - [`drive::run_tcp`] runs a machine in real time against real TCP servers.
//!
//! See [`machine`] for the time model (steps, thread order) and [`builtins`] for the
//! built-ins and the virtual arm.
//!
//! ## Layout
//!
//! | where | what |
//! |---|---|
//! | `syntax/` | lexer, parser and compiler: program text to code, every call resolved and checked |
//! | `vm/` | the [`Machine`] ([`machine`]): configuration and state, the scheduler, a thread's run, calls and stubs, the waits the driver's inputs end, interpreter mode, the memory budget |
//! | `value/` | [`Value`], its operators, indexing and members, what it costs the memory budget |
//! | `arm/` | the arm's mechanics: [`kinematics`], speed profiles and blends, force mode, poses, the [`world_model`] |
//! | [`builtins`] | the built-in table and each built-in's code |
//! | `native.rs` | what the machine and a built-in's code exchange: the table entry ([`builtins::Builtin`]), the bound arguments, what the code returns |
//! | `controller.rs` | what built-ins act on: the [`Arm`], the [`World`], the robot's sockets, program time, the events |
//! | [`event`], [`interpreter`], [`eip`], [`drive`] | the events out, interpreter mode's wire side, EtherNet/IP, the real-time driver |
//!
//! Dependencies point one way: the machine and the compiler use the built-in table;
//! the built-ins use `native`, `controller`, [`event`], `arm` and `value`; `controller`
//! uses `arm`, [`event`] and `value`, and nothing of the built-ins; `arm` and `value` use
//! neither the built-ins nor the machine (`arm` uses nothing outside itself). Three
//! edges go back by design: the value operators take the compiled code's operator and
//! store path (`syntax/`); a [`CallRecord`] names its [`Builtin`](builtins::Builtin),
//! whose code takes the controller that holds the events; and the controller holds the
//! memory budget's counters (`vm/memory.rs`).
//!
//! ## Bounds: any program text is safe to run
//!
//! A program is input: whatever it says, the interpreter neither crashes (no stack
//! overflow, no allocator abort, no panic), nor stalls, nor grows without bound. The
//! bounds, each an error naming a line and column:
//!
//! | what | bound | error |
//! |---|---|---|
//! | program text | 16 MiB ([`Program::parse`], [`Program::parse_bytes`]), checked before lexing; lexing and parsing are linear in the text | syntax, line 1 |
//! | nesting of blocks, brackets and unary operators (the parser's recursion) | 64 | syntax |
//! | depth of an expression's tree: every operator, index, call, list and unary operator is a level, and a left-associative chain counts each link (`1+1+...+1` with 128 `+` is too deep) | 128 | syntax |
//! | depth of a value (levels of nested lists and structs) | [`MAX_VALUE_DEPTH`] (32) | runtime, [`RuntimeErrorKind::Limit`] |
//! | members of a struct (`struct(a=1, ...)`) | [`MAX_STRUCT_MEMBERS`] (64) | compile |
//! | an XML-RPC reply (`handle.name(...)` on an `rpc_factory` handle) | 1 MiB (headers 16 KiB), values 32 levels deep, complete within 10 s of program time | runtime, [`RuntimeErrorKind::RemoteCall`] |
//! | size of one value (list elements at every depth, plus string bytes) | [`Config::max_value_size`] (1 000 000) | runtime, `Limit` |
//! | nested calls per thread | 256 | runtime, `Limit` |
//! | threads running at once | [`MAX_THREADS`](machine::MAX_THREADS) (64) | runtime, `Limit` |
//! | sockets open at once (`socket_open` of a new name past it) | [`MAX_SOCKETS`](builtins::sockets::MAX_SOCKETS) (64) | runtime, `Limit` |
//! | EtherNet/IP handles per program; instances; bytes per instance; labels per handle | [`eip::MAX_HANDLES`] (64); [`eip::MAX_INSTANCES`] (64); [`eip::MAX_DATA_SIZE`] (4096); [`eip::MAX_LABELS`] (256) | runtime, `Limit` or `Argument` |
//! | statements per thread per step without consuming time (its time slice) | [`Config::max_statements_per_step`] (10 000) | the thread goes on in the next step |
//! | steps of a motion one `run_until` puts the arm through one by one | [`MAX_MOTION_SAMPLES`](machine::MAX_MOTION_SAMPLES) (2^22) | past it the arm jumps to where the motion has it |
//! | motion events | two per move or servo/speed stream ([`Event::MoveStart`], [`Event::MoveEnd`]), one per output change ([`Event::Output`]) | a write of the value already there is not reported |
//! | memory the program holds at once: values of every variable of every frame of every thread and the globals, temporaries, call frames, threads, events not yet taken by the driver | [`Config::max_memory`] (256 MiB) | runtime, `Limit`: `memory budget exceeded: the program holds N bytes and needs M more, over its budget of B bytes (...)` |
//!
//! Everything recursive (parsing, compiling, cloning, comparing, writing and dropping
//! trees and values) is bounded by the depth bounds. Each value, call depth and thread
//! count has its own bound, but together they would allow nearly a terabyte (64
//! threads, 256 calls deep, a list of a million elements in every frame); the budget bounds
//! them together, counted as the program allocates and checked before a large
//! allocation (see [`machine`], "Memory"). A finished thread's slot is freed: handles
//! are never reused, so `join`/`kill` of an old handle does nothing. A step visits the
//! live threads only.
//!
//! ```
//! use std::time::Duration;
//! use urscript_interp::{Config, Event, Machine, Program, State};
//!
//! let program = Program::parse(r#"
//! def vision():
//!   socket_open("10.0.0.5", 5000, "camera")
//!   socket_send_line("shoot", "camera")
//!   pose = socket_read_ascii_float(6, "camera")
//!   if pose[0] == 6:
//!     textmsg("x = ", pose[1])
//!   end
//! end
//! "#).unwrap();
//! let mut m = Machine::new(program, Config::default());
//! m.run_until(Duration::ZERO);
//! assert!(matches!(m.poll_event(), Some(Event::Connect { port: 5000, .. })));
//! m.handle_connected("camera", Ok(()));
//! m.run_until(Duration::from_millis(2));
//! while let Some(e) = m.poll_event() {
//!     if let Event::Transmit { bytes, .. } = e { assert_eq!(bytes, b"shoot\n"); }
//! }
//! m.handle_received("camera", b"(0.4,-0.2,0.3,0,3.14,0)\n");
//! m.run_until(Duration::from_millis(4));
//! assert_eq!(m.state(), &State::Finished);
//! let messages: Vec<String> = std::iter::from_fn(|| m.poll_event())
//!     .filter_map(|e| match e {
//!         Event::Message(msg) => Some(msg.text),
//!         _ => None,
//!     })
//!     .collect();
//! assert_eq!(messages, ["x = 0.4"]);
//! ```
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod arm;
pub mod builtins;
pub mod drive;
pub mod eip;
mod error;
pub mod event;
mod history;
pub mod interpreter;
mod native;
mod rpc;
pub mod rtde_fields;
mod runtime;
mod sockets;
mod syntax;
mod value;
mod vm;
mod world_set;

pub use arm::{kinematics, world_model};

pub mod machine {
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
    //! a list element: the size of a [`Value`](crate::Value), 56 bytes on 64-bit targets) plus what it
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

    pub use crate::vm::{Config, Event, Machine, State, Stub, MAX_MOTION_SAMPLES, MAX_THREADS};
}

pub use error::{ControllerCode, ParseError, ParseErrorKind, RuntimeError, RuntimeErrorKind};
pub use event::{
    CallRecord, Effect, Event, Message, MessageKind, MoveEnd, MoveOutcome, MoveStart, Outcome,
    OutputValue, OutputWrite, ReadRecord,
};
pub use history::JOINT_HISTORY_STEPS;
pub use machine::{Config, Machine, State, Stub};
pub use runtime::{Arm, World};
pub use sockets::{Policy, Timeout};
pub use syntax::compile::{Preamble, Program};
pub use syntax::lexer::{top_level_end, TopLevel, UnitKind, UnitLine};
pub use value::{Value, MAX_STRUCT_MEMBERS, MAX_VALUE_DEPTH};
pub use world_set::{SetError, ARM_SETTINGS, WORLD_SETTINGS};

/// Reads a URScript constant: a number, `True`/`False`, a string, a list or a pose of
/// constants (as a stub's value on a command line).
///
/// ```
/// use urscript_interp::{parse_constant, Value};
/// assert_eq!(parse_constant("[1, -2.5]").unwrap(), Value::List(vec![Value::Int(1), Value::Float(-2.5)]));
/// assert!(parse_constant("x").is_err());
/// ```
pub fn parse_constant(text: &str) -> Result<Value, ParseError> {
    let toks = syntax::lexer::lex(text)?;
    let mut p = syntax::parser::Parser::new(toks);
    let e = p.expr()?;
    p.end_of_constant()?;
    syntax::parser::const_value(&e).ok_or_else(|| ParseError::new(1, 1, "not a constant".into()))
}
