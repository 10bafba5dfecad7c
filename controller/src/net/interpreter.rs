//! The interpreter socket (30020, e-Series PolyScope 5.10+): one thread per connection
//! (at most [`MAX_INTERPRETER_CONNECTIONS`]); every line received is given to the
//! [`Cell`](crate::Cell) ([`Cell::interpreter_line`](crate::Cell::interpreter_line)) and
//! its reply written back as one line ending in `\n`, in the order the lines came.
//!
//! The wire behaviour (the `ack:`/`discard:`/`state:` lines, the commands, the bounds) is
//! [`urscript_interp::interpreter`]'s, from UR's script manual ("Interpreter Mode") and
//! UR's "Interpreter mode" support article; see there. Here:
//! - The socket accepts connections whenever the controller runs, as the manual has it
//!   accept statements whenever a program runs (statements sent before the program
//!   calls `interpreter_mode()` wait in its queue); with no program running a statement
//!   is discarded (`discard: program not running: ...`).
//! - A line longer than [`MAX_LINE`] bytes is not kept: it is read to its `\n` and
//!   answered `discard: line too long (N bytes, at most 65536): <its first 64 bytes>...`.
//! - A line held behind a `clear_interpreter()` is answered when the program has run the
//!   clear: the connection looks for such answers every [`POLL`].

use std::io::{ErrorKind, Write};
use std::net::TcpStream;
use std::time::Duration;

use urscript_interp::interpreter::{Discard, Reply, MAX_LINE};

use super::{Activity, ClientEvent, Counts, ServerEvent, Shared, WRITE_TIMEOUT};
use crate::lines::{Event, LineReader};

/// Interpreter connections served at once; more are accepted and closed at once. Each
/// is a thread; a program in interpreter mode has one client as a rule, so 16 is ample
/// and bounds what a flood of peers can take, as [`MAX_CONNECTIONS`](super::MAX_CONNECTIONS)
/// does for the dashboard.
pub const MAX_INTERPRETER_CONNECTIONS: usize = 16;

/// How often a connection with nothing to read looks for late replies (and for the
/// server stopping).
pub const POLL: Duration = Duration::from_millis(20);

/// Bytes of a too-long line echoed in its discard.
const ECHO: usize = 64;

/// One interpreter connection (accepted by [`super::accept_each`]).
pub(super) fn serve(
    mut stream: TcpStream,
    conn: u64,
    peer: String,
    shared: &Shared,
    activity: &Activity,
) {
    let _ = stream.set_nodelay(true);
    let _ = stream.set_write_timeout(Some(WRITE_TIMEOUT));
    let _ = stream.set_read_timeout(Some(POLL));
    shared.emit(ServerEvent::Connect {
        conn,
        service: "interpreter",
        peer,
    });
    let (mut rx, mut tx) = (0u64, 0u64);
    let reason = session(&mut stream, conn, shared, activity, &mut rx, &mut tx);
    let reason = activity.closed_by().unwrap_or(reason);
    super::closed(shared, conn, reason, &Counts { rx, tx });
}

/// Writes one reply line; false when the client does not take it.
fn send(stream: &mut TcpStream, conn: u64, shared: &Shared, reply: &Reply, tx: &mut u64) -> bool {
    let text = reply.to_string();
    shared.emit(ServerEvent::Client {
        conn,
        service: "interpreter",
        event: ClientEvent::Reply(reply.clone()),
    });
    let mut bytes = text.into_bytes();
    bytes.push(b'\n');
    let ok = stream
        .write_all(&bytes)
        .and_then(|()| stream.flush())
        .is_ok();
    if ok {
        *tx += bytes.len() as u64;
    }
    ok
}

/// Answers one complete line (or a too-long one, of `len` bytes, of which `line` holds
/// the first few).
fn answer(
    stream: &mut TcpStream,
    conn: u64,
    shared: &Shared,
    line: &[u8],
    too_long: Option<usize>,
    tx: &mut u64,
) -> bool {
    let reply = match too_long {
        Some(len) => Some(Reply::Discard {
            reason: Discard::LineTooLong { len },
            statement: format!("{}...", String::from_utf8_lossy(line)),
        }),
        None => {
            shared.command_turn();
            let line = line.to_vec();
            shared.ask(move |cell, now| cell.interpreter_line(conn, &line, now))
        }
    };
    match reply {
        Some(r) => send(stream, conn, shared, &r, tx),
        None => true,
    }
}

fn session(
    stream: &mut TcpStream,
    conn: u64,
    shared: &Shared,
    activity: &Activity,
    rx: &mut u64,
    tx: &mut u64,
) -> &'static str {
    let mut reader = match stream.try_clone() {
        Ok(r) => r,
        Err(_) => return "cannot read",
    };
    let mut lines = LineReader::new(MAX_LINE, ECHO);
    // The first bytes of the too-long line being dropped, answered when it ends.
    let mut long: Vec<u8> = Vec::new();
    loop {
        if shared.stopped() {
            return "the server stopped";
        }
        let late = shared.ask(move |cell, _| cell.interpreter_replies(conn));
        for r in &late {
            if !send(stream, conn, shared, r, tx) {
                return "write failed: the client is not reading";
            }
        }
        match lines.read_from(&mut reader) {
            Ok(0) => return "client closed",
            Ok(n) => *rx += n as u64,
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::Interrupted | ErrorKind::WouldBlock | ErrorKind::TimedOut
                ) =>
            {
                continue
            }
            Err(_) => return "read failed",
        }
        activity.touch(shared);
        let answered = lines.drain(|event| {
            let ok = match event {
                Event::Line(line) => answer(stream, conn, shared, line, None, tx),
                Event::TooLong(start) => {
                    long.clear();
                    long.extend_from_slice(start);
                    true
                }
                Event::LongEnded(len) => {
                    let len = usize::try_from(len).unwrap_or(usize::MAX);
                    answer(stream, conn, shared, &long, Some(len), tx)
                }
            };
            if ok {
                Ok(())
            } else {
                Err("write failed: the client is not reading")
            }
        });
        if let Err(reason) = answered {
            return reason;
        }
    }
}
