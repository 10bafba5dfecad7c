//! The primary/secondary encoders against an independent decoder written here from the
//! Client Interfaces guide's package tables (3.x and 5.x), and against bytes URSim sends.

#![allow(clippy::field_reassign_with_default)]

use std::collections::BTreeMap;

use urscript_controller::primary::{
    encode_package, encode_robot_message, encode_robot_state, encode_version, Layout, Package,
    RobotMessage, PROGRAM_STARTED, PROGRAM_STOPPED,
};
use urscript_controller::{Config, Model, ProgramState, RobotMode, SafetyStatus, Status};

/// A big-endian reader that fails the test when the data runs out.
struct R<'a> {
    b: &'a [u8],
    p: usize,
}

impl<'a> R<'a> {
    fn new(b: &'a [u8]) -> Self {
        R { b, p: 0 }
    }
    fn take(&mut self, n: usize) -> &'a [u8] {
        assert!(
            self.p + n <= self.b.len(),
            "read past the end at {}",
            self.p
        );
        let s = &self.b[self.p..self.p + n];
        self.p += n;
        s
    }
    fn u8(&mut self) -> u8 {
        self.take(1)[0]
    }
    fn i8(&mut self) -> i8 {
        self.take(1)[0] as i8
    }
    fn bool(&mut self) -> bool {
        let v = self.u8();
        assert!(v <= 1, "bool byte {v}");
        v == 1
    }
    fn u32(&mut self) -> u32 {
        u32::from_be_bytes(self.take(4).try_into().unwrap())
    }
    fn i32(&mut self) -> i32 {
        i32::from_be_bytes(self.take(4).try_into().unwrap())
    }
    fn u64(&mut self) -> u64 {
        u64::from_be_bytes(self.take(8).try_into().unwrap())
    }
    fn f32(&mut self) -> f32 {
        f32::from_be_bytes(self.take(4).try_into().unwrap())
    }
    fn f64(&mut self) -> f64 {
        f64::from_be_bytes(self.take(8).try_into().unwrap())
    }
    fn f64x6(&mut self) -> [f64; 6] {
        std::array::from_fn(|_| self.f64())
    }
    fn rest(&mut self) -> &'a [u8] {
        let s = &self.b[self.p..];
        self.p = self.b.len();
        s
    }
    fn done(&self) -> bool {
        self.p == self.b.len()
    }
}

/// The sub-packages of one robot state message: type -> body (header stripped), and
/// type -> declared size.
type Split = (BTreeMap<u8, Vec<u8>>, BTreeMap<u8, usize>, Vec<u8>);

fn split_state(msg: &[u8]) -> Split {
    let mut r = R::new(msg);
    let len = r.u32() as usize;
    assert_eq!(len, msg.len(), "message length field");
    assert_eq!(r.u8(), 16, "robot state message type");
    let mut bodies = BTreeMap::new();
    let mut sizes = BTreeMap::new();
    let mut order = Vec::new();
    while !r.done() {
        let size = r.u32() as usize;
        let kind = r.u8();
        assert!(size >= 5);
        let body = r.take(size - 5).to_vec();
        assert!(bodies.insert(kind, body).is_none(), "package {kind} twice");
        sizes.insert(kind, size);
        order.push(kind);
    }
    (bodies, sizes, order)
}

fn config(version: &str, model: Model) -> Config {
    Config {
        polyscope: version.into(),
        model,
        ..Config::default()
    }
}

fn state_bytes(status: &Status, config: &Config) -> Vec<u8> {
    let mut out = Vec::new();
    encode_robot_state(&mut out, status, config);
    out
}

/// The sizes the guide documents, header included.
const E_SERIES_SIZES: [(u8, usize); 12] = [
    (0, 47),
    (1, 251),
    (2, 37),
    (3, 75),
    (4, 101),
    (5, 225),
    (6, 445),
    (7, 61),
    (8, 9),
    (11, 26),
    (12, 8),
    (13, 7),
];

