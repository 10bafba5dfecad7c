//! What the machine and a built-in's code exchange: the table entry ([`Builtin`]: name,
//! chapter, parameters with their defaults, the code), the arguments bound to the
//! parameters (`Args`), and what the code returns (`Out`: a value, or a wait for time,
//! motion, bytes or a connection). The table itself and the code are in
//! [`crate::builtins`]; the machine ([`crate::machine`]) calls an entry's code with the
//! [`Runtime`] and its `Args`. Nothing here knows the table.

use std::time::Duration;

use crate::error::Fault;
use crate::runtime::Runtime;
use crate::value::Value;

/// The manual's chapter a built-in belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Domain {
    /// `socket_*`.
    Sockets,
    /// Motion, the arm's state and settings.
    Motion,
    /// I/O and registers.
    Io,
    /// Math.
    Math,
    /// Strings and lists.
    Strings,
    /// Poses and kinematics.
    Poses,
    /// Messages to the operator and the log.
    Messages,
    /// Threads and time.
    Time,
    /// Interpreter mode.
    Interpreter,
}

/// A parameter's default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Default {
    /// No default: the argument must be given.
    Required,
    /// Optional without a value (the function behaves differently when it is left out).
    Absent,
    /// An int.
    Int(i32),
    /// A float.
    Float(f64),
    /// A bool.
    Bool(bool),
    /// A string.
    Str(&'static str),
    /// A list of floats.
    Floats(&'static [f64]),
    /// A list of ints.
    Ints(&'static [i32]),
    /// A pose.
    Pose([f64; 6]),
}

impl Default {
    /// The value an argument left out takes (`None` for a required one).
    pub fn value(&self) -> Option<Value> {
        Some(match *self {
            Default::Required => return None,
            Default::Absent => Value::None,
            Default::Int(i) => Value::Int(i),
            Default::Float(f) => Value::Float(f),
            Default::Bool(b) => Value::Bool(b),
            Default::Str(s) => Value::Str(s.as_bytes().to_vec()),
            Default::Floats(v) => Value::List(v.iter().map(|&x| Value::Float(x)).collect()),
            Default::Ints(v) => Value::List(v.iter().map(|&x| Value::Int(x)).collect()),
            Default::Pose(p) => Value::Pose(p),
        })
    }
}

/// One parameter of a built-in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Param {
    /// Its name, as keyword arguments use it.
    pub name: &'static str,
    /// Its default.
    pub default: Default,
}

/// What a built-in's code returns to the machine.
pub(crate) enum Out {
    /// Returns this value now.
    Value(Value),
    /// Takes this much program time (at least one step), then returns the value.
    Wait(Duration, Value),
    /// Waits until the motion clock (steps; see `crate::runtime::MotionClock`) reaches
    /// this (at least one step), then returns the value: a motion's end at the speed
    /// slider's fraction.
    Motion(f64, Value),
    /// A socket read waiting for bytes (started in the socket model).
    Read {
        socket: String,
        call: urscript_socket::robot::ReadCall,
        /// What the read saw so far (the bytes buffered when it started).
        input: Vec<u8>,
        buffered_at_start: usize,
    },
    /// `socket_open`, waiting for the driver's answer.
    Connect { socket: String },
    /// Interpreter mode: the machine acts on the program's queue of interpreted
    /// statements (and refuses what the mode's state does not allow).
    Interpreter(InterpreterRequest),
}

/// What an interpreter-mode built-in asks of the machine.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum InterpreterRequest {
    /// `interpreter_mode(clearQueueOnEnter, clearOnEnd)`.
    Enter {
        clear_queue: bool,
        clear_on_end: bool,
    },
    /// `end_interpreter()`.
    End,
    /// `clear_interpreter()`.
    Clear,
}

/// The code of a built-in.
pub(crate) type Handler = fn(&mut Runtime, &mut Args) -> Result<Out, Fault>;

/// A built-in function: one entry of the table.
#[derive(Clone, Copy)]
pub struct Builtin {
    /// Its URScript name.
    pub name: &'static str,
    /// Its chapter.
    pub domain: Domain,
    /// Its parameters, in order.
    pub params: &'static [Param],
    /// What it does here, in one sentence.
    pub summary: &'static str,
    pub(crate) run: Handler,
}

impl Builtin {
    pub(crate) const fn new(
        name: &'static str,
        domain: Domain,
        params: &'static [Param],
        summary: &'static str,
        run: Handler,
    ) -> Self {
        Builtin {
            name,
            domain,
            params,
            summary,
            run,
        }
    }

