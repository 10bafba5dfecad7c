//! Rigid-body dynamics of UR arms: the joint-space mass matrix and the Coriolis and
//! centrifugal torques, as `get_mass_matrix` and `get_coriolis_and_centrifugal_torques`
//! return them.
//!
//! ## The model
//! - Six rigid links on the DH frames of [`Model::dh`]; link `i` turns with joint `i` and
//!   carries its mass at its centre of mass, both as UR publishes them ("DH parameters for
//!   calculations of kinematics and dynamics": mass and centre of mass in the link's DH
//!   frame). Where that page's table was not at hand (UR3, UR5, UR10, UR16e, UR30 and the
//!   UR10e's last link) the values are those of UR's own ROS description
//!   (`Universal_Robots_ROS2_Description`, `config/<model>/physical_parameters.yaml`,
//!   which cites the same page), turned back from its URDF frames into the DH frames.
//! - **Inertias, approximated**: each link's inertia about its centre of mass is taken as
//!   isotropic (`k · I₃`), with `k` a third of the trace of the inertia tensor UR gives
//!   for it (the UR20's on UR's page; the others' in UR's ROS description). A trace does
//!   not depend on the axes it is written in, so no frame conversion is guessed; the
//!   products of inertia and the differences between the principal moments are left out.
//!   UR's page notes that link inertias are negligible on the UR3e and UR5e.
//! - The payload set by `set_target_payload` (mass, centre of gravity and inertia in the
//!   flange frame) is part of the last link.
//! - No friction, no joint elasticity; rotor (motor-side) inertias, which UR does not
//!   publish, are added on the diagonal only when asked (`include_rotors_inertia`), from
//!   values the caller gives.
//!
//! The torques come from the recursive Newton–Euler equations: the mass matrix column
//! `j` is the torque that a unit acceleration of joint `j` takes at rest, without
//! gravity; the Coriolis and centrifugal torques are the torques the joint speeds take
//! without acceleration or gravity.
//!
//! ```
//! use urscript_interp::kinematics::{dynamics, Model};
//! let m = dynamics::mass_matrix(Model::Ur5e, [0.0, -1.57, 1.57, 0.0, 0.0, 0.0], &dynamics::Payload::NONE);
//! assert_eq!(m[1][2], m[2][1]); // symmetric
//! assert!(m[0][0] > 0.0);
//! ```

use super::{frames, Model};
use crate::arm::vec3::{add, cross, dot, scale, sub};

/// One link's mass properties.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Link {
    /// Mass, kg.
    pub mass: f64,
    /// Centre of mass in the link's DH frame, m.
    pub com: [f64; 3],
    /// The isotropic moment of inertia about the centre of mass, kg·m² (see the model).
    pub inertia: f64,
}

const fn l(mass: f64, com: [f64; 3], trace: f64) -> Link {
    Link {
        mass,
        com,
        inertia: trace / 3.0,
    }
}

/// A payload at the flange: what `set_target_payload` sets.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Payload {
    /// Mass, kg.
    pub mass: f64,
    /// Centre of gravity in the flange frame, m.
    pub cog: [f64; 3],
    /// Inertia at the centre of gravity, flange axes: `[Ixx, Iyy, Izz, Ixy, Ixz, Iyz]`, kg·m².
    pub inertia: [f64; 6],
}

impl Payload {
    /// No payload.
    pub const NONE: Payload = Payload {
        mass: 0.0,
        cog: [0.0; 3],
        inertia: [0.0; 6],
    };
}

