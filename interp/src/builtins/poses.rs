//! Poses and kinematics: pose arithmetic composes rigid transforms with rotation vectors
//! as the manual defines them; `interpolate_pose` interpolates each element linearly
//! (exact for translation, approximate for rotation). The kinematics functions have no
//! model of the arm yet: `get_inverse_kin(x, qnear)` returns `qnear` (or the commanded
//! joints), `get_forward_kin()` the commanded pose.

use super::{floats, opt, req, Args, Builtin, Default, Domain, Out};
use crate::controller::Controller;
use crate::error::Fault;
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
        "No kinematics yet: qnear if given, else the commanded joints.",
        get_inverse_kin,
    ),
    Builtin::new(
        "get_forward_kin",
        D,
        &[opt("q", Default::Absent), opt("tcp", Default::Absent)],
        "No kinematics yet: the commanded pose.",
        get_forward_kin,
    ),
];

fn dist(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let (p, q) = (a.six(0)?, a.six(1)?);
    let d = (0..3).map(|k| (p[k] - q[k]).powi(2)).sum::<f64>().sqrt();
    Ok(Out::Value(Value::Float(d)))
}

fn compose(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let (p, q) = (a.six(0)?, a.six(1)?);
    Ok(Out::Value(Value::Pose(match a.name {
        "pose_trans" => crate::pose::trans(p, q),
        "pose_add" => crate::pose::add(p, q),
        _ => crate::pose::sub(p, q),
    })))
}

fn pose_inv(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(crate::pose::inv(a.six(0)?))))
}

fn interpolate_pose(_: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    let (p, q) = (a.six(0)?, a.six(1)?);
    let t = a.num(2)?;
    let mut out = [0.0; 6];
    for k in 0..6 {
        out[k] = p[k] + (q[k] - p[k]) * t;
    }
    Ok(Out::Value(Value::Pose(out)))
}

fn get_inverse_kin(c: &mut Controller, a: &mut Args) -> Result<Out, Fault> {
    a.six(0)?;
    Ok(Out::Value(if a.is_absent(1) {
        floats(c.arm.q)
    } else {
        floats(a.six(1)?)
    }))
}

fn get_forward_kin(c: &mut Controller, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(Value::Pose(c.arm.pose)))
}
