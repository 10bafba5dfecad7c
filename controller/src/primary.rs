//! The primary and secondary client interfaces (ports 30001 and 30002, and their read-only
//! twins 30011 and 30012), sans-IO: encoders that append whole messages to a `Vec<u8>`.
//!
//! Every message on these ports is `int32 length` (the whole message, these four bytes
//! included), `uint8 message type`, then the body; all numbers big-endian. The controller
//! sends, on connect, the [version message](encode_version), then every
//! [`STATE_PERIOD`] a [robot state message](encode_robot_state) (type 16) made of
//! sub-packages (`int32 size`, `uint8 package type`, data), and on the primary port only,
//! [robot messages](RobotMessage) (type 20) as things happen: the text of `textmsg`, the
//! `PROGRAM_XXX_STARTED` / `PROGRAM_XXX_STOPPED` key messages, runtime exceptions...
//!
//! Two layouts, chosen from [`Config::major`] ([`Layout::of`]): the e-Series one (5.x)
//! and the CB3 one (the last 3.x one, from 3.5: robot mode data ends with a byte for
//! internal use there, as in 5.x; 3.2 to 3.4 lacked it). Where they differ: masterboard
//! data (5.x adds a reserved byte), additional info (5.x has a teach pendant button state
//! and a reserved byte), and the packages only 5.x sends (tool communication info, tool
//! mode info, singularity info). See [`Package::size`] for each size.
//!
//! ```
//! use urscript_controller::primary::{encode_robot_state, encode_version, Layout};
//! use urscript_controller::{Config, Status};
//!
//! let config = Config::default(); // PolyScope 5.23.0, a UR5e
//! let mut out = Vec::new();
//! encode_version(&mut out, &config);
//! let version_len = out.len();
//! encode_robot_state(&mut out, &Status::default(), &config);
//! let state = &out[version_len..];
//! // int32 length (the whole message), then the message type 16.
//! let len = u32::from_be_bytes([state[0], state[1], state[2], state[3]]) as usize;
//! assert_eq!(len, state.len());
//! assert_eq!(state[4], 16);
//! assert_eq!(len, Layout::ESeries.robot_state_size());
//! ```
//!
//! # Values the virtual controller has no source for
//!
//! [`Status`] has no joint mode, tool mode, button state, calibration or
//! configuration limits; the encoders derive or fix them, and say so on each function:
//! joint and tool modes follow the robot mode ([`joint_mode`]); the control mode is
//! [`Status::control_mode`] (1 teach in teach/freedrive mode, 2 force in force mode); the speed slider limit is 1.0; joint limits are ±2π; joint speed limits
//! are the model's data-sheet ones; the kinematics checksums are a hash of the DH
//! parameters ([`kinematics_checksum`]).
//!
//! # Sources
//!
//! UR's "Client Interfaces" guide (primary/secondary, the 3.x and 5.x package tables), and
//! what clients parse: UR's `Universal_Robots_Client_Library` (primary parser), the
//! ROS-Industrial `ur_modern_driver` (its 3.5 robot mode data of 42 bytes after the
//! header), python-urx (`ursecmon.py`) and a public capture of URSim 5.4's bytes (the version message's
//! timestamp of all ones and source −2, the key messages' code and argument 0 and source
//! −3). Nothing was copied from them.

use std::time::Duration;

use crate::state::{Config, ProgramState, RobotMode, SafetyStatus};
use crate::status::Status;
use urscript_interp::kinematics::{Dh, Model};

/// The primary interface: robot state, version and robot messages; accepts scripts.
pub const PRIMARY_PORT: u16 = 30001;
/// The secondary interface: robot state and the version message only; accepts scripts.
pub const SECONDARY_PORT: u16 = 30002;
/// The read-only primary interface (e-Series, CB3 from 3.13): as 30001, scripts refused.
pub const PRIMARY_READ_ONLY_PORT: u16 = 30011;
/// The read-only secondary interface: as 30002, scripts refused.
pub const SECONDARY_READ_ONLY_PORT: u16 = 30012;

