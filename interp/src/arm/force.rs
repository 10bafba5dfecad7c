//! Force mode and contact on the virtual arm (`force_mode`, `end_force_mode`,
//! `get_tcp_force`, `force`, `tool_contact`; RTDE's `actual_TCP_force`).
//!
//! - **Contact**: the world may hold one plane ([`World::contact_plane`](crate::World::contact_plane),
//!   a pose whose z axis is the surface's outward normal; the obstacle fills the
//!   half-space below it) with a stiffness ([`World::contact_stiffness`](crate::World::contact_stiffness),
//!   N/m; 0, the default, is no plane: free space). A TCP `d` metres below the surface
//!   feels `stiffness · d` newtons along the normal (a spring at the TCP: no torque). The
//!   force sensor reads [`World::tcp_force`](crate::World::tcp_force) plus that force, in
//!   the base frame. Any motion may press into the plane (the arm does not stop there by
//!   itself); `tool_contact()` sees it.
//! - **Force mode** (the script manual's `force_mode(task_frame, selection_vector, wrench,
//!   type, limits)`): along each compliant axis of the task frame the arm moves so that
//!   the force it applies to the world along that axis reaches the wrench's. In free
//!   space nothing resists, so it moves at that axis's speed limit (`limits`) toward the
//!   wrench's sign (none for a zero wrench); against the plane it moves to the depth where
//!   the spring's force balances the wrench, never faster than the limit, and stays there.
//!   A compliant rotation with a torque turns at its limit (no contact torque is
//!   modelled). Non-compliant axes follow the program: the motion under way (`speedl`,
//!   `servoj`, `movel`...) or the pose the program last put the tool at. Type 2 takes the
//!   task frame as given; type 1 turns it so its y axis points from the TCP to its
//!   origin; type 3 so its x axis is the TCP's velocity projected onto its x-y plane (both
//!   as given when that direction is undefined). Damping and gain scaling are stored, not
//!   used; force mode runs in real time (the speed slider does not scale it).
//!   `end_force_mode()`, the program's end, `teach_mode()` and `freedrive_mode()` end it.

use crate::arm::kinematics::{self, Dh};
use crate::arm::pose::{mul, to_matrix, to_rotvec};
use crate::arm::vec3::{cross, dot};

type M = [[f64; 3]; 3];

/// An active `force_mode`.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct ForceMode {
    /// The task frame (base coordinates).
    pub frame: [f64; 6],
    /// The compliant axes (x, y, z, rx, ry, rz of the task frame).
    pub selection: [bool; 6],
    /// The force (N) and torque (Nm) the arm applies to the world along/about each axis.
    pub wrench: [f64; 6],
    /// 1, 2 or 3 (see the module docs).
    pub kind: u8,
    /// The speed limits of the compliant axes (m/s, rad/s).
    pub limits: [f64; 6],
    /// What force mode added to the program's motion so far: a translation (m) and a
    /// rotation vector (rad), both in the base frame.
    pub offset: [f64; 6],
    /// The tool pose the program last put the arm at (the motion's, without the offset).
    pub programmed: [f64; 6],
    /// The last step force mode moved the arm in.
    pub at: u64,
}

fn rot(p: [f64; 6]) -> M {
    to_matrix([p[3], p[4], p[5]])
}

fn unit(a: [f64; 3]) -> Option<[f64; 3]> {
    let n = dot(a, a).sqrt();
    (n > 1e-9 && n.is_finite()).then(|| [a[0] / n, a[1] / n, a[2] / n])
}

fn column(m: &M, k: usize) -> [f64; 3] {
    [m[0][k], m[1][k], m[2][k]]
}

/// The rotation whose columns are `x`, `y`, `z`.
fn from_columns(x: [f64; 3], y: [f64; 3], z: [f64; 3]) -> M {
    [[x[0], y[0], z[0]], [x[1], y[1], z[1]], [x[2], y[2], z[2]]]
}

/// `programmed` moved by `offset` (translation added, rotation turned about base axes).
pub(crate) fn offset_pose(programmed: [f64; 6], offset: [f64; 6]) -> [f64; 6] {
    let r = to_rotvec(mul(
        to_matrix([offset[3], offset[4], offset[5]]),
        rot(programmed),
    ));
    [
        programmed[0] + offset[0],
        programmed[1] + offset[1],
        programmed[2] + offset[2],
        r[0],
        r[1],
        r[2],
    ]
}

