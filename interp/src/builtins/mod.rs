//! The built-in functions: **one table**, one entry per function, grouped in modules by
//! domain as UR's script manual groups them. An entry is the function's signature,
//! declared once (`builtin!`: its name, each parameter's name, Rust type and default,
//! the code, what it does). The compiler resolves a call to its entry once and checks its
//! arguments (count, names) with line and column before anything runs; the machine then
//! binds the arguments (defaults filled), converts each to its parameter's type (a type
//! error names the parameter) and calls the code with them. The code never looks at
//! which function was called: functions that share code pass what differs as a value.
//!
//! Adding a built-in is one `builtin!` entry in its domain's `TABLE` (and its function
//! beside it).
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

use crate::error::Fault;
use crate::runtime::Runtime;
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

pub(crate) use crate::native::{builtin, Args, Out};
pub use crate::native::{Builtin, Default, Domain, Param};
pub(crate) use crate::runtime::secs;
pub use strings::MAX_STRING_LEN;

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

/// Six floats as a URScript list.
pub(crate) fn floats(v: [f64; 6]) -> Value {
    Value::List(v.iter().map(|&x| Value::Float(x)).collect())
}

/// Floats as a URScript list.
pub(crate) fn float_list(v: &[f64]) -> Value {
    Value::List(v.iter().map(|&x| Value::Float(x)).collect())
}

/// Does nothing and returns nothing: settings the virtual arm has no use for.
pub(crate) fn accept(_: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::None))
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

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
    fn call(c: &mut Runtime, name: &str, args: Vec<Value>) -> Value {
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
        let mut c = Runtime {
            dh: crate::kinematics::Model::Ur5e.dh(),
            step_time: Duration::from_millis(2),
            step: 0,
            arm: crate::runtime::Arm::default(),
            sockets: crate::sockets::Sockets::new(crate::sockets::Policy::default()),
            events: crate::vm::memory::Events::default(),
            effects: Vec::new(),
            mem: crate::vm::memory::Memory::new(crate::vm::memory::DEFAULT_MAX_MEMORY),
            motion: None,
            thread: 0,
            sampled: None,
            eip: crate::eip::Handles::default(),
            rtde_watchdogs: Vec::new(),
            tracked: None,
            queued: None,
            clock: crate::runtime::MotionClock::default(),
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
