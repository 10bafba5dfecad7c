//! Script intake on ports 30001/30002/30003: programs, secondary programs, bare lines,
//! commands, nesting, strings and comments, bounds, and any split of the input.

use proptest::prelude::*;
use urscript_controller::script_intake::{
    Command, Intake, IntakeError, ScriptIntake, MAX_LINE, MAX_PROGRAM,
};

type Out = Vec<Result<Intake, IntakeError>>;

fn all(bytes: &[u8]) -> Out {
    ScriptIntake::new().push(bytes)
}

fn program(name: &str, source: &str) -> Result<Intake, IntakeError> {
    Ok(Intake::Program {
        name: name.into(),
        source: source.into(),
    })
}

fn line(s: &str) -> Result<Intake, IntakeError> {
    Ok(Intake::Line(s.into()))
}

#[test]
fn a_def_program_comes_whole() {
    let src = "def move_it():\n  movej([0,0,0,0,0,0])\n  textmsg(\"done\")\nend\n";
    assert_eq!(all(src.as_bytes()), vec![program("move_it", src)]);
}

#[test]
fn nothing_before_the_closing_end() {
    let mut intake = ScriptIntake::new();
    assert!(intake.push(b"def a():\n  sleep(1)\n").is_empty());
    assert!(intake.is_pending());
    assert!(intake.push(b"end").is_empty(), "no newline yet");
    assert_eq!(
        intake.push(b"\n"),
        vec![program("a", "def a():\n  sleep(1)\nend\n")]
    );
    assert!(!intake.is_pending());
}

#[test]
fn nested_blocks_are_counted() {
    let src = "def outer():\n\
               \x20 def inner(x):\n\
               \x20   if x > 1:\n\
               \x20     return 1\n\
               \x20   elif x < 0:\n\
               \x20     return 2\n\
               \x20   else:\n\
               \x20     return 3\n\
               \x20   end\n\
               \x20 end\n\
               \x20 thread t():\n\
               \x20   while True:\n\
               \x20     sync()\n\
               \x20   end\n\
               \x20 end\n\
               \x20 for i in range(3):\n\
               \x20   inner(i)\n\
               \x20 end\n\
               end\n";
    assert_eq!(all(src.as_bytes()), vec![program("outer", src)]);
}

#[test]
fn end_in_strings_and_comments_closes_nothing() {
    let src = "def p():\n\
               \x20 textmsg(\"end\")\n\
               \x20 # end\n\
               \x20 s = \"if x:\" # while\n\
               \x20 t = \"a # end\"\n\
               \x20 u = 'end'\n\
               \x20 v = \"quote ' end\" + 'a \" end'\n\
               \x20 w = s.end\n\
               \x20 endless = 1\n\
               \x20 if_x = 2\n\
               end\n";
    assert_eq!(all(src.as_bytes()), vec![program("p", src)]);
}

/// Where a program ends is the interpreter's lexer's call: a block opened and closed on
/// one line (`if x: y = 1 end`, as the parser accepts it) leaves the count as it was, a
/// `$` step marker is no code.
#[test]
fn blocks_on_one_line_and_markers_as_the_interpreter_reads_them() {
    let src = "def p():\n  if x: y = 1 end\n  while False: sync() end\nend\n";
    assert_eq!(
        all(format!("{src}textmsg(1)\n").as_bytes()),
        vec![program("p", src), line("textmsg(1)")]
    );
    // At the top level a one-line block is one unit, and what follows is read afresh.
    assert_eq!(
        all(b"if True: textmsg(1) end\n$ 1 \"Robot Program\"\ntextmsg(2)\n"),
        vec![line("if True: textmsg(1) end"), line("textmsg(2)")]
    );
}

#[test]
fn sec_programs_and_bare_lines() {
    let input = b"set_digital_out(1, True)\n\
                  \n\
                  # a comment\n\
                  sec watch():\n  if read_input_boolean_register(0):\n    textmsg(\"hi\")\n  end\nend\n\
                  textmsg(\"x\")\r\n";
    assert_eq!(
        all(input),
        vec![
            line("set_digital_out(1, True)"),
            Ok(Intake::Secondary {
                name: "watch".into(),
                source: "sec watch():\n  if read_input_boolean_register(0):\n    textmsg(\"hi\")\n  end\nend\n".into()
            }),
            line("textmsg(\"x\")"),
        ]
    );
}

#[test]
fn a_bare_block_is_one_script() {
    assert_eq!(
        all(b"if True:\n  textmsg(1)\nend\nend\n"),
        vec![line("if True:\n  textmsg(1)\nend"), line("end")]
    );
}

