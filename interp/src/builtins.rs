//! The built-in functions: every `socket_*` function of the e-Series 5.x manual with its
//! real signature and defaults, strings, math, time, messages, and a **virtual arm**.
//!
//! ## The virtual arm
//! Commanded state and the time each command takes, not dynamics:
//! - `movej(q, a=1.4, v=1.05, t=0, r=0)`: takes `t` if given, else the largest joint
//!   distance / `v`; `movel(pose, a=1.2, v=0.25, t=0, r=0)` and `movep`: `t`, else the
//!   straight-line distance / `v`; `movec(via, to, ...)`: like `movel` to `to`;
//!   `optimovej`/`optimovel`: like `movej`/`movel` (their `a`, `v` are fractions on the
//!   robot; here they are taken as speeds). `direct_torque`: one step. Every motion takes at least one step. A motion sets the
//!   commanded joints (`movej` with a list) or pose (`movel` with a pose) to its target
//!   when it starts; there is no kinematics, so a `movej` does not change the pose and a
//!   `movel` does not change the joints (`movej`/`movel` given the other kind of target
//!   set that one).
//! - `servoj(q, a, v, t=0.002, lookahead_time=0.1, gain=300)`: sets `q`, takes `t`.
//! - `speedj(qd, a, t)`, `speedl(xd, a, t, aRot)`: set the speed and integrate it over `t`
//!   (one step if `t` is not given); `stopj(a)`, `stopl(a)`: zero speed, one step.
//! - `get_actual_joint_positions()`, `get_target_joint_positions()`: the commanded `q`;
//!   `get_actual_tcp_pose()`, `get_target_tcp_pose()`: the commanded pose; speeds the
//!   commanded speeds; `get_inverse_kin(x, qnear)`: `qnear` or the current `q`;
//!   `get_forward_kin()`: the current pose; `tool_contact()`: 0; `is_steady()`: True.
//! - Digital and analog outputs, tool outputs and the RTDE output registers store what is
//!   written and read back; inputs read `False`/0.
//! - Settings the virtual arm has no use for (`set_payload`, `set_tcp`, `set_gravity`,
//!   `force_mode`, `zero_ftsensor`, ...) are accepted and do nothing.
//!
//! Pose math (`pose_trans`, `pose_inv`, `pose_add`, `pose_sub`) composes rigid transforms
//! with rotation vectors as the manual defines them; `interpolate_pose` interpolates each
//! element linearly (exact for translation, approximate for rotation).

use std::time::Duration;

use urscript_socket::to_str::{parse_value, Scalar, Value as WireValue};

use crate::machine::{Event, Machine, NativeOut, Stub, Wait};
use crate::sockets::ReadSpec;
use crate::value::Value;

/// The longest string `str_cat` makes, as on the controller.
pub const MAX_STRING_LEN: usize = 1023;

const SOCKET_FUNCTIONS: &[&str] = &[
    "socket_open",
    "socket_close",
    "socket_send_string",
    "socket_send_line",
    "socket_send_byte",
    "socket_send_int",
    "socket_read_ascii_float",
    "socket_read_binary_integer",
    "socket_read_byte_list",
    "socket_read_line",
    "socket_read_string",
    "socket_get_var",
    "socket_set_var",
];

/// Accepted with any arguments; they do nothing on the virtual arm.
const NO_OPS: &[&str] = &[
    "set_payload",
    "set_payload_mass",
    "set_payload_cog",
    "set_target_payload",
    "set_tcp",
    "set_gravity",
    "set_tool_voltage",
    "zero_ftsensor",
    "force_mode",
    "end_force_mode",
    "force_mode_set_damping",
    "force_mode_set_gain_scaling",
    "freedrive_mode",
    "end_freedrive_mode",
    "teach_mode",
    "end_teach_mode",
    "set_safety_mode_transition_hardness",
    "set_tool_communication",
    "set_tool_output_mode",
    "set_tool_digital_output_mode",
    "set_standard_analog_input_domain",
    "set_tool_analog_input_domain",
    "set_analog_inputrange",
    "set_input_actions_to_default",
    "set_standard_digital_input_action",
    "set_runstate_standard_digital_output_to_value",
    "set_flag",
    "stop_conveyor_tracking",
    "enable_external_ft_sensor",
    "ft_rtde_input_enable",
    "set_friction_compensation",
    "end_screw_driving",
    "textmsg_clear",
];

