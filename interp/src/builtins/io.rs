//! I/O and registers on the virtual arm (the manual's interfaces and I/O configuration
//! chapters, sockets aside): digital and analog outputs, tool outputs, flags, the RTDE
//! output registers and the Modbus server's ports store what is written and read back.
//! Inputs and the RTDE input registers read their field of the virtual arm
//! (`crate::runtime::Arm`: `False`/0 unless a test sets them; nothing is wired).
//! Modbus signals live in a virtual client with no device behind it: an output signal
//! reads back what was set, an input signal reads 0/False. The virtual operator answers
//! `request_*_from_primary_client` at once with fixed values (False, 0, 0.0, "").
//! Other I/O settings are accepted with their manual signatures and change nothing
//! (their arguments are still checked against the manual's types).
//!
//! Each entry declares its signature once (`builtin!`); a family of functions (the
//! standard, configurable, tool and deprecated digital outputs, the register functions,
//! the Modbus signal functions...) shares a private function that takes the member as a
//! typed parameter (`DigitalOut`, `Register`, `SignalKind`, ...).

use super::{builtin, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::event::{Event, OutputValue, OutputWrite};
use crate::native::index;
use crate::runtime::ModbusSignal;
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Io;

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        set_standard_digital_out(n: i32, b: bool)
            => |c, x, n, b| set_digital(c, x, DigitalOut::Standard, n, b),
        "Sets standard digital output n (0-7).",
    ),
    builtin!(
        set_digital_out(n: i32, b: bool)
            => |c, x, n, b| set_digital(c, x, DigitalOut::Legacy, n, b),
        "Deprecated: sets digital output n (0-7 standard, 8-9 tool).",
    ),
    builtin!(
        set_configurable_digital_out(n: i32, b: bool)
            => |c, x, n, b| set_digital(c, x, DigitalOut::Configurable, n, b),
        "Sets configurable digital output n (0-7).",
    ),
    builtin!(
        set_tool_digital_out(n: i32, b: bool)
            => |c, x, n, b| set_digital(c, x, DigitalOut::Tool, n, b),
        "Sets tool digital output n (0-1).",
    ),
    builtin!(
        get_standard_digital_out(n: i32)
            => |c, x, n| get_digital_out(c, x, DigitalOut::Standard, n),
        "Standard digital output n as last set.",
    ),
    builtin!(
        get_digital_out(n: i32) => |c, x, n| get_digital_out(c, x, DigitalOut::Legacy, n),
        "Deprecated: digital output n as last set (0-7 standard, 8-9 tool).",
    ),
    builtin!(
        get_configurable_digital_out(n: i32)
            => |c, x, n| get_digital_out(c, x, DigitalOut::Configurable, n),
        "Configurable digital output n as last set.",
    ),
    builtin!(
        get_tool_digital_out(n: i32) => |c, x, n| get_digital_out(c, x, DigitalOut::Tool, n),
        "Tool digital output n as last set.",
    ),
    builtin!(
        get_standard_digital_in(n: i32)
            => |c, x, n| get_digital_in(c, x, DigitalIn::Standard, n),
        "Standard digital input n (0-7): False (nothing is wired).",
    ),
    builtin!(
        get_digital_in(n: i32) => |c, x, n| get_digital_in(c, x, DigitalIn::Legacy, n),
        "Deprecated: digital input n (0-7 standard, 8-9 tool): False (nothing is wired).",
    ),
    builtin!(
        get_configurable_digital_in(n: i32)
            => |c, x, n| get_digital_in(c, x, DigitalIn::Configurable, n),
        "Configurable digital input n (0-7): False (nothing is wired).",
    ),
    builtin!(
        get_tool_digital_in(n: i32) => |c, x, n| get_digital_in(c, x, DigitalIn::Tool, n),
        "Tool digital input n (0-1): False (nothing is wired).",
    ),
    builtin!(
        set_standard_analog_out(n: i32, f: f64) => set_analog_out,
        "Sets analog output n (0-1) to the fraction f of its range.",
    ),
    builtin!(
        set_analog_out(n: i32, f: f64) => set_analog_out,
        "Deprecated: sets analog output n (0-1).",
    ),
    builtin!(
        get_standard_analog_out(n: i32) => get_analog_out,
        "Analog output n (0-1) as last set.",
    ),
    builtin!(
        get_analog_out(n: i32) => get_analog_out,
        "Deprecated: analog output n (0-1) as last set.",
    ),
    builtin!(
        get_euromap_input(port_number: i32) => get_euromap_input,
        "Euromap67 input signal port_number (0-31; World::euromap_in, False unless a test sets it).",
    ),
    builtin!(
        get_euromap_output(port_number: i32) => get_euromap_output,
        "Euromap67 output signal port_number (0-31) as last set.",
    ),
    builtin!(
        set_euromap_output(port_number: i32, signal_value: bool) => set_euromap_output,
        "Sets Euromap67 output signal port_number (0-31).",
    ),
    builtin!(
        set_euromap_runstate_dependent_choice(port_number: i32, runstate_choice: i32)
            => set_euromap_runstate_dependent_choice,
        "How Euromap67 output port_number behaves when no program runs (0 preserve, 1 low, 2 high); recorded.",
    ),
    builtin!(set_flag(n: i32, b: bool) => set_flag, "Sets flag n (0-31)."),
    builtin!(get_flag(n: i32) => get_flag, "Flag n (0-31) as last set."),
    builtin!(
        read_port_bit(address: i32) => read_port_bit,
        "The Modbus server's bit port as last written (False if never).",
    ),
    builtin!(
        read_port_register(address: i32) => read_port_register,
        "The Modbus server's register port as last written, signed 16-bit (0 if never).",
    ),
    builtin!(
        write_port_bit(address: i32, value: bool) => write_port_bit,
        "Writes a bit port of the Modbus server.",
    ),
    builtin!(
        write_port_register(address: i32, value: i32) => write_port_register,
        "Writes a register port of the Modbus server (-32768 to 65535, kept as 16 bits).",
    ),
    builtin!(
        get_standard_analog_in(n: i32) => |c, x, n| get_analog_in(c, x, AnalogIn::Standard, n),
        "Standard analog input n (0-1): 0.0 (nothing is wired).",
    ),
    builtin!(
        get_analog_in(n: i32) => |c, x, n| get_analog_in(c, x, AnalogIn::Legacy, n),
        "Deprecated: analog input n (0-1 standard, 2-3 tool): 0.0 (nothing is wired).",
    ),
    builtin!(
        get_tool_analog_in(n: i32) => |c, x, n| get_analog_in(c, x, AnalogIn::Tool, n),
        "Tool analog input n (0-1): 0.0 (nothing is wired).",
    ),
    builtin!(
        read_input_integer_register(address: i32) => |c, x, k| read_input(c, x, Register::Int, k),
        "Input int register (0-47): 0 (no RTDE client writes it).",
    ),
    builtin!(
        read_input_float_register(address: i32) => |c, x, k| read_input(c, x, Register::Float, k),
        "Input float register (0-47): 0.0 (no RTDE client writes it).",
    ),
    builtin!(
        read_input_boolean_register(address: i32) => |c, x, k| read_input(c, x, Register::Bool, k),
        "Input bool register (0-127): False (no RTDE client writes it).",
    ),
    builtin!(
        read_output_integer_register(address: i32)
            => |c, x, k| read_output(c, x, Register::Int, k),
        "Output int register (0-47) as last written.",
    ),
    builtin!(
        read_output_float_register(address: i32)
            => |c, x, k| read_output(c, x, Register::Float, k),
        "Output float register (0-47) as last written.",
    ),
    builtin!(
        read_output_boolean_register(address: i32)
            => |c, x, k| read_output(c, x, Register::Bool, k),
        "Output bool register (0-127) as last written.",
    ),
    builtin!(
        write_output_integer_register(address: i32, value: i32)
            => |c, x, k, v| write_output(c, x, k, RegisterValue::Int(v)),
        "Writes output int register (0-47).",
    ),
    builtin!(
        write_output_float_register(address: i32, value: f64)
            => |c, x, k, v| write_output(c, x, k, RegisterValue::Float(v)),
        "Writes output float register (0-47).",
    ),
    builtin!(
        write_output_boolean_register(address: i32, value: bool)
            => |c, x, k, v| write_output(c, x, k, RegisterValue::Bool(v)),
        "Writes output bool register (0-127).",
    ),
    // Settings accepted with their manual signatures; they change nothing here.
    builtin!(set_tool_voltage(voltage: i32) => |_, _, _| none(), "Accepted."),
    builtin!(
        set_tool_communication(
            enabled: bool,
            baud_rate: i32,
            parity: i32,
            stop_bits: i32,
            rx_idle_chars: f64,
            tx_idle_chars: f64,
        ) => |_, _, _, _, _, _, _, _| none(),
        "Accepted (no tool serial port).",
    ),
    builtin!(set_tool_output_mode(mode: i32) => |_, _, _| none(), "Accepted."),
    builtin!(
        set_tool_digital_output_mode(n: i32, mode: i32) => |_, _, _, _| none(),
        "Accepted.",
    ),
    builtin!(
        set_standard_analog_input_domain(port: i32, domain: i32) => |_, _, _, _| none(),
        "Accepted.",
    ),
    builtin!(
        set_tool_analog_input_domain(port: i32, domain: i32) => |_, _, _, _| none(),
        "Accepted.",
    ),
    builtin!(
        set_analog_inputrange(port: i32, range: i32) => |_, _, _, _| none(),
        "Accepted.",
    ),
    // CB3 3.x (deprecated there): PolyScope 3.0-3.2 program headers and python-urx
    // emit `set_runstate_outputs([])`.
    builtin!(
        set_runstate_outputs(outputs: &[Value] = Ints(&[])) => |_, _, _| none(),
        "Accepted (CB3, deprecated): the outputs kept on when the program stops.",
    ),
    builtin!(set_input_actions_to_default() => |_, _| none(), "Accepted."),
    builtin!(
        set_standard_digital_input_action(port: i32, action: &[u8]) => |_, _, _, _| none(),
        "Accepted.",
    ),
    builtin!(
        set_runstate_standard_digital_output_to_value(outputId: i32, state: i32)
            => |_, _, _, _| none(),
        "Accepted.",
    ),
    builtin!(
        set_analog_outputdomain(port: i32, domain: i32) => set_analog_outputdomain,
        "Sets analog output port's (0-1) domain (0: 4-20 mA, 1: 0-10 V).",
    ),
    builtin!(
        set_configurable_digital_input_action(port: i32, action: &[u8])
            => |_, x, port, action| input_action(x, 8, port, action),
        "Sets the input's action, \"default\" or \"freedrive\" (accepted; nothing presses it).",
    ),
    builtin!(
        set_tool_digital_input_action(port: i32, action: &[u8])
            => |_, x, port, action| input_action(x, 2, port, action),
        "Sets the input's action, \"default\" or \"freedrive\" (accepted; nothing presses it).",
    ),
    builtin!(
        set_gp_boolean_input_action(port: i32, action: &[u8])
            => |_, x, port, action| input_action(x, 128, port, action),
        "Sets the bool input register's action, \"default\" or \"freedrive\" (accepted).",
    ),
    builtin!(
        set_runstate_configurable_digital_output_to_value(outputId: i32, state: i32)
            => |_, _, _, _| none(),
        "Accepted (the program's run state drives no output here).",
    ),
    builtin!(
        set_runstate_tool_digital_output_to_value(outputId: i32, state: i32)
            => |_, _, _, _| none(),
        "Accepted (the program's run state drives no output here).",
    ),
    builtin!(
        set_runstate_standard_analog_output_to_value(outputId: i32, state: i32)
            => |_, _, _, _| none(),
        "Accepted (the program's run state drives no output here).",
    ),
    builtin!(
        set_runstate_gp_boolean_output_to_value(outputId: i32, state: i32)
            => |_, _, _, _| none(),
        "Accepted (the program's run state drives no output here).",
    ),
    builtin!(
        modbus_set_runstate_dependent_choice(signal_name: String, runstate_choice: i32)
            => |c, x, name, _| modbus_exists(c, x, name, Value::None),
        "Accepted for a signal that exists (the run state drives no output here).",
    ),
    builtin!(
        rtde_set_watchdog(
            variable_name: String,
            min_frequency: f64,
            action: String = Str("pause"),
        ) => rtde_set_watchdog,
        "Watches an RTDE input field: no update within 1/min_frequency s and the action (ignore, pause, stop) is taken (World::rtde_watchdogs).",
    ),
    builtin!(
        modbus_add_signal(
            IP: String,
            slave_number: i32,
            signal_address: i32,
            signal_type: i32,
            signal_name: String,
            sequential_mode: bool = Bool(false),
            register_count: i32 = Int(1),
        ) => |c, x, _, slave, address, signal_type, name, _, count| {
            modbus_add(c, x, slave, address, SignalKind::Typed(signal_type), count, name)
        },
        "Adds a signal (type 0, 1, 2, 3, 15, 16) to the virtual Modbus client (no device).",
    ),
    builtin!(
        modbus_add_rw_signal(
            IP: String,
            slave_number: i32,
            read_address: i32,
            read_register_count: i32,
            write_address: i32,
            write_register_count: i32,
            signal_name: String,
            sequential_mode: bool = Bool(false),
        ) => |c, x, _, slave, address, count, _, _, name, _| {
            modbus_add(c, x, slave, address, SignalKind::ReadWrite, count, name)
        },
        "Adds a read-write register signal to the virtual Modbus client (no device).",
    ),
    builtin!(
        modbus_delete_signal(signal_name: String) => modbus_delete_signal,
        "Deletes a signal.",
    ),
    builtin!(
        modbus_get_signal_status(signal_name: String, is_secondary_program: bool = Bool(false))
            => |c, x, name, _| modbus_get_signal_status(c, x, name),
        "An output signal's value(s) as last set; an input's 0/False (a list if several).",
    ),
    builtin!(
        modbus_set_output_register(
            signal_name: String,
            register_value: &Value,
            is_secondary_program: bool = Bool(false),
        ) => |c, x, name, v, _| modbus_set_output(c, x, name, false, v),
        "Sets a register output signal (0-65535, or a list).",
    ),
    builtin!(
        modbus_set_output_signal(
            signal_name: String,
            digital_value: &Value,
            is_secondary_program: bool = Bool(false),
        ) => |c, x, name, v, _| modbus_set_output(c, x, name, true, v),
        "Sets a digital output signal (a bool, or a list).",
    ),
    builtin!(
        modbus_send_custom_command(
            IP: String,
            slave_number: i32,
            function_code: i32,
            data: &[Value],
        ) => |_, _, _, _, _, _| none(),
        "Accepted (no Modbus device; nothing is sent).",
    ),
    builtin!(
        modbus_set_digital_input_action(signal_name: String, action: &[u8])
            => modbus_set_digital_input_action,
        "Sets a signal's action, \"default\" or \"freedrive\" (accepted).",
    ),
    builtin!(
        modbus_set_signal_update_frequency(signal_name: String, update_frequency: f64)
            => |c, x, name, _| modbus_exists(c, x, name, Value::None),
        "Accepted for a signal that exists (no device is polled).",
    ),
    builtin!(
        modbus_get_error(signal_name: String, error_source: i32 = Int(0))
            => |c, x, name, _| modbus_exists(c, x, name, Value::Int(0)),
        "0: the virtual device never errs.",
    ),
    builtin!(
        modbus_get_time_since_signal_invalid(signal_name: String)
            => |c, x, name| modbus_exists(c, x, name, Value::Float(0.0)),
        "0.0: the virtual signals are never invalid.",
    ),
    builtin!(
        modbus_request_update_signal_value(signal_name: String)
            => |c, x, name| modbus_exists(c, x, name, Value::None),
        "Accepted for a signal that exists.",
    ),
    builtin!(
        modbus_reset_connection(connection_id: String, is_blocking: bool = Bool(true))
            => |_, _, _, _| none(),
        "Accepted (the virtual device is always connected).",
    ),
    builtin!(
        modbus_set_signal_watchdog(signal_name: String, new_timeout_in_sec: f64)
            => |c, x, name, _| modbus_exists(c, x, name, Value::None),
        "Accepted for a signal that exists.",
    ),
    builtin!(
        request_boolean_from_primary_client(message: &[u8])
            => |c, x, m| request(c, x, Answer::Bool, m),
        "The virtual operator's answer at once: False.",
    ),
    builtin!(
        request_integer_from_primary_client(message: &[u8])
            => |c, x, m| request(c, x, Answer::Int, m),
        "The virtual operator's answer at once: 0.",
    ),
    builtin!(
        request_float_from_primary_client(message: &[u8])
            => |c, x, m| request(c, x, Answer::Float, m),
        "The virtual operator's answer at once: 0.0.",
    ),
    builtin!(
        request_string_from_primary_client(message: &[u8])
            => |c, x, m| request(c, x, Answer::String, m),
        "The virtual operator's answer at once: \"\".",
    ),
];