const CB3_SIZES: [(u8, usize); 9] = [
    (0, 47),
    (1, 251),
    (2, 37),
    (3, 74),
    (4, 101),
    (5, 225),
    (6, 445),
    (7, 61),
    (8, 8),
];

#[test]
fn e_series_package_sizes_match_the_guide() {
    let msg = state_bytes(&Status::default(), &Config::default());
    let (_, sizes, order) = split_state(&msg);
    let want: BTreeMap<u8, usize> = E_SERIES_SIZES.into_iter().collect();
    assert_eq!(sizes, want);
    assert_eq!(order, [0, 1, 2, 3, 4, 5, 6, 7, 8, 11, 12, 13]);
    let total: usize = 5 + E_SERIES_SIZES.iter().map(|(_, s)| s).sum::<usize>();
    assert_eq!(msg.len(), total);
    assert_eq!(msg.len(), 1297);
    // python-urx skips anything it takes for a state message over 2000 bytes.
    assert!(msg.len() < 2000);
    assert_eq!(Layout::ESeries.robot_state_size(), 1297);
}

#[test]
fn cb3_package_sizes_match_the_guide() {
    let cfg = config("3.15.0", Model::Ur5);
    assert_eq!(Layout::of(&cfg), Layout::Cb3);
    let msg = state_bytes(&Status::default(), &cfg);
    let (_, sizes, _) = split_state(&msg);
    let want: BTreeMap<u8, usize> = CB3_SIZES.into_iter().collect();
    assert_eq!(sizes, want);
    assert_eq!(
        msg.len(),
        5 + CB3_SIZES.iter().map(|(_, s)| s).sum::<usize>()
    );
    assert_eq!(Layout::Cb3.robot_state_size(), msg.len());
}

#[test]
fn each_package_alone_has_its_documented_size() {
    for (layout, table) in [
        (Layout::ESeries, &E_SERIES_SIZES[..]),
        (Layout::Cb3, &CB3_SIZES[..]),
    ] {
        for &p in layout.packages() {
            let mut out = Vec::new();
            encode_package(&mut out, &Status::default(), layout, p);
            let want = table.iter().find(|(k, _)| *k == p.code()).unwrap().1;
            assert_eq!(out.len(), want, "{p:?} in {layout:?}");
            assert_eq!(
                u32::from_be_bytes(out[..4].try_into().unwrap()) as usize,
                want
            );
            assert_eq!(out[4], p.code());
        }
    }
    // CB3 has no tool communication, tool mode or singularity package.
    let mut out = Vec::new();
    encode_package(
        &mut out,
        &Status::default(),
        Layout::Cb3,
        Package::SingularityInfo,
    );
    assert!(out.is_empty());
}

fn busy_status() -> Status {
    let mut s = Status::default();
    s.time = 1234.5678;
    s.model = Model::Ur10e;
    s.robot_mode = RobotMode::Running;
    s.safety = SafetyStatus::Normal;
    s.program_state = ProgramState::Playing;
    s.actual_q = [0.1, -1.2, 1.3, -0.4, 1.5, -0.6];
    s.target_q = [0.11, -1.21, 1.31, -0.41, 1.51, -0.61];
    s.actual_qd = [0.01, 0.02, 0.03, 0.04, 0.05, 0.06];
    s.actual_current = [1.5, 2.5, 3.5, 0.5, 0.25, 0.125];
    s.joint_voltage = [47.5; 6];
    s.joint_temperatures = [36.0, 37.0, 38.0, 39.0, 40.0, 41.0];
    s.actual_tcp_pose = [0.4, -0.3, 0.5, 3.1, 0.2, -0.1];
    s.tcp_offset = [0.0, 0.0, 0.15, 0.0, 0.0, 0.0];
    s.actual_tcp_force = [1.0, 2.0, 3.0, 0.1, 0.2, 0.3];
    s.speed_fraction = 0.75;
    s.speed_scaling = 0.5;
    s.digital_inputs = 0b10_0000_0001_1000_0101; // standard 0, 2, configurable 7, 8, tool 1
    s.digital_outputs = 0b01_1000_0000_0000_0011;
    s.analog_inputs = [0.004, 7.5];
    s.analog_outputs = [0.012, 3.25];
    s.analog_io_types = 0b0110; // input 1 voltage, output 0 voltage
    s.tool_analog_inputs = [1.25, 0.015];
    s.tool_analog_input_types = 0b01;
    s.tool_output_voltage = 24;
    s.tool_current = 0.3;
    s.tool_temperature = 33.5;
    s.io_current = 0.07;
    s.robot_voltage = 48.25;
    s.robot_current = 1.75;
    s.controller_temperature = 31.5;
    s
}

