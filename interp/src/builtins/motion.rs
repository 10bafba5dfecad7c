//! Motion, the arm's state, and the arm's settings, on the **virtual arm**: the arm
//! follows each command in time (kinematics, speed profiles), not dynamics. See
//! `crate::arm::trajectory` for the profiles; in short:
//!
//! - `movej(q, a=1.4, v=1.05, t=0, r=0)`: a trapezoidal profile in joint space on the joint
//!   that moves furthest (a triangle when too short to reach `v`), all joints arriving
//!   together; `movel(pose, a=1.2, v=0.25, t=0, r=0)`, `movep`: the tool along the straight
//!   line, its orientation turning about one axis, along the same profile on the path
//!   length, the joints by inverse kinematics nearest the previous step's; `movec(pose_via,
//!   pose_to, ...)`: the same along the arc through `pose_via`'s position (mode 1 is taken
//!   as mode 0). `t > 0` stretches the profile to take `t`. `optimovej`/`optimovel`: like
//!   `movej`/`movel` (their `a`, `v` are fractions on the robot; here they are taken as
//!   speeds). A target given as a pose is reached through inverse kinematics nearest the
//!   joints the move starts from (out of reach: for `movej` a runtime error before the
//!   arm moves; for `movel`/`movep`/`movec` the tool sets off along its path and stops
//!   where the path leaves the arm's reach, with a protective stop, `Arm::protective_stop`,
//!   as a real arm stops when the line runs it into a singularity).
//!   Every motion takes at least one step; with `r = 0` the arm is exactly at the target,
//!   at rest, in the step the move returns.
//! - Blend radius `r > 0` (m; negative is a runtime error): the move returns where the
//!   tool enters the sphere of radius `r` around its target (the program's next
//!   statements run then, as on the controller, which evaluates them on entering the
//!   blend radius). A `movej`, `movel` or `movep` commanded in that same step after one
//!   of them blends in without a stop (see `crate::arm::trajectory::blend`: joint speeds
//!   continuous, the tool within `r` of the corner, a straight-move blend a circular arc
//!   at constant tool speed). A move commanded later (a `sleep`, `sync`, a socket read
//!   ran first), or one that cannot blend (`movec` either side, a next target inside
//!   the sphere), starts when the first has
//!   stopped at its target: the lookahead holds one move. The radius is reduced so that
//!   a blend never overlaps the one before it (UR: "blends cannot overlap").
//! - A joint target outside the joints' range, ±2π (±360°, UR's e-Series and CB3 arms),
//!   is a runtime error (`movej`, `movel` with joints, `servoj`, `set_pos`); inverse
//!   kinematics only gives solutions within it.
//! - `servoj(q, a, v, t=0.002, lookahead_time=0.1, gain=300)`: straight to `q` at constant
//!   speed over `t`.
//! - `speedj(qd, a, t)`, `speedl(xd, a, t, aRot)`: the speed ramps linearly to the target
//!   at `a`, then holds (the joints integrate it; for `speedl` they follow the tool) until
//!   the next motion command; returns after `t` (one step if not given). `stopj(a)`,
//!   `stopl(a, aRot)`: ramp the speed down to zero at `a`; return at rest.
//! - A motion runs until it ends, another motion command replaces it, or the thread that
//!   commanded it is killed or the program stops (then the arm stays where it is, at
//!   rest).
//! - `get_actual_joint_positions()`, `get_target_joint_positions()`: the arm's joints now
//!   (mid-move and mid-blend too); `get_actual_tcp_pose()`, `get_target_tcp_pose()`: the
//!   tool pose now; `get_target_waypoint()`: the target of the move under way (from the
//!   start of a blend, the next move's), the tool pose at rest; speeds the speeds now;
//!   `tool_contact()`: the steps since the TCP touched the contact plane (0 without
//!   contact; see `crate::arm::force`); `is_steady()`: False while a motion (a blend too) is
//!   under way, a speed is held, the joints move, or the arm is in teach/freedrive mode.
//! - The speed slider (`Arm::speed_fraction`): every motion above runs on the motion
//!   clock, which advances by the slider's fraction each step; moves and `stopj`/`stopl`
//!   return when their motion ends on it; `servoj`, `speedj`, `speedl` return after `t`
//!   of program time (the arm gets only as far as the slider lets it).
//! - `force_mode`/`end_force_mode`: see `crate::arm::force`. `teach_mode`/`freedrive_mode`:
//!   the arm stops and the operator moves the joints (`Arm::move_by_hand`) until the
//!   `end_` call or the program's end.
//! - `is_within_safety_limits(pose, qnear)`: reachable by the inverse kinematics with
//!   every joint within ±2π (joints given: each within ±2π).
//! - Settings read back by their getters: payload (`set_target_payload`, `set_payload*`
//!   -> `get_target_payload*`), TCP (`set_tcp` -> `get_tcp_offset`), gravity, base
//!   acceleration, path offset (`path_offset_*`), `set_pos` (the joints).
//! - What the robot measures of the world returns the documented fixed value of its
//!   field of the virtual arm (`crate::runtime::Arm`): `get_tcp_force()` and `force()`
//!   `World::tcp_force` (0) plus the contact plane's push, `get_joint_torques()` 0, `get_joint_temp(j)` 35.0 °C, `get_controller_temp()`
//!   30.0 °C, `get_tool_temp()` 32.0 °C, `get_tool_current()` 0.0 A;
//!   `get_tool_accelerometer_reading()` is the gravity vector seen from the flange.
//! - Settings the virtual arm has no use for (`zero_ftsensor`,
//!   `screw_driving`, ...) are accepted with their manual signatures and do nothing.

use super::{
    accept, builtin, float_list, floats, opt, req, secs, Args, Builtin, Default, Domain, Out,
};
use crate::arm::trajectory::{self, Kind, Path, Profile};
use crate::error::Fault;
use crate::event::MoveStart;
use crate::native::FromArg;
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Motion;
const ZERO3: &[f64] = &[0.0, 0.0, 0.0];
const NONE: &[super::Param] = &[];