/// One of the four ports this module's messages go out on, and what each does.
///
/// | port  | version on connect | robot state, 10 Hz | robot messages | scripts in |
/// |-------|--------------------|--------------------|----------------|------------|
/// | 30001 | yes                | yes                | yes            | yes        |
/// | 30002 | yes                | yes                | no             | yes        |
/// | 30011 | yes                | yes                | yes            | no         |
/// | 30012 | yes                | yes                | no             | no         |
///
/// CB3 and e-Series alike (the read-only ports are those of recent versions: every 5.x,
/// the last 3.x).
/// The realtime port is in [`crate::realtime`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Port {
    /// 30001.
    Primary,
    /// 30002.
    Secondary,
    /// 30011.
    PrimaryReadOnly,
    /// 30012.
    SecondaryReadOnly,
}

impl Port {
    /// Every port, in the order of the table.
    pub const ALL: [Port; 4] = [
        Port::Primary,
        Port::Secondary,
        Port::PrimaryReadOnly,
        Port::SecondaryReadOnly,
    ];

    /// The TCP port number.
    pub fn number(self) -> u16 {
        match self {
            Port::Primary => PRIMARY_PORT,
            Port::Secondary => SECONDARY_PORT,
            Port::PrimaryReadOnly => PRIMARY_READ_ONLY_PORT,
            Port::SecondaryReadOnly => SECONDARY_READ_ONLY_PORT,
        }
    }

    /// Whether robot messages (text, key, runtime exception...) go out on this port.
    pub fn sends_robot_messages(self) -> bool {
        matches!(self, Port::Primary | Port::PrimaryReadOnly)
    }

    /// Whether the controller runs what a client writes on this port
    /// ([`crate::script_intake`]); the read-only ports ignore it.
    pub fn accepts_scripts(self) -> bool {
        matches!(self, Port::Primary | Port::Secondary)
    }
}

/// Robot state messages go out at 10 Hz on the primary and secondary ports, CB3 and
/// e-Series alike.
pub const STATE_RATE_HZ: u32 = 10;
/// The period matching [`STATE_RATE_HZ`].
pub const STATE_PERIOD: Duration = Duration::from_millis(100);

/// Message type of the robot state message.
pub const MESSAGE_ROBOT_STATE: u8 = 16;
/// Message type of robot messages (version, text, key, runtime exception...).
pub const MESSAGE_ROBOT_MESSAGE: u8 = 20;

/// The source byte of the version message, as URSim sends it (−2).
pub const SOURCE_VERSION: i8 = -2;
/// The source byte of the other robot messages, as URSim sends them (−3).
pub const SOURCE_CONTROLLER: i8 = -3;

/// Which package layout: CB3 (PolyScope 3.x) or e-Series (5.x).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Layout {
    /// PolyScope 3.2 to 3.15 (CB3).
    Cb3,
    /// PolyScope 5.x (e-Series and the UR20/UR30).
    ESeries,
}

impl Layout {
    /// The layout for a configuration: CB3 for a major version below 5.
    pub fn of(config: &Config) -> Layout {
        if config.major() < 5 {
            Layout::Cb3
        } else {
            Layout::ESeries
        }
    }

    /// The packages [`encode_robot_state`] sends in this layout, in order.
    pub fn packages(self) -> &'static [Package] {
        match self {
            Layout::Cb3 => &CB3_PACKAGES,
            Layout::ESeries => &E_SERIES_PACKAGES,
        }
    }

    /// The size of the whole robot state message [`encode_robot_state`] writes.
    pub fn robot_state_size(self) -> usize {
        5 + self
            .packages()
            .iter()
            .map(|p| p.size(self).unwrap_or(0))
            .sum::<usize>()
    }
}

const CB3_PACKAGES: [Package; 9] = [
    Package::RobotModeData,
    Package::JointData,
    Package::ToolData,
    Package::MasterboardData,
    Package::CartesianInfo,
    Package::KinematicsInfo,
    Package::ConfigurationData,
    Package::ForceModeData,
    Package::AdditionalInfo,
];

const E_SERIES_PACKAGES: [Package; 12] = [
    Package::RobotModeData,
    Package::JointData,
    Package::ToolData,
    Package::MasterboardData,
    Package::CartesianInfo,
    Package::KinematicsInfo,
    Package::ConfigurationData,
    Package::ForceModeData,
    Package::AdditionalInfo,
    Package::ToolCommunicationInfo,
    Package::ToolModeInfo,
    Package::SingularityInfo,
];

