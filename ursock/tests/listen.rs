//! `ursock listen` as a debug assistant: every listen defect of issues 12 and 14 (each
//! test fails on the thread-per-connection listener) and every new option. Loopback only.

mod listen_common;

use std::io::{Read, Write};
use std::time::Duration;

use listen_common::{ask, read_line, read_n, robot, Listener, TempFile};

#[test]
fn reply_without_decode_is_sent() {
    // Issue 12: `--reply` without `--decode` never replied and said nothing.
    let l = Listener::start(&["--reply", "floats 1 2 3"]);
    let mut s = robot(&l.addr);
    s.write_all(b"shoot\n").unwrap();
    assert_eq!(read_n(&mut s, 7), b"(1,2,3)");
}

#[test]
fn get_is_answered_from_set_without_decode() {
    // Issue 12: GET was not answered from SET without `--decode var`.
    let l = Listener::start(&[]);
    let mut s = robot(&l.addr);
    s.write_all(b"SET A 7\nGET A\n").unwrap();
    assert_eq!(read_line(&mut s), "A 7\n");
}

#[test]
fn variables_belong_to_the_server() {
    // Issue 12: a value SET by one connection read back as 0 from the next.
    let l = Listener::start(&["--decode", "var"]);
    {
        let mut s = robot(&l.addr);
        s.write_all(b"SET POS_X 1234\n").unwrap();
        s.write_all(b"GET POS_X\n").unwrap();
        assert_eq!(read_line(&mut s), "POS_X 1234\n");
    }
    assert_eq!(ask(&l.addr, "GET POS_X\n"), "POS_X 1234\n");
    let help = std::process::Command::new(listen_common::bin())
        .args(["listen", "--help"])
        .output()
        .unwrap();
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(
        help.contains("shared by\n") || help.contains("shared by every"),
        "{help}"
    );
}

#[test]
fn unknown_variable_is_answered_and_said() {
    let l = Listener::start(&["--decode", "var"]);
    assert_eq!(ask(&l.addr, "GET NEVER_SET\n"), "NEVER_SET 0\n");
    l.wait_for("unknown variable NEVER_SET (never SET), answered 0", false);
}

#[test]
fn non_ascii_variable_name_gets_a_diagnostic() {
    // Issue 14 #11: `GET café` got no reply and no diagnostic.
    for decode in [&["--decode", "var"][..], &["--decode", "line"][..], &[][..]] {
        let l = Listener::start(decode);
        let mut s = robot(&l.addr);
        s.write_all("GET café\n".as_bytes()).unwrap();
        let err = l.wait_for("non-ASCII", true);
        assert!(err.contains("GET café"), "{err}");
    }
}

#[test]
fn exit_after_zero_exits() {
    // Issue 12: `--exit-after 0` never exited.
    let mut l = Listener::start(&["--exit-after", "0"]);
    assert!(l.wait_exit().success());
}

#[test]
fn exit_after_counts_robots_that_left() {
    let mut l = Listener::start(&["--exit-after", "2"]);
    drop(robot(&l.addr));
    drop(robot(&l.addr));
    assert!(l.wait_exit().success());
    l.wait_for_n("closed (", 2, false);
}

#[test]
fn typed_reply_with_no_robot_is_refused_and_said() {
    // Issue 12: reply specs typed with no robot connected were dropped silently.
    let mut l = Listener::start(&[]);
    l.type_line("floats 1 2 3");
    l.wait_for("no robot connected; nothing sent", true);
}

