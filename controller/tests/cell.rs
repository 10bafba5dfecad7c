//! The cell: programs on the controller's arm, in time, driven by clients.

use std::time::Duration;

use urscript_controller::{
    Cell, CellEvent, Config, Controller, Dashboard, Ended, Inputs, ProgramList, ProgramState,
    StopReason, Submitted,
};
use urscript_interp::{Event, MessageKind};

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

/// A cell whose arm is RUNNING at 2 s.
fn ready_cell() -> (Cell, Dashboard) {
    let controller =
        Controller::new(Config::default()).with_programs(Box::new(ProgramList::new(["pick.urp"])));
    let interp = Cell::interp_config(&controller);
    let mut cell = Cell::new(controller, interp);
    let mut dash = Dashboard::new();
    dash.handle_line(cell.controller(), "brake release", ms(0));
    cell.advance(ms(2000));
    assert_eq!(
        dash.handle_line(cell.controller(), "robotmode", ms(2000))
            .lines,
        ["Robotmode: RUNNING"]
    );
    (cell, dash)
}

fn events(cell: &mut Cell) -> Vec<CellEvent> {
    std::iter::from_fn(|| cell.poll_event()).collect()
}

fn texts(events: &[CellEvent]) -> Vec<String> {
    events
        .iter()
        .filter_map(|e| match e {
            CellEvent::Program(Event::Message(m)) if m.kind == MessageKind::Textmsg => {
                Some(m.text.clone())
            }
            _ => None,
        })
        .collect()
}

#[test]
fn a_program_runs_to_its_end_and_leaves_its_outputs() {
    let (mut cell, _) = ready_cell();
    let prog = "def prog():\n  write_output_integer_register(5, 77)\n  set_standard_digital_out(3, True)\n  sleep(0.1)\n  textmsg(\"done\")\nend\n";
    cell.submit(Submitted::Program(prog.into()), ms(2000));
    assert_eq!(cell.program(), Some("prog"));
    assert_eq!(cell.controller().program_state(), ProgramState::Playing);
    cell.advance(ms(2050));
    assert!(
        texts(&events(&mut cell)).is_empty(),
        "still sleeping at 50 ms"
    );
    cell.advance(ms(2200));
    let ev = events(&mut cell);
    assert_eq!(texts(&ev), ["done"]);
    assert!(ev.iter().any(
        |e| matches!(e, CellEvent::ProgramEnded { name, how: Ended::Finished, reason: StopReason::EndOfProgram } if name == "prog")
    ));
    assert_eq!(cell.program(), None);
    assert_eq!(cell.controller().program_state(), ProgramState::Stopped);
    let s = cell.status();
    assert_eq!(s.output_int_registers[5], 77);
    assert_eq!(s.digital_outputs & (1 << 3), 1 << 3);
    // The next program sees the arm as the last one left it.
    cell.submit(
        Submitted::Program("textmsg(read_output_integer_register(5))\n".into()),
        ms(2300),
    );
    assert_eq!(texts(&events(&mut cell)), ["77"]);
}

#[test]
fn a_program_is_refused_while_the_arm_cannot_move_or_when_it_does_not_parse() {
    let controller = Controller::new(Config::default());
    let interp = Cell::interp_config(&controller);
    let mut cell = Cell::new(controller, interp);
    cell.submit(Submitted::Program("textmsg(\"x\")\n".into()), ms(0));
    let ev = events(&mut cell);
    assert!(
        matches!(&ev[..], [CellEvent::Refused { text, .. }] if text.contains("POWER_OFF")),
        "{ev:?}"
    );
    let (mut cell, _) = ready_cell();
    cell.submit(Submitted::Program("x = )\n".into()), ms(2000));
    let ev = events(&mut cell);
    assert!(
        matches!(&ev[..], [CellEvent::Refused { line: 1, text, .. }] if text.starts_with("syntax_error_on_line:1:")),
        "{ev:?}"
    );
    assert_eq!(cell.controller().program_state(), ProgramState::Stopped);
}

