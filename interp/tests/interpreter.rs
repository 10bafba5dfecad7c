//! Interpreter mode (the interpreter socket's lines) in virtual time: the manual's
//! "Interpreter Mode" chapter, statement by statement.

use std::time::Duration;

use urscript_interp::interpreter::{Command, Discard, Reply, MAX_LINE, MAX_UNEXECUTED};
use urscript_interp::{Config, Event, Machine, Program, State};

const STEP: Duration = Duration::from_millis(2);

struct Run {
    m: Machine,
    now: Duration,
    messages: Vec<String>,
}

impl Run {
    fn new(src: &str) -> Run {
        let p = Program::parse(src).unwrap_or_else(|e| panic!("parse: {e}"));
        let mut r = Run {
            m: Machine::new(p, Config::default()),
            now: Duration::ZERO,
            messages: Vec::new(),
        };
        r.m.run_until(Duration::ZERO);
        r.drain();
        r
    }

    fn drain(&mut self) {
        while let Some(e) = self.m.poll_event() {
            if let Event::Message(msg) = e {
                self.messages.push(msg.text);
            }
        }
    }

    /// Runs `n` more steps.
    fn steps(&mut self, n: u32) {
        self.now += STEP * n;
        self.m.run_until(self.now);
        self.drain();
    }

    fn send(&mut self, line: &str) -> Reply {
        self.m
            .interpreter_line(line.as_bytes())
            .unwrap_or_else(|| panic!("`{line}` was held"))
    }

    fn ack(&mut self, line: &str) -> u32 {
        match self.send(line) {
            Reply::Ack { id, statement } => {
                assert_eq!(statement, line);
                id
            }
            other => panic!("`{line}`: {other}"),
        }
    }

    fn state(&mut self, command: &str) -> u64 {
        match self.send(command) {
            Reply::State { value, command: c } => {
                assert_eq!(c.word(), command);
                value
            }
            other => panic!("`{command}`: {other}"),
        }
    }
}

#[test]
fn statements_run_in_order_and_ids_count_up() {
    let mut r = Run::new("interpreter_mode()\n");
    assert!(r.m.interpreter_status().active);
    assert_eq!(r.state("statelastexecuted"), 0);
    assert_eq!(r.state("statelastinterpreted"), 0);
    let ids: Vec<u32> = (0..3)
        .map(|k| r.ack(&format!("textmsg(\"line \", {k})")))
        .collect();
    assert_eq!(ids, [1, 2, 3]);
    assert_eq!(r.state("statelastinterpreted"), 3);
    assert_eq!(r.state("stateunexecuted"), 3);
    assert_eq!(r.state("statelastexecuted"), 0);
    // One statement starts per step.
    r.steps(1);
    assert_eq!(r.state("statelastexecuted"), 1);
    r.steps(5);
    assert_eq!(r.state("statelastexecuted"), 3);
    assert_eq!(r.state("stateunexecuted"), 0);
    assert_eq!(r.messages, ["line 0", "line 1", "line 2"]);
    assert_eq!(r.m.state(), &State::Running);
}

#[test]
fn definitions_and_variables_persist_between_lines() {
    let mut r = Run::new("interpreter_mode()\n");
    r.ack("def twice(x): return 2 * x end");
    r.ack("y = twice(21)");
    r.ack("textmsg(\"y = \", y)");
    r.ack("thread t(): textmsg(\"in thread \", y + 1) end");
    r.ack("h = run t()");
    r.steps(10);
    assert_eq!(r.messages, ["y = 42", "in thread 43"]);
    assert_eq!(r.m.global("y"), Some(&urscript_interp::Value::Int(42)));
}

#[test]
fn the_program_scope_is_seen_and_several_statements_share_a_line() {
    let mut r = Run::new("base = 10\ninterpreter_mode()\n");
    r.ack("a = base + 1 textmsg(\"a = \", a)");
    r.steps(3);
    assert_eq!(r.messages, ["a = 11"]);
}

