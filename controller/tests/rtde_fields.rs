//! The interpreter and the controller's RTDE server know the same fields: every name of
//! the one table (`urscript_interp::rtde_fields`) and misspellings of them are asked of
//! both sides, and the values computed in more than one place (joint mode, elbow) are
//! compared across the interfaces that carry them.

use std::time::Duration;

use urscript_controller::primary::{joint_mode, Layout};
use urscript_controller::realtime::{encode_realtime_layout, offset};
use urscript_controller::{
    Cell, Config, Controller, Dashboard, InputRegistry, ProgramState, RobotMode, RtdeEvent,
    RtdeSession, SafetyStatus, Status, Submitted,
};
use urscript_interp::kinematics::Model;
use urscript_interp::rtde_fields::{self, Direction, Field};
use urscript_interp::{Event, Machine, Program, State};

fn packet(ty: u8, payload: &[u8]) -> Vec<u8> {
    let mut p = ((payload.len() + 3) as u16).to_be_bytes().to_vec();
    p.push(ty);
    p.extend_from_slice(payload);
    p
}

/// The payloads of the packets in `bytes`.
fn payloads(bytes: &[u8]) -> Vec<(u8, Vec<u8>)> {
    let mut out = Vec::new();
    let mut rest = bytes;
    while rest.len() >= 3 {
        let size = usize::from(u16::from_be_bytes([rest[0], rest[1]]));
        out.push((rest[2], rest[3..size].to_vec()));
        rest = &rest[size..];
    }
    out
}

/// A v2 session of the newest controller (every field available) that set up `names`
/// in `direction`: the session, the recipe id and the type list answered.
fn setup(names: &str, direction: Direction) -> (RtdeSession, InputRegistry, u8, String) {
    let config = Config::default();
    let mut registry = InputRegistry::new();
    let mut s = RtdeSession::new(&config, &mut registry);
    s.handle_received(&mut registry, &packet(b'V', &2u16.to_be_bytes()))
        .unwrap();
    let p = match direction {
        Direction::Output => {
            let mut p = 125.0f64.to_be_bytes().to_vec();
            p.extend_from_slice(names.as_bytes());
            packet(b'O', &p)
        }
        Direction::Input => packet(b'I', names.as_bytes()),
    };
    s.handle_received(&mut registry, &p).unwrap();
    let out = payloads(&s.take_outbox());
    let (_, reply) = out.last().expect("a setup reply").clone();
    let id = reply[0];
    let types = String::from_utf8(reply[1..].to_vec()).unwrap();
    (s, registry, id, types)
}

/// Whether the interpreter runs `src` without a runtime error.
fn interp_runs(src: &str) -> bool {
    let mut m = Machine::new(
        Program::parse(src).expect("parses"),
        urscript_interp::Config::default(),
    );
    m.run_until(Duration::from_millis(20));
    match m.state() {
        State::Finished => true,
        State::Error(_) => false,
        other => panic!("{src}: {other:?}"),
    }
}

/// Every name of the table, and names one slip away from them.
fn candidates() -> Vec<String> {
    let mut names: Vec<String> = Field::all().map(|f| f.to_string()).collect();
    for prefix in [
        "output_bit_register_",
        "output_int_register_",
        "output_double_register_",
        "input_bit_register_",
        "input_int_register_",
        "input_double_register_",
    ] {
        for n in [
            "05", "+5", "00", "064", "+100", "48", "63", "128", "256", "1e1", "",
        ] {
            names.push(format!("{prefix}{n}"));
        }
    }
    names.extend(
        [
            "input_bit_registers0_to_31x",
            "ACTUAL_Q",
            "actual_tcp_pose",
            "no_such_field",
            "speed_slider",
        ]
        .map(String::from),
    );
    names.sort();
    names.dedup();
    names
}

#[test]
fn a_name_is_known_to_both_sides_or_to_neither() {
    let (mut outputs, mut inputs) = (0, 0);
    for name in candidates() {
        // get_rtde_value reads outputs; rtde_set_watchdog watches inputs.
        let (_, _, _, out_type) = setup(&name, Direction::Output);
        let (_, _, _, in_type) = setup(&name, Direction::Input);
        let served = out_type != "NOT_FOUND";
        let writable = in_type != "NOT_FOUND";
        let read = interp_runs(&format!("x = get_rtde_value(\"{name}\")\n"));
        let watched = interp_runs(&format!("rtde_set_watchdog(\"{name}\", 1)\n"));
        assert_eq!(
            served, read,
            "{name}: controller output {out_type}, get_rtde_value {read}"
        );
        assert_eq!(
            writable, watched,
            "{name}: controller input {in_type}, rtde_set_watchdog {watched}"
        );
        // The controller answers the table's type for the table's names, and only them.
        let out_field = Field::lookup(&name, Direction::Output);
        let in_field = Field::lookup(&name, Direction::Input);
        assert_eq!(
            out_field.map_or("NOT_FOUND", |f| f.rtde_type().name()),
            out_type,
            "{name}"
        );
        assert_eq!(
            in_field.map_or("NOT_FOUND", |f| f.rtde_type().name()),
            in_type,
            "{name}"
        );
        outputs += usize::from(served);
        inputs += usize::from(writable);
    }
    // Every field of the table was served, and nothing else.
    let count = |d| Field::all().filter(|f| f.direction() == d).count();
    assert_eq!(outputs, count(Direction::Output));
    assert_eq!(inputs, count(Direction::Input));
    assert!(outputs > 400 && inputs > 150, "{outputs} {inputs}");
}