const SENSOR: [super::Param; 4] = [
    req("enable"),
    opt("sensor_mass", Default::Float(0.0)),
    opt("sensor_measuring_offset", Default::Floats(ZERO3)),
    opt("sensor_cog", Default::Floats(ZERO3)),
];

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        movej(q: Target, a: f64 = Float(1.4), v: f64 = Float(1.05), t: f64 = Float(0.0), r: f64 = Float(0.0))
            => |c, x, q, a, v, t, r| go(c, x, Space::Joint, q, (a, v, t, r)),
        "Moves in joint space: a trapezoidal profile on the largest joint distance (t: stretched to take t).",
    ),
    builtin!(
        movel(pose: Target, a: f64 = Float(1.2), v: f64 = Float(0.25), t: f64 = Float(0.0), r: f64 = Float(0.0))
            => |c, x, pose, a, v, t, r| go(c, x, Space::Tool, pose, (a, v, t, r)),
        "Moves the tool in a straight line: a trapezoidal profile on the distance (t: stretched to take t).",
    ),
    builtin!(
        movep(pose: Target, a: f64 = Float(1.2), v: f64 = Float(0.25), r: f64 = Float(0.0))
            => |c, x, pose, a, v, r| go(c, x, Space::Tool, pose, (a, v, 0.0, r)),
        "Process move: as movel.",
    ),
    builtin!(
        servoc(pose: Target, a: f64 = Float(1.2), v: f64 = Float(0.25), r: f64 = Float(0.0))
            => |c, x, pose, a, v, r| go(c, x, Space::Tool, pose, (a, v, 0.0, r)),
        "Servo to a pose in a circular blend: timed as movel to the pose.",
    ),
    builtin!(
        powerdown() => powerdown,
        "Shuts the robot down: the program halts and the controller running it powers the arm off (Arm::powerdown).",
    ),
    builtin!(
        protective_stop() => protective_stop,
        "Triggers a protective stop: the arm stops and the call takes one step, so the controller running it pauses the program before the next statement (Arm::protective_stop).",
    ),
    // `optimovej(goal, a=0.3, v=0.3, r=0)`, `optimovel(goal, ...)`: the manual names the
    // target `goal` (joints or a pose here).
    builtin!(
        optimovej(goal: Target, a: f64 = Float(0.3), v: f64 = Float(0.3), r: f64 = Float(0.0))
            => |c, x, goal, a, v, r| go(c, x, Space::Joint, goal, (a, v, 0.0, r)),
        "As movej (a and v taken as speeds).",
    ),
    builtin!(
        optimovel(goal: Target, a: f64 = Float(0.3), v: f64 = Float(0.3), r: f64 = Float(0.0))
            => |c, x, goal, a, v, r| go(c, x, Space::Tool, goal, (a, v, 0.0, r)),
        "As movel (a and v taken as speeds).",
    ),
    builtin!(
        movec(
            pose_via: Target,
            pose_to: Target,
            a: f64 = Float(1.2),
            v: f64 = Float(0.25),
            r: f64 = Float(0.0),
            mode: Given<'_, f64> = Int(0),
        ) => |c, x, via, to, a, v, r, mode| movec(c, x, via, to, (a, v, r), mode),
        "Circular move: the tool along the arc through pose_via to pose_to.",
    ),
    builtin!(
        servoj(
            q: [f64; 6],
            a: f64 = Float(0.0),
            v: f64 = Float(0.0),
            t: f64 = Float(0.002),
            lookahead_time: &Value = Float(0.1),
            gain: &Value = Float(300.0),
        ) => |c, x, q, a, v, t, _, _| servoj(c, x, q, (a, v, t)),
        "Moves to q at constant speed over t.",
    ),
    builtin!(
        speedj(qd: [f64; 6], a: f64, t: Option<f64> = Absent)
            => |c, x, qd, a, t| speed(c, x, Space::Joint, qd, a, t, None),
        "Ramps the joint speeds to qd at a and holds them; returns after t (one step if not given).",
    ),
    builtin!(
        speedl(xd: [f64; 6], a: f64, t: Option<f64> = Absent, aRot: Option<f64> = Absent)
            => |c, x, xd, a, t, a_rot| speed(c, x, Space::Tool, xd, a, t, a_rot),
        "Ramps the tool speed to xd at a (aRot) and holds it; returns after t (one step if not given).",
    ),
    builtin!(
        stopj(a: f64) => |c, _, a| stop(c, Space::Joint, a, None),
        "Ramps the joint speeds down to zero at a; returns at rest.",
    ),
    builtin!(
        stopl(a: f64, aRot: Option<f64> = Absent) => |c, _, a, a_rot| stop(c, Space::Tool, a, a_rot),
        "Ramps the tool speed down to zero at a (aRot); returns at rest.",
    ),
    builtin!(
        direct_torque(
            torque: [f64; 6],
            friction_comp: &Value = Bool(true),
            viscous_scale: &Value = Absent,
            coulomb_scale: &Value = Absent,
        ) => |c, _, _, _, _, _| direct_torque(c),
        "Torque control has no model here: takes one step.",
    ),
    Builtin::new(
        "get_actual_joint_positions",
        D,
        NONE,
        "The commanded joints.",
        joints,
    ),
    Builtin::new(
        "get_target_joint_positions",
        D,
        NONE,
        "The commanded joints.",
        joints,
    ),
    Builtin::new(
        "get_joint_positions",
        D,
        NONE,
        "The commanded joints (CB3 name).",
        joints,
    ),
    Builtin::new(
        "get_actual_joint_positions_history",
        D,
        &[opt("steps", Default::Int(0))],
        "The joints `steps` controller steps ago (0: now); a runtime error past the history's JOINT_HISTORY_STEPS steps.",
        joints_history,
    ),
    Builtin::new(
        "get_actual_joint_speeds",
        D,
        NONE,
        "The commanded joint speeds.",
        joint_speeds,
    ),
    Builtin::new(
        "get_target_joint_speeds",
        D,
        NONE,
        "The commanded joint speeds.",
        joint_speeds,
    ),
    Builtin::new(
        "get_actual_tcp_pose",
        D,
        NONE,
        "The commanded tool pose.",
        tcp_pose,
    ),
    Builtin::new(
        "get_target_tcp_pose",
        D,
        NONE,
        "The commanded tool pose.",
        tcp_pose,
    ),
    Builtin::new(
        "get_actual_tcp_speed",
        D,
        NONE,
        "The commanded tool speed.",
        tcp_speed,
    ),
    Builtin::new(
        "get_target_tcp_speed",
        D,
        NONE,
        "The commanded tool speed.",
        tcp_speed,
    ),
    Builtin::new(
        "get_tcp_force",
        D,
        NONE,
        "The force/torque sensor (base frame): World::tcp_force plus the contact plane's push on the TCP (settable: tcp_force, contact_plane, contact_stiffness).",
        tcp_force,
    ),
    Builtin::new(
        "force",
        D,
        NONE,
        "The norm of get_tcp_force()'s force part.",
        force,
    ),
    Builtin::new(
        "get_actual_tool_flange_pose",
        D,
        NONE,
        "The commanded tool pose without the TCP offset.",
        flange_pose,
    ),
    Builtin::new(
        "get_target_waypoint",
        D,
        NONE,
        "The target of the move under way (during a blend, the next move's); at rest, the tool pose.",
        waypoint,
    ),
    Builtin::new(
        "get_target_tcp_pose_along_path",
        D,
        NONE,
        "The commanded tool pose (no conveyor or path offset is added to it here).",
        tcp_pose,
    ),
    Builtin::new(
        "get_target_tcp_speed_along_path",
        D,
        NONE,
        "The commanded tool speed.",
        tcp_speed,
    ),
    Builtin::new(
        "get_target_payload",
        D,
        NONE,
        "The payload mass last set (kg; 0.0 at start).",
        payload,
    ),
    Builtin::new(
        "get_target_payload_cog",
        D,
        NONE,
        "The payload CoG last set ([x, y, z] m from the flange).",
        payload,
    ),
    Builtin::new(
        "get_target_payload_inertia",
        D,
        NONE,
        "The payload inertia last set ([Ixx, Iyy, Izz, Ixy, Ixz, Iyz] kg*m^2).",
        payload,
    ),
    Builtin::new(
        "get_joint_torques",
        D,
        NONE,
        "The joints' torques beyond moving the arm itself: fixed, [0, 0, 0, 0, 0, 0] Nm.",
        joint_torques,
    ),
    Builtin::new(
        "get_joint_temp",
        D,
        &[req("j")],
        "The temperature of joint j (0-5): fixed, 35.0 degrees C.",
        joint_temp,
    ),
    Builtin::new(
        "get_controller_temp",
        D,
        NONE,
        "The control box temperature: fixed, 30.0 degrees C.",
        scalar,
    ),
    Builtin::new(
        "get_tool_temp",
        D,
        NONE,
        "The tool temperature: fixed, 32.0 degrees C.",
        scalar,
    ),
    Builtin::new(
        "get_tool_current",
        D,
        NONE,
        "The tool current: fixed, 0.0 A (nothing draws from the tool connector).",
        scalar,
    ),
    Builtin::new(
        "get_tool_accelerometer_reading",
        D,
        NONE,
        "The gravity vector (set_gravity) in the flange's axes, m/s^2: [0, 0, 9.82] with the flange up.",
        accelerometer,
    ),
    Builtin::new(
        "get_gravity",
        D,
        NONE,
        "The gravity vector last set by set_gravity ([0, 0, 9.82] at start).",
        get3,
    ),
    Builtin::new(
        "get_base_acceleration",
        D,
        NONE,
        "The base acceleration last set by set_base_acceleration ([0, 0, 0] at start).",
        get3,
    ),
    Builtin::new(
        "get_freedrive_status",
        D,
        NONE,
        "0: normal operation (no singularity is modelled).",
        zero_int,
    ),
    Builtin::new(
        "get_inverse_kin_has_solution",
        D,
        &[
            req("pose"),
            opt("qnear", Default::Absent),
            opt("maxPositionError", Default::Float(1e-10)),
            opt("maxOrientationError", Default::Float(1e-10)),
            opt("tcp", Default::Absent),
        ],
        "True if get_inverse_kin has a solution: the arm reaches the pose exactly, or within maxPositionError and maxOrientationError.",
        has_solution,
    ),
    Builtin::new(
        "set_pos",
        D,
        &[req("q")],
        "Sets the joints of the simulated robot at once (the arm at rest).",
        set_pos,
    ),
    Builtin::new(
        "path_offset_enable",
        D,
        NONE,
        "Enables path offsetting.",
        path_offset,
    ),
    Builtin::new(
        "path_offset_disable",
        D,
        &[opt("a", Default::Float(20.0))],
        "Disables path offsetting: the applied offset is zero again.",
        path_offset,
    ),
    Builtin::new(
        "path_offset_set",
        D,
        &[req("offset"), req("type")],
        "Sets the offset (type 1-4), clamped to the maximum offset; applied while enabled.",
        path_offset,
    ),
    Builtin::new(
        "path_offset_get",
        D,
        &[req("type")],
        "The offset applied now (as set; zero while disabled).",
        path_offset,
    ),
    Builtin::new(
        "path_offset_set_alpha_filter",
        D,
        &[req("alpha")],
        "Sets the offset filter coefficient (0-1; the offset is applied unfiltered here).",
        path_offset,
    ),
    Builtin::new(
        "path_offset_set_max_offset",
        D,
        &[req("transLimit"), req("rotLimit")],
        "Sets the largest offset per axis (m, rad; 0.1 and 0.52 at start).",
        path_offset,
    ),
    Builtin::new(
        "get_tcp_offset",
        D,
        NONE,
        "The active TCP offset.",
        tcp_offset,
    ),
    Builtin::new(
        "tool_contact",
        D,
        &[opt("direction", Default::Absent)],
        "Steps since the TCP touched the contact plane (against `direction`, base frame; any if absent or zero); 0: no contact.",
        tool_contact,
    ),
    Builtin::new(
        "is_steady",
        D,
        NONE,
        "True when no motion is under way, the joints are at rest and the arm is not in teach/freedrive mode.",
        is_steady,
    ),
    Builtin::new(
        "is_within_safety_limits",
        D,
        &[req("pose"), opt("qnear", Default::Absent)],
        "A pose: True if the inverse kinematics reach it with every joint within ±2π (TCP offset, from qnear or the joints now); joints: True if each is within ±2π.",
        within_safety_limits,
    ),
    // Settings accepted with their manual signatures; they change nothing here.
    Builtin::new(
        "set_payload",
        D,
        &[req("m"), opt("cog", Default::Absent)],
        "Sets the payload mass and CoG (the TCP's position if cog is left out); zero inertia.",
        set_payload,
    ),
    Builtin::new(
        "set_payload_mass",
        D,
        &[req("m")],
        "Sets the payload mass; zero inertia.",
        set_payload,
    ),
    Builtin::new(
        "set_payload_cog",
        D,
        &[req("CoG")],
        "Sets the payload CoG; zero inertia.",
        set_payload,
    ),
    Builtin::new(
        "set_target_payload",
        D,
        &[
            req("m"),
            req("cog"),
            opt("inertia", Default::Floats(&[0.0; 6])),
            opt("transition_time", Default::Float(0.0)),
        ],
        "Sets the payload mass, CoG and inertia (|I| <= 133, Ixx, Iyy, Izz >= 0).",
        set_payload,
    ),
    Builtin::new(
        "set_tcp",
        D,
        &[req("pose"), opt("tcp_name", Default::Str(""))],
        "Sets the active TCP offset (get_tcp_offset).",
        set_tcp,
    ),
    Builtin::new(
        "set_gravity",
        D,
        &[req("d")],
        "Sets the gravity vector (get_gravity, the accelerometer).",
        set3,
    ),
    Builtin::new(
        "set_base_acceleration",
        D,
        &[req("a")],
        "Sets the base acceleration (get_base_acceleration).",
        set3,
    ),
    Builtin::new(
        "zero_ftsensor",
        D,
        NONE,
        "Accepted (no force sensor).",
        accept,
    ),
    Builtin::new(
        "force_mode",
        D,
        &[
            req("task_frame"),
            req("selection_vector"),
            req("wrench"),
            req("type"),
            req("limits"),
        ],
        "Starts force mode: compliant axes move to reach the wrench at their speed limits, stopped by the contact plane (see crate::arm::force).",
        force_mode,
    ),
    Builtin::new(
        "end_force_mode",
        D,
        NONE,
        "Ends force mode: the arm stays where it is.",
        force_mode,
    ),
    Builtin::new(
        "force_mode_set_damping",
        D,
        &[req("damping")],
        "Stores the force mode damping (0-1), as force_mode_get_damping reads it.",
        motion_setting,
    ),
    Builtin::new(
        "force_mode_set_gain_scaling",
        D,
        &[req("scaling")],
        "Stores the force mode gain scaling (0-2), as force_mode_get_gain_scaling reads it.",
        motion_setting,
    ),
    Builtin::new(
        "force_mode_get_damping",
        D,
        NONE,
        "The force mode damping last set (default 0).",
        motion_setting_get,
    ),
    Builtin::new(
        "force_mode_get_gain_scaling",
        D,
        NONE,
        "The force mode gain scaling last set (default 1).",
        motion_setting_get,
    ),
    Builtin::new(
        "motion_version_set",
        D,
        &[req("version")],
        "Stores the motion version (1 or 2) for movej/movel (the virtual arm's profiles are the same for both).",
        motion_setting,
    ),
    Builtin::new(
        "motion_version_get",
        D,
        NONE,
        "The motion version last set (default 1).",
        motion_setting_get,
    ),
    Builtin::new(
        "jerk_gain_scaling_set",
        D,
        &[req("gain")],
        "Stores the jerk gain scaling (0.01-1) (the virtual arm's profiles have no jerk limit).",
        motion_setting,
    ),
    Builtin::new(
        "jerk_gain_scaling_get",
        D,
        NONE,
        "The jerk gain scaling last set (default 1).",
        motion_setting_get,
    ),
    Builtin::new(
        "freedrive_mode",
        D,
        &[
            opt("freeAxes", Default::Ints(&[1, 1, 1, 1, 1, 1])),
            opt("feature", Default::Pose([0.0; 6])),
        ],
        "Freedrive: the arm stops; the operator moves the joints (Arm::move_by_hand); is_steady() False until end_freedrive_mode() or the program's end.",
        hand_mode,
    ),
    Builtin::new(
        "end_freedrive_mode",
        D,
        NONE,
        "Ends freedrive: the arm holds where the operator left it.",
        hand_mode,
    ),
    Builtin::new(
        "teach_mode",
        D,
        NONE,
        "Teach mode: the arm stops; the operator moves the joints (Arm::move_by_hand); is_steady() False until end_teach_mode() or the program's end.",
        hand_mode,
    ),
    Builtin::new(
        "end_teach_mode",
        D,
        NONE,
        "Ends teach mode: the arm holds where the operator left it.",
        hand_mode,
    ),
    Builtin::new(
        "set_safety_mode_transition_hardness",
        D,
        &[req("type")],
        "Accepted.",
        accept,
    ),
    Builtin::new(
        "enable_external_ft_sensor",
        D,
        &SENSOR,
        "Accepted (no force sensor).",
        accept,
    ),
    Builtin::new(
        "ft_rtde_input_enable",
        D,
        &SENSOR,
        "Accepted (no force sensor).",
        accept,
    ),
    Builtin::new(
        "set_friction_compensation",
        D,
        &[req("enabled")],
        "Accepted.",
        accept,
    ),
    Builtin::new("end_screw_driving", D, NONE, "Accepted.", accept),
    Builtin::new(
        "screw_driving",
        D,
        &[req("f"), req("v_limit")],
        "Accepted (no forces are modelled).",
        accept,
    ),
    Builtin::new(
        "freedrive_mode_no_incorrect_payload_check",
        D,
        NONE,
        "Accepted (nobody pushes the virtual arm).",
        accept,
    ),
    Builtin::new(
        "high_holding_torque_disable",
        D,
        NONE,
        "Accepted.",
        accept,
    ),
    Builtin::new("high_holding_torque_enable", D, NONE, "Accepted.", accept),
    Builtin::new(
        "pause_on_error_code",
        D,
        &[req("code"), opt("argument", Default::Absent)],
        "Accepted (the virtual arm raises no error codes).",
        accept,
    ),
    Builtin::new(
        "position_deviation_warning",
        D,
        &[req("enabled"), opt("threshold", Default::Float(0.8))],
        "Accepted (the virtual arm follows its target exactly).",
        accept,
    ),
    Builtin::new(
        "reset_revolution_counter",
        D,
        &[opt("qNear", Default::Floats(&[0.0; 6]))],
        "Accepted.",
        accept,
    ),
    Builtin::new(
        "tool_wrench_limit_set",
        D,
        &[
            req("frame_offset"),
            opt("Fx", Default::Absent),
            opt("Fy", Default::Absent),
            opt("Fz", Default::Absent),
            opt("Mx", Default::Absent),
            opt("My", Default::Absent),
            opt("Mz", Default::Absent),
        ],
        "Accepted (no dynamics).",
        accept,
    ),
    Builtin::new("tool_wrench_limit_disable", D, NONE, "Accepted.", accept),
    Builtin::new(
        "set_baselight_off",
        D,
        NONE,
        "Accepted (UR20/UR30 base light).",
        accept,
    ),
    Builtin::new(
        "set_baselight_iec",
        D,
        NONE,
        "Accepted (UR20/UR30 base light).",
        accept,
    ),
    Builtin::new(
        "set_baselight_solid",
        D,
        &[req("r"), req("g"), req("b")],
        "Accepted (UR20/UR30 base light).",
        accept,
    ),
];

