//! Structs: `struct(name=value, ...)`, member reads and writes, their text and equality.
mod common;
use std::time::Duration;

use common::messages;
use urscript_interp::{
    Config, Machine, Program, RuntimeErrorKind, State, Value, MAX_STRUCT_MEMBERS,
};

/// Runs `src` for 1 s of virtual time: its final state and the machine.
fn run(src: &str) -> Machine {
    let p = Program::parse(src).unwrap_or_else(|e| panic!("{src}: {e}"));
    let mut m = Machine::new(p, Config::default());
    m.run_until(Duration::from_secs(1));
    m
}

fn error(src: &str) -> (RuntimeErrorKind, u32, u32, String) {
    let m = run(src);
    let State::Error(e) = m.state() else {
        panic!("{src}: no error ({:?})", m.state())
    };
    (e.kind(), e.line(), e.column(), e.message().to_string())
}

#[test]
fn build_read_and_write_members() {
    let m = messages(
        "s = struct(a=1, b=[1, 2], name=\"cam\")\ntextmsg(s.a)\ntextmsg(s.b[1])\ns.a = 3\ns.b[0] = 7\ntextmsg(s.a + s.b[0])\ntextmsg(s.name)\n",
    );
    assert_eq!(m, ["1", "2", "10", "cam"]);
}

#[test]
fn members_hold_any_value_and_nest() {
    let m = run(
        "inner = struct(x=p[0.1, 0, 0, 0, 0, 0], ok=True)\nouter = struct(in=inner, k=2.5)\nouter.in.ok = False\nouter.in.x[2] = 0.3\nv = outer.in.x\nw = outer.in.ok\n",
    );
    assert_eq!(m.state(), &State::Finished);
    assert_eq!(
        m.global("v"),
        Some(&Value::Pose([0.1, 0.0, 0.3, 0.0, 0.0, 0.0]))
    );
    assert_eq!(m.global("w"), Some(&Value::Bool(false)));
}

#[test]
fn a_struct_is_a_value_copied_on_assignment_and_call() {
    let m = run(
        "def bump(t):\n  t.n = t.n + 1\n  return t\nend\na = struct(n=1)\nb = a\nb.n = 5\nc = bump(a)\nan = a.n\nbn = b.n\ncn = c.n\n",
    );
    assert_eq!(m.state(), &State::Finished);
    assert_eq!(m.global("an"), Some(&Value::Int(1)));
    assert_eq!(m.global("bn"), Some(&Value::Int(5)));
    assert_eq!(m.global("cn"), Some(&Value::Int(2)));
}

#[test]
fn text_and_equality() {
    let m = messages(
        "s = struct(a=1, b=[1, 2], t=\"x\")\ntextmsg(s)\ntextmsg(to_str(struct(q=p[0, 0, 0.1, 0, 0, 0])))\ntextmsg(struct(a=1) == struct(a=1.0))\ntextmsg(struct(a=1) == struct(a=2))\ntextmsg(struct(a=1, b=2) == struct(b=2, a=1))\ntextmsg(struct(a=1) != struct(b=1))\n",
    );
    assert_eq!(
        m,
        [
            "struct(a=1, b=[1, 2], t=\"x\")",
            "struct(q=p[0, 0, 0.1, 0, 0, 0])",
            "True",
            "False",
            "False",
            "True"
        ]
    );
}

#[test]
fn unknown_member_is_a_runtime_error_at_the_member() {
    let (kind, line, col, msg) = error("s = struct(a=1)\nx = s.b\n");
    assert_eq!(kind, RuntimeErrorKind::UnknownMember);
    assert_eq!((line, col), (2, 7));
    assert!(msg.contains("no member `b`"), "{msg}");
    // A member is never added by assignment: the shape is fixed by `struct(...)`.
    let (kind, line, _, msg) = error("s = struct(a=1)\ns.c = 2\n");
    assert_eq!((kind, line), (RuntimeErrorKind::UnknownMember, 2));
    assert!(msg.contains("`c`"), "{msg}");
}

