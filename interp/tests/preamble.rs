//! URCap preambles: definitions that run before the program, at the top of its body,
//! as PolyScope writes an installation's URCap contributions; and the world set from
//! `NAME=VALUE` settings.
use std::time::Duration;

use urscript_interp::{Config, Event, Machine, Preamble, Program, RuntimeErrorKind, State};

/// A URCap-like preamble: a global its functions share, a function, a thread.
const GRIPPER: &str = "\
# the gripper URCap's contribution
gripper_port = 63352
def gripper_move(width):
  textmsg(\"gripper to \", width)
  return width <= 85
end
thread gripper_watch():
  sync()
end
";

fn run(p: Program) -> (State, Vec<String>) {
    let mut m = Machine::new(p, Config::default());
    m.run_until(Duration::from_secs(1));
    let mut msgs = Vec::new();
    while let Some(e) = m.poll_event() {
        if let Event::Message(msg) = e {
            msgs.push(msg.text);
        }
    }
    (m.state().clone(), msgs)
}

fn gripper() -> Preamble {
    let mut p = Preamble::default();
    p.add(GRIPPER).unwrap();
    p
}

#[test]
fn a_def_program_calls_what_the_preamble_defines() {
    let src = "def prog():\n  ok = gripper_move(40)\n  textmsg(ok, gripper_port)\nend\n";
    let p = Program::parse_with_preamble(&gripper(), src).unwrap();
    assert_eq!(p.entry_name(), Some("prog"));
    assert_eq!(
        run(p),
        (
            State::Finished,
            vec!["gripper to 40".into(), "True63352".into()]
        )
    );
    // The same program without its preamble is refused before it starts, as the
    // controller refuses a program whose URCap is not installed.
    let (state, msgs) = run(Program::parse(src).unwrap());
    let State::Error(e) = state else {
        panic!("{state:?}")
    };
    assert_eq!(e.kind(), RuntimeErrorKind::UnknownFunction, "{e}");
    assert!(msgs.is_empty());
}

#[test]
fn top_level_statements_run_after_the_preamble_and_its_variables_are_globals() {
    let src =
        "gripper_port = gripper_port + 1\ntextmsg(gripper_port)\nh = run gripper_watch()\njoin h\n";
    let p = Program::parse_with_preamble(&gripper(), src).unwrap();
    assert_eq!(run(p), (State::Finished, vec!["63353".into()]));
}

#[test]
fn preambles_run_in_the_order_added_and_a_bad_one_adds_nothing() {
    let mut p = gripper();
    p.add("gripper_port = 1000\n").unwrap();
    let e = p.add("def broken(:\nend\n").unwrap_err();
    assert_eq!((e.line(), e.column()), (1, 12), "{e}");
    let prog = Program::parse_with_preamble(&p, "textmsg(gripper_port)\n").unwrap();
    assert_eq!(run(prog), (State::Finished, vec!["1000".into()]));
    assert!(Preamble::default().is_empty());
    assert!(!p.is_empty());
}

#[test]
fn settings_drive_the_inputs_a_program_reads() {
    let p = Program::parse(
        "textmsg(get_standard_digital_in(3), get_tcp_force()[2])\ntextmsg(read_input_integer_register(5))\n",
    )
    .unwrap();
    let mut m = Machine::new(p, Config::default());
    for s in [
        "digital_in[3]=True",
        "tcp_force[2]=-12.5",
        "input_int_regs[5]=77",
    ] {
        m.world_mut().set(s).unwrap();
    }
    m.run_until(Duration::ZERO);
    let mut text = Vec::new();
    while let Some(e) = m.poll_event() {
        if let Event::Message(msg) = e {
            text.push(msg.text);
        }
    }
    assert_eq!(text, ["True-12.5", "77"]);
}
