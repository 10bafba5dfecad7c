#![no_main]
use libfuzzer_sys::fuzz_target;
use urscript_socket::byte_list::ByteListDecoder;

fuzz_target!(|data: &[u8]| {
    urscript_socket_fuzz::check_split(|| ByteListDecoder::new(3).unwrap(), data, 3);
});