/// The largest joint distance from `from` to `to`.
fn joint_distance(from: [f64; 6], to: [f64; 6]) -> f64 {
    (0..6).map(|k| (to[k] - from[k]).abs()).fold(0.0, f64::max)
}

pub use crate::runtime::JOINT_LIMIT;

/// Refuses joint targets outside the arm's range (a little rounding over ±2π passes).
fn check_joints(name: &str, q: [f64; 6]) -> Result<[f64; 6], Fault> {
    for (k, x) in q.iter().enumerate() {
        if !x.is_finite() || x.abs() > JOINT_LIMIT + 1e-9 {
            return Err(Fault::from(format!(
                "`{name}`: joint {k} target {} rad is outside the joint limits (-6.2832 to 6.2832 rad, ±360°)",
                Value::Float(*x).to_str()
            )));
        }
    }
    Ok(q)
}

/// What a motion command moves: the joints, or the tool (in the base frame).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Space {
    Joint,
    Tool,
}

/// A motion's target as the program gives it: joint positions (a list of 6 numbers) or
/// a pose.
#[derive(Debug, Clone, Copy)]
enum Target {
    Joints([f64; 6]),
    Pose([f64; 6]),
}

impl Target {
    /// True if the target is joint positions.
    fn is_joints(self) -> bool {
        matches!(self, Target::Joints(_))
    }
}

