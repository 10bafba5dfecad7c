//! Every test vector of spec section 7, once through the core decoders/encoders and once
//! through the robot emulation.
#![allow(clippy::approx_constant)] // the spec's data, not π

use std::time::Duration;
use urscript_socket::ascii_float::{encode_float_tuple, FloatTuple, FloatTupleDecoder};
use urscript_socket::byte_list::ByteListDecoder;
use urscript_socket::int32::{encode_int32, Int32Decoder};
use urscript_socket::line::{encode_line, LineDecoder};
use urscript_socket::robot::{Policy, ReadCall, ReadResult, SocketConnection, Timeout};
use urscript_socket::string::ReadStringDecoder;
use urscript_socket::stx_etx::encode_stx_etx;
use urscript_socket::to_str::{encode_value, List, Scalar, Value};
use urscript_socket::var::{encode_set_var, VarReplyDecoder};
use urscript_socket::Status;

fn complete<T>(s: Status<T>) -> (T, usize) {
    match s {
        Status::Complete { item, consumed, .. } => (item, consumed),
        Status::Partial { .. } => panic!("expected a complete message"),
    }
}

/// Runs `call` on a fresh robot socket holding `input`; `None` input bytes = nothing came
/// and the timeout passed.
fn robot(input: &[u8], calls: &[ReadCall]) -> Vec<String> {
    let mut s = SocketConnection::new("socket_0", Policy::default());
    assert_eq!(s.receive(input), input.len());
    calls
        .iter()
        .map(|c| {
            s.start_read(c.clone(), Timeout::Forever, Duration::ZERO)
                .unwrap();
            let r: ReadResult = match s.poll_read() {
                Some(r) => r,
                None => s.give_up().unwrap(),
            };
            r.to_urscript()
        })
        .collect()
}

fn floats(n: usize) -> ReadCall {
    ReadCall::AsciiFloat { number: n }
}

fn string(prefix: &str, suffix: &str, esc: bool) -> ReadCall {
    ReadCall::String {
        prefix: prefix.into(),
        suffix: suffix.into(),
        interpret_escape: esc,
    }
}

#[test]
fn v1_ascii_float_with_spaces() {
    let (t, used) = complete(
        FloatTupleDecoder::new(4)
            .unwrap()
            .decode(b"( 1.414 , 3.14159, 1.616, 0.0 )")
            .unwrap(),
    );
    assert_eq!(
        (t.count(), t.values(), used),
        (4, &[1.414, 3.14159, 1.616, 0.0][..], 31)
    );
    assert_eq!(
        robot(b"( 1.414 , 3.14159, 1.616, 0.0 )", &[floats(4)]),
        ["[4, 1.414, 3.14159, 1.616, 0]"]
    );
}

#[test]
fn v2_ascii_float_timeout() {
    let mut d = FloatTupleDecoder::new(3).unwrap();
    assert_eq!(d.decode(b"").unwrap(), Status::Partial { consumed: 0 });
    assert_eq!(FloatTuple::failed(3).count(), 0);
    assert_eq!(robot(b"", &[floats(3)]), ["[0, nan, nan, nan]"]);
}

#[test]
fn v3_ascii_float_pose() {
    let (t, _) = complete(
        FloatTupleDecoder::new(6)
            .unwrap()
            .decode(b"(-0.15,-0.5,0.3,0,-3.14,0)")
            .unwrap(),
    );
    assert_eq!(t.values(), [-0.15, -0.5, 0.3, 0.0, -3.14, 0.0]);
    assert_eq!(
        robot(b"(-0.15,-0.5,0.3,0,-3.14,0)", &[floats(6)]),
        ["[6, -0.15, -0.5, 0.3, 0, -3.14, 0]"]
    );
}

