//! I/O and registers on the virtual arm: digital and analog outputs, tool outputs and
//! the RTDE output registers store what is written and read back; inputs read
//! `False`/0 (nothing is wired to them); I/O settings are accepted and change nothing.

use super::{accept, req, Args, Builtin, Domain, Out};
use crate::controller::Controller;
use crate::error::Fault;
use crate::value::Value;

const D: Domain = Domain::Io;
const N_B: &[super::Param] = &[req("n"), req("b")];
const N: &[super::Param] = &[req("n")];
const ADDRESS: &[super::Param] = &[req("address")];
const ADDRESS_VALUE: &[super::Param] = &[req("address"), req("value")];

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new(
        "set_standard_digital_out",
        D,
        N_B,
        "Sets standard digital output n (0-7).",
        set_digital,
    ),
    Builtin::new(
        "set_digital_out",
        D,
        N_B,
        "Sets digital output n (0-7 standard, 8-15 configurable).",
        set_digital,
    ),
    Builtin::new(
        "set_configurable_digital_out",
        D,
        N_B,
        "Sets configurable digital output n (0-7).",
        set_digital,
    ),
    Builtin::new(
        "set_tool_digital_out",
        D,
        N_B,
        "Sets tool digital output n (0-1).",
        set_digital,
    ),
    Builtin::new(
        "get_standard_digital_out",
        D,
        N,
        "Standard digital output n as last set.",
        get_digital_out,
    ),
    Builtin::new(
        "get_digital_out",
        D,
        N,
        "Digital output n as last set.",
        get_digital_out,
    ),
    Builtin::new(
        "get_configurable_digital_out",
        D,
        N,
        "Configurable digital output n as last set.",
        get_digital_out,
    ),
    Builtin::new(
        "get_tool_digital_out",
        D,
        N,
        "Tool digital output n as last set.",
        get_digital_out,
    ),
    Builtin::new(
        "get_standard_digital_in",
        D,
        N,
        "False: nothing is wired to the inputs.",
        get_digital_in,
    ),
    Builtin::new(
        "get_digital_in",
        D,
        N,
        "False: nothing is wired to the inputs.",
        get_digital_in,
    ),
    Builtin::new(
        "get_configurable_digital_in",
        D,
        N,
        "False: nothing is wired to the inputs.",
        get_digital_in,
    ),
    Builtin::new(
        "get_tool_digital_in",
        D,
        N,
        "False: nothing is wired to the inputs.",
        get_digital_in,
    ),
    Builtin::new(
        "set_standard_analog_out",
        D,
        &[req("n"), req("f")],
        "Sets analog output n (0-1).",
        set_analog_out,
    ),
    Builtin::new(
        "set_analog_out",
        D,
        &[req("n"), req("f")],
        "Sets analog output n (0-1).",
        set_analog_out,
    ),
    Builtin::new(
        "get_standard_analog_in",
        D,
        N,
        "0: nothing is wired to the inputs.",
        get_analog_in,
    ),
    Builtin::new(
        "get_analog_in",
        D,
        N,
        "0: nothing is wired to the inputs.",
        get_analog_in,
    ),
    Builtin::new(
        "get_tool_analog_in",
        D,
        N,
        "0: nothing is wired to the inputs.",
        get_analog_in,
    ),
    Builtin::new(
        "read_input_integer_register",
        D,
        ADDRESS,
        "0: no RTDE client writes the inputs.",
        read_input,
    ),
    Builtin::new(
        "read_input_float_register",
        D,
        ADDRESS,
        "0.0: no RTDE client writes the inputs.",
        read_input,
    ),
    Builtin::new(
        "read_input_boolean_register",
        D,
        ADDRESS,
        "False: no RTDE client writes the inputs.",
        read_input,
    ),
    Builtin::new(
        "read_output_integer_register",
        D,
        ADDRESS,
        "Output int register (0-47) as last written.",
        register,
    ),
    Builtin::new(
        "read_output_float_register",
        D,
        ADDRESS,
        "Output float register (0-47) as last written.",
        register,
    ),
    Builtin::new(
        "read_output_boolean_register",
        D,
        ADDRESS,
        "Output bool register (0-63) as last written.",
        register,
    ),
    Builtin::new(
        "write_output_integer_register",
        D,
        ADDRESS_VALUE,
        "Writes output int register (0-47).",
        register,
    ),
    Builtin::new(
        "write_output_float_register",
        D,
        ADDRESS_VALUE,
        "Writes output float register (0-47).",
        register,
    ),
    Builtin::new(
        "write_output_boolean_register",
        D,
        ADDRESS_VALUE,
        "Writes output bool register (0-63).",
        register,
    ),
    // Settings accepted with their manual signatures; they change nothing here.
    Builtin::new(
        "set_tool_voltage",
        D,
        &[req("voltage")],
        "Accepted.",
        accept,
    ),
    Builtin::new(
        "set_tool_communication",
        D,
        &[
            req("enabled"),
            req("baud_rate"),
            req("parity"),
            req("stop_bits"),
            req("rx_idle_chars"),
            req("tx_idle_chars"),
        ],
        "Accepted (no tool serial port).",
        accept,
    ),
    Builtin::new(
        "set_tool_output_mode",
        D,
        &[req("mode")],
        "Accepted.",
        accept,
    ),
    Builtin::new(
        "set_tool_digital_output_mode",
        D,
        &[req("n"), req("mode")],
        "Accepted.",
        accept,
    ),
    Builtin::new(
        "set_standard_analog_input_domain",
        D,
        &[req("port"), req("domain")],
        "Accepted.",
        accept,
    ),
    Builtin::new(
        "set_tool_analog_input_domain",
        D,
        &[req("port"), req("domain")],
        "Accepted.",
        accept,
    ),
    Builtin::new(
        "set_analog_inputrange",
        D,
        &[req("port"), req("range")],
        "Accepted.",
        accept,
    ),
    Builtin::new("set_input_actions_to_default", D, &[], "Accepted.", accept),
    Builtin::new(
        "set_standard_digital_input_action",
        D,
        &[req("port"), req("action")],
        "Accepted.",
        accept,
    ),
    Builtin::new(
        "set_runstate_standard_digital_output_to_value",
        D,
        &[req("outputId"), req("state")],
        "Accepted.",
        accept,
    ),
    Builtin::new("set_flag", D, N_B, "Accepted.", accept),
];

