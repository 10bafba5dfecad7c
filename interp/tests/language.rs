//! The language, construct by construct.
mod common;
use common::{messages, runtime_error};
use std::time::Duration;
use urscript_interp::{Config, Event, Machine, Program, State};

fn msgs(src: &str) -> Vec<String> {
    messages(src)
}

fn one(expr: &str) -> String {
    let m = msgs(&format!("textmsg({expr})\n"));
    m[0].clone()
}

fn parse_err(src: &str) -> String {
    Program::parse(src).unwrap_err().to_string()
}

#[test]
fn literals() {
    assert_eq!(one("42"), "42");
    assert_eq!(one("-7"), "-7");
    assert_eq!(one("1.5"), "1.5");
    assert_eq!(one("1e-3"), "0.001");
    assert_eq!(one("2.5E+2"), "250");
    assert_eq!(one(".5"), "0.5");
    assert_eq!(one("True"), "True");
    assert_eq!(one("False"), "False");
    assert_eq!(one("\"a\\n\""), "a\\n"); // no escapes in string literals
    assert_eq!(one("[1, 2.5, True]"), "[1, 2.5, True]");
    assert_eq!(one("[]"), "[]");
    assert_eq!(
        one("p[0.1, -0.2, 0.3, 0, 3.14, 0]"),
        "p[0.1, -0.2, 0.3, 0, 3.14, 0]"
    );
    assert_eq!(one("[[1, 2], [3, 4]]"), "[[1, 2], [3, 4]]");
}

#[test]
fn the_smallest_int_is_written_with_a_minus() {
    // `-2147483648` is `i32::MIN` (OnRobot's URCap preamble clamps with it), though
    // `2147483648` alone does not fit 32 bits.
    assert_eq!(one("-2147483648"), "-2147483648");
    assert_eq!(one("-2147483648 + 1"), "-2147483647");
    assert_eq!(one("- 2147483648 < 0"), "True");
    assert_eq!(
        parse_err("x = 2147483648\n"),
        "line 1, column 5: integer literal `2147483648` does not fit 32 bits"
    );
    assert_eq!(
        parse_err("x = -(2147483648)\n"),
        "line 1, column 7: integer literal `2147483648` does not fit 32 bits"
    );
    assert_eq!(
        parse_err("x = -2147483649\n"),
        "line 1, column 6: integer literal `2147483649` does not fit 32 bits"
    );
}

#[test]
fn a_number_may_be_the_last_bytes_of_the_program() {
    // No line end after the last literal: the whole number is read, not `2.`.
    for (src, want) in [
        ("x = 2.25\ntextmsg(x)\nx = 2.25", "2.25"),
        ("x = 1.5e-3\ntextmsg(x)\nx = 1.5e-3", "0.0015"),
        ("x = .75\ntextmsg(x)\nx = .75", "0.75"),
        ("x = 42\ntextmsg(x)\nx = 42", "42"),
    ] {
        assert_eq!(msgs(src), [want], "{src:?}");
    }
    assert_eq!(
        urscript_interp::parse_constant("50.5").unwrap(),
        urscript_interp::Value::Float(50.5)
    );
}

#[test]
fn comments_and_step_markers() {
    let m = msgs(
        "# a comment\n$ 1 \"Robot Program\"\nx = 1 # trailing\ntextmsg(\"#not a comment\", x)\n",
    );
    assert_eq!(m, ["#not a comment1"]);
}

#[test]
fn arithmetic_int_and_float_rules() {
    assert_eq!(one("7 / 2"), "3.5");
    assert_eq!(one("-7 / 2"), "-3.5");
    assert_eq!(one("1500000 / 1000000"), "1.5");
    assert_eq!(one("7 / 2.0"), "3.5");
    assert_eq!(one("7 % 3"), "1");
    assert_eq!(one("2 + 3 * 4"), "14");
    assert_eq!(one("(2 + 3) * 4"), "20");
    assert_eq!(one("10 - 2 - 3"), "5");
    assert_eq!(one("1 + 0.5"), "1.5");
    assert_eq!(one("-(2 + 3)"), "-5");
    assert_eq!(one("2147483647 + 1"), "-2147483648");
    assert_eq!(
        one("p[1, 2, 3, 0, 0, 0] + p[1, 1, 1, 0, 0, 0]"),
        "p[2, 3, 4, 0, 0, 0]"
    );
}