/// The digital outputs a function numbers from 0.
#[derive(Clone, Copy)]
enum DigitalOut {
    /// Standard outputs 0-7.
    Standard,
    /// Configurable outputs 0-7.
    Configurable,
    /// Tool outputs 0-1.
    Tool,
    /// The deprecated `set/get_digital_out`: 0-7 standard, 8-9 tool.
    Legacy,
}

/// The slot of output `n` of `kind`.
fn digital_slot<'a>(
    c: &'a mut Runtime,
    a: &Args,
    kind: DigitalOut,
    n: i32,
) -> Result<&'a mut bool, Fault> {
    let arm = &mut c.arm;
    let slot = usize::try_from(n).ok().and_then(|k| match kind {
        DigitalOut::Tool => arm.tool_out.get_mut(k),
        DigitalOut::Configurable => arm.digital_out[8..16].get_mut(k),
        DigitalOut::Standard => arm.digital_out[..8].get_mut(k),
        DigitalOut::Legacy if k >= 8 => arm.tool_out.get_mut(k - 8),
        DigitalOut::Legacy => arm.digital_out.get_mut(k),
    });
    slot.ok_or_else(|| Fault::from(format!("`{}`: no output {n}", a.name)))
}

fn set_digital(
    c: &mut Runtime,
    a: &mut Args,
    kind: DigitalOut,
    n: i32,
    on: bool,
) -> Result<Out, Fault> {
    let slot = digital_slot(c, a, kind, n)?;
    if std::mem::replace(slot, on) != on {
        output_changed(c, a, n, OutputValue::Digital(on));
    }
    Ok(Out::Value(Value::None))
}