#[test]
fn a_motion_moves_the_arm_and_holds_the_next_statements() {
    let mut r = Run::new("interpreter_mode()\n");
    let start = r.m.joint_positions();
    let target = [0.5, -1.2, 1.0, -1.4, -1.5, 0.3];
    let mv = r.ack(&format!("movej({target:?}, a=1.4, v=1.05)"));
    let after = r.ack("textmsg(\"arrived\")");
    r.steps(5);
    // The move runs: the arm left its start, the next statement waits.
    assert_eq!(r.state("statelastexecuted"), u64::from(mv));
    assert_eq!(r.state("stateunexecuted"), 1);
    assert_ne!(r.m.joint_positions(), start);
    assert!(r.messages.is_empty());
    r.steps(5000);
    assert_eq!(r.state("statelastexecuted"), u64::from(after));
    assert_eq!(r.messages, ["arrived"]);
    for (q, t) in r.m.joint_positions().iter().zip(target) {
        assert!((q - t).abs() < 1e-6, "{q} vs {t}");
    }
}

#[test]
fn abort_stops_the_move_and_the_next_statement_runs() {
    let mut r = Run::new("interpreter_mode()\n");
    r.ack("movej([1.5, -1.2, 1.0, -1.4, -1.5, 0.3], a=1.4, v=1.05)");
    r.ack("textmsg(\"next\")");
    r.steps(20);
    let mid = r.m.joint_positions();
    assert_eq!(r.state("abort"), 1);
    r.steps(3);
    assert_eq!(r.messages, ["next"]);
    assert_eq!(r.m.joint_positions(), mid, "the arm stopped where it was");
    // Nothing moves now: a second abort has nothing to stop.
    assert_eq!(r.state("abort"), 0);
}

#[test]
fn skipbuffer_drops_the_statements_not_started() {
    let mut r = Run::new("interpreter_mode()\n");
    r.ack("sleep(1)");
    for k in 0..3 {
        r.ack(&format!("textmsg({k})"));
    }
    r.steps(2);
    assert_eq!(r.state("skipbuffer"), 3);
    assert_eq!(r.state("stateunexecuted"), 0);
    // New statements are accepted right away and run after the sleep.
    let id = r.ack("textmsg(\"after skip\")");
    assert_eq!(id, 5);
    r.steps(600);
    assert_eq!(r.messages, ["after skip"]);
}

#[test]
fn clear_interpreter_removes_what_was_interpreted_and_holds_later_lines() {
    let mut r = Run::new("kept = 1\ninterpreter_mode()\n");
    r.ack("def f(): textmsg(\"f\") end");
    r.ack("made = 2");
    let clear = r.ack("clear_interpreter()");
    // Lines after the clear wait for it.
    assert_eq!(r.m.interpreter_line(b"f()"), None);
    assert_eq!(r.m.interpreter_line(b"textmsg(kept)"), None);
    assert_eq!(r.m.poll_interpreter_reply(), None);
    r.steps(10);
    assert_eq!(r.state("statelastcleared"), u64::from(clear));
    // `f` is gone; `kept`, the program's, stays.
    match r.m.poll_interpreter_reply() {
        Some(Reply::Discard {
            reason: Discard::Compile { message, .. },
            statement,
        }) => {
            assert_eq!(statement, "f()");
            assert!(
                message.starts_with("compile_error_name_not_found:f:"),
                "{message}"
            );
        }
        other => panic!("{other:?}"),
    }
    match r.m.poll_interpreter_reply() {
        Some(Reply::Ack { id, statement }) => {
            assert_eq!(statement, "textmsg(kept)");
            assert_eq!(id, clear + 1);
        }
        other => panic!("{other:?}"),
    }
    assert_eq!(r.m.global("made"), None);
    r.steps(3);
    assert_eq!(r.messages, ["1"]);
    // A name can be defined again after the clear.
    r.ack("def f(): textmsg(\"f again\") end");
    r.ack("f()");
    r.steps(4);
    assert_eq!(r.messages, ["1", "f again"]);
}