#[test]
fn comparisons_and_booleans_precedence() {
    assert_eq!(one("1 < 2 and 2 < 3"), "True");
    assert_eq!(one("not 1 == 2"), "True");
    assert_eq!(one("True or False and False"), "True");
    assert_eq!(one("True xor True"), "False");
    assert_eq!(one("False or True xor True"), "False");
    assert_eq!(one("1 == 1.0"), "True");
    assert_eq!(one("\"a\" == \"a\""), "True");
    assert_eq!(one("[1, 2] != [1, 2]"), "False");
    assert_eq!(one("2 >= 2"), "True");
    assert_eq!(one("not True or True"), "True");
}

#[test]
fn short_circuit_avoids_evaluating_the_right_side() {
    // (A name never assigned is refused before the program runs; an error the right
    // side would raise shows it is not evaluated.)
    assert_eq!(one("False and 1 % 0 > 0"), "False");
    assert_eq!(one("True or 1 % 0 > 0"), "True");
}

#[test]
fn indexing_and_element_assignment() {
    let m = msgs("l = [1, 2, 3]\nl[1] = 20\nq = p[0, 0, 0, 0, 0, 0]\nq[2] = 0.5\nm = [[1, 2], [3, 4]]\nm[1][0] = 30\ntextmsg(l, q)\ntextmsg(m[1], l[2])\ntextmsg(q[2])\n");
    assert_eq!(m, ["[1, 20, 3]p[0, 0, 0.5, 0, 0, 0]", "[30, 4]3", "0.5"]);
}

#[test]
fn statements_continue_inside_brackets() {
    let m = msgs("x = [1,\n  2,\n  3]\ny = (1 +\n 2)\ntextmsg(x, y)\n");
    assert_eq!(m, ["[1, 2, 3]3"]);
}

#[test]
fn if_elif_else() {
    let src = "def f(x):\n  if x < 0:\n    return \"neg\"\n  elif x == 0:\n    return \"zero\"\n  else:\n    return \"pos\"\n  end\nend\ntextmsg(f(-1), f(0))\ntextmsg(f(5))\n";
    assert_eq!(msgs(src), ["negzero", "pos"]);
}

#[test]
fn while_break_continue() {
    let src = "i = 0\ns = 0\nwhile True:\n  i = i + 1\n  if i > 10:\n    break\n  end\n  if i % 2 == 0:\n    continue\n  end\n  s = s + i\nend\ntextmsg(s)\n";
    assert_eq!(msgs(src), ["25"]);
}

#[test]
fn defaults_named_arguments_recursion() {
    let src = "def f(a, b=10, c=-1):\n  return a + b * c\nend\ndef fact(n):\n  if n <= 1:\n    return 1\n  end\n  return n * fact(n - 1)\nend\ntextmsg(f(1))\ntextmsg(f(1, c=2))\ntextmsg(f(1, 2, 3))\ntextmsg(fact(10))\n";
    assert_eq!(msgs(src), ["-9", "21", "7", "3628800"]);
}

#[test]
fn a_default_may_name_a_global() {
    // As URCap-generated code writes `def f(hz=DEFAULT_HZ):`: the global's value when
    // the function is called without that argument, read at each call.
    let src = "def prog():\n  RATE = 5\n  def f(hz=RATE, tag=\"x\"):\n    return str_cat(tag, hz)\n  end\n  textmsg(f())\n  RATE = 7\n  textmsg(f())\n  textmsg(f(hz=0.2))\n  textmsg(f(1, \"y\"))\nend\n";
    assert_eq!(msgs(src), ["x5", "x7", "x0.2", "y1"]);
    // A name never assigned is an error when the default is needed, not before.
    let src = "def f(a=NOWHERE):\n  return a\nend\ntextmsg(f(3))\ntextmsg(f())\n";
    let e = runtime_error(src);
    assert!(
        e.contains("unknown variable `NOWHERE`, the default of parameter `a` of `f`"),
        "{e}"
    );
    // Anything else than a constant or a name is still refused.
    assert_eq!(
        parse_err("def f(a=1+2):\nend\n"),
        "line 1, column 9: the default of parameter `a` must be a constant, a variable name, or a list or pose of those"
    );
}

