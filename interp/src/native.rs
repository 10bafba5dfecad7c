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
    /// One value per parameter.
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

impl Args {
    pub(crate) fn bad(&self, i: usize, what: &str) -> Fault {
        let v = &self.v[i];
        Fault::type_error(format!(
            "type error: `{}` argument `{}` needs {what}, got {} {}",
            self.name,
            self.params.get(i).map_or("?", |p| p.name),
            v.type_name(),
            v.to_source()
        ))
    }

    /// Argument `i` as a number (an int or a float).
    pub fn num(&self, i: usize) -> Result<f64, Fault> {
        self.v[i].as_f64().ok_or_else(|| self.bad(i, "a number"))
    }

    /// Argument `i` as an int (a float with no fraction is accepted).
    pub fn int(&self, i: usize) -> Result<i32, Fault> {
        match &self.v[i] {
            Value::Int(x) => Ok(*x),
            Value::Float(x) if x.fract() == 0.0 && x.abs() <= f64::from(i32::MAX) => Ok(*x as i32),
            _ => Err(self.bad(i, "an int")),
        }
    }

    /// Argument `i` as a string's bytes.
    pub fn bytes(&self, i: usize) -> Result<&[u8], Fault> {
        match &self.v[i] {
            Value::Str(s) => Ok(s),
            _ => Err(self.bad(i, "a string")),
        }
    }

    /// Argument `i` as text (a socket or variable name).
    pub fn text(&self, i: usize) -> Result<String, Fault> {
        Ok(String::from_utf8_lossy(self.bytes(i)?).into_owned())
    }

    /// Argument `i` as a bool (an int: non-zero is true).
    pub fn boolean(&self, i: usize) -> Result<bool, Fault> {
        match &self.v[i] {
            Value::Bool(b) => Ok(*b),
            Value::Int(x) => Ok(*x != 0),
            _ => Err(self.bad(i, "a bool")),
        }
    }

    /// Argument `i` as six numbers (a pose or a list of 6 numbers).
    pub fn six(&self, i: usize) -> Result<[f64; 6], Fault> {
        match &self.v[i] {
            Value::Pose(p) => Ok(*p),
            Value::List(items) if items.len() == 6 => {
                let mut out = [0.0; 6];
                for (o, x) in out.iter_mut().zip(items) {
                    *o = x.as_f64().ok_or_else(|| self.bad(i, "6 numbers"))?;
                }
                Ok(out)
            }
            _ => Err(self.bad(i, "6 numbers")),
        }
    }

    /// Argument `i` as a list of numbers of length `n` (a pose when `n` is 6).
    pub fn nums<const N: usize>(&self, i: usize) -> Result<[f64; N], Fault> {
        let what = format!("{N} numbers");
        let items: Vec<f64> = match &self.v[i] {
            Value::Pose(p) => p.to_vec(),
            Value::List(items) => items
                .iter()
                .map(Value::as_f64)
                .collect::<Option<Vec<f64>>>()
                .ok_or_else(|| self.bad(i, &what))?,
            _ => return Err(self.bad(i, &what)),
        };
        items.try_into().map_err(|_| self.bad(i, &what))
    }

    /// Argument `i` as an index into `0..n` (`what` names the thing indexed).
    pub fn index(&self, i: usize, n: usize, what: &str) -> Result<usize, Fault> {
        let k = self.int(i)?;
        usize::try_from(k)
            .ok()
            .filter(|k| *k < n)
            .ok_or_else(|| Fault::from(format!("`{}`: no {what} {k} (0-{})", self.name, n - 1)))
    }

    /// Argument `i` was left out (its default is [`Default::Absent`]).
    pub fn is_absent(&self, i: usize) -> bool {
        matches!(self.v[i], Value::None)
    }
}
