//! The realtime interface (port 30003, read-only twin 30013), sans-IO: one fixed-layout
//! package per controller cycle, `int32 message size` then doubles, big-endian.
//!
//! Two layouts ([`Layout`], from [`Config::major`]):
//!
//! - e-Series, the newest 5.x table (5.10 and later): [`E_SERIES_SIZE`] = 1220 bytes, the
//!   CB3 fields then `Safety Status`, three doubles used by UR software only, `Payload
//!   Mass`, `Payload CoG` and `Payload Inertia`.
//! - CB3, the last 3.x table (3.5 to 3.15): [`CB3_SIZE`] = 1108 bytes, ending with the
//!   elbow position and velocity.
//!
//! Port 30003 takes scripts as 30001 does ([`crate::script_intake`]); 30013 ignores
//! what it is sent.
//!
//! Field offsets are in [`offset`]. Fields the guide marks as used by Universal Robots
//! software only are zeros. Fields the virtual controller has no source for: `I control`
//! is the actual current, `Controller Timer`, `Test value` and `Linear momentum norm` are
//! 0. The elbow position and velocity are computed from the model's DH parameters.
//!
//! ```
//! use urscript_controller::realtime::{encode_realtime, offset, E_SERIES_SIZE};
//! use urscript_controller::{Config, Status};
//!
//! let mut status = Status::default();
//! status.time = 12.5;
//! let mut out = Vec::new();
//! encode_realtime(&mut out, &status, &Config::default());
//! assert_eq!(out.len(), E_SERIES_SIZE);
//! let time = f64::from_be_bytes(out[offset::TIME..offset::TIME + 8].try_into().unwrap());
//! assert_eq!(time, 12.5);
//! ```

use std::time::Duration;

use crate::primary::{joint_mode, safety_mode_code, Layout};
use crate::state::{Config, ProgramState};
use crate::status::Status;

/// The realtime port.
pub const REALTIME_PORT: u16 = 30003;
/// The read-only realtime port.
pub const REALTIME_READ_ONLY_PORT: u16 = 30013;
/// The e-Series sends a realtime package every controller cycle: 500 Hz.
pub const E_SERIES_RATE_HZ: u32 = 500;
/// CB3 sends at 125 Hz.
pub const CB3_RATE_HZ: u32 = 125;

/// The period for a layout (2 ms e-Series, 8 ms CB3).
pub fn period(layout: Layout) -> Duration {
    match layout {
        Layout::ESeries => Duration::from_millis(2),
        Layout::Cb3 => Duration::from_millis(8),
    }
}

/// The size of the e-Series package (5.10 and later).
pub const E_SERIES_SIZE: usize = 1220;
/// The size of the CB3 package (3.5 to 3.15).
pub const CB3_SIZE: usize = 1108;

/// The package size of a layout.
pub fn size(layout: Layout) -> usize {
    match layout {
        Layout::ESeries => E_SERIES_SIZE,
        Layout::Cb3 => CB3_SIZE,
    }
}

/// Byte offsets of the fields, from the start of the package (the size field at 0).
pub mod offset {
    /// Message size (int32).
    pub const MESSAGE_SIZE: usize = 0;
    /// Time (1 double).
    pub const TIME: usize = 4;
    /// q target (6).
    pub const Q_TARGET: usize = 12;
    /// qd target (6).
    pub const QD_TARGET: usize = 60;
    /// qdd target (6).
    pub const QDD_TARGET: usize = 108;
    /// I target (6).
    pub const I_TARGET: usize = 156;
    /// M target (6).
    pub const M_TARGET: usize = 204;
    /// q actual (6).
    pub const Q_ACTUAL: usize = 252;
    /// qd actual (6).
    pub const QD_ACTUAL: usize = 300;
    /// I actual (6).
    pub const I_ACTUAL: usize = 348;
    /// I control (6).
    pub const I_CONTROL: usize = 396;
    /// Tool vector actual (6).
    pub const TOOL_VECTOR_ACTUAL: usize = 444;
    /// TCP speed actual (6).
    pub const TCP_SPEED_ACTUAL: usize = 492;
    /// TCP force (6).
    pub const TCP_FORCE: usize = 540;
    /// Tool vector target (6).
    pub const TOOL_VECTOR_TARGET: usize = 588;
    /// TCP speed target (6).
    pub const TCP_SPEED_TARGET: usize = 636;
    /// Digital input bits (1, the bits as an integer-valued double).
    pub const DIGITAL_INPUT_BITS: usize = 684;
    /// Motor temperatures (6).
    pub const MOTOR_TEMPERATURES: usize = 692;
    /// Controller timer (1).
    pub const CONTROLLER_TIMER: usize = 740;
    /// Test value (1).
    pub const TEST_VALUE: usize = 748;
    /// Robot mode (1).
    pub const ROBOT_MODE: usize = 756;
    /// Joint modes (6).
    pub const JOINT_MODES: usize = 764;
    /// Safety mode (1).
    pub const SAFETY_MODE: usize = 812;
    /// Tool accelerometer values (3), after 6 doubles used by UR software only.
    pub const TOOL_ACCELEROMETER: usize = 868;
    /// Speed scaling (1), after 6 doubles used by UR software only.
    pub const SPEED_SCALING: usize = 940;
    /// Linear momentum norm (1).
    pub const LINEAR_MOMENTUM_NORM: usize = 948;
    /// V main (1), after 2 doubles used by UR software only.
    pub const V_MAIN: usize = 972;
    /// V robot (1).
    pub const V_ROBOT: usize = 980;
    /// I robot (1).
    pub const I_ROBOT: usize = 988;
    /// V actual (6).
    pub const V_ACTUAL: usize = 996;
    /// Digital outputs (1).
    pub const DIGITAL_OUTPUTS: usize = 1044;
    /// Program state (1).
    pub const PROGRAM_STATE: usize = 1052;
    /// Elbow position (3).
    pub const ELBOW_POSITION: usize = 1060;
    /// Elbow velocity (3).
    pub const ELBOW_VELOCITY: usize = 1084;
    /// Safety status (1, e-Series).
    pub const SAFETY_STATUS: usize = 1108;
    /// Payload mass (1, e-Series), after 3 doubles used by UR software only.
    pub const PAYLOAD_MASS: usize = 1140;
    /// Payload centre of gravity (3, e-Series).
    pub const PAYLOAD_COG: usize = 1148;
    /// Payload inertia (6, e-Series).
    pub const PAYLOAD_INERTIA: usize = 1172;
}