#[test]
fn a_default_may_be_a_list_or_pose_of_globals() {
    // OnRobot's FT URCap preamble writes `def f(offsets=[ZERO_POSE], ...)`: a list
    // literal around a global's name, built from the global's value at each call.
    let src = "def prog():\n  HOME = p[0.1, 0, 0, 0, 0, 0]\n  Z = 0.5\n  def f(ps=[HOME, [Z, 2]], q=p[Z, 0, 0, 0, 0, Z]):\n    return str_cat(ps, q)\n  end\n  textmsg(f())\n  Z = 1\n  textmsg(f(ps=[]))\n  textmsg(f(q=p[0,0,0,0,0,0]))\nend\n";
    assert_eq!(
        msgs(src),
        [
            "[p[0.1, 0, 0, 0, 0, 0], [0.5, 2]]p[0.5, 0, 0, 0, 0, 0.5]",
            "[]p[1, 0, 0, 0, 0, 1]",
            "[p[0.1, 0, 0, 0, 0, 0], [1, 2]]p[0, 0, 0, 0, 0, 0]",
        ]
    );
    // A pose item that is not a number is a type error when the default is needed.
    let e =
        runtime_error("S = \"a\"\ndef f(x=p[S, 0, 0, 0, 0, 0]):\n  return x\nend\ntextmsg(f())\n");
    assert!(e.contains("a pose item is"), "{e}");
    // Anything but literals and names inside is still refused.
    assert_eq!(
        parse_err("def f(a=[A, 1+B]):\nend\n"),
        "line 1, column 9: the default of parameter `a` must be a constant, a variable name, or a list or pose of those"
    );
}

#[test]
fn function_called_before_its_definition() {
    assert_eq!(msgs("textmsg(g())\ndef g():\n  return 5\nend\n"), ["5"]);
}

#[test]
fn scoping_global_local() {
    // Program-level variables are global; a function assigning one changes it; a new
    // name assigned in a function is local; `local` shadows; `global` creates a global.
    let src = "def prog():\n  a = 1\n  def set_a():\n    a = 2\n    b = 3\n  end\n  def shadow():\n    local a = 100\n    return a\n  end\n  def make():\n    global c = 7\n  end\n  set_a()\n  textmsg(a, shadow())\n  textmsg(a)\n  make()\n  textmsg(c)\nend\n";
    assert_eq!(msgs(src), ["2100", "2", "7"]);
    assert!(runtime_error("def f():\n  b = 3\nend\nf()\ntextmsg(b)\n")
        .starts_with("line 5: compile_error_name_not_found:b:"));
}

#[test]
fn one_top_level_def_is_the_program() {
    assert_eq!(msgs("def prog():\n  textmsg(\"ran\")\nend\n"), ["ran"]);
    // ... also when the file calls it.
    assert_eq!(
        msgs("def prog():\n  textmsg(\"ran\")\nend\nprog()\n"),
        ["ran"]
    );
    assert_eq!(
        Program::parse("def a():\nend\nx = 1\n")
            .unwrap()
            .entry_name(),
        None
    );
}

#[test]
fn halt_stops_the_program() {
    let h = common::run("textmsg(\"a\")\nhalt\ntextmsg(\"b\")\n");
    assert_eq!(h.m.state(), &urscript_interp::State::Halted);
    assert_eq!(h.messages, ["a"]);
}

#[test]
fn threads_run_join_kill() {
    let src = "global n = 0\nthread counter():\n  while True:\n    n = n + 1\n    sync()\n  end\nend\nthread finite():\n  sleep(0.01)\n  textmsg(\"finite done\")\nend\nt = run counter()\nf = run finite()\njoin f\ntextmsg(\"joined at n=\", n)\nkill t\nm = n\nsleep(0.1)\ntextmsg(n == m)\n";
    assert_eq!(msgs(src), ["finite done", "joined at n=6", "True"]);
}