/// A list of 6 numbers (joints) or a pose; the type error names the parameter otherwise.
impl FromArg<'_> for Target {
    fn from_arg(a: &Args, v: &Value, i: usize) -> Result<Self, Fault> {
        let six = <[f64; 6]>::from_arg(a, v, i)?;
        Ok(match v {
            Value::Pose(_) => Target::Pose(six),
            _ => Target::Joints(six),
        })
    }
}

/// An argument converted to `T`, with the value as the program wrote it (for an error
/// that quotes it).
struct Given<'v, T>(T, &'v Value);

impl<'v, T: FromArg<'v>> FromArg<'v> for Given<'v, T> {
    fn from_arg(a: &Args, v: &'v Value, i: usize) -> Result<Self, Fault> {
        Ok(Given(T::from_arg(a, v, i)?, v))
    }
}

/// A motion's target: joints (checked against the joint range), or a pose reached
/// through inverse kinematics nearest the joints the move starts from. Returns the joints
/// and the tool pose there (the pose given, for a pose).
fn target(c: &Runtime, name: &str, to: Target) -> Result<([f64; 6], [f64; 6]), Fault> {
    match to {
        Target::Pose(pose) => Ok((c.inverse(pose, c.move_start().0, c.arm.tcp)?, pose)),
        Target::Joints(q) => {
            let q = check_joints(name, q)?;
            Ok((q, c.tool_pose(q)))
        }
    }
}

