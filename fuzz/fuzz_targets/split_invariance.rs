#![no_main]
//! Differential: the first byte picks a decoder (and policy), the next ones the chunk
//! sizes; whole input, one byte at a time and the chosen chunks must agree exactly.
use libfuzzer_sys::fuzz_target;
use urscript_socket::ascii_float::{ExtraValues, FloatReadPolicy, FloatTupleDecoder, LeadingBytes, MissingValues};
use urscript_socket::byte_list::ByteListDecoder;
use urscript_socket::int32::Int32Decoder;
use urscript_socket::line::LineDecoder;
use urscript_socket::string::{DelimitedDecoder, ReadStringDecoder};
use urscript_socket::stx_etx::StxEtxDecoder;
use urscript_socket::to_str::ValueLineDecoder;
use urscript_socket::var::{VarMessageDecoder, VarReplyDecoder};
use urscript_socket_fuzz::check_split;

fuzz_target!(|data: &[u8]| {
    let Some((&pick, data)) = data.split_first() else { return };
    let n = usize::from(pick >> 4) % 6 + 1;
    match pick % 11 {
        0 | 1 => {
            let policy = FloatReadPolicy {
                leading_bytes: if pick & 16 != 0 { LeadingBytes::Fail } else { LeadingBytes::Skip },
                allow_exponent: pick & 32 == 0,
                extra_values: if pick & 64 != 0 { ExtraValues::TakeFirst } else { ExtraValues::Fail },
                missing_values: if pick & 128 != 0 { MissingValues::Fail } else { MissingValues::Count },
            };
            check_split(|| FloatTupleDecoder::with_policy(n, policy).unwrap().with_max_len(24), data, 24)
        }
        2 => check_split(|| Int32Decoder::new(n).unwrap(), data, 4 * n),
        3 => check_split(|| ByteListDecoder::new(n).unwrap(), data, n),
        4 => check_split(|| LineDecoder::with_max_len(n * 3), data, n * 3 + 1),
        5 => check_split(|| DelimitedDecoder::with_max_len(&b"<>!"[..n.min(3)], n * 4).unwrap(), data, n * 4 + 3),
        6 => check_split(|| StxEtxDecoder::with_max_len(n * 3), data, n * 3 + 2),
        7 => check_split(VarMessageDecoder::new, data, urscript_socket::var::DEFAULT_MAX_VAR_LINE_LEN + 1),
        8 => check_split(|| VarReplyDecoder::new("A").unwrap(), data, urscript_socket::var::DEFAULT_MAX_VAR_LINE_LEN + 1),
        9 => check_split(|| ReadStringDecoder::new(b"<<", br"\r", true).unwrap(), data, usize::MAX),
        _ => check_split(|| ValueLineDecoder::with_max_len(n * 3), data, n * 3 + 1),
    }
});
