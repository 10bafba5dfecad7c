//! The URSim profile's shipped programs folder: `--ursim` without `--programs` serves
//! `default.installation`, `external_control.urp` and `wait.urp` (ours, in PolyScope 5's
//! format) at URSim's paths, so a driver's documented start-up works: load the
//! installation, load the External Control program and play it, which fetches the
//! driver's script from `--urcap-host`. Every wait is bounded.

mod controller_common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpListener;
use std::sync::mpsc;
use std::time::{Duration, Instant};

use controller_common::{Controller, WAIT};

fn shipped(name: &str) -> Vec<u8> {
    std::fs::read(format!(
        "{}/ursim/programs/{name}",
        env!("CARGO_MANIFEST_DIR")
    ))
    .unwrap()
}

#[test]
fn the_shipped_files_are_what_the_translator_reads() {
    use urscript_controller::urp::{read_external_control_settings, read_urp};
    let settings = read_external_control_settings(&shipped("default.installation")).unwrap();
    assert!(settings.installed);
    assert_eq!(
        (settings.host.as_str(), settings.port),
        ("192.168.56.1", 50002)
    );
    let ec = read_urp(&shipped("external_control.urp")).unwrap();
    assert_eq!(ec.external_control.len(), 1);
    assert_eq!(ec.installation, "default");
    let wait = read_urp(&shipped("wait.urp")).unwrap();
    assert!(wait.external_control.is_empty());
}

#[test]
fn ursim_plays_the_shipped_external_control_program_against_a_driver() {
    // The driver's side: answers `request_program` with its script, as URCL's
    // script sender does, and says what it was asked.
    let driver = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = driver.local_addr().unwrap().port();
    let (asked_tx, asked) = mpsc::channel();
    std::thread::spawn(move || {
        let Ok((s, _)) = driver.accept() else { return };
        s.set_read_timeout(Some(WAIT)).unwrap();
        let mut r = BufReader::new(s.try_clone().unwrap());
        let mut line = String::new();
        let _ = r.read_line(&mut line);
        let mut w = s;
        // Statements that run until stopped (the URCap splices the reply in as the
        // node's body): the program, whose only node is the External Control node,
        // plays on only if they were fetched.
        let _ = w.write_all(b"while True:\n  sync()\nend\n");
        let _ = asked_tx.send(line);
        // Held open until the test ends.
        let _ = w.read(&mut [0u8; 1]);
    });
    let mut c = Controller::start_with(&["--ursim", "--urcap-host", &format!("127.0.0.1:{port}")]);
    c.ready();
    let mut d = c.dashboard();
    assert_eq!(
        d.ask("load installation default.installation"),
        "Loading installation: default.installation"
    );
    assert_eq!(
        d.ask("load /ursim/programs/external_control.urp"),
        "Loading program: /ursim/programs/external_control.urp"
    );
    assert_eq!(d.ask("play"), "Starting program");
    assert_eq!(
        asked.recv_timeout(WAIT).expect("the URCap's request"),
        "request_program\n"
    );
    c.wait_event("the program's start", |v| {
        v["event"] == "program" && v["what"] == "started"
    });
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(
        d.ask("programState"),
        "PLAYING external_control.urp",
        "the driver's script runs"
    );
    assert_eq!(d.ask("stop"), "Stopped");

    // The wait program plays until stopped.
    assert_eq!(d.ask("load wait.urp"), "Loading program: wait.urp");
    assert_eq!(d.ask("play"), "Starting program");
    let start = Instant::now();
    while d.ask("programState") != "PLAYING wait.urp" {
        assert!(start.elapsed() < WAIT, "wait.urp never played");
        std::thread::sleep(Duration::from_millis(20));
    }
    std::thread::sleep(Duration::from_millis(300));
    assert_eq!(d.ask("programState"), "PLAYING wait.urp");
    assert_eq!(d.ask("stop"), "Stopped");

    // The folder written for the process goes with it.
    let folder = std::env::temp_dir().join(format!("ursock-ursim-programs-{}", c.child.id()));
    assert!(folder.join("external_control.urp").is_file(), "{folder:?}");
    assert_eq!(d.ask("shutdown"), "Shutting down");
    let _ = c.events_to_the_end();
    let start = Instant::now();
    while c.child.try_wait().unwrap().is_none() {
        assert!(start.elapsed() < WAIT, "the process did not end");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert!(!folder.exists(), "{folder:?} is left behind");
}
