//! Runs the built `ursock` binary: offline commands on the spec's vectors, the demo, and
//! `listen` talking to `robot` over 127.0.0.1.

use std::io::{BufRead, BufReader};
use std::process::Stdio;

mod run_common;

use run_common::ursock;

/// Runs `ursock args` with `stdin` and returns (exit ok, stdout, stderr).
fn run(args: &[&str], stdin: &[u8]) -> (bool, String, String) {
    let (code, out, err) = run_common::run(args, stdin);
    (code == 0, out, err)
}

fn ok(args: &[&str], stdin: &[u8]) -> String {
    let (success, out, err) = run(args, stdin);
    assert!(success, "ursock {args:?} failed: {err}");
    out
}

#[test]
fn encode_examples_from_the_issue() {
    assert_eq!(
        ok(&["encode", "floats", "1.414", "3.14159"], b""),
        "(1.414,3.14159)"
    );
    assert_eq!(
        ok(&["encode", "int32", "100", "--hex"], b""),
        "00 00 00 64\n"
    );
    assert_eq!(
        ok(&["encode", "int32", "-1", "--hex"], b""),
        "FF FF FF FF\n"
    );
    assert_eq!(
        ok(&["encode", "bytes", "100", "200", "44", "--hex"], b""),
        "64 C8 2C\n"
    );
    assert_eq!(
        ok(&["encode", "var-reply", "POS_X", "1234"], b""),
        "POS_X 1234\n"
    );
    assert_eq!(ok(&["encode", "line", "hello"], b""), "hello\n");
}

#[test]
fn encode_robot_side_vectors() {
    // V17..V22
    assert_eq!(
        ok(&["encode", "--robot", "line", "hello", "--hex"], b""),
        "68 65 6C 6C 6F 0A\n"
    );
    assert_eq!(
        ok(&["encode", "--robot", "int", "-1", "--hex"], b""),
        "FF FF FF FF\n"
    );
    assert_eq!(
        ok(&["encode", "--robot", "set-var", "POS_Y", "2200"], b""),
        "SET POS_Y 2200\n"
    );
    assert_eq!(
        ok(&["encode", "--robot", "stx-etx", "hi", "--hex"], b""),
        "02 68 69 03\n"
    );
    assert_eq!(
        ok(
            &[
                "encode",
                "--robot",
                "value",
                "p[1.0, 2.0, 3.0, 4.0, 5.0, 6.0]"
            ],
            b""
        ),
        "p[1, 2, 3, 4, 5, 6]"
    );
    assert_eq!(
        ok(&["encode", "--robot", "value", "[True, False, True]"], b""),
        "[True, False, True]"
    );
}

#[test]
fn read_vectors() {
    let float = |input: &[u8], n: &str, repeat: &str| {
        ok(&["read", "ascii-float", n, "--repeat", repeat], input)
    };
    assert_eq!(
        float(b"( 1.414 , 3.14159, 1.616, 0.0 )", "4", "1"),
        "[4, 1.414, 3.14159, 1.616, 0]\n"
    ); // V1
    assert_eq!(float(b"", "3", "1"), "[0, nan, nan, nan]\n"); // V2
    assert_eq!(
        float(b"(-0.15,-0.5,0.3,0,-3.14,0)", "6", "1"),
        "[6, -0.15, -0.5, 0.3, 0, -3.14, 0]\n"
    ); // V3
    assert_eq!(float(b"(3)", "6", "1"), "[1, 3, nan, nan, nan, nan, nan]\n"); // V4
    assert_eq!(float(b"(1,2)\n(3,4)\n", "2", "2"), "[2, 1, 2]\n[2, 3, 4]\n"); // V5
    let ints = [0, 0, 0, 0x64, 0, 0, 7, 0xD0, 0, 0, 0x75, 0x30];
    assert_eq!(
        ok(&["read", "binary-integer", "3"], &ints),
        "[3, 100, 2000, 30000]\n"
    ); // V6
    assert_eq!(
        ok(&["read", "binary-integer", "3"], b""),
        "[0, -1, -1, -1]\n"
    ); // V7
    assert_eq!(
        ok(&["read", "binary-integer", "1"], &[0xFF; 4]),
        "[1, -1]\n"
    ); // V8
    assert_eq!(
        ok(&["read", "byte-list", "3"], &[0x64, 0xC8, 0x2C]),
        "[3, 100, 200, 44]\n"
    ); // V9
    assert_eq!(
        ok(&["read", "byte-list", "3"], b"ack"),
        "[3, 97, 99, 107]\n"
    ); // V10
    let s = |input: &[u8], extra: &[&str]| {
        let mut args = vec!["read", "string"];
        args.extend_from_slice(extra);
        ok(&args, input)
    };
    assert_eq!(
        s(b"noise>hello<", &["--prefix", ">", "--suffix", "<"]),
        "\"hello\"\n"
    ); // V11
    assert_eq!(
        s(
            b">hello<>world<",
            &["--prefix", ">", "--suffix", "<", "--repeat", "2"]
        ),
        "\"hello\"\n\"world\"\n"
    ); // V12
    assert_eq!(
        ok(&["read", "line"], b"reply from the server:\r\n"),
        "\"reply from the server:\"\n"
    ); // V13
    assert_eq!(
        s(b"reply from the server:\n Hello World", &[]),
        "\"reply from the server:\\n Hello World\"\n"
    ); // V14
    assert_eq!(
        s(
            b"OK,1\rNEXT\r",
            &["--suffix", "\\r", "--interpret-escape", "--repeat", "2"]
        ),
        "\"OK,1\"\n\"NEXT\"\n"
    ); // V15
    assert_eq!(
        s(&[0x01, b'"', b'\\', 0xFF], &[]),
        "\"\\x01\\\"\\\\\\xFF\"\n"
    );
}