/// [`target`] of a straight or circular tool move: a pose out of reach is no error
/// here. The tool sets off along its path and, where the path leaves the arm's reach,
/// stops with a protective stop (as a real arm stops when the line runs it into a
/// singularity); the joints returned are then the move's start, which do not reach
/// the pose.
fn tool_target(c: &Runtime, name: &str, to: Target) -> Result<([f64; 6], [f64; 6]), Fault> {
    match (target(c, name, to), to) {
        (Err(_), Target::Pose(pose)) => Ok((c.move_start().0, pose)),
        (other, _) => other,
    }
}

/// The blend radius `r` (m) of a call to `a`: not negative.
fn radius(a: &Args, r: f64) -> Result<f64, Fault> {
    if r.is_finite() && r >= 0.0 {
        Ok(r)
    } else {
        let what = if r < 0.0 {
            "is negative"
        } else {
            "is not a finite number"
        };
        Err(Fault::from(format!(
            "`{}`: blend radius r={} m {what} (0: no blend)",
            a.name,
            Value::Float(r).to_str()
        )))
    }
}

/// A move of the tool from where it starts ([`Runtime::move_start`]) along a line (or
/// the arc through `via`) to `pose` (joints `q1` there), along a trapezoidal profile,
/// blend radius `r`; returns the time until the program gets control back.
fn tool_move(
    c: &mut Runtime,
    via: Option<[f64; 6]>,
    pose: [f64; 6],
    (q1, given): ([f64; 6], bool),
    (accel, speed, t, r): (f64, f64, f64, f64),
    (name, line, fixed): (&'static str, u32, bool),
) -> f64 {
    let (q0, p0) = c.move_start();
    let path = Path::new(p0, via, pose);
    let (r0, mut turn) = trajectory::turn_between(p0, pose);
    let (mut pose, mut q1, mut given) = (pose, q1, given);
    if fixed {
        // movec mode 1: the orientation follows the arc's tangent; only pose_to's position
        // counts, and the target joints are those of the pose the arc ends in.
        let (t, end) = trajectory::fixed_turn(&path, p0, pose);
        turn = t;
        pose = end;
        q1 = c.inverse(end, q1, c.arm.tcp).unwrap_or(q0);
        given = false;
    }
    let length = path.length();
    // A move that only turns the tool is timed on its angle.
    let dist = if length > 1e-9 {
        length
    } else {
        (turn[0] * turn[0] + turn[1] * turn[1] + turn[2] * turn[2]).sqrt()
    };
    let profile = Profile::new(dist, speed, accel, t);
    let tcp = c.arm.tcp;
    let info = move_start(name, line, Some(q1), Some(pose), (accel, speed, t, r));
    c.start_move(
        Kind::Tool {
            path,
            r0,
            turn,
            profile,
            dist,
            to: pose,
            q0,
            q1,
            given,
        },
        tcp,
        r,
        info,
    )
}

/// The [`MoveStart`] of a command (its time is set when the arm sets off).
fn move_start(
    function: &'static str,
    line: u32,
    target_q: Option<[f64; 6]>,
    target_pose: Option<[f64; 6]>,
    (a, v, t, r): (f64, f64, f64, f64),
) -> MoveStart {
    MoveStart {
        line,
        function,
        at: std::time::Duration::ZERO,
        target_q,
        target_pose,
        speed: None,
        a,
        v,
        t,
        r,
    }
}

/// `movej`, `movel`, `movep`, `servoc`, `optimovej`, `optimovel`: the arm moves along a
/// trapezoidal profile (accelerate at `a` to `v`, cruise, decelerate), stretched to `t`
/// if given (0 for those without `t`), and is at the target when the move ends; with a
/// blend radius `r > 0` the program gets control back where the blend begins (see
/// [`Runtime::start_move`]). `space`: the joints move (`movej`, `optimovej`) or the tool
/// in a line (the others).
fn go(
    c: &mut Runtime,
    a: &mut Args,
    space: Space,
    to: Target,
    (accel, speed, t, r): (f64, f64, f64, f64),
) -> Result<Out, Fault> {
    let r = radius(a, r)?;
    let back = match space {
        Space::Joint => {
            let (q1, pose) = target(c, a.name, to)?;
            let q0 = c.move_start().0;
            let profile = Profile::new(joint_distance(q0, q1), speed, accel, t);
            let tcp = c.arm.tcp;
            let info = move_start(a.name, a.line, Some(q1), Some(pose), (accel, speed, t, r));
            c.start_move(Kind::Joint { q0, q1, profile }, tcp, r, info)
        }
        Space::Tool => {
            let (q1, pose) = tool_target(c, a.name, to)?;
            tool_move(
                c,
                None,
                pose,
                (q1, to.is_joints()),
                (accel, speed, t, r),
                (a.name, a.line, false),
            )
        }
    };
    Ok(Out::Motion(back, Value::None))
}

/// `movec`: along the arc from the tool's position through `pose_via`'s to `pose_to`'s
/// (a line if the three are on one). `mode=0` (unconstrained): the orientation turns
/// from the start's to `pose_to`'s; `mode=1` (fixed): it keeps its relation to the
/// arc's tangent from the start's, turning about the circle's axis by the angle swept
/// (`pose_to`'s orientation is not used); another mode is a runtime error.
fn movec(
    c: &mut Runtime,
    a: &mut Args,
    via: Target,
    to: Target,
    (accel, speed, r): (f64, f64, f64),
    Given(mode, mode_given): Given<'_, f64>,
) -> Result<Out, Fault> {
    let via = match via {
        Target::Pose(pose) => pose,
        Target::Joints(q) => c.tool_pose(check_joints(a.name, q)?),
    };
    let r = radius(a, r)?;
    let (q1, pose) = tool_target(c, a.name, to)?;
    let fixed = if mode == 0.0 {
        false
    } else if mode == 1.0 {
        true
    } else {
        return Err(Fault::from(format!(
            "`movec`: mode={} is neither 0 (unconstrained) nor 1 (fixed)",
            mode_given.to_str()
        )));
    };
    let back = tool_move(
        c,
        Some(via),
        pose,
        (q1, to.is_joints()),
        (accel, speed, 0.0, r),
        (a.name, a.line, fixed),
    );
    Ok(Out::Motion(back, Value::None))
}

/// `powerdown()`: the arm stops, the program halts at the call and the request is left
/// for the controller that runs it (`Arm::powerdown`: it powers the arm off; a real
/// controller also shuts itself down, which a virtual one serving its clients does not).
fn powerdown(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    c.stop_at_once();
    c.arm.powerdown = true;
    Ok(Out::Value(Value::None))
}

/// `protective_stop()`: the arm stops at once and the request is left for the
/// controller that runs the arm (`Arm::protective_stop`).
fn protective_stop(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    c.protective_stop();
    // One step: the statements after it do not run in the step the stop happened, so a
    // controller acting on `Arm::protective_stop` after the step pauses the program
    // before them, as the real one stops it at once.
    Ok(Out::Wait(c.step_time, Value::None))
}

/// `servoj`: straight to `q` in joint space at constant speed over `t` (`a`, `v`,
/// `lookahead_time` and `gain` shape a real servo's tracking; not modelled).
fn servoj(
    c: &mut Runtime,
    a: &mut Args,
    q: [f64; 6],
    (acc, speed, t): (f64, f64, f64),
) -> Result<Out, Fault> {
    let q1 = check_joints(a.name, q)?;
    let q0 = c.arm.q;
    let profile = Profile::new(joint_distance(q0, q1), 0.0, 0.0, t);
    let tcp = c.arm.tcp;
    let pose = c.tool_pose(q1);
    let info = move_start(a.name, a.line, Some(q1), Some(pose), (acc, speed, t, 0.0));
    c.start_motion(Kind::Joint { q0, q1, profile }, tcp, Some(info));
    Ok(Out::Wait(secs(t), Value::None))
}

/// `speedj(qd, a, t)`, `speedl(xd, a, t, aRot)`: the speed ramps linearly from the
/// current one to the target at `a` (the component that changes most; `aRot` for the
/// tool's rotation, `a` if left out), then holds until the next motion command; returns
/// after `t` (one step if left out).
fn speed(
    c: &mut Runtime,
    a: &mut Args,
    space: Space,
    target: [f64; 6],
    acc: f64,
    t: Option<f64>,
    a_rot: Option<f64>,
) -> Result<Out, Fault> {
    let t = t.unwrap_or(c.step_time.as_secs_f64());
    let tcp = c.arm.tcp;
    let mut info = move_start(a.name, a.line, None, None, (acc, 0.0, t, 0.0));
    info.speed = Some(target);
    match space {
        Space::Joint => {
            let qd0 = c.arm.qd;
            let ramp = trajectory::ramp_time(&qd0, &target, acc);
            let q0 = c.arm.q;
            c.start_motion(
                Kind::JointSpeed {
                    q0,
                    qd0,
                    qd1: target,
                    ramp,
                },
                tcp,
                Some(info),
            );
        }
        Space::Tool => tool_speed(c, target, acc, a_rot.unwrap_or(acc), Some(info)),
    }
    Ok(Out::Wait(secs(t), Value::None))
}

/// Ramps the tool speed to `v1` from the current one.
fn tool_speed(c: &mut Runtime, v1: [f64; 6], acc: f64, a_rot: f64, info: Option<MoveStart>) {
    let v0 = c.arm.tcp_speed;
    let ramp = trajectory::ramp_time(&v0[..3], &v1[..3], acc).max(trajectory::ramp_time(
        &v0[3..],
        &v1[3..],
        a_rot,
    ));
    let p0 = c.tcp_pose();
    let tcp = c.arm.tcp;
    c.start_motion(Kind::ToolSpeed { p0, v0, v1, ramp }, tcp, info);
}

/// `stopj(a)`: the joint speeds ramp down to zero at `a` (the fastest joint; the others
/// in proportion); `stopl(a, aRot)`: the tool speed, at `a` (`aRot` for its rotation,
/// `a` if left out). Returns when the arm is at rest (at least one step).
fn stop(c: &mut Runtime, space: Space, acc: f64, a_rot: Option<f64>) -> Result<Out, Fault> {
    let ramp = match space {
        Space::Joint => {
            let qd0 = c.arm.qd;
            let ramp = trajectory::ramp_time(&qd0, &[0.0; 6], acc);
            let (q0, tcp) = (c.arm.q, c.arm.tcp);
            c.start_motion(
                Kind::JointSpeed {
                    q0,
                    qd0,
                    qd1: [0.0; 6],
                    ramp,
                },
                tcp,
                None,
            );
            ramp
        }
        Space::Tool => {
            let a_rot = a_rot.unwrap_or(acc);
            let v0 = c.arm.tcp_speed;
            tool_speed(c, [0.0; 6], acc, a_rot, None);
            trajectory::ramp_time(&v0[..3], &[0.0; 3], acc).max(trajectory::ramp_time(
                &v0[3..],
                &[0.0; 3],
                a_rot,
            ))
        }
    };
    // At rest when the ramp ends on the motion clock (at least a step).
    let n = secs(ramp)
        .as_nanos()
        .div_ceil(c.step_time.as_nanos().max(1));
    let until = c.clock_now() + u64::try_from(n).unwrap_or(u64::MAX) as f64;
    Ok(Out::Motion(until, Value::None))
}

fn direct_torque(c: &mut Runtime) -> Result<Out, Fault> {
    Ok(Out::Wait(c.step_time, Value::None))
}

fn joints(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.q)))
}

