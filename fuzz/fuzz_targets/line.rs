#![no_main]
use libfuzzer_sys::fuzz_target;
use urscript_socket::line::LineDecoder;

fuzz_target!(|data: &[u8]| {
    urscript_socket_fuzz::check_split(|| LineDecoder::with_max_len(64), data, 65);
});
