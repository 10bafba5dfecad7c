#![no_main]
use libfuzzer_sys::fuzz_target;
use urscript_socket::ascii_float::FloatTupleDecoder;

fuzz_target!(|data: &[u8]| {
    urscript_socket_fuzz::check_split(|| FloatTupleDecoder::new(6).unwrap().with_max_len(256), data, 256);
});