#[test]
fn pause_freezes_program_time_and_play_resumes_it() {
    let (mut cell, mut dash) = ready_cell();
    cell.submit(
        Submitted::Program("sleep(1.0)\ntextmsg(\"woke\")\n".into()),
        ms(2000),
    );
    cell.advance(ms(2500));
    assert_eq!(
        dash.handle_line(cell.controller(), "pause", ms(2500)).lines,
        ["Pausing program"]
    );
    cell.advance(ms(5000));
    assert!(texts(&events(&mut cell)).is_empty(), "paused for 2.5 s");
    assert_eq!(
        dash.handle_line(cell.controller(), "play", ms(5000)).lines,
        ["Starting program"]
    );
    cell.advance(ms(5400));
    assert!(
        texts(&events(&mut cell)).is_empty(),
        "0.9 s of program time so far"
    );
    cell.advance(ms(5600));
    assert_eq!(texts(&events(&mut cell)), ["woke"]);
}

#[test]
fn stop_ends_the_program_and_closes_its_sockets() {
    let (mut cell, mut dash) = ready_cell();
    cell.submit(
        Submitted::Program(
            "socket_open(\"127.0.0.1\", 1, \"cam\")\nwhile True:\n  sync()\nend\n".into(),
        ),
        ms(2000),
    );
    let ev = events(&mut cell);
    assert!(ev.iter().any(|e| matches!(e, CellEvent::Program(Event::Connect { socket_name, .. }) if socket_name == "cam")));
    cell.machine_mut().unwrap().handle_connected("cam", Ok(()));
    cell.advance(ms(2100));
    assert_eq!(
        dash.handle_line(cell.controller(), "stop", ms(2100)).lines,
        ["Stopped"]
    );
    cell.advance(ms(2102));
    let ev = events(&mut cell);
    assert!(ev.iter().any(|e| matches!(e, CellEvent::Program(Event::Close { socket_name }) if socket_name == "cam")), "{ev:?}");
    assert!(ev.iter().any(|e| matches!(
        e,
        CellEvent::ProgramEnded {
            how: Ended::Stopped,
            ..
        }
    )));
    assert_eq!(cell.program(), None);
}

#[test]
fn a_new_program_replaces_the_running_one_and_a_secondary_runs_beside_it() {
    let (mut cell, _) = ready_cell();
    cell.submit(
        Submitted::Program("def a():\n  while True:\n    sync()\n  end\nend\n".into()),
        ms(2000),
    );
    cell.submit(
        Submitted::Secondary("sec s():\n  set_standard_digital_out(1, True)\nend\n".into()),
        ms(2010),
    );
    assert_eq!(
        cell.program(),
        Some("a"),
        "a secondary program does not replace it"
    );
    assert_eq!(cell.status().digital_outputs & 0b10, 0b10);
    cell.submit(
        Submitted::Program("def b():\n  sleep(5)\nend\n".into()),
        ms(2020),
    );
    let ev = events(&mut cell);
    assert!(ev.iter().any(
        |e| matches!(e, CellEvent::ProgramEnded { name, how: Ended::Stopped, reason: StopReason::Replaced } if name == "a")
    ));
    assert!(ev
        .iter()
        .any(|e| matches!(e, CellEvent::ProgramStarted { name } if name == "b")));
    assert_eq!(cell.program(), Some("b"));
}

#[test]
fn a_program_that_does_not_compile_leaves_the_running_one_alone() {
    // A driver sends `def move(): ... end` and then `move()`: the line after the
    // program's end comes as a one-line program of its own that calls a name it does
    // not define. It is refused; the program it came after runs to its end.
    let (mut cell, _) = ready_cell();
    cell.submit(
        Submitted::Program("def move():\n  sleep(0.1)\n  textmsg(\"moved\")\nend\n".into()),
        ms(2000),
    );
    cell.submit(Submitted::Program("move()\n".into()), ms(2000));
    assert_eq!(cell.program(), Some("move"));
    cell.advance(ms(2200));
    let ev = events(&mut cell);
    assert!(ev.iter().any(|e| matches!(
        e,
        CellEvent::Refused { line: 1, text, .. } if text.starts_with("compile_error_name_not_found:move:")
    )));
    assert_eq!(texts(&ev), ["moved"]);
    assert!(ev.iter().any(
        |e| matches!(e, CellEvent::ProgramEnded { name, how: Ended::Finished, .. } if name == "move")
    ));
}

