//! What a ROS-style driver does with a robot in headless mode (UR's client library, the
//! ROS 2 driver), done on the wire against `ursock controller`, from UR's documents
//! (dashboard server, RTDE and primary interface guides, the script manual):
//!
//! 1. the dashboard server powers the arm on and releases the brakes;
//! 2. RTDE: protocol version 2, an output recipe (`timestamp`, `actual_q`) at 500 Hz,
//!    started;
//! 3. the primary interface gets `stop program` and then a whole `def` program that
//!    connects back to the PC and follows the joint targets the PC streams (binary
//!    integers, joints scaled by 1 000 000), with a servo thread running `servoj` every
//!    step and a read timeout on the command socket;
//! 4. the PC streams one target per RTDE package, the arm follows (read back over
//!    RTDE), then the PC sends "stop" and the program ends.
//!
//! The program is written here for this test (it is not the client library's script).

use std::collections::HashMap;
use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

const WAIT: Duration = Duration::from_secs(20);
const SCALE: f64 = 1_000_000.0;

struct Controller {
    child: Child,
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
    fn start() -> Controller {
        let mut child = Command::new(env!("CARGO_BIN_EXE_ursock"))
            .args(["controller", "--json"])
            .args(["--dashboard-port", "0", "--primary-port", "0"])
            .args(["--secondary-port", "0", "--realtime-port", "0"])
            .args(["--rtde-port", "0", "--interpreter-port", "0"])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("start ursock controller");
        let out = BufReader::new(child.stdout.take().unwrap());
        let (tx, events) = mpsc::channel();
        std::thread::spawn(move || {
            for line in out.lines() {
                let Ok(line) = line else { return };
                let Ok(v) = serde_json::from_str::<serde_json::Value>(&line) else {
                    continue;
                };
                if tx.send(v).is_err() {
                    return;
                }
            }
        });
        let mut ports = HashMap::new();
        while ports.len() < 6 {
            let v = events.recv_timeout(WAIT).expect("listening events");
            assert_eq!(v["event"], "listening", "{v}");
            let addr = v["addr"].as_str().unwrap();
            let port = addr.rsplit_once(':').unwrap().1.parse().unwrap();
            ports.insert(v["service"].as_str().unwrap().to_string(), port);
        }
        Controller {
            child,
            ports,
            events,
        }
    }

    fn connect(&self, service: &str) -> TcpStream {
        let s = TcpStream::connect(("127.0.0.1", self.ports[service])).expect("connect");
        s.set_read_timeout(Some(WAIT)).unwrap();
        s
    }

