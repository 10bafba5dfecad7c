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

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use urscript_controller::net::{Ports, Server, ServerOptions};

const WAIT: Duration = Duration::from_secs(20);

fn start() -> Server {
    Server::start(
        ServerOptions {
            ports: Ports::any(),
            ..ServerOptions::default()
        },
        |_| {},
    )
    .expect("start")
}

fn connect(server: &Server, service: &str) -> TcpStream {
    let s = TcpStream::connect(server.addr(service).unwrap()).unwrap();
    s.set_read_timeout(Some(WAIT)).unwrap();
    s
}

fn running(server: &Server) {
    let s = connect(server, "dashboard");
    let mut r = BufReader::new(s.try_clone().unwrap());
    let mut w = s;
    let mut greeting = String::new();
    r.read_line(&mut greeting).unwrap();
    let mut ask = |cmd: &str| {
        w.write_all(format!("{cmd}\n").as_bytes()).unwrap();
        let mut line = String::new();
        r.read_line(&mut line).unwrap();
        line.trim_end().to_string()
    };
    assert_eq!(ask("brake release"), "Brake releasing");
    let start = Instant::now();
    while ask("robotmode") != "Robotmode: RUNNING" {
        assert!(start.elapsed() < WAIT, "the arm never ran");
        std::thread::sleep(Duration::from_millis(20));
    }
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
    let mut primary = connect(&server, "primary");
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

fn rtde_packet(kind: u8, payload: &[u8]) -> Vec<u8> {
    let mut p = ((payload.len() + 3) as u16).to_be_bytes().to_vec();
    p.push(kind);
    p.extend_from_slice(payload);
    p
}

/// The next RTDE packet of `kind`, others (data packages, text) skipped.
fn rtde_reply(s: &mut TcpStream, kind: u8) -> Vec<u8> {
    let start = Instant::now();
    while start.elapsed() < WAIT {
        let mut head = [0u8; 3];
        s.read_exact(&mut head).unwrap();
        let len = u16::from_be_bytes([head[0], head[1]]) as usize;
        assert!(len >= 3, "an RTDE packet of {len} bytes");
        let mut body = vec![0u8; len - 3];
        s.read_exact(&mut body).unwrap();
        if head[2] == kind {
            return body;
        }
    }
    panic!("no RTDE packet {:?} within {WAIT:?}", kind as char);
}

/// The library's input recipe (`tests/resources/rtde_input_recipe.txt`, in part).
const INPUTS: &str = "speed_slider_mask,speed_slider_fraction,standard_digital_output_mask,\
                      standard_digital_output";

/// An RTDE client as the library's `RTDEClient::init` leaves it: protocol 2, an output
/// recipe, started and paused again, the input recipe set up. Returns the connection and
/// the input setup's reply (recipe id, types).
fn rtde_client(server: &Server) -> (TcpStream, u8, String) {
    let mut s = connect(server, "rtde");
    s.write_all(&rtde_packet(b'V', &2u16.to_be_bytes()))
        .unwrap();
    assert_eq!(rtde_reply(&mut s, b'V'), [1]);
    let mut setup = 500f64.to_be_bytes().to_vec();
    setup.extend_from_slice(b"timestamp,actual_q");
    s.write_all(&rtde_packet(b'O', &setup)).unwrap();
    assert_eq!(rtde_reply(&mut s, b'O')[0], 1);
    s.write_all(&rtde_packet(b'S', &[])).unwrap();
    assert_eq!(rtde_reply(&mut s, b'S'), [1]);
    s.write_all(&rtde_packet(b'P', &[])).unwrap();
    assert_eq!(rtde_reply(&mut s, b'P'), [1]);
    let (id, types) = rtde_inputs(&mut s);
    (s, id, types)
}

fn rtde_inputs(s: &mut TcpStream) -> (u8, String) {
    s.write_all(&rtde_packet(b'I', INPUTS.as_bytes())).unwrap();
    let reply = rtde_reply(s, b'I');
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
    let s = connect(&server, "dashboard");
    let mut r = BufReader::new(s.try_clone().unwrap());
    let mut w = s;
    let mut greeting = String::new();
    r.read_line(&mut greeting).unwrap();
    let mut ask = |cmd: &str| {
        w.write_all(format!("{cmd}\n").as_bytes()).unwrap();
        let mut line = String::new();
        r.read_line(&mut line).unwrap();
        line.trim_end().to_string()
    };
    assert_eq!(ask("power off"), "Powering off");
    assert_eq!(ask("brake release"), "Brake releasing");
    let released = Instant::now();
    let mut primary = connect(&server, "primary");
    std::thread::sleep(Duration::from_millis(600).saturating_sub(released.elapsed()));
    primary.write_all(b"protective_stop()\n").unwrap();
    let start = Instant::now();
    while ask("safetystatus") != "Safetystatus: PROTECTIVE_STOP" {
        assert!(
            start.elapsed() < Duration::from_secs(1),
            "no protective stop: {}",
            ask("robotmode")
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    server.stop();
}
