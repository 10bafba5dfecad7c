//! Why a robot read failed, in the server writer's terms: the one set of rules that
//! `read`, `robot` and `listen` share.
//!
//! [`diagnose`] looks at the bytes a read saw and names the usual mistakes of PC-side
//! servers (the spec's section 8): Python `str(list)` or numpy text where a tuple was
//! expected, decimal commas, no parentheses, more values than asked, a leftover LF in
//! front of a binary read, a reply still arriving when the timeout passed. `read` and
//! `robot` give it what the read saw; `listen` gives it what the robot's next read will
//! see when a reply is sent ([`reply`]), with the read named by `--robot-reads` or guessed
//! from the reply, and adds what the library's robot emulation returns for it.

use std::time::Duration;

use urscript_socket::format::{Format, Message};
use urscript_socket::robot::{Policy, ReadCall, ReadResult, SocketConnection, Timeout};
use urscript_socket::{Decode, ErrorKind};

/// How many bytes of a reply a message quotes.
const SHOWN: usize = 40;

fn shown(bytes: &[u8]) -> String {
    let cut = &bytes[..bytes.len().min(SHOWN)];
    let mut s = crate::show::quoted(cut);
    if bytes.len() > SHOWN {
        s.push_str("...");
    }
    s
}

fn trim(bytes: &[u8]) -> &[u8] {
    let is_space = |b: &u8| matches!(b, b' ' | b'\t' | b'\r' | b'\n' | 0);
    let start = bytes
        .iter()
        .position(|b| !is_space(b))
        .unwrap_or(bytes.len());
    let end = bytes
        .iter()
        .rposition(|b| !is_space(b))
        .map_or(start, |e| e + 1);
    &bytes[start..end]
}

/// Explains, for `expected`, what is wrong with `bytes` (what the read saw: the bytes
/// buffered when it started and those that arrived until it ended). `None` when nothing
/// is recognizably wrong.
pub fn diagnose(expected: &ReadCall, bytes: &[u8]) -> Option<String> {
    match expected {
        ReadCall::AsciiFloat { number } => floats(*number, bytes),
        ReadCall::BinaryInteger { number } => binary(*number * 4, "int32", bytes),
        ReadCall::ByteList { number } => binary(*number, "byte", bytes),
        ReadCall::Line => {
            if bytes.is_empty() {
                Some("nothing arrived before the timeout".into())
            } else if !bytes.contains(&b'\n') {
                let cr = if bytes.contains(&b'\r') {
                    " (it holds a CR: the server ends lines with \\r only; end them with \\n)"
                } else {
                    ""
                };
                Some(format!(
                    "no LF (0x0A) arrived: socket_read_line needs the reply to end with \\n{cr}; got {}",
                    shown(bytes)
                ))
            } else {
                None
            }
        }
        ReadCall::String { prefix, suffix, .. } => {
            if bytes.is_empty() {
                return Some("nothing arrived before the timeout".into());
            }
            let find = |hay: &[u8], needle: &[u8]| {
                hay.windows(needle.len().max(1)).position(|w| w == needle)
            };
            let after = if prefix.is_empty() {
                bytes
            } else {
                match find(bytes, prefix) {
                    Some(i) => &bytes[i + prefix.len()..],
                    None => {
                        return Some(format!(
                            "the prefix {} never arrived, only other bytes: {}",
                            crate::show::quoted(prefix),
                            shown(bytes)
                        ))
                    }
                }
            };
            if !suffix.is_empty() && find(after, suffix).is_none() {
                return Some(format!(
                    "the suffix {} never arrived (the reply was cut off, or ends otherwise: {})",
                    crate::show::quoted(suffix),
                    shown(after)
                ));
            }
            None
        }
        _ => None,
    }
}