/// How far (m) the point `p` is below the contact plane `plane` (negative: above it),
/// and the plane's outward normal (base frame).
fn depth(plane: [f64; 6], p: [f64; 3]) -> (f64, [f64; 3]) {
    let n = column(&rot(plane), 2);
    let rel = [p[0] - plane[0], p[1] - plane[1], p[2] - plane[2]];
    (-dot(n, rel), n)
}

/// The force (N, base frame; no torque) the contact plane puts on a TCP at `pose`: zero
/// off the plane or with no plane (`stiffness` 0 or less).
pub(crate) fn contact_force(plane: [f64; 6], stiffness: f64, pose: [f64; 6]) -> [f64; 6] {
    if !(stiffness > 0.0 && stiffness.is_finite()) {
        return [0.0; 6];
    }
    let (d, n) = depth(plane, [pose[0], pose[1], pose[2]]);
    if d > 0.0 {
        let f = stiffness * d;
        [f * n[0], f * n[1], f * n[2], 0.0, 0.0, 0.0]
    } else {
        [0.0; 6]
    }
}

impl ForceMode {
    /// The task frame's axes (base frame) for a TCP at `tcp` moving at `v` (m/s).
    fn axes(&self, tcp: [f64; 6], v: [f64; 3]) -> M {
        let r = rot(self.frame);
        let z0 = column(&r, 2);
        let turned = match self.kind {
            1 => unit([
                self.frame[0] - tcp[0],
                self.frame[1] - tcp[1],
                self.frame[2] - tcp[2],
            ])
            .and_then(|y| {
                let z = unit([
                    z0[0] - dot(z0, y) * y[0],
                    z0[1] - dot(z0, y) * y[1],
                    z0[2] - dot(z0, y) * y[2],
                ])?;
                Some(from_columns(cross(y, z), y, z))
            }),
            3 => {
                let along = dot(v, z0);
                unit([
                    v[0] - along * z0[0],
                    v[1] - along * z0[1],
                    v[2] - along * z0[2],
                ])
                .map(|x| from_columns(x, cross(z0, x), z0))
            }
            _ => None,
        };
        turned.unwrap_or(r)
    }

    /// Moves the force mode's offset on by `dt` seconds for a tool now at `actual`
    /// (moving at `v`), against the contact plane (`stiffness` 0: none).
    pub fn step(
        &mut self,
        actual: [f64; 6],
        v: [f64; 3],
        dt: f64,
        plane: [f64; 6],
        stiffness: f64,
    ) {
        if !(dt > 0.0 && dt.is_finite()) {
            return;
        }
        let axes = self.axes(actual, v);
        let contact = stiffness > 0.0 && stiffness.is_finite();
        let (mut d, n) = depth(plane, [actual[0], actual[1], actual[2]]);
        for k in 0..3 {
            if !self.selection[k] {
                continue;
            }
            let u = column(&axes, k);
            let w = self.wrench[k];
            let cap = self.limits[k].abs() * dt;
            let nu = dot(n, u);
            // The depth at which the spring's force along `u` balances the wrench (the
            // world pushes back with -w along u).
            let balance = if contact && nu.abs() > 1e-9 {
                Some(-w / (stiffness * nu)).filter(|b| *b >= 0.0)
            } else {
                None
            };
            let s = match balance {
                // Only the plane can balance it: move to that depth (from above it too).
                Some(b) if w != 0.0 || d > 0.0 => (d - b) / nu,
                Some(_) => 0.0,
                // Nothing resists: at the limit toward the wrench.
                None if w != 0.0 => cap * w.signum(),
                None => 0.0,
            };
            let s = s.clamp(-cap, cap);
            if contact {
                d -= nu * s;
            }
            for (o, uk) in self.offset[..3].iter_mut().zip(u) {
                *o += s * uk;
            }
        }
        for k in 3..6 {
            let w = self.wrench[k];
            if !self.selection[k] || w == 0.0 {
                continue;
            }
            let u = column(&axes, k - 3);
            let a = self.limits[k].abs() * dt * w.signum();
            let turned = to_rotvec(mul(
                to_matrix([u[0] * a, u[1] * a, u[2] * a]),
                to_matrix([self.offset[3], self.offset[4], self.offset[5]]),
            ));
            self.offset[3..].copy_from_slice(&turned);
        }
    }
}

