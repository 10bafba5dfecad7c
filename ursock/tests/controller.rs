//! `ursock controller` against real TCP clients on 127.0.0.1: the greeting, a command
//! sequence with the controller's exact replies, two clients at once on one state,
//! `quit` closing, hostile lines, the connection bound, `shutdown` ending the process.
//! Every wait is bounded.

mod urp_common;

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const WAIT: Duration = Duration::from_secs(20);

struct Server {
    child: Child,
    addr: String,
}

impl Server {
    fn start(args: &[&str]) -> Server {
        Self::spawn(args, Stdio::null())
    }

    fn spawn(args: &[&str], stdin: Stdio) -> Server {
        let mut child = Command::new(env!("CARGO_BIN_EXE_ursock"))
            .args(["controller", "--dashboard-port", "0", "--no-streams"])
            .args(args)
            .stdin(stdin)
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start ursock controller");
        let mut out = BufReader::new(child.stdout.take().unwrap());
        let mut first = String::new();
        out.read_line(&mut first).expect("the listening line");
        // Keep draining stdout so the server never blocks on a full pipe.
        std::thread::spawn(move || {
            let mut sink = String::new();
            while out.read_line(&mut sink).map(|n| n > 0).unwrap_or(false) {
                sink.clear();
            }
        });
        let addr = if first.starts_with('{') {
            let v: serde_json::Value = serde_json::from_str(&first).expect("JSON");
            assert_eq!(v["event"], "listening");
            v["addr"].as_str().unwrap().to_string()
        } else {
            first
                .strip_prefix("listening on ")
                .and_then(|r| r.split_whitespace().next())
                .unwrap_or_else(|| panic!("listening line: {first:?}"))
                .to_string()
        };
        Server { child, addr }
    }

    fn client(&self) -> Client {
        let s = TcpStream::connect(&self.addr).expect("connect");
        s.set_read_timeout(Some(WAIT)).unwrap();
        let mut c = Client {
            reader: BufReader::new(s.try_clone().unwrap()),
            stream: s,
        };
        assert_eq!(c.line(), "Connected: Universal Robots Dashboard Server");
        c
    }
}

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

struct Client {
    stream: TcpStream,
    reader: BufReader<TcpStream>,
}

impl Client {
    fn line(&mut self) -> String {
        let mut l = String::new();
        self.reader.read_line(&mut l).expect("a reply line");
        assert!(l.ends_with('\n'), "reply ends in a newline: {l:?}");
        l.pop();
        l
    }

    fn ask(&mut self, cmd: &str) -> String {
        self.stream
            .write_all(format!("{cmd}\n").as_bytes())
            .unwrap();
        self.line()
    }

    /// Ask until the reply is `want` (bounded), for timed transitions.
    fn wait_for(&mut self, cmd: &str, want: &str) {
        let start = Instant::now();
        loop {
            let got = self.ask(cmd);
            if got == want {
                return;
            }
            assert!(
                start.elapsed() < WAIT,
                "{cmd}: still {got:?}, want {want:?}"
            );
            std::thread::sleep(Duration::from_millis(20));
        }
    }

    fn closed(&mut self) -> bool {
        let mut rest = Vec::new();
        self.reader.read_to_end(&mut rest).is_ok() && rest.is_empty()
    }
}

/// A `.urp` (gzip XML, as PolyScope saves it) whose program waits a minute: it runs
/// until stopped, so the program's state does not depend on how fast it is read.
fn waiting_urp(name: &str) -> Vec<u8> {
    urp_common::urp(
        name,
        r#"<Script type="Line"><expression>sleep(60)</expression></Script>"#,
    )
}

fn programs_dir() -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("ursock-controller-test-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::write(dir.join("pick.urp"), waiting_urp("pick")).unwrap();
    std::fs::write(dir.join("sub/place.urp"), waiting_urp("place")).unwrap();
    dir
}

