//! The world model: frames added, attached, moved and deleted by programs of our own,
//! their poses checked against pose arithmetic done here in the test, persistence
//! across programs on one arm, a frame on the TCP following a move, and the refusals.
mod common;
use std::time::Duration;

use common::messages;
use proptest::prelude::*;
use urscript_interp::{Config, Machine, Program, State, Value};

fn run(src: &str) -> Machine {
    let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
    m.run_until(Duration::from_secs(10));
    m
}

fn pose(m: &Machine, name: &str) -> [f64; 6] {
    match m.global(name) {
        Some(Value::Pose(p)) => *p,
        other => panic!("{name}: {other:?}"),
    }
}

fn near(a: [f64; 6], b: [f64; 6], eps: f64) -> bool {
    a.iter().zip(b).all(|(x, y)| (x - y).abs() < eps)
}

#[test]
fn frames_in_a_cell() {
    let m = run(r#"
add_frame("table", p[0.5, 0.2, 0.0, 0, 0, 1.5707963267948966])
add_frame("fixture", p[0.1, 0.0, 0.02, 0, 0, 0], "table")
attach_frame("fixture", "table")
global f_world = get_pose("fixture", "world")
global f_table = get_pose("fixture", "table")
global check = pose_trans(p[0.5, 0.2, 0.0, 0, 0, 1.5707963267948966], p[0.1, 0.0, 0.02, 0, 0, 0])
move_frame("table", p[0.6, 0.2, 0.0, 0, 0, 1.5707963267948966])
global f_moved = get_pose("fixture", "world")
global in_table = convert_pose(p[0.0, 0.0, 0.1, 0, 0, 0], "fixture", "table")
global parent = get_frame_parent("fixture")
global kids = get_children("world")
global there = is_frame("fixture")
delete_frame("table")
global parent_after = get_frame_parent("fixture")
global gone = is_frame("table")
"#);
    assert_eq!(m.state(), &State::Finished, "{:?}", m.state());
    assert!(near(pose(&m, "f_world"), pose(&m, "check"), 1e-9));
    assert!(near(
        pose(&m, "f_table"),
        [0.1, 0.0, 0.02, 0.0, 0.0, 0.0],
        1e-9
    ));
    // The fixture moved with the table: +0.1 m on x.
    let (a, b) = (pose(&m, "f_world"), pose(&m, "f_moved"));
    assert!((b[0] - a[0] - 0.1).abs() < 1e-9 && (b[1] - a[1]).abs() < 1e-9);
    assert!(near(
        pose(&m, "in_table"),
        [0.1, 0.0, 0.12, 0.0, 0.0, 0.0],
        1e-9
    ));
    assert_eq!(m.global("parent"), Some(&Value::Str(b"table".to_vec())));
    assert_eq!(
        m.global("kids"),
        Some(&Value::List(vec![
            Value::Str(b"base".to_vec()),
            Value::Str(b"table".to_vec())
        ]))
    );
    assert_eq!(m.global("there"), Some(&Value::Bool(true)));
    assert_eq!(
        m.global("parent_after"),
        Some(&Value::Str(b"world".to_vec()))
    );
    assert_eq!(m.global("gone"), Some(&Value::Bool(false)));
}

#[test]
fn a_frame_on_the_tcp_follows_the_arm_and_the_model_outlives_the_program() {
    let first = r#"
movej([0, -1.2, 1.5, -1.9, -1.57, 0])
add_frame("part", p[0, 0, 0.05, 0, 0, 0], "tcp")
attach_frame("part", "tcp")
global before = get_pose("part", "base")
global expect_before = pose_trans(get_actual_tcp_pose(), p[0, 0, 0.05, 0, 0, 0])
movej([0.3, -1.2, 1.5, -1.9, -1.57, 0])
global after = get_pose("part", "base")
global expect = pose_trans(get_actual_tcp_pose(), p[0, 0, 0.05, 0, 0, 0])
add_frame("station", p[0.4, -0.3, 0.1, 0, 0, 0], "world")
"#;
    let mut m = Machine::new(Program::parse(first).unwrap(), Config::default());
    m.run_until(Duration::from_secs(20));
    assert_eq!(m.state(), &State::Finished, "{:?}", m.state());
    assert!(near(pose(&m, "before"), pose(&m, "expect_before"), 1e-9));
    assert!(near(pose(&m, "after"), pose(&m, "expect"), 1e-9));
    assert!(!near(pose(&m, "after"), pose(&m, "before"), 1e-3));
    // A second program on the same arm sees the frames; reset clears them.
    let second = r#"
global kept = is_frame("station") and is_frame("part")
global station = get_pose("station", "world")
reset_world_model()
global cleared = not is_frame("station")
"#;
    let mut m2 = Machine::with_arm(
        Program::parse(second).unwrap(),
        Config::default(),
        m.into_arm(),
    );
    m2.run_until(Duration::from_secs(1));
    assert_eq!(m2.state(), &State::Finished, "{:?}", m2.state());
    assert_eq!(m2.global("kept"), Some(&Value::Bool(true)));
    assert!(near(
        pose(&m2, "station"),
        [0.4, -0.3, 0.1, 0.0, 0.0, 0.0],
        1e-9
    ));
    assert_eq!(m2.global("cleared"), Some(&Value::Bool(true)));
}

#[test]
fn payload_from_frames_on_the_tool() {
    let m = messages(
        r#"
add_frame("gripper", p[0, 0, 0, 0, 0, 0], "flange")
attach_frame("gripper", "flange")
set_mass_properties("gripper", 1.2, [0, 0, 0.05], [0.001, 0.001, 0.001, 0, 0, 0])
add_frame("part", p[0, 0, 0.1, 0, 0, 0], "flange")
attach_frame("part", "gripper")
set_mass_properties("part", 0.8, [0, 0, 0], [0, 0, 0, 0, 0, 0])
set_payload_from_attached_frames()
textmsg(get_target_payload())
textmsg(get_target_payload_cog())
"#,
    );
    // 2 kg; CoG (1.2 * 0.05 + 0.8 * 0.1) / 2 = 0.07 m along the flange's z.
    assert_eq!(m, ["2", "[0, 0, 0.07]"]);
}

#[test]
fn refusals_name_the_function() {
    for (src, want) in [
        ("add_frame(\"a\", p[0,0,0,0,0,0])\nadd_frame(\"a\", p[0,0,0,0,0,0])\n", "already exists"),
        ("add_frame(\"a\", p[0,0,0,0,0,0], \"nowhere\")\n", "no frame \"nowhere\""),
        ("attach_frame(\"tcp\", \"base\")\n", "cannot be attached"),
        ("add_frame(\"a\", p[0,0,0,0,0,0])\nadd_frame(\"b\", p[0,0,0,0,0,0])\nattach_frame(\"b\", \"a\")\nattach_frame(\"a\", \"b\")\n", "close a chain"),
        ("delete_frame(\"base\")\n", "cannot be deleted"),
        ("x = get_frame_parent(\"world\")\n", "no parent"),
        ("x = get_pose(\"missing\", \"world\")\n", "no frame \"missing\""),
        ("move_frame(\"flange\", p[0,0,0,0,0,0])\n", "cannot be moved"),
        ("add_frame(\"a\", p[0,0,0,0,0,0])\nset_mass_properties(\"a\", -1, [0,0,0], [0,0,0,0,0,0])\n", "mass"),
    ] {
        let m = run(src);
        let State::Error(e) = m.state() else {
            panic!("{src}: {:?}", m.state())
        };
        assert!(e.message().contains(want), "{src}: {e}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]
    /// convert_pose there and back is the identity, and get_pose agrees with
    /// convert_pose of the frame's own origin.
    #[test]
    fn convert_pose_round_trips(
        a in proptest::array::uniform6(-1.0f64..1.0),
        b in proptest::array::uniform6(-1.0f64..1.0),
        p in proptest::array::uniform6(-1.0f64..1.0),
    ) {
        let src = format!(
            "add_frame(\"a\", p{a:?})\nadd_frame(\"b\", p{b:?}, \"a\")\nglobal there = convert_pose(p{p:?}, \"a\", \"b\")\nglobal back = convert_pose(there, \"b\", \"a\")\nglobal rel = get_pose(\"b\", \"a\")\nglobal origin = convert_pose(p[0, 0, 0, 0, 0, 0], \"b\", \"a\")\n"
        );
        let m = run(&src);
        prop_assert_eq!(m.state(), &State::Finished);
        let same = |x: [f64; 6], y: [f64; 6]| {
            // Compare positions and the rotation vectors' rotations (a rotation vector
            // near pi may flip sign).
            let ok_pos = x[..3].iter().zip(&y[..3]).all(|(u, v)| (u - v).abs() < 1e-7);
            let ok_rot = x[3..].iter().zip(&y[3..]).all(|(u, v)| (u - v).abs() < 1e-6)
                || ((x[3] * x[3] + x[4] * x[4] + x[5] * x[5]).sqrt() - std::f64::consts::PI).abs() < 1e-3;
            ok_pos && ok_rot
        };
        prop_assert!(same(pose(&m, "back"), p), "{:?} vs {:?}", pose(&m, "back"), p);
        prop_assert!(same(pose(&m, "rel"), pose(&m, "origin")));
        prop_assert!(same(pose(&m, "rel"), b));
    }
}
