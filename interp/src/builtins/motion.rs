//! Motion, the arm's state, and the arm's settings, on the **virtual arm**: commanded
//! state and the time each command takes, not dynamics.
//!
//! - `movej(q, a=1.4, v=1.05, t=0, r=0)`: takes `t` if given, else the largest joint
//!   distance / `v`; `movel(pose, a=1.2, v=0.25, t=0, r=0)` and `movep`: `t`, else the
//!   straight-line distance / `v`; `movec(pose_via, pose_to, ...)`: like `movel` to
//!   `pose_to`; `optimovej`/`optimovel`: like `movej`/`movel` (their `a`, `v` are
//!   fractions on the robot; here they are taken as speeds). `direct_torque`: one step.
//!   Every motion takes at least one step. A motion sets the commanded joints (a target
//!   given as a list) or pose (a target given as a pose) when it starts; there is no
//!   kinematics yet, so a `movej` does not change the pose and a `movel` does not change
//!   the joints.
//! - `servoj(q, a, v, t=0.002, lookahead_time=0.1, gain=300)`: sets `q`, takes `t`.
//! - `speedj(qd, a, t)`, `speedl(xd, a, t, aRot)`: set the speed and integrate it over `t`
//!   (one step if `t` is not given); `stopj(a)`, `stopl(a)`: zero speed, one step.
//! - `get_actual_joint_positions()`, `get_target_joint_positions()`: the commanded `q`;
//!   `get_actual_tcp_pose()`, `get_target_tcp_pose()`, `get_target_waypoint()`: the
//!   commanded pose; speeds the commanded speeds; `tool_contact()`: 0; `is_steady()`: True.
//! - Settings read back by their getters: payload (`set_target_payload`, `set_payload*`
//!   -> `get_target_payload*`), TCP (`set_tcp` -> `get_tcp_offset`), gravity, base
//!   acceleration, path offset (`path_offset_*`), `set_pos` (the joints).
//! - What the robot measures of the world returns the documented fixed value of its
//!   field of the virtual arm (`crate::controller::Arm`): `get_tcp_force()` and `force()`
//!   0, `get_joint_torques()` 0, `get_joint_temp(j)` 35.0 °C, `get_controller_temp()`
//!   30.0 °C, `get_tool_temp()` 32.0 °C, `get_tool_current()` 0.0 A;
//!   `get_tool_accelerometer_reading()` is the gravity vector seen from the flange.
//! - Settings the virtual arm has no use for (`force_mode`, `zero_ftsensor`,
//!   `screw_driving`, ...) are accepted with their manual signatures and do nothing.

use super::{accept, float_list, floats, opt, req, secs, Args, Builtin, Default, Domain, Out};
use crate::controller::Controller;
use crate::error::Fault;
use crate::kinematics;
use crate::value::Value;

const D: Domain = Domain::Motion;
const ZERO3: &[f64] = &[0.0, 0.0, 0.0];
const NONE: &[super::Param] = &[];