    /// The index of parameter `name`.
    pub fn param(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|p| p.name == name)
    }

    /// The signature as the manual writes it: `socket_open(address, port, socket_name="socket_0")`.
    ///
    /// ```
    /// let b = urscript_interp::builtins::lookup("socket_read_line").unwrap();
    /// assert_eq!(b.signature(), r#"socket_read_line(socket_name="socket_0", timeout=2.0)"#);
    /// ```
    pub fn signature(&self) -> String {
        let params: Vec<String> = self
            .params
            .iter()
            .map(|p| match p.default.value() {
                None => p.name.to_string(),
                Some(Value::None) => format!("{}=None", p.name),
                // As Rust writes it shortest: 20.0, 0.8, 1e-10.
                Some(Value::Float(f)) => format!("{}={f:?}", p.name),
                Some(v) => format!("{}={}", p.name, v.to_source()),
            })
            .collect();
        format!("{}({})", self.name, params.join(", "))
    }
}

impl std::fmt::Debug for Builtin {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Builtin")
            .field("name", &self.name)
            .field("domain", &self.domain)
            .finish_non_exhaustive()
    }
}

/// Two entries are the same built-in if they have the same name (names are unique).
impl PartialEq for Builtin {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

/// A built-in call's arguments, bound to its parameters (defaults filled), and what the
/// code reports besides its value.
pub(crate) struct Args {
    /// The built-in's name (for error messages).
    pub name: &'static str,
    /// The built-in's parameters.
    pub params: &'static [Param],
    /// One value per parameter; the entry's code gets them converted (see
    /// [`builtin!`]) and finds this empty.
    pub v: Vec<Value>,
    /// How many arguments were given by position (the first `positional` of `v`).
    pub positional: usize,
    /// The line of the call.
    pub line: u32,
    /// A read that completed at once (for the call record).
    pub read: Option<crate::event::ReadRecord>,
    /// Why the call returned its failure value.
    pub failure: Option<String>,
    /// The call is recorded: keep what a read sees.
    pub traced: bool,
}

/// The type error for argument `i` of the call `a`, whose value `v` is not `what`.
pub(crate) fn bad_arg(a: &Args, v: &Value, i: usize, what: &str) -> Fault {
    Fault::type_error(format!(
        "type error: `{}` argument `{}` needs {what}, got {} {}",
        a.name,
        a.params.get(i).map_or("?", |p| p.name),
        v.type_name(),
        v.to_source()
    ))
}

/// `k` as an index into `0..n`, or the error of the call `a` (`what` names the thing
/// indexed).
pub(crate) fn index(a: &Args, k: i32, n: usize, what: &str) -> Result<usize, Fault> {
    usize::try_from(k).ok().filter(|k| *k < n).ok_or_else(|| {
        Fault::from(format!(
            "`{}`: no {what} {k} (0-{})",
            a.name,
            n.saturating_sub(1)
        ))
    })
}

/// A URScript argument as the Rust type a built-in's code takes: what [`builtin!`]
/// converts each argument with, before the code runs. The conversion borrows from the
/// argument where it can (`&Value`, `&[u8]`, `&[Value]`).
pub(crate) trait FromArg<'v>: Sized {
    /// `v`, argument `i` of the call `a`, as this type; a type error naming the
    /// parameter otherwise.
    fn from_arg(a: &Args, v: &'v Value, i: usize) -> Result<Self, Fault>;
}

/// Any value.
impl<'v> FromArg<'v> for &'v Value {
    fn from_arg(_: &Args, v: &'v Value, _: usize) -> Result<Self, Fault> {
        Ok(v)
    }
}

/// Any value, copied (for code that keeps it).
impl FromArg<'_> for Value {
    fn from_arg(_: &Args, v: &Value, _: usize) -> Result<Self, Fault> {
        Ok(v.clone())
    }
}

/// A number (an int or a float).
impl FromArg<'_> for f64 {
    fn from_arg(a: &Args, v: &Value, i: usize) -> Result<Self, Fault> {
        v.as_f64().ok_or_else(|| bad_arg(a, v, i, "a number"))
    }
}

/// An int (a float with no fraction is accepted).
impl FromArg<'_> for i32 {
    fn from_arg(a: &Args, v: &Value, i: usize) -> Result<Self, Fault> {
        match v {
            Value::Int(x) => Ok(*x),
            Value::Float(x) if x.fract() == 0.0 && x.abs() <= f64::from(i32::MAX) => Ok(*x as i32),
            _ => Err(bad_arg(a, v, i, "an int")),
        }
    }
}

/// A bool (an int: non-zero is true).
impl FromArg<'_> for bool {
    fn from_arg(a: &Args, v: &Value, i: usize) -> Result<Self, Fault> {
        match v {
            Value::Bool(b) => Ok(*b),
            Value::Int(x) => Ok(*x != 0),
            _ => Err(bad_arg(a, v, i, "a bool")),
        }
    }
}

