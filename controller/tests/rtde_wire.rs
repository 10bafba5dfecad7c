//! Wire compatibility with a real RTDE client: SDU Robotics' `ur_rtde` (the PyPI
//! package `ur-rtde`, its Python bindings `rtde_receive` and `rtde_io`) against a tiny
//! TCP server of [`RtdeSession`]s. Skipped, with the reason printed, when `python3` or
//! the modules are absent, or when the port cannot be bound.
//!
//! `ur_rtde` always connects to port 30004 (its constructors take no port), so the
//! server listens on 30004 of a loopback address picked from the process id
//! (`127.x.y.1`; Linux answers on all of 127.0.0.0/8), not on `127.0.0.1:0`.

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::thread;
use std::time::{Duration, Instant};

use urscript_controller::{Config, InputRegistry, RobotMode, RtdeEvent, RtdeSession, Status};

/// What every connection shares: the input owners, the controller's status (inputs
/// applied to it, as the cell will), and a log of the events.
struct Shared {
    registry: InputRegistry,
    status: Status,
    events: Vec<RtdeEvent>,
}

fn serve(
    mut stream: TcpStream,
    shared: Arc<Mutex<Shared>>,
    config: Config,
    start: Instant,
    stop: Arc<AtomicBool>,
) {
    stream
        .set_read_timeout(Some(Duration::from_millis(2)))
        .unwrap();
    stream.set_nodelay(true).unwrap();
    let mut session = RtdeSession::new(&config, &mut shared.lock().unwrap().registry);
    let mut buf = [0u8; 4096];
    while !stop.load(Ordering::Relaxed) {
        let received = match stream.read(&mut buf) {
            Ok(0) => break,
            Ok(n) => &buf[..n],
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => &[],
            Err(_) => break,
        };
        let out = {
            let mut g = shared.lock().unwrap();
            let g = &mut *g;
            if session.handle_received(&mut g.registry, received).is_err() {
                break;
            }
            while let Some(e) = session.poll_event() {
                if let RtdeEvent::Inputs { inputs, .. } = &e {
                    if let Some((mask, values)) = inputs.standard_digital_outputs {
                        let m = u64::from(mask);
                        g.status.digital_outputs =
                            (g.status.digital_outputs & !m) | (u64::from(values) & m);
                    }
                    for &(i, v) in &inputs.int_registers {
                        g.status.input_int_registers[i] = v;
                    }
                    for &(i, v) in &inputs.double_registers {
                        g.status.input_double_registers[i] = v;
                    }
                }
                g.events.push(e);
            }
            let now = start.elapsed();
            g.status.time = now.as_secs_f64();
            session.on_step(&g.status, now);
            session.take_outbox()
        };
        if !out.is_empty() && stream.write_all(&out).is_err() {
            break;
        }
    }
    session.close(&mut shared.lock().unwrap().registry);
}

const CLIENT: &str = r#"
import sys, time
import rtde_receive, rtde_io
host = sys.argv[1]
names = [
    "timestamp", "target_q", "target_qd", "target_qdd", "target_current",
    "target_moment", "actual_q", "actual_qd", "actual_current", "joint_control_output",
    "actual_TCP_pose", "actual_TCP_speed", "actual_TCP_force", "target_TCP_pose",
    "target_TCP_speed", "actual_digital_input_bits", "joint_temperatures",
    "actual_execution_time", "robot_mode", "joint_mode", "safety_mode",
    "actual_tool_accelerometer", "speed_scaling", "target_speed_fraction",
    "actual_momentum", "actual_main_voltage", "actual_robot_voltage",
    "actual_robot_current", "actual_joint_voltage", "actual_digital_output_bits",
]
assert len(names) == 30
r = rtde_receive.RTDEReceiveInterface(host, float(sys.argv[2]), names)
time.sleep(0.3)
t0 = r.getTimestamp()
time.sleep(0.5)
t1 = r.getTimestamp()
print("TIMESTAMPS", t0, t1)
print("ACTUAL_Q", " ".join(repr(x) for x in r.getActualQ()))
print("ROBOT_MODE", r.getRobotMode())
print("JOINT_TEMPERATURES", " ".join(repr(x) for x in r.getJointTemperatures()))
io = rtde_io.RTDEIOInterface(host)
print("SET_DO", io.setStandardDigitalOut(3, True))
print("SET_INT", io.setInputIntRegister(18, 42))
print("SET_DOUBLE", io.setInputDoubleRegister(19, 3.5))
deadline = time.time() + 3.0
bits = r.getActualDigitalOutputBits()
while bits & 8 == 0 and time.time() < deadline:
    time.sleep(0.01)
    bits = r.getActualDigitalOutputBits()
print("DO_BITS", bits)
io.disconnect()
r.disconnect()
# ur_rtde's own default recipe, chosen from the controller version.
d = rtde_receive.RTDEReceiveInterface(host)
time.sleep(0.2)
print("DEFAULT_Q", " ".join(repr(x) for x in d.getActualQ()))
print("DEFAULT_SAFETY", d.getSafetyMode())
d.disconnect()
print("DONE")
"#;

fn python_has_ur_rtde() -> Result<(), String> {
    match Command::new("python3")
        .args(["-c", "import rtde_receive, rtde_io"])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .output()
    {
        Err(e) => Err(format!("python3 cannot run: {e}")),
        Ok(o) if !o.status.success() => Err(format!(
            "the ur_rtde modules are absent (pip install ur-rtde): {}",
            String::from_utf8_lossy(&o.stderr).trim()
        )),
        Ok(_) => Ok(()),
    }
}

