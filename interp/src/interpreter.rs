//! Interpreter mode (e-Series, PolyScope 5.10+): a running program calls
//! `interpreter_mode()`, and from then on statements sent to the controller's interpreter
//! socket (port 30020), one per line, are compiled into the running program and run in
//! order. [`Machine::interpreter_line`](crate::Machine::interpreter_line) takes one line
//! (sans-IO: the caller owns the socket) and gives the reply to write back.
//!
//! # What the controller does, and where it is written
//! From the URScript manual (e-Series 5.x, chapter "Interpreter Mode") unless said
//! otherwise:
//! - Each statement is one line ending in `\n`; several statements may share a line and
//!   are accepted only if all compile. A `def ... end` is written on one line.
//! - A line that compiles is acknowledged `ack: <id>: <statement>`; ids are consecutive,
//!   start at 1 (0 means "none yet"), and wrap to 1. A line that does not compile, or that
//!   arrives while no program runs, is answered `discard: <reason>: <statement>`.
//! - Statements run in order, one after the other, in the scope `interpreter_mode()` was
//!   called from; when the last one has run the interpreter idles until more arrive.
//! - `interpreter_mode(clearQueueOnEnter=True, clearOnEnd=True)` blocks the main thread
//!   (only the main thread may call it; it cannot be sent to the interpreter: nested modes
//!   are not supported). Statements may be sent before it runs: they wait in the queue,
//!   which `clearQueueOnEnter=True` empties on entry. `clearOnEnd=True` removes what was
//!   interpreted when the mode ends.
//! - `end_interpreter()` (sent as a statement, or called by any thread) makes
//!   `interpreter_mode()` return. `clear_interpreter()` (only in interpreter mode) removes
//!   every function, thread and variable the interpreted statements made; statements sent
//!   after it wait until the clear is done, then are compiled and answered.
//! - Commands run as soon as they arrive, never queued, each alone on its line:
//!   `skipbuffer` (drop the statements not yet started; the one running finishes),
//!   `abort` (stop the `movej`/`movel` under way), and the state commands, answered
//!   `state: <n>: <command>`: `statelastexecuted` (largest id started),
//!   `statelastinterpreted` (largest id compiled), `statelastcleared` (largest id removed
//!   by a clear or the end of a mode), `stateunexecuted` (statements not started).
//! - UR's "Interpreter mode" support article (e-Series, 5.10+) gives the port, 30020, and
//!   an example client that sends each line and reads exactly one reply line, parsed as
//!   `word: number`, for statements and for every command alike.
//!
//! # Choices the manual leaves open (ours, documented)
//! - `skipbuffer` and `abort`: the manual says their reply "should be ignored". UR's
//!   example client reads one line after each; we answer `state: <n>: skipbuffer` (n:
//!   the statements skipped) and `state: <n>: abort` (n: 1 if a motion was stopped, else
//!   0), so a client reading one reply per line never waits.
//! - Discard reasons are our words (see [`Discard`]); the manual gives only the form.
//! - Each statement starts at the step after the previous one ended (one step at least
//!   per statement).
//! - A statement is compiled and acknowledged when it arrives, also before the program
//!   calls `interpreter_mode()` (the manual says such statements are queued, not when
//!   they are answered); the queue's entry clear counts them in `statelastcleared`.
//! - A line that arrives after an acknowledged `clear_interpreter()` or
//!   `end_interpreter()` that has not run yet is held (no reply yet) and compiled and
//!   answered once that statement has run: the manual says so for the clear; the end
//!   clears too (by default), so it is treated alike.
//! - Statements run in the scope `interpreter_mode()` was called from (the manual):
//!   they read and write the locals of the function that called it (and their changes
//!   stay, as the manual says of "local variables from the enclosing scope") and the
//!   program's globals. A plain assignment to a new name makes a global of the program
//!   (the manual says declaring new globals is "not supported" without saying what
//!   happens), removed again by a clear. A read of a name the program never mentioned is
//!   discarded as `compile_error_name_not_found`; one it mentions but never assigned is
//!   a runtime error when the statement runs.
//! - `abort` stops the arm at once (the arm model has no deceleration ramp; a blend
//!   radius does not change that) and the moving thread goes on with its next statement.
//!   It stops any joint or tool motion (`movej`, `movel`, and `movep`/`servoj`, which use
//!   the same motions here), not `speedj`/`speedl`.
//! - The bounds, which the manual does not give numbers for (it says an upper limit
//!   exists): [`MAX_LINE`], [`MAX_UNEXECUTED`], [`MAX_INTERPRETED`].