#[test]
fn member_of_a_non_struct_is_a_type_error() {
    let (kind, line, _, msg) = error("x = [1, 2]\ny = x.a\n");
    assert_eq!((kind, line), (RuntimeErrorKind::Type, 2));
    assert!(msg.contains("not of a list"), "{msg}");
    let (kind, _, _, msg) = error("x = 3\nx.a = 1\n");
    assert_eq!(kind, RuntimeErrorKind::Type);
    assert!(msg.contains("not of a int"), "{msg}");
    // Calling a method on a struct is not a remote call.
    let (kind, _, _, msg) = error("s = struct(a=1)\ns.a()\n");
    assert_eq!(kind, RuntimeErrorKind::Type);
    assert!(msg.contains("rpc_factory"), "{msg}");
}

#[test]
fn compile_time_checks() {
    let e = |src: &str| Program::parse(src).unwrap_err().to_string();
    assert_eq!(
        e("s = struct(1, 2)\n"),
        "line 1, column 5: `struct` takes named members only: struct(name=value, ...)"
    );
    assert_eq!(
        e("s = struct()\n"),
        "line 1, column 5: a struct needs at least one member"
    );
    assert!(e("s = struct(a=1, a=2)\n").contains("`a` given twice"));
    let many: Vec<String> = (0..=MAX_STRUCT_MEMBERS)
        .map(|i| format!("m{i}=0"))
        .collect();
    assert!(e(&format!("s = struct({})\n", many.join(", ")))
        .contains(&format!("at most {MAX_STRUCT_MEMBERS} members")));
    let ok: Vec<String> = (0..MAX_STRUCT_MEMBERS).map(|i| format!("m{i}=0")).collect();
    assert!(Program::parse(&format!("s = struct({})\n", ok.join(", "))).is_ok());
    assert!(e("s = struct(a=1)\ns. = 2\n").contains("member name"));
    // A member write reads the variable: one never assigned is refused before running.
    let m = Machine::new(Program::parse("t.a = 1\n").unwrap(), Config::default());
    let State::Error(err) = m.state() else {
        panic!("not refused")
    };
    assert!(err.message().starts_with("compile_error_name_not_found:t:"));
}

#[test]
fn struct_values_are_bounded() {
    // A struct holding itself over and over nests past the value depth bound.
    let (kind, line, _, msg) =
        error("s = struct(a=0)\ni = 0\nwhile i < 40:\n  s = struct(a=s)\n  i = i + 1\nend\n");
    assert_eq!((kind, line), (RuntimeErrorKind::Limit, 4));
    assert!(msg.contains("nested"), "{msg}");
    // The same through a member write: the variable keeps no value over the bound.
    let src = "s = struct(a=0)\ni = 0\nwhile i < 40:\n  s.a = s\n  i = i + 1\nend\n";
    let (kind, line, _, msg) = error(src);
    assert_eq!((kind, line), (RuntimeErrorKind::Limit, 4));
    assert!(msg.contains("nested"), "{msg}");
    assert_eq!(run(src).global("s"), None);
    // And by size: a member list doubled in a loop stops at Config::max_value_size.
    let (kind, line, _, msg) = error("s = struct(l=[0])\nwhile True:\n  s.l = [s.l, s.l]\nend\n");
    assert_eq!((kind, line), (RuntimeErrorKind::Limit, 3));
    assert!(msg.contains("nested") || msg.contains("elements"), "{msg}");
}

#[test]
fn a_program_may_define_its_own_struct_function() {
    // `struct` is the language's; a program's own function of that name wins.
    assert_eq!(
        messages("def struct(a):\n  return a + 1\nend\ntextmsg(struct(a=1))\n"),
        ["2"]
    );
}

#[test]
fn members_by_position() {
    // UR's own EtherNet/IP example indexes a struct by an int: `clamp[fixture] = True`
    // and `handle.read([...])[fixture]`; the members count in the order given.
    let m = messages(
        "s = struct(a=False, b=False, c=2)\nk = 1\ns[k] = True\ntextmsg(s.b)\ntextmsg(s[2] + s[0])\ns[0] = 5\ntextmsg(s.a)\n",
    );
    assert_eq!(m, ["True", "2", "5"]);
    let (kind, line, _, _) = error("s = struct(a=1)\nx = s[1]\n");
    assert_eq!((kind, line), (RuntimeErrorKind::Index, 2));
    let (kind, line, _, _) = error("s = struct(a=1)\ns[\"a\"] = 2\n");
    assert_eq!((kind, line), (RuntimeErrorKind::Type, 2));
}
