//! [`Status`]: one picture of the controller at one moment, plain data, from which every
//! stream is written (primary/secondary state packages, the realtime package, RTDE
//! outputs). The streams never look at the interpreter or the state machine themselves:
//! the cell fills a `Status` once per step and each encoder reads what it needs.
//!
//! Where the virtual controller has no physical world behind a field (currents,
//! voltages, temperatures), the value is the documented plausible one set by
//! [`Status::default`], and a test may change it.

use crate::state::{ProgramState, RobotMode, SafetyStatus};
use urscript_interp::kinematics::Model;

/// One picture of the controller. Units as UR's interfaces carry them: radians, rad/s,
/// metres, m/s, N, Nm, A, V, °C, seconds.
#[derive(Debug, Clone, PartialEq)]
pub struct Status {
    /// Seconds since the controller started (RTDE `timestamp`, realtime `Time`).
    pub time: f64,
    /// The arm model (kinematics info, configuration data).
    pub model: Model,
    /// The robot mode.
    pub robot_mode: RobotMode,
    /// The safety status.
    pub safety: SafetyStatus,
    /// The program's state (RTDE `runtime_state`, robot mode data's program flags).
    pub program_state: ProgramState,
    /// Whether the pendant is in remote control.
    pub remote_control: bool,
    /// The line of the script running now (RTDE `script_control_line`), 0 when none.
    pub script_line: u32,

    /// Target joint positions, velocities, accelerations.
    pub target_q: [f64; 6],
    /// Target joint velocities.
    pub target_qd: [f64; 6],
    /// Target joint accelerations.
    pub target_qdd: [f64; 6],
    /// Actual joint positions (the virtual arm follows its targets exactly).
    pub actual_q: [f64; 6],
    /// Actual joint velocities.
    pub actual_qd: [f64; 6],
    /// Target joint currents (A).
    pub target_current: [f64; 6],
    /// Actual joint currents (A).
    pub actual_current: [f64; 6],
    /// Target joint moments (Nm).
    pub target_moment: [f64; 6],
    /// Joint temperatures (°C).
    pub joint_temperatures: [f64; 6],
    /// Joint voltages (V).
    pub joint_voltage: [f64; 6],

    /// Actual TCP pose (base frame, rotation vector).
    pub actual_tcp_pose: [f64; 6],
    /// Actual TCP speed.
    pub actual_tcp_speed: [f64; 6],
    /// Generalised forces at the TCP (N, Nm).
    pub actual_tcp_force: [f64; 6],
    /// Target TCP pose.
    pub target_tcp_pose: [f64; 6],
    /// Target TCP speed.
    pub target_tcp_speed: [f64; 6],
    /// The active TCP offset (`set_tcp`).
    pub tcp_offset: [f64; 6],
    /// Tool accelerometer (m/s², tool frame).
    pub tool_accelerometer: [f64; 3],

    /// The speed slider (0..1, RTDE `target_speed_fraction`).
    pub speed_fraction: f64,
    /// The speed scaling in effect (0..1, RTDE `speed_scaling`).
    pub speed_scaling: f64,
    /// The arm's control mode, as primary's robot mode data carries it: 0 position,
    /// 1 teach (`teach_mode`, `freedrive_mode`, the operator's freedrive), 2 force
    /// (`force_mode`), 3 torque.
    pub control_mode: u8,

    /// Digital inputs: bits 0-7 standard, 8-15 configurable, 16-17 tool.
    pub digital_inputs: u64,
    /// Digital outputs, the same bits.
    pub digital_outputs: u64,
    /// Standard analog inputs 0-1 (A or V by domain).
    pub analog_inputs: [f64; 2],
    /// Standard analog outputs 0-1.
    pub analog_outputs: [f64; 2],
    /// Analog domains: bit 0,1 the inputs, bit 2,3 the outputs (0 current, 1 voltage),
    /// as RTDE's `analog_io_types`.
    pub analog_io_types: u32,
    /// Tool analog inputs 0-1.
    pub tool_analog_inputs: [f64; 2],
    /// Tool analog input types: bit 0, 1 (0 current, 1 voltage).
    pub tool_analog_input_types: u32,
    /// Tool output voltage (V): 0, 12 or 24.
    pub tool_output_voltage: i32,
    /// Tool current (A).
    pub tool_current: f64,
    /// Tool temperature (°C).
    pub tool_temperature: f64,
    /// I/O current (A).
    pub io_current: f64,

    /// Output bool registers 0-127.
    pub output_bool_registers: [bool; 128],
    /// Output int registers 0-47.
    pub output_int_registers: [i32; 48],
    /// Output double registers 0-47.
    pub output_double_registers: [f64; 48],
    /// Input bool registers 0-127.
    pub input_bool_registers: [bool; 128],
    /// Input int registers 0-47.
    pub input_int_registers: [i32; 48],
    /// Input double registers 0-47.
    pub input_double_registers: [f64; 48],

