//! What a running program tells its driver: typed events, never text to parse back.
//!
//! A driver acts on [`Event::Connect`], [`Event::Transmit`] and [`Event::Close`]; a
//! printer shows [`Event::Message`] (what `textmsg`, `varmsg` and `popup` said) and
//! [`Event::Call`] (a [`CallRecord`]: which built-in ran at which line, with which
//! arguments, what it returned and how).

use std::fmt;

use urscript_socket::robot::{ReadCall, ReadResult};

use crate::native::Builtin;
use crate::value::Value;

/// What a program asks of the controller that runs its arm, beyond motion: the
/// controller acts on it after the step ([`Machine::take_effects`](crate::Machine::take_effects)).
/// A program run alone (no controller) just goes on, its arm stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Effect {
    /// A protective stop: `protective_stop()`, a move whose path left the arm's reach,
    /// or the EtherNet/IP adapter's connection lost with the action "pause" or "stop".
    /// The arm has stopped; the controller pauses (or stops) the program.
    ProtectiveStop,
    /// An RTDE watchdog with the action "pause" fired: the controller pauses the program.
    Pause,
    /// `powerdown()`: the program halted at the call; the controller powers the arm off.
    PowerOff,
}

/// What the machine asks of its driver, or reports.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// `socket_open`: connect to `host:port`, then call
    /// [`Machine::handle_connected`](crate::Machine::handle_connected) with the outcome.
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
    /// What `textmsg`, `varmsg` or `popup` showed.
    Message(Message),
    /// A built-in (or stubbed) call and what it returned. Every socket call is recorded;
    /// other built-ins with [`Config::trace_all_calls`](crate::Config::trace_all_calls).
    /// A call that waits (a read, `socket_open`) is recorded when it returns.
    Call(Box<CallRecord>),
    /// A move (`movej`, `movel`, `movep`, `movec`, `optimove*`) started, or a stream of
    /// `servoj`, `servoc`, `speedj` or `speedl` commands did (one event for the stream, not
    /// one per command).
    MoveStart(Box<MoveStart>),
    /// The move or stream a [`Event::MoveStart`] reported ended, and how.
    MoveEnd(Box<MoveEnd>),
    /// The program changed an output (digital, tool digital or analog); a write that
    /// leaves the output as it was is not reported.
    Output(OutputWrite),
}

/// A move or stream's start: what the program asked.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveStart {
    /// The line of the command.
    pub line: u32,
    /// The function (`movej`, `servoj`...).
    pub function: &'static str,
    /// Program time the arm set off (a move queued behind a blending one starts when
    /// that one ends).
    pub at: std::time::Duration,
    /// The target joints (rad); for a tool move, those the inverse kinematics gave (the
    /// start's, if the pose is out of reach); `None` for a speed stream.
    pub target_q: Option<[f64; 6]>,
    /// The target tool pose (base frame); `None` for a speed stream.
    pub target_pose: Option<[f64; 6]>,
    /// The speeds a `speedj` (rad/s) or `speedl` (m/s, rad/s) stream started with.
    pub speed: Option<[f64; 6]>,
    /// Acceleration (`a`, rad/s² or m/s²), 0 if the function has none.
    pub a: f64,
    /// Speed (`v`), 0 if the function has none.
    pub v: f64,
    /// Time (`t`, s), 0 if not given.
    pub t: f64,
    /// Blend radius (`r`, m), 0 if none.
    pub r: f64,
}

/// How a move or stream ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[non_exhaustive]
pub enum MoveOutcome {
    /// The arm reached the target and stopped there (a servo stream: its last target).
    Reached,
    /// The next move took over in the blend before the target.
    Blended,
    /// `stopj` or `stopl` stopped it.
    Stopped,
    /// A protective stop (`protective_stop()`, or the path left the arm's reach).
    ProtectiveStop,
    /// Another motion command (of another kind, or from another thread) replaced it.
    Replaced,
    /// The program (or the thread that commanded it) stopped, or the move was aborted.
    Halted,
}

impl MoveOutcome {
    /// The outcome's name in `ursock`'s output: `reached`, `blended`, `stopped`,
    /// `protective-stop`, `replaced`, `halted`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Reached => "reached",
            Self::Blended => "blended",
            Self::Stopped => "stopped",
            Self::ProtectiveStop => "protective-stop",
            Self::Replaced => "replaced",
            Self::Halted => "halted",
        }
    }
}

/// A move or stream's end.
#[derive(Debug, Clone, PartialEq)]
pub struct MoveEnd {
    /// The line of the command that started it.
    pub line: u32,
    /// Its function.
    pub function: &'static str,
    /// How it ended.
    pub outcome: MoveOutcome,
    /// Program time it ended.
    pub at: std::time::Duration,
    /// How long it took (from its start).
    pub took: std::time::Duration,
    /// How many commands it was: 1 for a move, the number of `servoj`/`speedj`...
    /// calls for a stream.
    pub samples: u64,
    /// The joints (rad) where it ended.
    pub q: [f64; 6],
    /// The tool pose where it ended.
    pub pose: [f64; 6],
}

/// An output a program changed.
#[derive(Debug, Clone, PartialEq)]
pub struct OutputWrite {
    /// The line of the call.
    pub line: u32,
    /// The function (`set_standard_digital_out`...).
    pub function: &'static str,
    /// Which output: the pin as the function numbers it.
    pub pin: i64,
    /// Its new value.
    pub value: OutputValue,
}

/// A digital or analog output's value.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum OutputValue {
    /// A digital output.
    Digital(bool),
    /// An analog output (fraction of its range, as `set_standard_analog_out` takes it).
    Analog(f64),
}

