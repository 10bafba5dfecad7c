#![no_main]
use libfuzzer_sys::fuzz_target;
use urscript_socket::string::DelimitedDecoder;

fuzz_target!(|data: &[u8]| {
    urscript_socket_fuzz::check_split(|| DelimitedDecoder::with_max_len(b"\r\n", 64).unwrap(), data, 66);
});
