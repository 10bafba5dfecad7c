//! "Why did the robot's read fail?": checks a reply against the read the robot will do,
//! in the server writer's terms (spec section 8: what PC-side servers really send).
//!
//! The robot's read is known from `--robot-reads` (e.g. `ascii-float:6`), or assumed to
//! be `socket_read_ascii_float` when the reply looks like numbers. The verdict comes from
//! running the library's own robot emulation on the reply bytes.

use std::time::Duration;
use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};

use super::spec::Reply;

/// `ascii-float:N`, `binary-integer:N`, `byte-list:N`, `line`.
pub fn parse_robot_reads(s: &str) -> Result<ReadCall, String> {
    let (kind, n) = match s.split_once(':') {
        Some((k, n)) => (k, Some(n)),
        None => (s, None),
    };
    let number = || -> Result<usize, String> {
        let n: usize = n
            .ok_or_else(|| format!("--robot-reads {kind}:N needs N (1-30)"))?
            .parse()
            .map_err(|_| format!("--robot-reads {s}: N must be a number 1-30"))?;
        if !(1..=30).contains(&n) {
            return Err(format!(
                "--robot-reads {s}: N must be 1-30 (the controller's limit)"
            ));
        }
        Ok(n)
    };
    Ok(match kind {
        "ascii-float" => ReadCall::AsciiFloat { number: number()? },
        "binary-integer" => ReadCall::BinaryInteger { number: number()? },
        "byte-list" => ReadCall::ByteList { number: number()? },
        "line" => ReadCall::Line,
        _ => {
            return Err(format!(
                "--robot-reads {s}: expected ascii-float:N, binary-integer:N, byte-list:N or line"
            ))
        }
    })
}

/// What the robot's `call` returns when `bytes` is all it receives before its timeout.
pub fn simulate(call: &ReadCall, bytes: &[u8]) -> Option<String> {
    let mut s = SocketConnection::new("socket_0", Policy::default());
    s.receive(bytes);
    s.start_read(call.clone(), Timeout::Forever, Duration::ZERO)
        .ok()?;
    let r = s.poll_read().or_else(|| s.give_up())?;
    Some(r.to_urscript())
}

/// A float tuple followed by a line end: the robot's float read stops at `)` and leaves
/// the LF for the next read.
pub fn ends_with_tuple_and_lf(bytes: &[u8]) -> bool {
    let t = trim_end_nul(bytes);
    t.ends_with(b")\n") || t.ends_with(b")\r\n")
}

fn trim_end_nul(mut b: &[u8]) -> &[u8] {
    while let [rest @ .., 0] = b {
        b = rest;
    }
    b
}

fn numbers(text: &str) -> Vec<&str> {
    text.split(|c: char| c == ',' || c == ';' || c.is_whitespace() || "()[]".contains(c))
        .filter(|w| !w.is_empty() && w.parse::<f64>().is_ok())
        .collect()
}

fn looks_numeric(text: &str) -> bool {
    let t = text.trim();
    (t.contains("float64(") || t.contains("array("))
        || (t.chars().any(|c| c.is_ascii_digit())
            && t.chars()
                .all(|c| "0123456789.,;:+-eE[]() \t\r\n".contains(c)))
}

/// Warnings for sending `reply` to a robot that will do `expect` (if known).
/// `after_tuple_lf`: the previous reply on this connection was a float tuple + LF.
pub fn diagnose(reply: &Reply, expect: Option<&ReadCall>, after_tuple_lf: bool) -> Vec<String> {
    let mut w: Vec<String> = leftover_lf(reply, expect, after_tuple_lf)
        .into_iter()
        .collect();
    w.extend(content(reply, expect));
    w
}

/// The one check that depends on what was sent before on the connection.
pub fn leftover_lf(
    reply: &Reply,
    expect: Option<&ReadCall>,
    after_tuple_lf: bool,
) -> Option<String> {
    let binary_read = matches!(
        expect,
        Some(ReadCall::BinaryInteger { .. } | ReadCall::ByteList { .. })
    );
    (after_tuple_lf && (reply.is_binary() || binary_read)).then(|| {
        "a leftover LF: the previous reply ended `)\\n`; socket_read_ascii_float stops at `)` \
             and leaves the LF (0A) in the robot's buffer, so this binary read starts with it \
             and every value is shifted by one byte. Send tuples without LF (`floats`, not \
             `floats-lf`) before binary replies"
            .to_string()
    })
}

