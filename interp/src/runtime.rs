//! The virtual controller's state that built-ins act on: the arm, the robot's sockets,
//! program time, and the events for the driver. The scheduler ([`crate::machine`]) owns
//! one and lends it to each built-in call; built-ins see nothing of threads.

use std::collections::BTreeMap;
use std::f64::consts::FRAC_PI_2;
use std::time::Duration;

use crate::arm::kinematics::{self, Dh};
use crate::arm::trajectory::{self, Kind, Motion};
use crate::error::Fault;
use crate::event::{Effect, Event, Message, MessageKind, MoveEnd, MoveOutcome, MoveStart};
use crate::sockets::Sockets;

/// The virtual arm and the I/O around it: where the arm is now (mid-move too), not
/// dynamics (see
/// [`crate::builtins::motion`]). It outlives a program: a controller that runs program
/// after program hands it from one [`Machine`](crate::Machine) to the next
/// ([`Machine::with_arm`](crate::Machine::with_arm), [`Machine::into_arm`](crate::Machine::into_arm)),
/// as the real arm keeps its joints, outputs and registers between programs.
///
/// The public fields are what the controller's interfaces show (joints, outputs,
/// registers, payload) and what their clients may set (an RTDE client writes outputs and
/// input registers); the rest belongs to the built-ins. [`Arm::world`] is what the robot
/// senses: each of its fields starts at the fixed value documented beside it, the value
/// the built-ins return, and a test may set it.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub struct Arm {
    /// Joint positions (rad) now: mid-move, where the motion has the arm at this step.
    /// Default: UR's home pose `[0, -π/2, 0, -π/2, 0, 0]`.
    pub q: [f64; 6],
    /// Joint speeds (rad/s) now.
    pub qd: [f64; 6],
    /// Joint accelerations (rad/s²) now: the change of the joint speeds over the last step
    /// of the motion under way (zero at rest).
    pub qdd: [f64; 6],
    /// TCP speed now (base frame: m/s, then rad/s).
    pub tcp_speed: [f64; 6],
    /// The active TCP offset (`set_tcp`), from the flange.
    pub tcp: [f64; 6],
    /// Digital outputs: standard 0-7, configurable 8-15, tool 16-17.
    pub digital_out: [bool; 18],
    /// Tool digital outputs 0-1 (`set_tool_digital_out`).
    pub tool_out: [bool; 2],
    /// Standard analog outputs 0-1 (fraction of the range, 0..1, as `set_standard_analog_out` takes it).
    pub analog_out: [f64; 2],
    /// Output int registers 0-47 (`write_output_integer_register`).
    pub int_regs: [i32; 48],
    /// Output float registers 0-47.
    pub float_regs: [f64; 48],
    /// Output bool registers 0-127 (64-127 are the RTDE clients' range).
    pub bool_regs: [bool; 128],
    pub(crate) random_state: u64,
    /// Payload mass (kg), as last set. Default: none.
    pub payload_mass: f64,
    /// Payload centre of gravity (m, from the flange).
    pub payload_cog: [f64; 3],
    /// Payload inertia `[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]` (kg·m², at the CoG).
    pub payload_inertia: [f64; 6],
    /// Gravity as `set_gravity` gave it (m/s²). Default `[0, 0, 9.82]`.
    pub gravity: [f64; 3],
    /// Base acceleration as `set_base_acceleration` gave it (m/s²). Default 0.
    pub(crate) base_acceleration: [f64; 3],
    /// The analog outputs' domains (0: 4-20 mA, 1: 0-10 V). Default 1.
    pub analog_out_domain: [i32; 2],
    /// Flags 0-31 (`set_flag`).
    pub(crate) flags: [bool; 32],
    /// Euromap67 output signals 0-31 (`set_euromap_output`).
    pub(crate) euromap_out: [bool; 32],
    /// Their run-state choices (`set_euromap_runstate_dependent_choice`).
    pub(crate) euromap_runstate: [u8; 32],
    /// The Modbus server's ports as last written (`write_port_bit`/`_register`); a port
    /// never written reads False / 0.
    pub(crate) port_bits: BTreeMap<i32, bool>,
    pub(crate) port_registers: BTreeMap<i32, i16>,
    /// The virtual Modbus client's signals, by name (no device behind them).
    pub(crate) modbus: BTreeMap<String, ModbusSignal>,
    /// The two conveyor encoders.
    pub(crate) encoders: [Encoder; 2],
    /// The encoder a conveyor is tracked with, if one is.
    pub(crate) conveyor: Option<usize>,
    /// Path offsetting.
    pub(crate) path_offset: PathOffset,
    /// What the robot senses of the world: fixed values a test may change.
    pub world: World,
    /// Force mode damping (`force_mode_set_damping`, 0-1). Default 0.0, as the manual gives.
    pub(crate) force_mode_damping: f64,
    /// Force mode gain scaling (`force_mode_set_gain_scaling`, 0-2). Default 1.0.
    pub(crate) force_mode_gain_scaling: f64,
    /// Motion version for `movej`/`movel` (`motion_version_set`, 1 or 2). Default 1, the
    /// behaviour up to PolyScope 5.21 (PolyScope sets it from the installation in a
    /// program's preamble; a bare controller has no installation).
    pub(crate) motion_version: i32,
    /// Jerk gain scaling (`jerk_gain_scaling_set`, 0.01-1). Default 1.0.
    pub(crate) jerk_gain_scaling: f64,
    /// The Flexible EtherNet/IP Adapter's assemblies and the Robot→PLC data the programs
    /// wrote (see [`crate::eip`] and [`Arm::eip_to_plc`]).
    pub(crate) eip: crate::eip::Adapter,
    /// The world model's frames (`add_frame`...; see [`crate::world_model`]): kept
    /// across programs until `reset_world_model()`.
    pub(crate) world_model: crate::arm::world_model::WorldModel,
    /// The speed slider: the fraction (0-1) of its programmed speed the program's motion
    /// runs at (RTDE `speed_slider_fraction`, primary `set speed`, the operator). A move
    /// that takes 1.5 s at 1.0 takes 3.0 s at 0.5; a change takes effect from the next
    /// step. It scales every motion command's trajectory (`movej`, `movel`, `movep`,
    /// `movec`, `servoj`, `speedj`, `speedl`, `stopj`, `stopl`): the arm's speeds are the
    /// programmed ones times the fraction; force mode and the operator's hand are not
    /// scaled. Default 1.0; a value outside 0-1 counts as the nearest end (NaN as 1.0).
    pub speed_fraction: f64,
    /// `teach_mode()` (1) or `freedrive_mode()` (2) is on: the operator moves the joints
    /// ([`Arm::move_by_hand`]); 0: neither.
    pub(crate) hand_mode: u8,
    /// The active `force_mode`, if any (see [`crate::arm::force`]).
    pub(crate) force_mode: Option<crate::arm::force::ForceMode>,
}

