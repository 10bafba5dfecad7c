#![no_main]
//! The public API with arbitrary arguments, not only arbitrary bytes (issue 14): any bound
//! (`usize::MAX` included), any `number`, any prefix, suffix, delimiter or name, any receive
//! buffer size, and calls in any order (`decode`, `decode_eof` again and again, `flush`,
//! `take_partial`, `reset`). Nothing may panic; a constructor refuses or clamps; decoding
//! through a `RecvBuffer` never wedges, never holds more than its capacity, accounts for
//! every byte in `position()`, and end of input is final (after `Ok(None)` it stays `None`).
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use urscript_socket::ascii_float::{
    ExtraValues, FloatReadPolicy, FloatTupleDecoder, LeadingBytes, MissingValues,
};
use urscript_socket::byte_list::ByteListDecoder;
use urscript_socket::int32::Int32Decoder;
use urscript_socket::line::LineDecoder;
use urscript_socket::string::{DelimitedDecoder, ReadStringDecoder};
use urscript_socket::stx_etx::StxEtxDecoder;
use urscript_socket::to_str::ValueLineDecoder;
use urscript_socket::var::{VarMessageDecoder, VarReplyDecoder};
use urscript_socket::{Decode, RecvBuffer, MAX_BOUND};

#[derive(Debug, Arbitrary)]
enum Make {
    Line(usize),
    Value(usize),
    Stx(usize),
    Delimited(Vec<u8>, usize),
    Floats(usize, usize, u8),
    Int32(usize),
    Bytes(usize),
    ReadString(Vec<u8>, Vec<u8>, bool),
    VarMessage,
    VarReply(String),
}

#[derive(Debug, Arbitrary)]
enum Call {
    Feed(Vec<u8>),
    Decode,
    DecodeEof,
    /// `decode` / `decode_eof` on the decoder directly, without dropping what it says.
    Raw(Vec<u8>, bool),
    Flush,
    TakePartial,
    Reset,
}

#[derive(Debug, Arbitrary)]
struct Input {
    make: Make,
    capacity: u16,
    calls: Vec<Call>,
}

/// A small selection of bounds keeps the bound paths reachable; the rest are any usize.
fn bound(b: usize) -> usize {
    if b % 4 == 0 {
        b
    } else {
        b % 40
    }
}

/// Drives `d` through a `RecvBuffer` of `capacity` bytes. `may_wedge`: the documented
/// exceptions to "a full buffer always gets a way out" (a read-string window; a delimiter
/// longer than the buffer). `extra` runs the decoder's own calls (flush, take_partial, reset)
/// and returns the bytes they used.
fn run<D: Decode>(
    mut d: D,
    capacity: usize,
    may_wedge: bool,
    calls: &[Call],
    mut extra: impl FnMut(&mut D, &Call, &[u8]) -> usize,
) {
    let mut rx = RecvBuffer::with_capacity(capacity);
    let mut fed = 0u64;
    let mut ended = false;
    // Raw calls move the decoder's position over bytes the buffer never held.
    let mut raw = false;
    for call in calls {
        match call {
            Call::Feed(bytes) => {
                let n = rx.extend(bytes);
                fed += n as u64;
                if n > 0 {
                    ended = false;
                }
            }
            Call::Decode => {
                let r = rx.decode(&mut d).map(|o| o.is_some());
                if matches!(r, Ok(false)) && rx.is_full() {
                    assert!(may_wedge, "a full buffer got no way out");
                }
            }
            Call::DecodeEof => {
                let r = rx.decode_eof(&mut d).map(|o| o.is_some());
                if ended && !raw {
                    assert!(matches!(r, Ok(false)), "end of input is final: {r:?}");
                }
                ended = matches!(r, Ok(false));
            }
            Call::Raw(bytes, eof) => {
                raw = true;
                if *eof {
                    let _ = d.decode_eof(bytes);
                } else {
                    let _ = d.decode(bytes);
                }
            }
            other => {
                let used = extra(&mut d, other, rx.data());
                rx.consume(used);
            }
        }
        assert!(rx.len() <= rx.capacity());
        if !raw {
            assert_eq!(d.position() + rx.len() as u64, fed, "every byte accounted for");
        }
    }
}

fn none<D>(_: &mut D, _: &Call, _: &[u8]) -> usize {
    0
}

fuzz_target!(|input: Input| {
    let cap = usize::from(input.capacity % 2048) + 1;
    let calls = &input.calls;
    match input.make {
        Make::Line(b) => {
            let d = LineDecoder::with_max_len(bound(b));
            assert!(d.max_len() <= MAX_BOUND);
            run(d, cap, false, calls, none)
        }
        Make::Value(b) => run(ValueLineDecoder::with_max_len(bound(b)), cap, false, calls, none),
        Make::Stx(b) => run(StxEtxDecoder::with_max_len(bound(b)), cap, false, calls, none),
        Make::Delimited(delim, b) => {
            if let Ok(d) = DelimitedDecoder::with_max_len(&delim, bound(b)) {
                run(d, cap, delim.len() > cap, calls, |d, call, data| match call {
                    Call::Flush => d.flush(data).map_or(0, |(_, n)| n),
                    _ => 0,
                })
            } else {
                assert!(delim.is_empty() || delim.len() > 64);
            }
        }
        Make::Floats(n, b, p) => {
            let policy = FloatReadPolicy {
                leading_bytes: if p & 1 != 0 { LeadingBytes::Fail } else { LeadingBytes::Skip },
                allow_exponent: p & 2 == 0,
                extra_values: if p & 4 != 0 { ExtraValues::TakeFirst } else { ExtraValues::Fail },
                missing_values: if p & 8 != 0 { MissingValues::Fail } else { MissingValues::Count },
            };
            match FloatTupleDecoder::with_policy(n, policy) {
                Ok(d) => run(d.with_max_len(bound(b)), cap, false, calls, none),
                Err(_) => assert!(n == 0 || n > 30),
            }
        }
        Make::Int32(n) => match Int32Decoder::new(n) {
            Ok(d) => run(d, cap, false, calls, |d, call, data| match call {
                Call::TakePartial => d.take_partial(data).map_or(0, |(_, n)| n),
                _ => 0,
            }),
            Err(_) => assert!(n == 0 || n > 30),
        },
        Make::Bytes(n) => match ByteListDecoder::new(n) {
            Ok(d) => run(d, cap, false, calls, |d, call, data| match call {
                Call::TakePartial => d.take_partial(data).map_or(0, |(_, n)| n),
                _ => 0,
            }),
            Err(_) => assert!(n == 0 || n > 30),
        },
        Make::ReadString(prefix, suffix, escape) => {
            if let Ok(d) = ReadStringDecoder::new(&prefix, &suffix, escape) {
                run(d, cap, true, calls, |d, call, _| {
                    if let Call::Reset = call {
                        d.reset();
                    }
                    0
                })
            }
        }
        Make::VarMessage => run(VarMessageDecoder::new(), cap, false, calls, none),
        Make::VarReply(name) => {
            if let Ok(d) = VarReplyDecoder::new(&name) {
                run(d, cap, false, calls, none)
            }
        }
    }
});
