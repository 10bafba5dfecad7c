//! `get_rtde_value(key)` (e-Series 5.x interfaces): the value of an RTDE output field, as
//! an RTDE client would read it, from the virtual arm's state.
//!
//! Every output field of [`crate::rtde_fields`] is served (the interpreter has no
//! PolyScope version, so no field is gated), read by the table's function from the
//! virtual arm:
//!
//! | source | value |
//! | --- | --- |
//! | `timestamp` | program time, s |
//! | target and actual joints, TCP pose and speed | the commanded ones ([`Arm`](crate::Arm)): the virtual arm follows its targets |
//! | `actual_TCP_force` | [`Arm::measured_tcp_force`](crate::Arm::measured_tcp_force): [`World::tcp_force`](crate::World::tcp_force) plus the contact plane's push |
//! | `target_moment` | [`World::joint_torques`](crate::World::joint_torques) |
//! | `joint_temperatures`, tool temperature and current | [`World::joint_temp`](crate::World::joint_temp), [`World::tool_temp`](crate::World::tool_temp), [`World::tool_current`](crate::World::tool_current) |
//! | `actual_execution_time` | [`World::execution_time`](crate::World::execution_time) |
//! | `robot_mode`, `safety_mode`, `safety_status`, `runtime_state` | 7 (running), 1 (normal), 1 (normal), 2 (playing): a program runs only on a running arm; `joint_mode` and the status bits follow |
//! | `speed_scaling`, `target_speed_fraction` | the speed slider, [`Arm::speed_fraction`](crate::Arm::speed_fraction) (1.0 unless a client set it) |
//! | `actual_digital_input_bits`, `actual_digital_output_bits` | the 18 digital inputs / outputs, bit n = I/O n |
//! | standard and tool analog inputs | [`World::analog_in`](crate::World::analog_in) |
//! | registers | the output registers as written, the input registers from the world |
//! | `payload`, `payload_cog`, `payload_inertia` | the active payload |
//!
//! The rest are the table's plausible constants. Types become URScript values: VECTOR6D,
//! VECTOR3D a list of floats, VECTOR6INT32 / VECTOR6UINT32 a list of ints, DOUBLE a
//! float, BOOL a bool, the integers an int; UINT32 and UINT64 (bit fields, counters) as
//! URScript's 32-bit int of their low 32 bits, so bit 31 reads negative.
//!
//! A key that is not an RTDE output field (an input such as `speed_slider_mask`, a
//! misspelt name, a register number out of range or with a leading zero) is a runtime
//! error naming it.

