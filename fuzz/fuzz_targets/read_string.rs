#![no_main]
use libfuzzer_sys::fuzz_target;
use urscript_socket::string::ReadStringDecoder;

fuzz_target!(|data: &[u8]| {
    urscript_socket_fuzz::check_split(|| ReadStringDecoder::new(b">", b"<", false).unwrap(), data, usize::MAX);
});
