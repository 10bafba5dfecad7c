//! python-urx's secondary-interface parser (`urx.ursecmon.ParserUtils`) reads our bytes.
//!
//! Runs the Python named by `URX_PYTHON` (default `python3`); skipped, with the reason
//! printed, when that Python or the `urx` module is absent (`pip install urx`).

#![allow(clippy::field_reassign_with_default)]

use std::process::Command;

use urscript_controller::primary::{
    encode_package, encode_robot_message, encode_robot_state, encode_version, Layout, Package,
    RobotMessage,
};
use urscript_controller::{Config, Model, ProgramState, RobotMode, Status};

const SCRIPT: &str = r#"
import json, sys, logging
logging.disable(logging.CRITICAL)
from urx import ursecmon
data = open(sys.argv[1], "rb").read()
parser = ursecmon.ParserUtils()
out = []
while data:
    size = int.from_bytes(data[0:4], "big")
    packet, data = data[:size], data[size:]
    parsed = parser.parse(packet)
    def clean(v):
        if isinstance(v, bytes):
            return v.decode("utf-8", "replace")
        if isinstance(v, bool):
            return v
        return v
    out.append({k: {f: clean(x) for f, x in d.items()} for k, d in parsed.items()})
print(json.dumps(out))
"#;

fn python() -> String {
    std::env::var("URX_PYTHON").unwrap_or_else(|_| "python3".into())
}

