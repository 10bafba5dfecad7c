//! encode -> decode = identity, for every encoder/decoder pair (floats bit-exact).

use proptest::prelude::*;
use urscript_socket::ascii_float::{encode_float_tuple, FloatTupleDecoder};
use urscript_socket::byte_list::{encode_byte_list, ByteListDecoder};
use urscript_socket::int32::{encode_int32_list, Int32Decoder, Int32Values};
use urscript_socket::line::{encode_line, LineDecoder};
use urscript_socket::string::{encode_framed_string, DelimitedDecoder, ReadStringDecoder};
use urscript_socket::stx_etx::{encode_stx_etx, StxEtxDecoder};
use urscript_socket::to_str::{encode_value, parse_value, List, Scalar, Value};
use urscript_socket::var::{
    encode_get_var, encode_set_var, encode_var_reply, VarMessage, VarMessageDecoder,
    VarReplyDecoder,
};
use urscript_socket::{SliceSink, Status};

fn item<T>(s: Status<T>, len: usize) -> T {
    match s {
        Status::Complete { item, consumed, .. } => {
            assert_eq!(consumed, len, "the whole message is consumed");
            item
        }
        Status::Partial { .. } => panic!("incomplete"),
    }
}

fn finite_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        prop::num::f64::NORMAL | prop::num::f64::SUBNORMAL | prop::num::f64::ZERO,
        Just(f64::MAX),
        Just(f64::MIN_POSITIVE),
        Just(-5e-324),
        Just(-0.0),
        (-1e7..1e7f64),
    ]
}

