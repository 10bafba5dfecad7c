//! Issue 12 (and issue 14 items 5, 9, 10): `ursock` as a socket debug assistant. Each test
//! runs the built binary and failed on the code before the fix.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::Stdio;
use std::thread;
use std::time::Duration;

mod run_common;

use run_common::{run, ursock};

/// A one-connection server on 127.0.0.1 running `serve`; returns its port.
fn server(serve: impl FnOnce(TcpStream) + Send + 'static) -> u16 {
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = listener.local_addr().unwrap().port();
    thread::spawn(move || {
        if let Ok((stream, _)) = listener.accept() {
            serve(stream);
        }
    });
    port
}

fn robot(port: u16, extra: &[&str], script: &str) -> (i32, String, String) {
    let addr = format!("127.0.0.1:{port}");
    let mut args = vec!["robot", "--connect", &addr];
    args.extend_from_slice(extra);
    args.extend_from_slice(&["-e", script]);
    run(&args, b"")
}

/// Reads one line (through LF) from `s`.
fn read_line(s: &mut TcpStream) -> Vec<u8> {
    let mut line = Vec::new();
    let mut b = [0u8; 1];
    while s.read(&mut b).map(|n| n == 1).unwrap_or(false) {
        line.push(b[0]);
        if b[0] == b'\n' {
            break;
        }
    }
    line
}

#[test]
fn a_closed_stdout_ends_every_subcommand_quietly() {
    let port = server(|mut s| {
        let _ = s.read(&mut [0u8; 64]);
    });
    let addr = format!("127.0.0.1:{port}");
    let cases: Vec<(Vec<&str>, &[u8])> = vec![
        (vec!["demo"], b""),
        (vec!["encode", "int32", "1", "--hex"], b""),
        (vec!["encode", "line", "hello"], b""),
        (vec!["read", "ascii-float", "1"], b"(1)"),
        (vec!["decode", "line"], b"a\nb\n"),
        (
            vec!["robot", "--connect", &addr, "-e", "textmsg(\"x\")"],
            b"",
        ),
    ];
    for (args, input) in cases {
        let mut child = ursock()
            .args(&args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        // Close the reading end before the child writes anything.
        drop(child.stdout.take());
        let mut stdin = child.stdin.take().unwrap();
        let _ = stdin.write_all(input);
        drop(stdin);
        let out = child.wait_with_output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(0), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn decode_json_keeps_utf8_as_text_and_marks_raw_bytes_as_hex() {
    let message = |out: &str| -> String {
        let e: serde_json::Value = serde_json::from_str(out.lines().next().unwrap()).unwrap();
        assert_eq!(e["event"], "decoded");
        e["message"].to_string()
    };
    let (code, out, _) = run(&["decode", "line", "--json"], "café\n\u{7f}ok\n".as_bytes());
    assert_eq!(code, 0);
    assert_eq!(
        message(&out),
        r#"{"type":"line","value":{"encoding":"utf-8","text":"café"}}"#
    );
    let (code, out, _) = run(&["decode", "line", "--json"], b"caf\xE9\n");
    assert_eq!(code, 0);
    assert_eq!(
        message(&out),
        r#"{"type":"line","value":{"encoding":"hex","hex":"636166e9"}}"#
    );
    // Every line is valid JSON (serde_json reads it back).
    let (_, out, _) = run(&["decode", "stx-etx", "--json"], b"\x02\"q\\\x03");
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["message"]["value"]["text"], "\"q\\");
}

#[test]
fn read_and_robot_speak_json_lines() {
    let (code, out, _) = run(
        &["read", "ascii-float", "2", "--json", "--repeat", "2"],
        b"(1,2)(3,4)",
    );
    assert_eq!(code, 0);
    let lines: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    assert_eq!(lines.len(), 2);
    assert_eq!(lines[1]["result"]["values"][1], 4.0);
    assert_eq!(lines[0]["call"], "socket_read_ascii_float");
    let (_, out, _) = run(&["read", "string", "--json"], "café".as_bytes());
    let v: serde_json::Value = serde_json::from_str(out.trim()).unwrap();
    assert_eq!(v["result"]["text"], "café");

    let port = server(|mut s| {
        read_line(&mut s);
        s.write_all(b"(1.5, 2)\n").unwrap();
        let _ = s.read(&mut [0u8; 16]);
    });
    let (code, out, err) = robot(
        port,
        &["--json"],
        "socket_send_line(\"go\")\nx = socket_read_ascii_float(2)\nsocket_close()",
    );
    assert_eq!(code, 0, "{err}");
    let events: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).expect(l))
        .collect();
    let read = events
        .iter()
        .find(|e| e["call"] == "socket_read_ascii_float")
        .unwrap();
    assert_eq!(read["result"]["count"], 2);
    assert_eq!(read["line"], 2);
}

