//! Hostile input in the normal suite: 100 MB without a terminator into every bounded
//! decoder, 10,000-digit numbers, a million empty tokens, endlessly repeated prefixes,
//! invalid UTF-8. The decoders must report at the bound, keep memory bounded (the receive
//! buffer never grows) and recover for the next good message.

use std::time::Duration;
use urscript_socket::ascii_float::FloatTupleDecoder;
use urscript_socket::line::LineDecoder;
use urscript_socket::robot::{Policy, ReadCall, SocketConnection, Timeout};
use urscript_socket::string::{DelimitedDecoder, ReadStringDecoder};
use urscript_socket::stx_etx::StxEtxDecoder;
use urscript_socket::to_str::parse_value;
use urscript_socket::var::{VarMessageDecoder, VarReplyDecoder};
use urscript_socket::{Decoder, ErrorKind, RecvBuffer};

const HUNDRED_MB: usize = 100 << 20;

/// Streams `total` bytes of `filler` in 64 KiB pieces, then `tail`, through `d` over a
/// fixed 64 KiB buffer. Returns (errors seen, good messages after the flood).
fn flood<D: Decoder>(
    mut d: D,
    start: &[u8],
    filler: u8,
    total: usize,
    tail: &[u8],
) -> (Vec<ErrorKind>, usize) {
    let mut rx = RecvBuffer::<[u8; 65536]>::new();
    let piece = vec![filler; 65536];
    let mut errors = Vec::new();
    let mut good = 0;
    let mut drain =
        |rx: &mut RecvBuffer<[u8; 65536]>, errors: &mut Vec<ErrorKind>, good: &mut usize| loop {
            match rx.decode(&mut d) {
                Ok(Some(_)) => *good += 1,
                Ok(None) => break,
                Err(e) => errors.push(e.kind()),
            }
        };
    assert_eq!(rx.extend(start), start.len());
    let mut sent = 0;
    while sent < total {
        let n = rx.extend(&piece[..piece.len().min(total - sent)]);
        assert!(
            n > 0,
            "the decoder must make room: buffer stuck full at {sent} bytes"
        );
        sent += n;
        drain(&mut rx, &mut errors, &mut good);
        assert!(rx.len() <= rx.capacity());
    }
    let flood_good = good;
    let mut rest = tail;
    while !rest.is_empty() {
        let n = rx.extend(rest);
        rest = &rest[n..];
        drain(&mut rx, &mut errors, &mut good);
    }
    (errors, good - flood_good)
}

#[test]
fn hundred_megabytes_without_a_terminator() {
    let too_long = |e: &[ErrorKind]| e.len() == 1 && matches!(e[0], ErrorKind::TooLong { .. });
    let (e, good) = flood(LineDecoder::new(), b"", b'x', HUNDRED_MB, b"\nok\n");
    assert!(too_long(&e) && good == 1, "line: {e:?} {good}");
    let (e, good) = flood(
        StxEtxDecoder::new(),
        b"\x02",
        b'x',
        HUNDRED_MB,
        b"\x03\x02ok\x03",
    );
    assert!(too_long(&e) && good == 1, "stx: {e:?} {good}");
    let (e, good) = flood(
        DelimitedDecoder::new(b"<>").unwrap(),
        b"",
        b'<',
        HUNDRED_MB,
        b"<>ok<>",
    );
    assert!(too_long(&e) && good == 1, "delimited: {e:?} {good}");
    let (e, good) = flood(
        FloatTupleDecoder::new(2).unwrap(),
        b"(",
        b'1',
        HUNDRED_MB,
        b")(1,2)",
    );
    assert!(too_long(&e) && good == 1, "float: {e:?} {good}");
    let (e, good) = flood(
        VarMessageDecoder::new(),
        b"SET ",
        b'A',
        HUNDRED_MB,
        b"\nGET A\n",
    );
    assert!(too_long(&e) && good == 1, "var: {e:?} {good}");
    let (e, good) = flood(
        VarReplyDecoder::new("A").unwrap(),
        b"A ",
        b'1',
        HUNDRED_MB,
        b"\nA 1\n",
    );
    assert!(too_long(&e) && good == 1, "reply: {e:?} {good}");
    // Noise outside any frame: reported once, dropped as it comes, never buffered.
    let (e, good) = flood(StxEtxDecoder::new(), b"", b'n', HUNDRED_MB, b"\x02ok\x03");
    assert_eq!((e.len(), good), (1, 1), "noise: {e:?}");
    // Bytes before `(` under the default policy: skipped silently as they come.
    let (e, good) = flood(
        FloatTupleDecoder::new(1).unwrap(),
        b"",
        b' ',
        HUNDRED_MB,
        b"(7)",
    );
    assert_eq!((e.len(), good), (0, 1));
}