impl Model {
    /// The model's six links (see the [module](self) for the sources and the inertia
    /// approximation).
    pub fn links(self) -> [Link; 6] {
        match self {
            Model::Ur3 => [
                l(2.0, [0.0, -0.02, 0.0], 0.021811),
                l(3.42, [0.13, 0.0, 0.1157], 0.053076),
                l(1.26, [0.05, 0.0, 0.0238], 0.016637),
                l(0.8, [0.0, 0.0, 0.01], 0.005471),
                l(0.8, [0.0, 0.0, 0.01], 0.005394),
                l(0.35, [0.0, 0.0, -0.02], 0.000452),
            ],
            Model::Ur5 => [
                l(3.7, [0.0, -0.02561, 0.00193], 0.040351),
                l(8.393, [0.2125, 0.0, 0.11336], 0.282879),
                l(2.33, [0.15, 0.0, 0.0265], 0.066529),
                l(1.219, [0.0, -0.0018, 0.01634], 0.006222),
                l(1.219, [0.0, 0.0018, 0.01634], 0.005856),
                l(0.1879, [0.0, 0.0, -0.001159], 0.000293),
            ],
            Model::Ur10 => [
                l(7.1, [0.021, 0.0, 0.027], 0.09093),
                l(12.7, [0.38, 0.0, 0.158], 1.56825),
                l(4.27, [0.24, 0.0, 0.068], 0.62588),
                l(2.0, [0.0, 0.007, 0.018], 0.00776),
                l(2.0, [0.0, 0.007, 0.018], 0.00776),
                l(0.365, [0.0, 0.0, -0.026], 0.00115),
            ],
            Model::Ur3e => [
                l(1.98, [0.0, -0.02, 0.0], 0.021811),
                l(3.4445, [0.13, 0.0, 0.1157], 0.053076),
                l(1.437, [0.05, 0.0, 0.0238], 0.016633),
                l(0.871, [0.0, 0.0, 0.01], 0.00642),
                l(0.805, [0.0, 0.0, 0.01], 0.00642),
                l(0.261, [0.0, 0.0, -0.02], 0.000452),
            ],
            Model::Ur5e => [
                l(3.761, [0.0, -0.02561, 0.00193], 0.027195),
                l(8.058, [0.2125, 0.0, 0.11336], 0.282879),
                l(2.846, [0.15, 0.0, 0.0265], 0.066514),
                l(1.37, [0.0, -0.0018, 0.01634], 0.007314),
                l(1.3, [0.0, 0.0018, 0.01634], 0.007314),
                l(0.365, [0.0, 0.0, -0.001159], 0.00033),
            ],
            Model::Ur10e => [
                l(7.369, [0.021, 0.0, 0.027], 0.09093),
                l(13.051, [0.38, 0.0, 0.158], 1.56825),
                l(3.989, [0.24, 0.0, 0.068], 0.62588),
                l(2.1, [0.0, 0.007, 0.018], 0.00776),
                l(1.98, [0.0, 0.007, 0.018], 0.00776),
                l(0.615, [0.0, 0.0, -0.026], 0.00115),
            ],
            Model::Ur16e => [
                l(7.369, [0.0, -0.016, 0.030], 0.08825),
                l(10.45, [0.302, 0.0, 0.16], 0.97989),
                l(4.321, [0.194, 0.0, 0.065], 0.24865),
                l(2.18, [0.0, -0.009, 0.011], 0.01433),
                l(2.033, [0.0, 0.018, 0.012], 0.00971),
                l(0.907, [0.0, 0.0, -0.044], 0.00319),
            ],
            Model::Ur20 => [
                l(16.343, [0.0, -0.0610, 0.0062], 0.2492),
                l(29.632, [0.5226, 0.0, 0.2098], 9.4474),
                l(7.879, [0.3234, 0.0, 0.0604], 1.5370),
                l(3.054, [0.0, -0.0026, 0.0393], 0.0150),
                l(3.126, [0.0, 0.0024, 0.0379], 0.0160),
                l(0.846, [0.0, -0.0003, -0.0318], 0.0030),
            ],
            Model::Ur30 => [
                l(16.343, [-0.0001, -0.06, 0.0069], 0.08825),
                l(28.542, [0.3894, 0.0, 0.2103], 0.97989),
                l(7.156, [0.2257, 0.0, 0.0629], 0.24865),
                l(3.054, [0.0, -0.0048, 0.0353], 0.01433),
                l(3.126, [0.0, 0.0046, 0.0341], 0.00971),
                l(0.926, [0.0, 0.0, -0.0293], 0.00319),
            ],
        }
    }
}

type M3 = [[f64; 3]; 3];

fn mat_vec(m: &M3, v: [f64; 3]) -> [f64; 3] {
    std::array::from_fn(|i| m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2])
}

/// A rigid body in its link frame: mass, centre of mass, inertia about it (3×3).
#[derive(Clone, Copy)]
struct Body {
    mass: f64,
    com: [f64; 3],
    inertia: M3,
}

