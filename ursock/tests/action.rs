//! The repository's GitHub Action (action.yml) run here, step by step, as a runner runs
//! it (tests/action_steps.py: `run:` steps in bash, expressions and $GITHUB_ENV /
//! $GITHUB_OUTPUT / $GITHUB_PATH as a runner handles them), against the binary built
//! here: the start exports an address that answers a dashboard `robotmode` and an RTDE
//! handshake; the stop ends the controller with `stopped` last and hands its log to
//! `actions/upload-artifact`. Skips, saying why, without python3 and PyYAML.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::TcpStream;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

const WAIT: Duration = Duration::from_secs(20);

fn python() -> Option<String> {
    let py = std::env::var("URSOCK_PYTHON").unwrap_or_else(|_| "python3".into());
    let ok = Command::new(&py)
        .args(["-c", "import yaml"])
        .output()
        .is_ok_and(|o| o.status.success());
    ok.then_some(py)
}

/// Runs the action with `inputs`; its standard output.
fn run_action(py: &str, state: &Path, inputs: &[String]) -> String {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let out = Command::new(py)
        .arg(format!("{}/ursock/tests/action_steps.py", root))
        .arg(format!("{root}/action.yml"))
        .arg(state)
        .args(inputs)
        .output()
        .expect("python3");
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        out.status.success(),
        "the action failed: {text}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

fn output<'a>(text: &'a str, name: &str) -> &'a str {
    text.lines()
        .find_map(|l| l.strip_prefix(&format!("OUTPUT {name}=")))
        .unwrap_or_else(|| panic!("no output {name}: {text}"))
}

/// Kills the controller the action started if the test ends early.
struct Job(PathBuf);

impl Job {
    fn pid(&self) -> Option<String> {
        let env: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(self.0.join("env.json")).ok()?).ok()?;
        env["URSOCK_CONTROLLER_PID"].as_str().map(String::from)
    }
}

impl Drop for Job {
    fn drop(&mut self) {
        if let Some(pid) = self.pid() {
            let _ = Command::new("kill").args(["-KILL", &pid]).status();
        }
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

#[test]
fn the_action_starts_waits_exports_and_stops_the_controller() {
    let Some(py) = python() else {
        eprintln!("skipped: python3 with PyYAML is needed to run action.yml's steps");
        return;
    };
    let state = std::env::temp_dir().join(format!("ursock-action-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&state);
    let job = Job(state.clone());
    let log = state.join("controller.jsonl");
    let ports = "--dashboard-port 0 --primary-port 0 --secondary-port 0 --realtime-port 0 \
                 --rtde-port 0 --interpreter-port 0";
    let started = run_action(
        &py,
        &state,
        &[
            format!("binary={}", env!("CARGO_BIN_EXE_ursock")),
            format!("args=--ursim {ports}"),
            format!("log={}", log.display()),
            "wait-timeout=20".into(),
        ],
    );
    let host = output(&started, "host");
    assert_eq!(host, "127.0.0.1");
    let dashboard: u16 = output(&started, "dashboard-port").parse().unwrap();
    let rtde: u16 = output(&started, "rtde-port").parse().unwrap();
    assert_eq!(output(&started, "log"), log.display().to_string());

    let d = TcpStream::connect((host, dashboard)).unwrap();
    d.set_read_timeout(Some(WAIT)).unwrap();
    let mut r = BufReader::new(d.try_clone().unwrap());
    let mut line = String::new();
    r.read_line(&mut line).unwrap();
    assert!(line.starts_with("Connected: Universal Robots Dashboard Server"));
    (&d).write_all(b"robotmode\n").unwrap();
    line.clear();
    r.read_line(&mut line).unwrap();
    assert_eq!(line.trim_end(), "Robotmode: POWER_OFF");
    // An RTDE handshake: protocol version 2 accepted.
    let mut s = TcpStream::connect((host, rtde)).unwrap();
    s.set_read_timeout(Some(WAIT)).unwrap();
    s.write_all(&[0, 5, b'V', 0, 2]).unwrap();
    let mut reply = [0u8; 4];
    s.read_exact(&mut reply).unwrap();
    assert_eq!(reply, [0, 4, b'V', 1]);
    drop((d, r, s));

    let pid = job
        .pid()
        .expect("the controller's pid in the job's environment");
    let stopped = run_action(&py, &state, &["stop=true".into()]);
    let upload = stopped
        .lines()
        .find(|l| l.starts_with("USES actions/upload-artifact@"))
        .unwrap_or_else(|| panic!("no upload: {stopped}"));
    assert!(upload.contains(&log.display().to_string()), "{upload}");
    let events = std::fs::read_to_string(&log).unwrap();
    let last: serde_json::Value =
        serde_json::from_str(events.lines().last().expect("events")).unwrap();
    assert_eq!(last["event"], "stopped", "{events}");
    assert_eq!(last["reason"], "signal: SIGTERM");
    let alive = Command::new("kill")
        .args(["-0", &pid])
        .stderr(std::process::Stdio::null())
        .status()
        .unwrap()
        .success();
    assert!(!alive, "the controller still runs");
}