/// A sub-package of the robot state message.
///
/// Not sent: calibration data (9) and safety data (10), which the guide marks as used by
/// Universal Robots software only (clients such as python-urx skip them).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Package {
    /// Robot mode data (0).
    RobotModeData,
    /// Joint data (1).
    JointData,
    /// Tool data (2).
    ToolData,
    /// Masterboard data (3).
    MasterboardData,
    /// Cartesian info (4): TCP pose and TCP offset.
    CartesianInfo,
    /// Kinematics info (5): checksums and DH parameters.
    KinematicsInfo,
    /// Configuration data (6): limits, defaults, DH, robot type.
    ConfigurationData,
    /// Force mode data (7).
    ForceModeData,
    /// Additional info (8): freedrive buttons.
    AdditionalInfo,
    /// Tool communication info (11, e-Series).
    ToolCommunicationInfo,
    /// Tool mode info (12, e-Series).
    ToolModeInfo,
    /// Singularity info (13, e-Series).
    SingularityInfo,
}

impl Package {
    /// The package type byte.
    pub fn code(self) -> u8 {
        match self {
            Package::RobotModeData => 0,
            Package::JointData => 1,
            Package::ToolData => 2,
            Package::MasterboardData => 3,
            Package::CartesianInfo => 4,
            Package::KinematicsInfo => 5,
            Package::ConfigurationData => 6,
            Package::ForceModeData => 7,
            Package::AdditionalInfo => 8,
            Package::ToolCommunicationInfo => 11,
            Package::ToolModeInfo => 12,
            Package::SingularityInfo => 13,
        }
    }

    /// The package's size in bytes (its 5-byte header included) in a layout, `None`
    /// where the layout has no such package. The masterboard size is without the
    /// Euromap67 fields (never installed here).
    pub fn size(self, layout: Layout) -> Option<usize> {
        let e = layout == Layout::ESeries;
        Some(match self {
            Package::RobotModeData => 47,
            Package::JointData => 251,
            Package::ToolData => 37,
            Package::MasterboardData => 74 + usize::from(e),
            Package::CartesianInfo => 101,
            Package::KinematicsInfo => 225,
            Package::ConfigurationData => 445,
            Package::ForceModeData => 61,
            Package::AdditionalInfo => 8 + usize::from(e),
            Package::ToolCommunicationInfo if e => 26,
            Package::ToolModeInfo if e => 8,
            Package::SingularityInfo if e => 7,
            _ => return None,
        })
    }
}

/// Big-endian writer over the output vector.
struct W<'a>(&'a mut Vec<u8>);

impl W<'_> {
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn i8(&mut self, v: i8) {
        self.0.extend_from_slice(&v.to_be_bytes());
    }
    fn bool(&mut self, v: bool) {
        self.0.push(u8::from(v));
    }
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_be_bytes());
    }
    fn i32(&mut self, v: i32) {
        self.0.extend_from_slice(&v.to_be_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_be_bytes());
    }
    fn f32(&mut self, v: f64) {
        self.0.extend_from_slice(&(v as f32).to_be_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.0.extend_from_slice(&v.to_be_bytes());
    }
    fn f64s(&mut self, v: &[f64]) {
        for x in v {
            self.f64(*x);
        }
    }
    fn bytes(&mut self, b: &[u8]) {
        self.0.extend_from_slice(b);
    }
    /// Starts a length-prefixed block of type `kind`; returns where its length goes.
    fn open(&mut self, kind: u8) -> usize {
        let at = self.0.len();
        self.0.extend_from_slice(&[0, 0, 0, 0, kind]);
        at
    }
    /// Writes the block's length (from `at` to the end) at `at`.
    fn close(&mut self, at: usize) {
        let len = u32::try_from(self.0.len() - at).unwrap_or(u32::MAX);
        if let Some(slot) = self.0.get_mut(at..at + 4) {
            slot.copy_from_slice(&len.to_be_bytes());
        }
    }
}

/// Microseconds since the controller started, rounded to the millisecond as URSim's
/// timestamps are (negative or non-finite times give 0).
pub fn timestamp_us(time: f64) -> u64 {
    if time.is_finite() && time > 0.0 {
        ((time * 1000.0).round() as u64).saturating_mul(1000)
    } else {
        0
    }
}

