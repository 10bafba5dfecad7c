//! The tokio codecs as tokio-util users drive them: every encoder input type, request/reply
//! on one `Framed`, tolerant mode on every codec, end of input, error conversions; and
//! the owned items every adapter shares (`Int32Stream`, `OwnedDecoder`, `VarRequest`).

use bytes::{Bytes, BytesMut};
use futures_util::{SinkExt, StreamExt};
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio_util::codec::{Decoder, Encoder, Framed, FramedRead};
use urscript_socket::adapters::tokio_codec::{
    ByteCodec, CodecError, DelimitedCodec, FloatTupleCodec, Int32Codec, LineCodec, RequestReply,
    StxEtxCodec, Tolerant, VarCodec, VarRequest,
};
use urscript_socket::adapters::{ByteStream, Int32Stream, OwnedDecoder};
use urscript_socket::{EncodeError, ErrorKind};

fn encoded<T, C: Encoder<T, Error = CodecError>>(c: &mut C, item: T) -> Vec<u8> {
    let mut buf = BytesMut::new();
    c.encode(item, &mut buf).unwrap();
    buf.to_vec()
}

#[test]
fn text_codecs_take_every_byte_like_type() {
    let mut c = LineCodec::new();
    let s = String::from("OK");
    let v = b"OK".to_vec();
    for got in [
        encoded(&mut c, "OK"),
        encoded(&mut c, String::from("OK")),
        encoded(&mut c, &s),
        encoded(&mut c, b"OK".to_vec()),
        encoded(&mut c, &v),
        encoded(&mut c, Bytes::from_static(b"OK")),
        encoded(&mut c, BytesMut::from(&b"OK"[..])),
        encoded(&mut c, &b"OK"[..]),
        encoded(&mut c, *b"OK"),
        encoded(&mut c, b"OK"),
    ] {
        assert_eq!(got, b"OK\n");
    }
    assert_eq!(encoded(&mut StxEtxCodec::new(), "hi"), b"\x02hi\x03");
    assert_eq!(
        encoded(&mut StxEtxCodec::new(), String::from("hi")),
        b"\x02hi\x03"
    );
    let mut cr = DelimitedCodec::new(b"\r").unwrap();
    assert_eq!(encoded(&mut cr, "T1"), b"T1\r");
    assert_eq!(encoded(&mut cr, Bytes::from("T1")), b"T1\r");
}

#[test]
fn text_encoders_refuse_what_breaks_the_framing() {
    let mut buf = BytesMut::new();
    let e = LineCodec::new().encode("a\nb", &mut buf).unwrap_err();
    assert!(matches!(e, CodecError::Encode(_)), "{e}");
    let e = StxEtxCodec::new()
        .encode(vec![b'a', 3], &mut buf)
        .unwrap_err();
    assert!(matches!(e, CodecError::Encode(_)), "{e}");
}

#[test]
fn float_codec_takes_arrays_slices_vecs_and_enforces_its_count() {
    let mut c = FloatTupleCodec::new(3).unwrap();
    let v = vec![1.0, 2.5, -3.0];
    let a = [1.0, 2.5, -3.0];
    for got in [
        encoded(&mut c, a),
        encoded(&mut c, &a),
        encoded(&mut c, &a[..]),
        encoded(&mut c, v.clone()),
        encoded(&mut c, &v),
    ] {
        assert_eq!(got, b"(1,2.5,-3)");
    }
    let mut buf = BytesMut::from(&b"kept"[..]);
    for wrong in [vec![], vec![1.0], vec![1.0; 4], vec![1.0; 31]] {
        let e = c.encode(wrong.clone(), &mut buf).unwrap_err();
        assert!(
            matches!(e, CodecError::WrongCount { expected: 3, found } if found == wrong.len()),
            "{e}"
        );
        assert!(e.to_string().contains("3 values per message"), "{e}");
    }
    // NaN is refused too, and nothing of the tuple is left behind.
    let e = c.encode([1.0, f64::NAN, 2.0], &mut buf).unwrap_err();
    assert!(
        matches!(e, CodecError::Encode(EncodeError::NotFinite { index: 1 })),
        "{e}"
    );
    assert_eq!(buf, &b"kept"[..]);
    let mut lf = FloatTupleCodec::new(2).unwrap().with_trailing_lf(true);
    assert_eq!(encoded(&mut lf, [0.5, 0.25]), b"(0.5,0.25)\n");
}

