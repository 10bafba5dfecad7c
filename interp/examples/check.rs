//! Parses a URScript file, lists the functions it calls that are not built in, and runs
//! it for a few seconds of virtual time with every `socket_open` succeeding and no server
//! ever answering (reads time out to their sentinels). Prints every event; a protective
//! stop (a move beyond the reach, `protective_stop()`) pauses the program there.
//!
//! Run: `cargo run -p urscript-interp --example check -- FILE [SECONDS]`

use std::time::Duration;

use urscript_interp::{Config, Effect, Event, Machine, Program, State};

fn main() {
    let mut args = std::env::args().skip(1);
    let Some(path) = args.next() else {
        eprintln!("usage: check FILE [SECONDS]");
        std::process::exit(2);
    };
    let secs: f64 = args.next().and_then(|s| s.parse().ok()).unwrap_or(5.0);
    let src = match std::fs::read_to_string(&path) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{path}: {e}");
            std::process::exit(2);
        }
    };
    let program = match Program::parse(&src) {
        Ok(p) => p,
        Err(e) => {
            eprintln!("{path}: {e}");
            std::process::exit(1);
        }
    };
    let mut m = Machine::new(program, Config::default());
    for (name, line) in m.unknown_functions() {
        println!("not built in: `{name}` (first called on line {line})");
    }
    let end = Duration::from_secs_f64(secs);
    let mut now = Duration::ZERO;
    while m.state() == &State::Running && now <= end {
        m.run_until(now);
        while let Some(e) = m.poll_event() {
            println!("{:>8.3}s {e:?}", now.as_secs_f64());
            if let Event::Connect { socket_name, .. } = e {
                m.handle_connected(&socket_name, Ok(()));
            }
        }
        if m.effects().contains(&Effect::ProtectiveStop) {
            // A controller pauses the program here (a move left the reach, or
            // `protective_stop()` ran); nobody resumes it.
            println!(
                "{:>8.3}s protective stop: the program is paused",
                now.as_secs_f64()
            );
            break;
        }
        now = match m.poll_timeout() {
            // One step at a time, so a protective stop is seen where it happens.
            Some(t) if t > now => t.min(now + Duration::from_millis(2)),
            Some(_) => now + Duration::from_millis(2),
            None => break,
        };
    }
    println!("{:?} at {:.3}s", m.state(), now.as_secs_f64());
    if m.effects().contains(&Effect::ProtectiveStop) || matches!(m.state(), State::Error(_)) {
        std::process::exit(1);
    }
}