const OTHERS: &[&str] = &[
    "textmsg",
    "varmsg",
    "popup",
    "sync",
    "sleep",
    "get_steptime",
    "str_cat",
    "str_len",
    "str_sub",
    "str_find",
    "str_at",
    "str_empty",
    "to_str",
    "to_num",
    "sin",
    "cos",
    "tan",
    "asin",
    "acos",
    "atan",
    "atan2",
    "sqrt",
    "pow",
    "floor",
    "ceil",
    "log",
    "norm",
    "d2r",
    "r2d",
    "length",
    "get_list_length",
    "binary_list_to_integer",
    "integer_to_binary_list",
    "random",
    "point_dist",
    "pose_dist",
    "pose_add",
    "pose_sub",
    "pose_trans",
    "pose_inv",
    "interpolate_pose",
    "movej",
    "movel",
    "movep",
    "servoj",
    "speedj",
    "speedl",
    "stopj",
    "stopl",
    "get_actual_joint_positions",
    "get_target_joint_positions",
    "get_joint_positions",
    "get_actual_joint_positions_history",
    "movec",
    "optimovej",
    "optimovel",
    "direct_torque",
    "get_actual_joint_speeds",
    "get_target_joint_speeds",
    "get_actual_tcp_pose",
    "get_target_tcp_pose",
    "get_actual_tcp_speed",
    "get_target_tcp_speed",
    "get_tcp_force",
    "get_inverse_kin",
    "get_forward_kin",
    "get_tcp_offset",
    "tool_contact",
    "is_steady",
    "is_within_safety_limits",
    "set_standard_digital_out",
    "get_standard_digital_out",
    "get_standard_digital_in",
    "set_configurable_digital_out",
    "get_configurable_digital_out",
    "get_configurable_digital_in",
    "set_digital_out",
    "get_digital_out",
    "get_digital_in",
    "set_tool_digital_out",
    "get_tool_digital_out",
    "get_tool_digital_in",
    "set_standard_analog_out",
    "set_analog_out",
    "get_standard_analog_in",
    "get_analog_in",
    "get_tool_analog_in",
    "read_input_integer_register",
    "read_input_float_register",
    "read_input_boolean_register",
    "read_output_integer_register",
    "read_output_float_register",
    "read_output_boolean_register",
    "write_output_integer_register",
    "write_output_float_register",
    "write_output_boolean_register",
];

/// True if `name` is a built-in of this interpreter.
///
/// ```
/// assert!(urscript_interp::builtins::is_builtin("socket_read_ascii_float"));
/// assert!(!urscript_interp::builtins::is_builtin("rq_activate"));
/// ```
pub fn is_builtin(name: &str) -> bool {
    SOCKET_FUNCTIONS.contains(&name) || NO_OPS.contains(&name) || OTHERS.contains(&name)
}

/// Every built-in's name.
pub fn builtin_names() -> Vec<&'static str> {
    let mut v: Vec<&'static str> = SOCKET_FUNCTIONS.to_vec();
    v.extend_from_slice(OTHERS);
    v.extend_from_slice(NO_OPS);
    v
}

