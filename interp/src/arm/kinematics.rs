//! Forward and inverse kinematics of UR arms, from the Denavit–Hartenberg parameters UR
//! publishes for each model ("DH parameters for calculations of kinematics and
//! dynamics"), and the time a move takes with a trapezoidal speed profile.
//!
//! - [`forward`]: joint positions to the tool pose, `p[x, y, z, rx, ry, rz]` in the base
//!   frame (metres, rotation vector), through a TCP offset.
//! - [`inverse`]: a tool pose to every joint solution of the arm (up to 8, the analytic
//!   solution of a 6-axis arm with a spherical-like wrist offset, as UR's arms are), each
//!   joint brought within ±2π to the one closest to `qnear`; [`nearest`] picks the
//!   solution closest to `qnear`, as `get_inverse_kin` does.
//!
//! ```
//! use urscript_interp::kinematics::{forward, inverse, nearest, Model};
//! let dh = Model::Ur5e.dh();
//! let q = [0.3, -1.2, 1.4, -1.8, -1.57, 0.2];
//! let pose = forward(&dh, q, [0.0; 6]);
//! let back = nearest(&inverse(&dh, pose, [0.0; 6], q), q).unwrap();
//! assert!(back.iter().zip(q).all(|(a, b)| (a - b).abs() < 1e-9));
//! ```

use std::f64::consts::{FRAC_PI_2, TAU};
use std::fmt;
use std::str::FromStr;

use crate::arm::vec3::{add, cross, scale, sub};

pub mod dynamics;
mod reach;
pub(crate) use reach::nearest_reach;

/// A UR arm model.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
#[non_exhaustive]
pub enum Model {
    /// UR3 (CB3).
    Ur3,
    /// UR5 (CB3).
    Ur5,
    /// UR10 (CB3).
    Ur10,
    /// UR3e.
    Ur3e,
    /// UR5e (the default).
    #[default]
    Ur5e,
    /// UR10e.
    Ur10e,
    /// UR16e.
    Ur16e,
    /// UR20.
    Ur20,
    /// UR30.
    Ur30,
}

/// Every model, in the order of [`Model`].
pub const MODELS: [Model; 9] = [
    Model::Ur3,
    Model::Ur5,
    Model::Ur10,
    Model::Ur3e,
    Model::Ur5e,
    Model::Ur10e,
    Model::Ur16e,
    Model::Ur20,
    Model::Ur30,
];

/// Denavit–Hartenberg parameters of an arm (UR's convention: `a` is the link length
/// along x, `d` the offset along z, `alpha` the twist; every `theta` offset is 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Dh {
    /// Offsets along z, metres.
    pub d: [f64; 6],
    /// Lengths along x, metres.
    pub a: [f64; 6],
    /// Twists, radians.
    pub alpha: [f64; 6],
}

const ALPHA: [f64; 6] = [FRAC_PI_2, 0.0, 0.0, FRAC_PI_2, -FRAC_PI_2, 0.0];

const fn dh(d1: f64, a2: f64, a3: f64, d4: f64, d5: f64, d6: f64) -> Dh {
    Dh {
        d: [d1, 0.0, 0.0, d4, d5, d6],
        a: [0.0, a2, a3, 0.0, 0.0, 0.0],
        alpha: ALPHA,
    }
}

impl Model {
    /// The model's DH parameters, as UR publishes them.
    pub fn dh(self) -> Dh {
        match self {
            Model::Ur3 => dh(0.1519, -0.24365, -0.21325, 0.11235, 0.08535, 0.0819),
            Model::Ur5 => dh(0.089159, -0.425, -0.39225, 0.10915, 0.09465, 0.0823),
            Model::Ur10 => dh(0.1273, -0.612, -0.5723, 0.163941, 0.1157, 0.0922),
            Model::Ur3e => dh(0.15185, -0.24355, -0.2132, 0.13105, 0.08535, 0.0921),
            Model::Ur5e => dh(0.1625, -0.425, -0.3922, 0.1333, 0.0997, 0.0996),
            Model::Ur10e => dh(0.1807, -0.6127, -0.57155, 0.17415, 0.11985, 0.11655),
            Model::Ur16e => dh(0.1807, -0.4784, -0.36, 0.17415, 0.11985, 0.11655),
            Model::Ur20 => dh(0.2363, -0.862, -0.7287, 0.201, 0.1593, 0.1543),
            Model::Ur30 => dh(0.2363, -0.637, -0.5037, 0.201, 0.1593, 0.1543),
        }
    }