use std::collections::VecDeque;
use std::fmt;

use crate::syntax::compile::Sizes;

/// The longest line accepted (bytes, without the `\n`); a longer one is discarded
/// ([`Discard::LineTooLong`]).
pub const MAX_LINE: usize = 64 * 1024;

/// The most statements waiting to start (with the lines held behind a
/// `clear_interpreter()`); past it a line is discarded ([`Discard::QueueFull`]).
pub const MAX_UNEXECUTED: usize = 1024;

/// The most statement text (bytes) interpreted since the last clear: what the program
/// can grow by. Past it a line is discarded ([`Discard::TooMuchInterpreted`]) until
/// `clear_interpreter()` (or the end of a mode with `clearOnEnd=True`).
pub const MAX_INTERPRETED: usize = 4 * 1024 * 1024;

/// Why a line was not accepted: the `<reason>` of `discard: <reason>: <statement>`.
#[derive(Debug, Clone, PartialEq, Eq)]
#[non_exhaustive]
pub enum Discard {
    /// No program runs.
    NotRunning,
    /// The line is longer than [`MAX_LINE`] bytes.
    LineTooLong {
        /// Its length in bytes.
        len: usize,
    },
    /// [`MAX_UNEXECUTED`] statements wait already.
    QueueFull,
    /// [`MAX_INTERPRETED`] bytes were interpreted since the last clear.
    TooMuchInterpreted,
    /// The line is not UTF-8.
    NotUtf8,
    /// The line is empty (or only blanks).
    Empty,
    /// `interpreter_mode()` sent to the interpreter: nested modes are not supported.
    Nested,
    /// A syntax or compile error (the controller's words where we have them, e.g.
    /// `compile_error_name_not_found:x:`), with its column in the line.
    Compile {
        /// The column of the error in the line (1-based).
        column: u32,
        /// What is wrong.
        message: String,
    },
}

impl fmt::Display for Discard {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Discard::NotRunning => f.write_str("program not running"),
            Discard::LineTooLong { len } => {
                write!(f, "line too long ({len} bytes, at most {MAX_LINE})")
            }
            Discard::QueueFull => write!(
                f,
                "too many unexecuted statements (at most {MAX_UNEXECUTED}): wait, or send skipbuffer"
            ),
            Discard::TooMuchInterpreted => write!(
                f,
                "too much interpreted ({MAX_INTERPRETED} bytes): call clear_interpreter()"
            ),
            Discard::NotUtf8 => f.write_str("not UTF-8 text"),
            Discard::Empty => f.write_str("empty statement"),
            Discard::Nested => {
                f.write_str("interpreter_mode() cannot be interpreted: nested interpreter modes are not supported")
            }
            Discard::Compile { column, message } => {
                write!(f, "compile error at column {column}: {message}")
            }
        }
    }
}

/// A command run as soon as it arrives (never queued).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Command {
    /// `skipbuffer`: drop the statements not started.
    SkipBuffer,
    /// `abort`: stop the `movej`/`movel` under way.
    Abort,
    /// `statelastexecuted`.
    StateLastExecuted,
    /// `statelastinterpreted`.
    StateLastInterpreted,
    /// `statelastcleared`.
    StateLastCleared,
    /// `stateunexecuted`.
    StateUnexecuted,
}

impl Command {
    /// The command a line is, if it is one (alone on its line; blanks around it allowed).
    pub fn parse(line: &str) -> Option<Command> {
        Some(match line.trim() {
            "skipbuffer" => Command::SkipBuffer,
            "abort" => Command::Abort,
            "statelastexecuted" => Command::StateLastExecuted,
            "statelastinterpreted" => Command::StateLastInterpreted,
            "statelastcleared" => Command::StateLastCleared,
            "stateunexecuted" => Command::StateUnexecuted,
            _ => return None,
        })
    }

