//! `get_rtde_value(key)` (e-Series 5.x interfaces): the value of an RTDE output field, as
//! an RTDE client would read it, from the virtual arm's state.
//!
//! The fields served, by RTDE type (VECTOR6D, VECTOR3D: a list of floats; DOUBLE: a float;
//! INT32, UINT32, UINT64: an int, bit fields as URScript's 32-bit int, so bit 31 reads
//! negative; BOOL: a bool):
//!
//! | key | value |
//! | --- | --- |
//! | `timestamp` | program time, s |
//! | `target_q`, `actual_q`, `target_qd`, `actual_qd`, `target_qdd` | the joints now ([`Arm`](crate::Arm)) |
//! | `target_TCP_pose`, `actual_TCP_pose`, `target_TCP_speed`, `actual_TCP_speed` | the tool now |
//! | `actual_TCP_force` | [`Arm::measured_tcp_force`](crate::Arm::measured_tcp_force): [`World::tcp_force`](crate::World::tcp_force) plus the contact plane's push |
//! | `joint_temperatures` | [`World::joint_temp`](crate::World::joint_temp) |
//! | `actual_execution_time` | [`World::execution_time`](crate::World::execution_time) |
//! | `robot_mode`, `safety_mode`, `safety_status`, `runtime_state` | 7 (running), 1 (normal), 1 (normal), 2 (playing): a program runs only on a running arm |
//! | `speed_scaling`, `target_speed_fraction` | the speed slider, [`Arm::speed_fraction`](crate::Arm::speed_fraction) (1.0 unless a client set it) |
//! | `actual_digital_input_bits`, `actual_digital_output_bits` | the 18 digital inputs / outputs, bit n = I/O n |
//! | `standard_analog_input0/1`, `tool_analog_input0/1` | [`World::analog_in`](crate::World::analog_in) |
//! | `output_int_register_N`, `output_double_register_N`, `input_int_register_N`, `input_double_register_N` | RTDE registers 0-47 |
//! | `output_bit_register_N`, `input_bit_register_N` | RTDE bit registers 64-127 |
//! | `output_bit_registers0_to_31`, `output_bit_registers32_to_63`, `input_bit_registers0_to_31`, `input_bit_registers32_to_63` | bit registers as bit fields |
//! | `payload`, `payload_cog`, `payload_inertia` | the active payload |
//!
//! Any other key is a runtime error naming it.

use super::{float_list, floats, req, Args, Builtin, Domain, Out};
use crate::controller::Controller;
use crate::error::Fault;
use crate::value::Value;

pub(super) const TABLE: &[Builtin] = &[Builtin::new(
    "get_rtde_value",
    Domain::Io,
    &[req("key")],
    "The value of RTDE output field key, from the virtual arm's state.",
    get_rtde_value,
)];

/// Bits as URScript's 32-bit int (bit 31 makes it negative).
fn bits(b: impl Iterator<Item = bool>) -> Value {
    let mut v: u32 = 0;
    for (i, on) in b.take(32).enumerate() {
        if on {
            v |= 1 << i;
        }
    }
    Value::Int(v as i32)
}

/// The register number of `key` after `prefix`, within `0..n`.
fn register(key: &str, prefix: &str, n: usize) -> Option<usize> {
    key.strip_prefix(prefix)?
        .parse::<usize>()
        .ok()
        .filter(|i| *i < n)
}

fn get_rtde_value(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let key = a.text(0)?;
    let arm = &c.arm;
    let w = &arm.world;
    let v = match key.as_str() {
        "timestamp" => Value::Float(c.now().as_secs_f64()),
        "target_q" | "actual_q" => floats(arm.q),
        "target_qd" | "actual_qd" => floats(arm.qd),
        "target_qdd" => floats(arm.qdd),
        "target_TCP_pose" | "actual_TCP_pose" => floats(c.tcp_pose()),
        "target_TCP_speed" | "actual_TCP_speed" => floats(arm.tcp_speed),
        "actual_TCP_force" => floats(c.measured_tcp_force()),
        "joint_temperatures" => floats(w.joint_temp),
        "actual_execution_time" => Value::Float(w.execution_time),
        "robot_mode" => Value::Int(7),
        "safety_mode" | "safety_status" => Value::Int(1),
        "runtime_state" => Value::Int(2),
        "speed_scaling" | "target_speed_fraction" => Value::Float(arm.slider()),
        "actual_digital_input_bits" => bits(w.digital_in.iter().copied()),
        "actual_digital_output_bits" => bits(arm.digital_out.iter().copied()),
        "standard_analog_input0" => Value::Float(w.analog_in[0]),
        "standard_analog_input1" => Value::Float(w.analog_in[1]),
        "tool_analog_input0" => Value::Float(w.analog_in[2]),
        "tool_analog_input1" => Value::Float(w.analog_in[3]),
        "output_bit_registers0_to_31" => bits(arm.bool_regs[..32].iter().copied()),
        "output_bit_registers32_to_63" => bits(arm.bool_regs[32..64].iter().copied()),
        "input_bit_registers0_to_31" => bits(w.input_bool_regs[..32].iter().copied()),
        "input_bit_registers32_to_63" => bits(w.input_bool_regs[32..64].iter().copied()),
        "payload" => Value::Float(arm.payload_mass),
        "payload_cog" => float_list(&arm.payload_cog),
        "payload_inertia" => float_list(&arm.payload_inertia),
        k => {
            if let Some(i) = register(k, "output_int_register_", 48) {
                Value::Int(arm.int_regs[i])
            } else if let Some(i) = register(k, "output_double_register_", 48) {
                Value::Float(arm.float_regs[i])
            } else if let Some(i) = register(k, "input_int_register_", 48) {
                Value::Int(w.input_int_regs[i])
            } else if let Some(i) = register(k, "input_double_register_", 48) {
                Value::Float(w.input_float_regs[i])
            } else if let Some(i) = register(k, "output_bit_register_", 128).filter(|i| *i >= 64) {
                Value::Bool(arm.bool_regs[i])
            } else if let Some(i) = register(k, "input_bit_register_", 128).filter(|i| *i >= 64) {
                Value::Bool(w.input_bool_regs[i])
            } else {
                return Err(Fault::from(format!(
                    "`get_rtde_value`: \"{k}\" is not an RTDE output field this virtual controller serves"
                )));
            }
        }
    };
    Ok(Out::Value(v))
}