use super::{builtin, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::kinematics::Dh;
use crate::rtde_fields::{self, Direction, Field, RtdeSource, RtdeValue};
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Io;

pub(super) const TABLE: &[Builtin] = &[builtin!(
    get_rtde_value(key: String) => get_rtde_value,
    "The value of RTDE output field key, from the virtual arm's state.",
)];

/// Bools packed bit 0 first (at most 64).
fn bits(b: &[bool]) -> u64 {
    b.iter()
        .take(64)
        .enumerate()
        .fold(0, |acc, (i, &on)| acc | (u64::from(on) << i))
}

/// An RTDE value as a URScript value.
fn value(v: RtdeValue) -> Value {
    let floats = |v: &[f64]| Value::List(v.iter().map(|&x| Value::Float(x)).collect());
    match v {
        RtdeValue::Bool(b) => Value::Bool(b),
        RtdeValue::Uint8(x) => Value::Int(i32::from(x)),
        RtdeValue::Uint32(x) => Value::Int(x as i32),
        RtdeValue::Uint64(x) => Value::Int(x as u32 as i32),
        RtdeValue::Int32(x) => Value::Int(x),
        RtdeValue::Double(x) => Value::Float(x),
        RtdeValue::Vector3d(v) => floats(&v),
        RtdeValue::Vector6d(v) => floats(&v),
        RtdeValue::Vector6Int32(v) => Value::List(v.iter().map(|&x| Value::Int(x)).collect()),
        RtdeValue::Vector6Uint32(v) => {
            Value::List(v.iter().map(|&x| Value::Int(x as i32)).collect())
        }
    }
}

/// The virtual arm as an RTDE source: a running arm (robot mode 7, safety normal, a
/// program playing) whose targets are its actual values.
impl RtdeSource for Runtime {
    fn time(&self) -> f64 {
        self.now().as_secs_f64()
    }
    fn dh(&self) -> Dh {
        self.dh
    }
    fn robot_mode(&self) -> i32 {
        7
    }
    fn safety_status(&self) -> i32 {
        1
    }
    fn runtime_state(&self) -> u32 {
        2
    }
    fn target_q(&self) -> [f64; 6] {
        self.arm.q
    }
    fn target_qd(&self) -> [f64; 6] {
        self.arm.qd
    }
    fn target_qdd(&self) -> [f64; 6] {
        self.arm.qdd
    }
    fn actual_q(&self) -> [f64; 6] {
        self.arm.q
    }
    fn actual_qd(&self) -> [f64; 6] {
        self.arm.qd
    }
    fn target_moment(&self) -> [f64; 6] {
        self.arm.world.joint_torques
    }
    fn joint_temperatures(&self) -> [f64; 6] {
        self.arm.world.joint_temp
    }
    fn actual_execution_time(&self) -> f64 {
        self.arm.world.execution_time
    }
    fn actual_tcp_pose(&self) -> [f64; 6] {
        self.tcp_pose()
    }
    fn actual_tcp_speed(&self) -> [f64; 6] {
        self.arm.tcp_speed
    }
    fn actual_tcp_force(&self) -> [f64; 6] {
        self.measured_tcp_force()
    }
    fn target_tcp_pose(&self) -> [f64; 6] {
        self.tcp_pose()
    }
    fn target_tcp_speed(&self) -> [f64; 6] {
        self.arm.tcp_speed
    }
    fn tcp_offset(&self) -> [f64; 6] {
        self.arm.tcp
    }
    fn speed_fraction(&self) -> f64 {
        self.arm.slider()
    }
    fn speed_scaling(&self) -> f64 {
        self.arm.slider()
    }
    fn digital_inputs(&self) -> u64 {
        bits(&self.arm.world.digital_in)
    }
    fn digital_outputs(&self) -> u64 {
        bits(&self.arm.digital_out)
    }
    fn analog_inputs(&self) -> [f64; 2] {
        [self.arm.world.analog_in[0], self.arm.world.analog_in[1]]
    }
    fn analog_outputs(&self) -> [f64; 2] {
        let a = &self.arm;
        std::array::from_fn(|i| {
            rtde_fields::analog_output(a.analog_out[i], a.analog_out_domain[i] != 0)
        })
    }
    fn analog_io_types(&self) -> u32 {
        let d = self.arm.analog_out_domain;
        rtde_fields::analog_io_types([d[0] != 0, d[1] != 0])
    }
    fn tool_analog_inputs(&self) -> [f64; 2] {
        [self.arm.world.analog_in[2], self.arm.world.analog_in[3]]
    }
    fn tool_current(&self) -> f64 {
        self.arm.world.tool_current
    }
    fn tool_temperature(&self) -> f64 {
        self.arm.world.tool_temp
    }
    fn output_bool_registers(&self) -> &[bool] {
        &self.arm.bool_regs
    }
    fn output_int_registers(&self) -> &[i32] {
        &self.arm.int_regs
    }
    fn output_double_registers(&self) -> &[f64] {
        &self.arm.float_regs
    }
    fn input_bool_registers(&self) -> &[bool] {
        &self.arm.world.input_bool_regs
    }
    fn input_int_registers(&self) -> &[i32] {
        &self.arm.world.input_int_regs
    }
    fn input_double_registers(&self) -> &[f64] {
        &self.arm.world.input_float_regs
    }
    fn payload_mass(&self) -> f64 {
        self.arm.payload_mass
    }
    fn payload_cog(&self) -> [f64; 3] {
        self.arm.payload_cog
    }
    fn payload_inertia(&self) -> [f64; 6] {
        self.arm.payload_inertia
    }
}

fn get_rtde_value(c: &mut Runtime, _: &mut Args, key: String) -> Result<Out, Fault> {
    let field = Field::lookup(&key, Direction::Output).ok_or_else(|| {
        Fault::from(format!(
            "`get_rtde_value`: \"{key}\" is not an RTDE output field this virtual controller serves"
        ))
    })?;
    let v = field.read(&*c).ok_or_else(|| {
        Fault::from(format!(
            "`get_rtde_value`: \"{key}\" is not an output field"
        ))
    })?;
    Ok(Out::Value(value(v)))
}
