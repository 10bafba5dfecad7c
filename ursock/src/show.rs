//! Rendering bytes and decoded messages for people (hex, text, URScript notation, JSON).

use std::fmt::Write as _;

use urscript_socket::format::{write_quoted, Message};

// Why the hex writers here are ours and not a crate's: the `hex` crate writes one unbroken
// run (`hex::encode`), which is exactly the JSON form below, but not the spaced upper-case
// form people read (`00 00 00 64`) or the dump with offsets and an ASCII column; dump
// crates (`pretty-hex`, `hexyl`) each have their own layout (lower case, other separators,
// colours), and this layout is the one the listener, `ursock diagnose` and their docs show.
// Taking a crate for the one line the JSON form needs would add a dependency to save three
// lines. So all three stay, and the property tests below check them against the `hex` crate
// (the digits of every form) and against the layout as documented (offsets, widths, the
// ASCII column).

/// `00 00 00 64`
pub fn hex(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() * 3);
    for (i, b) in bytes.iter().enumerate() {
        if i > 0 {
            s.push(' ');
        }
        let _ = write!(s, "{b:02X}");
    }
    s
}

/// A quoted string literal, escaped by the core's [`write_quoted`] (`\n \r \t \\ \"`,
/// `\xHH`), except that valid UTF-8 beyond ASCII is shown as text (`"café"`); bytes
/// that are not UTF-8 stay `\xHH`.
pub fn quoted(bytes: &[u8]) -> String {
    let mut s = String::with_capacity(bytes.len() + 2);
    s.push('"');
    for chunk in bytes.utf8_chunks() {
        let mut rest = chunk.valid();
        while !rest.is_empty() {
            let ascii = rest.find(|c: char| !c.is_ascii()).unwrap_or(rest.len());
            escaped(&mut s, &rest.as_bytes()[..ascii]);
            rest = &rest[ascii..];
            if let Some(c) = rest.chars().next() {
                if c.is_control() {
                    let _ = write!(s, "\\u{{{:04X}}}", c as u32);
                } else {
                    s.push(c);
                }
                rest = &rest[c.len_utf8()..];
            }
        }
        escaped(&mut s, chunk.invalid());
    }
    s.push('"');
    s
}

/// `bytes` escaped as [`write_quoted`] does, without its quotes.
fn escaped(s: &mut String, bytes: &[u8]) {
    if bytes.is_empty() {
        return;
    }
    let start = s.len();
    let _ = write_quoted(s, bytes);
    s.pop();
    s.remove(start);
}

/// A hex dump, 16 bytes per row, each row with its offset and the printable ASCII:
///
/// ```text
/// 0000  68 65 6C 6C 6F 0A                                 |hello.|
/// ```
pub fn hex_dump(bytes: &[u8]) -> Vec<String> {
    bytes
        .chunks(16)
        .enumerate()
        .map(|(row, chunk)| {
            let mut s = format!("{:04X}  ", row * 16);
            for i in 0..16 {
                match chunk.get(i) {
                    Some(b) => {
                        let _ = write!(s, "{b:02X} ");
                    }
                    None => s.push_str("   "),
                }
                if i == 7 {
                    s.push(' ');
                }
            }
            s.push('|');
            s.extend(chunk.iter().map(|&b| {
                if b.is_ascii_graphic() || b == b' ' {
                    b as char
                } else {
                    '.'
                }
            }));
            s.push('|');
            s
        })
        .collect()
}

/// Bytes for a person: up to 16 bytes as the quoted text and the hex on one line;
/// longer chunks as their length, the start of the text, and a [`hex_dump`] below, one
/// row per 16 bytes, each row prefixed by `indent` (never one line of 12,000 characters).
pub fn text_and_hex(bytes: &[u8], indent: &str) -> String {
    const PREVIEW: usize = 48;
    if bytes.len() <= 16 {
        return format!("{}  {}", quoted(bytes), hex(bytes));
    }
    let mut s = format!("{} bytes", bytes.len());
    if bytes.len() <= PREVIEW {
        s = format!("{}  ({s})", quoted(bytes));
    } else {
        // Do not cut a UTF-8 character in two: back off over continuation bytes.
        let mut cut = PREVIEW;
        while cut > PREVIEW - 3 && bytes[cut] & 0xC0 == 0x80 {
            cut -= 1;
        }
        s = format!("{}...  ({s})", quoted(&bytes[..cut]));
    }
    for row in hex_dump(bytes) {
        s.push('\n');
        s.push_str(indent);
        s.push_str(&row);
    }
    s
}

/// Raw bytes in JSON, saying which form it chose: `{"encoding":"utf-8","text":"café"}`
/// when the bytes are valid UTF-8, else `{"encoding":"hex","hex":"e9"}`.
#[derive(serde::Serialize)]
#[serde(tag = "encoding")]
pub enum JsonBytes {
    #[serde(rename = "utf-8")]
    Utf8 { text: String },
    #[serde(rename = "hex")]
    Hex { hex: String },
}