    /// The model's name as UR writes it (`UR5e`).
    pub fn name(self) -> &'static str {
        match self {
            Model::Ur3 => "UR3",
            Model::Ur5 => "UR5",
            Model::Ur10 => "UR10",
            Model::Ur3e => "UR3e",
            Model::Ur5e => "UR5e",
            Model::Ur10e => "UR10e",
            Model::Ur16e => "UR16e",
            Model::Ur20 => "UR20",
            Model::Ur30 => "UR30",
        }
    }
}

impl fmt::Display for Model {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A model by name, any case: `ur5e`, `UR10`.
///
/// ```
/// use urscript_interp::kinematics::Model;
/// assert_eq!("ur10e".parse::<Model>(), Ok(Model::Ur10e));
/// assert!("ur99".parse::<Model>().is_err());
/// ```
impl FromStr for Model {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        MODELS
            .iter()
            .copied()
            .find(|m| m.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| {
                let names: Vec<&str> = MODELS.iter().map(|m| m.name()).collect();
                format!("unknown model `{s}` (one of {})", names.join(", "))
            })
    }
}

/// A homogeneous transform: rotation in `r`, translation in `t`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct T {
    r: [[f64; 3]; 3],
    t: [f64; 3],
}

impl T {
    const ID: T = T {
        r: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
        t: [0.0; 3],
    };

    fn mul(&self, b: &T) -> T {
        let mut r = [[0.0; 3]; 3];
        let mut t = self.t;
        for (i, (row, ti)) in r.iter_mut().zip(t.iter_mut()).enumerate() {
            for (j, cell) in row.iter_mut().enumerate() {
                *cell = (0..3).map(|k| self.r[i][k] * b.r[k][j]).sum();
            }
            *ti += (0..3).map(|k| self.r[i][k] * b.t[k]).sum::<f64>();
        }
        T { r, t }
    }

    fn inv(&self) -> T {
        let mut r = [[0.0; 3]; 3];
        for (i, row) in r.iter_mut().enumerate() {
            for (j, cell) in row.iter_mut().enumerate() {
                *cell = self.r[j][i];
            }
        }
        let t = [0, 1, 2].map(|i| -(0..3).map(|k| r[i][k] * self.t[k]).sum::<f64>());
        T { r, t }
    }

    fn of_pose(p: [f64; 6]) -> T {
        T {
            r: crate::arm::pose::to_matrix([p[3], p[4], p[5]]),
            t: [p[0], p[1], p[2]],
        }
    }

    fn pose(&self) -> [f64; 6] {
        let v = crate::arm::pose::to_rotvec(self.r);
        [self.t[0], self.t[1], self.t[2], v[0], v[1], v[2]]
    }

    /// One DH link: `Rz(theta) · Tz(d) · Tx(a) · Rx(alpha)`.
    fn link(theta: f64, d: f64, a: f64, alpha: f64) -> T {
        let (st, ct) = theta.sin_cos();
        let (sa, ca) = alpha.sin_cos();
        T {
            r: [
                [ct, -st * ca, st * sa],
                [st, ct * ca, -ct * sa],
                [0.0, sa, ca],
            ],
            t: [a * ct, a * st, d],
        }
    }
}

fn link(dh: &Dh, i: usize, theta: f64) -> T {
    T::link(theta, dh.d[i], dh.a[i], dh.alpha[i])
}

/// The flange transform of joint positions `q`.
fn flange(dh: &Dh, q: [f64; 6]) -> T {
    (0..6).fold(T::ID, |acc, i| acc.mul(&link(dh, i, q[i])))
}

/// The tool pose (base frame) of joint positions `q` with the TCP offset `tcp` (a pose in
/// the flange frame; all zeros: the flange).
pub fn forward(dh: &Dh, q: [f64; 6], tcp: [f64; 6]) -> [f64; 6] {
    flange(dh, q).mul(&T::of_pose(tcp)).pose()
}