fn floats(number: usize, bytes: &[u8]) -> Option<String> {
    let body = trim(bytes);
    if bytes.is_empty() {
        return Some("nothing arrived before the timeout".into());
    }
    if body.is_empty() {
        return Some(format!(
            "only blank bytes arrived ({}: line ends, spaces or NULs), no tuple; \
             send the values as (1,2,3)",
            shown(bytes)
        ));
    }
    let text = String::from_utf8_lossy(body);
    let fix = "send \"(\" + \",\".join(str(v) for v in values) + \")\"";
    if text.contains("float64(") || text.contains("float32(") {
        return Some(format!(
            "numpy 2 reprs like np.float64(0.1) arrived ({}): convert with float(v) or \
             .tolist() first, then {fix}",
            shown(body)
        ));
    }
    if body[0] == b'[' {
        let inner = text.trim_start_matches('[').trim_end_matches(']');
        let what = if inner.contains(',') {
            "a Python list, str(list)"
        } else {
            "a numpy array, str(array)"
        };
        return Some(format!(
            "{what}, arrived: {}; the robot reads only a tuple in parentheses, \
             like ({}): {fix}",
            shown(body),
            inner
                .split([',', ' '])
                .filter(|v| !v.is_empty())
                .collect::<Vec<_>>()
                .join(",")
        ));
    }
    let Some(open) = body.iter().position(|&b| b == b'(') else {
        let numeric = body
            .iter()
            .all(|b| b.is_ascii_digit() || b",.-+eE ;\t".contains(b));
        return Some(if numeric {
            format!(
                "no parentheses: the values arrived without parentheses ({}); the robot skips \
                 everything before `(` and reads only `(v1,v2,...)`; {fix}",
                shown(body)
            )
        } else {
            format!(
                "no tuple arrived before the read ended, only {}",
                shown(body)
            )
        });
    };
    let Some(close) = body[open..]
        .iter()
        .position(|&b| b == b')')
        .map(|c| open + c)
    else {
        return Some(format!(
            "the tuple has no closing ')': the reply was cut off or was still arriving \
             when the timeout passed ({})",
            shown(body)
        ));
    };
    let inner = String::from_utf8_lossy(&body[open + 1..close]);
    if inner.contains(';') || decimal_commas(&inner) {
        return Some(format!(
            "decimal commas ({}): the server formats numbers with ',' as the decimal point \
             (a locale setting); format them with '.' (C#: CultureInfo.InvariantCulture, \
             C: setlocale(LC_NUMERIC, \"C\"))",
            shown(&body[open..=close])
        ));
    }
    // What the robot's read makes of the tuple: the core's decoder, not a parse here.
    let mut decoder = Format::FloatTuple { number }.decoder().ok()?;
    match decoder.decode(&body[open..=close]) {
        Ok(status) => match status.item() {
            Some(Message::FloatTuple(t)) if t.count() < number => {
                let values = t.count();
                Some(format!(
                    "{values} of the {number} values arrived: count is {values}, the other slots nan"
                ))
            }
            _ => None,
        },
        Err(e) => match e.kind() {
            ErrorKind::TooManyValues { .. } => {
                // The decoder stops at the first value too many; the fields say how many.
                let values = inner.split(',').filter(|v| !v.trim().is_empty()).count();
                Some(format!(
                    "{values} values arrived where the read asked for {number}: the robot fails the \
                     whole read; send {number} values or read {values}"
                ))
            }
            ErrorKind::InvalidNumber | ErrorKind::Empty => {
                // The field holding the byte the decoder stopped at (offsets count from `(`).
                let raw = &body[open + 1..close];
                let at = usize::try_from(e.offset())
                    .unwrap_or(usize::MAX)
                    .saturating_sub(1)
                    .min(raw.len());
                let start = raw[..at]
                    .iter()
                    .rposition(|&b| b == b',')
                    .map_or(0, |i| i + 1);
                let end = raw[at..]
                    .iter()
                    .position(|&b| b == b',')
                    .map_or(raw.len(), |i| at + i);
                let field = String::from_utf8_lossy(raw.get(start..end).unwrap_or_default());
                let bad = field.trim();
                Some(format!(
                    "{bad:?} is not a number the robot reads (plain decimal, optional exponent)"
                ))
            }
            _ => Some(format!(
                "the robot's read fails: {}",
                crate::messages::value_error(&e)
            )),
        },
    }
}