#[test]
fn a_client_drives_the_controller() {
    let dir = programs_dir();
    let server = Server::start(&["--programs", dir.to_str().unwrap(), "--model", "ur10e"]);
    let mut c = server.client();
    assert_eq!(c.ask("robotmode"), "Robotmode: POWER_OFF");
    assert_eq!(c.ask("get robot model"), "UR10");
    assert_eq!(
        c.ask("PolyscopeVersion"),
        "URSoftware 5.23.0.0 (Jan 01 2025)"
    );
    assert_eq!(c.ask("is in remote control"), "true");
    assert_eq!(c.ask("load nothing.urp"), "File not found: nothing.urp");
    assert_eq!(c.ask("load ../pick.urp"), "File not found: ../pick.urp");
    assert_eq!(c.ask("load pick.urp"), "Loading program: pick.urp");
    let real = dir.join("pick.urp").canonicalize().unwrap();
    assert_eq!(
        c.ask("get loaded program"),
        format!("Loaded program: {}", real.display())
    );
    assert_eq!(c.ask("programState"), "STOPPED pick.urp");
    assert_eq!(c.ask("play"), "Failed to execute: play");
    assert_eq!(c.ask("power on"), "Powering on");
    c.wait_for("robotmode", "Robotmode: IDLE");
    assert_eq!(c.ask("brake release"), "Brake releasing");
    c.wait_for("robotmode", "Robotmode: RUNNING");
    assert_eq!(c.ask("play"), "Starting program");
    assert_eq!(c.ask("running"), "Program running: true");
    assert_eq!(c.ask("programState"), "PLAYING pick.urp");
    assert_eq!(c.ask("pause"), "Pausing program");
    assert_eq!(c.ask("stop"), "Stopped");
    assert_eq!(
        c.ask("load sub/place.urp"),
        "Loading program: sub/place.urp"
    );
    assert_eq!(c.ask("programState"), "STOPPED place.urp");
    assert_eq!(c.ask("safetystatus"), "Safetystatus: NORMAL");
    assert_eq!(c.ask("nonsense"), "could not understand: 'nonsense'");
    // CRLF from a terminal client
    assert_eq!(c.ask("robotmode\r"), "Robotmode: RUNNING");
    assert_eq!(c.ask("quit"), "Disconnected");
    assert!(c.closed(), "quit closes the connection");
    // the server goes on
    let mut d = server.client();
    assert_eq!(d.ask("robotmode"), "Robotmode: RUNNING");
    let _ = std::fs::remove_dir_all(dir);
}

#[test]
fn two_clients_share_one_controller() {
    let server = Server::start(&[]);
    let mut a = server.client();
    let mut b = server.client();
    assert_eq!(a.ask("power on"), "Powering on");
    b.wait_for("robotmode", "Robotmode: IDLE");
    assert_eq!(
        b.ask("set operational mode automatic"),
        "Operational mode 'automatic' is set"
    );
    assert_eq!(a.ask("get operational mode"), "AUTOMATIC");
    // interleaved, each gets its own replies
    a.stream.write_all(b"robotmode\n").unwrap();
    b.stream.write_all(b"get serial number\n").unwrap();
    assert_eq!(b.line(), "20235500001");
    assert_eq!(a.line(), "Robotmode: IDLE");
    assert_eq!(a.ask("quit"), "Disconnected");
    assert!(a.closed());
    assert_eq!(b.ask("get operational mode"), "AUTOMATIC");
}

#[test]
fn hostile_lines_and_pipelined_commands() {
    let server = Server::start(&["--json"]);
    let mut c = server.client();
    // a huge line without a newline is answered once and skipped to its newline
    let huge = vec![b'A'; 100_000];
    c.stream.write_all(&huge).unwrap();
    let r = c.line();
    assert!(r.starts_with("could not understand: 'AAAA"), "{r}");
    c.stream.write_all(b"AAAA\nrobotmode\n").unwrap();
    assert_eq!(c.line(), "Robotmode: POWER_OFF");
    // invalid UTF-8 and control bytes
    c.stream.write_all(b"\xff\xfe\x00\x07\n").unwrap();
    assert!(c.line().starts_with("could not understand: '"));
    // several commands in one segment, and one command split over two
    c.stream
        .write_all(b"version\nget robot model\nrob")
        .unwrap();
    assert_eq!(c.line(), "5.23.0.0");
    assert_eq!(c.line(), "UR5");
    c.stream.write_all(b"otmode\n").unwrap();
    assert_eq!(c.line(), "Robotmode: POWER_OFF");
    assert_eq!(c.ask(""), "could not understand: ''");
}