#[test]
fn v4_ascii_float_fewer_values() {
    let (t, _) = complete(FloatTupleDecoder::new(6).unwrap().decode(b"(3)").unwrap());
    assert_eq!(t.count(), 1);
    assert_eq!(
        robot(b"(3)", &[floats(6)]),
        ["[1, 3, nan, nan, nan, nan, nan]"]
    );
}

#[test]
fn v5_ascii_float_glued_tuples() {
    let buf = b"(1,2)\n(3,4)\n";
    let mut d = FloatTupleDecoder::new(2).unwrap();
    let (a, used) = complete(d.decode(buf).unwrap());
    let (b, _) = complete(d.decode(&buf[used..]).unwrap());
    assert_eq!((a.read(), b.read()), (&[1.0, 2.0][..], &[3.0, 4.0][..]));
    assert_eq!(
        robot(buf, &[floats(2), floats(2)]),
        ["[2, 1, 2]", "[2, 3, 4]"]
    );
}

#[test]
fn v6_binary_integers() {
    let bytes = [0, 0, 0, 0x64, 0, 0, 7, 0xD0, 0, 0, 0x75, 0x30];
    let (v, _) = complete(Int32Decoder::new(3).unwrap().decode(&bytes).unwrap());
    assert_eq!(v.iter().collect::<Vec<_>>(), [100, 2000, 30000]);
    assert_eq!(
        robot(&bytes, &[ReadCall::BinaryInteger { number: 3 }]),
        ["[3, 100, 2000, 30000]"]
    );
}

#[test]
fn v7_binary_integer_timeout() {
    assert_eq!(
        robot(b"", &[ReadCall::BinaryInteger { number: 3 }]),
        ["[0, -1, -1, -1]"]
    );
}

#[test]
fn v8_binary_integer_minus_one() {
    let (v, _) = complete(Int32Decoder::new(1).unwrap().decode(&[0xFF; 4]).unwrap());
    assert_eq!(v.get(0), Some(-1));
    assert_eq!(
        robot(&[0xFF; 4], &[ReadCall::BinaryInteger { number: 1 }]),
        ["[1, -1]"]
    );
}

#[test]
fn v9_byte_list() {
    let (b, _) = complete(
        ByteListDecoder::new(3)
            .unwrap()
            .decode(&[0x64, 0xC8, 0x2C])
            .unwrap(),
    );
    assert_eq!(b, [100, 200, 44]);
    assert_eq!(
        robot(&[0x64, 0xC8, 0x2C], &[ReadCall::ByteList { number: 3 }]),
        ["[3, 100, 200, 44]"]
    );
}

#[test]
fn v10_byte_list_ack() {
    assert_eq!(
        robot(b"ack", &[ReadCall::ByteList { number: 3 }]),
        ["[3, 97, 99, 107]"]
    );
}

#[test]
fn v11_read_string_prefix_suffix_noise() {
    let (s, used) = complete(
        ReadStringDecoder::new(b">", b"<", false)
            .unwrap()
            .decode(b"noise>hello<")
            .unwrap(),
    );
    assert_eq!((s, used), (&b"hello"[..], 12)); // buffer empty afterwards
    assert_eq!(
        robot(b"noise>hello<", &[string(">", "<", false)]),
        ["\"hello\""]
    );
}

#[test]
fn v12_read_string_twice() {
    let c = string(">", "<", false);
    assert_eq!(
        robot(b">hello<>world<", &[c.clone(), c]),
        ["\"hello\"", "\"world\""]
    );
}

#[test]
fn v13_read_line_crlf() {
    let (l, _) = complete(
        LineDecoder::new()
            .decode(b"reply from the server:\r\n")
            .unwrap(),
    );
    assert_eq!(l, b"reply from the server:");
    assert_eq!(
        robot(b"reply from the server:\r\n", &[ReadCall::Line]),
        ["\"reply from the server:\""]
    );
}

