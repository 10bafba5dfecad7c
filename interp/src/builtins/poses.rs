//! Poses and kinematics: pose arithmetic composes rigid transforms with rotation vectors
//! as the manual defines them; `rotvec2rpy`/`rpy2rotvec` convert to and from
//! roll-pitch-yaw; `wrench_trans` moves a wrench's point of view; `interpolate_pose` interpolates each element linearly
//! (exact for translation, approximate for rotation). `get_inverse_kin` and
//! `get_forward_kin` use the arm model's kinematics ([`crate::kinematics`]); a pose out
//! of exact reach gets the nearest the arm comes when that is within `maxPositionError`
//! and `maxOrientationError`, else the runtime error the controller raises (which
//! `get_inverse_kin_has_solution` is there to avoid).

use super::{builtin, float_list, floats, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Poses;

pub(super) const TABLE: &[Builtin] = &[
    builtin!(
        point_dist(p_from: [f64; 6], p_to: [f64; 6]) => dist,
        "The distance between the two poses' positions.",
    ),
    builtin!(
        pose_dist(p_from: [f64; 6], p_to: [f64; 6]) => dist,
        "The distance between the two poses' positions.",
    ),
    builtin!(
        rotvec2rpy(rotation_vector: [f64; 3]) => rotvec2rpy,
        "The roll-pitch-yaw angles [r, p, y] of a rotation vector (R = Rz(y)Ry(p)Rx(r)).",
    ),
    builtin!(
        rpy2rotvec(rpy_vector: [f64; 3]) => rpy2rotvec,
        "The rotation vector of roll-pitch-yaw angles [r, p, y] (R = Rz(y)Ry(p)Rx(r)).",
    ),
    builtin!(
        wrench_trans(T_from_to: [f64; 6], w_from: [f64; 6]) => wrench_trans,
        "The wrench [F, M] seen from the frame T_from_to: torque moved to its origin, both in its axes.",
    ),
    builtin!(
        pose_trans(p_from: [f64; 6], p_from_to: [f64; 6])
            => |c, x, p, q| compose(c, x, Compose::Trans, p, q),
        "p_from_to expressed in the base frame, seen from p_from (the composition).",
    ),
    builtin!(
        pose_add(p_1: [f64; 6], p_2: [f64; 6]) => |c, x, p, q| compose(c, x, Compose::Add, p, q),
        "Positions added, rotations composed.",
    ),
    builtin!(
        pose_sub(p_to: [f64; 6], p_from: [f64; 6]) => |c, x, p, q| compose(c, x, Compose::Sub, p, q),
        "Positions subtracted, rotations composed with the inverse.",
    ),
    builtin!(
        pose_inv(p_from: [f64; 6]) => |_, _, p| Ok(Out::Value(Value::Pose(crate::arm::pose::inv(p)))),
        "The inverse transform.",
    ),
    builtin!(
        interpolate_pose(p_from: [f64; 6], p_to: [f64; 6], alpha: f64) => interpolate_pose,
        "The pose a fraction alpha of the way (element-wise).",
    ),
    builtin!(
        get_inverse_kin(
            x: [f64; 6],
            qnear: Option<[f64; 6]> = Absent,
            maxPositionError: f64 = Float(1e-10),
            maxOrientationError: f64 = Float(1e-10),
            tcp: Option<[f64; 6]> = Absent,
        ) => get_inverse_kin,
        "The joints that put the tool at x, nearest qnear (default: the current joints), by the arm model's inverse kinematics; out of exact reach, the nearest the arm comes if within maxPositionError and maxOrientationError, else a runtime error (as on the controller).",
    ),
    builtin!(
        get_forward_kin(q: Option<[f64; 6]> = Absent, tcp: Option<[f64; 6]> = Absent) => get_forward_kin,
        "The tool pose of q (default: the current joints) through tcp (default: the active TCP), by the arm model's forward kinematics.",
    ),
];

fn dist(_: &mut Runtime, _: &mut Args, p: [f64; 6], q: [f64; 6]) -> Result<Out, Fault> {
    let d = (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt();
    Ok(Out::Value(Value::Float(d)))
}

/// `v` rotated by the rotation vector `r`.
pub(super) fn rotate(r: [f64; 3], v: [f64; 3]) -> [f64; 3] {
    let p = crate::arm::pose::trans(
        [0.0, 0.0, 0.0, r[0], r[1], r[2]],
        [v[0], v[1], v[2], 0.0, 0.0, 0.0],
    );
    [p[0], p[1], p[2]]
}

fn rotvec2rpy(_: &mut Runtime, _: &mut Args, r: [f64; 3]) -> Result<Out, Fault> {
    // The rotation matrix's columns: the rotated axes.
    let [c0, c1, c2] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].map(|e| rotate(r, e));
    let pitch = (-c0[2]).atan2(c0[0].hypot(c0[1]));
    let yaw = c0[1].atan2(c0[0]);
    let roll = c1[2].atan2(c2[2]);
    Ok(Out::Value(float_list(&[roll, pitch, yaw])))
}

fn rpy2rotvec(_: &mut Runtime, _: &mut Args, rpy: [f64; 3]) -> Result<Out, Fault> {
    let [roll, pitch, yaw] = rpy;
    let rot = |x: f64, y: f64, z: f64| [0.0, 0.0, 0.0, x, y, z];
    let p = crate::arm::pose::trans(
        crate::arm::pose::trans(rot(0.0, 0.0, yaw), rot(0.0, pitch, 0.0)),
        rot(roll, 0.0, 0.0),
    );
    Ok(Out::Value(float_list(&p[3..])))
}

fn wrench_trans(_: &mut Runtime, _: &mut Args, t: [f64; 6], w: [f64; 6]) -> Result<Out, Fault> {
    let (p, f, m) = ([t[0], t[1], t[2]], [w[0], w[1], w[2]], [w[3], w[4], w[5]]);
    // The torque about the new origin: M - p x F; then both in the new frame's axes.
    let pxf = [
        p[1] * f[2] - p[2] * f[1],
        p[2] * f[0] - p[0] * f[2],
        p[0] * f[1] - p[1] * f[0],
    ];
    let back = [-t[3], -t[4], -t[5]];
    let f_to = rotate(back, f);
    let m_to = rotate(back, [m[0] - pxf[0], m[1] - pxf[1], m[2] - pxf[2]]);
    Ok(Out::Value(float_list(&[
        f_to[0], f_to[1], f_to[2], m_to[0], m_to[1], m_to[2],
    ])))
}

/// How `pose_trans`, `pose_add` and `pose_sub` combine their two poses.
#[derive(Clone, Copy)]
enum Compose {
    Trans,
    Add,
    Sub,
}

fn compose(
    _: &mut Runtime,
    _: &mut Args,
    how: Compose,
    p: [f64; 6],
    q: [f64; 6],
) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(match how {
        Compose::Trans => crate::arm::pose::trans(p, q),
        Compose::Add => crate::arm::pose::add(p, q),
        Compose::Sub => crate::arm::pose::sub(p, q),
    })))
}

