//! Property tests of the arm model behind `get_jacobian`, `get_jacobian_time_derivative`,
//! `get_mass_matrix` and `get_coriolis_and_centrifugal_torques`: each checked against a
//! numeric derivative of something computed another way.
#![allow(clippy::needless_range_loop)] // matrices by row and column

use proptest::prelude::*;
use urscript_interp::kinematics::dynamics::{self, Payload};
use urscript_interp::kinematics::{forward, jacobian, jacobian_time_derivative, Model, MODELS};

/// The rotation matrix of a rotation vector (Rodrigues).
fn matrix(r: [f64; 3]) -> [[f64; 3]; 3] {
    let t = (r[0] * r[0] + r[1] * r[1] + r[2] * r[2]).sqrt();
    let mut m = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    if t < 1e-15 {
        return m;
    }
    let k = [r[0] / t, r[1] / t, r[2] / t];
    let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
    let (s, c) = t.sin_cos();
    for i in 0..3 {
        for j in 0..3 {
            let kk: f64 = (0..3).map(|l| kx[i][l] * kx[l][j]).sum();
            m[i][j] += s * kx[i][j] + (1.0 - c) * kk;
        }
    }
    m
}

/// The tool's twist from a central difference of the forward kinematics along `dq`.
fn numeric_twist(
    dh: &urscript_interp::kinematics::Dh,
    q: [f64; 6],
    dq: [f64; 6],
    tcp: [f64; 6],
) -> [f64; 6] {
    let h = 1e-6;
    let plus = forward(dh, std::array::from_fn(|k| q[k] + h * dq[k]), tcp);
    let minus = forward(dh, std::array::from_fn(|k| q[k] - h * dq[k]), tcp);
    let (rp, rm) = (
        matrix([plus[3], plus[4], plus[5]]),
        matrix([minus[3], minus[4], minus[5]]),
    );
    // R+ R-ᵀ ≈ I + 2h [ω]×.
    let d: [[f64; 3]; 3] =
        std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| rp[i][k] * rm[j][k]).sum()));
    [
        (plus[0] - minus[0]) / (2.0 * h),
        (plus[1] - minus[1]) / (2.0 * h),
        (plus[2] - minus[2]) / (2.0 * h),
        (d[2][1] - d[1][2]) / (4.0 * h),
        (d[0][2] - d[2][0]) / (4.0 * h),
        (d[1][0] - d[0][1]) / (4.0 * h),
    ]
}

fn mat_vec(m: &[[f64; 6]; 6], v: [f64; 6]) -> [f64; 6] {
    std::array::from_fn(|i| (0..6).map(|j| m[i][j] * v[j]).sum())
}

fn joints() -> impl Strategy<Value = [f64; 6]> {
    prop::array::uniform6(-3.0f64..3.0)
}

fn speeds() -> impl Strategy<Value = [f64; 6]> {
    prop::array::uniform6(-2.0f64..2.0)
}

fn tcps() -> impl Strategy<Value = [f64; 6]> {
    (
        prop::array::uniform3(-0.2f64..0.2),
        prop::array::uniform3(-2.0f64..2.0),
    )
        .prop_map(|(t, r)| [t[0], t[1], t[2], r[0], r[1], r[2]])
}

fn model() -> impl Strategy<Value = Model> {
    prop::sample::select(MODELS.to_vec())
}