fn get_digital_out(c: &mut Runtime, a: &mut Args, kind: DigitalOut, n: i32) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Bool(*digital_slot(c, a, kind, n)?)))
}

/// The digital inputs a function numbers from 0.
#[derive(Clone, Copy)]
enum DigitalIn {
    /// Standard inputs 0-7.
    Standard,
    /// Configurable inputs 0-7.
    Configurable,
    /// Tool inputs 0-1.
    Tool,
    /// The deprecated `get_digital_in`: 0-7 standard, 8-9 tool.
    Legacy,
}

fn get_digital_in(c: &mut Runtime, a: &mut Args, kind: DigitalIn, n: i32) -> Result<Out, Fault> {
    // digital_in: standard 0-7, configurable 8-15, tool 16-17.
    let k = match kind {
        DigitalIn::Standard => index(a, n, 8, "input")?,
        DigitalIn::Configurable => 8 + index(a, n, 8, "input")?,
        DigitalIn::Tool => 16 + index(a, n, 2, "input")?,
        DigitalIn::Legacy => match index(a, n, 10, "input")? {
            k @ 8.. => k + 8,
            k => k,
        },
    };
    Ok(Out::Value(Value::Bool(c.arm.world.digital_in[k])))
}

fn set_analog_out(c: &mut Runtime, a: &mut Args, n: i32, x: f64) -> Result<Out, Fault> {
    let slot = usize::try_from(n)
        .ok()
        .and_then(|n| c.arm.analog_out.get_mut(n))
        .ok_or_else(|| format!("`{}`: no analog output {n}", a.name))?;
    if std::mem::replace(slot, x) != x {
        output_changed(c, a, n, OutputValue::Analog(x));
    }
    Ok(Out::Value(Value::None))
}