fn interpolate_pose(
    _: &mut Runtime,
    _: &mut Args,
    p: [f64; 6],
    q: [f64; 6],
    t: f64,
) -> Result<Out, Fault> {
    let mut out = [0.0; 6];
    for k in 0..6 {
        out[k] = p[k] + (q[k] - p[k]) * t;
    }
    Ok(Out::Value(Value::Pose(out)))
}

fn get_inverse_kin(
    c: &mut Runtime,
    a: &mut Args,
    pose: [f64; 6],
    qnear: Option<[f64; 6]>,
    max_position: f64,
    max_orientation: f64,
    tcp: Option<[f64; 6]>,
) -> Result<Out, Fault> {
    let qnear = qnear.unwrap_or(c.arm.q);
    let tcp = tcp.unwrap_or(c.arm.tcp);
    let (max_position, max_orientation) = tolerances(a, max_position, max_orientation)?;
    let q = inverse_within(c, pose, qnear, tcp, max_position, max_orientation)
        .map_err(|e| Fault::from(format!("`get_inverse_kin`: {e}")))?;
    Ok(Out::Value(floats(q)))
}

/// The arguments `maxPositionError` (`p`) and `maxOrientationError` (`o`) of the call
/// `a`, checked: each 0 or more.
pub(super) fn tolerances(a: &Args, p: f64, o: f64) -> Result<(f64, f64), Fault> {
    for (name, v) in [("maxPositionError", p), ("maxOrientationError", o)] {
        if !(v >= 0.0 && v.is_finite()) {
            return Err(Fault::from(format!(
                "`{}`: {name} must be 0 or more, not {v}",
                a.name
            )));
        }
    }
    Ok((p, o))
}

/// The joints nearest `qnear` that put the tool at `pose` (through `tcp`), exactly when
/// the arm reaches it, else as near as the arm comes if that is within both allowed
/// errors (the manual's "maximum allowed" position and orientation errors); what was
/// missed otherwise.
pub(super) fn inverse_within(
    c: &Runtime,
    pose: [f64; 6],
    qnear: [f64; 6],
    tcp: [f64; 6],
    max_position: f64,
    max_orientation: f64,
) -> Result<[f64; 6], String> {
    c.inverse(pose, qnear, tcp).or_else(|exact| {
        let (q, p, o) = crate::kinematics::nearest_reach(&c.dh, pose, tcp, qnear);
        if p <= max_position && o <= max_orientation {
            Ok(q)
        } else {
            Err(format!(
                "{exact} (the nearest the arm comes is {p:.6} m and {o:.6} rad away; allowed: maxPositionError {max_position}, maxOrientationError {max_orientation})"
            ))
        }
    })
}

fn get_forward_kin(
    c: &mut Runtime,
    _: &mut Args,
    q: Option<[f64; 6]>,
    tcp: Option<[f64; 6]>,
) -> Result<Out, Fault> {
    let q = q.unwrap_or(c.arm.q);
    Ok(Out::Value(Value::Pose(match tcp {
        None => c.tool_pose(q),
        Some(tcp) => crate::kinematics::forward(&c.dh, q, tcp),
    })))
}
