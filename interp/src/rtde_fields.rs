//! The RTDE field table: every field name UR's "Real-Time Data Exchange (RTDE) Guide"
//! lists, with its type, its direction, the controller version that introduced it and
//! how its value is read. The interpreter's `get_rtde_value` and `rtde_set_watchdog`
//! and the controller's RTDE server all look names up here, so a name is known to both
//! or to neither.
//!
//! ```
//! use urscript_interp::rtde_fields::{Direction, Field, RtdeType};
//!
//! let f = Field::lookup("input_int_register_5", Direction::Input).unwrap();
//! assert_eq!(f.rtde_type(), RtdeType::Int32);
//! assert_eq!(f.to_string(), "input_int_register_5");
//! // Names are spelled exactly: no leading zeros, no sign.
//! assert!(Field::lookup("input_int_register_05", Direction::Input).is_none());
//! // Outputs and inputs are separate tables.
//! assert!(Field::lookup("actual_q", Direction::Input).is_none());
//! ```
//!
//! # Names
//!
//! The fixed names are [`Field::all`]'s first entries. Registers come in families
//! ([`Register`]), one name rule for all: the family's prefix, then the number in
//! decimal without leading zeros or sign (`input_int_register_5`, not `_05` nor `_+5`),
//! as the controller matches names exactly:
//!
//! | family | numbers | type | outputs | inputs |
//! |---|---|---|---|---|
//! | `output_bit_register_N` | 64-127 | BOOL | yes | - |
//! | `output_int_register_N` | 0-47 | INT32 | yes | - |
//! | `output_double_register_N` | 0-47 | DOUBLE | yes | - |
//! | `input_bit_register_N` | 64-127 | BOOL | yes | yes |
//! | `input_int_register_N` | 0-47 | INT32 | yes | yes |
//! | `input_double_register_N` | 0-47 | DOUBLE | yes | yes |
//!
//! Bool registers 0-63 are read and written 32 at a time, as the `UINT32` fields
//! `output_bit_registers0_to_31`, `output_bit_registers32_to_63`,
//! `input_bit_registers0_to_31` and `input_bit_registers32_to_63` (bit n = register n).
//!
//! # Versions
//!
//! Fields later controller versions added are gated by [`Since`] (checked by the
//! controller's RTDE server against its PolyScope version; the interpreter, which has no
//! version, serves every field). The versions are the guide's notes as far as they
//! could be established, cross-checked with clients that gate on them (`ur_rtde` asks
//! `payload_inertia` of a 3.15 controller, `ft_raw_wrench` only of e-Series, and the
//! TCP acceleration of 5.23 and later); (approximate) marks a version not certain:
//!
//! | fields | CB3 | e-Series |
//! |---|---|---|
//! | registers 24-47 (int, double) and bool registers 64-127 | 3.9 | 5.3 |
//! | `elbow_position`, `elbow_velocity` | 3.5 | 5.0 |
//! | `safety_status` | 3.10 | 5.4 |
//! | `payload`, `payload_cog`, `payload_inertia` (outputs and inputs) | 3.11 | 5.5 |
//! | `script_control_line` | 3.14 (approximate) | 5.6 (approximate) |
//! | `tool_output_mode`, `tool_digital_output0_mode`, `tool_digital_output1_mode` | - | 5.2 (approximate) |
//! | `ft_raw_wrench`, input `external_force_torque` | - | 5.9 |
//! | `joint_position_deviation_ratio`, `collision_detection_ratio`, `time_scale_source` | - | 5.14 (approximate) |
//! | `actual_current_window`, `tcp_offset` | - | 5.20 (approximate) |
//! | `actual_current_as_torque`, `actual_TCP_acceleration`, `target_TCP_acceleration`, `actual_configurable_digital_input_bits`, `actual_configurable_digital_output_bits`, `target_execution_time`, `actual_robot_energy_consumed`, `actual_robot_braking_energy_dissipated`, `encoder0_raw`, `encoder1_raw`, `wrench_calc_from_currents`, `target_gravity`, `target_base_acceleration`, `control_step`, `target_base_wrench` | - | 5.23 (approximate) |
//!
//! Everything else is available from RTDE's first version (CB3 3.4, e-Series 5.0).
//!
//! # Values
//!
//! Each output is read from an [`RtdeSource`] (the controller's status, or the
//! interpreter's virtual arm) by one function of this table. Where the source has
//! nothing behind a field, the value is derived or a documented plausible constant:
//!
//! - `joint_control_output`: the target currents; `actual_current_window`: zeros;
//!   `actual_momentum`: 0; the euromap67 fields: 0 (no Euromap67 interface);
//!   `ft_raw_wrench`: the TCP force; `joint_position_deviation_ratio`,
//!   `collision_detection_ratio`, `time_scale_source`: 0; `tool_output_mode` 0,
//!   `tool_digital_output0_mode`/`1_mode` 1 (sinking NPN).
//! - The newest fields: `actual_current_as_torque` the target moments (the virtual arm
//!   follows its targets); `wrench_calc_from_currents` the TCP force; the TCP
//!   accelerations, `target_base_acceleration`, `target_base_wrench`, the energies and
//!   the encoders 0; `target_execution_time` 2.0 (ms, the e-Series period);
//!   `target_gravity` `[0, 0, -9.82]`; `control_step` the step count, `time / 2 ms`;
//!   the configurable digital inputs and outputs: bits 8-15 of the digital bits, shifted
//!   down to 0-7.
//! - `elbow_position` / `elbow_velocity`: [`elbow`], the origin of the frame after
//!   joint 2 (the end of the upper arm) from the model's DH parameters and `actual_q`,
//!   and its exact time derivative along `actual_qd`.
//! - `joint_mode` and `tool_mode`: [`joint_mode`], from the robot mode.
//! - `safety_mode`: the safety status code, with the two e-Series stops (12, 13)
//!   reported as 5 (safeguard stop), as the older field predates them.
//! - `robot_status_bits`: bit 0 power on (POWER_ON, IDLE, BACKDRIVE, RUNNING), bit 1
//!   program running; the teach and power buttons (bits 2, 3) are never pressed.
//! - `safety_status_bits`: [`safety_status_bits`].
//! - `tcp_force_scalar`: the norm of the TCP force's xyz part.
//!
//! Inputs are written by clients: [`Field::input`] says what each one sets.
//! `tool_digital_output_mask` / `tool_digital_output` are served although the guide's
//! input table omits them (controllers accept them and `ur_rtde`'s `RTDEIOInterface`
//! sets them up), and `payload`, `payload_cog`, `payload_inertia` as inputs (the
//! outputs' names), an extension of this virtual controller.

use std::fmt;

use crate::kinematics::Dh;