#[test]
fn a_secondary_program_that_cannot_finish_says_so() {
    let (mut cell, _) = ready_cell();
    cell.submit(
        Submitted::Secondary(
            "sec s():\n  socket_open(\"127.0.0.1\", 50000, \"grip\")\n  socket_send_string(\"GO\", \"grip\")\nend\n"
                .into(),
        ),
        ms(2000),
    );
    // It asks for its connection (a driver of its own serves it) and waits for it.
    let ev = events(&mut cell);
    assert!(
        ev.iter().any(|e| matches!(e, CellEvent::Secondary(Event::Connect { socket_name, .. }) if socket_name == "grip")),
        "{ev:?}"
    );
    assert!(cell.secondary_machine_mut().is_some());
    // A second one waits its turn.
    cell.submit(
        Submitted::Secondary("sec t():\n  set_standard_digital_out(2, True)\nend\n".into()),
        ms(2010),
    );
    assert_eq!(cell.status().digital_outputs >> 2 & 1, 0);
    // No connection came within the secondary program's time: it is ended, saying so,
    // and the next one runs.
    cell.advance(ms(2000) + urscript_controller::SECONDARY_TIME);
    let ev = events(&mut cell);
    assert!(
        ev.iter().any(|e| matches!(
            e,
            CellEvent::Refused { text, .. }
                if text.contains("ended unfinished") && text.contains("socket_open(\"127.0.0.1\", 50000)")
        )),
        "{ev:?}"
    );
    assert!(ev.iter().any(|e| matches!(e, CellEvent::SecondaryEnded)));
    assert!(cell.secondary_machine_mut().is_none());
    assert_eq!(cell.status().digital_outputs >> 2 & 1, 1);
}

#[test]
fn client_inputs_reach_the_program_and_the_status() {
    let (mut cell, _) = ready_cell();
    cell.apply(&Inputs {
        int_registers: vec![(2, -9)],
        double_registers: vec![(47, 2.5)],
        bool_registers: vec![(64, true), (500, true)],
        standard_digital_outputs: Some((0b0000_0101, 0b0000_0100)),
        speed_slider_fraction: Some(0.3),
        ..Inputs::default()
    });
    let s = cell.status();
    assert_eq!(s.input_int_registers[2], -9);
    assert_eq!(s.input_double_registers[47], 2.5);
    assert!(s.input_bool_registers[64]);
    assert_eq!(s.digital_outputs & 0b101, 0b100);
    assert_eq!(s.speed_fraction, 0.3);
    cell.submit(
        Submitted::Program(
            "textmsg(read_input_integer_register(2), read_input_float_register(47))\n".into(),
        ),
        ms(2000),
    );
    assert_eq!(texts(&events(&mut cell)), ["-92.5"]);
}

#[test]
fn play_of_a_loaded_program_asks_for_its_text() {
    let (mut cell, mut dash) = ready_cell();
    assert_eq!(
        dash.handle_line(cell.controller(), "load pick.urp", ms(2000))
            .lines,
        ["Loading program: pick.urp"]
    );
    dash.handle_line(cell.controller(), "play", ms(2000));
    cell.advance(ms(2002));
    let ev = events(&mut cell);
    assert!(
        matches!(&ev[..], [CellEvent::NeedProgram { name, .. }] if name == "pick.urp"),
        "{ev:?}"
    );
    cell.advance(ms(2004));
    assert!(events(&mut cell).is_empty(), "asked once");
    cell.start_loaded("def pick():\n  textmsg(\"picked\")\nend\n".into(), ms(2004));
    let ev = events(&mut cell);
    assert_eq!(texts(&ev), ["picked"]);
    assert!(ev
        .iter()
        .any(|e| matches!(e, CellEvent::ProgramStarted { name } if name == "pick.urp")));
    assert_eq!(cell.controller().program_state(), ProgramState::Stopped);
}

/// A loaded program that cannot be read is refused once: the refusal does not ask for
/// its text again (which would read the file and report it a second time).
#[test]
fn a_loaded_program_refused_is_asked_for_and_reported_once() {
    let (mut cell, mut dash) = ready_cell();
    dash.handle_line(cell.controller(), "load pick.urp", ms(2000));
    dash.handle_line(cell.controller(), "play", ms(2000));
    cell.advance(ms(2002));
    let ev = events(&mut cell);
    assert!(matches!(&ev[..], [CellEvent::NeedProgram { .. }]), "{ev:?}");
    cell.refuse_loaded("pick.urp: not a .urp".into(), ms(2010));
    let ev = events(&mut cell);
    assert!(
        matches!(&ev[..], [CellEvent::Refused { text, .. }] if text == "pick.urp: not a .urp"),
        "{ev:?}"
    );
    cell.advance(ms(2020));
    assert!(events(&mut cell).is_empty());
    assert_eq!(cell.controller().program_state(), ProgramState::Stopped);
}