/// Reports the change of output `pin` of the function `a` calls.
fn output_changed(c: &mut Runtime, a: &Args, pin: i32, value: OutputValue) {
    c.events.push_back(Event::Output(OutputWrite {
        line: a.line,
        function: a.name,
        pin: i64::from(pin),
        value,
    }));
}

fn get_analog_out(c: &mut Runtime, a: &mut Args, n: i32) -> Result<Out, Fault> {
    let n = index(a, n, 2, "analog output")?;
    Ok(Out::Value(Value::Float(c.arm.analog_out[n])))
}

/// The analog inputs a function numbers from 0.
#[derive(Clone, Copy)]
enum AnalogIn {
    /// Standard inputs 0-1.
    Standard,
    /// Tool inputs 0-1.
    Tool,
    /// The deprecated `get_analog_in`: 0-1 standard, 2-3 tool.
    Legacy,
}

fn get_analog_in(c: &mut Runtime, a: &mut Args, kind: AnalogIn, n: i32) -> Result<Out, Fault> {
    // analog_in: standard 0-1, tool 2-3.
    let k = match kind {
        AnalogIn::Standard => index(a, n, 2, "analog input")?,
        AnalogIn::Tool => 2 + index(a, n, 2, "analog input")?,
        AnalogIn::Legacy => index(a, n, 4, "analog input")?,
    };
    Ok(Out::Value(Value::Float(c.arm.world.analog_in[k])))
}

