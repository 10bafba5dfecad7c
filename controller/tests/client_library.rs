//! What UR's client library (the C++ library under the ROS 2 driver) needs of the
//! controller, over TCP on 127.0.0.1, each test one behaviour its integration tests
//! (`ur_driver_tests`, `external_control_program_tests`, `dashboard_client_g5_tests`)
//! rely on:
//!
//! - `read_error_code` sends `protective_stop()` in a `sec` program on the primary
//!   interface and waits for a robot message of type error code (6) with code 209,
//!   argument 0 on that same connection;
//! - the driver claims RTDE inputs (speed slider, digital outputs...); a second driver
//!   gets `IN_USE` while the first one's RTDE connection is open (started, paused or not
//!   reading) and the fields once it is closed (the RTDE guide: "only one RTDE client can
//!   control a specific variable at any time");
//! - in UR's CI order, a program sent 0.6 s after a `brake release` from POWER_OFF runs.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

mod support;
use support::*;
use urscript_controller::net::Server;

fn start() -> Server {
    support::start().0
}

/// One primary package: its type and body (after the 5-byte header).
fn primary_package(s: &mut TcpStream) -> (u8, Vec<u8>) {
    let mut head = [0u8; 5];
    s.read_exact(&mut head).unwrap();
    let len = u32::from_be_bytes([head[0], head[1], head[2], head[3]]) as usize;
    assert!(
        (5..=1 << 20).contains(&len),
        "a primary package of {len} bytes"
    );
    let mut body = vec![0u8; len - 5];
    s.read_exact(&mut body).unwrap();
    (head[4], body)
}

fn be_i32(b: &[u8]) -> i32 {
    i32::from_be_bytes([b[0], b[1], b[2], b[3]])
}

/// The error codes (robot message type 6: code, argument, report level) in the robot
/// messages received on `s` until `until` holds for one or `WAIT` passes.
fn error_codes_until(
    s: &mut TcpStream,
    until: impl Fn(&(i32, i32, i32)) -> bool,
) -> Vec<(i32, i32, i32)> {
    let start = Instant::now();
    let mut codes = Vec::new();
    while start.elapsed() < WAIT {
        let (kind, body) = primary_package(s);
        // Robot message: timestamp (8), source (1), robot message type (1), then the
        // error code's code, argument, report level (3 x int32), data type, data, text.
        if kind == 20 && body.len() >= 22 && body[9] == 6 {
            let code = (
                be_i32(&body[10..]),
                be_i32(&body[14..]),
                be_i32(&body[18..]),
            );
            codes.push(code);
            if until(&code) {
                return codes;
            }
        }
    }
    panic!("no such error code within {WAIT:?}: {codes:?}");
}

#[test]
fn protective_stop_in_a_secondary_program_reaches_the_primary_client_as_code_209() {
    let server = start();
    running(&server);
    let mut primary = connect_to(&server, "primary");
    // The version message first, as the library reads it.
    assert_eq!(primary_package(&mut primary).0, 20);
    // The library's read_error_code, byte for byte (`sendScript` appends a newline).
    primary
        .write_all(b"sec setup():\n protective_stop()\nend\n")
        .unwrap();
    let codes = error_codes_until(&mut primary, |&(code, _, _)| code == 209);
    assert_eq!(
        codes,
        [(209, 0, 2)],
        "one error code: C209A0, report level WARNING"
    );
    let status = server.with_cell(|cell, _| cell.status());
    assert_eq!(
        status.safety,
        urscript_controller::SafetyStatus::ProtectiveStop
    );
    server.stop();
}

/// The library's input recipe (`tests/resources/rtde_input_recipe.txt`, in part).
const INPUTS: &str = "speed_slider_mask,speed_slider_fraction,standard_digital_output_mask,\
                      standard_digital_output";

/// An RTDE client as the library's `RTDEClient::init` leaves it: protocol 2, an output
/// recipe, started and paused again, the input recipe set up. Returns the connection and
/// the input setup's reply (recipe id, types).
fn rtde_client(server: &Server) -> (TcpStream, u8, String) {
    let mut s = connect_to(server, "rtde");
    s.write_all(&rtde_packet(b'V', &2u16.to_be_bytes()))
        .unwrap();
    assert_eq!(rtde_expect(&mut s, b'V').unwrap(), [1]);
    let mut setup = 500f64.to_be_bytes().to_vec();
    setup.extend_from_slice(b"timestamp,actual_q");
    s.write_all(&rtde_packet(b'O', &setup)).unwrap();
    assert_eq!(rtde_expect(&mut s, b'O').unwrap()[0], 1);
    s.write_all(&rtde_packet(b'S', &[])).unwrap();
    assert_eq!(rtde_expect(&mut s, b'S').unwrap(), [1]);
    s.write_all(&rtde_packet(b'P', &[])).unwrap();
    assert_eq!(rtde_expect(&mut s, b'P').unwrap(), [1]);
    let (id, types) = rtde_inputs(&mut s);
    (s, id, types)
}