#[test]
fn ten_thousand_digit_numbers() {
    let mut t = b"(".to_vec();
    t.extend(std::iter::repeat_n(b'9', 10_000));
    t.extend_from_slice(b".5,0.");
    t.extend(std::iter::repeat_n(b'0', 10_000));
    t.extend_from_slice(b"1)");
    let v = FloatTupleDecoder::new(2)
        .unwrap()
        .with_max_len(30_000)
        .decode(&t)
        .unwrap()
        .item()
        .unwrap();
    assert_eq!(
        v.values()[0],
        f64::INFINITY,
        "overflows to infinity, as str::parse does"
    );
    assert_eq!(v.values()[1], 0.0);
    let digits = "1".repeat(10_000);
    assert_eq!(
        parse_value(digits.as_bytes()).unwrap(),
        parse_value(b"1e9999").unwrap()
    );
    let mut line = b"SET A ".to_vec();
    line.extend(std::iter::repeat_n(b'0', 200));
    line.extend_from_slice(b"7\n");
    let m = VarMessageDecoder::new()
        .decode(&line)
        .unwrap()
        .item()
        .unwrap();
    assert_eq!(
        m,
        urscript_socket::var::VarMessage::Set {
            name: "A",
            value: 7
        }
    );
}

#[test]
fn a_million_empty_tokens() {
    let mut t = b"(".to_vec();
    t.extend(std::iter::repeat_n(b',', 1_000_000));
    t.push(b')');
    let mut d = FloatTupleDecoder::new(3).unwrap().with_max_len(2_000_000);
    assert_eq!(d.decode(&t).unwrap_err().kind(), ErrorKind::Empty);
    let list = format!("[{}]", ",".repeat(1_000_000));
    assert_eq!(
        parse_value(list.as_bytes()).unwrap_err().kind(),
        ErrorKind::Empty
    );
}

#[test]
fn repeated_prefixes_stay_linear_and_bounded() {
    // `<<<<...` with prefix `<<>` never matches; the scan must not restart at each byte.
    let mut d = ReadStringDecoder::new(b"<<>", b"!", false).unwrap();
    let mut buf = Vec::new();
    for _ in 0..2_000 {
        buf.extend_from_slice(&[b'<'; 500]);
        assert!(d.decode(&buf).unwrap().item().is_none());
    }
    buf.extend_from_slice(b">hi!");
    let s = d.decode(&buf).unwrap().item().unwrap();
    assert_eq!(s, b"hi");
    // The robot's buffer is bounded: a read waiting for a prefix cannot make it grow.
    let mut robot = SocketConnection::new(
        "s",
        Policy {
            receive_capacity: 4096,
            ..Policy::default()
        },
    );
    robot
        .start_read(
            ReadCall::String {
                prefix: b"<<>".to_vec(),
                suffix: vec![],
                interpret_escape: false,
            },
            Timeout::default(),
            Duration::ZERO,
        )
        .unwrap();
    let mut accepted = 0;
    for _ in 0..100 {
        accepted += robot.receive(&[b'<'; 1000]);
        assert!(robot.poll_read().is_none());
    }
    assert_eq!(accepted, 4096);
    assert_eq!(robot.give_up().unwrap().to_urscript(), "\"\"");
}

#[test]
fn invalid_utf8_in_text_formats() {
    let bad = b"\xFF\xFE\xC3\x28";
    assert_eq!(
        LineDecoder::new().decode(b"\xFF\xFE\n").unwrap().item(),
        Some(&b"\xFF\xFE"[..])
    );
    assert!(VarMessageDecoder::new().decode(b"SET \xFF 1\n").is_err());
    assert!(VarMessageDecoder::new().decode(b"GET A\xC3\x28\n").is_err());
    assert!(parse_value(bad).is_err());
    assert!(FloatTupleDecoder::new(1)
        .unwrap()
        .decode(b"(\xFF)")
        .is_err());
    let mut robot = SocketConnection::new("s", Policy::default());
    robot.receive(bad);
    robot
        .start_read(
            ReadCall::String {
                prefix: vec![],
                suffix: vec![],
                interpret_escape: false,
            },
            Timeout::Forever,
            Duration::ZERO,
        )
        .unwrap();
    assert_eq!(
        robot.poll_read().unwrap().to_urscript(),
        "\"\\xFF\\xFE\\xC3(\""
    );
}
