//! Interpreter mode over TCP (port 30020 of `net::Server`, on 127.0.0.1): a program that
//! called `interpreter_mode()` runs what a client sends there, line by line, and the arm
//! moves as the realtime interface reports.

use std::io::{Read, Write};
use std::sync::mpsc;
use std::time::{Duration, Instant};

mod support;
use support::*;
use urscript_controller::net::{Server, ServerEvent, ServerOptions};
use urscript_controller::realtime::{offset, E_SERIES_SIZE};
use urscript_controller::RobotMode;

fn message(rx: &mpsc::Receiver<ServerEvent>, text: &str) {
    wait_for(
        rx,
        |e| matches!(e, ServerEvent::Message(m) if m.text == text),
    );
}

/// `q actual` of one realtime package.
fn q_actual(package: &[u8]) -> [f64; 6] {
    let mut q = [0.0; 6];
    for (k, v) in q.iter_mut().enumerate() {
        let at = offset::Q_ACTUAL + 8 * k;
        *v = f64::from_be_bytes(package[at..at + 8].try_into().unwrap());
    }
    q
}

/// Releases the brakes and waits until the arm is RUNNING.
fn running(server: &Server, deadline: Instant) {
    server
        .with_cell(|cell, now| cell.controller().brake_release(now))
        .expect("brake release");
    while server.with_cell(|cell, now| cell.controller().robot_mode(now)) != RobotMode::Running {
        assert!(Instant::now() < deadline, "the arm never got RUNNING");
        std::thread::sleep(Duration::from_millis(10));
    }
}

/// Waits until the running program is in interpreter mode.
fn in_interpreter_mode(server: &Server, deadline: Instant) {
    while !server.with_cell(|cell, _| cell.interpreter_status().is_some_and(|s| s.active)) {
        assert!(Instant::now() < deadline, "interpreter mode never began");
        std::thread::sleep(Duration::from_millis(10));
    }
}

#[test]
fn a_bare_interpreter_mode_line_on_the_secondary_port_opens_the_mode() {
    let (server, events) = start();
    let deadline = Instant::now() + WAIT;
    running(&server, deadline);
    let mut interp = LineClient::new(&server, "interpreter");
    let mut secondary = connect_to(&server, "secondary");
    secondary.write_all(b"interpreter_mode()\n").unwrap();
    in_interpreter_mode(&server, deadline);
    assert_eq!(
        interp.say("textmsg(\"over 30020\")"),
        "ack: 1: textmsg(\"over 30020\")"
    );
    message(&events, "over 30020");
    assert_eq!(interp.say("end_interpreter()"), "ack: 2: end_interpreter()");
    wait_for(&events, |e| {
        matches!(
            e,
            ServerEvent::Program {
                what: "finished",
                ..
            }
        )
    });
    server.stop();
}

#[test]
fn the_interpreter_port_is_served() {
    let (server, _events) = start();
    let services: Vec<&str> = server.addrs().iter().map(|(s, _)| *s).collect();
    assert_eq!(
        services,
        [
            "dashboard",
            "primary",
            "secondary",
            "realtime",
            "rtde",
            "interpreter"
        ]
    );
}

#[test]
fn a_client_drives_interpreter_mode_over_tcp() {
    let (server, events) = start();
    let mut interp = LineClient::new(&server, "interpreter");
    // No program runs: statements are discarded, the numbers are 0.
    assert_eq!(
        interp.say("textmsg(1)"),
        "discard: program not running: textmsg(1)"
    );
    assert_eq!(
        interp.say("statelastexecuted"),
        "state: 0: statelastexecuted"
    );
    // A line past the bound is answered (its first 64 bytes), and the next one is read.
    let long = "x".repeat(70_000);
    assert_eq!(
        interp.say(&long),
        format!(
            "discard: line too long (70000 bytes, at most 65536): {}...",
            &long[..64]
        )
    );
    assert_eq!(interp.say("stateunexecuted"), "state: 0: stateunexecuted");

    // The arm RUNNING, then the program, sent on the secondary interface.
    let deadline = Instant::now() + WAIT;
    running(&server, deadline);
    let mut secondary = connect_to(&server, "secondary");
    secondary
        .write_all(
            b"def remote():\n  interpreter_mode()\n  textmsg(\"left interpreter mode\")\nend\n",
        )
        .unwrap();
    wait_for(&events, |e| {
        matches!(
            e,
            ServerEvent::Program {
                what: "started",
                ..
            }
        )
    });
    in_interpreter_mode(&server, deadline);

    // A motion, then a message after it.
    let target = [0.4, -1.3, 1.1, -1.2, -1.5, 0.25];
    let movej = format!("movej({target:?}, a=1.4, v=1.05)");
    assert_eq!(interp.say(&movej), format!("ack: 1: {movej}"));
    assert_eq!(
        interp.say("textmsg(\"arrived\")"),
        "ack: 2: textmsg(\"arrived\")"
    );
    // The realtime interface shows the arm getting there.
    let mut realtime = connect_to(&server, "realtime");
    let mut package = vec![0u8; E_SERIES_SIZE];
    loop {
        realtime.read_exact(&mut package).unwrap();
        let q = q_actual(&package);
        if q.iter().zip(target).all(|(a, b)| (a - b).abs() < 1e-6) {
            break;
        }
        assert!(
            Instant::now() < deadline,
            "the arm never reached {target:?}: {q:?}"
        );
    }
    drop(realtime);
    message(&events, "arrived");
    assert_eq!(
        interp.say("statelastexecuted"),
        "state: 2: statelastexecuted"
    );
    assert_eq!(
        interp.say("statelastinterpreted"),
        "state: 2: statelastinterpreted"
    );
    assert_eq!(interp.say("stateunexecuted"), "state: 0: stateunexecuted");

    // A definition, cleared: the line sent after the clear is answered once it ran.
    assert_eq!(
        interp.say("def f(): textmsg(\"f\") end"),
        "ack: 3: def f(): textmsg(\"f\") end"
    );
    assert_eq!(interp.say("f()"), "ack: 4: f()");
    message(&events, "f");
    assert_eq!(
        interp.say("clear_interpreter()"),
        "ack: 5: clear_interpreter()"
    );
    let reply = interp.say("f()");
    assert!(
        reply.starts_with("discard: compile error at column 1: compile_error_name_not_found:f:"),
        "{reply}"
    );
    assert!(reply.ends_with(": f()"), "{reply}");
    assert_eq!(interp.say("statelastcleared"), "state: 5: statelastcleared");

    // The end: the program goes on after `interpreter_mode()` and finishes.
    assert_eq!(interp.say("end_interpreter()"), "ack: 6: end_interpreter()");
    message(&events, "left interpreter mode");
    wait_for(&events, |e| {
        matches!(
            e,
            ServerEvent::Program {
                what: "finished",
                ..
            }
        )
    });
    assert_eq!(
        interp.say("textmsg(2)"),
        "discard: program not running: textmsg(2)"
    );
    server.stop();
}

#[test]
fn a_controller_before_polyscope_5_10_has_no_interpreter_port() {
    let start = |polyscope: &str| {
        Server::start(
            ServerOptions {
                config: urscript_controller::Config {
                    polyscope: polyscope.into(),
                    ..urscript_controller::Config::default()
                },
                ..any_ports()
            },
            |_| {},
        )
        .expect("start")
    };
    for (version, served) in [("3.15.8", false), ("5.9.4", false), ("5.10.0", true)] {
        let server = start(version);
        assert_eq!(server.addr("interpreter").is_some(), served, "{version}");
        assert!(server.addr("rtde").is_some());
        server.stop();
    }
}