/// `(0,15, 0,5)`: every field, split on ", ", is two digit groups joined by ','.
/// (The `;` form is caught before; `(0,15,0,5)` cannot be told from four values.)
fn decimal_commas(inner: &str) -> bool {
    inner.contains(", ")
        && inner.split(", ").all(|p| {
            let parts: Vec<&str> = p.trim().split(',').collect();
            parts.len() == 2
                && parts.iter().all(|d| {
                    !d.is_empty()
                        && d.trim_start_matches('-')
                            .chars()
                            .all(|c| c.is_ascii_digit())
                })
        })
}

fn binary(needed: usize, what: &str, bytes: &[u8]) -> Option<String> {
    if bytes.is_empty() {
        return Some("nothing arrived before the timeout".into());
    }
    if bytes[0] == b'\n' || bytes.starts_with(b"\r\n") {
        return Some(format!(
            "a leftover LF from an earlier text reply is in front of this binary read: it \
             became the first byte ({}); read it away first (socket_read_byte_list(1)) or \
             have the server not send the newline",
            shown(&bytes[..bytes.len().min(8)])
        ));
    }
    let body = trim(bytes);
    if what == "int32"
        && !body.is_empty()
        && body
            .iter()
            .all(|b| b.is_ascii_digit() || b" -+,()".contains(b))
    {
        return Some(format!(
            "text {} arrived where binary int32 was expected: pack the values, e.g. \
             struct.pack(\"!i\", v) in Python",
            shown(bytes)
        ));
    }
    if bytes.len() < needed {
        return Some(format!(
            "only {} of the {needed} bytes arrived before the timeout ({}): the read fails",
            bytes.len(),
            crate::show::hex(&bytes[..bytes.len().min(16)])
        ));
    }
    if what == "int32" && bytes.len() >= 4 {
        let be = i32::from_be_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
        let le = i32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
        if be.unsigned_abs() >= 1 << 24 && le.unsigned_abs() < 1 << 16 {
            return Some(format!(
                "the first value reads {be} big-endian but {le} little-endian: the server \
                 packs little-endian; use \"!i\" or \">i\" with struct.pack"
            ));
        }
    }
    None
}

/// The note for a read whose data was already waiting when it started, after the read
/// before it on the same socket timed out: most likely that read's late reply.
pub fn late_reply(previous: &ReadCall, previous_line: usize) -> String {
    format!(
        "this data was already waiting when the read started: probably the late reply to \
         {}() on line {previous_line}, which timed out; raise its timeout or answer sooner",
        previous.function_name()
    )
}

/// `ascii-float:N`, `binary-integer:N`, `byte-list:N`, `line` (`listen --robot-reads`).
pub fn parse_robot_reads(s: &str) -> Result<ReadCall, String> {
    let (kind, n) = match s.split_once(':') {
        Some((k, n)) => (k, Some(n)),
        None => (s, None),
    };
    let max = urscript_socket::format::MAX_VALUES;
    let number = || -> Result<usize, String> {
        let n: usize = n
            .ok_or_else(|| format!("--robot-reads {kind}:N needs N (1-{max})"))?
            .parse()
            .map_err(|_| format!("--robot-reads {s}: N must be a number 1-{max}"))?;
        if !(1..=max).contains(&n) {
            return Err(format!(
                "--robot-reads {s}: N must be 1-{max} (the controller's limit)"
            ));
        }
        Ok(n)
    };
    let bad = || {
        format!("--robot-reads {s}: expected ascii-float:N, binary-integer:N, byte-list:N or line")
    };
    // The names of `read`'s subcommands; `string` needs a prefix and suffix, not given here.
    let name = crate::formats::lookup(crate::formats::names::READS, kind)
        .filter(|n| n.core != Some("string"))
        .ok_or_else(bad)?;
    let number = if name.core == Some("line") {
        None
    } else {
        Some(number()?)
    };
    crate::formats::read_call(name, number)
}