#[test]
fn typed_reply_is_addressed_with_at_n() {
    // Issue 12: typed replies were broadcast to every robot.
    let mut l = Listener::start(&[]);
    let mut a = robot(&l.addr);
    l.wait_for("[#1]", false);
    let mut b = robot(&l.addr);
    l.wait_for("[#2] ", false);
    l.type_line("line hello");
    l.wait_for("say which, e.g. @1 line hello", true);
    l.type_line("@2 line hi  there");
    assert_eq!(read_line(&mut b), "hi  there\n");
    l.type_line("@1 hex 02 41 03");
    assert_eq!(read_n(&mut a, 3), [2, 0x41, 3]);
    l.type_line("@1 text OK\\r\\n");
    assert_eq!(read_n(&mut a, 4), b"OK\r\n");
    let out = l.wait_for("-> 4 ", false);
    assert!(out.contains("4F 4B 0D 0A  \"OK\\r\\n\""), "{out}");
    assert!(out.contains("02 41 03  \"\\x02A\\x03\""), "{out}");
    l.type_line("list");
    let out = l.wait_for("#2 127.0.0.1:", false);
    assert!(out.contains("2 connected; 0 variables"), "{out}");
    assert!(
        out.contains("#1 127.0.0.1:") && out.contains("tx 7 B"),
        "{out}"
    );
    l.type_line("close 1");
    let mut buf = [0u8; 8];
    assert_eq!(a.read(&mut buf).unwrap(), 0, "connection 1 closed");
    l.wait_for("[#1]", false);
    let out = l.wait_for("closed (closed by the operator): rx 0 B, tx 7 B", false);
    assert!(out.contains("closed by the operator"));
    l.type_line("@9 line x");
    l.wait_for("no connection #9", true);
    l.type_line("floats 1 x");
    l.wait_for("not a valid float", true);
}

#[test]
fn closed_stdout_exits_quietly() {
    // Issue 12: under listen every connection thread panicked on a closed stdout while
    // the listener ran on.
    let mut child = std::process::Command::new(listen_common::bin())
        .args([
            "listen",
            "--bind",
            "127.0.0.1",
            "--port",
            "0",
            "--decode",
            "line",
        ])
        .stdin(std::process::Stdio::piped())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdout = child.stdout.take().unwrap();
    let mut first = [0u8; 64];
    let n = stdout.read(&mut first).unwrap();
    let text = String::from_utf8_lossy(&first[..n]).to_string();
    let addr = text
        .trim()
        .strip_prefix("listening on ")
        .unwrap()
        .to_string();
    drop(stdout);
    let mut s = robot(&addr);
    for _ in 0..3 {
        let _ = s.write_all(b"hello\n");
        std::thread::sleep(Duration::from_millis(50));
    }
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(st) = child.try_wait().unwrap() {
            break st;
        }
        assert!(
            start.elapsed() < listen_common::WAIT,
            "listener kept running"
        );
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut err = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut err)
        .unwrap();
    assert!(status.success(), "{status:?} {err}");
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn json_events_are_one_object_a_line() {
    let l = Listener::start(&["--json", "--decode", "line", "--reply", "line ok"]);
    let mut s = robot(&l.addr);
    s.write_all("café\n".as_bytes()).unwrap();
    assert_eq!(read_line(&mut s), "ok\n");
    s.write_all(&[0xE9, b'\n']).unwrap();
    assert_eq!(read_line(&mut s), "ok\n");
    drop(s);
    let out = l.wait_for("\"close\"", false);
    let events: Vec<serde_json::Value> = out
        .lines()
        .map(|l| serde_json::from_str(l).unwrap_or_else(|e| panic!("{e}: {l}")))
        .collect();
    let kinds: Vec<&str> = events
        .iter()
        .map(|e| e["event"].as_str().unwrap())
        .collect();
    for k in ["listening", "connect", "rx", "decoded", "tx", "close"] {
        assert!(kinds.contains(&k), "{kinds:?}");
    }
    let rx: Vec<&serde_json::Value> = events.iter().filter(|e| e["event"] == "rx").collect();
    assert_eq!(
        rx[0]["bytes"],
        serde_json::json!({"encoding": "utf-8", "text": "café\n"})
    );
    assert_eq!(
        rx[1]["bytes"],
        serde_json::json!({"encoding": "hex", "hex": "e90a"})
    );
    assert_eq!(rx[0]["len"], 6);
    assert_eq!(rx[0]["conn"], 1);
    let decoded = events.iter().find(|e| e["event"] == "decoded").unwrap();
    assert_eq!(
        decoded["message"],
        serde_json::json!({"type": "line", "value": {"encoding": "utf-8", "text": "café"}})
    );
    assert_eq!(decoded["text"], "\"café\"");
    let tx = events.iter().find(|e| e["event"] == "tx").unwrap();
    assert_eq!(tx["origin"], "reply");
    assert_eq!(tx["bytes"]["text"], "ok\n");
    // One time field (`t`, seconds, rounded to the microsecond) and the wall clock.
    let mut last = 0.0;
    for e in &events {
        let t = e["t"].as_f64().unwrap_or_else(|| panic!("no t: {e}"));
        assert!(t >= last, "{e}");
        assert_eq!((t * 1e6).round() / 1e6, t, "{e}");
        last = t;
        assert!(e["time"].is_string(), "{e}");
    }
}

