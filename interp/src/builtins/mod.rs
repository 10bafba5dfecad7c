//! The built-in functions: **one table**, one entry per function (name, parameters with
//! their defaults, what it does, the code), grouped in modules by domain as UR's script
//! manual groups them. The compiler resolves a call to its entry once and checks its
//! arguments (count, names) with line and column before anything runs; the machine then
//! calls the entry's code with the arguments bound, defaults filled.
//!
//! Adding a built-in is one entry in its domain's `TABLE` (and its function beside it).
//!
//! | module | what |
//! | --- | --- |
//! | [`sockets`] | every `socket_*` function of the e-Series 5.x manual |
//! | [`motion`] | moves, servo/speed control, the arm's state, settings of the arm |
//! | [`dynamics`] | the arm's model: Jacobians, mass matrix, Coriolis torques, joint accelerations, `estimate_payload` |
//! | [`conveyor`] | conveyor tracking and its encoders (the motion chapter; no conveyor) |
//! | [`io`] | digital/analog I/O, tool I/O, flags, the RTDE registers, Modbus, I/O configuration |
//! | [`rtde`] | `get_rtde_value`: RTDE output fields from the virtual arm's state |
//! | [`math`] | numbers, lists of numbers, matrices (`inv`, `transpose`), bits, `random` |
//! | [`strings`] | strings, `to_str`/`to_num`, list length, `size`, `make_list` |
//! | [`poses`] | pose arithmetic, rotation vectors and RPY, wrenches, kinematics |
//! | [`rpc`] | `rpc_factory`: XML-RPC handles (the Interfaces chapter) |
//! | [`eip`] | `eip_reader_factory`, `eip_writer_factory`: the Flexible EtherNet/IP Adapter's handles |
//! | [`messages`] | `textmsg`, `varmsg`, `popup` |
//! | [`time`] | `sync`, `sleep`, `get_steptime`, `time` |
//! | [`interpreter`] | `interpreter_mode`, `end_interpreter`, `clear_interpreter` |
//! | [`world_model`] | named frames: `add_frame`, `attach_frame`, `get_pose`, `convert_pose`, ... |
//!
//! ## The virtual arm
//! The arm follows each motion command step by step (kinematics and speed profiles, not
//! dynamics), and the I/O around it holds what the program set: see [`motion`] and
//! [`io`] for what each function does to it.

use std::sync::OnceLock;
use std::time::Duration;

use crate::controller::Controller;
use crate::error::Fault;
use crate::value::Value;

pub mod conveyor;
pub mod dynamics;
pub mod eip;
pub mod interpreter;
pub mod io;
pub mod math;
pub mod messages;
pub mod motion;
pub mod poses;
pub mod rpc;
pub mod rtde;
pub mod sockets;
pub mod strings;
pub mod time;
pub mod world_model;

pub use strings::MAX_STRING_LEN;

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

/// A required parameter.
pub(crate) const fn req(name: &'static str) -> Param {
    Param {
        name,
        default: Default::Required,
    }
}

/// An optional parameter with this default.
pub(crate) const fn opt(name: &'static str, default: Default) -> Param {
    Param { name, default }
}

/// The `socket_name="socket_0"` parameter every socket function has.
pub(crate) const SOCKET_NAME: Param = opt("socket_name", Default::Str("socket_0"));

/// What a built-in's code returns to the machine.
pub(crate) enum Out {
    /// Returns this value now.
    Value(Value),
    /// Takes this much program time (at least one step), then returns the value.
    Wait(Duration, Value),
    /// Waits until the motion clock (steps; see `crate::controller::MotionClock`) reaches
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
pub(crate) type Handler = fn(&mut Controller, &mut Args) -> Result<Out, Fault>;

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

/// Every built-in, sorted by name (names are unique: a test proves it).
///
/// ```
/// let all = urscript_interp::builtins::all();
/// assert!(all.iter().any(|b| b.name == "socket_read_ascii_float"));
/// assert!(all.windows(2).all(|w| w[0].name < w[1].name));
/// ```
pub fn all() -> &'static [Builtin] {
    static ALL: OnceLock<Vec<Builtin>> = OnceLock::new();
    ALL.get_or_init(|| {
        let mut v: Vec<Builtin> = [
            sockets::TABLE,
            motion::TABLE,
            conveyor::TABLE,
            dynamics::TABLE,
            eip::TABLE,
            io::TABLE,
            math::TABLE,
            strings::TABLE,
            poses::TABLE,
            rpc::TABLE,
            rtde::TABLE,
            messages::TABLE,
            time::TABLE,
            interpreter::TABLE,
            world_model::TABLE,
        ]
        .concat();
        v.sort_by(|a, b| a.name.cmp(b.name));
        v
    })
}