/// Which function showed a [`Message`].
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum MessageKind {
    /// `textmsg(s1, s2="")`: the log line.
    Textmsg,
    /// `varmsg(name, value)`.
    Varmsg,
    /// `popup(s, title, warning, error, blocking)`.
    Popup {
        /// The popup's title.
        title: String,
        /// Shown as a warning.
        warning: bool,
        /// Shown as an error.
        error: bool,
        /// The program would wait for the operator (the virtual operator closes it at
        /// once).
        blocking: bool,
    },
    /// Not a function: the controller's warning that a move's blend radius `r` was
    /// reduced, because its blend would overlap the previous one (UR: blends may not
    /// overlap; the controller logs a warning) or the move is shorter than `r`. The line
    /// is the move's; `args` is empty.
    BlendRadiusReduced {
        /// The radius the move asked for (m).
        requested: f64,
        /// The radius it blends with (m); 0: it does not blend.
        reduced: f64,
    },
}

/// A message the program showed (PolyScope's log or a popup).
#[derive(Debug, Clone, PartialEq)]
pub struct Message {
    /// The line of the call.
    pub line: u32,
    /// Which function.
    pub kind: MessageKind,
    /// The text, as the controller composes it (`textmsg("x = ", 1)` shows `x = 1`).
    pub text: String,
    /// The call's arguments as given (for a printer that shows the call).
    pub args: Vec<Value>,
}

/// How a recorded call ended.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Outcome {
    /// It returned normally (a read whose bytes arrived, a send that was queued).
    Returned,
    /// A read's timeout passed (or its socket closed) first: the result is what the
    /// robot returns then, its sentinel or a partial result by the socket policy.
    TimedOut,
    /// A stub answered ([`Config::stub`](crate::Config::stub)); nothing else ran.
    Stubbed,
    /// It returned its failure value (`False`) for this reason: a connection refused, a
    /// socket that is not open, a broken connection.
    Failed(String),
}

/// The most bytes of a read's input a [`ReadRecord`] keeps.
pub const MAX_READ_INPUT: usize = 4096;

/// A socket read a call made, and the robot model's typed result.
#[derive(Debug, Clone, PartialEq)]
pub struct ReadRecord {
    /// The read rule used (function and arguments).
    pub call: ReadCall,
    /// What the robot model returned, before it became a URScript value.
    pub result: ReadResult,
    /// What the read saw: the bytes buffered on its socket when it started, then those
    /// that arrived while it waited (the first [`MAX_READ_INPUT`]). A diagnosis of a
    /// failed read starts here.
    pub input: Vec<u8>,
    /// How many bytes of `input` were already buffered when the read started (data that
    /// was waiting: a late reply to an earlier read, or what an earlier read left).
    pub buffered_at_start: usize,
}

/// One call of a built-in or a stub, as the machine ran it.
#[derive(Debug, Clone, PartialEq)]
pub struct CallRecord {
    /// The line of the call.
    pub line: u32,
    /// The column of the call's name.
    pub column: u32,
    /// The function's name.
    pub name: String,
    /// The built-in's table entry (`None` for a stub of a name that is not built in, and
    /// for an XML-RPC call, named `rpc_factory("xmlrpc", "URL").method` with the socket
    /// `rpc:URL`).
    pub builtin: Option<&'static Builtin>,
    /// Positional arguments, as evaluated.
    pub args: Vec<Value>,
    /// Named arguments, as evaluated, in the order written.
    pub kwargs: Vec<(String, Value)>,
    /// The variable the statement assigns the result to, when the statement is
    /// `name = call(...)`.
    pub assigned_to: Option<String>,
    /// What the call returned to the program.
    pub result: Value,
    /// How it ended.
    pub outcome: Outcome,
    /// The socket it used (its `socket_name` argument, default included).
    pub socket: Option<String>,
    /// The read it made, for the socket read functions and `socket_get_var`.
    pub read: Option<ReadRecord>,
}

impl CallRecord {
    /// The call as URScript source with its evaluated arguments:
    /// `socket_read_ascii_float(6, "camera")`.
    ///
    /// ```
    /// use urscript_interp::{CallRecord, Outcome, Value};
    /// let c = CallRecord {
    ///     line: 1, column: 1, name: "f".into(), builtin: None,
    ///     args: vec![Value::Int(1)], kwargs: vec![("k".into(), Value::Str(b"v".to_vec()))],
    ///     assigned_to: None, result: Value::None, outcome: Outcome::Stubbed,
    ///     socket: None, read: None,
    /// };
    /// assert_eq!(c.source(), r#"f(1, k="v")"#);
    /// ```
    pub fn source(&self) -> String {
        let mut out = String::with_capacity(self.name.len() + 16);
        out.push_str(&self.name);
        out.push('(');
        let mut first = true;
        let mut sep = |out: &mut String| {
            if !std::mem::take(&mut first) {
                out.push_str(", ");
            }
        };
        for a in &self.args {
            sep(&mut out);
            out.push_str(&a.to_source());
        }
        for (k, v) in &self.kwargs {
            sep(&mut out);
            out.push_str(k);
            out.push('=');
            out.push_str(&v.to_source());
        }
        out.push(')');
        out
    }
}

/// `name(args) -> result`, with ` (timeout)`, ` (stub)` or ` (failed: why)` after it.
impl fmt::Display for CallRecord {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} -> {}", self.source(), self.result)?;
        match &self.outcome {
            Outcome::Returned => Ok(()),
            Outcome::TimedOut => f.write_str(" (timeout)"),
            Outcome::Stubbed => f.write_str(" (stub)"),
            Outcome::Failed(why) => write!(f, " ({why})"),
        }
    }
}
