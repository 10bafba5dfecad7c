//! The arm's modes and limits as programs rely on them: force mode (free space and a
//! contact plane), teach/freedrive mode, the speed slider, and
//! `is_within_safety_limits`.
use std::time::Duration;

use urscript_interp::kinematics::{forward, Model};
use urscript_interp::{Arm, Config, Event, Machine, Program, State};

const STEP: Duration = Duration::from_millis(2);

fn machine(src: &str) -> Machine {
    Machine::new(Program::parse(src).unwrap(), Config::default())
}

fn messages(m: &mut Machine) -> Vec<String> {
    std::iter::from_fn(|| m.poll_event())
        .filter_map(|e| match e {
            Event::Message(msg) => Some(msg.text),
            _ => None,
        })
        .collect()
}

/// Runs step by step until the program stops (or `limit` steps); the step it stopped in.
fn run(m: &mut Machine, limit: u32) -> u32 {
    for k in 0..limit {
        m.run_until(STEP * k);
        if m.state() != &State::Running {
            return k;
        }
    }
    limit
}

fn floats(text: &str) -> Vec<f64> {
    text.trim_matches(|c| c == '[' || c == ']' || c == 'p')
        .split(',')
        .map(|x| x.trim().parse().unwrap())
        .collect()
}

#[test]
fn force_mode_in_free_space_moves_along_the_compliant_axis_at_its_speed_limit() {
    let src = "p0 = get_actual_tcp_pose()\n\
        force_mode(p[0, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0], [0, 0, -10, 0, 0, 0], 2, [0.1, 0.1, 0.1, 0.17, 0.17, 0.17])\n\
        sleep(0.5)\n\
        textmsg(is_steady())\n\
        sleep(0.5)\n\
        end_force_mode()\n\
        p1 = get_actual_tcp_pose()\n\
        textmsg(pose_sub(p1, p0))\n\
        textmsg(get_tcp_force())\n\
        sleep(0.2)\n\
        textmsg(pose_sub(get_actual_tcp_pose(), p1))\n";
    let mut m = machine(src);
    run(&mut m, 2000);
    assert_eq!(m.state(), &State::Finished);
    let msgs = messages(&mut m);
    assert_eq!(msgs[0], "False", "the arm moves in force mode");
    let moved = floats(&msgs[1]);
    // 1 s at 0.1 m/s down (-z: the wrench's sign), nothing else.
    assert!((moved[2] + 0.1).abs() < 0.003, "{moved:?}");
    for k in [0, 1, 3, 4, 5] {
        assert!(moved[k].abs() < 1e-6, "axis {k} held: {moved:?}");
    }
    // Nothing resists in free space: the sensor reads nothing.
    assert!(
        floats(&msgs[2]).iter().all(|f| f.abs() < 1e-9),
        "{}",
        msgs[2]
    );
    // end_force_mode: the arm stays where force mode left it.
    assert!(
        floats(&msgs[3]).iter().all(|f| f.abs() < 1e-9),
        "{}",
        msgs[3]
    );
}

#[test]
fn force_mode_presses_against_a_plane_until_the_spring_balances_the_wrench() {
    let src = "p0 = get_actual_tcp_pose()\n\
        force_mode(p[0, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0], [0, 0, -10, 0, 0, 0], 2, [0.1, 0.1, 0.1, 0.17, 0.17, 0.17])\n\
        while tool_contact() == 0:\n  sync()\nend\n\
        textmsg(\"contact\")\n\
        sleep(1.0)\n\
        textmsg(get_tcp_force())\n\
        textmsg(pose_sub(get_actual_tcp_pose(), p0))\n\
        textmsg(is_steady())\n\
        end_force_mode()\n";
    let mut m = machine(src);
    let start = m.tcp_pose();
    // A table 50 mm below the tool, 5000 N/m.
    m.world_mut()
        .set(&format!(
            "contact_plane=p[0, 0, {}, 0, 0, 0]",
            start[2] - 0.05
        ))
        .unwrap();
    m.world_mut().set("contact_stiffness=5000").unwrap();
    let end = run(&mut m, 2000);
    assert_eq!(m.state(), &State::Finished);
    let msgs = messages(&mut m);
    assert_eq!(msgs[0], "contact");
    let f = floats(&msgs[1]);
    // The table pushes back with the 10 N the arm applies.
    assert!((f[2] - 10.0).abs() < 0.01, "{f:?}");
    assert!(f[0].abs() < 1e-9 && f[1].abs() < 1e-9, "{f:?}");
    // 50 mm down to the table, then 10 N / 5000 N/m = 2 mm into it.
    let moved = floats(&msgs[2]);
    assert!((moved[2] + 0.052).abs() < 1e-4, "{moved:?}");
    assert_eq!(msgs[3], "True", "at rest against the table");
    // 50 mm at 0.1 m/s: contact after about 0.5 s; then 1 s.
    assert!((700..=800).contains(&end), "{end}");
}