fn joints_history(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let back = a.int(0)?;
    let q = c
        .joint_history
        .at(c.step, i64::from(back), c.arm.q)
        .map_err(|e| Fault::from(format!("`get_actual_joint_positions_history`: {e}")))?;
    Ok(Out::Value(floats(q)))
}

fn joint_speeds(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.qd)))
}

fn tcp_pose(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.tcp_pose())))
}

fn waypoint(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    let pose = c
        .motion
        .as_ref()
        .and_then(|m| m.waypoint(&c.dh))
        .unwrap_or_else(|| c.tcp_pose());
    Ok(Out::Value(Value::Pose(pose)))
}

fn tcp_speed(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.tcp_speed)))
}

fn tcp_force(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.measured_tcp_force())))
}

fn force(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    let f = &c.measured_tcp_force();
    Ok(Out::Value(Value::Float(
        (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt(),
    )))
}

fn flange_pose(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.flange_pose())))
}

fn payload(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(match a.name {
        "get_target_payload" => Value::Float(c.arm.payload_mass),
        "get_target_payload_cog" => float_list(&c.arm.payload_cog),
        _ => float_list(&c.arm.payload_inertia),
    }))
}

fn set_payload(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let arm = &mut c.arm;
    match a.name {
        "set_payload_mass" => arm.payload_mass = a.num(0)?,
        "set_payload_cog" => arm.payload_cog = a.nums(0)?,
        "set_payload" => {
            arm.payload_mass = a.num(0)?;
            // Without a CoG the controller takes the TCP's position.
            arm.payload_cog = if a.is_absent(1) {
                [arm.tcp[0], arm.tcp[1], arm.tcp[2]]
            } else {
                a.nums(1)?
            };
        }
        _ => {
            let (m, cog, inertia): (f64, [f64; 3], [f64; 6]) = (a.num(0)?, a.nums(1)?, a.nums(2)?);
            a.num(3)?;
            if inertia.iter().any(|x| x.abs() > 133.0) || inertia[..3].iter().any(|x| *x < 0.0) {
                return Err(Fault::from(format!(
                    "`set_target_payload`: inertia {inertia:?} out of range (each at most 133 kg*m^2, Ixx, Iyy, Izz not negative)"
                )));
            }
            arm.payload_mass = m;
            arm.payload_cog = cog;
            arm.payload_inertia = inertia;
            return Ok(Out::Value(Value::None));
        }
    }
    // The deprecated setters reset the inertia.
    arm.payload_inertia = [0.0; 6];
    Ok(Out::Value(Value::None))
}