/// Robot mode data as the guide lays it out.
#[derive(Debug, PartialEq)]
struct ModeData {
    timestamp: u64,
    connected: bool,
    enabled: bool,
    power_on: bool,
    emergency_stopped: bool,
    protective_stopped: bool,
    running: bool,
    paused: bool,
    robot_mode: i8,
    control_mode: u8,
    target_speed_fraction: f64,
    speed_scaling: f64,
    speed_fraction_limit: f64,
}

fn decode_mode(body: &[u8]) -> ModeData {
    let mut r = R::new(body);
    let m = ModeData {
        timestamp: r.u64(),
        connected: r.bool(),
        enabled: r.bool(),
        power_on: r.bool(),
        emergency_stopped: r.bool(),
        protective_stopped: r.bool(),
        running: r.bool(),
        paused: r.bool(),
        robot_mode: r.i8(),
        control_mode: r.u8(),
        target_speed_fraction: r.f64(),
        speed_scaling: r.f64(),
        speed_fraction_limit: r.f64(),
    };
    r.u8(); // internal use, 3.5 and later
    assert!(r.done());
    m
}

#[test]
fn decoder_reads_back_a_busy_status_in_both_layouts() {
    let s = busy_status();
    for (cfg, layout) in [
        (config("5.21.0", Model::Ur10e), Layout::ESeries),
        (config("3.15.0", Model::Ur10e), Layout::Cb3),
    ] {
        let msg = state_bytes(&s, &cfg);
        let (p, _, _) = split_state(&msg);

        let m = decode_mode(&p[&0]);
        assert_eq!(m.timestamp, 1_234_568_000, "µs, ms resolution");
        assert!(m.power_on && m.running && !m.paused && !m.protective_stopped);
        assert!(!m.emergency_stopped);
        assert_eq!(m.robot_mode, 7);
        assert_eq!(m.control_mode, 0);
        assert_eq!(m.target_speed_fraction, 0.75);
        assert_eq!(m.speed_scaling, 0.5);
        assert_eq!(m.speed_fraction_limit, 1.0);
        assert!(m.connected && m.enabled);

        // Joint data: 6 x (3 doubles, 4 floats, 1 byte).
        let mut r = R::new(&p[&1]);
        for j in 0..6 {
            assert_eq!(r.f64(), s.actual_q[j]);
            assert_eq!(r.f64(), s.target_q[j]);
            assert_eq!(r.f64(), s.actual_qd[j]);
            assert_eq!(r.f32(), s.actual_current[j] as f32);
            assert_eq!(r.f32(), 47.5);
            assert_eq!(r.f32(), s.joint_temperatures[j] as f32);
            r.f32(); // T micro
            assert_eq!(r.u8(), 253, "joint mode RUNNING");
        }
        assert!(r.done());

        // Tool data.
        let mut r = R::new(&p[&2]);
        assert_eq!((r.u8(), r.u8()), (1, 0));
        assert_eq!((r.f64(), r.f64()), (1.25, 0.015));
        assert_eq!(r.f32(), 48.25);
        assert_eq!(r.u8(), 24);
        assert_eq!(r.f32(), 0.3f32);
        assert_eq!(r.f32(), 33.5);
        assert_eq!(r.u8(), 253);
        assert!(r.done());

        // Masterboard data.
        let mut r = R::new(&p[&3]);
        assert_eq!(r.u32(), s.digital_inputs as u32);
        assert_eq!(r.u32(), s.digital_outputs as u32);
        assert_eq!((r.u8(), r.u8()), (0, 1), "analog input ranges");
        assert_eq!((r.f64(), r.f64()), (0.004, 7.5));
        assert_eq!((r.u8(), r.u8()), (1, 0), "analog output domains");
        assert_eq!((r.f64(), r.f64()), (0.012, 3.25));
        assert_eq!(r.f32(), 31.5);
        assert_eq!(r.f32(), 48.25);
        assert_eq!(r.f32(), 1.75);
        assert_eq!(r.f32(), 0.07f32);
        assert_eq!(r.u8(), 1, "safety mode NORMAL");
        assert!(!r.bool(), "reduced mode");
        assert!(!r.bool(), "euromap67 installed");
        r.u32();
        assert_eq!((r.u8(), r.u8()), (0, 0));
        if layout == Layout::ESeries {
            r.u8();
        }
        assert!(r.done());

        // Cartesian info.
        let mut r = R::new(&p[&4]);
        assert_eq!(r.f64x6(), s.actual_tcp_pose);
        assert_eq!(r.f64x6(), s.tcp_offset);
        assert!(r.done());

        // Kinematics info: checksums, theta, a, d, alpha, calibration status.
        let dh = Model::Ur10e.dh();
        let mut r = R::new(&p[&5]);
        let sums: Vec<u32> = (0..6).map(|_| r.u32()).collect();
        let mut distinct = sums.clone();
        distinct.sort();
        distinct.dedup();
        assert!(distinct.len() >= 5, "checksums differ per joint: {sums:?}");
        assert_eq!(r.f64x6(), [0.0; 6]);
        assert_eq!(r.f64x6(), dh.a);
        assert_eq!(r.f64x6(), dh.d);
        assert_eq!(r.f64x6(), dh.alpha);
        r.u32();
        assert!(r.done());

        // Configuration data.
        let mut r = R::new(&p[&6]);
        for _ in 0..6 {
            let (lo, hi) = (r.f64(), r.f64());
            assert!(lo < 0.0 && hi > 0.0);
        }
        for _ in 0..6 {
            let (v, a) = (r.f64(), r.f64());
            assert!(v > 1.0 && v < 7.0 && a > 0.0);
        }
        for _ in 0..5 {
            r.f64();
        }
        assert_eq!(r.f64x6(), dh.a);
        assert_eq!(r.f64x6(), dh.d);
        assert_eq!(r.f64x6(), dh.alpha);
        assert_eq!(r.f64x6(), [0.0; 6]);
        r.i32(); // masterboard version
        r.i32(); // controller box type
        assert_eq!(r.i32(), 2, "robot type UR10");
        r.i32();
        assert!(r.done());

        // Force mode data.
        let mut r = R::new(&p[&7]);
        assert_eq!(r.f64x6(), s.actual_tcp_force);
        r.f64();
        assert!(r.done());
    }
}