/// The joint mode code (joint data, tool data's tool mode, realtime joint modes) the
/// virtual arm reports, the one RTDE's `joint_mode` carries:
/// [`urscript_interp::rtde_fields::joint_mode`].
pub fn joint_mode(status: &Status) -> u8 {
    let code =
        urscript_interp::rtde_fields::joint_mode(status.robot_mode.code(), status.safety.code());
    u8::try_from(code).unwrap_or(0)
}

/// The safety mode code (masterboard data, realtime `Safety Mode`). The e-Series'
/// safety modes include the automatic-mode safeguard stop (12) and the three-position
/// enabling stop (13); CB3 has neither and reports them as SAFEGUARD_STOP (5).
pub fn safety_mode_code(safety: SafetyStatus, layout: Layout) -> u8 {
    match (safety, layout) {
        (
            SafetyStatus::AutomaticModeSafeguardStop
            | SafetyStatus::SystemThreePositionEnablingStop,
            Layout::Cb3,
        ) => 5,
        (s, _) => u8::try_from(s.code()).unwrap_or(0),
    }
}

/// Whether arm power is on in this robot mode.
fn powered(mode: RobotMode) -> bool {
    matches!(
        mode,
        RobotMode::PowerOn | RobotMode::Idle | RobotMode::Backdrive | RobotMode::Running
    )
}

/// The 32-bit checksum the kinematics info reports for joint `i`: FNV-1a over the
/// big-endian bytes of the joint's `theta` (0), `a`, `d` and `alpha`. Real controllers
/// report the checksum of the arm's calibration; clients only compare it between
/// connections, which this keeps stable per model.
pub fn kinematics_checksum(dh: &Dh, i: usize) -> u32 {
    let mut h: u32 = 0x811c_9dc5;
    let values = [
        0.0,
        dh.a.get(i).copied().unwrap_or(0.0),
        dh.d.get(i).copied().unwrap_or(0.0),
        dh.alpha.get(i).copied().unwrap_or(0.0),
    ];
    for v in values {
        for b in v.to_be_bytes() {
            h ^= u32::from(b);
            h = h.wrapping_mul(0x0100_0193);
        }
    }
    h
}

/// The robot type of the configuration data (UR5 1, UR10 2, UR3 3, UR16 4, UR20 7,
/// UR30 8) and its sub-type, here the series (CB3 1, e-Series 2, UR series 3).
pub fn robot_type(model: Model) -> (i32, i32) {
    match model {
        Model::Ur5 => (1, 1),
        Model::Ur10 => (2, 1),
        Model::Ur3 => (3, 1),
        Model::Ur5e => (1, 2),
        Model::Ur10e => (2, 2),
        Model::Ur3e => (3, 2),
        Model::Ur16e => (4, 2),
        Model::Ur20 => (7, 3),
        Model::Ur30 => (8, 3),
        _ => (1, 2),
    }
}

/// The joint speed limits (rad/s) from the model's data sheet.
pub fn joint_max_speeds(model: Model) -> [f64; 6] {
    use std::f64::consts::PI;
    let deg = |d: f64| d.to_radians();
    match model {
        Model::Ur3 | Model::Ur3e => [PI, PI, PI, 2.0 * PI, 2.0 * PI, 2.0 * PI],
        Model::Ur10 | Model::Ur10e | Model::Ur16e => [deg(120.0), deg(120.0), PI, PI, PI, PI],
        Model::Ur20 | Model::Ur30 => [
            deg(120.0),
            deg(120.0),
            deg(150.0),
            deg(210.0),
            deg(210.0),
            deg(210.0),
        ],
        _ => [PI; 6],
    }
}

/// Joint acceleration limit written in the configuration data (rad/s²), a plausible
/// constant (the controller has none to report).
pub const JOINT_MAX_ACCELERATION: f64 = 40.0;

