//! Issue 18, item 13: small things a careless user or a hostile input found in the
//! offline commands and `robot`'s options. Each ran wrong before.

use std::io::Write;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

/// Runs `ursock args` with `input` on stdin; (exit code, stdout, stderr). A run that does
/// not end within 60 s is killed and fails the test (it would have run forever).
fn run(args: &[&str], input: &[u8]) -> (i32, String, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_ursock"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("spawn ursock");
    let mut stdin = child.stdin.take().unwrap();
    let input = input.to_vec();
    let writer = std::thread::spawn(move || {
        let _ = stdin.write_all(&input);
    });
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(60) {
            let _ = child.kill();
            panic!("ursock {args:?} did not end");
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    writer.join().unwrap();
    let out = child.wait_with_output().unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn blank_bytes_are_not_called_nothing() {
    for input in [&b"\r\n"[..], b"\0\0\0"] {
        let (code, out, err) = run(&["read", "ascii-float", "2"], input);
        assert_eq!(code, 0);
        assert_eq!(out, "[0, nan, nan]\n");
        assert!(err.contains("only blank bytes arrived"), "{err}");
        assert!(!err.contains("nothing arrived"), "{err}");
    }
    let (_, _, err) = run(&["read", "ascii-float", "2"], b"");
    assert!(err.contains("nothing arrived"), "{err}");
}

#[test]
fn a_huge_repeat_on_an_ended_input_stops() {
    let (code, out, err) = run(
        &["read", "line", "--repeat", "18446744073709551615"],
        b"a\n",
    );
    assert_eq!(code, 0);
    assert_eq!(out, "\"a\"\n\"\"\n");
    assert!(err.contains("end of input"), "{err}");
}

#[test]
fn a_max_time_too_long_for_the_clock_means_no_limit() {
    let (code, out, err) = run(&["robot", "--max-time", "1e300", "-e", "textmsg(1)"], b"");
    assert_eq!(code, 0, "{err}");
    assert_eq!(out, "textmsg(1) -> 1\n");
    for bad in ["0", "-0.5", "NaN"] {
        let arg = format!("--max-time={bad}");
        let (code, _, err) = run(&["robot", &arg, "-e", "textmsg(1)"], b"");
        assert_ne!(code, 0);
        assert!(err.contains("above 0"), "{bad}: {err}");
    }
}

#[test]
fn every_variable_name_a_robot_can_send_decodes() {
    // A robot's string holds up to 1023 characters: a SET line with such a name is what a
    // robot can send, and `decode var` (the server side's default bound) takes it.
    let name = "N".repeat(1023);
    let (code, line, err) = run(&["encode", "--robot", "set-var", &name, "-2147483648"], b"");
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = run(&["decode", "var"], line.as_bytes());
    assert_eq!(code, 0, "{err}");
    assert_eq!(out, format!("SET {name} -2147483648\n"));
    let long = "N".repeat(1024);
    let (code, _, err) = run(&["encode", "--robot", "set-var", &long, "1"], b"");
    assert_ne!(code, 0);
    assert!(err.contains("1 to 1023"), "{err}");
}

#[test]
fn a_log_that_cannot_be_written_is_said_once_and_the_run_goes_on() {
    if !std::path::Path::new("/dev/full").exists() {
        eprintln!("no /dev/full here: skipped");
        return;
    }
    let (code, out, err) = run(
        &[
            "robot",
            "--log",
            "/dev/full",
            "-e",
            "textmsg(1)",
            "-e",
            "textmsg(2)",
        ],
        b"",
    );
    assert_eq!(code, 0, "{err}");
    assert_eq!(out, "textmsg(1) -> 1\ntextmsg(2) -> 2\n");
    assert_eq!(err.matches("--log: write failed").count(), 1, "{err}");
}

#[test]
fn a_script_that_is_not_utf8_or_ends_lines_with_cr_is_read_right() {
    let dir = std::env::temp_dir();
    let bad = dir.join(format!("ursock-bad-{}.script", std::process::id()));
    std::fs::write(&bad, b"textmsg(\"ok\")\nx = \"caf\xE9\"\n").unwrap();
    let (code, out, err) = run(&["robot", "--script", bad.to_str().unwrap()], b"");
    let _ = std::fs::remove_file(&bad);
    assert_ne!(code, 0);
    assert!(out.is_empty(), "nothing runs: {out}");
    assert!(
        err.contains("line 2, column 9: invalid UTF-8 (byte 0xe9)"),
        "{err}"
    );
    let cr = dir.join(format!("ursock-cr-{}.script", std::process::id()));
    std::fs::write(&cr, b"textmsg(\"a\")\rtextmsg(\"b\")\r").unwrap();
    let (code, out, err) = run(&["robot", "--script", cr.to_str().unwrap()], b"");
    let _ = std::fs::remove_file(&cr);
    assert_eq!(code, 0, "{err}");
    assert_eq!(out, "textmsg(\"a\") -> a\ntextmsg(\"b\") -> b\n");
}
