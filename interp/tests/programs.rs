//! The test programs of `tests/programs/`, each against a fake in-memory server through
//! the sans-IO events, in virtual time.
mod common;
use std::time::Duration;

use common::{int32s, Harness, Input};
use urscript_interp::{Config, State, Value};

fn reply(name: &str, bytes: impl AsRef<[u8]>) -> Vec<(String, Vec<u8>)> {
    vec![(name.to_string(), bytes.as_ref().to_vec())]
}

#[test]
fn external_control_like_servo_session() {
    let mut h = Harness::program("external_control_like.script", Config::default());
    let steps = 50;
    let mut sent_msgs = 0;
    let mut connected = Vec::new();
    let mut commands_sent = false;
    let state = h
        .run(Duration::from_secs(5), |input| match input {
            Input::Connected(name, _) => {
                connected.push(name.to_string());
                Vec::new()
            }
            Input::Tick(_) if connected.len() == 3 => {
                let mut out = Vec::new();
                if !commands_sent {
                    commands_sent = true;
                    // set_payload 2.5 kg, then an unknown command
                    out.push((
                        "command_socket".to_string(),
                        int32s(&[1, 2_500_000, 0, 0, 9, 0, 0, 0]),
                    ));
                }
                // One reverse message per 2 ms step, like a 500 Hz driver.
                if sent_msgs < steps {
                    let t = sent_msgs as f64 * 0.001;
                    let q: Vec<i32> = [t, -1.57 + t, 1.57, -1.57, -1.57, 0.0]
                        .iter()
                        .map(|x| (x * 1e6).round() as i32)
                        .collect();
                    let mut m = vec![20];
                    m.extend(q);
                    m.push(1);
                    out.push(("reverse_socket".to_string(), int32s(&m)));
                } else if sent_msgs == steps {
                    out.push((
                        "reverse_socket".to_string(),
                        int32s(&[0, 0, 0, 0, 0, 0, 0, -2]),
                    ));
                }
                sent_msgs += 1;
                out
            }
            _ => Vec::new(),
        })
        .clone();
    assert_eq!(state, State::Finished, "{:?}", h.messages);
    assert_eq!(
        h.connects.iter().map(|c| c.2).collect::<Vec<_>>(),
        [50001, 50003, 50004]
    );
    assert_eq!(h.sent("command_socket"), int32s(&[0, 1]));
    assert_eq!(h.sent("trajectory_socket"), int32s(&[0]));
    assert_eq!(
        h.messages.first().map(String::as_str),
        Some("servo thread started")
    );
    assert!(h.messages.contains(&"servo thread stopped".to_string()));
    // Every message was servoed once: the servo thread kept up with the 500 Hz stream.
    assert_eq!(
        h.messages.last().map(String::as_str),
        Some("servo steps: 50")
    );
    assert_eq!(h.m.global("command_count"), Some(&Value::Int(2)));
    let q = h.m.joint_positions();
    assert!((q[0] - 0.049).abs() < 1e-9, "{q:?}");
    assert_eq!(
        h.closed,
        ["reverse_socket", "trajectory_socket", "command_socket"]
    );
    // The trace shows each read and its result.
    assert!(
        h.calls.iter().any(|c| c.contains(
            "socket_read_binary_integer(8, \"reverse_socket\", 1) -> [8, 20, 0, -1570000"
        )),
        "{:?}",
        &h.calls[..5]
    );
}

#[test]
fn external_control_like_times_out_when_the_driver_is_silent() {
    let mut h = Harness::program("external_control_like.script", Config::default());
    let state = h.run_silent(Duration::from_secs(5)).clone();
    assert_eq!(state, State::Finished);
    assert!(
        h.messages
            .contains(&"reverse interface: no message within 1".to_string()),
        "{:?}",
        h.messages
    );
    // The read waited its whole second of program time.
    assert!(
        h.now >= Duration::from_secs(1) && h.now < Duration::from_millis(1100),
        "{:?}",
        h.now
    );
    assert!(h
        .calls
        .iter()
        .any(|c| c.ends_with("-> [0, -1, -1, -1, -1, -1, -1, -1, -1] (timeout)")));
}

#[test]
fn external_control_like_refused_connection_halts_with_popup() {
    let mut h = Harness::program("external_control_like.script", Config::default());
    h.refuse.push(50001);
    assert_eq!(h.run_silent(Duration::from_secs(1)), &State::Halted);
    assert_eq!(
        h.messages,
        ["popup \"Driver\": cannot reach the reverse interface"]
    );
}