#[test]
fn join_and_kill_of_a_thread_never_started_do_nothing() {
    assert_eq!(msgs("h = 0\njoin h\nkill h\ntextmsg(\"ok\")\n"), ["ok"]);
}

#[test]
fn critical_section_with_time_inside_lets_others_run() {
    let src = "global flag = False\nthread setter():\n  flag = True\nend\nenter_critical\nrun setter()\nsync()\nseen = flag\nexit_critical\ntextmsg(seen)\n";
    assert_eq!(msgs(src), ["True"]);
}

#[test]
fn main_ending_stops_threads() {
    let h = common::run(
        "thread forever():\n  while True:\n    sync()\n  end\nend\nrun forever()\nsleep(0.02)\n",
    );
    assert_eq!(h.m.state(), &urscript_interp::State::Finished);
    assert!(h.now < std::time::Duration::from_millis(100));
}

#[test]
fn parse_errors_name_line_column_and_construct() {
    assert_eq!(
        parse_err("x = 1\nfor i in l:\n"),
        "line 2, column 1: `for` loops are not URScript (use `while`)"
    );
    assert_eq!(
        parse_err("if x > 1\n  y = 2\nend\n"),
        "line 1, column 9: expected `:` after the `if` condition, found end of line"
    );
    assert_eq!(
        parse_err("while True:\n  sync()\n"),
        "line 3, column 1: expected `end` before the end of program"
    );
    assert_eq!(
        parse_err("x = (1 +\n"),
        "line 2, column 1: expected an expression, found end of program"
    );
    assert_eq!(
        parse_err("end\n"),
        "line 1, column 1: `end` without an open block"
    );
    assert_eq!(
        parse_err("x = s.\n"),
        "line 1, column 7: expected a member name after `.`, found end of line"
    );
    assert_eq!(
        parse_err("x = \"abc\n"),
        "line 1, column 5: string literal not closed on its line"
    );
    assert_eq!(
        parse_err("x = 99999999999\n"),
        "line 1, column 5: integer literal `99999999999` does not fit 32 bits"
    );
    assert_eq!(
        parse_err("break\n"),
        "line 1, column 1: `break` outside a `while` loop"
    );
    assert_eq!(
        parse_err("x = run nothing()\n"),
        "line 1, column 9: `run nothing()`: no thread named `nothing`"
    );
    assert_eq!(
        parse_err("def f(a=1, b):\nend\n"),
        "line 1, column 13: parameter `b` without a default follows one with a default"
    );
    assert_eq!(
        parse_err("x = p[1, 2]\n"),
        "line 1, column 5: a pose has 6 values, this one has 2"
    );
    assert_eq!(parse_err("1 + 2\n"), "line 1, column 6: expected a statement (a call or an assignment), found an expression before end of line");
}

#[test]
fn runtime_errors_say_the_line() {
    assert_eq!(
        runtime_error("l = [1, 2]\nx = l[2]\n"),
        "line 2: index out of range: index 2, length 2"
    );
    assert_eq!(
        runtime_error("x = 1\n\ny = x + \"a\"\n"),
        "line 3: type error: int + string (1 + \"a\")"
    );
    assert_eq!(
        runtime_error("x = 1 / 0\n"),
        "line 1: division by zero (1 / 0)"
    );
    // A name never assigned is refused before the program runs, as the controller does;
    // a global read before the program assigned it is a runtime error.
    assert!(runtime_error("x = y\n").starts_with("line 1: compile_error_name_not_found:y: "));
    assert_eq!(
        runtime_error("textmsg(x)\nx = 1\n"),
        "line 1: unknown variable `x`"
    );
    assert_eq!(
        runtime_error("l = [1]\nl[1.5] = 2\n"),
        "line 2: type error: an index must be an int, got float 1.5"
    );
    assert_eq!(runtime_error("rq_activate()\n"), "line 1: compile_error_name_not_found:rq_activate: `rq_activate` is neither defined in the program nor a built-in of the controller (a URCap's function? stub it)");
}