#[test]
fn decode_formats() {
    assert_eq!(
        ok(&["decode", "int32"], &[0, 0, 0, 1, 0xFF, 0xFF, 0xFF, 0xFF]),
        "1\n-1\n"
    );
    assert_eq!(
        ok(&["decode", "stx-etx"], b"\x02hi\x03\x02yo\x03"),
        "\"hi\"\n\"yo\"\n"
    );
    assert_eq!(ok(&["decode", "line"], b"a\r\nb\n"), "\"a\"\n\"b\"\n");
    assert_eq!(
        ok(&["decode", "delimiter", "--delimiter", ";"], b"a;b;c;"),
        "\"a\"\n\"b\"\n\"c\"\n"
    );
    assert_eq!(
        ok(&["decode", "var"], b"SET POS_Y 2200\nGET POS_X\n"),
        "SET POS_Y 2200\nGET POS_X\n"
    );
    assert_eq!(
        decoded_messages(&ok(&["decode", "var", "--json"], b"SET A -3\n")),
        json_lines("{\"type\":\"set\",\"name\":\"A\",\"value\":-3}\n")
    );
    assert_eq!(
        decoded_messages(&ok(
            &["decode", "value", "--json"],
            b"p[1, 2, 3, 4, 5, 6]\n[True, 2]\n"
        )),
        json_lines("{\"type\":\"pose\",\"value\":[1.0,2.0,3.0,4.0,5.0,6.0]}\n{\"type\":\"list\",\"value\":[true,2]}\n")
    );
}

/// Each line parsed as JSON.
fn json_lines(out: &str) -> Vec<serde_json::Value> {
    out.lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect()
}

/// The typed messages of `decode --json`'s `decoded` events.
fn decoded_messages(out: &str) -> Vec<serde_json::Value> {
    json_lines(out)
        .into_iter()
        .map(|e| {
            assert_eq!(e["event"], "decoded", "{e}");
            e["message"].clone()
        })
        .collect()
}

#[test]
fn bad_input_keeps_complete_messages_and_fails_with_one_line() {
    let (success, out, err) = run(&["decode", "var"], b"SET A 1\nSET B x\nGET A\n");
    assert!(!success);
    assert_eq!(out, "SET A 1\nGET A\n");
    assert!(err.contains("at byte 14"), "{err}");
    let (success, _, err) = run(&["decode", "line"], b"no newline");
    assert!(!success);
    assert!(err.contains("cut off"), "{err}");
}