/// Runs urx over `bytes`; `None` (with the reason printed) when it cannot run.
fn urx_parse(bytes: &[u8]) -> Option<String> {
    let py = python();
    match Command::new(&py)
        .args(["-c", "import urx.ursecmon"])
        .output()
    {
        Ok(o) if o.status.success() => {}
        Ok(o) => {
            eprintln!(
                "skipped: `{py}` cannot import urx ({}); `pip install urx` or set URX_PYTHON",
                String::from_utf8_lossy(&o.stderr)
                    .lines()
                    .last()
                    .unwrap_or("")
            );
            return None;
        }
        Err(e) => {
            eprintln!("skipped: no `{py}` ({e})");
            return None;
        }
    }
    let dir = std::env::temp_dir().join(format!(
        "urx-test-{}-{:?}",
        std::process::id(),
        std::thread::current().id()
    ));
    std::fs::create_dir_all(&dir).ok()?;
    let file = dir.join("bytes.bin");
    std::fs::write(&file, bytes).ok()?;
    let out = Command::new(&py)
        .args(["-c", SCRIPT])
        .arg(&file)
        .output()
        .expect("python runs");
    let _ = std::fs::remove_dir_all(&dir);
    assert!(
        out.status.success(),
        "urx failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    Some(String::from_utf8(out.stdout).expect("utf-8 json"))
}

/// The JSON number or value after `"key": ` in the object after `"section": {`.
fn field(json: &str, section: &str, key: &str) -> String {
    let s = json
        .find(&format!("\"{section}\": {{"))
        .unwrap_or_else(|| panic!("no {section} in {json}"));
    let obj = &json[s + section.len() + 4..];
    let obj = &obj[..obj.find('}').unwrap()];
    let k = obj
        .find(&format!("\"{key}\": "))
        .unwrap_or_else(|| panic!("no {key} in {obj}"));
    let v = &obj[k + key.len() + 4..];
    let end = v.find([',', '}']).unwrap_or(v.len());
    v[..end].trim().trim_matches('"').to_string()
}

fn num(json: &str, section: &str, key: &str) -> f64 {
    field(json, section, key).parse().unwrap()
}

fn status() -> Status {
    let mut s = Status::default();
    s.time = 3.25;
    s.model = Model::Ur5;
    s.robot_mode = RobotMode::Running;
    s.program_state = ProgramState::Playing;
    s.actual_q = [0.5, -1.5, 1.25, -0.75, 1.0, 0.125];
    s.target_q = [0.25; 6];
    s.actual_tcp_pose = [0.1, -0.2, 0.3, 0.4, -0.5, 0.6];
    s.tcp_offset = [0.0, 0.0, 0.1, 0.0, 0.0, 0.0];
    s.digital_inputs = 0b1010_0101;
    s.digital_outputs = 0b1_0000_0011;
    s.analog_inputs = [0.5, 9.75];
    s.tool_analog_inputs = [2.5, 0.75];
    s.tool_output_voltage = 12;
    s
}

#[test]
fn urx_reads_a_cb3_state_message() {
    let cfg = Config {
        polyscope: "3.15.0".into(),
        model: Model::Ur5,
        ..Config::default()
    };
    let s = status();
    let mut bytes = Vec::new();
    encode_version(&mut bytes, &cfg);
    encode_robot_state(&mut bytes, &s, &cfg);
    encode_robot_message(&mut bytes, &RobotMessage::program_started("prog"), 3.25);
    encode_robot_message(&mut bytes, &RobotMessage::text("hello"), 3.25);
    let Some(json) = urx_parse(&bytes) else {
        return;
    };
    assert_eq!(num(&json, "VersionMessage", "majorVersion"), 3.0);
    assert_eq!(num(&json, "VersionMessage", "minorVersion"), 15.0);
    assert_eq!(field(&json, "VersionMessage", "projectName"), "URControl");
    // urx knows the robot mode data of 3.0 (38 bytes) and 3.2 (46); the 47 bytes of
    // 3.5 and later fall to its oldest reading, which still gets the flags and the mode.
    assert_eq!(num(&json, "RobotModeData", "size"), 47.0);
    assert_eq!(num(&json, "RobotModeData", "robotMode"), 7.0);
    assert_eq!(field(&json, "RobotModeData", "isProgramRunning"), "true");
    assert_eq!(field(&json, "RobotModeData", "isPowerOnRobot"), "true");
    assert_eq!(num(&json, "RobotModeData", "timestamp"), 3_250_000.0);
    for j in 0..6 {
        assert_eq!(
            num(&json, "JointData", &format!("q_actual{j}")),
            s.actual_q[j]
        );
        assert_eq!(num(&json, "JointData", &format!("q_target{j}")), 0.25);
        assert_eq!(num(&json, "JointData", &format!("jointMode{j}")), 253.0);
    }
    for (k, v) in ["X", "Y", "Z", "Rx", "Ry", "Rz"]
        .iter()
        .zip(s.actual_tcp_pose)
    {
        assert_eq!(num(&json, "CartesianInfo", k), v);
    }
    assert_eq!(num(&json, "ToolData", "analogInput2"), 2.5);
    assert_eq!(num(&json, "ToolData", "analogInput3"), 0.75);
    assert_eq!(num(&json, "ToolData", "toolOutputVoltage"), 12.0);
    assert_eq!(field(&json, "keyMessage", "messageText"), "prog");
    assert_eq!(field(&json, "messageText", "messageText"), "hello");
}

#[test]
fn urx_reads_an_e_series_state_message() {
    let cfg = Config::default();
    let s = status();
    let mut bytes = Vec::new();
    encode_robot_state(&mut bytes, &s, &cfg);
    let Some(json) = urx_parse(&bytes) else {
        return;
    };
    // urx knows no 5.x layout, but the joint data and the pose read the same.
    for j in 0..6 {
        assert_eq!(
            num(&json, "JointData", &format!("q_actual{j}")),
            s.actual_q[j]
        );
    }
    for (k, v) in ["X", "Y", "Z", "Rx", "Ry", "Rz"]
        .iter()
        .zip(s.actual_tcp_pose)
    {
        assert_eq!(num(&json, "CartesianInfo", k), v);
    }
    assert_eq!(num(&json, "RobotModeData", "size"), 47.0);
    assert_eq!(field(&json, "RobotModeData", "isProgramRunning"), "true");
    assert_eq!(num(&json, "RobotModeData", "robotMode"), 7.0);
}

#[test]
fn urx_reads_our_cb3_masterboard_and_cartesian_packages() {
    // urx reads the masterboard's 32-bit I/O words and the TCP offset only after a 46-byte
    // (3.2-3.4) robot mode data: put our packages behind such a one.
    let s = status();
    let mut body = vec![0, 0, 0, 46, 0];
    body.extend(std::iter::repeat_n(0u8, 41));
    for p in [Package::MasterboardData, Package::CartesianInfo] {
        encode_package(&mut body, &s, Layout::Cb3, p);
    }
    let mut bytes = ((body.len() + 5) as u32).to_be_bytes().to_vec();
    bytes.push(16);
    bytes.extend(body);
    let Some(json) = urx_parse(&bytes) else {
        return;
    };
    assert_eq!(num(&json, "MasterBoardData", "digitalInputBits"), 165.0);
    assert_eq!(num(&json, "MasterBoardData", "digitalOutputBits"), 259.0);
    assert_eq!(num(&json, "MasterBoardData", "analogInput0"), 0.5);
    assert_eq!(num(&json, "MasterBoardData", "analogInput1"), 9.75);
    assert_eq!(
        num(&json, "MasterBoardData", "masterBoardTemperature"),
        30.0
    );
    assert_eq!(num(&json, "MasterBoardData", "robotVoltage48V"), 48.0);
    for (k, v) in ["X", "Y", "Z", "Rx", "Ry", "Rz"]
        .iter()
        .zip(s.actual_tcp_pose)
    {
        assert_eq!(num(&json, "CartesianInfo", k), v);
    }
    assert_eq!(num(&json, "CartesianInfo", "tcpOffsetZ"), 0.1);
}