/// A kind of RTDE general purpose register.
#[derive(Clone, Copy)]
enum Register {
    /// Int registers, 0-47.
    Int,
    /// Float registers, 0-47.
    Float,
    /// Bool registers, 0-127.
    Bool,
}

impl Register {
    /// How many registers of this kind there are, each way.
    fn count(self) -> usize {
        match self {
            Register::Int | Register::Float => 48,
            Register::Bool => 128,
        }
    }
}

/// A value written to an output register: its kind and the value.
#[derive(Clone, Copy)]
enum RegisterValue {
    Int(i32),
    Float(f64),
    Bool(bool),
}

fn read_input(c: &mut Runtime, a: &mut Args, kind: Register, addr: i32) -> Result<Out, Fault> {
    let k = index(a, addr, kind.count(), "register")?;
    let world = &c.arm.world;
    Ok(Out::Value(match kind {
        Register::Int => Value::Int(world.input_int_regs[k]),
        Register::Float => Value::Float(world.input_float_regs[k]),
        Register::Bool => Value::Bool(world.input_bool_regs[k]),
    }))
}

/// `addr` as the index of an output register of `kind`.
fn output_register(a: &Args, kind: Register, addr: i32) -> Result<usize, Fault> {
    usize::try_from(addr)
        .ok()
        .filter(|k| *k < kind.count())
        .ok_or_else(|| Fault::from(format!("`{}`: no register {addr}", a.name)))
}

fn read_output(c: &mut Runtime, a: &mut Args, kind: Register, addr: i32) -> Result<Out, Fault> {
    let k = output_register(a, kind, addr)?;
    let arm = &c.arm;
    Ok(Out::Value(match kind {
        Register::Int => Value::Int(arm.int_regs[k]),
        Register::Float => Value::Float(arm.float_regs[k]),
        Register::Bool => Value::Bool(arm.bool_regs[k]),
    }))
}

fn write_output(c: &mut Runtime, a: &mut Args, addr: i32, v: RegisterValue) -> Result<Out, Fault> {
    let arm = &mut c.arm;
    match v {
        RegisterValue::Int(x) => arm.int_regs[output_register(a, Register::Int, addr)?] = x,
        RegisterValue::Float(x) => arm.float_regs[output_register(a, Register::Float, addr)?] = x,
        RegisterValue::Bool(x) => arm.bool_regs[output_register(a, Register::Bool, addr)?] = x,
    }
    Ok(Out::Value(Value::None))
}

fn set_flag(c: &mut Runtime, a: &mut Args, n: i32, on: bool) -> Result<Out, Fault> {
    c.arm.flags[index(a, n, 32, "flag")?] = on;
    Ok(Out::Value(Value::None))
}