#[test]
fn end_interpreter_returns_to_the_program() {
    let mut r = Run::new("interpreter_mode()\ntextmsg(\"back in the program\")\ninterpreter_mode(clearOnEnd=False)\n");
    r.ack("def g(): textmsg(\"g\") end");
    r.ack("end_interpreter()");
    r.steps(5);
    assert_eq!(r.messages, ["back in the program"]);
    // The second mode: `g` was cleared by the first mode's end (clearOnEnd=True).
    assert!(r.m.interpreter_status().active);
    assert!(matches!(
        r.send("g()"),
        Reply::Discard {
            reason: Discard::Compile { .. },
            ..
        }
    ));
    r.ack("def h(): textmsg(\"h\") end");
    r.ack("h()");
    r.ack("end_interpreter()");
    r.steps(10);
    assert_eq!(r.messages, ["back in the program", "h"]);
    assert_eq!(r.m.state(), &State::Finished);
    assert!(!r.m.interpreter_status().active);
}

#[test]
fn statements_sent_before_the_mode_are_dropped_or_run_as_asked() {
    // Default: the queue is cleared on entry.
    let mut r = Run::new("sleep(0.01)\ninterpreter_mode()\n");
    let id = r.ack("textmsg(\"early\")");
    r.steps(10);
    assert!(r.messages.is_empty());
    assert_eq!(r.state("statelastcleared"), u64::from(id));
    // clearQueueOnEnter=False: they run.
    let mut r = Run::new("sleep(0.01)\ninterpreter_mode(clearQueueOnEnter=False)\n");
    r.ack("textmsg(\"early\")");
    r.steps(10);
    assert_eq!(r.messages, ["early"]);
}

#[test]
fn bad_lines_are_discarded_with_the_reason() {
    let mut r = Run::new("interpreter_mode()\n");
    let long = format!("textmsg(\"{}\")", "x".repeat(MAX_LINE));
    assert!(matches!(
        r.send(&long),
        Reply::Discard { reason: Discard::LineTooLong { len }, .. } if len == long.len()
    ));
    let reply = r.send("textmsg(");
    assert!(
        reply
            .to_string()
            .starts_with("discard: compile error at column"),
        "{reply}"
    );
    assert!(matches!(
        r.send("interpreter_mode()"),
        Reply::Discard {
            reason: Discard::Nested,
            ..
        }
    ));
    let reply = r.send("textmsg(nowhere)");
    assert!(
        reply
            .to_string()
            .contains("compile_error_name_not_found:nowhere:"),
        "{reply}"
    );
    let reply = r.send("rq_gripper_open()");
    assert!(
        reply
            .to_string()
            .contains("compile_error_name_not_found:rq_gripper_open:"),
        "{reply}"
    );
    assert!(matches!(
        r.send("return 1"),
        Reply::Discard {
            reason: Discard::Compile { .. },
            ..
        }
    ));
    assert!(matches!(
        r.m.interpreter_line(b"textmsg(\"caf\xe9\")"),
        Some(Reply::Discard {
            reason: Discard::NotUtf8,
            ..
        })
    ));
    // Nothing was interpreted: the next id is 1, and the program still runs.
    assert_eq!(r.ack("textmsg(\"ok\")"), 1);
    r.steps(2);
    assert_eq!(r.messages, ["ok"]);
}

#[test]
fn a_full_queue_discards() {
    let mut r = Run::new("interpreter_mode()\n");
    r.ack("sleep(10)");
    r.steps(1);
    for k in 0..MAX_UNEXECUTED {
        r.ack(&format!("textmsg({k})"));
    }
    assert_eq!(r.state("stateunexecuted"), MAX_UNEXECUTED as u64);
    let reply = r.send("textmsg(\"one too many\")");
    assert!(
        matches!(
            reply,
            Reply::Discard {
                reason: Discard::QueueFull,
                ..
            }
        ),
        "{reply}"
    );
    // A command still answers.
    assert_eq!(r.state("statelastexecuted"), 1);
}

