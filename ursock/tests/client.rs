//! `ursock client HOST:PORT` against a local device (a `TcpListener` on 127.0.0.1 in the
//! test): typed lines and `hex` lines are sent, replies are shown as `listen` shows them,
//! `--send`/`--file` send without stdin, `--every` repeats, `--max-time` ends, `--json`
//! gives events; and `listen --log` appends. Loopback only; every wait is bounded.

use std::io::{Read, Write};
use std::net::{TcpListener, TcpStream};
use std::process::{Command, Output, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

fn bin() -> &'static str {
    env!("CARGO_BIN_EXE_ursock")
}

/// A device on 127.0.0.1: accepts one connection, hands it to `serve` in a thread;
/// returns the address and what `serve` returns.
fn device<T: Send + 'static>(
    serve: impl FnOnce(TcpStream) -> T + Send + 'static,
) -> (String, mpsc::Receiver<T>) {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = l.local_addr().unwrap().to_string();
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let (s, _) = l.accept().unwrap();
        s.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
        let _ = tx.send(serve(s));
    });
    (addr, rx)
}

/// Reads exactly `n` bytes (fewer if the peer closed): never more, so what the client
/// sends next is left for the next read however TCP coalesced the writes.
fn read_n(s: &mut TcpStream, n: usize) -> Vec<u8> {
    let mut got = Vec::new();
    let mut buf = [0u8; 256];
    while got.len() < n {
        let want = (n - got.len()).min(buf.len());
        match s.read(&mut buf[..want]) {
            Ok(0) | Err(_) => break,
            Ok(k) => got.extend_from_slice(&buf[..k]),
        }
    }
    got
}

/// Runs `ursock client ADDR ARGS` with `stdin` typed, bounded by a kill after 30 s.
fn client(addr: &str, args: &[&str], stdin: &[u8]) -> Output {
    let mut child = Command::new(bin())
        .arg("client")
        .arg(addr)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut input = child.stdin.take().unwrap();
    input.write_all(stdin).unwrap();
    drop(input);
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            panic!("ursock client did not end");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.wait_with_output().unwrap()
}

