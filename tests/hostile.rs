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
use urscript_socket::{Decode, ErrorKind, RecvBuffer};

const HUNDRED_MB: usize = 100 << 20;

/// Streams `total` bytes of `filler` in 64 KiB pieces, then `tail`, through `d` over a
/// fixed 64 KiB buffer. Returns (errors seen, good messages after the flood).
fn flood<D: Decode>(
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
        assert!(robot.buffered().len() <= 4096);
    }
    // Bytes that cannot begin the prefix are dropped when the buffer fills (as the
    // controller discards what comes before a prefix), so the flood passes through a
    // buffer that never grows, and the socket is never wedged.
    assert!(accepted > 4096, "{accepted}");
    assert!(robot.buffered().len() <= 4096);
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

// ---- Issue 14, findings 6-8, and issue 10's offset bug: each failed on the old main. ----

/// Finding 6: `with_max_len(usize::MAX)` panicked in debug builds (`max_len + 1`) and, in
/// release, rejected every message at offset 18446744073709551615. Bounds are now clamped to
/// `MAX_BOUND`, and every message decodes.
#[test]
fn a_bound_of_usize_max_is_clamped_not_overflowed() {
    use urscript_socket::MAX_BOUND;
    let mut line = LineDecoder::with_max_len(usize::MAX);
    assert_eq!(line.max_len(), MAX_BOUND);
    assert_eq!(line.decode(b"abc\n").unwrap().item(), Some(&b"abc"[..]));
    assert_eq!(line.decode_eof(b"x\n").unwrap(), Some((&b"x"[..], 2)));
    let mut delimited = DelimitedDecoder::with_max_len(b"\r\n", usize::MAX).unwrap();
    assert_eq!(
        delimited.decode(b"ab\r\n").unwrap().item(),
        Some(&b"ab"[..])
    );
    assert_eq!(
        delimited.decode_eof(b"tail").unwrap(),
        Some((&b"tail"[..], 4))
    );
    let mut stx = StxEtxDecoder::with_max_len(usize::MAX);
    assert_eq!(stx.decode(b"\x02ok\x03").unwrap().item(), Some(&b"ok"[..]));
    let mut floats = FloatTupleDecoder::new(1).unwrap().with_max_len(usize::MAX);
    assert_eq!(floats.decode(b"(1)").unwrap().item().unwrap().read(), [1.0]);
    let mut values = urscript_socket::to_str::ValueLineDecoder::with_max_len(usize::MAX);
    assert!(values.decode(b"True\n").unwrap().item().is_some());
    // Over a long partial line the bound is never reached, and nothing wraps.
    let mut line = LineDecoder::with_max_len(usize::MAX - 1);
    let long = vec![b'x'; 100_000];
    assert_eq!(line.decode(&long).unwrap().consumed(), 0);
    assert_eq!(line.decode_eof(&long).unwrap_err().offset(), 0);
}

/// Drives `decode_eof` the way every caller must (drop `skip` after an error) and returns
/// what each call gave: items as `Some(debug)`, errors as (kind, offset), the last `None`.
fn eof_calls<D: Decode>(d: &mut D, mut buf: &[u8]) -> Vec<Result<String, (ErrorKind, u64)>>
where
    for<'a> D::Item<'a>: std::fmt::Debug,
{
    let mut out = Vec::new();
    for _ in 0..10 {
        match d.decode_eof(buf) {
            Ok(Some((item, n))) => {
                out.push(Ok(format!("{item:?}")));
                buf = &buf[n..];
            }
            Ok(None) => {
                out.push(Ok("None".into()));
                break;
            }
            Err(e) => {
                out.push(Err((e.kind(), e.offset())));
                buf = &buf[e.skip()..];
            }
        }
    }
    out
}

