//! Zero allocations per decoded message in the core decoders, in steady state: a counting
//! global allocator watches while prebuilt streams are decoded.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;

use urscript_socket::ascii_float::{encode_float_tuple, FloatTupleDecoder};
use urscript_socket::byte_list::ByteListDecoder;
use urscript_socket::int32::{encode_int32_list, Int32Decoder};
use urscript_socket::line::LineDecoder;
use urscript_socket::string::{DelimitedDecoder, ReadStringDecoder};
use urscript_socket::stx_etx::StxEtxDecoder;
use urscript_socket::var::{VarMessageDecoder, VarReplyDecoder};
use urscript_socket::{Decode, RecvBuffer, SliceSink};

struct Counting;

thread_local! {
    /// Allocations made by this thread (tests run on several threads at once).
    static ALLOCATIONS: Cell<usize> = const { Cell::new(0) };
}

fn allocations() -> usize {
    ALLOCATIONS.with(Cell::get)
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        let _ = ALLOCATIONS.try_with(|c| c.set(c.get() + 1));
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Decodes `stream` in 61-byte pieces through a fixed `RecvBuffer`, returning
/// (messages, allocations during the decode).
fn count<D: Decode>(mut d: D, stream: &[u8]) -> (usize, usize) {
    let mut rx = RecvBuffer::<[u8; 8192]>::new();
    let before = allocations();
    let mut n = 0;
    for piece in stream.chunks(61) {
        rx.extend(piece);
        while let Ok(Some(_)) = rx.decode(&mut d) {
            n += 1;
        }
    }
    (n, allocations() - before)
}

fn repeat(msg: &[u8], n: usize) -> Vec<u8> {
    msg.repeat(n)
}

#[test]
fn core_decoders_do_not_allocate() {
    let mut tuple = Vec::new();
    encode_float_tuple(&[-0.123456, 0.5, 0.3, 0.0, 3.1, -1e-3], true, &mut tuple).unwrap();
    let mut ints = Vec::new();
    encode_int32_list(&[1, 2, 3, 4, 5, 6, 7, 8], &mut ints).unwrap();
    let cases: Vec<(&str, (usize, usize))> = vec![
        (
            "float tuples",
            count(FloatTupleDecoder::new(6).unwrap(), &repeat(&tuple, 5000)),
        ),
        (
            "int32",
            count(Int32Decoder::new(8).unwrap(), &repeat(&ints, 5000)),
        ),
        (
            "bytes",
            count(ByteListDecoder::new(3).unwrap(), &repeat(b"ack", 5000)),
        ),
        (
            "lines",
            count(
                LineDecoder::new(),
                &repeat(b"reply from the server:\r\n", 5000),
            ),
        ),
        (
            "stx/etx",
            count(StxEtxDecoder::new(), &repeat(b"\x02hello\x03", 5000)),
        ),
        (
            "delimited",
            count(
                DelimitedDecoder::new(b"<>").unwrap(),
                &repeat(b"OK,1<>", 5000),
            ),
        ),
        (
            "read_string",
            count(
                ReadStringDecoder::new(b">", b"<", false).unwrap(),
                &repeat(b">hello<", 5000),
            ),
        ),
        (
            "var messages",
            count(VarMessageDecoder::new(), &repeat(b"SET POS_Y 2200\n", 5000)),
        ),
        (
            "var replies",
            count(
                VarReplyDecoder::new("POS_X").unwrap(),
                &repeat(b"POS_X 1234\n", 5000),
            ),
        ),
    ];
    for (name, (messages, allocations)) in cases {
        assert_eq!(messages, 5000, "{name}");
        assert_eq!(
            allocations, 0,
            "{name}: {allocations} allocations for {messages} messages"
        );
    }
}

#[test]
fn encoders_into_a_slice_do_not_allocate() {
    let mut storage = [0u8; 4096];
    let before = allocations();
    for i in 0..1000 {
        let mut sink = SliceSink::new(&mut storage);
        let v = f64::from(i) * 0.001;
        encode_float_tuple(&[v, -v, 0.5, 1e-7, 123456.789, 0.0], true, &mut sink).unwrap();
        encode_int32_list(&[i, -i, 0, 1, 2, 3, 4, 5], &mut sink).unwrap();
    }
    assert_eq!(allocations() - before, 0);
}
