//! Issue 18, items 5 and 6: the driver keeps real time against peers that misbehave and
//! programs that fall behind. Loopback only; every run is bounded by `max_time`, and a
//! run that would never end fails the test through a join deadline.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpListener;
use std::sync::mpsc;
use std::time::Duration;

use urscript_interp::drive::{Activity, Driver, Options, Outcome};
use urscript_interp::{Config, Event, Machine, Program};

/// Runs `f` on a thread; fails the test if it has not returned after `limit`.
fn within<T: Send + 'static>(limit: Duration, f: impl FnOnce() -> T + Send + 'static) -> T {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let _ = tx.send(f());
    });
    rx.recv_timeout(limit)
        .unwrap_or_else(|_| panic!("did not end within {limit:?}"))
}

/// A loopback server that answers each line it reads with `(1,2)\n` at once; its port.
fn answering_server() -> u16 {
    let server = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = server.local_addr().unwrap().port();
    std::thread::spawn(move || {
        let (s, _) = server.accept().unwrap();
        let mut w = s.try_clone().unwrap();
        for line in BufReader::new(s).lines() {
            if line.is_err() || w.write_all(b"(1,2)\n").is_err() {
                break;
            }
        }
    });
    port
}

/// Runs `src` to its end with the driver; the texts of its `textmsg`s.
fn messages_of(src: &str, config: Config, options: Options) -> Vec<String> {
    let mut m = Machine::new(Program::parse(src).unwrap(), config);
    let mut messages = Vec::new();
    let outcome = Driver::new(options)
        .run(&mut m, |a| {
            if let Activity::Event(Event::Message(msg)) = a {
                messages.push(msg.text.clone());
            }
        })
        .unwrap();
    assert_eq!(outcome, Outcome::Finished);
    messages
}

#[test]
fn a_peer_that_never_reads_cannot_hold_the_program() {
    // The server accepts and never reads: the kernel buffers fill, then the driver's
    // bounded queue; past it the connection counts as broken and sends return False.
    let server = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = server.local_addr().unwrap().port();
    let hold = std::thread::spawn(move || {
        let (s, _) = server.accept().unwrap();
        std::thread::sleep(Duration::from_secs(20));
        drop(s);
    });
    let chunk = "x".repeat(1000);
    let src = format!(
        "socket_open(\"127.0.0.1\", {port})\nn = 0\nok = True\nwhile ok:\n  i = 0\n  while ok and i < 2000:\n    ok = socket_send_string(\"{chunk}\")\n    i = i + 1\n  end\n  n = n + 1\n  sync()\nend\ntextmsg(\"refused after \", n)\n"
    );
    let (outcome, failed, messages) = within(Duration::from_secs(120), move || {
        let mut m = Machine::new(Program::parse(&src).unwrap(), Config::default());
        let mut d = Driver::new(Options {
            max_time: Some(Duration::from_secs(60)),
            ..Options::default()
        });
        let (mut failed, mut messages) = (0, Vec::new());
        let outcome = d
            .run(&mut m, |a| match a {
                Activity::SendFailed { .. } => failed += 1,
                Activity::Event(Event::Message(msg)) => messages.push(msg.text.clone()),
                _ => {}
            })
            .unwrap();
        (outcome, failed, messages)
    });
    assert_eq!(outcome, Outcome::Finished);
    assert_eq!(failed, 1);
    assert_eq!(messages.len(), 1);
    assert!(messages[0].starts_with("refused after "), "{messages:?}");
    drop(hold);
}

#[test]
fn max_time_ends_a_program_whose_peer_stopped_reading() {
    let server = TcpListener::bind("127.0.0.1:0").unwrap();
    let port = server.local_addr().unwrap().port();
    std::thread::spawn(move || {
        let (s, _) = server.accept().unwrap();
        std::thread::sleep(Duration::from_secs(30));
        drop(s);
    });
    // Sends 100 kB a step: the kernel buffers fill within the second; the queue does not.
    let chunk = "y".repeat(1000);
    let src = format!(
        "socket_open(\"127.0.0.1\", {port})\nwhile True:\n  i = 0\n  while i < 100:\n    socket_send_string(\"{chunk}\")\n    i = i + 1\n  end\n  sync()\nend\n"
    );
    let outcome = within(Duration::from_secs(60), move || {
        let mut m = Machine::new(Program::parse(&src).unwrap(), Config::default());
        Driver::new(Options {
            max_time: Some(Duration::from_millis(500)),
            ..Options::default()
        })
        .run(&mut m, |_| {})
        .unwrap()
    });
    assert_eq!(outcome, Outcome::MaxTime);
}

#[test]
fn a_program_behind_real_time_still_gets_answers_that_came_at_once() {
    // 100 µs steps and a busy loop in each: the program runs far behind real time. Each
    // read waits 50 ms of program time for a reply the server sends at once; the driver
    // services the sockets between any two steps, so no read may time out.
    let port = answering_server();
    let src = format!(
        "socket_open(\"127.0.0.1\", {port})\nmissed = 0\nk = 0\nwhile k < 20:\n  j = 0\n  while j < 20000:\n    j = j + 1\n  end\n  socket_send_line(\"go\")\n  r = socket_read_ascii_float(2, timeout=0.05)\n  if r[0] != 2:\n    missed = missed + 1\n  end\n  k = k + 1\nend\ntextmsg(missed)\n"
    );
    let config = Config {
        step_time: Duration::from_micros(100),
        ..Config::default()
    };
    let options = Options {
        max_time: Some(Duration::from_secs(100)),
        ..Options::default()
    };
    let messages = within(Duration::from_secs(120), move || {
        messages_of(&src, config, options)
    });
    assert_eq!(
        messages,
        ["0"],
        "reads timed out although the server answered at once"
    );
}

#[test]
fn a_reply_that_arrives_while_the_driver_sleeps_reaches_the_read_at_its_deadline() {
    // A poll interval longer than the read's timeout: the driver sleeps until the read's
    // deadline. Each reply arrives long before it (the server answers at once), so every
    // read must get its reply, although the driver wakes exactly at the deadline.
    let port = answering_server();
    let src = format!(
        "socket_open(\"127.0.0.1\", {port})\nmissed = 0\nk = 0\nwhile k < 5:\n  socket_send_line(\"go\")\n  r = socket_read_ascii_float(2, timeout=0.2)\n  if r[0] != 2:\n    missed = missed + 1\n  end\n  k = k + 1\nend\ntextmsg(missed)\n"
    );
    let options = Options {
        max_time: Some(Duration::from_secs(30)),
        poll_interval: Duration::from_secs(5),
        ..Options::default()
    };
    let messages = within(Duration::from_secs(60), move || {
        messages_of(&src, Config::default(), options)
    });
    assert_eq!(messages, ["0"], "replies that had arrived were not read");
}
