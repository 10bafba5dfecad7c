//! The fuzz seed corpora (fuzz/seeds/TARGET/*), replayed as ordinary tests through the
//! same split-invariance checks, so `cargo test` covers every regression input.

mod common;

use std::path::Path;

use common::check;
use urscript_socket::byte_list::ByteListDecoder;
use urscript_socket::int32::Int32Decoder;
use urscript_socket::line::LineDecoder;
use urscript_socket::string::{DelimitedDecoder, ReadStringDecoder};
use urscript_socket::stx_etx::StxEtxDecoder;
use urscript_socket::var::{VarMessageDecoder, VarReplyDecoder};
use urscript_socket::{ascii_float::FloatTupleDecoder, to_str::parse_value};

/// The seeds of `target`. The published crate ships without `fuzz/` (the corpora are
/// the repository's): there the replay has nothing to run and says so; in the repository
/// the corpora must be there.
fn seeds(target: &str) -> Vec<Vec<u8>> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    if !root.join("fuzz").exists() && !root.join(".git").exists() {
        eprintln!("a packaged crate: no fuzz/seeds to replay for {target}");
        return Vec::new();
    }
    let dir = root.join("fuzz/seeds").join(target);
    let mut out: Vec<Vec<u8>> = std::fs::read_dir(&dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|f| std::fs::read(f.unwrap().path()).unwrap())
        .collect();
    out.sort();
    assert!(!out.is_empty(), "no seeds for {target}");
    out
}

/// Every seed, whole and in pieces of every size from 1 to 9.
fn replay<D>(target: &str, make: impl Fn() -> D, bound: usize)
where
    D: urscript_socket::Decode,
    for<'a> D::Item<'a>: std::fmt::Debug,
{
    for seed in seeds(target) {
        for size in 1..10 {
            let cuts: Vec<usize> = (size..seed.len()).step_by(size).collect();
            check(&make, &seed, &cuts, bound + size);
        }
    }
}

#[test]
fn decoder_seeds_are_split_invariant() {
    replay(
        "float_tuple",
        || FloatTupleDecoder::new(6).unwrap().with_max_len(256),
        256,
    );
    replay("int32", || Int32Decoder::new(8).unwrap(), 32);
    replay("byte_list", || ByteListDecoder::new(3).unwrap(), 3);
    replay("line", || LineDecoder::with_max_len(64), 65);
    replay(
        "delimited",
        || DelimitedDecoder::with_max_len(b"\r\n", 64).unwrap(),
        66,
    );
    replay("stx_etx", || StxEtxDecoder::with_max_len(64), 66);
    replay(
        "var_message",
        VarMessageDecoder::new,
        urscript_socket::var::DEFAULT_MAX_VAR_LINE_LEN + 1,
    );
    replay(
        "var_reply",
        || VarReplyDecoder::new("POS_X").unwrap(),
        urscript_socket::var::DEFAULT_MAX_VAR_LINE_LEN + 1,
    );
    replay(
        "read_string",
        || ReadStringDecoder::new(b">", b"<", false).unwrap(),
        usize::MAX / 2,
    );
    // The differential target's seeds, read by every decoder.
    replay("split_invariance", || LineDecoder::with_max_len(8), 9);
    replay("split_invariance", || StxEtxDecoder::with_max_len(8), 10);
    replay(
        "split_invariance",
        || urscript_socket::to_str::ValueLineDecoder::with_max_len(8),
        9,
    );
    // The API target's seeds are structured (arbitrary), but any bytes are a stream.
    replay("api", || LineDecoder::with_max_len(8), 9);
}

#[test]
fn to_str_seeds_parse_or_fail_cleanly() {
    for seed in seeds("to_str") {
        let _ = parse_value(&seed);
    }
    assert!(parse_value(b"p[1, 2, 3, 4, 5, 6]").is_ok());
}