/// A parameter: name and default (`None`: required; `Some(Value::None)`: optional).
type Param = (&'static str, Option<Value>);

fn s(v: &str) -> Option<Value> {
    Some(Value::Str(v.as_bytes().to_vec()))
}
fn i(v: i32) -> Option<Value> {
    Some(Value::Int(v))
}
fn f(v: f64) -> Option<Value> {
    Some(Value::Float(v))
}
fn b(v: bool) -> Option<Value> {
    Some(Value::Bool(v))
}
const OPT: Option<Value> = Some(Value::None);

/// Binds arguments to parameters: positional, then named, then defaults.
fn bind(
    fname: &str,
    params: &[Param],
    args: Vec<Value>,
    kw: Vec<(&str, Value)>,
) -> Result<Vec<Value>, String> {
    if args.len() > params.len() {
        return Err(format!(
            "`{fname}` takes at most {} arguments, {} given",
            params.len(),
            args.len()
        ));
    }
    let mut slots: Vec<Option<Value>> = vec![None; params.len()];
    for (slot, v) in slots.iter_mut().zip(args) {
        *slot = Some(v);
    }
    for (n, v) in kw {
        let Some(k) = params.iter().position(|(p, _)| *p == n) else {
            return Err(format!("`{fname}` has no parameter `{n}`"));
        };
        if slots[k].is_some() {
            return Err(format!("argument `{n}` of `{fname}` given twice"));
        }
        slots[k] = Some(v);
    }
    params
        .iter()
        .zip(slots)
        .map(|((p, d), v)| {
            v.or_else(|| d.clone())
                .ok_or_else(|| format!("`{fname}` needs argument `{p}`"))
        })
        .collect()
}

fn num(v: &Value, fname: &str) -> Result<f64, String> {
    v.as_f64().ok_or_else(|| {
        format!(
            "type error: `{fname}` needs a number, got {} {}",
            v.type_name(),
            v.to_source()
        )
    })
}

fn int(v: &Value, fname: &str) -> Result<i32, String> {
    match v {
        Value::Int(i) => Ok(*i),
        Value::Float(x) if x.fract() == 0.0 && x.abs() <= f64::from(i32::MAX) => Ok(*x as i32),
        other => Err(format!(
            "type error: `{fname}` needs an int, got {} {}",
            other.type_name(),
            other.to_source()
        )),
    }
}

fn string(v: &Value, fname: &str) -> Result<Vec<u8>, String> {
    match v {
        Value::Str(s) => Ok(s.clone()),
        other => Err(format!(
            "type error: `{fname}` needs a string, got {} {}",
            other.type_name(),
            other.to_source()
        )),
    }
}

fn name_arg(v: &Value, fname: &str) -> Result<String, String> {
    Ok(String::from_utf8_lossy(&string(v, fname)?).into_owned())
}

fn boolean(v: &Value, fname: &str) -> Result<bool, String> {
    match v {
        Value::Bool(b) => Ok(*b),
        Value::Int(i) => Ok(*i != 0),
        other => Err(format!(
            "type error: `{fname}` needs a bool, got {} {}",
            other.type_name(),
            other.to_source()
        )),
    }
}

/// Six numbers from a list or a pose.
fn six(v: &Value, fname: &str) -> Result<[f64; 6], String> {
    let bad = || {
        format!(
            "type error: `{fname}` needs 6 numbers, got {} {}",
            v.type_name(),
            v.to_source()
        )
    };
    match v {
        Value::Pose(p) => Ok(*p),
        Value::List(items) if items.len() == 6 => {
            let mut out = [0.0; 6];
            for (o, x) in out.iter_mut().zip(items) {
                *o = x.as_f64().ok_or_else(bad)?;
            }
            Ok(out)
        }
        _ => Err(bad()),
    }
}

fn floats(v: [f64; 6]) -> Value {
    Value::List(v.iter().map(|&x| Value::Float(x)).collect())
}

fn secs(x: f64) -> Duration {
    Duration::try_from_secs_f64(x.max(0.0)).unwrap_or(Duration::MAX)
}

fn is_none(v: &Value) -> bool {
    matches!(v, Value::None)
}

/// The call as URScript text, for the trace.
fn call_text(name: &str, args: &[Value], kw: &[(&str, Value)]) -> String {
    let mut parts: Vec<String> = args.iter().map(Value::to_source).collect();
    parts.extend(kw.iter().map(|(k, v)| format!("{k}={}", v.to_source())));
    format!("{name}({})", parts.join(", "))
}

impl Machine {
    pub(crate) fn trace(&mut self, line: u32, text: String) {
        self.events.push_back(Event::Call { line, text });
    }

    pub(crate) fn call_native(
        &mut self,
        name: &str,
        args: Vec<Value>,
        kw: Vec<(&str, Value)>,
        line: u32,
    ) -> Result<NativeOut, String> {
        if let Some((_, stub)) = self.config.stubs.iter().find(|(n, _)| n == name) {
            let v = match stub {
                Stub::NoOp => Value::None,
                Stub::Return(v) => v.clone(),
            };
            let text = format!(
                "{} -> {} (stub)",
                call_text(name, &args, &kw),
                v.to_source()
            );
            self.trace(line, text);
            return Ok(NativeOut::Value(v));
        }
        if name.starts_with("socket_") && SOCKET_FUNCTIONS.contains(&name) {
            let text = if self.config.trace_socket_calls {
                call_text(name, &args, &kw)
            } else {
                String::new()
            };
            return self.socket_call(name, args, kw, line, text);
        }
        if NO_OPS.contains(&name) {
            return Ok(NativeOut::Value(Value::None));
        }
        let traced = self
            .config
            .trace_all_calls
            .then(|| call_text(name, &args, &kw));
        let out = self.other_call(name, args, kw)?;
        if let Some(text) = traced {
            let result = match &out {
                NativeOut::Value(v) => v.to_source(),
                NativeOut::Block(_) => "(waits)".into(),
            };
            self.trace(line, format!("{text} -> {result}"));
        }
        Ok(out)
    }

    fn socket_call(
        &mut self,
        name: &str,
        args: Vec<Value>,
        kw: Vec<(&str, Value)>,
        line: u32,
        text: String,
    ) -> Result<NativeOut, String> {
        let sock = || s("socket_0");
        let tracing = self.config.trace_socket_calls;
        let done = |m: &mut Machine, v: Value| {
            if tracing {
                let t = format!("{text} -> {}", v.to_source());
                m.trace(line, t);
            }
            Ok(NativeOut::Value(v))
        };
        let read = |m: &mut Machine, socket: String, spec: ReadSpec, timeout: f64| {
            let now = m.now();
            match m.sockets.start_read(&socket, &spec, timeout, now)? {
                Some(v) => {
                    m.flush(&socket);
                    if tracing {
                        let t = format!("{text} -> {}", v.to_source());
                        m.trace(line, t);
                    }
                    Ok(NativeOut::Value(v))
                }
                None => {
                    m.flush(&socket);
                    Ok(NativeOut::Block(Wait::Read {
                        socket,
                        spec,
                        call: text.clone(),
                        line,
                    }))
                }
            }
        };
        let number = |v: &Value| -> Result<usize, String> {
            let n = int(v, name)?;
            usize::try_from(n)
                .ok()
                .filter(|n| (1..=30).contains(n))
                .ok_or_else(|| format!("`{name}`: number must be 1..30, got {n}"))
        };
        match name {
            "socket_open" => {
                let a = bind(
                    name,
                    &[("address", None), ("port", None), ("socket_name", sock())],
                    args,
                    kw,
                )?;
                let host = name_arg(&a[0], name)?;
                let port = int(&a[1], name)?;
                let port = u16::try_from(port)
                    .map_err(|_| format!("`{name}`: port {port} out of range"))?;
                let socket = name_arg(&a[2], name)?;
                if self.sockets.is_open(&socket) {
                    // Policy: opening an open name closes the old connection first.
                    self.flush(&socket);
                    self.sockets.close(&socket);
                    self.events.push_back(Event::Close {
                        socket_name: socket.clone(),
                    });
                }
                self.events.push_back(Event::Connect {
                    socket_name: socket.clone(),
                    host,
                    port,
                });
                Ok(NativeOut::Block(Wait::Connect {
                    socket,
                    call: text,
                    line,
                }))
            }
            "socket_close" => {
                let a = bind(name, &[("socket_name", sock())], args, kw)?;
                let socket = name_arg(&a[0], name)?;
                if self.sockets.is_open(&socket) {
                    self.flush(&socket);
                    self.sockets.close(&socket);
                    self.events.push_back(Event::Close {
                        socket_name: socket,
                    });
                }
                if tracing {
                    self.trace(line, text);
                }
                Ok(NativeOut::Value(Value::None))
            }
            "socket_send_string" | "socket_send_line" => {
                let a = bind(name, &[("str", None), ("socket_name", sock())], args, kw)?;
                let socket = name_arg(&a[1], name)?;
                let bytes = a[0].to_str_bytes();
                let ok = if name == "socket_send_line" {
                    self.sockets.send_line(&socket, &bytes)
                } else {
                    self.sockets.send_string(&socket, &bytes)
                };
                self.flush(&socket);
                done(self, Value::Bool(ok))
            }
            "socket_send_byte" => {
                let a = bind(name, &[("value", None), ("socket_name", sock())], args, kw)?;
                let v = int(&a[0], name)?;
                let v = u8::try_from(v)
                    .map_err(|_| format!("`{name}`: value must be 0..255, got {v}"))?;
                let socket = name_arg(&a[1], name)?;
                let ok = self.sockets.send_byte(&socket, v);
                self.flush(&socket);
                done(self, Value::Bool(ok))
            }
            "socket_send_int" => {
                let a = bind(name, &[("value", None), ("socket_name", sock())], args, kw)?;
                let v = int(&a[0], name)?;
                let socket = name_arg(&a[1], name)?;
                let ok = self.sockets.send_int(&socket, v);
                self.flush(&socket);
                done(self, Value::Bool(ok))
            }
            "socket_set_var" => {
                let a = bind(
                    name,
                    &[("name", None), ("value", None), ("socket_name", sock())],
                    args,
                    kw,
                )?;
                let var = name_arg(&a[0], name)?;
                let v = int(&a[1], name)?;
                let socket = name_arg(&a[2], name)?;
                let ok = self.sockets.set_var(&socket, &var, v)?;
                self.flush(&socket);
                done(self, Value::Bool(ok))
            }
            "socket_get_var" => {
                let a = bind(name, &[("name", None), ("socket_name", sock())], args, kw)?;
                let var = name_arg(&a[0], name)?;
                let socket = name_arg(&a[1], name)?;
                read(self, socket, ReadSpec::GetVar(var), 2.0)
            }
            "socket_read_ascii_float" | "socket_read_binary_integer" | "socket_read_byte_list" => {
                let a = bind(
                    name,
                    &[
                        ("number", None),
                        ("socket_name", sock()),
                        ("timeout", f(2.0)),
                    ],
                    args,
                    kw,
                )?;
                let n = number(&a[0])?;
                let socket = name_arg(&a[1], name)?;
                let timeout = num(&a[2], name)?;
                let spec = match name {
                    "socket_read_ascii_float" => ReadSpec::AsciiFloat(n),
                    "socket_read_binary_integer" => ReadSpec::BinaryInteger(n),
                    _ => ReadSpec::ByteList(n),
                };
                read(self, socket, spec, timeout)
            }
            "socket_read_line" => {
                let a = bind(
                    name,
                    &[("socket_name", sock()), ("timeout", f(2.0))],
                    args,
                    kw,
                )?;
                let socket = name_arg(&a[0], name)?;
                let timeout = num(&a[1], name)?;
                read(self, socket, ReadSpec::Line, timeout)
            }
            "socket_read_string" => {
                let a = bind(
                    name,
                    &[
                        ("socket_name", sock()),
                        ("prefix", s("")),
                        ("suffix", s("")),
                        ("interpret_escape", b(false)),
                        ("timeout", f(2.0)),
                    ],
                    args,
                    kw,
                )?;
                let socket = name_arg(&a[0], name)?;
                let spec = ReadSpec::String {
                    prefix: string(&a[1], name)?,
                    suffix: string(&a[2], name)?,
                    interpret_escape: boolean(&a[3], name)?,
                };
                let timeout = num(&a[4], name)?;
                read(self, socket, spec, timeout)
            }
            _ => Err(format!("`{name}` is not supported")),
        }
    }

    fn other_call(
        &mut self,
        name: &str,
        args: Vec<Value>,
        kw: Vec<(&str, Value)>,
    ) -> Result<NativeOut, String> {
        let v = |x: Value| Ok(NativeOut::Value(x));
        let math1 = |args: Vec<Value>,
                     kw: Vec<(&str, Value)>,
                     g: fn(f64) -> f64|
         -> Result<NativeOut, String> {
            let a = bind(name, &[("f", None)], args, kw)?;
            Ok(NativeOut::Value(Value::Float(g(num(&a[0], name)?))))
        };
        match name {
            "textmsg" => {
                let a = bind(name, &[("s1", None), ("s2", s(""))], args, kw)?;
                let text = format!("{}{}", a[0].to_str(), a[1].to_str());
                self.events.push_back(Event::Message(text));
                v(Value::None)
            }
            "varmsg" => {
                let a = bind(name, &[("name", None), ("value", None)], args, kw)?;
                let text = format!("{} = {}", a[0].to_str(), a[1].to_str());
                self.events.push_back(Event::Message(text));
                v(Value::None)
            }
            "popup" => {
                let a = bind(
                    name,
                    &[
                        ("s", None),
                        ("title", s("Popup")),
                        ("warning", b(false)),
                        ("error", b(false)),
                        ("blocking", b(false)),
                    ],
                    args,
                    kw,
                )?;
                let text = format!("popup \"{}\": {}", a[1].to_str(), a[0].to_str());
                self.events.push_back(Event::Message(text));
                v(Value::None)
            }
            "sync" => {
                bind(name, &[], args, kw)?;
                let st = self.config.step_time;
                Ok(NativeOut::Block(self.wait_for(st, Value::None)))
            }
            "sleep" => {
                let a = bind(name, &[("t", None)], args, kw)?;
                let t = num(&a[0], name)?;
                Ok(NativeOut::Block(self.wait_for(secs(t), Value::None)))
            }
            "get_steptime" => {
                bind(name, &[], args, kw)?;
                v(Value::Float(self.config.step_time.as_secs_f64()))
            }
            // Strings.
            "str_cat" => {
                let a = bind(name, &[("op1", None), ("op2", None)], args, kw)?;
                let mut out = a[0].to_str_bytes();
                out.extend(a[1].to_str_bytes());
                // The controller's strings hold at most 1023 characters.
                if out.len() > MAX_STRING_LEN {
                    return Err(format!(
                        "`str_cat`: the result would be {} characters, more than {MAX_STRING_LEN}",
                        out.len()
                    ));
                }
                v(Value::Str(out))
            }
            "str_len" | "str_empty" => {
                let a = bind(name, &[("str", None)], args, kw)?;
                let st = string(&a[0], name)?;
                if name == "str_len" {
                    v(Value::Int(i32::try_from(st.len()).unwrap_or(i32::MAX)))
                } else {
                    v(Value::Bool(st.is_empty()))
                }
            }
            "str_sub" => {
                let a = bind(
                    name,
                    &[("src", None), ("index", None), ("len", i(-1))],
                    args,
                    kw,
                )?;
                let src = string(&a[0], name)?;
                let start = usize::try_from(int(&a[1], name)?).unwrap_or(usize::MAX);
                let len = int(&a[2], name)?;
                let start = start.min(src.len());
                let end = match usize::try_from(len) {
                    Ok(l) => start.saturating_add(l).min(src.len()),
                    Err(_) => src.len(),
                };
                v(Value::Str(src[start..end].to_vec()))
            }
            "str_find" => {
                let a = bind(
                    name,
                    &[("src", None), ("target", None), ("start_from", i(0))],
                    args,
                    kw,
                )?;
                let src = string(&a[0], name)?;
                let target = string(&a[1], name)?;
                let from = usize::try_from(int(&a[2], name)?)
                    .unwrap_or(0)
                    .min(src.len());
                let found = if target.is_empty() {
                    Some(from)
                } else {
                    src[from..]
                        .windows(target.len())
                        .position(|w| w == target.as_slice())
                        .map(|p| p + from)
                };
                v(Value::Int(
                    found.map_or(-1, |p| i32::try_from(p).unwrap_or(-1)),
                ))
            }
            "str_at" => {
                let a = bind(name, &[("src", None), ("index", None)], args, kw)?;
                let src = string(&a[0], name)?;
                let k = int(&a[1], name)?;
                let at = usize::try_from(k).ok().and_then(|k| src.get(k));
                v(Value::Str(at.map(|c| vec![*c]).unwrap_or_default()))
            }
            "to_str" => {
                let a = bind(name, &[("val", None)], args, kw)?;
                v(Value::Str(a[0].to_str_bytes()))
            }
            "to_num" => {
                let a = bind(name, &[("str", None)], args, kw)?;
                let st = string(&a[0], name)?;
                match parse_value(&st) {
                    Ok(WireValue::Scalar(Scalar::Int(x))) => v(Value::Int(x)),
                    Ok(WireValue::Scalar(Scalar::Float(x))) => v(Value::Float(x)),
                    _ => Err(format!(
                        "`to_num`: \"{}\" is not a number",
                        String::from_utf8_lossy(&st)
                    )),
                }
            }
            // Math.
            "sin" => math1(args, kw, f64::sin),
            "cos" => math1(args, kw, f64::cos),
            "tan" => math1(args, kw, f64::tan),
            "atan" => math1(args, kw, f64::atan),
            "d2r" => math1(args, kw, f64::to_radians),
            "r2d" => math1(args, kw, f64::to_degrees),
            "asin" | "acos" | "sqrt" => {
                let a = bind(name, &[("f", None)], args, kw)?;
                let x = num(&a[0], name)?;
                let r = match name {
                    "asin" => x.asin(),
                    "acos" => x.acos(),
                    _ => x.sqrt(),
                };
                if r.is_nan() && !x.is_nan() {
                    return Err(format!("`{name}`: {x} is outside its domain"));
                }
                v(Value::Float(r))
            }
            "atan2" => {
                let a = bind(name, &[("y", None), ("x", None)], args, kw)?;
                v(Value::Float(num(&a[0], name)?.atan2(num(&a[1], name)?)))
            }
            "pow" => {
                let a = bind(name, &[("base", None), ("exponent", None)], args, kw)?;
                v(Value::Float(num(&a[0], name)?.powf(num(&a[1], name)?)))
            }
            "log" => {
                let a = bind(name, &[("b", None), ("f", None)], args, kw)?;
                let (base, x) = (num(&a[0], name)?, num(&a[1], name)?);
                if base <= 0.0 || base == 1.0 || x <= 0.0 {
                    return Err(format!("`log`: log({base}, {x}) is undefined"));
                }
                v(Value::Float(x.ln() / base.ln()))
            }
            "floor" | "ceil" => {
                let a = bind(name, &[("f", None)], args, kw)?;
                let x = num(&a[0], name)?;
                let r = if name == "floor" { x.floor() } else { x.ceil() };
                if !(f64::from(i32::MIN)..=f64::from(i32::MAX)).contains(&r) {
                    return Err(format!("`{name}`: {x} does not fit an int"));
                }
                v(Value::Int(r as i32))
            }
            "norm" => {
                let a = bind(name, &[("a", None)], args, kw)?;
                match &a[0] {
                    Value::Int(x) => v(Value::Float(f64::from(*x).abs())),
                    Value::Float(x) => v(Value::Float(x.abs())),
                    Value::Pose(p) => v(Value::Float(p.iter().map(|x| x * x).sum::<f64>().sqrt())),
                    Value::List(items) => {
                        let mut sum = 0.0;
                        for x in items {
                            sum += num(x, name)?.powi(2);
                        }
                        v(Value::Float(sum.sqrt()))
                    }
                    other => Err(format!("type error: `norm` of a {}", other.type_name())),
                }
            }
            "length" | "get_list_length" => {
                let a = bind(name, &[("v", None)], args, kw)?;
                let n = match &a[0] {
                    Value::List(items) => items.len(),
                    Value::Str(st) => st.len(),
                    Value::Pose(_) => 6,
                    other => {
                        return Err(format!("type error: `{name}` of a {}", other.type_name()))
                    }
                };
                v(Value::Int(i32::try_from(n).unwrap_or(i32::MAX)))
            }
            "binary_list_to_integer" => {
                let a = bind(name, &[("l", None)], args, kw)?;
                let Value::List(items) = &a[0] else {
                    return Err(format!("type error: `{name}` needs a list of bools"));
                };
                if items.len() > 32 {
                    return Err(format!("`{name}`: at most 32 bits, got {}", items.len()));
                }
                let mut out: u32 = 0;
                for (k, x) in items.iter().enumerate() {
                    if boolean(x, name)? {
                        out |= 1 << k;
                    }
                }
                v(Value::Int(out as i32))
            }
            "integer_to_binary_list" => {
                let a = bind(name, &[("x", None)], args, kw)?;
                let x = int(&a[0], name)? as u32;
                v(Value::List(
                    (0..32).map(|k| Value::Bool(x >> k & 1 == 1)).collect(),
                ))
            }
            "random" => {
                bind(name, &[], args, kw)?;
                // A fixed-seed xorshift: runs are reproducible.
                let mut x = self.arm.random_state;
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                self.arm.random_state = x;
                v(Value::Float((x >> 11) as f64 / (1u64 << 53) as f64))
            }
            "point_dist" | "pose_dist" => {
                let a = bind(name, &[("p_from", None), ("p_to", None)], args, kw)?;
                let (p, q) = (six(&a[0], name)?, six(&a[1], name)?);
                let d = (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt();
                v(Value::Float(d))
            }
            "pose_trans" | "pose_add" | "pose_sub" => {
                let a = bind(name, &[("p_1", None), ("p_2", None)], args, kw)?;
                let (p, q) = (six(&a[0], name)?, six(&a[1], name)?);
                v(Value::Pose(match name {
                    "pose_trans" => crate::pose::trans(p, q),
                    "pose_add" => crate::pose::add(p, q),
                    _ => crate::pose::sub(p, q),
                }))
            }
            "pose_inv" => {
                let a = bind(name, &[("p_from", None)], args, kw)?;
                v(Value::Pose(crate::pose::inv(six(&a[0], name)?)))
            }
            "interpolate_pose" => {
                let a = bind(
                    name,
                    &[("p_from", None), ("p_to", None), ("alpha", None)],
                    args,
                    kw,
                )?;
                let (p, q) = (six(&a[0], name)?, six(&a[1], name)?);
                let t = num(&a[2], name)?;
                let mut out = [0.0; 6];
                for k in 0..6 {
                    out[k] = p[k] + (q[k] - p[k]) * t;
                }
                v(Value::Pose(out))
            }
            // The virtual arm.
            "direct_torque" => {
                // Torque control has no model here: the call takes one step.
                let a = bind(
                    name,
                    &[
                        ("torque", None),
                        ("friction_comp", OPT),
                        ("viscous_scale", OPT),
                        ("coulomb_scale", OPT),
                    ],
                    args,
                    kw,
                )?;
                six(&a[0], name)?;
                let st = self.config.step_time;
                Ok(NativeOut::Block(self.wait_for(st, Value::None)))
            }
            "movej" | "movel" | "movep" | "optimovej" | "optimovel" => {
                let joint_like = matches!(name, "movej" | "optimovej");
                let (da, dv) = if joint_like { (1.4, 1.05) } else { (1.2, 0.25) };
                let a = if name.starts_with("optimove") {
                    // No `t`: optimovej(q, a=0.3, v=0.3, r=0).
                    let mut a = bind(
                        name,
                        &[("q", None), ("a", f(0.3)), ("v", f(0.3)), ("r", f(0.0))],
                        args,
                        kw,
                    )?;
                    a.insert(3, Value::Float(0.0));
                    a
                } else {
                    bind(
                        name,
                        &[
                            ("q", None),
                            ("a", f(da)),
                            ("v", f(dv)),
                            ("t", f(0.0)),
                            ("r", f(0.0)),
                        ],
                        args,
                        kw,
                    )?
                };
                let target = six(&a[0], name)?;
                let speed = num(&a[2], name)?;
                let t = num(&a[3], name)?;
                let is_pose = matches!(a[0], Value::Pose(_));
                let dist = if is_pose {
                    let p = self.arm.pose;
                    let d = (0..3)
                        .map(|k| (target[k] - p[k]).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    self.arm.pose = target;
                    d
                } else {
                    let q = self.arm.q;
                    let d = (0..6).map(|k| (target[k] - q[k]).abs()).fold(0.0, f64::max);
                    self.arm.q = target;
                    d
                };
                self.arm.qd = [0.0; 6];
                let dur = if t > 0.0 {
                    t
                } else if speed > 0.0 {
                    dist / speed
                } else {
                    0.0
                };
                Ok(NativeOut::Block(self.wait_for(secs(dur), Value::None)))
            }
            "servoj" => {
                let a = bind(
                    name,
                    &[
                        ("q", None),
                        ("a", f(0.0)),
                        ("v", f(0.0)),
                        ("t", f(0.002)),
                        ("lookahead_time", f(0.1)),
                        ("gain", f(300.0)),
                    ],
                    args,
                    kw,
                )?;
                let q = six(&a[0], name)?;
                let t = num(&a[3], name)?;
                if t > 0.0 {
                    for ((qd, new), old) in self.arm.qd.iter_mut().zip(q).zip(self.arm.q) {
                        *qd = (new - old) / t;
                    }
                }
                self.arm.q = q;
                Ok(NativeOut::Block(self.wait_for(secs(t), Value::None)))
            }
            "speedj" | "speedl" => {
                let a = bind(
                    name,
                    &[("qd", None), ("a", f(1.0)), ("t", OPT), ("aRot", OPT)],
                    args,
                    kw,
                )?;
                let qd = six(&a[0], name)?;
                let t = if is_none(&a[2]) {
                    self.config.step_time.as_secs_f64()
                } else {
                    num(&a[2], name)?
                };
                if name == "speedj" {
                    self.arm.qd = qd;
                    for (q, v) in self.arm.q.iter_mut().zip(qd) {
                        *q += v * t;
                    }
                } else {
                    self.arm.tcp_speed = qd;
                    for (x, v) in self.arm.pose.iter_mut().zip(qd) {
                        *x += v * t;
                    }
                }
                Ok(NativeOut::Block(self.wait_for(secs(t), Value::None)))
            }
            "stopj" | "stopl" => {
                bind(name, &[("a", None), ("aRot", OPT)], args, kw)?;
                self.arm.qd = [0.0; 6];
                self.arm.tcp_speed = [0.0; 6];
                let st = self.config.step_time;
                Ok(NativeOut::Block(self.wait_for(st, Value::None)))
            }
            "get_actual_joint_positions" | "get_target_joint_positions" | "get_joint_positions" => {
                bind(name, &[], args, kw)?;
                v(floats(self.arm.q))
            }
            "get_actual_joint_positions_history" => {
                bind(name, &[("steps", i(0))], args, kw)?;
                v(floats(self.arm.q))
            }
            "movec" => {
                // Moves to `pose_to` through `pose_via`: timed as a straight line to the
                // target (no arc), like `movel`.
                let a = bind(
                    name,
                    &[
                        ("pose_via", None),
                        ("pose_to", None),
                        ("a", f(1.2)),
                        ("v", f(0.25)),
                        ("r", f(0.0)),
                        ("mode", i(0)),
                    ],
                    args,
                    kw,
                )?;
                let target = six(&a[1], name)?;
                let speed = num(&a[3], name)?;
                let dist = if matches!(a[1], Value::List(_)) {
                    let d = (0..6)
                        .map(|k| (target[k] - self.arm.q[k]).abs())
                        .fold(0.0, f64::max);
                    self.arm.q = target;
                    d
                } else {
                    let p = self.arm.pose;
                    let d = (0..3)
                        .map(|k| (target[k] - p[k]).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    self.arm.pose = target;
                    d
                };
                let dur = if speed > 0.0 { dist / speed } else { 0.0 };
                Ok(NativeOut::Block(self.wait_for(secs(dur), Value::None)))
            }
            "get_actual_joint_speeds" | "get_target_joint_speeds" => {
                bind(name, &[], args, kw)?;
                v(floats(self.arm.qd))
            }
            "get_actual_tcp_pose" | "get_target_tcp_pose" => {
                bind(name, &[], args, kw)?;
                v(Value::Pose(self.arm.pose))
            }
            "get_actual_tcp_speed" | "get_target_tcp_speed" => {
                bind(name, &[], args, kw)?;
                v(floats(self.arm.tcp_speed))
            }
            "get_tcp_force" => {
                bind(name, &[], args, kw)?;
                v(Value::Pose([0.0; 6]))
            }
            "get_tcp_offset" => {
                bind(name, &[], args, kw)?;
                v(Value::Pose(self.arm.tcp))
            }
            "get_inverse_kin" => {
                let a = bind(
                    name,
                    &[
                        ("x", None),
                        ("qnear", OPT),
                        ("maxPositionError", OPT),
                        ("maxOrientationError", OPT),
                        ("tcp", OPT),
                    ],
                    args,
                    kw,
                )?;
                six(&a[0], name)?;
                if is_none(&a[1]) {
                    v(floats(self.arm.q))
                } else {
                    v(floats(six(&a[1], name)?))
                }
            }
            "get_forward_kin" => {
                bind(name, &[("q", OPT), ("tcp", OPT)], args, kw)?;
                v(Value::Pose(self.arm.pose))
            }
            "tool_contact" => {
                bind(name, &[("direction", OPT)], args, kw)?;
                v(Value::Int(0))
            }
            "is_steady" => {
                bind(name, &[], args, kw)?;
                v(Value::Bool(true))
            }
            "is_within_safety_limits" => v(Value::Bool(true)),
            // I/O.
            "set_standard_digital_out"
            | "set_digital_out"
            | "set_configurable_digital_out"
            | "set_tool_digital_out" => {
                let a = bind(name, &[("n", None), ("b", None)], args, kw)?;
                let n = int(&a[0], name)?;
                let on = boolean(&a[1], name)?;
                *self.digital_slot(name, n)? = on;
                v(Value::None)
            }
            "get_standard_digital_out"
            | "get_digital_out"
            | "get_configurable_digital_out"
            | "get_tool_digital_out" => {
                let a = bind(name, &[("n", None)], args, kw)?;
                let n = int(&a[0], name)?;
                let on = *self.digital_slot(name, n)?;
                v(Value::Bool(on))
            }
            "get_standard_digital_in"
            | "get_digital_in"
            | "get_configurable_digital_in"
            | "get_tool_digital_in" => {
                let a = bind(name, &[("n", None)], args, kw)?;
                int(&a[0], name)?;
                v(Value::Bool(false))
            }
            "set_standard_analog_out" | "set_analog_out" => {
                let a = bind(name, &[("n", None), ("f", None)], args, kw)?;
                let n = int(&a[0], name)?;
                let x = num(&a[1], name)?;
                let slot = usize::try_from(n)
                    .ok()
                    .and_then(|n| self.arm.analog_out.get_mut(n))
                    .ok_or_else(|| format!("`{name}`: no analog output {n}"))?;
                *slot = x;
                v(Value::None)
            }
            "get_standard_analog_in" | "get_analog_in" | "get_tool_analog_in" => {
                let a = bind(name, &[("n", None)], args, kw)?;
                int(&a[0], name)?;
                v(Value::Float(0.0))
            }
            "read_input_integer_register"
            | "read_input_float_register"
            | "read_input_boolean_register" => {
                let a = bind(name, &[("address", None)], args, kw)?;
                int(&a[0], name)?;
                v(match name {
                    "read_input_integer_register" => Value::Int(0),
                    "read_input_float_register" => Value::Float(0.0),
                    _ => Value::Bool(false),
                })
            }
            "read_output_integer_register"
            | "read_output_float_register"
            | "read_output_boolean_register"
            | "write_output_integer_register"
            | "write_output_float_register"
            | "write_output_boolean_register" => {
                let write = name.starts_with("write");
                let a = if write {
                    bind(name, &[("address", None), ("value", None)], args, kw)?
                } else {
                    bind(name, &[("address", None)], args, kw)?
                };
                let addr = int(&a[0], name)?;
                let k = usize::try_from(addr)
                    .ok()
                    .filter(|k| *k < if name.contains("boolean") { 64 } else { 48 });
                let k = k.ok_or_else(|| format!("`{name}`: no register {addr}"))?;
                let arm = &mut self.arm;
                if name.contains("integer") {
                    if write {
                        arm.int_regs[k] = int(&a[1], name)?;
                    }
                    v(if write {
                        Value::None
                    } else {
                        Value::Int(arm.int_regs[k])
                    })
                } else if name.contains("float") {
                    if write {
                        arm.float_regs[k] = num(&a[1], name)?;
                    }
                    v(if write {
                        Value::None
                    } else {
                        Value::Float(arm.float_regs[k])
                    })
                } else {
                    if write {
                        arm.bool_regs[k] = boolean(&a[1], name)?;
                    }
                    v(if write {
                        Value::None
                    } else {
                        Value::Bool(arm.bool_regs[k])
                    })
                }
            }
            _ => Err(format!(
                "`{name}` is not a built-in this interpreter supports (stub it to run past it)"
            )),
        }
    }

    fn digital_slot(&mut self, name: &str, n: i32) -> Result<&mut bool, String> {
        let (slots, offset): (&mut [bool], usize) = if name.contains("tool") {
            (&mut self.arm.tool_out, 0)
        } else if name.contains("configurable") {
            (&mut self.arm.digital_out, 8)
        } else {
            (&mut self.arm.digital_out, 0)
        };
        usize::try_from(n)
            .ok()
            .and_then(|k| slots.get_mut(k + offset))
            .ok_or_else(|| format!("`{name}`: no output {n}"))
    }
}
