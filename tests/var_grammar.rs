//! The nom parser of `SET`/`GET` lines and replies (`urscript_socket::var`) against a
//! second, hand-written reading of the same grammar (`var_grammar/oracle.rs`): on lines
//! built from the grammar's own pieces and from bytes that break it, both must give the
//! same message or the same error kind at the same offset.

use proptest::prelude::*;
use urscript_socket::var::{parse_var_message, VarMessage, VarReplyDecoder};
use urscript_socket::ErrorKind;

#[path = "var_grammar/oracle.rs"]
mod oracle;

/// Pieces of good lines and of nearly good ones.
const PIECES: &[&[u8]] = &[
    b"SET",
    b"GET",
    b"S",
    b"G",
    b"E",
    b"T",
    b"SE",
    b"GE",
    b" ",
    b" ",
    b"\t",
    b"A",
    b"POS_X",
    b"-",
    b"+",
    b"0",
    b"7",
    b"007",
    b"2147483647",
    b"2147483648",
    b"-2147483648",
    b"99999999999",
    b"x",
    b"\x01",
    b"\xE9",
    b"\r",
];

fn line() -> impl Strategy<Value = Vec<u8>> {
    prop::collection::vec(prop::sample::select(PIECES), 0..8).prop_map(|p| p.concat())
}

fn ours(line: &[u8]) -> oracle::Message<'_> {
    parse_var_message(line).map(|m| match m {
        VarMessage::Set { name, value } => (true, name.as_bytes(), Some(value)),
        VarMessage::Get { name } => (false, name.as_bytes(), None),
    })
}

/// The reply decoder on one line: its value, or its error (kind, offset in the line).
fn reply(name: &str, line: &[u8]) -> Result<i32, (ErrorKind, usize)> {
    let mut framed = line.to_vec();
    framed.push(b'\n');
    let mut dec = VarReplyDecoder::new(name).unwrap();
    match dec.decode(&framed) {
        Ok(s) => Ok(s.item().expect("one whole line decodes to an item")),
        Err(e) => Err((e.kind(), usize::try_from(e.offset()).unwrap())),
    }
}

#[test]
fn errors_point_at_the_byte_that_breaks_the_line() {
    let unexpected = |found, at| {
        Err((
            ErrorKind::UnexpectedByte {
                found,
                expected: oracle::EXPECTED_MESSAGE,
            },
            at,
        ))
    };
    assert_eq!(ours(b"GEX A"), unexpected(b'X', 2));
    assert_eq!(ours(b"PUT A"), unexpected(b'P', 0));
    assert_eq!(ours(b"SETA 1"), unexpected(b'A', 3));
    assert_eq!(ours(b"SET A 1x"), unexpected(b'x', 7));
    assert_eq!(ours(b"SET A -x"), unexpected(b'x', 7));
    assert_eq!(ours(b"SE"), Err((ErrorKind::Truncated, 2)));
    assert_eq!(ours(b""), Err((ErrorKind::Truncated, 0)));
    assert_eq!(ours(b"SET A "), Err((ErrorKind::Truncated, 6)));
    assert_eq!(
        ours(b"SET A 2147483648"),
        Err((ErrorKind::IntegerOutOfRange, 6))
    );
    assert_eq!(ours(b"SET A +007"), Ok((true, &b"A"[..], Some(7))));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn messages_agree_with_the_oracle(line in line()) {
        prop_assert_eq!(ours(&line), oracle::var_message(&line), "{:?}", String::from_utf8_lossy(&line));
    }

    #[test]
    fn replies_agree_with_the_oracle(line in line()) {
        // The decoder drops one CR before the LF, as the framer does for every line.
        let bare = line.strip_suffix(b"\r").unwrap_or(&line);
        prop_assert_eq!(reply("POS_X", &line), oracle::var_reply(bare, b"POS_X"), "{:?}", String::from_utf8_lossy(&line));
    }
}