    /// Payload mass (kg).
    pub payload_mass: f64,
    /// Payload centre of gravity (m, flange frame).
    pub payload_cog: [f64; 3],
    /// Payload inertia `[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]` (kg·m²).
    pub payload_inertia: [f64; 6],

    /// Main voltage (V), robot voltage (48 V), robot current (A).
    pub main_voltage: f64,
    /// Robot voltage (V).
    pub robot_voltage: f64,
    /// Robot current (A).
    pub robot_current: f64,
    /// Control box temperature (°C).
    pub controller_temperature: f64,
}

impl Default for Status {
    /// A UR5e at rest, powered off, in the home position UR's simulator starts in.
    /// Plausible fixed values where the physical world is needed: joint temperatures
    /// 35 °C, joint voltages 48 V, main voltage 48 V, robot voltage 48 V, robot current
    /// 0 A (powered off), controller 30 °C, tool 32 °C.
    fn default() -> Self {
        let home = [
            0.0,
            -core::f64::consts::FRAC_PI_2,
            0.0,
            -core::f64::consts::FRAC_PI_2,
            0.0,
            0.0,
        ];
        Status {
            time: 0.0,
            model: Model::Ur5e,
            robot_mode: RobotMode::PowerOff,
            safety: SafetyStatus::Normal,
            program_state: ProgramState::Stopped,
            remote_control: true,
            script_line: 0,
            target_q: home,
            target_qd: [0.0; 6],
            target_qdd: [0.0; 6],
            actual_q: home,
            actual_qd: [0.0; 6],
            target_current: [0.0; 6],
            actual_current: [0.0; 6],
            target_moment: [0.0; 6],
            joint_temperatures: [35.0; 6],
            joint_voltage: [48.0; 6],
            actual_tcp_pose: [0.0; 6],
            actual_tcp_speed: [0.0; 6],
            actual_tcp_force: [0.0; 6],
            target_tcp_pose: [0.0; 6],
            target_tcp_speed: [0.0; 6],
            tcp_offset: [0.0; 6],
            tool_accelerometer: [0.0, 0.0, 9.82],
            speed_fraction: 1.0,
            speed_scaling: 1.0,
            control_mode: 0,
            digital_inputs: 0,
            digital_outputs: 0,
            analog_inputs: [0.0; 2],
            analog_outputs: [0.0; 2],
            analog_io_types: 0b1100,
            tool_analog_inputs: [0.0; 2],
            tool_analog_input_types: 0b11,
            tool_output_voltage: 0,
            tool_current: 0.0,
            tool_temperature: 32.0,
            io_current: 0.0,
            output_bool_registers: [false; 128],
            output_int_registers: [0; 48],
            output_double_registers: [0.0; 48],
            input_bool_registers: [false; 128],
            input_int_registers: [0; 48],
            input_double_registers: [0.0; 48],
            payload_mass: 0.0,
            payload_cog: [0.0; 3],
            payload_inertia: [0.0; 6],
            main_voltage: 48.0,
            robot_voltage: 48.0,
            robot_current: 0.0,
            controller_temperature: 30.0,
        }
    }
}

/// What a client may write into the controller through RTDE inputs (or any other
/// interface that sets I/O): each field `Some` is applied by the cell at its next step.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Inputs {
    /// Speed slider fraction (applied when the client's mask bit 0 is set).
    pub speed_slider_fraction: Option<f64>,
    /// Standard digital outputs: (mask, values), bits 0-7.
    pub standard_digital_outputs: Option<(u8, u8)>,
    /// Configurable digital outputs: (mask, values), bits 0-7 (outputs 8-15).
    pub configurable_digital_outputs: Option<(u8, u8)>,
    /// Tool digital outputs: (mask, values), bits 0-1.
    pub tool_digital_outputs: Option<(u8, u8)>,
    /// Standard analog outputs: mask (bit 0, 1), types (bit 0, 1: 0 current, 1 voltage)
    /// and the two values.
    pub standard_analog_outputs: Option<(u8, u8, [f64; 2])>,
    /// Input bool registers set: (index 0-127, value).
    pub bool_registers: Vec<(usize, bool)>,
    /// Input int registers set: (index 0-47, value).
    pub int_registers: Vec<(usize, i32)>,
    /// Input double registers set: (index 0-47, value).
    pub double_registers: Vec<(usize, f64)>,
    /// Payload set through RTDE: mass, centre of gravity, inertia (if given).
    pub payload: Option<(f64, [f64; 3], Option<[f64; 6]>)>,
    /// The RTDE input fields this package wrote, by name (each counts as an update for
    /// the programs' `rtde_set_watchdog`); empty from other interfaces. At most one
    /// recipe's fields ([`crate::rtde::RTDE_MAX_FIELDS`]).
    pub fields: Vec<String>,
}