fn get_flag(c: &mut Runtime, a: &mut Args, n: i32) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Bool(
        c.arm.flags[index(a, n, 32, "flag")?],
    )))
}

/// `addr` as a port address of the Modbus server (0 or more).
fn port(a: &Args, addr: i32) -> Result<i32, Fault> {
    if addr < 0 {
        return Err(Fault::from(format!("`{}`: no port {addr}", a.name)));
    }
    Ok(addr)
}

fn read_port_bit(c: &mut Runtime, a: &mut Args, addr: i32) -> Result<Out, Fault> {
    let bit = c.arm.port_bits.get(&port(a, addr)?).copied();
    Ok(Out::Value(Value::Bool(bit.unwrap_or(false))))
}

fn read_port_register(c: &mut Runtime, a: &mut Args, addr: i32) -> Result<Out, Fault> {
    let register = c.arm.port_registers.get(&port(a, addr)?).copied();
    Ok(Out::Value(Value::Int(i32::from(register.unwrap_or(0)))))
}

fn write_port_bit(c: &mut Runtime, a: &mut Args, addr: i32, on: bool) -> Result<Out, Fault> {
    c.arm.port_bits.insert(port(a, addr)?, on);
    Ok(Out::Value(Value::None))
}

fn write_port_register(c: &mut Runtime, a: &mut Args, addr: i32, v: i32) -> Result<Out, Fault> {
    let addr = port(a, addr)?;
    if !(-32768..=65535).contains(&v) {
        return Err(Fault::from(format!(
            "`write_port_register`: {v} does not fit a register (-32768 to 65535)"
        )));
    }
    c.arm.port_registers.insert(addr, v as u16 as i16);
    Ok(Out::Value(Value::None))
}

/// What an accepted setting returns.
fn none() -> Result<Out, Fault> {
    Ok(Out::Value(Value::None))
}

fn set_analog_outputdomain(
    c: &mut Runtime,
    a: &mut Args,
    port: i32,
    domain: i32,
) -> Result<Out, Fault> {
    let port = index(a, port, 2, "analog output")?;
    if !(0..=1).contains(&domain) {
        return Err(Fault::from(format!(
            "`set_analog_outputdomain`: domain {domain} is not 0 (4-20 mA) or 1 (0-10 V)"
        )));
    }
    c.arm.analog_out_domain[port] = domain;
    Ok(Out::Value(Value::None))
}

/// Checks an input action: "default" or "freedrive".
fn check_action(a: &Args, action: &[u8]) -> Result<(), Fault> {
    if action == b"default" || action == b"freedrive" {
        Ok(())
    } else {
        Err(Fault::from(format!(
            "`{}`: action \"{}\" is not \"default\" or \"freedrive\"",
            a.name,
            String::from_utf8_lossy(action)
        )))
    }
}

/// Checks the action of input `port` of `n` inputs (accepted; nothing presses it).
fn input_action(a: &mut Args, n: usize, port: i32, action: &[u8]) -> Result<Out, Fault> {
    index(a, port, n, "input")?;
    check_action(a, action)?;
    none()
}

/// The Modbus signal called `name`.
fn signal<'a>(c: &'a mut Runtime, a: &Args, name: &str) -> Result<&'a mut ModbusSignal, Fault> {
    c.arm
        .modbus
        .get_mut(name)
        .ok_or_else(|| Fault::from(format!("`{}`: no Modbus signal \"{name}\"", a.name)))
}

/// `v` if the signal called `name` exists (its error otherwise): the functions that
/// change nothing on a signal of the virtual client.
fn modbus_exists(c: &mut Runtime, a: &mut Args, name: String, v: Value) -> Result<Out, Fault> {
    signal(c, a, &name)?;
    Ok(Out::Value(v))
}

/// A Modbus signal's type as it is added.
#[derive(Clone, Copy)]
enum SignalKind {
    /// `modbus_add_signal`'s `signal_type`: 0, 1, 2, 3, 15 or 16.
    Typed(i32),
    /// `modbus_add_rw_signal`: a read-write register signal (type 23 here).
    ReadWrite,
}

fn modbus_add(
    c: &mut Runtime,
    a: &mut Args,
    slave: i32,
    address: i32,
    kind: SignalKind,
    count: i32,
    name: String,
) -> Result<Out, Fault> {
    if !(0..=255).contains(&slave) {
        return Err(Fault::from(format!(
            "`{}`: slave number {slave} is not 0-255",
            a.name
        )));
    }
    let signal_type = match kind {
        SignalKind::ReadWrite => 23,
        SignalKind::Typed(t) if [0, 1, 2, 3, 15, 16].contains(&t) => t,
        SignalKind::Typed(t) => {
            return Err(Fault::from(format!(
                "`modbus_add_signal`: signal type {t} is not 0, 1, 2, 3, 15 or 16"
            )))
        }
    };
    if address < 0 || !(1..=123).contains(&count) {
        return Err(Fault::from(format!(
            "`{}`: address below 0 or register count {count} not 1-123",
            a.name
        )));
    }
    if name.is_empty() || name.len() > 20 {
        return Err(Fault::from(format!(
            "`{}`: signal name \"{name}\" must be 1-20 characters",
            a.name
        )));
    }
    c.arm.modbus.insert(
        name,
        ModbusSignal {
            signal_type,
            values: vec![0; count as usize],
        },
    );
    none()
}

