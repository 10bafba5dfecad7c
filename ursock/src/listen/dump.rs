//! Bytes for people: hex and text side by side, wrapped with offsets when long.

use std::fmt::Write as _;

/// Bytes shown on one row of the wrapped dump.
pub const ROW: usize = 16;

/// A quoted literal: control bytes escaped (`\n`, `\r`, `\t`, `\xHH`); when the bytes are
/// valid UTF-8, non-ASCII characters are shown as themselves (`"café"`).
pub fn text(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() + 2);
    s.push('"');
    match std::str::from_utf8(bytes) {
        Ok(t) => {
            for c in t.chars() {
                push_char(&mut s, c);
            }
        }
        Err(_) => {
            for &b in bytes {
                if b.is_ascii() {
                    push_char(&mut s, b as char);
                } else {
                    let _ = write!(s, "\\x{b:02X}");
                }
            }
        }
    }
    s.push('"');
    s
}

fn push_char(s: &mut String, c: char) {
    match c {
        '\n' => s.push_str("\\n"),
        '\r' => s.push_str("\\r"),
        '\t' => s.push_str("\\t"),
        '\\' => s.push_str("\\\\"),
        '"' => s.push_str("\\\""),
        c if (c as u32) < 0x20 || c as u32 == 0x7F => {
            let _ = write!(s, "\\x{:02X}", c as u32);
        }
        c => s.push(c),
    }
}

/// A chunk: `68 69  "hi"` on one line when short, otherwise a header and rows of
/// [`ROW`] bytes (`0010  ...  |text|`) followed by the text when it is valid UTF-8.
/// Every line but the first starts with `indent`.
pub fn chunk(bytes: &[u8], indent: &str, max: usize) -> String {
    let all = bytes;
    let bytes = &bytes[..bytes.len().min(max.max(ROW))];
    if all.len() <= ROW {
        return format!("{}  {}", crate::show::hex(bytes), text(bytes));
    }
    let mut s = String::new();
    let _ = write!(s, "({} bytes)", all.len());
    for (i, row) in bytes.chunks(ROW).enumerate() {
        let _ = write!(
            s,
            "\n{indent}{:04X}  {:<47}  |",
            i * ROW,
            crate::show::hex(row)
        );
        for &b in row {
            s.push(if (0x20..0x7F).contains(&b) {
                b as char
            } else {
                '.'
            });
        }
        s.push('|');
    }
    if bytes.len() < all.len() {
        let _ = write!(
            s,
            "\n{indent}... {} more bytes not shown (--show-max {max})",
            all.len() - bytes.len()
        );
    } else if !bytes.is_ascii() && std::str::from_utf8(bytes).is_ok() {
        let _ = write!(s, "\n{indent}text {}", text(bytes));
    }
    s
}