#[test]
fn int32_and_byte_codecs_take_values_and_lists() {
    let mut c = Int32Codec::new();
    assert_eq!(encoded(&mut c, -2), [0xFF, 0xFF, 0xFF, 0xFE]);
    let want = [0, 0, 0, 1, 0, 0, 0, 2];
    let v = vec![1, 2];
    for got in [
        encoded(&mut c, [1, 2]),
        encoded(&mut c, &[1, 2]),
        encoded(&mut c, &[1, 2][..]),
        encoded(&mut c, v.clone()),
        encoded(&mut c, &v),
    ] {
        assert_eq!(got, want);
    }
    let mut b = ByteCodec::new();
    assert_eq!(encoded(&mut b, 13u8), [13]);
    let bv = vec![2u8, 3];
    for got in [
        encoded(&mut b, [2u8, 3]),
        encoded(&mut b, &[2u8, 3]),
        encoded(&mut b, &[2u8, 3][..]),
        encoded(&mut b, bv.clone()),
        encoded(&mut b, &bv),
        encoded(&mut b, Bytes::from_static(&[2, 3])),
    ] {
        assert_eq!(got, [2, 3]);
    }
}

#[test]
fn var_codec_replies_with_any_name_type() {
    let mut c = VarCodec::new();
    let name = String::from("POS_X");
    assert_eq!(encoded(&mut c, ("POS_X", 1)), b"POS_X 1\n");
    assert_eq!(encoded(&mut c, (name.clone(), 2)), b"POS_X 2\n");
    assert_eq!(encoded(&mut c, (&name, 3)), b"POS_X 3\n");
    assert!(c.encode(("BAD NAME", 1), &mut BytesMut::new()).is_err());
}

#[test]
fn request_reply_decodes_with_one_and_encodes_with_the_other() {
    let mut c = RequestReply::new(VarCodec::new(), Int32Codec::new());
    let mut rx = BytesMut::from(&b"GET A\n"[..]);
    assert_eq!(
        c.decode(&mut rx).unwrap(),
        Some(VarRequest::Get { name: "A".into() })
    );
    assert_eq!(encoded(&mut c, 7), [0, 0, 0, 7]);
    // End of input goes to the decoder: a SET cut before its LF is reported, then gone.
    let mut rx = BytesMut::from(&b"SET A 1"[..]);
    assert_eq!(c.decode(&mut rx).unwrap(), None);
    let e = c.decode_eof(&mut rx).unwrap_err();
    assert!(
        matches!(e, CodecError::Decode(d) if d.kind() == ErrorKind::Truncated),
        "{e}"
    );
    assert!(rx.is_empty());
    assert_eq!(c.decode_eof(&mut rx).unwrap(), None);
    let (_dec, enc) = c.into_parts();
    let _: Int32Codec = enc;
}

/// Drives a tolerant codec over `input` fed one byte at a time, then end of input.
fn tolerant_items<C>(codec: C, input: &[u8]) -> Vec<Result<String, ErrorKind>>
where
    C: Decoder<Error = CodecError>,
    C::Item: std::fmt::Debug,
{
    let mut c = Tolerant::new(codec);
    let mut buf = BytesMut::new();
    let mut out = Vec::new();
    for &b in input {
        buf.extend_from_slice(&[b]);
        while let Some(item) = c.decode(&mut buf).unwrap() {
            out.push(item.map(|v| format!("{v:?}")).map_err(|e| e.kind()));
        }
    }
    while let Some(item) = c.decode_eof(&mut buf).unwrap() {
        out.push(item.map(|v| format!("{v:?}")).map_err(|e| e.kind()));
    }
    out
}

#[test]
fn tolerant_mode_reports_and_goes_on_for_every_codec() {
    let lines = tolerant_items(LineCodec::with_max_len(4), b"ok\ntoo long\nok2\ncut");
    assert_eq!(lines.len(), 4, "{lines:?}");
    assert!(lines[0].is_ok() && lines[2].is_ok());
    assert_eq!(lines[1], Err(ErrorKind::TooLong { limit: 4 }));
    assert_eq!(
        lines[3],
        Err(ErrorKind::Truncated),
        "a line cut by the end of input"
    );

    let vars = tolerant_items(VarCodec::new(), b"SET A x\nGET A\nHELLO\nSET B 2\n");
    assert_eq!(vars.len(), 4, "{vars:?}");
    assert!(vars[0].is_err() && vars[2].is_err());
    assert_eq!(
        vars[1],
        Ok(format!("{:?}", VarRequest::Get { name: "A".into() }))
    );
    assert!(vars[3].is_ok());

    let floats = tolerant_items(FloatTupleCodec::new(2).unwrap(), b"(1,x)(1,2)(3,4,5)(6,7)");
    assert_eq!(floats.iter().filter(|r| r.is_ok()).count(), 2, "{floats:?}");
    assert!(floats.iter().any(|r| r.is_err()));

    let stx = tolerant_items(StxEtxCodec::new(), b"\x02a\x03\x02cut");
    assert_eq!(stx.len(), 2, "{stx:?}");
    assert_eq!(stx[1], Err(ErrorKind::Truncated));

    let ints = tolerant_items(Int32Codec::new(), &[0, 0, 0, 5, 0, 0]);
    assert_eq!(ints, [Ok("5".to_string()), Err(ErrorKind::Truncated)]);
}