/// The tool's speed (base frame: linear m/s, then angular rad/s) when the joints `q` move
/// at `qd`, with the TCP offset `tcp`: the geometric Jacobian times `qd`, from one pass
/// over the links.
pub(crate) fn tool_twist(dh: &Dh, q: [f64; 6], qd: [f64; 6], tcp: [f64; 6]) -> [f64; 6] {
    // Each joint turns about the z axis of the frame before it, at that frame's origin.
    let mut axes = [[0.0; 3]; 6];
    let mut origins = [[0.0; 3]; 6];
    let mut t = T::ID;
    for i in 0..6 {
        axes[i] = [t.r[0][2], t.r[1][2], t.r[2][2]];
        origins[i] = t.t;
        t = t.mul(&link(dh, i, q[i]));
    }
    let pe = t.mul(&T::of_pose(tcp)).t;
    let mut out = [0.0; 6];
    for i in 0..6 {
        let (z, o, w) = (axes[i], origins[i], qd[i]);
        let r = [pe[0] - o[0], pe[1] - o[1], pe[2] - o[2]];
        out[0] += w * (z[1] * r[2] - z[2] * r[1]);
        out[1] += w * (z[2] * r[0] - z[0] * r[2]);
        out[2] += w * (z[0] * r[1] - z[1] * r[0]);
        out[3] += w * z[0];
        out[4] += w * z[1];
        out[5] += w * z[2];
    }
    out
}

/// The frames of the arm at `q`: `[base, after joint 1, ..., after joint 6 (the flange)]`.
fn frames(dh: &Dh, q: [f64; 6]) -> [T; 7] {
    let mut out = [T::ID; 7];
    for i in 0..6 {
        out[i + 1] = out[i].mul(&link(dh, i, q[i]));
    }
    out
}

/// The z axis of a frame (the axis the next joint turns about).
fn z_axis(t: &T) -> [f64; 3] {
    [t.r[0][2], t.r[1][2], t.r[2][2]]
}

/// The Jacobian of the tool at joints `q` through the TCP offset `tcp`: 6 rows (the TCP's
/// linear speed along the base's x, y, z in m/s, then its angular speed about them in
/// rad/s), one column per joint, so that `J · qd` is the speed of [`forward`]'s pose (what
/// `get_actual_tcp_speed` reports). Column `j` is `[z × (p − o); z]` for joint `j`'s axis
/// `z` through `o` and the TCP position `p`.
///
/// ```
/// use urscript_interp::kinematics::{jacobian, Model};
/// let j = jacobian(&Model::Ur5e.dh(), [0.0; 6], [0.0; 6]);
/// // Joint 1 turns about the base's z axis.
/// assert_eq!([j[3][0], j[4][0], j[5][0]], [0.0, 0.0, 1.0]);
/// ```
pub fn jacobian(dh: &Dh, q: [f64; 6], tcp: [f64; 6]) -> [[f64; 6]; 6] {
    let f = frames(dh, q);
    let p = f[6].mul(&T::of_pose(tcp)).t;
    let mut j = [[0.0; 6]; 6];
    for (col, t) in f.iter().take(6).enumerate() {
        let z = z_axis(t);
        let v = cross(z, sub(p, t.t));
        for k in 0..3 {
            j[k][col] = v[k];
            j[k + 3][col] = z[k];
        }
    }
    j
}