#[test]
fn modes_and_flags_follow_the_status() {
    let cfg = Config::default();
    let mut s = Status::default();
    let mode = |s: &Status| {
        let (p, _, _) = split_state(&state_bytes(s, &cfg));
        (decode_mode(&p[&0]), p[&1][40], p[&3].clone())
    };
    let (m, joint, _) = mode(&s);
    assert_eq!(m.robot_mode, 3);
    assert!(!m.power_on);
    assert_eq!(joint, 239, "POWER_OFF joint mode");

    s.robot_mode = RobotMode::Idle;
    s.program_state = ProgramState::Paused;
    s.safety = SafetyStatus::ProtectiveStop;
    let (m, joint, mb) = mode(&s);
    assert_eq!(m.robot_mode, 5);
    assert!(m.power_on && m.paused && !m.running && m.protective_stopped);
    assert_eq!(joint, 255);
    // Safety mode byte: after 4+4+2+16+2+16+16 bytes.
    assert_eq!(mb[60], 3);

    s.safety = SafetyStatus::RobotEmergencyStop;
    s.robot_mode = RobotMode::PowerOff;
    let (m, _, _) = mode(&s);
    assert!(m.emergency_stopped && !m.power_on);

    s.safety = SafetyStatus::AutomaticModeSafeguardStop;
    let (_, _, mb) = mode(&s);
    assert_eq!(mb[60], 12, "e-Series safety mode");
    let cb3 = config("3.15.0", Model::Ur5);
    let (p, _, _) = split_state(&state_bytes(&s, &cb3));
    assert_eq!(p[&3][60], 5, "CB3 has no automatic-mode safeguard stop");

    s.safety = SafetyStatus::Reduced;
    let (_, _, mb) = mode(&s);
    assert_eq!((mb[60], mb[61]), (2, 1));
}

