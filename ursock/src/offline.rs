//! Offline commands on stdin/stdout: `encode`, `read`, `decode`.

use std::io::Read;

use urscript_socket::format::Message;
use urscript_socket::robot::{Policy, ReadCall, ReadResult, SocketConnection, Timeout};
use urscript_socket::RecvBuffer;

use crate::formats::{drain, DecodeFormat, Side};
use crate::show::hex;
use crate::{out, outln};

/// `ursock encode FORMAT VALUES... [--hex] [--escapes] [--robot]`
pub fn encode(
    format: &str,
    values: &[String],
    as_hex: bool,
    escapes: bool,
    robot: bool,
) -> Result<(), String> {
    let side = if robot { Side::Robot } else { Side::Server };
    let bytes = crate::formats::encode(side, format, values, escapes)?;
    if as_hex {
        outln!("{}", hex(&bytes));
    } else {
        out::bytes(&bytes);
    }
    Ok(())
}

/// The most bytes of a read's input kept for its diagnosis.
const DIAGNOSIS_WINDOW: usize = 4096;

/// Whether a result deserves a diagnosis: the sentinel, or fewer floats than asked.
pub fn failed(call: &ReadCall, r: &ReadResult) -> bool {
    r.is_sentinel()
        || matches!((call, r), (ReadCall::AsciiFloat { number }, ReadResult::Floats(t)) if t.count() < *number)
}

