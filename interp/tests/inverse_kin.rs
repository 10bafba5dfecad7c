//! `get_inverse_kin` of a pose out of reach, as the controller treats it: the manual
//! gives the call a "maximum allowed" position and orientation error (1e-10 m and rad by
//! default) and `get_inverse_kin_has_solution` to avoid its runtime exception when no
//! solution exists. The zero pose (`p[0, 0, 0, 0, 0, 0]`, what a program reads from
//! registers no client has written yet) is out of every UR arm's reach.
use std::time::Duration;

use urscript_interp::kinematics::{forward, Model};
use urscript_interp::{Config, Event, Machine, Program, State};

fn run(src: &str) -> (Machine, Vec<String>) {
    let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
    m.run_until(Duration::from_secs(5));
    let msgs = std::iter::from_fn(|| m.poll_event())
        .filter_map(|e| match e {
            Event::Message(msg) => Some(msg.text),
            _ => None,
        })
        .collect();
    (m, msgs)
}

#[test]
fn the_zero_pose_raises_the_runtime_exception_unless_the_program_asks_first() {
    // A program that reads its target from registers before the client wrote them.
    let src = "target = p[read_input_float_register(0), read_input_float_register(1), read_input_float_register(2), read_input_float_register(3), read_input_float_register(4), read_input_float_register(5)]\n\
        if get_inverse_kin_has_solution(target):\n  movej(get_inverse_kin(target))\nelse:\n  textmsg(\"not yet\")\nend\n\
        q = get_inverse_kin(target)\n\
        textmsg(\"never\")\n";
    let (m, msgs) = run(src);
    assert_eq!(msgs, ["not yet"]);
    let State::Error(e) = m.state() else {
        panic!("{:?}", m.state())
    };
    assert_eq!(e.line(), 7);
    assert!(
        e.message().contains("no inverse kinematics solution")
            && e.message().contains("maxPositionError"),
        "{e}"
    );
}

#[test]
fn a_pose_just_out_of_reach_has_a_solution_within_the_allowed_errors() {
    // The arm stretched out; the pose 5 mm beyond its tool.
    let dh = Model::Ur5e.dh();
    let stretched = [0.0, -0.3, 0.0, -1.2, -1.57, 0.0];
    let at = forward(&dh, stretched, [0.0; 6]);
    let out = [at[0], at[1], at[2] - dh.d[0]];
    let n = (out[0] * out[0] + out[1] * out[1] + out[2] * out[2]).sqrt();
    let pose = format!(
        "p[{}, {}, {}, {}, {}, {}]",
        at[0] + 0.005 * out[0] / n,
        at[1] + 0.005 * out[1] / n,
        at[2] + 0.005 * out[2] / n,
        at[3],
        at[4],
        at[5]
    );
    let near = "[0.0, -0.5, 0.3, -1.2, -1.5, 0.1]";
    let src = format!(
        "x = {pose}\n\
        textmsg(get_inverse_kin_has_solution(x, {near}), get_inverse_kin_has_solution(x, {near}, 0.01, 0.1))\n\
        q = get_inverse_kin(x, {near}, maxPositionError=0.01, maxOrientationError=0.1)\n\
        textmsg(point_dist(get_forward_kin(q), x) < 0.01)\n\
        get_inverse_kin(x, {near}, maxPositionError=-1)\n"
    );
    let (m, msgs) = run(&src);
    assert_eq!(msgs, ["FalseTrue", "True"]);
    let State::Error(e) = m.state() else {
        panic!("{:?}", m.state())
    };
    assert!(e.message().contains("must be 0 or more"), "{e}");
}