#[test]
fn version_message_bytes() {
    let cfg = Config {
        polyscope: "5.4.0.50".into(),
        build_date: "21-06-2019, 10:03:02".into(),
        ..Config::default()
    };
    let mut out = Vec::new();
    encode_version(&mut out, &cfg);
    let mut want = vec![0, 0, 0, 0x37, 20];
    want.extend([0xff; 8]);
    want.extend([0xfe, 3, 9]);
    want.extend(b"URControl");
    want.extend([5, 4, 0, 0, 0, 0, 0, 0, 0, 50]);
    want.extend(b"21-06-2019, 10:03:02");
    assert_eq!(out, want);

    // Default config: three-part version.
    let mut out = Vec::new();
    encode_version(&mut out, &Config::default());
    let mut r = R::new(&out);
    assert_eq!(r.u32() as usize, out.len());
    assert_eq!(r.u8(), 20);
    r.u64();
    r.i8();
    assert_eq!(r.u8(), 3);
    let n = r.u8() as usize;
    assert_eq!(r.take(n), b"URControl");
    assert_eq!((r.u8(), r.u8(), r.i32(), r.i32()), (5, 23, 0, 0));
    assert_eq!(r.rest(), b"Jan 01 2025");
}

/// (timestamp, source, sub-type, body) of a robot message.
fn robot_message(bytes: &[u8]) -> (u64, i8, u8, Vec<u8>) {
    let mut r = R::new(bytes);
    assert_eq!(r.u32() as usize, bytes.len());
    assert_eq!(r.u8(), 20);
    (r.u64(), r.i8(), r.u8(), r.rest().to_vec())
}

#[test]
fn key_messages_as_ursim_sends_them() {
    let mut out = Vec::new();
    encode_robot_message(&mut out, &RobotMessage::program_started("silly"), 16634.482);
    // URSim 5.4's bytes for `def silly():` / `end` sent to 30001.
    let mut want = vec![
        0, 0, 0, 0x30, 0x14, 0, 0, 0, 0x03, 0xdf, 0x7e, 0x0d, 0x50, 0xfd, 7,
    ];
    want.extend([0; 8]);
    want.push(19);
    want.extend(b"PROGRAM_XXX_STARTEDsilly");
    assert_eq!(out, want);

    let mut out = Vec::new();
    encode_robot_message(&mut out, &RobotMessage::program_stopped("a b"), 2.0);
    let (t, src, kind, body) = robot_message(&out);
    assert_eq!((t, src, kind), (2_000_000, -3, 7));
    let mut r = R::new(&body);
    assert_eq!((r.i32(), r.i32()), (0, 0));
    let n = r.u8() as usize;
    assert_eq!(r.take(n), PROGRAM_STOPPED.as_bytes());
    assert_eq!(r.rest(), b"a b");
    assert_eq!(PROGRAM_STARTED, "PROGRAM_XXX_STARTED");
}