/// The time derivative of [`jacobian`] while the joints at `q` move at `qd`
/// (`d/dt J(q(t))` with `dq/dt = qd`): `Jd · qd` is the part of the tool's acceleration
/// `J · qdd + Jd · qd` that the joint speeds alone make. Each joint axis `z` turns with
/// the links before it (`dz/dt = ω × z`); each axis point and the TCP move at the speeds
/// the joints before them give.
pub fn jacobian_time_derivative(
    dh: &Dh,
    q: [f64; 6],
    qd: [f64; 6],
    tcp: [f64; 6],
) -> [[f64; 6]; 6] {
    let f = frames(dh, q);
    let p = f[6].mul(&T::of_pose(tcp)).t;
    let axes: [[f64; 3]; 6] = std::array::from_fn(|i| z_axis(&f[i]));
    // The linear speed of point `x` fixed to the link after joint `upto - 1`.
    let speed_of = |x: [f64; 3], upto: usize| -> [f64; 3] {
        (0..upto).fold([0.0; 3], |acc, k| {
            add(acc, scale(qd[k], cross(axes[k], sub(x, f[k].t))))
        })
    };
    let p_dot = speed_of(p, 6);
    let mut jd = [[0.0; 6]; 6];
    let mut w = [0.0; 3]; // the angular speed of the link before joint `col`
    for col in 0..6 {
        let z = axes[col];
        let z_dot = cross(w, z);
        let o_dot = speed_of(f[col].t, col);
        let v = add(cross(z_dot, sub(p, f[col].t)), cross(z, sub(p_dot, o_dot)));
        for k in 0..3 {
            jd[k][col] = v[k];
            jd[k + 3][col] = z_dot[k];
        }
        w = add(w, scale(qd[col], z));
    }
    jd
}

/// Brings `x` within ±2π to the value closest to `near`.
fn wrap_near(x: f64, near: f64) -> f64 {
    let mut v = x + TAU * ((near - x) / TAU).round();
    if v > TAU {
        v -= TAU;
    } else if v < -TAU {
        v += TAU;
    }
    v
}

/// Every joint solution that puts the tool at `pose` with the TCP offset `tcp`: up to 8
/// (shoulder left/right, wrist up/down, elbow up/down), each joint within ±2π and closest
/// to `qnear`'s. At a wrist singularity (joint 5 at 0 or π) joint 6 is free and takes
/// `qnear`'s value. Empty if the pose is out of reach.
pub fn inverse(dh: &Dh, pose: [f64; 6], tcp: [f64; 6], qnear: [f64; 6]) -> Vec<[f64; 6]> {
    if !pose.iter().chain(&tcp).chain(&qnear).all(|x| x.is_finite()) {
        return Vec::new();
    }
    let (a2, a3, d4, d6) = (dh.a[1], dh.a[2], dh.d[3], dh.d[5]);
    let t06 = T::of_pose(pose).mul(&T::of_pose(tcp).inv());
    let r = t06.r;
    let p = t06.t;
    // Joint 1: the wrist centre (frame 5's origin) lies d6 back along the tool z axis.
    let p05 = [p[0] - d6 * r[0][2], p[1] - d6 * r[1][2]];
    let rho = p05[0].hypot(p05[1]);
    // The wrist centre must lie outside the cylinder of radius d4 around joint 1 (on it,
    // up to rounding, the two shoulder solutions meet).
    if rho < d4.abs() - 1e-9 || rho < 1e-12 {
        return Vec::new();
    }
    let psi = p05[1].atan2(p05[0]);
    let phi = (d4 / rho).clamp(-1.0, 1.0).acos();
    let mut out = Vec::with_capacity(8);
    for q1 in [psi + phi + FRAC_PI_2, psi - phi + FRAC_PI_2] {
        let (s1, c1) = q1.sin_cos();
        // Joint 5 from the tool position seen along joint 1's normal.
        let c5 = ((p[0] * s1 - p[1] * c1 - d4) / d6).clamp(-1.0, 1.0);
        // acos near ±1 turns rounding into ~1e-8 rad: a wrist that is straight up to
        // rounding is straight.
        let a5 = match c5.acos() {
            a if a < 1e-7 => 0.0,
            a => a,
        };
        for q5 in [a5, -a5] {
            let s5 = q5.sin();
            // Joint 6 from the base axes seen from the tool (atan2 needs only the sign of
            // sin q5); free at the wrist singularity, where it takes `qnear`'s value.
            let n = (-r[0][1] * s1 + r[1][1] * c1) * s5.signum();
            let d = (r[0][0] * s1 - r[1][0] * c1) * s5.signum();
            let q6 = if s5.abs() < 1e-9 || n.hypot(d) < 1e-9 {
                qnear[5]
            } else {
                n.atan2(d)
            };
            // Joints 2, 3, 4: a planar two-link problem for the point frame 1 sees.
            let t01 = link(dh, 0, q1);
            let t45 = link(dh, 4, q5);
            let t56 = link(dh, 5, q6);
            let t14 = t01.inv().mul(&t06).mul(&t45.mul(&t56).inv());
            let p13 = [t14.t[0] - d4 * t14.r[0][1], t14.t[1] - d4 * t14.r[1][1]];
            let l2 = p13[0] * p13[0] + p13[1] * p13[1];
            let c3 = (l2 - a2 * a2 - a3 * a3) / (2.0 * a2 * a3);
            if !(-1.0 - 1e-9..=1.0 + 1e-9).contains(&c3) {
                continue;
            }
            let a3q = c3.clamp(-1.0, 1.0).acos();
            for q3 in [a3q, -a3q] {
                let l = l2.sqrt();
                if l < 1e-12 {
                    continue;
                }
                let q2 = -p13[1].atan2(-p13[0]) + (a3 * q3.sin() / l).clamp(-1.0, 1.0).asin();
                let t13 = link(dh, 1, q2).mul(&link(dh, 2, q3));
                let t34 = t13.inv().mul(&t14);
                let q4 = t34.r[1][0].atan2(t34.r[0][0]);
                let mut q = [q1, q2, q3, q4, q5, q6];
                for (x, near) in q.iter_mut().zip(qnear) {
                    *x = wrap_near(*x, near);
                }
                // A solution must reach the pose (guards the branches' edge cases).
                let reached = forward(dh, q, tcp);
                let known = out
                    .iter()
                    .any(|o: &[f64; 6]| o.iter().zip(&q).all(|(a, b)| (a - b).abs() < 1e-9));
                if pose_error(reached, pose) < 1e-6 && !known {
                    out.push(q);
                }
            }
        }
    }
    out
}