impl Arm {
    /// Whether the arm is in `teach_mode()` or `freedrive_mode()`: the operator moves its
    /// joints ([`Arm::move_by_hand`]) and `is_steady()` is False.
    pub fn hand_guided(&self) -> bool {
        self.hand_mode != 0
    }

    /// Whether a program's `force_mode` is on.
    pub fn in_force_mode(&self) -> bool {
        self.force_mode.is_some()
    }

    /// The arm's control mode as primary's robot mode data carries it: 1 teach (in
    /// teach or freedrive mode), 2 force (in force mode), else 0 position.
    pub fn control_mode(&self) -> u8 {
        if self.hand_guided() {
            1
        } else if self.in_force_mode() {
            2
        } else {
            0
        }
    }

    /// The operator moves the joints by hand to `q` (rad, each within ±2π): the arm is at
    /// rest there, and the program sees it at its next step. The caller decides whether
    /// the arm may be moved by hand (a controller allows it in teach/freedrive mode,
    /// [`Arm::hand_guided`], or with no program running).
    ///
    /// ```
    /// let mut arm = urscript_interp::Arm::default();
    /// arm.move_by_hand([0.1, -1.2, 1.3, -1.5, -1.6, 0.2]).unwrap();
    /// assert_eq!(arm.q[2], 1.3);
    /// assert!(arm.move_by_hand([0.0, 0.0, 7.0, 0.0, 0.0, 0.0]).is_err());
    /// ```
    pub fn move_by_hand(&mut self, q: [f64; 6]) -> Result<(), String> {
        if let Some((k, v)) = q
            .iter()
            .enumerate()
            .find(|(_, v)| !v.is_finite() || v.abs() > JOINT_LIMIT)
        {
            return Err(format!(
                "joint {k} at {v} rad is outside the joints' range (±2π)"
            ));
        }
        self.q = q;
        self.qd = [0.0; 6];
        self.qdd = [0.0; 6];
        self.tcp_speed = [0.0; 6];
        Ok(())
    }

    /// What the force/torque sensor reads (N, Nm; base frame, as `get_tcp_force()` and
    /// RTDE's `actual_TCP_force`): [`World::tcp_force`] plus the contact plane's push on
    /// the TCP (see [`World::contact_plane`]), for the arm's kinematics `dh`.
    pub fn measured_tcp_force(&self, dh: &Dh) -> [f64; 6] {
        let pose = kinematics::forward(dh, self.q, self.tcp);
        let c = crate::arm::force::contact_force(
            self.world.contact_plane,
            self.world.contact_stiffness,
            pose,
        );
        std::array::from_fn(|k| self.world.tcp_force[k] + c[k])
    }

    /// The speed slider as it scales motion: 0-1 (NaN counts as 1).
    pub(crate) fn slider(&self) -> f64 {
        if self.speed_fraction.is_nan() {
            1.0
        } else {
            self.speed_fraction.clamp(0.0, 1.0)
        }
    }
}

impl Arm {
    /// The Robot→PLC data of EtherNet/IP instance `instance` as the robot's programs last
    /// wrote it (`eip_writer_factory` handles; `add_configuration` makes it zeros), what
    /// a scanner would read; `None` if no program or configuration made it.
    ///
    /// ```
    /// use std::time::Duration;
    /// use urscript_interp::{Config, Machine, Program};
    /// let src = "w = eip_writer_factory(\"101\", 4)\nw.define_int16(2, \"n\")\nw.write(struct(n=-2))\n";
    /// let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
    /// m.run_until(Duration::ZERO);
    /// assert_eq!(m.into_arm().eip_to_plc(101), Some(&[0, 0, 0xfe, 0xff][..]));
    /// ```
    pub fn eip_to_plc(&self, instance: i32) -> Option<&[u8]> {
        self.eip.to_plc.get(&instance).map(Vec::as_slice)
    }
}

/// A conveyor encoder (`encoder_*`): how it is fed and its tick count.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Encoder {
    /// 0: not enabled; 1: pulse decoding on digital inputs; 2: fed by `encoder_set_tick_count`.
    pub mode: u8,
    /// The tick range's id (`range_id`, 0-4); pulse decoding counts as 0 (32-bit signed).
    pub range_id: i32,
    pub ticks: i64,
}

/// Path offsetting (`path_offset_*`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct PathOffset {
    pub enabled: bool,
    pub offset: [f64; 6],
    pub kind: i32,
    /// Largest translation (m) and rotation (rad) per axis: 0.1 and 0.52 by default.
    pub max_trans: f64,
    pub max_rot: f64,
    pub alpha: f64,
}

impl Default for PathOffset {
    fn default() -> Self {
        PathOffset {
            enabled: false,
            offset: [0.0; 6],
            kind: 1,
            max_trans: 0.1,
            max_rot: 0.52,
            alpha: 1.0,
        }
    }
}

