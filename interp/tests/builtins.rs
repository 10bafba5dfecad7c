//! Built-ins, one by one.
mod common;
use std::time::Duration;

use common::{int32s, messages, runtime_error, Harness, Input};
use urscript_interp::{
    Config, Effect, Event, Machine, MessageKind, Outcome, Program, State, Stub, Value,
};

fn one(expr: &str) -> String {
    messages(&format!("textmsg({expr})\n"))[0].clone()
}

fn sock(body: &str) -> String {
    format!("socket_open(\"127.0.0.1\", 5000)\n{body}")
}

/// Runs `body` after opening socket_0, with `server` answering.
fn with_server(body: &str, server: impl FnMut(Input<'_>) -> Vec<(String, Vec<u8>)>) -> Harness {
    let mut h = Harness::new(&sock(body), Config::default());
    h.run(Duration::from_secs(10), server);
    assert_eq!(
        h.m.state(),
        &State::Finished,
        "{:?} {:?}",
        h.messages,
        h.calls
    );
    h
}

fn preloaded(body: &str, data: &'static [u8]) -> Harness {
    with_server(body, move |i| match i {
        Input::Connected(..) => vec![("socket_0".into(), data.to_vec())],
        _ => Vec::new(),
    })
}

#[test]
fn socket_sends() {
    let h = preloaded(
        "socket_send_string(\"hi\")\nsocket_send_line(\"hello\")\nsocket_send_byte(2)\nsocket_send_int(-1)\nsocket_set_var(\"POS_Y\", 2200)\nsocket_send_string(p[1.0, 2.0, 3.0, 4.0, 5.0, 6.0])\nsocket_send_line([True, False])\nsocket_send_string(2.123456123456)\nok = socket_send_line(\"x\", socket_name=\"nope\")\ntextmsg(ok)\n",
        b"",
    );
    let mut want =
        b"hihello\n\x02\xFF\xFF\xFF\xFFSET POS_Y 2200\np[1, 2, 3, 4, 5, 6][True, False]\n2.123456"
            .to_vec();
    assert_eq!(h.sent("socket_0"), want.as_slice());
    want.clear();
    assert_eq!(h.messages, ["False"]);
    assert!(
        h.calls
            .iter()
            .any(|c| c == "2: socket_send_string(\"hi\") -> True"),
        "{:?}",
        h.calls
    );
}

#[test]
fn socket_send_int_truncates_a_float() {
    // Drivers send scaled floats (`socket_send_int(10000.0 * pose[0])`): truncated
    // toward zero (our choice; the manual is silent), so -0.9 and 0.9 both send 0.
    let h = preloaded(
        "socket_send_int(2.9)\nsocket_send_int(-2.9)\nsocket_send_int(-0.9)\nsocket_send_int(10000.0 * 0.12345678)\nsocket_send_int(-2147483648.5)\n",
        b"",
    );
    assert_eq!(
        h.sent("socket_0"),
        b"\x00\x00\x00\x02\xFF\xFF\xFF\xFE\x00\x00\x00\x00\x00\x00\x04\xD2\x80\x00\x00\x00"
    );
    // Outside the int32 range it is an error, as an int literal there is.
    let e = runtime_error("socket_send_int(2147483648.0)\n");
    assert!(e.contains("needs an int"), "{e}");
}

#[test]
fn socket_reads_from_the_spec_vectors() {
    let h = preloaded(
        "textmsg(socket_read_ascii_float(4))\ntextmsg(socket_read_binary_integer(3))\ntextmsg(socket_read_byte_list(3))\ntextmsg(socket_read_line())\ntextmsg(socket_read_string(prefix=\">\", suffix=\"<\"))\ntextmsg(socket_read_string(\"socket_0\", \">\", \"<\"))\n",
        b"( 1.414 , 3.14159, 1.616, 0.0 )\x00\x00\x00\x64\x00\x00\x07\xD0\x00\x00\x75\x30\x64\xC8\x2Creply from the server:\r\nnoise>hello<>world<",
    );
    assert_eq!(
        h.messages,
        [
            "[4, 1.414, 3.14159, 1.616, 0]",
            "[3, 100, 2000, 30000]",
            "[3, 100, 200, 44]",
            "reply from the server:",
            "hello",
            "world"
        ]
    );
}

#[test]
fn socket_read_timeouts_give_sentinels_after_their_timeout() {
    let mut h = Harness::new(
        &sock("a = socket_read_ascii_float(3, timeout=0.5)\nb = socket_read_binary_integer(2, \"socket_0\", 0.25)\nc = socket_read_string()\nd = socket_get_var(\"X\")\ntextmsg(a)\ntextmsg(b)\ntextmsg(str_len(c), d)\n"),
        Config::default(),
    );
    h.run_silent(Duration::from_secs(10));
    assert_eq!(h.m.state(), &State::Finished);
    assert_eq!(h.messages, ["[0, nan, nan, nan]", "[0, -1, -1]", "00"]);
    // 0.5 + 0.25 + 2 + 2 seconds, plus the connect step.
    assert!((h.now.as_secs_f64() - 4.75).abs() < 0.01, "{:?}", h.now);
    assert_eq!(h.sent("socket_0"), b"GET X\n");
}

#[test]
fn socket_read_with_zero_timeout_waits_forever() {
    let mut h = Harness::new(
        &sock("x = socket_read_line(timeout=0)\ntextmsg(x)\n"),
        Config::default(),
    );
    h.run_silent(Duration::from_secs(20));
    assert_eq!(h.m.state(), &State::Running);
    assert_eq!(h.m.poll_timeout(), None);
    h.m.handle_received("socket_0", b"late\n");
    h.run_silent(Duration::from_secs(21));
    assert_eq!(h.messages, ["late"]);
}

#[test]
fn a_byte_read_that_times_out_counts_the_bytes_that_arrived() {
    // Robotiq's gripper URCap: `GET SID` answered with a few bytes, read with a byte
    // list of 17 that times out; the count says how many arrived.
    let h = with_server(
        "socket_send_line(\"GET SID\")\nsid = socket_read_byte_list(17, timeout=0.1)\ntextmsg(sid[0])\ntextmsg(sid)\nn = socket_read_binary_integer(2, timeout=0.1)\ntextmsg(n)\n",
        |i| match i {
            Input::Received(_, b"GET SID\n") => {
                vec![("socket_0".into(), b"[9]\n".to_vec())]
            }
            _ => Vec::new(),
        },
    );
    assert_eq!(
        h.messages,
        [
            "4",
            "[4, 91, 57, 93, 10, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1, -1]",
            "[0, -1, -1]"
        ]
    );
}

#[test]
fn socket_get_var() {
    let h = with_server("textmsg(socket_get_var(\"POS_X\"))\n", |i| match i {
        Input::Received(_, b"GET POS_X\n") => vec![("socket_0".into(), b"POS_X 0077\n".to_vec())],
        _ => Vec::new(),
    });
    assert_eq!(h.messages, ["77"]);
}

#[test]
fn socket_read_on_a_socket_not_open_returns_the_sentinel_at_once() {
    assert_eq!(
        messages("textmsg(socket_read_byte_list(2, \"none\"))\n"),
        ["[0, -1, -1]"]
    );
}

#[test]
fn socket_open_failure_returns_false_and_the_program_goes_on() {
    let mut h = Harness::new(
        "ok = socket_open(\"10.0.0.1\", 5000, \"cam\")\ntextmsg(ok)\n",
        Config::default(),
    );
    h.refuse.push(5000);
    h.run_silent(Duration::from_secs(1));
    assert_eq!(h.messages, ["False"]);
    assert_eq!(
        h.connects,
        [("cam".to_string(), "10.0.0.1".to_string(), 5000)]
    );
}

#[test]
fn socket_close_and_program_end_close_sockets() {
    let mut h = Harness::new("socket_open(\"h\", 1, \"a\")\nsocket_open(\"h\", 2, \"b\")\nsocket_close(\"a\")\nsocket_close(\"never_opened\")\n", Config::default());
    h.run_silent(Duration::from_secs(1));
    assert_eq!(h.closed, ["a", "b"]);
}

#[test]
fn socket_argument_errors() {
    assert_eq!(
        runtime_error("socket_read_ascii_float(31)\n"),
        "line 1: `socket_read_ascii_float`: number must be 1..30, got 31"
    );
    assert_eq!(
        runtime_error("socket_send_byte(256)\n"),
        "line 1: `socket_send_byte`: value must be 0..255, got 256"
    );
    assert_eq!(
        runtime_error("socket_open(\"h\", 70000)\n"),
        "line 1: `socket_open`: port 70000 out of range"
    );
    // Argument names and counts are checked when the program compiles, before it runs.
    let e = Program::parse("x = 1\nif x:\n  socket_read_line(\"s\", bogus=1)\nend\n").unwrap_err();
    assert_eq!(
        e.to_string(),
        "line 3, column 3: `socket_read_line` has no parameter `bogus` (its parameters: socket_name, timeout)"
    );
    assert_eq!(e.kind(), urscript_interp::ParseErrorKind::Compile);
}

#[test]
fn peer_closing_resolves_pending_reads() {
    let mut h = Harness::new(
        &sock("x = socket_read_binary_integer(1, timeout=0)\ntextmsg(x)\n"),
        Config::default(),
    );
    h.run_silent(Duration::from_millis(10));
    h.m.handle_peer_closed("socket_0");
    h.run_silent(Duration::from_millis(20));
    assert_eq!(h.messages, ["[0, -1]"]);
}

#[test]
fn strings() {
    assert_eq!(one("str_cat(\"a\", 1.5)"), "a1.5");
    assert_eq!(
        one("str_cat(p[1, 2, 3, 0, 0, 0], [1, 2])"),
        "p[1, 2, 3, 0, 0, 0][1, 2]"
    );
    assert_eq!(one("str_len(\"hello\")"), "5");
    assert_eq!(one("str_sub(\"hello\", 1, 3)"), "ell");
    assert_eq!(one("str_sub(\"hello\", 2)"), "llo");
    assert_eq!(one("str_sub(\"hello\", 9)"), "");
    assert_eq!(one("str_find(\"a,b,c\", \",\")"), "1");
    assert_eq!(one("str_find(\"a,b,c\", \",\", 2)"), "3");
    assert_eq!(one("str_find(\"abc\", \"x\")"), "-1");
    assert_eq!(one("str_at(\"abc\", 2)"), "c");
    assert_eq!(one("str_empty(\"\")"), "True");
    assert_eq!(one("to_str(2.123456123456)"), "2.123456");
    assert_eq!(one("to_str(True)"), "True");
    assert_eq!(one("to_num(\"12\") + 1"), "13");
    assert_eq!(one("to_num(\" -2.5e1 \")"), "-25");
    assert!(runtime_error("to_num(\"abc\")\n").contains("is not a number"));
    assert!(runtime_error("str_len(5)\n").contains("needs a string, got int 5"));
    assert!(
        runtime_error("s = \"ab\"\nwhile True:\n  s = str_cat(s, s)\nend\n")
            .contains("more than 1023")
    );
}

#[test]
fn math() {
    assert_eq!(one("sin(0)"), "0");
    assert_eq!(one("cos(0)"), "1");
    assert_eq!(one("tan(0)"), "0");
    assert_eq!(one("asin(1)"), "1.570796");
    assert_eq!(one("acos(1)"), "0");
    assert_eq!(one("atan(1)"), "0.785398");
    assert_eq!(one("atan2(1, 1)"), "0.785398");
    // The manual: atan2(x, y) is the arc tangent of x/y, the signs of both giving the
    // quadrant.
    assert_eq!(one("atan2(1, 0)"), "1.570796");
    assert_eq!(one("atan2(0, -1)"), "3.141593");
    assert_eq!(one("atan2(y=-1, x=1)"), "2.356194");
    assert_eq!(one("sqrt(16)"), "4");
    assert_eq!(one("pow(2, 10)"), "1024");
    assert_eq!(one("floor(2.7)"), "2");
    assert_eq!(one("floor(-2.5)"), "-3");
    assert_eq!(one("ceil(2.1)"), "3");
    assert_eq!(one("log(10, 1000)"), "3");
    assert_eq!(one("norm(-3)"), "3");
    assert_eq!(one("norm([3, 4])"), "5");
    assert_eq!(one("d2r(180)"), "3.141593");
    assert_eq!(one("r2d(3.14159265358979)"), "180");
    assert_eq!(one("length([1, 2, 3])"), "3");
    assert_eq!(one("get_list_length([])"), "0");
    assert_eq!(one("binary_list_to_integer([True, False, True])"), "5");
    assert_eq!(one("integer_to_binary_list(6)[1]"), "True");
    assert_eq!(one("length(integer_to_binary_list(6))"), "32");
    assert_eq!(one("random() < 1"), "True");
    assert_eq!(
        one("point_dist(p[0, 0, 0, 0, 0, 0], p[3, 4, 0, 0, 0, 0])"),
        "5"
    );
    assert_eq!(
        one("pose_trans(p[1, 0, 0, 0, 0, 1.5707963], p[1, 0, 0, 0, 0, 0])"),
        "p[1, 1, 0, 0, 0, 1.570796]"
    );
    assert_eq!(
        one("pose_inv(p[1, 2, 3, 0, 0, 0])"),
        "p[-1, -2, -3, 0, 0, 0]"
    );
    assert_eq!(
        one("pose_add(p[1, 2, 3, 0, 0, 0.5], p[1, 1, 1, 0, 0, 0.25])"),
        "p[2, 3, 4, 0, 0, 0.75]"
    );
    assert_eq!(
        one("pose_sub(p[1, 2, 3, 0, 0, 0.5], p[1, 1, 1, 0, 0, 0.25])"),
        "p[0, 1, 2, 0, 0, 0.25]"
    );
    assert_eq!(
        one("interpolate_pose(p[0, 0, 0, 0, 0, 0], p[1, 2, 0, 0, 0, 0], 0.5)"),
        "p[0.5, 1, 0, 0, 0, 0]"
    );
    assert!(runtime_error("sqrt(-1)\n").contains("outside its domain"));
}

#[test]
fn time_builtins() {
    let mut h = Harness::new(
        "textmsg(get_steptime())\nsleep(0.1)\nsync()\nsync()\n",
        Config::cb3(),
    );
    h.run_silent(Duration::from_secs(1));
    assert_eq!(h.messages, ["0.008"]);
    // sleep(0.1) is 13 steps of 8 ms, then two more steps.
    assert_eq!(h.now, Duration::from_millis(8 * 15));
}

/// Steps (2 ms) a wait of `secs` takes: rounded up, at least one.
fn steps(secs: f64) -> u64 {
    ((secs * 500.0) - 1e-9).ceil().max(1.0) as u64
}

#[test]
fn virtual_arm_motion_takes_time() {
    use urscript_interp::kinematics::move_time;
    let src = "qa = [1, -1.5707963267948966, 1.5707963267948966, -1.5707963267948966, -1.5707963267948966, 0]
movej(qa, v=0.5)
p = get_actual_tcp_pose()
movel(pose_trans(p, p[0, 0, 0.1, 0, 0, 0]), v=0.1)
textmsg(point_dist(p, get_actual_tcp_pose()))
q = get_actual_joint_positions()
textmsg(norm(get_inverse_kin(get_forward_kin(q), q) - q) < 0.000001)
movej(qa, t=0.5)
servoj([0.1, -1.5, 1.5, -1.5, -1.5, 0], t=0.008)
textmsg(get_target_joint_speeds()[0])
speedj([0.2, 0, 0, 0, 0, 0], 2, 0.1)
stopj(2)
textmsg(get_actual_joint_speeds())
";
    let mut h = Harness::new(src, Config::default());
    h.run_silent(Duration::from_secs(10));
    assert_eq!(h.m.state(), &State::Finished);
    // A servoj that ended leaves the arm at rest at its target (the speed of its segment,
    // -112.5 rad/s, is what a sample during it sees: `motion_in_time.rs`).
    assert_eq!(h.messages, ["0.1", "True", "0", "[0, 0, 0, 0, 0, 0]"]);
    // From the start position [0, -pi/2, 0, -pi/2, 0, 0] the first movej's longest joint
    // moves pi/2 at 0.5 rad/s with 1.4 rad/s² ramps; the movel 0.1 m at 0.1 m/s with
    // 1.2 m/s² ramps; then 0.5 s, 8 ms, 0.1 s, and stopj's 0.1 s ramp from 0.2 rad/s
    // down at 2 rad/s².
    let t1 = steps(move_time(std::f64::consts::FRAC_PI_2, 0.5, 1.4));
    let t2 = steps(move_time(0.1, 0.1, 1.2));
    assert_eq!((t1, t2), (1750, 542));
    assert_eq!(
        h.now,
        Duration::from_millis(2 * (t1 + t2 + 250 + 4 + 50 + 50))
    );
    // speedj ramped joint 0 from rest to 0.2 rad/s in its 0.1 s (0.01 rad), stopj back to
    // rest in 0.1 s (0.01 rad); the pose follows the joints.
    let q = h.m.joint_positions();
    assert!((q[0] - 0.12).abs() < 1e-12, "{q:?}");
    let pose = urscript_interp::kinematics::forward(
        &urscript_interp::kinematics::Model::Ur5e.dh(),
        q,
        [0.0; 6],
    );
    assert_eq!(h.m.tcp_pose(), pose);
}

#[test]
fn a_pose_out_of_reach_stops_the_program_as_on_the_controller() {
    // (A `movel` there sets off along its line and ends in a protective stop:
    // tests/motion_in_time.rs.)
    let h = common::run("movej(p[2, 0, 0.5, 0, 3.14, 0])\ntextmsg(\"never\")\n");
    let State::Error(e) = h.m.state() else {
        panic!("{:?}", h.m.state())
    };
    assert_eq!(e.line(), 1);
    assert!(e.message().contains("out of reach"), "{e}");
    assert!(h.messages.is_empty());
    assert_eq!(
        common::messages(
            "textmsg(get_inverse_kin_has_solution(p[2, 0, 0.5, 0, 3.14, 0]), get_inverse_kin_has_solution(get_forward_kin()))\n"
        ),
        ["FalseTrue"]
    );
}

#[test]
fn io_and_registers() {
    let src = "set_standard_digital_out(3, True)\nset_tool_digital_out(1, True)\nset_configurable_digital_out(0, True)\nwrite_output_integer_register(5, 42)\nwrite_output_float_register(0, 1.5)\nwrite_output_boolean_register(63, True)\nset_standard_analog_out(1, 0.7)\ntextmsg(get_standard_digital_out(3), get_standard_digital_out(2))\ntextmsg(get_tool_digital_out(1), get_configurable_digital_out(0))\ntextmsg(read_output_integer_register(5), read_output_float_register(0))\ntextmsg(read_output_boolean_register(63), read_input_integer_register(0))\ntextmsg(get_standard_digital_in(0), tool_contact())\nset_payload(1.5, [0, 0, 0.05])\nset_tcp(p[0, 0, 0.1, 0, 0, 0])\n";
    assert_eq!(
        messages(src),
        ["TrueFalse", "TrueTrue", "421.5", "True0", "False0"]
    );
    assert!(runtime_error("set_standard_digital_out(20, True)\n").contains("no output 20"));
}

#[test]
fn textmsg_and_popup() {
    assert_eq!(
        messages("textmsg(\"a\")\ntextmsg(\"b\", 2)\npopup(\"hello\", \"Title\", warning=True)\nvarmsg(\"x\", [1, 2])\n"),
        ["a", "b2", "popup \"Title\": hello", "x = [1, 2]"]
    );
    // Each message says which function showed it, a popup with its title and flags.
    let mut m = Machine::new(
        Program::parse("popup(\"hello\", \"Title\", warning=True)\n").unwrap(),
        Config::default(),
    );
    m.run_until(Duration::ZERO);
    let Some(Event::Message(msg)) = m.poll_event() else {
        panic!("no message")
    };
    assert_eq!(msg.line, 1);
    assert_eq!(
        msg.kind,
        MessageKind::Popup {
            title: "Title".into(),
            warning: true,
            error: false,
            blocking: false
        }
    );
}

#[test]
fn stubs_replace_unknown_functions() {
    let p = Program::parse(
        "rq_activate()\nx = rq_current_pos()\ntextmsg(x)\nmovej([1, 2, 3, 4, 5, 6])\n",
    )
    .unwrap();
    let config = Config::default()
        .stub("rq_activate", Stub::NoOp)
        .stub("rq_current_pos", Stub::Return(Value::Int(3)))
        .stub("movej", Stub::NoOp);
    let mut m = Machine::new(p, config);
    assert!(m.unknown_functions().is_empty());
    m.run_until(Duration::ZERO);
    assert_eq!(m.state(), &State::Finished);
    let events: Vec<Event> = std::iter::from_fn(|| m.poll_event()).collect();
    assert!(events
        .iter()
        .any(|e| matches!(e, Event::Message(m) if m.text == "3")));
    let stubbed = events
        .iter()
        .find_map(|e| match e {
            Event::Call(c) if c.name == "rq_current_pos" => Some(c),
            _ => None,
        })
        .expect("the stub's call is recorded");
    assert_eq!(stubbed.to_string(), "rq_current_pos() -> 3 (stub)");
    assert_eq!((stubbed.line, stubbed.column), (2, 5));
    assert_eq!(stubbed.outcome, Outcome::Stubbed);
    assert_eq!(stubbed.assigned_to.as_deref(), Some("x"));
    assert_eq!(m.joint_positions()[0], 0.0);
}

#[test]
fn unknown_functions_are_listed_before_running() {
    let p = Program::parse(
        "def prog():\n  if False:\n    force_mode_example()\n  end\n  sync()\nend\n",
    )
    .unwrap();
    let m = Machine::new(p, Config::default());
    assert_eq!(
        m.unknown_functions(),
        [("force_mode_example".to_string(), 3)]
    );
}

#[test]
fn binary_int_stream_drained_until_empty() {
    // The trajectory-cancel idiom: read until result[0] <= 0.
    let h = preloaded(
        "n = 0\nwhile True:\n  r = socket_read_binary_integer(2, timeout=0.01)\n  if r[0] <= 0:\n    break\n  end\n  n = n + 1\nend\ntextmsg(n)\n",
        &[0, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 3, 0, 0, 0, 4, 0, 0, 0, 5, 0, 0, 0, 6],
    );
    assert_eq!(h.messages, ["3"]);
    let _ = int32s(&[]);
}

#[test]
fn optimove_and_movec_and_direct_torque() {
    let mut h = Harness::new("optimovej([0, -1.5707963267948966, 0.3, -1.5707963267948966, 0, 0], a=0, v=0.3)\np = get_actual_tcp_pose()\nmovec(p, pose_add(p, p[0, 0, -0.1, 0, 0, 0]), a=0, v=0.1)\ndirect_torque([0, 0, 0, 0, 0, 0])\ntextmsg(point_dist(p, get_actual_tcp_pose()))\n", Config::default());
    h.run_silent(Duration::from_secs(10));
    assert_eq!(h.m.state(), &State::Finished);
    assert_eq!(h.messages, ["0.1"]);
    // 0.3 rad at 0.3 rad/s, 0.1 m at 0.1 m/s (no ramps: a=0), one step.
    assert_eq!(h.now, Duration::from_millis(1000 + 1000 + 2));
}

#[test]
fn servoc_moves_to_the_pose_and_protective_stop_is_left_for_the_controller() {
    use std::time::Duration;
    use urscript_interp::{Config, Machine, Program};
    let src = "movej([0.2, -1.4, 1.0, -1.2, -1.5, 0.3])\np0 = get_actual_tcp_pose()\ntarget = pose_trans(p0, p[0, 0, 0.05, 0, 0, 0])\nservoc(target)\nd = pose_dist(get_actual_tcp_pose(), target)\nprotective_stop()\n";
    let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
    m.run_until(Duration::from_secs(5));
    assert_eq!(m.state(), &urscript_interp::State::Finished);
    match m.global("d") {
        Some(urscript_interp::Value::Float(d)) => assert!(*d < 1e-9, "{d}"),
        other => panic!("{other:?}"),
    }
    assert!(m.effects().contains(&Effect::ProtectiveStop));
}
