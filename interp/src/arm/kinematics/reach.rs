//! The nearest the arm comes to a pose it cannot reach exactly: `get_inverse_kin`'s
//! `maxPositionError` and `maxOrientationError` are "the maximum allowed" errors, so a
//! pose out of exact reach still has a solution when the arm comes within both.
//!
//! Damped least squares from `qnear` on the model's forward kinematics (a numerical
//! Jacobian), at most [`MAX_ITERATIONS`] steps; the best joints seen are kept.

use super::{forward, Dh};
use crate::arm::pose::{mul, to_matrix, to_rotvec, transpose};

/// The most damped-least-squares steps: 200, far more than a reachable neighbourhood
/// needs (a few tens), and a bound on the time one call takes (about 1400 forward
/// kinematics).
pub(crate) const MAX_ITERATIONS: usize = 200;

/// The damping: keeps steps finite at and beyond the edge of the reach, where the
/// Jacobian loses rank.
const DAMPING: f64 = 0.05;

/// How far the joints at `q` leave the tool from `pose`: the position error (m) and the
/// orientation error (rad), with the 6-vector from the tool to the pose (translation,
/// rotation vector in the base frame).
fn error(dh: &Dh, q: [f64; 6], pose: [f64; 6], tcp: [f64; 6]) -> (f64, f64, [f64; 6]) {
    let at = forward(dh, q, tcp);
    let dp = [pose[0] - at[0], pose[1] - at[1], pose[2] - at[2]];
    let dr = to_rotvec(mul(
        to_matrix([pose[3], pose[4], pose[5]]),
        transpose(to_matrix([at[3], at[4], at[5]])),
    ));
    let norm = |v: [f64; 3]| (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    (
        norm(dp),
        norm(dr),
        [dp[0], dp[1], dp[2], dr[0], dr[1], dr[2]],
    )
}

/// Solves `a x = b` (6×6) by elimination with partial pivoting; `None` if singular.
fn solve(mut a: [[f64; 6]; 6], mut b: [f64; 6]) -> Option<[f64; 6]> {
    for col in 0..6 {
        let pivot = (col..6).max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))?;
        if a[pivot][col].abs() < 1e-15 || !a[pivot][col].is_finite() {
            return None;
        }
        a.swap(col, pivot);
        b.swap(col, pivot);
        let top = a[col];
        for row in col + 1..6 {
            let f = a[row][col] / top[col];
            for (v, t) in a[row].iter_mut().zip(top).skip(col) {
                *v -= f * t;
            }
            b[row] -= f * b[col];
        }
    }
    let mut x = [0.0; 6];
    for row in (0..6).rev() {
        let s: f64 = (row + 1..6).map(|k| a[row][k] * x[k]).sum();
        x[row] = (b[row] - s) / a[row][row];
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// The joints from `qnear` that bring the tool nearest `pose`, with their position error
/// (m) and orientation error (rad).
pub(crate) fn nearest_reach(
    dh: &Dh,
    pose: [f64; 6],
    tcp: [f64; 6],
    qnear: [f64; 6],
) -> ([f64; 6], f64, f64) {
    let mut q = qnear;
    let (mut p, mut o, mut e) = error(dh, q, pose, tcp);
    let mut best = (q, p, o);
    for _ in 0..MAX_ITERATIONS {
        if p < 1e-12 && o < 1e-12 {
            break;
        }
        // The Jacobian of the error's change, column by column.
        let h = 1e-7;
        let mut j = [[0.0; 6]; 6];
        for k in 0..6 {
            let mut qk = q;
            qk[k] += h;
            let (_, _, ek) = error(dh, qk, pose, tcp);
            for r in 0..6 {
                // The error falls as the tool moves toward the pose.
                j[r][k] = (e[r] - ek[r]) / h;
            }
        }
        // (JᵀJ + λ²I) dq = Jᵀe
        let mut a = [[0.0; 6]; 6];
        let mut b = [0.0; 6];
        for r in 0..6 {
            for c in 0..6 {
                a[r][c] = (0..6).map(|k| j[k][r] * j[k][c]).sum();
            }
            a[r][r] += DAMPING * DAMPING;
            b[r] = (0..6).map(|k| j[k][r] * e[k]).sum();
        }
        let Some(dq) = solve(a, b) else { break };
        for k in 0..6 {
            q[k] += dq[k];
        }
        (p, o, e) = error(dh, q, pose, tcp);
        if !(p.is_finite() && o.is_finite()) {
            break;
        }
        if p + o < best.1 + best.2 {
            best = (q, p, o);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::Model;

    #[test]
    fn a_pose_out_of_reach_is_approached_as_near_as_the_arm_comes() {
        let dh = Model::Ur5e.dh();
        // The arm stretched out (elbow straight), the pose 5 mm further out than the tool.
        let stretched = [0.0, -0.3, 0.0, -1.2, -1.57, 0.0];
        let at = forward(&dh, stretched, [0.0; 6]);
        let out = [at[0], at[1], at[2] - dh.d[0]];
        let n = (out[0] * out[0] + out[1] * out[1] + out[2] * out[2]).sqrt();
        let pose = [
            at[0] + 0.005 * out[0] / n,
            at[1] + 0.005 * out[1] / n,
            at[2] + 0.005 * out[2] / n,
            at[3],
            at[4],
            at[5],
        ];
        let (q, p, o) = nearest_reach(&dh, pose, [0.0; 6], [0.0, -0.5, 0.3, -1.2, -1.5, 0.1]);
        let (pq, oq, _) = error(&dh, q, pose, [0.0; 6]);
        assert_eq!((p, o), (pq, oq));
        assert!(p > 0.0005 && p < 0.0055 && o < 0.05, "{p} {o}");
        // A reachable pose comes back exactly.
        let q0 = [0.3, -1.2, 1.4, -1.8, -1.57, 0.2];
        let target = forward(&dh, q0, [0.0; 6]);
        let (_, p, o) = nearest_reach(&dh, target, [0.0; 6], [0.2, -1.1, 1.3, -1.7, -1.5, 0.1]);
        assert!(p < 1e-9 && o < 1e-9, "{p} {o}");
    }
}