#[test]
fn commands_are_whole_lines() {
    let input = b"power on\nbrake release\nset robotmode run\n  power off  \nset unlock protective stop\nstop program\nset speed0.25\nset speed 1\nset speed fast\npower on now\n";
    assert_eq!(
        all(input),
        vec![
            Ok(Intake::Command(Command::PowerOn)),
            Ok(Intake::Command(Command::BrakeRelease)),
            Ok(Intake::Command(Command::BrakeRelease)),
            Ok(Intake::Command(Command::PowerOff)),
            Ok(Intake::Command(Command::UnlockProtectiveStop)),
            Ok(Intake::Command(Command::StopProgram)),
            Ok(Intake::Command(Command::SetSpeed(0.25))),
            Ok(Intake::Command(Command::SetSpeed(1.0))),
            line("set speed fast"),
            line("power on now"),
        ]
    );
    // Inside a program, `power on` is just a line of it.
    let src = "def p():\n  power on\nend\n";
    assert_eq!(all(src.as_bytes()), vec![program("p", src)]);
}

#[test]
fn an_over_long_line_is_dropped_and_the_next_line_is_read() {
    let mut input = vec![b'x'; MAX_LINE + 1];
    input.extend_from_slice(b"\ntextmsg(1)\n");
    assert_eq!(
        all(&input),
        vec![Err(IntakeError::LineTooLong), line("textmsg(1)")]
    );
    // A line of exactly MAX_LINE bytes is fine.
    let mut input = vec![b'a'; MAX_LINE];
    input.push(b'\n');
    let got = all(&input);
    assert_eq!(got.len(), 1);
    assert!(matches!(&got[0], Ok(Intake::Line(l)) if l.len() == MAX_LINE));
}

#[test]
fn an_over_long_line_in_a_program_drops_the_program_to_its_end() {
    let mut input = b"def big():\n  if True:\n".to_vec();
    input.extend(vec![b'y'; MAX_LINE + 10]);
    input.extend_from_slice(b"\n  end\n  textmsg(2)\nend\ntextmsg(3)\n");
    assert_eq!(
        all(&input),
        vec![Err(IntakeError::LineTooLong), line("textmsg(3)")]
    );
}

#[test]
fn an_over_long_program_is_dropped_to_its_end() {
    let mut input = b"def huge():\n".to_vec();
    let body = format!("  x = \"{}\"\n", "z".repeat(60_000));
    let n = MAX_PROGRAM / body.len() + 2;
    for _ in 0..n {
        input.extend_from_slice(body.as_bytes());
    }
    input.extend_from_slice(b"  while True:\n    sync()\n  end\nend\npower off\n");
    let mut intake = ScriptIntake::new();
    let mut got = Vec::new();
    for chunk in input.chunks(100_000) {
        got.extend(intake.push(chunk));
    }
    assert_eq!(
        got,
        vec![
            Err(IntakeError::ProgramTooLong {
                name: "huge".into()
            }),
            Ok(Intake::Command(Command::PowerOff)),
        ]
    );
    assert!(!intake.is_pending());
}

#[test]
fn invalid_utf8_is_replaced_not_refused() {
    assert_eq!(
        all(b"textmsg(\"\xff\")\n"),
        vec![line("textmsg(\"\u{fffd}\")")]
    );
}

const SAMPLE: &str = "power on\n\
def prog():\n  # end\n  if True:\n    textmsg(\"end\")\n  end\nend\n\
sec s():\n  while False:\n  end\nend\r\n\
textmsg(\"bare\")\n\
set speed 0.5\n\
if x:\nend\n";

proptest! {
    #[test]
    fn any_split_gives_the_same_result(cuts in proptest::collection::vec(0usize..SAMPLE.len(), 0..8)) {
        let whole = all(SAMPLE.as_bytes());
        prop_assert_eq!(whole.len(), 6);
        let mut cuts = cuts;
        cuts.sort();
        let mut intake = ScriptIntake::new();
        let mut got = Vec::new();
        let mut at = 0;
        for c in cuts {
            got.extend(intake.push(&SAMPLE.as_bytes()[at..c.max(at)]));
            at = c.max(at);
        }
        got.extend(intake.push(&SAMPLE.as_bytes()[at..]));
        prop_assert_eq!(got, whole);
    }

    #[test]
    fn arbitrary_bytes_never_panic_and_split_the_same(bytes in proptest::collection::vec(any::<u8>(), 0..400), cut in 0usize..400) {
        let whole = all(&bytes);
        let cut = cut.min(bytes.len());
        let mut intake = ScriptIntake::new();
        let mut got = intake.push(&bytes[..cut]);
        got.extend(intake.push(&bytes[cut..]));
        prop_assert_eq!(got, whole);
    }
}

#[test]
fn split_at_every_byte_boundary() {
    let whole = all(SAMPLE.as_bytes());
    for i in 0..=SAMPLE.len() {
        let mut intake = ScriptIntake::new();
        let mut got = intake.push(&SAMPLE.as_bytes()[..i]);
        got.extend(intake.push(&SAMPLE.as_bytes()[i..]));
        assert_eq!(got, whole, "split at {i}");
    }
    // And one byte at a time.
    let mut intake = ScriptIntake::new();
    let got: Out = SAMPLE.bytes().flat_map(|b| intake.push(&[b])).collect();
    assert_eq!(got, whole);
}