#[test]
fn force_mode_holds_the_axes_it_does_not_select_whatever_the_wrench_says_there() {
    // Only z is compliant; the wrench asks for force and torque on every axis, and a
    // tilted surface pushes back partly along x: x, y and the orientation stay put.
    // (Types 2 and 3 keep the frame's z axis; type 1 turns it toward the frame's origin.)
    for kind in [2, 3] {
        let src = format!(
            "p0 = get_actual_tcp_pose()\n\
            force_mode(p[0.3, 0.2, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0], [10, -10, -10, 1, -1, 1], {kind}, [0.1, 0.1, 0.1, 0.17, 0.17, 0.17])\n\
            sleep(1.0)\n\
            textmsg(pose_sub(get_actual_tcp_pose(), p0))\n\
            end_force_mode()\n"
        );
        let mut m = machine(&src);
        let start = m.tcp_pose();
        // A surface 30 mm below, tilted 0.3 rad about y.
        m.world_mut()
            .set(&format!(
                "contact_plane=p[{}, {}, {}, 0, 0.3, 0]",
                start[0],
                start[1],
                start[2] - 0.03
            ))
            .unwrap();
        m.world_mut().set("contact_stiffness=5000").unwrap();
        run(&mut m, 2000);
        assert_eq!(m.state(), &State::Finished, "type {kind}");
        let moved = floats(&messages(&mut m)[0]);
        for k in [0, 1, 3, 4, 5] {
            assert!(moved[k].abs() < 1e-9, "type {kind}, axis {k}: {moved:?}");
        }
        assert!(moved[2] < -0.02, "type {kind}: z is compliant: {moved:?}");
    }
}

#[test]
fn speedl_until_tool_contact_stops_at_the_surface() {
    // ur_rtde's moveUntilContact: speedl toward the surface until tool_contact, then stopl.
    let src = "speedl([0, 0, -0.05, 0, 0, 0], 0.5)\n\
        while tool_contact(direction=[0, 0, -1, 0, 0, 0]) == 0:\n  speedl([0, 0, -0.05, 0, 0, 0], 0.5)\nend\n\
        stopl(3)\n\
        textmsg(get_actual_tcp_pose())\n\
        textmsg(tool_contact(direction=[0, 0, 1, 0, 0, 0]))\n\
        textmsg(force() > 0)\n";
    let mut m = machine(src);
    let start = m.tcp_pose();
    let table = start[2] - 0.02;
    m.world_mut()
        .set(&format!("contact_plane=p[0, 0, {table}, 0, 0, 0]"))
        .unwrap();
    m.world_mut().set("contact_stiffness=20000").unwrap();
    run(&mut m, 3000);
    assert_eq!(m.state(), &State::Finished);
    let msgs = messages(&mut m);
    let at = floats(&msgs[0]);
    // Stopped just past the surface (a step of travel and the ramp down).
    assert!(
        at[2] < table && at[2] > table - 0.002,
        "{} vs {table}",
        at[2]
    );
    // Contact against the motion only: none seen looking the other way.
    assert_eq!(msgs[1], "0");
    assert_eq!(msgs[2], "True");
}