#[test]
fn argument_errors_are_one_line_and_non_zero() {
    for args in [
        &["read", "ascii-float", "31"][..],
        &["encode", "floats", "nan"],
        &["encode", "floats"],
        &["encode", "bogus", "1"],
        &["robot", "-e", "socket_frobnicate(1)"],
    ] {
        let (success, _, err) = run(args, b"");
        assert!(!success, "{args:?}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.starts_with("ursock: "), "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let (_, _, err) = run(&["robot", "-e", "socket_send_line(\"a\")\nfoo(1)"], b"");
    assert!(err.contains("line 1") || err.contains("line 2"), "{err}");
}

#[test]
fn robot_stops_at_a_protective_stop_and_exits_non_zero() {
    // A movel far beyond the reach: the arm stops at once with a protective stop, which
    // pauses a controller's program; the statement after it never runs.
    let (success, out, err) = run(
        &[
            "robot",
            "--max-time",
            "20",
            "-e",
            "movel(p[1.5, 0, 0.3, 0, 3.14, 0], a=0.5, v=0.2)\ntextmsg(\"after\")",
        ],
        b"",
    );
    assert!(!success, "{out}");
    assert!(err.contains("protective stop"), "{err}");
    assert!(!out.contains("after"), "{out}");
    let (success, out, _) = run(
        &[
            "robot",
            "--json",
            "-e",
            "protective_stop()\ntextmsg(\"after\")",
        ],
        b"",
    );
    assert!(!success);
    assert!(out.contains(r#""outcome":"protective_stop""#), "{out}");
    assert!(!out.contains(r#""text":"after""#), "{out}");
}

#[test]
fn demo_transcript_covers_every_function() {
    let out = ok(&["demo"], b"");
    for needle in [
        "socket_open",
        "socket_send_byte(2)",
        "socket_send_string(\"hi\")",
        "socket_send_int(-1)",
        "socket_send_line(\"hello\")",
        "socket_set_var(\"POS_Y\", 2200)",
        "socket_get_var(\"POS_Y\")",
        "socket_read_ascii_float(6)",
        "[6, 0.4, -0.2, 0.3, 0, 3.14, 0]",
        "socket_read_binary_integer(3)",
        "[3, 100, 2000, 30000]",
        "socket_read_byte_list(3)",
        "[3, 100, 200, 44]",
        "socket_read_string(prefix=\">\", suffix=\"<\")",
        "\"hello\"",
        "socket_read_line()",
        "\"reply from the server:\"",
        "[0, nan, nan, nan]",
        "socket_close()",
        "stx-etx frame \"hi\"",
        "int32 -1",
        "var SET POS_Y 2200",
        "02 68 69 03".split(' ').next().unwrap(),
    ] {
        assert!(
            out.contains(needle),
            "demo transcript lacks {needle:?}:\n{out}"
        );
    }
}

#[test]
fn listen_and_robot_talk_over_loopback() {
    let mut listen = ursock()
        .args([
            "listen",
            "--bind",
            "127.0.0.1",
            "--port",
            "0",
            "--decode",
            "line",
        ])
        .args(["--reply", "floats 0.1 -0.2 0.3", "--exit-after", "1"])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut lines = BufReader::new(listen.stdout.take().unwrap()).lines();
    let first = lines.next().unwrap().unwrap();
    let addr = first
        .strip_prefix("listening on ")
        .expect(&first)
        .to_string();
    let script = "# a vision request\nsocket_send_line(\"shoot\")\npose = socket_read_ascii_float(3)\nsocket_set_var(\"A\", 7)\nx = socket_get_var(\"A\")\nsocket_close()\n";
    let robot = ursock()
        .args(["robot", "--connect", &addr])
        .args(["-e", script])
        .output()
        .unwrap();
    let robot_out = String::from_utf8_lossy(&robot.stdout);
    assert!(
        robot.status.success(),
        "{}",
        String::from_utf8_lossy(&robot.stderr)
    );
    assert!(
        robot_out.contains("pose = socket_read_ascii_float(3) -> [3, 0.1, -0.2, 0.3]"),
        "{robot_out}"
    );
    assert!(
        robot_out.contains("x = socket_get_var(\"A\") -> 7"),
        "{robot_out}"
    );
    assert!(listen.wait().unwrap().success());
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    let log = rest.join("\n");
    assert!(log.contains("= \"shoot\""), "{log}");
    assert!(
        log.contains("28 30 2E 31 2C 2D 30 2E 32 2C 30 2E 33 29"),
        "{log}"
    );
    assert!(log.contains("closed"), "{log}");
}

/// Issue 10: `decode` is a map over the core's format registry. The value-line decoder
/// and its error offsets are the core's (byte 6, also after a CR and after earlier
/// lines), float text is the robot's own `to_str` form, and `--delimiter` takes the same
/// escapes as `--escapes`.
#[test]
fn decode_uses_the_core_registry_and_writer() {
    for input in [&b"p[1,2,x,4,5,6]\r\n"[..], b"p[1,2,x,4,5,6]\n"] {
        let (success, _, err) = run(&["decode", "value"], input);
        assert!(!success);
        assert!(err.contains("at byte 6"), "{input:?}: {err}");
    }
    let (success, out, err) = run(&["decode", "value"], b"[1]\np[1,2,x]\n[2]\n");
    assert!(!success);
    assert_eq!(out, "[1]\n[2]\n");
    assert!(err.contains("at byte 10"), "{err}");
    assert_eq!(
        ok(
            &["decode", "value"],
            b"p[0.1, 0.2, 0.3, 0, 3.14159265, 0]\n"
        ),
        "p[0.1, 0.2, 0.3, 0, 3.141593, 0]\n"
    );
    assert_eq!(
        ok(
            &["decode", "delimiter", "--delimiter", "\\x03"],
            b"a\x03b\x03"
        ),
        "\"a\"\n\"b\"\n"
    );
    let (success, _, err) = run(&["decode", "delimiter", "--delimiter", "\\q"], b"");
    assert!(
        !success && err.contains("--delimiter") && err.contains("unknown escape"),
        "{err}"
    );
    // The same escapes in `encode --escapes`.
    assert_eq!(
        ok(
            &["encode", "string", "a\\x03\\0", "--escapes", "--hex"],
            b""
        ),
        "61 03 00\n"
    );
}