/// A Modbus signal of the virtual client.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ModbusSignal {
    /// 0 digital input, 1 digital output, 2 register input, 3 register output, 15
    /// multiple digital outputs, 16 multiple register outputs, 23 read-write registers.
    pub signal_type: i32,
    /// Its value(s): one per register or coil.
    pub values: Vec<i32>,
}

impl Default for Arm {
    fn default() -> Self {
        Arm {
            q: [0.0, -FRAC_PI_2, 0.0, -FRAC_PI_2, 0.0, 0.0],
            qd: [0.0; 6],
            qdd: [0.0; 6],
            tcp_speed: [0.0; 6],
            tcp: [0.0; 6],
            digital_out: [false; 18],
            tool_out: [false; 2],
            analog_out: [0.0; 2],
            int_regs: [0; 48],
            float_regs: [0.0; 48],
            bool_regs: [false; 128],
            random_state: 0x2545_F491_4F6C_DD1D,
            payload_mass: 0.0,
            payload_cog: [0.0; 3],
            payload_inertia: [0.0; 6],
            gravity: [0.0, 0.0, 9.82],
            base_acceleration: [0.0; 3],
            analog_out_domain: [1; 2],
            flags: [false; 32],
            euromap_out: [false; 32],
            euromap_runstate: [0; 32],
            port_bits: BTreeMap::new(),
            port_registers: BTreeMap::new(),
            modbus: BTreeMap::new(),
            encoders: [Encoder::default(); 2],
            conveyor: None,
            path_offset: PathOffset::default(),
            world: World::default(),
            eip: crate::eip::Adapter::default(),
            world_model: crate::arm::world_model::WorldModel::default(),
            force_mode_damping: 0.0,
            force_mode_gain_scaling: 1.0,
            motion_version: 1,
            jerk_gain_scaling: 1.0,
            speed_fraction: 1.0,
            hand_mode: 0,
            force_mode: None,
        }
    }
}

/// What the virtual robot senses of the world: inputs, measurements, the operator's
/// answers. Each starts at the fixed value documented beside it; a test (or a driver that
/// simulates a cell) sets them through [`Machine::world_mut`](crate::Machine::world_mut).
///
/// ```
/// use std::time::Duration;
/// use urscript_interp::{Config, Machine, Program};
/// let p = Program::parse("textmsg(get_standard_digital_in(2), get_joint_temp(0))\n").unwrap();
/// let mut m = Machine::new(p, Config::default());
/// m.world_mut().digital_in[2] = true;
/// m.world_mut().joint_temp[0] = 41.5;
/// m.run_until(Duration::ZERO);
/// # let mut text = String::new();
/// # while let Some(urscript_interp::Event::Message(msg)) = m.poll_event() { text = msg.text; }
/// assert_eq!(text, "True41.5");
/// ```
#[derive(Debug, Clone, PartialEq)]
pub struct World {
    /// Digital inputs: standard 0-7, configurable 8-15, tool 16-17. Default all False.
    pub digital_in: [bool; 18],
    /// Analog inputs: standard 0-1, tool 2-3 (A or V). Default 0.
    pub analog_in: [f64; 4],
    /// RTDE input int registers 0-47 (an RTDE client writes them). Default 0.
    pub input_int_regs: [i32; 48],
    /// RTDE input float registers 0-47. Default 0.0.
    pub input_float_regs: [f64; 48],
    /// RTDE input bool registers 0-127. Default False.
    pub input_bool_regs: [bool; 128],
    /// Force/torque at the flange (N, Nm) besides the contact plane's. Default 0
    /// (nothing pushes the virtual arm).
    pub tcp_force: [f64; 6],
    /// A surface the tool can touch: a plane, as a pose (base frame) whose z axis is its
    /// outward normal; the obstacle fills the half-space below it. It pushes the TCP
    /// back like a spring of [`World::contact_stiffness`] (`force_mode` in the crate README's table of physical functions).
    /// Default `p[0, 0, 0, 0, 0, 0]` (with no stiffness: no surface).
    pub contact_plane: [f64; 6],
    /// The contact plane's stiffness (N/m): a TCP `d` m below it feels `stiffness · d`
    /// N along its normal. Default 0.0: no surface, free space.
    pub contact_stiffness: f64,
    /// Joint torques beyond what moving the arm itself takes (Nm). Default 0.
    pub joint_torques: [f64; 6],
    /// Joint temperatures (°C). Default 35.0 each.
    pub joint_temp: [f64; 6],
    /// Control box temperature (°C). Default 30.0.
    pub controller_temp: f64,
    /// Tool temperature (°C). Default 32.0.
    pub tool_temp: f64,
    /// Tool current (A). Default 0.0 (nothing draws power from the tool connector).
    pub tool_current: f64,
    /// What the virtual operator answers `request_boolean_from_primary_client` (at once).
    /// Default False.
    pub operator_bool: bool,
    /// The answer to `request_integer_from_primary_client`. Default 0.
    pub operator_int: i32,
    /// The answer to `request_float_from_primary_client`. Default 0.0.
    pub operator_float: f64,
    /// The answer to `request_string_from_primary_client`. Default "".
    pub operator_string: Vec<u8>,
    /// The inertia of each joint's rotor as the joint sees it through its gear, kg·m²:
    /// what `get_mass_matrix(include_rotors_inertia=True)` adds on the diagonal. UR
    /// publishes no rotor inertias, so the default is 0.0 each (the flag changes nothing
    /// until a test sets them).
    pub rotor_inertia: [f64; 6],
    /// The controller's real-time thread execution time per step (ms), RTDE's
    /// `actual_execution_time` (`get_rtde_value`). Default 0.0 (the virtual controller's
    /// steps take no controller time).
    pub execution_time: f64,
    /// How long the low-level controller had been running when the program started:
    /// `time(0)` (the manual: controller execution time, counted since the low-level
    /// controller started, monotonic) is this plus the program time. Default zero (the
    /// virtual controller starts with the program).
    pub controller_uptime: Duration,
    /// The system clock (GMT, since 1970-01-01) when the program started: `time(2)` is
    /// this plus the program time. Default zero, 1970-01-01 00:00:00: the machine never
    /// reads a clock (time is an input), so a test or driver that wants the date sets it.
    pub system_time: Duration,
    /// What the EtherNet/IP scanner (a PLC) last sent to the robot, by PLC→Robot
    /// instance id: what `eip_reader_factory` handles read (little-endian; bytes past the
    /// end read as zero). Default: none (every instance reads zeros). At most
    /// [`crate::eip::MAX_INSTANCES`] instances of [`crate::eip::MAX_DATA_SIZE`] bytes are read.
    pub eip_from_plc: BTreeMap<i32, Vec<u8>>,
    /// An EtherNet/IP scanner is connected and sending: it feeds the reader handles'
    /// watchdogs and `is_instance_connected` is True for configured instances. Default
    /// False: the virtual cell has no PLC, so a watchdog times out.
    pub eip_connected: bool,
    /// The RTDE watchdogs act (`rtde_set_watchdog`): a controller with an RTDE server
    /// sets it and counts its clients' writes in [`World::rtde_input_updates`]. Default
    /// False: no RTDE client is modelled, so a watchdog is recorded and never fires.
    pub rtde_watchdogs: bool,
    /// Euromap67 input signals 0-31 (`get_euromap_input`). Default all False.
    pub euromap_in: [bool; 32],
    /// How many times RTDE clients wrote each input field, by its RTDE name
    /// (`input_int_register_0`, `speed_slider_fraction`, ...): a watchdog fires when
    /// its field's count has not changed for `1 / min_frequency` s. The controller
    /// writes it; its keys are RTDE's input field names (a bounded set).
    pub rtde_input_updates: BTreeMap<String, u64>,
}