fn modbus_set_digital_input_action(
    c: &mut Runtime,
    a: &mut Args,
    name: String,
    action: &[u8],
) -> Result<Out, Fault> {
    check_action(a, action)?;
    modbus_exists(c, a, name, Value::None)
}

fn modbus_delete_signal(c: &mut Runtime, _: &mut Args, name: String) -> Result<Out, Fault> {
    c.arm.modbus.remove(&name);
    none()
}

fn modbus_get_signal_status(c: &mut Runtime, a: &mut Args, name: String) -> Result<Out, Fault> {
    let s = signal(c, a, &name)?;
    let digital = matches!(s.signal_type, 0 | 1 | 15);
    let one = |v: i32| {
        if digital {
            Value::Bool(v != 0)
        } else {
            Value::Int(v)
        }
    };
    Ok(Out::Value(if s.values.len() == 1 {
        one(s.values[0])
    } else {
        Value::List(s.values.iter().map(|v| one(*v)).collect())
    }))
}

/// Sets a digital (`digital`) or register output signal to `value`, one value or a list.
fn modbus_set_output(
    c: &mut Runtime,
    a: &mut Args,
    name: String,
    digital: bool,
    value: &Value,
) -> Result<Out, Fault> {
    let given = match value {
        Value::List(items) => items.as_slice(),
        v => std::slice::from_ref(v),
    };
    let function = a.name;
    let s = signal(c, a, &name)?;
    let fits = if digital {
        matches!(s.signal_type, 1 | 15)
    } else {
        matches!(s.signal_type, 3 | 16 | 23)
    };
    if !fits || given.is_empty() || given.len() > s.values.len() {
        return Err(Fault::from(format!(
            "`{function}`: the signal (type {}, {} value(s)) cannot take {} value(s)",
            s.signal_type,
            s.values.len(),
            given.len()
        )));
    }
    for (slot, v) in s.values.iter_mut().zip(given) {
        *slot = match v {
            Value::Bool(b) if digital => i32::from(*b),
            Value::Int(x) if digital => i32::from(*x != 0),
            Value::Int(x) if (0..=65535).contains(x) => *x,
            other => {
                return Err(Fault::from(format!(
                    "`{function}`: {} is not a {}",
                    other.to_source(),
                    if digital {
                        "bool"
                    } else {
                        "register value (0-65535)"
                    }
                )))
            }
        };
    }
    none()
}

/// The kind of answer a `request_*_from_primary_client` asks the operator for.
#[derive(Clone, Copy)]
enum Answer {
    Bool,
    Int,
    Float,
    String,
}

fn request(c: &mut Runtime, a: &mut Args, kind: Answer, message: &[u8]) -> Result<Out, Fault> {
    if message.is_empty() {
        return Err(Fault::from(format!("`{}`: the message is empty", a.name)));
    }
    let world = &c.arm.world;
    Ok(Out::Value(match kind {
        Answer::Bool => Value::Bool(world.operator_bool),
        Answer::Int => Value::Int(world.operator_int),
        Answer::Float => Value::Float(world.operator_float),
        Answer::String => Value::Str(world.operator_string.clone()),
    }))
}

