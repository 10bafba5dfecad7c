//! The arm moves in time: anyone sampling it during a motion (the program's own threads,
//! or a controller streaming the arm at every step) sees it between its start and its
//! target, never a jump.
use std::time::Duration;

use urscript_interp::kinematics::{forward, move_time, Model};
use urscript_interp::{Config, Effect, Event, Machine, Program, RuntimeErrorKind, State};

const STEP: Duration = Duration::from_millis(2);
const HOME: [f64; 6] = [
    0.0,
    -std::f64::consts::FRAC_PI_2,
    0.0,
    -std::f64::consts::FRAC_PI_2,
    0.0,
    0.0,
];

fn machine(src: &str) -> Machine {
    Machine::new(Program::parse(src).unwrap(), Config::default())
}

/// Runs step by step until the program stops (or `limit`), calling `each` after every
/// step with the step's index.
fn steps(m: &mut Machine, limit: u32, mut each: impl FnMut(u32, &Machine)) -> u32 {
    for k in 0..limit {
        m.run_until(STEP * k);
        each(k, m);
        if m.state() != &State::Running {
            return k;
        }
    }
    limit
}

fn messages(m: &mut Machine) -> Vec<String> {
    std::iter::from_fn(|| m.poll_event())
        .filter_map(|e| match e {
            Event::Message(msg) => Some(msg.text),
            _ => None,
        })
        .collect()
}

#[test]
fn movej_with_defaults_takes_the_trapezoid_time_and_ends_exactly_at_its_target() {
    let q1 = [1.2, -1.2, 0.8, -1.9, 0.3, 0.4];
    let src = format!("movej({q1:?})\n");
    let mut m = machine(&src);
    let end = steps(&mut m, 5000, |_, _| {});
    assert_eq!(m.state(), &State::Finished);
    // The leading joint moves 1.2 rad: longer than v²/a = 0.7875 rad, so a trapezoid:
    // d/v + v/a = 1.142857 + 0.75 s.
    let d: f64 = 1.2;
    let (v, a) = (1.05, 1.4);
    let formula = d / v + v / a;
    assert!((move_time(d, v, a) - formula).abs() < 1e-12);
    let want = (formula / 0.002).ceil() as u32;
    assert_eq!(end, want, "the program ends in the step the move ends");
    assert_eq!(m.joint_positions(), q1);
    assert_eq!(m.arm().qd, [0.0; 6]);
}

#[test]
fn a_short_movej_is_a_triangle() {
    // 0.2 rad < v²/a: 2·sqrt(d/a).
    let mut m = machine("movej([0.2, -1.5707963267948966, 0, -1.5707963267948966, 0, 0])\n");
    let mut peak: f64 = 0.0;
    let end = steps(&mut m, 5000, |_, m| peak = peak.max(m.arm().qd[0]));
    let t = 2.0 * (0.2f64 / 1.4).sqrt();
    assert_eq!(end, (t / 0.002).ceil() as u32);
    // The peak speed is a·t/2 (sampled at a step, so at most that), below v.
    assert!(
        peak <= 1.4 * t / 2.0 + 1e-9 && peak > 1.4 * t / 2.0 - 1.4 * 0.002 - 1e-9,
        "{peak}"
    );
}

#[test]
fn a_sample_mid_move_lies_strictly_between_start_and_target() {
    let q1 = [1.0, -1.0, 0.5, -2.0, 0.5, -0.5];
    let mut m = machine(&format!("movej({q1:?})\n"));
    m.run_until(Duration::from_millis(700));
    let q = m.joint_positions();
    for k in 0..6 {
        let (lo, hi) = if HOME[k] < q1[k] {
            (HOME[k], q1[k])
        } else {
            (q1[k], HOME[k])
        };
        assert!(
            lo < q[k] && q[k] < hi,
            "joint {k}: {} not in ({lo}, {hi})",
            q[k]
        );
        // All joints are at the same fraction of their way.
        let f = (q[k] - HOME[k]) / (q1[k] - HOME[k]);
        let f0 = (q[0] - HOME[0]) / (q1[0] - HOME[0]);
        assert!((f - f0).abs() < 1e-9);
    }
    assert!(m.arm().qd.iter().any(|v| *v != 0.0));
    assert!(m.arm().tcp_speed.iter().any(|v| *v != 0.0));
}