#[test]
fn no_program_no_statement() {
    let mut r = Run::new("textmsg(\"done\")\n");
    assert_eq!(r.m.state(), &State::Finished);
    let reply = r.send("textmsg(1)");
    assert_eq!(
        reply.to_string(),
        "discard: program not running: textmsg(1)"
    );
    assert_eq!(r.state("statelastinterpreted"), 0);
}

#[test]
fn only_the_main_thread_enters_and_clear_needs_the_mode() {
    let mut r = Run::new("thread t():\n  interpreter_mode()\nend\nrun t()\nsleep(1)\n");
    r.steps(2);
    let State::Error(e) = r.m.state() else {
        panic!("{:?}", r.m.state())
    };
    assert!(e.message().contains("main thread"), "{}", e.message());
    let r = Run::new("clear_interpreter()\n");
    assert!(matches!(r.m.state(), State::Error(_)));
}

#[test]
fn commands_parse_alone_on_their_line() {
    assert_eq!(Command::parse(" skipbuffer "), Some(Command::SkipBuffer));
    assert_eq!(Command::parse("abort textmsg(1)"), None);
}

#[test]
fn a_clear_stops_the_threads_the_lines_started() {
    let mut r = Run::new("interpreter_mode()\n");
    r.ack("thread ticker(): while True: textmsg(\"tick\") sleep(0.01) end end");
    r.ack("run ticker()");
    r.steps(30);
    let ticks = r.messages.len();
    assert!(ticks >= 2, "{:?}", r.messages);
    r.ack("clear_interpreter()");
    r.steps(3);
    let after_clear = r.messages.len();
    r.steps(100);
    assert_eq!(r.messages.len(), after_clear, "the thread still runs");
    assert_eq!(r.m.state(), &State::Running);
}

#[test]
fn end_interpreter_from_another_thread_ends_the_mode() {
    let mut r = Run::new(
        "thread stopper():\n  sleep(0.1)\n  end_interpreter()\nend\nrun stopper()\ninterpreter_mode()\ntextmsg(\"out\")\n",
    );
    r.steps(10);
    assert!(r.m.interpreter_status().active);
    r.steps(100);
    assert_eq!(r.messages, ["out"]);
    assert_eq!(r.m.state(), &State::Finished);
}

/// Whatever a client sends, the machine neither panics nor leaves interpreter mode
/// broken: it still runs a statement after.
#[test]
fn hostile_lines_do_not_break_the_machine() {
    let mut r = Run::new("interpreter_mode()\n");
    let deep = format!("x = {}1{}", "(".repeat(500), ")".repeat(500));
    let lines = [
        "def",
        "def f(",
        "def g(): textmsg(1)",
        "end",
        "thread",
        "run nothing()",
        "while False: end",
        "global",
        "x[3] = 1",
        "\u{0}\u{7f}",
        "if True: textmsg(1) else: halt",
        "kill 3",
        "join 7",
        "enter_critical",
        "break",
        "\"unterminated",
        "1 +",
        "textmsg(1) textmsg(2",
        &deep,
        "def f(): return 1 end def f(): return 2 end",
        "     ",
        "skipbuffer textmsg(1)",
        "abort",
        "\r",
    ];
    for line in lines {
        let reply = r.m.interpreter_line(line.as_bytes());
        r.steps(1);
        assert_eq!(r.m.state(), &State::Running, "after {line:?}: {reply:?}");
    }
    let id = r.ack("textmsg(\"still here\")");
    assert_eq!(r.state("statelastinterpreted"), u64::from(id));
    r.steps(2000);
    assert!(
        r.messages.iter().any(|m| m == "still here"),
        "{:?}",
        r.messages
    );
}