#[test]
fn the_primary_interfaces_unlock_releases_at_once_the_dashboards_is_held() {
    use urscript_controller::SafetyStatus;
    let (mut cell, _) = ready_cell();
    cell.controller().protective_stop(ms(2000));
    // The dashboard's command is refused within the 5 s hold...
    assert!(cell.controller().unlock_protective_stop(ms(2050)).is_err());
    assert_eq!(
        cell.controller().safety_status(ms(2050)),
        SafetyStatus::ProtectiveStop
    );
    // ...the primary interface's releases the stop when it arrives, nothing left timed.
    cell.controller()
        .request_unlock_protective_stop(ms(2100))
        .unwrap();
    assert_eq!(
        cell.controller().safety_status(ms(2100)),
        SafetyStatus::Normal
    );
    assert_eq!(cell.controller().poll_timeout(), None);
    // With no stop it changes nothing, and a later stop stays until unlocked again.
    cell.controller()
        .request_unlock_protective_stop(ms(2200))
        .unwrap();
    cell.controller().protective_stop(ms(3000));
    assert_eq!(
        cell.controller().safety_status(ms(60_000)),
        SafetyStatus::ProtectiveStop
    );
}

#[test]
fn interpreter_lines_reach_the_program_and_late_replies_their_connection() {
    let (mut cell, _dash) = ready_cell();
    let say = |cell: &mut Cell, conn: u64, line: &str, t: u64| {
        cell.interpreter_line(conn, line.as_bytes(), ms(t))
            .map(|r| r.to_string())
    };
    let replies = |cell: &mut Cell, conn: u64| -> Vec<String> {
        cell.interpreter_replies(conn)
            .iter()
            .map(ToString::to_string)
            .collect()
    };
    assert_eq!(
        say(&mut cell, 1, "textmsg(1)", 2000).unwrap(),
        "discard: program not running: textmsg(1)"
    );
    assert_eq!(
        say(&mut cell, 1, "statelastinterpreted", 2000).unwrap(),
        "state: 0: statelastinterpreted"
    );
    cell.submit(
        Submitted::Program("def remote():\n  interpreter_mode()\nend\n".into()),
        ms(2000),
    );
    assert!(cell.interpreter_status().unwrap().active);
    assert_eq!(
        say(&mut cell, 1, "clear_interpreter()", 2002).unwrap(),
        "ack: 1: clear_interpreter()"
    );
    // Two connections' lines wait behind the clear; each gets its own reply.
    assert_eq!(say(&mut cell, 2, "textmsg(\"two\")\r", 2002), None);
    assert_eq!(say(&mut cell, 1, "textmsg(\"one\")", 2002), None);
    assert!(replies(&mut cell, 1).is_empty());
    cell.advance(ms(2010));
    assert_eq!(replies(&mut cell, 1), ["ack: 3: textmsg(\"one\")"]);
    assert_eq!(replies(&mut cell, 2), ["ack: 2: textmsg(\"two\")"]);
    assert!(replies(&mut cell, 1).is_empty(), "given once");
    let shown = texts(&events(&mut cell));
    assert_eq!(shown, ["two", "one"]);
    // A line held when the program is replaced: no program runs for it.
    assert_eq!(
        say(&mut cell, 3, "sleep(10)", 2012).unwrap(),
        "ack: 4: sleep(10)"
    );
    say(&mut cell, 3, "clear_interpreter()", 2012).unwrap();
    assert_eq!(say(&mut cell, 3, "textmsg(3)", 2012), None);
    cell.submit(Submitted::Program("textmsg(\"next\")\n".into()), ms(2020));
    assert_eq!(
        replies(&mut cell, 3),
        ["discard: program not running: textmsg(3)"]
    );
}

