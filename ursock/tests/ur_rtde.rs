//! An unmodified real client library drives `ursock controller` as it drives an arm:
//! SINTEF's `ur_rtde` (from PyPI) powers the arm on and releases the brakes through the
//! dashboard server, sets up its RTDE recipes, uploads its own control script (on the
//! realtime port), moves the arm with `moveJ` and `moveL`, reads the arm back through
//! `RTDEReceiveInterface`, sets an output through `RTDEIOInterface`, and stops its script.
//!
//! Skips, saying why, when Python or the `ur_rtde` module is absent (`.ci/run` installs
//! it in a virtual environment and names its interpreter in `URSOCK_PYTHON`). `ur_rtde`
//! has no port options, so the controller listens on the standard ports of a loopback
//! address of its own (`127.x.y.z`, from the process id).

use std::io::{BufRead, BufReader};
use std::process::{Command, Stdio};

const CLIENT: &str = r#"
import sys, time
import dashboard_client, rtde_control, rtde_receive, rtde_io
host = sys.argv[1]
d = dashboard_client.DashboardClient(host)
d.connect()
d.powerOn()
d.brakeRelease()
deadline = time.time() + 20
while "RUNNING" not in d.robotmode():
    assert time.time() < deadline, d.robotmode()
    time.sleep(0.05)
c = rtde_control.RTDEControlInterface(host)
r = rtde_receive.RTDEReceiveInterface(host)
target = [0.2, -1.4, 1.0, -1.2, -1.5, 0.3]
assert c.moveJ(target, 1.05, 1.4)
q = r.getActualQ()
assert max(abs(a - b) for a, b in zip(q, target)) < 1e-6, q
pose = r.getActualTCPPose()
up = list(pose)
up[2] += 0.05
assert c.moveL(up, 0.25, 1.2)
time.sleep(0.05)
now = r.getActualTCPPose()
assert max(abs(a - b) for a, b in zip(now[:3], up[:3])) < 1e-6, (now, up)
fk = c.getForwardKinematics()
assert max(abs(a - b) for a, b in zip(fk[:3], up[:3])) < 1e-6, (fk, up)
io = rtde_io.RTDEIOInterface(host)
assert io.setStandardDigitalOut(5, True)
deadline = time.time() + 5
while not (r.getActualDigitalOutputBits() >> 5) & 1:
    assert time.time() < deadline, r.getActualDigitalOutputBits()
    time.sleep(0.01)
c.stopScript()
print("OK", r.getRobotMode(), d.programState())
"#;

fn python() -> String {
    std::env::var("URSOCK_PYTHON").unwrap_or_else(|_| "python3".into())
}

fn has_ur_rtde(python: &str) -> bool {
    Command::new(python)
        .args([
            "-c",
            "import rtde_control, rtde_receive, rtde_io, dashboard_client",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

#[test]
fn ur_rtde_drives_the_virtual_controller() {
    let python = python();
    if !has_ur_rtde(&python) {
        eprintln!(
            "skipped: {python} cannot import ur_rtde (pip install ur-rtde, or set URSOCK_PYTHON)"
        );
        return;
    }
    let pid = std::process::id();
    let host = format!(
        "127.{}.{}.{}",
        100 + (pid >> 16) % 100,
        (pid >> 8) % 256,
        pid % 250 + 2
    );
    let mut child = Command::new(env!("CARGO_BIN_EXE_ursock"))
        .args(["controller", "--bind", &host, "--json"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("start ursock controller");
    let mut out = BufReader::new(child.stdout.take().unwrap());
    let mut listening = 0;
    let mut line = String::new();
    while listening < 6 {
        line.clear();
        if out.read_line(&mut line).unwrap_or(0) == 0 {
            let _ = child.kill();
            panic!("the controller did not start on {host}");
        }
        listening += usize::from(line.contains("\"listening\""));
    }
    let events =
        std::thread::spawn(move || out.lines().map_while(Result::ok).collect::<Vec<String>>());
    let run = Command::new(&python)
        .args(["-c", CLIENT, &host])
        .output()
        .expect("run python");
    let _ = child.kill();
    let _ = child.wait();
    let events = events.join().unwrap();
    let stdout = String::from_utf8_lossy(&run.stdout);
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        run.status.success() && stdout.starts_with("OK 7"),
        "ur_rtde failed:\n{stdout}\n{stderr}\nlast events:\n{}",
        events[events.len().saturating_sub(20)..].join("\n")
    );
    // Its control script ran as a program on the virtual arm and ended when stopped.
    let program: Vec<&String> = events
        .iter()
        .filter(|e| e.contains("\"program\""))
        .collect();
    assert!(
        program
            .iter()
            .any(|e| e.contains("\"started\"") && e.contains("rtde_control")),
        "{program:?}"
    );
    assert!(
        program.iter().any(|e| e.contains("\"finished\"")),
        "{program:?}"
    );
}