#[test]
fn connect_failures_say_why() {
    // A port nobody listens on (bound, then closed).
    let port = TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port();
    let (code, out, err) = robot(port, &[], "textmsg(\"x\")");
    assert_ne!(code, 0);
    assert!(err.contains("refused"), "{err}");
    assert!(
        out.contains(&format!(
            "socket_open(\"127.0.0.1\", {port}, \"socket_0\") -> False"
        )),
        "{out}"
    );
    let (_, _, err) = run(
        &["robot", "--connect", "127.0.0.1", "-e", "textmsg(1)"],
        b"",
    );
    assert!(err.contains("no port"), "{err}");
    let (_, _, err) = run(
        &[
            "robot",
            "--connect",
            "no-such-host.invalid:30000",
            "-e",
            "textmsg(1)",
        ],
        b"",
    );
    assert!(
        err.contains("unknown host") || err.contains("lookup"),
        "{err}"
    );
    // Inside a script, socket_open returns False, says why, and the program goes on.
    let script = format!("socket_open(\"127.0.0.1\", {port})\ntextmsg(\"goes on\")");
    let (code, out, err) = run(&["robot", "-e", &script], b"");
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("-> False") && out.contains("goes on"), "{out}");
    assert!(err.contains("refused"), "{err}");
}

#[test]
fn messages_say_what_happened() {
    let (_, _, err) = run(&["encode", "floats", "nan", "1"], b"");
    assert!(err.contains("the 1st value (index 0)"), "{err}");
    let (_, _, err) = run(&["encode", "--robot", "value", "p[1,2,3]"], b"");
    assert!(!err.contains("asked for") && err.contains("pose"), "{err}");
    let (_, _, err) = run(&["decode", "value"], b"p[1,2,3]\n");
    assert!(!err.contains("asked for"), "{err}");
    let (_, _, err) = run(&["encode", "--robot", "value", "[1, 2"], b"");
    assert!(err.contains("input ended before ']'"), "{err}");
    let (_, out, _) = run(&["--help"], b"");
    let first = out.lines().next().unwrap();
    assert!(
        first.contains("debug assistant") && !first.contains("Sans-IO"),
        "{first}"
    );
    let port = server(|mut s| {
        let _ = s.read(&mut [0u8; 16]);
    });
    let (_, out, _) = robot(port, &[], "textmsg(1)");
    assert!(
        out.starts_with(&format!(
            "socket_open(\"127.0.0.1\", {port}, \"socket_0\") -> True"
        )),
        "{out}"
    );
}

#[test]
fn like_commands_behave_alike() {
    let (code, _, err) = run(&["encode", "int32"], b"");
    assert_ne!(code, 0);
    assert!(
        err.starts_with("ursock: ") && err.lines().count() == 1,
        "{err}"
    );
    let (code, _, _) = run(&["encode", "--robot", "int"], b"");
    assert_ne!(code, 0);
    // An unterminated last message: an error for every format, accepted with the flag.
    for (args, input) in [
        (&["decode", "line"][..], &b"a\nb"[..]),
        (&["decode", "delimiter", "--delimiter", ";"], b"a;b"),
        (&["decode", "var"], b"SET A 1\nGET A"),
    ] {
        let (code, out, err) = run(args, input);
        assert_ne!(code, 0, "{args:?}");
        assert_eq!(out.lines().count(), 1, "{args:?}: {out}");
        assert!(err.contains("cut off"), "{args:?}: {err}");
        let mut relaxed = args.to_vec();
        relaxed.push("--allow-unterminated");
        let (code, out, err) = run(&relaxed, input);
        assert_eq!(code, 0, "{args:?}: {err}");
        assert_eq!(out.lines().count(), 2, "{args:?}: {out}");
    }
    let (code, out, err) = run(&["read", "ascii-float", "1", "--repeat", "0"], b"(1)");
    assert_ne!(code, 0);
    assert!(out.is_empty() && err.contains("--repeat"), "{out}{err}");
}