impl Default for World {
    fn default() -> Self {
        World {
            digital_in: [false; 18],
            analog_in: [0.0; 4],
            input_int_regs: [0; 48],
            input_float_regs: [0.0; 48],
            input_bool_regs: [false; 128],
            tcp_force: [0.0; 6],
            contact_plane: [0.0; 6],
            contact_stiffness: 0.0,
            joint_torques: [0.0; 6],
            joint_temp: [35.0; 6],
            controller_temp: 30.0,
            tool_temp: 32.0,
            tool_current: 0.0,
            operator_bool: false,
            operator_int: 0,
            operator_float: 0.0,
            operator_string: Vec::new(),
            rotor_inertia: [0.0; 6],
            execution_time: 0.0,
            controller_uptime: Duration::ZERO,
            system_time: Duration::ZERO,
            eip_from_plc: BTreeMap::new(),
            eip_connected: false,
            rtde_watchdogs: false,
            euromap_in: [false; 32],
            rtde_input_updates: BTreeMap::new(),
        }
    }
}

/// The controller's state.
#[derive(Debug)]
pub(crate) struct Runtime {
    /// The arm's kinematics (its model's DH parameters).
    pub dh: Dh,
    /// Length of one step.
    pub step_time: Duration,
    /// The step running now (or next).
    pub step: u64,
    pub arm: Arm,
    pub sockets: Sockets,
    /// What the driver must do or show, oldest first.
    pub events: crate::vm::memory::Events,
    /// What the program asks of the controller running it, in the order asked, each
    /// kind at most once (so at most as many as [`Effect`] has kinds).
    pub(crate) effects: Vec<Effect>,
    /// The count of the program's memory against its budget.
    pub mem: crate::vm::memory::Memory,
    /// The motion under way, if the arm moves.
    pub motion: Option<Motion>,
    /// The handle of the thread running now (the owner of a motion it commands).
    pub thread: u32,
    /// The step the arm was last put at by the motion under way.
    pub sampled: Option<u64>,
    /// The program's EtherNet/IP handles.
    pub eip: crate::eip::Handles,
    /// The program's RTDE watchdogs (`rtde_set_watchdog`).
    pub rtde_watchdogs: Vec<RtdeWatchdog>,
    /// The motion clock: the time motions run on (see [`MotionClock`]).
    pub clock: MotionClock,
    /// The step the TCP's contact with the contact plane began in (`tool_contact`), while
    /// it lasts.
    pub contact_since: Option<u64>,
    /// The joints of the steps before (`get_actual_joint_positions_history`).
    pub(crate) joint_history: crate::history::JointHistory,
    /// The move or stream whose start was reported and whose end was not.
    pub tracked: Option<Tracked>,
    /// The start of the move queued behind a blending one (reported when it starts).
    pub queued: Option<Box<MoveStart>>,
}

/// A move or stream under way, as reported ([`Event::MoveStart`]).
#[derive(Debug)]
pub(crate) struct Tracked {
    pub start: Box<MoveStart>,
    /// The step it started in.
    pub step: u64,
    /// Commands so far (a stream's `servoj` calls...).
    pub samples: u64,
    /// A stream of `servoj`/`speedj`... commands (its end is the next other command).
    pub stream: bool,
    /// A stream whose last command's motion has ended: the step it ended in.
    pub ended: Option<u64>,
}

/// The motion clock, counted in steps: it advances by the speed slider's fraction each
/// step (1.0: it is the step count), so every motion sampled on it runs at that fraction
/// of its programmed speed. Piecewise linear in the step: `anchor` at `anchor_step`, then
/// `fraction` per step; a slider change starts a new piece at the step it takes effect.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct MotionClock {
    pub fraction: f64,
    pub anchor_step: u64,
    pub anchor: f64,
}

impl Default for MotionClock {
    fn default() -> Self {
        MotionClock {
            fraction: 1.0,
            anchor_step: 0,
            anchor: 0.0,
        }
    }
}