/// `ursock read CALL [ARGS] [--repeat K] [--json] [--timestamps]`: the robot's read
/// functions over stdin; the end of input acts as the read timeout. Runs the library's
/// robot emulation. Memory is bounded: stdin is read one chunk at a time, and only while
/// the emulated socket takes bytes; a read that cannot complete with a full receive
/// buffer ends as on the robot, with its sentinel (as when a timeout passes).
pub fn read(call: ReadCall, repeat: usize, json: bool, timestamps: bool) -> Result<(), String> {
    let mut socket = SocketConnection::new(
        "socket_0",
        Policy {
            receive_capacity: 1 << 20,
            ..Policy::default()
        },
    );
    let mut stdin = std::io::stdin().lock();
    let mut chunk = vec![0u8; 64 * 1024];
    // Bytes read from stdin that the socket has not taken yet: at most one chunk.
    let mut pending: Vec<u8> = Vec::new();
    let mut eof = false;
    for done in 0..repeat {
        if eof && pending.is_empty() && socket.buffered().is_empty() && done > 0 {
            // The input has ended and nothing is left: every further read would time out.
            out::note(&format!(
                "end of input: the {} remaining read(s) would all time out; stopped",
                repeat - done
            ));
            break;
        }
        // What this read sees: what was buffered before it, then what arrives.
        let mut seen: Vec<u8> =
            socket.buffered()[..socket.buffered().len().min(DIAGNOSIS_WINDOW)].to_vec();
        let note_seen = |bytes: &[u8], seen: &mut Vec<u8>| {
            let room = DIAGNOSIS_WINDOW.saturating_sub(seen.len());
            seen.extend_from_slice(&bytes[..bytes.len().min(room)]);
        };
        socket
            .start_read(call.clone(), Timeout::Forever, std::time::Duration::ZERO)
            .map_err(|e| e.to_string())?;
        let mut buffer_full = false;
        let result = loop {
            if let Some(r) = socket.poll_read() {
                break r;
            }
            if !pending.is_empty() {
                let n = socket.receive(&pending);
                note_seen(&pending[..n], &mut seen);
                pending.drain(..n);
                if n > 0 {
                    continue;
                }
                // The socket takes nothing and the read is still waiting: its receive
                // buffer is full. On the robot nothing more can arrive; the read times out.
                buffer_full = true;
                break socket.give_up().unwrap_or_else(|| call.sentinel());
            }
            if eof {
                // The end of input is the timeout: the read gets its sentinel.
                break socket.give_up().unwrap_or_else(|| call.sentinel());
            }
            match stdin.read(&mut chunk) {
                Ok(0) => eof = true,
                Ok(n) => {
                    let taken = socket.receive(&chunk[..n]);
                    note_seen(&chunk[..taken], &mut seen);
                    pending.extend_from_slice(&chunk[taken..n]);
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(format!("stdin: {e}")),
            }
        };
        let binary = matches!(
            call,
            ReadCall::BinaryInteger { .. } | ReadCall::ByteList { .. }
        );
        let mut why = if binary || failed(&call, &result) {
            crate::diagnose::diagnose(&call, &seen)
        } else {
            None
        };
        if buffer_full {
            let full = format!(
                "the 1 MiB receive buffer filled and the read could not complete{}",
                why.as_deref().map(|w| format!(": {w}")).unwrap_or_default()
            );
            why = Some(full);
        }
        let event = crate::report::Read {
            t: crate::report::now(),
            call: call.function_name().to_string(),
            result: crate::report::Value::from(&result),
            sentinel: result.is_sentinel(),
            why,
        };
        show_read(&event, json, timestamps);
    }
    Ok(())
}

/// One read's event: the JSON line, or for people the result in URScript notation
/// (prefixed by `+0.003s` with `timestamps`) and the reason on stderr.
fn show_read(event: &crate::report::Read, json: bool, timestamps: bool) {
    if json {
        outln!("{}", crate::report::Event::Read(event.clone()).to_json());
        return;
    }
    let stamp = if timestamps {
        format!("+{:.3}s ", event.t)
    } else {
        String::new()
    };
    outln!("{stamp}{}", event.result);
    if let Some(w) = &event.why {
        out::note(&format!("why: {w}"));
    }
}

/// `ursock decode FORMAT [--json] [--allow-unterminated]`: what a robot sent, one message
/// per line. Every complete message is printed; each bad stretch of input gets one line
/// on stderr and the exit status is 1. An unterminated last message (no LF, no
/// delimiter) is such a bad stretch for every format, unless `allow_unterminated`.
pub fn decode(
    format: DecodeFormat,
    delimiter: &[u8],
    json: bool,
    allow_unterminated: bool,
) -> Result<(), String> {
    let mut decoder = format.decoder(delimiter)?;
    let kind = format.text_kind();
    let mut rx = RecvBuffer::with_capacity(1 << 20);
    let mut stdin = std::io::stdin().lock();
    let mut errors = 0usize;
    let mut on = |m: Result<Message<'_>, urscript_socket::DecodeError>| match m {
        Ok(m) => {
            // One `decoded` event: the JSON line, or its text for people.
            let event = crate::report::Decoded {
                t: crate::report::now(),
                conn: None,
                message: crate::report::TypedMessage::new(&m, kind),
                text: crate::show::message_text(&m),
            };
            if json {
                outln!("{}", crate::report::Event::Decoded(event).to_json());
            } else {
                outln!("{}", event.text);
            }
        }
        Err(e) => {
            errors += 1;
            out::note(&format!("bad input: {}", crate::messages::value_error(&e)));
        }
    };
    let mut cut_off: Option<Vec<u8>> = None;
    let terminated = format.terminated();
    loop {
        let space = rx.spare();
        if space.is_empty() {
            // Cannot happen with bounded decoders below the buffer size; refuse to spin.
            return Err("input message larger than the 1 MiB buffer".into());
        }
        let n = match stdin.read(space) {
            Ok(n) => n,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => return Err(format!("stdin: {e}")),
        };
        rx.commit(n);
        if n > 0 {
            drain(&mut decoder, &mut rx, false, &mut on);
            continue;
        }
        drain(&mut decoder, &mut rx, false, &mut on);
        if terminated && !rx.is_empty() {
            if allow_unterminated {
                if format != DecodeFormat::Delimiter {
                    // The library reads lines strictly; give the last one its LF.
                    rx.extend(b"\n");
                }
                drain(&mut decoder, &mut rx, true, &mut on);
            } else {
                cut_off = Some(rx.data().to_vec());
                rx.clear();
            }
        } else {
            drain(&mut decoder, &mut rx, true, &mut on);
        }
        break;
    }
    if let Some(rest) = cut_off {
        errors += 1;
        out::note(&format!(
            "bad input: the last message was cut off before its terminator: {} ({} bytes at \
             the end of input; --allow-unterminated accepts it)",
            crate::show::quoted(&rest[..rest.len().min(80)]),
            rest.len()
        ));
    }
    if errors > 0 {
        return Err(format!("{errors} bad stretch(es) of input (see above)"));
    }
    Ok(())
}