#[test]
fn protective_stop_in_a_secondary_program_stops_the_arm() {
    use urscript_controller::SafetyStatus;
    let (mut cell, _) = ready_cell();
    cell.submit(
        Submitted::Secondary("sec setup():\n  protective_stop()\nend\n".into()),
        ms(2100),
    );
    assert_eq!(
        cell.controller().safety_status(ms(2100)),
        SafetyStatus::ProtectiveStop
    );
}

#[test]
fn an_rtde_watchdog_pauses_the_program_when_its_client_stops_writing() {
    let (mut cell, _) = ready_cell();
    let prog = "def fed():\n  rtde_set_watchdog(\"input_int_register_0\", 10, \"PAUSE\")\n  while True:\n    sync()\n  end\nend\n";
    cell.submit(Submitted::Program(prog.into()), ms(2000));
    // A client writes the register every 40 ms for half a second: the program plays.
    let mut t = 2000;
    while t < 2500 {
        t += 40;
        cell.apply(&Inputs {
            int_registers: vec![(0, 1)],
            fields: vec!["input_int_register_0".into()],
            ..Inputs::default()
        });
        cell.advance(ms(t));
    }
    assert_eq!(cell.controller().program_state(), ProgramState::Playing);
    // The client goes away: its last write was applied before the last advance, so the
    // program saw it in the first step after t - 40 ms; 0.1 s later it is paused.
    cell.advance(ms(t + 50));
    assert_eq!(cell.controller().program_state(), ProgramState::Playing);
    cell.advance(ms(t + 70));
    assert_eq!(cell.controller().program_state(), ProgramState::Paused);
}

#[test]
fn powerdown_ends_the_program_and_powers_the_arm_off() {
    let (mut cell, mut dash) = ready_cell();
    cell.submit(
        Submitted::Program(
            "def off():\n  textmsg(\"bye\")\n  powerdown()\n  textmsg(\"never\")\nend\n".into(),
        ),
        ms(2000),
    );
    cell.advance(ms(2010));
    assert_eq!(texts(&events(&mut cell)), ["bye"]);
    assert_eq!(cell.controller().program_state(), ProgramState::Stopped);
    assert_eq!(
        dash.handle_line(cell.controller(), "robotmode", ms(2010))
            .lines,
        ["Robotmode: POWER_OFF"]
    );
}

#[test]
fn the_speed_slider_scales_the_programs_motion() {
    let (mut cell, _) = ready_cell();
    cell.apply(&Inputs {
        speed_slider_fraction: Some(0.5),
        ..Inputs::default()
    });
    let prog = "movej([0.5, -1.2, 0.8, -1.9, 0.3, 0.4], t=1.5)\ntextmsg(\"done\")\n";
    cell.submit(Submitted::Program(prog.into()), ms(2000));
    cell.advance(ms(2000 + 1600));
    assert!(
        texts(&events(&mut cell)).is_empty(),
        "at half speed a 1.5 s move is not over at 1.6 s"
    );
    let s = cell.status();
    assert_eq!((s.speed_fraction, s.speed_scaling), (0.5, 0.5));
    assert!(s.actual_qd.iter().any(|v| *v != 0.0), "still moving");
    cell.advance(ms(2000 + 2990));
    assert!(texts(&events(&mut cell)).is_empty(), "3.0 s at half speed");
    cell.advance(ms(2000 + 3010));
    assert_eq!(texts(&events(&mut cell)), ["done"]);
    assert_eq!(cell.status().actual_q, [0.5, -1.2, 0.8, -1.9, 0.3, 0.4]);
}

