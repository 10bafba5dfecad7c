//! Arbitrary program text never panics the parser, and programs that parse never panic
//! the machine.
use std::time::Duration;

use proptest::prelude::*;
use urscript_interp::{Config, Machine, Program};

/// Fragments of URScript, so the generator reaches deep into the grammar.
fn fragment() -> impl Strategy<Value = String> {
    prop_oneof![
        Just("def f(a, b=1):\n".to_string()),
        Just("thread t():\n".to_string()),
        Just("end\n".to_string()),
        Just("if x > 1:\n".to_string()),
        Just("elif x:\n".to_string()),
        Just("else:\n".to_string()),
        Just("while True:\n".to_string()),
        Just("break\n".to_string()),
        Just("continue\n".to_string()),
        Just("return x\n".to_string()),
        Just("x = [1, 2.5, p[1,2,3,4,5,6]]\n".to_string()),
        Just("x[0] = f(1, b=2)\n".to_string()),
        Just("h = run t()\n".to_string()),
        Just("join h\n".to_string()),
        Just("kill h\n".to_string()),
        Just("sync()\n".to_string()),
        Just("global g = not x or y xor z and -w\n".to_string()),
        Just("local l = (1 + 2) * 3 / 4 % 5\n".to_string()),
        Just("textmsg(str_cat(\"a\", x))\n".to_string()),
        Just("socket_read_ascii_float(3, \"s\")\n".to_string()),
        Just("enter_critical\nexit_critical\n".to_string()),
        Just("halt\n".to_string()),
        Just("x = struct(a=1, b=[x, 2], c=struct(d=p[1,2,3,4,5,6]))\n".to_string()),
        Just("x.c.d[1] = x.a\n".to_string()),
        Just("r = rpc_factory(\"xmlrpc\", \"http://h:1/\")\n".to_string()),
        Just("y = r.m(x, 1.5, \"s\")\n".to_string()),
        Just("y = make_list(4, \"ab\")\nz = [1.0, 2.0] * 2 + [x[0], 1]\n".to_string()),
        "[ -~\n]{0,12}",
    ]
}

/// The machine's count of the program's memory is never below a recount of it.
fn audit(m: &mut Machine) {
    if m.state() == &urscript_interp::State::Running {
        let (counted, recounted) = m.memory_audit();
        assert!(counted >= recounted, "memory count {counted} < {recounted}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 256, ..ProptestConfig::default() })]

    #[test]
    fn parser_never_panics_on_bytes(text in "\\PC{0,200}") {
        let _ = Program::parse(&text);
    }

    #[test]
    fn parser_and_machine_never_panic_on_fragments(parts in proptest::collection::vec(fragment(), 0..30)) {
        let text: String = parts.concat();
        if let Ok(p) = Program::parse(&text) {
            let config = Config { max_statements_per_step: 2000, ..Config::default() };
            let mut m = Machine::new(p, config);
            m.run_until(Duration::from_millis(20));
            audit(&mut m);
            m.handle_connected("s", Ok(()));
            m.handle_received("s", b"(1,2,3)\n");
            m.handle_connected("rpc:http://h:1/", Ok(()));
            m.handle_received("rpc:http://h:1/", b"HTTP/1.1 200 OK\r\n\r\n<methodResponse><params><param><value><int>1</int>");
            m.handle_peer_closed("rpc:http://h:1/");
            m.run_until(Duration::from_millis(40));
            audit(&mut m);
            while m.poll_event().is_some() {}
        }
    }
}

#[test]
fn deep_nesting_is_an_error_not_a_stack_overflow() {
    let deep = format!("x = {}1{}\n", "(".repeat(100_000), ")".repeat(100_000));
    assert!(Program::parse(&deep)
        .unwrap_err()
        .to_string()
        .contains("nested too deeply"));
    let neg = format!("x = {}1\n", "-".repeat(100_000));
    assert!(Program::parse(&neg).is_err());
    let nots = format!("x = {}True\n", "not ".repeat(100_000));
    assert!(Program::parse(&nots).is_err());
    let blocks = "if True:\n".repeat(10_000);
    assert!(Program::parse(&blocks).is_err());
    // Member chains: read, call and assignment target.
    let members = format!("x = s{}\n", ".a".repeat(100_000));
    assert!(Program::parse(&members)
        .unwrap_err()
        .to_string()
        .contains("nested too deeply"));
    let target = format!("s{} = 1\n", ".a".repeat(100_000));
    assert!(Program::parse(&target).is_err());
    let calls = format!("x = r{}\n", ".m()".repeat(100_000));
    assert!(Program::parse(&calls).is_err());
}
