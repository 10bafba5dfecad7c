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

pub mod builtins;
mod compile;
mod controller;
pub mod drive;
pub mod eip;
mod error;
pub mod event;
mod force;
mod history;
pub mod interpreter;
pub mod kinematics;
mod lexer;
pub mod machine;
mod memory;
mod parser;
mod pose;
mod rpc;
mod sockets;
mod trajectory;
mod value;
pub mod world_model;
mod world_set;

pub use compile::{Preamble, Program};
pub use controller::{Arm, World};
pub use error::{ParseError, ParseErrorKind, RuntimeError, RuntimeErrorKind};
pub use event::{
    CallRecord, Event, Message, MessageKind, MoveEnd, MoveOutcome, MoveStart, Outcome, OutputValue,
    OutputWrite, ReadRecord,
};
pub use history::JOINT_HISTORY_STEPS;
pub use machine::{Config, Machine, State, Stub};
pub use sockets::{Policy, Timeout};
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
    let toks = lexer::lex(text)?;
    let mut p = parser::Parser::new(toks);
    let e = p.expr()?;
    p.end_of_constant()?;
    parser::const_value(&e).ok_or_else(|| ParseError::new(1, 1, "not a constant".into()))
}