/// The built-in called `name`.
///
/// ```
/// use urscript_interp::builtins::{lookup, Domain};
/// assert_eq!(lookup("socket_open").unwrap().domain, Domain::Sockets);
/// assert!(lookup("rq_activate").is_none()); // a URCap's function, not the controller's
/// ```
pub fn lookup(name: &str) -> Option<&'static Builtin> {
    let all = all();
    all.binary_search_by(|b| b.name.cmp(name))
        .ok()
        .map(|i| &all[i])
}

/// The built-in or `other` name nearest `name` by edit distance (insertions, deletions,
/// substitutions and swaps of neighbours), if one is near enough to be a typo: at most
/// one edit per three characters of `name` (one at least). Ties go to the built-in, then
/// the first in order.
///
/// ```
/// use urscript_interp::builtins::nearest_name;
/// assert_eq!(nearest_name("movjj", ["pick"]), Some("movej".to_string()));
/// assert_eq!(nearest_name("pikc", ["pick"]), Some("pick".to_string()));
/// assert_eq!(nearest_name("zzzzzz", ["pick"]), None);
/// ```
pub fn nearest_name<'a>(name: &str, other: impl IntoIterator<Item = &'a str>) -> Option<String> {
    /// Names longer than this are not compared (the distance table is its square).
    const MAX_LEN: usize = 64;
    if name.is_empty() || name.len() > MAX_LEN {
        return None;
    }
    let limit = (name.chars().count() / 3).max(1);
    let mut best: Option<(usize, &str)> = None;
    let candidates = all().iter().map(|b| b.name).chain(other);
    for c in candidates {
        if c == name || c.len() > MAX_LEN || c.len().abs_diff(name.len()) > limit {
            continue;
        }
        let d = edit_distance(name, c);
        if d <= limit && best.is_none_or(|(bd, _)| d < bd) {
            best = Some((d, c));
        }
    }
    best.map(|(_, c)| c.to_string())
}

/// The optimal string alignment distance of `a` and `b` (by characters).
fn edit_distance(a: &str, b: &str) -> usize {
    let a: Vec<char> = a.chars().collect();
    let b: Vec<char> = b.chars().collect();
    let w = b.len() + 1;
    let mut d = vec![0usize; (a.len() + 1) * w];
    for i in 0..=a.len() {
        d[i * w] = i;
    }
    for (j, x) in d.iter_mut().enumerate().take(w) {
        *x = j;
    }
    for i in 1..=a.len() {
        for j in 1..=b.len() {
            let cost = usize::from(a[i - 1] != b[j - 1]);
            let mut v = (d[(i - 1) * w + j] + 1)
                .min(d[i * w + j - 1] + 1)
                .min(d[(i - 1) * w + j - 1] + cost);
            if i > 1 && j > 1 && a[i - 1] == b[j - 2] && a[i - 2] == b[j - 1] {
                v = v.min(d[(i - 2) * w + j - 2] + 1);
            }
            d[i * w + j] = v;
        }
    }
    d[a.len() * w + b.len()]
}

/// True if `name` is a built-in of this interpreter.
///
/// ```
/// assert!(urscript_interp::builtins::is_builtin("socket_read_ascii_float"));
/// assert!(!urscript_interp::builtins::is_builtin("rq_activate"));
/// ```
pub fn is_builtin(name: &str) -> bool {
    lookup(name).is_some()
}