#[test]
fn tolerant_encodes_through() {
    let mut c = Tolerant::new(FloatTupleCodec::new(1).unwrap());
    assert_eq!(encoded(&mut c, [2.0]), b"(2)");
    assert!(matches!(
        c.encode([1.0, 2.0], &mut BytesMut::new()),
        Err(CodecError::WrongCount { .. })
    ));
    let _: &FloatTupleCodec = c.get_ref();
}

#[tokio::test]
async fn without_tolerant_the_stream_ends_with_it_it_goes_on() {
    let input = b"a line longer than eight\nshoot\n";
    let strict: Vec<_> = FramedRead::new(&input[..], LineCodec::with_max_len(8))
        .collect()
        .await;
    assert_eq!(
        strict.len(),
        1,
        "tokio-util ends the stream at the first error"
    );
    assert!(strict[0].is_err());

    let tolerant: Vec<_> = FramedRead::new(&input[..], Tolerant::new(LineCodec::with_max_len(8)))
        .collect()
        .await;
    assert_eq!(tolerant.len(), 2);
    assert!(tolerant[0].as_ref().unwrap().is_err());
    assert_eq!(tolerant[1].as_ref().unwrap().as_ref().unwrap(), "shoot");
}

#[tokio::test]
async fn one_framed_line_in_tuple_out_over_a_duplex() {
    let (server, mut robot) = tokio::io::duplex(64);
    let mut framed = Framed::new(
        server,
        RequestReply::new(
            Tolerant::new(LineCodec::new()),
            FloatTupleCodec::new(2).unwrap(),
        ),
    );
    robot.write_all(b"shoot\n").await.unwrap();
    assert_eq!(framed.next().await.unwrap().unwrap().unwrap(), "shoot");
    framed.send(vec![1.0, 2.0]).await.unwrap();
    framed.send(&[3.0, 4.0][..]).await.unwrap();
    assert!(framed.send([1.0]).await.is_err());
    drop(framed);
    let mut got = Vec::new();
    robot.read_to_end(&mut got).await.unwrap();
    assert_eq!(got, b"(1,2)(3,4)");
}

#[test]
fn codec_errors_convert_into_io_errors() {
    use std::io::ErrorKind as Io;
    let io = std::io::Error::new(Io::BrokenPipe, "gone");
    assert_eq!(
        std::io::Error::from(CodecError::Io(io)).kind(),
        Io::BrokenPipe
    );
    let mut buf = BytesMut::from(&b"SET\n"[..]);
    let decode = VarCodec::new().decode(&mut buf).unwrap_err();
    assert_eq!(std::io::Error::from(decode).kind(), Io::InvalidData);
    let encode = CodecError::Encode(EncodeError::NoValues);
    assert_eq!(std::io::Error::from(encode).kind(), Io::InvalidInput);
}

/// `socket_send_int` values are `i32` in every adapter: tokio, blocking, embedded.
#[tokio::test]
async fn single_ints_are_i32_everywhere() {
    let bytes: Vec<u8> = [7i32, -1, i32::MIN]
        .iter()
        .flat_map(|v| v.to_be_bytes())
        .collect();
    let tokio_items: Vec<i32> = FramedRead::new(&bytes[..], Int32Codec::new())
        .map(Result::unwrap)
        .collect()
        .await;
    let blocking_items: Vec<i32> =
        urscript_socket::adapters::blocking::MessageReader::new(&bytes[..], Int32Stream::new())
            .map(Result::unwrap)
            .collect();
    assert_eq!(tokio_items, [7, -1, i32::MIN]);
    assert_eq!(blocking_items, tokio_items);
    let bytes_items: Vec<u8> =
        urscript_socket::adapters::blocking::MessageReader::new(&[2u8, 3][..], ByteStream::new())
            .map(Result::unwrap)
            .collect();
    assert_eq!(bytes_items, [2, 3]);
}