/// Writes the version message: robot message (20) of sub-type VERSION (3) with the
/// project name `URControl`, major and minor version (bytes), bugfix and build (int32),
/// and the build date (the rest), from [`Config::polyscope`] (`5.21.0.1234` gives
/// 5, 21, 0, 1234) and [`Config::build_date`]. Timestamp all ones and source −2, as
/// URSim sends them.
pub fn encode_version(out: &mut Vec<u8>, config: &Config) {
    let full = config.full_version();
    let mut parts = full
        .split('.')
        .map(|p| p.trim().parse::<u64>().unwrap_or(0));
    let major = u8::try_from(parts.next().unwrap_or(0)).unwrap_or(u8::MAX);
    let minor = u8::try_from(parts.next().unwrap_or(0)).unwrap_or(u8::MAX);
    let bugfix = i32::try_from(parts.next().unwrap_or(0)).unwrap_or(i32::MAX);
    let build = i32::try_from(parts.next().unwrap_or(0)).unwrap_or(i32::MAX);
    let mut w = W(out);
    let at = w.open(MESSAGE_ROBOT_MESSAGE);
    w.u64(u64::MAX);
    w.i8(SOURCE_VERSION);
    w.u8(RobotMessageKind::Version.code());
    let name = b"URControl";
    w.u8(name.len() as u8);
    w.bytes(name);
    w.u8(major);
    w.u8(minor);
    w.i32(bugfix);
    w.i32(build);
    w.bytes(config.build_date.as_bytes());
    w.close(at);
}

/// Writes one robot state message (type 16) with every package of the configuration's
/// [`Layout`] ([`Layout::packages`]), in the guide's order. The kinematics info and
/// configuration data, which do not change, go in every message too, so a client that
/// connects late or reads one message has everything.
pub fn encode_robot_state(out: &mut Vec<u8>, status: &Status, config: &Config) {
    let layout = Layout::of(config);
    encode_robot_state_with(out, status, layout, layout.packages());
}

/// Writes one robot state message (type 16) with the given packages, in the given order
/// (a package the layout lacks is skipped).
pub fn encode_robot_state_with(
    out: &mut Vec<u8>,
    status: &Status,
    layout: Layout,
    packages: &[Package],
) {
    let mut w = W(out);
    let at = w.open(MESSAGE_ROBOT_STATE);
    for &p in packages {
        if p.size(layout).is_some() {
            encode_package_body(&mut w, status, layout, p);
        }
    }
    w.close(at);
}

/// Writes one sub-package alone (its 5-byte header included), as it appears inside the
/// robot state message. Nothing is written for a package the layout lacks.
pub fn encode_package(out: &mut Vec<u8>, status: &Status, layout: Layout, package: Package) {
    if package.size(layout).is_some() {
        encode_package_body(&mut W(out), status, layout, package);
    }
}