/// The inertia about a body's centre of mass of a point mass `m` at offset `r` from it
/// (the parallel-axis term): `m (|r|² I − r rᵀ)`.
fn point_inertia(m: f64, r: [f64; 3]) -> M3 {
    let rr = dot(r, r);
    std::array::from_fn(|i| {
        std::array::from_fn(|j| m * (if i == j { rr } else { 0.0 } - r[i] * r[j]))
    })
}

/// The last link with the payload fixed to it: one body.
fn with_payload(link: &Link, p: &Payload) -> Body {
    let iso = link.inertia;
    let link_body = Body {
        mass: link.mass,
        com: link.com,
        inertia: [[iso, 0.0, 0.0], [0.0, iso, 0.0], [0.0, 0.0, iso]],
    };
    if p.mass.is_nan() || p.mass <= 0.0 {
        return link_body;
    }
    let mass = link.mass + p.mass;
    let com = scale(
        1.0 / mass,
        add(scale(link.mass, link.com), scale(p.mass, p.cog)),
    );
    let [ixx, iyy, izz, ixy, ixz, iyz] = p.inertia;
    let ip = [[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]];
    let a = point_inertia(link.mass, sub(link.com, com));
    let b = point_inertia(p.mass, sub(p.cog, com));
    let inertia = std::array::from_fn(|i| {
        std::array::from_fn(|j| link_body.inertia[i][j] + ip[i][j] + a[i][j] + b[i][j])
    });
    Body { mass, com, inertia }
}

/// The arm at one set of joints: what every Newton–Euler pass there shares (all in the
/// base frame).
struct Posed {
    /// Each joint's axis and a point on it.
    axes: [[f64; 3]; 6],
    origins: [[f64; 3]; 7],
    /// Each link's mass, centre of mass and inertia about it (base axes).
    mass: [f64; 6],
    com: [[f64; 3]; 6],
    inertia: [M3; 6],
}

impl Posed {
    fn new(model: Model, q: [f64; 6], payload: &Payload) -> Posed {
        let f = frames(&model.dh(), q);
        let links = model.links();
        let mut posed = Posed {
            axes: [[0.0; 3]; 6],
            origins: std::array::from_fn(|i| f[i].t),
            mass: [0.0; 6],
            com: [[0.0; 3]; 6],
            inertia: [[[0.0; 3]; 3]; 6],
        };
        for i in 0..6 {
            let b = with_payload(&links[i], if i == 5 { payload } else { &Payload::NONE });
            let rot = &f[i + 1].r;
            posed.axes[i] = [f[i].r[0][2], f[i].r[1][2], f[i].r[2][2]];
            posed.mass[i] = b.mass;
            posed.com[i] = add(f[i + 1].t, mat_vec(rot, b.com));
            // The inertia in base axes: R I Rᵀ.
            posed.inertia[i] = std::array::from_fn(|r_| {
                std::array::from_fn(|c_| {
                    (0..3)
                        .map(|k| {
                            (0..3)
                                .map(|m| rot[r_][k] * b.inertia[k][m] * rot[c_][m])
                                .sum::<f64>()
                        })
                        .sum()
                })
            });
        }
        posed
    }

    /// The joint torques that give the joints moving at `qd` the accelerations `qdd`,
    /// without gravity (recursive Newton–Euler).
    fn torques(&self, qd: [f64; 6], qdd: [f64; 6]) -> [f64; 6] {
        // Forward: each link's angular speed and acceleration, its frame origin's and its
        // centre of mass's accelerations.
        let mut w = [0.0; 3];
        let mut wd = [0.0; 3];
        let mut a_origin = [0.0; 3]; // acceleration of the previous frame's origin
        let mut force = [[0.0; 3]; 6]; // m · a of each centre of mass
        let mut moment = [[0.0; 3]; 6]; // I α + ω × I ω of each link, about its centre of mass
        for i in 0..6 {
            let z = self.axes[i];
            let w_prev = w;
            w = add(w, scale(qd[i], z));
            wd = add(add(wd, scale(qdd[i], z)), scale(qd[i], cross(w_prev, z)));
            let r = sub(self.origins[i + 1], self.origins[i]);
            let a_next = add(add(a_origin, cross(wd, r)), cross(w, cross(w, r)));
            let rc = sub(self.com[i], self.origins[i + 1]);
            let a_c = add(add(a_next, cross(wd, rc)), cross(w, cross(w, rc)));
            let inertia = &self.inertia[i];
            force[i] = scale(self.mass[i], a_c);
            moment[i] = add(mat_vec(inertia, wd), cross(w, mat_vec(inertia, w)));
            a_origin = a_next;
        }
        // Backward: the force and moment each joint passes on, the torque about its axis.
        let mut tau = [0.0; 6];
        let mut f_next = [0.0; 3];
        let mut n_next = [0.0; 3];
        for i in (0..6).rev() {
            let o = self.origins[i];
            let f_i = add(force[i], f_next);
            let n_i = add(
                add(add(moment[i], n_next), cross(sub(self.com[i], o), force[i])),
                cross(sub(self.origins[i + 1], o), f_next),
            );
            tau[i] = dot(n_i, self.axes[i]);
            f_next = f_i;
            n_next = n_i;
        }
        tau
    }
}