/// Checks of the reply's own bytes (done once for `--reply` and rules, at start).
pub fn content(reply: &Reply, expect: Option<&ReadCall>) -> Vec<String> {
    let mut w = Vec::new();
    let text = String::from_utf8_lossy(&reply.bytes);
    let t = text.trim();
    if let Some(ReadCall::BinaryInteger { number }) = expect {
        let need = number * 4;
        if reply.bytes.len() < need {
            w.push(format!(
                "socket_read_binary_integer({number}) needs {need} bytes, this reply has {}: the \
                 robot waits for the rest and times out with [0, -1, ...]",
                reply.bytes.len()
            ));
        } else if !reply.is_binary() && looks_numeric(&text) {
            w.push(format!(
                "text digits sent to socket_read_binary_integer({number}): it reads raw 4-byte \
                 big-endian ints (`int32 ...`, Python struct.pack(\"!{number}i\", ...)), not text"
            ));
        }
    }
    let float_read = match expect {
        Some(ReadCall::AsciiFloat { number }) => Some(*number),
        None if !reply.is_float_tuple() && !reply.is_binary() && looks_numeric(&text) => {
            Some(numbers(t).len().clamp(1, 30))
        }
        _ => None,
    };
    let Some(n) = float_read else { return w };
    let before = w.len();
    if t.contains("float64(") {
        w.push(
            "`np.float64(...)` is numpy 2's repr of a value: socket_read_ascii_float cannot \
             parse it. Convert to float first: \"(\" + \",\".join(str(float(v)) for v in a) + \")\""
                .to_string(),
        );
    } else if t.starts_with('[') || t.starts_with("array(") {
        if t.contains(',') {
            w.push(
                "`[...]` is Python str(list): socket_read_ascii_float needs a tuple in \
                 parentheses, `(0.1,0.2)`; send `floats ...` or format \"(\" + \",\".join(...) + \")\""
                    .to_string(),
            );
        } else {
            w.push(
                "`[0.1 0.2]` is numpy str(array): no parentheses and no commas; \
                 socket_read_ascii_float needs `(0.1,0.2)` (send a.tolist() formatted as a tuple)"
                    .to_string(),
            );
        }
    } else if t.contains(';') || has_decimal_comma(t) {
        w.push(
            "decimal commas (`0,15;0,5`, a locale's number format): the robot reads `,` as the \
             separator between values; format numbers with `.` (invariant culture) and separate \
             them with `,`"
                .to_string(),
        );
    } else if !t.contains('(') && looks_numeric(t) {
        w.push(
            "no parentheses: socket_read_ascii_float skips everything before `(` and waits for \
             one; wrap the values: `(0.1,0.2)`"
                .to_string(),
        );
    }
    let count = first_tuple_count(t);
    if let (Some(ReadCall::AsciiFloat { number }), Some(k)) = (expect, count) {
        if k > *number {
            w.push(format!(
                "{k} values where the robot reads {number}: socket_read_ascii_float({number}) \
                 fails on a longer tuple and consumes it ([0, nan, ...])"
            ));
        }
    }
    let call = ReadCall::AsciiFloat { number: n };
    if let Some(result) = simulate(&call, &reply.bytes) {
        let failed = result.starts_with("[0,") || result == "[0]";
        if failed || w.len() > before {
            w.push(format!(
                "the robot's socket_read_ascii_float({n}) would return {result}"
            ));
        }
    }
    w
}

/// `0,15` style numbers: a digit, a comma, a digit, with no space after commas anywhere
/// and a `;` or an odd shape. Kept conservative: only when `;` separates values or every
/// comma sits between digits and the count of digit groups is even.
fn has_decimal_comma(t: &str) -> bool {
    let b = t.as_bytes();
    let between_digits = b
        .windows(3)
        .filter(|w| w[1] == b',' && w[0].is_ascii_digit() && w[2].is_ascii_digit())
        .count();
    between_digits > 0 && t.contains(';')
}

fn first_tuple_count(t: &str) -> Option<usize> {
    let start = t.find('(')?;
    let end = start + t[start..].find(')')?;
    let inner = &t[start + 1..end];
    if inner.trim().is_empty() {
        return Some(0);
    }
    Some(inner.split(',').count())
}