/// Settings stored on the arm and read back by their getters: each refuses a value
/// outside the range the manual gives, naming it.
fn motion_setting(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let arm = &mut c.arm;
    let (slot, lo, hi) = match a.name {
        "force_mode_set_damping" => (&mut arm.force_mode_damping, 0.0, 1.0),
        "force_mode_set_gain_scaling" => (&mut arm.force_mode_gain_scaling, 0.0, 2.0),
        "jerk_gain_scaling_set" => (&mut arm.jerk_gain_scaling, 0.01, 1.0),
        _ => {
            let v = a.int(0)?;
            if v != 1 && v != 2 {
                return Err(Fault::from(format!(
                    "`motion_version_set`: motion version {v} is not 1 or 2"
                )));
            }
            arm.motion_version = v;
            return Ok(Out::Value(Value::None));
        }
    };
    let v = a.num(0)?;
    if !(lo..=hi).contains(&v) {
        return Err(Fault::from(format!(
            "`{}`: {} {v} is not in {lo}-{hi}",
            a.name, a.params[0].name
        )));
    }
    *slot = v;
    Ok(Out::Value(Value::None))
}

fn motion_setting_get(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let arm = &c.arm;
    Ok(Out::Value(match a.name {
        "force_mode_get_damping" => Value::Float(arm.force_mode_damping),
        "force_mode_get_gain_scaling" => Value::Float(arm.force_mode_gain_scaling),
        "jerk_gain_scaling_get" => Value::Float(arm.jerk_gain_scaling),
        _ => Value::Int(arm.motion_version),
    }))
}

fn joint_torques(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.world.joint_torques)))
}

fn joint_temp(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let j = a.index(0, 6, "joint")?;
    Ok(Out::Value(Value::Float(c.arm.world.joint_temp[j])))
}

fn scalar(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Float(match a.name {
        "get_controller_temp" => c.arm.world.controller_temp,
        "get_tool_temp" => c.arm.world.tool_temp,
        _ => c.arm.world.tool_current,
    })))
}

fn accelerometer(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    // What the flange's axes see of gravity: the inverse rotation applied to it.
    let f = c.flange_pose();
    Ok(Out::Value(float_list(&super::poses::rotate(
        [-f[3], -f[4], -f[5]],
        c.arm.gravity,
    ))))
}

fn get3(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(float_list(if a.name == "get_gravity" {
        &c.arm.gravity
    } else {
        &c.arm.base_acceleration
    })))
}

fn set3(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let v = a.nums(0)?;
    if a.name == "set_gravity" {
        c.arm.gravity = v;
    } else {
        c.arm.base_acceleration = v;
    }
    Ok(Out::Value(Value::None))
}

fn zero_int(_: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Int(0)))
}

fn has_solution(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let pose = a.six(0)?;
    let qnear = if a.is_absent(1) { c.arm.q } else { a.six(1)? };
    let tcp = if a.is_absent(4) { c.arm.tcp } else { a.six(4)? };
    let (max_position, max_orientation) = super::poses::tolerances(a)?;
    Ok(Out::Value(Value::Bool(
        super::poses::inverse_within(c, pose, qnear, tcp, max_position, max_orientation).is_ok(),
    )))
}

fn set_pos(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let q = check_joints(a.name, a.six(0)?)?;
    c.halt();
    c.arm.q = q;
    c.arm.qd = [0.0; 6];
    c.arm.tcp_speed = [0.0; 6];
    Ok(Out::Value(Value::None))
}

