//! Real public robot programs, which are not in this repository (their licences are
//! their authors'): set `URSCRIPT_EXTERNAL_CONTROL` to the path of UR Client Library's
//! `resources/external_control.urscript` with its placeholders filled (ports 50001,
//! 50003, 50004; `MULT_jointstate` 1000000) and run
//! `cargo test -p urscript-interp --test real_programs -- --ignored`: this test drives it
//! through a servoj session with a fake driver.
mod common;
use std::time::Duration;

use common::{int32s, Harness, Input};
use urscript_interp::{Config, State};

#[test]
#[ignore = "needs URSCRIPT_EXTERNAL_CONTROL: a real program that is not in this repository"]
fn external_control_servo_session() {
    let path = std::env::var("URSCRIPT_EXTERNAL_CONTROL")
        .expect("set URSCRIPT_EXTERNAL_CONTROL to the filled external_control.urscript");
    let src = std::fs::read_to_string(path).unwrap();
    let mut h = Harness::new(&src, Config::default());
    let unknown = h.m.unknown_functions();
    eprintln!("functions not built in: {unknown:?}");
    let mut connected = 0;
    let mut n = 0;
    let state = h
        .run(Duration::from_secs(5), |input| match input {
            Input::Connected(..) => {
                connected += 1;
                Vec::new()
            }
            Input::Tick(_) if connected == 3 => {
                n += 1;
                let mut out = Vec::new();
                if n == 1 {
                    // SET_PAYLOAD 1.5 kg, cog (0, 0, 0.05)
                    let mut cmd = vec![1, 1_500_000, 0, 0, 50_000];
                    cmd.resize(28, 0);
                    out.push(("script_command_socket".to_string(), int32s(&cmd)));
                }
                if n <= 50 {
                    let t = f64::from(n) * 0.001;
                    let mut m = vec![20];
                    // From the virtual arm's start, within the script's 20 rad/s check.
                    let h = std::f64::consts::FRAC_PI_2;
                    m.extend([t, -h, 0.0, -h, 0.0, 0.0].map(|x| (x * 1e6).round() as i32));
                    m.push(1);
                    out.push(("reverse_socket".to_string(), int32s(&m)));
                } else if n == 51 {
                    out.push((
                        "reverse_socket".to_string(),
                        int32s(&[20, 0, 0, 0, 0, 0, 0, -2]),
                    ));
                }
                out
            }
            _ => Vec::new(),
        })
        .clone();
    for m in &h.messages {
        eprintln!("message: {m}");
    }
    assert_eq!(state, State::Finished, "{:?}", h.calls.last());
    assert!(
        (h.m.joint_positions()[0] - 0.05).abs() < 1e-9,
        "{:?}",
        h.m.joint_positions()
    );
    assert!(h
        .messages
        .contains(&"ExternalControl: All threads ended".to_string()));
}
