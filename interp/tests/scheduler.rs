//! The scheduler in virtual time: thread order, time consumption, blocking reads.
mod common;
use std::time::Duration;

use common::{messages, Harness};
use urscript_interp::{Config, Event, Machine, Program, State};

#[test]
fn blocking_read_thread_interleaves_with_a_sync_loop() {
    let src = r#"
global ticks = 0
global got = "none"
global got_at = -1
thread reader():
  got = socket_read_line("srv", timeout=0)
  got_at = ticks
end
socket_open("127.0.0.1", 6000, "srv")
run reader()
while ticks < 100:
  ticks = ticks + 1
  sync()
end
textmsg(got, got_at)
"#;
    let mut h = Harness::new(src, Config::default());
    let mut sent = false;
    h.run(Duration::from_secs(1), |input| match input {
        // The server answers at 50 ms: the reader resumes at the next step while the
        // main loop kept counting every 2 ms.
        common::Input::Tick(t) if t >= Duration::from_millis(50) && !sent => {
            sent = true;
            vec![("srv".into(), b"hello\n".to_vec())]
        }
        _ => Vec::new(),
    });
    assert_eq!(h.m.state(), &State::Finished);
    // socket_open returns at step 1; from there step k makes ticks = k. The bytes are
    // fed before step 25 (50 ms) runs; the reader runs after the main program in that
    // step and sees ticks = 25.
    assert_eq!(h.messages, ["hello25"]);
    // ticks reaches 100 at step 100; the loop ends at step 101.
    assert_eq!(h.now, Duration::from_millis(202));
}

#[test]
fn threads_run_in_start_order_after_the_main_program_each_step() {
    let src = "global log = \"\"\nthread a():\n  while True:\n    log = str_cat(log, \"a\")\n    sync()\n  end\nend\nthread b():\n  while True:\n    log = str_cat(log, \"b\")\n    sync()\n  end\nend\nrun b()\nrun a()\ni = 0\nwhile i < 3:\n  log = str_cat(log, \"M\")\n  i = i + 1\n  sync()\nend\ntextmsg(log)\n";
    // Step 0: M then b then a (started this step, after main ran up to its sync).
    assert_eq!(messages(src), ["MbaMbaMba"]);
}

#[test]
fn poll_timeout_reports_the_next_wake() {
    let p = Program::parse(
        "sleep(0.5)\nsocket_open(\"h\", 1, \"s\")\nx = socket_read_line(\"s\", timeout=1.0)\n",
    )
    .unwrap();
    let mut m = Machine::new(p, Config::default());
    assert_eq!(m.poll_timeout(), Some(Duration::ZERO));
    m.run_until(Duration::ZERO);
    assert_eq!(m.poll_timeout(), Some(Duration::from_millis(500)));
    // Nothing due before 500 ms.
    m.run_until(Duration::from_millis(499));
    assert!(m.poll_event().is_none());
    m.run_until(Duration::from_millis(500));
    assert!(matches!(m.poll_event(), Some(Event::Connect { .. })));
    // Waiting for the connection: only an input can wake it.
    assert_eq!(m.poll_timeout(), None);
    m.handle_connected("s", Ok(()));
    assert_eq!(m.poll_timeout(), Some(Duration::from_millis(502)));
    m.run_until(Duration::from_millis(502));
    // The read's deadline, one second later.
    assert_eq!(m.poll_timeout(), Some(Duration::from_millis(1502)));
    m.handle_received("s", b"x\n");
    assert_eq!(m.poll_timeout(), Some(Duration::from_millis(504)));
    m.run_until(Duration::from_millis(504));
    assert_eq!(m.state(), &State::Finished);
    assert_eq!(m.poll_timeout(), None);
}

#[test]
fn run_until_skips_idle_steps_quickly() {
    // An hour of sleeping is a handful of wakes, not 1.8 million steps.
    let p = Program::parse("sleep(3600)\ntextmsg(\"awake\")\n").unwrap();
    let mut m = Machine::new(p, Config::default());
    let t = std::time::Instant::now();
    m.run_until(Duration::from_secs(3601));
    assert!(t.elapsed() < Duration::from_secs(1));
    assert!(matches!(m.poll_event(), Some(Event::Message(msg)) if msg.text == "awake"));
}