/// Checks a call's arguments against parameters at compile time: `positional` given by
/// position, then `named` by name. Returns, for each argument in order, the index of the
/// parameter it fills; or what is wrong.
pub(crate) fn match_args<'p>(
    fname: &str,
    params: impl ExactSizeIterator<Item = (&'p str, bool)> + Clone,
    positional: usize,
    named: &[&str],
) -> Result<Vec<u8>, String> {
    let n = params.len();
    if positional > n {
        return Err(format!(
            "`{fname}` takes {} {n} argument{}, {positional} given",
            if params.clone().any(|(_, has_default)| has_default) {
                "at most"
            } else {
                "exactly"
            },
            if n == 1 { "" } else { "s" }
        ));
    }
    let mut filled = vec![false; n];
    let mut slots = Vec::with_capacity(positional + named.len());
    for (k, f) in filled.iter_mut().enumerate().take(positional) {
        *f = true;
        slots.push(k as u8);
    }
    for k in named {
        let Some(at) = params.clone().position(|(p, _)| p == *k) else {
            let names: Vec<&str> = params.clone().map(|(p, _)| p).collect();
            return Err(format!(
                "`{fname}` has no parameter `{k}` (its parameters: {})",
                if names.is_empty() {
                    "none".to_string()
                } else {
                    names.join(", ")
                }
            ));
        };
        if filled[at] {
            return Err(format!("argument `{k}` of `{fname}` given twice"));
        }
        filled[at] = true;
        slots.push(at as u8);
    }
    for ((p, has_default), f) in params.zip(&filled) {
        if !f && !has_default {
            return Err(format!("`{fname}` needs argument `{p}`"));
        }
    }
    Ok(slots)
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
    fn bad(&self, i: usize, what: &str) -> Fault {
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

/// Six floats as a URScript list.
pub(crate) fn floats(v: [f64; 6]) -> Value {
    Value::List(v.iter().map(|&x| Value::Float(x)).collect())
}

/// Floats as a URScript list.
pub(crate) fn float_list(v: &[f64]) -> Value {
    Value::List(v.iter().map(|&x| Value::Float(x)).collect())
}

/// Seconds as a duration (negative: zero; too large: the longest).
pub(crate) fn secs(x: f64) -> Duration {
    Duration::try_from_secs_f64(x.max(0.0)).unwrap_or(Duration::MAX)
}

/// Does nothing and returns nothing: settings the virtual arm has no use for.
pub(crate) fn accept(_: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::None))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_are_unique_and_every_default_is_a_value() {
        let all = all();
        for w in all.windows(2) {
            assert_ne!(w[0].name, w[1].name, "defined twice");
        }
        for b in all {
            let mut seen_default = false;
            for p in b.params {
                let has = p.default != Default::Required;
                assert!(
                    has || !seen_default,
                    "{}: required `{}` after an optional one",
                    b.name,
                    p.name
                );
                seen_default |= has;
            }
            assert!(!b.summary.is_empty(), "{} has no summary", b.name);
            assert!(b.params.len() < 256);
        }
    }

    /// Calls built-in `name` on `c` with these positional arguments (defaults after).
    fn call(c: &mut Controller, name: &str, args: Vec<Value>) -> Value {
        let b = lookup(name).unwrap();
        let positional = args.len();
        let mut v: Vec<Value> = b
            .params
            .iter()
            .map(|p| p.default.value().unwrap_or(Value::None))
            .collect();
        for (slot, x) in v.iter_mut().zip(args) {
            *slot = x;
        }
        let mut a = Args {
            name: b.name,
            params: b.params,
            v,
            positional,
            line: 1,
            read: None,
            failure: None,
            traced: false,
        };
        match (b.run)(c, &mut a) {
            Ok(Out::Value(v) | Out::Wait(_, v) | Out::Motion(_, v)) => v,
            Ok(_) => panic!("{name} waits for a socket"),
            Err(e) => panic!("{name}: {e:?}"),
        }
    }

    /// What the robot measures of the world is a field of the virtual arm: the built-ins
    /// read what a test sets there.
    #[test]
    fn the_worlds_values_are_fields_a_test_sets() {
        let mut c = Controller {
            dh: crate::kinematics::Model::Ur5e.dh(),
            step_time: Duration::from_millis(2),
            step: 0,
            arm: crate::controller::Arm::default(),
            sockets: crate::sockets::Sockets::new(crate::sockets::Policy::default()),
            events: crate::memory::Events::default(),
            mem: crate::memory::Memory::new(crate::memory::DEFAULT_MAX_MEMORY),
            motion: None,
            thread: 0,
            sampled: None,
            eip: crate::eip::Handles::default(),
            rtde_watchdogs: Vec::new(),
            tracked: None,
            queued: None,
            clock: crate::controller::MotionClock::default(),
            contact_since: None,
            joint_history: crate::history::JointHistory::default(),
        };
        // The documented defaults.
        assert_eq!(
            call(&mut c, "get_joint_temp", vec![Value::Int(2)]),
            Value::Float(35.0)
        );
        assert_eq!(
            call(&mut c, "get_controller_temp", vec![]),
            Value::Float(30.0)
        );
        assert_eq!(call(&mut c, "get_tool_temp", vec![]), Value::Float(32.0));
        assert_eq!(call(&mut c, "get_tool_current", vec![]), Value::Float(0.0));
        let arm = &mut c.arm;
        arm.world.joint_temp[2] = 61.5;
        arm.world.controller_temp = 41.0;
        arm.world.tool_temp = 45.0;
        arm.world.tool_current = 0.6;
        arm.world.joint_torques = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        arm.world.tcp_force = [3.0, 0.0, 4.0, 0.0, 0.0, 0.5];
        arm.world.digital_in[16 + 1] = true; // tool input 1
        arm.world.digital_in[8 + 2] = true; // configurable input 2
        arm.world.analog_in[1] = 4.5;
        arm.world.input_int_regs[24] = 7;
        arm.world.input_float_regs[47] = 2.5;
        arm.world.input_bool_regs[127] = true;
        arm.world.operator_int = 12;
        arm.world.operator_string = b"part A".to_vec();
        assert_eq!(
            call(&mut c, "get_joint_temp", vec![Value::Int(2)]),
            Value::Float(61.5)
        );
        assert_eq!(
            call(&mut c, "get_controller_temp", vec![]),
            Value::Float(41.0)
        );
        assert_eq!(call(&mut c, "get_tool_temp", vec![]), Value::Float(45.0));
        assert_eq!(call(&mut c, "get_tool_current", vec![]), Value::Float(0.6));
        assert_eq!(
            call(&mut c, "get_joint_torques", vec![]),
            floats([1.0, 2.0, 3.0, 4.0, 5.0, 6.0])
        );
        assert_eq!(
            call(&mut c, "get_tcp_force", vec![]),
            Value::Pose([3.0, 0.0, 4.0, 0.0, 0.0, 0.5])
        );
        assert_eq!(call(&mut c, "force", vec![]), Value::Float(5.0));
        assert_eq!(
            call(&mut c, "get_tool_digital_in", vec![Value::Int(1)]),
            Value::Bool(true)
        );
        assert_eq!(
            call(&mut c, "get_digital_in", vec![Value::Int(9)]),
            Value::Bool(true)
        );
        assert_eq!(
            call(&mut c, "get_configurable_digital_in", vec![Value::Int(2)]),
            Value::Bool(true)
        );
        assert_eq!(
            call(&mut c, "get_standard_digital_in", vec![Value::Int(2)]),
            Value::Bool(false)
        );
        assert_eq!(
            call(&mut c, "get_standard_analog_in", vec![Value::Int(1)]),
            Value::Float(4.5)
        );
        assert_eq!(
            call(&mut c, "read_input_integer_register", vec![Value::Int(24)]),
            Value::Int(7)
        );
        assert_eq!(
            call(&mut c, "read_input_float_register", vec![Value::Int(47)]),
            Value::Float(2.5)
        );
        assert_eq!(
            call(&mut c, "read_input_boolean_register", vec![Value::Int(127)]),
            Value::Bool(true)
        );
        let msg = Value::Str(b"?".to_vec());
        assert_eq!(
            call(
                &mut c,
                "request_integer_from_primary_client",
                vec![msg.clone()]
            ),
            Value::Int(12)
        );
        assert_eq!(
            call(&mut c, "request_string_from_primary_client", vec![msg]),
            Value::Str(b"part A".to_vec())
        );
    }

    #[test]
    fn argument_matching_names_what_is_wrong() {
        let p = [("a", false), ("b", true)];
        assert_eq!(
            match_args("f", p.iter().copied(), 1, &["b"]),
            Ok(vec![0, 1])
        );
        let e = match_args("f", p.iter().copied(), 3, &[]).unwrap_err();
        assert_eq!(e, "`f` takes at most 2 arguments, 3 given");
        let e = match_args("f", p.iter().copied(), 0, &["b"]).unwrap_err();
        assert_eq!(e, "`f` needs argument `a`");
        let e = match_args("f", p.iter().copied(), 1, &["a"]).unwrap_err();
        assert_eq!(e, "argument `a` of `f` given twice");
        let e = match_args("f", p.iter().copied(), 0, &["c"]).unwrap_err();
        assert_eq!(e, "`f` has no parameter `c` (its parameters: a, b)");
    }
}
