//! `ursock controller`'s output and end: a controller whose standard output nobody
//! reads still serves every client (events past its queue are dropped and counted,
//! and said once output resumes); `shutdown` ends the program and closes every client
//! before its last event, `stopped`, and the process ends with status 0;
//! `--no-shutdown` refuses it and nothing else. Every wait is bounded.

mod controller_common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use controller_common::{Controller, WAIT};

fn rtde_packet(kind: u8, payload: &[u8]) -> Vec<u8> {
    let size = u16::try_from(payload.len() + 3).expect("a small packet");
    let mut p = size.to_be_bytes().to_vec();
    p.push(kind);
    p.extend_from_slice(payload);
    p
}

/// Reads RTDE packets until one of type `kind` (at most 10 000).
fn rtde_expect(s: &mut TcpStream, kind: u8) -> Vec<u8> {
    for _ in 0..10_000 {
        let mut head = [0u8; 3];
        s.read_exact(&mut head).expect("an RTDE packet");
        let size = usize::from(u16::from_be_bytes([head[0], head[1]]));
        let mut payload = vec![0u8; size.saturating_sub(3)];
        s.read_exact(&mut payload).expect("its payload");
        if head[2] == kind {
            return payload;
        }
    }
    panic!("no RTDE packet {}", kind as char);
}

#[test]
fn a_controller_whose_output_nobody_reads_serves_on_and_says_what_it_dropped() {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ursock"))
        .args([
            "controller",
            "--json",
            "--dashboard-port",
            "0",
            "--primary-port",
            "0",
        ])
        .args([
            "--secondary-port",
            "0",
            "--realtime-port",
            "0",
            "--rtde-port",
            "0",
        ])
        .args(["--interpreter-port", "0"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start ursock controller");
    let mut out = BufReader::new(child.stdout.take().expect("stdout"));
    let mut ports = std::collections::HashMap::new();
    while ports.len() < 6 {
        let mut line = String::new();
        out.read_line(&mut line).expect("a listening line");
        let v: serde_json::Value = serde_json::from_str(&line).expect("JSON");
        let addr = v["addr"].as_str().expect("addr").to_string();
        ports.insert(v["service"].as_str().expect("service").to_string(), addr);
    }
    // From here on nobody reads standard output (its pipe fills within a few hundred
    // events).
    let mut rtde = TcpStream::connect(&ports["rtde"]).expect("rtde");
    rtde.set_read_timeout(Some(WAIT)).unwrap();
    rtde.write_all(&rtde_packet(b'V', &2u16.to_be_bytes()))
        .unwrap();
    let mut setup = 125.0f64.to_be_bytes().to_vec();
    setup.extend_from_slice(b"timestamp");
    rtde.write_all(&rtde_packet(b'O', &setup)).unwrap();
    rtde.write_all(&rtde_packet(b'S', &[])).unwrap();
    rtde_expect(&mut rtde, b'U');
    let d = TcpStream::connect(&ports["dashboard"]).expect("dashboard");
    d.set_read_timeout(Some(WAIT)).unwrap();
    let mut r = BufReader::new(d.try_clone().unwrap());
    let mut w = d;
    let mut line = String::new();
    r.read_line(&mut line).expect("greeting");
    // More than the pipe and the output queue hold (4096 events).
    for i in 0..6000 {
        w.write_all(b"robotmode\n").unwrap();
        line.clear();
        r.read_line(&mut line)
            .unwrap_or_else(|e| panic!("command {i} was not answered: {e}"));
        assert!(line.starts_with("Robotmode: "), "command {i}: {line:?}");
    }
    // RTDE still streams.
    for _ in 0..50 {
        rtde_expect(&mut rtde, b'U');
    }
    // Output resumes: what was dropped is said, with its count.
    let (tx, lines) = mpsc::channel();
    std::thread::spawn(move || {
        for l in out.lines() {
            let Ok(l) = l else { return };
            if tx.send(l).is_err() {
                return;
            }
        }
    });
    let start = Instant::now();
    let dropped = loop {
        let l = lines
            .recv_timeout(WAIT.saturating_sub(start.elapsed()))
            .expect("a dropped event");
        let v: serde_json::Value = serde_json::from_str(&l).expect("JSON");
        if v["event"] == "dropped" {
            break v["count"].as_u64().expect("count");
        }
    };
    assert!(dropped > 0, "dropped {dropped}");
    let _ = child.kill();
    let _ = child.wait();
}

#[test]
fn shutdown_ends_the_program_and_closes_every_client_then_says_stopped() {
    let mut c = Controller::start();
    c.ready();
    let mut p = c.connect("primary");
    p.write_all(b"def waits():\n  while True:\n    sync()\n  end\nend\n")
        .unwrap();
    c.wait_event("program started", |v| {
        v["event"] == "program" && v["what"] == "started"
    });
    let mut rtde = c.connect("rtde");
    rtde.write_all(&rtde_packet(b'V', &2u16.to_be_bytes()))
        .unwrap();
    rtde_expect(&mut rtde, b'V');
    let _idle = c.dashboard();
    let mut d = c.dashboard();
    assert_eq!(d.ask("shutdown"), "Shutting down");
    let events = c.events_to_the_end();
    let last = events.last().expect("events after the shutdown");
    assert_eq!(last["event"], "stopped", "{last}");
    assert!(
        last["reason"].as_str().unwrap_or("").contains("shutdown"),
        "{last}"
    );
    assert!(
        events
            .iter()
            .any(|v| v["event"] == "program" && v["what"] == "stopped"),
        "no program end: {events:?}"
    );
    let closes = events.iter().filter(|v| v["event"] == "close").count();
    // The primary, RTDE and both dashboard clients (and the one that readied the arm,
    // if it was still open).
    assert!(closes >= 4, "{closes} closes: {events:?}");
    let start = Instant::now();
    let status = loop {
        if let Some(status) = c.child.try_wait().unwrap() {
            break status;
        }
        assert!(start.elapsed() < WAIT, "the process did not end");
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(status.code(), Some(0));
}

#[test]
fn no_shutdown_refuses_shutdown_and_nothing_else() {
    let c = Controller::start_with(&["--no-shutdown"]);
    let mut d = c.dashboard();
    assert_eq!(d.ask("shutdown"), "Failed to execute: shutdown");
    assert_eq!(d.ask("power on"), "Powering on");
    assert!(d.ask("robotmode").starts_with("Robotmode: "));
    let mut c = c;
    assert!(c.child.try_wait().unwrap().is_none(), "the process ended");
}