#[test]
fn calls_are_checked_when_the_program_compiles_with_line_and_column() {
    use urscript_interp::ParseErrorKind;
    let e = Program::parse("textmsg(\"never shown\")\ndef f(a):\n  return a\nend\nx = 1 + f()\n")
        .unwrap_err();
    assert_eq!(e.to_string(), "line 5, column 9: `f` needs argument `a`");
    assert_eq!(e.kind(), ParseErrorKind::Compile);
    for (src, want) in [
        (
            "  sleep()\n",
            "line 1, column 3: `sleep` needs argument `t`",
        ),
        (
            "sync(1)\n",
            "line 1, column 1: `sync` takes exactly 0 arguments, 1 given",
        ),
        (
            "x = [textmsg(1, 2, 3)]\n",
            "line 1, column 6: `textmsg` takes at most 2 arguments, 3 given",
        ),
        (
            "def g(a, b=1):\nend\ng(1, a=2)\n",
            "line 3, column 1: argument `a` of `g` given twice",
        ),
        (
            "movej([0,0,0,0,0,0], speed=1)\n",
            "line 1, column 1: `movej` has no parameter `speed` (its parameters: q, a, v, t, r)",
        ),
        (
            "x = 1\nwhile x:\n  continue\nend\nif x:\n    break\nend\n",
            "line 6, column 5: `break` outside a `while` loop",
        ),
    ] {
        let e = Program::parse(src).unwrap_err();
        assert_eq!(e.to_string(), want, "{src}");
        assert_eq!(e.kind(), ParseErrorKind::Compile, "{src}");
    }
    // A syntax error is its own kind.
    assert_eq!(
        Program::parse("x = (\n").unwrap_err().kind(),
        ParseErrorKind::Syntax
    );
}

#[test]
fn runtime_errors_are_typed_with_line_and_column() {
    use urscript_interp::RuntimeErrorKind as K;
    for (src, kind, line, col) in [
        ("l = [1]\nx = l[1]\n", K::Index, 2, 1),
        ("x = 1 + \"a\"\n", K::Type, 1, 1),
        ("x = 1 % 0\n", K::DivisionByZero, 1, 1),
        ("x = y\n", K::UnknownVariable, 1, 5),
        ("textmsg(1)\nz = 2 * zz\n", K::UnknownVariable, 2, 9),
        ("x = 1\nif x:\n  y = asin(2)\nend\n", K::Argument, 3, 7),
        ("x = 1\n  rq_activate()\n", K::UnknownFunction, 2, 3),
    ] {
        let h = common::run(src);
        let State::Error(e) = h.m.state() else {
            panic!("{src}: no error")
        };
        assert_eq!(
            (e.kind(), e.line(), e.column()),
            (kind, line, col),
            "{src}: {e}"
        );
    }
}

#[test]
fn the_controllers_language_rules() {
    // Statements side by side on one line, separated by spaces or tabs.
    assert_eq!(
        msgs("textmsg(\"a\") textmsg(\"b\")\nw = -0.2\ttextmsg(w)\nx = 1 p = [x] textmsg(p[0])\n"),
        ["a", "b", "-0.2", "1"]
    );
    // string + string joins them (up to the controller's 1023 characters).
    assert_eq!(one("\"x = \" + to_str(1.5) + \"!\""), "x = 1.5!");
    assert!(
        runtime_error(&format!("s = \"{}\"\nt = s + s\n", "a".repeat(600)))
            .contains("more than 1023")
    );
    assert!(runtime_error("x = \"a\" + 1\n").contains("type error: string + int"));
    // A bool in arithmetic is 0 or 1.
    assert_eq!(one("3 * True + False"), "3");
    assert_eq!(one("1 * get_standard_digital_in(0)"), "0");
    assert_eq!(one("True / 2"), "0.5");
    // Still an error: an expression that does not end where a statement may begin.
    assert!(Program::parse("x = 1 )\n").is_err());
}

#[test]
fn an_unknown_name_stops_the_program_before_it_starts() {
    // As the controller's compile error: not even the first statement runs.
    let h = common::run("textmsg(\"never\")\nif False:\n  rq_activate()\nend\n");
    assert!(h.messages.is_empty(), "{:?}", h.messages);
    let State::Error(e) = h.m.state() else {
        panic!("{:?}", h.m.state())
    };
    assert_eq!((e.line(), e.column()), (3, 3));
    assert!(
        e.message()
            .starts_with("compile_error_name_not_found:rq_activate:"),
        "{e}"
    );
}