const fn movej_like(da: f64, dv: f64) -> [super::Param; 5] {
    [
        req("q"),
        opt("a", Default::Float(da)),
        opt("v", Default::Float(dv)),
        opt("t", Default::Float(0.0)),
        opt("r", Default::Float(0.0)),
    ]
}
const MOVEJ: [super::Param; 5] = movej_like(1.4, 1.05);
const MOVEL: [super::Param; 5] = [
    req("pose"),
    opt("a", Default::Float(1.2)),
    opt("v", Default::Float(0.25)),
    opt("t", Default::Float(0.0)),
    opt("r", Default::Float(0.0)),
];
const MOVEP: [super::Param; 4] = [
    req("pose"),
    opt("a", Default::Float(1.2)),
    opt("v", Default::Float(0.25)),
    opt("r", Default::Float(0.0)),
];
/// `optimovej(goal, a=0.3, v=0.3, r=0)`, `optimovel(goal, ...)`: the manual names the
/// target `goal` (joints or a pose here).
const OPTIMOVE: [super::Param; 4] = [
    req("goal"),
    opt("a", Default::Float(0.3)),
    opt("v", Default::Float(0.3)),
    opt("r", Default::Float(0.0)),
];
const SENSOR: [super::Param; 4] = [
    req("enable"),
    opt("sensor_mass", Default::Float(0.0)),
    opt("sensor_measuring_offset", Default::Floats(ZERO3)),
    opt("sensor_cog", Default::Floats(ZERO3)),
];

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new(
        "movej",
        D,
        &MOVEJ,
        "Moves in joint space: takes t, else the largest joint distance / v.",
        movej,
    ),
    Builtin::new(
        "movel",
        D,
        &MOVEL,
        "Moves in a straight line: takes t, else the distance / v.",
        movej,
    ),
    Builtin::new("movep", D, &MOVEP, "Process move: timed as movel.", movej),
    Builtin::new(
        "servoc",
        D,
        &MOVEP,
        "Servo to a pose in a circular blend: timed as movel to the pose.",
        movej,
    ),
    Builtin::new(
        "protective_stop",
        D,
        NONE,
        "Triggers a protective stop: the arm stops, and the controller running it pauses the program (Arm::protective_stop).",
        protective_stop,
    ),
    Builtin::new(
        "optimovej",
        D,
        &OPTIMOVE,
        "As movej (a and v taken as speeds).",
        movej,
    ),
    Builtin::new(
        "optimovel",
        D,
        &OPTIMOVE,
        "As movel (a and v taken as speeds).",
        movej,
    ),
    Builtin::new(
        "movec",
        D,
        &[
            req("pose_via"),
            req("pose_to"),
            opt("a", Default::Float(1.2)),
            opt("v", Default::Float(0.25)),
            opt("r", Default::Float(0.0)),
            opt("mode", Default::Int(0)),
        ],
        "Circular move: timed as a straight line to pose_to.",
        movec,
    ),
    Builtin::new(
        "servoj",
        D,
        &[
            req("q"),
            opt("a", Default::Float(0.0)),
            opt("v", Default::Float(0.0)),
            opt("t", Default::Float(0.002)),
            opt("lookahead_time", Default::Float(0.1)),
            opt("gain", Default::Float(300.0)),
        ],
        "Sets the joints to q; takes t.",
        servoj,
    ),
    Builtin::new(
        "speedj",
        D,
        &[req("qd"), req("a"), opt("t", Default::Absent)],
        "Joint speed for t (one step if not given), integrated into the joints.",
        speed,
    ),
    Builtin::new(
        "speedl",
        D,
        &[
            req("xd"),
            req("a"),
            opt("t", Default::Absent),
            opt("aRot", Default::Absent),
        ],
        "Tool speed for t (one step if not given), integrated into the pose.",
        speed,
    ),
    Builtin::new("stopj", D, &[req("a")], "Zero joint speed; one step.", stop),
    Builtin::new(
        "stopl",
        D,
        &[req("a"), opt("aRot", Default::Absent)],
        "Zero tool speed; one step.",
        stop,
    ),
    Builtin::new(
        "direct_torque",
        D,
        &[
            req("torque"),
            opt("friction_comp", Default::Bool(true)),
            opt("viscous_scale", Default::Absent),
            opt("coulomb_scale", Default::Absent),
        ],
        "Torque control has no model here: takes one step.",
        direct_torque,
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
        "The commanded joints (no history is kept).",
        joints,
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
        "The force/torque at the flange: fixed, p[0, 0, 0, 0, 0, 0] (nothing pushes the virtual arm).",
        tcp_force,
    ),
    Builtin::new(
        "force",
        D,
        NONE,
        "The norm of get_tcp_force()'s force part: fixed, 0.0.",
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
        "The target of the last move: the commanded tool pose.",
        tcp_pose,
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
        "True if some joint position puts the tool at the pose (the arm's inverse kinematics).",
        has_solution,
    ),
    Builtin::new(
        "set_pos",
        D,
        &[req("q")],
        "Sets the joints of the simulated robot at once.",
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
        "0: no contact is modelled.",
        tool_contact,
    ),
    Builtin::new(
        "is_steady",
        D,
        NONE,
        "True: the virtual arm is always steady.",
        is_steady,
    ),
    Builtin::new(
        "is_within_safety_limits",
        D,
        &[req("pose"), opt("qnear", Default::Absent)],
        "True: no safety limits are modelled.",
        is_steady,
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
        "Accepted (no forces are modelled).",
        accept,
    ),
    Builtin::new("end_force_mode", D, NONE, "Accepted.", accept),
    Builtin::new(
        "force_mode_set_damping",
        D,
        &[req("damping")],
        "Accepted.",
        accept,
    ),
    Builtin::new(
        "force_mode_set_gain_scaling",
        D,
        &[req("scaling")],
        "Accepted.",
        accept,
    ),
    Builtin::new(
        "freedrive_mode",
        D,
        &[
            opt("freeAxes", Default::Ints(&[1, 1, 1, 1, 1, 1])),
            opt("feature", Default::Pose([0.0; 6])),
        ],
        "Accepted (nobody pushes the virtual arm).",
        accept,
    ),
    Builtin::new("end_freedrive_mode", D, NONE, "Accepted.", accept),
    Builtin::new("teach_mode", D, NONE, "Accepted.", accept),
    Builtin::new("end_teach_mode", D, NONE, "Accepted.", accept),
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

