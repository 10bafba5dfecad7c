//! The realtime package (port 30003) against the guide's tables: sizes, offsets computed
//! here from the table's (field, number of doubles) rows, and values read back.

#![allow(clippy::field_reassign_with_default)]

use urscript_controller::primary::Layout;
use urscript_controller::realtime::{
    encode_realtime, encode_realtime_layout, offset, CB3_SIZE, E_SERIES_SIZE,
};
use urscript_controller::{Config, Model, ProgramState, RobotMode, SafetyStatus, Status};

/// The guide's rows after `Message Size` (int32): name and number of doubles. The CB3
/// table (3.5-3.15) stops after `Elbow velocity`.
const ROWS: [(&str, usize); 43] = [
    ("Time", 1),
    ("q target", 6),
    ("qd target", 6),
    ("qdd target", 6),
    ("I target", 6),
    ("M target", 6),
    ("q actual", 6),
    ("qd actual", 6),
    ("I actual", 6),
    ("I control", 6),
    ("Tool vector actual", 6),
    ("TCP speed actual", 6),
    ("TCP force", 6),
    ("Tool vector target", 6),
    ("TCP speed target", 6),
    ("Digital input bits", 1),
    ("Motor temperatures", 6),
    ("Controller Timer", 1),
    ("Test value", 1),
    ("Robot Mode", 1),
    ("Joint Modes", 6),
    ("Safety Mode", 1),
    ("unused 1", 6),
    ("Tool Accelerometer values", 3),
    ("unused 2", 6),
    ("Speed scaling", 1),
    ("Linear momentum norm", 1),
    ("unused 3", 1),
    ("unused 4", 1),
    ("V main", 1),
    ("V robot", 1),
    ("I robot", 1),
    ("V actual", 6),
    ("Digital outputs", 1),
    ("Program state", 1),
    ("Elbow position", 3),
    ("Elbow velocity", 3),
    ("Safety Status", 1),
    ("unused 5", 1),
    ("unused 6", 1),
    ("unused 7", 1),
    ("Payload Mass", 1),
    ("Payload CoG", 3),
];

fn table_offset(name: &str) -> usize {
    let mut at = 4;
    for (n, count) in ROWS {
        if n == name {
            return at;
        }
        at += 8 * count;
    }
    panic!("no row {name}");
}

fn f64_at(b: &[u8], at: usize) -> f64 {
    f64::from_be_bytes(b[at..at + 8].try_into().unwrap())
}

fn f64s_at<const N: usize>(b: &[u8], at: usize) -> [f64; N] {
    std::array::from_fn(|i| f64_at(b, at + 8 * i))
}

#[test]
fn sizes_match_the_documented_ones() {
    // Rows plus `Payload Inertia` (6 doubles), the last 5.x row.
    let e_series = table_offset("Payload CoG") + 3 * 8 + 6 * 8;
    assert_eq!(e_series, 1220);
    assert_eq!(E_SERIES_SIZE, 1220);
    let cb3 = table_offset("Safety Status");
    assert_eq!(cb3, 1108);
    assert_eq!(CB3_SIZE, 1108);

    for (cfg, want) in [
        (Config::default(), 1220usize),
        (
            Config {
                polyscope: "3.15.7".into(),
                model: Model::Ur5,
                ..Config::default()
            },
            1108,
        ),
    ] {
        let mut out = vec![0xaa]; // appends after what is there
        encode_realtime(&mut out, &Status::default(), &cfg);
        assert_eq!(out.len(), 1 + want);
        assert_eq!(
            u32::from_be_bytes(out[1..5].try_into().unwrap()) as usize,
            want
        );
    }
}