impl JsonBytes {
    pub fn new(bytes: &[u8]) -> Self {
        match std::str::from_utf8(bytes) {
            Ok(t) => JsonBytes::Utf8 {
                text: t.to_string(),
            },
            Err(_) => JsonBytes::Hex {
                hex: bytes.iter().fold(String::new(), |mut s, b| {
                    let _ = write!(s, "{b:02x}");
                    s
                }),
            },
        }
    }
}

/// A decoded message as one line of text: a single int32 or byte as its number, text
/// as [`quoted`], everything else in the core's URScript notation (`SET A 1`,
/// `p[1, 2, 3, 0, 3.141593, 0]`).
pub fn message_text(m: &Message<'_>) -> String {
    match m {
        Message::Int32(v) if v.len() == 1 => v.get(0).unwrap_or(0).to_string(),
        Message::Bytes([b]) => b.to_string(),
        Message::Text(t) => quoted(t),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::report::TypedMessage;
    use proptest::prelude::*;
    use urscript_socket::format::Format;
    use urscript_socket::Decode;

    #[test]
    fn quoted_escapes_as_the_core_and_keeps_utf8_text() {
        assert_eq!(quoted(b"a\"\\\n\r\t\x00\x7F"), r#""a\"\\\n\r\t\x00\x7F""#);
        assert_eq!(quoted("café".as_bytes()), "\"café\"");
        assert_eq!(quoted(b"caf\xE9 \xC3\xA9"), "\"caf\\xE9 é\"");
        assert_eq!(quoted("\u{85}".as_bytes()), "\"\\u{0085}\"");
    }

    #[test]
    fn messages_use_the_core_writer() {
        let mut d = Format::Value.decoder().unwrap();
        let m = d.decode(b"p[0.1, 0, 0, 0, 3.14159265, 0]\n").unwrap();
        let m = m.item().unwrap();
        assert_eq!(message_text(&m), "p[0.1, 0, 0, 0, 3.141593, 0]");
        assert_eq!(
            TypedMessage::new(&m, "line").to_json(),
            r#"{"type":"pose","value":[0.1,0.0,0.0,0.0,3.14159265,0.0]}"#
        );
        let mut d = Format::Int32 { number: 1 }.decoder().unwrap();
        let m = d.decode(&[0, 0, 0, 100]).unwrap().item().unwrap();
        assert_eq!(message_text(&m), "100");
        assert_eq!(
            TypedMessage::new(&m, "line").to_json(),
            r#"{"type":"int32","value":100}"#
        );
        let mut d = Format::StxEtx.decoder().unwrap();
        let m = d.decode(b"\x02hi\x03").unwrap().item().unwrap();
        assert_eq!(message_text(&m), "\"hi\"");
        assert_eq!(
            TypedMessage::new(&m, "frame").to_json(),
            r#"{"type":"frame","value":{"encoding":"utf-8","text":"hi"}}"#
        );
    }

    proptest! {
        #[test]
        fn hex_forms_hold_the_hex_crates_digits(bytes in proptest::collection::vec(any::<u8>(), 0..40)) {
            let spaced = hex(&bytes);
            let words: Vec<&str> = spaced.split(' ').filter(|w| !w.is_empty()).collect();
            prop_assert_eq!(words.len(), bytes.len());
            prop_assert_eq!(words.concat(), ::hex::encode_upper(&bytes));
            prop_assert_eq!(spaced.len(), (bytes.len() * 3).saturating_sub(1));
            let json = serde_json::to_value(JsonBytes::new(&bytes)).unwrap();
            match std::str::from_utf8(&bytes) {
                Ok(text) => prop_assert_eq!(json["text"].as_str(), Some(text)),
                Err(_) => prop_assert_eq!(json["hex"].as_str().map(String::from), Some(::hex::encode(&bytes))),
            }
        }

        #[test]
        fn hex_dump_rows_follow_the_layout(bytes in proptest::collection::vec(any::<u8>(), 0..100)) {
            let rows = hex_dump(&bytes);
            prop_assert_eq!(rows.len(), bytes.len().div_ceil(16));
            for (n, (row, chunk)) in rows.iter().zip(bytes.chunks(16)).enumerate() {
                // `OOOO  ` + 16 columns of `HH ` + one extra space after the 8th + `|text|`.
                let (offset, rest) = row.split_at(6);
                prop_assert_eq!(offset, format!("{:04X}  ", n * 16));
                let (digits, text) = rest.split_at(16 * 3 + 1);
                prop_assert_eq!(digits.replace(' ', ""), ::hex::encode_upper(chunk));
                prop_assert_eq!(&digits[24..25], " ");
                let shown: String = chunk
                    .iter()
                    .map(|&b| if (0x20..0x7F).contains(&b) { b as char } else { '.' })
                    .collect();
                prop_assert_eq!(text, format!("|{shown}|"));
            }
        }
    }
}
