//! Poses and kinematics: pose arithmetic composes rigid transforms with rotation vectors
//! as the manual defines them; `rotvec2rpy`/`rpy2rotvec` convert to and from
//! roll-pitch-yaw; `wrench_trans` moves a wrench's point of view; `interpolate_pose` interpolates each element linearly
//! (exact for translation, approximate for rotation). `get_inverse_kin` and
//! `get_forward_kin` use the arm model's kinematics ([`crate::kinematics`]); a pose out
//! of exact reach gets the nearest the arm comes when that is within `maxPositionError`
//! and `maxOrientationError`, else the runtime error the controller raises (which
//! `get_inverse_kin_has_solution` is there to avoid).

use super::{float_list, floats, opt, req, Args, Builtin, Default, Domain, Out};
use crate::error::Fault;
use crate::runtime::Runtime;
use crate::value::Value;

const D: Domain = Domain::Poses;
const TWO: &[super::Param] = &[req("p_from"), req("p_to")];

pub(super) const TABLE: &[Builtin] = &[
    Builtin::new(
        "point_dist",
        D,
        TWO,
        "The distance between the two poses' positions.",
        dist,
    ),
    Builtin::new(
        "pose_dist",
        D,
        TWO,
        "The distance between the two poses' positions.",
        dist,
    ),
    Builtin::new(
        "rotvec2rpy",
        D,
        &[req("rotation_vector")],
        "The roll-pitch-yaw angles [r, p, y] of a rotation vector (R = Rz(y)Ry(p)Rx(r)).",
        rotvec2rpy,
    ),
    Builtin::new(
        "rpy2rotvec",
        D,
        &[req("rpy_vector")],
        "The rotation vector of roll-pitch-yaw angles [r, p, y] (R = Rz(y)Ry(p)Rx(r)).",
        rpy2rotvec,
    ),
    Builtin::new(
        "wrench_trans",
        D,
        &[req("T_from_to"), req("w_from")],
        "The wrench [F, M] seen from the frame T_from_to: torque moved to its origin, both in its axes.",
        wrench_trans,
    ),
    Builtin::new(
        "pose_trans",
        D,
        &[req("p_from"), req("p_from_to")],
        "p_from_to expressed in the base frame, seen from p_from (the composition).",
        compose,
    ),
    Builtin::new(
        "pose_add",
        D,
        &[req("p_1"), req("p_2")],
        "Positions added, rotations composed.",
        compose,
    ),
    Builtin::new(
        "pose_sub",
        D,
        &[req("p_to"), req("p_from")],
        "Positions subtracted, rotations composed with the inverse.",
        compose,
    ),
    Builtin::new(
        "pose_inv",
        D,
        &[req("p_from")],
        "The inverse transform.",
        pose_inv,
    ),
    Builtin::new(
        "interpolate_pose",
        D,
        &[req("p_from"), req("p_to"), req("alpha")],
        "The pose a fraction alpha of the way (element-wise).",
        interpolate_pose,
    ),
    Builtin::new(
        "get_inverse_kin",
        D,
        &[
            req("x"),
            opt("qnear", Default::Absent),
            opt("maxPositionError", Default::Float(1e-10)),
            opt("maxOrientationError", Default::Float(1e-10)),
            opt("tcp", Default::Absent),
        ],
        "The joints that put the tool at x, nearest qnear (default: the current joints), by the arm model's inverse kinematics; out of exact reach, the nearest the arm comes if within maxPositionError and maxOrientationError, else a runtime error (as on the controller).",
        get_inverse_kin,
    ),
    Builtin::new(
        "get_forward_kin",
        D,
        &[opt("q", Default::Absent), opt("tcp", Default::Absent)],
        "The tool pose of q (default: the current joints) through tcp (default: the active TCP), by the arm model's forward kinematics.",
        get_forward_kin,
    ),
];

fn dist(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (p, q) = (a.six(0)?, a.six(1)?);
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

fn rotvec2rpy(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let r: [f64; 3] = a.nums(0)?;
    // The rotation matrix's columns: the rotated axes.
    let [c0, c1, c2] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]].map(|e| rotate(r, e));
    let pitch = (-c0[2]).atan2(c0[0].hypot(c0[1]));
    let yaw = c0[1].atan2(c0[0]);
    let roll = c1[2].atan2(c2[2]);
    Ok(Out::Value(float_list(&[roll, pitch, yaw])))
}

fn rpy2rotvec(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let [roll, pitch, yaw]: [f64; 3] = a.nums(0)?;
    let rot = |x: f64, y: f64, z: f64| [0.0, 0.0, 0.0, x, y, z];
    let p = crate::arm::pose::trans(
        crate::arm::pose::trans(rot(0.0, 0.0, yaw), rot(0.0, pitch, 0.0)),
        rot(roll, 0.0, 0.0),
    );
    Ok(Out::Value(float_list(&p[3..])))
}

fn wrench_trans(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let t = a.six(0)?;
    let w = a.six(1)?;
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

fn compose(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (p, q) = (a.six(0)?, a.six(1)?);
    Ok(Out::Value(Value::Pose(match a.name {
        "pose_trans" => crate::arm::pose::trans(p, q),
        "pose_add" => crate::arm::pose::add(p, q),
        _ => crate::arm::pose::sub(p, q),
    })))
}

fn pose_inv(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(crate::arm::pose::inv(a.six(0)?))))
}

fn interpolate_pose(_: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let (p, q) = (a.six(0)?, a.six(1)?);
    let t = a.num(2)?;
    let mut out = [0.0; 6];
    for k in 0..6 {
        out[k] = p[k] + (q[k] - p[k]) * t;
    }
    Ok(Out::Value(Value::Pose(out)))
}

fn get_inverse_kin(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let pose = a.six(0)?;
    let qnear = if a.is_absent(1) { c.arm.q } else { a.six(1)? };
    let tcp = if a.is_absent(4) { c.arm.tcp } else { a.six(4)? };
    let (max_position, max_orientation) = tolerances(a)?;
    let q = inverse_within(c, pose, qnear, tcp, max_position, max_orientation)
        .map_err(|e| Fault::from(format!("`get_inverse_kin`: {e}")))?;
    Ok(Out::Value(floats(q)))
}

/// `maxPositionError` and `maxOrientationError` (arguments 2 and 3): each 0 or more.
pub(super) fn tolerances(a: &Args) -> Result<(f64, f64), Fault> {
    let (p, o) = (a.num(2)?, a.num(3)?);
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

fn get_forward_kin(c: &mut Runtime, a: &mut Args) -> Result<Out, Fault> {
    let q = if a.is_absent(0) { c.arm.q } else { a.six(0)? };
    Ok(Out::Value(Value::Pose(if a.is_absent(1) {
        c.tool_pose(q)
    } else {
        crate::kinematics::forward(&c.dh, q, a.six(1)?)
    })))
}
