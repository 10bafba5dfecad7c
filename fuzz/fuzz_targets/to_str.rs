#![no_main]
//! `parse_value` on any bytes: no panic; whatever parses re-encodes (when it fits the
//! robot's 1023 characters) to text that, parsed and encoded again, is unchanged (the
//! first encoding may normalise: `-0.0000001` becomes the robot's `-0`, read back as 0).
use libfuzzer_sys::fuzz_target;
use urscript_socket::to_str::{encode_value, parse_value};

fuzz_target!(|data: &[u8]| {
    let Ok(value) = parse_value(data) else { return };
    let mut text = Vec::new();
    if encode_value(&value, &mut text).is_err() {
        return;
    }
    let again = parse_value(&text).expect("encoder output parses");
    let mut text2 = Vec::new();
    encode_value(&again, &mut text2).expect("re-encodes");
    let third = parse_value(&text2).expect("encoder output parses");
    let mut text3 = Vec::new();
    encode_value(&third, &mut text3).expect("re-encodes");
    assert_eq!(text2, text3, "to_str text is a fixed point after one normalisation");
});
