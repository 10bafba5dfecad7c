//! The ready contract of `ursock controller`: `--ready-file` and the `ready` event once
//! every port listens, `ursock wait` until it answers, SIGTERM and SIGINT ending it as a
//! dashboard `shutdown` does (the `stopped` event last, status 0), and the documented
//! exit statuses for a port in use and a bad option. Every wait is bounded.

mod controller_common;

use std::io::Write;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use controller_common::{Controller, WAIT};

fn ursock() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ursock"))
}

/// A path in the temporary directory for this test.
fn temp_path(name: &str) -> std::path::PathBuf {
    std::env::temp_dir().join(format!("ursock-ready-{}-{name}", std::process::id()))
}

/// The process's exit status, waiting at most [`WAIT`].
fn status(c: &mut Controller) -> std::process::ExitStatus {
    let start = Instant::now();
    loop {
        if let Some(status) = c.child.try_wait().unwrap() {
            return status;
        }
        assert!(start.elapsed() < WAIT, "the process did not end");
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn signal(c: &Controller, name: &str) {
    let ok = Command::new("kill")
        .args([format!("-{name}"), c.child.id().to_string()])
        .status()
        .expect("kill")
        .success();
    assert!(ok, "kill -{name}");
}

/// A program that runs until stopped, sent to the primary interface.
fn start_program(c: &Controller) -> std::net::TcpStream {
    c.ready();
    let mut p = c.connect("primary");
    p.write_all(b"def waits():\n  while True:\n    sync()\n  end\nend\n")
        .unwrap();
    c.wait_event("program started", |v| {
        v["event"] == "program" && v["what"] == "started"
    });
    p
}

#[test]
fn ready_file_and_event_name_every_port_wait_answers_and_sigterm_stops_with_status_0() {
    let file = temp_path("addrs.json");
    let _ = std::fs::remove_file(&file);
    let mut c = Controller::start_with(&["--ready-file", file.to_str().unwrap()]);
    // The events after the six `listening` ones (Controller::start read them): what
    // scheduling the loop got, then `ready`.
    let scheduling = c.wait_event("any", |_| true);
    assert_eq!(scheduling["event"], "scheduling", "{scheduling}");
    let ready = c.wait_event("any", |_| true);
    assert_eq!(ready["event"], "ready", "{ready}");
    let addrs = ready["addrs"].as_object().expect("addrs");
    assert_eq!(addrs.len(), 6, "{ready}");
    let port = |s: &str| {
        addrs[s]
            .as_str()
            .unwrap()
            .rsplit_once(':')
            .unwrap()
            .1
            .to_string()
    };
    // The file is there, whole, with the same addresses.
    let text = std::fs::read_to_string(&file).expect("the ready file");
    let from_file: serde_json::Value = serde_json::from_str(&text).expect("JSON");
    assert_eq!(&from_file, &ready["addrs"]);
    let _ = std::fs::remove_file(&file);

    let waited = ursock()
        .args(["wait", &format!("127.0.0.1:{}", port("dashboard"))])
        .args([
            "--rtde-port",
            &port("rtde"),
            "--primary-port",
            &port("primary"),
        ])
        .args(["--timeout", "20"])
        .output()
        .unwrap();
    assert!(waited.status.success(), "{waited:?}");
    assert!(
        String::from_utf8_lossy(&waited.stdout).starts_with("ready: dashboard"),
        "{waited:?}"
    );

    let _primary = start_program(&c);
    let _idle = c.dashboard();
    signal(&c, "TERM");
    let events = c.events_to_the_end();
    let last = events.last().expect("events after SIGTERM");
    assert_eq!(last["event"], "stopped", "{last}");
    assert_eq!(last["reason"], "signal: SIGTERM", "{last}");
    assert!(
        events
            .iter()
            .any(|v| v["event"] == "program" && v["what"] == "stopped"),
        "no program end: {events:?}"
    );
    // The primary client and the idle dashboard client (and the one that readied the
    // arm if still open) are closed before `stopped`.
    let closes = events.iter().filter(|v| v["event"] == "close").count();
    assert!(closes >= 2, "{closes} closes: {events:?}");
    assert_eq!(status(&mut c).code(), Some(0));
}

#[test]
fn sigint_stops_as_sigterm_does() {
    let mut c = Controller::start();
    let _primary = start_program(&c);
    signal(&c, "INT");
    let events = c.events_to_the_end();
    let last = events.last().expect("events after SIGINT");
    assert_eq!(last["reason"], "signal: SIGINT", "{last}");
    assert!(events
        .iter()
        .any(|v| v["event"] == "program" && v["what"] == "stopped"));
    assert_eq!(status(&mut c).code(), Some(0));
}

#[test]
fn sigterm_stops_a_controller_in_local_control_too() {
    let mut c = Controller::start_with(&["--local"]);
    signal(&c, "TERM");
    let events = c.events_to_the_end();
    assert_eq!(events.last().unwrap()["event"], "stopped", "{events:?}");
    assert_eq!(status(&mut c).code(), Some(0));
}

fn run_controller(args: &[&str]) -> std::process::Output {
    let mut child = ursock()
        .arg("controller")
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > WAIT {
            let _ = child.kill();
            panic!("ursock controller {args:?} did not end");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

#[test]
fn a_port_in_use_exits_3_and_a_bad_option_2_as_the_help_says() {
    let taken = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = taken.local_addr().unwrap().port().to_string();
    let out = run_controller(&["--dashboard-port", &port, "--no-streams"]);
    assert_eq!(out.status.code(), Some(3), "{out:?}");
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("in use"),
        "{out:?}"
    );
    // A stream port in use, after the dashboard's was bound: the same status.
    let out = run_controller(&["--dashboard-port", "0", "--rtde-port", &port]);
    assert_eq!(out.status.code(), Some(3), "{out:?}");

    for bad in [
        &["--model", "ur99"][..],
        &["--polyscope", "five"],
        &["--no-such-option"],
        &["--dashboard-port", "70000"],
    ] {
        let out = run_controller(bad);
        assert_eq!(out.status.code(), Some(2), "{bad:?}: {out:?}");
    }

    let help = ursock().args(["controller", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    for said in ["Exit status", "2 a bad option", "3 a port in use"] {
        assert!(help.contains(said), "{said:?} not in the help: {help}");
    }
    let readme = std::fs::read_to_string(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../controller/README.md"
    ))
    .unwrap();
    for said in ["| 2 |", "| 3 |", "--ready-file", "ursock wait"] {
        assert!(
            readme.contains(said),
            "{said:?} not in controller/README.md"
        );
    }
}

#[test]
fn wait_gives_up_with_status_1_saying_what_did_not_answer() {
    // Nobody listens.
    let free = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = free.local_addr().unwrap().port();
    drop(free);
    let out = ursock()
        .args(["wait", &format!("127.0.0.1:{port}"), "--timeout", "0.5"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("not ready") && err.contains("dashboard"),
        "{err}"
    );

    // Something listens that is no dashboard server: it greets otherwise.
    let other = std::net::TcpListener::bind("127.0.0.1:0").unwrap();
    let port = other.local_addr().unwrap().port();
    std::thread::spawn(move || {
        for s in other.incoming().flatten().take(100) {
            let mut s = s;
            let _ = s.write_all(b"HTTP/1.0 400 Bad Request\r\n\r\n");
        }
    });
    let out = ursock()
        .args(["wait", &format!("127.0.0.1:{port}"), "--timeout", "1"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{out:?}");
    assert!(String::from_utf8_lossy(&out.stderr).contains("greeting"));
}