#[test]
fn vision_pick_loop() {
    let mut h = Harness::program("vision_pick.script", Config::default());
    let mut triggers = 0;
    let state = h
        .run(Duration::from_secs(30), |input| match input {
            Input::Received("camera", b"TRIGGER\n") => {
                triggers += 1;
                match triggers {
                    1 => reply("camera", "(12.5, -30, 90)\n"),
                    2 => reply("camera", "(0)\n"), // no part: count 1
                    3 => reply("camera", "( 1e1 , 2.5e1 , -45 )"),
                    _ => reply("camera", "(100,0,0)\n"),
                }
            }
            _ => Vec::new(),
        })
        .clone();
    assert_eq!(state, State::Finished, "{:?}", h.messages);
    assert_eq!(
        h.messages,
        [
            "picked part 1",
            "no part, count = 1",
            "picked part 2",
            "picked part 3"
        ]
    );
    assert_eq!(
        h.sent("camera"),
        b"TRIGGER\nTRIGGER\nTRIGGER\nTRIGGER\nDONE 3\n"
    );
    // The last pick was 0.1 along the x of home's frame, which is turned half a turn
    // about y: 0.3 - 0.1 in the base. The arm ends above it.
    let pose = h.m.tcp_pose();
    assert!(
        (pose[0] - 0.2).abs() < 1e-4 && (pose[2] - 0.30).abs() < 1e-4,
        "{pose:?}"
    );
    // Motion takes time: 3 picks of 4 motions and a 0.2 s sleep each.
    assert!(h.now > Duration::from_secs(1), "{:?}", h.now);
}

#[test]
fn vision_pick_loop_gives_up_when_the_camera_is_silent() {
    let mut h = Harness::program("vision_pick.script", Config::default());
    assert_eq!(h.run_silent(Duration::from_secs(10)), &State::Finished);
    assert_eq!(h.messages, ["no part, count = 0", "no part, count = 0"]);
    // Two reads of 1.5 s each.
    assert!(
        h.now >= Duration::from_secs(3) && h.now < Duration::from_millis(3100),
        "{:?}",
        h.now
    );
}

#[test]
fn gripper_daemon_set_get_var_with_timeout_counter() {
    let mut h = Harness::program("gripper_daemon.script", Config::default());
    let mut pos = 0;
    let mut target = 0;
    let mut gets = 0;
    let state = h
        .run(Duration::from_secs(10), |input| match input {
            Input::Received("gripper", bytes) => {
                let text = String::from_utf8_lossy(bytes).to_string();
                let mut out = Vec::new();
                for line in text.lines() {
                    let parts: Vec<&str> = line.split(' ').collect();
                    match parts.as_slice() {
                        ["SET", "POS", v] => target = v.parse().unwrap(),
                        ["GET", "POS"] => {
                            gets += 1;
                            // The fingers move 100 per request; the daemon pads to 3 digits.
                            pos = if target > pos {
                                (pos + 100).min(target)
                            } else {
                                (pos - 100).max(target)
                            };
                            out.extend(reply("gripper", format!("POS {pos:03}\n")));
                        }
                        _ => {}
                    }
                }
                out
            }
            _ => Vec::new(),
        })
        .clone();
    assert_eq!(state, State::Finished, "{:?}", h.messages);
    assert_eq!(h.messages, ["closed", "opened"]);
    assert_eq!(gets, 6);
    let sent = String::from_utf8(h.sent("gripper").to_vec()).unwrap();
    assert!(
        sent.starts_with("SET SPE 255\nSET FOR 150\nSET POS 255\nSET GTO 1\nGET POS\n"),
        "{sent}"
    );
}

#[test]
fn gripper_daemon_that_never_answers_ends_in_a_popup() {
    let mut h = Harness::program("gripper_daemon.script", Config::default());
    assert_eq!(h.run_silent(Duration::from_secs(200)), &State::Finished);
    // Closing gives up after 20 tries; opening "succeeds" at once: get_var's timeout
    // sentinel 0 is the position asked for. On a real controller too.
    assert_eq!(
        h.messages,
        ["popup \"Gripper\": gripper stuck at 0", "opened"]
    );
    // 20 get_var of 2 s and 19 sleeps of 50 ms, then one get_var (plus a few steps).
    let expected = 20.0 * 2.0 + 19.0 * 0.05 + 2.0;
    assert!((h.now.as_secs_f64() - expected).abs() < 0.1, "{:?}", h.now);
}

#[test]
fn keyence_style_cr_framing() {
    let mut h = Harness::program("keyence_style.script", Config::default());
    let state = h
        .run(Duration::from_secs(10), |input| match input {
            Input::Received("cv", bytes) => match bytes {
                b"\r" => Vec::new(),
                b"T1" => reply("cv", "T1\r"),
                b"MR,#100" => reply("cv", "MR,+0000012.345\r"),
                _ => reply("cv", "ER,XX,02\r"),
            },
            _ => Vec::new(),
        })
        .clone();
    assert_eq!(state, State::Finished, "{:?}", h.messages);
    assert_eq!(h.sent("cv"), b"T1\rMR,#100\rXX\r");
    assert_eq!(
        h.messages,
        [
            "measured 12.345",
            "unknown command answer: ER,XX,028",
            "raised by 0.012345"
        ]
    );
}