#[test]
fn clear_on_end_false_keeps_definitions_for_the_next_mode() {
    let mut r = Run::new("interpreter_mode(clearOnEnd=False)\ninterpreter_mode()\n");
    r.ack("def kept(): textmsg(\"kept\") end");
    r.ack("end_interpreter()");
    r.steps(5);
    assert!(r.m.interpreter_status().active, "the second mode");
    r.ack("kept()");
    r.steps(3);
    assert_eq!(r.messages, ["kept"]);
    // Nothing was cleared at the first end.
    assert_eq!(r.state("statelastcleared"), 0);
}

#[test]
fn a_runtime_error_in_a_statement_stops_the_program() {
    let mut r = Run::new("interpreter_mode()\n");
    r.ack("l = [1, 2]");
    r.ack("textmsg(l[5])");
    r.steps(5);
    assert!(matches!(r.m.state(), State::Error(_)), "{:?}", r.m.state());
}

#[test]
fn statements_run_in_the_scope_interpreter_mode_was_called_from() {
    let mut r = Run::new(
        "def helper(k):\n  speed = 5\n  interpreter_mode()\n  textmsg(\"speed after: \", speed)\nend\nhelper(3)\n",
    );
    assert!(r.m.interpreter_status().active);
    r.ack("textmsg(\"k \", k)");
    r.ack("textmsg(\"speed \", speed)");
    r.ack("speed = speed + k");
    r.ack("fresh = 1");
    r.ack("end_interpreter()");
    r.steps(10);
    assert_eq!(r.messages, ["k 3", "speed 5", "speed after: 8"]);
    assert_eq!(r.m.state(), &State::Finished);
    // `speed` stayed the function's local; the new name was a global, cleared at the end.
    assert_eq!(r.m.global("speed"), None);
    assert_eq!(r.m.global("fresh"), None);
}

mod arbitrary_lines {
    use super::*;
    use proptest::prelude::*;

    /// One interpreter line: statements on one line, commands, junk.
    fn line() -> impl Strategy<Value = String> {
        prop_oneof![
            Just("def f(a, b=1): return a + b end".to_string()),
            Just("thread t(): sleep(0.01) textmsg(\"t\") end".to_string()),
            Just("h = run t()".to_string()),
            Just("kill h".to_string()),
            Just("x = f(1)".to_string()),
            Just("x = x + 1".to_string()),
            Just("textmsg(x)".to_string()),
            Just("movej([0.2, -1.4, 1.2, -1.3, -1.6, 0.1], a=3, v=3)".to_string()),
            Just("movel(p[0.3, -0.2, 0.4, 0, 3.14, 0], a=1, v=1)".to_string()),
            Just("sleep(0.004)".to_string()),
            Just("clear_interpreter()".to_string()),
            Just("end_interpreter()".to_string()),
            Just("interpreter_mode()".to_string()),
            Just("skipbuffer".to_string()),
            Just("abort".to_string()),
            Just("statelastexecuted".to_string()),
            Just("stateunexecuted".to_string()),
            Just("if x > 2: textmsg(\"big\") else: x = 0 end".to_string()),
            "[ -~]{0,40}",
        ]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]
        /// Whatever lines arrive, in any order, with steps between: no panic, the numbers
        /// stay consistent, the queue stays bounded.
        #[test]
        fn any_lines_keep_the_machine_consistent(
            lines in proptest::collection::vec((line(), 0u32..4), 0..40)
        ) {
            let mut r = Run::new("x = 0\ninterpreter_mode(clearOnEnd=False)\ninterpreter_mode()\n");
            for (text, steps) in lines {
                let reply = r.m.interpreter_line(text.as_bytes());
                if let Some(Reply::Ack { id, .. }) = &reply {
                    prop_assert_eq!(u64::from(*id), r.state("statelastinterpreted"));
                }
                r.steps(steps);
                while r.m.poll_interpreter_reply().is_some() {}
                let s = r.m.interpreter_status();
                prop_assert!(s.last_executed <= s.last_interpreted);
                prop_assert!(s.last_cleared <= s.last_interpreted);
                prop_assert!(s.unexecuted <= MAX_UNEXECUTED);
            }
            r.steps(500);
        }
    }
}
