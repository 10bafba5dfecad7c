//! One `ursock controller --json` process on free ports for a test, with its JSON
//! events (each line parsed, or checked by the test's own function), its ports by
//! service, a dashboard client, the arm made ready, and the RTDE package helpers that
//! the streaming tests share. Every wait is bounded by [`WAIT`].
#![allow(dead_code)] // each test binary uses its own part

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

/// The longest any single wait of a test lasts.
pub const WAIT: Duration = Duration::from_secs(20);

/// The services whose `listening` events a start waits for.
const SERVICES: [&str; 6] = [
    "dashboard",
    "primary",
    "secondary",
    "realtime",
    "rtde",
    "interpreter",
];

/// Turns one output line into its event (and fails the test on a bad one).
type Check = Box<dyn Fn(&str) -> serde_json::Value>;

/// A running `ursock controller --json` (killed when dropped).
pub struct Controller {
    pub child: Child,
    ports: HashMap<String, u16>,
    lines: mpsc::Receiver<String>,
    check: Check,
}

impl Drop for Controller {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Controller {
    /// A controller with every service on a free port.
    pub fn start() -> Controller {
        Self::start_with(&[])
    }

    /// The same, with extra command-line arguments.
    pub fn start_with(extra: &[&str]) -> Controller {
        Self::start_checked(extra, |line| {
            serde_json::from_str(line).unwrap_or_else(|e| panic!("{e}: {line}"))
        })
    }

    /// The same, every output line (from the first `listening` on) turned into its
    /// event by `check`, which fails the test on a line it refuses.
    pub fn start_checked(
        extra: &[&str],
        check: impl Fn(&str) -> serde_json::Value + 'static,
    ) -> Controller {
        let mut child = Command::new(env!("CARGO_BIN_EXE_ursock"))
            .args(["controller", "--json"])
            .args(extra)
            .args(["--dashboard-port", "0", "--primary-port", "0"])
            .args(["--secondary-port", "0", "--realtime-port", "0"])
            .args(["--rtde-port", "0", "--interpreter-port", "0"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start ursock controller");
        let out = BufReader::new(child.stdout.take().expect("piped stdout"));
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in out.lines() {
                let Ok(line) = line else { return };
                if tx.send(line).is_err() {
                    return;
                }
            }
        });
        let mut c = Controller {
            child,
            ports: HashMap::new(),
            lines,
            check: Box::new(check),
        };
        while !SERVICES.iter().all(|s| c.ports.contains_key(*s)) {
            let v = c.next_event();
            assert_eq!(v["event"], "listening", "{v}");
            let addr = v["addr"].as_str().expect("addr");
            let port = addr.rsplit_once(':').expect("host:port").1.parse().unwrap();
            c.ports
                .insert(v["service"].as_str().expect("service").to_string(), port);
        }
        c
    }

    /// The next event, waiting at most `left`.
    fn recv(&self, left: Duration) -> Result<serde_json::Value, mpsc::RecvTimeoutError> {
        self.lines
            .recv_timeout(left)
            .map(|line| (self.check)(&line))
    }

    /// The next event (at most [`WAIT`]).
    pub fn next_event(&self) -> serde_json::Value {
        self.recv(WAIT).expect("an event")
    }

    /// A client of `service` (as the `listening` event names it), reads bounded.
    pub fn connect(&self, service: &str) -> TcpStream {
        let s = TcpStream::connect(("127.0.0.1", self.ports[service])).expect("connect");
        s.set_read_timeout(Some(WAIT)).unwrap();
        s
    }

    /// A dashboard client past the greeting.
    pub fn dashboard(&self) -> Dashboard {
        let w = self.connect("dashboard");
        let mut d = Dashboard {
            r: BufReader::new(w.try_clone().unwrap()),
            w,
        };
        let mut greeting = String::new();
        d.r.read_line(&mut greeting).unwrap();
        assert_eq!(
            greeting.trim_end(),
            "Connected: Universal Robots Dashboard Server"
        );
        d
    }

    /// Powers the arm on and releases the brakes through the dashboard server, and
    /// waits until the robot mode is RUNNING.
    pub fn ready(&self) {
        let mut d = self.dashboard();
        d.ask("brake release");
        d.wait_mode("RUNNING");
    }

    /// As an operator does: `power on`, then (once the robot mode is IDLE) `brake
    /// release`, then waits until it is RUNNING. The dashboard client it used, to ask on.
    pub fn power_on_and_release(&self) -> Dashboard {
        let mut d = self.dashboard();
        d.ask("power on");
        d.wait_mode("IDLE");
        d.ask("brake release");
        d.wait_mode("RUNNING");
        d
    }

    /// Every event until the process closes its output (at most [`WAIT`]).
    pub fn events_to_the_end(&self) -> Vec<serde_json::Value> {
        let start = Instant::now();
        let mut all = Vec::new();
        loop {
            let left = WAIT.saturating_sub(start.elapsed());
            match self.recv(left) {
                Ok(v) => all.push(v),
                Err(mpsc::RecvTimeoutError::Disconnected) => return all,
                Err(mpsc::RecvTimeoutError::Timeout) => panic!("the output never ended"),
            }
        }
    }

    /// Waits for the first event for which `want` holds.
    pub fn wait_event(
        &self,
        what: &str,
        want: impl Fn(&serde_json::Value) -> bool,
    ) -> serde_json::Value {
        let start = Instant::now();
        loop {
            let left = WAIT.saturating_sub(start.elapsed());
            let v = self
                .recv(left)
                .unwrap_or_else(|_| panic!("no {what} event"));
            if want(&v) {
                return v;
            }
        }
    }
}

/// A dashboard server client: one command line, one reply line.
pub struct Dashboard {
    r: BufReader<TcpStream>,
    w: TcpStream,
}

impl Dashboard {
    /// Sends `command` and returns the reply without its line end.
    pub fn ask(&mut self, command: &str) -> String {
        self.w.write_all(format!("{command}\n").as_bytes()).unwrap();
        let mut line = String::new();
        self.r.read_line(&mut line).unwrap();
        line.trim_end().to_string()
    }

    /// Asks `robotmode` until the reply is `Robotmode: MODE` (at most [`WAIT`]).
    pub fn wait_mode(&mut self, mode: &str) {
        let want = format!("Robotmode: {mode}");
        let start = Instant::now();
        loop {
            let got = self.ask("robotmode");
            if got == want {
                return;
            }
            assert!(start.elapsed() < WAIT, "never {mode}: {got}");
            std::thread::sleep(Duration::from_millis(20));
        }
    }
}

/// Sends one RTDE package: `u16` size (header included), `u8` type, payload.
pub fn rtde_send(s: &mut TcpStream, kind: u8, payload: &[u8]) {
    let mut p = ((payload.len() + 3) as u16).to_be_bytes().to_vec();
    p.push(kind);
    p.extend_from_slice(payload);
    s.write_all(&p).unwrap();
}

/// Reads one RTDE package: its type and payload.
pub fn rtde_read(s: &mut TcpStream) -> (u8, Vec<u8>) {
    let mut head = [0u8; 3];
    s.read_exact(&mut head).unwrap();
    let size = u16::from_be_bytes([head[0], head[1]]) as usize;
    let mut body = vec![0u8; size.saturating_sub(3)];
    s.read_exact(&mut body).unwrap();
    (head[2], body)
}