#[test]
fn leading_zeros_and_signs_are_refused_by_both_sides() {
    for name in [
        "input_int_register_05",
        "input_int_register_+5",
        "output_int_register_07",
    ] {
        assert_eq!(setup(name, Direction::Output).3, "NOT_FOUND", "{name}");
        assert!(
            !interp_runs(&format!("x = get_rtde_value(\"{name}\")\n")),
            "{name}"
        );
    }
    assert_eq!(
        setup("input_int_register_05", Direction::Input).3,
        "NOT_FOUND"
    );
    assert!(!interp_runs(
        "rtde_set_watchdog(\"input_int_register_05\", 1)\n"
    ));
    assert!(interp_runs(
        "rtde_set_watchdog(\"input_int_register_5\", 1)\n"
    ));
}

const ROBOT_MODES: [RobotMode; 10] = [
    RobotMode::NoController,
    RobotMode::Disconnected,
    RobotMode::ConfirmSafety,
    RobotMode::Booting,
    RobotMode::PowerOff,
    RobotMode::PowerOn,
    RobotMode::Idle,
    RobotMode::Backdrive,
    RobotMode::Running,
    RobotMode::UpdatingFirmware,
];

const SAFETY: [SafetyStatus; 11] = [
    SafetyStatus::Normal,
    SafetyStatus::Reduced,
    SafetyStatus::ProtectiveStop,
    SafetyStatus::Recovery,
    SafetyStatus::SafeguardStop,
    SafetyStatus::SystemEmergencyStop,
    SafetyStatus::RobotEmergencyStop,
    SafetyStatus::Violation,
    SafetyStatus::Fault,
    SafetyStatus::AutomaticModeSafeguardStop,
    SafetyStatus::SystemThreePositionEnablingStop,
];

fn f64_at(b: &[u8], at: usize) -> f64 {
    f64::from_be_bytes(b[at..at + 8].try_into().unwrap())
}

/// The output data package of `names` for `status`, after the recipe id.
fn outputs(names: &str, status: &Status) -> Vec<u8> {
    let (mut s, mut registry, id, types) = setup(names, Direction::Output);
    assert_eq!(id, 1, "{types}");
    s.handle_received(&mut registry, &packet(b'S', &[]))
        .unwrap();
    s.take_outbox();
    s.on_step(status, Duration::ZERO);
    let data = payloads(&s.take_outbox());
    data[0].1[1..].to_vec()
}

#[test]
fn joint_mode_is_one_formula_on_rtde_primary_and_realtime() {
    for robot_mode in ROBOT_MODES {
        for safety in SAFETY {
            let status = Status {
                robot_mode,
                safety,
                ..Status::default()
            };
            let want = rtde_fields::joint_mode(robot_mode.code(), safety.code());
            assert_eq!(i32::from(joint_mode(&status)), want);
            let d = outputs("joint_mode,tool_mode", &status);
            for j in 0..6 {
                let at = 4 * j;
                let v = i32::from_be_bytes(d[at..at + 4].try_into().unwrap());
                assert_eq!(v, want, "{robot_mode} {safety} joint {j}");
            }
            let tool = u32::from_be_bytes(d[24..28].try_into().unwrap());
            assert_eq!(tool as i32, want);
            let mut rt = Vec::new();
            encode_realtime_layout(&mut rt, &status, Layout::ESeries);
            for j in 0..6 {
                assert_eq!(
                    f64_at(&rt, offset::JOINT_MODES + 8 * j),
                    f64::from(want),
                    "{robot_mode} {safety}"
                );
            }
        }
    }
    assert_eq!(rtde_fields::joint_mode(RobotMode::Running.code(), 1), 253);
}

