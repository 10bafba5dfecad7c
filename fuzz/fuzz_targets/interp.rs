#![no_main]
//! The URScript interpreter on any program text (issue 18): the input up to the first NUL
//! byte is the program (any bytes: `Program::parse_bytes`), the rest is what the servers
//! send. A program that compiles runs for a bounded number of virtual steps on a machine
//! whose sockets are simulated: every `Connect` is answered Ok (a port ending in 7 is
//! refused), every `Transmit` answered with the next chunk of the input, and each step
//! feeds a chunk to every open socket; at the end the peers close. Nothing may panic,
//! hang (statements per step and steps are bounded) or grow without bound (values are
//! bounded by `Config::max_value_size`, all the program holds by a small
//! `Config::max_memory`, events drained each step), and the machine's count of its memory
//! is never below what a recount finds.
use libfuzzer_sys::fuzz_target;
use urscript_interp::{Config, Event, Machine, Program, State};

/// Steps run per input.
const STEPS: u32 = 100;

/// Bytes the simulated servers still have to send.
struct Feed<'a> {
    rest: &'a [u8],
}

impl<'a> Feed<'a> {
    /// The next chunk: its length is the first byte (mod 32).
    fn chunk(&mut self) -> &'a [u8] {
        let Some((&n, rest)) = self.rest.split_first() else {
            return &[];
        };
        let n = usize::from(n % 32).min(rest.len());
        let (chunk, rest) = rest.split_at(n);
        self.rest = rest;
        chunk
    }
}

fuzz_target!(|data: &[u8]| {
    let (text, socket_bytes) = match data.iter().position(|&b| b == 0) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[][..]),
    };
    let Ok(program) = Program::parse_bytes(text) else {
        return;
    };
    let config = Config {
        max_statements_per_step: 1_000,
        max_value_size: 1_000,
        max_memory: 1 << 20,
        trace_all_calls: true,
        ..Config::default()
    };
    let step = config.step_time;
    let mut m = Machine::new(program, config);
    let mut feed = Feed { rest: socket_bytes };
    for k in 0..STEPS {
        if k + 1 == STEPS {
            for name in m.open_sockets() {
                m.handle_peer_closed(&name);
            }
        } else {
            for name in m.open_sockets() {
                let chunk = feed.chunk();
                m.handle_received(&name, chunk);
            }
        }
        m.run_until(step * k);
        while let Some(e) = m.poll_event() {
            match e {
                Event::Connect {
                    socket_name, port, ..
                } => {
                    let result = if port % 10 == 7 {
                        Err("refused".to_string())
                    } else {
                        Ok(())
                    };
                    m.handle_connected(&socket_name, result);
                }
                Event::Transmit { socket_name, bytes } => {
                    let _ = bytes;
                    let chunk = feed.chunk();
                    m.handle_received(&socket_name, chunk);
                }
                _ => {}
            }
        }
        if m.state() != &State::Running {
            break;
        }
        let (counted, recounted) = m.memory_audit();
        assert!(counted >= recounted, "memory count {counted} < {recounted}");
        // The next wake-up is never in the past.
        if let Some(t) = m.poll_timeout() {
            assert!(t >= step * k, "poll_timeout {t:?} before step {k}");
        }
    }
});