#[test]
fn offsets_match_the_table() {
    let pairs = [
        ("Time", offset::TIME),
        ("q target", offset::Q_TARGET),
        ("qd target", offset::QD_TARGET),
        ("qdd target", offset::QDD_TARGET),
        ("I target", offset::I_TARGET),
        ("M target", offset::M_TARGET),
        ("q actual", offset::Q_ACTUAL),
        ("qd actual", offset::QD_ACTUAL),
        ("I actual", offset::I_ACTUAL),
        ("I control", offset::I_CONTROL),
        ("Tool vector actual", offset::TOOL_VECTOR_ACTUAL),
        ("TCP speed actual", offset::TCP_SPEED_ACTUAL),
        ("TCP force", offset::TCP_FORCE),
        ("Tool vector target", offset::TOOL_VECTOR_TARGET),
        ("TCP speed target", offset::TCP_SPEED_TARGET),
        ("Digital input bits", offset::DIGITAL_INPUT_BITS),
        ("Motor temperatures", offset::MOTOR_TEMPERATURES),
        ("Controller Timer", offset::CONTROLLER_TIMER),
        ("Test value", offset::TEST_VALUE),
        ("Robot Mode", offset::ROBOT_MODE),
        ("Joint Modes", offset::JOINT_MODES),
        ("Safety Mode", offset::SAFETY_MODE),
        ("Tool Accelerometer values", offset::TOOL_ACCELEROMETER),
        ("Speed scaling", offset::SPEED_SCALING),
        ("Linear momentum norm", offset::LINEAR_MOMENTUM_NORM),
        ("V main", offset::V_MAIN),
        ("V robot", offset::V_ROBOT),
        ("I robot", offset::I_ROBOT),
        ("V actual", offset::V_ACTUAL),
        ("Digital outputs", offset::DIGITAL_OUTPUTS),
        ("Program state", offset::PROGRAM_STATE),
        ("Elbow position", offset::ELBOW_POSITION),
        ("Elbow velocity", offset::ELBOW_VELOCITY),
        ("Safety Status", offset::SAFETY_STATUS),
        ("Payload Mass", offset::PAYLOAD_MASS),
        ("Payload CoG", offset::PAYLOAD_COG),
    ];
    for (name, at) in pairs {
        assert_eq!(table_offset(name), at, "{name}");
    }
    assert_eq!(offset::PAYLOAD_INERTIA, table_offset("Payload CoG") + 24);
    assert_eq!(offset::MESSAGE_SIZE, 0);
    assert_eq!(offset::TIME, 4);
    assert_eq!(offset::Q_ACTUAL, 252);
}

fn busy() -> Status {
    let mut s = Status::default();
    s.time = 77.125;
    s.robot_mode = RobotMode::Running;
    s.safety = SafetyStatus::Reduced;
    s.program_state = ProgramState::Paused;
    s.target_q = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6];
    s.target_qd = [1.1, 1.2, 1.3, 1.4, 1.5, 1.6];
    s.target_qdd = [2.1, 2.2, 2.3, 2.4, 2.5, 2.6];
    s.target_current = [3.1; 6];
    s.target_moment = [4.1; 6];
    s.actual_q = [-0.5, -1.0, 1.2, -0.3, 0.9, 0.1];
    s.actual_qd = [0.0; 6];
    s.actual_current = [0.7; 6];
    s.actual_tcp_pose = [0.3, 0.2, 0.1, 0.0, 3.0, 0.0];
    s.actual_tcp_speed = [0.01; 6];
    s.actual_tcp_force = [5.0; 6];
    s.target_tcp_pose = [0.31, 0.21, 0.11, 0.0, 3.0, 0.0];
    s.target_tcp_speed = [0.02; 6];
    s.digital_inputs = 0x2_0081;
    s.digital_outputs = 0x1_0102;
    s.joint_temperatures = [40.5; 6];
    s.tool_accelerometer = [0.1, -0.2, 9.7];
    s.speed_scaling = 0.3;
    s.main_voltage = 47.9;
    s.robot_voltage = 48.1;
    s.robot_current = 2.2;
    s.joint_voltage = [47.0; 6];
    s.payload_mass = 1.5;
    s.payload_cog = [0.0, 0.01, 0.05];
    s.payload_inertia = [0.1, 0.2, 0.3, 0.0, 0.0, 0.01];
    s
}