/// `rtde_set_watchdog(variable_name, min_frequency, action="pause")`: a watchdog on one
/// RTDE input field, replacing any on the same field; the action is taken when the
/// field has no update for `1 / min_frequency` s (checked each step, once per time-out).
/// The action's case does not matter (PolyScope writes `"PAUSE"`). A frequency of 0
/// removes the field's watchdog (our reading; the manual gives no way to remove one but
/// the program's end). The watchdogs end with the program. `variable_name` must be an
/// input field of [`crate::rtde_fields`] (`input_int_register_0`,
/// `speed_slider_fraction`, ...): any other name is a runtime error.
fn rtde_set_watchdog(
    c: &mut Runtime,
    _: &mut Args,
    variable: String,
    f: f64,
    action: String,
) -> Result<Out, Fault> {
    if crate::rtde_fields::Field::lookup(&variable, crate::rtde_fields::Direction::Input).is_none()
    {
        return Err(
            format!("`rtde_set_watchdog`: \"{variable}\" is not an RTDE input field").into(),
        );
    }
    let action = match action.to_ascii_lowercase().as_str() {
        "ignore" => 0,
        "pause" => 1,
        "stop" => 2,
        other => {
            return Err(format!(
                "`rtde_set_watchdog`: action must be \"ignore\", \"pause\" or \"stop\", got \"{other}\""
            )
            .into())
        }
    };
    if !(f.is_finite() && f >= 0.0) {
        return Err(
            format!("`rtde_set_watchdog`: min_frequency must be at least 0, got {f}").into(),
        );
    }
    c.rtde_watchdogs.retain(|w| w.variable != variable);
    if f == 0.0 {
        return Ok(Out::Value(Value::None));
    }
    if c.rtde_watchdogs.len() >= crate::runtime::MAX_RTDE_WATCHDOGS {
        return Err(Fault::new(
            crate::error::RuntimeErrorKind::Limit,
            format!(
                "`rtde_set_watchdog`: at most {} watchdogs",
                crate::runtime::MAX_RTDE_WATCHDOGS
            ),
        ));
    }
    let st = c.step_time.as_secs_f64().max(1e-9);
    let steps = (1.0 / f / st).ceil();
    let period = if steps.is_finite() && steps < 1e15 {
        (steps as u64).max(1)
    } else {
        u64::MAX / 2
    };
    let seen = c
        .arm
        .world
        .rtde_input_updates
        .get(&variable)
        .copied()
        .unwrap_or(0);
    let since = c.step;
    c.rtde_watchdogs.push(crate::runtime::RtdeWatchdog {
        variable,
        period,
        action,
        seen,
        since,
        fired: false,
    });
    Ok(Out::Value(Value::None))
}

/// The Euromap67 functions of the CB3 3.x manual, on a virtual Euromap67 interface: 32
/// input and 32 output signals (our bound: the manual names the signals by number only).
/// Inputs read [`World::euromap_in`](crate::World::euromap_in); outputs read back what
/// was set; the run-state choice (0: preserve, 1: low, 2: high when no program runs) is
/// recorded (no program runs on the virtual arm between programs to apply it).
///
/// This is signal `n` of those (0-31) as an index.
fn euromap_signal(a: &Args, n: i32) -> Result<usize, Fault> {
    index(a, n, 32, "Euromap67 signal")
}

fn get_euromap_input(c: &mut Runtime, a: &mut Args, n: i32) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Bool(
        c.arm.world.euromap_in[euromap_signal(a, n)?],
    )))
}

fn get_euromap_output(c: &mut Runtime, a: &mut Args, n: i32) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Bool(
        c.arm.euromap_out[euromap_signal(a, n)?],
    )))
}

fn set_euromap_output(c: &mut Runtime, a: &mut Args, n: i32, on: bool) -> Result<Out, Fault> {
    c.arm.euromap_out[euromap_signal(a, n)?] = on;
    Ok(Out::Value(Value::None))
}

fn set_euromap_runstate_dependent_choice(
    c: &mut Runtime,
    a: &mut Args,
    n: i32,
    choice: i32,
) -> Result<Out, Fault> {
    let n = euromap_signal(a, n)?;
    if !(0..=2).contains(&choice) {
        return Err(format!(
            "`{}`: runstate_choice must be 0, 1 or 2, got {choice}",
            a.name
        )
        .into());
    }
    c.arm.euromap_runstate[n] = choice as u8;
    Ok(Out::Value(Value::None))
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use crate::{Config, Machine, Program, State};

    /// The error `src` stops with (a program of one step or so).
    fn error(src: &str) -> String {
        let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
        m.run_until(Duration::from_secs(1));
        match m.state() {
            State::Error(e) => e.to_string(),
            other => panic!("{src}: expected an error, got {other:?}"),
        }
    }

    /// The settings that change nothing check their arguments' types as the manual
    /// gives them, and take arguments of those types.
    #[test]
    fn accepted_settings_check_their_argument_types() {
        assert_eq!(
            error("set_tool_voltage(\"24\")\n"),
            "line 1: type error: `set_tool_voltage` argument `voltage` needs an int, got string \"24\""
        );
        assert_eq!(
            error("set_tool_communication(True, 115200, 0, 1, 1.5, \"x\")\n"),
            "line 1: type error: `set_tool_communication` argument `tx_idle_chars` needs a number, got string \"x\""
        );
        assert_eq!(
            error("modbus_send_custom_command(\"10.0.0.2\", 1, 6, 17)\n"),
            "line 1: type error: `modbus_send_custom_command` argument `data` needs a list, got int 17"
        );
        assert_eq!(
            error("modbus_add_signal(\"10.0.0.2\", 1, 5, 3, \"r\", \"yes\")\n"),
            "line 1: type error: `modbus_add_signal` argument `sequential_mode` needs a bool, got string \"yes\""
        );
        let fine = "set_tool_voltage(24)\nset_tool_communication(True, 115200, 0, 1, 1.5, 3.5)\n\
                    set_runstate_outputs([])\nmodbus_reset_connection(\"10.0.0.2\", False)\n\
                    modbus_send_custom_command(\"10.0.0.2\", 1, 6, [17, 32])\nx = 1 / 0\n";
        assert!(error(fine).starts_with("line 6:"), "{}", error(fine));
    }
}