fn rtde_inputs(s: &mut TcpStream) -> (u8, String) {
    s.write_all(&rtde_packet(b'I', INPUTS.as_bytes())).unwrap();
    let reply = rtde_expect(s, b'I').unwrap();
    (reply[0], String::from_utf8(reply[1..].to_vec()).unwrap())
}

#[test]
fn rtde_inputs_stay_claimed_while_the_first_client_is_connected_and_free_once_it_closes() {
    let server = start();
    let (first, id, types) = rtde_client(&server);
    assert_eq!((id, types.as_str()), (1, "UINT32,DOUBLE,UINT8,UINT8"));
    // A second driver while the first one's connection is open (paused): IN_USE, as the
    // library's second ExampleRobotWrapper sees it when the first one still lives.
    let (mut second, id, types) = rtde_client(&server);
    assert_eq!((id, types.as_str()), (0, "IN_USE,IN_USE,IN_USE,IN_USE"));
    // The first driver goes: its connection closes, its claims go with it.
    drop(first);
    let start = Instant::now();
    loop {
        let (id, types) = rtde_inputs(&mut second);
        if id != 0 {
            assert_eq!(types, "UINT32,DOUBLE,UINT8,UINT8");
            break;
        }
        assert_eq!(types, "IN_USE,IN_USE,IN_USE,IN_USE");
        assert!(
            start.elapsed() < Duration::from_secs(2),
            "the claims outlived the connection"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    server.stop();
}

#[test]
fn rtde_inputs_of_a_started_client_that_stopped_reading_are_freed_when_it_closes() {
    let server = start();
    let (mut first, id, _) = rtde_client(&server);
    assert_eq!(id, 1);
    // Started again at 500 Hz and never read: packages pile up on both sides.
    first.write_all(&rtde_packet(b'S', &[])).unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let (mut second, id, _) = rtde_client(&server);
    assert_eq!(id, 0, "in use while the first is connected");
    // Closed with unread data: the peer sees a reset, the controller a failed read or
    // write; the claims go either way.
    drop(first);
    let start = Instant::now();
    while rtde_inputs(&mut second).0 == 0 {
        assert!(
            start.elapsed() < Duration::from_secs(2),
            "the claims outlived the connection"
        );
        std::thread::sleep(Duration::from_millis(10));
    }
    server.stop();
}

/// UR's `dashboard_client_g5_tests` in UR's CI order (a process per test, one URSim):
/// `non_expected_result_returns_correctly` ends with `power off` and `brake release`,
/// and `clear_protective_stop` sends `protective_stop()` on the primary interface 0.6 s
/// later (measured against `ursock controller`; the library's fixed 100 ms waits) and
/// wants the safety status PROTECTIVE_STOP within 1 s. The arm must be RUNNING by then:
/// [`Timing`](urscript_controller::Timing)'s defaults take it from POWER_OFF to RUNNING
/// in 0.4 s.
#[test]
fn a_program_sent_0_6_s_after_a_brake_release_from_power_off_runs() {
    let server = start();
    let mut d = LineClient::dashboard(&server);
    assert_eq!(d.say("power off"), "Powering off");
    assert_eq!(d.say("brake release"), "Brake releasing");
    let released = Instant::now();
    let mut primary = connect_to(&server, "primary");
    std::thread::sleep(Duration::from_millis(600).saturating_sub(released.elapsed()));
    primary.write_all(b"protective_stop()\n").unwrap();
    let start = Instant::now();
    while d.say("safetystatus") != "Safetystatus: PROTECTIVE_STOP" {
        assert!(
            start.elapsed() < Duration::from_secs(1),
            "no protective stop: {}",
            d.say("robotmode")
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    server.stop();
}

/// What a robot message (primary package type 20) says, as the library reads it.
#[derive(Debug, PartialEq)]
enum Said {
    /// A key message: title and text.
    Key(String, String),
    /// An error code: code, argument, report level.
    Code(i32, i32, i32),
    /// A safety mode message: the mode.
    Safety(u8),
    /// A runtime exception: line, column, text.
    Exception(i32, i32, String),
    /// Another robot message type.
    Other(u8),
}

/// The robot messages received on `s` until one satisfies `until` (within `WAIT`).
fn said_until(s: &mut TcpStream, until: impl Fn(&Said) -> bool) -> Vec<Said> {
    let start = Instant::now();
    let mut said = Vec::new();
    while start.elapsed() < WAIT {
        let (kind, body) = primary_package(s);
        if kind != 20 || body.len() < 10 {
            continue;
        }
        // Timestamp (8), source (1), robot message type (1), then its fields.
        let rest = &body[10..];
        let s = match body[9] {
            7 if rest.len() >= 9 => {
                let len = usize::from(rest[8]);
                let title = String::from_utf8_lossy(&rest[9..9 + len]).into_owned();
                let text = String::from_utf8_lossy(&rest[9 + len..]).into_owned();
                Said::Key(title, text)
            }
            6 if rest.len() >= 12 => {
                Said::Code(be_i32(rest), be_i32(&rest[4..]), be_i32(&rest[8..]))
            }
            5 if rest.len() >= 9 => Said::Safety(rest[8]),
            10 if rest.len() >= 8 => Said::Exception(
                be_i32(rest),
                be_i32(&rest[4..]),
                String::from_utf8_lossy(&rest[8..]).into_owned(),
            ),
            other => Said::Other(other),
        };
        let done = until(&s);
        said.push(s);
        if done {
            return said;
        }
    }
    panic!("not within {WAIT:?}: {said:?}");
}

/// The library's `test_send_script_blocking_ignore_warnings`: `power off`, `set
/// robotmode run` and, once RUNNING, `protective_stop()` wrapped in a named function
/// (`sendScriptBlocking`), which returns on that name's `PROGRAM_XXX_STOPPED` only. The
/// stop's safety mode and error code come before it; `set unlock protective stop` then
/// frees the arm and the next program runs.
#[test]
fn a_script_stopped_by_protective_stop_reports_program_stopped() {
    let server = start();
    let mut primary = connect_to(&server, "primary");
    assert_eq!(primary_package(&mut primary).0, 20);
    primary.write_all(b"power off\n").unwrap();
    primary.write_all(b"set robotmode run\n").unwrap();
    let begin = Instant::now();
    while server.with_cell(|cell, _| cell.status().robot_mode)
        != urscript_controller::RobotMode::Running
    {
        assert!(begin.elapsed() < WAIT, "the arm never ran");
        std::thread::sleep(Duration::from_millis(20));
    }
    primary
        .write_all(b"def script_1764250000000():\n  protective_stop()\nend\n")
        .unwrap();
    let name = "script_1764250000000".to_string();
    let stopped = Said::Key("PROGRAM_XXX_STOPPED".into(), name.clone());
    let said = said_until(&mut primary, |s| *s == stopped);
    let at = |want: &Said| said.iter().position(|s| s == want);
    let started = at(&Said::Key("PROGRAM_XXX_STARTED".into(), name.clone()));
    let safety = at(&Said::Safety(3));
    let code = at(&Said::Code(209, 0, 2));
    assert!(
        started.is_some() && safety.is_some() && code.is_some(),
        "{said:?}"
    );
    assert!(started < safety && safety < code, "{said:?}");
    let status = server.with_cell(|cell, _| cell.status());
    assert_eq!(
        status.safety,
        urscript_controller::SafetyStatus::ProtectiveStop
    );
    assert_eq!(
        status.program_state,
        urscript_controller::ProgramState::Stopped
    );
    // The library's commandUnlockProtectiveStop, then its next test's program.
    primary.write_all(b"set unlock protective stop\n").unwrap();
    said_until(&mut primary, |s| *s == Said::Safety(1));
    primary
        .write_all(b"def next_one():\n  textmsg(\"ran\")\nend\n")
        .unwrap();
    let said = said_until(&mut primary, |s| {
        *s == Said::Key("PROGRAM_XXX_STOPPED".into(), "next_one".into())
    });
    assert!(
        said.contains(&Said::Key("PROGRAM_XXX_STARTED".into(), "next_one".into())),
        "{said:?}"
    );
    server.stop();
}

/// The library's `test_program_execution_reports_exception`: a program calling a function
/// nothing defines is reported as URSim reports it, the code alone
/// (`compile_error_name_not_found:NAME:`) in a runtime exception at the call.
#[test]
fn a_call_of_an_unknown_function_is_reported_with_the_code_alone() {
    let server = start();
    running(&server);
    let mut primary = connect_to(&server, "primary");
    assert_eq!(primary_package(&mut primary).0, 20);
    primary
        .write_all(b"def test_function():\n  calldoesntexist()\nend\n")
        .unwrap();
    let said = said_until(&mut primary, |s| matches!(s, Said::Exception(..)));
    assert_eq!(
        said.last(),
        Some(&Said::Exception(
            2,
            3,
            "compile_error_name_not_found:calldoesntexist:".into()
        ))
    );
    server.stop();
}
