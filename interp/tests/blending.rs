//! Blend radius `r` on `movej`, `movel`, `movep`: the program gets control back where
//! the tool enters the sphere of radius `r` around the target, the next move blends in
//! without a stop, the tool stays within `r` of the corner, a statement that takes time
//! before the next move makes the arm stop at the target, and a radius that would overlap
//! the previous blend is reduced. Virtual time: the arm is sampled at every step.
use std::time::Duration;

use urscript_interp::kinematics::{forward, Model};
use urscript_interp::{Config, Event, Machine, MessageKind, Program, State, Value};

const STEP: Duration = Duration::from_millis(2);
const Q0: [f64; 6] = [0.3, -1.4, 1.6, -1.8, -1.57, 0.2];

/// The arm at one step.
#[derive(Debug, Clone, Copy)]
struct At {
    q: [f64; 6],
    qd: [f64; 6],
    /// Tool position (no TCP offset is set) and linear tool speed.
    p: [f64; 3],
    speed: f64,
}

/// Runs `src` to its end, sampling the arm after every step; returns the samples (one
/// per step, from step 0) and the machine.
fn run(src: &str) -> (Vec<At>, Machine) {
    let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
    let mut out = Vec::new();
    for k in 0..20_000u32 {
        m.run_until(STEP * k);
        let a = m.arm();
        let p = m.tcp_pose();
        let v = a.tcp_speed;
        out.push(At {
            q: a.q,
            qd: a.qd,
            p: [p[0], p[1], p[2]],
            speed: (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt(),
        });
        if m.state() != &State::Running {
            break;
        }
    }
    assert_eq!(m.state(), &State::Finished, "{src}");
    (out, m)
}

fn add(q: [f64; 6], d: [f64; 6]) -> [f64; 6] {
    std::array::from_fn(|k| q[k] + d[k])
}

fn tool(q: [f64; 6]) -> [f64; 3] {
    let p = forward(&Model::Ur5e.dh(), q, [0.0; 6]);
    [p[0], p[1], p[2]]
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Distance of `p` from the segment `a`-`b`.
fn off_segment(p: [f64; 3], a: [f64; 3], b: [f64; 3]) -> f64 {
    let ab = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
    let ap = [p[0] - a[0], p[1] - a[1], p[2] - a[2]];
    let l2 = ab[0] * ab[0] + ab[1] * ab[1] + ab[2] * ab[2];
    let f = ((ap[0] * ab[0] + ap[1] * ab[1] + ap[2] * ab[2]) / l2).clamp(0.0, 1.0);
    dist(p, [a[0] + ab[0] * f, a[1] + ab[1] * f, a[2] + ab[2] * f])
}

/// Distance of joints `q` from the joint-space segment `a`-`b` (largest joint).
fn off_joint_segment(q: [f64; 6], a: [f64; 6], b: [f64; 6]) -> f64 {
    let d: Vec<f64> = (0..6).map(|k| b[k] - a[k]).collect();
    let l2: f64 = d.iter().map(|x| x * x).sum();
    let f = ((0..6).map(|k| (q[k] - a[k]) * d[k]).sum::<f64>() / l2).clamp(0.0, 1.0);
    (0..6)
        .map(|k| (q[k] - (a[k] + d[k] * f)).abs())
        .fold(0.0, f64::max)
}

fn pose(p: [f64; 3], rot: [f64; 3]) -> String {
    format!(
        "p[{}, {}, {}, {}, {}, {}]",
        p[0], p[1], p[2], rot[0], rot[1], rot[2]
    )
}

fn moving(a: &At) -> bool {
    a.qd.iter().any(|v| *v != 0.0)
}

/// The steps from the first that moves to the last that moves.
fn moving_span(s: &[At]) -> (usize, usize) {
    let first = s.iter().position(moving).unwrap();
    let last = s.iter().rposition(moving).unwrap();
    (first, last)
}

/// The largest change of any joint speed from one step to the next (rad/s).
fn largest_speed_step(s: &[At]) -> f64 {
    s.windows(2)
        .map(|w| {
            (0..6)
                .map(|k| (w[1].qd[k] - w[0].qd[k]).abs())
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max)
}

const Q1_STEP: [f64; 6] = [0.6, 0.2, -0.3, 0.0, 0.0, 0.0];
const Q2_STEP: [f64; 6] = [0.2, -0.3, 0.4, 0.3, 0.0, 0.0];

fn two_movej(r: f64, between: &str) -> String {
    let q1 = add(Q0, Q1_STEP);
    let q2 = add(q1, Q2_STEP);
    format!("set_pos({Q0:?})\nmovej({q1:?}, r={r})\n{between}movej({q2:?})\n")
}

#[test]
fn a_blended_pair_of_movej_is_faster_never_stops_and_keeps_joint_speeds_continuous() {
    let q1 = add(Q0, Q1_STEP);
    let q2 = add(q1, Q2_STEP);
    let r = 0.05;
    let (plain, _) = run(&two_movej(0.0, ""));
    let (blended, m) = run(&two_movej(r, ""));
    assert_eq!(m.joint_positions(), q2);
    eprintln!(
        "movej pair: {} steps unblended, {} blended (r = {r})",
        plain.len(),
        blended.len()
    );
    assert!(blended.len() < plain.len());
    // Unblended, the arm is at rest at q1 in between.
    let (f, l) = moving_span(&plain);
    assert!(plain[f..l].iter().any(|a| !moving(a) && a.q == q1));
    // Blended, it never stops between its start and its end, and never reaches q1.
    let (f, l) = moving_span(&blended);
    assert!(blended[f..=l].iter().all(moving));
    assert_eq!(l + 2, blended.len(), "moving until the last step");
    let w = tool(q1);
    let nearest = blended.iter().map(|a| dist(a.p, w)).fold(1.0, f64::min);
    assert!(nearest > 1e-3, "{nearest}");
    // No step changes a joint speed by more than a few steps' worth of acceleration
    // (a stop, or a restart from rest, would change it by the whole speed).
    let jump = largest_speed_step(&blended);
    let peak = blended
        .iter()
        .map(|a| a.qd.iter().fold(0.0f64, |x, v| x.max(v.abs())))
        .fold(0.0, f64::max);
    eprintln!("largest joint speed change per step {jump} rad/s; peak speed {peak} rad/s");
    assert!(jump < 0.02 && peak > 0.5, "{jump} {peak}");
    // Off the two joint-space segments only inside the blend: the tool there within r
    // of the waypoint (the joint-space curve moves the tool on a curve: 2 % margin).
    let mut inside = 0;
    let mut farthest: f64 = 0.0;
    for a in &blended {
        let off = off_joint_segment(a.q, Q0, q1).min(off_joint_segment(a.q, q1, q2));
        if off > 1e-9 {
            inside += 1;
            farthest = farthest.max(dist(a.p, w));
        }
    }
    eprintln!("blend: {inside} steps, tool at most {farthest} m from the waypoint");
    assert!(inside > 10 && farthest <= r * 1.02, "{inside} {farthest}");
}

#[test]
fn r_zero_stops_at_the_waypoint_as_before() {
    let q1 = add(Q0, Q1_STEP);
    let (plain, _) = run(&two_movej(0.0, ""));
    let stops = plain.iter().filter(|a| !moving(a) && a.q == q1).count();
    assert!(stops >= 1);
}

#[test]
fn control_returns_where_the_blend_begins_and_the_arm_reports_the_move_under_way() {
    let q1 = add(Q0, Q1_STEP);
    let r = 0.05;
    let src = format!(
        "set_pos({Q0:?})\nmovej({q1:?}, r={r})\nqa = get_actual_joint_positions()\nwp = get_target_waypoint()\nsteady = is_steady()\nsleep(3)\nsteady_after = is_steady()\nwp_after = get_target_waypoint()\n"
    );
    let (_, m) = run(&src);
    let list = |name: &str| -> Vec<f64> {
        match m.global(name) {
            Some(Value::List(l)) => l
                .iter()
                .map(|v| match v {
                    Value::Float(x) => *x,
                    other => panic!("{other:?}"),
                })
                .collect(),
            Some(Value::Pose(p)) => p.to_vec(),
            other => panic!("{name}: {other:?}"),
        }
    };
    let qa = list("qa");
    let qa: [f64; 6] = std::array::from_fn(|k| qa[k]);
    let w = tool(q1);
    let d = dist(tool(qa), w);
    // Inside the sphere, by at most the ~1 m/s the tool moves in one 2 ms step.
    assert!(d <= r && d > r - 0.002, "{d}");
    assert_eq!(m.global("steady"), Some(&Value::Bool(false)));
    // The waypoint is the move's target, not where the tool is.
    let wp = list("wp");
    let target = forward(&Model::Ur5e.dh(), q1, [0.0; 6]);
    assert!((0..6).all(|k| (wp[k] - target[k]).abs() < 1e-9), "{wp:?}");
    // Nothing blended into: the arm stopped at the target.
    assert_eq!(m.global("steady_after"), Some(&Value::Bool(true)));
    assert_eq!(m.joint_positions(), q1);
    let after = list("wp_after");
    assert!((0..3).all(|k| (after[k] - target[k]).abs() < 1e-9));
}

#[test]
fn a_statement_that_takes_time_before_the_next_move_makes_the_arm_stop_at_the_target() {
    let q1 = add(Q0, Q1_STEP);
    let q2 = add(q1, Q2_STEP);
    let (plain, _) = run(&two_movej(0.0, ""));
    let (late, m) = run(&two_movej(0.05, "sleep(0.1)\n"));
    assert_eq!(m.joint_positions(), q2);
    // The arm comes to rest exactly at q1, then the next move starts from there.
    assert!(late.iter().any(|a| !moving(a) && a.q == q1));
    // No faster than unblended (the sleep ran while the arm was still moving).
    assert!(late.len() >= plain.len(), "{} {}", late.len(), plain.len());
    assert!(largest_speed_step(&late) < 0.02);
}

#[test]
fn a_statement_that_takes_no_time_before_the_next_move_still_blends() {
    let (plain, _) = run(&two_movej(0.0, ""));
    let (blended, _) = run(&two_movej(0.05, "x = 1 + 2\ntextmsg(\"at the blend\")\n"));
    let (f, l) = moving_span(&blended);
    assert!(blended[f..=l].iter().all(moving));
    assert!(blended.len() < plain.len());
}

/// A point in space (m).
type P3 = [f64; 3];

/// The tool's position at `Q0`, three corners of a path from it (legs of these lengths),
/// and the tool's orientation at `Q0`.
fn corners(leg1: f64, leg2: f64, leg3: f64) -> (P3, P3, P3, P3, P3) {
    let p0 = forward(&Model::Ur5e.dh(), Q0, [0.0; 6]);
    let rot = [p0[3], p0[4], p0[5]];
    let a = [p0[0], p0[1], p0[2]];
    let b = [a[0] + leg1, a[1], a[2]];
    let c = [b[0], b[1] - leg2, b[2]];
    let d = [c[0] - leg3 * 0.6, c[1], c[2] + leg3 * 0.8];
    (a, b, c, d, rot)
}

#[test]
fn movel_blends_on_an_arc_within_r_of_the_corner() {
    let (a, b, c, _, rot) = corners(0.15, 0.12, 0.0);
    let r = 0.04;
    let src = |r: f64| {
        format!(
            "set_pos({Q0:?})\nmovel({}, r={r})\nmovel({})\n",
            pose(b, rot),
            pose(c, rot)
        )
    };
    let (plain, _) = run(&src(0.0));
    let (blended, m) = run(&src(r));
    let end = m.tcp_pose();
    assert!(dist([end[0], end[1], end[2]], c) < 1e-9);
    assert!(blended.len() < plain.len());
    let (f, l) = moving_span(&blended);
    assert!(blended[f..=l].iter().all(moving));
    let mut inside = 0;
    let mut farthest: f64 = 0.0;
    for s in &blended {
        let off = off_segment(s.p, a, b).min(off_segment(s.p, b, c));
        if off > 1e-6 {
            inside += 1;
            farthest = farthest.max(dist(s.p, b));
        }
    }
    eprintln!("movel blend: {inside} steps off the lines, at most {farthest} m from the corner");
    assert!(inside > 10 && farthest <= r + 1e-9, "{inside} {farthest}");
    // The tool keeps its speed through the corner (0.25 m/s cruise).
    for s in &blended[f + 200..l - 200] {
        assert!((s.speed - 0.25).abs() < 1e-6, "{}", s.speed);
    }
    assert!(largest_speed_step(&blended) < 0.05);
}

#[test]
fn movep_keeps_a_constant_tool_speed_through_its_blends() {
    let (_, b, c, d, rot) = corners(0.1, 0.1, 0.1);
    let src = format!(
        "set_pos({Q0:?})\nmovep({}, a=1.2, v=0.1, r=0.02)\nmovep({}, a=1.2, v=0.1, r=0.02)\nmovep({}, a=1.2, v=0.1)\n",
        pose(b, rot),
        pose(c, rot),
        pose(d, rot)
    );
    let (s, _) = run(&src);
    let (f, l) = moving_span(&s);
    // After the first ramp (0.1 / 1.2 s = 42 steps) and before the last, the tool moves
    // at v, through both blends.
    let cruise = &s[f + 45..l - 45];
    assert!(cruise.len() > 500, "{}", cruise.len());
    for a in cruise {
        assert!((a.speed - 0.1).abs() < 1e-6, "{}", a.speed);
    }
    // Both corners were cut.
    let near = |p: [f64; 3]| s.iter().map(|a| dist(a.p, p)).fold(1.0, f64::min);
    assert!(near(b) > 1e-3 && near(b) < 0.02);
    assert!(near(c) > 1e-3 && near(c) < 0.02);
}

#[test]
fn a_radius_overlapping_the_previous_blend_is_reduced() {
    // Legs of 0.1 m with r = 0.08 at both corners: the second blend keeps to the
    // 0.1 - 0.08 = 0.02 m the first leaves of the middle leg (slow enough, 0.1 m/s, to
    // stop in those 0.02 m at 1.2 m/s^2 had no move come after).
    let (a, b, c, d, rot) = corners(0.15, 0.1, 0.15);
    let src = format!(
        "set_pos({Q0:?})\nmovel({}, v=0.1, r=0.08)\nmovel({}, v=0.1, r=0.08)\nmovel({}, v=0.1)\n",
        pose(b, rot),
        pose(c, rot),
        pose(d, rot)
    );
    let (s, _) = run(&src);
    let (f, l) = moving_span(&s);
    assert!(s[f..=l].iter().all(moving));
    let mut near_c: f64 = 0.0;
    let mut cut_c = 0;
    for x in &s {
        let off = off_segment(x.p, a, b)
            .min(off_segment(x.p, b, c))
            .min(off_segment(x.p, c, d));
        if off > 1e-6 && dist(x.p, b) > 0.08 + 1e-9 {
            cut_c += 1;
            near_c = near_c.max(dist(x.p, c));
        }
    }
    eprintln!("second blend: {cut_c} steps, at most {near_c} m from its corner");
    assert!(cut_c > 0 && near_c <= 0.02 + 1e-9, "{cut_c} {near_c}");
}

#[test]
fn a_next_move_shorter_than_the_radius_is_not_blended_into() {
    // The next target lies inside the first blend's sphere: the arm stops at the corner.
    let (_, b, c, _, rot) = corners(0.15, 0.03, 0.0);
    let src = format!(
        "set_pos({Q0:?})\nmovel({}, r=0.05)\nmovel({})\n",
        pose(b, rot),
        pose(c, rot)
    );
    let (s, _) = run(&src);
    let (f, l) = moving_span(&s);
    let stop = s[f..l]
        .iter()
        .find(|a| !moving(a))
        .expect("the arm stops in between");
    assert!(dist(stop.p, b) < 1e-9, "{:?}", stop.p);
}

#[test]
fn a_negative_radius_is_a_runtime_error() {
    let src = format!("movej({Q0:?}, r=-0.1)\n");
    let mut m = Machine::new(Program::parse(&src).unwrap(), Config::default());
    m.run_until(Duration::from_millis(10));
    match m.state() {
        State::Error(e) => assert!(e.to_string().contains("blend radius"), "{e}"),
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_blend_that_begins_while_the_arm_still_accelerates_is_still_faster() {
    // Short moves with a radius close to half of them: the tool enters the sphere
    // before the arm has reached its cruise speed.
    let q1 = add(Q0, [0.15, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let q2 = add(q1, [0.0, 0.0, 0.15, 0.0, 0.0, 0.0]);
    let src = |r: f64| format!("set_pos({Q0:?})\nmovej({q1:?}, r={r})\nmovej({q2:?})\n");
    let leg = dist(tool(Q0), tool(q1)).min(dist(tool(q1), tool(q2)));
    let r = 0.45 * leg;
    let (plain, _) = run(&src(0.0));
    let (blended, _) = run(&src(r));
    eprintln!(
        "short movej pair (legs >= {leg} m, r = {r}): {} steps unblended, {} blended",
        plain.len(),
        blended.len()
    );
    assert!(blended.len() < plain.len());
    let (f, l) = moving_span(&blended);
    assert!(blended[f..=l].iter().all(moving));
    assert!(largest_speed_step(&blended) < 0.02);
}

#[test]
fn a_blend_slower_than_stopping_is_not_made() {
    // A radius as long as the move: the blend would begin at once, at the speed of the
    // first step. The arm stops at the waypoint instead, no slower than unblended.
    let q1 = add(Q0, [0.15, 0.0, 0.0, 0.0, 0.0, 0.0]);
    let q2 = add(q1, [0.0, 0.0, 0.15, 0.0, 0.0, 0.0]);
    let src = |r: f64| format!("set_pos({Q0:?})\nmovej({q1:?}, r={r})\nmovej({q2:?})\n");
    let (plain, _) = run(&src(0.0));
    let (blended, _) = run(&src(1.0));
    assert!(blended.iter().any(|a| !moving(a) && a.q == q1));
    assert!(
        blended.len() <= plain.len(),
        "{} {}",
        blended.len(),
        plain.len()
    );
}

#[test]
fn a_polyscope_style_loop_of_blended_waypoints_never_stops_until_its_last_move() {
    // Three waypoints blended in a loop (the loop's condition takes no time, so the last
    // move of one pass blends into the first of the next), then a final move without r.
    let q1 = add(Q0, Q1_STEP);
    let q2 = add(q1, Q2_STEP);
    let src = format!(
        "set_pos({Q0:?})\ni = 0\nwhile i < 3:\n  $ 1 \"Waypoint_1\"\n  movej({q1:?}, a=1.4, v=1.05, r=0.05)\n  movej({q2:?}, a=1.4, v=1.05, r=0.05)\n  movej({Q0:?}, a=1.4, v=1.05, r=0.05)\n  i = i + 1\nend\nmovej({q1:?})\n"
    );
    let (s, m) = run(&src);
    assert_eq!(m.joint_positions(), q1);
    let (f, l) = moving_span(&s);
    assert!(s[f..=l].iter().all(moving));
    assert!(largest_speed_step(&s) < 0.02);
    // It never passes exactly through a waypoint before the last (leaving out the start
    // at Q0 and the last 0.1 s before the end at q1).
    for w in [q1, q2, Q0] {
        let nearest = s[f + 100..l - 50]
            .iter()
            .map(|a| dist(a.p, tool(w)))
            .fold(1.0, f64::min);
        assert!(nearest > 1e-3, "{nearest}");
    }
}

/// `movej` to `q1` then `movel` on (or `movel` to `q1`'s tool position then `movej`
/// back to `Q0`), with blend radius `r` and without: (samples blended, samples
/// unblended, the corner, the tool's straight line from, to).
fn joint_and_tool(r: f64, tool_first: bool) -> (Vec<At>, Vec<At>, P3, P3, P3) {
    let q1 = add(Q0, Q1_STEP);
    let w = tool(q1);
    let p1 = forward(&Model::Ur5e.dh(), q1, [0.0; 6]);
    let rot = [p1[3], p1[4], p1[5]];
    let c = [w[0] - 0.09, w[1] + 0.12, w[2] - 0.05];
    let qc = format!("get_inverse_kin({}, qnear={q1:?})", pose(c, rot));
    // Tool first: start at c, movel to w, then movej back to Q0.
    let src = |r: f64| {
        if tool_first {
            format!(
                "set_pos({q1:?})\nmovej({qc})\nmovel({}, r={r})\nmovej({Q0:?})\n",
                pose(w, rot)
            )
        } else {
            format!(
                "set_pos({Q0:?})\nmovej({q1:?}, r={r})\nmovel({})\n",
                pose(c, rot)
            )
        }
    };
    let (from, to) = if tool_first { (c, w) } else { (w, c) };
    let (blended, _) = run(&src(r));
    let (plain, _) = run(&src(0.0));
    (blended, plain, w, from, to)
}

#[test]
fn a_movej_blends_into_a_movel_and_a_movel_into_a_movej() {
    let r = 0.04;
    for tool_first in [false, true] {
        let (blended, plain, w, from, to) = joint_and_tool(r, tool_first);
        eprintln!(
            "{}: {} steps unblended, {} blended",
            if tool_first {
                "movel -> movej"
            } else {
                "movej -> movel"
            },
            plain.len(),
            blended.len()
        );
        assert!(blended.len() < plain.len());
        // From the pair's first move on (the reverse case first moves to the line's
        // start with a movej and stops there), the arm never stops until the end.
        let start = if tool_first {
            blended
                .iter()
                .position(|a| dist(a.p, from) < 1e-9 && !moving(a))
                .unwrap()
        } else {
            0
        };
        let (f, l) = moving_span(&blended[start..]);
        assert!(blended[start + f..=start + l].iter().all(moving));
        assert!(largest_speed_step(&blended) < 0.05);
        // The tool follows the straight line for a while, and cuts the corner.
        let line_steps = blended
            .iter()
            .filter(|a| off_segment(a.p, from, to) < 1e-6 && dist(a.p, from) > 1e-3)
            .count();
        assert!(line_steps > 50, "{line_steps}");
        // (The reverse case starts at the corner: from its stop at the line's start on.)
        let nearest = blended[start..]
            .iter()
            .map(|a| dist(a.p, w))
            .fold(1.0, f64::min);
        assert!(nearest > 1e-3 && nearest < r, "{nearest}");
    }
}

#[test]
fn any_sequence_of_blended_moves_ends_at_its_last_target_without_a_jump() {
    // Moves of every kind with radii from none to longer than the moves, collinear,
    // reversing and tiny legs, times given: deterministic pseudo-random programs.
    let mut seed: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut next = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        (seed % 10_000) as f64 / 10_000.0
    };
    let p0 = forward(&Model::Ur5e.dh(), Q0, [0.0; 6]);
    let rot = [p0[3], p0[4], p0[5]];
    let mut finished = 0;
    let mut worst_dv: f64 = 0.0;
    for _ in 0..12 {
        let mut src = format!("set_pos({Q0:?})\n");
        let mut last = String::new();
        for i in 0..5 {
            let r = [0.0, 0.01, 0.05, 0.3][(next() * 4.0) as usize];
            let kind = (next() * 5.0) as usize;
            let p = [
                p0[0] + 0.1 * (next() - 0.5),
                p0[1] + 0.1 * (next() - 0.5),
                p0[2] + 0.1 * (next() - 0.5),
            ];
            let target = pose(p, rot);
            let line = match kind {
                0 => format!("movej(get_inverse_kin({target}, qnear={Q0:?}), r={r})"),
                1 => format!("movel({target}, r={r})"),
                2 => format!("movep({target}, v=0.1, r={r})"),
                3 => format!("movel({target}, t=0.6, r={r})"),
                _ => {
                    let via = pose([p[0] + 0.02, p[1] - 0.03, p[2]], rot);
                    format!("movec({via}, {target}, r={r})")
                }
            };
            if i % 2 == 1 {
                // Sometimes the same target twice (a zero-length move).
                src.push_str(&format!("{line}\n"));
            }
            src.push_str(&format!("{line}\n"));
            last = target;
        }
        // A last move without a radius, to where the previous one went.
        src.push_str(&format!("movel({last})\n"));
        let mut m = Machine::new(Program::parse(&src).unwrap(), Config::default());
        // From step 0 on (where set_pos puts the arm at Q0 at once).
        m.run_until(Duration::ZERO);
        let (mut prev, mut prev_qd) = (m.arm().q, m.arm().qd);
        for k in 1..40_000u32 {
            m.run_until(STEP * k);
            let (q, qd) = (m.arm().q, m.arm().qd);
            let d = (0..6).map(|j| (q[j] - prev[j]).abs()).fold(0.0, f64::max);
            assert!(d < 0.05, "{src}: a jump of {d} rad at step {k}");
            let dv = (0..6)
                .map(|j| (qd[j] - prev_qd[j]).abs())
                .fold(0.0, f64::max);
            worst_dv = worst_dv.max(dv);
            (prev, prev_qd) = (q, qd);
            if m.state() != &State::Running {
                break;
            }
        }
        // An arc through a random via may be out of reach: a runtime error, not a panic.
        if let State::Error(e) = m.state() {
            assert!(e.to_string().contains("reach"), "{e}\n{src}");
            continue;
        }
        assert_eq!(m.state(), &State::Finished, "{src}");
        let end = m.tcp_pose();
        let want: Vec<f64> = last
            .trim_start_matches("p[")
            .trim_end_matches(']')
            .split(", ")
            .map(|x| x.parse().unwrap())
            .collect();
        assert!(
            (0..3).all(|k| (end[k] - want[k]).abs() < 1e-6),
            "{end:?} {want:?}\n{src}"
        );
        finished += 1;
    }
    eprintln!("{finished} of 12 programs finished (the others: an arc out of reach); largest joint speed change in a step {worst_dv} rad/s");
    assert!(finished >= 6, "{finished}");
    // Joint speeds change gradually (a tight blend arc turns them fast, but no step
    // stops a moving arm or starts one at speed).
    assert!(worst_dv < 0.3, "{worst_dv}");
}

#[test]
fn during_a_blend_a_thread_sees_the_next_moves_waypoint_and_an_unsteady_arm() {
    // A thread samples the waypoint and is_steady() at every step; the main program
    // blends two moves.
    let q1 = add(Q0, Q1_STEP);
    let q2 = add(q1, Q2_STEP);
    let src = format!(
        "set_pos({Q0:?})\nthread watch():\n  while True:\n    w = get_target_waypoint()\n    textmsg(w[0], is_steady())\n    sync()\n  end\nend\nh = run watch()\nmovej({q1:?}, r=0.05)\nmovej({q2:?})\nkill h\n"
    );
    let mut m = Machine::new(Program::parse(&src).unwrap(), Config::default());
    for k in 0..5000u32 {
        m.run_until(STEP * k);
        if m.state() != &State::Running {
            break;
        }
    }
    assert_eq!(m.state(), &State::Finished);
    let samples: Vec<(f64, bool)> = std::iter::from_fn(|| m.poll_event())
        .filter_map(|e| match e {
            urscript_interp::Event::Message(msg) => Some(msg.text),
            _ => None,
        })
        .map(|t| {
            let steady = t.ends_with("True");
            let x = t.trim_end_matches("True").trim_end_matches("False");
            (x.parse().unwrap(), steady)
        })
        .collect();
    let x1 = forward(&Model::Ur5e.dh(), q1, [0.0; 6])[0];
    let x2 = forward(&Model::Ur5e.dh(), q2, [0.0; 6])[0];
    // First the first move's target, then the next's, never back; never steady while
    // the arm moves (the watcher is killed when the last move ends).
    // (textmsg prints floats to a few decimals.)
    assert!((x1 - x2).abs() > 0.01, "{x1} {x2}");
    let first = samples
        .iter()
        .take_while(|s| (s.0 - x1).abs() < 1e-4)
        .count();
    let rest = &samples[first..];
    assert!(
        first > 100 && rest.len() > 100,
        "{first} {} {samples:?}",
        rest.len()
    );
    assert!(rest.iter().all(|s| (s.0 - x2).abs() < 1e-4));
    assert!(samples.iter().all(|s| !s.1));
}

/// A PolyScope MoveP with a circle move: `movep` to the arc's start, `movec` through a
/// via point, `movep` on, each with a blend radius.
fn movep_movec_movep(r: f64) -> (Vec<At>, P3, P3, P3) {
    let p0 = forward(&Model::Ur5e.dh(), Q0, [0.0; 6]);
    let rot = [p0[3], p0[4], p0[5]];
    // Right-angle corners: the line comes in along +y, the half circle leaves `a` along
    // +x and reaches `b` along -x, the last line leaves along -y.
    let a = [p0[0], p0[1] + 0.1, p0[2]];
    let via = [a[0] + 0.05, a[1] - 0.05, a[2]];
    let b = [a[0], a[1] - 0.1, a[2]];
    let c = [b[0], b[1] - 0.1, b[2]];
    let src = format!(
        "set_pos({Q0:?})\nmovep({}, a=1.2, v=0.1, r={r})\nmovec({}, {}, a=1.2, v=0.1, r={r}, mode=0)\nmovep({}, a=1.2, v=0.1)\n",
        pose(a, rot),
        pose(via, rot),
        pose(b, rot),
        pose(c, rot)
    );
    let (s, m) = run(&src);
    let end = m.tcp_pose();
    assert!(dist([end[0], end[1], end[2]], c) < 1e-9);
    (s, a, b, c)
}

#[test]
fn blends_into_and_out_of_a_circle_move_never_stop_the_arm() {
    let (plain, _, _, _) = movep_movec_movep(0.0);
    let (blended, a, b, _) = movep_movec_movep(0.02);
    eprintln!(
        "movep-movec-movep: {} steps unblended, {} blended",
        plain.len(),
        blended.len()
    );
    assert!(blended.len() + 20 < plain.len());
    // Unblended the arm stops at both corners; blended it never stops on the way.
    let (f, l) = moving_span(&plain);
    assert!(!plain[f..=l].iter().all(moving));
    let (f, l) = moving_span(&blended);
    assert!(blended[f..=l].iter().all(moving));
    // Both corners are cut, within r (the blends are tool-space curves inside the
    // sphere).
    // (b is where the arm starts: look from the first blend on.)
    let near = |p: [f64; 3]| {
        blended[300..]
            .iter()
            .map(|s| dist(s.p, p))
            .fold(1.0, f64::min)
    };
    assert!(near(a) > 1e-4 && near(a) < 0.02, "{}", near(a));
    assert!(near(b) > 1e-4 && near(b) < 0.02, "{}", near(b));
    // Joint speeds change gradually through the blends.
    let dv = largest_speed_step(&blended);
    eprintln!("largest joint speed change in a step: {dv} rad/s");
    assert!(dv < 0.05, "{dv}");
}

/// The blend-radius warnings a finished run left in the machine's events: (line,
/// requested, reduced).
fn radius_warnings(m: &mut Machine) -> Vec<(u32, f64, f64)> {
    let mut out = Vec::new();
    while let Some(e) = m.poll_event() {
        if let Event::Message(msg) = e {
            if let MessageKind::BlendRadiusReduced { requested, reduced } = msg.kind {
                assert!(msg.text.contains("blend radius reduced"), "{}", msg.text);
                out.push((msg.line, requested, reduced));
            }
        }
    }
    out
}

#[test]
fn a_reduced_radius_is_reported_as_a_warning_with_its_line() {
    // As in the overlap test above: the second move's 0.08 m leaves 0.02 m.
    let (_, b, c, d, rot) = corners(0.15, 0.1, 0.15);
    let src = format!(
        "set_pos({Q0:?})\nmovel({}, v=0.1, r=0.08)\nmovel({}, v=0.1, r=0.08)\nmovel({}, v=0.1)\n",
        pose(b, rot),
        pose(c, rot),
        pose(d, rot)
    );
    let (_, mut m) = run(&src);
    let w = radius_warnings(&mut m);
    assert_eq!(w.len(), 1, "{w:?}");
    assert_eq!(w[0].0, 3);
    assert_eq!(w[0].1, 0.08);
    // (The rest of the middle leg after the first blend, as the arm follows it: 0.02 m
    // to within the blend's exit point found by bisection.)
    assert!((w[0].2 - 0.02).abs() < 1e-4, "{w:?}");
    // Radii with room to spare: no warning.
    let src = format!(
        "set_pos({Q0:?})\nmovel({}, v=0.1, r=0.02)\nmovel({}, v=0.1, r=0.02)\nmovel({}, v=0.1)\n",
        pose(b, rot),
        pose(c, rot),
        pose(d, rot)
    );
    let (_, mut m) = run(&src);
    assert!(radius_warnings(&mut m).is_empty());
}

#[test]
fn a_radius_longer_than_the_first_move_is_reported() {
    let (_, b, _, _, rot) = corners(0.05, 0.1, 0.15);
    let src = format!("set_pos({Q0:?})\nmovel({}, v=0.1, r=0.2)\n", pose(b, rot));
    let (_, mut m) = run(&src);
    let w = radius_warnings(&mut m);
    assert_eq!(w.len(), 1, "{w:?}");
    assert_eq!(w[0].0, 2);
    assert!((w[0].2 - 0.05).abs() < 1e-6, "{w:?}");
}

#[test]
fn movec_in_fixed_mode_turns_the_tool_with_the_arc() {
    // A half circle in the base's xy plane: mode=1 turns the tool by pi about the
    // circle's axis (z), whatever pose_to's orientation; mode=0 ends in pose_to's.
    let p0 = forward(&Model::Ur5e.dh(), Q0, [0.0; 6]);
    let rot = [p0[3], p0[4], p0[5]];
    let a = [p0[0], p0[1], p0[2]];
    let via = [a[0] + 0.05, a[1] - 0.05, a[2]];
    let b = [a[0], a[1] - 0.1, a[2]];
    let run_mode = |mode: u32| {
        let src = format!(
            "set_pos({Q0:?})\nmovec({}, {}, a=1.2, v=0.1, mode={mode})\n",
            pose(via, rot),
            pose(b, rot)
        );
        run(&src).1.tcp_pose()
    };
    let end0 = run_mode(0);
    assert!(dist([end0[3], end0[4], end0[5]], rot) < 1e-6, "{end0:?}");
    let end1 = run_mode(1);
    assert!(dist([end1[0], end1[1], end1[2]], b) < 1e-6);
    // The turn from the start's orientation to the end's: pi about z (either sign).
    let r0 = matrix(rot);
    let r1 = matrix([end1[3], end1[4], end1[5]]);
    // r1 = Rz(pi) r0: r1 r0^T has z axis fixed and x, y flipped.
    let m: [[f64; 3]; 3] =
        std::array::from_fn(|i| std::array::from_fn(|j| (0..3).map(|k| r1[i][k] * r0[j][k]).sum()));
    let want = [[-1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0]];
    for i in 0..3 {
        for j in 0..3 {
            assert!((m[i][j] - want[i][j]).abs() < 1e-6, "{m:?}");
        }
    }
}

#[test]
fn movec_with_an_unknown_mode_is_a_runtime_error() {
    let p0 = forward(&Model::Ur5e.dh(), Q0, [0.0; 6]);
    let rot = [p0[3], p0[4], p0[5]];
    let a = [p0[0], p0[1], p0[2]];
    let src = format!(
        "set_pos({Q0:?})\nmovec({}, {}, mode=2)\n",
        pose([a[0] + 0.05, a[1] - 0.05, a[2]], rot),
        pose([a[0], a[1] - 0.1, a[2]], rot)
    );
    let mut m = Machine::new(Program::parse(&src).unwrap(), Config::default());
    m.run_until(Duration::from_secs(5));
    match m.state() {
        State::Error(e) => assert!(e.to_string().contains("mode=2"), "{e}"),
        s => panic!("{s:?}"),
    }
}

/// The rotation matrix of a rotation vector (Rodrigues).
fn matrix(v: [f64; 3]) -> [[f64; 3]; 3] {
    let th = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if th < 1e-12 {
        return [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
    }
    let k = [v[0] / th, v[1] / th, v[2] / th];
    let (s, c) = th.sin_cos();
    std::array::from_fn(|i| {
        std::array::from_fn(|j| {
            let id = if i == j { 1.0 } else { 0.0 };
            let kx = [[0.0, -k[2], k[1]], [k[2], 0.0, -k[0]], [-k[1], k[0], 0.0]];
            id * c + (1.0 - c) * k[i] * k[j] + s * kx[i][j]
        })
    })
}

/// `first` (its last move's blend radius written `{r}`), then `second`, with blend
/// radius `r`; returns the samples and the tool position where the program got control
/// back after `first` (global `pw`).
fn circle_blend(first: &str, second: &str, r: f64) -> (Vec<At>, [f64; 3]) {
    let src = format!(
        "set_pos({Q0:?})\n{}\npw = get_actual_tcp_pose()\n{second}\n",
        first.replace("{r}", &r.to_string())
    );
    let (s, m) = run(&src);
    let pw = match m.global("pw") {
        Some(Value::Pose(p)) => [p[0], p[1], p[2]],
        other => panic!("{other:?}"),
    };
    (s, pw)
}

/// Distance of `p` from the circle of radius `rad` about `c` in the horizontal plane.
fn off_circle(p: [f64; 3], c: [f64; 3], rad: f64) -> f64 {
    let h = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)).sqrt();
    ((h - rad).powi(2) + (p[2] - c[2]).powi(2)).sqrt()
}

#[test]
fn straight_and_circular_moves_blend_in_tool_space_at_constant_speed() {
    let p0 = forward(&Model::Ur5e.dh(), Q0, [0.0; 6]);
    let rot = [p0[3], p0[4], p0[5]];
    let s0 = [p0[0], p0[1], p0[2]];
    // A line along +y to w; half circles of radius 0.05 m in the horizontal plane.
    let w = [s0[0], s0[1] + 0.1, s0[2]];
    let c1 = [w[0], w[1] + 0.05, w[2]]; // first half circle: w -> e1, centre c1
    let e1 = [w[0], w[1] + 0.1, w[2]];
    let via1 = [w[0] + 0.05, w[1] + 0.05, w[2]];
    // The first arrives at e1 along -x; the second leaves it along +y (a right-angle
    // corner): a half circle about c2 on to e2.
    let c2 = [e1[0] - 0.05, e1[1], e1[2]];
    let via2 = [c2[0], c2[1] + 0.05, c2[2]];
    let e2 = [c2[0] - 0.05, c2[1], c2[2]];
    let last = [e1[0] - 0.1, e1[1], e1[2]];
    let line_in = format!("movel({}, a=1.2, v=0.1, r={{r}})", pose(w, rot));
    let arc1 = |r: &str| {
        format!(
            "movec({}, {}, a=1.2, v=0.1, r={r}, mode=0)",
            pose(via1, rot),
            pose(e1, rot)
        )
    };
    // (first, second, corner, on either path)
    type OnPath = Box<dyn Fn([f64; 3]) -> f64>;
    let cases: Vec<(&str, String, String, [f64; 3], OnPath)> = vec![
        (
            "line into arc",
            line_in.clone(),
            arc1("0"),
            w,
            Box::new(move |p| off_segment(p, s0, w).min(off_circle(p, c1, 0.05))),
        ),
        (
            "arc into line",
            format!("{line_in}\n{}", arc1("{r}")).replace("r={r})", "r=0)"),
            format!("movel({}, a=1.2, v=0.1)", pose(last, rot)),
            e1,
            Box::new(move |p| {
                off_segment(p, s0, w)
                    .min(off_circle(p, c1, 0.05))
                    .min(off_segment(p, e1, last))
            }),
        ),
        (
            "arc into arc",
            format!("{line_in}\n{}", arc1("{r}")).replace("r={r})", "r=0)"),
            format!(
                "movec({}, {}, a=1.2, v=0.1, mode=0)",
                pose(via2, rot),
                pose(e2, rot)
            ),
            e1,
            Box::new(move |p| {
                off_segment(p, s0, w)
                    .min(off_circle(p, c1, 0.05))
                    .min(off_circle(p, c2, 0.05))
            }),
        ),
    ];
    let r = 0.02;
    for (name, first, second, corner, on_path) in cases {
        let (plain, _) = circle_blend(&first, &second, 0.0);
        let (s, pw) = circle_blend(&first, &second, r);
        eprintln!(
            "{name}: {} steps unblended, {} blended",
            plain.len(),
            s.len()
        );
        assert!(s.len() + 20 < plain.len(), "{name}");
        // Control came back where the tool entered the sphere.
        let back = dist(pw, corner);
        assert!(
            (back - r).abs() < 0.1 * STEP.as_secs_f64() + 1e-6,
            "{name}: {back}"
        );
        // The arm does not stop near the corner (unblended it does at the corner; the
        // moves before may stop elsewhere).
        let around = |x: &&At| dist(x.p, corner) < 2.0 * r;
        let (f, l) = moving_span(&plain);
        assert!(!plain[f..=l].iter().filter(around).all(moving), "{name}");
        let (f, l) = moving_span(&s);
        assert!(s[f..=l].iter().filter(around).all(moving), "{name}");
        // Off the paths only inside the sphere (a tolerance of what the tool moves in a
        // step), and it does leave them: the corner is cut.
        let mut off_steps = 0;
        let mut near: f64 = 1.0;
        let mut slowest: f64 = 1.0;
        let mut fastest: f64 = 0.0;
        for x in &s[f..=l] {
            near = near.min(dist(x.p, corner));
            if dist(x.p, corner) < r {
                slowest = slowest.min(x.speed);
                fastest = fastest.max(x.speed);
            }
            if on_path(x.p) > 1e-5 {
                off_steps += 1;
                assert!(dist(x.p, corner) <= r + 1e-6, "{name}: {:?}", x.p);
            }
        }
        assert!(off_steps > 10 && near > 1e-4, "{name}: {off_steps} {near}");
        // Constant tool speed through the blend (the moves' 0.1 m/s).
        eprintln!("{name}: tool speed {slowest}..{fastest} m/s in the sphere");
        assert!(
            slowest > 0.098 && fastest < 0.102,
            "{name}: {slowest} {fastest}"
        );
        let dv = largest_speed_step(&s);
        eprintln!("{name}: largest joint speed change in a step {dv} rad/s");
        assert!(dv < 0.05, "{name}: {dv}");
    }
}

#[test]
fn movej_into_movec_and_back_blends_in_joint_space() {
    let p0 = forward(&Model::Ur5e.dh(), Q0, [0.0; 6]);
    let rot = [p0[3], p0[4], p0[5]];
    let w = [p0[0], p0[1] + 0.1, p0[2]];
    let via = [w[0] + 0.05, w[1] + 0.05, w[2]];
    let e = [w[0], w[1] + 0.1, w[2]];
    let last = [e[0] - 0.1, e[1], e[2]];
    let src = |r: f64| {
        format!(
            "set_pos({Q0:?})\nmovej(get_inverse_kin({}), a=1.4, v=0.3, r={r})\nmovec({}, {}, a=1.2, v=0.1, r={r})\nmovej(get_inverse_kin({}), a=1.4, v=0.3)\n",
            pose(w, rot),
            pose(via, rot),
            pose(e, rot),
            pose(last, rot)
        )
    };
    let (plain, _) = run(&src(0.0));
    let (s, _) = run(&src(0.02));
    eprintln!(
        "movej-movec-movej: {} steps unblended, {} blended",
        plain.len(),
        s.len()
    );
    assert!(s.len() + 20 < plain.len());
    let (f, l) = moving_span(&s);
    assert!(s[f..=l].iter().all(moving));
    let dv = largest_speed_step(&s);
    eprintln!("movej-movec-movej: largest joint speed change in a step {dv} rad/s");
    assert!(dv < 0.05, "{dv}");
}