fn stdout(o: &Output) -> String {
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn typed_lines_are_sent_and_replies_shown() {
    let (addr, got) = device(|mut s| {
        let req = read_n(&mut s, 6);
        s.write_all(b"(0.4,-0.2,0.3)").unwrap();
        let more = read_n(&mut s, 3);
        read_n(&mut s, 1); // open until the client closes
        (req, more)
    });
    let o = client(&addr, &["--wait", "1"], b"shoot\nhex 02 41 03\n");
    assert!(o.status.success(), "{o:?}");
    let (req, more) = got.recv_timeout(Duration::from_secs(30)).unwrap();
    assert_eq!(req, b"shoot\n");
    assert_eq!(more, [2, 0x41, 3]);
    let out = stdout(&o);
    assert!(out.contains("connected to 127.0.0.1:"), "{out}");
    assert!(out.contains("-> 6    73 68 6F 6F 74 0A"), "{out}");
    assert!(out.contains("\"shoot\\n\""), "{out}");
    assert!(out.contains("<- 14"), "{out}");
    assert!(out.contains("\"(0.4,-0.2,0.3)\""), "{out}");
    assert!(out.contains("-> 3    02 41 03"), "{out}");
    assert!(
        out.contains("closed (stdin ended): rx 14 B, tx 9 B"),
        "{out}"
    );
}

#[test]
fn escapes_eol_and_bad_lines() {
    let (addr, got) = device(|mut s| read_n(&mut s, 100));
    let o = client(
        &addr,
        &["--eol", "crlf", "--wait", "0.2"],
        b"T1\\t2\nbad\\q\nhex zz\nend\n",
    );
    assert!(o.status.success(), "{o:?}");
    assert_eq!(
        got.recv_timeout(Duration::from_secs(30)).unwrap(),
        b"T1\t2\r\nend\r\n"
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(err.contains("unknown escape \\q"), "{err}");
    assert!(err.contains("\"zz\" is not"), "{err}");
}

#[test]
fn send_and_file_without_stdin_as_json() {
    let dir = std::env::temp_dir().join(format!("ursock-client-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let file = dir.join("payload.bin");
    std::fs::write(&file, [0u8, 1, 2, 0xFF]).unwrap();
    let (addr, got) = device(|mut s| {
        let req = read_n(&mut s, 11);
        s.write_all(b"OK\n").unwrap();
        read_n(&mut s, 1); // open until the client closes
        req
    });
    let o = client(
        &addr,
        &[
            "--send",
            "GET A",
            "--send",
            "hex: 01",
            "--file",
            file.to_str().unwrap(),
            "--json",
            "--wait",
            "1",
        ],
        // Not read: --send replaces typing.
        b"never sent\n",
    );
    assert!(o.status.success(), "{o:?}");
    assert_eq!(
        got.recv_timeout(Duration::from_secs(30)).unwrap(),
        b"GET A\n\x01\x00\x01\x02\xFF"
    );
    let events: Vec<serde_json::Value> = stdout(&o)
        .lines()
        .map(|l| serde_json::from_str(l).unwrap())
        .collect();
    let kinds: Vec<&str> = events
        .iter()
        .map(|e| e["event"].as_str().unwrap())
        .collect();
    assert_eq!(
        kinds,
        ["connect", "tx", "tx", "tx", "rx", "close"],
        "{events:?}"
    );
    assert_eq!(events[4]["bytes"]["text"], "OK\n");
    assert_eq!(events[3]["bytes"]["hex"], "000102ff");
    assert_eq!(events[5]["reason"], "everything sent");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn every_repeats_until_max_time() {
    let (addr, got) = device(|mut s| {
        let mut all = Vec::new();
        let mut buf = [0u8; 64];
        while let Ok(n) = s.read(&mut buf) {
            if n == 0 {
                break;
            }
            all.extend_from_slice(&buf[..n]);
        }
        all
    });
    let start = Instant::now();
    let o = client(
        &addr,
        &["--send", "ping", "--every", "0.1", "--max-time", "1"],
        b"",
    );
    let took = start.elapsed();
    assert!(o.status.success(), "{o:?}");
    let sent = got.recv_timeout(Duration::from_secs(30)).unwrap();
    let pings = sent.windows(5).filter(|w| w == b"ping\n").count();
    assert!((5..=12).contains(&pings), "{pings} pings in {took:?}");
    assert!(took >= Duration::from_millis(900), "{took:?}");
    assert!(
        stdout(&o).contains("closed (--max-time passed)"),
        "{}",
        stdout(&o)
    );
}

#[test]
fn the_device_closing_ends_the_client() {
    let (addr, _got) = device(|mut s| {
        s.write_all(b"bye").unwrap();
    });
    // stdin stays open: only the close can end it.
    let mut child = Command::new(bin())
        .args(["client", &addr])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > Duration::from_secs(30) {
            let _ = child.kill();
            panic!("the client did not end when the device closed");
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    let o = child.wait_with_output().unwrap();
    assert!(o.status.success(), "{o:?}");
    let out = stdout(&o);
    assert!(out.contains("\"bye\""), "{out}");
    assert!(
        out.contains("closed (the device closed): rx 3 B, tx 0 B"),
        "{out}"
    );
}

#[test]
fn bad_arguments_are_one_line_errors() {
    let l = TcpListener::bind("127.0.0.1:0").unwrap();
    let addr = l.local_addr().unwrap().to_string();
    for args in [
        &["--every", "0"][..],
        &["--every", "nan"],
        &["--max-time", "-1"],
        &["--eol", "lfcr"],
        &["--send", "bad\\q"],
        &["--file", "/nonexistent/ursock-client"],
    ] {
        let o = client(&addr, args, b"");
        assert_eq!(o.status.code(), Some(1), "{args:?}: {o:?}");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.starts_with("ursock: "), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
    // Nothing listens there any more.
    drop(l);
    let o = client(&addr, &[], b"");
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    assert!(String::from_utf8_lossy(&o.stderr).contains("cannot connect"));
    let o = client("no-port-here", &[], b"");
    assert_eq!(o.status.code(), Some(1), "{o:?}");
}

#[test]
fn listen_log_appends() {
    let dir = std::env::temp_dir().join(format!("ursock-listen-log-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let log = dir.join("session.log");
    std::fs::write(&log, "an earlier session\n").unwrap();
    for round in 0..2 {
        let mut child = Command::new(bin())
            .args(["listen", "--bind", "127.0.0.1", "--port", "0", "--log"])
            .arg(&log)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .unwrap();
        let mut first = [0u8; 256];
        let n = child.stdout.as_mut().unwrap().read(&mut first).unwrap();
        let line = String::from_utf8_lossy(&first[..n]).into_owned();
        let addr = line
            .trim()
            .strip_prefix("listening on ")
            .unwrap_or_else(|| panic!("{line}"))
            .to_string();
        let mut s = TcpStream::connect(&addr).unwrap();
        s.write_all(format!("round {round}\n").as_bytes()).unwrap();
        drop(s);
        let start = Instant::now();
        while !std::fs::read_to_string(&log)
            .unwrap()
            .contains(&format!("round {round}"))
        {
            assert!(start.elapsed() < Duration::from_secs(30), "nothing logged");
            std::thread::sleep(Duration::from_millis(20));
        }
        drop(child.stdin.take()); // the end of stdin does not end listen: kill it
        let _ = child.kill();
        let _ = child.wait();
    }
    let text = std::fs::read_to_string(&log).unwrap();
    assert!(text.starts_with("an earlier session\n"), "{text}");
    assert!(
        text.contains("round 0") && text.contains("round 1"),
        "{text}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

/// Stamps in the local zone (`TZ`) with its offset, or UTC with `--utc`, as `listen`.
#[test]
fn times_are_local_with_their_offset_or_utc() {
    for (utc, suffix) in [(false, "+05:30"), (true, "Z")] {
        let (addr, _got) = device(|mut s| read_n(&mut s, 3));
        let mut cmd = Command::new(bin());
        cmd.args(["client", &addr, "--json", "--send", "hi", "--wait", "0.2"])
            .env("TZ", "XST-5:30")
            .stdin(Stdio::null());
        if utc {
            cmd.arg("--utc");
        }
        let o = cmd.output().unwrap();
        assert!(o.status.success(), "{o:?}");
        let first: serde_json::Value =
            serde_json::from_str(stdout(&o).lines().next().unwrap()).unwrap();
        let time = first["time"].as_str().unwrap();
        assert!(time.ends_with(suffix), "--utc {utc}: {time}");
    }
}