#[test]
fn connections_are_bounded_and_shutdown_ends_the_process() {
    let mut server = Server::start(&["--local"]);
    let mut open: Vec<Client> = (0..16).map(|_| server.client()).collect();
    // the 17th is closed without a greeting
    let mut extra = TcpStream::connect(&server.addr).unwrap();
    extra.set_read_timeout(Some(WAIT)).unwrap();
    let mut buf = [0u8; 64];
    assert!(matches!(extra.read(&mut buf), Ok(0) | Err(_)));
    assert_eq!(open[0].ask("quit"), "Disconnected");
    open.remove(0);
    // a slot is free again (the closing thread may take a moment)
    let start = Instant::now();
    let mut c = loop {
        let s = TcpStream::connect(&server.addr).unwrap();
        s.set_read_timeout(Some(WAIT)).unwrap();
        let mut r = BufReader::new(s.try_clone().unwrap());
        let mut l = String::new();
        if r.read_line(&mut l).map(|n| n > 0).unwrap_or(false) {
            assert_eq!(l, "Connected: Universal Robots Dashboard Server\n");
            break Client {
                stream: s,
                reader: r,
            };
        }
        assert!(start.elapsed() < WAIT);
        std::thread::sleep(Duration::from_millis(20));
    };
    assert_eq!(c.ask("is in remote control"), "false");
    assert!(c
        .ask("power on")
        .starts_with("Command is not allowed due to safety reasons"));
    assert!(c
        .ask("shutdown")
        .starts_with("Command is not allowed due to safety reasons"));
    drop(open);
    drop(c);

    let mut server2 = Server::start(&[]);
    let mut d = server2.client();
    assert_eq!(d.ask("shutdown"), "Shutting down");
    assert!(d.closed());
    let start = Instant::now();
    loop {
        if let Some(status) = server2.child.try_wait().unwrap() {
            assert!(status.success());
            break;
        }
        assert!(start.elapsed() < WAIT, "shutdown ends the process");
        std::thread::sleep(Duration::from_millis(20));
    }
    let _ = server.child.kill();
}

#[test]
fn bad_options_are_one_line_errors() {
    for args in [
        &["--model", "ur99"][..],
        &["--polyscope", "five"][..],
        &["--programs", "/no/such/dir/here"][..],
        &["--serial", ""][..],
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_ursock"))
            .args(["controller", "--dashboard-port", "0", "--no-streams"])
            .args(args)
            .output()
            .unwrap();
        assert!(!out.status.success(), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.starts_with("ursock: "), "{err}");
    }
}

#[test]
fn the_operator_stops_the_robot_from_standard_input() {
    let mut server = Server::spawn(&[], Stdio::piped());
    let mut stdin = server.child.stdin.take().unwrap();
    let mut c = server.client();
    c.ask("brake release");
    c.wait_for("robotmode", "Robotmode: RUNNING");
    stdin.write_all(b"protective stop\n").unwrap();
    c.wait_for("safetystatus", "Safetystatus: PROTECTIVE_STOP");
    assert_eq!(
        c.ask("unlock protective stop"),
        "Cannot unlock protective stop until 5s after occurrence. Always inspect cause of protective stop before unlocking"
    );
    stdin.write_all(b"emergency stop\n").unwrap();
    c.wait_for("safetystatus", "Safetystatus: ROBOT_EMERGENCY_STOP");
    assert_eq!(c.ask("robotmode"), "Robotmode: POWER_OFF");
    // junk and an overlong line are ignored
    stdin.write_all(&vec![b'x'; 10_000]).unwrap();
    stdin.write_all(b"\nnonsense\nrelease\nlocal\n").unwrap();
    c.wait_for("is in remote control", "false");
    assert_eq!(c.ask("safetystatus"), "Safetystatus: NORMAL");
    assert!(c
        .ask("power on")
        .starts_with("Command is not allowed due to safety reasons"));
}

#[test]
fn remote_control_disabled_accepts_commands_and_answers_false() {
    // As URSim and a new robot: the setting off, `is in remote control` false, commands
    // still act (UR's client library's dashboard tests expect both).
    let server = Server::start(&["--remote-control-disabled"]);
    let mut c = server.client();
    assert_eq!(c.ask("is in remote control"), "false");
    assert_eq!(c.ask("power on"), "Powering on");
    assert_eq!(
        c.ask("set operational mode manual"),
        "Operational mode 'manual' is set"
    );
    assert_eq!(c.ask("is in remote control"), "false");
}
