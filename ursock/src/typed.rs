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
                    // Digits only: `from_str_radix` alone would take `+1` as 01.
                    .filter(|h| h.iter().all(u8::is_ascii_hexdigit))
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

// Why the hex parser is ours and not the `hex` crate's:
// `hex::decode` reads one run of digits and nothing else, while a person types words
// (`02 41 03`, `0x02,0x41`, `aa:bb-cc`); splitting words, dropping `0x` and the `:`/`-`
// separators stays ours either way, and what would be left for the crate is turning two
// digits into a byte, one line with `char::to_digit`. Its error (`InvalidHexCharacter`)
// also gives the index in the cleaned run, not in what was typed, and a byte index at
// that (a non-ASCII character shows as its first byte). So the parser stays here, and
// the `hex` crate is its oracle in the property tests below. That test catches the old
// version's bug: `u8::from_str_radix` on each pair took a sign, so `+1` was the byte 01.

/// The bytes of hex words: pairs of hex digits, `0x` optional, separated by spaces or
/// commas (`02 41 03`, `024103`, `0x02,0x41`; `:` and `-` inside a word are ignored).
/// Only `0-9 a-f A-F` are digits (no sign). An error names the word and, for a character
/// that is not a hex digit, its position in the word (counted in characters, from 1).
pub fn hex<'a>(words: impl IntoIterator<Item = &'a str>) -> Result<Vec<u8>, String> {
    let mut out = Vec::new();
    for word in words
        .into_iter()
        .flat_map(|w| w.split(|c: char| c.is_whitespace() || c == ','))
    {
        let prefix = usize::from(word.starts_with("0x") || word.starts_with("0X")) * 2;
        let mut high: Option<u8> = None;
        let mut digits = 0;
        for (n, c) in word.chars().enumerate().skip(prefix) {
            if matches!(c, ':' | '-') {
                continue;
            }
            let Some(v) = c.to_digit(16).and_then(|v| u8::try_from(v).ok()) else {
                return Err(format!(
                    "{word:?} is not hexadecimal: {c:?} (character {}) is not a hex digit",
                    n + 1
                ));
            };
            digits += 1;
            match high.take() {
                None => high = Some(v),
                Some(h) => out.push(h << 4 | v),
            }
        }
        if high.is_some() {
            return Err(format!(
                "{word:?} is not whole bytes: {digits} hex digits (two make a byte)"
            ));
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
    use proptest::prelude::*;

    #[test]
    fn escapes() {
        assert_eq!(unescape(r"OK\r\n\t\0\\\x41").unwrap(), b"OK\r\n\t\0\\A");
        assert_eq!(unescape("café").unwrap(), "café".as_bytes());
        assert!(unescape(r"bad\q")
            .unwrap_err()
            .contains("unknown escape \\q"));
        assert!(unescape(r"\x4").unwrap_err().contains("two hex digits"));
        assert!(unescape(r"\x+1").unwrap_err().contains("two hex digits"));
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
        assert!(hex(["0x"]).unwrap_err().contains("no bytes"));
        // No sign: `u8::from_str_radix` would take `+1` as 01.
        let e = hex(["02", "+1"]).unwrap_err();
        assert!(e.contains("'+' (character 1)"), "{e}");
        let e = hex(["0xaé"]).unwrap_err();
        assert!(e.contains("'é' (character 4)"), "{e}");
    }

    /// The `hex` crate's reading of one word, as documented above: drop `0x`, `:` and `-`,
    /// then pairs of hex digits.
    fn oracle(word: &str) -> Result<Vec<u8>, ::hex::FromHexError> {
        let digits = word
            .strip_prefix("0x")
            .or_else(|| word.strip_prefix("0X"))
            .unwrap_or(word);
        ::hex::decode(digits.replace([':', '-'], ""))
    }

    /// Words of mostly hex digits (so that many are valid) with now and then a
    /// character that is special, a separator or no digit at all.
    fn word() -> impl Strategy<Value = String> {
        let chars = prop_oneof![
            6 => prop::sample::select(vec!['0', '9', 'a', 'F']),
            1 => prop::sample::select(vec!['g', 'x', 'X', ':', '-', '+', ' ', ',', 'é']),
        ];
        proptest::collection::vec(chars, 0..12).prop_map(|v| v.into_iter().collect())
    }

    proptest! {
        // Cheap cases; enough of them that a sign in a valid position turns up every run.
        #![proptest_config(ProptestConfig::with_cases(4000))]

        #[test]
        fn hex_agrees_with_the_hex_crate(words in proptest::collection::vec(word(), 0..4)) {
            let ours = hex(words.iter().map(String::as_str));
            let theirs: Result<Vec<Vec<u8>>, _> = words
                .iter()
                .flat_map(|w| w.split([' ', ',']))
                .map(oracle)
                .collect();
            match (ours, theirs) {
                (Ok(a), Ok(b)) => prop_assert_eq!(a, b.concat()),
                (Err(e), Ok(b)) => prop_assert!(b.concat().is_empty(), "{e}"),
                (Ok(a), Err(e)) => prop_assert!(false, "{a:?} but the hex crate says {e}"),
                (Err(_), Err(_)) => {}
            }
        }

        #[test]
        fn every_way_to_write_bytes_reads_back(bytes in proptest::collection::vec(any::<u8>(), 1..20)) {
            let lower = ::hex::encode(&bytes);
            let upper = ::hex::encode_upper(&bytes);
            let spaced: Vec<String> = bytes.iter().map(|b| format!("{b:02x}")).collect();
            let prefixed: Vec<String> = bytes.iter().map(|b| format!("0x{b:02X}")).collect();
            for typed in [lower.clone(), upper, spaced.join(" "), prefixed.join(","), format!("0x{lower}"), spaced.join(":")] {
                prop_assert_eq!(&hex([typed.as_str()]).unwrap(), &bytes, "{}", typed);
            }
        }
    }
}