impl MotionClock {
    /// The clock at step `step`.
    pub fn at(&self, step: u64) -> f64 {
        self.anchor + (step as f64 - self.anchor_step as f64) * self.fraction
    }

    /// The first step at or after `from` whose clock has reached `t`; `None` if the clock
    /// stands still (slider at 0) short of it.
    pub fn step_reaching(&self, t: f64, from: u64) -> Option<u64> {
        if self.at(from) >= t {
            return Some(from);
        }
        if self.fraction <= 0.0 {
            return None;
        }
        let guess = self.anchor_step as f64 + ((t - self.anchor) / self.fraction).ceil();
        // `as` saturates; rounding is corrected by a step either way.
        let mut s = (guess as u64).max(from);
        while s > from && self.at(s - 1) >= t {
            s -= 1;
        }
        while self.at(s) < t && s < u64::MAX {
            s += 1;
        }
        Some(s)
    }
}

/// The most RTDE watchdogs a program sets (one per input field; RTDE has fewer input
/// fields than this).
pub const MAX_RTDE_WATCHDOGS: usize = 256;

/// One `rtde_set_watchdog(variable_name, min_frequency, action)`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct RtdeWatchdog {
    pub variable: String,
    /// Steps without an update before it fires.
    pub period: u64,
    /// 0 ignore, 1 pause, 2 stop.
    pub action: u8,
    /// The field's update count last seen, and the step it was seen to change.
    pub seen: u64,
    pub since: u64,
    pub fired: bool,
}

/// What a fired RTDE watchdog asks.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum WatchdogTrip {
    Pause,
    Stop(String),
}

impl Runtime {
    /// Checks the RTDE watchdogs at this step (see [`World::rtde_watchdogs`]).
    pub fn check_rtde_watchdogs(&mut self) -> Option<WatchdogTrip> {
        if !self.arm.world.rtde_watchdogs {
            return None;
        }
        let step = self.step;
        let mut trip = None;
        for w in &mut self.rtde_watchdogs {
            let count = self
                .arm
                .world
                .rtde_input_updates
                .get(&w.variable)
                .copied()
                .unwrap_or(0);
            if count != w.seen {
                w.seen = count;
                w.since = step;
                w.fired = false;
                continue;
            }
            if w.fired || step < w.since.saturating_add(w.period) {
                continue;
            }
            w.fired = true;
            match w.action {
                1 => trip = trip.or(Some(WatchdogTrip::Pause)),
                2 => {
                    trip = Some(WatchdogTrip::Stop(format!(
                    "RTDE watchdog: no update of input \"{}\" within its period: program stopped",
                    w.variable
                )))
                }
                _ => {}
            }
        }
        trip
    }

    /// The first step a running RTDE watchdog may fire at (the machine wakes for it).
    pub fn next_rtde_watchdog(&self) -> Option<u64> {
        if !self.arm.world.rtde_watchdogs {
            return None;
        }
        self.rtde_watchdogs
            .iter()
            .filter(|w| !w.fired)
            .map(|w| w.since.saturating_add(w.period))
            .min()
    }
}

impl Runtime {
    /// Takes up the arm's speed slider ([`Arm::speed_fraction`]) from step `self.step` on.
    pub fn sync_speed(&mut self) {
        let f = self.arm.slider();
        if f != self.clock.fraction {
            let at = self.clock.at(self.step);
            self.clock = MotionClock {
                fraction: f,
                anchor_step: self.step,
                anchor: at,
            };
        }
    }

    /// The motion clock now.
    pub fn clock_now(&self) -> f64 {
        self.clock.at(self.step)
    }

    /// The joint speeds in motion time: the programmed speeds the arm moves at the
    /// slider's fraction of (the speeds themselves at a fraction of 0 or 1). A speed
    /// command ramps from these, so a stream of them keeps its path under the slider.
    pub fn motion_qd(&self) -> [f64; 6] {
        self.unscaled(self.arm.qd)
    }

    /// The tool speed in motion time (see [`Runtime::motion_qd`]).
    pub fn motion_tcp_speed(&self) -> [f64; 6] {
        self.unscaled(self.arm.tcp_speed)
    }

    fn unscaled(&self, v: [f64; 6]) -> [f64; 6] {
        let f = self.clock.fraction;
        if f > 0.0 && f < 1.0 {
            v.map(|x| x / f)
        } else {
            v
        }
    }

    /// Ends teach/freedrive mode and force mode (the program stopped).
    pub fn end_modes(&mut self) {
        self.arm.hand_mode = 0;
        self.arm.force_mode = None;
    }

    /// The force the sensor reads now (see [`Arm::measured_tcp_force`]).
    pub fn measured_tcp_force(&self) -> [f64; 6] {
        self.arm.measured_tcp_force(&self.dh)
    }

    /// A protective stop: the arm stops at once and [`Effect::ProtectiveStop`] is left
    /// for the controller that runs the arm (a program alone just goes on, stopped).
    pub fn protective_stop(&mut self) {
        self.end_move(MoveOutcome::ProtectiveStop, self.step);
        self.stop_at_once();
        self.effect(Effect::ProtectiveStop);
    }

    /// Leaves `e` for the controller that runs the program (once: a second request of
    /// the same kind before the controller takes them adds nothing).
    pub(crate) fn effect(&mut self, e: Effect) {
        if !self.effects.contains(&e) {
            self.effects.push(e);
        }
    }

    /// The arm stops where it is, at once (no ramp): no motion, no speed.
    pub fn stop_at_once(&mut self) {
        self.halt();
        self.arm.qd = [0.0; 6];
        self.arm.tcp_speed = [0.0; 6];
    }