/// A string's bytes.
impl<'v> FromArg<'v> for &'v [u8] {
    fn from_arg(a: &Args, v: &'v Value, i: usize) -> Result<Self, Fault> {
        match v {
            Value::Str(s) => Ok(s),
            _ => Err(bad_arg(a, v, i, "a string")),
        }
    }
}

/// A string as text (a socket or variable name; bytes that are not UTF-8 become U+FFFD).
impl FromArg<'_> for String {
    fn from_arg(a: &Args, v: &Value, i: usize) -> Result<Self, Fault> {
        let bytes: &[u8] = FromArg::from_arg(a, v, i)?;
        Ok(String::from_utf8_lossy(bytes).into_owned())
    }
}

/// A list's items.
impl<'v> FromArg<'v> for &'v [Value] {
    fn from_arg(a: &Args, v: &'v Value, i: usize) -> Result<Self, Fault> {
        match v {
            Value::List(items) => Ok(items),
            _ => Err(bad_arg(a, v, i, "a list")),
        }
    }
}

/// `N` numbers: a list of `N` numbers, or a pose when `N` is 6.
impl<const N: usize> FromArg<'_> for [f64; N] {
    fn from_arg(a: &Args, v: &Value, i: usize) -> Result<Self, Fault> {
        let what = || bad_arg(a, v, i, &format!("{N} numbers"));
        let mut out = [0.0; N];
        match v {
            Value::Pose(p) if N == 6 => out.copy_from_slice(p),
            Value::List(items) if items.len() == N => {
                for (o, x) in out.iter_mut().zip(items) {
                    *o = x.as_f64().ok_or_else(what)?;
                }
            }
            _ => return Err(what()),
        }
        Ok(out)
    }
}

/// An argument whose default is [`Default::Absent`]: `None` when it was left out.
impl<'v, T: FromArg<'v>> FromArg<'v> for Option<T> {
    fn from_arg(a: &Args, v: &'v Value, i: usize) -> Result<Self, Fault> {
        match v {
            Value::None => Ok(None),
            v => T::from_arg(a, v, i).map(Some),
        }
    }
}

/// A parameter's URScript name from its Rust name (`r#type` is `type`).
pub(crate) const fn param_name(rust: &'static str) -> &'static str {
    match rust.as_bytes() {
        [b'r', b'#', rest @ ..] => match core::str::from_utf8(rest) {
            Ok(name) => name,
            Err(_) => rust,
        },
        _ => rust,
    }
}

/// One table entry, its signature declared once: the built-in's URScript name, each
/// parameter's name, the Rust type its argument converts to ([`FromArg`]) and its
/// default (a [`Default`] variant, none if it is required), the code, and what it does
/// in one sentence. The entry's domain is the calling module's `D`.
///
/// The code is called as `code(runtime, args, p1, p2, ...)` with every argument
/// converted; an argument of the wrong type is a type error naming its parameter,
/// before the code runs.
///
/// ```ignore
/// builtin!(sleep(t: f64) => sleep, "Waits t seconds of program time."),
/// builtin!(time(mode: i32 = Int(0)) => time, "The time as struct(sec, nanosec)."),
/// builtin!(socket_close(socket_name: String = Str("socket_0")) => close, "Closes it."),
/// builtin!(movel(pose: [f64; 6], a: f64 = Float(1.2)) => |c, x, p, a| go(c, x, Kind::Line, p, a), "..."),
/// ```
macro_rules! builtin {
    (@default) => {
        $crate::native::Default::Required
    };
    (@default $kind:ident $(($($v:tt)*))?) => {
        $crate::native::Default::$kind $(($($v)*))?
    };
    (
        $name:ident ( $($p:ident : $t:ty $(= $kind:ident $(($($v:tt)*))?)?),* $(,)? )
        => $code:expr, $summary:literal $(,)?
    ) => {
        $crate::native::Builtin::new(
            stringify!($name),
            D,
            &[$($crate::native::Param {
                name: $crate::native::param_name(stringify!($p)),
                default: $crate::native::builtin!(@default $($kind $(($($v)*))?)?),
            }),*],
            $summary,
            |c, a| {
                let v = ::core::mem::take(&mut a.v);
                #[allow(unused_labels)]
                let out = 'call: {
                    let _args = &mut v
                        .iter()
                        .chain(::core::iter::repeat(&$crate::value::Value::None))
                        .enumerate();
                    $(
                        let (k, x) = _args.next().unwrap_or((0, &$crate::value::Value::None));
                        #[allow(non_snake_case)]
                        let $p: $t = match $crate::native::FromArg::from_arg(a, x, k) {
                            Ok(p) => p,
                            Err(e) => break 'call Err(e),
                        };
                    )*
                    ($code)(c, &mut *a, $($p),*)
                };
                a.v = v;
                out
            },
        )
    };
}
pub(crate) use builtin;