fn encode_package_body(w: &mut W<'_>, s: &Status, layout: Layout, package: Package) {
    let e = layout == Layout::ESeries;
    let at = w.open(package.code());
    let mode = joint_mode(s);
    match package {
        Package::RobotModeData => {
            w.u64(timestamp_us(s.time));
            let connected = !matches!(
                s.robot_mode,
                RobotMode::NoController | RobotMode::Disconnected
            );
            w.bool(connected); // isRealRobotConnected
            w.bool(true); // isRealRobotEnabled
            w.bool(powered(s.robot_mode));
            w.bool(matches!(
                s.safety,
                SafetyStatus::SystemEmergencyStop | SafetyStatus::RobotEmergencyStop
            ));
            w.bool(s.safety == SafetyStatus::ProtectiveStop);
            w.bool(s.program_state == ProgramState::Playing);
            w.bool(s.program_state == ProgramState::Paused);
            w.i8(i8::try_from(s.robot_mode.code()).unwrap_or(-1));
            w.u8(s.control_mode); // control mode: 0 position, 1 teach, 2 force
            w.f64(s.speed_fraction);
            w.f64(s.speed_scaling);
            w.f64(1.0); // target speed fraction limit
            w.u8(0); // for UR's internal use (3.5 and later)
        }
        Package::JointData => {
            for j in 0..6 {
                w.f64(s.actual_q[j]);
                w.f64(s.target_q[j]);
                w.f64(s.actual_qd[j]);
                w.f32(s.actual_current[j]);
                w.f32(s.joint_voltage[j]);
                w.f32(s.joint_temperatures[j]);
                w.f32(s.joint_temperatures[j]); // T micro (deprecated)
                w.u8(mode);
            }
        }
        Package::ToolData => {
            w.u8((s.tool_analog_input_types & 1) as u8);
            w.u8(((s.tool_analog_input_types >> 1) & 1) as u8);
            w.f64s(&s.tool_analog_inputs);
            w.f32(if powered(s.robot_mode) {
                s.robot_voltage
            } else {
                0.0
            });
            w.u8(u8::try_from(s.tool_output_voltage.clamp(0, 255)).unwrap_or(0));
            w.f32(s.tool_current);
            w.f32(s.tool_temperature);
            w.u8(mode); // tool mode
        }
        Package::MasterboardData => {
            w.u32(s.digital_inputs as u32);
            w.u32(s.digital_outputs as u32);
            w.u8((s.analog_io_types & 1) as u8);
            w.u8(((s.analog_io_types >> 1) & 1) as u8);
            w.f64s(&s.analog_inputs);
            w.u8(((s.analog_io_types >> 2) & 1) as u8);
            w.u8(((s.analog_io_types >> 3) & 1) as u8);
            w.f64s(&s.analog_outputs);
            w.f32(s.controller_temperature);
            w.f32(s.robot_voltage);
            w.f32(s.robot_current);
            w.f32(s.io_current);
            w.u8(safety_mode_code(s.safety, layout));
            w.bool(s.safety == SafetyStatus::Reduced);
            w.bool(false); // Euromap67 interface installed
            w.u32(0); // used by UR software only
            w.u8(0); // operational mode selector input
            w.u8(0); // three-position enabling device input
            if e {
                w.u8(0); // reserved
            }
        }
        Package::CartesianInfo => {
            w.f64s(&s.actual_tcp_pose);
            w.f64s(&s.tcp_offset);
        }
        Package::KinematicsInfo => {
            let dh = s.model.dh();
            for i in 0..6 {
                w.u32(kinematics_checksum(&dh, i));
            }
            w.f64s(&[0.0; 6]); // theta
            w.f64s(&dh.a);
            w.f64s(&dh.d);
            w.f64s(&dh.alpha);
            w.u32(0); // calibration status
        }
        Package::ConfigurationData => {
            let tau = std::f64::consts::TAU;
            for _ in 0..6 {
                w.f64(-tau);
                w.f64(tau);
            }
            for v in joint_max_speeds(s.model) {
                w.f64(v);
                w.f64(JOINT_MAX_ACCELERATION);
            }
            w.f64(1.05); // v joint default
            w.f64(1.4); // a joint default
            w.f64(0.25); // v tool default
            w.f64(1.2); // a tool default
            w.f64(0.5); // equivalent radius
            let dh = s.model.dh();
            w.f64s(&dh.a);
            w.f64s(&dh.d);
            w.f64s(&dh.alpha);
            w.f64s(&[0.0; 6]); // theta
            w.i32(if e { 4 } else { 3 }); // masterboard version
            w.i32(if e { 1 } else { 0 }); // controller box type
            let (kind, sub) = robot_type(s.model);
            w.i32(kind);
            w.i32(sub);
        }
        Package::ForceModeData => {
            w.f64s(&s.actual_tcp_force);
            w.f64(0.0); // robot dexterity
        }
        Package::AdditionalInfo => {
            if e {
                w.u8(0); // teach pendant button state
                w.bool(false); // freedrive button enabled
                w.bool(false); // I/O enabled freedrive
                w.u8(0); // reserved
            } else {
                w.bool(false); // freedrive button pressed
                w.bool(false); // freedrive button enabled
                w.bool(false); // I/O enabled freedrive
            }
        }
        Package::ToolCommunicationInfo => {
            w.bool(false);
            w.i32(115_200); // baud rate
            w.i32(0); // parity: none
            w.i32(1); // stop bits
            w.f32(1.5); // rx idle chars
            w.f32(3.5); // tx idle chars
        }
        Package::ToolModeInfo => {
            w.u8(0); // output mode
            w.u8(1); // digital output 0 mode
            w.u8(1); // digital output 1 mode
        }
        Package::SingularityInfo => {
            w.u8(0); // severity: none
            w.u8(0); // type: none
        }
    }
    w.close(at);
}

/// The sub-type byte of a robot message (type 20).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RobotMessageKind {
    /// Text message (0).
    Text,
    /// Program label (1).
    ProgramLabel,
    /// Popup (2).
    Popup,
    /// Version (3).
    Version,
    /// Safety mode (5).
    SafetyMode,
    /// Error code (6).
    ErrorCode,
    /// Key message (7).
    Key,
    /// Request value (9).
    RequestValue,
    /// Runtime exception (10).
    RuntimeException,
}