#[test]
fn runtime_exception_as_ursim_sends_it() {
    let mut out = Vec::new();
    let msg = RobotMessage::RuntimeException {
        line: 2,
        column: 1,
        text: "syntax_error_on_line:2:end:".into(),
    };
    encode_robot_message(&mut out, &msg, 5.0);
    let mut want = vec![0, 0, 0, 0x32, 0x14];
    want.extend([0xff; 8]);
    want.extend([0xfd, 0x0a, 0, 0, 0, 2, 0, 0, 0, 1]);
    want.extend(b"syntax_error_on_line:2:end:");
    assert_eq!(out, want);
}

#[test]
fn compile_errors_as_ursim_sends_them() {
    let mut out = Vec::new();
    encode_robot_message(&mut out, &RobotMessage::syntax_error(2, 1, "end"), 1.0);
    assert_eq!(&out[..4], &[0, 0, 0, 0x32]);
    assert_eq!(&out[13..23], &[0xfd, 0x0a, 0, 0, 0, 2, 0, 0, 0, 1]);
    assert_eq!(&out[23..], b"syntax_error_on_line:2:end:");

    let mut out = Vec::new();
    encode_robot_message(&mut out, &RobotMessage::name_not_found(2, 2, "txtmsg"), 1.0);
    let mut want = vec![0, 0, 0, 0x3b, 0x14];
    want.extend([0xff; 8]);
    want.extend([0xfd, 0x0a, 0, 0, 0, 2, 0, 0, 0, 2]);
    want.extend(b"compile_error_name_not_found:txtmsg:");
    assert_eq!(out, want);
}

#[test]
fn text_popup_error_and_other_messages_decode() {
    let mut out = Vec::new();
    encode_robot_message(&mut out, &RobotMessage::text("hello é"), 1.5);
    let (t, src, kind, body) = robot_message(&out);
    assert_eq!((t, src, kind), (1_500_000, -3, 0));
    assert_eq!(body, "hello é".as_bytes());

    let mut out = Vec::new();
    let popup = RobotMessage::Popup {
        request_id: 7,
        requested_type: 0,
        warning: true,
        error: false,
        blocking: true,
        title: "Title".into(),
        text: "Body text".into(),
    };
    encode_robot_message(&mut out, &popup, 0.0);
    let (_, _, kind, body) = robot_message(&out);
    assert_eq!(kind, 2);
    let mut r = R::new(&body);
    assert_eq!(r.u32(), 7);
    assert_eq!(r.u8(), 0);
    assert_eq!((r.bool(), r.bool(), r.bool()), (true, false, true));
    let n = r.u8() as usize;
    assert_eq!(r.take(n), b"Title");
    assert_eq!(r.rest(), b"Body text");

    let mut out = Vec::new();
    let err = RobotMessage::ErrorCode {
        code: 209,
        argument: 3,
        report_level: 2,
        data_type: 1,
        data: 42,
        text: "Joint 3".into(),
    };
    encode_robot_message(&mut out, &err, 0.0);
    let (_, _, kind, body) = robot_message(&out);
    assert_eq!(kind, 6);
    let mut r = R::new(&body);
    assert_eq!(
        (r.i32(), r.i32(), r.i32(), r.u8(), r.u32()),
        (209, 3, 2, 1, 42)
    );
    assert_eq!(r.rest(), b"Joint 3");

    let mut out = Vec::new();
    let req = RobotMessage::RequestValue {
        request_id: 9,
        requested_type: 2,
        text: "How many?".into(),
    };
    encode_robot_message(&mut out, &req, 0.0);
    let (_, _, kind, body) = robot_message(&out);
    assert_eq!(kind, 9);
    let mut r = R::new(&body);
    assert_eq!((r.u32(), r.u8()), (9, 2));
    assert_eq!(r.rest(), b"How many?");

    let mut out = Vec::new();
    let safety = RobotMessage::SafetyMode {
        code: 1,
        argument: 0,
        safety: SafetyStatus::ProtectiveStop,
        report_data_type: 0,
        report_data: 0,
    };
    encode_robot_message(&mut out, &safety, 0.0);
    let (_, _, kind, body) = robot_message(&out);
    assert_eq!(kind, 5);
    assert_eq!(body.len(), 4 + 4 + 1 + 4 + 4);
    assert_eq!(body[8], 3);

    let mut out = Vec::new();
    let label = RobotMessage::ProgramLabel {
        id: -4,
        text: "label".into(),
    };
    encode_robot_message(&mut out, &label, 0.0);
    let (_, _, kind, body) = robot_message(&out);
    assert_eq!(kind, 1);
    assert_eq!(&body[..4], &(-4i32).to_be_bytes());
    assert_eq!(&body[4..], b"label");
}

