//! One `ursock controller --json` process on free ports for a test, with its JSON
//! events, its ports by service, a dashboard client and the RTDE package helpers
//! that the streaming tests share. Every wait is bounded by [`WAIT`].
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

/// A running `ursock controller --json` (killed when dropped).
pub struct Controller {
    pub child: Child,
    ports: HashMap<String, u16>,
    events: mpsc::Receiver<serde_json::Value>,
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
        let (tx, events) = mpsc::channel();
        std::thread::spawn(move || {
            for line in out.lines() {
                let Ok(line) = line else { return };
                let v: serde_json::Value =
                    serde_json::from_str(&line).unwrap_or_else(|e| panic!("{e}: {line}"));
                if tx.send(v).is_err() {
                    return;
                }
            }
        });
        let mut ports = HashMap::new();
        while !SERVICES.iter().all(|s| ports.contains_key(*s)) {
            let v = events.recv_timeout(WAIT).expect("listening events");
            assert_eq!(v["event"], "listening", "{v}");
            let addr = v["addr"].as_str().expect("addr");
            let port = addr.rsplit_once(':').expect("host:port").1.parse().unwrap();
            ports.insert(v["service"].as_str().expect("service").to_string(), port);
        }
        Controller {
            child,
            ports,
            events,
        }
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
        let start = Instant::now();
        loop {
            let mode = d.ask("robotmode");
            if mode == "Robotmode: RUNNING" {
                return;
            }
            assert!(start.elapsed() < WAIT, "never RUNNING: {mode}");
            std::thread::sleep(Duration::from_millis(50));
        }
    }

    /// Every event until the process closes its output (at most [`WAIT`]).
    pub fn events_to_the_end(&self) -> Vec<serde_json::Value> {
        let start = Instant::now();
        let mut all = Vec::new();
        loop {
            let left = WAIT.saturating_sub(start.elapsed());
            match self.events.recv_timeout(left) {
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
                .events
                .recv_timeout(left)
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
