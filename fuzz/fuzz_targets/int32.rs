#![no_main]
use libfuzzer_sys::fuzz_target;
use urscript_socket::int32::Int32Decoder;

fuzz_target!(|data: &[u8]| {
    urscript_socket_fuzz::check_split(|| Int32Decoder::new(8).unwrap(), data, 32);
});