#[test]
fn long_titles_are_cut_on_a_character_boundary() {
    let title = "é".repeat(200); // 400 bytes
    let mut out = Vec::new();
    let msg = RobotMessage::Key {
        code: 1,
        argument: 2,
        title: title.clone(),
        text: "t".into(),
    };
    encode_robot_message(&mut out, &msg, 0.0);
    let (_, _, _, body) = robot_message(&out);
    let mut r = R::new(&body);
    r.i32();
    r.i32();
    let n = r.u8() as usize;
    assert_eq!(n, 254);
    let t = std::str::from_utf8(r.take(n)).unwrap();
    assert_eq!(t, &title[..254]);
    assert_eq!(r.rest(), b"t");
}

#[test]
fn extreme_values_do_not_panic() {
    let mut s = busy_status();
    s.time = f64::NAN;
    s.tool_output_voltage = -5;
    s.actual_q = [f64::INFINITY; 6];
    s.robot_mode = RobotMode::NoController;
    for version in [
        "5.21.0",
        "3.15.0",
        "",
        "x.y",
        "99999999999999999999.300.1.2",
    ] {
        let cfg = config(version, Model::Ur30);
        let msg = state_bytes(&s, &cfg);
        let (p, _, _) = split_state(&msg);
        assert_eq!(R::new(&p[&0]).u64(), 0);
        assert_eq!(
            p[&0][15], 0xff,
            "robot mode -1 after the timestamp and 7 flags"
        );
        let mut out = Vec::new();
        encode_version(&mut out, &cfg);
        robot_message(&out);
    }
}

#[test]
fn ports_and_what_they_carry() {
    use urscript_controller::primary::{Port, STATE_PERIOD, STATE_RATE_HZ};
    let numbers: Vec<u16> = Port::ALL.iter().map(|p| p.number()).collect();
    assert_eq!(numbers, [30001, 30002, 30011, 30012]);
    let messages: Vec<bool> = Port::ALL.iter().map(|p| p.sends_robot_messages()).collect();
    assert_eq!(messages, [true, false, true, false]);
    let scripts: Vec<bool> = Port::ALL.iter().map(|p| p.accepts_scripts()).collect();
    assert_eq!(scripts, [true, true, false, false]);
    assert_eq!(STATE_RATE_HZ, 10);
    assert_eq!(STATE_PERIOD.as_millis(), 100);
}

#[test]
fn robot_mode_data_carries_the_control_mode() {
    for (mode, layout) in [
        (0u8, Layout::ESeries),
        (1, Layout::ESeries),
        (2, Layout::Cb3),
    ] {
        let mut s = Status::default();
        s.control_mode = mode;
        let mut out = Vec::new();
        encode_package(&mut out, &s, layout, Package::RobotModeData);
        // Header (4-byte length, type), timestamp, seven flags, robot mode, control mode.
        assert_eq!(out[4], 0);
        assert_eq!(out[5 + 8 + 7 + 1], mode);
        // The speed fraction follows it.
        let f = f64::from_be_bytes(out[22..30].try_into().unwrap());
        assert_eq!(f, s.speed_fraction);
    }
}