impl RobotMessageKind {
    /// The sub-type byte.
    pub fn code(self) -> u8 {
        match self {
            RobotMessageKind::Text => 0,
            RobotMessageKind::ProgramLabel => 1,
            RobotMessageKind::Popup => 2,
            RobotMessageKind::Version => 3,
            RobotMessageKind::SafetyMode => 5,
            RobotMessageKind::ErrorCode => 6,
            RobotMessageKind::Key => 7,
            RobotMessageKind::RequestValue => 9,
            RobotMessageKind::RuntimeException => 10,
        }
    }
}

/// The key message title a program's start carries (the text is the program's name).
pub const PROGRAM_STARTED: &str = "PROGRAM_XXX_STARTED";
/// The key message title a program's end carries.
pub const PROGRAM_STOPPED: &str = "PROGRAM_XXX_STOPPED";

/// A robot message (type 20) the controller sends on the primary port. Texts longer than
/// a one-byte length field allows (titles) are cut at 255 bytes, on a character boundary.
#[derive(Debug, Clone, PartialEq)]
pub enum RobotMessage {
    /// `textmsg` output and other plain text: the text fills the rest.
    Text {
        /// The text.
        text: String,
    },
    /// A program label (int32 id, text).
    ProgramLabel {
        /// The label id.
        id: i32,
        /// The label text.
        text: String,
    },
    /// A popup: uint32 request id, uint8 requested type, bool warning, error, blocking,
    /// uint8 title size, title, text.
    Popup {
        /// Request id (0 for a plain popup).
        request_id: u32,
        /// Requested type (0 for none).
        requested_type: u8,
        /// Shown as a warning.
        warning: bool,
        /// Shown as an error.
        error: bool,
        /// Blocks the program until dismissed.
        blocking: bool,
        /// The title.
        title: String,
        /// The text.
        text: String,
    },
    /// A safety mode change: int32 code, int32 argument, uint8 safety mode, uint32 report
    /// data type, uint32 report data.
    SafetyMode {
        /// Message code.
        code: i32,
        /// Message argument.
        argument: i32,
        /// The new safety mode.
        safety: SafetyStatus,
        /// Report data type.
        report_data_type: u32,
        /// Report data.
        report_data: u32,
    },
    /// An error code: int32 code, int32 argument, int32 report level, uint8 data type,
    /// uint32 data, text.
    ErrorCode {
        /// Message code (the `C` number).
        code: i32,
        /// Message argument (the `A` number).
        argument: i32,
        /// Report level (0 debug, 1 info, 2 warning, 3 violation, 4 fault...).
        report_level: i32,
        /// Data type.
        data_type: u8,
        /// Data.
        data: u32,
        /// The text.
        text: String,
    },
    /// A key message: int32 code, int32 argument, uint8 title size, title, text.
    Key {
        /// Message code (0 for the program messages).
        code: i32,
        /// Message argument.
        argument: i32,
        /// The title, e.g. [`PROGRAM_STARTED`].
        title: String,
        /// The text, e.g. the program's name.
        text: String,
    },
    /// A value request (`request_integer_from_primary_client`...): uint32 request id,
    /// uint8 requested type, text.
    RequestValue {
        /// Request id.
        request_id: u32,
        /// Requested type.
        requested_type: u8,
        /// The text.
        text: String,
    },
    /// A runtime exception or a compile error: int32 line, int32 column, text
    /// (`syntax_error_on_line:2:end:`, `compile_error_name_not_found:txtmsg:`...).
    RuntimeException {
        /// Script line.
        line: i32,
        /// Script column.
        column: i32,
        /// The text.
        text: String,
    },
}

impl RobotMessage {
    /// The key message a program's start sends: title [`PROGRAM_STARTED`], code and
    /// argument 0, text the program's name.
    pub fn program_started(name: &str) -> Self {
        RobotMessage::Key {
            code: 0,
            argument: 0,
            title: PROGRAM_STARTED.into(),
            text: name.into(),
        }
    }

    /// The key message a program's end sends ([`PROGRAM_STOPPED`]).
    pub fn program_stopped(name: &str) -> Self {
        RobotMessage::Key {
            code: 0,
            argument: 0,
            title: PROGRAM_STOPPED.into(),
            text: name.into(),
        }
    }

    /// The runtime exception a syntax error gives: `syntax_error_on_line:LINE:TOKEN:`,
    /// as URSim words it (`def silly()` without its colon, then `end`, gives line 2,
    /// column 1, token `end`).
    pub fn syntax_error(line: i32, column: i32, token: &str) -> Self {
        RobotMessage::RuntimeException {
            line,
            column,
            text: format!("syntax_error_on_line:{line}:{token}:"),
        }
    }