#[test]
fn long_chunks_are_wrapped_with_offsets_and_utf8_shown_as_text() {
    let l = Listener::start(&["--decode", "line"]);
    let mut s = robot(&l.addr);
    let long = format!("{}é\n", "x".repeat(40));
    s.write_all(long.as_bytes()).unwrap();
    let out = l.wait_for("0020  ", false);
    assert!(out.contains("(43 bytes)"), "{out}");
    assert!(out.contains("0010  78 78"), "{out}");
    assert!(
        out.contains(&format!("text \"{}é\\n\"", "x".repeat(40))),
        "{out}"
    );
    // Timestamps: relative and wall clock on every traffic line.
    let line = out.lines().find(|l| l.contains("<- 43")).unwrap();
    assert!(
        line.contains("[#1] +") && line.contains("s ") && line.matches(':').count() >= 2,
        "{line}"
    );
}

#[test]
fn log_file_holds_the_session_and_counters_are_shown() {
    let dir = std::env::temp_dir().join(format!("ursock-listen-log-{}", std::process::id()));
    let _ = std::fs::create_dir_all(&dir);
    let path = dir.join("session.log");
    let l = Listener::start(&[
        "--decode",
        "line",
        "--reply",
        "line OK",
        "--log",
        path.to_str().unwrap(),
    ]);
    assert_eq!(ask(&l.addr, "ping\n"), "OK\n");
    l.wait_for("closed (robot closed): rx 5 B, tx 3 B", false);
    let log = std::fs::read_to_string(&path).unwrap();
    assert!(
        log.contains("= \"ping\"") && log.contains("-> 3") && log.contains("rx 5 B, tx 3 B"),
        "{log}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn rules_emulate_a_camera() {
    let rules = TempFile::new(
        "camera.rules",
        "# a camera\ntrigger => floats 0.5 -0.25\njob * => line OK\nst?tus => hex 06\n",
    );
    let l = Listener::start(&[
        "--decode",
        "line",
        "--rules",
        rules.path(),
        "--reply",
        "line ?",
    ]);
    let mut s = robot(&l.addr);
    s.write_all(b"trigger\n").unwrap();
    assert_eq!(read_n(&mut s, 11), b"(0.5,-0.25)");
    s.write_all(b"job 42\n").unwrap();
    assert_eq!(read_line(&mut s), "OK\n");
    s.write_all(b"status\n").unwrap();
    assert_eq!(read_n(&mut s, 1), [6]);
    s.write_all(b"other\n").unwrap();
    assert_eq!(read_line(&mut s), "?\n");
    l.wait_for("rule 3 (job *) matched", false);
    // A bad rules file fails at start, one line on stderr.
    let bad = std::process::Command::new(listen_common::bin())
        .args(["listen", "--port", "0", "--rules", "/nonexistent/rules"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).starts_with("ursock: --rules"));
}

#[test]
fn says_why_the_robots_float_read_fails() {
    let mut l = Listener::start(&["--robot-reads", "ascii-float:2"]);
    let s = robot(&l.addr);
    l.wait_for("[#1]", false);
    for (typed, why) in [
        ("line [0.1, 0.2]", "str(list)"),
        ("line [0.1 0.2]", "str(array)"),
        ("string (0,15;0,5)", "decimal commas"),
        ("line 0.1,0.2", "no parentheses"),
        (
            "floats 1 2 3",
            "3 values arrived where the read asked for 2",
        ),
        ("line np.float64(0.1)", "numpy 2"),
    ] {
        l.type_line(typed);
        let err = l.wait_for(why, true);
        assert!(
            err.contains("would return [0, nan, nan]") || why.starts_with('3'),
            "{typed}: {err}"
        );
    }
    let _ = s.set_read_timeout(Some(Duration::from_millis(10)));
    // A leftover LF in front of a binary read.
    let mut l = Listener::start(&["--robot-reads", "binary-integer:1"]);
    let _s2 = robot(&l.addr);
    l.wait_for("[#1]", false);
    l.type_line("floats-lf 1 2");
    l.type_line("int32 5");
    l.wait_for("a leftover LF", true);
    // Without --robot-reads, number-like text is still checked.
    let mut l = Listener::start(&[]);
    let _s3 = robot(&l.addr);
    l.wait_for("[#1]", false);
    l.type_line("line [0.1, 0.2, 0.3]");
    let err = l.wait_for("str(list)", true);
    assert!(
        err.contains("socket_read_ascii_float(3) would return [0, nan, nan, nan]"),
        "{err}"
    );
    drop(s);
}

#[test]
fn max_connections_refuses_beyond_and_says_it_once() {
    // With eviction off (--evict-idle 0), a full table refuses new connections.
    let l = Listener::start(&["--max-connections", "2", "--evict-idle", "0", "-q"]);
    let _a = robot(&l.addr);
    let _b = robot(&l.addr);
    l.wait_for("[#2]", false);
    for _ in 0..5 {
        let mut c = robot(&l.addr);
        let mut buf = [0u8; 4];
        // Accepted and closed at once: end of stream (or a reset).
        assert!(matches!(c.read(&mut buf), Ok(0) | Err(_)));
    }
    let err = l.wait_for("refused connection", true);
    assert_eq!(err.matches("refused connection").count(), 1, "{err}");
    drop(_a);
    l.wait_for("[#1]", false);
    l.wait_for("closed (", false);
    assert_eq!(ask(&l.addr, "GET Z\n"), "Z 0\n");
    l.wait_for("connections were refused", true);
}

#[test]
fn odd_typed_input_is_refused_without_panicking() {
    let mut l = Listener::start(&[]);
    let mut s = robot(&l.addr);
    l.wait_for("[#1]", false);
    for typed in [
        "line\u{3000}x",
        "hex 0",
        "hex zz",
        "text \\q",
        "@",
        "@x line a",
        "nope 1",
        "close 77",
    ] {
        l.type_line(typed);
    }
    l.type_line("line\u{3000}done");
    // Only the two good lines reach the robot; the process is alive and said why for the rest.
    assert_eq!(read_line(&mut s), "x\n");
    assert_eq!(read_line(&mut s), "done\n");
    let err = l.wait_for("close 77: no such connection", true);
    for why in [
        "whole bytes",
        "not hexadecimal",
        "unknown escape",
        "expected a connection number",
        "unknown reply format \"nope\"",
    ] {
        assert!(err.contains(why), "{why}: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

#[test]
fn a_reply_after_the_robots_timeout_is_said() {
    let mut l = Listener::start(&["--decode", "line"]);
    let mut s = robot(&l.addr);
    s.write_all(b"shoot\n").unwrap();
    l.wait_for("= \"shoot\"", false);
    std::thread::sleep(Duration::from_millis(2300));
    l.type_line("floats 1 2");
    assert_eq!(read_n(&mut s, 5), b"(1,2)");
    let err = l.wait_for("after the robot's last message", true);
    assert!(err.contains("NEXT read"), "{err}");
    // A prompt reply says nothing.
    s.write_all(b"shoot\n").unwrap();
    l.wait_for("= \"shoot\"", false);
    l.type_line("floats 3 4");
    assert_eq!(read_n(&mut s, 5), b"(3,4)");
    assert_eq!(
        l.stderr().matches("after the robot's last message").count(),
        1
    );
}

#[test]
fn a_robot_that_stops_reading_is_dropped_after_write_timeout() {
    let reply = format!("string {}", "y".repeat(60_000));
    let l = Listener::start(&[
        "--decode",
        "line",
        "--reply",
        &reply,
        "--write-timeout",
        "0.5",
        "--max-queue",
        "100000000",
        "-q",
    ]);
    let mut s = robot(&l.addr);
    for _ in 0..400 {
        if s.write_all(b"go\n").is_err() {
            break;
        }
    }
    let err = l.wait_for("is still not written", true);
    assert!(
        err.contains("[#1]") && err.contains("--write-timeout"),
        "{err}"
    );
    // The listener goes on serving.
    assert_eq!(ask(&l.addr, "GET Q\n"), "Q 0\n");
}

#[test]
fn reply_and_rules_are_checked_once_at_start() {
    let out = listen_common::output(&["--exit-after", "0", "--reply", "line [0.1, 0.2]"]);
    assert!(out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--reply: warning:") && err.contains("str(list)"),
        "{err}"
    );
    let bad = std::process::Command::new(listen_common::bin())
        .args(["listen", "--port", "0", "--reply", "floats 1 x"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    let err = String::from_utf8_lossy(&bad.stderr);
    assert_eq!(err.lines().count(), 1, "{err}");
    assert!(err.starts_with("ursock: --reply: floats:"), "{err}");
}

/// Issue 10: `listen` checks replies with the same rules as `read` and `robot`, so every
/// read `--robot-reads` names is covered (a line read of a reply without LF too).
#[test]
fn listen_checks_replies_with_the_read_rules() {
    let run = |reply: &str, reads: &str| {
        let out = listen_common::output(&[
            "--exit-after",
            "0",
            "--robot-reads",
            reads,
            "--reply",
            reply,
        ]);
        assert!(out.status.success());
        String::from_utf8_lossy(&out.stderr).into_owned()
    };
    let err = run("string OK", "line");
    assert!(err.contains("--reply: warning: no LF"), "{err}");
    assert!(run("line OK", "line").is_empty());
    let err = run("bytes 1 2", "binary-integer:1");
    assert!(err.contains("only 2 of the 4 bytes"), "{err}");
}

#[test]
fn a_full_table_evicts_the_longest_idle_for_a_new_robot() {
    // Two connections that never send hold every slot (as a careless or hostile host
    // would); a robot that comes later is served, and the idlest is closed.
    let l = Listener::start(&["--max-connections", "2", "--evict-idle", "0.2", "-q"]);
    let mut idle_a = robot(&l.addr);
    l.wait_for("[#1]", false);
    let mut idle_b = robot(&l.addr);
    l.wait_for("[#2]", false);
    std::thread::sleep(Duration::from_millis(400));
    assert_eq!(ask(&l.addr, "GET GOOD\n"), "GOOD 0\n");
    let err = l.wait_for("evicted", true);
    assert!(
        err.contains("[#1]") && err.contains("idle longest"),
        "{err}"
    );
    // The evicted one (the first, idle longest) sees its end; the other stays.
    let mut buf = [0u8; 4];
    assert!(matches!(idle_a.read(&mut buf), Ok(0) | Err(_)));
    idle_b
        .set_read_timeout(Some(Duration::from_millis(100)))
        .unwrap();
    assert!(idle_b.read(&mut buf).is_err(), "still open");
}

#[test]
fn one_address_cannot_take_every_slot() {
    let l = Listener::start(&["--max-per-address", "2", "-q"]);
    let _a = robot(&l.addr);
    let _b = robot(&l.addr);
    l.wait_for("[#2]", false);
    let mut c = robot(&l.addr);
    let mut buf = [0u8; 4];
    assert!(matches!(c.read(&mut buf), Ok(0) | Err(_)));
    let err = l.wait_for("already open from that address", true);
    assert!(err.contains("--max-per-address 2"), "{err}");
    drop(_a);
    l.wait_for("closed (", false);
    assert_eq!(ask(&l.addr, "GET Z\n"), "Z 0\n");
}

#[test]
fn silent_peers_from_one_address_are_evicted_for_a_newcomer_from_it() {
    let l = Listener::start(&["--max-per-address", "4", "--evict-idle", "0.5", "-q"]);
    let silent: Vec<_> = (0..4).map(|_| robot(&l.addr)).collect();
    l.wait_for("[#4]", false);
    std::thread::sleep(Duration::from_millis(800));
    // The robot at that address is served, in place of the silent peer idle longest.
    assert_eq!(ask(&l.addr, "GET Z\n"), "Z 0\n");
    l.wait_for("evicted", true);
    drop(silent);
}

#[test]
fn a_log_that_cannot_be_written_is_said_once_and_the_session_goes_on() {
    if !std::path::Path::new("/dev/full").exists() {
        eprintln!("no /dev/full here: skipped");
        return;
    }
    let l = Listener::start(&["--log", "/dev/full", "--decode", "var"]);
    assert_eq!(ask(&l.addr, "SET A 1\nGET A\n"), "A 1\n");
    let err = l.wait_for("--log: write failed", true);
    assert_eq!(err.matches("--log: write failed").count(), 1, "{err}");
    assert_eq!(ask(&l.addr, "GET A\n"), "A 1\n");
}

#[test]
fn send_to_all_reaches_every_robot_and_says_so_per_robot() {
    let mut l = Listener::start(&[]);
    let mut a = robot(&l.addr);
    let mut b = robot(&l.addr);
    l.wait_for("[#2] ", false);
    // Without a target, two robots are still refused, and the message names @*.
    l.type_line("line hi");
    l.wait_for("or @* line hi for all; nothing sent", true);
    l.type_line("@* line hi");
    assert_eq!(read_line(&mut a), "hi\n");
    assert_eq!(read_line(&mut b), "hi\n");
    l.wait_for("sent 3 bytes to 2 of 2 robots (#1 #2)", false);
    l.type_line("all hex 41 0a");
    assert_eq!(read_line(&mut a), "A\n");
    assert_eq!(read_line(&mut b), "A\n");
    l.wait_for("sent 2 bytes to 2 of 2 robots (#1 #2)", false);
    // With every robot gone, there is nobody to send to.
    drop((a, b));
    l.wait_for_n("closed (", 2, false);
    l.type_line("@* line x");
    l.wait_for("no robot connected; nothing sent", true);
}

#[test]
fn send_to_all_reports_a_robot_that_got_nothing() {
    let mut l = Listener::start(&["--max-queue", "4"]);
    let mut a = robot(&l.addr);
    l.wait_for("[#1] ", false);
    l.type_line("@* line 12345678");
    l.wait_for(
        "sent 9 bytes to 0 of 1 robots; not sent to #1: larger than --max-queue 4",
        false,
    );
    l.type_line("@* line 12");
    assert_eq!(read_line(&mut a), "12\n");
}

#[test]
fn snippets_are_sent_by_name_or_number() {
    let f = TempFile::new(
        "snips.txt",
        "# camera answers\npose = floats 0.4 -0.2 0.3\nack  = text OK\\r\\n\n",
    );
    let mut l = Listener::start(&["--snippets", f.path()]);
    let mut a = robot(&l.addr);
    l.wait_for("[#1] ", false);
    l.type_line("$pose");
    assert_eq!(read_n(&mut a, 14), b"(0.4,-0.2,0.3)");
    l.type_line("@1 $2");
    assert_eq!(read_n(&mut a, 4), b"OK\r\n");
    l.type_line("$nope");
    l.wait_for(
        "$nope: no such snippet (1..2 or a name; `snippets` lists them); nothing sent",
        true,
    );
    l.type_line("snippets");
    l.wait_for("$2 ack = text OK\\r\\n", false);
    let mut b = robot(&l.addr);
    l.wait_for("[#2] ", false);
    l.type_line("@* $ack");
    assert_eq!(read_n(&mut a, 4), b"OK\r\n");
    assert_eq!(read_n(&mut b, 4), b"OK\r\n");
}

#[test]
fn a_bad_snippets_file_is_refused_naming_the_line() {
    let f = TempFile::new("bad-snips.txt", "ok = line a\n\nbad = floatz 1\n");
    let out = listen_common::output(&["--snippets", f.path()]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains(&format!(
            "--snippets {}: line 3 (bad): unknown reply format \"floatz\"",
            f.path()
        )),
        "{err}"
    );
}

#[test]
fn every_sends_periodically_until_stopped_or_the_robot_leaves() {
    let f = TempFile::new("every.txt", "tick = line T\n");
    let mut l = Listener::start(&["--snippets", f.path()]);
    let mut a = robot(&l.addr);
    l.wait_for("[#1] ", false);
    l.type_line("every 0.001 $tick");
    l.wait_for(
        "every 0.001: the period must be 0.01 to 86400 s; nothing started",
        true,
    );
    l.type_line("every 1e30 $tick");
    l.wait_for("every 1e30: the period must be 0.01 to 86400 s", true);
    l.type_line("every -1 $tick");
    l.wait_for("every -1: the period must be", true);
    l.type_line("every soon $tick");
    l.wait_for("every soon: not a number of seconds", true);
    l.type_line("every 0.5");
    l.wait_for("expected every SECONDS [@N|@*] $NAME", true);
    l.type_line("every 0.02 $tick");
    l.wait_for("job 1 started: every 0.02 s to #1: $tick", false);
    for _ in 0..3 {
        assert_eq!(read_line(&mut a), "T\n");
    }
    l.type_line("every");
    l.wait_for("job 1: every 0.02 s to #1: $tick", false);
    l.type_line("every off");
    l.wait_for("stopped 1 periodic sends", false);
    // A job bound to a robot ends when the robot leaves, and says so.
    l.type_line("every 0.02 $tick");
    l.wait_for("job 2 started", false);
    assert_eq!(read_line(&mut a), "T\n");
    drop(a);
    l.wait_for("job 2 stopped: connection #1 is gone", false);
    l.type_line("every");
    l.wait_for("no periodic sends", false);
}

/// Issue 30: `listen --robot FILE` runs a virtual robot against the listener and says
/// its moves as `ursock robot` does: a line when each starts (function, target, speed)
/// and when it ends (how, in how long).
#[test]
fn a_robot_run_by_listen_shows_its_moves() {
    let program = TempFile::new(
        "moves.script",
        "socket_send_line(\"hi\")\nmovel(p[0.3, -0.2, 0.4, 0, 3.14, 0], a=1.2, v=0.25, t=0, r=0)\nmovej([0.5, -1.5, 1, -1, 0.2, 0], t=0.5)\n",
    );
    let out = listen_common::output(&[
        "--decode",
        "line",
        "--exit-after",
        "1",
        "--robot",
        program.path(),
    ]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{text}");
    let line = |needle: &str| {
        text.lines()
            .find(|l| l.contains(needle))
            .unwrap_or_else(|| panic!("no line with {needle:?}:\n{text}"))
            .to_string()
    };
    line("= \"hi\"");
    line("line 2: movel -> p[0.3, -0.2, 0.4, 0, 3.14, 0] starts (v 0.25, a 1.2)");
    assert!(line("line 2: movel -> p[0.3, -0.2, 0.4, 0, 3.14, 0]: reached in ").ends_with(" s"));
    line("line 3: movej -> [0.5, -1.5, 1, -1, 0.2, 0] starts (v 1.05, a 1.4, t 0.5 s)");
    line("line 3: movej -> [0.5, -1.5, 1, -1, 0.2, 0]: reached in 0.5");
}