/// An RTDE data type, as the setup replies name it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RtdeType {
    /// `BOOL`, one byte 0 or 1.
    Bool,
    /// `UINT8`.
    Uint8,
    /// `UINT32`.
    Uint32,
    /// `UINT64`.
    Uint64,
    /// `INT32`.
    Int32,
    /// `DOUBLE`, IEEE 754 binary64.
    Double,
    /// `VECTOR3D`, three doubles.
    Vector3d,
    /// `VECTOR6D`, six doubles.
    Vector6d,
    /// `VECTOR6INT32`, six `INT32`.
    Vector6Int32,
    /// `VECTOR6UINT32`, six `UINT32`.
    Vector6Uint32,
}

impl RtdeType {
    /// The name in setup replies (`VECTOR6D`).
    pub fn name(self) -> &'static str {
        match self {
            RtdeType::Bool => "BOOL",
            RtdeType::Uint8 => "UINT8",
            RtdeType::Uint32 => "UINT32",
            RtdeType::Uint64 => "UINT64",
            RtdeType::Int32 => "INT32",
            RtdeType::Double => "DOUBLE",
            RtdeType::Vector3d => "VECTOR3D",
            RtdeType::Vector6d => "VECTOR6D",
            RtdeType::Vector6Int32 => "VECTOR6INT32",
            RtdeType::Vector6Uint32 => "VECTOR6UINT32",
        }
    }

    /// Its size on the wire, in bytes.
    pub fn size(self) -> usize {
        match self {
            RtdeType::Bool | RtdeType::Uint8 => 1,
            RtdeType::Uint32 | RtdeType::Int32 => 4,
            RtdeType::Uint64 | RtdeType::Double => 8,
            RtdeType::Vector3d => 24,
            RtdeType::Vector6d => 48,
            RtdeType::Vector6Int32 | RtdeType::Vector6Uint32 => 24,
        }
    }
}

impl fmt::Display for RtdeType {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One value of an RTDE field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RtdeValue {
    /// `BOOL`.
    Bool(bool),
    /// `UINT8`.
    Uint8(u8),
    /// `UINT32`.
    Uint32(u32),
    /// `UINT64`.
    Uint64(u64),
    /// `INT32`.
    Int32(i32),
    /// `DOUBLE`.
    Double(f64),
    /// `VECTOR3D`.
    Vector3d([f64; 3]),
    /// `VECTOR6D`.
    Vector6d([f64; 6]),
    /// `VECTOR6INT32`.
    Vector6Int32([i32; 6]),
    /// `VECTOR6UINT32`.
    Vector6Uint32([u32; 6]),
}

impl RtdeValue {
    /// Its type.
    pub fn rtde_type(&self) -> RtdeType {
        match self {
            RtdeValue::Bool(_) => RtdeType::Bool,
            RtdeValue::Uint8(_) => RtdeType::Uint8,
            RtdeValue::Uint32(_) => RtdeType::Uint32,
            RtdeValue::Uint64(_) => RtdeType::Uint64,
            RtdeValue::Int32(_) => RtdeType::Int32,
            RtdeValue::Double(_) => RtdeType::Double,
            RtdeValue::Vector3d(_) => RtdeType::Vector3d,
            RtdeValue::Vector6d(_) => RtdeType::Vector6d,
            RtdeValue::Vector6Int32(_) => RtdeType::Vector6Int32,
            RtdeValue::Vector6Uint32(_) => RtdeType::Vector6Uint32,
        }
    }

    /// Append its big-endian bytes to `out`.
    pub fn encode(&self, out: &mut Vec<u8>) {
        match *self {
            RtdeValue::Bool(b) => out.push(u8::from(b)),
            RtdeValue::Uint8(v) => out.push(v),
            RtdeValue::Uint32(v) => out.extend_from_slice(&v.to_be_bytes()),
            RtdeValue::Uint64(v) => out.extend_from_slice(&v.to_be_bytes()),
            RtdeValue::Int32(v) => out.extend_from_slice(&v.to_be_bytes()),
            RtdeValue::Double(v) => out.extend_from_slice(&v.to_be_bytes()),
            RtdeValue::Vector3d(v) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
            RtdeValue::Vector6d(v) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
            RtdeValue::Vector6Int32(v) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
            RtdeValue::Vector6Uint32(v) => v
                .iter()
                .for_each(|x| out.extend_from_slice(&x.to_be_bytes())),
        }
    }

    /// Read a value of type `ty` from the start of `bytes`: the value and the rest, or
    /// `None` when `bytes` is too short.
    pub fn decode(ty: RtdeType, bytes: &[u8]) -> Option<(RtdeValue, &[u8])> {
        let mut r = bytes;
        let v = match ty {
            RtdeType::Bool => RtdeValue::Bool(take::<1>(&mut r)?[0] != 0),
            RtdeType::Uint8 => RtdeValue::Uint8(take::<1>(&mut r)?[0]),
            RtdeType::Uint32 => RtdeValue::Uint32(u32::from_be_bytes(take(&mut r)?)),
            RtdeType::Uint64 => RtdeValue::Uint64(u64::from_be_bytes(take(&mut r)?)),
            RtdeType::Int32 => RtdeValue::Int32(i32::from_be_bytes(take(&mut r)?)),
            RtdeType::Double => RtdeValue::Double(f64::from_be_bytes(take(&mut r)?)),
            RtdeType::Vector3d => RtdeValue::Vector3d(doubles(&mut r)?),
            RtdeType::Vector6d => RtdeValue::Vector6d(doubles(&mut r)?),
            RtdeType::Vector6Int32 => {
                let mut a = [0i32; 6];
                for x in &mut a {
                    *x = i32::from_be_bytes(take(&mut r)?);
                }
                RtdeValue::Vector6Int32(a)
            }
            RtdeType::Vector6Uint32 => {
                let mut a = [0u32; 6];
                for x in &mut a {
                    *x = u32::from_be_bytes(take(&mut r)?);
                }
                RtdeValue::Vector6Uint32(a)
            }
        };
        Some((v, r))
    }
}

/// The first `N` bytes of `r`, which moves past them; `None` when it is shorter.
fn take<const N: usize>(r: &mut &[u8]) -> Option<[u8; N]> {
    let (head, rest) = r.split_first_chunk::<N>()?;
    *r = rest;
    Some(*head)
}

fn doubles<const N: usize>(r: &mut &[u8]) -> Option<[f64; N]> {
    let mut a = [0.0; N];
    for x in &mut a {
        *x = f64::from_be_bytes(take(r)?);
    }
    Some(a)
}

/// Which way a field goes, seen from the controller: outputs are sent to clients,
/// inputs written by them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Direction {
    /// Sent by the controller (CONTROL_PACKAGE_SETUP_OUTPUTS).
    Output,
    /// Written by a client (CONTROL_PACKAGE_SETUP_INPUTS).
    Input,
}

/// The controller versions a field exists from: `(major, minor)` on CB3 (`None`: not on
/// CB3) and on e-Series (major 5 and later).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Since {
    /// The first CB3 version, if any.
    pub cb3: Option<(u32, u32)>,
    /// The first e-Series version.
    pub e_series: (u32, u32),
}