    /// Starts a motion now (replacing any under way) for the thread running now, and puts
    /// the arm at its start. `stream`: the command of a servo or speed stream (reported
    /// once per stream: a command of the same function continues the one under way);
    /// `None`: `stopj`/`stopl`, which stop what is under way.
    pub fn start_motion(&mut self, kind: Kind, tcp: [f64; 6], stream: Option<MoveStart>) {
        match stream {
            None => self.end_move(MoveOutcome::Stopped, self.step),
            Some(info) => {
                let same = self
                    .tracked
                    .as_ref()
                    .is_some_and(|t| t.stream && t.start.function == info.function);
                if same {
                    if let Some(t) = self.tracked.as_mut() {
                        t.samples = t.samples.saturating_add(1);
                        t.ended = None;
                    }
                } else {
                    self.supersede();
                    self.begin_move(info, true, self.step);
                }
            }
        }
        self.queued = None;
        self.motion = Some(Motion {
            kind,
            start: self.clock_now(),
            owner: self.thread,
            tcp,
            blend: None,
            next: None,
        });
        self.restart_force_offset();
        self.sampled = None;
        self.advance(self.step);
    }

    /// A motion that starts where the arm is (force mode's offset included) carries that
    /// offset in its own start: force mode adds to it from zero.
    fn restart_force_offset(&mut self) {
        if let Some(fm) = self.arm.force_mode.as_mut() {
            fm.offset = [0.0; 6];
        }
    }

    /// The move under way that the running thread commanded with a blend radius (the
    /// program got control back when its blend began).
    fn blending(&self) -> Option<&Motion> {
        self.motion
            .as_ref()
            .filter(|m| m.owner == self.thread && m.blend.is_some())
    }

    /// Where the running thread's next move starts: the target (joints, tool pose) of a
    /// move under way with a blend radius (the next move blends from it, or starts there
    /// when it ends), else where the arm is.
    pub fn move_start(&self) -> ([f64; 6], [f64; 6]) {
        self.blending()
            .and_then(|m| m.kind.end(&self.dh, m.tcp))
            .unwrap_or_else(|| (self.arm.q, self.tcp_pose()))
    }

    /// Starts a move (`movej`, `movel`, `movep`, `movec`) planned from
    /// [`move_start`](Self::move_start), with blend radius `r` at its target; returns the
    /// time until the program gets control back: the move's end, or where its blend
    /// begins (`r > 0`).
    ///
    /// If a move with a blend radius is under way for this thread: commanded in the step
    /// its blend began (the program ran no statement that takes time since), the new move
    /// blends from it ([`trajectory::blend`]); later (a `sleep`, a socket read, ... in
    /// between), or if the two cannot blend, the arm stops at that move's target and the
    /// new move starts there when it ends: the controller's lookahead of one move.
    ///
    /// A radius limited because the blends would overlap (or the move is shorter than
    /// `r`) is reported as a [`MessageKind::BlendRadiusReduced`] message for `line`, as
    /// the controller logs a warning.
    ///
    /// The move is reported ([`Event::MoveStart`]) when the arm sets off with it; the one
    /// it blends from ends `Blended` then.
    pub fn start_move(&mut self, kind: Kind, tcp: [f64; 6], r: f64, info: MoveStart) -> f64 {
        let line = info.line;
        let dt = self.step_time.as_secs_f64();
        let steps = |secs: f64| {
            if dt > 0.0 && secs.is_finite() {
                (secs.max(0.0) / dt).ceil() as u64
            } else {
                0
            }
        };
        let now = self.clock_now();
        let mut kind = kind;
        let mut start = now;
        // A blend goes on from the programmed path; any other move starts where the arm is.
        let mut continuous = false;
        if let Some(m) = self.blending() {
            let t = (now - m.start) * dt;
            let began = m.blend.is_some_and(|b| b.step == self.step);
            let blended = if began {
                trajectory::blend(&self.dh, tcp, (&m.kind, t), &kind, self.arm.q)
            } else {
                None
            };
            match blended {
                Some(k) => {
                    kind = k;
                    continuous = true;
                    self.end_move(MoveOutcome::Blended, self.step);
                }
                None => start = (m.start + steps(m.duration()) as f64).max(now),
            }
        }
        let (mut blend, reduced) = trajectory::blend_start(&self.dh, tcp, &kind, r);
        if let Some(reduced) = reduced {
            self.events.push_back(Event::Message(Message {
                line,
                kind: MessageKind::BlendRadiusReduced {
                    requested: r,
                    reduced,
                },
                text: format!(
                    "blend radius reduced from {} m to {} m: blends may not overlap",
                    crate::value::Value::Float(r).to_str(),
                    crate::value::Value::Float(reduced).to_str()
                ),
                args: Vec::new(),
            }));
        }
        let back = blend.map_or(kind.duration(), |b| b.at);
        // The motion clock the program gets control back at: whole steps of motion time
        // after the move's start (as the scheduler counts a wait).
        let n = secs(back)
            .as_nanos()
            .div_ceil(self.step_time.as_nanos().max(1));
        let until = start + u64::try_from(n).unwrap_or(u64::MAX) as f64;
        if let Some(b) = blend.as_mut() {
            b.back = until;
            b.after = self.step.saturating_add(1);
            b.step = u64::MAX;
        }
        let motion = Motion {
            kind,
            start,
            owner: self.thread,
            tcp,
            blend,
            next: None,
        };
        if start > now {
            if let Some(m) = self.motion.as_mut() {
                m.next = Some(Box::new(motion));
                self.queued = Some(Box::new(info));
            }
        } else {
            self.supersede();
            self.begin_move(info, false, self.step);
            self.queued = None;
            if !continuous {
                self.restart_force_offset();
            }
            self.motion = Some(motion);
            self.sampled = None;
            self.advance(self.step);
        }
        until
    }