/// What a server sends, as far as the rules care: its bytes and the kind of reply.
#[derive(Debug, Clone, Copy)]
pub struct Sent<'a> {
    pub bytes: &'a [u8],
    /// A float tuple (`floats`, `floats-lf`).
    pub float_tuple: bool,
    /// Bytes meant for a binary read (`int32`, `bytes`).
    pub binary: bool,
}

/// The read a reply is checked against: `expect` (`--robot-reads`), or, when that is
/// not given, a binary read for binary replies and `socket_read_ascii_float` for text
/// that looks like numbers (with as many values as it holds).
fn read_for(sent: &Sent<'_>, expect: Option<&ReadCall>) -> Option<ReadCall> {
    if let Some(call) = expect {
        return Some(call.clone());
    }
    let max = urscript_socket::format::MAX_VALUES;
    if sent.binary {
        return Some(ReadCall::ByteList {
            number: sent.bytes.len().clamp(1, max),
        });
    }
    let text = String::from_utf8_lossy(sent.bytes);
    (!sent.float_tuple && looks_numeric(&text)).then(|| ReadCall::AsciiFloat {
        number: numbers(text.trim()).clamp(1, max),
    })
}

/// What the robot's next read sees when `sent` arrives: an LF left by a previous
/// `(...)\n` reply (`after_tuple_lf`) comes first.
fn seen_by_read(sent: &Sent<'_>, after_tuple_lf: bool) -> Vec<u8> {
    let mut seen = Vec::with_capacity(sent.bytes.len() + 1);
    if after_tuple_lf {
        seen.push(b'\n');
    }
    seen.extend_from_slice(sent.bytes);
    seen
}

/// Warnings for sending `sent` to a robot that will do `expect` (if known), by the rules
/// of [`diagnose`] applied to what the robot's read will see, plus what the library's
/// robot emulation returns for a float read that would fail.
pub fn reply(sent: &Sent<'_>, expect: Option<&ReadCall>, after_tuple_lf: bool) -> Vec<String> {
    let Some(call) = read_for(sent, expect) else {
        return Vec::new();
    };
    if sent.bytes.is_empty() {
        return Vec::new();
    }
    let mut w: Vec<String> = diagnose(&call, &seen_by_read(sent, after_tuple_lf))
        .into_iter()
        .collect();
    if let ReadCall::AsciiFloat { number } = call {
        if let Some(result) = simulate(&call, sent.bytes) {
            if result.is_sentinel() || !w.is_empty() {
                w.push(format!(
                    "the robot's socket_read_ascii_float({number}) would return {}",
                    result.to_urscript()
                ));
            }
        }
    }
    w
}

/// The one check of [`reply`] that depends on what was sent before on the connection (for
/// `--reply` and rules, whose own bytes were checked once at start): a leftover LF in
/// front of a binary read.
pub fn leftover_lf(
    sent: &Sent<'_>,
    expect: Option<&ReadCall>,
    after_tuple_lf: bool,
) -> Option<String> {
    let call = read_for(sent, expect)?;
    let binary = matches!(
        call,
        ReadCall::BinaryInteger { .. } | ReadCall::ByteList { .. }
    );
    if !(after_tuple_lf && binary) {
        return None;
    }
    diagnose(&call, &seen_by_read(sent, true))
}

/// What the robot's `call` returns when `bytes` is all it receives before its timeout.
pub fn simulate(call: &ReadCall, bytes: &[u8]) -> Option<ReadResult> {
    let mut s = SocketConnection::new("socket_0", Policy::default());
    s.receive(bytes);
    s.start_read(call.clone(), Timeout::Forever, Duration::ZERO)
        .ok()?;
    s.poll_read().or_else(|| s.give_up())
}

/// A float tuple followed by a line end: the robot's float read stops at `)` and leaves
/// the LF for the next read.
pub fn ends_with_tuple_and_lf(bytes: &[u8]) -> bool {
    let mut t = bytes;
    while let [rest @ .., 0] = t {
        t = rest;
    }
    t.ends_with(b")\n") || t.ends_with(b")\r\n")
}

