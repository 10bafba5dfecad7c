//! The arm's model as the e-Series 5.x manual's internals expose it (PolyScope 5.22 and
//! later): Jacobians, the mass matrix, the Coriolis and centrifugal torques, and the joint
//! accelerations. Computed on the virtual arm's model
//! ([`crate::kinematics::jacobian`], [`crate::kinematics::dynamics`]: rigid links with
//! UR's published masses and centres of mass, isotropic inertias, no friction).
//!
//! - `get_jacobian(q, tcp)`, `get_jacobian_time_derivative(q, qd, tcp)`: 6×6 matrices (a
//!   list of 6 rows), rows `[vx, vy, vz, wx, wy, wz]` in the base frame, columns by joint;
//!   `q`, `qd`, `tcp` default to the joints, joint speeds and TCP now. The manual does
//!   not name the frame; the base frame is chosen so that `get_jacobian() * qd` is the
//!   speed `get_actual_tcp_speed()` reports.
//! - `get_mass_matrix(q, include_rotors_inertia=False)`: 6×6, with the active payload
//!   (`set_target_payload`) on the flange; with `include_rotors_inertia` the rotor
//!   inertias of [`World::rotor_inertia`](crate::World::rotor_inertia) are added on the
//!   diagonal.
//! - `get_coriolis_and_centrifugal_torques(q, qd)`: 6 torques (Nm), `C(q, qd)·qd`.
//! - `get_target_joint_accelerations()`, `get_actual_joint_accelerations()`: the joint
//!   accelerations of the motion under way ([`Arm::qdd`](crate::Arm::qdd)); the virtual
//!   arm follows its target exactly, so both are the same.
//!
//! - `estimate_payload(poses, wrenches)`: `struct(mass, cog)` from the wrenches gravity
//!   puts on the payload at four or more TCP poses
//!   ([`dynamics::estimate_payload`]):
//!   `mass` in kg, `cog` `[x, y, z]` in m from the flange in the flange's axes (as
//!   `set_target_payload` takes it). The poses are TCP poses, as the manual asks
//!   (`get_actual_tcp_pose()`): the active TCP's rotation is taken off each to get the
//!   flange's orientation (with a TCP that only shifts the tool, they are the same).
//!   Each wrench is at the flange in the base's axes (`get_tcp_force()`). The manual's
//!   refusals (fewer than 4 poses, a wrench count that differs, two orientations closer
//!   than π/(2n)) are runtime errors, as is more than [`MAX_PAYLOAD_POSES`] poses (our
//!   bound: the check compares every pair).
//!
//! An arm whose DH parameters are not one of [`MODELS`]'s has no dynamics parameters:
//! the dynamics functions are then a runtime error.

use super::{builtin, float_list, floats, Args, Builtin, Domain, Out};
use crate::error::Fault;
use crate::kinematics::dynamics::{self, Payload};
use crate::kinematics::{self, Model, MODELS};
use crate::native::FromArg;
use crate::runtime::Runtime;
use crate::value::Value;

/// The most poses `estimate_payload` takes. Its orientation check compares every pair
/// (about 27 multiply-adds each): 500 poses are about 3.4 M, under the 4 M a matrix
/// product may take, so one call stays well within a step.
pub const MAX_PAYLOAD_POSES: usize = 500;

/// The chapter of the entries below, but for the Jacobians (in blocks of their own).
const D: Domain = Domain::Motion;

pub(super) const TABLE: &[Builtin] = &[
    {
        const D: Domain = Domain::Poses;
        builtin!(
            get_jacobian(q: Option<[f64; 6]> = Absent, tcp: Option<[f64; 6]> = Absent)
                => jacobian,
            "The 6x6 Jacobian (base frame: linear, then angular speed per joint speed) at q (default: the joints now) through tcp (default: the active TCP).",
        )
    },
    {
        const D: Domain = Domain::Poses;
        builtin!(
            get_jacobian_time_derivative(
                q: Option<[f64; 6]> = Absent,
                qd: Option<[f64; 6]> = Absent,
                tcp: Option<[f64; 6]> = Absent,
            ) => jacobian_time_derivative,
            "The time derivative of the Jacobian at q moving at qd (defaults: the joints and joint speeds now) through tcp (default: the active TCP).",
        )
    },
    builtin!(
        get_mass_matrix(q: Option<[f64; 6]> = Absent, include_rotors_inertia: bool = Bool(false))
            => mass_matrix,
        "The 6x6 joint-space mass matrix at q (default: the joints now) with the active payload, rotor inertias added if asked.",
    ),
    builtin!(
        get_coriolis_and_centrifugal_torques(q: Option<[f64; 6]> = Absent, qd: Option<[f64; 6]> = Absent)
            => coriolis,
        "The Coriolis and centrifugal joint torques at q moving at qd (defaults: the joints and joint speeds now).",
    ),
    builtin!(
        estimate_payload(poses: Sixes, wrenches: Sixes) => estimate_payload,
        "struct(mass, cog): the payload whose weight explains the wrenches measured at the TCP poses (at least 4, orientations pi/(2n) apart).",
    ),
    builtin!(
        get_target_joint_accelerations() => accelerations,
        "The joint accelerations of the motion under way (zero at rest).",
    ),
    builtin!(
        get_actual_joint_accelerations() => accelerations,
        "The joint accelerations now (the virtual arm follows its target exactly).",
    ),
];

/// A 6×6 matrix as URScript's matrix: a list of 6 rows.
fn matrix(m: [[f64; 6]; 6]) -> Value {
    Value::List(m.iter().map(|row| floats(*row)).collect())
}