    /// Puts the arm where the motion under way (and force mode) has it at step `step`.
    pub fn advance(&mut self, step: u64) {
        let clock = self.clock.at(step);
        // The move queued behind a blended one starts when that one has ended.
        if let Some(m) = self.motion.as_mut() {
            if m.next.as_ref().is_some_and(|n| clock >= n.start) {
                if let Some(n) = m.next.take() {
                    // The move before it ended at its target.
                    if let Some((q, _)) = m.kind.end(&self.dh, m.tcp) {
                        self.arm.q = q;
                    }
                    self.motion = Some(*n);
                    self.sampled = None;
                    self.end_move(MoveOutcome::Reached, step);
                    if let Some(info) = self.queued.take() {
                        self.begin_move(*info, false, step);
                    }
                }
            }
        }
        if self.motion.is_none() && self.arm.force_mode.is_none() {
            return;
        }
        if self.sampled == Some(step) {
            return;
        }
        // The joint accelerations: the change of speed since the last sample.
        let steps = match self.sampled {
            Some(last) if step > last => step - last,
            _ => 1,
        };
        let dt = steps as f64 * self.step_time.as_secs_f64();
        self.sampled = Some(step);
        let before = (self.arm.q, self.arm.qd);
        let mut moved = false;
        // How the motion ended in this step, if it did: a protective stop, or at its
        // target (with whether a queued move started).
        let mut ended: Option<Result<bool, ()>> = None;
        if let Some(m) = self.motion.as_mut() {
            moved = true;
            // The program gets control back from a move with a blend in the first step
            // its motion clock reaches the blend.
            if let Some(b) = m.blend.as_mut() {
                if b.step == u64::MAX && clock >= b.back && step >= b.after {
                    b.step = step;
                }
            }
            let f = self.clock.fraction;
            let t = (clock - m.start) * self.step_time.as_secs_f64();
            let s = m.sample(&self.dh, t, self.arm.q);
            self.arm.q = s.q;
            // The arm moves at the slider's fraction of the programmed speeds.
            let qd = s.qd.map(|v| v * f);
            for ((a, new), old) in self.arm.qdd.iter_mut().zip(qd).zip(self.arm.qd) {
                *a = if dt > 0.0 { (new - old) / dt } else { 0.0 };
            }
            self.arm.qd = qd;
            self.arm.tcp_speed = match s.tcp_speed {
                Some(v) => v.map(|x| x * f),
                None => crate::arm::trajectory::tcp_speed(&self.dh, s.q, qd, self.arm.tcp),
            };
            if s.stop {
                // The path left the arm's reach: it stops here (nothing queued goes on) and
                // the controller running it makes that a protective stop.
                self.motion = None;
                self.arm.qd = [0.0; 6];
                self.arm.qdd = [0.0; 6];
                self.arm.tcp_speed = [0.0; 6];
                self.effect(Effect::ProtectiveStop);
                ended = Some(Err(()));
            } else if s.done {
                // A move queued behind this one starts now (at rest, where this one ended).
                let next = m.next.take();
                ended = Some(Ok(next.is_some()));
                self.motion = next.map(|n| *n);
                self.arm.qdd = [0.0; 6];
            }
        }
        match ended {
            Some(Err(())) => {
                self.queued = None;
                self.end_move(MoveOutcome::ProtectiveStop, step);
            }
            Some(Ok(queued)) => {
                match self.tracked.as_mut() {
                    Some(t) if t.stream => t.ended = Some(step),
                    _ => self.end_move(MoveOutcome::Reached, step),
                }
                if queued {
                    if let Some(info) = self.queued.take() {
                        self.begin_move(*info, false, step);
                    }
                }
            }
            None => {}
        }
        if self.arm.force_mode.is_some() {
            self.force_step(step, moved, before);
        }
        if self.arm.world.contact_stiffness > 0.0 {
            self.track_contact(step);
        }
        self.joint_history.record(step, before.0, self.arm.q);
    }

    /// Force mode up to step `step` (from the last step it ran to), from joints `before`
    /// (speeds `qd_before`): the program's pose (the motion's, when one was sampled this
    /// step, else the last) moved by what force mode adds (see [`crate::arm::force`]).
    fn force_step(&mut self, step: u64, sampled: bool, (before, qd_before): ([f64; 6], [f64; 6])) {
        let step_time = self.step_time.as_secs_f64();
        let tcp = self.arm.tcp;
        let programmed_q = self.arm.q;
        let v = [
            self.arm.tcp_speed[0],
            self.arm.tcp_speed[1],
            self.arm.tcp_speed[2],
        ];
        let plane = self.arm.world.contact_plane;
        let stiffness = self.arm.world.contact_stiffness;
        let actual = kinematics::forward(&self.dh, before, tcp);
        let Some(fm) = self.arm.force_mode.as_mut() else {
            return;
        };
        if sampled {
            fm.programmed = kinematics::forward(&self.dh, programmed_q, tcp);
        }
        // Each step moves force mode once (a motion started in a step already run only
        // takes up the offset).
        let dt = step.saturating_sub(fm.at) as f64 * step_time;
        fm.at = fm.at.max(step);
        let kept = fm.offset;
        fm.step(actual, v, dt, plane, stiffness);
        let mut q = crate::arm::force::joints_at(
            &self.dh,
            crate::arm::force::offset_pose(fm.programmed, fm.offset),
            tcp,
            before,
        );
        if q.is_none() {
            // Out of reach: force mode goes no further that way.
            fm.offset = kept;
            q = crate::arm::force::joints_at(
                &self.dh,
                crate::arm::force::offset_pose(fm.programmed, kept),
                tcp,
                before,
            );
        }
        let q = q.unwrap_or(before);
        if dt <= 0.0 {
            self.arm.q = q;
            return;
        }
        let qd: [f64; 6] = if dt > 0.0 {
            std::array::from_fn(|k| (q[k] - before[k]) / dt)
        } else {
            [0.0; 6]
        };
        for ((a, new), old) in self.arm.qdd.iter_mut().zip(qd).zip(qd_before) {
            *a = if dt > 0.0 { (new - old) / dt } else { 0.0 };
        }
        self.arm.q = q;
        self.arm.qd = qd;
        self.arm.tcp_speed = crate::arm::trajectory::tcp_speed(&self.dh, q, qd, tcp);
    }

