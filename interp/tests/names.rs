//! Names at compile time: a variable that nothing in its scope chain can have given a
//! value is refused before the first statement runs, as the controller refuses it
//! (`compile_error_name_not_found`); everything a real program may do still runs.
use std::time::Duration;

use urscript_interp::{Config, ControllerCode, Event, Machine, Program, RuntimeErrorKind, State};

/// The machine before any step: its state, and the messages after running 1 s.
fn run(src: &str) -> (State, State, Vec<String>) {
    let p = Program::parse(src).unwrap_or_else(|e| panic!("{src}: {e}"));
    let mut m = Machine::new(p, Config::default());
    let before = m.state().clone();
    m.run_until(Duration::from_secs(1));
    let mut msgs = Vec::new();
    while let Some(e) = m.poll_event() {
        if let Event::Message(msg) = e {
            msgs.push(msg.text);
        }
    }
    (before, m.state().clone(), msgs)
}

fn refused(src: &str, name: &str, line: u32, col: u32) {
    let (before, _, msgs) = run(src);
    let State::Error(e) = before else {
        panic!("{src}: not refused ({before:?})")
    };
    assert_eq!(e.kind(), RuntimeErrorKind::UnknownVariable, "{src}: {e}");
    assert!(
        e.message()
            .starts_with(&format!("compile_error_name_not_found:{name}:")),
        "{src}: {e}"
    );
    assert_eq!((e.line(), e.column()), (line, col), "{src}: {e}");
    assert_eq!(
        e.code(),
        Some(&ControllerCode::NameNotFound { name: name.into() }),
        "{src}: {e}"
    );
    // Nothing ran.
    assert!(msgs.is_empty(), "{src}: {msgs:?}");
}

fn accepted(src: &str, want: &[&str]) {
    let (before, after, msgs) = run(src);
    assert_eq!(before, State::Running, "{src}");
    assert_eq!(after, State::Finished, "{src}: {msgs:?}");
    assert_eq!(msgs, want, "{src}");
}

#[test]
fn a_name_never_assigned_is_refused_before_anything_runs() {
    refused("textmsg(\"start\")\nx = 1 + yy\n", "yy", 2, 9);
    // In a function: neither a parameter, nor assigned in it, nor a global.
    refused(
        "def f(a):\n  return a + b\nend\ntextmsg(\"start\")\ntextmsg(f(1))\n",
        "b",
        2,
        14,
    );
    // A function's local is not seen by another function, nor by the program.
    refused(
        "def f():\n  b = 3\nend\ndef g():\n  return b\nend\nf()\ntextmsg(g())\n",
        "b",
        5,
        10,
    );
    // A thread does not see a function's locals.
    refused(
        "def f():\n  speed = 3\n  return speed\nend\nthread t():\n  textmsg(speed)\nend\nf()\nrun t()\n",
        "speed",
        6,
        11,
    );
    // Inside an index, a condition, a call's named argument, a list; `x[0] = ...` reads x.
    refused("l = [1]\ntextmsg(l[k])\n", "k", 2, 11);
    refused("while cond:\n  sync()\nend\n", "cond", 1, 7);
    refused("movej([0, 0, 0, 0, 0, 0], a=acc)\n", "acc", 1, 29);
    refused("l = [1, 2, n]\n", "n", 1, 12);
    refused("q[0] = 1\n", "q", 1, 1);
    // The first in the text wins, a variable before a function.
    refused("x = aa\nrq_activate()\ny = bb\n", "aa", 1, 5);
    let (before, _, _) = run("rq_activate()\nx = aa\n");
    let State::Error(e) = before else { panic!() };
    assert!(e
        .message()
        .starts_with("compile_error_name_not_found:rq_activate:"));
    assert_eq!(
        e.code().map(ToString::to_string).as_deref(),
        Some("compile_error_name_not_found:rq_activate:")
    );
}

#[test]
fn what_a_real_program_does_still_runs() {
    // A global assigned after the function that reads it is defined (and after the
    // function is first defined in the text): globals are program-wide.
    accepted(
        "def show():\n  textmsg(speed)\nend\nspeed = 0.25\nshow()\n",
        &["0.25"],
    );
    // A thread body reading globals the program assigns, one of them after `run`.
    accepted(
        "thread t():\n  textmsg(a, b)\nend\na = 1\nb = 0\nh = run t()\nb = 2\njoin h\n",
        &["12"],
    );
    // A variable assigned in a branch only, read after the branch.
    accepted(
        "if get_standard_digital_in(0):\n  x = 1\nelse:\n  x = 2\nend\ntextmsg(x)\n",
        &["2"],
    );
    // Assigned later in a loop than it is read (read only on later passes).
    accepted(
        "i = 0\nwhile i < 3:\n  if i > 0:\n    textmsg(last)\n  end\n  last = i\n  i = i + 1\nend\n",
        &["0", "1"],
    );
    // `global` in a function makes a global others read; `local` declares a local.
    accepted(
        "def make():\n  global c = 7\nend\ndef use():\n  return c\nend\nmake()\ntextmsg(use())\n",
        &["7"],
    );
    accepted(
        "def f():\n  local v = 3\n  return v\nend\ntextmsg(f())\n",
        &["3"],
    );
    // Parameters, defaults, recursion, a function's own locals in any order.
    accepted(
        "def f(n, acc=1):\n  if n <= 1:\n    return acc\n  end\n  return f(n - 1, acc * n)\nend\ntextmsg(f(5))\n",
        &["120"],
    );
    // The driver form: one def, its variables read by its inner functions and threads.
    accepted(
        "def prog():\n  MULT = 1000\n  def scale(x):\n    return x / MULT\n  end\n  thread t():\n    textmsg(scale(500))\n  end\n  h = run t()\n  join h\nend\n",
        &["0.5"],
    );
    // A variable named `p`, indexed as `p[i]`.
    accepted("p = [4, 5]\ntextmsg(p[1])\n", &["5"]);
    // A thread handle in a variable, joined and killed.
    accepted(
        "thread t():\n  sleep(10)\nend\nh = run t()\nkill h\ntextmsg(\"ok\")\n",
        &["ok"],
    );
}

#[test]
fn the_real_programs_still_start() {
    for f in [
        "external_control_like.script",
        "gripper_daemon.script",
        "keyence_style.script",
        "vision_pick.script",
    ] {
        let src =
            std::fs::read_to_string(format!("{}/tests/programs/{f}", env!("CARGO_MANIFEST_DIR")))
                .unwrap();
        let m = Machine::new(Program::parse(&src).unwrap(), Config::default());
        assert_eq!(m.state(), &State::Running, "{f}");
    }
}