/// The model whose DH parameters the arm has.
fn model(c: &Runtime, name: &str) -> Result<Model, Fault> {
    MODELS
        .iter()
        .copied()
        .find(|m| m.dh() == c.dh)
        .ok_or_else(|| {
            Fault::from(format!(
                "`{name}`: the arm's DH parameters are not those of a UR model, so it has no dynamics parameters"
            ))
        })
}

fn payload(c: &Runtime) -> Payload {
    Payload {
        mass: c.arm.payload_mass,
        cog: c.arm.payload_cog,
        inertia: c.arm.payload_inertia,
    }
}

fn jacobian(
    c: &mut Runtime,
    _: &mut Args,
    q: Option<[f64; 6]>,
    tcp: Option<[f64; 6]>,
) -> Result<Out, Fault> {
    let q = q.unwrap_or(c.arm.q);
    let tcp = tcp.unwrap_or(c.arm.tcp);
    Ok(Out::Value(matrix(kinematics::jacobian(&c.dh, q, tcp))))
}

fn jacobian_time_derivative(
    c: &mut Runtime,
    _: &mut Args,
    q: Option<[f64; 6]>,
    qd: Option<[f64; 6]>,
    tcp: Option<[f64; 6]>,
) -> Result<Out, Fault> {
    let q = q.unwrap_or(c.arm.q);
    let qd = qd.unwrap_or(c.arm.qd);
    let tcp = tcp.unwrap_or(c.arm.tcp);
    Ok(Out::Value(matrix(kinematics::jacobian_time_derivative(
        &c.dh, q, qd, tcp,
    ))))
}

fn mass_matrix(
    c: &mut Runtime,
    a: &mut Args,
    q: Option<[f64; 6]>,
    rotors: bool,
) -> Result<Out, Fault> {
    let model = model(c, a.name)?;
    let q = q.unwrap_or(c.arm.q);
    let mut m = dynamics::mass_matrix(model, q, &payload(c));
    if rotors {
        for (i, row) in m.iter_mut().enumerate() {
            row[i] += c.arm.world.rotor_inertia[i];
        }
    }
    Ok(Out::Value(matrix(m)))
}

fn coriolis(
    c: &mut Runtime,
    a: &mut Args,
    q: Option<[f64; 6]>,
    qd: Option<[f64; 6]>,
) -> Result<Out, Fault> {
    let model = model(c, a.name)?;
    let q = q.unwrap_or(c.arm.q);
    let qd = qd.unwrap_or(c.arm.qd);
    let tau = dynamics::coriolis_and_centrifugal_torques(model, q, qd, &payload(c));
    Ok(Out::Value(float_list(&tau)))
}

fn accelerations(c: &mut Runtime, _: &mut Args) -> Result<Out, Fault> {
    Ok(Out::Value(floats(c.arm.qdd)))
}

/// A list of at most [`MAX_PAYLOAD_POSES`] items of 6 numbers each (poses, or lists of 6
/// numbers): `estimate_payload`'s poses and wrenches. Anything else is a type error
/// naming the parameter ("a list of poses") or the item.
struct Sixes(Vec<[f64; 6]>);

impl FromArg<'_> for Sixes {
    fn from_arg(a: &Args, v: &Value, i: usize) -> Result<Self, Fault> {
        let param = a.params.get(i).map_or("?", |p| p.name);
        let Value::List(items) = v else {
            return Err(Fault::type_error(format!(
                "type error: `{}` argument `{param}` needs a list of {param}, got {} {}",
                a.name,
                v.type_name(),
                v.to_source()
            )));
        };
        if items.len() > MAX_PAYLOAD_POSES {
            return Err(Fault::from(format!(
                "`{}`: {} items in `{param}`, at most {MAX_PAYLOAD_POSES}",
                a.name,
                items.len(),
            )));
        }
        let bad_item = |k: usize, x: &Value| {
            Fault::type_error(format!(
                "type error: `{}` argument `{param}` needs 6 numbers in each item, item {k} is {} {}",
                a.name,
                x.type_name(),
                x.to_source()
            ))
        };
        items
            .iter()
            .enumerate()
            .map(|(k, x)| match x {
                Value::Pose(p) => Ok(*p),
                Value::List(v) if v.len() == 6 => {
                    let mut out = [0.0; 6];
                    for (o, n) in out.iter_mut().zip(v) {
                        *o = n.as_f64().ok_or_else(|| bad_item(k, x))?;
                    }
                    Ok(out)
                }
                _ => Err(bad_item(k, x)),
            })
            .collect::<Result<_, _>>()
            .map(Sixes)
    }
}

fn estimate_payload(
    c: &mut Runtime,
    _: &mut Args,
    Sixes(poses): Sixes,
    Sixes(wrenches): Sixes,
) -> Result<Out, Fault> {
    // The flange's orientation: the TCP pose composed with the inverse of the TCP's
    // rotation (its offset does not change the orientation).
    let tcp_rot_inv =
        crate::arm::pose::inv([0.0, 0.0, 0.0, c.arm.tcp[3], c.arm.tcp[4], c.arm.tcp[5]]);
    let flanges: Vec<[f64; 6]> = poses
        .iter()
        .map(|p| crate::arm::pose::trans(*p, tcp_rot_inv))
        .collect();
    let (mass, cog) = dynamics::estimate_payload(&flanges, &wrenches, c.arm.gravity)
        .map_err(|e| Fault::from(format!("`estimate_payload`: {e}")))?;
    Ok(Out::Value(Value::Struct(vec![
        ("mass".to_string(), Value::Float(mass)),
        ("cog".to_string(), float_list(&cog)),
    ])))
}