/// The output slot a digital function names.
fn digital_slot<'a>(c: &'a mut Controller, a: &Args) -> Result<&'a mut bool, Fault> {
    let n = a.int(0)?;
    let (slots, offset): (&mut [bool], usize) = if a.name.contains("tool") {
        (&mut c.arm.tool_out, 0)
    } else if a.name.contains("configurable") {
        (&mut c.arm.digital_out, 8)
    } else {
        (&mut c.arm.digital_out, 0)
    };
    usize::try_from(n)
        .ok()
        .and_then(|k| slots.get_mut(k + offset))
        .ok_or_else(|| Fault::from(format!("`{}`: no output {n}", a.name)))
}

fn set_digital(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let on = a.boolean(1)?;
    *digital_slot(c, a)? = on;
    Ok(Out::Value(Value::None))
}

fn get_digital_out(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Bool(*digital_slot(c, a)?)))
}

fn get_digital_in(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    a.int(0)?;
    Ok(Out::Value(Value::Bool(false)))
}

fn set_analog_out(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let n = a.int(0)?;
    let x = a.num(1)?;
    let slot = usize::try_from(n)
        .ok()
        .and_then(|n| c.arm.analog_out.get_mut(n))
        .ok_or_else(|| format!("`{}`: no analog output {n}", a.name))?;
    *slot = x;
    Ok(Out::Value(Value::None))
}

fn get_analog_in(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    a.int(0)?;
    Ok(Out::Value(Value::Float(0.0)))
}

fn read_input(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    a.int(0)?;
    Ok(Out::Value(match a.name {
        "read_input_integer_register" => Value::Int(0),
        "read_input_float_register" => Value::Float(0.0),
        _ => Value::Bool(false),
    }))
}

fn register(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let write = a.name.starts_with("write");
    let addr = a.int(0)?;
    let bools = a.name.contains("boolean");
    let k = usize::try_from(addr)
        .ok()
        .filter(|k| *k < if bools { 64 } else { 48 })
        .ok_or_else(|| format!("`{}`: no register {addr}", a.name))?;
    let arm = &mut c.arm;
    let v = if a.name.contains("integer") {
        if write {
            arm.int_regs[k] = a.int(1)?;
        }
        Value::Int(arm.int_regs[k])
    } else if a.name.contains("float") {
        if write {
            arm.float_regs[k] = a.num(1)?;
        }
        Value::Float(arm.float_regs[k])
    } else {
        if write {
            arm.bool_regs[k] = a.boolean(1)?;
        }
        Value::Bool(arm.bool_regs[k])
    };
    Ok(Out::Value(if write { Value::None } else { v }))
}