impl Since {
    /// Whether a controller of `version` (`[major, minor, bugfix, build]`) has the field.
    pub fn allows(self, version: [u32; 4]) -> bool {
        let [major, minor, ..] = version;
        let min = if major >= 5 {
            Some(self.e_series)
        } else {
            self.cb3
        };
        min.is_some_and(|m| (major, minor) >= m)
    }
}

const fn since(cb3: Option<(u32, u32)>, e_series: (u32, u32)) -> Since {
    Since { cb3, e_series }
}

const ALWAYS: Since = since(Some((3, 4)), (5, 0));
const UPPER_REGISTERS: Since = since(Some((3, 9)), (5, 3));
const ELBOW: Since = since(Some((3, 5)), (5, 0));
const SAFETY_STATUS: Since = since(Some((3, 10)), (5, 4));
const PAYLOAD: Since = since(Some((3, 11)), (5, 5));
const SCRIPT_LINE: Since = since(Some((3, 14)), (5, 6));
const TOOL_MODES: Since = since(None, (5, 2));
const FT_RAW: Since = since(None, (5, 9));
const RATIOS: Since = since(None, (5, 14));
const NEWER: Since = since(None, (5, 20));
const NEWEST: Since = since(None, (5, 23));

/// What the outputs are read from: one picture of the arm and controller. Units as
/// UR's interfaces carry them: radians, rad/s, metres, m/s, N, Nm, A, V, °C, seconds.
/// The provided methods give the plausible constants a source without a physical
/// world uses.
pub trait RtdeSource {
    /// Seconds since the controller started (`timestamp`).
    fn time(&self) -> f64;
    /// The arm's DH parameters (`elbow_position`).
    fn dh(&self) -> Dh;
    /// The robot mode code (-1 no controller ... 7 running, 8 updating firmware).
    fn robot_mode(&self) -> i32;
    /// The safety status code (1 normal ... 9 fault, 12, 13).
    fn safety_status(&self) -> i32;
    /// The runtime state (1 stopped, 2 playing, 4 paused).
    fn runtime_state(&self) -> u32;
    /// The line of the script running now, 0 when none.
    fn script_line(&self) -> u32 {
        0
    }
    /// Target joint positions.
    fn target_q(&self) -> [f64; 6];
    /// Target joint velocities.
    fn target_qd(&self) -> [f64; 6];
    /// Target joint accelerations.
    fn target_qdd(&self) -> [f64; 6];
    /// Actual joint positions.
    fn actual_q(&self) -> [f64; 6];
    /// Actual joint velocities.
    fn actual_qd(&self) -> [f64; 6];
    /// Target joint currents (A): 0.
    fn target_current(&self) -> [f64; 6] {
        [0.0; 6]
    }
    /// Actual joint currents (A): 0.
    fn actual_current(&self) -> [f64; 6] {
        [0.0; 6]
    }
    /// Target joint moments (Nm).
    fn target_moment(&self) -> [f64; 6];
    /// Joint temperatures (°C).
    fn joint_temperatures(&self) -> [f64; 6];
    /// Joint voltages (V): 48 each.
    fn joint_voltage(&self) -> [f64; 6] {
        [48.0; 6]
    }
    /// The controller thread's execution time per step (ms).
    fn actual_execution_time(&self) -> f64;
    /// Actual TCP pose (base frame, rotation vector).
    fn actual_tcp_pose(&self) -> [f64; 6];
    /// Actual TCP speed.
    fn actual_tcp_speed(&self) -> [f64; 6];
    /// Generalised forces at the TCP.
    fn actual_tcp_force(&self) -> [f64; 6];
    /// Target TCP pose.
    fn target_tcp_pose(&self) -> [f64; 6];
    /// Target TCP speed.
    fn target_tcp_speed(&self) -> [f64; 6];
    /// The active TCP offset.
    fn tcp_offset(&self) -> [f64; 6];
    /// The tool accelerometer (m/s², tool frame): gravity only, `[0, 0, 9.82]`.
    fn tool_accelerometer(&self) -> [f64; 3] {
        [0.0, 0.0, 9.82]
    }
    /// The speed slider (0..1).
    fn speed_fraction(&self) -> f64;
    /// The speed scaling in effect (0..1).
    fn speed_scaling(&self) -> f64;
    /// Digital inputs: bits 0-7 standard, 8-15 configurable, 16-17 tool.
    fn digital_inputs(&self) -> u64;
    /// Digital outputs, the same bits.
    fn digital_outputs(&self) -> u64;
    /// Standard analog inputs 0-1.
    fn analog_inputs(&self) -> [f64; 2];
    /// Standard analog outputs 0-1.
    fn analog_outputs(&self) -> [f64; 2];
    /// Analog domains: bits 0, 1 the inputs, 2, 3 the outputs (0 current, 1 voltage).
    fn analog_io_types(&self) -> u32;
    /// Tool analog inputs 0-1.
    fn tool_analog_inputs(&self) -> [f64; 2];
    /// Tool analog input types: bits 0, 1 (0 current, 1 voltage): both voltage.
    fn tool_analog_input_types(&self) -> u32 {
        0b11
    }
    /// Tool output voltage (V): 0.
    fn tool_output_voltage(&self) -> i32 {
        0
    }
    /// Tool current (A).
    fn tool_current(&self) -> f64;
    /// Tool temperature (°C).
    fn tool_temperature(&self) -> f64;
    /// I/O current (A): 0.
    fn io_current(&self) -> f64 {
        0.0
    }
    /// Output bool registers 0-127 (a register past the end reads False).
    fn output_bool_registers(&self) -> &[bool];
    /// Output int registers 0-47.
    fn output_int_registers(&self) -> &[i32];
    /// Output double registers 0-47.
    fn output_double_registers(&self) -> &[f64];
    /// Input bool registers 0-127.
    fn input_bool_registers(&self) -> &[bool];
    /// Input int registers 0-47.
    fn input_int_registers(&self) -> &[i32];
    /// Input double registers 0-47.
    fn input_double_registers(&self) -> &[f64];
    /// Payload mass (kg).
    fn payload_mass(&self) -> f64;
    /// Payload centre of gravity (m, flange frame).
    fn payload_cog(&self) -> [f64; 3];
    /// Payload inertia `[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]` (kg·m²).
    fn payload_inertia(&self) -> [f64; 6];
    /// Main voltage (V): 48.
    fn main_voltage(&self) -> f64 {
        48.0
    }
    /// Robot voltage (V): 48 (powered).
    fn robot_voltage(&self) -> f64 {
        48.0
    }
    /// Robot current (A): 0.5 (powered).
    fn robot_current(&self) -> f64 {
        0.5
    }
}