#[test]
fn move_until_contact_steps_back_to_where_the_contact_began() {
    // The loop ur_rtde's control script runs for moveUntilContact: speedl until
    // tool_contact, then the joints from just before the contact
    // (get_actual_joint_positions_history), stopl, and movel back there.
    let src = "xd = [0, 0, -0.05, 0, 0, 0]\n\
        while True:\n\
          step_back = tool_contact(direction=p[0, 0, -1, 0, 0, 0])\n\
          if step_back <= 0:\n\
            speedl(xd, 0.5, t=get_steptime())\n\
          else:\n\
            q = get_actual_joint_positions_history(step_back)\n\
            stopl(3)\n\
            textmsg(get_actual_tcp_pose())\n\
            movel(q)\n\
            break\n\
          end\n\
        end\n\
        textmsg(get_actual_tcp_pose())\n\
        textmsg(tool_contact())\n";
    let mut m = machine(src);
    let start = m.tcp_pose();
    let table = start[2] - 0.02;
    m.world_mut()
        .set(&format!("contact_plane=p[0, 0, {table}, 0, 0, 0]"))
        .unwrap();
    m.world_mut().set("contact_stiffness=20000").unwrap();
    run(&mut m, 5000);
    assert_eq!(m.state(), &State::Finished);
    let msgs = messages(&mut m);
    let stopped = floats(&msgs[0]);
    let back = floats(&msgs[1]);
    // It stopped past the surface, then went back to just above it: out of contact.
    assert!(stopped[2] < table, "{} vs {table}", stopped[2]);
    assert!(
        back[2] >= table && back[2] < table + 0.0005,
        "{} vs {table}",
        back[2]
    );
    assert_eq!(msgs[2], "0");
}

#[test]
fn the_joint_history_ends_at_its_bound() {
    let mut m = machine("textmsg(get_actual_joint_positions_history(1000))\nget_actual_joint_positions_history(1001)\n");
    run(&mut m, 10);
    assert!(
        matches!(m.state(), State::Error(e) if e.message().contains("beyond the history buffer")),
        "{:?}",
        m.state()
    );
    assert_eq!(messages(&mut m).len(), 1);
}

#[test]
fn teach_mode_is_not_steady_and_the_joints_follow_the_operator() {
    let src = "teach_mode()\n\
        textmsg(is_steady())\n\
        sleep(0.1)\n\
        textmsg(get_actual_joint_positions())\n\
        end_teach_mode()\n\
        textmsg(is_steady())\n";
    let mut m = machine(src);
    m.run_until(Duration::ZERO);
    assert!(m.arm().hand_guided());
    assert_eq!(m.arm().control_mode(), 1);
    let q = [0.1, -1.2, 1.3, -1.5, -1.6, 0.2];
    m.arm_mut().move_by_hand(q).unwrap();
    assert!(m
        .arm_mut()
        .move_by_hand([7.0, 0.0, 0.0, 0.0, 0.0, 0.0])
        .is_err());
    run(&mut m, 200);
    assert_eq!(m.state(), &State::Finished);
    let msgs = messages(&mut m);
    assert_eq!(msgs[0], "False");
    assert_eq!(floats(&msgs[1]), q);
    assert_eq!(msgs[2], "True");
    assert!(!m.arm().hand_guided(), "the program's end ends teach mode");
}

#[test]
fn freedrive_mode_ends_with_the_program() {
    let mut m = machine("freedrive_mode()\ntextmsg(is_steady())\nsleep(0.01)\n");
    m.run_until(Duration::ZERO);
    assert!(m.arm().hand_guided());
    run(&mut m, 100);
    assert_eq!(messages(&mut m), ["False"]);
    assert!(!m.arm().hand_guided());
    // Outside teach/freedrive the joints cannot be moved by hand under a program.
    let mut m = machine("sleep(1)\n");
    m.run_until(Duration::ZERO);
    assert!(!m.arm().hand_guided());
}

/// The step a `movej(..., t=1.5)` program ends in with the slider at `fraction`, changed
/// to `then` after `switch` steps.
fn movej_steps(fraction: f64, switch: u32, then: f64) -> u32 {
    let mut m = machine("movej([0.5, -1.2, 0.8, -1.9, 0.3, 0.4], t=1.5)\n");
    m.arm_mut().speed_fraction = fraction;
    for k in 0..10_000 {
        if k == switch {
            m.arm_mut().speed_fraction = then;
        }
        m.run_until(STEP * k);
        if m.state() != &State::Running {
            assert_eq!(m.joint_positions(), [0.5, -1.2, 0.8, -1.9, 0.3, 0.4]);
            return k;
        }
    }
    panic!("the move never ended");
}

#[test]
fn the_speed_slider_scales_a_move_and_a_change_mid_move_takes_effect_then() {
    assert_eq!(movej_steps(1.0, 0, 1.0), 750);
    // Half speed: 3.0 s.
    assert_eq!(movej_steps(0.5, 0, 0.5), 1500);
    // Full speed for 0.75 s (half the move), then half speed for the rest: 0.75 + 1.5 s.
    assert_eq!(movej_steps(1.0, 375, 0.5), 1125);
}