/// The joint-space mass (inertia) matrix at joints `q` with `payload` at the flange:
/// symmetric, positive definite, kg·m² (rows and columns by joint).
#[allow(clippy::needless_range_loop)] // the two halves of a symmetric matrix
pub fn mass_matrix(model: Model, q: [f64; 6], payload: &Payload) -> [[f64; 6]; 6] {
    let posed = Posed::new(model, q, payload);
    let mut m = [[0.0; 6]; 6];
    for j in 0..6 {
        let mut e = [0.0; 6];
        e[j] = 1.0;
        let col = posed.torques([0.0; 6], e);
        for (row, v) in m.iter_mut().zip(col) {
            row[j] = v;
        }
    }
    // Exactly symmetric (the two halves differ by rounding only).
    for i in 0..6 {
        for j in 0..i {
            let v = 0.5 * (m[i][j] + m[j][i]);
            m[i][j] = v;
            m[j][i] = v;
        }
    }
    m
}

/// The Coriolis and centrifugal joint torques (Nm) when the joints at `q` move at `qd`:
/// `C(q, qd) · qd`, what keeping those speeds takes, without gravity.
pub fn coriolis_and_centrifugal_torques(
    model: Model,
    q: [f64; 6],
    qd: [f64; 6],
    payload: &Payload,
) -> [f64; 6] {
    Posed::new(model, q, payload).torques(qd, [0.0; 6])
}