/// Finding 7: after an end-of-input error the offending bytes are dropped and the next call
/// returns `Ok(None)`. The old line decoder reported an over-long tail twice (TooLong, then
/// Truncated), the STX/ETX decoder reported its rest as noise, and a `RecvBuffer` kept the
/// bytes a decoder had dropped at end of input, so a delimited decoder flushed them again.
#[test]
fn end_of_input_errors_are_final() {
    let too_long = |limit| Err((ErrorKind::TooLong { limit }, 2));
    let none = Ok("None".to_string());
    let mut line = LineDecoder::with_max_len(2);
    assert_eq!(eof_calls(&mut line, b"abcdef"), [too_long(2), none.clone()]);
    assert_eq!(line.position(), 6);
    let mut stx = StxEtxDecoder::with_max_len(1);
    assert_eq!(
        eof_calls(&mut stx, b"\x02abcdef"),
        [too_long(1), none.clone()]
    );
    let mut delimited = DelimitedDecoder::with_max_len(b"<>", 2).unwrap();
    assert_eq!(
        eof_calls(&mut delimited, b"abcd<"),
        [too_long(2), none.clone()]
    );
    // The same through a RecvBuffer: once `Ok(None)` or the error came, it stays `Ok(None)`.
    let mut rx = RecvBuffer::<[u8; 16]>::new();
    let mut delimited = DelimitedDecoder::with_max_len(b"<>", 2).unwrap();
    rx.extend(b"abcd<");
    assert_eq!(
        rx.decode_eof(&mut delimited).unwrap_err().kind(),
        ErrorKind::TooLong { limit: 2 }
    );
    for _ in 0..3 {
        assert_eq!(rx.decode_eof(&mut delimited).unwrap(), None);
        assert!(rx.is_empty());
    }
    assert_eq!(delimited.position(), 5);
    let mut rx = RecvBuffer::<[u8; 16]>::new();
    let mut lines = LineDecoder::new();
    rx.extend(b"ok\ncut");
    assert_eq!(rx.decode_eof(&mut lines).unwrap(), Some(&b"ok"[..]));
    let e = rx.decode_eof(&mut lines).unwrap_err();
    assert_eq!((e.kind(), e.offset()), (ErrorKind::Truncated, 3));
    for _ in 0..3 {
        assert_eq!(rx.decode_eof(&mut lines).unwrap(), None);
    }
    // Noise before `(` under the default policy: dropped, accounted, and gone.
    let mut rx = RecvBuffer::<[u8; 16]>::new();
    let mut floats = FloatTupleDecoder::new(1).unwrap();
    rx.extend(b" \n ");
    assert_eq!(rx.decode_eof(&mut floats).unwrap(), None);
    assert!(rx.is_empty());
    assert_eq!(floats.position(), 3);
}

/// Finding 7 through the tokio codecs, where it was seen: the line, STX/ETX and delimited
/// codecs returned the same error forever (offsets 3, 6, 9...) from repeated `decode_eof`.
#[cfg(feature = "tokio")]
#[test]
fn tokio_codecs_end_of_input_errors_are_final() {
    use bytes::BytesMut;
    use tokio_util::codec::Decoder as _;
    use urscript_socket::adapters::tokio_codec::{DelimitedCodec, LineCodec, StxEtxCodec};
    let mut src = BytesMut::from(&b"abc"[..]);
    let mut lines = LineCodec::new();
    assert!(lines.decode_eof(&mut src).is_err());
    assert!(lines.decode_eof(&mut src).unwrap().is_none());
    let mut src = BytesMut::from(&b"\x02abc"[..]);
    let mut stx = StxEtxCodec::new();
    assert!(stx.decode_eof(&mut src).is_err());
    assert!(stx.decode_eof(&mut src).unwrap().is_none());
    let mut src = BytesMut::from(&b"abc"[..]);
    let mut delimited = DelimitedCodec::new(b";").unwrap();
    assert_eq!(
        &delimited.decode_eof(&mut src).unwrap().unwrap()[..],
        b"abc"
    );
    assert!(delimited.decode_eof(&mut src).unwrap().is_none());
}

/// Finding 8: a receive buffer smaller than its decoder's bound wedged: full, no complete
/// message, `Ok(None)` forever. Now the message is reported once as too long for the
/// buffer, dropped, the rest of it discarded as it comes, and the next one decodes: for
/// every shape that can (a `socket_read_string` by its rule consumes nothing until complete).
#[test]
fn a_buffer_smaller_than_the_bound_reports_once_and_recovers() {
    fn run<D: Decode>(mut d: D, stream: &[u8]) -> (Vec<ErrorKind>, Vec<String>)
    where
        for<'a> D::Item<'a>: std::fmt::Debug,
    {
        let mut rx = RecvBuffer::<[u8; 8]>::new();
        let (mut errors, mut items) = (Vec::new(), Vec::new());
        let mut rest = stream;
        let mut rounds = 0;
        while !rest.is_empty() || !rx.is_empty() {
            rounds += 1;
            assert!(rounds < 1000, "wedged");
            let n = rx.extend(rest);
            rest = &rest[n..];
            loop {
                match rx.decode(&mut d) {
                    Ok(Some(item)) => items.push(format!("{item:?}")),
                    Ok(None) => break,
                    Err(e) => errors.push(e.kind()),
                }
            }
            if rest.is_empty() {
                if let Ok(Some(item)) = rx.decode_eof(&mut d) {
                    items.push(format!("{item:?}"));
                }
                break;
            }
        }
        (errors, items)
    }
    let once = vec![ErrorKind::TooLong { limit: 8 }];
    let (e, items) = run(LineDecoder::new(), b"a much longer line\nok\n");
    assert_eq!((e, items), (once.clone(), vec!["[111, 107]".to_string()]));
    let (e, items) = run(DelimitedDecoder::new(b"<>").unwrap(), b"0123456789<>ok<>");
    assert_eq!((e, items.len()), (once.clone(), 1));
    let (e, items) = run(StxEtxDecoder::new(), b"\x02payload too big\x03\x02ok\x03");
    assert_eq!((e, items), (once.clone(), vec!["[111, 107]".to_string()]));
    let (e, items) = run(
        FloatTupleDecoder::new(3).unwrap(),
        b"(1.5, 2.5, 3.5)(1,2,3)",
    );
    assert_eq!((e, items.len()), (once.clone(), 1));
    // 12 bytes per message, none fits: each is reported once and skipped by its count, so
    // the stream stays aligned (no error, no item from a message's tail).
    let ints = [[0u8, 0, 0, 1, 0, 0, 0, 2, 0, 0, 0, 3]; 3].concat();
    let (e, items) = run(urscript_socket::int32::Int32Decoder::new(3).unwrap(), &ints);
    assert_eq!(e, [ErrorKind::TooLong { limit: 8 }; 3]);
    assert!(items.is_empty(), "{items:?}");
    let (e, items) = run(urscript_socket::int32::Int32Decoder::new(2).unwrap(), &ints);
    assert_eq!(
        (e.len(), items.len()),
        (0, 4),
        "8-byte messages fit: {items:?}"
    );
    // The documented exception: a read-string window waits (nothing consumed).
    let mut rx = RecvBuffer::<[u8; 8]>::new();
    let mut read = ReadStringDecoder::new(b">", b"<", false).unwrap();
    rx.extend(b"0123456789");
    assert_eq!(rx.decode(&mut read).unwrap(), None);
    assert!(rx.is_full());
}

