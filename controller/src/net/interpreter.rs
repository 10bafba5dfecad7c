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

use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::time::Duration;

use urscript_interp::interpreter::{Discard, Reply, MAX_LINE};

use super::{Activity, Counts, ServerEvent, Shared, WRITE_TIMEOUT};

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
        what: "reply",
        text: text.clone(),
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
            let now = shared.now();
            shared.lock_cell().interpreter_line(conn, line, now)
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
    let mut chunk = [0u8; 4096];
    // The line so far (at most MAX_LINE bytes); `long`: the length of a line past
    // MAX_LINE being skipped to its end (its first ECHO bytes kept in `line`).
    let mut line: Vec<u8> = Vec::new();
    let mut long: Option<usize> = None;
    loop {
        if shared.stopped() {
            return "the server stopped";
        }
        let late = shared.lock_cell().interpreter_replies(conn);
        for r in &late {
            if !send(stream, conn, shared, r, tx) {
                return "write failed: the client is not reading";
            }
        }
        let n = match reader.read(&mut chunk) {
            Ok(0) => return "client closed",
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::Interrupted | ErrorKind::WouldBlock | ErrorKind::TimedOut
                ) =>
            {
                continue
            }
            Err(_) => return "read failed",
        };
        activity.touch(shared);
        *rx += n as u64;
        let mut rest = &chunk[..n];
        while !rest.is_empty() {
            let end = rest.iter().position(|&b| b == b'\n');
            let part = &rest[..end.unwrap_or(rest.len())];
            rest = match end {
                Some(i) => &rest[i + 1..],
                None => &[],
            };
            if let Some(len) = long.as_mut() {
                *len += part.len();
            } else if line.len() + part.len() > MAX_LINE {
                long = Some(line.len() + part.len());
                line.extend_from_slice(&part[..ECHO.saturating_sub(line.len()).min(part.len())]);
                line.truncate(ECHO);
            } else {
                line.extend_from_slice(part);
            }
            if end.is_some() {
                let ok = answer(stream, conn, shared, &line, long.take(), tx);
                line.clear();
                if !ok {
                    return "write failed: the client is not reading";
                }
            }
        }
    }
}