/// The position error (metres) plus the orientation error (radians) between two poses.
pub fn pose_error(a: [f64; 6], b: [f64; 6]) -> f64 {
    let ta = T::of_pose(a);
    let tb = T::of_pose(b);
    let dp = (0..3)
        .map(|i| (ta.t[i] - tb.t[i]).powi(2))
        .sum::<f64>()
        .sqrt();
    let dr = crate::arm::pose::to_rotvec(ta.r_t_mul(&tb));
    dp + (dr[0] * dr[0] + dr[1] * dr[1] + dr[2] * dr[2]).sqrt()
}

impl T {
    /// `self.rᵀ · b.r`: the rotation from this frame to `b`'s.
    fn r_t_mul(&self, b: &T) -> [[f64; 3]; 3] {
        let mut o = [[0.0; 3]; 3];
        for (i, row) in o.iter_mut().enumerate() {
            for (j, cell) in row.iter_mut().enumerate() {
                *cell = (0..3).map(|k| self.r[k][i] * b.r[k][j]).sum();
            }
        }
        o
    }
}

/// The solution closest to `qnear` (smallest sum of joint distances), as the controller
/// chooses.
pub fn nearest(solutions: &[[f64; 6]], qnear: [f64; 6]) -> Option<[f64; 6]> {
    let cost = |q: &[f64; 6]| -> f64 { q.iter().zip(qnear).map(|(a, b)| (a - b).abs()).sum() };
    solutions
        .iter()
        .copied()
        .min_by(|a, b| cost(a).total_cmp(&cost(b)))
}

/// The time a move of `distance` takes at speed `v` with acceleration `a`, by a
/// trapezoidal profile (accelerate, cruise, decelerate; a triangle when the distance is
/// too short to reach `v`). A non-positive `a` means "reach `v` at once".
///
/// ```
/// use urscript_interp::kinematics::move_time;
/// assert_eq!(move_time(1.0, 0.5, 0.0), 2.0);
/// assert!((move_time(1.0, 0.5, 1.0) - 2.5).abs() < 1e-12); // 2 s cruise + 0.5 s ramps
/// assert!((move_time(0.01, 1.0, 1.0) - 0.2).abs() < 1e-12); // a triangle
/// ```
pub fn move_time(distance: f64, v: f64, a: f64) -> f64 {
    let d = distance.abs();
    let positive = |x: f64| x.is_finite() && x > 0.0;
    if !positive(d) || !positive(v) {
        return 0.0;
    }
    if !positive(a) {
        return d / v;
    }
    if d >= v * v / a {
        d / v + v / a
    } else {
        2.0 * (d / a).sqrt()
    }
}