    /// The runtime exception an unknown name gives: `compile_error_name_not_found:NAME:`.
    pub fn name_not_found(line: i32, column: i32, name: &str) -> Self {
        RobotMessage::RuntimeException {
            line,
            column,
            text: format!("compile_error_name_not_found:{name}:"),
        }
    }

    /// A text message.
    pub fn text(text: &str) -> Self {
        RobotMessage::Text { text: text.into() }
    }

    /// The message's sub-type.
    pub fn kind(&self) -> RobotMessageKind {
        match self {
            RobotMessage::Text { .. } => RobotMessageKind::Text,
            RobotMessage::ProgramLabel { .. } => RobotMessageKind::ProgramLabel,
            RobotMessage::Popup { .. } => RobotMessageKind::Popup,
            RobotMessage::SafetyMode { .. } => RobotMessageKind::SafetyMode,
            RobotMessage::ErrorCode { .. } => RobotMessageKind::ErrorCode,
            RobotMessage::Key { .. } => RobotMessageKind::Key,
            RobotMessage::RequestValue { .. } => RobotMessageKind::RequestValue,
            RobotMessage::RuntimeException { .. } => RobotMessageKind::RuntimeException,
        }
    }
}

/// At most 255 bytes of `s`, cut on a character boundary.
fn short(s: &str) -> &[u8] {
    let mut end = s.len().min(255);
    while !s.is_char_boundary(end) {
        end -= 1;
    }
    &s.as_bytes()[..end]
}

/// Writes a robot message (type 20): uint64 timestamp, int8 source
/// ([`SOURCE_CONTROLLER`]), uint8 sub-type, then the message's fields. The timestamp is
/// `time` ([`timestamp_us`]), except for runtime exceptions, which URSim stamps with all
/// ones.
pub fn encode_robot_message(out: &mut Vec<u8>, message: &RobotMessage, time: f64) {
    let mut w = W(out);
    let at = w.open(MESSAGE_ROBOT_MESSAGE);
    let stamp = match message {
        RobotMessage::RuntimeException { .. } => u64::MAX,
        _ => timestamp_us(time),
    };
    w.u64(stamp);
    w.i8(SOURCE_CONTROLLER);
    w.u8(message.kind().code());
    match message {
        RobotMessage::Text { text } => w.bytes(text.as_bytes()),
        RobotMessage::ProgramLabel { id, text } => {
            w.i32(*id);
            w.bytes(text.as_bytes());
        }
        RobotMessage::Popup {
            request_id,
            requested_type,
            warning,
            error,
            blocking,
            title,
            text,
        } => {
            w.u32(*request_id);
            w.u8(*requested_type);
            w.bool(*warning);
            w.bool(*error);
            w.bool(*blocking);
            let t = short(title);
            w.u8(t.len() as u8);
            w.bytes(t);
            w.bytes(text.as_bytes());
        }
        RobotMessage::SafetyMode {
            code,
            argument,
            safety,
            report_data_type,
            report_data,
        } => {
            w.i32(*code);
            w.i32(*argument);
            w.u8(u8::try_from(safety.code()).unwrap_or(0));
            w.u32(*report_data_type);
            w.u32(*report_data);
        }
        RobotMessage::ErrorCode {
            code,
            argument,
            report_level,
            data_type,
            data,
            text,
        } => {
            w.i32(*code);
            w.i32(*argument);
            w.i32(*report_level);
            w.u8(*data_type);
            w.u32(*data);
            w.bytes(text.as_bytes());
        }
        RobotMessage::Key {
            code,
            argument,
            title,
            text,
        } => {
            w.i32(*code);
            w.i32(*argument);
            let t = short(title);
            w.u8(t.len() as u8);
            w.bytes(t);
            w.bytes(text.as_bytes());
        }
        RobotMessage::RequestValue {
            request_id,
            requested_type,
            text,
        } => {
            w.u32(*request_id);
            w.u8(*requested_type);
            w.bytes(text.as_bytes());
        }
        RobotMessage::RuntimeException { line, column, text } => {
            w.i32(*line);
            w.i32(*column);
            w.bytes(text.as_bytes());
        }
    }
    w.close(at);
}