/// Cholesky: succeeds only on a symmetric positive-definite matrix.
fn is_positive_definite(m: &[[f64; 6]; 6]) -> bool {
    let mut l = [[0.0; 6]; 6];
    for i in 0..6 {
        for j in 0..=i {
            let s: f64 = m[i][j] - (0..j).map(|k| l[i][k] * l[j][k]).sum::<f64>();
            if i == j {
                if s <= 0.0 {
                    return false;
                }
                l[i][i] = s.sqrt();
            } else {
                l[i][j] = s / l[j][j];
            }
        }
    }
    true
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(200))]

    /// `J · dq` is the speed at which the forward kinematics' pose moves along `dq`.
    #[test]
    fn the_jacobian_is_the_derivative_of_the_forward_kinematics(
        model in model(), q in joints(), dq in speeds(), tcp in tcps()
    ) {
        let dh = model.dh();
        let j = jacobian(&dh, q, tcp);
        let analytic = mat_vec(&j, dq);
        let numeric = numeric_twist(&dh, q, dq, tcp);
        for k in 0..6 {
            prop_assert!((analytic[k] - numeric[k]).abs() < 1e-6, "{model} row {k}: {analytic:?} vs {numeric:?}");
        }
    }

    /// `Jd(q, qd)` is the rate of change of `J` along `qd`.
    #[test]
    fn the_jacobian_time_derivative_is_the_rate_of_change_of_the_jacobian(
        model in model(), q in joints(), qd in speeds(), tcp in tcps()
    ) {
        let dh = model.dh();
        let h = 1e-6;
        let jp = jacobian(&dh, std::array::from_fn(|k| q[k] + h * qd[k]), tcp);
        let jm = jacobian(&dh, std::array::from_fn(|k| q[k] - h * qd[k]), tcp);
        let jd = jacobian_time_derivative(&dh, q, qd, tcp);
        for r in 0..6 {
            for c in 0..6 {
                let numeric = (jp[r][c] - jm[r][c]) / (2.0 * h);
                prop_assert!((jd[r][c] - numeric).abs() < 1e-6, "{model} [{r}][{c}]: {} vs {numeric}", jd[r][c]);
            }
        }
    }

    /// The mass matrix is symmetric and positive definite, with or without a payload.
    #[test]
    fn the_mass_matrix_is_symmetric_positive_definite(
        model in model(), q in joints(), mass in 0.0f64..20.0, cog in prop::array::uniform3(-0.2f64..0.2)
    ) {
        let payload = Payload { mass, cog, inertia: [0.0; 6] };
        let m = dynamics::mass_matrix(model, q, &payload);
        for i in 0..6 {
            for j in 0..6 {
                prop_assert_eq!(m[i][j], m[j][i]);
            }
        }
        prop_assert!(is_positive_definite(&m), "{model} at {q:?}: {m:?}");
    }

    /// The Coriolis and centrifugal torques are those of the same mass matrix, by
    /// Lagrange's equations: `c_i = Σ_jk (∂M_ij/∂q_k − ½ ∂M_jk/∂q_i) qd_j qd_k`, with the
    /// partial derivatives taken numerically; and they grow with the square of the speeds.
    #[test]
    fn the_coriolis_torques_match_the_mass_matrix(
        model in model(), q in joints(), qd in speeds(), mass in 0.0f64..10.0
    ) {
        // A payload off the flange axis whose inertia differs about each axis: its
        // gyroscopic torque counts too.
        let p = Payload { mass, cog: [0.02, -0.01, 0.08], inertia: [0.02, 0.05, 0.01, 0.003, -0.002, 0.001] };
        let h = 1e-5;
        let dm: [[[f64; 6]; 6]; 6] = std::array::from_fn(|k| {
            let mut qp = q;
            let mut qm = q;
            qp[k] += h;
            qm[k] -= h;
            let (mp, mm) = (dynamics::mass_matrix(model, qp, &p), dynamics::mass_matrix(model, qm, &p));
            std::array::from_fn(|i| std::array::from_fn(|j| (mp[i][j] - mm[i][j]) / (2.0 * h)))
        });
        let c = dynamics::coriolis_and_centrifugal_torques(model, q, qd, &p);
        for i in 0..6 {
            let lagrange: f64 = (0..6)
                .map(|j| (0..6).map(|k| (dm[k][i][j] - 0.5 * dm[i][j][k]) * qd[j] * qd[k]).sum::<f64>())
                .sum();
            prop_assert!((c[i] - lagrange).abs() < 1e-5 * (1.0 + lagrange.abs()), "{model} joint {i}: {} vs {lagrange}", c[i]);
        }
        let c2 = dynamics::coriolis_and_centrifugal_torques(model, q, qd.map(|x| 2.0 * x), &p);
        for k in 0..6 {
            prop_assert!((c2[k] - 4.0 * c[k]).abs() < 1e-9 * (1.0 + c[k].abs()));
        }
    }
}

#[test]
fn at_rest_there_are_no_coriolis_torques() {
    for model in MODELS {
        let c = dynamics::coriolis_and_centrifugal_torques(
            model,
            [0.1, -1.0, 1.2, 0.3, 0.4, 0.5],
            [0.0; 6],
            &Payload::NONE,
        );
        assert_eq!(c, [0.0; 6], "{model}");
    }
}
