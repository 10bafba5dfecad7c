//! Play to first statement of a played `.urp`: the time UR's Client Library's URCap-mode
//! tests give it (they load and play `external_control.urp`, then wait 500 ms for the
//! program to connect back to the driver).
//!
//! An in-process controller (`net::Server`) serves a programs directory holding a large
//! `.urp`: 300 waypoints in `Move` nodes, 200 assignments and an External Control node.
//! A driver thread on 127.0.0.1 answers `request_program` with a script and keeps the
//! connection open, as UR's `ScriptSender` does; the script's first statement opens a
//! socket back to the driver's reverse port. One iteration: dashboard `play`, until the
//! reverse port accepts that connection (what the library waits for); then `stop`
//! (not timed).

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use urscript_controller::net::{Ports, Server, ServerEvent, ServerOptions};

const WAIT: Duration = Duration::from_secs(20);

fn waypoint(k: usize) -> String {
    let a = 0.001 * k as f64;
    format!(
        r#"<Move motionType="MoveJ" speed="1.0" acceleration="1.4"><children><Waypoint type="Fixed" name="Waypoint_{k}" kinematicsFlags="4"><motionParameters/><position><JointAngles angles="{a}, -1.5, 1.4, -1.5, -1.57, 0.2"/><TCPOffset pose="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/><Kinematics status="NOT_INITIALIZED" validChecksum="false"/></position><BaseToFeature pose="0.0, 0.0, 0.0, 0.0, 0.0, 0.0"/></Waypoint></children></Move>"#
    )
}

/// The large program: assignments, the External Control node, then the moves.
fn large_urp() -> String {
    let mut nodes = String::new();
    for k in 0..200 {
        nodes.push_str(&format!(
            r#"<Assignment><variable name="v{k}"/><expression><ExpressionToken token="{k}"/></expression></Assignment>"#
        ));
    }
    nodes.push_str(r#"<Contributed strategyClass="com.fzi.externalcontrol.ExternalControlNode" strategyProgramNodeType="External Control"><dataModel/></Contributed>"#);
    for k in 0..300 {
        nodes.push_str(&waypoint(k));
    }
    format!(
        r#"<URProgram name="large" installation="default" createdIn="5.21.0"><children><MainProgram runOnlyOnce="true"><children>{nodes}</children></MainProgram></children></URProgram>"#
    )
}

struct Dashboard {
    r: BufReader<TcpStream>,
    w: TcpStream,
}

impl Dashboard {
    fn ask(&mut self, cmd: &str) -> String {
        self.w.write_all(format!("{cmd}\n").as_bytes()).unwrap();
        let mut line = String::new();
        self.r.read_line(&mut line).unwrap();
        line.trim_end().to_string()
    }
}

fn play_to_first_statement(c: &mut Criterion) {
    let dir = std::env::temp_dir().join(format!("urp-play-bench-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("large.urp"), large_urp()).unwrap();

    // The driver: its script sender (connection kept open) and its reverse port.
    let reverse = TcpListener::bind("127.0.0.1:0").unwrap();
    let reverse_port = reverse.local_addr().unwrap().port();
    let sender = TcpListener::bind("127.0.0.1:0").unwrap();
    let sender_port = sender.local_addr().unwrap().port();
    let script = format!(
        "socket_open(\"127.0.0.1\", {reverse_port}, \"reverse_socket\")\nwhile (True):\n  sync()\nend\n"
    );
    std::thread::spawn(move || {
        let mut open = Vec::new();
        for s in sender.incoming() {
            let Ok(mut s) = s else { continue };
            let mut request = [0u8; 16];
            if s.read_exact(&mut request).is_ok() && s.write_all(script.as_bytes()).is_ok() {
                open.push(s); // kept open, as the ScriptSender keeps it
            }
        }
    });

    let (tx, events) = mpsc::channel();
    let tx = std::sync::Mutex::new(tx);
    let server = Server::start(
        ServerOptions {
            ports: Ports::any(),
            programs: Some(dir.clone()),
            urcap_host: Some(("127.0.0.1".into(), sender_port)),
            ..ServerOptions::default()
        },
        move |e| {
            if matches!(e, ServerEvent::Program { .. }) {
                let _ = tx.lock().unwrap().send(e);
            }
        },
    )
    .unwrap();
    let s = TcpStream::connect(server.addr("dashboard").unwrap()).unwrap();
    s.set_read_timeout(Some(WAIT)).unwrap();
    let mut d = Dashboard {
        r: BufReader::new(s.try_clone().unwrap()),
        w: s,
    };
    let mut greeting = String::new();
    d.r.read_line(&mut greeting).unwrap();
    assert_eq!(d.ask("brake release"), "Brake releasing");
    let start = Instant::now();
    while d.ask("robotmode") != "Robotmode: RUNNING" {
        assert!(start.elapsed() < WAIT, "the arm never ran");
        std::thread::sleep(Duration::from_millis(20));
    }
    assert_eq!(d.ask("load large.urp"), "Loading program: large.urp");

    let mut group = c.benchmark_group("urp_play");
    group.sample_size(20);
    group.bench_function("play_to_first_statement_large_urp", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let t = Instant::now();
                assert_eq!(d.ask("play"), "Starting program");
                let (back, _) = reverse.accept().unwrap();
                total += t.elapsed();
                assert_eq!(d.ask("stop"), "Stopped");
                loop {
                    match events.recv_timeout(WAIT).expect("the program's end") {
                        ServerEvent::Program {
                            what: "started", ..
                        } => {}
                        ServerEvent::Program {
                            what: "stopped", ..
                        } => break,
                        other => panic!("{other:?}"),
                    }
                }
                drop(back);
            }
            total
        })
    });
    group.finish();
    server.stop();
    let _ = std::fs::remove_dir_all(&dir);
}

criterion_group!(benches, play_to_first_statement);
criterion_main!(benches);