fn name() -> impl Strategy<Value = String> {
    "[A-Za-z_][A-Za-z0-9_]{0,20}"
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 500, ..ProptestConfig::default() })]

    #[test]
    fn float_tuples_bit_exact(values in prop::collection::vec(finite_f64(), 1..=30), lf in any::<bool>()) {
        let mut out = Vec::new();
        let n = encode_float_tuple(&values, lf, &mut out).unwrap();
        prop_assert_eq!(n, out.len());
        prop_assert!(!out.iter().any(|&b| b == b'e' || b == b'E'), "no exponent");
        let text_len = out.len() - usize::from(lf);
        let t = item(FloatTupleDecoder::new(values.len()).unwrap().decode(&out).unwrap(), text_len);
        prop_assert_eq!(t.count(), values.len());
        for (a, b) in t.values().iter().zip(&values) {
            prop_assert_eq!(a.to_bits(), b.to_bits());
        }
        // Into a fixed buffer too: same bytes.
        let mut storage = [0u8; urscript_socket::ascii_float::MAX_ENCODED_LEN];
        let mut sink = SliceSink::new(&mut storage);
        encode_float_tuple(&values, lf, &mut sink).unwrap();
        prop_assert_eq!(sink.written(), &out[..]);
        // And std parses every token back identically (an independent oracle).
        let inner = std::str::from_utf8(&out[1..text_len - 1]).unwrap();
        for (tok, v) in inner.split(',').zip(&values) {
            prop_assert_eq!(tok.parse::<f64>().unwrap().to_bits(), v.to_bits());
        }
    }

    #[test]
    fn int32_lists(values in prop::collection::vec(any::<i32>(), 1..=30)) {
        let mut out = Vec::new();
        encode_int32_list(&values, &mut out).unwrap();
        let v = item(Int32Decoder::new(values.len()).unwrap().decode(&out).unwrap(), out.len());
        prop_assert_eq!(v.iter().collect::<Vec<_>>(), values);
    }

    /// The view's accessors against an independent reading of the same bytes (a trailing
    /// partial value ignored), at any index, huge ones included.
    #[test]
    fn int32_values_view(bytes in prop::collection::vec(any::<u8>(), 0..130), index in any::<usize>()) {
        let want: Vec<i32> = bytes
            .chunks(4)
            .filter(|c| c.len() == 4)
            .map(|c| (u32::from(c[0]) << 24 | u32::from(c[1]) << 16 | u32::from(c[2]) << 8 | u32::from(c[3])) as i32)
            .collect();
        let v = Int32Values::new(&bytes);
        prop_assert_eq!(v.len(), want.len());
        prop_assert_eq!(v.iter().len(), want.len());
        prop_assert_eq!(v.iter().collect::<Vec<_>>(), want.clone());
        for (i, w) in want.iter().enumerate() {
            prop_assert_eq!(v.get(i), Some(*w));
        }
        prop_assert_eq!(v.get(want.len()), None);
        prop_assert_eq!(v.get(index), want.get(index).copied());
        prop_assert_eq!(v.get(usize::MAX / 4 + 1), None);
        let mut out = [0i32; 40];
        prop_assert_eq!(v.copy_to(&mut out), want.len());
        prop_assert_eq!(&out[..want.len()], &want[..]);
    }

    #[test]
    fn byte_lists(values in prop::collection::vec(any::<u8>(), 1..=30)) {
        let mut out = Vec::new();
        encode_byte_list(&values, &mut out).unwrap();
        let b = item(ByteListDecoder::new(values.len()).unwrap().decode(&out).unwrap(), out.len());
        prop_assert_eq!(b, &values[..]);
    }

    #[test]
    fn lines(text in prop::collection::vec(any::<u8>().prop_filter("no LF", |&b| b != b'\n'), 0..200)
        .prop_filter("no trailing CR", |t| t.last() != Some(&b'\r')))
    {
        let mut out = Vec::new();
        encode_line(&text, &mut out).unwrap();
        prop_assert_eq!(item(LineDecoder::new().decode(&out).unwrap(), out.len()), &text[..]);
    }

    #[test]
    fn stx_etx(text in prop::collection::vec(any::<u8>().prop_filter("no STX/ETX", |&b| b != 2 && b != 3), 0..200)) {
        let mut out = Vec::new();
        encode_stx_etx(&text, &mut out).unwrap();
        prop_assert_eq!(item(StxEtxDecoder::new().decode(&out).unwrap(), out.len()), &text[..]);
    }

    #[test]
    fn framed_strings(prefix in "[!-~]{1,4}", suffix in "[!-~]{1,4}", text in "[ -~]{0,300}") {
        let mut out = Vec::new();
        if encode_framed_string(prefix.as_bytes(), text.as_bytes(), suffix.as_bytes(), &mut out).is_err() {
            // Refused exactly when the reader would meet the suffix before the text's end.
            let joined = text.clone() + &suffix;
            prop_assert!(joined.find(&suffix) != Some(text.len()));
            return Ok(());
        }
        let got = item(ReadStringDecoder::new(prefix.as_bytes(), suffix.as_bytes(), false).unwrap().decode(&out).unwrap(), out.len());
        prop_assert_eq!(got, text.as_bytes());
        // The server-side splitter sees the same message after the prefix.
        let mut d = DelimitedDecoder::new(suffix.as_bytes()).unwrap();
        let got = item(d.decode(&out[prefix.len()..]).unwrap(), out.len() - prefix.len());
        prop_assert_eq!(got, text.as_bytes());
    }

    #[test]
    fn var_messages(n in name(), v in any::<i32>()) {
        let mut out = Vec::new();
        encode_set_var(&n, v, &mut out).unwrap();
        let m = item(VarMessageDecoder::new().decode(&out).unwrap(), out.len());
        prop_assert_eq!(m, VarMessage::Set { name: &n, value: v });
        out.clear();
        encode_get_var(&n, &mut out).unwrap();
        prop_assert_eq!(item(VarMessageDecoder::new().decode(&out).unwrap(), out.len()), VarMessage::Get { name: &n });
        out.clear();
        encode_var_reply(&n, v, &mut out).unwrap();
        prop_assert_eq!(item(VarReplyDecoder::new(&n).unwrap().decode(&out).unwrap(), out.len()), v);
    }

    #[test]
    fn to_str_pose(p in prop::array::uniform6(-1e6..1e6f64)) {
        let mut out = Vec::new();
        encode_value(&Value::Pose(p), &mut out).unwrap();
        let Value::Pose(back) = parse_value(&out).unwrap() else { panic!("not a pose") };
        for (a, b) in back.iter().zip(&p) {
            // The robot's text keeps 6 decimals: the value read back is the rounded one.
            let rounded: f64 = format!("{b:.6}").parse().unwrap();
            prop_assert_eq!(a.to_bits() , if rounded == 0.0 { a.to_bits() } else { rounded.to_bits() });
        }
    }

    #[test]
    fn to_str_lists(items in prop::collection::vec(prop_oneof![any::<i32>().prop_map(Scalar::Int), any::<bool>().prop_map(Scalar::Bool)], 0..50)) {
        let mut out = Vec::new();
        if encode_value(&Value::List(List::from_items(&items)), &mut out).is_err() {
            prop_assert!(items.len() > 80, "only over-long lists are refused");
            return Ok(());
        }
        let Value::List(back) = parse_value(&out).unwrap() else { panic!("not a list") };
        prop_assert_eq!(back.iter().collect::<Vec<_>>(), items);
    }
}