/// The joint mode code every interface reports (RTDE `joint_mode` and `tool_mode`, the
/// primary interface's joint and tool data, the realtime joint modes) for a robot mode
/// code and a safety status code: a safety violation (8) or fault (9) shows as
/// VIOLATION 251 or FAULT 252; otherwise the robot mode's: RUNNING 253, IDLE 255,
/// BOOTING 247, MOTOR_INITIALISATION 246 (power on), BACKDRIVE 238, BOOTLOADER 249
/// (updating firmware), POWER_OFF 239 (power off, and no controller, disconnected or
/// confirm safety).
pub fn joint_mode(robot_mode: i32, safety_status: i32) -> i32 {
    match safety_status {
        8 => return 251,
        9 => return 252,
        _ => {}
    }
    match robot_mode {
        7 => 253,
        5 => 255,
        2 => 247,
        4 => 246,
        6 => 238,
        8 => 249,
        _ => 239,
    }
}

/// RTDE's `safety_status_bits` for a safety status code: bit 0 normal, 1 reduced,
/// 2 protective stopped, 3 recovery, 4 safeguard stopped, 5 system emergency stopped,
/// 6 robot emergency stopped, 7 emergency stopped (either), 8 violation, 9 fault,
/// 10 stopped due to safety (any of 2 and 4-9, and the two e-Series stops 12 and 13,
/// which also set bit 4).
pub fn safety_status_bits(safety_status: i32) -> u32 {
    let bits: &[u32] = match safety_status {
        1 => &[0],
        2 => &[1],
        3 => &[2, 10],
        4 => &[3, 10],
        5 | 12 | 13 => &[4, 10],
        6 => &[5, 7, 10],
        7 => &[6, 7, 10],
        8 => &[8, 10],
        9 => &[9, 10],
        _ => &[],
    };
    bits.iter().fold(0, |acc, b| acc | 1 << b)
}

/// The elbow's position and velocity in the base frame: the origin of the frame after
/// joint 2 (the end of the upper arm, where the elbow joint's axis is), from the DH
/// parameters at joint positions `q`, and its time derivative when the joints move at
/// `qd` (only joints 1 and 2 move it).
pub fn elbow(dh: &Dh, q: [f64; 6], qd: [f64; 6]) -> ([f64; 3], [f64; 3]) {
    let (s1, c1) = q[0].sin_cos();
    let (s2, c2) = q[1].sin_cos();
    let (sa, ca) = dh.alpha[0].sin_cos();
    // Joint 2's axis and origin: frame 1 = Rz(q1) Tz(d1) Tx(a1) Rx(alpha1).
    let o1 = [dh.a[0] * c1, dh.a[0] * s1, dh.d[0]];
    let z1 = [s1 * sa, -c1 * sa, ca];
    // Frame 2's origin in frame 1: Rz(q2) Tz(d2) Tx(a2), then rotated by Rx(alpha1)
    // and Rz(q1).
    let (x, y, z) = (dh.a[1] * c2, dh.a[1] * s2, dh.d[1]);
    let (y, z) = (y * ca - z * sa, y * sa + z * ca);
    let p = [o1[0] + x * c1 - y * s1, o1[1] + x * s1 + y * c1, o1[2] + z];
    // Joint 1 turns p about the base's z axis; joint 2 about z1 through o1.
    let r = [p[0] - o1[0], p[1] - o1[1], p[2] - o1[2]];
    let (w1, w2) = (qd[0], qd[1]);
    let v = [
        w1 * -p[1] + w2 * (z1[1] * r[2] - z1[2] * r[1]),
        w1 * p[0] + w2 * (z1[2] * r[0] - z1[0] * r[2]),
        w2 * (z1[0] * r[1] - z1[1] * r[0]),
    ];
    (p, v)
}

/// A standard analog output's value as RTDE and the primary interface carry it, from
/// the fraction of its range the program or a client set: 4-20 mA (in A) for a current
/// output, 0-10 V for a voltage output.
pub fn analog_output(fraction: f64, voltage: bool) -> f64 {
    if voltage {
        10.0 * fraction
    } else {
        (4.0 + 16.0 * fraction) / 1000.0
    }
}

/// RTDE's `analog_io_types`: bits 0, 1 the standard analog inputs (always voltage
/// here), bits 2, 3 the outputs (set: voltage).
pub fn analog_io_types(output_voltage: [bool; 2]) -> u32 {
    0b11 | u32::from(output_voltage[0]) << 2 | u32::from(output_voltage[1]) << 3
}

/// Bools from `from` on (32 of them, or fewer at the end), packed bit 0 first.
fn pack_bits(bits: &[bool], from: usize) -> u32 {
    bits.iter()
        .skip(from)
        .take(32)
        .enumerate()
        .fold(0, |acc, (i, b)| acc | (u32::from(*b) << i))
}

/// What an input field writes. Masks and values are separate fields: a client sends
/// a value with its mask (in the same package or an earlier one).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Input {
    /// `speed_slider_mask` (`UINT32`, bit 0: apply the fraction).
    SpeedSliderMask,
    /// `speed_slider_fraction` (0..1).
    SpeedSliderFraction,
    /// `standard_digital_output_mask`.
    StandardDigitalOutputMask,
    /// `standard_digital_output` (outputs 0-7).
    StandardDigitalOutput,
    /// `configurable_digital_output_mask`.
    ConfigurableDigitalOutputMask,
    /// `configurable_digital_output` (outputs 8-15).
    ConfigurableDigitalOutput,
    /// `tool_digital_output_mask`.
    ToolDigitalOutputMask,
    /// `tool_digital_output` (tool outputs 0-1).
    ToolDigitalOutput,
    /// `standard_analog_output_mask`.
    StandardAnalogOutputMask,
    /// `standard_analog_output_type` (bit n: output n is a voltage).
    StandardAnalogOutputType,
    /// `standard_analog_output_0` / `_1` (a fraction of the range).
    StandardAnalogOutput(u8),
    /// `input_bit_registers0_to_31` (0) / `input_bit_registers32_to_63` (32): 32 bool
    /// registers from this one.
    BitRegisters(u8),
    /// `input_bit_register_N`, N in 64-127.
    BitRegister(u8),
    /// `input_int_register_N`, N in 0-47.
    IntRegister(u8),
    /// `input_double_register_N`, N in 0-47.
    DoubleRegister(u8),
    /// `external_force_torque` (the external F/T sensor's wrench).
    ExternalForceTorque,
    /// `payload` (kg).
    Payload,
    /// `payload_cog`.
    PayloadCog,
    /// `payload_inertia`.
    PayloadInertia,
}

