//! Forward and inverse kinematics of every UR model: round trips over many joint
//! positions, the known zero pose, reach limits, and move times.

use std::f64::consts::FRAC_PI_2;

use urscript_interp::kinematics::{
    forward, inverse, move_time, nearest, pose_error, Model, MODELS,
};

/// A deterministic generator (xorshift), so a failure names a reproducible case.
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64
    }
    fn angle(&mut self, span: f64) -> f64 {
        (self.next() * 2.0 - 1.0) * span
    }
}

#[test]
fn inverse_undoes_forward_for_every_model() {
    let mut rng = Rng(0x9E37_79B9_7F4A_7C15);
    for model in MODELS {
        let dh = model.dh();
        let mut checked = 0;
        for _ in 0..400 {
            let q = [0; 6].map(|_| rng.angle(3.1));
            // Away from the singularities, where joints are not unique.
            if q[4].sin().abs() < 0.05 || q[2].sin().abs() < 0.05 {
                continue;
            }
            let tcp = [0.0, 0.0, rng.next() * 0.2, 0.0, 0.0, rng.angle(1.0)];
            let pose = forward(&dh, q, tcp);
            let solutions = inverse(&dh, pose, tcp, q);
            assert!(!solutions.is_empty(), "{model}: no solution for {q:?}");
            assert!(solutions.len() <= 8);
            for s in &solutions {
                assert!(
                    pose_error(forward(&dh, *s, tcp), pose) < 1e-7,
                    "{model} {s:?}"
                );
                assert!(s.iter().all(|x| x.abs() <= std::f64::consts::TAU + 1e-9));
            }
            let best = nearest(&solutions, q).unwrap();
            for (a, b) in best.iter().zip(q) {
                assert!((a - b).abs() < 1e-7, "{model}: {best:?} is not {q:?}");
            }
            checked += 1;
        }
        assert!(checked > 300, "{model}: only {checked} cases");
    }
}

#[test]
fn the_zero_position_is_where_the_dh_parameters_put_it() {
    // All joints at 0: the arm lies along -x; the flange at (a2 + a3, -(d4 + d6), d1 - d5),
    // its z axis along -y: a rotation of π/2 about x.
    for model in MODELS {
        let d = model.dh();
        let p = forward(&d, [0.0; 6], [0.0; 6]);
        let want = [d.a[1] + d.a[2], -(d.d[3] + d.d[5]), d.d[0] - d.d[4]];
        for i in 0..3 {
            assert!((p[i] - want[i]).abs() < 1e-12, "{model}: {p:?}");
        }
        assert!(
            pose_error(p, [p[0], p[1], p[2], FRAC_PI_2, 0.0, 0.0]) < 1e-9,
            "{model}: {p:?}"
        );
    }
    // UR5e's published zero pose.
    let p = forward(&Model::Ur5e.dh(), [0.0; 6], [0.0; 6]);
    assert!((p[0] + 0.8172).abs() < 1e-12 && (p[1] + 0.2329).abs() < 1e-12);
    assert!((p[2] - 0.0628).abs() < 1e-12);
}

#[test]
fn a_pose_out_of_reach_has_no_solution() {
    let dh = Model::Ur5e.dh();
    assert!(inverse(&dh, [2.0, 0.0, 0.5, 0.0, 3.1, 0.0], [0.0; 6], [0.0; 6]).is_empty());
    assert!(inverse(&dh, [f64::NAN, 0.0, 0.5, 0.0, 0.0, 0.0], [0.0; 6], [0.0; 6]).is_empty());
    // The upright "home" pose (a wrist singularity: joint 6 takes qnear's value) and the
    // usual ready pose, tool down in front of the robot (x and y negative, as in UR's
    // examples), are reachable and found again.
    for home in [
        [0.0, -FRAC_PI_2, 0.0, -FRAC_PI_2, 0.0, 0.0],
        [0.0, -FRAC_PI_2, FRAC_PI_2, -FRAC_PI_2, -FRAC_PI_2, 0.0],
    ] {
        let p = forward(&dh, home, [0.0; 6]);
        let back = nearest(&inverse(&dh, p, [0.0; 6], home), home).expect("a solution");
        assert!(
            back.iter().zip(home).all(|(a, b)| (a - b).abs() < 1e-7),
            "{back:?}"
        );
    }
    let ready = forward(
        &dh,
        [0.0, -FRAC_PI_2, FRAC_PI_2, -FRAC_PI_2, -FRAC_PI_2, 0.0],
        [0.0; 6],
    );
    assert!(
        ready[0] < 0.0 && ready[1] < 0.0 && ready[2] > 0.0,
        "{ready:?}"
    );
}

#[test]
fn tool_down_poses_near_a_half_turn_keep_every_solution() {
    // Rotations by nearly π (a tool pointing down, as vision programs compute them) are
    // where a rotation vector is least precise; all 8 solutions must survive.
    let dh = Model::Ur5e.dh();
    let h = std::f64::consts::FRAC_PI_2;
    let qnear = [0.0, -h, h, -h, -h, 0.0];
    for angle in [
        std::f64::consts::PI,
        std::f64::consts::PI - 1.8e-6,
        // A half turn written with 4 decimals, as programs do: a bit more than π.
        std::f64::consts::PI + 7.3e-6,
        3.0,
    ] {
        for axis in [[0.0f64, 1.0, 0.0], [-1.0, -1.0, 0.0], [1.0, 0.0, 0.01]] {
            let n: f64 = (axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]).sqrt();
            let r = axis.map(|a| a / n * angle);
            let pose = [0.2875, -0.23, 0.25, r[0], r[1], r[2]];
            let solutions = inverse(&dh, pose, [0.0; 6], qnear);
            assert_eq!(solutions.len(), 8, "{pose:?}");
            for s in solutions {
                assert!(
                    pose_error(forward(&dh, s, [0.0; 6]), pose) < 1e-9,
                    "{pose:?}"
                );
            }
        }
    }
}

#[test]
fn move_times_follow_a_trapezoid() {
    assert_eq!(move_time(0.0, 1.0, 1.0), 0.0);
    assert_eq!(move_time(1.0, 0.0, 1.0), 0.0);
    assert_eq!(move_time(f64::NAN, 1.0, 1.0), 0.0);
    // Longer distances take longer; a higher acceleration never slows a move.
    let mut last = 0.0;
    for i in 1..100 {
        let d = f64::from(i) * 0.05;
        let t = move_time(d, 1.05, 1.4);
        assert!(t > last);
        assert!(move_time(d, 1.05, 2.8) <= t);
        last = t;
    }
}

#[test]
fn models_parse_by_name() {
    for m in MODELS {
        assert_eq!(m.name().to_lowercase().parse::<Model>(), Ok(m));
    }
    assert_eq!(Model::default(), Model::Ur5e);
}
