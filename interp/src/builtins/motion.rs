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
//!   `get_actual_tcp_pose()`, `get_target_tcp_pose()`: the commanded pose; speeds the
//!   commanded speeds; `get_tcp_force()`: zero (no forces are modelled);
//!   `tool_contact()`: 0; `is_steady()`: True.
//! - Settings the virtual arm has no use for (`set_payload`, `set_tcp`, `set_gravity`,
//!   `force_mode`, `zero_ftsensor`, ...) are accepted with their manual signatures and do
//!   nothing.

use super::{accept, floats, opt, req, secs, Args, Builtin, Default, Domain, Out};
use crate::controller::Controller;
use crate::error::Fault;
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
const OPTIMOVE: [super::Param; 4] = [
    req("q"),
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
        "Zero: no forces are modelled.",
        tcp_force,
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
        "Accepted (no dynamics).",
        accept,
    ),
    Builtin::new(
        "set_payload_mass",
        D,
        &[req("m")],
        "Accepted (no dynamics).",
        accept,
    ),
    Builtin::new(
        "set_payload_cog",
        D,
        &[req("CoG")],
        "Accepted (no dynamics).",
        accept,
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
        "Accepted (no dynamics).",
        accept,
    ),
    Builtin::new(
        "set_tcp",
        D,
        &[req("pose")],
        "Sets the active TCP offset (get_tcp_offset).",
        set_tcp,
    ),
    Builtin::new(
        "set_gravity",
        D,
        &[req("d")],
        "Accepted (no dynamics).",
        accept,
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
        "stop_conveyor_tracking",
        D,
        &[opt("a", Default::Float(20.0))],
        "Accepted (no conveyor).",
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

/// Sets the commanded joints (a list target) or pose (a pose target); the distance.
fn go_to(c: &mut Controller, target: &Value, six: [f64; 6]) -> f64 {
    c.arm.qd = [0.0; 6];
    if matches!(target, Value::Pose(_)) {
        let d = line_distance(c.arm.pose, six);
        c.arm.pose = six;
        d
    } else {
        let d = joint_distance(c.arm.q, six);
        c.arm.q = six;
        d
    }
}

fn movej(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let target = a.six(0)?;
    let speed = a.num(2)?;
    // movep and optimove* have no `t`.
    let t = if a.params.len() == 5 { a.num(3)? } else { 0.0 };
    let dist = go_to(c, &a.v[0], target);
    let dur = if t > 0.0 {
        t
    } else if speed > 0.0 {
        dist / speed
    } else {
        0.0
    };
    Ok(Out::Wait(secs(dur), Value::None))
}

fn movec(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let target = a.six(1)?;
    let speed = a.num(3)?;
    let dist = go_to(c, &a.v[1], target);
    let dur = if speed > 0.0 { dist / speed } else { 0.0 };
    Ok(Out::Wait(secs(dur), Value::None))
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
        c.arm.tcp_speed = qd;
        for (x, v) in c.arm.pose.iter_mut().zip(qd) {
            *x += v * t;
        }
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
    Ok(Out::Value(Value::Pose(c.arm.pose)))
}

fn tcp_speed(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.tcp_speed)))
}

fn tcp_force(_: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose([0.0; 6])))
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