#[test]
fn values_read_back_at_their_offsets() {
    let s = busy();
    for layout in [Layout::ESeries, Layout::Cb3] {
        let mut b = Vec::new();
        encode_realtime_layout(&mut b, &s, layout);
        assert_eq!(f64_at(&b, table_offset("Time")), 77.125);
        assert_eq!(f64s_at::<6>(&b, table_offset("q target")), s.target_q);
        assert_eq!(f64s_at::<6>(&b, table_offset("qd target")), s.target_qd);
        assert_eq!(f64s_at::<6>(&b, table_offset("qdd target")), s.target_qdd);
        assert_eq!(f64s_at::<6>(&b, table_offset("I target")), s.target_current);
        assert_eq!(f64s_at::<6>(&b, table_offset("M target")), s.target_moment);
        assert_eq!(f64s_at::<6>(&b, table_offset("q actual")), s.actual_q);
        assert_eq!(f64s_at::<6>(&b, table_offset("I actual")), s.actual_current);
        assert_eq!(
            f64s_at::<6>(&b, table_offset("Tool vector actual")),
            s.actual_tcp_pose
        );
        assert_eq!(
            f64s_at::<6>(&b, table_offset("TCP speed actual")),
            s.actual_tcp_speed
        );
        assert_eq!(
            f64s_at::<6>(&b, table_offset("TCP force")),
            s.actual_tcp_force
        );
        assert_eq!(
            f64s_at::<6>(&b, table_offset("Tool vector target")),
            s.target_tcp_pose
        );
        assert_eq!(
            f64s_at::<6>(&b, table_offset("TCP speed target")),
            s.target_tcp_speed
        );
        assert_eq!(f64_at(&b, table_offset("Digital input bits")), 131_201.0);
        assert_eq!(
            f64s_at::<6>(&b, table_offset("Motor temperatures")),
            [40.5; 6]
        );
        assert_eq!(f64_at(&b, table_offset("Robot Mode")), 7.0);
        assert_eq!(f64s_at::<6>(&b, table_offset("Joint Modes")), [253.0; 6]);
        assert_eq!(f64_at(&b, table_offset("Safety Mode")), 2.0);
        assert_eq!(
            f64s_at::<3>(&b, table_offset("Tool Accelerometer values")),
            s.tool_accelerometer
        );
        assert_eq!(f64_at(&b, table_offset("Speed scaling")), 0.3);
        assert_eq!(f64_at(&b, table_offset("V main")), 47.9);
        assert_eq!(f64_at(&b, table_offset("V robot")), 48.1);
        assert_eq!(f64_at(&b, table_offset("I robot")), 2.2);
        assert_eq!(f64s_at::<6>(&b, table_offset("V actual")), [47.0; 6]);
        assert_eq!(f64_at(&b, table_offset("Digital outputs")), 65_794.0);
        assert_eq!(f64_at(&b, table_offset("Program state")), 4.0);
        assert_eq!(
            f64s_at::<3>(&b, table_offset("Elbow velocity")),
            [0.0; 3],
            "still arm"
        );
        if layout == Layout::ESeries {
            assert_eq!(f64_at(&b, table_offset("Safety Status")), 2.0);
            assert_eq!(f64_at(&b, table_offset("Payload Mass")), 1.5);
            assert_eq!(f64s_at::<3>(&b, table_offset("Payload CoG")), s.payload_cog);
            assert_eq!(
                f64s_at::<6>(&b, table_offset("Payload CoG") + 24),
                s.payload_inertia
            );
        }
    }
}

#[test]
fn elbow_is_an_upper_arm_away_from_the_shoulder_and_turns_with_the_base() {
    for model in [Model::Ur5e, Model::Ur10, Model::Ur3e] {
        let dh = model.dh();
        let mut s = busy();
        s.model = model;
        s.actual_qd = [0.8, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut b = Vec::new();
        encode_realtime_layout(&mut b, &s, Layout::ESeries);
        let elbow = f64s_at::<3>(&b, table_offset("Elbow position"));
        // The shoulder joint sits at (0, 0, d1); the elbow an upper arm (|a2|) from it.
        let d = ((elbow[0]).powi(2) + (elbow[1]).powi(2) + (elbow[2] - dh.d[0]).powi(2)).sqrt();
        assert!((d - dh.a[1].abs()).abs() < 1e-9, "{model}: {d}");
        // Turning only the base at w: v = w z × p.
        let v = f64s_at::<3>(&b, table_offset("Elbow velocity"));
        let want = [-0.8 * elbow[1], 0.8 * elbow[0], 0.0];
        for i in 0..3 {
            assert!((v[i] - want[i]).abs() < 1e-6, "{model}: {v:?} vs {want:?}");
        }
    }
}

#[test]
fn non_finite_values_do_not_panic() {
    let mut s = busy();
    s.time = f64::NAN;
    s.actual_q = [f64::INFINITY; 6];
    s.actual_qd = [f64::NAN; 6];
    s.robot_mode = RobotMode::NoController;
    let mut b = Vec::new();
    encode_realtime_layout(&mut b, &s, Layout::ESeries);
    assert_eq!(b.len(), E_SERIES_SIZE);
    assert_eq!(f64_at(&b, table_offset("Robot Mode")), -1.0);
}