#[test]
fn statement_bound_is_configurable() {
    let p = Program::parse("i = 0\nwhile i < 1000:\n  i = i + 1\nend\n").unwrap();
    let mut m = Machine::new(
        p.clone(),
        Config {
            max_statements_per_step: 500,
            ..Config::default()
        },
    );
    // 1000 iterations of two statements: five slices of 500, one step each.
    m.run_until(Duration::from_millis(6));
    assert_eq!(m.state(), &State::Running);
    m.run_until(Duration::from_millis(8));
    assert_eq!(m.state(), &State::Finished);
    let mut m = Machine::new(p, Config::default());
    m.run_until(Duration::ZERO);
    assert_eq!(m.state(), &State::Finished);
}

#[test]
fn a_runtime_error_in_a_thread_stops_the_program() {
    let src = "thread bad():\n  sync()\n  x = [1][5]\nend\nrun bad()\nwhile True:\n  sync()\nend\n";
    let mut h = Harness::new(src, Config::default());
    h.run_silent(Duration::from_secs(1));
    assert_eq!(
        h.m.state().clone(),
        State::Error(match h.m.state() {
            State::Error(e) => e.clone(),
            _ => unreachable!(),
        })
    );
    let State::Error(e) = h.m.state() else {
        panic!()
    };
    assert_eq!(
        e.to_string(),
        "line 3: index out of range: index 5, length 1"
    );
    assert_eq!(h.now, Duration::from_millis(2));
}

#[test]
fn killing_a_thread_blocked_in_a_read_frees_the_socket() {
    let src = "thread r():\n  socket_read_line(\"s\", timeout=0)\nend\nsocket_open(\"h\", 1, \"s\")\nt = run r()\nsync()\nkill t\nx = socket_read_line(\"s\", timeout=0.01)\ntextmsg(str_len(x))\n";
    let mut h = Harness::new(src, Config::default());
    h.run_silent(Duration::from_secs(1));
    assert_eq!(h.m.state(), &State::Finished);
    assert_eq!(h.messages, ["0"]);
}

#[test]
fn starting_threads_without_end_is_bounded() {
    let src = "thread t():\n  while True:\n    sync()\n  end\nend\nwhile True:\n  run t()\nend\n";
    let mut h = Harness::new(src, Config::default());
    h.run_silent(Duration::from_secs(1));
    let State::Error(e) = h.m.state() else {
        panic!("{:?}", h.m.state())
    };
    assert_eq!(
        e.to_string(),
        "line 7: `run t()`: more than 64 threads running"
    );
}

#[test]
fn machine_is_send_and_reports_time_and_sockets() {
    fn assert_send<T: Send>() {}
    assert_send::<Machine>();
    assert_send::<Program>();
    let p = Program::parse("socket_open(\"h\", 1, \"a\")\nsleep(0.1)\n").unwrap();
    let mut m = Machine::new(p, Config::cb3());
    m.run_until(Duration::ZERO);
    m.handle_connected("a", Ok(()));
    m.run_until(Duration::from_millis(8));
    assert_eq!(m.open_sockets(), ["a"]);
    assert_eq!(m.now(), Duration::from_millis(16));
    m.run_until(Duration::from_secs(1));
    assert_eq!(m.state(), &State::Finished);
    assert!(m.open_sockets().is_empty());
}

/// `socket_open` is a blocking call: however soon the connection is up, it returns in the
/// step after its call at the earliest, so successive opens happen in successive steps
/// (a server that accepts each connection in a thread of its own has that step to).
#[test]
fn successive_socket_opens_take_a_step_each() {
    let p = Program::parse(
        "socket_open(\"h\", 1, \"a\")\nsocket_open(\"h\", 2, \"b\")\ntextmsg(\"both\")\n",
    )
    .unwrap();
    let mut m = Machine::new(p, Config::default());
    let connects = |m: &mut Machine| {
        std::iter::from_fn(|| m.poll_event())
            .filter(|e| matches!(e, Event::Connect { .. }))
            .count()
    };
    m.run_until(Duration::ZERO);
    assert_eq!(connects(&mut m), 1);
    // Answered at once: the program still waits for the next step.
    m.handle_connected("a", Ok(()));
    m.run_until(Duration::ZERO);
    assert_eq!(
        connects(&mut m),
        0,
        "the second open ran in the first's step"
    );
    assert_eq!(m.poll_timeout(), Some(Duration::from_millis(2)));
    m.run_until(Duration::from_millis(2));
    assert_eq!(connects(&mut m), 1);
    m.handle_connected("b", Ok(()));
    m.run_until(Duration::from_millis(4));
    assert_eq!(m.state(), &State::Finished);
}
