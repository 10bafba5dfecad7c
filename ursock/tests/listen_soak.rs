//! Soak and hostile-peer tests of `ursock listen` (issue 14): many short connections with
//! threads and RSS flat, a robot that never reads beside a good one, descriptor
//! exhaustion, a SET flood against `--max-vars`. Loopback only; bounded in count and in
//! time (every wait ends); figures are printed, never compared with a clock.
//!
//! `URSOCK_SOAK_CONNECTIONS=100000 cargo test -p ursock --release --test listen_soak`
//! runs the long version.

mod listen_common;

use std::io::{Read, Write};
use std::time::Instant;

use listen_common::{ask, read_line, robot, Listener};

#[test]
fn many_short_connections_keep_threads_and_rss_flat() {
    let total: usize = std::env::var("URSOCK_SOAK_CONNECTIONS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(20_000);
    let warm_up = (total / 10).max(1);
    let l = Listener::start(&["--decode", "var", "--quiet"]);
    assert_eq!(ask(&l.addr, "SET X 42\nGET X\n"), "X 42\n");
    let start = Instant::now();
    let mut after_warm_up = (0, 0);
    for i in 0..total {
        let mut s = robot(&l.addr);
        s.write_all(b"GET X\n").unwrap();
        assert_eq!(read_line(&mut s), "X 42\n", "connection {i}");
        drop(s);
        if i + 1 == warm_up {
            after_warm_up = l.threads_and_rss();
        }
    }
    // Let the last closes be handled: one more exchange after them.
    assert_eq!(ask(&l.addr, "GET X\n"), "X 42\n");
    let end = l.threads_and_rss();
    println!(
        "{total} connections in {:.1} s: threads {} -> {}, RSS {} kB -> {} kB (after {warm_up} -> end)",
        start.elapsed().as_secs_f64(),
        after_warm_up.0,
        end.0,
        after_warm_up.1,
        end.1
    );
    assert!(
        end.0 <= after_warm_up.0 + 1,
        "threads grew: {after_warm_up:?} -> {end:?}"
    );
    assert!(
        end.1 <= after_warm_up.1 * 2 + 4096,
        "RSS grew: {after_warm_up:?} -> {end:?}"
    );
    // The old listener held one thread per connection ever made.
    assert!(end.0 < 16, "{end:?}");
}

#[test]
fn a_robot_that_never_reads_does_not_block_a_good_one() {
    let big = "x".repeat(4000);
    let reply = format!("string {big}");
    let l = Listener::start(&[
        "--decode",
        "line",
        "--reply",
        &reply,
        "--max-queue",
        "65536",
        "-q",
    ]);
    // The bad robot asks and asks and never reads.
    let bad_addr = l.addr.clone();
    let bad = std::thread::spawn(move || {
        let mut s = robot(&bad_addr);
        let burst = "go\n".repeat(100);
        for _ in 0..2000 {
            if s.write_all(burst.as_bytes()).is_err() {
                return true; // dropped by the listener
            }
        }
        // Everything fitted in the kernel's buffers: read what was queued; a dropped
        // connection ends (EOF or reset), a live one would go on for 800 MB.
        let mut sink = vec![0u8; 64 * 1024];
        let mut total = 0usize;
        loop {
            match s.read(&mut sink) {
                Ok(0) => return true,
                Ok(n) => total += n,
                Err(e)
                    if e.kind() == std::io::ErrorKind::WouldBlock
                        || e.kind() == std::io::ErrorKind::TimedOut =>
                {
                    return false
                }
                Err(_) => return true,
            }
            if total > 200 * 1024 * 1024 {
                return false;
            }
        }
    });
    l.wait_for("[#1]", false);
    let mut good = robot(&l.addr);
    let mut buf = vec![0u8; 4000];
    for _ in 0..50 {
        good.write_all(b"hi\n").unwrap();
        good.read_exact(&mut buf).unwrap();
        assert_eq!(buf, big.as_bytes());
    }
    let err = l.wait_for("not reading", true);
    assert!(err.contains("[#1]"), "{err}");
    assert!(bad.join().unwrap(), "the bad robot was never dropped");
    // The good one still gets replies after.
    good.write_all(b"hi\n").unwrap();
    good.read_exact(&mut buf).unwrap();
}

#[test]
fn descriptor_exhaustion_is_said_once_and_recovered_from() {
    let l = Listener::start_with_fd_limit(
        32,
        &[
            "--decode",
            "var",
            "--max-connections",
            "1000",
            "--max-per-address",
            "0",
            "-q",
        ],
    );
    let mut held = Vec::new();
    for _ in 0..60 {
        held.push(robot(&l.addr)); // the kernel's backlog takes them; accept runs out
    }
    let err = l.wait_for("accept failed", true);
    std::thread::sleep(std::time::Duration::from_secs(2));
    let err2 = l.stderr();
    assert_eq!(err2.matches("accept failed").count(), 1, "{err2}");
    assert!(err2.len() < 4096, "stderr grew to {} bytes", err2.len());
    assert!(
        err.contains("Too many open files") || err.contains("os error 24"),
        "{err}"
    );
    drop(held);
    assert_eq!(ask(&l.addr, "GET Y\n"), "Y 0\n");
    l.wait_for("recovered after", true);
}

#[test]
fn set_flood_against_max_vars_is_refused_and_bounded() {
    let l = Listener::start(&["--decode", "var", "--max-vars", "100", "-q"]);
    let mut s = robot(&l.addr);
    let mut batch = String::new();
    for i in 0..100_000 {
        batch.push_str(&format!("SET V{i:0>100} {i}\n"));
        if batch.len() > 64 * 1024 {
            s.write_all(batch.as_bytes()).unwrap();
            batch.clear();
        }
    }
    s.write_all(batch.as_bytes()).unwrap();
    let long = format!("SET {} 1\n", "N".repeat(200));
    s.write_all(long.as_bytes()).unwrap();
    s.write_all(format!("GET V{:0>100}\nGET V{:0>100}\n", 5, 500).as_bytes())
        .unwrap();
    assert_eq!(read_line(&mut s), format!("V{:0>100} 5\n", 5));
    assert_eq!(read_line(&mut s), format!("V{:0>100} 0\n", 500));
    // The flood took only its share (half the table): the next robot's names fit.
    let mut good = robot(&l.addr);
    good.write_all(b"SET GOOD 42\nGET GOOD\n").unwrap();
    assert_eq!(read_line(&mut good), "GOOD 42\n");
    drop(good);
    drop(s);
    let err = l.wait_for("its share", true);
    assert_eq!(err.matches("refused").count(), 1, "{err}");
    let out = l.wait_for("SETs refused", false);
    assert!(out.contains("99951 SETs refused"), "{out}");
    let (_, rss) = l.threads_and_rss();
    println!("RSS after 100,000 SETs against --max-vars 100: {rss} kB");
    assert!(rss < 64 * 1024, "{rss} kB");
}

#[test]
fn a_reply_larger_than_the_queue_is_refused_and_the_robot_stays() {
    let mut l = Listener::start(&["--max-queue", "100"]);
    let mut s = robot(&l.addr);
    l.wait_for("[#1]", false);
    l.type_line(&format!("line {}", "x".repeat(300)));
    let err = l.wait_for("not sent: larger than --max-queue 100", true);
    assert!(err.contains("reply of 301 bytes"), "{err}");
    // The robot is still served.
    l.type_line("line ok");
    assert_eq!(read_line(&mut s), "ok\n");
}

#[test]
fn a_robot_that_asks_many_times_before_reading_is_answered_every_time() {
    // 200,000 GETs written before the first read (1.8 MB in, 1.4 MB of answers: more than
    // the 1 MiB reply queue): the listener reads no faster than it can answer, the answers
    // wait in the sockets' buffers, and the robot, which then reads, gets every one.
    let l = Listener::start(&["--decode", "var", "-q"]);
    let mut s = robot(&l.addr);
    let batch = "GET GOOD\n".repeat(10_000);
    for _ in 0..20 {
        s.write_all(batch.as_bytes()).unwrap();
    }
    let mut r = std::io::BufReader::new(s);
    let mut line = String::new();
    for i in 0..200_000 {
        line.clear();
        use std::io::BufRead;
        assert!(
            r.read_line(&mut line).unwrap() > 0,
            "closed after {i} answers"
        );
        assert_eq!(line, "GOOD 0\n");
    }
}
