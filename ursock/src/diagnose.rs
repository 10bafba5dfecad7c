//! Why a robot read failed, in the server writer's terms.
//!
//! [`diagnose`] looks at the bytes a read saw and names the usual mistakes of PC-side
//! servers (the spec's section 8): Python `str(list)` or numpy text where a tuple was
//! expected, decimal commas, no parentheses, more values than asked, a leftover LF in
//! front of a binary read, a reply still arriving when the timeout passed. It is a pure
//! function so `robot`, `read` and `listen` can share it.

use urscript_socket::robot::ReadCall;

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
    if body.is_empty() {
        return Some("nothing arrived before the timeout".into());
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
                "the values arrived without parentheses ({}): the robot reads only `(v1,v2,...)`; {fix}",
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
    let values = inner.split(',').filter(|v| !v.trim().is_empty()).count();
    if values > number {
        return Some(format!(
            "{values} values arrived where the read asked for {number}: the robot fails the \
             whole read; send {number} values or read {values}"
        ));
    }
    if let Some(bad) = inner
        .split(',')
        .map(str::trim)
        .find(|v| v.parse::<f64>().is_err())
    {
        return Some(format!(
            "{bad:?} is not a number the robot reads (plain decimal, optional exponent)"
        ));
    }
    if values < number {
        return Some(format!(
            "{values} of the {number} values arrived: count is {values}, the other slots nan"
        ));
    }
    None
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

#[cfg(test)]
mod tests {
    use super::*;

    fn f(n: usize, b: &[u8]) -> String {
        diagnose(&ReadCall::AsciiFloat { number: n }, b).unwrap_or_default()
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
}