#[test]
fn hex_in_and_out_escapes_and_utf8_text() {
    let (code, out, _) = run(&["encode", "hex", "02", "41", "03"], b"");
    assert_eq!((code, out.as_bytes()), (0, &b"\x02A\x03"[..]));
    let (_, out, _) = run(&["encode", "--robot", "hex", "0241", "0x03", "--hex"], b"");
    assert_eq!(out, "02 41 03\n");
    let (code, _, _) = run(&["encode", "hex", "0g"], b"");
    assert_ne!(code, 0);
    let (_, out, _) = run(&["encode", "string", "OK\\r\\n", "--escapes", "--hex"], b"");
    assert_eq!(out, "4F 4B 0D 0A\n");
    let (_, out, _) = run(&["encode", "string", "OK\\r\\n", "--hex"], b"");
    assert_eq!(out, "4F 4B 5C 72 5C 6E\n");
    let (code, _, err) = run(&["encode", "string", "bad\\q", "--escapes"], b"");
    assert!(code != 0 && err.contains("unknown escape"), "{err}");
    let (_, out, _) = run(&["decode", "line"], "café\n".as_bytes());
    assert_eq!(out, "\"café\"\n");
    let (_, out, _) = run(&["read", "line"], "café\n".as_bytes());
    assert_eq!(out, "\"café\"\n");
    let (_, out, _) = run(&["read", "line"], b"caf\xE9\n");
    assert_eq!(out, "\"caf\\xE9\"\n");
}

#[test]
fn long_chunks_get_a_wrapped_hex_dump_and_trace_lines_a_time() {
    let port = server(|mut s| {
        read_line(&mut s);
        let long: Vec<u8> = (0..12_000u32).map(|i| b'a' + (i % 26) as u8).collect();
        s.write_all(&long).unwrap();
        let _ = s.read(&mut [0u8; 16]);
    });
    let (code, out, err) = robot(
        port,
        &["--trace"],
        "socket_send_line(\"go\")\nx = socket_read_byte_list(30)",
    );
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("0000  61 62 63 64 65 66 67 68  69 6A"),
        "{out}"
    );
    assert!(out.contains("0010  71 72 73"), "{out}");
    assert!(out.contains("|abcdefghijklmnop|"), "{out}");
    let longest = out.lines().map(str::len).max().unwrap();
    assert!(longest < 200, "a line of {longest} characters");
    assert!(
        out.lines().any(|l| l.trim_start().starts_with("+0.")),
        "{out}"
    );
}

#[test]
fn read_timestamps_and_robot_log() {
    let (_, out, _) = run(
        &["read", "line", "--timestamps", "--repeat", "2"],
        b"a\nb\n",
    );
    for l in out.lines() {
        let (t, rest) = l.split_once(' ').unwrap();
        assert!(t.starts_with('+') && t.ends_with('s'), "{l}");
        assert!(rest.starts_with('"'), "{l}");
    }
    let port = server(|mut s| {
        let _ = s.read(&mut [0u8; 16]);
    });
    let log = std::env::temp_dir().join(format!("ursock-log-{}.txt", std::process::id()));
    let (code, out, _) = robot(
        port,
        &["--log", log.to_str().unwrap()],
        "textmsg(\"logged\")",
    );
    assert_eq!(code, 0);
    let logged = std::fs::read_to_string(&log).unwrap();
    let _ = std::fs::remove_file(&log);
    assert!(logged.contains("textmsg(\"logged\") -> logged"), "{logged}");
    assert_eq!(logged.lines().count(), out.lines().count(), "{logged}");
}

#[test]
fn sending_to_a_server_that_closed_returns_false_and_the_script_goes_on() {
    let port = server(drop);
    let script = "sleep(0.2)\nsocket_send_line(\"a\")\nsleep(0.2)\nsocket_send_line(\"b\")\nsocket_send_int(1)\ntextmsg(\"still running\")";
    let (code, out, err) = robot(port, &[], script);
    assert_eq!(code, 0, "{err}");
    assert!(out.contains("-> False"), "{out}");
    assert!(out.contains("still running"), "{out}");
    assert!(err.contains("closed"), "{err}");
    // In --json, the reason is the event's `why`.
    let port = server(drop);
    let (code, out, _) = robot(port, &["--json"], script);
    assert_eq!(code, 0);
    let failed: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str::<serde_json::Value>(l).unwrap())
        .filter(|e| e["result"] == false)
        .collect();
    assert!(!failed.is_empty(), "{out}");
    assert!(
        failed[0]["why"].as_str().unwrap().contains("closed"),
        "{out}"
    );
}