/// How an output is read: a function of the source whose result type is the field's
/// RTDE type.
#[derive(Clone, Copy)]
enum Read {
    Double(fn(&dyn RtdeSource) -> f64),
    Vector3d(fn(&dyn RtdeSource) -> [f64; 3]),
    Vector6d(fn(&dyn RtdeSource) -> [f64; 6]),
    Int32(fn(&dyn RtdeSource) -> i32),
    Uint8(fn(&dyn RtdeSource) -> u8),
    Uint32(fn(&dyn RtdeSource) -> u32),
    Uint64(fn(&dyn RtdeSource) -> u64),
    Vector6Int32(fn(&dyn RtdeSource) -> [i32; 6]),
}

impl Read {
    fn rtde_type(self) -> RtdeType {
        match self {
            Read::Double(_) => RtdeType::Double,
            Read::Vector3d(_) => RtdeType::Vector3d,
            Read::Vector6d(_) => RtdeType::Vector6d,
            Read::Int32(_) => RtdeType::Int32,
            Read::Uint8(_) => RtdeType::Uint8,
            Read::Uint32(_) => RtdeType::Uint32,
            Read::Uint64(_) => RtdeType::Uint64,
            Read::Vector6Int32(_) => RtdeType::Vector6Int32,
        }
    }

    fn read(self, s: &dyn RtdeSource) -> RtdeValue {
        match self {
            Read::Double(f) => RtdeValue::Double(f(s)),
            Read::Vector3d(f) => RtdeValue::Vector3d(f(s)),
            Read::Vector6d(f) => RtdeValue::Vector6d(f(s)),
            Read::Int32(f) => RtdeValue::Int32(f(s)),
            Read::Uint8(f) => RtdeValue::Uint8(f(s)),
            Read::Uint32(f) => RtdeValue::Uint32(f(s)),
            Read::Uint64(f) => RtdeValue::Uint64(f(s)),
            Read::Vector6Int32(f) => RtdeValue::Vector6Int32(f(s)),
        }
    }
}

/// How a fixed-name field is served.
#[derive(Clone, Copy)]
enum Kind {
    /// An output, read so.
    Output(Read),
    /// An input of this type, writing this.
    Input(RtdeType, Input),
}

/// One fixed-name field.
struct Named {
    name: &'static str,
    since: Since,
    kind: Kind,
}

impl Named {
    fn rtde_type(&self) -> RtdeType {
        match self.kind {
            Kind::Output(r) => r.rtde_type(),
            Kind::Input(ty, _) => ty,
        }
    }

    fn direction(&self) -> Direction {
        match self.kind {
            Kind::Output(_) => Direction::Output,
            Kind::Input(..) => Direction::Input,
        }
    }
}

/// The table's constructors, one per output type (`v6`: VECTOR6D ...) and `inp` for
/// inputs.
macro_rules! outputs {
    ($($f:ident: $t:ty => $v:ident),*) => {$(
        const fn $f(name: &'static str, since: Since, read: fn(&dyn RtdeSource) -> $t) -> Named {
            Named { name, since, kind: Kind::Output(Read::$v(read)) }
        }
    )*};
}

outputs!(f64_: f64 => Double, v3: [f64; 3] => Vector3d, v6: [f64; 6] => Vector6d,
    i32_: i32 => Int32, u8_: u8 => Uint8, u32_: u32 => Uint32, u64_: u64 => Uint64,
    v6i32: [i32; 6] => Vector6Int32);

const fn inp(name: &'static str, ty: RtdeType, since: Since, input: Input) -> Named {
    Named {
        name,
        since,
        kind: Kind::Input(ty, input),
    }
}

use RtdeType as T;
use RtdeValue as V;