/// The payload (mass, kg; centre of gravity from the flange in the flange frame, m)
/// that explains the wrenches measured at `poses`, as `estimate_payload(poses, wrenches)`
/// computes it: each wrench `[Fx, Fy, Fz, Tx, Ty, Tz]` is gravity acting on the payload,
/// at the tool flange but in the base's orientation, measured with the flange at the
/// matching pose (only its orientation counts). `gravity` is the gravity vector as
/// `set_gravity` gives it (its length is g).
///
/// The mass is the mean of `|F| / g`; the centre of gravity the least-squares solution of
/// `T_i = (R_i · cog) × F_i` over every pose. As the manual requires: at least four poses,
/// as many wrenches, and no two orientations closer than `π / (2n)` radians (`n` poses);
/// otherwise an error says what is wrong.
///
/// ```
/// use urscript_interp::kinematics::dynamics::estimate_payload;
/// let poses = [
///     [0.0, 0.0, 0.5, 0.0, 0.0, 0.0],
///     [0.0, 0.0, 0.5, 1.5, 0.0, 0.0],
///     [0.0, 0.0, 0.5, 0.0, 1.5, 0.0],
///     [0.0, 0.0, 0.5, 0.0, 0.0, 2.0],
/// ];
/// // 2 kg right at the flange: gravity pulls it down, and no torque at any pose.
/// let wrenches = [[0.0, 0.0, -19.64, 0.0, 0.0, 0.0]; 4];
/// let (mass, cog) = estimate_payload(&poses, &wrenches, [0.0, 0.0, 9.82]).unwrap();
/// assert!((mass - 2.0).abs() < 1e-12);
/// assert!(cog.iter().all(|c| c.abs() < 1e-12));
/// assert!(estimate_payload(&poses[..3], &wrenches[..3], [0.0, 0.0, 9.82]).is_err());
/// ```
pub fn estimate_payload(
    poses: &[[f64; 6]],
    wrenches: &[[f64; 6]],
    gravity: [f64; 3],
) -> Result<(f64, [f64; 3]), String> {
    let n = poses.len();
    if n < 4 {
        return Err(format!("needs at least 4 poses, {n} given"));
    }
    if wrenches.len() != n {
        return Err(format!(
            "needs one wrench per pose: {n} poses, {} wrenches",
            wrenches.len()
        ));
    }
    let g = dot(gravity, gravity).sqrt();
    if !(g.is_finite() && g > 0.0) {
        return Err("gravity is zero".to_string());
    }
    let rot: Vec<M3> = poses
        .iter()
        .map(|p| crate::arm::pose::to_matrix([p[3], p[4], p[5]]))
        .collect();
    let min = std::f64::consts::PI / (2.0 * n as f64);
    for i in 0..n {
        for j in 0..i {
            // The angle of Rᵢᵀ Rⱼ.
            let tr: f64 = (0..3)
                .map(|k| (0..3).map(|l| rot[i][l][k] * rot[j][l][k]).sum::<f64>())
                .sum();
            let angle = ((tr - 1.0) / 2.0).clamp(-1.0, 1.0).acos();
            if angle.is_nan() || angle < min {
                return Err(format!(
                    "poses {j} and {i} are {angle:.4} rad apart, less than pi/(2n) = {min:.4}"
                ));
            }
        }
    }
    let mass = wrenches
        .iter()
        .map(|w| (w[0] * w[0] + w[1] * w[1] + w[2] * w[2]).sqrt())
        .sum::<f64>()
        / (n as f64 * g);
    // T = (R c) × F = −[F]× R c: accumulate the normal equations AᵀA c = Aᵀ T.
    let mut ata = [[0.0; 3]; 3];
    let mut atb = [0.0; 3];
    for (r, w) in rot.iter().zip(wrenches) {
        let f = [w[0], w[1], w[2]];
        let fx = [[0.0, -f[2], f[1]], [f[2], 0.0, -f[0]], [-f[1], f[0], 0.0]];
        let a: M3 = std::array::from_fn(|i| {
            std::array::from_fn(|j| -(0..3).map(|k| fx[i][k] * r[k][j]).sum::<f64>())
        });
        for i in 0..3 {
            for j in 0..3 {
                ata[i][j] += (0..3).map(|k| a[k][i] * a[k][j]).sum::<f64>();
            }
            atb[i] += (0..3).map(|k| a[k][i] * w[3 + k]).sum::<f64>();
        }
    }
    let det = |m: &M3| dot(m[0], cross(m[1], m[2]));
    let d = det(&ata);
    if !(d.is_finite() && d.abs() > 1e-12) {
        return Err(
            "the wrenches do not determine a centre of gravity (no force measured?)".to_string(),
        );
    }
    // Cramer's rule: column i replaced by Aᵀ T.
    let cog = std::array::from_fn(|i| {
        let mut m = ata;
        for (row, b) in m.iter_mut().zip(atb) {
            row[i] = b;
        }
        det(&m) / d
    });
    Ok((mass, cog))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::arm::kinematics::MODELS;

    /// The kinetic energy `½ qdᵀ M qd` equals the links' own, summed from each centre of
    /// mass's speed (a numeric derivative of the forward kinematics) and each link's
    /// angular speed: the mass matrix is checked against a second, independent sum.
    #[test]
    fn the_mass_matrix_gives_the_links_kinetic_energy() {
        let q = [0.3, -1.1, 1.4, -0.7, 1.2, 0.5];
        let qd = [0.4, -0.3, 0.8, 0.5, -0.6, 0.9];
        let payload = Payload {
            mass: 2.0,
            cog: [0.01, 0.02, 0.05],
            inertia: [0.01, 0.02, 0.015, 0.001, 0.0, 0.002],
        };
        for model in MODELS {
            let m = mass_matrix(model, q, &payload);
            let from_m: f64 = 0.5
                * (0..6)
                    .map(|i| (0..6).map(|j| qd[i] * m[i][j] * qd[j]).sum::<f64>())
                    .sum::<f64>();
            let links = model.links();
            let com_at = |q: [f64; 6], i: usize, b: &Body| -> [f64; 3] {
                let f = frames(&model.dh(), q);
                add(f[i + 1].t, mat_vec(&f[i + 1].r, b.com))
            };
            let h = 1e-6;
            let qp: [f64; 6] = std::array::from_fn(|k| q[k] + h * qd[k]);
            let qm: [f64; 6] = std::array::from_fn(|k| q[k] - h * qd[k]);
            let f = frames(&model.dh(), q);
            let mut energy = 0.0;
            let mut w = [0.0; 3];
            for i in 0..6 {
                let z = [f[i].r[0][2], f[i].r[1][2], f[i].r[2][2]];
                w = add(w, scale(qd[i], z));
                let b = if i == 5 {
                    with_payload(&links[5], &payload)
                } else {
                    with_payload(&links[i], &Payload::NONE)
                };
                let v = scale(0.5 / h, sub(com_at(qp, i, &b), com_at(qm, i, &b)));
                let rot = &f[i + 1].r;
                // ω in the link's axes, then ½ ωᵀ I ω.
                let wl: [f64; 3] = std::array::from_fn(|k| (0..3).map(|j| rot[j][k] * w[j]).sum());
                energy += 0.5 * b.mass * dot(v, v) + 0.5 * dot(wl, mat_vec(&b.inertia, wl));
            }
            assert!(
                (from_m - energy).abs() < 1e-6 * energy.max(1.0),
                "{model}: {from_m} vs {energy}"
            );
        }
    }

    /// Wrenches made from a known payload at varied poses give it back.
    #[test]
    fn payload_estimation_recovers_the_payload_that_made_the_wrenches() {
        let (mass, cog) = (2.3, [0.03, -0.02, 0.11]);
        let gravity = [0.0, 0.0, 9.82];
        let poses: Vec<[f64; 6]> = [
            [0.0, 0.0, 0.0],
            [1.2, 0.0, 0.0],
            [0.0, 1.3, 0.0],
            [0.0, 0.0, 1.4],
            [0.8, -0.9, 0.5],
        ]
        .iter()
        .map(|r| [0.4, 0.1, 0.3, r[0], r[1], r[2]])
        .collect();
        let wrenches: Vec<[f64; 6]> = poses
            .iter()
            .map(|p| {
                let rc = mat_vec(&crate::arm::pose::to_matrix([p[3], p[4], p[5]]), cog);
                let f = scale(-mass, gravity);
                let t = cross(rc, f);
                [f[0], f[1], f[2], t[0], t[1], t[2]]
            })
            .collect();
        let (m, c) = estimate_payload(&poses, &wrenches, gravity).unwrap();
        assert!((m - mass).abs() < 1e-12, "{m}");
        for k in 0..3 {
            assert!((c[k] - cog[k]).abs() < 1e-9, "{c:?}");
        }
        // What the manual refuses.
        let e = estimate_payload(&poses[..3], &wrenches[..3], gravity).unwrap_err();
        assert_eq!(e, "needs at least 4 poses, 3 given");
        let e = estimate_payload(&poses, &wrenches[..4], gravity).unwrap_err();
        assert_eq!(e, "needs one wrench per pose: 5 poses, 4 wrenches");
        let mut close_poses = poses.clone();
        close_poses[4] = [0.4, 0.1, 0.3, 0.0, 0.0, 0.1];
        let e = estimate_payload(&close_poses, &wrenches, gravity).unwrap_err();
        assert!(e.starts_with("poses 0 and 4 are 0.1000 rad apart"), "{e}");
        let e = estimate_payload(&poses, &[[0.0; 6]; 5], gravity).unwrap_err();
        assert!(e.contains("do not determine"), "{e}");
        // Nothing panics on numbers that are not.
        let nan = [[f64::NAN; 6]; 5];
        assert!(estimate_payload(&nan, &nan, gravity).is_err());
    }

    #[test]
    fn a_heavier_payload_weighs_on_every_joint_that_carries_it() {
        let q = [0.0, -1.2, 1.0, -1.0, 1.3, 0.2];
        let light = mass_matrix(Model::Ur10e, q, &Payload::NONE);
        let heavy = mass_matrix(
            Model::Ur10e,
            q,
            &Payload {
                mass: 5.0,
                cog: [0.0, 0.0, 0.1],
                inertia: [0.0; 6],
            },
        );
        for i in 0..5 {
            assert!(heavy[i][i] > light[i][i], "joint {i}");
        }
    }
}
