//! What a person types as bytes: text with escapes and hex. The one interpreter of each,
//! used by `encode --escapes`, `--delimiter`, and `listen`'s `text` and `hex` replies.

/// The escapes [`unescape`] knows, for messages.
pub const ESCAPES: &str = "\\r \\n \\t \\0 \\\\ \\xHH";

/// Typed text with `\r \n \t \0 \\ \xHH` escapes interpreted; an unknown escape is an
/// error rather than a guess.
///
/// `unescape(r"OK\r\n")` is `b"OK\r\n"`; `unescape(r"\q")` is an error.
pub fn unescape(s: &str) -> Result<Vec<u8>, String> {
    let mut out = Vec::with_capacity(s.len());
    let b = s.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] != b'\\' {
            out.push(b[i]);
            i += 1;
            continue;
        }
        let (byte, len) = match b.get(i + 1) {
            Some(b'n') => (b'\n', 2),
            Some(b'r') => (b'\r', 2),
            Some(b't') => (b'\t', 2),
            Some(b'0') => (0, 2),
            Some(b'\\') => (b'\\', 2),
            Some(b'x') => {
                let v = b
                    .get(i + 2..i + 4)
                    .and_then(|h| std::str::from_utf8(h).ok())
                    .and_then(|h| u8::from_str_radix(h, 16).ok())
                    .ok_or_else(|| format!("{s:?}: \\x needs two hex digits (at byte {i})"))?;
                (v, 4)
            }
            Some(_) => {
                let c = s[i + 1..].chars().next().unwrap_or('?');
                return Err(format!(
                    "{s:?}: unknown escape \\{c} at byte {i} (known: {ESCAPES})"
                ));
            }
            None => return Err(format!("{s:?}: a lone \\ at the end")),
        };
        out.push(byte);
        i += len;
    }
    Ok(out)
}

/// The bytes of hex words: pairs of hex digits, `0x` optional, separated by spaces or
/// commas (`02 41 03`, `024103`, `0x02,0x41`; `:` and `-` inside a word are ignored).
pub fn hex<'a>(words: impl IntoIterator<Item = &'a str>) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    for word in words
        .into_iter()
        .flat_map(|w| w.split(|c: char| c.is_whitespace() || c == ','))
    {
        let digits = word
            .strip_prefix("0x")
            .or_else(|| word.strip_prefix("0X"))
            .unwrap_or(word);
        let digits: Vec<u8> = digits
            .bytes()
            .filter(|b| !matches!(b, b':' | b'-'))
            .collect();
        if !digits.len().is_multiple_of(2) {
            return Err(format!("{word:?} is not whole bytes (two hex digits each)"));
        }
        for pair in digits.chunks(2) {
            let text = std::str::from_utf8(pair).unwrap_or("?");
            out.push(
                u8::from_str_radix(text, 16).map_err(|_| format!("{word:?} is not hexadecimal"))?,
            );
        }
    }
    if out.is_empty() {
        return Err("no bytes given (at least one, like 02 41 03)".into());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn escapes() {
        assert_eq!(unescape(r"OK\r\n\t\0\\\x41").unwrap(), b"OK\r\n\t\0\\A");
        assert_eq!(unescape("café").unwrap(), "café".as_bytes());
        assert!(unescape(r"bad\q")
            .unwrap_err()
            .contains("unknown escape \\q"));
        assert!(unescape(r"\x4").unwrap_err().contains("two hex digits"));
        assert!(unescape("end\\").unwrap_err().contains("lone"));
        assert!(unescape("\\é").unwrap_err().contains("unknown escape \\é"));
    }

    #[test]
    fn hex_words() {
        assert_eq!(hex(["02 41 03"]).unwrap(), [2, 0x41, 3]);
        assert_eq!(hex(["0241", "0x03"]).unwrap(), [2, 0x41, 3]);
        assert_eq!(
            hex(["0x02,0x41", "aa:bb-cc"]).unwrap(),
            [2, 0x41, 0xAA, 0xBB, 0xCC]
        );
        assert!(hex(["0"]).unwrap_err().contains("whole bytes"));
        assert!(hex(["zz"]).unwrap_err().contains("not hexadecimal"));
        assert!(hex([""]).unwrap_err().contains("no bytes"));
    }
}