/// How many numbers a text holds (`[0.1, 0.2]`, `0,15;0,5`, `(1 2)`).
fn numbers(text: &str) -> usize {
    text.split(|c: char| c == ',' || c == ';' || c.is_whitespace() || "()[]".contains(c))
        .filter(|w| !w.is_empty() && w.parse::<f64>().is_ok())
        .count()
}

/// Text a server meant as numbers (digits and the punctuation of lists and tuples, or
/// numpy's reprs).
fn looks_numeric(text: &str) -> bool {
    let t = text.trim();
    (t.contains("float64(") || t.contains("array("))
        || (t.chars().any(|c| c.is_ascii_digit())
            && t.chars()
                .all(|c| "0123456789.,;:+-eE[]() \t\r\n".contains(c)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn f(n: usize, b: &[u8]) -> String {
        diagnose(&ReadCall::AsciiFloat { number: n }, b).unwrap_or_default()
    }

    #[test]
    fn blank_bytes_are_not_nothing() {
        assert_eq!(f(2, b""), "nothing arrived before the timeout");
        let w = f(2, b"\r\n");
        assert!(w.starts_with("only blank bytes arrived (\"\\r\\n\""), "{w}");
        assert!(f(2, b"\0\0").contains("only blank bytes"));
    }

    #[test]
    fn python_list() {
        let d = f(2, b"[0.1, 0.2]\n");
        assert!(
            d.contains("Python list, str(list)") && d.contains("like (0.1,0.2)"),
            "{d}"
        );
    }

    #[test]
    fn numpy_array_and_repr() {
        assert!(f(2, b"[0.1 0.2]").contains("numpy array, str(array)"));
        assert!(f(2, b"(np.float64(0.1), np.float64(0.2))").contains("numpy 2"));
    }

    #[test]
    fn decimal_comma() {
        assert!(f(2, b"(0,15;0,5)").contains("decimal commas"));
        assert!(f(2, b"(0,15, 0,5)").contains("decimal commas"));
    }

    #[test]
    fn no_parentheses() {
        assert!(f(2, b"0.1, 0.2\n").contains("without parentheses"));
    }

    #[test]
    fn more_values_than_asked() {
        assert!(f(2, b"(1,2,3)").contains("3 values arrived where the read asked for 2"));
    }

    #[test]
    fn fewer_values_and_good_tuples() {
        assert!(f(6, b"(3)").contains("1 of the 6"));
        assert_eq!(
            diagnose(&ReadCall::AsciiFloat { number: 2 }, b"(1, 2)\n"),
            None
        );
    }

    /// The core's decoder finds the bad value; the message names its field, also next
    /// to bytes that are not UTF-8 or are several bytes long.
    #[test]
    fn a_bad_value_is_named_by_the_field_the_decoder_stopped_in() {
        assert!(f(3, b"(1, 2x, 3)").contains("\"2x\" is not a number"));
        assert!(f(2, b"(1,,2)").contains("\"\" is not a number"));
        assert!(f(2, "(é,1)".as_bytes()).contains("\"é\" is not a number"));
        assert!(f(2, b"(1,\xE9\xE9)").contains("is not a number"));
        assert!(f(2, b"(\xE9,1)").contains("is not a number"));
    }

    #[test]
    fn reply_cut_by_the_timeout() {
        assert!(f(3, b"(0.1,0.2").contains("still arriving when the timeout passed"));
        assert!(f(3, b"").contains("nothing arrived"));
    }

    #[test]
    fn leftover_lf_before_binary() {
        let d = diagnose(&ReadCall::BinaryInteger { number: 1 }, b"\n\0\0\0").unwrap();
        assert!(d.contains("leftover LF"), "{d}");
    }

    #[test]
    fn text_or_little_endian_where_int32_expected() {
        let d = diagnose(&ReadCall::BinaryInteger { number: 1 }, b"100\n").unwrap();
        assert!(d.contains("text"), "{d}");
        let d = diagnose(&ReadCall::BinaryInteger { number: 1 }, &[100, 0, 0, 0]).unwrap();
        assert!(d.contains("little-endian"), "{d}");
        let d = diagnose(&ReadCall::BinaryInteger { number: 2 }, &[0, 0, 0, 1]).unwrap();
        assert!(d.contains("only 4 of the 8"), "{d}");
    }

    #[test]
    fn lines_and_strings() {
        assert!(diagnose(&ReadCall::Line, b"OK\r").unwrap().contains("CR"));
        let s = ReadCall::String {
            prefix: b">".to_vec(),
            suffix: b"<".to_vec(),
            interpret_escape: false,
        };
        assert!(diagnose(&s, b"junk")
            .unwrap()
            .contains("prefix \">\" never arrived"));
        assert!(diagnose(&s, b">abc").unwrap().contains("suffix"));
        assert_eq!(diagnose(&s, b">abc<"), None);
    }

    #[test]
    fn late_reply_names_the_earlier_read() {
        let m = late_reply(&ReadCall::AsciiFloat { number: 6 }, 3);
        assert!(m.contains("socket_read_ascii_float() on line 3"), "{m}");
    }

    fn sent(bytes: &[u8]) -> Sent<'_> {
        Sent {
            bytes,
            float_tuple: false,
            binary: false,
        }
    }

    #[test]
    fn a_reply_is_checked_by_the_same_rules_with_the_robots_result() {
        let two = ReadCall::AsciiFloat { number: 2 };
        let w = reply(&sent(b"[0.1, 0.2]\n"), Some(&two), false);
        assert!(w[0].contains("Python list, str(list)"), "{w:?}");
        assert!(
            w[1].contains("socket_read_ascii_float(2) would return [0, nan, nan]"),
            "{w:?}"
        );
        let w = reply(&sent(b"(0,15;0,5)"), Some(&two), false);
        assert!(w[0].contains("decimal commas"), "{w:?}");
        let w = reply(&sent(b"0.1,0.2\n"), Some(&two), false);
        assert!(w[0].contains("no parentheses"), "{w:?}");
        assert!(reply(&sent(b"(1,2)"), Some(&two), false).is_empty());
    }

    #[test]
    fn without_robot_reads_number_like_text_is_checked_as_a_float_read() {
        let w = reply(&sent(b"[0.1, 0.2, 0.3]\n"), None, false);
        assert!(w[0].contains("str(list)"), "{w:?}");
        assert!(
            w[1].contains("socket_read_ascii_float(3) would return [0, nan, nan, nan]"),
            "{w:?}"
        );
        assert!(reply(&sent(b"OK\n"), None, false).is_empty());
    }

    #[test]
    fn a_leftover_lf_is_seen_by_the_next_binary_read() {
        let int32 = Sent {
            bytes: &[0, 0, 0, 5],
            float_tuple: false,
            binary: true,
        };
        let one = ReadCall::BinaryInteger { number: 1 };
        assert!(leftover_lf(&int32, Some(&one), false).is_none());
        assert!(leftover_lf(&int32, Some(&one), true)
            .unwrap()
            .contains("a leftover LF"));
        // Without --robot-reads, a binary reply is checked as a binary read.
        assert!(leftover_lf(&int32, None, true)
            .unwrap()
            .contains("a leftover LF"));
        assert!(reply(&int32, None, true)[0].contains("a leftover LF"));
        assert!(ends_with_tuple_and_lf(b"(1,2)\r\n") && !ends_with_tuple_and_lf(b"(1,2)"));
    }

    #[test]
    fn robot_reads_names_a_read() {
        assert_eq!(
            parse_robot_reads("ascii-float:6").unwrap(),
            ReadCall::AsciiFloat { number: 6 }
        );
        assert_eq!(parse_robot_reads("line").unwrap(), ReadCall::Line);
        assert!(parse_robot_reads("ascii-float:31")
            .unwrap_err()
            .contains("1-30"));
        assert!(parse_robot_reads("ascii-float")
            .unwrap_err()
            .contains("needs N"));
        assert!(parse_robot_reads("nope").is_err());
    }
}