/// The straight-line distance between two poses' positions.
fn line_distance(from: [f64; 6], to: [f64; 6]) -> f64 {
    (0..3)
        .map(|k| (to[k] - from[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// How a move is timed: in joint space (the joint that moves furthest, at the joint
/// speed) or along a line (the tool's path, at the tool speed).
#[derive(Clone, Copy, PartialEq)]
enum Path {
    Joint,
    Line,
}

/// Moves the arm to `target` (joints, or a pose reached through inverse kinematics nearest
/// the current joints); the distance along `path`.
fn go_to(c: &mut Controller, target: &Value, six: [f64; 6], path: Path) -> Result<f64, Fault> {
    let from_q = c.arm.q;
    let from_pose = c.tcp_pose();
    let q = if matches!(target, Value::Pose(_)) {
        c.inverse(six, from_q, c.arm.tcp)?
    } else {
        six
    };
    c.arm.qd = [0.0; 6];
    c.arm.q = q;
    Ok(match path {
        Path::Joint => joint_distance(from_q, q),
        Path::Line => line_distance(from_pose, c.tcp_pose()),
    })
}

/// `movej`, `movel`, `movep`, `optimovej`, `optimovel`: the arm is at the target when the
/// move ends; the move takes `t` if given, else a trapezoidal profile (accelerate at `a`
/// to `v`, cruise, decelerate) over the distance.
fn movej(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let target = a.six(0)?;
    let (accel, speed) = (a.num(1)?, a.num(2)?);
    // movep and optimove* have no `t`.
    let t = if a.params.len() == 5 { a.num(3)? } else { 0.0 };
    let path = if matches!(a.name, "movej" | "optimovej") {
        Path::Joint
    } else {
        Path::Line
    };
    let dist = go_to(c, &a.v[0], target, path)?;
    let dur = if t > 0.0 {
        t
    } else {
        kinematics::move_time(dist, speed, accel)
    };
    Ok(Out::Wait(secs(dur), Value::None))
}

/// `movec`: timed as a straight line to `pose_to` (the arc through `pose_via` is not
/// modelled).
fn movec(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let target = a.six(1)?;
    let (accel, speed) = (a.num(2)?, a.num(3)?);
    let dist = go_to(c, &a.v[1], target, Path::Line)?;
    Ok(Out::Wait(
        secs(kinematics::move_time(dist, speed, accel)),
        Value::None,
    ))
}

/// `protective_stop()`: the arm stops at once and the request is left for the
/// controller that runs the arm (a program alone just goes on, stopped).
fn protective_stop(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    c.arm.qd = [0.0; 6];
    c.arm.tcp_speed = [0.0; 6];
    c.arm.protective_stop = true;
    Ok(Out::Value(Value::None))
}

fn servoj(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let q = a.six(0)?;
    let t = a.num(3)?;
    if t > 0.0 {
        for ((qd, new), old) in c.arm.qd.iter_mut().zip(q).zip(c.arm.q) {
            *qd = (new - old) / t;
        }
    }
    c.arm.q = q;
    Ok(Out::Wait(secs(t), Value::None))
}

fn speed(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let qd = a.six(0)?;
    a.num(1)?;
    let t = if a.is_absent(2) {
        c.step_time.as_secs_f64()
    } else {
        a.num(2)?
    };
    if a.name == "speedj" {
        c.arm.qd = qd;
        for (q, v) in c.arm.q.iter_mut().zip(qd) {
            *q += v * t;
        }
    } else {
        // The tool moves at `xd` for `t`; the joints follow it (inverse kinematics nearest
        // the current joints).
        c.arm.tcp_speed = qd;
        let mut pose = c.tcp_pose();
        for (x, v) in pose.iter_mut().zip(qd) {
            *x += v * t;
        }
        c.arm.q = c.inverse(pose, c.arm.q, c.arm.tcp)?;
    }
    Ok(Out::Wait(secs(t), Value::None))
}

fn stop(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    a.num(0)?;
    c.arm.qd = [0.0; 6];
    c.arm.tcp_speed = [0.0; 6];
    Ok(Out::Wait(c.step_time, Value::None))
}

fn direct_torque(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    a.six(0)?;
    Ok(Out::Wait(c.step_time, Value::None))
}

fn joints(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.q)))
}

fn joint_speeds(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.qd)))
}