    /// Follows the TCP's contact with the contact plane (`tool_contact`).
    fn track_contact(&mut self, step: u64) {
        let touching = self.arm.world.contact_stiffness > 0.0
            && self.measured_contact().iter().any(|f| *f != 0.0);
        self.contact_since = match (touching, self.contact_since) {
            (true, None) => Some(step),
            (true, since) => since,
            (false, _) => None,
        };
    }

    /// The contact plane's push on the TCP now (N, base frame).
    pub fn measured_contact(&self) -> [f64; 6] {
        crate::arm::force::contact_force(
            self.arm.world.contact_plane,
            self.arm.world.contact_stiffness,
            self.tcp_pose(),
        )
    }

    /// A built-in about to allocate `bytes` (more than a few) checks they fit in the
    /// program's memory budget first. A refusal must come before the built-in changes
    /// anything: the machine recounts and runs it once more if the count was high.
    pub fn reserve(&mut self, bytes: usize) -> Result<(), Fault> {
        let events = self.events.bytes();
        if self.mem.fits(events, bytes) {
            return Ok(());
        }
        self.mem.refused = true;
        Err(self.mem.over(events, bytes))
    }

    /// Reports the start of a move or stream at step `step` and tracks it.
    fn begin_move(&mut self, mut info: MoveStart, stream: bool, step: u64) {
        info.at = self.time_of(step);
        let start = Box::new(info);
        self.events.push_back(Event::MoveStart(start.clone()));
        self.tracked = Some(Tracked {
            start,
            step,
            samples: 1,
            stream,
            ended: None,
        });
    }

    /// Ends what is tracked because another command takes over now: a stream whose last
    /// command's motion had ended reached its target then; anything else is replaced.
    fn supersede(&mut self) {
        match self.tracked.as_ref().and_then(|t| t.ended) {
            Some(at) => self.end_move(MoveOutcome::Reached, at),
            None => self.end_move(MoveOutcome::Replaced, self.step),
        }
    }

    /// Reports the end of the tracked move or stream (if any) at step `step`, the arm
    /// where it is now.
    fn end_move(&mut self, outcome: MoveOutcome, step: u64) {
        let Some(t) = self.tracked.take() else {
            return;
        };
        // A stream whose last command had ended reached its target then.
        let (outcome, step) = match t.ended {
            Some(at) if outcome != MoveOutcome::ProtectiveStop => (MoveOutcome::Reached, at),
            _ => (outcome, step),
        };
        let step = step.max(t.step);
        let at = self.time_of(step);
        let pose = self.tcp_pose();
        self.events.push_back(Event::MoveEnd(Box::new(MoveEnd {
            line: t.start.line,
            function: t.start.function,
            outcome,
            at,
            took: at.saturating_sub(t.start.at),
            samples: t.samples,
            q: self.arm.q,
            pose,
        })));
    }

    /// Stops the arm where it is (its thread was killed, the program stopped).
    pub fn halt(&mut self) {
        self.queued = None;
        self.end_move(MoveOutcome::Halted, self.step);
        if self.motion.take().is_some() {
            self.arm.qd = [0.0; 6];
            self.arm.qdd = [0.0; 6];
            self.arm.tcp_speed = [0.0; 6];
        }
    }

    /// The tool pose of the joints `q` through the active TCP offset.
    pub fn tool_pose(&self, q: [f64; 6]) -> [f64; 6] {
        kinematics::forward(&self.dh, q, self.arm.tcp)
    }

    /// The commanded tool pose (the TCP, base frame).
    pub fn tcp_pose(&self) -> [f64; 6] {
        self.tool_pose(self.arm.q)
    }

    /// The commanded flange pose (no TCP offset).
    pub fn flange_pose(&self) -> [f64; 6] {
        kinematics::forward(&self.dh, self.arm.q, [0.0; 6])
    }

    /// The joints that put the tool at `pose` through `tcp`, nearest `qnear`; what went
    /// wrong, in the controller's terms, if the pose is out of reach.
    pub fn inverse(
        &self,
        pose: [f64; 6],
        qnear: [f64; 6],
        tcp: [f64; 6],
    ) -> Result<[f64; 6], String> {
        let solutions = kinematics::inverse(&self.dh, pose, tcp, qnear);
        kinematics::nearest(&solutions, qnear).ok_or_else(|| {
            format!(
                "no inverse kinematics solution: {} is out of reach",
                crate::value::Value::Pose(pose).to_str()
            )
        })
    }

    /// The program time of the step running now.
    pub fn now(&self) -> Duration {
        self.time_of(self.step)
    }

    /// The program time of step `step`.
    pub fn time_of(&self, step: u64) -> Duration {
        let nanos = self.step_time.as_nanos().saturating_mul(u128::from(step));
        Duration::from_nanos(u64::try_from(nanos).unwrap_or(u64::MAX))
    }

    /// Queues the socket's outgoing bytes as an event.
    pub fn flush(&mut self, name: &str) {
        let bytes = self.sockets.take_outgoing(name);
        if !bytes.is_empty() {
            self.events.push_back(Event::Transmit {
                socket_name: name.to_string(),
                bytes,
            });
        }
    }

    /// Closes `name` if it is open, sending what it still holds first.
    pub fn close(&mut self, name: &str) {
        if self.sockets.is_open(name) {
            self.flush(name);
            self.sockets.close(name);
            self.events.push_back(Event::Close {
                socket_name: name.to_string(),
            });
        }
    }
}

/// The joint range of UR's arms (e-Series and CB3): ±2π, ±360°.
pub const JOINT_LIMIT: f64 = std::f64::consts::TAU;

/// Seconds as a duration (negative: zero; too large: the longest).
pub(crate) fn secs(x: f64) -> Duration {
    Duration::try_from_secs_f64(x.max(0.0)).unwrap_or(Duration::MAX)
}