    /// Its word on the wire.
    pub fn word(self) -> &'static str {
        match self {
            Command::SkipBuffer => "skipbuffer",
            Command::Abort => "abort",
            Command::StateLastExecuted => "statelastexecuted",
            Command::StateLastInterpreted => "statelastinterpreted",
            Command::StateLastCleared => "statelastcleared",
            Command::StateUnexecuted => "stateunexecuted",
        }
    }
}

/// The controller's answer to one line. [`Display`](fmt::Display) writes the wire text
/// (without the `\n` that ends it on the socket).
///
/// ```
/// use urscript_interp::interpreter::{Command, Discard, Reply};
/// let ack = Reply::Ack { id: 3, statement: "textmsg(1)".into() };
/// assert_eq!(ack.to_string(), "ack: 3: textmsg(1)");
/// let d = Reply::Discard { reason: Discard::NotRunning, statement: "x".into() };
/// assert_eq!(d.to_string(), "discard: program not running: x");
/// let s = Reply::State { value: 0, command: Command::StateUnexecuted };
/// assert_eq!(s.to_string(), "state: 0: stateunexecuted");
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Reply {
    /// The line compiled and waits to run as statement `id`.
    Ack {
        /// Its id.
        id: u32,
        /// The line as received.
        statement: String,
    },
    /// The line was not accepted.
    Discard {
        /// Why.
        reason: Discard,
        /// The line as received (invalid UTF-8 replaced).
        statement: String,
    },
    /// A command's answer.
    State {
        /// The number it answers.
        value: u64,
        /// The command.
        command: Command,
    },
}

impl fmt::Display for Reply {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Reply::Ack { id, statement } => write!(f, "ack: {id}: {statement}"),
            Reply::Discard { reason, statement } => write!(f, "discard: {reason}: {statement}"),
            Reply::State { value, command } => write!(f, "state: {value}: {}", command.word()),
        }
    }
}

/// The numbers the state commands answer, and whether the program is in interpreter mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Status {
    /// `interpreter_mode()` is running (the main thread is blocked in it).
    pub active: bool,
    /// `statelastexecuted`: the largest id started (0: none).
    pub last_executed: u32,
    /// `statelastinterpreted`: the largest id compiled (0: none).
    pub last_interpreted: u32,
    /// `statelastcleared`: the largest id removed by a clear (0: none).
    pub last_cleared: u32,
    /// `stateunexecuted`: statements waiting to start.
    pub unexecuted: usize,
}

/// One acknowledged statement waiting to start.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Queued {
    pub id: u32,
    pub func: u32,
}

/// The machine's interpreter-mode state.
#[derive(Debug, Default)]
pub(crate) struct Interpreter {
    pub status: Status,
    /// `clearOnEnd` of the mode running.
    pub clear_on_end: bool,
    /// Acknowledged statements not started, oldest first (at most [`MAX_UNEXECUTED`]).
    pub queue: VecDeque<Queued>,
    /// Lines received after a `clear_interpreter()` (or a clearing `end_interpreter()`)
    /// was acknowledged and before it ran: compiled and answered once it has.
    pub held: VecDeque<String>,
    /// The id of the acknowledged statement that clears (lines behind it are held).
    pub clearing: Option<u32>,
    /// Replies to held lines, for the caller to poll.
    pub replies: VecDeque<Reply>,
    /// The program's tables before the first statement interpreted since the last clear.
    pub base: Option<Sizes>,
    /// Statement text interpreted since the last clear (bytes).
    pub interpreted: usize,
    /// The depth of the main thread's frames under the statement running now.
    pub executing: Option<usize>,
    /// `end_interpreter()` ran: the mode ends when the statement running ends.
    pub ending: bool,
    /// `clear_interpreter()` ran: the clear happens when the statement running ends.
    pub clear_pending: bool,
}

impl Interpreter {
    /// The id after the last one given (1 after `u32::MAX`, as the manual's ids wrap).
    pub fn next_id(&self) -> u32 {
        match self.status.last_interpreted {
            u32::MAX => 1,
            n => n + 1,
        }
    }
}