fn path_offset(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let po = &mut c.arm.path_offset;
    let kind = |a: &Args, i: usize| -> Result<i32, Fault> {
        let t = a.int(i)?;
        if (1..=4).contains(&t) {
            Ok(t)
        } else {
            Err(Fault::from(format!("`{}`: type {t} is not 1-4", a.name)))
        }
    };
    match a.name {
        "path_offset_enable" => po.enabled = true,
        "path_offset_disable" => {
            a.num(0)?;
            po.enabled = false;
            po.offset = [0.0; 6];
        }
        "path_offset_set" => {
            let mut o = a.six(0)?;
            po.kind = kind(a, 1)?;
            for (k, x) in o.iter_mut().enumerate() {
                let lim = if k < 3 { po.max_trans } else { po.max_rot };
                *x = x.clamp(-lim, lim);
            }
            po.offset = o;
        }
        "path_offset_get" => {
            kind(a, 0)?;
            let o = if po.enabled { po.offset } else { [0.0; 6] };
            return Ok(Out::Value(Value::Pose(o)));
        }
        "path_offset_set_alpha_filter" => {
            let alpha = a.num(0)?;
            if !(0.0..=1.0).contains(&alpha) {
                return Err(Fault::from(format!(
                    "`path_offset_set_alpha_filter`: alpha {alpha} is not in 0-1"
                )));
            }
            po.alpha = alpha;
        }
        _ => {
            po.max_trans = a.num(0)?.abs();
            po.max_rot = a.num(1)?.abs();
        }
    }
    Ok(Out::Value(Value::None))
}

fn tcp_offset(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.arm.tcp)))
}

fn set_tcp(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    c.arm.tcp = a.six(0)?;
    Ok(Out::Value(Value::None))
}

/// `tool_contact(direction)`: the number of steps back to just before the TCP touched
/// the contact plane (at least 1 while it touches), 0 without contact. With a direction
/// (base frame, its first three elements) only a contact against it counts: the plane's
/// normal opposes the direction.
fn tool_contact(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let direction = if a.is_absent(0) { [0.0; 6] } else { a.six(0)? };
    let f = c.measured_contact();
    let touching = f.iter().any(|x| *x != 0.0);
    let against = direction[..3].iter().all(|x| *x == 0.0)
        || f[0] * direction[0] + f[1] * direction[1] + f[2] * direction[2] < 0.0;
    if !(touching && against) {
        return Ok(Out::Value(Value::Int(0)));
    }
    let since = c.contact_since.unwrap_or(c.step);
    let steps = c.step.saturating_sub(since).saturating_add(1);
    Ok(Out::Value(Value::Int(
        i32::try_from(steps).unwrap_or(i32::MAX),
    )))
}

fn is_steady(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    let still = c.motion.is_none() && c.arm.qd.iter().all(|v| *v == 0.0) && !c.arm.hand_guided();
    Ok(Out::Value(Value::Bool(still)))
}

/// `is_within_safety_limits(pose, qnear)`: a pose is within the limits if the arm's
/// inverse kinematics reach it with every joint within its range (±2π; through the
/// active TCP offset, nearest `qnear` or the joints now); joint positions if each is
/// within its range. The installation's safety planes and TCP limits are not modelled.
fn within_safety_limits(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let six = a.six(0)?;
    let ok = if matches!(a.v[0], Value::Pose(_)) {
        let qnear = if a.is_absent(1) { c.arm.q } else { a.six(1)? };
        c.inverse(six, qnear, c.arm.tcp).is_ok()
    } else {
        check_joints(a.name, six).is_ok()
    };
    Ok(Out::Value(Value::Bool(ok)))
}

/// `teach_mode()`, `freedrive_mode(freeAxes, feature)` and their ends. The arm stops
/// (and leaves force mode) on entering; the operator then moves the joints
/// ([`crate::Arm::move_by_hand`]; `freeAxes` and `feature` are checked, and the
/// operator's joints taken as given).
fn hand_mode(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    match a.name {
        "teach_mode" | "freedrive_mode" => {
            if a.name == "freedrive_mode" {
                let axes = a.six(0)?;
                if axes.iter().any(|x| *x != 0.0 && *x != 1.0) {
                    return Err(Fault::from(format!(
                        "`freedrive_mode`: freeAxes {} must be 0 or 1 each",
                        a.v[0].to_str()
                    )));
                }
                a.six(1)?;
            }
            c.stop_at_once();
            c.arm.force_mode = None;
            c.arm.hand_mode = if a.name == "teach_mode" { 1 } else { 2 };
        }
        _ => {
            c.arm.hand_mode = 0;
            c.arm.qd = [0.0; 6];
            c.arm.tcp_speed = [0.0; 6];
        }
    }
    Ok(Out::Value(Value::None))
}

/// `force_mode(task_frame, selection_vector, wrench, type, limits)` and
/// `end_force_mode()` (see [`crate::arm::force`]).
fn force_mode(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    if a.name == "end_force_mode" {
        c.arm.force_mode = None;
        if c.motion.is_none() {
            c.arm.qd = [0.0; 6];
            c.arm.qdd = [0.0; 6];
            c.arm.tcp_speed = [0.0; 6];
        }
        return Ok(Out::Value(Value::None));
    }
    let frame = a.six(0)?;
    let sel = a.six(1)?;
    let wrench = a.six(2)?;
    let kind = a.int(3)?;
    let limits = a.six(4)?;
    if sel.iter().any(|x| *x != 0.0 && *x != 1.0) {
        return Err(Fault::from(format!(
            "`force_mode`: selection_vector {} must be 0 or 1 each",
            a.v[1].to_str()
        )));
    }
    let kind = match kind {
        1..=3 => kind as u8,
        _ => {
            return Err(Fault::from(format!(
                "`force_mode`: type {kind} is not 1, 2 or 3"
            )))
        }
    };
    if frame
        .iter()
        .chain(&wrench)
        .chain(&limits)
        .any(|x| !x.is_finite())
    {
        return Err(Fault::from(
            "`force_mode`: task_frame, wrench and limits must be finite numbers",
        ));
    }
    let programmed = c.tcp_pose();
    c.arm.hand_mode = 0;
    c.arm.force_mode = Some(crate::arm::force::ForceMode {
        frame,
        selection: sel.map(|x| x == 1.0),
        wrench,
        kind,
        limits,
        offset: [0.0; 6],
        programmed,
        at: c.step,
    });
    // The arm moves from this step's pose on.
    c.sampled = Some(c.step);
    Ok(Out::Value(Value::None))
}