/// Every fixed-name field, outputs then inputs (a name may be both: `payload`,
/// `input_bit_registers0_to_31`).
const NAMED: &[Named] = &[
    f64_("timestamp", ALWAYS, |s| s.time()),
    v6("target_q", ALWAYS, |s| s.target_q()),
    v6("target_qd", ALWAYS, |s| s.target_qd()),
    v6("target_qdd", ALWAYS, |s| s.target_qdd()),
    v6("target_current", ALWAYS, |s| s.target_current()),
    v6("target_moment", ALWAYS, |s| s.target_moment()),
    v6("actual_q", ALWAYS, |s| s.actual_q()),
    v6("actual_qd", ALWAYS, |s| s.actual_qd()),
    v6("actual_current", ALWAYS, |s| s.actual_current()),
    v6("actual_current_window", NEWER, |_| [0.0; 6]),
    v6("joint_control_output", ALWAYS, |s| s.target_current()),
    v6("actual_TCP_pose", ALWAYS, |s| s.actual_tcp_pose()),
    v6("actual_TCP_speed", ALWAYS, |s| s.actual_tcp_speed()),
    v6("actual_TCP_force", ALWAYS, |s| s.actual_tcp_force()),
    v6("target_TCP_pose", ALWAYS, |s| s.target_tcp_pose()),
    v6("target_TCP_speed", ALWAYS, |s| s.target_tcp_speed()),
    u64_("actual_digital_input_bits", ALWAYS, |s| s.digital_inputs()),
    v6("joint_temperatures", ALWAYS, |s| s.joint_temperatures()),
    f64_("actual_execution_time", ALWAYS, |s| {
        s.actual_execution_time()
    }),
    i32_("robot_mode", ALWAYS, |s| s.robot_mode()),
    v6i32("joint_mode", ALWAYS, |s| {
        [joint_mode(s.robot_mode(), s.safety_status()); 6]
    }),
    i32_("safety_mode", ALWAYS, |s| match s.safety_status() {
        12 | 13 => 5,
        code => code,
    }),
    i32_("safety_status", SAFETY_STATUS, |s| s.safety_status()),
    v3("actual_tool_accelerometer", ALWAYS, |s| {
        s.tool_accelerometer()
    }),
    f64_("speed_scaling", ALWAYS, |s| s.speed_scaling()),
    f64_("target_speed_fraction", ALWAYS, |s| s.speed_fraction()),
    f64_("actual_momentum", ALWAYS, |_| 0.0),
    f64_("actual_main_voltage", ALWAYS, |s| s.main_voltage()),
    f64_("actual_robot_voltage", ALWAYS, |s| s.robot_voltage()),
    f64_("actual_robot_current", ALWAYS, |s| s.robot_current()),
    v6("actual_joint_voltage", ALWAYS, |s| s.joint_voltage()),
    u64_("actual_digital_output_bits", ALWAYS, |s| {
        s.digital_outputs()
    }),
    u32_("runtime_state", ALWAYS, |s| s.runtime_state()),
    v3("elbow_position", ELBOW, |s| {
        elbow(&s.dh(), s.actual_q(), s.actual_qd()).0
    }),
    v3("elbow_velocity", ELBOW, |s| {
        elbow(&s.dh(), s.actual_q(), s.actual_qd()).1
    }),
    u32_("robot_status_bits", ALWAYS, |s| {
        let power = matches!(s.robot_mode(), 4..=7);
        let running = s.runtime_state() == 2;
        u32::from(power) | u32::from(running) << 1
    }),
    u32_("safety_status_bits", ALWAYS, |s| {
        safety_status_bits(s.safety_status())
    }),
    u32_("analog_io_types", ALWAYS, |s| s.analog_io_types()),
    f64_("standard_analog_input0", ALWAYS, |s| s.analog_inputs()[0]),
    f64_("standard_analog_input1", ALWAYS, |s| s.analog_inputs()[1]),
    f64_("standard_analog_output0", ALWAYS, |s| s.analog_outputs()[0]),
    f64_("standard_analog_output1", ALWAYS, |s| s.analog_outputs()[1]),
    f64_("io_current", ALWAYS, |s| s.io_current()),
    u32_("euromap67_input_bits", ALWAYS, |_| 0),
    u32_("euromap67_output_bits", ALWAYS, |_| 0),
    f64_("euromap67_24V_voltage", ALWAYS, |_| 0.0),
    f64_("euromap67_24V_current", ALWAYS, |_| 0.0),
    u32_("tool_mode", ALWAYS, |s| {
        joint_mode(s.robot_mode(), s.safety_status()) as u32
    }),
    u32_("tool_analog_input_types", ALWAYS, |s| {
        s.tool_analog_input_types()
    }),
    f64_("tool_analog_input0", ALWAYS, |s| s.tool_analog_inputs()[0]),
    f64_("tool_analog_input1", ALWAYS, |s| s.tool_analog_inputs()[1]),
    i32_("tool_output_voltage", ALWAYS, |s| s.tool_output_voltage()),
    f64_("tool_output_current", ALWAYS, |s| s.tool_current()),
    f64_("tool_temperature", ALWAYS, |s| s.tool_temperature()),
    f64_("tcp_force_scalar", ALWAYS, |s| {
        let [fx, fy, fz, ..] = s.actual_tcp_force();
        (fx * fx + fy * fy + fz * fz).sqrt()
    }),
    u32_("output_bit_registers0_to_31", ALWAYS, |s| {
        pack_bits(s.output_bool_registers(), 0)
    }),
    u32_("output_bit_registers32_to_63", ALWAYS, |s| {
        pack_bits(s.output_bool_registers(), 32)
    }),
    u32_("input_bit_registers0_to_31", ALWAYS, |s| {
        pack_bits(s.input_bool_registers(), 0)
    }),
    u32_("input_bit_registers32_to_63", ALWAYS, |s| {
        pack_bits(s.input_bool_registers(), 32)
    }),
    u8_("tool_output_mode", TOOL_MODES, |_| 0),
    u8_("tool_digital_output0_mode", TOOL_MODES, |_| 1),
    u8_("tool_digital_output1_mode", TOOL_MODES, |_| 1),
    f64_("payload", PAYLOAD, |s| s.payload_mass()),
    v3("payload_cog", PAYLOAD, |s| s.payload_cog()),
    v6("payload_inertia", PAYLOAD, |s| s.payload_inertia()),
    u32_("script_control_line", SCRIPT_LINE, |s| s.script_line()),
    v6("ft_raw_wrench", FT_RAW, |s| s.actual_tcp_force()),
    f64_("joint_position_deviation_ratio", RATIOS, |_| 0.0),
    f64_("collision_detection_ratio", RATIOS, |_| 0.0),
    i32_("time_scale_source", RATIOS, |_| 0),
    v6("tcp_offset", NEWER, |s| s.tcp_offset()),
    v6("actual_current_as_torque", NEWEST, |s| s.target_moment()),
    v6("actual_TCP_acceleration", NEWEST, |_| [0.0; 6]),
    v6("target_TCP_acceleration", NEWEST, |_| [0.0; 6]),
    u64_("actual_configurable_digital_input_bits", NEWEST, |s| {
        s.digital_inputs() >> 8 & 0xff
    }),
    u64_("actual_configurable_digital_output_bits", NEWEST, |s| {
        s.digital_outputs() >> 8 & 0xff
    }),
    f64_("target_execution_time", NEWEST, |_| 2.0),
    f64_("actual_robot_energy_consumed", NEWEST, |_| 0.0),
    f64_("actual_robot_braking_energy_dissipated", NEWEST, |_| 0.0),
    i32_("encoder0_raw", NEWEST, |_| 0),
    i32_("encoder1_raw", NEWEST, |_| 0),
    v6("wrench_calc_from_currents", NEWEST, |s| {
        s.actual_tcp_force()
    }),
    v3("target_gravity", NEWEST, |_| [0.0, 0.0, -9.82]),
    v6("target_base_acceleration", NEWEST, |_| [0.0; 6]),
    u64_("control_step", NEWEST, |s| {
        (s.time().max(0.0) / 0.002).round() as u64
    }),
    v6("target_base_wrench", NEWEST, |_| [0.0; 6]),
    inp(
        "speed_slider_mask",
        T::Uint32,
        ALWAYS,
        Input::SpeedSliderMask,
    ),
    inp(
        "speed_slider_fraction",
        T::Double,
        ALWAYS,
        Input::SpeedSliderFraction,
    ),
    inp(
        "standard_digital_output_mask",
        T::Uint8,
        ALWAYS,
        Input::StandardDigitalOutputMask,
    ),
    inp(
        "standard_digital_output",
        T::Uint8,
        ALWAYS,
        Input::StandardDigitalOutput,
    ),
    inp(
        "configurable_digital_output_mask",
        T::Uint8,
        ALWAYS,
        Input::ConfigurableDigitalOutputMask,
    ),
    inp(
        "configurable_digital_output",
        T::Uint8,
        ALWAYS,
        Input::ConfigurableDigitalOutput,
    ),
    inp(
        "tool_digital_output_mask",
        T::Uint8,
        ALWAYS,
        Input::ToolDigitalOutputMask,
    ),
    inp(
        "tool_digital_output",
        T::Uint8,
        ALWAYS,
        Input::ToolDigitalOutput,
    ),
    inp(
        "standard_analog_output_mask",
        T::Uint8,
        ALWAYS,
        Input::StandardAnalogOutputMask,
    ),
    inp(
        "standard_analog_output_type",
        T::Uint8,
        ALWAYS,
        Input::StandardAnalogOutputType,
    ),
    inp(
        "standard_analog_output_0",
        T::Double,
        ALWAYS,
        Input::StandardAnalogOutput(0),
    ),
    inp(
        "standard_analog_output_1",
        T::Double,
        ALWAYS,
        Input::StandardAnalogOutput(1),
    ),
    inp(
        "input_bit_registers0_to_31",
        T::Uint32,
        ALWAYS,
        Input::BitRegisters(0),
    ),
    inp(
        "input_bit_registers32_to_63",
        T::Uint32,
        ALWAYS,
        Input::BitRegisters(32),
    ),
    inp(
        "external_force_torque",
        T::Vector6d,
        FT_RAW,
        Input::ExternalForceTorque,
    ),
    inp("payload", T::Double, PAYLOAD, Input::Payload),
    inp("payload_cog", T::Vector3d, PAYLOAD, Input::PayloadCog),
    inp(
        "payload_inertia",
        T::Vector6d,
        PAYLOAD,
        Input::PayloadInertia,
    ),
];