/// The joints nearest `near` that put the tool (offset `tcp`) at `pose`.
pub(crate) fn joints_at(
    dh: &Dh,
    pose: [f64; 6],
    tcp: [f64; 6],
    near: [f64; 6],
) -> Option<[f64; 6]> {
    kinematics::nearest(&kinematics::inverse(dh, pose, tcp, near), near)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(kind: u8, selection: [bool; 6], wrench: [f64; 6]) -> ForceMode {
        ForceMode {
            frame: [0.5, 0.0, 0.2, 0.0, 0.0, 0.0],
            selection,
            wrench,
            kind,
            limits: [0.1; 6],
            offset: [0.0; 6],
            programmed: [0.0; 6],
            at: 0,
        }
    }

    #[test]
    fn type_1_turns_y_toward_the_frames_origin_and_type_3_x_along_the_velocity() {
        // The TCP 0.5 m from the origin along -x: y points to +x.
        let tcp = [0.0, 0.0, 0.2, 0.0, 0.0, 0.0];
        let mut m = mode(
            1,
            [false, true, false, false, false, false],
            [0.0, 5.0, 0.0, 0.0, 0.0, 0.0],
        );
        m.step(tcp, [0.0; 3], 1.0, [0.0; 6], 0.0);
        assert!(
            (m.offset[0] - 0.1).abs() < 1e-12 && m.offset[1].abs() < 1e-12,
            "{:?}",
            m.offset
        );
        // Moving along base y: x is that direction.
        let mut m = mode(
            3,
            [true, false, false, false, false, false],
            [5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        m.step(tcp, [0.0, 0.3, 0.0], 1.0, [0.0; 6], 0.0);
        assert!(
            (m.offset[1] - 0.1).abs() < 1e-12 && m.offset[0].abs() < 1e-12,
            "{:?}",
            m.offset
        );
        // Type 2: the frame as given.
        let mut m = mode(
            2,
            [true, false, false, false, false, false],
            [-5.0, 0.0, 0.0, 0.0, 0.0, 0.0],
        );
        m.step(tcp, [0.0, 0.3, 0.0], 1.0, [0.0; 6], 0.0);
        assert!((m.offset[0] + 0.1).abs() < 1e-12, "{:?}", m.offset);
    }

    #[test]
    fn only_the_selected_axes_of_the_task_frame_move() {
        // Only z selected, a wrench on every axis, a tilted plane in contact.
        let tcp = [0.1, -0.2, 0.25, 0.0, 0.0, 0.0];
        let plane = [0.1, -0.2, 0.26, 0.0, 0.3, 0.0];
        for kind in [1, 2, 3] {
            let mut m = mode(
                kind,
                [false, false, true, false, false, false],
                [10.0, -10.0, -10.0, 1.0, -1.0, 1.0],
            );
            let v = [0.02, 0.01, 0.0];
            let axes = m.axes(tcp, v);
            m.step(tcp, v, 0.1, plane, 5000.0);
            let t = [m.offset[0], m.offset[1], m.offset[2]];
            assert!(dot(t, t) > 0.0, "type {kind}: z moves");
            for k in 0..2 {
                assert!(
                    dot(t, column(&axes, k)).abs() < 1e-12,
                    "type {kind}: axis {k} held: {:?}",
                    m.offset
                );
            }
            assert_eq!(m.offset[3..], [0.0; 3], "type {kind}: no turn");
        }
    }

    #[test]
    fn a_wrench_away_from_the_plane_leaves_it_and_a_zero_wrench_only_comes_out_of_it() {
        let plane = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        // 1 mm into the plane.
        let tcp = [0.3, 0.0, -0.001, 0.0, 0.0, 0.0];
        let mut m = mode(
            2,
            [false, false, true, false, false, false],
            [0.0, 0.0, 10.0, 0.0, 0.0, 0.0],
        );
        m.frame = [0.0; 6];
        m.step(tcp, [0.0; 3], 0.002, plane, 1000.0);
        assert!(
            (m.offset[2] - 0.0002).abs() < 1e-12,
            "pulls up at the limit: {:?}",
            m.offset
        );
        let mut m = mode(2, [false, false, true, false, false, false], [0.0; 6]);
        m.frame = [0.0; 6];
        m.step(tcp, [0.0; 3], 1.0, plane, 1000.0);
        assert!(
            (m.offset[2] - 0.001).abs() < 1e-12,
            "out to the surface: {:?}",
            m.offset
        );
        assert_eq!(contact_force(plane, 1000.0, tcp)[2], 1.0);
        assert_eq!(contact_force(plane, 0.0, tcp), [0.0; 6]);
    }
}