/// Issue 10: `printf 'p[1,2,x,4,5,6]\r\n' | ursock decode value` said byte 7; the `x` is
/// byte 6, with LF or CR LF alike. The framer says where a line's content starts, so the
/// value-line decoder's errors point at the byte.
#[test]
fn value_line_errors_point_at_the_bad_byte() {
    use urscript_socket::to_str::ValueLineDecoder;
    for input in [&b"p[1,2,x,4,5,6]\r\n"[..], b"p[1,2,x,4,5,6]\n"] {
        let e = ValueLineDecoder::new().decode(input).unwrap_err();
        assert_eq!(
            (e.kind(), e.offset(), e.skip()),
            (ErrorKind::InvalidNumber, 6, input.len())
        );
    }
    // After other lines, and through `Status::at`.
    let mut d = ValueLineDecoder::new();
    let s = d.decode(b"[1, 2]\r\np[1,2,x,4,5,6]\r\n").unwrap();
    assert_eq!((s.at(), s.consumed()), (Some(0), 8));
    assert_eq!(d.decode(b"p[1,2,x,4,5,6]\r\n").unwrap_err().offset(), 8 + 6);
}

/// Found by the `api` fuzz target: a caller that breaks the contract (passes fewer bytes
/// than it was told to keep) made the read-string window slice past the buffer's end
/// (`range start index 5 out of range`), a panic reachable from the public API. Now the
/// decoder searches such a buffer afresh, and a bracketed frame never ends before it starts.
#[test]
fn a_caller_that_passes_fewer_bytes_gets_no_panic() {
    let mut read = ReadStringDecoder::new(b">>>>", b"<", false).unwrap();
    assert!(read.decode(b">>>>ab").unwrap().item().is_none());
    assert!(read.decode(b"").unwrap().item().is_none());
    assert_eq!(read.decode_eof(b"").unwrap(), None);
    assert!(read.decode(b">>>>ab").unwrap().item().is_none());
    assert_eq!(read.decode(b"xy<").unwrap().item(), None);
    let mut floats = FloatTupleDecoder::new(1).unwrap();
    assert!(floats.decode(b"(1").unwrap().item().is_none());
    let _ = floats.decode(b")");
    let mut stx = StxEtxDecoder::new();
    assert!(stx.decode(b"\x02ab").unwrap().item().is_none());
    let _ = stx.decode(b"\x03");
}

/// Found by `recv_buffer_of_any_size_never_wedges`: a delimited decoder with a bound of 0
/// flushed an empty message that consumed nothing at end of input, forever. Now the rest is
/// reported over-long once and dropped.
#[test]
fn a_zero_bound_flush_ends() {
    // Half a two-byte delimiter is held: nothing of it fits a bound of 0.
    let mut d = DelimitedDecoder::with_max_len(b"<>", 0).unwrap();
    let e = d.decode_eof(b"<").unwrap_err();
    assert_eq!((e.kind(), e.skip()), (ErrorKind::TooLong { limit: 0 }, 1));
    assert_eq!(d.decode_eof(b"").unwrap(), None);
    assert_eq!(d.position(), 1);
    assert_eq!(d.flush(b"<"), None);
}
