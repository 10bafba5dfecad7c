//! Offline commands on stdin/stdout: `encode`, `read`, `decode`.

use std::io::{Read, Write};

use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
use urscript_socket::RecvBuffer;

use crate::formats::{encode_robot, encode_server, AnyDecoder, DecodeFormat};
use crate::show::hex;

/// `ursock encode FORMAT VALUES... [--hex] [--robot]`
pub fn encode(format: &str, values: &[String], as_hex: bool, robot: bool) -> Result<(), String> {
    let bytes = if robot {
        encode_robot(format, values)?
    } else {
        encode_server(format, values)?
    };
    let mut out = std::io::stdout().lock();
    let r = if as_hex {
        writeln!(out, "{}", hex(&bytes))
    } else {
        out.write_all(&bytes)
    };
    r.and_then(|_| out.flush())
        .map_err(|e| format!("stdout: {e}"))
}

/// `ursock read CALL [ARGS] [--repeat K]`: the robot's read functions over stdin; the end
/// of input acts as the read timeout. Runs the library's robot emulation.
pub fn read(call: ReadCall, repeat: usize) -> Result<(), String> {
    let mut socket = SocketConnection::new(
        "socket_0",
        Policy {
            receive_capacity: 1 << 20,
            ..Policy::default()
        },
    );
    let mut stdin = std::io::stdin().lock();
    let mut out = std::io::stdout().lock();
    let mut chunk = vec![0u8; 64 * 1024];
    let mut pending_input: Vec<u8> = Vec::new();
    let mut eof = false;
    for _ in 0..repeat.max(1) {
        socket
            .start_read(call.clone(), Timeout::Forever, std::time::Duration::ZERO)
            .map_err(|e| e.to_string())?;
        let result = loop {
            if let Some(r) = socket.poll_read() {
                break r;
            }
            // Offer what the buffer refused before, then read more.
            if !pending_input.is_empty() {
                let n = socket.receive(&pending_input);
                pending_input.drain(..n);
                if n > 0 {
                    continue;
                }
            }
            if eof {
                // The end of input is the timeout: the read gets its sentinel.
                break socket.give_up().unwrap_or_else(|| call.sentinel());
            }
            match stdin.read(&mut chunk) {
                Ok(0) => eof = true,
                Ok(n) => {
                    let taken = socket.receive(&chunk[..n]);
                    pending_input.extend_from_slice(&chunk[taken..n]);
                }
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(e) => return Err(format!("stdin: {e}")),
            }
        };
        writeln!(out, "{}", result.to_urscript()).map_err(|e| format!("stdout: {e}"))?;
    }
    Ok(())
}

/// `ursock decode FORMAT [--json]`: what a robot sent, one message per line. Every
/// complete message is printed; each bad stretch of input gets one line on stderr and the
/// exit status is 1.
pub fn decode(format: DecodeFormat, delimiter: &[u8], json: bool) -> Result<(), String> {
    let mut decoder = AnyDecoder::new(format, delimiter)?;
    let mut rx = RecvBuffer::with_capacity(1 << 20);
    let mut stdin = std::io::stdin().lock();
    let mut out = std::io::stdout().lock();
    let mut errors = 0usize;
    let mut write_err: Option<std::io::Error> = None;
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
        decoder.drain(&mut rx, n == 0, &mut |m| match m {
            Ok(m) => {
                let line = if json { m.json() } else { m.text() };
                if let Err(e) = writeln!(out, "{line}") {
                    write_err = Some(e);
                }
            }
            Err(e) => {
                errors += 1;
                eprintln!("ursock: bad input: {e}");
            }
        });
        if let Some(e) = write_err.take() {
            return Err(format!("stdout: {e}"));
        }
        if n == 0 {
            break;
        }
    }
    out.flush().map_err(|e| format!("stdout: {e}"))?;
    if errors > 0 {
        return Err(format!("{errors} bad stretch(es) of input (see above)"));
    }
    Ok(())
}