    fn wait_event(
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

struct Dashboard {
    r: BufReader<TcpStream>,
    w: TcpStream,
}

impl Dashboard {
    fn ask(&mut self, command: &str) -> String {
        self.w.write_all(format!("{command}\n").as_bytes()).unwrap();
        let mut line = String::new();
        self.r.read_line(&mut line).unwrap();
        line.trim_end().to_string()
    }
}

/// One RTDE package: `u16` size (header included), `u8` type, payload.
fn rtde_send(s: &mut TcpStream, kind: u8, payload: &[u8]) {
    let mut p = ((payload.len() + 3) as u16).to_be_bytes().to_vec();
    p.push(kind);
    p.extend_from_slice(payload);
    s.write_all(&p).unwrap();
}

fn rtde_read(s: &mut TcpStream) -> (u8, Vec<u8>) {
    let mut head = [0u8; 3];
    s.read_exact(&mut head).unwrap();
    let size = u16::from_be_bytes([head[0], head[1]]) as usize;
    let mut body = vec![0u8; size.saturating_sub(3)];
    s.read_exact(&mut body).unwrap();
    (head[2], body)
}

/// The next data package's `timestamp` and `actual_q` (recipe 1).
fn rtde_state(s: &mut TcpStream) -> (f64, [f64; 6]) {
    loop {
        let (kind, body) = rtde_read(s);
        if kind != b'U' {
            continue;
        }
        assert_eq!(body[0], 1, "recipe id");
        let f = |i: usize| f64::from_be_bytes(body[1 + 8 * i..9 + 8 * i].try_into().unwrap());
        return (f(0), [f(1), f(2), f(3), f(4), f(5), f(6)]);
    }
}

/// A command to the program: read timeout in ms, six joints scaled, mode (1 follow,
/// 0 stop).
fn command(timeout_ms: i32, q: [f64; 6], mode: i32) -> Vec<u8> {
    let mut out = Vec::new();
    out.extend_from_slice(&timeout_ms.to_be_bytes());
    for v in q {
        out.extend_from_slice(&((v * SCALE).round() as i32).to_be_bytes());
    }
    out.extend_from_slice(&mode.to_be_bytes());
    out
}

fn program(port: u16) -> String {
    format!(
        "def follow_pc():
  global target = get_actual_joint_positions()
  global mode = 1
  thread servo():
    while mode == 1:
      servoj(target, t=0.002, lookahead_time=0.03, gain=2000)
    end
  end
  socket_open(\"127.0.0.1\", {port}, \"cmd\")
  servoing = run servo()
  wait = 0
  while mode == 1:
    m = socket_read_binary_integer(8, \"cmd\", wait)
    if m[0] != 8:
      textmsg(\"no command in time\")
      mode = 0
    else:
      wait = m[1] / 1000.0
      if m[8] == 1:
        target = [m[2] / {SCALE}, m[3] / {SCALE}, m[4] / {SCALE}, m[5] / {SCALE}, m[6] / {SCALE}, m[7] / {SCALE}]
      else:
        mode = 0
      end
    end
  end
  join servoing
  stopj(4.0)
  socket_close(\"cmd\")
  textmsg(\"done\")
end
"
    )
}

#[test]
fn a_headless_driver_starts_the_arm_streams_targets_and_stops() {
    let c = Controller::start();
    // 1. Dashboard: power on, brake release.
    let d = c.connect("dashboard");
    let mut dash = Dashboard {
        r: BufReader::new(d.try_clone().unwrap()),
        w: d,
    };
    let mut greeting = String::new();
    dash.r.read_line(&mut greeting).unwrap();
    assert_eq!(dash.ask("power on"), "Powering on");
    assert_eq!(dash.ask("brake release"), "Brake releasing");
    let start = Instant::now();
    while dash.ask("robotmode") != "Robotmode: RUNNING" {
        assert!(start.elapsed() < WAIT, "never RUNNING");
        std::thread::sleep(Duration::from_millis(20));
    }
    // 2. RTDE: protocol 2, outputs at 500 Hz, start.
    let mut rtde = c.connect("rtde");
    rtde_send(&mut rtde, b'V', &2u16.to_be_bytes());
    assert_eq!(rtde_read(&mut rtde), (b'V', vec![1]));
    let mut setup = 500.0f64.to_be_bytes().to_vec();
    setup.extend_from_slice(b"timestamp,actual_q");
    rtde_send(&mut rtde, b'O', &setup);
    assert_eq!(
        rtde_read(&mut rtde),
        (b'O', b"\x01DOUBLE,VECTOR6D".to_vec())
    );
    rtde_send(&mut rtde, b'S', &[]);
    assert_eq!(rtde_read(&mut rtde), (b'S', vec![1]));
    let (t0, home) = rtde_state(&mut rtde);
    // 3. The program, after `stop program`, on the primary interface.
    let pc = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = pc.local_addr().unwrap().port();
    let mut primary = c.connect("primary");
    primary
        .write_all(format!("stop program\n{}", program(port)).as_bytes())
        .unwrap();
    let (mut cmd, _) = pc.accept().unwrap();
    cmd.set_nodelay(true).unwrap();
    // 4. One target per RTDE package: joint 6 turns 0.2 rad in 200 steps.
    let mut target = home;
    let mut last = t0;
    for _ in 0..200 {
        let (t, _) = rtde_state(&mut rtde);
        assert!(t >= last, "time goes forward");
        last = t;
        target[5] += 0.001;
        cmd.write_all(&command(100, target, 1)).unwrap();
    }
    let start = Instant::now();
    loop {
        let (_, q) = rtde_state(&mut rtde);
        if (q[5] - target[5]).abs() < 1e-5 {
            assert!((q[0] - home[0]).abs() < 1e-5, "{q:?} {home:?}");
            break;
        }
        assert!(
            start.elapsed() < WAIT,
            "the arm never followed: {q:?}, {target:?}"
        );
    }
    cmd.write_all(&command(100, target, 0)).unwrap();
    let ended = c.wait_event("program end", |v| {
        v["event"] == "program" && v["what"] != "started"
    });
    assert_eq!(ended["what"], "finished", "{ended}");
    assert_eq!(ended["name"], "follow_pc");
    // The program closed its socket.
    let mut rest = Vec::new();
    cmd.set_read_timeout(Some(WAIT)).unwrap();
    let _ = cmd.read_to_end(&mut rest);
    assert!(rest.is_empty());
}