/// Serve `config` on `127.x.y.octet:30004` to the client script run with output
/// frequency `hz` (`-1`: ur_rtde picks from the controller version), and check what the
/// client saw and wrote. `None` when skipped.
fn run_ur_rtde(config: Config, octet: u32, hz: &str) -> Option<(String, Vec<RtdeEvent>)> {
    if let Err(why) = python_has_ur_rtde() {
        eprintln!("skipped: {why}");
        return None;
    }
    let pid = std::process::id();
    let host = format!("127.{}.{}.{octet}", 1 + (pid >> 8) % 250, pid % 250);
    let listener = match TcpListener::bind((host.as_str(), 30004)) {
        Ok(l) => l,
        Err(e) => {
            eprintln!("skipped: cannot listen on {host}:30004: {e}");
            return None;
        }
    };
    listener.set_nonblocking(true).unwrap();
    let status = Status {
        robot_mode: RobotMode::Running,
        joint_temperatures: [30.0, 31.0, 32.0, 33.0, 34.0, 35.5],
        ..Status::default()
    };
    let home = status.actual_q;
    let shared = Arc::new(Mutex::new(Shared {
        registry: InputRegistry::new(),
        status,
        events: Vec::new(),
    }));
    let stop = Arc::new(AtomicBool::new(false));
    let start = Instant::now();
    let server = {
        let (shared, stop) = (shared.clone(), stop.clone());
        thread::spawn(move || {
            let mut conns = Vec::new();
            while !stop.load(Ordering::Relaxed) {
                match listener.accept() {
                    Ok((s, _)) => {
                        s.set_nonblocking(false).unwrap();
                        let (shared, stop, config) = (shared.clone(), stop.clone(), config.clone());
                        conns.push(thread::spawn(move || serve(s, shared, config, start, stop)));
                    }
                    Err(_) => thread::sleep(Duration::from_millis(5)),
                }
            }
            for c in conns {
                let _ = c.join();
            }
        })
    };

    let mut child = Command::new("python3")
        .args(["-u", "-c", CLIENT, &host, hz])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("python3 runs");
    let deadline = Instant::now() + Duration::from_secs(60);
    while child.try_wait().unwrap().is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            break;
        }
        thread::sleep(Duration::from_millis(20));
    }
    let out = child.wait_with_output().unwrap();
    stop.store(true, Ordering::Relaxed);
    server.join().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    println!(
        "client ({}) stdout:\n{stdout}\nclient stderr:\n{stderr}",
        out.status
    );
    let g = shared.lock().unwrap();
    println!("events: {:?}", g.events);
    assert!(out.status.success(), "the client failed");
    assert!(stdout.contains("DONE"));

    let line = |key: &str| -> Vec<f64> {
        let l = stdout
            .lines()
            .find(|l| l.starts_with(key))
            .unwrap_or_else(|| panic!("no {key} line"));
        l.split_whitespace()
            .skip(1)
            .map(|x| match x {
                "True" => 1.0,
                "False" => 0.0,
                x => x.parse().unwrap(),
            })
            .collect()
    };
    // Timestamps advance with the server's clock (0.5 s apart, give or take).
    let ts = line("TIMESTAMPS");
    assert!(
        ts[0] > 0.0 && ts[1] - ts[0] > 0.3 && ts[1] - ts[0] < 1.0,
        "{ts:?}"
    );
    assert_eq!(line("ACTUAL_Q"), home.to_vec());
    assert_eq!(line("ROBOT_MODE"), vec![7.0]);
    assert_eq!(
        line("JOINT_TEMPERATURES"),
        vec![30.0, 31.0, 32.0, 33.0, 34.0, 35.5]
    );
    assert_eq!(line("SET_DO"), vec![1.0]);
    // The digital output written through rtde_io came back through rtde_receive.
    assert_eq!(line("DO_BITS"), vec![8.0]);
    assert_eq!(line("DEFAULT_Q"), home.to_vec());
    assert_eq!(line("DEFAULT_SAFETY"), vec![1.0]);
    assert_eq!(g.status.input_int_registers[18], 42);
    assert_eq!(g.status.input_double_registers[19], 3.5);
    assert_eq!(g.registry.owned(), 0, "every session released its inputs");
    Some((stdout, g.events.clone()))
}

/// The 30-field output setup the client made: recipe id, types, frequency.
fn output_setup(events: &[RtdeEvent]) -> (u8, Vec<String>, f64) {
    events
        .iter()
        .find_map(|e| match e {
            RtdeEvent::OutputSetup {
                recipe,
                fields,
                types,
                frequency,
            } if fields.len() == 30 => Some((*recipe, types.clone(), *frequency)),
            _ => None,
        })
        .expect("a 30-field output setup")
}

#[test]
fn ur_rtde_receives_30_fields_at_500_hz_and_writes_inputs() {
    let Some((_, events)) = run_ur_rtde(Config::default(), 1, "500") else {
        return;
    };
    let (recipe, types, frequency) = output_setup(&events);
    assert_ne!(recipe, 0, "accepted: {types:?}");
    assert!(!types.iter().any(|t| t == "NOT_FOUND"));
    assert_eq!(frequency, 500.0);
}

#[test]
fn ur_rtde_on_a_cb3_controller_asks_125_hz() {
    let cb3 = Config {
        polyscope: "3.15.7".into(),
        ..Config::default()
    };
    let Some((_, events)) = run_ur_rtde(cb3, 2, "-1") else {
        return;
    };
    let (recipe, _, frequency) = output_setup(&events);
    assert_ne!(recipe, 0);
    assert_eq!(
        frequency, 125.0,
        "ur_rtde picks 125 Hz from the CB3 version"
    );
}