#[test]
fn force_mode_against_a_surface_shows_in_the_tcp_force_and_the_control_mode() {
    let (mut cell, _) = ready_cell();
    let z = cell.status().actual_tcp_pose[2];
    cell.arm_mut()
        .world
        .set(&format!("contact_plane=p[0, 0, {}, 0, 0, 0]", z - 0.03))
        .unwrap();
    cell.arm_mut().world.set("contact_stiffness=10000").unwrap();
    let prog = "force_mode(p[0, 0, 0, 0, 0, 0], [0, 0, 1, 0, 0, 0], [0, 0, -20, 0, 0, 0], 2, [0.1, 0.1, 0.1, 1, 1, 1])\nsleep(2)\nend_force_mode()\n";
    cell.submit(Submitted::Program(prog.into()), ms(2000));
    cell.advance(ms(2000 + 100));
    let s = cell.status();
    assert_eq!(s.control_mode, 2, "force");
    assert_eq!(
        s.actual_tcp_force, [0.0; 6],
        "free space: the sensor reads nothing"
    );
    assert!(
        (s.actual_tcp_pose[2] - (z - 0.01)).abs() < 0.001,
        "0.1 m/s down"
    );
    cell.advance(ms(2000 + 1000));
    let s = cell.status();
    // 30 mm to the surface, then 20 N / 10000 N/m = 2 mm into it.
    assert!(
        (s.actual_tcp_force[2] - 20.0).abs() < 0.01,
        "{:?}",
        s.actual_tcp_force
    );
    assert!((s.actual_tcp_pose[2] - (z - 0.032)).abs() < 1e-5);
    cell.advance(ms(2000 + 2100));
    assert_eq!(cell.status().control_mode, 0, "the program ended");
}

#[test]
fn in_teach_mode_the_operator_moves_the_joints_and_the_streams_follow() {
    let (mut cell, _) = ready_cell();
    cell.submit(Submitted::Program("sleep(5)\n".into()), ms(2000));
    let q = [0.2, -1.3, 1.1, -1.4, -1.5, 0.3];
    assert!(cell.move_by_hand(q).is_err(), "not in teach mode");
    cell.submit(
        Submitted::Program(
            "teach_mode()\nsleep(5)\ntextmsg(get_actual_joint_positions())\n".into(),
        ),
        ms(2100),
    );
    cell.advance(ms(2200));
    assert_eq!(cell.status().control_mode, 1, "teach");
    cell.move_by_hand(q).unwrap();
    assert!(cell.move_by_hand([0.0, 0.0, 9.0, 0.0, 0.0, 0.0]).is_err());
    cell.advance(ms(2300));
    let s = cell.status();
    assert_eq!(s.actual_q, q);
    assert_eq!(s.target_q, q);
    cell.advance(ms(7200));
    assert_eq!(
        texts(&events(&mut cell)),
        ["[0.2, -1.3, 1.1, -1.4, -1.5, 0.3]"]
    );
    assert_eq!(cell.status().control_mode, 0);
    // With no program running, the operator's freedrive moves the arm too.
    cell.move_by_hand([0.0; 6]).unwrap();
    assert_eq!(cell.status().actual_q, [0.0; 6]);
}

#[test]
fn operator_commands_act_on_the_cell_as_listed() {
    use urscript_controller::{OperatorCommand, SafetyStatus};
    let (mut cell, _) = ready_cell();
    let run = |cell: &mut Cell, line: &str, at: u64| {
        line.parse::<OperatorCommand>()
            .unwrap_or_else(|e| panic!("{line}: {e}"))
            .apply(cell, ms(at))
    };
    assert_eq!(run(&mut cell, "speed 0.25", 2000), Ok(()));
    cell.advance(ms(2010));
    assert_eq!(cell.status().speed_fraction, 0.25);
    assert_eq!(run(&mut cell, "Protective Stop", 2010), Ok(()));
    assert_eq!(
        cell.controller().safety_status(ms(2010)),
        SafetyStatus::ProtectiveStop
    );
    assert_eq!(run(&mut cell, "release", 2020), Ok(()));
    assert_eq!(
        cell.controller().safety_status(ms(2020)),
        SafetyStatus::Normal
    );
    // By hand with no program running: the joints follow.
    assert_eq!(
        run(&mut cell, "freedrive 0.1 -1.5 1.2 -1.3 -1.5 0.2", 2030),
        Ok(())
    );
    assert_eq!(cell.status().actual_q[0], 0.1);
    // A program running outside teach/freedrive mode: refused, the joints stay.
    cell.submit(
        Submitted::Program("def waits():\n  while True:\n    sync()\n  end\nend\n".into()),
        ms(2040),
    );
    cell.advance(ms(2050));
    let refused = run(&mut cell, "freedrive 0 -1.5 1.2 -1.3 -1.5 0.2", 2050);
    assert!(refused.is_err_and(|why| why.contains("teach or freedrive")));
    assert_eq!(cell.status().actual_q[0], 0.1);
    assert_eq!(run(&mut cell, "local", 2060), Ok(()));
    assert!(!cell.controller().remote_control());
}