#[test]
fn a_loop_that_uses_its_time_slice_goes_on_in_the_next_step() {
    // The manual's "Thread scheduling": a thread that uses its slice computing waits
    // for the next frame; it is not stopped.
    let src = "i = 0\nwhile i < 25000:\n  i = i + 1\nend\ntextmsg(\"done \", i)\n";
    let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
    m.run_until(Duration::ZERO);
    assert_eq!(m.state(), &State::Running);
    m.run_until(Duration::from_millis(20));
    assert_eq!(m.state(), &State::Finished);
    let mut done = None;
    while let Some(e) = m.poll_event() {
        if let Event::Message(msg) = e {
            done = Some(msg.text);
        }
    }
    assert_eq!(done.as_deref(), Some("done 25000"));
    // An empty endless loop runs on, a step at a time, with the other threads.
    let src =
        "thread t():\n  sleep(0.01)\n  textmsg(\"thread ran\")\nend\nrun t()\nwhile True:\nend\n";
    let mut m = Machine::new(Program::parse(src).unwrap(), Config::default());
    m.run_until(Duration::from_millis(100));
    assert_eq!(m.state(), &State::Running);
    assert!(std::iter::from_fn(|| m.poll_event())
        .any(|e| matches!(e, Event::Message(msg) if msg.text == "thread ran")));
}

#[test]
fn list_arithmetic_is_element_wise() {
    assert_eq!(one("[1, 2, 3] + [10, 20, 30]"), "[11, 22, 33]");
    assert_eq!(one("[1.0, 2.0] * 0.5"), "[0.5, 1]");
    assert_eq!(one("2 * [1, 2] - [1, 1]"), "[1, 3]");
    assert_eq!(one("[1000000, 2500000] / 1000000"), "[1, 2.5]");
    assert!(runtime_error("x = [1, 2] + [1]\n").contains("lists of different lengths"));
    assert!(runtime_error("x = [1, 2] + \"a\"\n").contains("type error"));
}

#[test]
fn a_line_ending_in_an_operator_continues() {
    assert_eq!(
        msgs("x = 1\nif x == 2 or\n  x == 1:\n  textmsg(\"yes\")\nend\ny = 1 +\n 2\ntextmsg(y)\n"),
        ["yes", "3"]
    );
}

#[test]
fn numbers_as_conditions() {
    assert_eq!(
        msgs("if 0.5:\n  textmsg(\"a\")\nend\nif 0:\n  textmsg(\"b\")\nend\n"),
        ["a"]
    );
    assert!(runtime_error("if \"x\":\n  sync()\nend\n").contains("needs a bool, got string"));
}

#[test]
fn template_placeholders_must_be_filled() {
    assert_eq!(parse_err("x = {{JOINT_STATE_REPLACE}}\n"), "line 1, column 5: a template placeholder (`{{...}}` or `{% ... %}`) must be filled in before the program runs");
}

#[test]
fn float_division_by_zero_is_infinite() {
    assert_eq!(one("1.0 / 0 > 1000000"), "True");
}

#[test]
fn a_variable_named_p_can_be_indexed_and_assigned() {
    assert_eq!(
        msgs("p = get_tcp_offset()\np[2] = 0.5\nl = [p[2], 1]\ntextmsg(p, l)\n"),
        ["p[0, 0, 0.5, 0, 0, 0][0.5, 1]"]
    );
}

#[test]
fn real_world_syntax_variants() {
    let src = "def empty():\r\nend\r\nsec secondary():\r\n  textmsg(\"sec\")\r\nend\r\ndef f(): # comment after the colon\n\treturn\nend\nx=1\nif(x==1): textmsg(\"inline\") end\nwhile x < 3: x = x + 1 end\nthread t():\n  return\nend\nh = run t()\njoin h\nempty()\nsecondary()\ntextmsg(not(x == 3), [-1, -2.5])\ntextmsg(1., .5)\ntextmsg(f())\n";
    assert_eq!(
        msgs(src),
        ["inline", "sec", "False[-1, -2.5]", "10.5", "None"]
    );
}