/// A family of numbered registers: `prefix` then the number.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Register {
    /// `output_bit_register_N`, 64-127, BOOL (output only).
    OutputBit,
    /// `output_int_register_N`, 0-47, INT32 (output only).
    OutputInt,
    /// `output_double_register_N`, 0-47, DOUBLE (output only).
    OutputDouble,
    /// `input_bit_register_N`, 64-127, BOOL.
    InputBit,
    /// `input_int_register_N`, 0-47, INT32.
    InputInt,
    /// `input_double_register_N`, 0-47, DOUBLE.
    InputDouble,
}

/// Every register family.
const REGISTERS: [Register; 6] = [
    Register::OutputBit,
    Register::OutputInt,
    Register::OutputDouble,
    Register::InputBit,
    Register::InputInt,
    Register::InputDouble,
];

impl Register {
    /// The name before the number (`input_int_register_`).
    pub fn prefix(self) -> &'static str {
        match self {
            Register::OutputBit => "output_bit_register_",
            Register::OutputInt => "output_int_register_",
            Register::OutputDouble => "output_double_register_",
            Register::InputBit => "input_bit_register_",
            Register::InputInt => "input_int_register_",
            Register::InputDouble => "input_double_register_",
        }
    }

    /// The numbers the family has: 64-127 for bools (0-63 are the two `UINT32`
    /// fields), 0-47 for ints and doubles.
    pub fn numbers(self) -> std::ops::RangeInclusive<u8> {
        match self {
            Register::OutputBit | Register::InputBit => 64..=127,
            _ => 0..=47,
        }
    }

    /// Its type.
    pub fn rtde_type(self) -> RtdeType {
        match self {
            Register::OutputBit | Register::InputBit => RtdeType::Bool,
            Register::OutputInt | Register::InputInt => RtdeType::Int32,
            Register::OutputDouble | Register::InputDouble => RtdeType::Double,
        }
    }

    /// Whether clients may write it (the input families; every family is an output).
    pub fn is_input(self) -> bool {
        matches!(
            self,
            Register::InputBit | Register::InputInt | Register::InputDouble
        )
    }

    /// Register `n` of this family, by the one name rule: `n` spelled in decimal,
    /// without sign or leading zeros, within [`Register::numbers`].
    fn parse(self, name: &str) -> Option<u8> {
        let digits = name.strip_prefix(self.prefix())?;
        if digits.is_empty()
            || digits.len() > 3
            || !digits.bytes().all(|b| b.is_ascii_digit())
            || (digits.len() > 1 && digits.starts_with('0'))
        {
            return None;
        }
        let n: u8 = digits.parse().ok()?;
        self.numbers().contains(&n).then_some(n)
    }

    /// The versions register `n` exists from: ints and doubles 24-47 and every
    /// individually named bool (64-127) are the upper ranges.
    fn since(self, n: u8) -> Since {
        if n >= 24 {
            UPPER_REGISTERS
        } else {
            ALWAYS
        }
    }
}

/// One field of the table in one direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Field(Repr);

#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
enum Repr {
    /// `NAMED[i]`.
    Named(u16),
    /// A register, as an output or (input families only) an input.
    Register(Register, Direction, u8),
}

impl Field {
    /// The field named `name` in `direction`, or `None` when RTDE has no such field
    /// (the setup answers `NOT_FOUND`). Versions are not checked: see [`Field::since`].
    pub fn lookup(name: &str, direction: Direction) -> Option<Field> {
        if let Some(i) = NAMED
            .iter()
            .position(|f| f.name == name && f.direction() == direction)
        {
            return u16::try_from(i).ok().map(|i| Field(Repr::Named(i)));
        }
        REGISTERS
            .iter()
            .filter(|r| direction == Direction::Output || r.is_input())
            .find_map(|&r| {
                r.parse(name)
                    .map(|n| Field(Repr::Register(r, direction, n)))
            })
    }

    /// Every field: the fixed names (outputs, then inputs), then every register of each
    /// family as an output, then the input families' registers as inputs.
    pub fn all() -> impl Iterator<Item = Field> {
        let named = (0..NAMED.len()).filter_map(|i| u16::try_from(i).ok().map(Repr::Named));
        let registers = [Direction::Output, Direction::Input]
            .into_iter()
            .flat_map(|d| {
                REGISTERS
                    .iter()
                    .filter(move |r| d == Direction::Output || r.is_input())
                    .flat_map(move |&r| r.numbers().map(move |n| Repr::Register(r, d, n)))
            });
        named.chain(registers).map(Field)
    }

    fn named(self) -> Option<&'static Named> {
        match self.0 {
            Repr::Named(i) => NAMED.get(usize::from(i)),
            Repr::Register(..) => None,
        }
    }

    /// Its RTDE type.
    pub fn rtde_type(self) -> RtdeType {
        match self.0 {
            Repr::Named(_) => self.named().map_or(RtdeType::Bool, Named::rtde_type),
            Repr::Register(r, ..) => r.rtde_type(),
        }
    }

    /// Its direction.
    pub fn direction(self) -> Direction {
        match self.0 {
            Repr::Named(_) => self.named().map_or(Direction::Output, Named::direction),
            Repr::Register(_, d, _) => d,
        }
    }

    /// The controller versions it exists from.
    pub fn since(self) -> Since {
        match self.0 {
            Repr::Named(_) => self.named().map_or(ALWAYS, |f| f.since),
            Repr::Register(r, _, n) => r.since(n),
        }
    }

    /// Its value now, for an output; `None` for an input.
    pub fn read(self, source: &dyn RtdeSource) -> Option<RtdeValue> {
        match self.0 {
            Repr::Named(_) => match self.named()?.kind {
                Kind::Output(read) => Some(read.read(source)),
                Kind::Input(..) => None,
            },
            Repr::Register(_, Direction::Input, _) => None,
            Repr::Register(r, Direction::Output, n) => {
                let n = usize::from(n);
                Some(match r {
                    Register::OutputBit => {
                        V::Bool(source.output_bool_registers().get(n) == Some(&true))
                    }
                    Register::InputBit => {
                        V::Bool(source.input_bool_registers().get(n) == Some(&true))
                    }
                    Register::OutputInt => {
                        V::Int32(source.output_int_registers().get(n).copied().unwrap_or(0))
                    }
                    Register::InputInt => {
                        V::Int32(source.input_int_registers().get(n).copied().unwrap_or(0))
                    }
                    Register::OutputDouble => V::Double(
                        source
                            .output_double_registers()
                            .get(n)
                            .copied()
                            .unwrap_or(0.0),
                    ),
                    Register::InputDouble => V::Double(
                        source
                            .input_double_registers()
                            .get(n)
                            .copied()
                            .unwrap_or(0.0),
                    ),
                })
            }
        }
    }

    /// What it writes, for an input; `None` for an output.
    pub fn input(self) -> Option<Input> {
        match self.0 {
            Repr::Named(_) => match self.named()?.kind {
                Kind::Input(_, i) => Some(i),
                Kind::Output(_) => None,
            },
            Repr::Register(_, Direction::Output, _) => None,
            Repr::Register(r, Direction::Input, n) => match r {
                Register::InputBit => Some(Input::BitRegister(n)),
                Register::InputInt => Some(Input::IntRegister(n)),
                Register::InputDouble => Some(Input::DoubleRegister(n)),
                _ => None,
            },
        }
    }
}

