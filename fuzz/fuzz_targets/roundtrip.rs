#![no_main]
//! Arbitrary valid values -> encode -> decode gives the values back (floats bit-exact).
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use urscript_socket::ascii_float::{encode_float_tuple, FloatTupleDecoder};
use urscript_socket::int32::{encode_int32_list, Int32Decoder};
use urscript_socket::line::{encode_line, LineDecoder};
use urscript_socket::string::{encode_framed_string, ReadStringDecoder};
use urscript_socket::stx_etx::{encode_stx_etx, StxEtxDecoder};
use urscript_socket::var::{encode_set_var, VarMessage, VarMessageDecoder};
use urscript_socket::Status;

#[derive(Debug, Arbitrary)]
enum Msg {
    Floats(Vec<f64>, bool),
    Ints(Vec<i32>),
    Line(Vec<u8>),
    Stx(Vec<u8>),
    Framed(Vec<u8>),
    Var(String, i32),
}

fn item<T>(s: Status<T>) -> T {
    match s {
        Status::Complete { item, .. } => item,
        Status::Partial { .. } => panic!("encoded message incomplete"),
    }
}

fuzz_target!(|msg: Msg| {
    let mut out = Vec::new();
    match msg {
        Msg::Floats(v, lf) => {
            if encode_float_tuple(&v, lf, &mut out).is_err() {
                assert!(v.is_empty() || v.len() > 30 || v.iter().any(|x| !x.is_finite()));
                return;
            }
            assert!(!out.contains(&b'e') && !out.contains(&b'E'));
            let t = item(FloatTupleDecoder::new(v.len()).unwrap().decode(&out).unwrap());
            assert_eq!(t.count(), v.len());
            for (a, b) in t.values().iter().zip(&v) {
                assert_eq!(a.to_bits(), b.to_bits());
            }
        }
        Msg::Ints(v) => {
            let v = &v[..v.len().min(30)];
            if v.is_empty() {
                return;
            }
            encode_int32_list(v, &mut out).unwrap();
            let got = item(Int32Decoder::new(v.len()).unwrap().decode(&out).unwrap());
            assert!(got.iter().eq(v.iter().copied()));
        }
        Msg::Line(t) => {
            if encode_line(&t, &mut out).is_err() || t.len() > 4096 || t.last() == Some(&b'\r') {
                return;
            }
            assert_eq!(item(LineDecoder::new().decode(&out).unwrap()), &t[..]);
        }
        Msg::Stx(t) => {
            if encode_stx_etx(&t, &mut out).is_err() || t.len() > 4096 {
                return;
            }
            assert_eq!(item(StxEtxDecoder::new().decode(&out).unwrap()), &t[..]);
        }
        Msg::Framed(t) => {
            if t.len() > 1000 || encode_framed_string(b">", &t, b"<", &mut out).is_err() {
                return;
            }
            let got = item(ReadStringDecoder::new(b">", b"<", false).unwrap().decode(&out).unwrap());
            assert_eq!(got, &t[..]);
        }
        Msg::Var(name, v) => {
            if name.len() > 200 || encode_set_var(&name, v, &mut out).is_err() {
                return;
            }
            let m = item(VarMessageDecoder::new().decode(&out).unwrap());
            assert_eq!(m, VarMessage::Set { name: &name, value: v });
        }
    }
});