#[test]
fn a_huge_timeout_means_forever_and_does_not_panic() {
    let port = server(|mut s| {
        read_line(&mut s);
        thread::sleep(Duration::from_millis(100));
        s.write_all(b"(1,2)\n").unwrap();
        let _ = s.read(&mut [0u8; 16]);
    });
    let (code, out, err) = robot(
        port,
        &[],
        "socket_send_line(\"go\")\nx = socket_read_ascii_float(2, timeout=1e19)",
    );
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(out.contains("-> [2, 1, 2]"), "{out}");
}

/// Runs `ursock read string --prefix > --suffix <` on 16 MiB of junk followed by `tail`,
/// written from another thread; returns (stdout, stderr, bytes written).
fn read_string_after_junk(tail: &'static [u8]) -> (String, String, usize) {
    let mut child = ursock()
        .args(["read", "string", "--prefix", ">", "--suffix", "<"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let writer = thread::spawn(move || {
        let junk = vec![b'x'; 64 * 1024];
        let mut written = 0usize;
        for _ in 0..(16 * 1024 * 1024 / junk.len()) {
            match stdin.write_all(&junk) {
                Ok(()) => written += junk.len(),
                Err(_) => break,
            }
        }
        if stdin.write_all(tail).is_ok() {
            written += tail.len();
        }
        written
    });
    let out = child.wait_with_output().unwrap();
    let written = writer.join().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        written,
    )
}

#[test]
fn a_prefix_that_never_comes_streams_through_a_bounded_buffer() {
    // The old code read all 16 MiB into memory before answering; now the bytes that
    // cannot begin the prefix are dropped as the 1 MiB receive buffer fills, as the
    // controller discards what precedes a prefix: stdin streams through.
    let (out, err, written) = read_string_after_junk(b"");
    assert_eq!(out, "\"\"\n");
    assert_eq!(written, 16 * 1024 * 1024);
    assert!(err.contains("prefix \">\" never arrived"), "{err}");
}

#[test]
fn a_reply_behind_a_junk_flood_is_still_read() {
    let (out, _, _) = read_string_after_junk(b">ok<");
    assert_eq!(out, "\"ok\"\n");
}

#[test]
fn failed_reads_are_explained_in_the_server_writers_terms() {
    for (input, n, needle) in [
        (&b"[0.1, 0.2]\n"[..], "2", "Python list, str(list)"),
        (b"[0.1 0.2]\n", "2", "numpy"),
        (b"(0,15;0,5)\n", "2", "decimal commas"),
        (b"0.1, 0.2\n", "2", "without parentheses"),
        (
            b"(1,2,3)\n",
            "2",
            "3 values arrived where the read asked for 2",
        ),
        (b"(1,2", "2", "cut off"),
    ] {
        let (code, out, err) = run(&["read", "ascii-float", n], input);
        assert_eq!(code, 0);
        assert!(out.starts_with("[0, nan"), "{out}");
        assert!(err.contains(needle), "{input:?}: {err}");
    }
    // In `robot`: a leftover LF in front of a binary read, and a late reply.
    let port = server(|mut s| {
        read_line(&mut s);
        s.write_all(b"(1,2)\n\x00\x00\x07").unwrap();
        read_line(&mut s);
        thread::sleep(Duration::from_millis(400));
        s.write_all(b"(3,4)\n").unwrap();
        let _ = s.read(&mut [0u8; 16]);
    });
    let script = "socket_send_line(\"a\")\nx = socket_read_ascii_float(2)\ny = socket_read_binary_integer(1)\nsocket_send_line(\"b\")\nz = socket_read_ascii_float(2, timeout=0.1)\nsleep(0.6)\nw = socket_read_ascii_float(2, timeout=0.5)";
    let (code, out, err) = robot(port, &[], script);
    assert_eq!(code, 0, "{err}");
    assert!(
        out.contains("y = socket_read_binary_integer(1) -> [1, 167772167]"),
        "{out}"
    );
    assert!(err.contains("line 3: why: a leftover LF"), "{err}");
    assert!(err.contains("line 5: why: nothing arrived"), "{err}");
    assert!(
        err.contains("line 7: why: this data was already waiting"),
        "{err}"
    );
    assert!(
        out.contains("w = socket_read_ascii_float(2, timeout=0.5) -> [2, 3, 4]"),
        "{out}"
    );
}