/// The realtime `Program state` value: the runtime state codes RTDE uses (1 stopped,
/// 2 playing, 4 paused).
pub fn program_state_code(state: ProgramState) -> f64 {
    match state {
        ProgramState::Stopped => 1.0,
        ProgramState::Playing => 2.0,
        ProgramState::Paused => 4.0,
    }
}

/// The elbow (the origin of the third joint's frame) in the base frame, for joint
/// positions `q` of the status's model: [`urscript_interp::rtde_fields::elbow`].
pub fn elbow_position(status: &Status, q: [f64; 6]) -> [f64; 3] {
    urscript_interp::rtde_fields::elbow(&status.model.dh(), q, [0.0; 6]).0
}

/// Writes one realtime package in the configuration's layout.
pub fn encode_realtime(out: &mut Vec<u8>, status: &Status, config: &Config) {
    encode_realtime_layout(out, status, Layout::of(config));
}

/// Writes one realtime package in the given layout.
pub fn encode_realtime_layout(out: &mut Vec<u8>, s: &Status, layout: Layout) {
    let start = out.len();
    let total = size(layout);
    out.reserve(total);
    out.extend_from_slice(&(total as u32).to_be_bytes());
    let mut d = |v: &[f64]| {
        for x in v {
            out.extend_from_slice(&x.to_be_bytes());
        }
    };
    d(&[s.time]);
    d(&s.target_q);
    d(&s.target_qd);
    d(&s.target_qdd);
    d(&s.target_current);
    d(&s.target_moment);
    d(&s.actual_q);
    d(&s.actual_qd);
    d(&s.actual_current);
    d(&s.actual_current); // I control
    d(&s.actual_tcp_pose);
    d(&s.actual_tcp_speed);
    d(&s.actual_tcp_force);
    d(&s.target_tcp_pose);
    d(&s.target_tcp_speed);
    d(&[(s.digital_inputs & 0x3ffff) as f64]);
    d(&s.joint_temperatures);
    d(&[0.0]); // controller timer
    d(&[0.0]); // test value
    d(&[f64::from(s.robot_mode.code())]);
    d(&[f64::from(joint_mode(s)); 6]);
    d(&[f64::from(safety_mode_code(s.safety, layout))]);
    d(&[0.0; 6]); // used by UR software only
    d(&s.tool_accelerometer);
    d(&[0.0; 6]); // used by UR software only
    d(&[s.speed_scaling]);
    d(&[0.0]); // linear momentum norm
    d(&[0.0; 2]); // used by UR software only
    d(&[s.main_voltage, s.robot_voltage, s.robot_current]);
    d(&s.joint_voltage);
    d(&[(s.digital_outputs & 0x3ffff) as f64]);
    d(&[program_state_code(s.program_state)]);
    let (elbow, elbow_velocity) =
        urscript_interp::rtde_fields::elbow(&s.model.dh(), s.actual_q, s.actual_qd);
    d(&elbow);
    d(&elbow_velocity);
    if layout == Layout::ESeries {
        d(&[f64::from(s.safety.code())]);
        d(&[0.0; 3]); // used by UR software only
        d(&[s.payload_mass]);
        d(&s.payload_cog);
        d(&s.payload_inertia);
    }
    debug_assert_eq!(out.len() - start, total);
}