#[test]
fn the_speed_slider_scales_the_arm_speeds_and_stops_the_arm_at_zero() {
    let mut m =
        machine("speedj([0.2, 0, 0, 0, 0, 0], 100, 1.0)\ntextmsg(get_actual_joint_speeds())\n");
    m.arm_mut().speed_fraction = 0.5;
    run(&mut m, 2000);
    let msgs = messages(&mut m);
    let qd = floats(&msgs[0]);
    assert!((qd[0] - 0.1).abs() < 1e-9, "{qd:?}");
    // At 0 the move does not advance and the program waits on it.
    let mut m = machine("movej([0.5, -1.2, 0.8, -1.9, 0.3, 0.4], t=0.5)\ntextmsg(\"done\")\n");
    m.arm_mut().speed_fraction = 0.0;
    let q0 = m.joint_positions();
    run(&mut m, 1000);
    assert_eq!(m.state(), &State::Running);
    assert_eq!(m.joint_positions(), q0);
    m.arm_mut().speed_fraction = 1.0;
    for k in 1000..1300 {
        m.run_until(STEP * k);
    }
    assert_eq!(m.state(), &State::Finished);
    assert_eq!(messages(&mut m), ["done"]);
}

/// The joints after a streamed `speedj` (50 calls of `t=0.002`, each speed a little
/// higher, as UR's External Control script interpolates a spline) at the slider's
/// `fraction`, and the step the stream ended in.
fn speedj_stream(fraction: f64) -> ([f64; 6], u32) {
    let src = "i = 0
        while i < 50:
          i = i + 1
          speedj([0.01 * i, -0.005 * i, 0, 0, 0, 0], 20, 0.002)
        end
        stopj(1000)
";
    let mut m = machine(src);
    m.arm_mut().speed_fraction = fraction;
    let end = run(&mut m, 10_000);
    assert_eq!(m.state(), &State::Finished);
    (m.joint_positions(), end)
}

#[test]
fn under_the_speed_slider_a_streamed_speedj_keeps_its_path_and_takes_longer() {
    let (full, full_steps) = speedj_stream(1.0);
    let (quarter, quarter_steps) = speedj_stream(0.25);
    // Each call lasts its `t` of motion time: four steps at 25 %, so the program's own
    // clock (its count of calls) stays on the path the arm follows.
    assert!(
        quarter_steps >= 4 * full_steps - 8 && quarter_steps <= 4 * full_steps + 8,
        "{full_steps} steps at 100 %, {quarter_steps} at 25 %"
    );
    for j in 0..6 {
        assert!(
            (full[j] - quarter[j]).abs() < 1e-6,
            "joint {j}: {} at 100 %, {} at 25 %",
            full[j],
            quarter[j]
        );
    }
    assert!(
        full[0] - Arm::default().q[0] > 0.01,
        "the stream moved the arm"
    );
}

/// A `servoj` with `t` reaches its target in `t` of motion time and returns then.
#[test]
fn under_the_speed_slider_servoj_returns_when_its_target_is_reached() {
    let src = "q = get_actual_joint_positions()
        servoj([q[0] + 0.01, q[1], q[2], q[3], q[4], q[5]], t=0.1)
        textmsg(get_actual_joint_positions()[0] - q[0])
";
    let mut m = machine(src);
    m.arm_mut().speed_fraction = 0.5;
    let end = run(&mut m, 1000);
    assert_eq!(m.state(), &State::Finished);
    let moved: f64 = messages(&mut m)[0].parse().unwrap();
    assert!((moved - 0.01).abs() < 1e-9, "moved {moved}");
    // 0.1 s of motion at half speed: 100 steps of 2 ms.
    assert!((100..=102).contains(&end), "ended in step {end}");
}

#[test]
fn is_within_safety_limits_is_reach_and_joint_range() {
    let home = Arm::default().q;
    let reachable = forward(
        &Model::Ur5e.dh(),
        [0.3, -1.2, 1.4, -1.8, -1.5, 0.2],
        [0.0; 6],
    );
    let src = format!(
        "textmsg(is_within_safety_limits(p[3.0, 0, 0.4, 0, 3.14, 0]))\n\
         textmsg(is_within_safety_limits(p{reachable:?}))\n\
         textmsg(is_within_safety_limits([0, -1.57, 0, -1.57, 0, 7.0]))\n\
         textmsg(is_within_safety_limits({home:?}))\n"
    );
    let mut m = machine(&src);
    run(&mut m, 10);
    assert_eq!(messages(&mut m), ["False", "True", "False", "True"]);
}