#[test]
fn another_thread_sees_monotonic_progress_and_an_unsteady_arm() {
    let src = "thread watch():
  while True:
    q = get_actual_joint_positions()
    textmsg(q[0], is_steady())
    sync()
  end
end
h = run watch()
movej([1, -1.5707963267948966, 0, -1.5707963267948966, 0, 0])
kill h
textmsg(\"end \", is_steady())
";
    let mut m = machine(src);
    steps(&mut m, 5000, |_, _| {});
    assert_eq!(m.state(), &State::Finished);
    let msgs = messages(&mut m);
    assert_eq!(msgs.last().map(String::as_str), Some("end True"));
    let samples: Vec<(f64, bool)> = msgs[..msgs.len() - 1]
        .iter()
        .map(|s| {
            let steady = s.ends_with("True");
            let q = s.trim_end_matches("True").trim_end_matches("False");
            (q.parse().unwrap(), steady)
        })
        .collect();
    assert!(samples.len() > 500, "{}", samples.len());
    let mut rising = 0;
    for w in samples.windows(2) {
        assert!(w[1].0 >= w[0].0, "{w:?}");
        if w[1].0 > w[0].0 {
            rising += 1;
        }
    }
    assert!(rising > 500, "{rising}");
    // No jump: at most v·step per step (plus rounding).
    for w in samples.windows(2) {
        assert!(w[1].0 - w[0].0 <= 1.05 * 0.002 + 1e-9, "{w:?}");
    }
    // Not steady while it moves.
    assert!(samples[1..samples.len() - 1]
        .iter()
        .all(|(_, steady)| !steady));
}

#[test]
fn a_controller_sampling_the_arm_every_step_sees_no_jump() {
    let mut m = machine("movej([0.5, -1.4, 1.6, -1.8, -1.57, 0.1], a=3, v=2)\nmovel(pose_trans(get_actual_tcp_pose(), p[0.1, -0.05, 0.1, 0.2, 0, 0.3]))\n");
    let mut last = m.arm().q;
    let mut last_tcp = m.tcp_pose();
    let mut moved = 0;
    steps(&mut m, 10000, |_, m| {
        let q = m.arm().q;
        // Joints at most 2 rad/s (movej's v) apart per step, the tool at most movel's
        // 0.25 m/s or what the joint speeds give it (never the whole move at once).
        let d = (0..6).map(|k| (q[k] - last[k]).abs()).fold(0.0, f64::max);
        let p = m.tcp_pose();
        let dp = (0..3)
            .map(|k| (p[k] - last_tcp[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(d < 0.05 && dp < 0.004, "{last:?} -> {q:?}");
        if d > 0.0 {
            moved += 1;
        }
        last = q;
        last_tcp = p;
    });
    assert_eq!(m.state(), &State::Finished);
    assert!(moved > 100);
}

#[test]
fn movel_keeps_the_tool_on_the_straight_line() {
    let dh = Model::Ur5e.dh();
    let q0 = [0.3, -1.4, 1.6, -1.8, -1.57, 0.2];
    let p0 = forward(&dh, q0, [0.0; 6]);
    let p1 = [p0[0] + 0.15, p0[1] - 0.1, p0[2] + 0.05, p0[3], p0[4], p0[5]];
    let src = format!(
        "set_pos({q0:?})\nmovel(p[{}, {}, {}, {}, {}, {}])\n",
        p1[0], p1[1], p1[2], p1[3], p1[4], p1[5]
    );
    let mut m = machine(&src);
    let dir: Vec<f64> = (0..3).map(|k| p1[k] - p0[k]).collect();
    let len = dir.iter().map(|x| x * x).sum::<f64>().sqrt();
    let mut worst: f64 = 0.0;
    let mut inside = 0;
    let mut last_along = -1.0;
    let end = steps(&mut m, 10000, |_, m| {
        let p = m.tcp_pose();
        let rel: Vec<f64> = (0..3).map(|k| p[k] - p0[k]).collect();
        let along = (0..3).map(|k| rel[k] * dir[k]).sum::<f64>() / len;
        let off = (0..3)
            .map(|k| (rel[k] - along * dir[k] / len).powi(2))
            .sum::<f64>()
            .sqrt();
        worst = worst.max(off);
        assert!(along >= last_along - 1e-12);
        last_along = along;
        if along > 1e-4 && along < len - 1e-4 {
            inside += 1;
            // The tool moves along the line at no more than v.
            let v = m.arm().tcp_speed;
            let speed = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            assert!(speed <= 0.25 + 1e-9 && speed > 0.0, "{speed}");
        }
    });
    assert!(worst < 1e-6, "{worst}");
    assert!(inside > 100);
    let want = (move_time(len, 0.25, 1.2) / 0.002).ceil() as u32;
    assert_eq!(end, want);
    let p = m.tcp_pose();
    assert!((0..3).all(|k| (p[k] - p1[k]).abs() < 1e-9), "{p:?}");
}

#[test]
fn movec_passes_through_its_via_point() {
    let dh = Model::Ur5e.dh();
    let q0 = [0.3, -1.4, 1.6, -1.8, -1.57, 0.2];
    let p0 = forward(&dh, q0, [0.0; 6]);
    let r = 0.05;
    let via = [p0[0] + r, p0[1] + r, p0[2], p0[3], p0[4], p0[5]];
    let to = [p0[0] + 2.0 * r, p0[1], p0[2], p0[3], p0[4], p0[5]];
    let pose = |p: [f64; 6]| {
        format!(
            "p[{}, {}, {}, {}, {}, {}]",
            p[0], p[1], p[2], p[3], p[4], p[5]
        )
    };
    let mut m = machine(&format!(
        "set_pos({q0:?})\nmovec({}, {})\n",
        pose(via),
        pose(to)
    ));
    let centre = [p0[0] + r, p0[1], p0[2]];
    let mut nearest_via: f64 = 1.0;
    steps(&mut m, 10000, |_, m| {
        let p = m.tcp_pose();
        let d =
            ((p[0] - centre[0]).powi(2) + (p[1] - centre[1]).powi(2) + (p[2] - centre[2]).powi(2))
                .sqrt();
        assert!((d - r).abs() < 1e-6, "{d}");
        nearest_via = nearest_via.min(((p[0] - via[0]).powi(2) + (p[1] - via[1]).powi(2)).sqrt());
    });
    assert_eq!(m.state(), &State::Finished);
    assert!(nearest_via < 0.25 * 0.002 + 1e-9, "{nearest_via}");
}

#[test]
fn stopj_decelerates_to_zero() {
    let src = "speedj([0.5, -0.3, 0, 0, 0, 0], 1.0, 0.6)\nstopj(2.0)\ntextmsg(\"stopped\")\n";
    let mut m = machine(src);
    let mut speeds = Vec::new();
    let mut qs = Vec::new();
    steps(&mut m, 2000, |_, m| {
        speeds.push(m.arm().qd);
        qs.push(m.arm().q[0]);
    });
    assert_eq!(m.state(), &State::Finished);
    // Up at 1 rad/s² for 0.5 s, held, then down at 2 rad/s² in 0.25 s.
    let top = speeds.iter().map(|v| v[0]).fold(0.0, f64::max);
    assert!((top - 0.5).abs() < 1e-9, "{top}");
    let from = speeds.iter().position(|v| v[0] == top).unwrap();
    let down: Vec<f64> = speeds[from..].iter().map(|v| v[0]).collect();
    assert!(down.windows(2).all(|w| w[1] <= w[0] + 1e-12));
    assert_eq!(*down.last().unwrap(), 0.0);
    // Joint 1 in proportion (0.3 of 0.5), stopping together.
    assert!(speeds.iter().all(|v| (v[1] + 0.6 * v[0]).abs() < 1e-9));
    // 0.6 s of speedj (0.5 s up: 0.125 rad, 0.1 s held: 0.05 rad), then 0.25 s
    // stopping (0.0625 rad).
    let want = 0.125 + 0.5 * 0.1 + 0.0625;
    assert!((qs.last().unwrap() - want).abs() < 1e-9, "{:?}", qs.last());
    let ramp_steps = down.iter().filter(|v| **v > 0.0 && **v < top).count();
    assert!((120..=126).contains(&ramp_steps), "{ramp_steps}");
}

#[test]
fn servoj_moves_at_constant_speed_over_its_time() {
    let mut m = machine(
        "servoj([0.08, -1.5707963267948966, 0, -1.5707963267948966, 0, 0], t=0.02)\nsync()\n",
    );
    let mut seen = Vec::new();
    steps(&mut m, 100, |_, m| seen.push((m.arm().q[0], m.arm().qd[0])));
    // 10 steps at 4 rad/s, 0.008 rad each.
    for (k, (q, qd)) in seen.iter().take(10).enumerate() {
        assert!((q - 0.008 * k as f64).abs() < 1e-12, "{k}: {q}");
        assert!((qd - 4.0).abs() < 1e-9);
    }
    assert_eq!(seen[10], (0.08, 0.0));
}

#[test]
fn killing_the_moving_thread_or_stopping_the_program_leaves_the_arm_where_it_is() {
    let src = "thread mover():
  movej([1, -1, 1, -1, 1, 1])
end
h = run mover()
sleep(0.5)
kill h
q = get_actual_joint_positions()
sleep(0.5)
textmsg(q == get_actual_joint_positions(), is_steady())
";
    let mut m = machine(src);
    steps(&mut m, 2000, |_, _| {});
    assert_eq!(messages(&mut m), ["TrueTrue"]);
    let q = m.joint_positions();
    assert!(q[0] > 0.0 && q[0] < 1.0, "{q:?}");
    // A halt mid-move.
    let mut m = machine(
        "thread mover():\n  movej([1, -1, 1, -1, 1, 1])\nend\nrun mover()\nsleep(0.3)\nhalt\n",
    );
    steps(&mut m, 2000, |_, _| {});
    assert_eq!(m.state(), &State::Halted);
    let q = m.joint_positions();
    assert!(q[0] > 0.0 && q[0] < 1.0, "{q:?}");
    assert_eq!(m.arm().qd, [0.0; 6]);
    m.run_until(Duration::from_secs(5));
    assert_eq!(m.joint_positions(), q);
}

#[test]
fn a_joint_target_outside_the_joint_range_is_a_runtime_error() {
    for src in [
        "movej([0, -1.57, 0, -1.57, 0, 6.4])\n",
        "servoj([0, -1.57, 0, -7, 0, 0])\n",
        "movel([0, -1.57, 0, -1.57, 0, -6.3])\n",
        "set_pos([0, -1.57, 0, -1.57, 0, 10])\n",
    ] {
        let mut m = machine(src);
        m.run_until(Duration::from_secs(1));
        let State::Error(e) = m.state() else {
            panic!("{src}: {:?}", m.state())
        };
        assert_eq!(e.kind(), RuntimeErrorKind::Argument, "{src}: {e}");
        assert!(
            e.message().contains("outside the joint limits"),
            "{src}: {e}"
        );
        assert_eq!(m.joint_positions(), HOME);
    }
    // Exactly 2π is within the range.
    let mut m = machine("movej([0, -1.57, 0, -1.57, 0, 6.283185307179586], a=100, v=100)\n");
    m.run_until(Duration::from_secs(2));
    assert_eq!(m.state(), &State::Finished);
}

#[test]
fn inverse_kinematics_picks_solutions_within_the_joint_range() {
    // Near the limit, the solution nearest the current joints would be past 2π; the
    // chosen one is within the range.
    let dh = Model::Ur5e.dh();
    let q = [6.2, -1.2, 1.4, -1.8, -1.57, 6.25];
    let pose = forward(&dh, q, [0.0; 6]);
    let near = [6.27, -1.2, 1.4, -1.8, -1.57, 6.27];
    let all = urscript_interp::kinematics::inverse(&dh, pose, [0.0; 6], near);
    assert!(!all.is_empty());
    assert!(all
        .iter()
        .flatten()
        .all(|x| x.abs() <= std::f64::consts::TAU));
}

#[test]
fn speedl_and_stopl_move_the_tool_along_its_speed() {
    let q0 = [0.3, -1.4, 1.6, -1.8, -1.57, 0.2];
    let src = format!(
        "set_pos({q0:?})\nspeedl([0.05, 0, 0, 0, 0, 0], 0.5, 0.5)\nstopl(0.5)\ntextmsg(is_steady())\n"
    );
    let p0 = forward(&Model::Ur5e.dh(), q0, [0.0; 6]);
    let mut m = machine(&src);
    let mut xs = Vec::new();
    steps(&mut m, 2000, |_, m| {
        let p = m.tcp_pose();
        // Along x only.
        assert!(
            (p[1] - p0[1]).abs() < 1e-6 && (p[2] - p0[2]).abs() < 1e-6,
            "{p:?}"
        );
        xs.push(p[0] - p0[0]);
    });
    assert_eq!(m.state(), &State::Finished);
    assert_eq!(messages(&mut m), ["True"]);
    assert!(xs.windows(2).all(|w| w[1] >= w[0] - 1e-12));
    // 0.1 s up (2.5 mm), 0.4 s at 0.05 m/s (20 mm), 0.1 s down (2.5 mm).
    let last = *xs.last().unwrap();
    assert!((last - 0.025).abs() < 1e-6, "{last}");
    assert_eq!(m.arm().tcp_speed, [0.0; 6]);
}

/// A `movel` to a pose beyond the arm's reach: the tool sets off along the line and,
/// where the line leaves the reach, the arm stops with a protective stop (as UR's client
/// library expects of a real arm), not with a runtime error before it moves.
#[test]
fn movel_beyond_reach_moves_along_the_line_then_stops_with_a_protective_stop() {
    let dh = Model::Ur5e.dh();
    let q0 = [0.3, -1.4, 1.6, -1.8, -1.57, 0.2];
    let p0 = forward(&dh, q0, [0.0; 6]);
    // 3 m further out along x: far outside a UR5e's 0.85 m reach.
    let p1 = [p0[0] + 3.0, p0[1], p0[2], p0[3], p0[4], p0[5]];
    let src = format!(
        "set_pos({q0:?})\nmovel(p[{}, {}, {}, {}, {}, {}], a=1.2, v=0.25)\ntextmsg(\"after\")\n",
        p1[0], p1[1], p1[2], p1[3], p1[4], p1[5]
    );
    let mut m = machine(&src);
    let mut stopped_at = None;
    let mut furthest: f64 = 0.0;
    steps(&mut m, 20_000, |k, m| {
        let p = m.tcp_pose();
        furthest = furthest.max(p[0] - p0[0]);
        if stopped_at.is_none() && m.effects().contains(&Effect::ProtectiveStop) {
            stopped_at = Some(k);
        }
    });
    let k = stopped_at.expect("a protective stop");
    // It moved out along the line first, and stopped short of the target, at rest.
    assert!(furthest > 0.05 && furthest < 3.0, "{furthest}");
    assert!(k > 10, "{k}");
    assert_eq!(m.arm().qd, [0.0; 6]);
    let p = m.tcp_pose();
    assert!(
        (p[1] - p0[1]).abs() < 1e-6 && (p[2] - p0[2]).abs() < 1e-6,
        "{p:?}"
    );
    // The same target by `movej` is refused before the arm moves.
    let mut j = machine(&src.replace("movel(", "movej("));
    j.run_until(Duration::from_secs(1));
    let State::Error(e) = j.state() else {
        panic!("{:?}", j.state())
    };
    assert!(e.message().contains("out of reach"), "{e}");
}