#[test]
fn an_operand_may_follow_on_the_next_line() {
    // The controller's grammar is not line-based: after `=` or an operator an operand
    // must follow, and a line end (after a comment) does not end the statement. Real
    // generated scripts (ur_rtde's control script, after its value substitution) rely
    // on it; the value's line may go on with the next statement.
    assert_eq!(
        msgs("x = # the offset\n24    y = 2\ntextmsg(x + y)\n"),
        ["26"]
    );
    assert_eq!(msgs("z = 1 +\n  2\ntextmsg(z)\n"), ["3"]);
    assert_eq!(msgs("textmsg(\n\"a\")\n"), ["a"]);
    // A statement still cannot end where an operand is missing.
    assert!(
        parse_err("x =\n").contains("expected"),
        "{}",
        parse_err("x =\n")
    );
}

#[test]
fn a_matrix_entry_is_read_and_written_with_two_indices() {
    // UR's manual, "Matrix and array expressions": `b = matrix[0,0]`, `matrix[2,1] = 20`
    // (row, then column; 0-indexed). The same entry as `m[i][j]`.
    let src = "m = [[1, 2], [3, 4], [5, 6]]\ntextmsg(m[0, 0], m[2,1])\nm[2, 1] = 20\ntextmsg(m)\ni = 1\nm[i, i - 1] = m[i, 1] * 10\ntextmsg(m[1])\ntextmsg(m[i, 0] == m[i][0])\ndef f():\n  global g = [[0, 0], [0, 0]]\n  g[1, 0] = 7\n  return g[1, 0]\nend\ntextmsg(f())\n";
    assert_eq!(
        msgs(src),
        ["16", "[[1, 2], [3, 4], [5, 20]]", "[40, 4]", "True", "7"]
    );
    // Out of range, as `m[i][j]` would be.
    let e = runtime_error("m = [[1, 2], [3, 4]]\nx = m[0, 2]\n");
    assert!(e.starts_with("line 2"), "{e}");
    // Two indices only.
    assert_eq!(
        parse_err("m = [[1]]\nx = m[0, 0, 0]\n"),
        "line 2, column 11: a matrix entry takes two indices, `m[row, column]`"
    );
    assert_eq!(
        parse_err("m = [[1]]\nm[0, 0, 0] = 1\n"),
        "line 2, column 7: a matrix entry takes two indices, `m[row, column]`"
    );
}

#[test]
fn jump_to_label_starts_at_a_step_marker() {
    // PolyScope writes `jump_to_label(N)` to start a program at a selected node: the run
    // goes on at the first statement after `$ N`, here inside a loop, which then loops
    // as usual.
    let src = "def prog():\n  textmsg(\"start\")\n  jump_to_label(3)\n  $ 1 \"Robot Program\"\n  textmsg(\"skipped\")\n  i = 0\n  while i < 2:\n    $ 2 \"first\"\n    textmsg(\"first\")\n    $ 3 \"second\" \"breakAfter\"\n    textmsg(\"second\")\n    i = i + 1\n  end\nend\n";
    // `i` is not yet assigned where the jump lands: the condition reads it.
    let e = runtime_error(src);
    assert!(e.contains("`i`"), "{e}");
    let src = src
        .replace("  i = 0\n", "")
        .replace("textmsg(\"start\")\n", "textmsg(\"start\")\n  i = 0\n");
    assert_eq!(msgs(&src), ["start", "second", "first", "second"]);
    // A marker that is not there, or not followed by a statement, is a compile error.
    let e = Program::parse("textmsg(1)\njump_to_label(9)\n$ 9 \"last\"\n").unwrap_err();
    assert_eq!(
        e.to_string(),
        "line 2, column 1: `jump_to_label(9)`: no step marker `$ 9` followed by a statement in this function"
    );
    assert!(Program::parse("jump_to_label(4)\n$ 5 \"x\"\ntextmsg(1)\n").is_err());
    // The program's own `jump_to_label` is called as any function.
    assert_eq!(
        msgs("def jump_to_label(n):\n  textmsg(\"own\", n)\nend\njump_to_label(2)\n$ 2 \"x\"\n"),
        ["own2"]
    );
}