fn tcp_pose(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.tcp_pose())))
}

fn tcp_speed(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.tcp_speed)))
}

fn tcp_force(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.arm.world.tcp_force)))
}

fn force(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    let f = &c.arm.world.tcp_force;
    Ok(Out::Value(Value::Float(
        (f[0] * f[0] + f[1] * f[1] + f[2] * f[2]).sqrt(),
    )))
}

fn flange_pose(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.flange_pose())))
}

fn payload(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(match a.name {
        "get_target_payload" => Value::Float(c.arm.payload_mass),
        "get_target_payload_cog" => float_list(&c.arm.payload_cog),
        _ => float_list(&c.arm.payload_inertia),
    }))
}

fn set_payload(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
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

fn joint_torques(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.world.joint_torques)))
}

fn joint_temp(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let j = a.index(0, 6, "joint")?;
    Ok(Out::Value(Value::Float(c.arm.world.joint_temp[j])))
}

fn scalar(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Float(match a.name {
        "get_controller_temp" => c.arm.world.controller_temp,
        "get_tool_temp" => c.arm.world.tool_temp,
        _ => c.arm.world.tool_current,
    })))
}

fn accelerometer(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    // What the flange's axes see of gravity: the inverse rotation applied to it.
    let f = c.flange_pose();
    Ok(Out::Value(float_list(&super::poses::rotate(
        [-f[3], -f[4], -f[5]],
        c.arm.gravity,
    ))))
}

fn get3(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(float_list(if a.name == "get_gravity" {
        &c.arm.gravity
    } else {
        &c.arm.base_acceleration
    })))
}

fn set3(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let v = a.nums(0)?;
    if a.name == "set_gravity" {
        c.arm.gravity = v;
    } else {
        c.arm.base_acceleration = v;
    }
    Ok(Out::Value(Value::None))
}

fn zero_int(_: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Int(0)))
}

fn has_solution(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let pose = a.six(0)?;
    let qnear = if a.is_absent(1) { c.arm.q } else { a.six(1)? };
    let tcp = if a.is_absent(4) { c.arm.tcp } else { a.six(4)? };
    Ok(Out::Value(Value::Bool(c.inverse(pose, qnear, tcp).is_ok())))
}

fn set_pos(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    c.arm.q = a.six(0)?;
    c.arm.qd = [0.0; 6];
    Ok(Out::Value(Value::None))
}

fn path_offset(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
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

fn tcp_offset(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.arm.tcp)))
}

fn set_tcp(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    c.arm.tcp = a.six(0)?;
    Ok(Out::Value(Value::None))
}

fn tool_contact(_: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Int(0)))
}

fn is_steady(_: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Bool(true)))
}