#[test]
fn v14_read_string_everything() {
    let input = b"reply from the server:\n Hello World";
    let (s, _) = complete(
        ReadStringDecoder::new(b"", b"", false)
            .unwrap()
            .decode(input)
            .unwrap(),
    );
    assert_eq!(s, input);
    assert_eq!(
        robot(input, &[string("", "", false)]),
        ["\"reply from the server:\\n Hello World\""]
    );
}

#[test]
fn v15_read_string_cr_suffix_escape() {
    let mut s = SocketConnection::new("socket_0", Policy::default());
    s.receive(b"OK,1\rNEXT\r");
    s.start_read(string("", "\\r", true), Timeout::Forever, Duration::ZERO)
        .unwrap();
    assert_eq!(s.poll_read().unwrap(), ReadResult::Text(b"OK,1".to_vec()));
    assert_eq!(s.buffered(), b"NEXT\r");
}

#[test]
fn v16_get_var() {
    let (v, _) = complete(
        VarReplyDecoder::new("POS_X")
            .unwrap()
            .decode(b"POS_X 1234\n")
            .unwrap(),
    );
    assert_eq!(v, 1234);
    let mut s = SocketConnection::new("socket_0", Policy::default());
    s.start_read(
        ReadCall::GetVar {
            name: "POS_X".into(),
        },
        Timeout::Forever,
        Duration::ZERO,
    )
    .unwrap();
    assert_eq!(s.take_outgoing(), b"GET POS_X\n");
    s.receive(b"POS_X 1234\n");
    assert_eq!(s.poll_read().unwrap(), ReadResult::Int(1234));
}

#[test]
fn v17_send_line() {
    let mut out = Vec::new();
    encode_line(b"hello", &mut out).unwrap();
    assert_eq!(out, [0x68, 0x65, 0x6C, 0x6C, 0x6F, 0x0A]);
    let mut s = SocketConnection::new("socket_0", Policy::default());
    s.send_line(b"hello");
    assert_eq!(s.take_outgoing(), out);
}

#[test]
fn v18_send_int() {
    let mut out = Vec::new();
    encode_int32(-1, &mut out).unwrap();
    assert_eq!(out, [0xFF; 4]);
    let mut s = SocketConnection::new("socket_0", Policy::default());
    s.send_int(-1);
    assert_eq!(s.take_outgoing(), out);
}

#[test]
fn v19_set_var() {
    let mut out = Vec::new();
    encode_set_var("POS_Y", 2200, &mut out).unwrap();
    assert_eq!(out, b"SET POS_Y 2200\n");
    let mut s = SocketConnection::new("socket_0", Policy::default());
    s.set_var("POS_Y", 2200).unwrap();
    assert_eq!(s.take_outgoing(), out);
}

#[test]
fn v20_stx_etx() {
    let mut out = Vec::new();
    encode_stx_etx(b"hi", &mut out).unwrap();
    assert_eq!(out, [0x02, 0x68, 0x69, 0x03]);
    let mut s = SocketConnection::new("socket_0", Policy::default());
    s.send_byte(2);
    s.send_string(b"hi");
    s.send_byte(3);
    assert_eq!(s.take_outgoing(), out);
}

#[test]
fn v21_send_string_pose() {
    let mut out = Vec::new();
    encode_value(&Value::Pose([1.0, 2.0, 3.0, 4.0, 5.0, 6.0]), &mut out).unwrap();
    assert_eq!(out, b"p[1, 2, 3, 4, 5, 6]");
}

#[test]
fn v22_send_string_bool_list() {
    let items = [Scalar::Bool(true), Scalar::Bool(false), Scalar::Bool(true)];
    let mut out = Vec::new();
    encode_value(&Value::List(List::from_items(&items)), &mut out).unwrap();
    assert_eq!(out, b"[True, False, True]");
}

#[test]
fn server_float_tuple_encoding_reads_back() {
    let mut out = Vec::new();
    encode_float_tuple(&[1.414, 3.14159], false, &mut out).unwrap();
    assert_eq!(out, b"(1.414,3.14159)");
}