#[test]
fn owned_forms_of_every_core_message() {
    use urscript_socket::ascii_float::FloatTupleDecoder;
    use urscript_socket::byte_list::ByteListDecoder;
    use urscript_socket::int32::Int32Decoder;
    use urscript_socket::line::LineDecoder;
    use urscript_socket::string::{DelimitedDecoder, ReadStringDecoder};
    use urscript_socket::stx_etx::StxEtxDecoder;
    use urscript_socket::var::{VarMessageDecoder, VarReplyDecoder};

    fn first<D: OwnedDecoder>(mut d: D, input: &[u8]) -> D::Owned {
        D::to_owned_item(d.decode(input).unwrap().item().unwrap())
    }
    assert_eq!(first(LineDecoder::new(), b"a\n"), b"a");
    assert_eq!(first(StxEtxDecoder::new(), b"\x02a\x03"), b"a");
    assert_eq!(first(DelimitedDecoder::new(b";").unwrap(), b"a;"), b"a");
    assert_eq!(
        first(ReadStringDecoder::new(b">", b"<", false).unwrap(), b">a<"),
        b"a"
    );
    assert_eq!(first(ByteListDecoder::new(2).unwrap(), &[1, 2]), [1, 2]);
    assert_eq!(
        first(Int32Decoder::new(2).unwrap(), &[0, 0, 0, 1, 0, 0, 0, 2]),
        [1, 2]
    );
    assert_eq!(first(Int32Stream::new(), &[0, 0, 0, 9]), 9);
    assert_eq!(first(ByteStream::new(), &[9]), 9);
    assert_eq!(
        first(FloatTupleDecoder::new(1).unwrap(), b"(1.5)").values(),
        [1.5]
    );
    assert_eq!(first(VarReplyDecoder::new("A").unwrap(), b"A 5\n"), 5);
    assert_eq!(
        first(VarMessageDecoder::new(), b"SET A 5\n"),
        VarRequest::Set {
            name: "A".into(),
            value: 5
        }
    );
}

/// Both orders compose: `Tolerant<RequestReply<..>>` and `RequestReply<Tolerant<..>, ..>`.
#[tokio::test]
async fn tolerant_and_request_reply_compose_either_way() {
    let input = b"SET A x\nGET A\n";
    let outer: Vec<_> = FramedRead::new(
        &input[..],
        Tolerant::new(RequestReply::new(VarCodec::new(), Int32Codec::new())),
    )
    .collect()
    .await;
    let inner: Vec<_> = FramedRead::new(
        &input[..],
        RequestReply::new(Tolerant::new(VarCodec::new()), Int32Codec::new()),
    )
    .collect()
    .await;
    for items in [&outer, &inner] {
        assert_eq!(items.len(), 2);
        assert!(items[0].as_ref().unwrap().is_err());
        assert_eq!(
            items[1].as_ref().unwrap().as_ref().unwrap(),
            &VarRequest::Get { name: "A".into() }
        );
    }
    let mut c = Tolerant::new(RequestReply::new(VarCodec::new(), Int32Codec::new()));
    assert_eq!(encoded(&mut c, [1, 2]).len(), 8);
}

/// The run-time codec decodes every registry format, byte by byte as whole, and its
/// owned items print as the borrowed messages do.
#[test]
fn format_codec_covers_every_registry_format() {
    use urscript_socket::format::Format;
    let cases: [(Format, &[u8], &str); 10] = [
        (
            Format::FloatTuple { number: 2 },
            b"(1.5,-3)",
            "[2, 1.5, -3]",
        ),
        (Format::Int32 { number: 1 }, &[0, 0, 0, 7], "[7]"),
        (Format::Bytes { number: 2 }, &[2, 65], "[2, 65]"),
        (Format::Line, b"hi\r\n", "\"hi\""),
        (
            Format::String {
                prefix: b">",
                suffix: b"<",
                interpret_escape: false,
            },
            b"junk>ok<",
            "\"ok\"",
        ),
        (Format::Delimited { delimiter: b";" }, b"a;", "\"a\""),
        (Format::StxEtx, b"\x02ab\x03", "\"ab\""),
        (Format::Var, b"GET X\n", "GET X"),
        (Format::VarReply { name: "X" }, b"X 5\n", "5"),
        (
            Format::Value,
            b"p[1, 2, 3, 0, 0, 0.5]\n",
            "p[1, 2, 3, 0, 0, 0.5]",
        ),
    ];
    for (format, bytes, text) in cases {
        let mut whole = urscript_socket::adapters::tokio_codec::FormatCodec::new(format).unwrap();
        let mut buf = bytes::BytesMut::from(bytes);
        let got = whole.decode(&mut buf).unwrap().unwrap();
        assert_eq!(got.to_string(), text, "{format}");
        let mut bytewise =
            urscript_socket::adapters::tokio_codec::FormatCodec::new(format).unwrap();
        let mut buf = bytes::BytesMut::new();
        let mut items = Vec::new();
        for b in bytes {
            buf.extend_from_slice(&[*b]);
            if let Some(m) = bytewise.decode(&mut buf).unwrap() {
                items.push(m);
            }
        }
        assert_eq!(items, [got], "{format}");
    }
}