#[test]
fn the_elbow_is_one_formula_on_rtde_realtime_and_get_rtde_value() {
    let poses = [
        [0.0, -std::f64::consts::FRAC_PI_2, 0.0, -1.57, 0.0, 0.0],
        [0.4, -1.2, 1.1, 0.3, -0.2, 0.5],
        [-2.5, 0.7, -0.4, 1.0, 2.0, -3.0],
    ];
    for model in [Model::Ur5e, Model::Ur10, Model::Ur3e] {
        for q in poses {
            let qd = [0.3, -0.7, 0.9, 0.1, 0.2, 0.3];
            let status = Status {
                model,
                actual_q: q,
                actual_qd: qd,
                program_state: ProgramState::Playing,
                ..Status::default()
            };
            let (p, v) = rtde_fields::elbow(&model.dh(), q, qd);
            let d = outputs("elbow_position,elbow_velocity", &status);
            let mut rt = Vec::new();
            encode_realtime_layout(&mut rt, &status, Layout::ESeries);
            for i in 0..3 {
                assert_eq!(f64_at(&d, 8 * i), p[i], "{model} {q:?}");
                assert_eq!(f64_at(&d, 24 + 8 * i), v[i], "{model} {q:?}");
                assert_eq!(f64_at(&rt, offset::ELBOW_POSITION + 8 * i), p[i]);
                assert_eq!(f64_at(&rt, offset::ELBOW_VELOCITY + 8 * i), v[i]);
            }
        }
    }
    // The interpreter's get_rtde_value, on its UR5e arm.
    let q = poses[1];
    let mut m = Machine::new(
        Program::parse("textmsg(get_rtde_value(\"elbow_position\"))\n").unwrap(),
        urscript_interp::Config::default(),
    );
    m.arm_mut().q = q;
    m.run_until(Duration::from_millis(20));
    let text = std::iter::from_fn(|| m.poll_event())
        .find_map(|e| match e {
            Event::Message(msg) => Some(msg.text),
            _ => None,
        })
        .expect("a message");
    let got: Vec<f64> = text
        .trim_matches(['[', ']'])
        .split(',')
        .map(|x| x.trim().parse().unwrap())
        .collect();
    let (p, _) = rtde_fields::elbow(&Model::Ur5e.dh(), q, [0.0; 6]);
    for i in 0..3 {
        assert!((got[i] - p[i]).abs() < 1e-4, "{text} vs {p:?}");
    }
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// A program watching `field` (pause after 0.1 s without an update) on a running arm,
/// fed by an RTDE client that writes an input recipe of `names` (whose packages carry
/// `data` after the recipe id) every 40 ms for half a second: the program's state then.
fn watched_while_fed(field: &str, names: &str, data: &[u8]) -> ProgramState {
    let controller = Controller::new(Config::default());
    let interp = Cell::interp_config(&controller);
    let mut cell = Cell::new(controller, interp);
    Dashboard::new().handle_line(cell.controller(), "brake release", ms(0));
    cell.advance(ms(2000));
    let prog = format!(
        "def fed():\n  rtde_set_watchdog(\"{field}\", 10, \"PAUSE\")\n  while True:\n    sync()\n  end\nend\n"
    );
    cell.submit(Submitted::Program(prog), ms(2000));
    let (mut s, mut registry, id, types) = setup(names, Direction::Input);
    assert_eq!(id, 1, "{types}");
    let mut package = vec![id];
    package.extend_from_slice(data);
    let mut t = 2000;
    while t < 2500 {
        t += 40;
        s.handle_received(&mut registry, &packet(b'U', &package))
            .unwrap();
        while let Some(e) = s.poll_event() {
            if let RtdeEvent::Inputs { inputs, .. } = e {
                cell.apply(&inputs);
            }
        }
        cell.advance(ms(t));
    }
    cell.controller().program_state()
}

#[test]
fn an_rtde_watchdog_is_fed_by_writes_to_its_field_by_name() {
    // Bool registers 0-31 written as their UINT32 field.
    assert_eq!(
        watched_while_fed(
            "input_bit_registers0_to_31",
            "input_bit_registers0_to_31",
            &5u32.to_be_bytes()
        ),
        ProgramState::Playing
    );
    // The second analog output and a mask are fields of their own.
    let mut d = 3u8.to_be_bytes().to_vec();
    d.extend_from_slice(&0.5f64.to_be_bytes());
    assert_eq!(
        watched_while_fed(
            "standard_analog_output_1",
            "standard_analog_output_mask,standard_analog_output_1",
            &d
        ),
        ProgramState::Playing
    );
    assert_eq!(
        watched_while_fed(
            "standard_analog_output_mask",
            "standard_analog_output_mask,standard_analog_output_1",
            &d
        ),
        ProgramState::Playing
    );
    // A field the client does not write is not fed.
    assert_eq!(
        watched_while_fed(
            "standard_analog_output_0",
            "standard_analog_output_mask,standard_analog_output_1",
            &d
        ),
        ProgramState::Paused
    );
    assert_eq!(
        watched_while_fed(
            "input_int_register_3",
            "input_int_register_3",
            &7i32.to_be_bytes()
        ),
        ProgramState::Playing
    );
}
