#![no_main]
//! The robot emulation under arbitrary interleavings of received chunks, reads, polls,
//! timeouts and closes: never a panic, the receive buffer never over its bound, a
//! refused call consumes nothing, and a complete message that was delivered is never
//! lost: a read started on a buffer holding a whole encoded tuple returns it at once.
use arbitrary::Arbitrary;
use libfuzzer_sys::fuzz_target;
use urscript_socket::ascii_float::encode_float_tuple;
use std::time::Duration;
use urscript_socket::robot::{Policy, ReadCall, ShortRead, SocketConnection, Timeout};

#[derive(Debug, Arbitrary)]
enum Call {
    Floats(u8),
    Ints(u8),
    Bytes(u8),
    Line,
    Str(Vec<u8>, Vec<u8>, bool),
    Var(String),
}

#[derive(Debug, Arbitrary)]
enum Op {
    Receive(Vec<u8>),
    Start(Call),
    Poll,
    Timeout,
    Close,
    /// Clear the buffer with reads, then deliver one whole tuple and read it.
    Tuple(Vec<f64>),
}

fn call(c: Call) -> ReadCall {
    match c {
        Call::Floats(n) => ReadCall::AsciiFloat { number: usize::from(n) },
        Call::Ints(n) => ReadCall::BinaryInteger { number: usize::from(n) },
        Call::Bytes(n) => ReadCall::ByteList { number: usize::from(n) },
        Call::Line => ReadCall::Line,
        Call::Str(prefix, suffix, interpret_escape) => ReadCall::String { prefix, suffix, interpret_escape },
        Call::Var(name) => ReadCall::GetVar { name },
    }
}

fuzz_target!(|input: (bool, Vec<Op>)| {
    let (whole_values, ops) = input;
    let policy = Policy {
        receive_capacity: 512,
        short_read: if whole_values { ShortRead::WholeValues } else { ShortRead::Sentinel },
        ..Policy::default()
    };
    let mut s = SocketConnection::new("socket_0", policy);
    for op in ops {
        match op {
            Op::Receive(bytes) => {
                let before = s.buffered().len();
                let n = s.receive(&bytes);
                assert_eq!(s.buffered().len(), before + n);
            }
            Op::Start(c) => {
                let before = s.buffered().to_vec();
                if s.start_read(call(c), Timeout::Forever, Duration::ZERO).is_err() {
                    assert_eq!(s.buffered(), &before[..], "a refused call consumes nothing");
                }
            }
            Op::Poll => {
                let _ = s.poll_read();
            }
            Op::Timeout => {
                let _ = s.give_up();
            }
            Op::Close => s.peer_closed(),
            Op::Tuple(values) => {
                let mut text = Vec::new();
                if s.is_peer_closed() || encode_float_tuple(&values, false, &mut text).is_err() {
                    continue;
                }
                let _ = s.give_up();
                // Empty the buffer the way a program would: byte reads until nothing is left.
                while !s.buffered().is_empty() {
                    let n = s.buffered().len().min(30);
                    s.start_read(ReadCall::ByteList { number: n }, Timeout::Forever, Duration::ZERO).unwrap();
                    assert!(s.poll_read().is_some());
                }
                if s.receive(&text) < text.len() {
                    continue;
                }
                s.start_read(ReadCall::AsciiFloat { number: values.len() }, Timeout::Forever, Duration::ZERO).unwrap();
                let r = s.poll_read().expect("a whole tuple completes the read");
                let urscript_socket::robot::ReadResult::Floats(t) = r else { panic!("not floats") };
                assert_eq!(t.count(), values.len());
                assert!(t.values().iter().zip(&values).all(|(a, b)| a.to_bits() == b.to_bits()));
            }
        }
        assert!(s.buffered().len() <= 512);
    }
});
