#![no_main]
use libfuzzer_sys::fuzz_target;
use urscript_socket::var::VarMessageDecoder;

fuzz_target!(|data: &[u8]| {
    urscript_socket_fuzz::check_split(VarMessageDecoder::new, data, urscript_socket::var::DEFAULT_MAX_VAR_LINE_LEN + 1);
});