impl fmt::Display for Field {
    /// Its name, as RTDE spells it.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Repr::Named(_) => f.write_str(self.named().map_or("", |n| n.name)),
            Repr::Register(r, _, n) => write!(f, "{}{n}", r.prefix()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_name_is_unique_in_its_direction_and_found_again() {
        let mut seen = std::collections::BTreeSet::new();
        for f in Field::all() {
            let name = f.to_string();
            assert!(seen.insert((f.direction(), name.clone())), "{name} twice");
            assert_eq!(Field::lookup(&name, f.direction()), Some(f), "{name}");
            assert_eq!(f.read(&Zero).is_some(), f.direction() == Direction::Output);
            assert_eq!(f.input().is_some(), f.direction() == Direction::Input);
            if let Some(v) = f.read(&Zero) {
                assert_eq!(v.rtde_type(), f.rtde_type(), "{name}");
            }
        }
    }

    #[test]
    fn register_numbers_have_one_spelling() {
        let p = |s: &str| Register::InputInt.parse(s);
        assert_eq!(p("input_int_register_5"), Some(5));
        assert_eq!(p("input_int_register_0"), Some(0));
        assert_eq!(p("input_int_register_47"), Some(47));
        for bad in ["05", "+5", "48", "", "999", "-1", " 5", "5 ", "00"] {
            assert_eq!(p(&format!("input_int_register_{bad}")), None, "{bad:?}");
        }
        assert_eq!(Register::InputBit.parse("input_bit_register_63"), None);
        assert_eq!(Register::InputBit.parse("input_bit_register_064"), None);
        assert_eq!(
            Register::InputBit.parse("input_bit_register_127"),
            Some(127)
        );
        assert_eq!(Register::InputBit.parse("input_bit_register_128"), None);
    }

    #[test]
    fn joint_mode_follows_the_robot_mode_and_safety() {
        assert_eq!(joint_mode(7, 1), 253);
        assert_eq!(joint_mode(5, 1), 255);
        assert_eq!(joint_mode(3, 1), 239);
        assert_eq!(joint_mode(-1, 1), 239);
        assert_eq!(joint_mode(7, 8), 251);
        assert_eq!(joint_mode(7, 9), 252);
    }

    #[test]
    fn the_elbow_is_frame_two_and_its_velocity_the_derivative() {
        let dh = crate::kinematics::Model::Ur5e.dh();
        let q = [0.3, -1.1, 0.7, 0.2, -0.4, 0.9];
        let qd = [0.5, -0.8, 0.3, 0.0, 0.0, 0.0];
        let (p, v) = elbow(&dh, q, qd);
        // The closed form of UR's DH (alpha1 = pi/2, a1 = d2 = 0).
        let (d1, a2) = (dh.d[0], dh.a[1]);
        let want = [
            a2 * q[1].cos() * q[0].cos(),
            a2 * q[1].cos() * q[0].sin(),
            d1 + a2 * q[1].sin(),
        ];
        // And the forward kinematics of the first two links.
        let mut two = dh;
        for i in 2..6 {
            two.a[i] = 0.0;
            two.d[i] = 0.0;
        }
        let fk = crate::kinematics::forward(&two, q, [0.0; 6]);
        let h = 1e-6;
        let at = |t: f64| elbow(&dh, std::array::from_fn(|i| q[i] + t * qd[i]), qd).0;
        let (ahead, behind) = (at(h), at(-h));
        for i in 0..3 {
            assert!((p[i] - want[i]).abs() < 1e-12, "{p:?} {want:?}");
            assert!((p[i] - fk[i]).abs() < 1e-12, "{p:?} {fk:?}");
            let numeric = (ahead[i] - behind[i]) / (2.0 * h);
            assert!((v[i] - numeric).abs() < 1e-6, "{v:?} {numeric}");
        }
    }

    /// A source of zeros.
    struct Zero;

    impl RtdeSource for Zero {
        fn time(&self) -> f64 {
            0.0
        }
        fn dh(&self) -> Dh {
            crate::kinematics::Model::Ur5e.dh()
        }
        fn robot_mode(&self) -> i32 {
            7
        }
        fn safety_status(&self) -> i32 {
            1
        }
        fn runtime_state(&self) -> u32 {
            1
        }
        fn target_q(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn target_qd(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn target_qdd(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn actual_q(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn actual_qd(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn target_moment(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn joint_temperatures(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn actual_execution_time(&self) -> f64 {
            0.0
        }
        fn actual_tcp_pose(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn actual_tcp_speed(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn actual_tcp_force(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn target_tcp_pose(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn target_tcp_speed(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn tcp_offset(&self) -> [f64; 6] {
            [0.0; 6]
        }
        fn speed_fraction(&self) -> f64 {
            0.0
        }
        fn speed_scaling(&self) -> f64 {
            0.0
        }
        fn digital_inputs(&self) -> u64 {
            0
        }
        fn digital_outputs(&self) -> u64 {
            0
        }
        fn analog_inputs(&self) -> [f64; 2] {
            [0.0; 2]
        }
        fn analog_outputs(&self) -> [f64; 2] {
            [0.0; 2]
        }
        fn analog_io_types(&self) -> u32 {
            0
        }
        fn tool_analog_inputs(&self) -> [f64; 2] {
            [0.0; 2]
        }
        fn tool_current(&self) -> f64 {
            0.0
        }
        fn tool_temperature(&self) -> f64 {
            0.0
        }
        fn output_bool_registers(&self) -> &[bool] {
            &[]
        }
        fn output_int_registers(&self) -> &[i32] {
            &[]
        }
        fn output_double_registers(&self) -> &[f64] {
            &[]
        }
        fn input_bool_registers(&self) -> &[bool] {
            &[]
        }
        fn input_int_registers(&self) -> &[i32] {
            &[]
        }
        fn input_double_registers(&self) -> &[f64] {
            &[]
        }
        fn payload_mass(&self) -> f64 {
            0.0
        }
        fn payload_cog(&self) -> [f64; 3] {
            [0.0; 3]
        }
        fn payload_inertia(&self) -> [f64; 6] {
            [0.0; 6]
        }
    }
}
